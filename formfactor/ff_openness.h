/* ff_openness.h - how open each face is to the room beyond its near
 * surroundings (issue 27, docs/hierarchy.md "Clusters partly hidden").
 *
 *     float *open = malloc(count * sizeof *open);
 *     ff_openness(patches, count, triangles, triangle_face, triangle_count, delta, open);
 *
 * A cluster receiver gathers one irradiance for all its faces. Where some
 * of them are hidden at close range (a ceiling 1 cm above a lamp, a wall
 * behind a row of books) they take their share of what the open ones
 * should have had, and the open ones, which the camera sees, come out
 * dark. Face f's openness is the share of FF_OPEN_RAYS rays from points
 * drawn by area on f, in directions drawn by cos (what f receives from a
 * uniform surrounding), that meet no face within FF_OPEN_REACH of the
 * scene's size: 1 in the open,
 * about 1/2 at the foot of a wall, near 0 under a lamp. The links refuse
 * a cluster whose faces' openness spreads more than --cluster-open
 * (ff_cluster_bound_mixed), as --cluster-cone refuses faces facing apart.
 *
 * Every number is drawn from the face's index (Owen-scrambled Sobol'
 * points), so the result depends on nothing but the scene. A face's rays
 * are ff_face_openness, the same code on the host (ff_openness) and in a
 * backend's kernel (ff_backend.openness: 32 M rays at 10^6 faces, 2.1 s
 * on 16 host threads of an H200 machine). */
#ifndef FF_OPENNESS_H
#define FF_OPENNESS_H

#include <math.h>
#include <stdint.h>

#include "ff_bvh.h"
#include "rad_ff_kernel.h"
#include "rad_ff_visibility.h"
#include "rad_status.h"

/* Rays per face. */
#define FF_OPEN_RAYS 32u
/* How far a ray must go unblocked: this fraction of the scene's diagonal
 * (the bounding box of the faces). */
#define FF_OPEN_REACH 0.125

/* A cos-weighted direction about the unit n from two numbers in [0, 1). */
static inline RAD_HD rad_vec3 ff_open_direction(rad_vec3 n, double u, double v)
{
    rad_vec3 t = rad_v3_orthonormal(fabs(n.x) < 0.6 ? rad_v3(1, 0, 0) : rad_v3(0, 1, 0), n);
    rad_vec3 b = rad_v3_cross(n, t);
    double r = sqrt(u), phi = 2.0 * RAD_PI * v, h = sqrt(fmax(0.0, 1.0 - u));
    return rad_v3_add(rad_v3_add(rad_v3_scale(t, r * cos(phi)), rad_v3_scale(b, r * sin(phi))), rad_v3_scale(n, h));
}

/* Face f's openness: the share of its FF_OPEN_RAYS rays of length `reach`
 * that no triangle of the BVH stops. */
static inline RAD_HD float ff_face_openness(const rad_ff_patch *p, uint32_t f, double reach, double delta,
                                            const ff_bvh_node *nodes, const ff_bvh_tri *tris, int32_t root,
                                            uint32_t root_count)
{
    const rad_u32x4 key = rad_ff_vis_key(f, f, 0x6f70656eull); /* "open" */
    uint32_t clear = 0, last = FF_BVH_NO_HIT;
    for (uint32_t r = 0; r < FF_OPEN_RAYS; r++) {
        double u = rad_u01(rad_owen_scramble(rad_sobol4(r, 0), key.v[0]));
        double v = rad_u01(rad_owen_scramble(rad_sobol4(r, 1), key.v[1]));
        double s = rad_u01(rad_owen_scramble(rad_sobol4(r, 2), key.v[2]));
        double t = rad_u01(rad_owen_scramble(rad_sobol4(r, 3), key.v[3]));
        rad_vec3 x = rad_ff_sample_point(p, u, v);
        rad_vec3 w = ff_open_direction(p->normal, s, t);
        rad_vec3 y = rad_v3_add(x, rad_v3_scale(w, reach));
        /* the far end on no face, its plane facing back at x */
        ff_segment seg = ff_segment_make(x, p->normal, p->face, y, rad_v3_scale(w, -1.0), UINT32_MAX, delta);
        clear += !ff_bvh_occluded_cached(nodes, tris, root, root_count, &seg, &last);
    }
    return (float)clear / (float)FF_OPEN_RAYS;
}

/* The rays' length: FF_OPEN_REACH of the diagonal of the patches' box. */
double ff_openness_reach(const rad_ff_patch *patches, uint32_t count);

/* open[f] = ff_face_openness for patches 0 .. count - 1 through a built
 * BVH, on the host's threads (the CPU backend's ff_backend.openness). */
void ff_openness_bvh(const rad_ff_patch *patches, uint32_t count, double reach, double delta, const ff_bvh *bvh,
                     float *open);

/* open[f] in [0, 1] for patches 0 .. count - 1 (the roots, in the frame
 * the occluder triangles are in); delta as ff_segment's. Builds and frees a
 * BVH of the triangles (the tests' reference: the links take the
 * backend's, which holds one already). RAD_ERR_NOMEM (logged). */
rad_status ff_openness(const rad_ff_patch *patches, uint32_t count, const double *triangles,
                       const uint32_t *triangle_face, uint32_t triangle_count, double delta, float *open);

#endif
