/* test_ffile_sparse.c - the sparse layout of the form-factor file (version 3).
 *
 * A matrix of N = 150 patches (three tiles of 64 columns, the last one
 * 22 wide) with whole tiles of zeros, a row of zeros, a -0.0 and a value
 * that float32 rounds to zero is written with rad_ff_write_serial in both
 * layouts: the sparse file reads back every row exactly as the dense one
 * (f64), or as float (f32), and is smaller. Record encoding: zero tiles
 * are not listed, -0.0 is kept. Damage: every truncation and every
 * single-byte flip of a small sparse file is refused or harmless, and a
 * record whose checksum was recomputed after its tile list was broken is
 * refused with what is wrong.
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "rad_bytes.h"
#include "rad_ffile.h"
#include "rad_hash.h"
#include "rad_test.h"

#define N 150

static double positions[] = {0, 0, 0, 1, 0, 0, 1, 1, 0};
static rad_patch patches[N];

static rad_mesh mesh_of(size_t n)
{
    for (size_t i = 0; i < n; i++) {
        rad_patch *p = &patches[i];
        memset(p, 0, sizeof *p);
        p->vertex_count = 3;
        p->v[0] = 0, p->v[1] = 1, p->v[2] = 2, p->v[3] = RAD_NO_VERTEX;
        p->area = 0.5;
        p->normal = rad_v3(0, 0, 1);
        p->centroid = rad_v3(2.0 / 3.0, 1.0 / 3.0, 0);
        p->rho[0] = p->rho[1] = p->rho[2] = 0.5;
    }
    rad_mesh mesh = {.positions = positions, .vertex_count = 3, .patches = patches, .patch_count = n};
    return mesh;
}

static rad_ff_info info_of(size_t n, rad_element_type element, rad_ff_layout_kind layout)
{
    rad_ff_info info = {.patch_count = n, .vertex_count = 3, .element_type = element, .estimator = RAD_ESTIMATOR_MC,
                        .samples = 64, .seed = 3, .layout = layout};
    strcpy(info.scene_name, "sparse");
    return info;
}

/* 1 if `path` opens and its n rows read back bitwise equal to `expect`. */
static int reads_back(const char *path, const double *expect, size_t n)
{
    rad_ff_file *ff = NULL;
    if (rad_ff_open(path, &ff) != RAD_OK) return 0;
    double *rows = malloc(n * n * sizeof *rows);
    int ok = rows && rad_ff_read_rows(ff, 0, n, rows) == RAD_OK && memcmp(rows, expect, n * n * sizeof *rows) == 0;
    free(rows);
    rad_ff_close(ff);
    return ok;
}

static size_t file_size(const char *path)
{
    size_t size = 0;
    free(rad_test_read_file(path, &size));
    return size;
}

int main(void)
{
    static double matrix[N * N], as_float[N * N];
    rad_mesh mesh = mesh_of(N);
    /* Row i: columns in tile (i % 3) only, except row 7 (all zero); tile 2
     * of row 9 holds only -0.0; row 11's only entry rounds to 0 in float32. */
    for (int i = 0; i < N; i++)
        for (int j = 0; j < N; j++)
            matrix[i * N + j] = (j / 64 == i % 3 && i != j && i != 7) ? 1.0 / (1 + i + 0.5 * j) : 0.0;
    for (int j = 0; j < N; j++) matrix[9 * N + j] = j >= 128 ? -0.0 : 0.0;
    for (int j = 0; j < N; j++) matrix[11 * N + j] = j == 5 ? 1e-60 : 0.0;
    for (int k = 0; k < N * N; k++) as_float[k] = (float)matrix[k];

    /* Both layouts, both element types: the same numbers. */
    rad_ff_info dense = info_of(N, RAD_ELEMENT_F64, RAD_FF_LAYOUT_DENSE);
    rad_ff_info sparse = info_of(N, RAD_ELEMENT_F64, RAD_FF_LAYOUT_SPARSE);
    rad_ff_info sparse32 = info_of(N, RAD_ELEMENT_F32, RAD_FF_LAYOUT_SPARSE);
    RAD_CHECK(rad_ff_write_serial("sparse.dense", &dense, &mesh, matrix) == RAD_OK);
    RAD_CHECK(rad_ff_write_serial("sparse.f64", &sparse, &mesh, matrix) == RAD_OK);
    RAD_CHECK(rad_ff_write_serial("sparse.f32", &sparse32, &mesh, matrix) == RAD_OK);
    RAD_CHECK(reads_back("sparse.dense", matrix, N));
    RAD_CHECK(reads_back("sparse.f64", matrix, N));
    RAD_CHECK(reads_back("sparse.f32", as_float, N));
    size_t dense_size = file_size("sparse.dense"), sparse_size = file_size("sparse.f64");
    fprintf(stderr, "N = %d: dense %zu bytes, sparse %zu (f32 %zu)\n", N, dense_size, sparse_size,
            file_size("sparse.f32"));
    RAD_CHECK(sparse_size < dense_size / 2);

    rad_ff_file *ff = NULL;
    RAD_CHECK(rad_ff_open("sparse.f64", &ff) == RAD_OK);
    if (ff) {
        const rad_ff_info *got = rad_ff_file_info(ff);
        RAD_CHECK(got->layout == RAD_FF_LAYOUT_SPARSE && got->matrix_bytes > 0 && got->seed == 3);
        double rows[2 * N];
        RAD_CHECK(rad_ff_read_rows(ff, 100, 2, rows) == RAD_OK && memcmp(rows, matrix + 100 * N, sizeof rows) == 0);
        rad_test_capture_log();
        RAD_CHECK(rad_ff_read_rows(ff, N - 1, 2, rows) == RAD_ERR_INVALID);
        rad_ff_close(ff);
    }
    size_t dsize = 0;
    unsigned char *d = rad_test_read_file("sparse.dense", &dsize);
    RAD_CHECK(d && rad_get_u32(d + 8) == RAD_FF_VERSION_DENSE); /* dense files stay version 2 */
    free(d);

    /* The records: row 7 lists no tile (8 bytes), row 9 lists tile 2 for
     * its -0.0, row 11 lists tile 0 in float64 and nothing in float32,
     * row 0 lists tile 0 only: 8 + 64 * 8 bytes. */
    static unsigned char record[8 + 4 * 4 + N * 8];
    RAD_CHECK(rad_ff_row_encode(matrix + 7 * N, N, RAD_ELEMENT_F64, record) == 8 && rad_get_u32(record) == 0);
    RAD_CHECK(rad_ff_row_encode(matrix + 9 * N, N, RAD_ELEMENT_F64, record) == 8 + 22 * 8);
    RAD_CHECK(rad_get_u32(record) == 1 && rad_get_u32(record + 4) == 2 && signbit(rad_get_f64(record + 8)));
    RAD_CHECK(rad_ff_row_encode(matrix + 11 * N, N, RAD_ELEMENT_F64, record) == 8 + 64 * 8);
    RAD_CHECK(rad_ff_row_encode(matrix + 11 * N, N, RAD_ELEMENT_F32, record) == 8);
    RAD_CHECK(rad_ff_row_encode(matrix, N, RAD_ELEMENT_F64, record) == 8 + 64 * 8 && rad_get_u32(record + 4) == 0);
    RAD_CHECK(rad_ff_row_encode(matrix, N, RAD_ELEMENT_F64, NULL) == 8 + 64 * 8);
    RAD_CHECK(rad_ff_row_record_max(N, RAD_ELEMENT_F32) == 16 + 600 && rad_ff_row_record_max(N, RAD_ELEMENT_F64) == 16 + 1200);

    /* Damage, on a file small enough to flip every byte: N = 3. */
    double small[9] = {0, 0.25, 0, 0, 0, 0, 0.1, 0.2, 0};
    rad_mesh mesh3 = mesh_of(3);
    rad_ff_info info3 = info_of(3, RAD_ELEMENT_F64, RAD_FF_LAYOUT_SPARSE);
    RAD_CHECK(rad_ff_write_serial("sparse.small", &info3, &mesh3, small) == RAD_OK);
    RAD_CHECK(reads_back("sparse.small", small, 3));
    size_t size = 0;
    unsigned char *bytes = rad_test_read_file("sparse.small", &size);
    RAD_CHECK(bytes != NULL);
    rad_test_capture_log();
    int accepted = 0, refused = 0, silently_wrong = 0;
    for (size_t len = 0; bytes && len < size; len++) {
        rad_test_write_file("sparse.damaged", bytes, len);
        accepted += reads_back("sparse.damaged", small, 3);
    }
    RAD_CHECK(accepted == 0);
    for (size_t k = 0; bytes && k < size; k++) {
        bytes[k] ^= 0x5a;
        rad_test_write_file("sparse.damaged", bytes, size);
        rad_ff_file *f = NULL;
        double rows[9];
        if (rad_ff_open("sparse.damaged", &f) != RAD_OK || rad_ff_read_rows(f, 0, 3, rows) != RAD_OK)
            refused++;
        else if (memcmp(rows, small, sizeof rows) != 0)
            silently_wrong++;
        rad_ff_close(f);
        bytes[k] ^= 0x5a;
    }
    fprintf(stderr, "byte flips: %d of %zu refused, %d silently wrong\n", refused, size, silently_wrong);
    RAD_CHECK(silently_wrong == 0 && refused > (int)size * 9 / 10);

    /* A broken tile list behind a valid checksum: row 2 lists tile 1,
     * which a 3-column row does not have. */
    if (bytes) {
        uint64_t matrix_offset = rad_get_u64(bytes + 88), index_offset = rad_get_u64(bytes + 96);
        uint64_t *index = (uint64_t *)(bytes + index_offset); /* N + 1 offsets, N checksums */
        unsigned char *row2 = bytes + matrix_offset + index[2];
        RAD_CHECK(rad_get_u32(row2) == 1 && rad_get_u32(row2 + 4) == 0);
        rad_put_u32(row2 + 4, 1);
        index[3 + 1 + 2] = rad_hash64(RAD_HASH_SEED, row2, index[3] - index[2]);
        rad_put_u64(bytes + 120, rad_hash64(RAD_HASH_SEED, index, 7 * 8));
        rad_put_u64(bytes + 248, rad_hash64(RAD_HASH_SEED, bytes, 248));
        rad_test_write_file("sparse.damaged", bytes, size);
        rad_test_capture_log();
        RAD_CHECK(rad_ff_open("sparse.damaged", &ff) == RAD_OK);
        if (ff) {
            double rows[9];
            RAD_CHECK(rad_ff_read_rows(ff, 0, 3, rows) == RAD_ERR_FORMAT);
            RAD_CHECK(rad_test_log_contains("row 2: tile number beyond the row"));
            rad_ff_close(ff);
        }
    }
    free(bytes);
    remove("sparse.dense");
    remove("sparse.f64");
    remove("sparse.f32");
    remove("sparse.small");
    remove("sparse.damaged");
    return rad_test_finish();
}
