/* rad_links.c - hierarchical radiosity's links in memory: freeing them and
 * the structural checks a reader makes before trusting them (rad_links.h). */
#include "rad_links.h"

#include <math.h>
#include <stddef.h>
#include <stdlib.h>
#include <string.h>
#ifdef _OPENMP
#include <omp.h>
#endif

#include "rad_log.h"
#include "rad_polygon.h"

_Static_assert(sizeof(rad_link_node) == 48 && offsetof(rad_link_node, area) == 40,
               "a node is the file's 48-byte record (docs/formats.md)");
_Static_assert(sizeof(rad_link_cluster) == 32 && offsetof(rad_link_cluster, area) == 24,
               "a cluster is the file's 32-byte record (docs/formats.md)");
_Static_assert(sizeof(rad_link) == 16 && offsetof(rad_link, error) == 4 && offsetof(rad_link, factor) == 8,
               "a link is the file's 16-byte record (docs/formats.md)");

void rad_links_free(rad_links *links)
{
    if (!links) return;
    free(links->nodes);
    free(links->clusters);
    free(links->cluster_roots);
    free(links->first_link);
    free(links->links);
    memset(links, 0, sizeof *links);
}

/* What is wrong with node k's own fields and its place in the trees
 * (parent, children, root, level, leaf index, corners, area); NULL if
 * nothing. leaf_seen marks the patches already claimed by a leaf. */
static const char *node_fault(const rad_links *links, uint32_t k, size_t vertex_count, unsigned char *leaf_seen)
{
    const rad_link_node *node = &links->nodes[k];
    const int is_root = k < links->root_count;
    if (is_root) {
        if (node->parent != RAD_NO_ELEMENT) return "a root with a parent";
        if (node->root != k) return "a root whose root is not itself";
        if (node->level != 0) return "a root at a level other than 0";
    } else {
        if (node->parent == RAD_NO_ELEMENT) return "no parent, but not among the roots (roots come first)";
        if (node->parent >= k) return "parent not before its child";
        const rad_link_node *parent = &links->nodes[node->parent];
        if (parent->first_child == RAD_NO_ELEMENT || k < parent->first_child || k - parent->first_child >= 4)
            return "not among its parent's children";
        if (node->root != parent->root) return "another root than its parent's";
        if (node->level != parent->level + 1) return "level is not its parent's + 1";
    }
    if (node->first_child != RAD_NO_ELEMENT) {
        if (node->first_child <= k) return "children not after their parent";
        if ((uint64_t)node->first_child + 4 > links->node_count) return "children beyond the node table";
        for (uint32_t c = 0; c < 4; c++)
            if (links->nodes[node->first_child + c].parent != k) return "a child whose parent is another node";
        if (node->leaf != RAD_NO_ELEMENT) return "a split node that is also a leaf";
    } else {
        if (node->leaf >= links->leaf_count) return "leaf's patch out of range (or a leaf without a patch)";
        if (leaf_seen[node->leaf]) return "leaf's patch already the leaf of another node";
        leaf_seen[node->leaf] = 1;
    }
    if (node->vertex_count != 3 && node->vertex_count != 4) return "vertex count not 3 or 4";
    for (uint32_t c = 0; c < node->vertex_count; c++)
        if (node->v[c] >= vertex_count) return "a corner beyond the vertex table";
    if (node->vertex_count == 3 && node->v[3] != RAD_NO_VERTEX) return "a triangle with a fourth corner";
    if (!(isfinite(node->area) && node->area > 0)) return "area not finite and positive";
    return NULL;
}

/* Relative difference allowed between a cluster's area and the sum of
 * its roots' (summed in another order than the writer's). */
#define CLUSTER_AREA_TOLERANCE 1e-9

/* What is wrong with cluster c's own fields and its place in the cluster
 * tree (parent, children, root range, area); NULL if nothing. Its area
 * against its roots' is checked later (cluster_areas_fault). */
static const char *cluster_fault(const rad_links *links, uint32_t c)
{
    const rad_link_cluster *cluster = &links->clusters[c];
    if (c == 0) {
        if (cluster->parent != RAD_NO_ELEMENT) return "a parent, but cluster 0 is the tree's root";
        if (cluster->root_begin != 0 || cluster->root_end != links->root_count)
            return "not every root, but cluster 0 holds them all (root range 0 .. root count)";
    } else {
        if (cluster->parent == RAD_NO_ELEMENT) return "no parent, but not cluster 0";
        if (cluster->parent >= c) return "parent not before its child";
        const rad_link_cluster *parent = &links->clusters[cluster->parent];
        if (parent->child_count == 0 || c < parent->first_child || c - parent->first_child >= parent->child_count)
            return "not among its parent's children";
    }
    if (cluster->pad != 0) return "pad not zero";
    if (cluster->root_begin >= cluster->root_end || cluster->root_end > links->root_count)
        return "root range empty or beyond the root count";
    if (cluster->child_count == 0) {
        if (cluster->first_child != RAD_NO_ELEMENT) return "a leaf cluster (no children) with a first child";
    } else {
        if (cluster->child_count < 2) return "an inner cluster with one child (at least 2)";
        if (cluster->first_child == RAD_NO_ELEMENT || cluster->first_child <= c)
            return "children not after their parent";
        if ((uint64_t)cluster->first_child + cluster->child_count > links->cluster_count)
            return "children beyond the cluster table";
        uint32_t at = cluster->root_begin; /* where the next child's roots must begin */
        for (uint32_t k = 0; k < cluster->child_count; k++) {
            const rad_link_cluster *child = &links->clusters[cluster->first_child + k];
            if (child->parent != c) return "a child whose parent is another cluster";
            if (child->root_begin != at || child->root_end <= at || child->root_end > cluster->root_end)
                return "its children's root ranges do not partition its own in order";
            at = child->root_end;
        }
        if (at != cluster->root_end) return "its children's root ranges do not partition its own in order";
    }
    if (!(isfinite(cluster->area) && cluster->area > 0)) return "area not finite and positive";
    return NULL;
}

/* Which entry of cluster_roots is not a root, or a root listed before
 * (*out_why says which); UINT32_MAX if they are a permutation of the
 * roots. */
static uint32_t cluster_roots_fault(const rad_links *links, unsigned char *root_seen, const char **out_why)
{
    for (uint32_t i = 0; i < links->root_count; i++) {
        uint32_t root = links->cluster_roots[i];
        *out_why = root >= links->root_count ? "not a root (beyond the root count)" : "a root listed twice";
        if (root >= links->root_count || root_seen[root]) return i;
        root_seen[root] = 1;
    }
    return UINT32_MAX;
}

/* The first cluster whose area is not the sum of its roots' areas
 * (relative CLUSTER_AREA_TOLERANCE); UINT32_MAX if none. Run once the
 * tree and the cluster roots are valid. sum[] (cluster_count) gets the
 * sums, from the leaf clusters up (children come after their parent). */
static uint32_t cluster_areas_fault(const rad_links *links, double *sum)
{
    for (uint32_t c = links->cluster_count; c-- > 0;) {
        const rad_link_cluster *cluster = &links->clusters[c];
        sum[c] = 0;
        if (cluster->child_count == 0)
            for (uint32_t i = cluster->root_begin; i < cluster->root_end; i++)
                sum[c] += links->nodes[links->cluster_roots[i]].area;
        else
            for (uint32_t k = 0; k < cluster->child_count; k++) sum[c] += sum[cluster->first_child + k];
        if (!(fabs(cluster->area - sum[c]) <= CLUSTER_AREA_TOLERANCE * sum[c])) return c;
    }
    return UINT32_MAX;
}

/* What is wrong with id r's links (range, sources, factors, errors);
 * NULL if nothing. *out_bad gets the first bad link's index. */
static const char *links_fault(const rad_links *links, uint32_t r, uint64_t *out_bad)
{
    uint64_t begin = links->first_link[r], end = links->first_link[r + 1];
    *out_bad = begin;
    if (end < begin || end > links->link_count) return "first_link decreases here or passes the link count";
    for (uint64_t i = begin; i < end; i++) {
        const rad_link *link = &links->links[i];
        *out_bad = i;
        if (link->source >= rad_links_id_count(links))
            return links->cluster_count ? "source beyond the node and cluster tables" : "source beyond the node table";
        if (i > begin && link->source <= links->links[i - 1].source) return "sources not strictly ascending";
        if (!(isfinite(link->factor) && link->factor >= 0)) return "factor not finite and >= 0";
        if (!(isfinite(link->error) && link->error >= 0)) return "error not finite and >= 0";
    }
    return NULL;
}

/* Fewer links a block than this are paired in one block: the cursors'
 * set-up (a pass over every source's links per block) would cost more
 * than the threads save. */
#define PAIR_BLOCK_MIN_LINKS 4096

rad_status rad_links_pairing_make(const rad_links *L, int threads, rad_links_pairing *w)
{
    memset(w, 0, sizeof *w);
    const uint64_t ids = rad_links_id_count(L);
#ifdef _OPENMP
    if (threads <= 0) threads = omp_get_max_threads();
#endif
    uint32_t blocks = threads > 1 ? (uint32_t)threads : 1;
    if (blocks > RAD_LINKS_PAIR_BLOCKS) blocks = RAD_LINKS_PAIR_BLOCKS;
    if (L->link_count < (uint64_t)blocks * PAIR_BLOCK_MIN_LINKS) blocks = 1;
    w->blocks = blocks;
    w->ids = ids;
    for (uint32_t b = 1; b < blocks; b++) w->begin[b] = rad_links_receiver_of(L, L->link_count / blocks * b);
    w->begin[0] = 0;
    w->begin[blocks] = (uint32_t)ids;
    w->cursor = malloc((size_t)blocks * (ids ? ids : 1) * sizeof *w->cursor);
    if (!w->cursor) {
        rad_error("links: out of memory for pairing %llu links", (unsigned long long)L->link_count);
        return RAD_ERR_NOMEM;
    }
    /* block b starts in each source's links past those whose source is
     * below its first receiver: one pass over each source's links */
#pragma omp parallel for schedule(dynamic, 1024) num_threads(threads > 0 ? threads : 1)
    for (uint64_t s = 0; s < ids; s++) {
        const uint64_t k0 = L->first_link[s], k1 = L->first_link[s + 1];
        uint64_t k = k0;
        for (uint32_t b = 0; b < blocks; b++) {
            while (k < k1 && L->links[k].source < w->begin[b]) k++;
            w->cursor[(size_t)b * ids + s] = (uint32_t)(k - k0); /* < 2^32: strictly ascending sources */
        }
    }
    return RAD_OK;
}

void rad_links_pairing_free(rad_links_pairing *w)
{
    free(w->cursor);
    memset(w, 0, sizeof *w);
}

/* The first of ids [begin, end) whose links fail links_fault, or end: on
 * the threads (10^6 triangles make 8 * 10^8 links to read), the faults
 * then reported in id order as one thread would find them. */
static uint64_t first_links_fault(const rad_links *links, uint64_t begin, uint64_t end)
{
    uint64_t first = end;
#pragma omp parallel for schedule(dynamic, 1024) reduction(min : first)
    for (uint64_t k = begin; k < end; k++) {
        uint64_t bad;
        if (k < first && links_fault(links, (uint32_t)k, &bad)) first = k;
    }
    return first;
}

rad_status rad_links_check_cluster_tree(const rad_links *links, const char *what)
{
    rad_status status = RAD_ERR_FORMAT;
    unsigned char *root_seen = calloc(links->root_count, 1);
    double *sum = malloc((size_t)links->cluster_count * sizeof *sum);
    if (!root_seen || !sum) {
        rad_error("%s: out of memory checking %u clusters", what, links->cluster_count);
        status = RAD_ERR_NOMEM;
        goto done;
    }
    const char *why;
    uint32_t bad = cluster_roots_fault(links, root_seen, &why);
    if (bad != UINT32_MAX) {
        rad_error("%s: cluster roots: entry %u (%u): %s (each root once, none out of range or twice)", what, bad,
                  links->cluster_roots[bad], why);
        goto done;
    }
    for (uint32_t c = 0; c < links->cluster_count; c++) {
        why = cluster_fault(links, c);
        if (why) {
            rad_error("%s: cluster %u: %s", what, c, why);
            goto done;
        }
    }
    bad = cluster_areas_fault(links, sum);
    if (bad != UINT32_MAX) {
        rad_error("%s: cluster %u: area %.17g is not its roots' %.17g", what, bad, links->clusters[bad].area,
                  sum[bad]);
        goto done;
    }
    status = RAD_OK;
done:
    free(root_seen);
    free(sum);
    return status;
}

/* The clusters (after the nodes): the tree, then each cluster's links. */
static rad_status check_clusters(const rad_links *links, const char *what)
{
    const rad_status status = rad_links_check_cluster_tree(links, what);
    if (status != RAD_OK) return status;
    const uint64_t n = links->node_count, end = n + links->cluster_count, bad = first_links_fault(links, n, end);
    if (bad == end) return RAD_OK;
    uint64_t bad_link;
    const char *why = links_fault(links, (uint32_t)bad, &bad_link);
    rad_error("%s: cluster %llu: link %llu: %s", what, (unsigned long long)(bad - n), (unsigned long long)bad_link, why);
    return RAD_ERR_FORMAT;
}

rad_status rad_links_check(const rad_links *links, size_t vertex_count, const char *what)
{
    uint64_t ids = rad_links_id_count(links);
    if (links->root_count == 0 || links->root_count > links->node_count || links->node_count == RAD_NO_ELEMENT ||
        links->leaf_count == 0 || links->leaf_count > links->node_count) {
        rad_error("%s: %u roots, %u leaves among %u nodes: implausible", what, links->root_count, links->leaf_count,
                  links->node_count);
        return RAD_ERR_FORMAT;
    }
    if ((uint64_t)links->cluster_count >= 2 * (uint64_t)links->root_count || ids >= RAD_NO_ELEMENT) {
        rad_error("%s: %u clusters over %u roots (%u nodes): implausible", what, links->cluster_count,
                  links->root_count, links->node_count);
        return RAD_ERR_FORMAT;
    }
    if (!links->nodes || !links->first_link || (links->link_count && !links->links) ||
        (links->cluster_count && (!links->clusters || !links->cluster_roots))) {
        rad_error("%s: links without their tables", what);
        return RAD_ERR_FORMAT;
    }
    if (links->first_link[0] != 0 || links->first_link[ids] != links->link_count) {
        rad_error("%s: first_link runs from %llu to %llu, not from 0 to the link count %llu", what,
                  (unsigned long long)links->first_link[0], (unsigned long long)links->first_link[ids],
                  (unsigned long long)links->link_count);
        return RAD_ERR_FORMAT;
    }
    unsigned char *leaf_seen = calloc(links->leaf_count, 1);
    if (!leaf_seen) {
        rad_error("%s: out of memory checking %u leaves", what, links->leaf_count);
        return RAD_ERR_NOMEM;
    }
    rad_status status = RAD_ERR_FORMAT;
    uint64_t leaves = 0;
    const uint64_t first_bad = first_links_fault(links, 0, links->node_count);
    for (uint32_t k = 0; k < links->node_count; k++) {
        const char *why = node_fault(links, k, vertex_count, leaf_seen);
        if (why) {
            rad_error("%s: node %u: %s", what, k, why);
            goto done;
        }
        leaves += links->nodes[k].first_child == RAD_NO_ELEMENT;
        uint64_t bad;
        if (k == first_bad) {
            why = links_fault(links, k, &bad);
            rad_error("%s: node %u: link %llu: %s", what, k, (unsigned long long)bad, why);
            goto done;
        }
    }
    if (leaves != links->leaf_count) {
        rad_error("%s: %llu leaves, the leaves mesh has %u patches", what, (unsigned long long)leaves,
                  links->leaf_count);
        goto done;
    }
    status = links->cluster_count ? check_clusters(links, what) : RAD_OK;
done:
    free(leaf_seen);
    return status;
}
