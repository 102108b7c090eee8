/* rad_rfile.c - writes and reads the radiosity file (layout in rad_rfile.h).
 *
 * Every number is encoded field by field as little-endian (rad_bytes.h),
 * so the file does not depend on the host's struct padding. */
#define _FILE_OFFSET_BITS 64
#define _POSIX_C_SOURCE 200809L
#include "rad_rfile.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "rad_bytes.h"
#include "rad_fs.h"
#include "rad_hash.h"
#include "rad_log.h"
#include "rad_patch_table.h"

/* Header field offsets (see the table in rad_rfile.h). */
enum {
    RF_OFF_MAGIC = 0,
    RF_OFF_VERSION = 8,
    RF_OFF_HEADER_BYTES = 12,
    RF_OFF_PATCH_COUNT = 16,
    RF_OFF_VERTEX_COUNT = 24,
    RF_OFF_CHANNELS = 32,
    RF_OFF_METHOD = 36,
    RF_OFF_CONVERGED = 40,
    RF_OFF_ITERATIONS = 44,
    RF_OFF_TOLERANCE = 56,
    RF_OFF_RESIDUAL = 64,
    RF_OFF_FINGERPRINT = 88,
    RF_OFF_CHANNEL_METHOD = 96,
    RF_OFF_FLAGS = 108,
    RF_OFF_VERTEX_OFFSET = 112,
    RF_OFF_PATCH_OFFSET = 120,
    RF_OFF_RADIOSITY_OFFSET = 128,
    RF_OFF_FILE_BYTES = 136,
    RF_OFF_PAYLOAD_SUM = 144,
    RF_OFF_SCENE_PATH = 152, /* char[88] */
    RF_OFF_HEADER_SUM = 248
};

/* A unit normal may be off by this much in length (float rounding of the
 * mesh builder is far smaller). */
/* Refuse patch or vertex counts above this (the mesh uses uint32 indices). */
#define RF_MAX_COUNT ((uint64_t)UINT32_MAX - 1)

typedef struct rf_layout {
    uint64_t vertex_offset, patch_offset, radiosity_offset, file_bytes;
} rf_layout;

/* Counts are <= RF_MAX_COUNT, so none of these products overflow 64 bits. */
static rf_layout rf_layout_of(uint64_t patch_count, uint64_t vertex_count)
{
    rf_layout l;
    l.vertex_offset = RAD_RF_HEADER_BYTES;
    l.patch_offset = rad_align_up(l.vertex_offset + vertex_count * 24, RAD_RF_ALIGN);
    l.radiosity_offset = rad_align_up(l.patch_offset + patch_count * RAD_RF_PATCH_BYTES, RAD_RF_ALIGN);
    l.file_bytes = l.radiosity_offset + patch_count * 24;
    return l;
}

static int valid_method(uint32_t m) { return m >= RAD_SOLVE_JACOBI && m <= RAD_SOLVE_CG; }

/* The whole file image: header + tables + radiosity. */
static rad_status rf_encode(const char *path, const rad_radiosity *r, unsigned char **out_bytes, size_t *out_size)
{
    const rad_mesh *mesh = &r->mesh;
    if (mesh->patch_count == 0 || mesh->patch_count > RF_MAX_COUNT || mesh->vertex_count > RF_MAX_COUNT) {
        rad_error("%s: cannot write %zu patches and %zu vertices", path, mesh->patch_count, mesh->vertex_count);
        return RAD_ERR_INVALID;
    }
    if ((r->channel_count != 1 && r->channel_count != 3) || !valid_method(r->method)) {
        rad_error("%s: cannot write channel count %u with method %u", path, r->channel_count, r->method);
        return RAD_ERR_INVALID;
    }
    rf_layout l = rf_layout_of(mesh->patch_count, mesh->vertex_count);
    if (l.file_bytes > SIZE_MAX) {
        rad_error("%s: %llu bytes do not fit in memory", path, (unsigned long long)l.file_bytes);
        return RAD_ERR_NOMEM;
    }
    unsigned char *b = calloc(1, (size_t)l.file_bytes);
    if (!b) {
        rad_error("%s: out of memory for %llu bytes", path, (unsigned long long)l.file_bytes);
        return RAD_ERR_NOMEM;
    }
    rad_patch_table_encode(mesh, b + l.vertex_offset, b + l.patch_offset);
    for (size_t i = 0; i < 3 * mesh->patch_count; i++) rad_put_f64(b + l.radiosity_offset + 8 * i, r->radiosity[i]);

    memcpy(b + RF_OFF_MAGIC, RAD_RF_MAGIC, 8);
    rad_put_u32(b + RF_OFF_VERSION, RAD_RF_VERSION);
    rad_put_u32(b + RF_OFF_HEADER_BYTES, RAD_RF_HEADER_BYTES);
    rad_put_u64(b + RF_OFF_PATCH_COUNT, mesh->patch_count);
    rad_put_u64(b + RF_OFF_VERTEX_COUNT, mesh->vertex_count);
    rad_put_u32(b + RF_OFF_CHANNELS, r->channel_count);
    rad_put_u32(b + RF_OFF_METHOD, r->method);
    rad_put_u32(b + RF_OFF_CONVERGED, r->converged ? 1u : 0u);
    for (int c = 0; c < 3; c++) {
        rad_put_u32(b + RF_OFF_ITERATIONS + 4 * c, r->iterations[c]);
        rad_put_f64(b + RF_OFF_RESIDUAL + 8 * c, r->residual[c]);
        rad_put_u32(b + RF_OFF_CHANNEL_METHOD + 4 * c, r->channel_method[c] ? r->channel_method[c] : r->method);
    }
    rad_put_f64(b + RF_OFF_TOLERANCE, r->tolerance);
    rad_put_u32(b + RF_OFF_FLAGS, r->flags);
    memcpy(b + RF_OFF_SCENE_PATH, r->scene_path, strnlen(r->scene_path, sizeof r->scene_path - 1));
    rad_put_u64(b + RF_OFF_FINGERPRINT, r->scene_fingerprint);
    rad_put_u64(b + RF_OFF_VERTEX_OFFSET, l.vertex_offset);
    rad_put_u64(b + RF_OFF_PATCH_OFFSET, l.patch_offset);
    rad_put_u64(b + RF_OFF_RADIOSITY_OFFSET, l.radiosity_offset);
    rad_put_u64(b + RF_OFF_FILE_BYTES, l.file_bytes);
    rad_put_u64(b + RF_OFF_PAYLOAD_SUM,
            rad_hash64(RAD_HASH_SEED, b + RAD_RF_HEADER_BYTES, (size_t)(l.file_bytes - RAD_RF_HEADER_BYTES)));
    rad_put_u64(b + RF_OFF_HEADER_SUM, rad_hash64(RAD_HASH_SEED, b, RF_OFF_HEADER_SUM));
    *out_bytes = b;
    *out_size = (size_t)l.file_bytes;
    return RAD_OK;
}

rad_status rad_rf_write(const char *path, const rad_radiosity *radiosity)
{
    rad_status status;
    unsigned char *bytes = NULL;
    size_t size = 0;
    FILE *f = NULL;
    char temp[4096];
    int have_temp = 0;

    status = rf_encode(path, radiosity, &bytes, &size);
    if (status != RAD_OK) goto done;
    status = rad_fs_temp_create(path, temp, sizeof temp);
    if (status != RAD_OK) goto done;
    have_temp = 1;
    f = rad_fs_temp_open(temp);
    if (!f) {
        rad_error("%s: cannot open: %s", temp, strerror(errno));
        status = RAD_ERR_IO;
        goto done;
    }
    if (fwrite(bytes, 1, size, f) != size) {
        rad_error("%s: write failed: %s", temp, strerror(errno));
        status = RAD_ERR_IO;
        goto done;
    }
    int closed = fclose(f);
    f = NULL;
    if (closed != 0) {
        rad_error("%s: write failed on close: %s", temp, strerror(errno));
        status = RAD_ERR_IO;
        goto done;
    }
    status = rad_fs_commit(temp, path);
    have_temp = 0; /* rad_fs_commit removes the temporary on failure */
done:
    if (f) fclose(f);
    if (have_temp && status != RAD_OK) rad_fs_discard(temp);
    free(bytes);
    return status;
}

/* ---- reading ---- */

static rad_status read_file(const char *path, unsigned char **out_bytes, size_t *out_size)
{
    rad_status status = RAD_ERR_IO;
    unsigned char *bytes = NULL;
    FILE *f = rad_fs_open_input(path);
    if (!f) return RAD_ERR_IO;
    if (fseeko(f, 0, SEEK_END) != 0) {
        rad_error("%s: cannot seek: %s", path, strerror(errno));
        goto done;
    }
    off_t end = ftello(f);
    if (end < 0 || fseeko(f, 0, SEEK_SET) != 0) {
        rad_error("%s: cannot determine the file size: %s", path, strerror(errno));
        goto done;
    }
    if (end < (off_t)RAD_RF_HEADER_BYTES) {
        rad_error("%s: %lld bytes is too short for a radiosity file (header alone is %u bytes)", path,
                  (long long)end, RAD_RF_HEADER_BYTES);
        status = RAD_ERR_FORMAT;
        goto done;
    }
    if ((uint64_t)end > SIZE_MAX) {
        rad_error("%s: %lld bytes do not fit in memory", path, (long long)end);
        status = RAD_ERR_NOMEM;
        goto done;
    }
    bytes = malloc((size_t)end);
    if (!bytes) {
        rad_error("%s: out of memory for %lld bytes", path, (long long)end);
        status = RAD_ERR_NOMEM;
        goto done;
    }
    if (fread(bytes, 1, (size_t)end, f) != (size_t)end) {
        rad_error("%s: read error: %s", path, ferror(f) ? strerror(errno) : "file shrank while reading");
        goto done;
    }
    *out_bytes = bytes;
    *out_size = (size_t)end;
    bytes = NULL;
    status = RAD_OK;
done:
    free(bytes);
    fclose(f);
    return status;
}

/* Magic, version, checksums and layout; values come later. */
static rad_status check_header(const char *path, const unsigned char *b, size_t size, rf_layout *out_layout)
{
    if (memcmp(b + RF_OFF_MAGIC, RAD_RF_MAGIC, 8) != 0) {
        if (memcmp(b, "RADFF", 5) == 0)
            rad_error("%s: is a form-factor file, not a radiosity file (run solve on it first)", path);
        else
            rad_error("%s: not a radiosity file (bad magic)", path);
        return RAD_ERR_FORMAT;
    }
    uint32_t version = rad_get_u32(b + RF_OFF_VERSION);
    if (version != RAD_RF_VERSION) {
        rad_error("%s: radiosity file version %u, this program reads version %u", path, version, RAD_RF_VERSION);
        return RAD_ERR_FORMAT;
    }
    if (rad_get_u64(b + RF_OFF_HEADER_SUM) != rad_hash64(RAD_HASH_SEED, b, RF_OFF_HEADER_SUM)) {
        rad_error("%s: header checksum mismatch (file corrupt)", path);
        return RAD_ERR_FORMAT;
    }
    uint64_t n = rad_get_u64(b + RF_OFF_PATCH_COUNT), v = rad_get_u64(b + RF_OFF_VERTEX_COUNT);
    if (rad_get_u32(b + RF_OFF_HEADER_BYTES) != RAD_RF_HEADER_BYTES || n == 0 || n > RF_MAX_COUNT || v < 3 ||
        v > RF_MAX_COUNT) {
        rad_error("%s: bad header (header size %u, %llu patches, %llu vertices)", path,
                  rad_get_u32(b + RF_OFF_HEADER_BYTES), (unsigned long long)n, (unsigned long long)v);
        return RAD_ERR_FORMAT;
    }
    rf_layout l = rf_layout_of(n, v);
    if (rad_get_u64(b + RF_OFF_VERTEX_OFFSET) != l.vertex_offset || rad_get_u64(b + RF_OFF_PATCH_OFFSET) != l.patch_offset ||
        rad_get_u64(b + RF_OFF_RADIOSITY_OFFSET) != l.radiosity_offset ||
        rad_get_u64(b + RF_OFF_FILE_BYTES) != l.file_bytes) {
        rad_error("%s: section offsets do not match %llu patches and %llu vertices", path, (unsigned long long)n,
                  (unsigned long long)v);
        return RAD_ERR_FORMAT;
    }
    if (size != l.file_bytes) {
        rad_error("%s: %s: %zu bytes, expected %llu for %llu patches", path,
                  size < l.file_bytes ? "truncated" : "trailing data", size, (unsigned long long)l.file_bytes,
                  (unsigned long long)n);
        return RAD_ERR_FORMAT;
    }
    if (rad_get_u64(b + RF_OFF_PAYLOAD_SUM) !=
        rad_hash64(RAD_HASH_SEED, b + RAD_RF_HEADER_BYTES, size - RAD_RF_HEADER_BYTES)) {
        rad_error("%s: payload checksum mismatch (file corrupt)", path);
        return RAD_ERR_FORMAT;
    }
    *out_layout = l;
    return RAD_OK;
}


static rad_status decode_body(const char *path, const unsigned char *b, const rf_layout *l, rad_radiosity *r)
{
    rad_mesh *mesh = &r->mesh;
    rad_patch_table_decode(b + l->vertex_offset, b + l->patch_offset, mesh);
    rad_status status = rad_patch_table_check(path, mesh);
    if (status != RAD_OK) return status;
    for (size_t i = 0; i < 3 * mesh->patch_count; i++) {
        r->radiosity[i] = rad_get_f64(b + l->radiosity_offset + 8 * i);
        if (!isfinite(r->radiosity[i])) {
            rad_error("%s: patch %zu: radiosity of channel %zu is not finite", path, i / 3, i % 3);
            return RAD_ERR_INVALID;
        }
    }
    return RAD_OK;
}

static rad_status decode_scalars(const char *path, const unsigned char *b, rad_radiosity *r)
{
    r->channel_count = rad_get_u32(b + RF_OFF_CHANNELS);
    r->method = rad_get_u32(b + RF_OFF_METHOD);
    r->converged = rad_get_u32(b + RF_OFF_CONVERGED);
    r->tolerance = rad_get_f64(b + RF_OFF_TOLERANCE);
    r->scene_fingerprint = rad_get_u64(b + RF_OFF_FINGERPRINT);
    r->flags = rad_get_u32(b + RF_OFF_FLAGS); /* unknown bits: kept, ignored */
    int ok = (r->channel_count == 1 || r->channel_count == 3) && valid_method(r->method) && r->converged <= 1 &&
             isfinite(r->tolerance) && r->tolerance > 0;
    for (int c = 0; c < 3; c++) {
        r->iterations[c] = rad_get_u32(b + RF_OFF_ITERATIONS + 4 * c);
        r->residual[c] = rad_get_f64(b + RF_OFF_RESIDUAL + 8 * c);
        r->channel_method[c] = rad_get_u32(b + RF_OFF_CHANNEL_METHOD + 4 * c);
        ok = ok && r->residual[c] >= 0 && isfinite(r->residual[c]) && valid_method(r->channel_method[c]);
    }
    if (!ok) {
        rad_error("%s: bad solver record (channels %u, method %u, converged %u, tolerance %g)", path,
                  r->channel_count, r->method, r->converged, r->tolerance);
        return RAD_ERR_INVALID;
    }
    return RAD_OK;
}

rad_status rad_rf_read(const char *path, rad_radiosity *out_radiosity)
{
    rad_status status;
    unsigned char *bytes = NULL;
    size_t size = 0;
    rf_layout l;
    rad_radiosity r;
    memset(&r, 0, sizeof r);

    status = read_file(path, &bytes, &size);
    if (status != RAD_OK) goto done;
    status = check_header(path, bytes, size, &l);
    if (status != RAD_OK) goto done;
    status = decode_scalars(path, bytes, &r);
    if (status != RAD_OK) goto done;
    memcpy(r.scene_path, bytes + RF_OFF_SCENE_PATH, sizeof r.scene_path - 1); /* NUL-ended by the memset */
    r.mesh.patch_count = (size_t)rad_get_u64(bytes + RF_OFF_PATCH_COUNT);
    r.mesh.vertex_count = (size_t)rad_get_u64(bytes + RF_OFF_VERTEX_COUNT);
    r.mesh.positions = malloc(r.mesh.vertex_count * 3 * sizeof(double));
    r.mesh.patches = malloc(r.mesh.patch_count * sizeof(rad_patch));
    r.radiosity = malloc(r.mesh.patch_count * 3 * sizeof(double));
    if (!r.mesh.positions || !r.mesh.patches || !r.radiosity) {
        rad_error("%s: out of memory for %zu patches", path, r.mesh.patch_count);
        status = RAD_ERR_NOMEM;
        goto done;
    }
    status = decode_body(path, bytes, &l, &r);
    if (status != RAD_OK) goto done;
    *out_radiosity = r;
    memset(&r, 0, sizeof r);
done:
    rad_radiosity_free(&r);
    free(bytes);
    return status;
}

void rad_radiosity_free(rad_radiosity *radiosity)
{
    if (!radiosity) return;
    rad_mesh_free(&radiosity->mesh); /* groups too, where a caller set them (formfactor --refine) */
    free(radiosity->radiosity);
    memset(radiosity, 0, sizeof *radiosity);
}
