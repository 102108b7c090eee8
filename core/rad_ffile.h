/* rad_ffile.h - the form-factor file ("RADFF"), see docs/formats.md.
 *
 * Layout (little-endian, every section 64-byte aligned):
 *   header        256 bytes (rad_ff_header below)
 *   vertex table  vertex_count * 3 float64 (x, y, z)
 *   patch table   patch_count * 128-byte rad_patch records
 *   group table   (version 2, when group_count > 0) group_count * 64-byte
 *                 names, then patch_count * uint32: each patch's group
 *   matrix        dense (versions 1, 2): patch_count^2 elements (float32
 *                 or float64), row-major, F_ij at i * N + j;
 *                 sparse (version 3, --format sparse): one record per row,
 *                 holding only the row's non-zero tiles of
 *                 RAD_FF_TILE_COLUMNS columns (rad_ff_row_encode)
 *   row checksums dense: patch_count * uint64, rad_hash64 of each matrix
 *                 row's bytes; sparse: the row index, patch_count + 1
 *                 uint64 record offsets (from the matrix offset), then
 *                 patch_count uint64 checksums of the row records
 * The links layout (version 4, hierarchical radiosity, rad_links.h) has,
 * instead of the matrix and its row checksums, the node table, the
 * first_link table, the links and their checksum table (rad_lfile.h);
 * its patch table is the leaves mesh. With clusters (version 5) the
 * cluster table and the cluster roots lie between the nodes and first_link.
 * The header carries a checksum of itself, of the vertex + patch tables and
 * of the row-checksum table, so a reader detects truncation, corruption and
 * foreign files before trusting any number.
 *
 * Writing is split so that MPI ranks can write their row blocks in
 * parallel: rad_ff_layout() gives every offset, rad_ff_prologue_encode()
 * the bytes of header + tables, rad_ff_row_checksum() each row's checksum,
 * rad_ff_header_finish() the final header once all row checksums are known.
 * Reading (rad_ff_open/read_rows/read_links/close) uses stdio and
 * validates as it goes.
 *
 * `--format paper` files (int32 N, then N*N float64) are written by
 * formfactor only; rad_ff_open recognises and refuses them with a message.
 */
#ifndef RAD_FFILE_H
#define RAD_FFILE_H

#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

#include "rad_estimator.h"
#include "rad_links.h"
#include "rad_mesh.h"
#include "rad_status.h"

#define RAD_FF_MAGIC "RADFF\r\n\x1a" /* 8 bytes; catches text-mode mangling */
/* Version 2 added the group table; readers take 1 to 5 (a version-1 file
 * reads as one without groups: rad_mesh.group_count 0). Version 3 added
 * the sparse layout; dense files are still written as version 2, which
 * they are byte for byte, so that version-2 readers keep reading them. */
#define RAD_FF_VERSION 5u /* the newest version readers take */
#define RAD_FF_VERSION_DENSE 2u
#define RAD_FF_VERSION_SPARSE 3u
/* Version 4 added the links layout; links files are version 4, dense and
 * sparse files stay versions 2 and 3, byte for byte. */
#define RAD_FF_VERSION_LINKS 4u
/* Version 5 added clusters to the links layout (issue 27): a links file
 * with clusters is version 5, one without stays version 4, byte for byte. */
#define RAD_FF_VERSION_CLUSTERS 5u
#define RAD_FF_VERSION_OLDEST 1u
/* Columns per tile of a sparse row record. */
#define RAD_FF_TILE_COLUMNS 64u
#define RAD_FF_HEADER_BYTES 256u
#define RAD_FF_ALIGN 64u

typedef enum rad_ff_layout_kind {
    RAD_FF_LAYOUT_DENSE = 0,  /* every entry stored (versions 1-3) */
    RAD_FF_LAYOUT_SPARSE = 1, /* row records of non-zero tiles (version 3) */
    RAD_FF_LAYOUT_LINKS = 2   /* hierarchical radiosity's nodes and links, no
                                 matrix (version 4; with clusters, 5):
                                 rad_ff_write_links, rad_ff_read_links */
} rad_ff_layout_kind;

typedef enum rad_element_type {
    RAD_ELEMENT_F32 = 1,
    RAD_ELEMENT_F64 = 2
} rad_element_type;


/* What the matrix was computed with; recorded in the header. */
typedef struct rad_ff_info {
    uint64_t patch_count;
    uint64_t vertex_count;
    uint32_t element_type;     /* rad_element_type */
    uint32_t estimator;        /* rad_estimator_id */
    uint32_t samples;          /* point pairs per patch pair */
    uint32_t shadow_rays;      /* of those, pairs that carry a shadow ray */
    uint64_t seed;
    uint64_t scene_fingerprint;
    int32_t subdiv;
    uint32_t flags;            /* RAD_FF_FLAG_* */
    char scene_name[96];       /* NUL-terminated, informational */
    uint32_t group_count;      /* G, entries of the group table: the mesh's group_count
                                  (0: no table; always 0 in version-1 files) */
    uint32_t layout;           /* rad_ff_layout_kind (dense in versions 1 and 2) */
    uint64_t matrix_bytes;     /* sparse: bytes of all row records (known once
                                  written); links: bytes from the node table's
                                  start to the last link's end; dense: ignored, 0 */
    /* The links layout: the rad_links' counts and settings (rad_links.h),
     * set by rad_ff_write_links from the links it writes and by the reader
     * from the header; 0 in the other layouts. leaf_count is patch_count. */
    uint32_t node_count, root_count;
    uint64_t link_count;
    double link_tol, error_bound;
    uint32_t cluster_count; /* 0: no clusters (version 4); else version 5 */
} rad_ff_info;

#define RAD_FF_FLAG_PARTIAL_SUBDIV 1u /* only one group was subdivided */
#define RAD_FF_FLAG_STANDARD_ERRORS 2u /* the matrix holds standard errors of F (--errors), not F */
/* F_ij = c_ij A_j with c_ij = c_ji to the bit (rad_ff_kernel.h): the matrix
 * is reciprocal but for the rounding of the two products and of the stored
 * element type. formfactor sets it; solve then bounds the CG check's skew
 * term by that rounding instead of measuring it (docs/solve.md). */
#define RAD_FF_FLAG_RECIPROCAL 4u
/* The scene's `Ke` was read as emitted radiance L_e, so the patch table's
 * E is pi Ke (formfactor --ke radiance, rad_scene_options.ke_radiance);
 * clear: E is Ke. solve carries it into the radiosity file
 * (RAD_RF_FLAG_KE_RADIANCE), render into the image's metadata. */
#define RAD_FF_FLAG_KE_RADIANCE 8u
/* The links layout: formfactor --closure on found the scene closed
 * (every face's hemisphere meets other faces' fronts only), so every
 * leaf's row sums to 1 and solve balances the links' rows to 1
 * (rad_closure.h; solve --closure). */
#define RAD_FF_FLAG_CLOSED 16u

/* Byte offsets of each section, derived from N, V, G and the element type
 * (links: node_count, root_count, cluster_count and link_count). */
typedef struct rad_ff_layout {
    uint64_t vertex_offset, patch_offset, matrix_offset, row_checksum_offset, file_bytes;
    uint64_t group_offset;       /* group names (G * 64 bytes); 0 when G = 0 */
    uint64_t patch_group_offset; /* N * uint32 after them; 0 when G = 0 */
    uint64_t element_bytes; /* 4 or 8 */
    uint64_t row_bytes;     /* N * element_bytes (dense rows; decoded sparse rows) */
    uint64_t index_bytes;   /* at row_checksum_offset: dense N * 8, sparse (2N + 1) * 8,
                               links the checksum table's bytes */
    /* Links layout: the node table is at matrix_offset, these follow it
     * (64-byte aligned); 0 in the other layouts. */
    uint64_t first_link_offset, link_offset;
    uint64_t cluster_offset, cluster_root_offset; /* before first_link; 0 without clusters */
} rad_ff_layout;

rad_ff_layout rad_ff_layout_of(const rad_ff_info *info);

/* Header + vertex table + patch table + group table as one buffer of
 * layout.matrix_offset bytes (padding zeroed), to be written at offset 0.
 * info->group_count must equal mesh->group_count.
 * The header's row-checksum digest is left 0 until rad_ff_header_finish.
 * *out_bytes is freed with free(). */
rad_status rad_ff_prologue_encode(const rad_ff_info *info, const rad_mesh *mesh, unsigned char **out_bytes,
                                  size_t *out_size);

/* Checksum of one row as stored (dense: element_type bytes; sparse: the record). */
uint64_t rad_ff_row_checksum(const void *row, size_t row_bytes);

/* Sparse layout: the record of one row of n entries, stored as
 * element_type: u32 tile count T, T ascending u32 tile numbers, zero
 * padding to 8 bytes, then each listed tile's entries (columns
 * [64 t, min(64 t + 64, n))), zero padding to 8 bytes. A tile whose
 * stored entries are all zero bits is not listed. Writes the record to
 * `out` (NULL: only counts) and returns its size in bytes. */
size_t rad_ff_row_encode(const double *row, uint64_t n, uint32_t element_type, void *out);
/* The largest record a row of n entries can need. */
size_t rad_ff_row_record_max(uint64_t n, uint32_t element_type);
/* A record of `size` bytes without its file (a matrix handed over in
 * memory: formfactor --radiosity): how many tiles and entries it lists,
 * then (at most that many into tiles[] and values[]) its tile numbers and
 * entries as double. NULL, or what is wrong with it. */
const char *rad_ff_record_sizes(const unsigned char *record, uint64_t size, uint64_t n, uint32_t *out_tiles,
                                uint64_t *out_values);
const char *rad_ff_record_decode(const unsigned char *record, uint64_t size, uint64_t n, uint32_t element_type,
                                 uint32_t *tiles, uint32_t *out_tiles, double *values, uint64_t *out_values);

/* Rewrites the 256-byte header at the start of `prologue` for `info`
 * (sparse: its matrix_bytes, now known) with the digest of the index
 * (layout.index_bytes bytes: dense, the N row checksums; sparse, the N + 1
 * offsets and N checksums) and recomputes the header checksum. */
void rad_ff_header_finish(unsigned char *prologue, const rad_ff_info *info, const void *index);

/* Writes a whole file from one process (tests, tools): `matrix` holds
 * N * N doubles, stored converted to info->element_type in info->layout.
 * Temporary name + rename, as every output. */
rad_status rad_ff_write_serial(const char *path, const rad_ff_info *info, const rad_mesh *mesh,
                               const double *matrix);

/* Writes a file of the links layout from one process: header, the tables
 * of the leaves mesh (the patches solve writes and render draws), then
 * the node table, (with clusters) the cluster table and cluster roots,
 * first_link, the links and their checksums (rad_lfile.h).
 * info->layout must be RAD_FF_LAYOUT_LINKS and its counts match `leaves`
 * (patch_count, vertex_count, group_count); its node_count, root_count,
 * cluster_count, link_count, link_tol and error_bound are taken from
 * `links`, which must pass rad_links_check and match the leaves
 * (RAD_ERR_INVALID, logged, and nothing written, if not). Version 4
 * without clusters, 5 with them. element_type is stored as
 * RAD_ELEMENT_F64 (the factors' type) and the scene name cut at 63 bytes
 * (the link counts take the name field's last 32 bytes; with clusters, at
 * 59: the cluster count takes 4 more). Deterministic bytes, padding
 * zeroed; temporary name + rename, as every output. */
rad_status rad_ff_write_links(const char *path, const rad_ff_info *info, const rad_mesh *leaves,
                              const rad_links *links);
/* The header rad_ff_write_links would write for `links` into *out (the
 * counts, link_tol, error_bound and matrix_bytes filled in), after the
 * same checks (RAD_ERR_INVALID, logged with `what`, for links a reader
 * would refuse): formfactor --radiosity solves links it does not write. */
rad_status rad_ff_links_info(const char *what, const rad_ff_info *info, const rad_mesh *leaves,
                             const rad_links *links, rad_ff_info *out);

/* ---- reading ---- */

typedef struct rad_ff_file rad_ff_file; /* opaque */

/* Opens and validates: magic, version, sizes against the file size, header
 * and table checksums, the row-checksum table's digest, patch records
 * (finite, unit normals, rho in [0,1), E >= 0, vertex indices in range),
 * the group table (names NUL-terminated, not empty, zero-padded; every
 * patch's group in range); in the links layout the link counts (trees of
 * quadtrees over the patches; version 5: 1 to 2 R - 1 clusters over the
 * R roots, ids below RAD_NO_ELEMENT) and the sections' sizes and offsets
 * against the file size, and the digest of the links' checksum table.
 * rad_ff_file_info(file)->layout tells the kinds apart: a links file is
 * read with rad_ff_read_links, the others with rad_ff_read_rows (or
 * rad_ff_read_records); each refuses the other kind with a message.
 * Errors name the file and what is wrong. */
rad_status rad_ff_open(const char *path, rad_ff_file **out_file);
void rad_ff_close(rad_ff_file *file); /* NULL is fine */
/* A form-factor file's header and patch table without its matrix: what a
 * reader of a matrix handed over in memory (formfactor --radiosity: solve's
 * stage on rows that were never written) takes from the file. The patch
 * table is encoded and decoded as a file's is, so readers see the very
 * mesh they would read from the file; reading rows from it is refused.
 * `name` stands for the path in messages. */
rad_status rad_ff_open_tables(const char *name, const rad_ff_info *info, const rad_mesh *mesh,
                              rad_ff_file **out_file);

const rad_ff_info *rad_ff_file_info(const rad_ff_file *file);
/* The patch mesh stored in the file (owned by the file), with its groups
 * (group_count 0 for a file without a group table). */
const rad_mesh *rad_ff_file_mesh(const rad_ff_file *file);

/* Reads rows [row_begin, row_begin + row_count) into `out` (row_count * N
 * doubles, converted from the stored element type; a sparse file's
 * missing tiles as 0), verifying each row's checksum (and a sparse
 * record's structure). Errors name the file and the first bad row.
 * RAD_ERR_INVALID for a links file ("holds links, not a matrix"). */
rad_status rad_ff_read_rows(rad_ff_file *file, uint64_t row_begin, uint64_t row_count, double *out);

/* Links layout: reads the node table, (version 5) the cluster table and
 * cluster roots, first_link and the links into *out
 * (rad_links_free frees it), verifying each section's and each block's
 * checksum, then rad_links_check (the file's vertex count, the file's
 * name) and that every leaf is its patch (corners; the rho and E of its
 * root's other leaves). RAD_ERR_FORMAT (damaged), RAD_ERR_IO, RAD_ERR_NOMEM,
 * logged naming the file and what is wrong; RAD_ERR_INVALID for a matrix
 * file ("holds a matrix, not links"). *out is zeroed on failure. */
rad_status rad_ff_read_links(rad_ff_file *file, rad_links *out);

/* Sparse layout, for readers that decode rows on several threads: the
 * records of rows [row_begin, row_begin + row_count) as stored, in one
 * read, into `buffer` (rad_ff_record_offset(file, row_begin + row_count) -
 * rad_ff_record_offset(file, row_begin) bytes); then each row's record,
 * at buffer + rad_ff_record_offset(file, row) - rad_ff_record_offset(file,
 * row_begin), goes through rad_ff_record_decode, which touches nothing
 * but its outputs (any thread). Its counts come first from
 * rad_ff_record_counts, so that the outputs can be placed. */
uint64_t rad_ff_record_offset(const rad_ff_file *file, uint64_t row);
rad_status rad_ff_read_records(rad_ff_file *file, uint64_t row_begin, uint64_t row_count, unsigned char *buffer);
/* Verifies row `row`'s record (checksum, tile list) and gives how many
 * tiles and entries it stores; RAD_ERR_FORMAT (logged) if it is damaged. */
rad_status rad_ff_record_counts(const rad_ff_file *file, uint64_t row, const unsigned char *record,
                                uint32_t *out_tiles, uint64_t *out_values);

#endif
