/* fuzz_rfile.c - the radiosity file reader (rad_rf_read).
 *
 * As fuzz_ffile.c: each input is read as it is and with its two checksums
 * (payload over [256, end), header over [0, 248)) recomputed, so that the
 * fuzzer gets past them to the size, offset and value checks. What the
 * reader accepts must hold what its header comment promises.
 */
#include "fuzz_common.h" /* first: it defines _GNU_SOURCE */

#include <math.h>

#include "rad_bytes.h"
#include "rad_hash.h"
#include "rad_rfile.h"

static void read_back(const char *path)
{
    rad_radiosity r;
    if (rad_rf_read(path, &r) != RAD_OK) return;
    const rad_mesh *mesh = &r.mesh;
    FUZZ_REQUIRE(mesh->patch_count > 0 && mesh->vertex_count >= 3);
    FUZZ_REQUIRE(r.channel_count == 1 || r.channel_count == 3);
    FUZZ_REQUIRE(r.method >= RAD_SOLVE_JACOBI && r.method <= RAD_SOLVE_CG && r.converged <= 1);
    for (size_t i = 0; i < 3 * mesh->vertex_count; i++) FUZZ_REQUIRE(isfinite(mesh->positions[i]));
    for (size_t i = 0; i < mesh->patch_count; i++) {
        const rad_patch *p = &mesh->patches[i];
        FUZZ_REQUIRE(p->vertex_count == 3 || p->vertex_count == 4);
        for (uint32_t k = 0; k < p->vertex_count; k++) FUZZ_REQUIRE(p->v[k] < mesh->vertex_count);
        FUZZ_REQUIRE(p->area > 0 && isfinite(p->area));
        FUZZ_REQUIRE(fabs(rad_v3_length(p->normal) - 1) <= 1e-6);
        FUZZ_REQUIRE(isfinite(p->centroid.x) && isfinite(p->centroid.y) && isfinite(p->centroid.z));
        for (int c = 0; c < 3; c++) {
            FUZZ_REQUIRE(p->rho[c] >= 0 && p->rho[c] < 1);
            FUZZ_REQUIRE(p->emission[c] >= 0 && isfinite(p->emission[c]));
            FUZZ_REQUIRE(isfinite(r.radiosity[3 * i + c]));
        }
    }
    rad_radiosity_free(&r);
}

static int repair(uint8_t *b, size_t size)
{
    if (size < RAD_RF_HEADER_BYTES) return 0;
    rad_put_u64(b + 144, rad_hash64(RAD_HASH_SEED, b + RAD_RF_HEADER_BYTES, size - RAD_RF_HEADER_BYTES));
    rad_put_u64(b + 248, rad_hash64(RAD_HASH_SEED, b, 248));
    return 1;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    return fuzz_read_as_is_and_repaired(data, size, read_back, repair);
}
