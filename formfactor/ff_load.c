/* ff_load.c - the scene and the refined mesh of a formfactor run
 * (ff_load.h): the loader's file reader that keeps outputs out of the
 * inputs, the warning for a scene without light, --refine's split and
 * --reuse's checked matrix. */
#include "ff_load.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "ff_backend.h"
#include "rad_enclosure.h"
#include "rad_ffile.h"
#include "rad_fs.h"
#include "rad_log.h"
#include "rad_rfile.h"

/* The loader reads the OBJ and each mtllib through here: none of them may
 * be an output of this run (`-o scene.mtl` would replace the scene's
 * materials). */
static rad_status read_scene_file(const char *path, char **out_data, size_t *out_size, void *user)
{
    const ff_options *o = user;
    rad_fs_role roles[] = {{"the scene's file", path, 0}, {"-o", o->radiosity_path ? NULL : o->output, 1},
                           {"--radiosity", o->radiosity_path, 1}, {"--stats", o->stats_path, 1},
                           {"--errors", o->errors_path, 1}};
    *out_data = NULL;
    if (rad_fs_check_roles(roles, sizeof roles / sizeof roles[0]) != RAD_OK) return RAD_ERR_USAGE;
    return rad_fs_read_all(path, out_data, out_size);
}

/* Before any work: a scene where no face emits gives solve nothing to
 * spread, so its image will be black (docs/reliability.md). The matrix is
 * still computed and written: it serves uses without light (thermal
 * exchange, view factors). */
static void warn_if_dark(const rad_scene *scene)
{
    for (size_t f = 0; f < scene->face_count; f++) {
        const double *e = scene->materials[scene->faces[f].material].emission;
        if (e[0] > 0 || e[1] > 0 || e[2] > 0) return;
    }
    rad_warn("%s: no face emits light (no material it uses has Ke > 0), so solve's radiosity and render's image "
             "will be black; the form factors are computed and written all the same. " RAD_SCENE_NO_LIGHT_HINT,
             scene->path);
}

/* A room modelled from a closed mesh whose faces point outward, with
 * objects or lights inside (rad_enclosure.h): light escapes through its
 * back faces and its walls render black (issue 30: 98 % of the light
 * escaped, no message anywhere). Refused, naming the flag that fixes it,
 * unless the run flips normals or says --keep-normals, or every face is
 * wound against its vn (the loader then names --flip-normals). */
static rad_status check_enclosure(const ff_options *options, const rad_scene *scene)
{
    rad_enclosure shell;
    if (options->keep_normals || options->flip_normals || options->flip_groups ||
        (scene->vn_face_count > 0 && scene->vn_against_count == scene->vn_face_count) || /* the loader said
                                                              --flip-normals: every face is against its vn */
        !rad_enclosure_find_outward(scene, &shell))
        return RAD_OK;
    const char *name = scene->groups[shell.group];
    char flag[RAD_NAME_MAX + 2]; /* the name as a shell takes it */
    snprintf(flag, sizeof flag, strpbrk(name, " \t'\"") ? "'%s'" : "%s", name);
    rad_error("%s:%u: object '%s' (%zu faces) encloses every other face, and %.0f%% of its area faces outward, "
              "away from them: seen from inside, where the light is, it is invisible, so light escapes through "
              "it and its walls render black. A room modelled from Blender's cube needs its normals flipped: "
              "run formfactor with --flip-group %s (only that object; --flip-normals would turn the objects "
              "inside it inside out), or in Blender select it, Edit Mode, Mesh > Normals > Flip, and export "
              "again; --keep-normals runs the scene as it is",
              scene->path, shell.line, name, shell.face_count, 100 * shell.outward_fraction, flag);
    return RAD_ERR_INVALID;
}

rad_status ff_load_scene(const ff_options *options, rad_scene *out_scene)
{
    rad_scene_options loader = {.read_file = read_scene_file, .read_file_user = (void *)options,
                                .clamp_rho = options->clamp_rho, .flip_normals = options->flip_normals,
                                .flip_groups = options->flip_groups, .ke_radiance = options->ke_radiance};
    rad_status st = options->scene_path ? rad_scene_load_file(options->scene_path, &loader, out_scene)
                                        : rad_scene_load_default(out_scene);
    if (st == RAD_OK && (st = check_enclosure(options, out_scene)) != RAD_OK) rad_scene_free(out_scene);
    if (st == RAD_OK && options->flip_groups)
        rad_info("%s: --flip-group %s: those objects' faces wound the other way round", out_scene->path,
                 options->flip_groups);
    if (st == RAD_OK) warn_if_dark(out_scene);
    if (st == RAD_OK && options->ke_radiance)
        rad_info("%s: Ke read as emitted radiance L (--ke radiance): E = pi Ke", out_scene->path);
    return st;
}

/* Largest old matrix --reuse holds in memory (N_old^2 doubles); above it
 * every pair is computed. */
#define FF_REUSE_MAX_BYTES (2.0 * 1024 * 1024 * 1024)

/* --reuse: the old matrix F (N_old x N_old) is a form-factor matrix as
 * formfactor writes it, or it is refused naming the first entry that is
 * not (row, column, value): every entry finite, >= 0 and at most 1 (to the
 * rounding of float32 sums: FF_REUSE_F_SLACK); and, reciprocal by
 * construction (RAD_FF_FLAG_RECIPROCAL), c_ij = F_ij / A_j equal to
 * c_ji = F_ji / A_i to the element type's rounding (FF_REUSE_C_RTOL, plus
 * float32's smallest step divided by the areas for subnormal entries).
 * The checksums only say that the file is as written; this says that
 * what was written are form factors. */
#define FF_REUSE_F_SLACK 1e-6
#define FF_REUSE_C_RTOL 1e-6
static rad_status check_reused(const char *path, const rad_mesh *mesh, const double *F, int reciprocal)
{
    size_t n = mesh->patch_count;
    for (size_t i = 0; i < n; i++)
        for (size_t j = 0; j < n; j++) {
            double f = F[i * n + j];
            const char *why = !isfinite(f) ? "not a finite number"
                            : f < 0 ? "negative"
                            : f > 1 + FF_REUSE_F_SLACK ? "above 1" : NULL;
            if (why) {
                rad_error("--reuse %s: F[%zu][%zu] = %.9g is %s; a form factor is a fraction in [0, 1], so the file "
                          "is damaged or not formfactor's; refused",
                          path, i, j, f, why);
                return RAD_ERR_INVALID;
            }
        }
    if (!reciprocal) return RAD_OK;
    for (size_t i = 0; i < n; i++)
        for (size_t j = i + 1; j < n; j++) {
            double ai = mesh->patches[i].area, aj = mesh->patches[j].area;
            double cij = F[i * n + j] / aj, cji = F[j * n + i] / ai;
            double slack = FF_REUSE_C_RTOL * (cij > cji ? cij : cji) + 1.5e-45 * (1 / ai + 1 / aj);
            if (fabs(cij - cji) > slack) {
                rad_error("--reuse %s: F[%zu][%zu] = %.9g and F[%zu][%zu] = %.9g break reciprocity (A_i F_ij = "
                          "%.9g, A_j F_ji = %.9g), which the file says holds by construction; it is damaged; refused",
                          path, i, j, F[i * n + j], j, i, F[j * n + i], ai * F[i * n + j], aj * F[j * n + i]);
                return RAD_ERR_INVALID;
            }
        }
    return RAD_OK;
}

/* --reuse: the couplings c = F / A_column of `mesh` (the mesh refined
 * from) out of its form-factor file, one value per unordered pair (taken
 * from the entry above the diagonal, so that c_ij = c_ji to the bit), and
 * each new patch's old index where it was not split. */
static rad_status load_reuse(const ff_options *opt, const rad_mesh *mesh, const rad_mesh *refined,
                             const uint8_t *split, const uint32_t *parent, ff_refinement *out)
{
    const char *path = opt->reuse_path;
    size_t n_old = mesh->patch_count, n = refined->patch_count;
    if ((double)n_old * (double)n_old * sizeof(double) > FF_REUSE_MAX_BYTES) {
        rad_warn("--reuse %s: %zu patches' matrix is more than 2 GiB in memory; computing every pair", path, n_old);
        return RAD_OK;
    }
    rad_ff_file *file = NULL;
    rad_status st = rad_ff_open(path, &file);
    if (st != RAD_OK) return st;
    const rad_ff_info *info = rad_ff_file_info(file);
    const rad_mesh *stored = rad_ff_file_mesh(file);
    if (stored->patch_count != n_old || stored->vertex_count != mesh->vertex_count ||
        memcmp(stored->positions, mesh->positions, 3 * mesh->vertex_count * sizeof *mesh->positions) != 0 ||
        memcmp(stored->patches, mesh->patches, n_old * sizeof *mesh->patches) != 0) {
        rad_error("--reuse %s: not the form factors of the mesh of %s (patches or vertices differ)", path,
                  opt->refine_path);
        st = RAD_ERR_INVALID;
    } else if (info->flags & RAD_FF_FLAG_STANDARD_ERRORS) {
        rad_error("--reuse %s: holds standard errors, not form factors", path);
        st = RAD_ERR_INVALID;
    } else if (info->layout == RAD_FF_LAYOUT_LINKS) {
        rad_error("--reuse %s: holds links (formfactor --method hierarchical), not a matrix to reuse", path);
        st = RAD_ERR_INVALID;
    } else if (info->estimator != (uint32_t)opt->estimator || info->shadow_rays != opt->shadow_rays ||
               info->samples != opt->samples) {
        rad_error("--reuse %s: computed with --estimator %s --samples %u --shadow-rays %u, this run with %s %u %u; "
                  "reuse needs the same settings", path, rad_estimator_name((rad_estimator_id)info->estimator),
                  info->samples, info->shadow_rays, rad_estimator_name(opt->estimator), opt->samples,
                  opt->shadow_rays);
        st = RAD_ERR_INVALID;
    } else if (info->seed != opt->seed) {
        rad_error("--reuse %s: computed with --seed %llu, this run with --seed %llu; reuse needs the same settings",
                  path, (unsigned long long)info->seed, (unsigned long long)opt->seed);
        st = RAD_ERR_INVALID;
    } else if (info->element_type != (uint32_t)opt->element) {
        rad_error("--reuse %s: stored as --element %s, this run writes --element %s; reuse needs the same settings",
                  path, ff_element_name((rad_element_type)info->element_type), ff_element_name(opt->element));
        st = RAD_ERR_INVALID;
    }
    double *matrix = NULL;
    uint32_t *old = NULL;
    if (st == RAD_OK) {
        matrix = malloc(n_old * n_old * sizeof *matrix);
        old = malloc((n ? n : 1) * sizeof *old);
        if (!matrix || !old) {
            rad_error("--reuse %s: out of memory for its %zu x %zu matrix", path, n_old, n_old);
            st = RAD_ERR_NOMEM;
        }
    }
    if (st == RAD_OK) st = rad_ff_read_rows(file, 0, n_old, matrix);
    if (st == RAD_OK) st = check_reused(path, mesh, matrix, info->flags & RAD_FF_FLAG_RECIPROCAL);
    rad_ff_close(file);
    if (st != RAD_OK) {
        free(matrix);
        free(old);
        return st;
    }
    for (size_t a = 0; a < n_old; a++) {
        matrix[a * n_old + a] = 0.0;
        for (size_t b = a + 1; b < n_old; b++)
            matrix[b * n_old + a] = matrix[a * n_old + b] = matrix[a * n_old + b] / mesh->patches[b].area;
    }
    for (size_t i = 0; i < n; i++) old[i] = split[parent[i]] ? FF_REUSE_NONE : parent[i];
    out->reuse_old = old;
    out->reuse_coupling = matrix;
    return RAD_OK;
}

/* Why a solution's mesh (`prev`, read from a radiosity file) is not of
 * this run's scene, for the message: the first difference found, patch by
 * patch, against its source face - wound the other way (--flip-normals),
 * another Kd (--clamp-rho, or an edited MTL), another Ke, a face this
 * scene lacks, or else the geometry. */
static void explain_other_scene(const ff_options *opt, const rad_scene *sc, const rad_mesh *prev, char *out,
                                size_t size)
{
    for (size_t p = 0; p < prev->patch_count; p++) {
        const rad_patch *pa = &prev->patches[p];
        if (pa->source_face >= sc->face_count) {
            snprintf(out, size, "its patch %zu comes from face %u, and this scene has %zu faces (another OBJ)", p,
                     pa->source_face, sc->face_count);
            return;
        }
        const rad_face *f = &sc->faces[pa->source_face];
        double nx = 0, ny = 0, nz = 0; /* Newell's normal of the face as this run wound it */
        for (uint32_t k = 0; k < f->vertex_count; k++) {
            const double *a = &sc->positions[3 * (size_t)f->v[k]];
            const double *b = &sc->positions[3 * (size_t)f->v[(k + 1) % f->vertex_count]];
            nx += (a[1] - b[1]) * (a[2] + b[2]);
            ny += (a[2] - b[2]) * (a[0] + b[0]);
            nz += (a[0] - b[0]) * (a[1] + b[1]);
        }
        if (nx * pa->normal.x + ny * pa->normal.y + nz * pa->normal.z < 0) {
            snprintf(out, size, "its faces are wound the other way round (face %u, OBJ line %u): %s",
                     pa->source_face, f->line,
                     opt->flip_normals ? "this run has --flip-normals and that solution's formfactor run did not"
                                           : "that solution's formfactor run had --flip-normals and this one does not");
            return;
        }
        const rad_material *m = &sc->materials[f->material];
        for (int c = 0; c < 3; c++) {
            if (m->rho[c] != pa->rho[c]) {
                snprintf(out, size, "material '%s' has Kd %g %g %g here and %g %g %g there (another --clamp-rho%s, or "
                         "an edited MTL)", m->name, m->rho[0], m->rho[1], m->rho[2], pa->rho[0], pa->rho[1],
                         pa->rho[2], opt->clamp_rho > 0 ? "" : ": this run has none");
                return;
            }
            if (m->emission[c] != pa->emission[c]) {
                snprintf(out, size, "material '%s' has E %g %g %g here and %g %g %g there (an edited MTL, or "
                         "another --ke: radiance reads E = pi Ke)", m->name,
                         m->emission[0], m->emission[1], m->emission[2], pa->emission[0], pa->emission[1],
                         pa->emission[2]);
                return;
            }
        }
    }
    snprintf(out, size, "the same faces and materials, so the geometry differs (moved vertices, or another OBJ)");
}

/* Every rank reads the file and computes the same split. */
rad_status ff_load_refined_mesh(const ff_options *opt, const rad_scene *scene, rad_mesh *out_mesh,
                                ff_refinement *out_refinement)
{
    rad_radiosity prev;
    const char *path = opt->refine_path;
    rad_status st = rad_rf_read(path, &prev);
    if (st != RAD_OK) return st;
    uint8_t *split = NULL;
    uint32_t *parent = NULL;
    rad_mesh mesh = {0};
    ff_refinement refinement = {0};
    if (prev.scene_fingerprint != scene->fingerprint) {
        char why[512];
        explain_other_scene(opt, scene, &prev.mesh, why, sizeof why);
        rad_error("%s: solved for another scene (fingerprint %016llx) than %s (%016llx): %s; refine the solution of "
                  "the same scene, loaded with the same settings", path, (unsigned long long)prev.scene_fingerprint,
                  scene->path, (unsigned long long)scene->fingerprint, why);
        st = RAD_ERR_INVALID;
        goto done;
    }
    for (size_t p = 0; p < prev.mesh.patch_count; p++)
        if (prev.mesh.patches[p].source_face >= scene->face_count) {
            rad_error("%s: patch %zu names face %u of %zu", path, p, prev.mesh.patches[p].source_face,
                      scene->face_count);
            st = RAD_ERR_INVALID;
            goto done;
        }
    if ((st = rad_mesh_set_groups(scene, &prev.mesh)) != RAD_OK) goto done;
    split = malloc(prev.mesh.patch_count ? prev.mesh.patch_count : 1);
    if (!split) {
        rad_error("out of memory refining %zu patches", prev.mesh.patch_count);
        st = RAD_ERR_NOMEM;
        goto done;
    }
    const rad_refine_options *ro = &opt->refine;
    rad_refine_stats rs;
    if ((st = rad_refine_mark(&prev.mesh, prev.radiosity, ro, split, &rs)) != RAD_OK) goto done;
    if ((st = rad_refine_split(&prev.mesh, split, &mesh, &parent)) != RAD_OK) goto done;
    if (opt->reuse_path && (st = load_reuse(opt, &prev.mesh, &mesh, split, parent, &refinement)) != RAD_OK) goto done;
    refinement.stats = rs;
    refinement.patches_before = prev.mesh.patch_count;
    rad_info("refine %s: %zu of %zu patches split (%zu over --refine-tol %g, %zu more to balance, %zu at the "
             "smallest size, %zu over --refine-max-patches): %zu patches; largest jump %.3g x the mean",
             path, rs.split, prev.mesh.patch_count, rs.marked - rs.over_budget, ro->tolerance, rs.balanced,
             rs.too_small, rs.over_budget, rs.patches_after, rs.max_indicator);
    *out_mesh = mesh;
    *out_refinement = refinement;
done:
    if (st != RAD_OK) {
        rad_mesh_free(&mesh);
        ff_refinement_free(&refinement);
    }
    free(split);
    free(parent);
    rad_radiosity_free(&prev);
    return st;
}

void ff_refinement_free(ff_refinement *refinement)
{
    free(refinement->reuse_old);
    free(refinement->reuse_coupling);
    refinement->reuse_old = NULL;
    refinement->reuse_coupling = NULL;
}
