/* ff_clusters.h - clusters above the faces (issue 27, docs/hierarchy.md
 * "Clusters"): a binary volume hierarchy over the roots of a hierarchical
 * run, so that link refinement starts from one self-link of the whole
 * scene instead of every pair of faces (Sillion 1995; Smits, Arvo and
 * Greenberg 1994).
 *
 *     ff_cluster_tree t;
 *     ff_clusters_build(root_patches, open, root_count, max_cone, &t);
 *     ... t.clusters[c].bound, t.roots[t.clusters[c].link.root_begin .. root_end) ...
 *     ff_clusters_free(&t);
 *
 * The tree is built top down: a cluster's roots are split at the median of
 * their centres along the widest axis of the centres' box, or, where their
 * normals spread beyond max_cone from their mean and that box is thin (a
 * table top), at the median of the normals' component along the axis it
 * varies most on (ties by root
 * index: the same tree for any thread count), until at most
 * FF_CLUSTER_LEAF_ROOTS roots are left. A cluster's children are
 * consecutive and come after it (rad_link_cluster's rules).
 *
 * What a link needs to know of a cluster (ff_cluster_bound, ff_cluster_math.h,
 * with the pair's estimate and the draws written once for CPU and GPU) is what its
 * faces can send and receive without looking at them one by one: the
 * bounding sphere, the total area S, the vector area V = sum A n, and a
 * cone holding every face normal. The area a cluster shows in direction w,
 * P(w) = sum A max(n.w, 0), then lies in [max(V.w, 0), (V.w + S) / 2]
 * (since P(w) - P(-w) = V.w and P(w) + P(-w) <= S), and equals V.w when
 * the cone faces w entirely: a flat wall of many triangles is as exact as
 * one polygon. The estimate in between takes P = (V.w + T) / 2 with T =
 * sum A |n.w|, which the second moment M = sum A n n^T brackets: w.M.w <=
 * T <= sqrt(S w.M.w) (Cauchy-Schwarz), and T >= |V.w|; the estimate is the
 * geometric mean of the two ends (exact for a flat cluster, 12 % low for
 * normals spread evenly over the sphere). */
#ifndef FF_CLUSTERS_H
#define FF_CLUSTERS_H

#include <stdint.h>

#include "ff_cluster_math.h"
#include "rad_ff_kernel.h"
#include "rad_links.h"
#include "rad_math.h"
#include "rad_status.h"

/* Roots a leaf cluster holds at most. */
#define FF_CLUSTER_LEAF_ROOTS 4u

typedef struct ff_cluster_tree {
    ff_cluster *clusters;
    uint32_t count;
    uint32_t *roots;      /* root_count: the roots in cluster order */
    double *area_before;  /* root_count + 1: the roots' areas summed in cluster order (sampling by area) */
    uint32_t root_count;
} ff_cluster_tree;

/* The tree over roots 0 .. root_count - 1 (patches in the backend's frame):
 * a cluster whose normals spread beyond max_cone (radians; RAD_PI: never)
 * is split by orientation, any other by position (ff_clusters.c). open:
 * each root's openness (ff_openness.h) for the bounds' open_lo, open_hi,
 * or NULL (all 1). RAD_ERR_NOMEM (logged). */
rad_status ff_clusters_build(const rad_ff_patch *root_patches, const float *open, uint32_t root_count, double max_cone,
                             ff_cluster_tree *out);

void ff_clusters_free(ff_cluster_tree *t); /* safe on zeroed */

#endif
