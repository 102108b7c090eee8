/* ff_openness.c - how open each face is (ff_openness.h). */
#include "ff_openness.h"

#include <math.h>

#include "ff_bvh.h"
#include "rad_box.h"
#include "rad_ff_visibility.h"
#include "rad_rng.h"

/* A cos-weighted direction about the unit n from two numbers in [0, 1). */
static rad_vec3 cos_direction(rad_vec3 n, double u, double v)
{
    rad_vec3 t = rad_v3_orthonormal(fabs(n.x) < 0.6 ? (rad_vec3){1, 0, 0} : (rad_vec3){0, 1, 0}, n);
    rad_vec3 b = rad_v3_cross(n, t);
    double r = sqrt(u), phi = 2.0 * RAD_PI * v, h = sqrt(fmax(0.0, 1.0 - u));
    return rad_v3_add(rad_v3_add(rad_v3_scale(t, r * cos(phi)), rad_v3_scale(b, r * sin(phi))), rad_v3_scale(n, h));
}

rad_status ff_openness(const rad_ff_patch *patches, uint32_t count, const double *triangles,
                       const uint32_t *triangle_face, uint32_t triangle_count, double delta, float *open)
{
    if (count == 0) return RAD_OK;
    rad_box box = rad_box_empty();
    for (uint32_t f = 0; f < count; f++)
        for (uint32_t k = 0; k < patches[f].vertex_count; k++)
            rad_box_add(&box, (const double[3]){patches[f].p[k].x, patches[f].p[k].y, patches[f].p[k].z});
    const double reach = FF_OPEN_REACH * rad_box_diagonal(&box);
    ff_bvh bvh;
    rad_status st = ff_bvh_build(triangles, triangle_face, triangle_count, &bvh);
    if (st != RAD_OK) return st;
#pragma omp parallel for schedule(dynamic, 256)
    for (int64_t f = 0; f < (int64_t)count; f++) {
        const rad_ff_patch *p = &patches[f];
        const rad_u32x4 key = rad_ff_vis_key((uint32_t)f, (uint32_t)f, 0x6f70656eull); /* "open" */
        uint32_t clear = 0, last = FF_BVH_NO_HIT;
        for (uint32_t r = 0; r < FF_OPEN_RAYS; r++) {
            double u = rad_u01(rad_owen_scramble(rad_sobol4(r, 0), key.v[0]));
            double v = rad_u01(rad_owen_scramble(rad_sobol4(r, 1), key.v[1]));
            double s = rad_u01(rad_owen_scramble(rad_sobol4(r, 2), key.v[2]));
            double t = rad_u01(rad_owen_scramble(rad_sobol4(r, 3), key.v[3]));
            rad_vec3 x = rad_ff_sample_point(p, u, v);
            rad_vec3 w = cos_direction(p->normal, s, t);
            rad_vec3 y = rad_v3_add(x, rad_v3_scale(w, reach));
            /* the far end on no face, its plane facing back at x */
            ff_segment seg = ff_segment_make(x, p->normal, p->face, y, rad_v3_scale(w, -1.0), UINT32_MAX, delta);
            clear += !ff_bvh_occluded_cached(bvh.nodes, bvh.tris, bvh.root, bvh.root_count, &seg, &last);
        }
        open[f] = (float)clear / (float)FF_OPEN_RAYS;
    }
    ff_bvh_free(&bvh);
    return RAD_OK;
}
