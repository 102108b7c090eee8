/* test_damage.c - damaged files are refused, never trusted.
 *
 * The radiosity file (what solve writes and render reads): a small file
 * (N = 3) must be refused with a message naming it at every truncation
 * length, and after every single-byte change (three XOR patterns at every
 * offset: header, tables, padding, radiosity). Every byte of the file is
 * covered by one of its two checksums, so nothing may be accepted.
 *
 * Both formats: a file from the future (radiosity version 2, form-factor
 * version 5; checksums valid) is
 * refused as such; sizes whose layout would overflow 64 bits or need
 * absurd memory are refused before any allocation, even with valid
 * checksums; a centroid outside its patch (which render's reader
 * refuses) is refused by the form-factor reader already. (test_ffile does truncations and
 * flips for the form-factor file.)
 */
#define _FILE_OFFSET_BITS 64
#define _POSIX_C_SOURCE 200809L
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "rad_bytes.h"
#include "rad_ffile.h"
#include "rad_hash.h"
#include "rad_rfile.h"
#include "rad_test.h"

static double positions[] = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0, 0, 0, 1};

static void small_mesh(rad_patch patches[3], rad_mesh *mesh)
{
    memset(patches, 0, 3 * sizeof *patches);
    for (int i = 0; i < 3; i++) {
        rad_patch *p = &patches[i];
        p->vertex_count = i == 2 ? 4 : 3;
        p->v[0] = 0, p->v[1] = 1, p->v[2] = 2 + (i == 1), p->v[3] = i == 2 ? 3 : RAD_NO_VERTEX;
        p->source_face = (uint32_t)i;
        p->area = 0.5 + i * 0.25;
        p->normal = rad_v3(0, 0, 1);
        p->centroid = rad_v3(0.3, 0.3, 0);
        p->rho[0] = 0.5, p->rho[1] = 0.25, p->rho[2] = 0.125;
        p->emission[0] = i == 0 ? 1.0 : 0.0;
    }
    *mesh = (rad_mesh){.positions = positions, .vertex_count = 5, .patches = patches, .patch_count = 3};
}

/* Like rad_test_capture_log, without echoing thousands of expected
 * refusals to stderr. */
static void quiet_sink(rad_log_level level, const char *message, void *user)
{
    (void)level, (void)user;
    size_t used = strlen(rad_test_log);
    snprintf(rad_test_log + used, sizeof rad_test_log - used, "%s\n", message);
}

static void capture_quietly(void)
{
    rad_test_log[0] = 0;
    rad_log_set_sink(quiet_sink, NULL);
}

/* 1 if the reader accepted `path`; a refusal must come with a message
 * naming the file. */
static int rf_accepts(const char *path, int *unnamed)
{
    rad_radiosity r;
    capture_quietly();
    rad_status st = rad_rf_read(path, &r);
    if (st == RAD_OK) {
        rad_radiosity_free(&r);
        return 1;
    }
    if (!rad_test_log_contains(path)) (*unnamed)++;
    return 0;
}

static void test_radiosity_damage(void)
{
    rad_patch patches[3];
    rad_radiosity r;
    memset(&r, 0, sizeof r);
    small_mesh(patches, &r.mesh);
    double b[9] = {1.0, 0.5, 0.25, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6};
    r.radiosity = b;
    r.channel_count = 3;
    r.method = RAD_SOLVE_GAUSS_SEIDEL;
    r.converged = 1;
    r.iterations[0] = r.iterations[1] = r.iterations[2] = 12;
    r.tolerance = 1e-10;
    r.residual[0] = r.residual[1] = r.residual[2] = 1e-11;
    r.scene_fingerprint = 0xfeed;
    const char *path = "test_damage.rad", *damaged = "test_damage.damaged.rad";
    RAD_CHECK(rad_rf_write(path, &r) == RAD_OK);
    size_t size = 0;
    unsigned char *bytes = rad_test_read_file(path, &size);
    RAD_CHECK(bytes && size == 840);
    if (!bytes) return;

    int accepted = 0, unnamed = 0;
    for (size_t len = 0; len < size; len++) {
        rad_test_write_file(damaged, bytes, len);
        accepted += rf_accepts(damaged, &unnamed);
    }
    RAD_CHECK(accepted == 0 && unnamed == 0);
    fprintf(stderr, "radiosity file: %zu truncations, %d accepted, %d without the file's name\n", size, accepted,
            unnamed);

    static const unsigned char patterns[] = {0x01, 0x80, 0xff};
    int flips = 0;
    accepted = unnamed = 0;
    for (size_t k = 0; k < size; k++)
        for (size_t p = 0; p < sizeof patterns; p++) {
            bytes[k] ^= patterns[p];
            rad_test_write_file(damaged, bytes, size);
            bytes[k] ^= patterns[p];
            accepted += rf_accepts(damaged, &unnamed);
            flips++;
        }
    RAD_CHECK(accepted == 0 && unnamed == 0);
    fprintf(stderr, "radiosity file: %d single-byte changes, %d accepted, %d without the file's name\n", flips,
            accepted, unnamed);

    /* Trailing bytes and an empty file. */
    unsigned char *longer = calloc(1, size + 64);
    if (longer) {
        memcpy(longer, bytes, size);
        rad_test_write_file(damaged, longer, size + 64);
        RAD_CHECK(!rf_accepts(damaged, &unnamed) && rad_test_log_contains("trailing"));
        free(longer);
    }

    /* A future version, checksums valid: named as a version problem. */
    rad_put_u32(bytes + 8, 2);
    rad_put_u64(bytes + 248, rad_hash64(RAD_HASH_SEED, bytes, 248));
    rad_test_write_file(damaged, bytes, size);
    RAD_CHECK(!rf_accepts(damaged, &unnamed) && rad_test_log_contains("version 2"));

    /* Intact file still reads back exactly. */
    rad_radiosity back;
    RAD_CHECK(rad_rf_read(path, &back) == RAD_OK);
    RAD_CHECK(memcmp(back.radiosity, b, sizeof b) == 0);
    rad_radiosity_free(&back);
    free(bytes);
    remove(path);
    remove(damaged);
    rad_log_set_sink(NULL, NULL);
}

/* Rewrites the form-factor header's checksum after a change. */
static void ff_reseal(unsigned char *h) { rad_put_u64(h + 248, rad_hash64(RAD_HASH_SEED, h, 248)); }

static rad_status ff_open_status(const char *path)
{
    rad_ff_file *ff = NULL;
    rad_status st = rad_ff_open(path, &ff);
    rad_ff_close(ff);
    return st;
}

static void test_form_factor_header_limits(void)
{
    rad_patch patches[3];
    rad_mesh mesh;
    small_mesh(patches, &mesh);
    rad_ff_info info = {.patch_count = 3, .vertex_count = 5, .element_type = RAD_ELEMENT_F64,
                        .estimator = RAD_ESTIMATOR_MC, .samples = 8, .shadow_rays = 0, .seed = 1};
    const double matrix[9] = {0, 0.5, 0.25, 0.5, 0, 0.25, 0.25, 0.25, 0};
    const char *path = "test_damage.ff", *damaged = "test_damage.damaged.ff";
    RAD_CHECK(rad_ff_write_serial(path, &info, &mesh, matrix) == RAD_OK);
    size_t size = 0;
    unsigned char *bytes = rad_test_read_file(path, &size);
    RAD_CHECK(bytes != NULL);
    if (!bytes) return;
    unsigned char h[RAD_FF_HEADER_BYTES];
    capture_quietly();

    /* The next version with a valid header checksum. */
    memcpy(h, bytes, sizeof h);
    rad_put_u32(h + 8, RAD_FF_VERSION + 1); /* 6 */
    ff_reseal(h);
    memcpy(bytes, h, sizeof h);
    rad_test_write_file(damaged, bytes, size);
    RAD_CHECK(ff_open_status(damaged) == RAD_ERR_FORMAT && rad_test_log_contains("format version 6"));

    /* N = 2^31 (the format's limit) with float64: N^2 * 8 = 2^65 bytes
     * wraps around 64 bits, and the wrapped layout asks for a file of
     * "only" 272 GiB. A sparse file of exactly that size, with offsets and
     * header checksum agreeing with the wrapped layout, must be refused as
     * implausible before anything is allocated or read. */
    memcpy(h, bytes, sizeof h);
    rad_put_u32(h + 8, RAD_FF_VERSION_DENSE);
    rad_put_u64(h + 16, UINT64_C(1) << 31);
    rad_ff_info big = {.patch_count = UINT64_C(1) << 31, .vertex_count = 5, .element_type = RAD_ELEMENT_F64};
    rad_ff_layout l = rad_ff_layout_of(&big);
    RAD_CHECK(l.row_checksum_offset == l.matrix_offset); /* the wrap this case is about */
    rad_put_u64(h + 88, l.matrix_offset);
    rad_put_u64(h + 96, l.row_checksum_offset);
    rad_put_u64(h + 104, l.file_bytes);
    ff_reseal(h);
    FILE *f = fopen(damaged, "wb");
    int sparse = f && fwrite(h, 1, sizeof h, f) == sizeof h && fflush(f) == 0 &&
                 ftruncate(fileno(f), (off_t)l.file_bytes) == 0;
    if (f) fclose(f);
    if (sparse) {
        capture_quietly();
        RAD_CHECK(ff_open_status(damaged) == RAD_ERR_FORMAT);
        RAD_CHECK(rad_test_log_contains(damaged) && rad_test_log_contains("implausible"));
    } else {
        fprintf(stderr, "skipped: this file system cannot hold a sparse %llu-byte file\n",
                (unsigned long long)l.file_bytes);
    }
    free(bytes);
    remove(path);
    remove(damaged);
    rad_log_set_sink(NULL, NULL);
}

/* Found by fuzz_ffile's invariants: the form-factor reader accepted a NaN
 * centroid, then (once NaN was refused) a centroid of 1e165 - both with
 * valid checksums; solve copied them into the radiosity file and render's
 * reader refused that. A centroid must lie inside its patch. */
static void test_form_factor_bad_centroid(void)
{
    static const double bad[] = {NAN, 1e165, -0.5, INFINITY};
    for (size_t k = 0; k < sizeof bad / sizeof bad[0]; k++) {
        rad_patch patches[3];
        rad_mesh mesh;
        small_mesh(patches, &mesh);
        if (k % 2) patches[1].centroid.z = bad[k];
        else patches[1].centroid.y = bad[k];
        rad_ff_info info = {.patch_count = 3, .vertex_count = 5, .element_type = RAD_ELEMENT_F32,
                            .estimator = RAD_ESTIMATOR_MC, .samples = 8, .shadow_rays = 0, .seed = 1};
        const double matrix[9] = {0};
        const char *path = "test_damage.centroid.ff";
        RAD_CHECK(rad_ff_write_serial(path, &info, &mesh, matrix) == RAD_OK);
        capture_quietly();
        RAD_CHECK(ff_open_status(path) == RAD_ERR_FORMAT);
        RAD_CHECK(rad_test_log_contains("patch 1: centroid is not inside the patch"));
        rad_log_set_sink(NULL, NULL);
        remove(path);
    }
}

int main(void)
{
    test_radiosity_damage();
    test_form_factor_header_limits();
    test_form_factor_bad_centroid();
    return rad_test_finish();
}
