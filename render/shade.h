/* shade.h - colours at patch corners from per-patch radiosity.
 *
 * Smooth shading (the classic radiosity look): the colour at corner k of
 * patch p is the area-weighted mean radiosity of the patches around that
 * vertex that lie on the same smooth surface as p: normals within
 * RAD_CREASE_DEGREES of p's and the same material (rho and emission
 * equal; rad_same_surface in core/rad_adjacency.h). So values blend across
 * the seams of a subdivided wall but never around a wall corner, a block's
 * edge, or from the light into the ceiling.
 *
 * Conforming: where a refined patch meets an unrefined one (formfactor
 * --refine) a vertex of the fine patches lies inside the coarse patch's
 * edge (a T-vertex; contact cutting leaves them too). The coarse patch
 * interpolates linearly along that edge, so the fine patches' corners at
 * the T-vertex take that same interpolated value (longest edges first,
 * repeated until nothing moves where both sides of a line have vertices
 * inside the other's edges): the two sides agree along the whole edge and
 * the image has no seam.
 * The raster stage then interpolates the corners across the patch
 * (Gouraud). Emitters show their radiosity B = E + reflected, like any patch.
 *
 * Flat shading gives every corner the patch's own radiosity.
 *
 * Channels: 3 gives RGB corners; 1 gives channel 0 (B_r) alone, for grey
 * scenes, whose files store the one solved channel in all three (and for
 * luminance, which render stores the same way: tonemap.h).
 */
#ifndef RENDER_SHADE_H
#define RENDER_SHADE_H

#include "rad_mesh.h"
#include "rad_status.h"

typedef enum render_shading {
    RENDER_SHADING_SMOOTH = 0,
    RENDER_SHADING_FLAT = 1,
    RENDER_SHADING_LINEAR = 2
} render_shading;

/* "smooth", "flat", "linear" (--shading and the EXR's rad:shading). */
const char *render_shading_name(render_shading shading);

/* radiosity: patch_count * 3 (RGB per patch, as in the radiosity file).
 * channels: 3 or 1 (channel 0 only). out_corners: the caller's buffer of
 * patch_count * 4 * channels doubles, corner k of patch p at
 * (4 * p + k) * channels; corner 3 of a triangle is left 0. Fails only for
 * lack of memory (RAD_ERR_NOMEM), patches that are not triangles or quads
 * or have vertex indices out of range, or a channel count other than 1 or 3
 * (RAD_ERR_INVALID). */
rad_status render_shade_corners(const rad_mesh *mesh, const double *radiosity, int channels, render_shading shading,
                                double *out_corners);

/* The OBJ's smoothing groups (`s N`; Blender's Shade Smooth writes `s 1`)
 * by the scene's face (rad_patch.source_face): patches of faces in one
 * group (not 0) with the same material blend across their shared corners
 * whatever the angle between them, as a path tracer shades the surface
 * with interpolated normals; other patches as above. */
typedef struct render_smoothing {
    const uint32_t *face_group; /* face_count entries: 0 = flat */
    size_t face_count;
} render_smoothing;

/* render_shade_corners with smoothing groups (NULL: none). */
rad_status render_shade_corners_smoothed(const rad_mesh *mesh, const double *radiosity, int channels,
                                         render_shading shading, const render_smoothing *smoothing,
                                         double *out_corners);

#endif
