/* shaped_plan.h - the shaped solve's plan, the host's bookkeeping
 * (shaped_plan.c), which shaped.c's CPU sweeps and its driver of the
 * device backends (shaped_gpu.h) share. Private to solve/.
 *
 * Every node's leaves are one range of a depth-first leaf list (children
 * come after their parent, so one forward pass over the nodes places
 * them); each link's pair is the link stored at its source; a receiver
 * end is shaped or not (shaped.h, "Which ends"): the ends are numbered in
 * link order, each with its point factors' offset (shaped_math.h, "Ends").
 *
 *     shaped_plan p;
 *     shaped_plan_make(links, leaves, B, gate, threads, &p, node_B);  // up to the ends
 *     shaped_plan_factors(&p);     // the CPU: the point factors on the host, ends that sum to 0 dropped
 *     shaped_plan_work(&p);        // the CPU: the trees' work (Gauss-Seidel's groups)
 *     shaped_plan_row_sums(&p);    // the CPU: the leaves' row sums (a device backend returns them)
 *     ...
 *     shaped_plan_free(&p);
 */
#ifndef SOLVE_SHAPED_PLAN_H
#define SOLVE_SHAPED_PLAN_H

#include <stdint.h>

#include "rad_links.h"
#include "rad_mesh.h"
#include "rad_status.h"
#include "shaped_gpu.h"
#include "shaped_math.h"

typedef struct shaped_plan {
    const rad_links *L;
    const rad_mesh *leaves;
    uint32_t *leaf_nodes;    /* leaf_count: the leaf nodes, each node's leaves consecutive */
    uint32_t *first, *count; /* node_count: node i's leaves are leaf_nodes[first[i] .. first[i] + count[i]) */
    double *leaf_area;       /* node_count: its leaves' areas summed */
    uint32_t *end;           /* link_count: the link's end, or SHAPED_NO_END (shaped_math.h, "Ends"); NULL: flat */
    uint32_t *pair_end;      /* link_count: the pair's other link's end, or SHAPED_NO_END; NULL: flat */
    uint64_t end_count;      /* ends numbered in link order; dropped ones keep their number */
    uint64_t *end_link;      /* end_count: its link */
    uint32_t *end_receiver;  /* end_count: its receiver */
    uint64_t *end_at;        /* end_count: its point factors f[end_at .. end_at + count[receiver]) */
    double *inv_mean;        /* end_count: 1 / the area-weighted mean of those (0: dropped) */
    uint64_t dropped;        /* ends whose factors sum to 0 */
    float *f;                /* the point factors, where the host computes them (NULL where a device does) */
    uint64_t weight_count;
    uint64_t *shaped_first;  /* ids + 1: receiver r's ends are shaped_first[r] .. [r + 1]; none at clusters */
    double *row_sum;         /* node_count (leaves): the leaf's row sum with the shape */
    double *rho, *E;         /* node_count * 3: the node's material (its root's); with closure a leaf's
                                rho s^2 and E s (rad_closure.h) */
    double *scale, *closed_row; /* closure: node_count, a leaf's s and row of S K S (1, 0 at split nodes);
                                   NULL without */
    double *area_q;          /* leaf_count: leaf areas in leaf-list order (the sweeps stream them) */
    rad_vec3 *leaf_centroid, *leaf_normal; /* leaf_count: in leaf-list order (the point factors') */
    uint32_t *up;            /* ids: shaped_view's */
    uint64_t *pull_first;    /* ids + 1: shaped_view's */
    uint32_t *pull_child;
    double *id_area;         /* ids */
    uint32_t *tree_first;    /* root_count + 1: tree t's nodes are tree_nodes[tree_first[t] .. [t + 1]), */
    uint32_t *tree_nodes;    /* in index order (parents first) */
    uint64_t *tree_work;     /* root_count: the links the tree's nodes receive, plus (once the lists are
                                made) the point factors a sweep reads for them: the receiver's where the
                                link's end is shaped, the source's where the pair's other end is */
    uint32_t *root_cluster;  /* root_count: the leaf cluster holding the root; NULL without clusters */
    uint64_t cluster_links;  /* the links the clusters receive */
    int threads;
    shaped_view view;        /* the arrays above as shaped_math.h reads them */
} shaped_plan;

static inline int shaped_plan_is_leaf(const shaped_plan *p, uint32_t i)
{
    return p->L->nodes[i].first_child == RAD_NO_ELEMENT;
}

/* The plan up to the choice of ends: ranges, materials, pairs, the ids'
 * up and pull lists, which ends to shape (gate: shaped.h's; `flat`: none,
 * and neither the pairs nor a per-link array: solve_shaped_options.flat).
 * node_B: 3 values per id, the flat solution B (3 per leaf patch) pulled
 * up the trees and the clusters. RAD_ERR_NOMEM, RAD_ERR_INVALID (a link
 * without its pair), logged; *p is freed on failure. */
rad_status shaped_plan_make(const rad_links *L, const rad_mesh *leaves, const double *B, double gate, int flat,
                            int threads, shaped_plan *p, double *node_B);
void shaped_plan_free(shaped_plan *p); /* zeroes it */

/* The point factors on the host threads and each end's inv_mean; an end
 * whose factors sum to 0 is dropped (shaped_plan_drop). RAD_ERR_NOMEM
 * (logged). */
rad_status shaped_plan_factors(shaped_plan *p);
/* The ends whose inv_mean is 0 dropped from the plan's end and pair_end
 * (shaped_drop_end), counted in p->dropped. */
void shaped_plan_drop(shaped_plan *p);
/* The trees' work that the shaped ends add (tree_work), for Gauss-Seidel's
 * groups. */
void shaped_plan_work(shaped_plan *p);
/* Every leaf's row sum with the shape, from the host's point factors. */
void shaped_plan_row_sums(shaped_plan *p);
/* Every cluster's B (3 per id), children before parents. */
void shaped_plan_pull_clusters(const shaped_plan *p, double *B);

/* What the device backends take beyond the plan (shaped_gpu.h): the ids
 * by depth. */
typedef struct shaped_device_arrays {
    uint32_t *depth, *depth_order, *depth_first;
} shaped_device_arrays;

/* The device plan of `p` (before the factors): `out` points into `p` and
 * `a`. RAD_ERR_NOMEM (logged). Free `a` with shaped_device_arrays_free,
 * also on failure. */
rad_status shaped_plan_device(const shaped_plan *p, shaped_device_arrays *a, solve_shaped_device_plan *out);
void shaped_device_arrays_free(shaped_device_arrays *a);

#endif
