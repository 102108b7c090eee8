/* ff_fixture.h - scenes and whole-matrix runs shared by the form-factor
 * tests (CPU and CUDA). Static functions: include from one test file. */
#ifndef FF_FIXTURE_H
#define FF_FIXTURE_H

#include <stdlib.h>
#include <string.h>

#include "ff_backend.h"
#include "ff_rows.h"
#include "ff_setup.h"

/* Scenes served from memory through the loader's read_file hook. */
static const char *const scene_mtl = "newmtl grey\nKd 0.5 0.5 0.5\n";
static const char *const parallel_obj =
    "mtllib s.mtl\nusemtl grey\n"
    "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n"
    "v 0 0 1\nv 0 1 1\nv 1 1 1\nv 1 0 1\nf 5 6 7 8\n";
static const char *const perpendicular_obj =
    "mtllib s.mtl\nusemtl grey\n"
    "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n"
    "v 0 0 1\nv 0 1 1\nf 1 4 6 5\n";
/* The parallel pair with a 2x2 plate between them: nothing gets through. */
static const char *const blocked_obj =
    "mtllib s.mtl\nusemtl grey\n"
    "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n"
    "v 0 0 1\nv 0 1 1\nv 1 1 1\nv 1 0 1\nf 5 6 7 8\n"
    "v -0.5 -0.5 0.5\nv 1.5 -0.5 0.5\nv 1.5 1.5 0.5\nv -0.5 1.5 0.5\nf 9 10 11 12\n";

static const char *g_obj;

static rad_status read_memory(const char *path, char **out_data, size_t *out_size, void *user)
{
    (void)user;
    const char *text = strstr(path, ".mtl") ? scene_mtl : g_obj;
    *out_size = strlen(text);
    *out_data = malloc(*out_size + 1);
    memcpy(*out_data, text, *out_size + 1);
    return RAD_OK;
}

typedef struct fixture {
    rad_scene scene;
    rad_mesh mesh;
    rad_ff_patch *patches;
    double *triangles;
    uint32_t *triangle_face, triangle_count;
    double centre[3]; /* the frame (ff_frame_centre) */
} fixture;

static int fixture_load(fixture *fx, const char *obj_text, const char *path, int subdiv)
{
    memset(fx, 0, sizeof *fx);
    g_obj = obj_text;
    rad_scene_options so = {.read_file = obj_text ? read_memory : NULL};
    rad_mesh_options mo = {.subdiv = subdiv};
    if (rad_scene_load_file(path, &so, &fx->scene) != RAD_OK || rad_mesh_build(&fx->scene, &mo, &fx->mesh) != RAD_OK)
        return 0;
    ff_frame_centre(&fx->mesh, fx->centre);
    return ff_patches_build(&fx->scene, &fx->mesh, fx->centre, &fx->patches) == RAD_OK &&
           ff_occluders_build(&fx->scene, fx->centre, &fx->triangles, &fx->triangle_face, &fx->triangle_count) == RAD_OK;
}

static void fixture_free(fixture *fx)
{
    free(fx->patches);
    free(fx->triangles);
    free(fx->triangle_face);
    rad_mesh_free(&fx->mesh);
    rad_scene_free(&fx->scene);
}

/* Backend couplings of all N rows (and their errors, if not NULL) into
 * form factors, as the driver does (ff_rows_finish). */
static void to_form_factors(const fixture *fx, double *f, double *errors)
{
    uint32_t n = (uint32_t)fx->mesh.patch_count;
    ff_rows_summary unused = {0};
    double *area = malloc((n ? n : 1) * sizeof *area);
    if (!area) abort();
    for (uint32_t j = 0; j < n; j++) area[j] = fx->patches[j].area;
    ff_rows_finish(area, n, 0, n, f, errors, 1, &unused);
    free(area);
}

/* Settings beyond the common ones; zero = the defaults. */
typedef struct compute_extra {
    double target_error;
    uint32_t max_samples; /* 0 = 64 x samples */
    int pairs_once;       /* each pair by one row, then ff_rows_mirror_local */
    double **errors;      /* non-NULL: receives the standard errors of F (caller frees) */
} compute_extra;

/* The whole matrix F of a fixture (caller frees), or NULL on failure. */
static double *compute_full(const ff_backend *backend, const fixture *fx, uint32_t samples, uint32_t rays,
                            uint64_t seed, rad_estimator_id estimator, const compute_extra *extra,
                            ff_counters *counters)
{
    uint32_t n = (uint32_t)fx->mesh.patch_count;
    compute_extra none = {0};
    if (!extra) extra = &none;
    ff_setup su = {.patches = fx->patches, .patch_count = n, .triangles = fx->triangles,
                   .triangle_face = fx->triangle_face, .triangle_count = fx->triangle_count, .samples = samples,
                   .shadow_rays = rays, .seed = seed, .estimator = estimator, .plane_eps = ff_plane_eps(&fx->mesh), .threads = 2,
                   .cull = 1, .scene_convex = ff_scene_is_convex_enclosure(&fx->scene, ff_plane_eps(&fx->mesh)),
                   .cull_margin = ff_cull_margin(&fx->mesh, fx->centre, ff_plane_eps(&fx->mesh)), .ray_delta = ff_ray_delta(&fx->mesh), .target_error = extra->target_error,
                   .max_samples = extra->max_samples ? extra->max_samples : 64 * samples,
                   .pairs_once = extra->pairs_once};
    void *state = NULL;
    double *f = malloc(sizeof(double) * n * n);
    double *e = extra->errors ? malloc(sizeof(double) * n * n) : NULL;
    ff_counters local = {0};
    if (!f || (extra->errors && !e) || backend->create(&su, &state) != RAD_OK) {
        free(f);
        free(e);
        return NULL;
    }
    rad_status st = backend->compute_rows(state, 0, n, f, e, counters ? counters : &local);
    backend->destroy(state);
    if (st != RAD_OK) {
        free(f);
        free(e);
        return NULL;
    }
    if (extra->pairs_once) {
        ff_rows_mirror_local(n, 0, n, f, 2);
        if (e) ff_rows_mirror_local(n, 0, n, e, 2);
    }
    to_form_factors(fx, f, e);
    if (e) *extra->errors = e;
    return f;
}

/* The whole matrix of a fixture, one batch per pair, no errors. */
static double *compute_estimator(const ff_backend *backend, const fixture *fx, uint32_t samples, uint32_t rays,
                                 uint64_t seed, rad_estimator_id estimator, ff_counters *counters)
{
    return compute_full(backend, fx, samples, rays, seed, estimator, NULL, counters);
}

/* The plain point-pair estimator (the paper's, corrected). */
static inline double *compute_with(const ff_backend *backend, const fixture *fx, uint32_t samples, uint32_t rays,
                            uint64_t seed, ff_counters *counters)
{
    return compute_estimator(backend, fx, samples, rays, seed, RAD_ESTIMATOR_MC, counters);
}

#endif
