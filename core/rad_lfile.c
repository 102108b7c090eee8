/* rad_lfile.c - the link sections of a form-factor file in the links
 * layout: writing them with their checksums, reading and verifying them
 * (rad_lfile.h); and rad_ff_write_links, which writes a whole links file
 * through rad_ffile.h's prologue and header functions. */
#define _FILE_OFFSET_BITS 64
#define _POSIX_C_SOURCE 200809L
#include "rad_lfile.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "rad_bytes.h"
#include "rad_fs.h"
#include "rad_hash.h"
#include "rad_log.h"

_Static_assert(sizeof(rad_link_node) == RAD_LFILE_NODE_BYTES, "a node record is 48 bytes");
_Static_assert(sizeof(rad_link) == RAD_LFILE_LINK_BYTES, "a link record is 16 bytes");
_Static_assert(sizeof(rad_link_cluster) == RAD_LFILE_CLUSTER_BYTES, "a cluster record is 32 bytes");
_Static_assert((uint64_t)RAD_LFILE_BLOCK_LINKS * RAD_LFILE_LINK_BYTES % RAD_FF_ALIGN == 0,
               "a full block of links ends on a section boundary");

/* Checksum table entries before the link blocks': node table and
 * first_link, and with clusters the cluster table and cluster roots. */
static uint64_t sections_before_blocks(uint32_t cluster_count) { return cluster_count ? 4 : 2; }

uint64_t rad_lfile_checksum_count(uint32_t cluster_count, uint64_t link_count)
{
    return sections_before_blocks(cluster_count) + (link_count + RAD_LFILE_BLOCK_LINKS - 1) / RAD_LFILE_BLOCK_LINKS;
}

const char *rad_lfile_counts_fault(const rad_ff_info *info)
{
    uint64_t nodes = info->node_count, roots = info->root_count;
    if (roots == 0 || roots > nodes || nodes >= RAD_NO_ELEMENT) return "node or root count out of range";
    /* every split adds 4 nodes, of which 3 more leaves than before */
    if ((nodes - roots) % 4 != 0 || info->patch_count != roots + (nodes - roots) / 4 * 3)
        return "node, root and leaf counts do not make trees of quadtrees";
    /* a cluster tree over R roots: at most R leaf clusters, each inner one
     * with 2 children or more, so at most 2 R - 1 clusters */
    if ((uint64_t)info->cluster_count >= 2 * roots) return "more clusters than a cluster tree over the roots has";
    if (nodes + info->cluster_count >= RAD_NO_ELEMENT) return "more nodes and clusters than link ids";
    if (info->link_count > RAD_LFILE_MAX_LINKS) return "link count beyond the format's limit";
    if (!(isfinite(info->link_tol) && info->link_tol >= 0)) return "link tolerance not finite and >= 0";
    if (!(isfinite(info->error_bound) && info->error_bound >= 0)) return "error bound not finite and >= 0";
    return NULL;
}

/* The bytes of one section or block: `size` from `data`, then zeros up to
 * `end` (the next section's offset). */
typedef struct section {
    const char *what;
    uint64_t offset, size, end;
    void *data;
} section;

static const unsigned char zero_padding[RAD_FF_ALIGN];

/* Section k in file order: node table, (with clusters) cluster table
 * and cluster roots, first_link, then the link blocks; its data pointer
 * into `links`. Returns how many there are (rad_lfile_checksum_count). */
static uint64_t section_at(const rad_ff_layout *l, const rad_links *links, uint64_t k, section *out)
{
    uint64_t n = links->node_count, count = links->link_count, ids = rad_links_id_count(links);
    uint32_t clusters = links->cluster_count;
    uint64_t before = sections_before_blocks(clusters);
    if (k + 1 < before) {
        /* the sections before first_link */
        const section fixed[] = {
            {"node table", l->matrix_offset, n * RAD_LFILE_NODE_BYTES,
             clusters ? l->cluster_offset : l->first_link_offset, links->nodes},
            {"cluster table", l->cluster_offset, (uint64_t)clusters * RAD_LFILE_CLUSTER_BYTES, l->cluster_root_offset,
             links->clusters},
            {"cluster roots", l->cluster_root_offset, (uint64_t)links->root_count * 4, l->first_link_offset,
             links->cluster_roots},
        };
        *out = fixed[k];
    } else if (k + 1 == before) {
        *out = (section){"first_link table", l->first_link_offset, (ids + 1) * 8, l->link_offset, links->first_link};
    } else {
        uint64_t b = k - before, first = b * RAD_LFILE_BLOCK_LINKS;
        uint64_t last = count - first < RAD_LFILE_BLOCK_LINKS ? count : first + RAD_LFILE_BLOCK_LINKS;
        uint64_t offset = l->link_offset + first * RAD_LFILE_LINK_BYTES;
        *out = (section){"links", offset, (last - first) * RAD_LFILE_LINK_BYTES,
                         last == count ? l->row_checksum_offset : l->link_offset + last * RAD_LFILE_LINK_BYTES,
                         links->links + first};
    }
    return rad_lfile_checksum_count(clusters, count);
}

/* rad_hash64 of a section's data followed by its padding (`pad`, zeros
 * where written), as one run of bytes: the data's whole 8-byte words,
 * then its tail (the cluster roots' last u32 where root_count is odd)
 * with the padding. */
static uint64_t section_checksum(const section *s, const unsigned char *pad)
{
    size_t whole = (size_t)(s->size / 8 * 8), tail = (size_t)(s->size - whole);
    size_t pad_size = (size_t)(s->end - s->offset - s->size);
    unsigned char rest[8 + RAD_FF_ALIGN];
    if (tail) memcpy(rest, (const unsigned char *)s->data + whole, tail);
    if (pad_size) memcpy(rest + tail, pad, pad_size);
    return rad_hash64(rad_hash64(RAD_HASH_SEED, s->data, whole), rest, tail + pad_size);
}

rad_status rad_lfile_write(FILE *f, const char *what, const rad_ff_layout *layout, const rad_links *links,
                           uint64_t *checksums)
{
    section s;
    uint64_t count = section_at(layout, links, 0, &s);
    for (uint64_t k = 0; k < count; k++) {
        section_at(layout, links, k, &s);
        size_t pad = (size_t)(s.end - s.offset - s.size);
        if (fseeko(f, (off_t)s.offset, SEEK_SET) != 0 || fwrite(s.data, 1, (size_t)s.size, f) != s.size ||
            fwrite(zero_padding, 1, pad, f) != pad) {
            rad_error("%s: write failed (%s): %s", what, s.what, strerror(errno));
            return RAD_ERR_IO;
        }
        checksums[k] = section_checksum(&s, zero_padding);
    }
    return RAD_OK;
}

rad_status rad_lfile_read(FILE *f, const char *path, const rad_ff_info *info, const rad_ff_layout *layout,
                          const uint64_t *checksums, rad_links *out)
{
    rad_status status = RAD_OK;
    rad_links links = {.node_count = info->node_count, .root_count = info->root_count,
                       .leaf_count = (uint32_t)info->patch_count, .cluster_count = info->cluster_count,
                       .link_count = info->link_count, .link_tol = info->link_tol,
                       .error_bound = info->error_bound};
    memset(out, 0, sizeof *out);
    /* the file's size matched these counts at rad_ff_open: no allocation
     * here is larger than the file */
    int clusters = links.cluster_count > 0;
    links.nodes = malloc((size_t)links.node_count * sizeof *links.nodes + 1);
    if (clusters) {
        links.clusters = malloc((size_t)links.cluster_count * sizeof *links.clusters);
        links.cluster_roots = malloc((size_t)links.root_count * sizeof *links.cluster_roots);
    }
    links.first_link = malloc(((size_t)rad_links_id_count(&links) + 1) * sizeof *links.first_link);
    links.links = malloc((size_t)links.link_count * sizeof *links.links + 1);
    if (!links.nodes || !links.first_link || !links.links || (clusters && (!links.clusters || !links.cluster_roots))) {
        rad_error("%s: out of memory for %u nodes, %u clusters and %llu links", path, links.node_count,
                  links.cluster_count, (unsigned long long)links.link_count);
        status = RAD_ERR_NOMEM;
        goto done;
    }
    section s;
    uint64_t count = section_at(layout, &links, 0, &s), blocks_at = sections_before_blocks(links.cluster_count);
    for (uint64_t k = 0; k < count; k++) {
        section_at(layout, &links, k, &s);
        unsigned char pad[RAD_FF_ALIGN];
        size_t pad_size = (size_t)(s.end - s.offset - s.size);
        if (fseeko(f, (off_t)s.offset, SEEK_SET) != 0 || fread(s.data, 1, (size_t)s.size, f) != s.size ||
            fread(pad, 1, pad_size, f) != pad_size) {
            rad_error("%s: %s: read error (the file changed or shrank?)", path, s.what);
            status = RAD_ERR_IO;
            goto done;
        }
        if (section_checksum(&s, pad) != checksums[k]) {
            if (k >= blocks_at)
                rad_error("%s: links %llu..%llu: checksum mismatch: the file is corrupted", path,
                          (unsigned long long)((k - blocks_at) * RAD_LFILE_BLOCK_LINKS),
                          (unsigned long long)((k - blocks_at) * RAD_LFILE_BLOCK_LINKS +
                                               s.size / RAD_LFILE_LINK_BYTES - 1));
            else
                rad_error("%s: %s: checksum mismatch: the file is corrupted", path, s.what);
            status = RAD_ERR_FORMAT;
            goto done;
        }
    }
    *out = links;
    memset(&links, 0, sizeof links);
done:
    rad_links_free(&links);
    return status;
}

rad_status rad_lfile_check_leaves(const rad_links *links, const rad_mesh *leaves, const char *what)
{
    if (links->leaf_count != leaves->patch_count) {
        rad_error("%s: %u leaves for %zu patches", what, links->leaf_count, leaves->patch_count);
        return RAD_ERR_FORMAT;
    }
    /* each root's first leaf, whose rho and E its other leaves must have */
    uint32_t *first_leaf = malloc((size_t)links->root_count * sizeof *first_leaf);
    if (!first_leaf) {
        rad_error("%s: out of memory for %u roots", what, links->root_count);
        return RAD_ERR_NOMEM;
    }
    for (uint32_t r = 0; r < links->root_count; r++) first_leaf[r] = RAD_NO_ELEMENT;
    rad_status status = RAD_OK;
    for (uint32_t k = 0; k < links->node_count && status == RAD_OK; k++) {
        const rad_link_node *node = &links->nodes[k];
        if (node->first_child != RAD_NO_ELEMENT) continue;
        const rad_patch *p = &leaves->patches[node->leaf];
        const char *why = NULL;
        if (p->vertex_count != node->vertex_count || memcmp(p->v, node->v, sizeof p->v) != 0) {
            why = "corners differ from its patch's";
        } else if (first_leaf[node->root] == RAD_NO_ELEMENT) {
            first_leaf[node->root] = node->leaf;
        } else {
            const rad_patch *q = &leaves->patches[first_leaf[node->root]];
            if (memcmp(p->rho, q->rho, sizeof p->rho) != 0 || memcmp(p->emission, q->emission, sizeof p->emission) != 0)
                why = "its patch's rho or E differs from other leaves' of its root";
        }
        if (why) {
            rad_error("%s: node %u (leaf, patch %u): %s", what, k, node->leaf, why);
            status = RAD_ERR_FORMAT;
        }
    }
    free(first_leaf);
    return status;
}

/* ---- the whole file (rad_ffile.h) ---- */

/* The info a links file's header gets: the caller's, with the counts and
 * settings of `links`. RAD_ERR_INVALID (logged) for links that a reader
 * would refuse, or that do not belong to `leaves`. */
rad_status rad_ff_links_info(const char *path, const rad_ff_info *info_in, const rad_mesh *leaves,
                             const rad_links *links, rad_ff_info *out)
{
    rad_ff_info info = *info_in;
    if (info.layout != RAD_FF_LAYOUT_LINKS) {
        rad_error("internal: %s: rad_ff_write_links needs info->layout = RAD_FF_LAYOUT_LINKS, not %u", path,
                  info.layout);
        return RAD_ERR_INVALID;
    }
    info.element_type = RAD_ELEMENT_F64;
    info.node_count = links->node_count;
    info.root_count = links->root_count;
    info.cluster_count = links->cluster_count;
    info.link_count = links->link_count;
    info.link_tol = links->link_tol;
    info.error_bound = links->error_bound;
    rad_status status = rad_links_check(links, leaves->vertex_count, path);
    if (status == RAD_OK) status = rad_lfile_check_leaves(links, leaves, path);
    const char *why = status == RAD_OK ? rad_lfile_counts_fault(&info) : NULL;
    if (why) rad_error("%s: %s", path, why);
    if (status == RAD_ERR_NOMEM) return status;
    if (status != RAD_OK || why) {
        rad_error("internal: %s: the links above are not valid; nothing written", path);
        return RAD_ERR_INVALID;
    }
    rad_ff_layout l = rad_ff_layout_of(&info);
    info.matrix_bytes = l.link_offset + info.link_count * RAD_LFILE_LINK_BYTES - l.matrix_offset;
    *out = info;
    return RAD_OK;
}

rad_status rad_ff_write_links(const char *path, const rad_ff_info *info_in, const rad_mesh *leaves,
                              const rad_links *links)
{
    rad_status status;
    unsigned char *prologue = NULL;
    uint64_t *checksums = NULL;
    size_t prologue_size = 0;
    FILE *f = NULL;
    char temp[4096];
    rad_ff_info info;
    if ((status = rad_ff_links_info(path, info_in, leaves, links, &info)) != RAD_OK) return status;
    if ((status = rad_ff_prologue_encode(&info, leaves, &prologue, &prologue_size)) != RAD_OK) return status;
    if ((status = rad_fs_temp_create(path, temp, sizeof temp)) != RAD_OK) {
        free(prologue);
        return status;
    }
    rad_ff_layout l = rad_ff_layout_of(&info);
    checksums = malloc(l.index_bytes);
    if (!checksums) {
        rad_error("%s: out of memory", path);
        status = RAD_ERR_NOMEM;
        goto done;
    }
    f = rad_fs_temp_open(temp);
    if (!f) {
        rad_error("%s: cannot open: %s", temp, strerror(errno));
        status = RAD_ERR_IO;
        goto done;
    }
    if ((status = rad_lfile_write(f, temp, &l, links, checksums)) != RAD_OK) goto done;
    rad_ff_header_finish(prologue, &info, checksums);
    int ok = fseeko(f, (off_t)l.row_checksum_offset, SEEK_SET) == 0 &&
             fwrite(checksums, 1, (size_t)l.index_bytes, f) == l.index_bytes;
    ok = ok && fseeko(f, 0, SEEK_SET) == 0 && fwrite(prologue, 1, prologue_size, f) == prologue_size;
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
    free(checksums);
    return status;
}
