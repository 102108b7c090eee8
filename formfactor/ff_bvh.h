/* ff_bvh.h - a flat binary BVH over the occluder triangles, and its any-hit
 * traversal, written once for host and device. (The shaft test that
 * spares a pair its shadow rays walks the same BVH: ff_shaft.h.)
 *
 * ff_bvh_build (ff_bvh_build.c) builds it with Embree's binned-SAH builder
 * (rtcBuildBVH) and flattens it; the CUDA backend copies the two arrays to
 * the GPU and calls ff_bvh_occluded per shadow segment, the CPU backend
 * calls it on the host; tests compare the walk with a scan of every
 * triangle.
 *
 * Layout (16-byte aligned):
 *   node     64 bytes: both children's boxes (float, grown by FF_BVH_PAD
 *            so that a float walk never misses a leaf a double segment
 *            reaches) and references
 *   triangle 80 bytes: v0, edge1, edge2 in double, face id
 *
 * Boxes are float (the walk is the cheap, conservative part); the hit test
 * is double (exact enough for faces 1e-9 of the scene apart, where float
 * end points would put both faces in one plane).
 * A child reference c >= 0 is an inner node index; c < 0 is a leaf holding
 * the triangles [~c, ~c + count).
 */
#ifndef FF_BVH_H
#define FF_BVH_H

#include <float.h>
#include <stdint.h>

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
    FF_ALIGN16 double v0[3];
    double e1[3];  /* v1 - v0 */
    double e2[3];  /* v2 - v0 */
    uint32_t face; /* scene face: rays from or to this face ignore it */
    uint32_t pad;
} ff_bvh_tri;

typedef struct ff_bvh {
    ff_bvh_node *nodes;
    uint32_t node_count;
    ff_bvh_tri *tris;  /* in leaf order */
    uint32_t tri_count;
    int32_t root;      /* a child reference (a leaf when the scene is tiny) */
    uint32_t root_count;
} ff_bvh;

/* Builds from triangle_count triangles (9 doubles each) and their faces.
 * An empty scene gives an empty BVH (every ray unoccluded). */
rad_status ff_bvh_build(const double *triangles, const uint32_t *triangle_face, uint32_t triangle_count,
                        ff_bvh *out_bvh);
void ff_bvh_free(ff_bvh *bvh);

#define FF_BVH_STACK 64 /* > depth of Embree's builder (maxDepth 32 + leaves) */

/* Boxes are grown by FF_BVH_PAD float ulps of the largest coordinate,
 * and the walk accepts t a hair outside [0, 1]: the float segment (end
 * points rounded) then never misses a box the double segment enters. */
#define FF_BVH_PAD (16.0f * FLT_EPSILON)
#define FF_BVH_T_SLACK 1e-6f

/* A shadow segment from x, on face a with unit normal na, to y, on face b
 * with normal nb (double, the backends' centred frame).
 *
 * What counts as a hit (the same on CPU and GPU, ff_bvh_hit_tri): the
 * segment meets a triangle of a face other than a and b at a point that
 * lies more than `delta` in front of both end planes - of na through x and
 * of nb through y. Heights, not fractions of the segment: a face 1e-9 of
 * the scene in front of x blocks whatever the segment's length (the old
 * rule, t in [1e-4, 1 - 1e-4], let a 5-unit ray pass through anything
 * within half a millimetre of either end: two facing squares 1e-4 apart
 * saw each other and the whole room, rows summed to 2). delta is
 * FF_RAY_DELTA of the scene's diagonal, far above double rounding (1e-16)
 * and far below any gap a model means: faces that share an edge with the
 * source or target face, or lie in its plane, meet the segment only at
 * its end, at height 0, and never count. A segment that leaves x's plane
 * backwards (na.(y - x) <= 0) carries no weight and is never blocked. */
#define FF_RAY_DELTA 1e-12

typedef struct ff_segment {
    double o[3], d[3];     /* x, and y - x */
    double rise_a, rise_b; /* na.(y - x) and nb.(x - y): height over each end plane per unit of t */
    double delta;
    float fo[3], inv_fd[3]; /* the segment in float, for the box tests */
    uint32_t skip_a, skip_b;
} ff_segment;

static inline RAD_HD ff_segment ff_segment_make(rad_vec3 x, rad_vec3 nx, uint32_t face_x, rad_vec3 y, rad_vec3 ny,
                                                uint32_t face_y, double delta)
{
    ff_segment s;
    rad_vec3 d = rad_v3_sub(y, x);
    s.o[0] = x.x, s.o[1] = x.y, s.o[2] = x.z;
    s.d[0] = d.x, s.d[1] = d.y, s.d[2] = d.z;
    s.rise_a = rad_v3_dot(nx, d);
    s.rise_b = -rad_v3_dot(ny, d);
    s.delta = delta;
    for (int a = 0; a < 3; a++) {
        s.fo[a] = (float)s.o[a];
        s.inv_fd[a] = 1.0f / (float)s.d[a];
    }
    s.skip_a = face_x, s.skip_b = face_y;
    return s;
}

/* Where the segment's line meets the triangle: its t, or -1 where it
 * misses (or runs parallel). Moller-Trumbore in double; no plane tests. */
static inline RAD_HD double ff_bvh_tri_t(const ff_bvh_tri *t, const ff_segment *s)
{
    const double *d = s->d;
    double px = d[1] * t->e2[2] - d[2] * t->e2[1];
    double py = d[2] * t->e2[0] - d[0] * t->e2[2];
    double pz = d[0] * t->e2[1] - d[1] * t->e2[0];
    double det = t->e1[0] * px + t->e1[1] * py + t->e1[2] * pz;
    if (det == 0.0) return -1.0; /* segment parallel to the triangle's plane */
    double inv = 1.0 / det;
    double sx = s->o[0] - t->v0[0], sy = s->o[1] - t->v0[1], sz = s->o[2] - t->v0[2];
    double u = (sx * px + sy * py + sz * pz) * inv;
    if (u < 0.0 || u > 1.0) return -1.0;
    double qx = sy * t->e1[2] - sz * t->e1[1];
    double qy = sz * t->e1[0] - sx * t->e1[2];
    double qz = sx * t->e1[1] - sy * t->e1[0];
    double v = (d[0] * qx + d[1] * qy + d[2] * qz) * inv;
    if (v < 0.0 || u + v > 1.0) return -1.0;
    return (t->e2[0] * qx + t->e2[1] * qy + t->e2[2] * qz) * inv;
}

/* Does the segment hit the triangle (see ff_segment)? */
static inline RAD_HD int ff_bvh_hit_tri(const ff_bvh_tri *t, const ff_segment *s)
{
    const double tt = ff_bvh_tri_t(t, s);
    /* Inside the segment, and in front of both end planes by more than delta. */
    return tt > 0.0 && tt < 1.0 && tt * s->rise_a > s->delta && (1.0 - tt) * s->rise_b > s->delta;
}

/* Does the float segment meet a box before t_max (t within [0, t_max] and a slack)? */
static inline RAD_HD int ff_bvh_hit_box_before(const float lo[3], const float hi[3], const float o[3],
                                               const float inv_d[3], float t_max)
{
    float tmin = -FF_BVH_T_SLACK, tmax = t_max + FF_BVH_T_SLACK;
    for (int a = 0; a < 3; a++) {
        float t0 = (lo[a] - o[a]) * inv_d[a], t1 = (hi[a] - o[a]) * inv_d[a];
        float near_t = t0 < t1 ? t0 : t1, far_t = t0 < t1 ? t1 : t0;
        /* NaN (0 * inf, origin on a slab of a flat box) keeps the interval open. */
        tmin = near_t > tmin ? near_t : tmin;
        tmax = far_t < tmax ? far_t : tmax;
    }
    return tmin <= tmax;
}

/* Does the float segment meet a box (t within [0, 1] and a slack)? */
static inline RAD_HD int ff_bvh_hit_box(const float lo[3], const float hi[3], const float o[3], const float inv_d[3])
{
    return ff_bvh_hit_box_before(lo, hi, o, inv_d, 1.0f);
}

#define FF_BVH_NO_HIT UINT32_MAX

/* Does the segment hit triangle t, one of neither end's faces? */
static inline RAD_HD int ff_bvh_blocks(const ff_bvh_tri *t, const ff_segment *s)
{
    return t->face != s->skip_a && t->face != s->skip_b && ff_bvh_hit_tri(t, s);
}

/* The index in tris of a triangle of the leaf that the segment hits, or
 * FF_BVH_NO_HIT. */
static inline RAD_HD uint32_t ff_bvh_leaf_hit(const ff_bvh_tri *tris, int32_t ref, uint32_t count,
                                              const ff_segment *s)
{
    for (uint32_t k = 0; k < count; k++) {
        const uint32_t at = (uint32_t)(~ref) + k;
        if (ff_bvh_blocks(&tris[at], s)) return at;
    }
    return FF_BVH_NO_HIT;
}

/* Any-hit query for a segment: the index of the first triangle found that
 * it hits, or FF_BVH_NO_HIT. */
static inline RAD_HD uint32_t ff_bvh_any_hit(const ff_bvh_node *nodes, const ff_bvh_tri *tris, int32_t root,
                                             uint32_t root_count, const ff_segment *s)
{
    if (root < 0) return root_count ? ff_bvh_leaf_hit(tris, root, root_count, s) : FF_BVH_NO_HIT;
    int32_t stack[FF_BVH_STACK];
    int top = 0;
    stack[top++] = root;
    while (top > 0) {
        const ff_bvh_node *n = &nodes[stack[--top]];
        if (ff_bvh_hit_box(n->lo0, n->hi0, s->fo, s->inv_fd)) {
            if (n->child0 < 0) {
                const uint32_t hit = ff_bvh_leaf_hit(tris, n->child0, n->count0, s);
                if (hit != FF_BVH_NO_HIT) return hit;
            } else if (top < FF_BVH_STACK) {
                stack[top++] = n->child0;
            }
        }
        if (ff_bvh_hit_box(n->lo1, n->hi1, s->fo, s->inv_fd)) {
            if (n->child1 < 0) {
                const uint32_t hit = ff_bvh_leaf_hit(tris, n->child1, n->count1, s);
                if (hit != FF_BVH_NO_HIT) return hit;
            } else if (top < FF_BVH_STACK) {
                stack[top++] = n->child1;
            }
        }
    }
    return FF_BVH_NO_HIT;
}

/* Does the segment hit anything (first hit returns)? */
static inline RAD_HD int ff_bvh_occluded(const ff_bvh_node *nodes, const ff_bvh_tri *tris, int32_t root,
                                         uint32_t root_count, const ff_segment *s)
{
    return ff_bvh_any_hit(nodes, tris, root, root_count, s) != FF_BVH_NO_HIT;
}

/* The same answer, asking first the triangle that blocked the caller's
 * last blocked segment (*last; FF_BVH_NO_HIT before any), which becomes
 * the one this segment hits. A pair's shadow segments, and the next
 * pair's of the same element, mostly end on the same occluder, so a
 * blocked segment is then one triangle test instead of a walk; a hit is a
 * hit whichever triangle shows it, so the answer is the walk's. */
static inline RAD_HD int ff_bvh_occluded_cached(const ff_bvh_node *nodes, const ff_bvh_tri *tris, int32_t root,
                                                uint32_t root_count, const ff_segment *s, uint32_t *last)
{
    if (*last != FF_BVH_NO_HIT && ff_bvh_blocks(&tris[*last], s)) return 1;
    const uint32_t hit = ff_bvh_any_hit(nodes, tris, root, root_count, s);
    if (hit == FF_BVH_NO_HIT) return 0;
    *last = hit;
    return 1;
}

#endif
