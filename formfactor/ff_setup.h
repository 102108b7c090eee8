/* ff_setup.h - from scene and mesh to the flat arrays the backends read,
 * and the split of rows among ranks. */
#ifndef FF_SETUP_H
#define FF_SETUP_H

#include <stdint.h>

#include "rad_ff_kernel.h"
#include "rad_mesh.h"
#include "rad_scene.h"
#include "rad_status.h"

/* The frame the backends compute in: the scene moved so that the centre
 * of its bounding box is the origin. Form factors do not depend on where
 * the scene is, but float shadow rays do: a room 300 m from the origin
 * has float end points 0.03 mm apart, and rays that graze a face touching
 * their patch then clip it (a spurious hit; culling, which reasons in
 * exact geometry, would then change the bytes). Patches and occluders are
 * built in this frame; the files keep the scene's own coordinates. */
void ff_frame_centre(const rad_mesh *mesh, double centre[3]);

/* One rad_ff_patch per mesh patch, moved by -centre, each corner that is
 * not one of its source face's own vertices put into that face's plane
 * (caller frees *out_patches). */
rad_status ff_patches_build(const rad_scene *scene, const rad_mesh *mesh, const double centre[3],
                            rad_ff_patch **out_patches);

/* One patch of that array: `p` (its corners index `positions`, xyz per
 * vertex, scene coordinates), moved and put into its face's plane as
 * ff_patches_build does; for the elements of a hierarchy (ff_links.h). */
void ff_patch_make(const rad_scene *scene, const double *positions, const rad_patch *p, const double centre[3],
                   rad_ff_patch *out);

/* Occluders: every scene face as triangles (a quad gives two),
 * moved by -centre, with the face each came from. Caller frees both arrays. */
rad_status ff_occluders_build(const rad_scene *scene, const double centre[3], double **out_triangles,
                              uint32_t **out_triangle_face, uint32_t *out_triangle_count);

/* Is the scene one convex enclosure seen from inside (every vertex on or
 * in front of every face's plane)? Then no face can come between two
 * others and no shadow ray is needed. */
int ff_scene_is_convex_enclosure(const rad_scene *scene, double eps);

/* Is the scene closed: does every face's hemisphere meet other faces'
 * fronts only (ff_closed.c)? FF_CLOSED_RAYS rays from each patch of the
 * base mesh (cosine-distributed from points spread over it) to their first
 * hit among the occluders (ff_occluders_build's, moved by -centre), which
 * must exist and face the ray. closed 0 as soon as one ray escapes or
 * meets a back: open_patch is such a patch (the lowest found), escaped
 * whether its ray met nothing. RAD_ERR_NOMEM (the BVH). Threads:
 * OpenMP's. The scene's closure (rad_closure.h) is off where it is not. */
#define FF_CLOSED_RAYS 16u
typedef struct ff_closed_result {
    int closed;
    uint64_t rays;      /* cast (every patch's when closed) */
    int64_t open_patch; /* -1 when closed */
    int escaped;        /* open_patch's failing ray met nothing (else a back) */
} ff_closed_result;
rad_status ff_scene_is_closed(const rad_mesh *base, const double centre[3], const double *triangles,
                              const uint32_t *triangle_face, uint32_t triangle_count, ff_closed_result *out);

/* Tolerance of the facing test: 1e-11 of the scene's bounding-box diagonal
 * (rounding, not geometry: faces 1e-9 of the scene apart face each other;
 * pieces of one face never do, rad_ff_pair_facing). */
double ff_plane_eps(const rad_mesh *mesh);

/* How far the culling tests grow a pair's float shaft box (scene units):
 * float rounding grows with the size of the coordinates, not of the
 * scene, so: the larger of 1e4 eps and 8 float ulps of the largest
 * coordinate (a room 1 km from the origin). */
float ff_cull_margin(const rad_mesh *mesh, const double centre[3], double eps);

/* The shadow segments' delta (ff_segment in ff_bvh.h): FF_RAY_DELTA of the
 * scene's bounding-box diagonal. */
double ff_ray_delta(const rad_mesh *mesh);

/* Splits rows 0..n-1 into `ranks` contiguous blocks of about equal work
 * (for ranks that hold all their rows: reciprocity on; streamed rows go
 * to the ranks block-cyclically, ff_plan.h):
 * row i costs the number of columns facing it, estimated on a fixed,
 * evenly spaced subset of at most FF_PARTITION_PROBES columns (so the split
 * is cheap and the same on every rank). out_begin has ranks + 1 entries;
 * rank r owns [out_begin[r], out_begin[r + 1]). */
#define FF_PARTITION_PROBES 512
rad_status ff_partition_rows(const rad_ff_patch *patches, uint32_t n, double eps, int ranks, uint32_t *out_begin);

#endif
