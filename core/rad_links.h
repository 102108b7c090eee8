/* rad_links.h - hierarchical radiosity's links in memory: the element
 * tree over the leaves mesh and the links between its nodes (issue 26;
 * docs/hierarchy.md). formfactor --method hierarchical makes them
 * (formfactor/ff_links.c), the form-factor file stores them (layout
 * RAD_FF_LAYOUT_LINKS, rad_ffile.h), solve solves on them (rad_lsolve.h).
 *
 *     rad_links links;                     // from ff_links, or rad_ff_read_links
 *     node r's links: links.links[links.first_link[r] .. links.first_link[r + 1])
 *     rad_links_free(&links);
 *
 * Nodes. Node 0 .. root_count - 1 are the roots (the patches of the
 * --subdiv 0 mesh, contacts cut), the others their descendants; a split
 * node's 4 children are consecutive and come after it. Leaves are the
 * patches of the leaves mesh (the form-factor file's patch table, what
 * solve writes and render draws): node.leaf is the patch's index, and
 * every patch is the leaf of exactly one node. A node's corners index the
 * leaves mesh's vertex table, which holds every vertex of the hierarchy
 * (also those only split nodes use). Materials are the root's: every leaf
 * under a root has its rho and E.
 *
 * Links. A link stored at receiver r with source s carries
 * F_rs, the form factor from r to s (visibility included), and `error`, a
 * bound on how far the form factor from any leaf under r to s may lie from
 * F_rs (F units). Radiosity gathered at r is pushed to all of r's leaves:
 * B_leaf = E + rho * (sum over the links of the leaf and of its ancestors
 * of F_rs B_s), B_s of a split node being the area-weighted mean of its
 * leaves. Links come in pairs: (r <- s) and (s <- r), with
 * A_r F_rs = A_s F_sr to rounding (one symmetric coupling c_rs: F_rs =
 * c_rs A_s). A node's links are sorted by source, so the bytes do not
 * depend on ranks, threads or backends.
 */
#ifndef RAD_LINKS_H
#define RAD_LINKS_H

#include <stddef.h>
#include <stdint.h>

#include "rad_status.h"

#ifndef RAD_NO_ELEMENT
#define RAD_NO_ELEMENT UINT32_MAX
#endif

/* One node as the file stores it (48 bytes). */
typedef struct rad_link_node {
    uint32_t parent;       /* RAD_NO_ELEMENT for a root */
    uint32_t first_child;  /* children first_child .. + 3; RAD_NO_ELEMENT for a leaf */
    uint32_t leaf;         /* a leaf's patch in the leaves mesh; RAD_NO_ELEMENT for a split node */
    uint32_t root;         /* the root of its tree (itself for a root) */
    uint32_t level;        /* 0 for a root */
    uint32_t vertex_count; /* 3 or 4 */
    uint32_t v[4];         /* corners in the leaves mesh's vertex table; v[3] = RAD_NO_VERTEX for triangles */
    double area;
} rad_link_node;

/* One cluster as the file stores it (32 bytes): clustering (issue 27,
 * docs/hierarchy.md "Clusters"). Clusters form one tree above the roots:
 * cluster 0 holds every root, a cluster's parent comes before it, an inner
 * cluster's children are the consecutive clusters first_child ..
 * first_child + child_count - 1 (>= 2 of them), and a leaf cluster
 * (child_count 0, first_child RAD_NO_ELEMENT) has as its children the roots
 * cluster_roots[root_begin .. root_end). Every cluster, inner ones too,
 * holds the roots cluster_roots[root_begin .. root_end), its children's
 * ranges partitioning its own in child order, so that the leaf clusters'
 * ranges partition 0 .. root_count. area is the sum of its roots' areas. */
typedef struct rad_link_cluster {
    uint32_t parent;      /* RAD_NO_ELEMENT for cluster 0 */
    uint32_t first_child; /* inner: the first child cluster; leaf cluster: RAD_NO_ELEMENT */
    uint32_t child_count; /* inner: >= 2; leaf cluster: 0 */
    uint32_t root_begin, root_end; /* cluster_roots[root_begin .. root_end), root_end > root_begin */
    uint32_t pad;         /* 0 */
    double area;
} rad_link_cluster;

/* One link as the file stores it (16 bytes). */
typedef struct rad_link {
    uint32_t source; /* id: a node, or node_count + a cluster (rad_links_id_count) */
    float error;     /* bound on |F(leaf under receiver -> source) - factor|, F units */
    double factor;   /* F_rs, receiver -> source */
} rad_link;

/* Links address nodes and clusters alike: ids 0 .. node_count - 1 are the
 * nodes, id node_count + c is cluster c (rad_links_id_count ids in all).
 * A link at a cluster receiver c is gathered by every leaf under c's
 * roots (B_leaf = E + rho_leaf * (... + F_cs B_s)), as a split node's
 * links are by its leaves; a cluster's B is the area-weighted mean of its
 * roots' B. Reciprocity holds with the cluster's area. Without clusters
 * (cluster_count 0) the ids are the nodes' and nothing changes. */
typedef struct rad_links {
    rad_link_node *nodes;
    uint32_t node_count;
    uint32_t root_count;  /* nodes 0 .. root_count - 1 */
    uint32_t leaf_count;  /* = the leaves mesh's patch_count */
    uint32_t cluster_count;          /* 0: no clusters */
    rad_link_cluster *clusters;      /* cluster_count; NULL without clusters */
    uint32_t *cluster_roots;         /* root_count: the roots in cluster order; NULL without clusters */
    uint64_t *first_link; /* rad_links_id_count + 1 */
    rad_link *links;
    uint64_t link_count;
    double link_tol;      /* the --link-tol they were refined to (informational) */
    double error_bound;   /* formfactor's bound on the solution's relative error from the
                             links' errors (docs/hierarchy.md); 0 where unknown */
} rad_links;

/* Receivers and sources: the nodes, then the clusters. */
static inline uint64_t rad_links_id_count(const rad_links *links)
{
    return (uint64_t)links->node_count + links->cluster_count;
}

/* The receiver of link k (k < link_count): the id whose range
 * [first_link[id], first_link[id + 1]) holds it. Where a loop runs over
 * the links in blocks, each block starts here: a loop over receivers in
 * chunks leaves one thread with the largest clusters' links, which are
 * many (up to 3.5e5 each at 10^6 faces, 1.0e7 in the largest 62) and next
 * to each other (the top of the cluster tree). */
static inline uint32_t rad_links_receiver_of(const rad_links *links, uint64_t k)
{
    uint64_t lo = 0, hi = rad_links_id_count(links); /* first_link[lo] <= k < first_link[hi] */
    while (hi - lo > 1) {
        const uint64_t mid = lo + (hi - lo) / 2;
        if (links->first_link[mid] <= k) lo = mid;
        else hi = mid;
    }
    return (uint32_t)lo;
}

void rad_links_free(rad_links *links); /* safe on zeroed */

/* Every link's pair - the link at its source back to its receiver -
 * found without a search: the transpose by cursors. A source's links are
 * in ascending order of their sources (rad_links_check), so while the
 * receivers are walked in ascending order, each one's link back sits at
 * its source's cursor, which then moves on. The receivers are cut into
 * `blocks` ranges of about equal links (never a receiver apart), walked
 * side by side, each with its own cursors, set where the range starts.
 *
 *     rad_links_pairing w;
 *     rad_links_pairing_make(L, threads, &w);
 *     // on the threads, each block b:
 *     uint32_t *at = rad_links_pairing_cursors(&w, b);
 *     for (uint32_t r = w.begin[b]; r < w.begin[b + 1]; r++)
 *         for (uint64_t k = L->first_link[r]; k < L->first_link[r + 1]; k++)
 *             back = rad_links_pair_next(L, at, r, k);   // UINT64_MAX: no pair
 *
 * A caller may skip the links of some sources, so long as it skips all of
 * them (their cursors are not read). Binary searches in the source's
 * links instead were the most of formfactor's error bound and of the
 * shaped solve's plan at 10^6 triangles (860 M links, a few cache misses
 * each). The cursors take 4 bytes an id a block. */
#define RAD_LINKS_PAIR_BLOCKS 16
typedef struct rad_links_pairing {
    uint32_t blocks;
    uint32_t begin[RAD_LINKS_PAIR_BLOCKS + 1]; /* block b: receivers begin[b] .. begin[b + 1] - 1 */
    uint64_t ids;
    uint32_t *cursor; /* blocks * ids */
} rad_links_pairing;

/* Blocks for `threads` (0: OpenMP's; at most RAD_LINKS_PAIR_BLOCKS, one
 * for few links) and their cursors, set on the threads. RAD_ERR_NOMEM
 * (logged). */
rad_status rad_links_pairing_make(const rad_links *links, int threads, rad_links_pairing *out);
void rad_links_pairing_free(rad_links_pairing *w); /* safe on zeroed */

static inline uint32_t *rad_links_pairing_cursors(const rad_links_pairing *w, uint32_t block)
{
    return &w->cursor[(size_t)block * w->ids];
}

/* Link k's pair (k at receiver r, in its block's walk; `at` that block's
 * cursors), the cursor moved past it; UINT64_MAX where the source's next
 * link does not go back to r: the links do not come in pairs. */
static inline uint64_t rad_links_pair_next(const rad_links *links, uint32_t *at, uint32_t r, uint64_t k)
{
    const uint32_t s = links->links[k].source;
    const uint64_t j = links->first_link[s] + at[s]++;
    return j < links->first_link[s + 1] && links->links[j].source == r ? j : UINT64_MAX;
}

/* Structural checks a reader makes before trusting the links: roots
 * first, parents and children consistent, children after their parent,
 * levels, every leaf one patch and every patch one leaf (leaf_count
 * patches), corners in range (vertex_count vertices), areas finite and
 * > 0, first_link non-decreasing from 0 to link_count over all ids,
 * sources below rad_links_id_count and strictly ascending per receiver,
 * factors finite and >= 0, errors finite and >= 0. With clusters: fewer
 * than 2 root_count of them, cluster_roots a permutation of the roots,
 * the cluster tree as rad_link_cluster describes it (pad 0), each
 * cluster's area finite, > 0 and its roots' sum to a relative 1e-9, and
 * its links as a node's. RAD_ERR_FORMAT with a message naming `what` (a
 * file name) and the first bad node, cluster or link. */
rad_status rad_links_check(const rad_links *links, size_t vertex_count, const char *what);

/* The part of rad_links_check that the cluster tree's users index by:
 * cluster_roots a permutation of the roots, every cluster's parent,
 * children and root range (rad_link_cluster's rules), and its area the sum
 * of its roots' (relative 1e-9). Needs cluster_count > 0 and both tables.
 * RAD_ERR_FORMAT (logged, naming `what` and the cluster), RAD_ERR_NOMEM. */
rad_status rad_links_check_cluster_tree(const rad_links *links, const char *what);

/* Gauss-Seidel's groups of consecutive trees, for both solves on links
 * (rad_lsolve, solve/shaped.c): a group closes once its trees' work
 * (work[t] per tree, in root order) reaches `group` (0: every tree alone),
 * the last may hold less. Fills first[0 .. count] (group g is trees
 * first[g] .. first[g + 1]) and held[0 .. count) (each group's work);
 * returns count. Depends on the work alone, not on the threads. */
static inline uint32_t rad_links_tree_groups(const uint64_t *work, uint32_t roots, uint64_t group, uint32_t *first,
                                             uint64_t *held)
{
    uint32_t count = 0;
    uint64_t sum = 0;
    first[0] = 0;
    for (uint32_t t = 0; t < roots; t++) {
        sum += work[t];
        if (sum >= group || t + 1 == roots) {
            held[count] = sum;
            first[++count] = t + 1;
            sum = 0;
        }
    }
    return count;
}

#endif
