/* test_ffile.c - the form-factor file: round trip, and damage refused.
 *
 * A small file (N = 3) is written with rad_ff_write_serial and read back
 * exactly (f64) or to float precision (f32). Then every truncation length
 * and every single-byte flip of the file must be refused by rad_ff_open or
 * rad_ff_read_rows with a message - never accepted with different numbers.
 */
#include <stdlib.h>
#include <string.h>

#include "rad_ffile.h"
#include "rad_test.h"

static double positions[] = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0, 0, 0, 1};

static rad_mesh small_mesh(rad_patch patches[3])
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
        p->rho[0] = p->rho[1] = p->rho[2] = 0.5;
        p->emission[0] = i == 0 ? 1.0 : 0.0;
    }
    rad_mesh mesh = {positions, 5, patches, 3};
    return mesh;
}

static rad_ff_info small_info(rad_element_type element)
{
    rad_ff_info info = {.patch_count = 3, .vertex_count = 5, .element_type = element,
                        .estimator = RAD_ESTIMATOR_MC, .samples = 512, .shadow_rays = 32, .seed = 7,
                        .scene_fingerprint = 0x1234, .subdiv = 0};
    strcpy(info.scene_name, "small");
    return info;
}

static const double matrix[9] = {0, 0.25, 0.125, 0.5, 0, 1.0 / 3.0, 0.1, 0.2, 0};

static unsigned char *read_whole(const char *path, size_t *size)
{
    FILE *f = fopen(path, "rb");
    if (!f) return NULL;
    fseek(f, 0, SEEK_END);
    *size = (size_t)ftell(f);
    rewind(f);
    unsigned char *data = malloc(*size);
    if (data && fread(data, 1, *size, f) != *size) {
        free(data);
        data = NULL;
    }
    fclose(f);
    return data;
}

static void write_whole(const char *path, const unsigned char *data, size_t size)
{
    FILE *f = fopen(path, "wb");
    if (size) fwrite(data, 1, size, f);
    fclose(f);
}

/* 1 if the file opens and every row reads back equal to `expect`. */
static int reads_back(const char *path, const double *expect)
{
    rad_ff_file *ff = NULL;
    if (rad_ff_open(path, &ff) != RAD_OK) return 0;
    double rows[9];
    int ok = rad_ff_read_rows(ff, 0, 3, rows) == RAD_OK && memcmp(rows, expect, sizeof rows) == 0;
    rad_ff_close(ff);
    return ok;
}

int main(void)
{
    rad_patch patches[3];
    rad_mesh mesh = small_mesh(patches);
    const char *path = "test_ffile.out", *damaged = "test_ffile.damaged";

    /* Round trip, float64: every number and the patch table exactly. */
    rad_ff_info info = small_info(RAD_ELEMENT_F64);
    RAD_CHECK(rad_ff_write_serial(path, &info, &mesh, matrix) == RAD_OK);
    rad_ff_file *ff = NULL;
    RAD_CHECK(rad_ff_open(path, &ff) == RAD_OK);
    if (ff) {
        const rad_ff_info *got = rad_ff_file_info(ff);
        RAD_CHECK(got->patch_count == 3 && got->samples == 512 && got->shadow_rays == 32 && got->seed == 7);
        RAD_CHECK(got->scene_fingerprint == 0x1234 && strcmp(got->scene_name, "small") == 0);
        const rad_mesh *m = rad_ff_file_mesh(ff);
        RAD_CHECK(m->patch_count == 3 && memcmp(m->patches, patches, sizeof patches) == 0);
        RAD_CHECK(m->vertex_count == 5 && memcmp(m->positions, positions, sizeof positions) == 0);
        double rows[6];
        RAD_CHECK(rad_ff_read_rows(ff, 1, 2, rows) == RAD_OK);
        RAD_CHECK(memcmp(rows, matrix + 3, sizeof rows) == 0);
        RAD_CHECK(rad_ff_read_rows(ff, 2, 2, rows) == RAD_ERR_INVALID); /* past the end */
        rad_ff_close(ff);
    }

    /* float32: values rounded to float, nothing else changes. */
    rad_ff_info info32 = small_info(RAD_ELEMENT_F32);
    RAD_CHECK(rad_ff_write_serial("test_ffile.f32", &info32, &mesh, matrix) == RAD_OK);
    double as_float[9];
    for (int k = 0; k < 9; k++) as_float[k] = (float)matrix[k];
    RAD_CHECK(reads_back("test_ffile.f32", as_float));

    /* Every truncation is refused at open. */
    size_t size = 0;
    unsigned char *bytes = read_whole(path, &size);
    RAD_CHECK(bytes && size > 700);
    int accepted = 0;
    rad_test_capture_log();
    for (size_t len = 0; bytes && len < size; len++) {
        write_whole(damaged, bytes, len);
        accepted += reads_back(damaged, matrix);
    }
    RAD_CHECK(accepted == 0);
    RAD_CHECK(rad_test_log_contains("truncated"));

    /* Every single-byte flip is refused (header, tables, matrix, checksums);
     * padding bytes are the only ones that may change without harm, and a
     * flipped padding byte must still read back the right numbers. */
    int silently_wrong = 0, refused = 0;
    for (size_t k = 0; bytes && k < size; k++) {
        bytes[k] ^= 0x5a;
        write_whole(damaged, bytes, size);
        rad_ff_file *d = NULL;
        if (rad_ff_open(damaged, &d) != RAD_OK) {
            refused++;
        } else {
            double rows[9];
            if (rad_ff_read_rows(d, 0, 3, rows) != RAD_OK)
                refused++;
            else if (memcmp(rows, matrix, sizeof rows) != 0 ||
                     memcmp(rad_ff_file_mesh(d)->patches, patches, sizeof patches) != 0)
                silently_wrong++;
            rad_ff_close(d);
        }
        bytes[k] ^= 0x5a;
    }
    RAD_CHECK(silently_wrong == 0);
    RAD_CHECK(refused > (int)size * 9 / 10);
    fprintf(stderr, "byte flips: %d of %zu refused, %d silently wrong\n", refused, size, silently_wrong);

    /* A foreign file and a paper-format file are named as such. */
    rad_test_capture_log();
    write_whole(damaged, (const unsigned char *)"hello, world, this is not a matrix", 34);
    RAD_CHECK(rad_ff_open(damaged, &ff) == RAD_ERR_FORMAT);
    RAD_CHECK(rad_test_log_contains("not a form-factor file"));
    unsigned char paper[4 + 8 * 4] = {2, 0, 0, 0};
    write_whole(damaged, paper, sizeof paper);
    RAD_CHECK(rad_ff_open(damaged, &ff) == RAD_ERR_FORMAT);
    RAD_CHECK(rad_test_log_contains("paper-format"));
    RAD_CHECK(rad_ff_open("no/such/file", &ff) == RAD_ERR_IO);
    RAD_CHECK(rad_test_log_contains("no/such/file: cannot open"));

    free(bytes);
    remove(path);
    remove(damaged);
    remove("test_ffile.f32");
    return rad_test_finish();
}
