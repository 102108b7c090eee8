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
 * points), so the result depends on nothing but the scene. */
#ifndef FF_OPENNESS_H
#define FF_OPENNESS_H

#include <stdint.h>

#include "rad_ff_kernel.h"
#include "rad_status.h"

/* Rays per face. */
#define FF_OPEN_RAYS 32u
/* How far a ray must go unblocked: this fraction of the scene's diagonal
 * (the bounding box of the faces). */
#define FF_OPEN_REACH 0.125

/* open[f] in [0, 1] for patches 0 .. count - 1 (the roots, in the frame
 * the occluder triangles are in); delta as ff_segment's. Builds and frees a
 * BVH of the triangles. RAD_ERR_NOMEM (logged). */
rad_status ff_openness(const rad_ff_patch *patches, uint32_t count, const double *triangles,
                       const uint32_t *triangle_face, uint32_t triangle_count, double delta, float *open);

#endif
