/* fuzz_ffile.c - the form-factor file reader (rad_ff_open,
 * rad_ff_read_rows; rad_ff_read_links for the links layout).
 *
 * Each input is read twice: as it is, and with its checksums repaired.
 * Random bytes almost never carry a valid header checksum, so the first
 * pass exercises the magic/version/size/checksum checks; the second
 * recomputes every checksum (header, tables, row checksums and their
 * digest, from the N, V and element type the header claims; in the links
 * layout the sections' and link blocks' checksums from the node and link
 * counts it claims) so that the fuzzer reaches the checks of sizes,
 * offsets and values behind them.
 *
 * What the reader accepts must be self-consistent: the mesh as the header
 * says, patch records valid, every row readable (a row may still fail its
 * checksum in the first pass - then it must be refused, not crash), links
 * that pass rad_links_check again with the header's counts, and the other
 * kind's reader refusing; and the radiosity file solve would write from
 * it must be accepted by render's reader (written to a scratch file and
 * read back). A small valid links file is among the regressions
 * (regressions/ffile/links-small, written by tests/test_lfile.c).
 */
#include "fuzz_common.h" /* first: it defines _GNU_SOURCE */

#include <math.h>

#include "rad_bytes.h"
#include "rad_ffile.h"
#include "rad_hash.h"
#include "rad_lfile.h"
#include "rad_links.h"
#include "rad_rfile.h"

/* Rows are read in one call when N is at most this, else in blocks (the
 * file size bounds N anyway: every row has at least 8 bytes of index). */
#define FUZZ_ROWS_AT_ONCE 64

static void read_back(const char *path)
{
    rad_ff_file *ff = NULL;
    if (rad_ff_open(path, &ff) != RAD_OK) {
        FUZZ_REQUIRE(ff == NULL);
        return;
    }
    const rad_ff_info *info = rad_ff_file_info(ff);
    const rad_mesh *mesh = rad_ff_file_mesh(ff);
    uint64_t n = info->patch_count;
    FUZZ_REQUIRE(n > 0 && mesh->patch_count == n && mesh->vertex_count == info->vertex_count);
    FUZZ_REQUIRE(info->element_type == RAD_ELEMENT_F32 || info->element_type == RAD_ELEMENT_F64);
    for (size_t i = 0; i < mesh->patch_count; i++) {
        const rad_patch *p = &mesh->patches[i];
        FUZZ_REQUIRE(p->vertex_count == 3 || p->vertex_count == 4);
        for (uint32_t k = 0; k < p->vertex_count; k++) FUZZ_REQUIRE(p->v[k] < mesh->vertex_count);
        FUZZ_REQUIRE(p->area > 0 && isfinite(p->area));
    }
    for (size_t i = 0; i < 3 * mesh->vertex_count; i++) FUZZ_REQUIRE(isfinite(mesh->positions[i]));
    FUZZ_REQUIRE(mesh->group_count == info->group_count);
    for (size_t g = 0; g < mesh->group_count; g++)
        FUZZ_REQUIRE(mesh->group_names[g][0] != 0 && memchr(mesh->group_names[g], 0, RAD_NAME_MAX) != NULL);
    for (size_t i = 0; i < mesh->patch_count && mesh->group_count; i++)
        FUZZ_REQUIRE(mesh->patch_group[i] < mesh->group_count);
    /* What solve would write from this mesh, render's reader must accept:
     * the patch checks of the two readers must agree. */
    rad_radiosity solved = {.mesh = *mesh, .channel_count = 3, .method = RAD_SOLVE_JACOBI, .tolerance = 1e-10};
    solved.radiosity = calloc(3 * n, sizeof *solved.radiosity);
    if (solved.radiosity) {
        const char *rad_path = fuzz_scratch_path("solved.rad");
        FUZZ_REQUIRE(rad_rf_write(rad_path, &solved) == RAD_OK);
        rad_radiosity back;
        FUZZ_REQUIRE(rad_rf_read(rad_path, &back) == RAD_OK);
        rad_radiosity_free(&back);
        free(solved.radiosity);
    }
    double dummy;
    if (info->layout == RAD_FF_LAYOUT_LINKS) {
        rad_links links;
        if (rad_ff_read_links(ff, &links) == RAD_OK) {
            FUZZ_REQUIRE(links.node_count == info->node_count && links.root_count == info->root_count &&
                         links.leaf_count == n && links.link_count == info->link_count);
            FUZZ_REQUIRE(rad_links_check(&links, mesh->vertex_count, "fuzz") == RAD_OK);
            rad_links_free(&links);
        } else {
            FUZZ_REQUIRE(links.nodes == NULL && links.links == NULL && links.first_link == NULL);
        }
        FUZZ_REQUIRE(rad_ff_read_rows(ff, 0, 1, &dummy) != RAD_OK); /* not a matrix */
        rad_ff_close(ff);
        return;
    }
    rad_links none;
    FUZZ_REQUIRE(rad_ff_read_links(ff, &none) != RAD_OK && none.nodes == NULL); /* not links */
    uint64_t block = n < FUZZ_ROWS_AT_ONCE ? n : FUZZ_ROWS_AT_ONCE;
    double *rows = malloc(block * n * sizeof *rows);
    for (uint64_t r = 0; rows && r < n; r += block) {
        uint64_t count = n - r < block ? n - r : block;
        if (rad_ff_read_rows(ff, r, count, rows) != RAD_OK) break;
    }
    FUZZ_REQUIRE(rad_ff_read_rows(ff, n, 1, &dummy) != RAD_OK); /* past the end */
    free(rows);
    rad_ff_close(ff);
}

/* Recomputes every checksum in place where the claimed layout fits in the
 * input; returns 0 when the header is too short or the sizes do not fit. */
static int repair(uint8_t *b, size_t size)
{
    if (size < RAD_FF_HEADER_BYTES) return 0;
    rad_ff_info info = {.patch_count = rad_get_u64(b + 16), .vertex_count = rad_get_u64(b + 24),
                        .element_type = rad_get_u32(b + 32),
                        .group_count = rad_get_u32(b + 8) >= 2 ? rad_get_u32(b + 232) : 0};
    if (info.patch_count == 0 || info.patch_count > size || info.vertex_count > size || info.group_count > size)
        return 0;
    if (rad_get_u32(b + 8) >= 3 && rad_get_u32(b + 236) == RAD_FF_LAYOUT_SPARSE) {
        info.layout = RAD_FF_LAYOUT_SPARSE;
        info.matrix_bytes = rad_get_u64(b + 240);
        if (info.matrix_bytes > size) return 0;
    }
    if (rad_get_u32(b + 8) >= 4 && rad_get_u32(b + 236) == RAD_FF_LAYOUT_LINKS) {
        info.layout = RAD_FF_LAYOUT_LINKS;
        info.node_count = rad_get_u32(b + 192);
        info.root_count = rad_get_u32(b + 196);
        info.link_count = rad_get_u64(b + 200);
        info.cluster_count = rad_get_u32(b + 8) >= 5 ? rad_get_u32(b + 188) : 0;
        if (info.node_count > size || info.root_count > size || info.cluster_count > size || info.link_count > size)
            return 0;
    }
    rad_ff_layout l = rad_ff_layout_of(&info);
    if (l.file_bytes > size) return 0;
    uint64_t n = info.patch_count;
    if (info.layout == RAD_FF_LAYOUT_LINKS) {
        /* node table, (cluster table, cluster roots,) first_link, each
         * block of links: each up to the next */
        uint64_t starts[4], fixed = 0;
        starts[fixed++] = l.matrix_offset;
        if (info.cluster_count) starts[fixed++] = l.cluster_offset, starts[fixed++] = l.cluster_root_offset;
        starts[fixed++] = l.first_link_offset;
        uint64_t sums = rad_lfile_checksum_count(info.cluster_count, info.link_count);
        for (uint64_t k = 0; k < sums; k++) {
            uint64_t at = k < fixed ? starts[k] : l.link_offset + (k - fixed) * RAD_LFILE_BLOCK_LINKS * 16;
            uint64_t end = k + 1 < fixed ? starts[k + 1] : k + 1 == fixed ? l.link_offset
                         : k + 1 < sums ? at + RAD_LFILE_BLOCK_LINKS * 16 : l.row_checksum_offset;
            rad_put_u64(b + l.row_checksum_offset + 8 * k, rad_hash64(RAD_HASH_SEED, b + at, (size_t)(end - at)));
        }
    } else if (info.layout == RAD_FF_LAYOUT_SPARSE) {
        /* Each record's checksum where its offsets make sense; then the index's. */
        const uint8_t *offsets = b + l.row_checksum_offset;
        for (uint64_t i = 0; i < n; i++) {
            uint64_t at = rad_get_u64(offsets + 8 * i), end = rad_get_u64(offsets + 8 * (i + 1));
            if (at <= end && end <= info.matrix_bytes)
                rad_put_u64(b + l.row_checksum_offset + 8 * (n + 1 + i),
                            rad_ff_row_checksum(b + l.matrix_offset + at, (size_t)(end - at)));
        }
    } else {
        for (uint64_t i = 0; i < n; i++)
            rad_put_u64(b + l.row_checksum_offset + 8 * i,
                        rad_ff_row_checksum(b + l.matrix_offset + i * l.row_bytes, l.row_bytes));
    }
    rad_put_u64(b + 112, rad_hash64(RAD_HASH_SEED, b + RAD_FF_HEADER_BYTES, l.matrix_offset - RAD_FF_HEADER_BYTES));
    rad_put_u64(b + 120, rad_hash64(RAD_HASH_SEED, b + l.row_checksum_offset, l.index_bytes));
    rad_put_u64(b + 248, rad_hash64(RAD_HASH_SEED, b, 248));
    return 1;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    return fuzz_read_as_is_and_repaired(data, size, read_back, repair);
}
