/* test_ffile.c - the form-factor file: round trip, and damage refused.
 *
 * A small file (N = 3, two groups) is written with rad_ff_write_serial and
 * read back exactly (f64) or to float precision (f32). Then every
 * truncation length and every single-byte flip of the file must be refused
 * by rad_ff_open or rad_ff_read_rows with a message - never accepted with
 * different numbers. Groups: a mesh without them writes a file without a
 * group table; the same file as version 1 (what formfactor wrote before the
 * table existed) still reads; a group table with valid checksums but a
 * patch's group out of range, or a name without its NUL, is refused.
 */
#include <stdlib.h>
#include <string.h>

#include "rad_bytes.h"
#include "rad_ffile.h"
#include "rad_hash.h"
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
    rad_mesh mesh = {.positions = positions, .vertex_count = 5, .patches = patches, .patch_count = 3};
    return mesh;
}

/* Patches 0 and 2 in "walls", patch 1 in "light,1" (a comma: any OBJ name). */
static char group_names[2][RAD_NAME_MAX] = {"walls", "light,1"};
static uint32_t patch_group[3] = {0, 1, 0};
static void add_groups(rad_mesh *mesh, rad_ff_info *info)
{
    mesh->group_names = group_names;
    mesh->group_count = 2;
    mesh->patch_group = patch_group;
    info->group_count = 2;
}

/* Recomputes the tables checksum and the header checksum after an edit. */
static void reseal(unsigned char *bytes)
{
    uint64_t matrix_offset = rad_get_u64(bytes + 88);
    rad_put_u64(bytes + 112, rad_hash64(RAD_HASH_SEED, bytes + RAD_FF_HEADER_BYTES, matrix_offset - RAD_FF_HEADER_BYTES));
    rad_put_u64(bytes + 248, rad_hash64(RAD_HASH_SEED, bytes, 248));
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

    /* Round trip, float64: every number, the patch and group tables exactly. */
    rad_ff_info info = small_info(RAD_ELEMENT_F64);
    add_groups(&mesh, &info);
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
        RAD_CHECK(got->group_count == 2 && m->group_count == 2);
        RAD_CHECK(m->group_names && strcmp(m->group_names[0], "walls") == 0 && strcmp(m->group_names[1], "light,1") == 0);
        RAD_CHECK(m->patch_group && memcmp(m->patch_group, patch_group, sizeof patch_group) == 0);
        double rows[6];
        RAD_CHECK(rad_ff_read_rows(ff, 1, 2, rows) == RAD_OK);
        RAD_CHECK(memcmp(rows, matrix + 3, sizeof rows) == 0);
        RAD_CHECK(rad_ff_read_rows(ff, 2, 2, rows) == RAD_ERR_INVALID); /* past the end */
        rad_ff_close(ff);
    }

    /* float32: values rounded to float, nothing else changes. */
    rad_ff_info info32 = small_info(RAD_ELEMENT_F32);
    info32.group_count = 2;
    RAD_CHECK(rad_ff_write_serial("test_ffile.f32", &info32, &mesh, matrix) == RAD_OK);
    double as_float[9];
    for (int k = 0; k < 9; k++) as_float[k] = (float)matrix[k];
    RAD_CHECK(reads_back("test_ffile.f32", as_float));

    /* Every truncation is refused at open. */
    size_t size = 0;
    unsigned char *bytes = rad_test_read_file(path, &size);
    RAD_CHECK(bytes && size > 700);
    int accepted = 0;
    rad_test_capture_log();
    for (size_t len = 0; bytes && len < size; len++) {
        rad_test_write_file(damaged, bytes, len);
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
        rad_test_write_file(damaged, bytes, size);
        rad_ff_file *d = NULL;
        if (rad_ff_open(damaged, &d) != RAD_OK) {
            refused++;
        } else {
            double rows[9];
            if (rad_ff_read_rows(d, 0, 3, rows) != RAD_OK)
                refused++;
            else if (memcmp(rows, matrix, sizeof rows) != 0 ||
                     memcmp(rad_ff_file_mesh(d)->patches, patches, sizeof patches) != 0 ||
                     rad_ff_file_mesh(d)->group_count != 2 ||
                     memcmp(rad_ff_file_mesh(d)->patch_group, patch_group, sizeof patch_group) != 0 ||
                     memcmp(rad_ff_file_mesh(d)->group_names, group_names, sizeof group_names) != 0)
                silently_wrong++;
            rad_ff_close(d);
        }
        bytes[k] ^= 0x5a;
    }
    RAD_CHECK(silently_wrong == 0);
    RAD_CHECK(refused > (int)size * 9 / 10);
    fprintf(stderr, "byte flips: %d of %zu refused, %d silently wrong\n", refused, size, silently_wrong);

    /* A group table that its checksums cannot catch: written so (the
     * checksums resealed), a patch's group out of range and a name that
     * fills its 64 bytes are refused and named. */
    const rad_ff_layout lay = rad_ff_layout_of(&info);
    RAD_CHECK(lay.group_offset > 0 && lay.patch_group_offset == lay.group_offset + 2 * RAD_NAME_MAX);
    if (bytes) {
        rad_test_capture_log();
        rad_put_u32(bytes + lay.patch_group_offset + 4, 2);
        reseal(bytes);
        rad_test_write_file(damaged, bytes, size);
        RAD_CHECK(rad_ff_open(damaged, &ff) == RAD_ERR_FORMAT && ff == NULL);
        RAD_CHECK(rad_test_log_contains("patch 1: group 2 out of range (2 groups)"));
        rad_put_u32(bytes + lay.patch_group_offset + 4, 1);
        memset(bytes + lay.group_offset + RAD_NAME_MAX, 'x', RAD_NAME_MAX);
        reseal(bytes);
        rad_test_write_file(damaged, bytes, size);
        RAD_CHECK(rad_ff_open(damaged, &ff) == RAD_ERR_FORMAT && ff == NULL);
        RAD_CHECK(rad_test_log_contains("group 1: name not NUL-terminated"));
    }

    /* Without groups: no group table (the layout of version 1), and the
     * same bytes marked version 1 - a file from before the table - read
     * back the same numbers, with no groups. */
    rad_mesh plain = small_mesh(patches);
    rad_ff_info plain_info = small_info(RAD_ELEMENT_F64);
    RAD_CHECK(rad_ff_write_serial("test_ffile.plain", &plain_info, &plain, matrix) == RAD_OK);
    RAD_CHECK(rad_ff_layout_of(&plain_info).matrix_offset == 256 + 128 + 3 * 128);
    size_t plain_size = 0;
    unsigned char *old = rad_test_read_file("test_ffile.plain", &plain_size);
    RAD_CHECK(old != NULL && plain_size < size);
    if (old) {
        RAD_CHECK(rad_get_u32(old + 8) == RAD_FF_VERSION_DENSE && rad_get_u64(old + 224) == 0 && rad_get_u32(old + 232) == 0);
        rad_put_u32(old + 8, 1);
        reseal(old);
        rad_test_write_file("test_ffile.v1", old, plain_size);
        RAD_CHECK(reads_back("test_ffile.v1", matrix));
        RAD_CHECK(rad_ff_open("test_ffile.v1", &ff) == RAD_OK);
        if (ff) {
            RAD_CHECK(rad_ff_file_info(ff)->group_count == 0 && rad_ff_file_mesh(ff)->group_count == 0);
            RAD_CHECK(rad_ff_file_mesh(ff)->patch_group == NULL && rad_ff_file_mesh(ff)->group_names == NULL);
            rad_ff_close(ff);
        }
        /* A version-1 file whose reserved bytes say "groups" has none. */
        rad_put_u32(old + 232, 2);
        reseal(old);
        rad_test_write_file("test_ffile.v1", old, plain_size);
        RAD_CHECK(reads_back("test_ffile.v1", matrix));
        free(old);
    }
    /* The info must match the mesh's groups. */
    rad_test_capture_log();
    RAD_CHECK(rad_ff_write_serial("test_ffile.plain", &info, &plain, matrix) == RAD_ERR_INVALID);
    RAD_CHECK(rad_test_log_contains("does not match the mesh"));

    /* A foreign file and a paper-format file are named as such. */
    rad_test_capture_log();
    rad_test_write_file(damaged, (const unsigned char *)"hello, world, this is not a matrix", 34);
    RAD_CHECK(rad_ff_open(damaged, &ff) == RAD_ERR_FORMAT);
    RAD_CHECK(rad_test_log_contains("not a form-factor file"));
    unsigned char paper[4 + 8 * 4] = {2, 0, 0, 0};
    rad_test_write_file(damaged, paper, sizeof paper);
    RAD_CHECK(rad_ff_open(damaged, &ff) == RAD_ERR_FORMAT);
    RAD_CHECK(rad_test_log_contains("paper-format"));
    RAD_CHECK(rad_ff_open("no/such/file", &ff) == RAD_ERR_IO);
    RAD_CHECK(rad_test_log_contains("no/such/file: cannot open"));

    free(bytes);
    remove(path);
    remove(damaged);
    remove("test_ffile.f32");
    remove("test_ffile.plain");
    remove("test_ffile.v1");
    return rad_test_finish();
}
