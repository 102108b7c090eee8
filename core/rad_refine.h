/* rad_refine.h - error-driven refinement of a patch mesh from a solution.
 *
 * Usage (formfactor --refine):
 *     rad_refine_options opt = rad_refine_defaults();
 *     uint8_t *split = malloc(mesh.patch_count);
 *     rad_refine_stats stats;
 *     rad_refine_mark(&mesh, radiosity, &opt, split, &stats);
 *     rad_mesh refined;
 *     rad_refine_split(&mesh, split, &refined, NULL);
 *
 * Where the mesh is too coarse: render reconstructs radiosity linearly
 * between patch corners (render/shade.h), so what a patch's neighbours
 * cannot predict linearly is the error left. The indicator of patch p is
 *     d_p = | Y_p - sum_q w_q Y_q / sum_q w_q |,   w_q = 1 / |c_q - c_p|^2,
 * over the patches q of p's smooth surface (normals within 1 degree, same
 * material: the surfaces render smooths over) that share a corner with p;
 * Y is the Rec. 709 luminance of B and c the centroids. d_p is measured
 * against the scene's reflected mean Ybar (area-weighted mean of Y over
 * the patches that do not emit). Radiosity linear across a surface gives
 * d = 0 inside it; shadow edges, penumbrae, contact lines and the
 * gradients running into corners (where the neighbours lie on one side)
 * give d > 0 that does not vanish as patches shrink. (A plain jump
 * max |Y_p - Y_q| also splits smooth gradients, which linear shading draws
 * well: on the Cornell box it reached relative RMSE 0.045 with 2402
 * patches where this reaches 0.036 with 2561; docs/accuracy.md.)
 *
 * A patch is split when d_p > tolerance * Ybar and its size sqrt(area) is
 * at least min_size * (scene bounding-box diagonal). When max_patches
 * limits the result, the patches with the largest d_p^2 * area (their
 * share of the squared image error) go first. Then a balance pass splits
 * neighbours (same surface, sharing a corner) that would end up more than
 * twice as large as a split patch's children, so that render's T-vertex
 * anchoring interpolates over short edges only.
 *
 * Splitting is one level: a quad into 4 through its edge midpoints and the
 * mean of its corners, a triangle into 4 through its edge midpoints, as
 * rad_mesh_build subdivides (rad_polygon_split). Midpoints are shared
 * between split patches; an unsplit neighbour keeps its edge, which leaves
 * a T-vertex that render anchors (render/shade.h). Children keep the parent's source face,
 * material and group, and come where the parent was (patch order is
 * kept); new vertices follow the old ones.
 */
#ifndef RAD_REFINE_H
#define RAD_REFINE_H

#include <stddef.h>
#include <stdint.h>

#include "rad_mesh.h"
#include "rad_status.h"

typedef struct rad_refine_options {
    double tolerance;   /* split where d_p > tolerance * Ybar (> 0) */
    double min_size;    /* no split below sqrt(area) = min_size * scene diagonal */
    size_t max_patches; /* 0 = no limit; else at most this many patches after the split
                           (before the balance pass, which may add a few) */
} rad_refine_options;

/* tolerance 0.05, min_size 1/128, max_patches 0. */
rad_refine_options rad_refine_defaults(void);

typedef struct rad_refine_stats {
    size_t marked;        /* patches over the tolerance, large enough to split */
    size_t too_small;     /* over the tolerance but at min_size */
    size_t over_budget;   /* marked but left for max_patches */
    size_t balanced;      /* split by the balance pass */
    size_t split;         /* total split */
    size_t patches_after; /* patch_count + 3 * split */
    double mean_luminance;  /* Ybar */
    double max_indicator;   /* max d_p / Ybar */
} rad_refine_stats;

/* radiosity: patch_count * 3 (RGB per patch). out_split: patch_count bytes,
 * 1 = split. Fails with RAD_ERR_INVALID for a bad option or a mesh whose
 * patches are not triangles or quads, RAD_ERR_NOMEM for lack of memory. */
rad_status rad_refine_mark(const rad_mesh *mesh, const double *radiosity, const rad_refine_options *options,
                           uint8_t *out_split, rad_refine_stats *out_stats);

/* The mesh with every patch p where split[p] != 0 split once. out_parent
 * (optional, malloc'ed, patches_after entries): the input patch each output
 * patch came from. Groups are copied. */
rad_status rad_refine_split(const rad_mesh *mesh, const uint8_t *split, rad_mesh *out_mesh, uint32_t **out_parent);

#endif
