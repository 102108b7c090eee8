/* ff_load.h - the scene and, with --refine, the patch mesh of a
 * formfactor run: the OBJ (or the built-in Cornell box) read with the
 * run's outputs kept out of its inputs, and the mesh of a solution split
 * where it is too coarse (core/rad_refine.h), with --reuse's couplings for
 * the pairs it left whole.
 *
 *     rad_scene scene;
 *     rad_mesh mesh;
 *     ff_refinement refinement;
 *     if (ff_load_scene(&options, &scene) == RAD_OK &&
 *         ff_load_refined_mesh(&options, &scene, &mesh, &refinement) == RAD_OK) {
 *         ...
 *         ff_refinement_free(&refinement);
 *         rad_mesh_free(&mesh);
 *     }
 *     rad_scene_free(&scene);
 *
 * The plain mesh (--subdiv) is core's rad_mesh_build: the driver checks a
 * run's limits between counting its patches and building it. No MPI here:
 * every rank loads the same and logs as any rank would (the driver
 * silences all but rank 0).
 */
#ifndef FF_LOAD_H
#define FF_LOAD_H

#include <stddef.h>
#include <stdint.h>

#include "ff_options.h"
#include "rad_mesh.h"
#include "rad_refine.h"
#include "rad_scene.h"
#include "rad_status.h"

/* What --refine made besides the mesh. */
typedef struct ff_refinement {
    rad_refine_stats stats; /* what was split */
    size_t patches_before;  /* patches of the mesh refined from */
    uint32_t *reuse_old;    /* --reuse: each new patch's index in the old mesh where it was not
                               split, else FF_REUSE_NONE (ff_backend.h); NULL: none reused */
    double *reuse_coupling; /* --reuse: c = F / A_column of the old mesh, patches_before^2,
                               symmetric (one value per unordered pair); NULL with reuse_old */
} ff_refinement;

/* The scene of options->scene_path (NULL: the built-in box), loaded with
 * --clamp-rho and --flip-normals; none of the files it reads (the OBJ,
 * each mtllib) may be an output of this run. Warns when no face emits
 * light. *out_scene is set on success. */
rad_status ff_load_scene(const ff_options *options, rad_scene *out_scene);

/* --refine: the mesh of options->refine_path (a solution of `scene`, or
 * refused saying how it differs) with each patch split where the solution
 * says (options->refine), and, with options->reuse_path, that file's
 * couplings (refused unless it holds the form factors of that mesh,
 * computed with this run's settings). Logs what was split. Both outputs
 * are set only on success; the caller frees them (rad_mesh_free,
 * ff_refinement_free). */
rad_status ff_load_refined_mesh(const ff_options *options, const rad_scene *scene, rad_mesh *out_mesh,
                                ff_refinement *out_refinement);

/* Frees what ff_load_refined_mesh allocated; a zeroed one is fine. */
void ff_refinement_free(ff_refinement *refinement);

#endif
