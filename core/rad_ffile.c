#define _FILE_OFFSET_BITS 64
#define _POSIX_C_SOURCE 200809L
#include "rad_ffile.h"

#include <errno.h>
#include <stdio.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "rad_bytes.h"
#include "rad_fs.h"
#include "rad_hash.h"
#include "rad_lfile.h"
#include "rad_log.h"
#include "rad_patch_table.h"

_Static_assert(RAD_PATCH_RECORD_BYTES == 128, "the patch table's records are 128 bytes (rad_patch_table.h)");

/* Header field offsets (docs/formats.md). */
enum {
    H_MAGIC = 0,
    H_VERSION = 8,
    H_HEADER_BYTES = 12,
    H_PATCH_COUNT = 16,
    H_VERTEX_COUNT = 24,
    H_ELEMENT_TYPE = 32,
    H_ESTIMATOR = 36,
    H_SAMPLES = 40,
    H_SHADOW_RAYS = 44,
    H_SEED = 48,
    H_FINGERPRINT = 56,
    H_SUBDIV = 64,
    H_FLAGS = 68,
    H_VERTEX_OFFSET = 72,
    H_PATCH_OFFSET = 80,
    H_MATRIX_OFFSET = 88,
    H_ROW_CHECKSUM_OFFSET = 96,
    H_FILE_BYTES = 104,
    H_TABLES_CHECKSUM = 112,
    H_ROW_CHECKSUMS_DIGEST = 120,
    H_SCENE_NAME = 128, /* 96 bytes, NUL-padded; 64 in the links layout, 60 in version 5's */
    H_CLUSTER_COUNT = 188, /* links layout, version 5: the name's last 4 of its 64 bytes */
    H_NODE_COUNT = 192, /* links layout (version 4): the rest of the name's 96 bytes */
    H_ROOT_COUNT = 196,
    H_LINK_COUNT = 200,
    H_LINK_TOL = 208,
    H_ERROR_BOUND = 216,
    H_GROUP_OFFSET = 224, /* version 2; reserved (zero) in version 1 */
    H_GROUP_COUNT = 232,  /* version 2 */
    H_LAYOUT = 236,       /* version 3 (reserved, zero, before) */
    H_MATRIX_BYTES = 240, /* version 3, sparse layout: bytes of the row records; links: of the link sections */
    H_HEADER_CHECKSUM = 248
};

/* The scene name's bytes in the links layout (the link counts follow),
 * and in version 5's (the cluster count follows). */
#define RAD_FF_LINKS_NAME_BYTES (H_NODE_COUNT - H_SCENE_NAME)
#define RAD_FF_CLUSTERS_NAME_BYTES (H_CLUSTER_COUNT - H_SCENE_NAME)

/* Largest N the format allows: patch indices are uint32 in the mesh. */
#define RAD_FF_MAX_PATCHES (UINT64_C(1) << 31)
/* Largest matrix a reader believes in (1 EiB, more than any file system
 * holds). It also keeps the layout's arithmetic far from 64-bit overflow:
 * at N = 2^31, N^2 float64 would be 2^65 bytes and wrap around. */
#define RAD_FF_MAX_MATRIX_BYTES (UINT64_C(1) << 60)

rad_ff_layout rad_ff_layout_of(const rad_ff_info *info)
{
    rad_ff_layout l;
    uint64_t n = info->patch_count;
    l.element_bytes = info->element_type == RAD_ELEMENT_F32 ? 4 : 8;
    l.row_bytes = n * l.element_bytes;
    l.vertex_offset = RAD_FF_HEADER_BYTES;
    l.patch_offset = rad_align_up(l.vertex_offset + info->vertex_count * 24, RAD_FF_ALIGN);
    uint64_t patches_end = l.patch_offset + n * RAD_PATCH_RECORD_BYTES;
    if (info->group_count) {
        l.group_offset = rad_align_up(patches_end, RAD_FF_ALIGN);
        l.patch_group_offset = l.group_offset + (uint64_t)info->group_count * RAD_NAME_MAX;
        l.matrix_offset = rad_align_up(l.patch_group_offset + n * 4, RAD_FF_ALIGN);
    } else {
        l.group_offset = l.patch_group_offset = 0;
        l.matrix_offset = rad_align_up(patches_end, RAD_FF_ALIGN);
    }
    uint64_t matrix_bytes = info->layout == RAD_FF_LAYOUT_SPARSE ? info->matrix_bytes : n * l.row_bytes;
    l.index_bytes = info->layout == RAD_FF_LAYOUT_SPARSE ? (2 * n + 1) * 8 : n * 8;
    l.first_link_offset = l.link_offset = l.cluster_offset = l.cluster_root_offset = 0;
    if (info->layout == RAD_FF_LAYOUT_LINKS) {
        /* node table at the matrix offset, then (with clusters) the cluster
         * table and the cluster roots, then first_link, then the links */
        uint64_t ids = (uint64_t)info->node_count + info->cluster_count;
        uint64_t after =
            rad_align_up(l.matrix_offset + (uint64_t)info->node_count * RAD_LFILE_NODE_BYTES, RAD_FF_ALIGN);
        if (info->cluster_count) {
            l.cluster_offset = after;
            l.cluster_root_offset =
                rad_align_up(l.cluster_offset + (uint64_t)info->cluster_count * RAD_LFILE_CLUSTER_BYTES, RAD_FF_ALIGN);
            after = rad_align_up(l.cluster_root_offset + (uint64_t)info->root_count * 4, RAD_FF_ALIGN);
        }
        l.first_link_offset = after;
        l.link_offset = rad_align_up(l.first_link_offset + (ids + 1) * 8, RAD_FF_ALIGN);
        matrix_bytes = l.link_offset + info->link_count * RAD_LFILE_LINK_BYTES - l.matrix_offset;
        l.index_bytes = rad_lfile_checksum_count(info->cluster_count, info->link_count) * 8;
    }
    l.row_checksum_offset = rad_align_up(l.matrix_offset + matrix_bytes, RAD_FF_ALIGN);
    l.file_bytes = l.row_checksum_offset + l.index_bytes;
    return l;
}

static uint64_t tile_count_of(uint64_t n) { return (n + RAD_FF_TILE_COLUMNS - 1) / RAD_FF_TILE_COLUMNS; }

size_t rad_ff_row_record_max(uint64_t n, uint32_t element_type)
{
    uint64_t element = element_type == RAD_ELEMENT_F32 ? 4 : 8;
    return (size_t)(rad_align_up(4 + 4 * tile_count_of(n), 8) + rad_align_up(n * element, 8));
}

/* The entries of columns [j0, j1) of `row` as stored; 1 if all bits are zero. */
static int store_tile(const double *row, uint64_t j0, uint64_t j1, uint32_t element_type, unsigned char *out)
{
    int zero = 1;
    for (uint64_t j = j0; j < j1; j++) {
        if (element_type == RAD_ELEMENT_F32) {
            float v = (float)row[j];
            uint32_t bits;
            memcpy(&bits, &v, 4);
            zero &= bits == 0;
            memcpy(out + 4 * (j - j0), &v, 4);
        } else {
            uint64_t bits;
            memcpy(&bits, &row[j], 8);
            zero &= bits == 0;
            memcpy(out + 8 * (j - j0), &row[j], 8);
        }
    }
    return zero;
}

size_t rad_ff_row_encode(const double *row, uint64_t n, uint32_t element_type, void *out)
{
    uint64_t element = element_type == RAD_ELEMENT_F32 ? 4 : 8, tiles = tile_count_of(n);
    unsigned char scratch[RAD_FF_TILE_COLUMNS * 8];
    uint32_t listed = 0;
    for (uint64_t t = 0; t < tiles; t++) {
        uint64_t j0 = t * RAD_FF_TILE_COLUMNS, j1 = j0 + RAD_FF_TILE_COLUMNS < n ? j0 + RAD_FF_TILE_COLUMNS : n;
        if (!store_tile(row, j0, j1, element_type, scratch)) listed++;
    }
    size_t values_at = (size_t)rad_align_up(4 + 4 * (uint64_t)listed, 8), size = values_at;
    unsigned char *o = out;
    if (o) {
        memset(o, 0, values_at);
        rad_put_u32(o, listed);
    }
    uint32_t k = 0;
    for (uint64_t t = 0; t < tiles && listed; t++) {
        uint64_t j0 = t * RAD_FF_TILE_COLUMNS, j1 = j0 + RAD_FF_TILE_COLUMNS < n ? j0 + RAD_FF_TILE_COLUMNS : n;
        if (store_tile(row, j0, j1, element_type, scratch)) continue;
        if (o) {
            rad_put_u32(o + 4 + 4 * k, (uint32_t)t);
            memcpy(o + size, scratch, (size_t)((j1 - j0) * element));
        }
        k++;
        size += (size_t)((j1 - j0) * element);
    }
    size_t end = (size_t)rad_align_up(size, 8);
    if (o) memset(o + size, 0, end - size);
    return end;
}

/* Decodes a sparse row record of `size` bytes: its tile numbers into
 * tiles[] (*out_count of them, at most tile_count_of(n)) and its entries,
 * tile after tile, as doubles into values[] (*out_values, at most n).
 * NULL if the record is well formed, else what is wrong. */
static const char *decode_record(const unsigned char *rec, uint64_t size, uint64_t n, uint32_t element_type,
                                 uint32_t *tiles, uint32_t *out_count, double *values, uint64_t *out_values)
{
    uint64_t element = element_type == RAD_ELEMENT_F32 ? 4 : 8, tile_total = tile_count_of(n);
    if (size < 8 || size % 8) return "record size is not a multiple of 8 bytes of at least 8";
    uint64_t listed = rad_get_u32(rec);
    if (listed > tile_total) return "more tiles than the row has";
    uint64_t values_at = rad_align_up(4 + 4 * listed, 8), at = values_at, v = 0;
    if (values_at > size) return "tile list runs past the record";
    for (uint64_t k = 4 + 4 * listed; k < values_at; k++)
        if (rec[k]) return "padding is not zero";
    for (uint64_t k = 0; k < listed; k++) {
        uint64_t t = rad_get_u32(rec + 4 + 4 * k);
        if (t >= tile_total) return "tile number beyond the row";
        if (k > 0 && t <= tiles[k - 1]) return "tile numbers not ascending within the row";
        tiles[k] = (uint32_t)t;
        uint64_t j0 = t * RAD_FF_TILE_COLUMNS, j1 = j0 + RAD_FF_TILE_COLUMNS < n ? j0 + RAD_FF_TILE_COLUMNS : n;
        if (at + (j1 - j0) * element > size) return "tiles run past the record";
        for (uint64_t j = j0; j < j1; j++, at += element, v++) {
            if (element_type == RAD_ELEMENT_F32) {
                float f;
                memcpy(&f, rec + at, 4);
                values[v] = f;
            } else {
                memcpy(&values[v], rec + at, 8);
            }
        }
    }
    if (rad_align_up(at, 8) != size) return "record size disagrees with its tiles";
    for (uint64_t k = at; k < size; k++)
        if (rec[k]) return "padding is not zero";
    *out_count = (uint32_t)listed;
    *out_values = v;
    return NULL;
}

const char *rad_ff_record_decode(const unsigned char *record, uint64_t size, uint64_t n, uint32_t element_type,
                                 uint32_t *tiles, uint32_t *out_tiles, double *values, uint64_t *out_values)
{
    return decode_record(record, size, n, element_type, tiles, out_tiles, values, out_values);
}

const char *rad_ff_record_sizes(const unsigned char *record, uint64_t size, uint64_t n, uint32_t *out_tiles,
                                uint64_t *out_values)
{
    if (size < 8 || size % 8) return "record size is not a multiple of 8 bytes of at least 8";
    uint64_t listed = rad_get_u32(record), values = 0;
    if (listed > tile_count_of(n) || 4 + 4 * listed > size) return "more tiles than the row has";
    for (uint64_t k = 0; k < listed; k++) {
        uint64_t j0 = (uint64_t)rad_get_u32(record + 4 + 4 * k) * RAD_FF_TILE_COLUMNS;
        values += j0 >= n ? 0 : (j0 + RAD_FF_TILE_COLUMNS < n ? RAD_FF_TILE_COLUMNS : n - j0);
    }
    *out_tiles = (uint32_t)listed;
    *out_values = values;
    return NULL;
}

uint64_t rad_ff_row_checksum(const void *row, size_t row_bytes)
{
    return rad_hash64(RAD_HASH_SEED, row, row_bytes);
}

static void encode_header(const rad_ff_info *info, const rad_ff_layout *l, uint64_t tables_checksum,
                          unsigned char *h)
{
    int sparse = info->layout == RAD_FF_LAYOUT_SPARSE, links = info->layout == RAD_FF_LAYOUT_LINKS;
    int clusters = links && info->cluster_count > 0;
    memset(h, 0, RAD_FF_HEADER_BYTES);
    memcpy(h + H_MAGIC, RAD_FF_MAGIC, 8);
    rad_put_u32(h + H_VERSION, clusters ? RAD_FF_VERSION_CLUSTERS
                               : links  ? RAD_FF_VERSION_LINKS
                               : sparse ? RAD_FF_VERSION_SPARSE
                                        : RAD_FF_VERSION_DENSE);
    rad_put_u32(h + H_HEADER_BYTES, RAD_FF_HEADER_BYTES);
    rad_put_u64(h + H_PATCH_COUNT, info->patch_count);
    rad_put_u64(h + H_VERTEX_COUNT, info->vertex_count);
    rad_put_u32(h + H_ELEMENT_TYPE, info->element_type);
    rad_put_u32(h + H_ESTIMATOR, info->estimator);
    rad_put_u32(h + H_SAMPLES, info->samples);
    rad_put_u32(h + H_SHADOW_RAYS, info->shadow_rays);
    rad_put_u64(h + H_SEED, info->seed);
    rad_put_u64(h + H_FINGERPRINT, info->scene_fingerprint);
    rad_put_u32(h + H_SUBDIV, (uint32_t)info->subdiv);
    rad_put_u32(h + H_FLAGS, info->flags);
    rad_put_u64(h + H_VERTEX_OFFSET, l->vertex_offset);
    rad_put_u64(h + H_PATCH_OFFSET, l->patch_offset);
    rad_put_u64(h + H_MATRIX_OFFSET, l->matrix_offset);
    rad_put_u64(h + H_ROW_CHECKSUM_OFFSET, l->row_checksum_offset);
    rad_put_u64(h + H_FILE_BYTES, l->file_bytes);
    rad_put_u64(h + H_TABLES_CHECKSUM, tables_checksum);
    size_t name_len = strnlen(info->scene_name, clusters ? RAD_FF_CLUSTERS_NAME_BYTES - 1
                                                : links  ? RAD_FF_LINKS_NAME_BYTES - 1
                                                         : sizeof info->scene_name - 1);
    memcpy(h + H_SCENE_NAME, info->scene_name, name_len);
    rad_put_u64(h + H_GROUP_OFFSET, l->group_offset);
    rad_put_u32(h + H_GROUP_COUNT, info->group_count);
    if (sparse) {
        rad_put_u32(h + H_LAYOUT, info->layout);
        rad_put_u64(h + H_MATRIX_BYTES, info->matrix_bytes);
    }
    if (links) {
        rad_put_u32(h + H_NODE_COUNT, info->node_count);
        rad_put_u32(h + H_ROOT_COUNT, info->root_count);
        rad_put_u64(h + H_LINK_COUNT, info->link_count);
        rad_put_f64(h + H_LINK_TOL, info->link_tol);
        rad_put_f64(h + H_ERROR_BOUND, info->error_bound);
        rad_put_u32(h + H_LAYOUT, info->layout);
        rad_put_u64(h + H_MATRIX_BYTES, l->link_offset + info->link_count * RAD_LFILE_LINK_BYTES - l->matrix_offset);
    }
    if (clusters) rad_put_u32(h + H_CLUSTER_COUNT, info->cluster_count);
    rad_put_u64(h + H_HEADER_CHECKSUM, rad_hash64(RAD_HASH_SEED, h, H_HEADER_CHECKSUM));
}

static void decode_header(const unsigned char *h, rad_ff_info *info)
{
    memset(info, 0, sizeof *info);
    info->patch_count = rad_get_u64(h + H_PATCH_COUNT);
    info->vertex_count = rad_get_u64(h + H_VERTEX_COUNT);
    info->element_type = rad_get_u32(h + H_ELEMENT_TYPE);
    info->estimator = rad_get_u32(h + H_ESTIMATOR);
    info->samples = rad_get_u32(h + H_SAMPLES);
    info->shadow_rays = rad_get_u32(h + H_SHADOW_RAYS);
    info->seed = rad_get_u64(h + H_SEED);
    info->scene_fingerprint = rad_get_u64(h + H_FINGERPRINT);
    info->subdiv = (int32_t)rad_get_u32(h + H_SUBDIV);
    info->flags = rad_get_u32(h + H_FLAGS);
    memcpy(info->scene_name, h + H_SCENE_NAME, sizeof info->scene_name - 1);
    uint32_t version = rad_get_u32(h + H_VERSION);
    if (version >= 2) info->group_count = rad_get_u32(h + H_GROUP_COUNT);
    if (version >= 3) {
        info->layout = rad_get_u32(h + H_LAYOUT);
        info->matrix_bytes = rad_get_u64(h + H_MATRIX_BYTES);
    }
    if (version >= RAD_FF_VERSION_LINKS && info->layout == RAD_FF_LAYOUT_LINKS) {
        memset(info->scene_name + RAD_FF_LINKS_NAME_BYTES - 1, 0,
               sizeof info->scene_name - (RAD_FF_LINKS_NAME_BYTES - 1));
        info->node_count = rad_get_u32(h + H_NODE_COUNT);
        info->root_count = rad_get_u32(h + H_ROOT_COUNT);
        info->link_count = rad_get_u64(h + H_LINK_COUNT);
        info->link_tol = rad_get_f64(h + H_LINK_TOL);
        info->error_bound = rad_get_f64(h + H_ERROR_BOUND);
    }
    /* version 4 keeps name bytes where version 5 has the cluster count */
    if (version >= RAD_FF_VERSION_CLUSTERS && info->layout == RAD_FF_LAYOUT_LINKS) {
        memset(info->scene_name + RAD_FF_CLUSTERS_NAME_BYTES - 1, 0,
               sizeof info->scene_name - (RAD_FF_CLUSTERS_NAME_BYTES - 1));
        info->cluster_count = rad_get_u32(h + H_CLUSTER_COUNT);
    }
}

rad_status rad_ff_prologue_encode(const rad_ff_info *info, const rad_mesh *mesh, unsigned char **out_bytes,
                                  size_t *out_size)
{
    if (info->patch_count != mesh->patch_count || info->vertex_count != mesh->vertex_count ||
        info->group_count != mesh->group_count || (mesh->group_count && (!mesh->group_names || !mesh->patch_group))) {
        rad_error("internal: form-factor info does not match the mesh");
        return RAD_ERR_INVALID;
    }
    for (size_t i = 0; i < mesh->patch_count && mesh->group_count; i++)
        if (mesh->patch_group[i] >= mesh->group_count) {
            rad_error("internal: patch %zu: group %u of %zu", i, mesh->patch_group[i], mesh->group_count);
            return RAD_ERR_INVALID;
        }
    rad_ff_layout l = rad_ff_layout_of(info);
    unsigned char *bytes = calloc(1, l.matrix_offset);
    if (!bytes) {
        rad_error("out of memory encoding the form-factor file header (%llu bytes)",
                  (unsigned long long)l.matrix_offset);
        return RAD_ERR_NOMEM;
    }
    rad_patch_table_encode(mesh, bytes + l.vertex_offset, bytes + l.patch_offset);
    for (size_t g = 0; g < mesh->group_count; g++) {
        const char *name = mesh->group_names[g];
        memcpy(bytes + l.group_offset + g * RAD_NAME_MAX, name, strnlen(name, RAD_NAME_MAX - 1));
    }
    if (mesh->group_count)
        for (size_t i = 0; i < mesh->patch_count; i++)
            rad_put_u32(bytes + l.patch_group_offset + 4 * i, mesh->patch_group[i]);
    uint64_t tables = rad_hash64(RAD_HASH_SEED, bytes + RAD_FF_HEADER_BYTES, l.matrix_offset - RAD_FF_HEADER_BYTES);
    encode_header(info, &l, tables, bytes);
    *out_bytes = bytes;
    *out_size = l.matrix_offset;
    return RAD_OK;
}

void rad_ff_header_finish(unsigned char *prologue, const rad_ff_info *info, const void *index)
{
    rad_ff_layout l = rad_ff_layout_of(info);
    encode_header(info, &l, rad_get_u64(prologue + H_TABLES_CHECKSUM), prologue);
    rad_put_u64(prologue + H_ROW_CHECKSUMS_DIGEST, rad_hash64(RAD_HASH_SEED, index, l.index_bytes));
    rad_put_u64(prologue + H_HEADER_CHECKSUM, rad_hash64(RAD_HASH_SEED, prologue, H_HEADER_CHECKSUM));
}

static int write_at(FILE *f, uint64_t offset, const void *data, size_t size)
{
    return fseeko(f, (off_t)offset, SEEK_SET) == 0 && fwrite(data, 1, size, f) == size;
}

rad_status rad_ff_write_serial(const char *path, const rad_ff_info *info_in, const rad_mesh *mesh,
                               const double *matrix)
{
    rad_status status = RAD_OK;
    unsigned char *prologue = NULL, *row = NULL;
    uint64_t *index = NULL;
    size_t prologue_size = 0;
    FILE *f = NULL;
    char temp[4096];
    rad_ff_info info = *info_in;
    int sparse = info.layout == RAD_FF_LAYOUT_SPARSE;
    if (info.layout != RAD_FF_LAYOUT_DENSE && !sparse) {
        rad_error("internal: %s: rad_ff_write_serial writes matrices (layout %u; links: rad_ff_write_links)", path,
                  info.layout);
        return RAD_ERR_INVALID;
    }
    if ((status = rad_ff_prologue_encode(&info, mesh, &prologue, &prologue_size)) != RAD_OK) return status;
    if ((status = rad_fs_temp_create(path, temp, sizeof temp)) != RAD_OK) {
        free(prologue);
        return status;
    }
    rad_ff_layout l = rad_ff_layout_of(&info);
    uint64_t n = info.patch_count;
    /* Dense: N row checksums. Sparse: N + 1 record offsets, then N checksums. */
    uint64_t *offsets = NULL, *checksums = NULL;
    size_t row_max = sparse ? rad_ff_row_record_max(n, info.element_type) : (size_t)l.row_bytes;
    row = malloc(row_max ? row_max : 1);
    index = malloc((2 * n + 1) * 8);
    if (!row || !index) {
        rad_error("%s: out of memory", path);
        status = RAD_ERR_NOMEM;
        goto done;
    }
    offsets = sparse ? index : NULL;
    checksums = sparse ? index + n + 1 : index;
    f = rad_fs_temp_open(temp);
    if (!f) {
        rad_error("%s: cannot open: %s", temp, strerror(errno));
        status = RAD_ERR_IO;
        goto done;
    }
    int ok = 1;
    uint64_t at = 0;
    for (uint64_t i = 0; i < n && ok; i++) {
        const double *src = matrix + i * n;
        size_t size = l.row_bytes;
        if (sparse)
            size = rad_ff_row_encode(src, n, info.element_type, row);
        else if (info.element_type == RAD_ELEMENT_F32)
            for (uint64_t j = 0; j < n; j++) ((float *)row)[j] = (float)src[j];
        else
            memcpy(row, src, size);
        if (offsets) offsets[i] = at;
        checksums[i] = rad_ff_row_checksum(row, size);
        ok = write_at(f, l.matrix_offset + at, row, size);
        at += size;
    }
    if (sparse) {
        offsets[n] = at;
        info.matrix_bytes = at;
        l = rad_ff_layout_of(&info);
    }
    rad_ff_header_finish(prologue, &info, index);
    ok = ok && write_at(f, l.row_checksum_offset, index, (size_t)l.index_bytes);
    ok = ok && write_at(f, 0, prologue, prologue_size);
    if (fclose(f) != 0) ok = 0;
    f = NULL;
    if (!ok) {
        rad_error("%s: write failed: %s", temp, strerror(errno));
        status = RAD_ERR_IO;
        goto done;
    }
    status = rad_fs_commit(temp, path);
done:
    if (f) fclose(f);
    if (status != RAD_OK) rad_fs_discard(temp);
    free(prologue);
    free(row);
    free(index);
    return status;
}

/* ---- reading ---- */

struct rad_ff_file {
    char path[4096];
    FILE *f;
    rad_ff_info info;
    rad_ff_layout layout;
    rad_mesh mesh;
    uint64_t *index;         /* the layout's index: row_offsets (sparse) and row_checksums;
                                links: the checksum table (rad_lfile.h) */
    uint64_t *row_offsets;   /* sparse: N + 1 record offsets from the matrix offset; else NULL */
    uint64_t *row_checksums; /* N; NULL in the links layout */
    unsigned char *row_buffer;
    uint32_t *tile_buffer;   /* sparse: one row's tile numbers */
    double *value_buffer;    /* sparse: one row's stored entries */
};


/* The group table (G names, then each patch's group), from the tables as
 * read (which start at byte RAD_FF_HEADER_BYTES of the file). */
static rad_status decode_groups(const char *path, const unsigned char *tables, const rad_ff_layout *l,
                                rad_mesh *mesh, uint32_t group_count)
{
    if (group_count == 0) return RAD_OK;
    const unsigned char *names = tables + (l->group_offset - RAD_FF_HEADER_BYTES);
    const unsigned char *ids = tables + (l->patch_group_offset - RAD_FF_HEADER_BYTES);
    mesh->group_names = malloc((size_t)group_count * sizeof *mesh->group_names);
    mesh->patch_group = malloc((mesh->patch_count ? mesh->patch_count : 1) * sizeof *mesh->patch_group);
    if (!mesh->group_names || !mesh->patch_group) {
        rad_error("%s: out of memory for %u groups", path, group_count);
        return RAD_ERR_NOMEM;
    }
    for (uint32_t g = 0; g < group_count; g++) {
        const unsigned char *name = names + (size_t)g * RAD_NAME_MAX;
        size_t len = strnlen((const char *)name, RAD_NAME_MAX);
        int padded = len < RAD_NAME_MAX;
        for (size_t k = len; padded && k < RAD_NAME_MAX; k++) padded = name[k] == 0;
        if (len == 0 || !padded) {
            rad_error("%s: group %u: %s", path, g, len == 0 ? "empty name" : "name not NUL-terminated and zero-padded");
            return RAD_ERR_FORMAT;
        }
        memcpy(mesh->group_names[g], name, RAD_NAME_MAX);
    }
    for (size_t i = 0; i < mesh->patch_count; i++) {
        mesh->patch_group[i] = rad_get_u32(ids + 4 * i);
        if (mesh->patch_group[i] >= group_count) {
            rad_error("%s: patch %zu: group %u out of range (%u groups)", path, i, mesh->patch_group[i], group_count);
            return RAD_ERR_FORMAT;
        }
    }
    mesh->group_count = group_count;
    return RAD_OK;
}

static int read_at(FILE *f, uint64_t offset, void *data, size_t size)
{
    return fseeko(f, (off_t)offset, SEEK_SET) == 0 && fread(data, 1, size, f) == size;
}

/* A file in the paper's layout: int32 N, then N*N float64. */
static int looks_like_paper_format(const unsigned char *h, uint64_t file_size)
{
    int32_t n;
    memcpy(&n, h, 4);
    return n > 0 && file_size == 4 + 8 * (uint64_t)n * (uint64_t)n;
}

/* The links layout's part of the header: its version, element type and
 * counts, before any size is computed from them. */
static rad_status check_links_header(const char *path, uint32_t version, const rad_ff_info *info)
{
    if (version < RAD_FF_VERSION_LINKS) {
        rad_error("%s: the links layout in a version-%u file (links need version %u)", path, version,
                  RAD_FF_VERSION_LINKS);
        return RAD_ERR_FORMAT;
    }
    if (info->element_type != RAD_ELEMENT_F64) {
        rad_error("%s: element type %u in the links layout (its factors are float64, 2)", path, info->element_type);
        return RAD_ERR_FORMAT;
    }
    if (version >= RAD_FF_VERSION_CLUSTERS && info->cluster_count == 0) {
        rad_error("%s: a version-%u links file without clusters (those are version %u)", path, version,
                  RAD_FF_VERSION_LINKS);
        return RAD_ERR_FORMAT;
    }
    const char *why = rad_lfile_counts_fault(info);
    if (why) {
        rad_error("%s: implausible sizes (%u nodes, %u roots, %u clusters, %llu leaves, %llu links): %s", path,
                  info->node_count, info->root_count, info->cluster_count, (unsigned long long)info->patch_count,
                  (unsigned long long)info->link_count, why);
        return RAD_ERR_FORMAT;
    }
    return RAD_OK;
}

static rad_status check_header(const char *path, const unsigned char *h, uint64_t got, uint64_t file_size,
                               rad_ff_info *info, rad_ff_layout *layout)
{
    if (got < 8 || memcmp(h, RAD_FF_MAGIC, 8) != 0) {
        if (got >= 4 && looks_like_paper_format(h, file_size))
            rad_error("%s: this is a paper-format matrix (int32 N + N*N float64, written by --format paper); "
                      "it has no patch table: run formfactor without --format paper",
                      path);
        else
            rad_error("%s: not a form-factor file (bad magic)", path);
        return RAD_ERR_FORMAT;
    }
    if (got < RAD_FF_HEADER_BYTES) {
        rad_error("%s: truncated: %llu bytes, the header alone needs %u", path, (unsigned long long)file_size,
                  RAD_FF_HEADER_BYTES);
        return RAD_ERR_FORMAT;
    }
    uint32_t version = rad_get_u32(h + H_VERSION);
    if (version < RAD_FF_VERSION_OLDEST || version > RAD_FF_VERSION) {
        rad_error("%s: format version %u, this program reads versions %u to %u%s", path, version,
                  RAD_FF_VERSION_OLDEST, RAD_FF_VERSION, version > RAD_FF_VERSION ? " (written by a newer radiosity?)" : "");
        return RAD_ERR_FORMAT;
    }
    if (rad_get_u64(h + H_HEADER_CHECKSUM) != rad_hash64(RAD_HASH_SEED, h, H_HEADER_CHECKSUM)) {
        rad_error("%s: header checksum mismatch: the file is corrupted", path);
        return RAD_ERR_FORMAT;
    }
    decode_header(h, info);
    if (info->layout != RAD_FF_LAYOUT_DENSE && info->layout != RAD_FF_LAYOUT_SPARSE &&
        info->layout != RAD_FF_LAYOUT_LINKS) {
        rad_error("%s: unknown matrix layout %u", path, info->layout);
        return RAD_ERR_FORMAT;
    }
    if (info->layout == RAD_FF_LAYOUT_DENSE && info->matrix_bytes != 0) {
        rad_error("%s: a dense matrix with a sparse matrix size", path);
        return RAD_ERR_FORMAT;
    }
    if (info->element_type != RAD_ELEMENT_F32 && info->element_type != RAD_ELEMENT_F64) {
        rad_error("%s: unknown element type %u", path, info->element_type);
        return RAD_ERR_FORMAT;
    }
    if (info->patch_count == 0 || info->patch_count > RAD_FF_MAX_PATCHES ||
        info->vertex_count > 4 * RAD_FF_MAX_PATCHES) {
        rad_error("%s: implausible sizes (N = %llu, %llu vertices)", path, (unsigned long long)info->patch_count,
                  (unsigned long long)info->vertex_count);
        return RAD_ERR_FORMAT;
    }
    if (info->group_count > info->patch_count) {
        rad_error("%s: implausible sizes (%u groups for %llu patches)", path, info->group_count,
                  (unsigned long long)info->patch_count);
        return RAD_ERR_FORMAT;
    }
    const int links = info->layout == RAD_FF_LAYOUT_LINKS;
    if (links && check_links_header(path, version, info) != RAD_OK) return RAD_ERR_FORMAT;
    uint64_t element_bytes = info->element_type == RAD_ELEMENT_F32 ? 4 : 8;
    if (!links && info->patch_count * info->patch_count > RAD_FF_MAX_MATRIX_BYTES / element_bytes) {
        rad_error("%s: implausible sizes (N = %llu: the matrix alone would be %.3g bytes)", path,
                  (unsigned long long)info->patch_count,
                  (double)info->patch_count * (double)info->patch_count * (double)element_bytes);
        return RAD_ERR_FORMAT;
    }
    if (info->layout == RAD_FF_LAYOUT_SPARSE &&
        info->matrix_bytes / info->patch_count > rad_ff_row_record_max(info->patch_count, info->element_type)) {
        rad_error("%s: implausible sizes (%llu bytes of sparse rows for N = %llu)", path,
                  (unsigned long long)info->matrix_bytes, (unsigned long long)info->patch_count);
        return RAD_ERR_FORMAT;
    }
    *layout = rad_ff_layout_of(info);
    if (rad_get_u64(h + H_MATRIX_OFFSET) != layout->matrix_offset ||
        (version >= 2 && rad_get_u64(h + H_GROUP_OFFSET) != layout->group_offset) ||
        rad_get_u64(h + H_FILE_BYTES) != layout->file_bytes ||
        rad_get_u64(h + H_ROW_CHECKSUM_OFFSET) != layout->row_checksum_offset ||
        (links && info->matrix_bytes != layout->link_offset + info->link_count * RAD_LFILE_LINK_BYTES -
                                            layout->matrix_offset)) {
        rad_error("%s: section offsets disagree with N = %llu", path, (unsigned long long)info->patch_count);
        return RAD_ERR_FORMAT;
    }
    if (file_size != layout->file_bytes) {
        rad_error("%s: %s: %llu bytes, N = %llu needs %llu", path, file_size < layout->file_bytes ? "truncated" : "trailing bytes",
                  (unsigned long long)file_size, (unsigned long long)info->patch_count,
                  (unsigned long long)layout->file_bytes);
        return RAD_ERR_FORMAT;
    }
    return RAD_OK;
}

/* The mesh from the tables as read (which start at byte
 * RAD_FF_HEADER_BYTES), checked; ff's info, layout and mesh.positions /
 * mesh.patches (allocated) set. */
static rad_status decode_tables(const char *path, const unsigned char *tables, rad_ff_file *ff)
{
    const rad_ff_layout *l = &ff->layout;
    ff->mesh.vertex_count = ff->info.vertex_count;
    ff->mesh.patch_count = ff->info.patch_count;
    rad_patch_table_decode(tables + (l->vertex_offset - RAD_FF_HEADER_BYTES),
                           tables + (l->patch_offset - RAD_FF_HEADER_BYTES), &ff->mesh);
    rad_status status = rad_patch_table_check(path, &ff->mesh);
    if (status == RAD_OK) status = decode_groups(path, tables, l, &ff->mesh, ff->info.group_count);
    return status;
}

rad_status rad_ff_open_tables(const char *name, const rad_ff_info *info, const rad_mesh *mesh,
                              rad_ff_file **out_file)
{
    rad_status status = RAD_ERR_NOMEM;
    unsigned char *prologue = NULL;
    size_t prologue_size = 0;
    rad_ff_file *ff = calloc(1, sizeof *ff);
    *out_file = NULL;
    if (!ff) return RAD_ERR_NOMEM;
    snprintf(ff->path, sizeof ff->path, "%s", name);
    ff->info = *info;
    ff->info.layout = RAD_FF_LAYOUT_SPARSE;
    ff->layout = rad_ff_layout_of(&ff->info);
    uint64_t n = ff->info.patch_count;
    ff->mesh.positions = malloc(ff->info.vertex_count * 24 + 1);
    ff->mesh.patches = malloc((n ? n : 1) * sizeof(rad_patch));
    if (!ff->mesh.positions || !ff->mesh.patches) {
        rad_error("%s: out of memory for N = %llu", name, (unsigned long long)n);
        goto done;
    }
    /* The mesh as a reader of the file would see it. */
    if ((status = rad_ff_prologue_encode(&ff->info, mesh, &prologue, &prologue_size)) != RAD_OK) goto done;
    status = decode_tables(name, prologue + RAD_FF_HEADER_BYTES, ff);
    if (status != RAD_OK) goto done;
    *out_file = ff;
    ff = NULL;
done:
    free(prologue);
    rad_ff_close(ff);
    return status;
}

rad_status rad_ff_open(const char *path, rad_ff_file **out_file)
{
    rad_status status = RAD_ERR_FORMAT;
    unsigned char h[RAD_FF_HEADER_BYTES];
    unsigned char *tables = NULL;
    rad_ff_file *ff = calloc(1, sizeof *ff);
    *out_file = NULL;
    if (!ff) return RAD_ERR_NOMEM;
    snprintf(ff->path, sizeof ff->path, "%s", path);
    ff->f = rad_fs_open_input(path);
    if (!ff->f) {
        status = RAD_ERR_IO;
        goto done;
    }
    if (fseeko(ff->f, 0, SEEK_END) != 0) {
        rad_error("%s: cannot seek: %s", path, strerror(errno));
        status = RAD_ERR_IO;
        goto done;
    }
    uint64_t file_size = (uint64_t)ftello(ff->f);
    rewind(ff->f);
    size_t got = fread(h, 1, sizeof h, ff->f);
    if ((status = check_header(path, h, got, file_size, &ff->info, &ff->layout)) != RAD_OK) goto done;
    status = RAD_ERR_FORMAT;

    const rad_ff_layout *l = &ff->layout;
    uint64_t n = ff->info.patch_count, v = ff->info.vertex_count;
    uint64_t tables_size = l->matrix_offset - RAD_FF_HEADER_BYTES;
    tables = malloc(tables_size);
    ff->mesh.positions = malloc(v * 24 + 1);
    ff->mesh.patches = malloc(n * sizeof(rad_patch));
    int sparse = ff->info.layout == RAD_FF_LAYOUT_SPARSE, links = ff->info.layout == RAD_FF_LAYOUT_LINKS;
    size_t record_max = rad_ff_row_record_max(n, ff->info.element_type);
    ff->index = malloc(l->index_bytes);
    ff->row_buffer = malloc(links ? 8 : sparse ? record_max : l->row_bytes);
    ff->tile_buffer = malloc(sparse ? 4 * tile_count_of(n) : 4);
    ff->value_buffer = malloc(sparse ? 8 * n : 8);
    if (!tables || !ff->mesh.positions || !ff->mesh.patches || !ff->index || !ff->row_buffer || !ff->tile_buffer ||
        !ff->value_buffer) {
        rad_error("%s: out of memory for N = %llu", path, (unsigned long long)n);
        status = RAD_ERR_NOMEM;
        goto done;
    }
    if (!read_at(ff->f, RAD_FF_HEADER_BYTES, tables, tables_size) ||
        !read_at(ff->f, l->row_checksum_offset, ff->index, l->index_bytes)) {
        rad_error("%s: read error", path);
        status = RAD_ERR_IO;
        goto done;
    }
    if (rad_hash64(RAD_HASH_SEED, tables, tables_size) != rad_get_u64(h + H_TABLES_CHECKSUM)) {
        rad_error("%s: vertex/patch table checksum mismatch: the file is corrupted", path);
        goto done;
    }
    if (rad_hash64(RAD_HASH_SEED, ff->index, l->index_bytes) != rad_get_u64(h + H_ROW_CHECKSUMS_DIGEST)) {
        rad_error("%s: %s table is corrupted (or the file was not completely written)", path,
                  links ? "links' checksum" : "row-checksum");
        goto done;
    }
    ff->row_offsets = sparse ? ff->index : NULL;
    ff->row_checksums = links ? NULL : sparse ? ff->index + n + 1 : ff->index;
    for (uint64_t i = 0; sparse && i <= n; i++) {
        uint64_t at = ff->row_offsets[i], size = i < n ? ff->row_offsets[i + 1] - at : 0;
        if ((i == 0 && at != 0) || (i == n && at != ff->info.matrix_bytes) ||
            (i < n && (ff->row_offsets[i + 1] < at || size < 8 || size % 8 || size > record_max))) {
            rad_error("%s: row %llu: record offset out of order or out of range", path, (unsigned long long)i);
            goto done;
        }
    }
    if ((status = decode_tables(path, tables, ff)) != RAD_OK) goto done;
    *out_file = ff;
    ff = NULL;
    status = RAD_OK;
done:
    free(tables);
    rad_ff_close(ff);
    return status;
}

void rad_ff_close(rad_ff_file *file)
{
    if (!file) return;
    if (file->f) fclose(file->f);
    rad_mesh_free(&file->mesh);
    free(file->index);
    free(file->tile_buffer);
    free(file->value_buffer);
    free(file->row_buffer);
    free(file);
}

const rad_ff_info *rad_ff_file_info(const rad_ff_file *file) { return &file->info; }
const rad_mesh *rad_ff_file_mesh(const rad_ff_file *file) { return &file->mesh; }

/* RAD_ERR_INVALID, logged: a file of tables only (rad_ff_open_tables) has no rows to read. */
static rad_status refuse_tables(const rad_ff_file *file)
{
    rad_error("internal: %s: the patch table alone, no matrix to read", file->path);
    return RAD_ERR_INVALID;
}

/* RAD_ERR_INVALID, logged, where `file` holds links, not a matrix. */
static rad_status refuse_links(const rad_ff_file *file)
{
    if (file->info.layout != RAD_FF_LAYOUT_LINKS) return RAD_OK;
    rad_error("%s: holds links, not a matrix: hierarchical radiosity's nodes and links (form-factor layout %u, "
              "version %u), read with rad_ff_read_links",
              file->path, RAD_FF_LAYOUT_LINKS,
              file->info.cluster_count ? RAD_FF_VERSION_CLUSTERS : RAD_FF_VERSION_LINKS);
    return RAD_ERR_INVALID;
}

rad_status rad_ff_read_rows(rad_ff_file *file, uint64_t row_begin, uint64_t row_count, double *out)
{
    const rad_ff_layout *l = &file->layout;
    uint64_t n = file->info.patch_count;
    if (refuse_links(file) != RAD_OK) return RAD_ERR_INVALID;
    if (row_begin > n || row_count > n - row_begin) {
        rad_error("%s: rows %llu..%llu out of range (N = %llu)", file->path, (unsigned long long)row_begin,
                  (unsigned long long)(row_begin + row_count), (unsigned long long)n);
        return RAD_ERR_INVALID;
    }
    uint64_t start = file->row_offsets ? file->row_offsets[row_begin] : row_begin * l->row_bytes;
    if (row_count && !file->f) return refuse_tables(file);
    if (row_count && fseeko(file->f, (off_t)(l->matrix_offset + start), SEEK_SET) != 0) {
        rad_error("%s: cannot seek: %s", file->path, strerror(errno));
        return RAD_ERR_IO;
    }
    for (uint64_t r = 0; r < row_count; r++) {
        uint64_t i = row_begin + r;
        uint64_t size = file->row_offsets ? file->row_offsets[i + 1] - file->row_offsets[i] : l->row_bytes;
        if (fread(file->row_buffer, 1, size, file->f) != size) {
            rad_error("%s: row %llu: read error", file->path, (unsigned long long)i);
            return RAD_ERR_IO;
        }
        if (rad_ff_row_checksum(file->row_buffer, size) != file->row_checksums[i]) {
            rad_error("%s: row %llu: checksum mismatch: the matrix is corrupted", file->path,
                      (unsigned long long)i);
            return RAD_ERR_FORMAT;
        }
        double *dst = out + r * n;
        if (file->row_offsets) {
            uint32_t count;
            uint64_t stored;
            const char *why = decode_record(file->row_buffer, size, n, file->info.element_type, file->tile_buffer,
                                            &count, file->value_buffer, &stored);
            if (why) {
                rad_error("%s: row %llu: %s", file->path, (unsigned long long)i, why);
                return RAD_ERR_FORMAT;
            }
            memset(dst, 0, n * sizeof *dst);
            for (uint64_t k = 0, v = 0; k < count; k++) {
                uint64_t j0 = (uint64_t)file->tile_buffer[k] * RAD_FF_TILE_COLUMNS;
                uint64_t width = j0 + RAD_FF_TILE_COLUMNS < n ? RAD_FF_TILE_COLUMNS : n - j0;
                memcpy(dst + j0, file->value_buffer + v, width * sizeof *dst);
                v += width;
            }
        } else if (file->info.element_type == RAD_ELEMENT_F32)
            for (uint64_t j = 0; j < n; j++) dst[j] = ((const float *)file->row_buffer)[j];
        else
            memcpy(dst, file->row_buffer, l->row_bytes);
    }
    return RAD_OK;
}

rad_status rad_ff_read_links(rad_ff_file *file, rad_links *out)
{
    memset(out, 0, sizeof *out);
    if (file->info.layout != RAD_FF_LAYOUT_LINKS) {
        rad_error("%s: holds a matrix, not links (the %s layout; links are the layout of hierarchical radiosity, "
                  "version %u)",
                  file->path, file->info.layout == RAD_FF_LAYOUT_SPARSE ? "sparse" : "dense", RAD_FF_VERSION_LINKS);
        return RAD_ERR_INVALID;
    }
    rad_links links;
    rad_status status = rad_lfile_read(file->f, file->path, &file->info, &file->layout, file->index, &links);
    if (status == RAD_OK) status = rad_links_check(&links, file->mesh.vertex_count, file->path);
    if (status == RAD_OK) status = rad_lfile_check_leaves(&links, &file->mesh, file->path);
    if (status != RAD_OK) {
        rad_links_free(&links);
        return status;
    }
    *out = links;
    return RAD_OK;
}

uint64_t rad_ff_record_offset(const rad_ff_file *file, uint64_t row)
{
    return file->row_offsets && row <= file->info.patch_count ? file->row_offsets[row] : 0;
}

/* `size` bytes at `offset` of the file into `buffer`, in chunks read by
 * several threads at once (pread: no shared file position): a matrix
 * read from the page cache goes several times faster than by one
 * thread's fread. 0, or -1 with errno. */
static int read_parallel(FILE *f, uint64_t offset, unsigned char *buffer, uint64_t size)
{
    const uint64_t chunk = (uint64_t)8 << 20;
    const int fd = fileno(f);
    int64_t chunks = (int64_t)((size + chunk - 1) / chunk), failed = 0;
#pragma omp parallel for schedule(dynamic, 1) reduction(+ : failed) if (chunks > 1)
    for (int64_t k = 0; k < chunks; k++) {
        uint64_t at = (uint64_t)k * chunk, want = size - at < chunk ? size - at : chunk;
        while (want > 0) {
            ssize_t got = pread(fd, buffer + at, (size_t)want, (off_t)(offset + at));
            if (got <= 0) {
                failed++;
                break;
            }
            at += (uint64_t)got;
            want -= (uint64_t)got;
        }
    }
    return failed ? -1 : 0;
}

rad_status rad_ff_read_records(rad_ff_file *file, uint64_t row_begin, uint64_t row_count, unsigned char *buffer)
{
    uint64_t n = file->info.patch_count;
    if (refuse_links(file) != RAD_OK) return RAD_ERR_INVALID;
    if (!file->row_offsets || row_begin > n || row_count > n - row_begin) {
        rad_error("%s: rows %llu..%llu: out of range or not a sparse file", file->path,
                  (unsigned long long)row_begin, (unsigned long long)(row_begin + row_count));
        return RAD_ERR_INVALID;
    }
    uint64_t at = file->row_offsets[row_begin], size = file->row_offsets[row_begin + row_count] - at;
    if (size && !file->f) return refuse_tables(file);
    if (size && read_parallel(file->f, file->layout.matrix_offset + at, buffer, size) != 0) {
        rad_error("%s: rows %llu..%llu: read error", file->path, (unsigned long long)row_begin,
                  (unsigned long long)(row_begin + row_count));
        return RAD_ERR_IO;
    }
    return RAD_OK;
}

rad_status rad_ff_record_counts(const rad_ff_file *file, uint64_t row, const unsigned char *record,
                                uint32_t *out_tiles, uint64_t *out_values)
{
    uint64_t size = file->row_offsets[row + 1] - file->row_offsets[row];
    if (rad_ff_row_checksum(record, size) != file->row_checksums[row]) {
        rad_error("%s: row %llu: checksum mismatch: the matrix is corrupted", file->path, (unsigned long long)row);
        return RAD_ERR_FORMAT;
    }
    const char *why = rad_ff_record_sizes(record, size, file->info.patch_count, out_tiles, out_values);
    if (why) {
        rad_error("%s: row %llu: %s", file->path, (unsigned long long)row, why);
        return RAD_ERR_FORMAT;
    }
    return RAD_OK;
}
