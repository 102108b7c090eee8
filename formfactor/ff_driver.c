/* ff_driver.c - one formfactor run (ff_driver.h): load and check the
 * scene, set up the backend, the estimate line, the rounds of rows and
 * their collective writes, the order in which the files are committed,
 * progress lines and the stats. */
#define _GNU_SOURCE /* sched_getaffinity */
#include "ff_driver.h"

#include <inttypes.h>
#include <math.h>
#include <sched.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/statvfs.h>
#include <unistd.h>

#include "ff_backend.h"
#include "ff_cuda.h"
#include "ff_output.h"
#include "ff_plan.h"
#include "ff_rows.h"
#include "ff_setup.h"
#include "ff_stats.h"
#include "rad_ffile.h"
#include "rad_fs.h"
#include "rad_log.h"
#include "rad_mesh.h"
#include "rad_refine.h"
#include "rad_rfile.h"
#include "rad_scene.h"

/* Shared by every rank: what the run computes with. */
typedef struct ff_run {
    ff_comm *comm;
    ff_options opt;
    rad_scene scene;
    rad_mesh mesh;
    rad_ff_patch *patches;
    double *area; /* the patches' areas, contiguous: ff_rows_finish reads one per entry */
    double *triangles;
    uint32_t *triangle_face, triangle_count;
    uint32_t *row_begin; /* ranks + 1 */
    const ff_backend *backend;
    void *backend_state;
    /* check_limits (rank 0, before the mesh), then setup (every rank,
     * after the split; pairs_once the same on every rank). */
    ff_plan plan;
    int gpus;        /* CUDA devices this process sees; 0 with --backend cpu (not asked) */
    int want_errors; /* standard errors computed (not --no-errors) */
    ff_rank_stats stats;
    rad_refine_stats refine;      /* --refine: what was split */
    size_t refine_patches_before; /* --refine: patches of its mesh */
    uint32_t *reuse_old;          /* --reuse: ff_setup.reuse_old, or NULL */
    double *reuse_coupling;       /* --reuse: ff_setup.reuse_coupling */
    double start;
    /* Progress (report_progress): this rank's rows done (of plan.rank_rows)
     * before the current backend call, the rows it has added to the shared
     * counter, when, and (rank 0) when it last reported, every how many
     * seconds, and whether to a terminal (one line that updates).
     * calibrating: no reports. */
    uint32_t progress_base, progress_round_end; /* rows before this backend call, and after it */
    uint64_t progress_added;
    double progress_added_at, progress_said_at, progress_every, compute_start;
    double estimated_seconds; /* estimate(): the calibration's forecast, or -1 */
    int progress_tty, calibrating;
} ff_run;

/* The files of a run: the matrix, and its standard errors on request. */
typedef struct ff_files {
    ff_output *matrix;
    ff_output *errors; /* NULL without --errors */
} ff_files;

/* "1.2 s", "3 min 20 s", "33 h 10 min". */
static const char *format_seconds(double s, char *out, size_t size)
{
    if (!(s < 1e9)) snprintf(out, size, "longer than 30 years");
    else if (s < 0.01) snprintf(out, size, "%.1f ms", 1e3 * s);
    else if (s < 60) snprintf(out, size, "%.2g s", s);
    else if (s < 3600) snprintf(out, size, "%d min %d s", (int)(s / 60), (int)fmod(s, 60));
    else snprintf(out, size, "%d h %d min", (int)(s / 3600), (int)fmod(s / 60, 60));
    return out;
}

/* "1.23 GiB": bytes as double, since refused sizes overflow 64 bits. */
static const char *format_bytes(double bytes, char *out, size_t size)
{
    static const char *const units[] = {"bytes", "KiB", "MiB", "GiB", "TiB", "PiB", "EiB", "ZiB"};
    int u = 0;
    while (bytes >= 1024 && u < 7) bytes /= 1024, u++;
    snprintf(out, size, u ? "%.3g %s" : "%.0f %s", bytes, units[u]);
    return out;
}

/* The backends' progress callback, on every rank: adds this rank's rows to
 * the shared counter at most once a second; rank 0 reports the whole run's
 * rows every progress_every seconds (about 40 lines per run, at least
 * 2 s apart; on a terminal one line, updated twice a second). */
static void report_progress(void *user, uint64_t rows_done)
{
    ff_run *run = user;
    if (run->calibrating) return;
    double t = ff_comm_time();
    uint64_t done = run->progress_base + rows_done;
    /* at most once a second, and at the end of each round (the other
     * ranks' counts then reach rank 0 round by round) */
    if (done > run->progress_added && (t - run->progress_added_at >= 1.0 || done == run->progress_round_end)) {
        ff_comm_progress_add(run->comm, done - run->progress_added);
        run->progress_added = done;
        run->progress_added_at = t;
    }
    if (ff_comm_rank(run->comm) != 0 || t - run->progress_said_at < run->progress_every) return;
    run->progress_said_at = t;
    double fraction = (double)ff_comm_progress_read(run->comm) / (double)(run->mesh.patch_count ? run->mesh.patch_count : 1);
    double elapsed = t - run->compute_start;
    /* The first rows say little about the rest: until 5 % are done, the
     * calibration's forecast (which sampled the whole matrix) holds. */
    double to_go = fraction > 0 ? elapsed * (1 - fraction) / fraction : -1;
    if (fraction < 0.05 && run->estimated_seconds >= 0)
        to_go = run->estimated_seconds > elapsed ? run->estimated_seconds - elapsed : 0;
    char took[32], left[32];
    const char *format = run->progress_tty ? "\r%s%.1f%% of the rows (%d rank(s)), %s elapsed, about %s to go\033[K"
                                           : "%s%.1f%% of the rows (%d rank(s)), %s elapsed, about %s to go";
    char line[256];
    snprintf(line, sizeof line, format, run->progress_tty ? "formfactor: " : "", 100 * fraction, ff_comm_size(run->comm),
             format_seconds(elapsed, took, sizeof took),
             to_go >= 0 ? format_seconds(to_go, left, sizeof left) : "?");
    if (run->progress_tty && rad_log_get_level() >= RAD_LOG_INFO) {
        fputs(line, stderr); /* the one line that updates; ended before the next message (run_formfactor) */
        fflush(stderr);
    } else {
        rad_info("%s", line);
    }
}

static int default_threads(const ff_run *run)
{
    if (run->opt.threads > 0) return run->opt.threads;
    const char *env = getenv("OMP_NUM_THREADS");
    if (env && atoi(env) > 0) return atoi(env);
    /* The cores this rank may run on (mpirun binds ranks to cores by
     * default), and no more than its share of the node. */
    long cores = sysconf(_SC_NPROCESSORS_ONLN);
    long t = cores / ff_comm_node_size(run->comm);
    cpu_set_t mask;
    if (sched_getaffinity(0, sizeof mask, &mask) == 0 && CPU_COUNT(&mask) < t) t = CPU_COUNT(&mask);
    return t > 0 ? (int)t : 1;
}

/* Physical memory of this node divided among the ranks on it (bytes). */
static double memory_per_rank(const ff_run *run)
{
    long pages = sysconf(_SC_PHYS_PAGES), page = sysconf(_SC_PAGESIZE);
    int node_ranks = ff_comm_node_size(run->comm) > 0 ? ff_comm_node_size(run->comm) : 1;
    return pages > 0 && page > 0 ? (double)pages * (double)page / node_ranks : INFINITY;
}

static ff_plan_choices plan_choices(const ff_options *o)
{
    return (ff_plan_choices){.element = o->element, .format = o->format, .errors_file = o->errors_path != NULL,
                             .standard_errors = !o->no_errors, .reciprocity = o->reciprocity,
                             .backend = o->backend, .max_bytes = o->max_bytes,
                             .allow_disk_overcommit = o->allow_disk_overcommit};
}

/* Rank 0, before the mesh is built: plans the run and refuses, with the
 * numbers, one whose patch count exceeds the format, whose file would not
 * fit in the free space of the output's file system or under --max-bytes,
 * or whose memory per rank would exceed this node's memory per rank. */
static rad_status check_limits(ff_run *run, uint64_t n)
{
    char dir[4096];
    const char *slash = strrchr(run->opt.output, '/');
    if (slash)
        snprintf(dir, sizeof dir, "%.*s", slash == run->opt.output ? 1 : (int)(slash - run->opt.output), run->opt.output);
    else
        snprintf(dir, sizeof dir, ".");
    struct statvfs fs; /* no answer: opening the output fails later and says why */
    double free_bytes = statvfs(dir, &fs) == 0 ? (double)fs.f_bavail * (double)fs.f_frsize : INFINITY;
    double per_rank = memory_per_rank(run);
    ff_plan_limits limits = {.patch_count = n, .ranks = ff_comm_size(run->comm), .rank = 0,
                             .memory_per_rank = per_rank, .free_bytes = free_bytes,
                             .max_rows_per_write = ff_output_max_rows(n, run->opt.format, run->opt.element)};
    ff_plan_choices choices = plan_choices(&run->opt);
    ff_plan_make(&limits, &choices, &run->plan);
    const ff_plan *plan = &run->plan;
    char why[4400] = "", have[32];
    if (plan->refusal == FF_PLAN_ACCEPTED && run->opt.format == FF_FORMAT_SPARSE && plan->file_bytes > free_bytes) {
        char bound[32];
        rad_warn("%s has %s free and the sparse file may need up to %s (all N^2 entries); most scenes need a "
                 "tenth of that, and a full disk stops the run with nothing left behind",
                 dir, format_bytes(free_bytes, have, sizeof have), format_bytes(plan->file_bytes, bound, sizeof bound));
    }
    switch (plan->refusal) {
    case FF_PLAN_ACCEPTED: return RAD_OK;
    case FF_PLAN_TOO_MANY_PATCHES:
        snprintf(why, sizeof why, "more than the format's limit of %" PRIu64 " patches", FF_MAX_PATCHES);
        break;
    case FF_PLAN_DISK:
        if (run->opt.format == FF_FORMAT_SPARSE)
            snprintf(why, sizeof why, "%s has %s free, less than a tenth of that bound (the sparse file is often a "
                     "tenth of it: --allow-disk-overcommit runs anyway; a full disk stops the run, old output kept)",
                     dir, format_bytes(free_bytes, have, sizeof have));
        else
            snprintf(why, sizeof why, "%s has %s free", dir, format_bytes(free_bytes, have, sizeof have));
        break;
    case FF_PLAN_MAX_BYTES:
        snprintf(why, sizeof why, "--max-bytes is %s", format_bytes(run->opt.max_bytes, have, sizeof have));
        break;
    case FF_PLAN_MEMORY:
        snprintf(why, sizeof why, "this node has %s per rank (%d rank(s) on it)",
                 format_bytes(per_rank, have, sizeof have),
                 ff_comm_node_size(run->comm) > 0 ? ff_comm_node_size(run->comm) : 1);
        break;
    }
    char need[32], mem[32];
    rad_error("%s: %" PRIu64 " patches: %s would need %s (N^2 x %.0f bytes) and each rank about %s "
              "of memory, but %s; refused (--element f32 halves the file; each --subdiv level less divides it by 16)",
              run->opt.refine_path ? "--refine" : "--subdiv", n, run->opt.output,
              format_bytes(plan->file_bytes, need, sizeof need),
              plan->element_bytes, format_bytes(plan->memory_bytes, mem, sizeof mem), why);
    return RAD_ERR_NOMEM;
}

/* The loader reads the OBJ and each mtllib through here: none of them may
 * be an output of this run (`-o scene.mtl` would replace the scene's
 * materials). */
static rad_status read_scene_file(const char *path, char **out_data, size_t *out_size, void *user)
{
    const ff_options *o = user;
    rad_fs_role roles[] = {{"the scene's file", path, 0}, {"-o", o->output, 1}, {"--stats", o->stats_path, 1},
                           {"--errors", o->errors_path, 1}};
    *out_data = NULL;
    if (rad_fs_check_roles(roles, sizeof roles / sizeof roles[0]) != RAD_OK) return RAD_ERR_USAGE;
    return rad_fs_read_all(path, out_data, out_size);
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
static rad_status load_reuse(ff_run *run, const rad_mesh *mesh, const uint8_t *split, const uint32_t *parent)
{
    const char *path = run->opt.reuse_path;
    size_t n_old = mesh->patch_count, n = run->mesh.patch_count;
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
                  run->opt.refine_path);
        st = RAD_ERR_INVALID;
    } else if (info->flags & RAD_FF_FLAG_STANDARD_ERRORS) {
        rad_error("--reuse %s: holds standard errors, not form factors", path);
        st = RAD_ERR_INVALID;
    } else if (info->estimator != (uint32_t)run->opt.estimator || info->shadow_rays != run->opt.shadow_rays ||
               info->samples != run->opt.samples) {
        rad_error("--reuse %s: computed with --estimator %s --samples %u --shadow-rays %u, this run with %s %u %u; "
                  "reuse needs the same settings", path, rad_estimator_name((rad_estimator_id)info->estimator),
                  info->samples, info->shadow_rays, rad_estimator_name(run->opt.estimator), run->opt.samples,
                  run->opt.shadow_rays);
        st = RAD_ERR_INVALID;
    } else if (info->seed != run->opt.seed) {
        rad_error("--reuse %s: computed with --seed %llu, this run with --seed %llu; reuse needs the same settings",
                  path, (unsigned long long)info->seed, (unsigned long long)run->opt.seed);
        st = RAD_ERR_INVALID;
    } else if (info->element_type != (uint32_t)run->opt.element) {
        rad_error("--reuse %s: stored as --element %s, this run writes --element %s; reuse needs the same settings",
                  path, ff_element_name((rad_element_type)info->element_type), ff_element_name(run->opt.element));
        st = RAD_ERR_INVALID;
    }
    double *matrix = NULL;
    if (st == RAD_OK) {
        matrix = malloc(n_old * n_old * sizeof *matrix);
        run->reuse_old = malloc((n ? n : 1) * sizeof *run->reuse_old);
        if (!matrix || !run->reuse_old) {
            rad_error("--reuse %s: out of memory for its %zu x %zu matrix", path, n_old, n_old);
            st = RAD_ERR_NOMEM;
        }
    }
    if (st == RAD_OK) st = rad_ff_read_rows(file, 0, n_old, matrix);
    if (st == RAD_OK) st = check_reused(path, mesh, matrix, info->flags & RAD_FF_FLAG_RECIPROCAL);
    rad_ff_close(file);
    if (st != RAD_OK) {
        free(matrix);
        free(run->reuse_old);
        run->reuse_old = NULL;
        return st;
    }
    for (size_t a = 0; a < n_old; a++) {
        matrix[a * n_old + a] = 0.0;
        for (size_t b = a + 1; b < n_old; b++)
            matrix[b * n_old + a] = matrix[a * n_old + b] = matrix[a * n_old + b] / mesh->patches[b].area;
    }
    for (size_t i = 0; i < n; i++) run->reuse_old[i] = split[parent[i]] ? FF_REUSE_NONE : parent[i];
    run->reuse_coupling = matrix;
    return RAD_OK;
}

/* Why a solution's mesh (`prev`, read from a radiosity file) is not of
 * this run's scene, for the message: the first difference found, patch by
 * patch, against its source face - wound the other way (--flip-normals),
 * another Kd (--clamp-rho, or an edited MTL), another Ke, a face this
 * scene lacks, or else the geometry. */
static void explain_other_scene(const ff_run *run, const rad_mesh *prev, char *out, size_t size)
{
    const rad_scene *sc = &run->scene;
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
                     run->opt.flip_normals ? "this run has --flip-normals and that solution's formfactor run did not"
                                           : "that solution's formfactor run had --flip-normals and this one does not");
            return;
        }
        const rad_material *m = &sc->materials[f->material];
        for (int c = 0; c < 3; c++) {
            if (m->rho[c] != pa->rho[c]) {
                snprintf(out, size, "material '%s' has Kd %g %g %g here and %g %g %g there (another --clamp-rho%s, or "
                         "an edited MTL)", m->name, m->rho[0], m->rho[1], m->rho[2], pa->rho[0], pa->rho[1],
                         pa->rho[2], run->opt.clamp_rho > 0 ? "" : ": this run has none");
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

/* --refine: the mesh of a solution of this scene, split where the
 * solution says it is too coarse (core/rad_refine.h). Every rank reads the
 * file and computes the same split. */
static rad_status refine_mesh(ff_run *run)
{
    rad_radiosity prev;
    const char *path = run->opt.refine_path;
    rad_status st = rad_rf_read(path, &prev);
    if (st != RAD_OK) return st;
    uint8_t *split = NULL;
    uint32_t *parent = NULL;
    if (prev.scene_fingerprint != run->scene.fingerprint) {
        char why[512];
        explain_other_scene(run, &prev.mesh, why, sizeof why);
        rad_error("%s: solved for another scene (fingerprint %016llx) than %s (%016llx): %s; refine the solution of "
                  "the same scene, loaded with the same settings", path, (unsigned long long)prev.scene_fingerprint,
                  run->scene.path, (unsigned long long)run->scene.fingerprint, why);
        st = RAD_ERR_INVALID;
        goto done;
    }
    for (size_t p = 0; p < prev.mesh.patch_count; p++)
        if (prev.mesh.patches[p].source_face >= run->scene.face_count) {
            rad_error("%s: patch %zu names face %u of %zu", path, p, prev.mesh.patches[p].source_face,
                      run->scene.face_count);
            st = RAD_ERR_INVALID;
            goto done;
        }
    if ((st = rad_mesh_set_groups(&run->scene, &prev.mesh)) != RAD_OK) goto done;
    split = malloc(prev.mesh.patch_count ? prev.mesh.patch_count : 1);
    if (!split) {
        rad_error("out of memory refining %zu patches", prev.mesh.patch_count);
        st = RAD_ERR_NOMEM;
        goto done;
    }
    rad_refine_options ro = {.tolerance = run->opt.refine_tol, .min_size = run->opt.refine_min_size,
                             .max_patches = (size_t)run->opt.refine_max_patches};
    rad_refine_stats rs;
    if ((st = rad_refine_mark(&prev.mesh, prev.radiosity, &ro, split, &rs)) != RAD_OK) goto done;
    if ((st = rad_refine_split(&prev.mesh, split, &run->mesh, &parent)) != RAD_OK) goto done;
    if (run->opt.reuse_path && (st = load_reuse(run, &prev.mesh, split, parent)) != RAD_OK) goto done;
    run->refine = rs;
    run->refine_patches_before = prev.mesh.patch_count;
    if (ff_comm_rank(run->comm) == 0)
        rad_info("refine %s: %zu of %zu patches split (%zu over --refine-tol %g, %zu more to balance, %zu at the "
                 "smallest size, %zu over --refine-max-patches): %zu patches; largest jump %.3g x the mean",
                 path, rs.split, prev.mesh.patch_count, rs.marked - rs.over_budget, ro.tolerance, rs.balanced,
                 rs.too_small, rs.over_budget, rs.patches_after, rs.max_indicator);
done:
    free(split);
    free(parent);
    rad_radiosity_free(&prev);
    return st;
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
             "will be black; the form factors are computed and written all the same", scene->path);
}

static rad_status load(ff_run *run)
{
    double t0 = ff_comm_time();
    rad_scene_options loader = {.read_file = read_scene_file, .read_file_user = &run->opt,
                                .clamp_rho = run->opt.clamp_rho, .flip_normals = run->opt.flip_normals,
                                .ke_radiance = run->opt.ke_radiance};
    rad_status st = run->opt.scene_path ? rad_scene_load_file(run->opt.scene_path, &loader, &run->scene)
                                        : rad_scene_load_default(&run->scene);
    double t1 = ff_comm_time();
    if (st == RAD_OK && ff_comm_rank(run->comm) == 0) warn_if_dark(&run->scene);
    if (st == RAD_OK && ff_comm_rank(run->comm) == 0 && run->opt.ke_radiance)
        rad_info("%s: Ke read as emitted radiance L (--ke radiance): E = pi Ke", run->scene.path);
    rad_mesh_options mo = {.subdiv = run->opt.subdiv, .only_group = run->opt.subdiv_only,
                           .contacts = run->opt.contacts};
    if (run->opt.refine_path) {
        /* The refined mesh is small beside its matrix: built first, then checked. */
        if (st == RAD_OK) st = refine_mesh(run);
        if (st == RAD_OK && ff_comm_rank(run->comm) == 0) st = check_limits(run, run->mesh.patch_count);
    } else {
        uint64_t n = st == RAD_OK ? rad_mesh_count_patches(&run->scene, &mo) : 0;
        /* 0: nothing left after contact cutting, which rad_mesh_build explains */
        if (st == RAD_OK && n > 0 && ff_comm_rank(run->comm) == 0) st = check_limits(run, n);
        if (st == RAD_OK) st = rad_mesh_build(&run->scene, &mo, &run->mesh);
    }
    if (st == RAD_OK && run->mesh.patch_count == 0) {
        rad_error("%s: the scene has no faces", run->scene.path);
        st = RAD_ERR_INVALID;
    }
    run->stats.load = t1 - t0;
    run->stats.subdivide = ff_comm_time() - t1;
    return st;
}

/* Collective: plans the run on every rank once its rows are split (a rank
 * whose split failed plans as if its rows were split evenly: it still
 * takes part), makes the ranks agree on pairs_once - where one rank's
 * block does not fit, every rank streams - and picks the backend the plan
 * names. */
static void plan_after_split(ff_run *run, rad_status split)
{
    ff_plan_limits limits = {.patch_count = run->mesh.patch_count, .ranks = ff_comm_size(run->comm),
                             .rank = ff_comm_rank(run->comm), .row_begin = split == RAD_OK ? run->row_begin : NULL,
                             .memory_per_rank = memory_per_rank(run),
                             .free_bytes = INFINITY, /* the disk was checked before the mesh */
                             .gpus_visible = run->gpus,
                             .max_rows_per_write = ff_output_max_rows(run->mesh.patch_count, run->opt.format,
                                                                      run->opt.element)};
    ff_plan_choices choices = plan_choices(&run->opt);
    ff_plan_make(&limits, &choices, &run->plan);
    uint64_t some_rank_streams = ff_comm_max_u64(run->comm, !run->plan.pairs_once);
    if (some_rank_streams && run->plan.pairs_once) {
        choices.reciprocity = FF_RECIPROCITY_OFF;
        ff_plan_make(&limits, &choices, &run->plan);
    }
    run->backend = run->plan.gpu ? &ff_backend_cuda : &ff_backend_cpu;
    if (run->plan.gpu && run->reuse_old && ff_comm_rank(run->comm) == 0)
        rad_info("--reuse: the CUDA backend computes every pair (reuse is the CPU backend's)");
}

static rad_status setup(ff_run *run)
{
    double t0 = ff_comm_time();
    int ranks = ff_comm_size(run->comm);
    uint32_t n = (uint32_t)run->mesh.patch_count;
    double centre[3];
    ff_frame_centre(&run->mesh, centre);
    rad_status st = ff_patches_build(&run->scene, &run->mesh, centre, &run->patches);
    if (st == RAD_OK && !(run->area = malloc((n ? n : 1) * sizeof *run->area))) st = RAD_ERR_NOMEM;
    for (uint32_t j = 0; st == RAD_OK && j < n; j++) run->area[j] = run->patches[j].area;
    if (st == RAD_OK)
        st = ff_occluders_build(&run->scene, centre, &run->triangles, &run->triangle_face, &run->triangle_count);
    run->row_begin = calloc((size_t)ranks + 1, sizeof *run->row_begin);
    if (st == RAD_OK && !run->row_begin) st = RAD_ERR_NOMEM;
    double eps = ff_plane_eps(&run->mesh);
    int convex = run->opt.cull == FF_CULL_ALL && ff_scene_is_convex_enclosure(&run->scene, eps);
    if (st == RAD_OK) st = ff_partition_rows(run->patches, n, eps, ranks, run->row_begin);
    run->want_errors = !run->opt.no_errors;
    plan_after_split(run, st); /* collective, so every rank plans, even one that failed above */
    run->stats.threads = default_threads(run);
    if (st == RAD_OK) {
        ff_setup su = {.patches = run->patches, .patch_count = n, .triangles = run->triangles,
                       .triangle_face = run->triangle_face, .triangle_count = run->triangle_count,
                       .samples = run->opt.samples, .shadow_rays = run->opt.shadow_rays, .seed = run->opt.seed,
                       .estimator = run->opt.estimator, .quad_rtol = run->opt.quad_rtol,
                       .quad_atol = run->opt.quad_atol, .target_error = run->opt.target_error,
                       .max_samples = run->opt.max_samples, .errors = run->want_errors,
                       .cull = run->opt.cull == FF_CULL_ALL, .scene_convex = convex,
                       .cull_margin = ff_cull_margin(&run->mesh, centre, eps), .plane_eps = eps,
                       .ray_delta = ff_ray_delta(&run->mesh),
                       .pairs_once = run->plan.pairs_once, .threads = run->stats.threads,
                       .reuse_old = run->reuse_old, .reuse_coupling = run->reuse_coupling,
                       .reuse_n = (uint32_t)run->refine_patches_before,
                       .device = ff_comm_rank(run->comm), .progress = report_progress, .progress_user = run};
        st = run->backend->create(&su, &run->backend_state);
    }
    run->stats.setup = ff_comm_time() - t0;
    return st;
}

/* Collective: rows [r0, r0 + count) of this rank into each file (count may be 0). */
static rad_status write_round(ff_run *run, const ff_files *files, uint32_t r0, uint32_t count, const double *rows,
                              const double *errors)
{
    double t0 = ff_comm_time();
    rad_status st = ff_output_write_rows(files->matrix, r0, count, rows);
    if (files->errors) {
        rad_status e = ff_output_write_rows(files->errors, r0, count, errors);
        if (st == RAD_OK) st = e;
    }
    run->stats.io += ff_comm_time() - t0;
    return st;
}

/* The same for rows the backend encoded (compute_records). */
static rad_status write_records_round(ff_run *run, const ff_files *files, uint32_t r0, uint32_t count,
                                      const ff_records *values, const ff_records *errors)
{
    double t0 = ff_comm_time();
    rad_status st = ff_output_write_records(files->matrix, r0, count, values);
    if (files->errors) {
        rad_status e = ff_output_write_records(files->errors, r0, count, errors);
        if (st == RAD_OK) st = e;
    }
    run->stats.io += ff_comm_time() - t0;
    return st;
}

/* Whether rounds come back from the backend finished and encoded
 * (compute_records: the CUDA backend scales and encodes on the GPU and
 * returns only the stored bytes) instead of as rows the CPU finishes: where
 * the plan says so (streamed rounds of a sparse file on the GPU) and the
 * backend can. RAD_FF_FINISH=host turns it off (tests compare the two: the
 * same bytes); the plan's larger rounds then come back as rows. */
static int records_from_backend(const ff_run *run)
{
    const char *finish = getenv("RAD_FF_FINISH");
    return run->plan.device_records && run->backend->compute_records && !(finish && strcmp(finish, "host") == 0);
}

/* Streamed rounds finished by the backend: the rank's rows, round by
 * round (ff_plan_round_rows: block-cyclic), computed, finished and encoded
 * by the backend, and written collectively. Every rank joins every write,
 * with no rows after a failure. */
static rad_status compute_record_rounds(ff_run *run, const ff_files *files, ff_counters *counters)
{
    const ff_plan *plan = &run->plan;
    uint32_t element = run->opt.element, r0, count;
    rad_status st = RAD_OK;
    run->progress_base = 0;
    for (uint64_t round = 0; round < plan->rounds; round++) {
        count = ff_plan_round_rows(plan, round, &r0);
        ff_records values = {0}, errors = {0};
        if (st == RAD_OK && count > 0) {
            run->progress_round_end = run->progress_base + count;
            st = run->backend->compute_records(run->backend_state, r0, count, element, &values,
                                               files->errors ? &errors : NULL, &run->stats.rows, counters);
            run->progress_base += count;
        }
        rad_status w = write_records_round(run, files, r0, st == RAD_OK ? count : 0, &values, &errors);
        if (st == RAD_OK) st = w;
    }
    return st;
}

/* A buffer of `count` doubles, from the backend up to FF_BACKEND_BUFFER_MAX (ff_plan.h). */
static double *alloc_buffer(ff_run *run, size_t count)
{
    if (count == 0) count = 1;
    return count * sizeof(double) <= FF_BACKEND_BUFFER_MAX ? run->backend->alloc_rows(run->backend_state, count)
                                                           : malloc(count * sizeof(double));
}

static void free_buffer(ff_run *run, size_t count, double *buffer)
{
    if (count == 0) count = 1;
    if (count * sizeof(double) <= FF_BACKEND_BUFFER_MAX)
        run->backend->free_rows(run->backend_state, buffer);
    else
        free(buffer);
}

/* Rank 0, before any row is written: one line with what the run will
 * take - the outputs' size, the memory per rank and the time. The time
 * comes from a calibration: FF_CALIBRATION_CHUNKS chunks of rows spread
 * over the matrix, together about 1/64 of it, computed by the run's own
 * backend (and computed again later: 1.6 % more work) and scaled to the
 * rows of the busiest rank (busiest_rows); at most FF_CALIBRATION_PAIRS
 * pairs in all (at least one row a chunk), so that a huge run's
 * calibration takes bounded memory and time (N = 326 698: 4 rows, not
 * 1/64 of the run). A GPU's chunks of a small scene are
 * mostly launch latency, so small runs are overestimated; runs of fewer
 * than FF_CALIBRATION_MIN patches take seconds and are not calibrated.
 * Sets the progress lines' cadence from the estimate. */
#define FF_CALIBRATION_CHUNKS 4
#define FF_CALIBRATION_MIN 1024
#define FF_CALIBRATION_PAIRS ((uint64_t)1 << 21)
/* The first row of calibration chunk k: chunks centred in equal parts of the matrix. */
static uint32_t calibration_row(uint32_t n, uint32_t chunk, uint32_t k)
{
    uint64_t centre = (uint64_t)n * (2 * k + 1) / (2 * FF_CALIBRATION_CHUNKS);
    uint32_t r0 = centre > chunk / 2 ? (uint32_t)(centre - chunk / 2) : 0;
    return r0 + chunk > n ? n - chunk : r0;
}

/* The rows whose time is the run's: with pairs_once a block of the split,
 * which balances the ranks' work (not their rows), so N / ranks; streamed,
 * the most rows a rank takes in blocks of rows_per_round (one block more than
 * another rank's where the blocks do not divide evenly). */
static double busiest_rows(const ff_run *run)
{
    if (run->plan.pairs_once) return (double)run->mesh.patch_count / ff_comm_size(run->comm);
    return run->plan.most_rows;
}

/* Rows in each calibration chunk: 1/64 of the matrix over the chunks (at
 * least 2 rows a chunk), within FF_CALIBRATION_PAIRS (at least 1). */
static uint32_t calibration_chunk(uint32_t n)
{
    uint32_t chunk = n / 64 / FF_CALIBRATION_CHUNKS > 2 ? n / 64 / FF_CALIBRATION_CHUNKS : 2;
    uint64_t most = FF_CALIBRATION_PAIRS / FF_CALIBRATION_CHUNKS / (n ? n : 1);
    if (most < 1) most = 1;
    return chunk > most ? (uint32_t)most : chunk;
}

/* Rank 0 (estimate's contract above); with --max-seconds, refuses
 * (RAD_ERR_USAGE, logged) a run whose estimate exceeds it, or whose
 * calibration could not run. Returns RAD_OK otherwise. */
static rad_status estimate(ff_run *run)
{
    uint32_t n = (uint32_t)run->mesh.patch_count;
    double seconds = -1, calibration = 0;
    uint32_t chunk = calibration_chunk(n);
    const char *failed = NULL; /* why a calibrated run has no time */
    if (n >= FF_CALIBRATION_MIN && records_from_backend(run)) {
        /* Rows the backend finishes itself: calibrated the same way, so
         * that no rows cross to the host (at N = 188 416 those copies took
         * 2.9 s). */
        ff_counters scratch = {0};
        ff_rows_summary ignored = {0};
        rad_status st = RAD_OK;
        run->calibrating = 1;
        double t0 = ff_comm_time();
        for (uint32_t k = 0; k < FF_CALIBRATION_CHUNKS && st == RAD_OK; k++) {
            ff_records values, errors;
            st = run->backend->compute_records(run->backend_state, calibration_row(n, chunk, k), chunk,
                                               run->opt.element, &values, run->opt.errors_path ? &errors : NULL,
                                               &ignored, &scratch);
        }
        calibration = ff_comm_time() - t0;
        run->calibrating = 0;
        if (st == RAD_OK)
            seconds = calibration * (busiest_rows(run) / (FF_CALIBRATION_CHUNKS * chunk));
        else
            failed = "its rows failed";
    } else if (n >= FF_CALIBRATION_MIN) {
        double *rows = alloc_buffer(run, (size_t)chunk * n);
        double *errors = run->want_errors ? alloc_buffer(run, (size_t)chunk * n) : NULL;
        if (rows && (errors || !run->want_errors)) {
            ff_counters scratch = {0};
            rad_status st = RAD_OK;
            run->calibrating = 1;
            double t0 = ff_comm_time();
            for (uint32_t k = 0; k < FF_CALIBRATION_CHUNKS && st == RAD_OK; k++) {
                st = run->backend->compute_rows(run->backend_state, calibration_row(n, chunk, k), chunk, rows, errors,
                                                &scratch);
            }
            calibration = ff_comm_time() - t0;
            run->calibrating = 0;
            if (st == RAD_OK)
                seconds = calibration * (busiest_rows(run) / (FF_CALIBRATION_CHUNKS * chunk));
            else
                failed = "its rows failed";
        } else {
            failed = "out of memory for its rows";
        }
        if (rows) free_buffer(run, (size_t)chunk * n, rows);
        if (errors) free_buffer(run, (size_t)chunk * n, errors);
    }
    char bytes[32], memory[32], time[32], took[32];
    /* The sparse format's size is known once written: the dense size bounds it. */
    const char *bound = run->opt.format == FF_FORMAT_SPARSE ? "at most " : "";
    if (seconds >= 0)
        rad_info("estimate: %s%s to write, about %s of memory per rank, about %s of form factors on %d rank(s) "
                 "(calibrated on %u of %u rows in %s)",
                 bound, format_bytes(run->plan.file_bytes, bytes, sizeof bytes),
                 format_bytes(run->plan.memory_bytes, memory, sizeof memory),
                 format_seconds(seconds, time, sizeof time), ff_comm_size(run->comm), FF_CALIBRATION_CHUNKS * chunk,
                 n, format_seconds(calibration, took, sizeof took));
    else if (failed)
        rad_info("estimate: %s%s to write, about %s of memory per rank, time of form factors unknown (the "
                 "calibration on %u of %u rows could not run: %s)", bound,
                 format_bytes(run->plan.file_bytes, bytes, sizeof bytes),
                 format_bytes(run->plan.memory_bytes, memory, sizeof memory), FF_CALIBRATION_CHUNKS * chunk, n,
                 failed);
    else
        rad_info("estimate: %s%s to write, about %s of memory per rank, seconds of form factors", bound,
                 format_bytes(run->plan.file_bytes, bytes, sizeof bytes),
                 format_bytes(run->plan.memory_bytes, memory, sizeof memory));
    run->estimated_seconds = seconds;
    run->progress_every = seconds / 40 > 2.0 ? seconds / 40 : 2.0;
    if (run->progress_tty) run->progress_every = 0.5;
    /* Tests ask for lines at a cadence of their own. */
    const char *every = getenv("RAD_PROGRESS_SECONDS");
    if (every && atof(every) > 0) run->progress_every = atof(every);
    double limit = run->opt.max_seconds;
    if (limit > 0 && failed) {
        rad_error("--max-seconds %g: the run's time is unknown (its calibration could not run: %s); refused "
                  "(drop --max-seconds to run it anyway)", limit, failed);
        return RAD_ERR_USAGE;
    }
    if (limit > 0 && seconds > limit) {
        char limit_text[32];
        rad_error("--max-seconds %g: the run is estimated at about %s of form factors on %d rank(s), more than %s; "
                  "refused before writing anything (more ranks or GPUs, a lower --subdiv, fewer --shadow-rays, or a "
                  "larger --max-seconds)", limit, format_seconds(seconds, time, sizeof time), ff_comm_size(run->comm),
                  format_seconds(limit, limit_text, sizeof limit_text));
        return RAD_ERR_USAGE;
    }
    return RAD_OK;
}

/* Row buffers of `count` doubles, for the values and (if wanted) the
 * standard errors; collective: fails on every rank if it fails on one. */
static rad_status alloc_buffers(ff_run *run, size_t count, double **rows, double **errors)
{
    *rows = alloc_buffer(run, count);
    *errors = run->want_errors ? alloc_buffer(run, count) : NULL;
    rad_status st = ff_comm_agree(run->comm, *rows && (*errors || !run->want_errors) ? RAD_OK : RAD_ERR_NOMEM);
    if (st != RAD_OK) {
        if (*rows) free_buffer(run, count, *rows);
        if (*errors) free_buffer(run, count, *errors);
        *rows = *errors = NULL;
    }
    return st;
}

/* pairs_once: fills in the entries that other rows computed - of this
 * rank's block, then from other ranks' - once every rank has computed its
 * rows (collective; `st` is this rank's status so far). */
static rad_status complete_block(ff_run *run, double *block, double *errors, ff_counters *counters, rad_status st)
{
    int rank = ff_comm_rank(run->comm);
    uint32_t n = (uint32_t)run->mesh.patch_count;
    uint32_t begin = run->row_begin[rank], end = run->row_begin[rank + 1];
    st = ff_comm_agree(run->comm, st);
    if (st != RAD_OK) return st;
    double t0 = ff_comm_time();
    counters->pairs_mirrored += ff_rows_mirror_local(n, begin, end, block, run->stats.threads);
    st = ff_rows_exchange(run->comm, run->row_begin, n, block, &counters->pairs_mirrored);
    if (errors) {
        ff_rows_mirror_local(n, begin, end, errors, run->stats.threads);
        if (st == RAD_OK) st = ff_rows_exchange(run->comm, run->row_begin, n, errors, NULL);
    }
    run->stats.mirror = ff_comm_time() - t0;
    return st;
}

/* This rank's rows, in the plan's rounds (ff_plan_round_rows), computed
 * and written collectively. Streamed (--reciprocity off), the buffers
 * hold one round: each round - a block of rows taken block-cyclically, so
 * that the ranks' blocks of a round are consecutive - is computed, scaled
 * and written before the next. With pairs_once they hold the rank's whole
 * block of the split: each round is computed into its place, the block is
 * completed from the other rows' entries, scaled, and written in the same
 * rounds. Every rank joins every collective write, with no rows after a
 * failure. */
static rad_status compute_rounds(ff_run *run, const ff_files *files, ff_counters *counters)
{
    if (records_from_backend(run)) return compute_record_rounds(run, files, counters);
    const ff_plan *plan = &run->plan;
    uint32_t n = (uint32_t)run->mesh.patch_count;
    uint32_t begin = plan->block_begin, end = plan->block_end; /* pairs_once: the rank's block */
    double *rows = NULL, *errors = NULL;
    /* Rounds the plan meant for the backend to finish (RAD_FF_FINISH=host) come back as rows. */
    size_t buffer_doubles = plan->device_records ? (size_t)plan->rows_per_round * n : plan->buffer_doubles;
    rad_status st = alloc_buffers(run, buffer_doubles, &rows, &errors);
    if (st != RAD_OK) {
        if (plan->pairs_once)
            rad_error("out of memory for this rank's %u rows of %u form factors (try --reciprocity off)", end - begin,
                      n);
        else
            rad_error("out of memory for %u rows of %u form factors", plan->rows_per_round, n);
        return st;
    }
    uint32_t r0, count;
    run->progress_base = 0;
    for (uint64_t round = 0; round < plan->rounds; round++) {
        count = ff_plan_round_rows(plan, round, &r0);
        size_t at = plan->pairs_once ? (size_t)(r0 - begin) * n : 0;
        if (st == RAD_OK && count > 0) {
            run->progress_round_end = run->progress_base + count;
            st = run->backend->compute_rows(run->backend_state, r0, count, rows + at, errors ? errors + at : NULL,
                                            counters);
            run->progress_base += count;
        }
        if (plan->pairs_once) continue; /* written once the block is complete */
        if (st == RAD_OK) ff_rows_finish(run->area, n, r0, count, rows, errors, run->stats.threads, &run->stats.rows);
        rad_status w = write_round(run, files, r0, st == RAD_OK ? count : 0, rows, errors);
        if (st == RAD_OK) st = w;
    }
    if (plan->pairs_once) {
        st = complete_block(run, rows, errors, counters, st);
        if (st == RAD_OK)
            ff_rows_finish(run->area, n, begin, end - begin, rows, errors, run->stats.threads, &run->stats.rows);
        /* The sparse format places all the rank's records in row order (the
         * same bytes for any rank count); collective, so every rank joins. */
        uint32_t reserve = st == RAD_OK ? end - begin : 0;
        if (files->matrix) ff_output_reserve(files->matrix, reserve, rows);
        if (files->errors) ff_output_reserve(files->errors, reserve, errors);
        if (st == RAD_OK) {
            for (uint64_t round = 0; round < plan->rounds; round++) {
                count = ff_plan_round_rows(plan, round, &r0);
                size_t at = (size_t)(r0 - begin) * n;
                rad_status w = write_round(run, files, r0, st == RAD_OK ? count : 0, rows + at, errors ? errors + at : NULL);
                if (st == RAD_OK) st = w;
            }
        }
    }
    free_buffer(run, buffer_doubles, rows);
    if (errors) free_buffer(run, buffer_doubles, errors);
    return st;
}

/* Which rows this rank computes, for the stats (ff_stats.h). */
static void stats_rows(const ff_plan *plan, ff_rank_stats *stats)
{
    stats->row_count = plan->rank_rows;
    if (plan->pairs_once) {
        stats->row_begin = plan->block_begin;
        stats->row_end = plan->block_end;
    } else {
        uint32_t first;
        ff_plan_round_rows(plan, 0, &first);
        stats->row_begin = first;
        stats->row_end = (uint32_t)plan->patch_count;
        stats->block_size = plan->rows_per_round;
        stats->block_stride = (uint64_t)plan->ranks * plan->rows_per_round;
    }
}

/* Computes this rank's rows and writes them collectively. */
static rad_status compute_and_write(ff_run *run, const ff_files *files)
{
    stats_rows(&run->plan, &run->stats);
    ff_counters counters = {0};
    rad_status st = compute_rounds(run, files, &counters);
    run->stats.counters = counters;
    run->stats.form_factors = counters.kernel_seconds;
    run->stats.visibility = counters.visibility_seconds;
    run->stats.gpu_memory = counters.memory_seconds;
    return st;
}

static rad_status write_stats(ff_run *run)
{
    int rank = ff_comm_rank(run->comm), ranks = ff_comm_size(run->comm);
    ff_rank_stats *all = rank == 0 ? calloc((size_t)ranks, sizeof *all) : NULL;
    rad_status st = ff_comm_agree(run->comm, rank == 0 && !all ? RAD_ERR_NOMEM : RAD_OK);
    if (st != RAD_OK) return st;
    run->stats.rank = rank;
    ff_comm_gather(run->comm, &run->stats, sizeof run->stats, all, 0);
    if (rank == 0) {
        const char *scene = run->opt.scene_path ? run->opt.scene_path : rad_default_scene_name;
        ff_run_info info = {.scene = scene, .fingerprint = run->scene.fingerprint,
                            .patch_count = (uint32_t)run->mesh.patch_count, .subdiv = run->opt.subdiv,
                            .subdiv_only = run->opt.subdiv_only,
                            .contacts = ff_contacts_name(run->opt.contacts), .samples = run->opt.samples,
                            .shadow_rays = run->opt.shadow_rays, .seed = run->opt.seed,
                            .estimator = rad_estimator_name(run->opt.estimator),
                            .cull = ff_cull_name(run->opt.cull),
                            .reciprocity = ff_reciprocity_name(run->plan.pairs_once ? FF_RECIPROCITY_ON
                                                                                     : FF_RECIPROCITY_OFF),
                            .target_error = run->opt.target_error, .max_samples = run->opt.max_samples,
                            .errors = run->want_errors, .backend = run->backend->name,
                            .element = ff_element_name(run->opt.element), .format = ff_format_name(run->opt.format),
                            .output = run->opt.output, .ranks = ranks, .gpus_visible = run->gpus,
                            .refine_from = run->opt.refine_path, .refine_tol = run->opt.refine_tol,
                            .refine = &run->refine, .refine_patches_before = run->refine_patches_before};
        ff_stats_log_summary(&info, all);
        if (run->opt.stats_path) st = ff_stats_write_json(run->opt.stats_path, &info, all);
    }
    free(all);
    return ff_comm_agree(run->comm, st);
}

/* Opens the outputs (collective): the matrix, and the --errors file
 * (float32; sparse with the matrix, else native) beside it. */
static rad_status open_outputs(ff_run *run, ff_files *files)
{
    rad_ff_info info = {.patch_count = run->mesh.patch_count, .vertex_count = run->mesh.vertex_count,
                        .element_type = run->opt.element, .estimator = run->opt.estimator,
                        .samples = run->opt.samples, .shadow_rays = run->opt.shadow_rays, .seed = run->opt.seed,
                        .scene_fingerprint = run->scene.fingerprint, .subdiv = run->opt.subdiv,
                        .flags = (run->opt.subdiv_only ? RAD_FF_FLAG_PARTIAL_SUBDIV : 0) | RAD_FF_FLAG_RECIPROCAL |
                                 (run->opt.ke_radiance ? RAD_FF_FLAG_KE_RADIANCE : 0),
                        .group_count = (uint32_t)run->mesh.group_count};
    snprintf(info.scene_name, sizeof info.scene_name, "%s",
             run->opt.scene_path ? run->opt.scene_path : rad_default_scene_name);
    rad_status st = ff_output_open(run->comm, run->opt.output, run->opt.format, &info, &run->mesh, &files->matrix);
    if (st == RAD_OK && run->opt.errors_path) {
        rad_ff_info error_info = info;
        error_info.element_type = RAD_ELEMENT_F32;
        error_info.flags |= RAD_FF_FLAG_STANDARD_ERRORS; /* the matrix's flags besides: solve matches them */
        ff_format format = run->opt.format == FF_FORMAT_SPARSE ? FF_FORMAT_SPARSE : FF_FORMAT_DENSE;
        st = ff_output_open(run->comm, run->opt.errors_path, format, &error_info, &run->mesh, &files->errors);
        if (st != RAD_OK) files->errors = NULL;
    }
    if (files->matrix) ff_output_set_threads(files->matrix, run->stats.threads);
    if (files->errors) ff_output_set_threads(files->errors, run->stats.threads);
    return st;
}

/* Collective: both files are written and closed before either is renamed;
 * the errors file is renamed first, so a failure there leaves the old
 * matrix in place too. (Both destinations were checked up front.) */
static rad_status commit_outputs(const ff_files *files, rad_status st)
{
    if (files->matrix) st = ff_output_close(files->matrix, st);
    if (files->errors) st = ff_output_close(files->errors, st);
    if (files->errors) st = ff_output_commit(files->errors, st);
    if (files->matrix) st = ff_output_commit(files->matrix, st);
    return st;
}

static rad_status run_formfactor(ff_run *run)
{
    int rank = ff_comm_rank(run->comm);
    run->start = ff_comm_time();
    /* Loading is deterministic, so rank 0 alone reports its errors. */
    rad_log_level level = rad_log_get_level();
    if (rank != 0) rad_log_set_level(RAD_LOG_NONE);
    rad_status st = ff_comm_agree(run->comm, load(run));
    if (rank != 0) rad_log_set_level(level);
    if (st != RAD_OK) return st;
    if (run->mesh.patch_count > UINT32_MAX / 2) {
        if (rank == 0) rad_error("%zu patches: more than this format's 2^31 limit", run->mesh.patch_count);
        return RAD_ERR_NOMEM;
    }
    /* Asking CUDA starts its driver (~0.5 s); a CPU run does not need it. */
    double t_cuda = ff_comm_time();
    run->gpus = run->opt.backend != FF_BACKEND_CPU ? ff_cuda_device_count() : 0;
    run->stats.cuda_start = ff_comm_time() - t_cuda;
    if ((st = ff_comm_agree(run->comm, setup(run))) != RAD_OK) return st;
    if (rank == 0)
        rad_info("%s: %zu patches from %zu faces, %u samples and %u shadow rays per pair, %d rank(s) x %d thread(s), "
                 "backend %s",
                 run->opt.scene_path ? run->opt.scene_path : rad_default_scene_name, run->mesh.patch_count,
                 run->scene.face_count, run->opt.samples, run->opt.shadow_rays, ff_comm_size(run->comm),
                 run->stats.threads, run->backend->name);
    run->progress_every = 2.0;
    run->estimated_seconds = -1;
    run->progress_tty = rank == 0 && isatty(STDERR_FILENO) && rad_log_get_level() >= RAD_LOG_INFO;
    double t_estimate = ff_comm_time();
    /* Under -q only for --max-seconds, which needs the time (the line is not shown). */
    if (rank == 0 && (rad_log_get_level() >= RAD_LOG_INFO || run->opt.max_seconds > 0)) st = estimate(run);
    run->stats.estimate = ff_comm_time() - t_estimate;
    if (run->opt.max_seconds > 0) st = ff_comm_agree(run->comm, st); /* every rank knows the option */
    if (st != RAD_OK) return st;

    ff_files files = {0};
    double t0 = ff_comm_time();
    st = open_outputs(run, &files);
    run->stats.io += ff_comm_time() - t0;
    ff_comm_progress_open(run->comm);
    run->compute_start = ff_comm_time();
    run->progress_said_at = run->compute_start;
    if (st == RAD_OK) st = compute_and_write(run, &files);
    ff_comm_progress_close(run->comm);
    if (run->progress_tty && run->progress_said_at > run->compute_start) fputc('\n', stderr); /* end the updating line */
    t0 = ff_comm_time();
    st = commit_outputs(&files, st);
    run->stats.io += ff_comm_time() - t0;
    run->stats.total = ff_comm_time() - run->start;
    if (st != RAD_OK) return st;
    if (rank == 0) rad_info("wrote %s%s%s", run->opt.output, run->opt.errors_path ? " and " : "",
                            run->opt.errors_path ? run->opt.errors_path : "");
    return write_stats(run);
}

static void run_free(ff_run *run)
{
    if (run->backend && run->backend_state) run->backend->destroy(run->backend_state);
    free(run->patches);
    free(run->area);
    free(run->reuse_old);
    free(run->reuse_coupling);
    free(run->triangles);
    free(run->triangle_face);
    free(run->row_begin);
    rad_mesh_free(&run->mesh);
    rad_scene_free(&run->scene);
}

rad_status ff_driver_run(ff_comm *comm, const ff_options *options)
{
    ff_run run = {.comm = comm, .opt = *options};
    rad_status status = run_formfactor(&run);
    run_free(&run);
    return status;
}
