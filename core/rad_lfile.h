/* rad_lfile.h - the link sections of a form-factor file in the links
 * layout (RAD_FF_LAYOUT_LINKS, version 4; with clusters, version 5;
 * docs/formats.md, "The links layout"). After the header and the vertex,
 * patch and group tables that every form-factor file has (rad_ffile.c),
 * each section 64-byte aligned:
 *
 *   node table    node_count x 48-byte rad_link_node records, at the
 *                 header's matrix offset
 *   cluster table (version 5 only) cluster_count x 32-byte
 *                 rad_link_cluster records
 *   cluster roots (version 5 only) root_count x u32, the roots in
 *                 cluster order
 *   first_link    (ids + 1) x u64, ids = node_count + cluster_count: id
 *                 r's links are links[first_link[r] .. first_link[r + 1])
 *   links         link_count x 16-byte rad_link records
 *   checksums     rad_lfile_checksum_count(cluster_count, link_count) x
 *                 u64, at the header's row-checksum offset: rad_hash64 of
 *                 each section above but the links, in file order, then
 *                 of each block of RAD_LFILE_BLOCK_LINKS links; each with
 *                 the zero padding that follows it up to the next
 *                 section, as one run of bytes, so that every byte of the
 *                 file is covered by a checksum (the header's digest
 *                 covers this table).
 *
 * rad_ffile.c places the sections (rad_ff_layout_of), writes and checks
 * the header and reads with these (rad_ff_read_links); rad_lfile.c writes
 * whole files (rad_ff_write_links) through rad_ffile.h's prologue and
 * header functions. Those two, in rad_ffile.h, are the API; these are
 * their parts.
 */
#ifndef RAD_LFILE_H
#define RAD_LFILE_H

#include <stdint.h>
#include <stdio.h>

#include "rad_ffile.h"
#include "rad_links.h"
#include "rad_mesh.h"
#include "rad_status.h"

#define RAD_LFILE_NODE_BYTES 48u
#define RAD_LFILE_CLUSTER_BYTES 32u
#define RAD_LFILE_LINK_BYTES 16u
/* Links per checksum (1 MiB): a reader verifies the links block by block
 * as it reads them. */
#define RAD_LFILE_BLOCK_LINKS 65536u
/* Largest link count a reader believes in (1 EiB of links), which keeps
 * the layout's arithmetic far from 64-bit overflow. */
#define RAD_LFILE_MAX_LINKS (UINT64_C(1) << 56)

/* Entries of the checksum table: node table, (with clusters) cluster
 * table and cluster roots, first_link, link blocks. */
uint64_t rad_lfile_checksum_count(uint32_t cluster_count, uint64_t link_count);

/* Why the header's link counts (info: node_count, root_count,
 * cluster_count, link_count, link_tol, error_bound against patch_count,
 * the leaves) cannot be a tree of quadtrees over the leaves with a
 * cluster tree above its roots; NULL if they can. Checked before the
 * layout is computed from them. */
const char *rad_lfile_counts_fault(const rad_ff_info *info);

/* Writes the node table, (with clusters) cluster table and cluster
 * roots, first_link table and links at the layout's offsets of `f` with
 * zero padding, and their checksums into checksums[]
 * (rad_lfile_checksum_count entries). RAD_ERR_IO, logged
 * with `what` (the file being written). */
rad_status rad_lfile_write(FILE *f, const char *what, const rad_ff_layout *layout, const rad_links *links,
                           uint64_t *checksums);

/* Reads the link sections of a file opened and checked by rad_ff_open
 * (info and layout from its header, checksums its verified checksum
 * table) into *out (rad_links_free frees it), verifying every section's
 * and block's checksum before the next. Counts, link_tol and error_bound
 * come from info. No structural check (rad_links_check does that).
 * RAD_ERR_FORMAT for a checksum mismatch, RAD_ERR_IO for a short read,
 * RAD_ERR_NOMEM; logged naming `path` and the section. On failure *out
 * is zeroed. */
rad_status rad_lfile_read(FILE *f, const char *path, const rad_ff_info *info, const rad_ff_layout *layout,
                          const uint64_t *checksums, rad_links *out);

/* The links against the leaves mesh they were written with: one leaf per
 * patch (leaf_count = patch_count), each leaf's corners the patch's, and
 * every leaf under a root with the same rho and E (solve takes a split
 * node's materials from its root). RAD_ERR_FORMAT naming `what` and the
 * first bad node. Run after rad_links_check. */
rad_status rad_lfile_check_leaves(const rad_links *links, const rad_mesh *leaves, const char *what);

#endif
