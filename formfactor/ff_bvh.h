/* ff_bvh.h - a flat binary BVH over the occluder triangles, and its any-hit
 * traversal, written once for host and device.
 *
 * ff_bvh_build (ff_bvh_build.c) builds it with Embree's binned-SAH builder
 * (rtcBuildBVH) and flattens it; the CUDA backend copies the two arrays to
 * the GPU and calls ff_bvh_occluded per shadow ray; tests call the same
 * function on the host and compare it with Embree's own rtcOccluded1.
 *
 * Layout (all 16-byte aligned so the GPU loads them as float4):
 *   node     64 bytes: both children's boxes and references
 *   triangle 48 bytes: v0 + face id, edge1, edge2
 * A child reference c >= 0 is an inner node index; c < 0 is a leaf holding
 * the triangles [~c, ~c + count).
 */
#ifndef FF_BVH_H
#define FF_BVH_H

#include <stdint.h>

#include "rad_ff_kernel.h"
#include "rad_math.h"
#include "rad_status.h"

#if defined(__CUDACC__)
#define FF_ALIGN16 __align__(16)
#else
#define FF_ALIGN16 _Alignas(16)
#endif

typedef struct ff_bvh_node {
    FF_ALIGN16 float lo0[3];
    int32_t child0;
    float hi0[3];
    int32_t child1;
    float lo1[3];
    uint32_t count0; /* triangles in child 0 if it is a leaf */
    float hi1[3];
    uint32_t count1;
} ff_bvh_node;

typedef struct ff_bvh_tri {
    FF_ALIGN16 float v0[3];
    uint32_t face; /* scene face: rays from or to this face ignore it */
    float e1[3];   /* v1 - v0 */
    float pad1;
    float e2[3];   /* v2 - v0 */
    float pad2;
} ff_bvh_tri;

typedef struct ff_bvh {
    ff_bvh_node *nodes;
    uint32_t node_count;
    ff_bvh_tri *tris;  /* in leaf order */
    uint32_t tri_count;
    int32_t root;      /* a child reference (a leaf when the scene is tiny) */
    uint32_t root_count;
} ff_bvh;

/* Builds from triangle_count triangles (9 floats each) and their faces.
 * An empty scene gives an empty BVH (every ray unoccluded). */
rad_status ff_bvh_build(const float *triangles, const uint32_t *triangle_face, uint32_t triangle_count,
                        ff_bvh *out_bvh);
void ff_bvh_free(ff_bvh *bvh);

#define FF_BVH_STACK 64 /* > depth of Embree's builder (maxDepth 32 + leaves) */

/* A shadow segment x -> y is tested over t in [FF_RAY_T_MIN, FF_RAY_T_MAX]
 * of o + t (y - x), on CPU (Embree) and GPU alike: hits within 1e-4 of the
 * segment's length from either end are ignored. Those are the faces that
 * meet the source or target face at an edge, touched only because the end
 * points were rounded to float; counting them darkened pairs at corners
 * at random. */
#define FF_RAY_T_MIN 1e-4f
#define FF_RAY_T_MAX (1.0f - 1e-4f)

/* Does the segment o + t d, t in [FF_RAY_T_MIN, FF_RAY_T_MAX], hit a triangle whose face
 * is neither skip_a nor skip_b? Moller-Trumbore in float. */
static inline RAD_HD int ff_bvh_hit_tri(const ff_bvh_tri *t, const float o[3], const float d[3])
{
    float px = d[1] * t->e2[2] - d[2] * t->e2[1];
    float py = d[2] * t->e2[0] - d[0] * t->e2[2];
    float pz = d[0] * t->e2[1] - d[1] * t->e2[0];
    float det = t->e1[0] * px + t->e1[1] * py + t->e1[2] * pz;
    if (det == 0.0f) return 0; /* segment parallel to the triangle's plane */
    float inv = 1.0f / det;
    float sx = o[0] - t->v0[0], sy = o[1] - t->v0[1], sz = o[2] - t->v0[2];
    float u = (sx * px + sy * py + sz * pz) * inv;
    if (u < 0.0f || u > 1.0f) return 0;
    float qx = sy * t->e1[2] - sz * t->e1[1];
    float qy = sz * t->e1[0] - sx * t->e1[2];
    float qz = sx * t->e1[1] - sy * t->e1[0];
    float v = (d[0] * qx + d[1] * qy + d[2] * qz) * inv;
    if (v < 0.0f || u + v > 1.0f) return 0;
    float tt = (t->e2[0] * qx + t->e2[1] * qy + t->e2[2] * qz) * inv;
    return tt >= FF_RAY_T_MIN && tt <= FF_RAY_T_MAX;
}

/* Entry distance of the segment into a box, or a miss (returns 0). */
static inline RAD_HD int ff_bvh_hit_box(const float lo[3], const float hi[3], const float o[3], const float inv_d[3])
{
    float tmin = FF_RAY_T_MIN, tmax = FF_RAY_T_MAX;
    for (int a = 0; a < 3; a++) {
        float t0 = (lo[a] - o[a]) * inv_d[a], t1 = (hi[a] - o[a]) * inv_d[a];
        float near_t = t0 < t1 ? t0 : t1, far_t = t0 < t1 ? t1 : t0;
        /* NaN (0 * inf, origin on a slab of a flat box) keeps the interval open. */
        tmin = near_t > tmin ? near_t : tmin;
        tmax = far_t < tmax ? far_t : tmax;
    }
    return tmin <= tmax;
}

static inline RAD_HD int ff_bvh_leaf_hit(const ff_bvh_tri *tris, int32_t ref, uint32_t count, const float o[3],
                                         const float d[3], uint32_t skip_a, uint32_t skip_b)
{
    for (uint32_t k = 0; k < count; k++) {
        const ff_bvh_tri *t = &tris[~ref + (int32_t)k];
        if (t->face != skip_a && t->face != skip_b && ff_bvh_hit_tri(t, o, d)) return 1;
    }
    return 0;
}

/* Any-hit query for the segment from o to o + d (first hit returns). */
static inline RAD_HD int ff_bvh_occluded(const ff_bvh_node *nodes, const ff_bvh_tri *tris, int32_t root,
                                         uint32_t root_count, const float o[3], const float d[3], uint32_t skip_a,
                                         uint32_t skip_b)
{
    if (root < 0) return root_count ? ff_bvh_leaf_hit(tris, root, root_count, o, d, skip_a, skip_b) : 0;
    float inv_d[3] = {1.0f / d[0], 1.0f / d[1], 1.0f / d[2]};
    int32_t stack[FF_BVH_STACK];
    int top = 0;
    stack[top++] = root;
    while (top > 0) {
        const ff_bvh_node *n = &nodes[stack[--top]];
        if (ff_bvh_hit_box(n->lo0, n->hi0, o, inv_d)) {
            if (n->child0 < 0) {
                if (ff_bvh_leaf_hit(tris, n->child0, n->count0, o, d, skip_a, skip_b)) return 1;
            } else if (top < FF_BVH_STACK) {
                stack[top++] = n->child0;
            }
        }
        if (ff_bvh_hit_box(n->lo1, n->hi1, o, inv_d)) {
            if (n->child1 < 0) {
                if (ff_bvh_leaf_hit(tris, n->child1, n->count1, o, d, skip_a, skip_b)) return 1;
            } else if (top < FF_BVH_STACK) {
                stack[top++] = n->child1;
            }
        }
    }
    return 0;
}

/* Could a triangle other than those of the two patches' faces meet a
 * shadow segment between patches pi and pj? Conservative, so "no" is
 * certain and "yes" only possible. A triangle is out of the way if
 *  - it lies wholly on or behind the plane of pi or of pj, and each patch
 *    lies wholly on or in front of the other's plane (then every segment
 *    leaves pi's plane at once and meets pj's only at its end; a patch
 *    that straddles the other's plane has segments from behind it), or
 *  - its bounding box misses the box around both patches (which holds
 *    every segment), grown by a margin for the rays' float rounding. */
static inline RAD_HD int ff_bvh_box_overlaps(const float a_lo[3], const float a_hi[3], const float b_lo[3],
                                             const float b_hi[3])
{
    return a_lo[0] <= b_hi[0] && b_lo[0] <= a_hi[0] && a_lo[1] <= b_hi[1] && b_lo[1] <= a_hi[1] &&
           a_lo[2] <= b_hi[2] && b_lo[2] <= a_hi[2];
}

static inline RAD_HD int ff_tri_behind(const float v[3][3], const rad_ff_patch *q)
{
    for (int k = 0; k < 3; k++)
        if (rad_v3_dot(q->normal, rad_v3_sub(rad_v3(v[k][0], v[k][1], v[k][2]), q->p[0])) > 0.0) return 0;
    return 1;
}

static inline RAD_HD int ff_tri_in_shaft(const ff_bvh_tri *t, const float lo[3], const float hi[3],
                                         const rad_ff_patch *pi, const rad_ff_patch *pj, int use_planes)
{
    if (t->face == pi->face || t->face == pj->face) return 0;
    float v[3][3], tlo[3], thi[3];
    for (int a = 0; a < 3; a++) {
        v[0][a] = t->v0[a];
        v[1][a] = t->v0[a] + t->e1[a];
        v[2][a] = t->v0[a] + t->e2[a];
        tlo[a] = fminf(v[0][a], fminf(v[1][a], v[2][a]));
        thi[a] = fmaxf(v[0][a], fmaxf(v[1][a], v[2][a]));
    }
    return ff_bvh_box_overlaps(tlo, thi, lo, hi) && !(use_planes && (ff_tri_behind(v, pi) || ff_tri_behind(v, pj)));
}

static inline RAD_HD int ff_bvh_leaf_in_shaft(const ff_bvh_tri *tris, int32_t ref, uint32_t count, const float lo[3],
                                              const float hi[3], const rad_ff_patch *pi, const rad_ff_patch *pj,
                                              int use_planes)
{
    for (uint32_t k = 0; k < count; k++)
        if (ff_tri_in_shaft(&tris[~ref + (int32_t)k], lo, hi, pi, pj, use_planes)) return 1;
    return 0;
}

/* Is every vertex of `a` on or in front of the plane of `b`? */
static inline RAD_HD int ff_patch_in_front(const rad_ff_patch *a, const rad_ff_patch *b)
{
    for (uint32_t k = 0; k < a->vertex_count; k++)
        if (rad_v3_dot(b->normal, rad_v3_sub(a->p[k], b->p[0])) < 0.0) return 0;
    return 1;
}

static inline RAD_HD int ff_bvh_shaft_may_occlude(const ff_bvh_node *nodes, const ff_bvh_tri *tris, int32_t root,
                                                  uint32_t root_count, const float lo[3], const float hi[3],
                                                  const rad_ff_patch *pi, const rad_ff_patch *pj, int use_planes)
{
    if (root < 0) return root_count ? ff_bvh_leaf_in_shaft(tris, root, root_count, lo, hi, pi, pj, use_planes) : 0;
    int32_t stack[FF_BVH_STACK];
    int top = 0;
    stack[top++] = root;
    while (top > 0) {
        const ff_bvh_node *n = &nodes[stack[--top]];
        for (int c = 0; c < 2; c++) {
            const float *clo = c ? n->lo1 : n->lo0, *chi = c ? n->hi1 : n->hi0;
            int32_t child = c ? n->child1 : n->child0;
            uint32_t count = c ? n->count1 : n->count0;
            if (!ff_bvh_box_overlaps(clo, chi, lo, hi)) continue;
            if (child < 0) {
                if (ff_bvh_leaf_in_shaft(tris, child, count, lo, hi, pi, pj, use_planes)) return 1;
            } else if (top < FF_BVH_STACK) {
                stack[top++] = child;
            } else {
                return 1; /* cannot look further: assume it may */
            }
        }
    }
    return 0;
}

/* The box around both patches, grown by `margin` (float rounding of the
 * rays' end points), and whether the plane test applies to the pair. */
static inline RAD_HD int ff_pair_shaft(const rad_ff_patch *pi, const rad_ff_patch *pj, float margin, float lo[3],
                                       float hi[3])
{
    lo[0] = hi[0] = (float)pi->p[0].x;
    lo[1] = hi[1] = (float)pi->p[0].y;
    lo[2] = hi[2] = (float)pi->p[0].z;
    for (int side = 0; side < 2; side++) {
        const rad_ff_patch *q = side ? pj : pi;
        for (uint32_t k = 0; k < q->vertex_count; k++) {
            float v[3] = {(float)q->p[k].x, (float)q->p[k].y, (float)q->p[k].z};
            for (int a = 0; a < 3; a++) {
                lo[a] = fminf(lo[a], v[a]);
                hi[a] = fmaxf(hi[a], v[a]);
            }
        }
    }
    for (int a = 0; a < 3; a++) {
        lo[a] -= margin;
        hi[a] += margin;
    }
    return ff_patch_in_front(pi, pj) && ff_patch_in_front(pj, pi);
}

/* Must pair (pi, pj) trace its shadow rays? Not if no triangle is in its
 * shaft (see ff_tri_in_shaft). Any way of visiting the triangles gives the
 * same answer: this BVH walk, or the GPU's warp-wide scan. */
static inline RAD_HD int ff_pair_may_be_occluded(const ff_bvh_node *nodes, const ff_bvh_tri *tris, int32_t root,
                                                 uint32_t root_count, const rad_ff_patch *pi, const rad_ff_patch *pj,
                                                 float margin)
{
    float lo[3], hi[3];
    int use_planes = ff_pair_shaft(pi, pj, margin, lo, hi);
    return ff_bvh_shaft_may_occlude(nodes, tris, root, root_count, lo, hi, pi, pj, use_planes);
}

#endif
