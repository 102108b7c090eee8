/* ff_closed.c - is the scene closed (ff_setup.h)? Every face's hemisphere
 * must meet other faces' fronts only: rays from each patch of the base
 * mesh, cosine-distributed from points spread over it, each to its first
 * hit on the occluder BVH (ff_bvh.h), which must exist and face the ray.
 * A ray that escapes or meets a back (a light modelled as one quad, seen
 * from the ceiling behind it; an open box) says no. A closed scene has no
 * such ray, so it always passes; an open one passes only if every hole and
 * back is too small for FF_CLOSED_RAYS rays a face to find, and then the
 * closure's rows of 1 are off by about that fraction of a face's view.
 *
 * The first hit walks the BVH's boxes against the segment cut at the
 * nearest hit so far (ff_bvh_hit_box_before); a triangle counts where
 * ff_bvh_tri_t meets it more than delta in front of the origin's plane
 * (the origin's face skipped), and
 * its front is the side its corners turn counter-clockwise to, the
 * face's own normal (ff_occluders_build keeps each face's winding). */
#include <math.h>
#include <stdlib.h>

#include "ff_bvh.h"
#include "ff_setup.h"
#include "rad_box.h"
#include "rad_log.h"
#include "rad_math.h"
#include "rad_rng.h"

#define FF_CLOSED_KEY 0x636c6f73u /* "clos": the rays' Philox key */

static void leaf_first(const ff_bvh *b, int32_t ref, uint32_t count, const ff_segment *s, double *best,
                       const ff_bvh_tri **hit)
{
    for (uint32_t k = 0; k < count; k++) {
        const ff_bvh_tri *t = &b->tris[~ref + (int32_t)k];
        if (t->face == s->skip_a) continue;
        const double tt = ff_bvh_tri_t(t, s); /* in front of the origin's plane by more than delta */
        if (tt > 0.0 && tt <= 1.0 && tt * s->rise_a > s->delta && tt < *best) *best = tt, *hit = t;
    }
}

/* The segment's first hit, NULL for none. */
static const ff_bvh_tri *first_hit(const ff_bvh *b, const ff_segment *s)
{
    double best = INFINITY;
    const ff_bvh_tri *hit = NULL;
    if (b->root < 0) {
        leaf_first(b, b->root, b->root_count, s, &best, &hit);
        return hit;
    }
    int32_t stack[FF_BVH_STACK];
    int top = 0;
    stack[top++] = b->root;
    while (top > 0) {
        const ff_bvh_node *n = &b->nodes[stack[--top]];
        const float t_max = best < 1 ? (float)best : 1.0f;
        if (ff_bvh_hit_box_before(n->lo0, n->hi0, s->fo, s->inv_fd, t_max)) {
            if (n->child0 < 0) leaf_first(b, n->child0, n->count0, s, &best, &hit);
            else if (top < FF_BVH_STACK) stack[top++] = n->child0;
        }
        if (ff_bvh_hit_box_before(n->lo1, n->hi1, s->fo, s->inv_fd, t_max)) {
            if (n->child1 < 0) leaf_first(b, n->child1, n->count1, s, &best, &hit);
            else if (top < FF_BVH_STACK) stack[top++] = n->child1;
        }
    }
    return hit;
}

/* Ray k of patch p: a point of the patch (its triangles by area) and a
 * cosine-distributed direction, from Philox(p, k). */
static void patch_ray(const rad_mesh *m, uint32_t p, uint32_t k, rad_vec3 *point, rad_vec3 *dir)
{
    const rad_patch *pa = &m->patches[p];
    rad_u32x4 r = rad_philox4x32((rad_u32x4){{p, k, 0, 0}}, FF_CLOSED_KEY, 0);
    double u1 = rad_u01(r.v[0]), u2 = rad_u01(r.v[1]), u3 = rad_u01(r.v[2]), u4 = rad_u01(r.v[3]);
    rad_vec3 v[4] = {{0, 0, 0}, {0, 0, 0}, {0, 0, 0}, {0, 0, 0}};
    for (uint32_t c = 0; c < pa->vertex_count && c < 4; c++) {
        const double *x = &m->positions[3 * (size_t)pa->v[c]];
        v[c] = rad_v3(x[0], x[1], x[2]);
    }
    rad_vec3 a = v[0], b = v[1], c = v[2];
    if (pa->vertex_count == 4) {
        const double first = rad_v3_length(rad_v3_cross(rad_v3_sub(v[1], v[0]), rad_v3_sub(v[2], v[0]))),
                     second = rad_v3_length(rad_v3_cross(rad_v3_sub(v[2], v[0]), rad_v3_sub(v[3], v[0])));
        const double cut = first + second > 0 ? first / (first + second) : 1;
        if (u1 < cut) {
            u1 = u1 / cut;
        } else {
            u1 = (u1 - cut) / (1 - cut);
            b = v[2], c = v[3];
        }
    }
    const double su = sqrt(u1); /* uniform on the triangle */
    *point = rad_v3_add(rad_v3_scale(a, 1 - su), rad_v3_add(rad_v3_scale(b, su * (1 - u2)), rad_v3_scale(c, su * u2)));
    const rad_vec3 n = pa->normal;
    const rad_vec3 t = rad_v3_normalize(fabs(n.x) > 0.5 ? rad_v3_cross(n, rad_v3(0, 1, 0)) : rad_v3_cross(n, rad_v3(1, 0, 0)));
    const rad_vec3 bt = rad_v3_cross(n, t);
    const double rr = sqrt(u3), phi = 2 * RAD_PI * u4;
    *dir = rad_v3_add(rad_v3_add(rad_v3_scale(t, rr * cos(phi)), rad_v3_scale(bt, rr * sin(phi))),
                      rad_v3_scale(n, sqrt(1 - u3)));
}

rad_status ff_scene_is_closed(const rad_mesh *base, const double centre[3], const double *triangles,
                              const uint32_t *triangle_face, uint32_t triangle_count, ff_closed_result *out)
{
    ff_closed_result r = {.closed = 0};
    ff_bvh bvh;
    rad_status st = ff_bvh_build(triangles, triangle_face, triangle_count, &bvh);
    if (st != RAD_OK) return st;
    rad_box box = rad_box_of_points(base->positions, base->vertex_count);
    const double length = 2 * rad_box_diagonal(&box) + 1e-300, delta = ff_ray_delta(base);
    const rad_vec3 shift = rad_v3(centre[0], centre[1], centre[2]);
    const int64_t patches = (int64_t)base->patch_count;
    uint64_t failed = 0, cast = 0;
    int64_t first = -1;
    int first_escaped = 0; /* how first's ray failed */
#pragma omp parallel for schedule(dynamic, 256) reduction(+ : failed, cast)
    for (int64_t p = 0; p < patches; p++) {
        int64_t seen;
#pragma omp atomic read
        seen = first;
        if (seen >= 0) continue; /* one open patch decides */
        const rad_patch *pa = &base->patches[p];
        for (uint32_t k = 0; k < FF_CLOSED_RAYS; k++) {
            rad_vec3 x, d;
            patch_ray(base, (uint32_t)p, k, &x, &d);
            x = rad_v3_sub(x, shift);
            const rad_vec3 y = rad_v3_add(x, rad_v3_scale(d, length));
            ff_segment s = ff_segment_make(x, pa->normal, pa->source_face, y, rad_v3_scale(d, -1), UINT32_MAX, delta);
            cast++;
            const ff_bvh_tri *t = first_hit(&bvh, &s);
            int open = !t;
            if (t) {
                const rad_vec3 e1 = rad_v3(t->e1[0], t->e1[1], t->e1[2]), e2 = rad_v3(t->e2[0], t->e2[1], t->e2[2]);
                open = rad_v3_dot(rad_v3_cross(e1, e2), d) >= 0; /* its back */
            }
            if (open) {
                failed++;
#pragma omp critical(ff_closed_first)
                {
                    int64_t now;
#pragma omp atomic read
                    now = first;
                    if (now < 0 || p < now) {
                        first_escaped = !t;
#pragma omp atomic write
                        first = p;
                    }
                }
                break;
            }
        }
    }
    ff_bvh_free(&bvh);
    r.closed = failed == 0 && patches > 0;
    r.rays = cast;
    r.open_patch = first;
    r.escaped = first_escaped;
    *out = r;
    return RAD_OK;
}
