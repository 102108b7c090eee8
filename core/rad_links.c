/* rad_links.c - hierarchical radiosity's links in memory: freeing them and
 * the structural checks a reader makes before trusting them (rad_links.h). */
#include "rad_links.h"

#include <math.h>
#include <stddef.h>
#include <stdlib.h>
#include <string.h>

#include "rad_log.h"
#include "rad_polygon.h"

_Static_assert(sizeof(rad_link_node) == 48 && offsetof(rad_link_node, area) == 40,
               "a node is the file's 48-byte record (docs/formats.md)");
_Static_assert(sizeof(rad_link) == 16 && offsetof(rad_link, error) == 4 && offsetof(rad_link, factor) == 8,
               "a link is the file's 16-byte record (docs/formats.md)");

void rad_links_free(rad_links *links)
{
    if (!links) return;
    free(links->nodes);
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

/* What is wrong with node r's links (range, sources, factors, errors);
 * NULL if nothing. *out_bad gets the first bad link's index. */
static const char *links_fault(const rad_links *links, uint32_t r, uint64_t *out_bad)
{
    uint64_t begin = links->first_link[r], end = links->first_link[r + 1];
    *out_bad = begin;
    if (end < begin || end > links->link_count) return "first_link decreases here or passes the link count";
    for (uint64_t i = begin; i < end; i++) {
        const rad_link *link = &links->links[i];
        *out_bad = i;
        if (link->source >= links->node_count) return "source beyond the node table";
        if (i > begin && link->source <= links->links[i - 1].source) return "sources not strictly ascending";
        if (!(isfinite(link->factor) && link->factor >= 0)) return "factor not finite and >= 0";
        if (!(isfinite(link->error) && link->error >= 0)) return "error not finite and >= 0";
    }
    return NULL;
}

rad_status rad_links_check(const rad_links *links, size_t vertex_count, const char *what)
{
    if (links->root_count == 0 || links->root_count > links->node_count || links->node_count == RAD_NO_ELEMENT ||
        links->leaf_count == 0 || links->leaf_count > links->node_count) {
        rad_error("%s: %u roots, %u leaves among %u nodes: implausible", what, links->root_count, links->leaf_count,
                  links->node_count);
        return RAD_ERR_FORMAT;
    }
    if (!links->nodes || !links->first_link || (links->link_count && !links->links)) {
        rad_error("%s: links without their tables", what);
        return RAD_ERR_FORMAT;
    }
    if (links->first_link[0] != 0 || links->first_link[links->node_count] != links->link_count) {
        rad_error("%s: first_link runs from %llu to %llu, not from 0 to the link count %llu", what,
                  (unsigned long long)links->first_link[0], (unsigned long long)links->first_link[links->node_count],
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
    for (uint32_t k = 0; k < links->node_count; k++) {
        const char *why = node_fault(links, k, vertex_count, leaf_seen);
        if (why) {
            rad_error("%s: node %u: %s", what, k, why);
            goto done;
        }
        leaves += links->nodes[k].first_child == RAD_NO_ELEMENT;
        uint64_t bad;
        why = links_fault(links, k, &bad);
        if (why) {
            rad_error("%s: node %u: link %llu: %s", what, k, (unsigned long long)bad, why);
            goto done;
        }
    }
    if (leaves != links->leaf_count) {
        rad_error("%s: %llu leaves, the leaves mesh has %u patches", what, (unsigned long long)leaves,
                  links->leaf_count);
        goto done;
    }
    status = RAD_OK;
done:
    free(leaf_seen);
    return status;
}
