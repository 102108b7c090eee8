/* ff_pair_class.h - what becomes of a pair (i, j) before the per-pair
 * procedure runs: the one classification both backends make, host and
 * device (the CPU backend per column of a row, the CUDA backend in its
 * listing kernel), so that they zero, skip and cull the same pairs.
 *
 *     ff_pair_rules rules = ff_pair_rules_make(su, patches, nodes, tris, root, root_count);
 *     int near;
 *     ff_pair_verdict v = ff_pair_classify(&rules, i, j, &near);
 *     if (ff_pair_computed(v))
 *         rad_ff_pair_compute(&pp, pi, pj, i, j, v == FF_PAIR_TRACED ? &tracer : NULL, &r);
 *
 * Include it after rad_ff_pair.h, which the including file configures
 * (RAD_FF_LANE_SUM among others); this header uses its contour test.
 */
#ifndef FF_PAIR_CLASS_H
#define FF_PAIR_CLASS_H

#include <stdint.h>

#include "ff_backend.h"
#include "ff_bvh.h"
#include "ff_shaft.h"
#include "rad_ff_contour.h"
#include "rad_ff_kernel.h"
#include "rad_ff_quad.h"

/* In the order the rules decide; the first that applies is the verdict. */
typedef enum ff_pair_verdict {
    FF_PAIR_OTHER_ROW = 0, /* pairs_once: row j computes the pair (rad_ff_row_computes); the
                              entry is 0 here and not counted */
    FF_PAIR_NOT_FACING,    /* i == j, or the patches cannot exchange light (rad_ff_pair_facing):
                              0, counted as pairs_not_facing */
    FF_PAIR_REUSED,        /* --reuse: both patches unsplit; the coupling comes from the
                              refined-from matrix (ff_setup.reuse_old) */
    FF_PAIR_UNTRACED,      /* computed without shadow rays: the run casts none */
    FF_PAIR_OPEN_SCENE,    /* computed without shadow rays: the scene is one convex enclosure */
    FF_PAIR_OPEN_BOX,      /* computed without shadow rays: nothing else meets the pair's
                              shaft (ff_pair_may_be_occluded) */
    FF_PAIR_TRACED         /* computed with shadow rays: something may lie between */
} ff_pair_verdict;

/* Does the per-pair procedure run for the pair? */
static inline RAD_HD int ff_pair_computed(ff_pair_verdict v)
{
    return v >= FF_PAIR_UNTRACED;
}

/* What the classification needs of a run: flat, no host-only pointers on
 * the device (there, patches and the BVH are the device's copies and
 * reuse_old is NULL). */
typedef struct ff_pair_rules {
    const rad_ff_patch *patches;
    double plane_eps;          /* rad_ff_pair_facing tolerance, scene units */
    int pairs_once;            /* each unordered pair in one row only */
    const uint32_t *reuse_old; /* ff_setup.reuse_old; NULL: no pair is reused */
    int traces;                /* the run casts shadow rays (shadow_rays > 0) */
    int cull, scene_convex;    /* ff_setup's occlusion culling */
    float cull_margin;         /* scene units: the shaft's float box */
    double ray_delta;          /* scene units: ff_segment's delta */
    int weighted;              /* the quadrature estimator: only segments that carry weight count */
    const ff_bvh_node *nodes;  /* the occluders' BVH, for the shaft test */
    const ff_bvh_tri *tris;
    int32_t root;
    uint32_t root_count;
} ff_pair_rules;

/* The rules of a setup over the given patches and BVH (the host's, or
 * their device copies). */
static inline ff_pair_rules ff_pair_rules_make(const ff_setup *su, const rad_ff_patch *patches,
                                               const ff_bvh_node *nodes, const ff_bvh_tri *tris, int32_t root,
                                               uint32_t root_count)
{
    ff_pair_rules r;
    r.patches = patches;
    r.plane_eps = su->plane_eps;
    r.pairs_once = su->pairs_once;
    r.reuse_old = su->reuse_old;
    r.traces = su->shadow_rays > 0;
    r.cull = su->cull;
    r.scene_convex = su->scene_convex;
    r.cull_margin = su->cull_margin;
    r.ray_delta = su->ray_delta;
    r.weighted = su->estimator == RAD_ESTIMATOR_QUADRATURE;
    r.nodes = nodes;
    r.tris = tris;
    r.root = root;
    r.root_count = root_count;
    return r;
}

/* Is the computed pair a near one, in the backends' sense of a costly
 * pair: near (rad_ff_pair_near), or its smaller patch reaches behind the
 * other's plane - the contour integral over their clipped parts, or the
 * area rule over its fan, then takes hundreds to thousands of points. */
static inline RAD_HD int ff_pair_costly(const rad_ff_patch *pi, const rad_ff_patch *pj, uint32_t i, uint32_t j)
{
    if (rad_ff_pair_near(pi, pj)) return 1;
    int i_is_q = rad_ff_quad_roles(pi, pj, i, j);
    return rad_ff_contour_straddles(i_is_q ? pi : pj, i_is_q ? pj : pi);
}

/* The verdict on pair (i, j) (see ff_pair_verdict for the order of the
 * rules). Culling, where the run asks for it: the convex-enclosure rule,
 * then the shaft test without the hull's planes (`hull` 0: on
 * cornell_sphere --subdiv 3 they clear 412 k pairs instead of 397 k, but
 * building them cost more than the rays they save - H100: 19 ms of
 * kernels with them, 18 without). With `near` not NULL, a computed
 * pair's *near says whether it is costly (ff_pair_costly); it is not
 * touched otherwise. */
static inline RAD_HD ff_pair_verdict ff_pair_classify(const ff_pair_rules *r, uint32_t i, uint32_t j, int *near)
{
    const rad_ff_patch *pi = &r->patches[i], *pj = &r->patches[j];
    if (r->pairs_once && !rad_ff_row_computes(i, j)) return FF_PAIR_OTHER_ROW;
    if (i == j || !rad_ff_pair_facing(pi, pj, r->plane_eps)) return FF_PAIR_NOT_FACING;
    if (r->reuse_old && r->reuse_old[i] != FF_REUSE_NONE && r->reuse_old[j] != FF_REUSE_NONE)
        return FF_PAIR_REUSED;
    if (near) *near = ff_pair_costly(pi, pj, i, j);
    if (!r->traces) return FF_PAIR_UNTRACED;
    if (!r->cull) return FF_PAIR_TRACED;
    if (r->scene_convex) return FF_PAIR_OPEN_SCENE;
    if (!ff_pair_may_be_occluded(r->nodes, r->tris, r->root, r->root_count, pi, pj, r->cull_margin, r->ray_delta, 0,
                                 r->weighted))
        return FF_PAIR_OPEN_BOX;
    return FF_PAIR_TRACED;
}

#endif
