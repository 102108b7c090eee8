/* ff_shaft.h - occlusion culling by shafts, written once for host and
 * device: can anything lie between two patches? A walk of the flat BVH of
 * ff_bvh.h that visits only what meets the pair's shaft; a "no" spares
 * the pair its shadow rays (ff_pair_class.h decides when it is asked).
 */
#ifndef FF_SHAFT_H
#define FF_SHAFT_H

#include <math.h>
#include <stdint.h>

#include "ff_bvh.h"
#include "rad_ff_kernel.h"
#include "rad_math.h"

/* Could a triangle other than those of the two patches' faces meet a
 * shadow segment between patches pi and pj? Conservative, so "no" is
 * certain and "yes" only possible. Every segment lies in the shaft, the
 * convex hull of the two patches (Haines & Wallace's shaft, exact rather
 * than boxed), and a triangle is out of the way if
 *  - its bounding box misses the box around both patches, or
 *  - all three of its vertices lie outside one plane of the hull (farther
 *    than the segments' delta, ff_segment), or
 *  - it lies wholly on or behind the plane of pi or of pj (within delta:
 *    ff_bvh_hit_tri counts no hit there), and only the
 *    segments that carry weight count: those join a point of pi to one of
 *    pj strictly in front of pi's plane, and a point of pj to one of pi
 *    strictly in front of pj's, so their insides are strictly in front of
 *    both planes. That holds for the quadrature estimator, which weights
 *    its rays by the kernel (`weighted`), and for any estimator when each
 *    patch lies on or in front of the other's plane (every segment is then
 *    one that counts); the Monte Carlo estimators' visible fraction counts
 *    every ray alike. This also drops triangles lying in a patch's plane,
 *    which the hull keeps; or
 *  - both patches lie wholly on one side of its own plane (within delta):
 *    a segment between them then meets that plane at most at an end (the
 *    walls of a room, for every pair inside it).
 * BVH nodes are pruned the same way: by the box (float, grown by the
 * margin that covers float rounding of the coordinates), and by a hull
 * plane that has the whole node box outside it. */
#define FF_SHAFT_PLANES 32 /* hull faces of <= 8 points: <= 12; more triples may share a plane */

typedef struct ff_shaft {
    float lo[3], hi[3];   /* box around both patches, grown by the margin */
    rad_vec3 points[8];   /* the two patches' vertices */
    int point_count;
    int drop_behind;      /* the patch-plane rule applies (see above) */
    int plane_count;      /* hull planes; -1 = not built yet (built at the first triangle the box keeps) */
    double margin, delta, extent; /* margin: the float box; delta: the planes (ff_segment) */
    double n[FF_SHAFT_PLANES][3]; /* unit outward normals: inside is n.p <= d */
    double d[FF_SHAFT_PLANES];    /* offsets, grown by delta */
} ff_shaft;

static inline RAD_HD int ff_bvh_box_overlaps(const float a_lo[3], const float a_hi[3], const float b_lo[3],
                                             const float b_hi[3])
{
    return a_lo[0] <= b_hi[0] && b_lo[0] <= a_hi[0] && a_lo[1] <= b_hi[1] && b_lo[1] <= a_hi[1] &&
           a_lo[2] <= b_hi[2] && b_lo[2] <= a_hi[2];
}

/* Is every vertex of `a` on or in front of the plane of `b`? */
static inline RAD_HD int ff_patch_in_front(const rad_ff_patch *a, const rad_ff_patch *b)
{
    for (uint32_t k = 0; k < a->vertex_count; k++)
        if (rad_v3_dot(b->normal, rad_v3_sub(a->p[k], b->p[0])) < 0.0) return 0;
    return 1;
}

/* The planes of the convex hull of points p[0..count): every plane through
 * three of them that has all the others on one side (within tol). Brute
 * force over the <= 56 triples of <= 8 points; a plane found twice costs a
 * test, not correctness; past FF_SHAFT_PLANES the rest are dropped, which
 * only makes the shaft larger. */
static inline RAD_HD void ff_shaft_hull(ff_shaft *s, const rad_vec3 *p, int count, double tol, double margin)
{
    s->plane_count = 0;
    for (int a = 0; a < count; a++)
        for (int b = a + 1; b < count; b++)
            for (int c = b + 1; c < count; c++) {
                rad_vec3 n = rad_v3_cross(rad_v3_sub(p[b], p[a]), rad_v3_sub(p[c], p[a]));
                double len = rad_v3_length(n);
                if (!(len > tol * tol)) continue; /* (nearly) collinear */
                n = rad_v3_scale(n, 1.0 / len);
                double d = rad_v3_dot(n, p[a]);
                /* Most triples are not faces: the first points on both sides end the test. */
                int above = 0, below = 0;
                for (int k = 0; k < count && !(above && below); k++) {
                    double h = rad_v3_dot(n, p[k]) - d;
                    above |= h > tol;
                    below |= h < -tol;
                }
                if (above && below) continue;
                if (above) n = rad_v3_scale(n, -1.0), d = -d; /* outward: the points are below */
                if (s->plane_count == FF_SHAFT_PLANES) return;
                s->n[s->plane_count][0] = n.x, s->n[s->plane_count][1] = n.y, s->n[s->plane_count][2] = n.z;
                s->d[s->plane_count] = d + margin;
                s->plane_count++;
            }
}

/* The vertices of both patches (at most 8) into points; returns how many. */
static inline RAD_HD int ff_pair_vertices(const rad_ff_patch *pi, const rad_ff_patch *pj, rad_vec3 points[8])
{
    int count = 0;
    for (uint32_t k = 0; k < pi->vertex_count; k++) points[count++] = pi->p[k];
    for (uint32_t k = 0; k < pj->vertex_count; k++) points[count++] = pj->p[k];
    return count;
}

/* The shaft of pair (pi, pj); margin and delta in scene units. */
static inline RAD_HD void ff_shaft_build(const rad_ff_patch *pi, const rad_ff_patch *pj, float margin, double delta,
                                          int weighted, ff_shaft *s)
{
    s->drop_behind = weighted || (ff_patch_in_front(pi, pj) && ff_patch_in_front(pj, pi));
    rad_vec3 *points = s->points;
    int count = s->point_count = ff_pair_vertices(pi, pj, points);
    for (int a = 0; a < 3; a++) s->lo[a] = INFINITY, s->hi[a] = -INFINITY;
    double extent = 0;
    for (int k = 0; k < count; k++) {
        float v[3] = {(float)points[k].x, (float)points[k].y, (float)points[k].z};
        for (int a = 0; a < 3; a++) {
            s->lo[a] = fminf(s->lo[a], v[a]);
            s->hi[a] = fmaxf(s->hi[a], v[a]);
        }
    }
    for (int a = 0; a < 3; a++) {
        extent = fmax(extent, (double)s->hi[a] - s->lo[a]);
        s->lo[a] -= margin;
        s->hi[a] += margin;
    }
    s->plane_count = -1;
    s->margin = margin;
    s->delta = delta;
    s->extent = extent;
}

/* The hull planes, once a triangle inside the box makes them worth it
 * (building them costs about what 100 shadow rays do). */
static inline RAD_HD void ff_shaft_need_hull(ff_shaft *s)
{
    if (s->plane_count >= 0) return;
    ff_shaft_hull(s, s->points, s->point_count, 1e-9 * s->extent, s->delta);
}

/* Do the pair's points all lie on one side of the triangle's plane
 * (within delta)? */
static inline RAD_HD int ff_tri_plane_separates(const double v[3][3], const ff_shaft *s)
{
    rad_vec3 a = rad_v3(v[0][0], v[0][1], v[0][2]);
    rad_vec3 n = rad_v3_cross(rad_v3_sub(rad_v3(v[1][0], v[1][1], v[1][2]), a),
                              rad_v3_sub(rad_v3(v[2][0], v[2][1], v[2][2]), a));
    double len = rad_v3_length(n);
    if (!(len > 0.0)) return 0;
    double tol = s->delta * len;
    int front = 1, back = 1;
    for (int k = 0; k < s->point_count; k++) {
        double h = rad_v3_dot(n, rad_v3_sub(s->points[k], a));
        front &= h >= -tol;
        back &= h <= tol;
    }
    return front || back;
}

/* Is the triangle on or behind q's plane, within delta (where
 * ff_bvh_hit_tri counts no hit)? */
static inline RAD_HD int ff_tri_behind(const double v[3][3], const rad_ff_patch *q, double delta)
{
    for (int k = 0; k < 3; k++) {
        double h = rad_v3_dot(q->normal, rad_v3_sub(rad_v3(v[k][0], v[k][1], v[k][2]), q->p[0]));
        if (h > delta) return 0;
    }
    return 1;
}

/* Are all the points outside one hull plane? */
static inline RAD_HD int ff_shaft_separates(const ff_shaft *s, const double (*v)[3], int count)
{
    for (int p = 0; p < s->plane_count; p++) {
        int outside = 1;
        for (int k = 0; k < count && outside; k++)
            outside = s->n[p][0] * v[k][0] + s->n[p][1] * v[k][1] + s->n[p][2] * v[k][2] > s->d[p];
        if (outside) return 1;
    }
    return 0;
}

/* Is a whole box outside one hull plane (its corner nearest the plane is)? */
static inline RAD_HD int ff_shaft_separates_box(const ff_shaft *s, const float lo[3], const float hi[3])
{
    for (int p = 0; p < s->plane_count; p++) {
        double h = 0;
        for (int a = 0; a < 3; a++) h += s->n[p][a] * (s->n[p][a] > 0 ? lo[a] : hi[a]);
        if (h > s->d[p]) return 1;
    }
    return 0;
}

static inline RAD_HD int ff_tri_in_shaft(const ff_bvh_tri *t, ff_shaft *s, const rad_ff_patch *pi,
                                         const rad_ff_patch *pj)
{
    if (t->face == pi->face || t->face == pj->face) return 0;
    double v[3][3];
    float tlo[3], thi[3];
    for (int a = 0; a < 3; a++) {
        v[0][a] = t->v0[a];
        v[1][a] = t->v0[a] + t->e1[a];
        v[2][a] = t->v0[a] + t->e2[a];
        tlo[a] = (float)fmin(v[0][a], fmin(v[1][a], v[2][a]));
        thi[a] = (float)fmax(v[0][a], fmax(v[1][a], v[2][a]));
    }
    if (!ff_bvh_box_overlaps(tlo, thi, s->lo, s->hi)) return 0;
    if (s->drop_behind && (ff_tri_behind(v, pi, s->delta) || ff_tri_behind(v, pj, s->delta))) return 0;
    if (ff_tri_plane_separates(v, s)) return 0;
    ff_shaft_need_hull(s);
    return !ff_shaft_separates(s, (const double(*)[3])v, 3);
}

static inline RAD_HD int ff_bvh_leaf_in_shaft(const ff_bvh_tri *tris, int32_t ref, uint32_t count, ff_shaft *s,
                                              const rad_ff_patch *pi, const rad_ff_patch *pj)
{
    for (uint32_t k = 0; k < count; k++)
        if (ff_tri_in_shaft(&tris[~ref + (int32_t)k], s, pi, pj)) return 1;
    return 0;
}

static inline RAD_HD int ff_bvh_shaft_may_occlude(const ff_bvh_node *nodes, const ff_bvh_tri *tris, int32_t root,
                                                  uint32_t root_count, ff_shaft *s, const rad_ff_patch *pi,
                                                  const rad_ff_patch *pj)
{
    if (root < 0) return root_count ? ff_bvh_leaf_in_shaft(tris, root, root_count, s, pi, pj) : 0;
    int32_t stack[FF_BVH_STACK];
    int top = 0;
    stack[top++] = root;
    while (top > 0) {
        const ff_bvh_node *n = &nodes[stack[--top]];
        for (int c = 0; c < 2; c++) {
            const float *clo = c ? n->lo1 : n->lo0, *chi = c ? n->hi1 : n->hi0;
            int32_t child = c ? n->child1 : n->child0;
            uint32_t count = c ? n->count1 : n->count0;
            if (!ff_bvh_box_overlaps(clo, chi, s->lo, s->hi) || ff_shaft_separates_box(s, clo, chi)) continue;
            if (child < 0) {
                if (ff_bvh_leaf_in_shaft(tris, child, count, s, pi, pj)) return 1;
            } else if (top < FF_BVH_STACK) {
                stack[top++] = child;
            } else {
                return 1; /* cannot look further: assume it may */
            }
        }
    }
    return 0;
}

/* Must pair (pi, pj) trace its shadow rays? Not if no triangle is in its
 * shaft (see ff_tri_in_shaft). Any way of visiting the triangles gives the
 * same answer: this BVH walk, or a scan of all triangles. Without `hull`
 * the hull's planes are left out (a looser test, for tests); `weighted`:
 * only segments that carry weight count (the quadrature estimator). */
static inline RAD_HD int ff_pair_may_be_occluded(const ff_bvh_node *nodes, const ff_bvh_tri *tris, int32_t root,
                                                 uint32_t root_count, const rad_ff_patch *pi, const rad_ff_patch *pj,
                                                 float margin, double delta, int hull, int weighted)
{
    ff_shaft s;
    ff_shaft_build(pi, pj, margin, delta, weighted, &s);
    if (!hull) s.plane_count = 0; /* built, and empty */
    return ff_bvh_shaft_may_occlude(nodes, tris, root, root_count, &s, pi, pj);
}

#endif
