/* ff_driver.c - one formfactor run (ff_driver.h): the order of its
 * steps - load and check the scene (ff_load.h, ff_limits.h), set up the
 * backend, the estimate (ff_progress.h), the rounds of rows and their
 * writes, the order in which the files are committed, and the
 * stats. */
#include "rad_clock.h"
#include "ff_driver.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "ff_backend.h"
#include "ff_cuda.h"
#include "ff_limits.h"
#include "ff_load.h"
#include "ff_output.h"
#include "ff_plan.h"
#include "ff_progress.h"
#include "ff_row_buffer.h"
#include "ff_rows.h"
#include "ff_hierarchical.h"
#include "ff_setup.h"
#include "ff_solve.h"
#include "ff_stats.h"
#include "ff_writer.h"
#include "rad_cpu.h"
#include "rad_ffile.h"
#include "rad_log.h"
#include "rad_mesh.h"
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
    /* ff_limits_check (rank 0, before the mesh), then setup (every rank,
     * after the split; pairs_once the same on every rank). */
    ff_plan plan;
    int gpus;        /* CUDA devices this process sees; 0 with --backend cpu (not asked) */
    int want_errors; /* standard errors computed (not --no-errors) */
    int records;     /* streamed rounds come back from the backend encoded (records_from_backend) */
    ff_rank_stats stats;
    ff_refinement refinement; /* --refine: what was split; --reuse's couplings */
    double start;
    ff_progress progress; /* the backend's progress callback reports here */
    ff_solve *solve;      /* --radiosity: this rank's rows go into solve's matrix, not a file */
} ff_run;

/* The files of a run: the matrix, and its standard errors on request. */
typedef struct ff_files {
    ff_output *matrix;
    ff_output *errors; /* NULL without --errors */
} ff_files;

/* The scene and the mesh; rank 0 checks the run's limits before the mesh
 * is built (a refined mesh is small beside its matrix: built first). */
static rad_status load(ff_run *run)
{
    int rank = ff_comm_rank(run->comm);
    int ranks = ff_comm_size(run->comm), node_ranks = ff_comm_node_size(run->comm);
    double t0 = rad_clock_seconds();
    rad_status st = ff_load_scene(&run->opt, &run->scene);
    double t1 = rad_clock_seconds();
    rad_mesh_options mo = {.subdiv = run->opt.subdiv, .only_group = run->opt.subdiv_only,
                           .contacts = run->opt.contacts};
    if (run->opt.refine_path) {
        if (st == RAD_OK) st = ff_load_refined_mesh(&run->opt, &run->scene, &run->mesh, &run->refinement);
        if (st == RAD_OK && rank == 0)
            st = ff_limits_check(&run->opt, run->mesh.patch_count, ranks, node_ranks, &run->plan);
    } else {
        uint64_t n = st == RAD_OK ? rad_mesh_count_patches(&run->scene, &mo) : 0;
        /* 0: nothing left after contact cutting, which rad_mesh_build explains */
        if (st == RAD_OK && n > 0 && rank == 0 && !run->opt.dry_run)
            st = ff_limits_check(&run->opt, n, ranks, node_ranks, &run->plan);
        if (st == RAD_OK) st = rad_mesh_build(&run->scene, &mo, &run->mesh);
    }
    if (st == RAD_OK && run->mesh.patch_count == 0) {
        rad_error("%s: the scene has no faces", run->scene.path);
        st = RAD_ERR_INVALID;
    }
    run->stats.load = t1 - t0;
    run->stats.subdivide = rad_clock_seconds() - t1;
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
                             .memory_per_rank = ff_limits_memory_per_rank(ff_comm_node_size(run->comm)),
                             .free_bytes = INFINITY, /* the disk was checked before the mesh */
                             .gpus_visible = run->gpus,
                             .max_rows_per_write = ff_output_max_rows(run->mesh.patch_count, run->opt.format,
                                                                      run->opt.element)};
    ff_plan_choices choices = ff_plan_choices_of(&run->opt);
    ff_plan_make(&limits, &choices, &run->plan);
    uint64_t some_rank_streams = ff_comm_max_u64(run->comm, !run->plan.pairs_once);
    if (some_rank_streams && run->plan.pairs_once) {
        choices.reciprocity = FF_RECIPROCITY_OFF;
        ff_plan_make(&limits, &choices, &run->plan);
    }
    run->backend = run->plan.gpu ? &ff_backend_cuda : &ff_backend_cpu;
    if (run->plan.gpu && run->refinement.reuse_old && ff_comm_rank(run->comm) == 0)
        rad_info("--reuse: the CUDA backend computes every pair (reuse is the CPU backend's)");
}

/* Whether rounds come back from the backend finished and encoded
 * (compute_records: the CUDA backend scales and encodes on the GPU and
 * returns only the stored bytes) instead of as rows the CPU finishes: where
 * the plan says so (streamed rounds of a sparse file on the GPU) and the
 * backend can. RAD_FF_FINISH=host turns it off (tests compare the two: the
 * same bytes); the plan's larger rounds then come back as rows. */
static int records_from_backend(const ff_run *run)
{
    return run->plan.device_records && run->backend->compute_records && !run->opt.finish_on_host;
}

static rad_status setup(ff_run *run)
{
    double t0 = rad_clock_seconds();
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
    /* --radiosity: the ranks' blocks are solve's too (ff_solve.h) */
    if (st == RAD_OK && run->opt.radiosity_path) ff_solve_align_split(run->row_begin, ranks, n);
    run->want_errors = !run->opt.no_errors;
    plan_after_split(run, st); /* collective, so every rank plans, even one that failed above */
    run->stats.threads = rad_cpu_threads_per_rank(run->opt.threads, ff_comm_node_size(run->comm));
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
                       .reuse_old = run->refinement.reuse_old, .reuse_coupling = run->refinement.reuse_coupling,
                       .reuse_n = (uint32_t)run->refinement.patches_before, .device = ff_comm_rank(run->comm),
                       .progress = ff_progress_report, .progress_user = &run->progress};
        st = run->backend->create(&su, &run->backend_state);
    }
    run->records = records_from_backend(run);
    run->stats.setup = rad_clock_seconds() - t0;
    return st;
}

/* Collective: rows [r0, r0 + count) of this rank into each file (count may be 0). */
static rad_status write_round(ff_run *run, const ff_files *files, uint32_t r0, uint32_t count, const double *rows,
                              const double *errors)
{
    double t0 = rad_clock_seconds();
    rad_status st = ff_output_write_rows(files->matrix, r0, count, rows);
    if (files->errors) {
        rad_status e = ff_output_write_rows(files->errors, r0, count, errors);
        if (st == RAD_OK) st = e;
    }
    run->stats.io += rad_clock_seconds() - t0;
    return st;
}

/* The same for rows the backend encoded (compute_records). */
static rad_status write_records_round(ff_run *run, const ff_files *files, uint32_t r0, uint32_t count,
                                      const ff_records *values, const ff_records *errors)
{
    double t0 = rad_clock_seconds();
    rad_status st = ff_output_write_records(files->matrix, r0, count, values);
    if (files->errors) {
        rad_status e = ff_output_write_records(files->errors, r0, count, errors);
        if (st == RAD_OK) st = e;
    }
    run->stats.io += rad_clock_seconds() - t0;
    return st;
}

/* Streamed rounds finished by the backend: the rank's rows, round by
 * round (ff_plan_round_rows: block-cyclic), computed, finished and encoded
 * by the backend, and written (in the background: the backend's records
 * stay valid until the call after next, ff_backend.h, while a write
 * lasts until the next one starts, ff_output.h). Every rank joins every write,
 * with no rows after a failure. */
static rad_status compute_record_rounds(ff_run *run, const ff_files *files, ff_counters *counters)
{
    const ff_plan *plan = &run->plan;
    uint32_t element = run->opt.element, r0, count;
    rad_status st = RAD_OK;
    for (uint64_t round = 0; round < plan->rounds; round++) {
        count = ff_plan_round_rows(plan, round, &r0);
        ff_records values = {0}, errors = {0};
        if (st == RAD_OK && count > 0) {
            ff_progress_call_begin(&run->progress, count);
            st = run->backend->compute_records(run->backend_state, r0, count, element, &values,
                                               files->errors ? &errors : NULL, &run->stats.rows, counters);
            ff_progress_call_end(&run->progress);
        }
        rad_status w = write_records_round(run, files, r0, st == RAD_OK ? count : 0, &values, &errors);
        if (st == RAD_OK) st = w;
    }
    return st;
}

/* Row buffers of `count` doubles, for the values and (if wanted) the
 * standard errors; collective: fails on every rank if it fails on one. */
static rad_status alloc_buffers(ff_run *run, size_t count, double **rows, double **errors)
{
    *rows = ff_row_buffer_alloc(run->backend, run->backend_state, count);
    *errors = run->want_errors ? ff_row_buffer_alloc(run->backend, run->backend_state, count) : NULL;
    rad_status st = ff_comm_agree(run->comm, *rows && (*errors || !run->want_errors) ? RAD_OK : RAD_ERR_NOMEM);
    if (st != RAD_OK) {
        if (*rows) ff_row_buffer_free(run->backend, run->backend_state, count, *rows);
        if (*errors) ff_row_buffer_free(run->backend, run->backend_state, count, *errors);
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
    double t0 = rad_clock_seconds();
    counters->pairs_mirrored += ff_rows_mirror_local(n, begin, end, block, run->stats.threads);
    st = ff_rows_exchange(run->comm, run->row_begin, n, block, &counters->pairs_mirrored);
    if (errors) {
        ff_rows_mirror_local(n, begin, end, errors, run->stats.threads);
        if (st == RAD_OK) st = ff_rows_exchange(run->comm, run->row_begin, n, errors, NULL);
    }
    run->stats.mirror = rad_clock_seconds() - t0;
    return st;
}

/* This rank's rows, in the plan's rounds (ff_plan_round_rows), computed
 * and written. Streamed (--reciprocity off), the buffers
 * hold one round: each round - a block of rows taken block-cyclically, so
 * that the ranks' blocks of a round are consecutive - is computed, scaled
 * and written before the next. With pairs_once they hold the rank's whole
 * block of the split: each round is computed into its place, the block is
 * completed from the other rows' entries, scaled, and written in the same
 * rounds. Every rank joins every write (its placement is collective), with no rows after a
 * failure. */
static rad_status compute_rounds(ff_run *run, const ff_files *files, ff_counters *counters)
{
    if (run->records) return compute_record_rounds(run, files, counters);
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
    for (uint64_t round = 0; round < plan->rounds; round++) {
        count = ff_plan_round_rows(plan, round, &r0);
        size_t at = plan->pairs_once ? (size_t)(r0 - begin) * n : 0;
        if (st == RAD_OK && count > 0) {
            ff_progress_call_begin(&run->progress, count);
            st = run->backend->compute_rows(run->backend_state, r0, count, rows + at, errors ? errors + at : NULL,
                                            counters);
            ff_progress_call_end(&run->progress);
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
    ff_row_buffer_free(run->backend, run->backend_state, buffer_doubles, rows);
    if (errors) ff_row_buffer_free(run->backend, run->backend_state, buffer_doubles, errors);
    return st;
}

/* Which rows this rank computes, for the stats (ff_stats.h). */
static void stats_rows(const ff_plan *plan, ff_rank_stats *stats)
{
    stats->row_count = plan->rank_rows;
    if (plan->blocks) {
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

/* Computes this rank's rows and writes them. */
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
                            .output = run->opt.radiosity_path ? "(in memory: --radiosity)" : run->opt.output,
                            .held = run->opt.radiosity_path != NULL, .ranks = ranks, .gpus_visible = run->gpus,
                            .refine_from = run->opt.refine_path, .refine_tol = run->opt.refine.tolerance,
                            .refine = &run->refinement.stats,
                            .refine_patches_before = run->refinement.patches_before};
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
    /* The threads this rank computes with encode the rows; a few of them
     * write in the background (ff_writer.h). */
    int threads = run->stats.threads > 0 ? run->stats.threads : 1;
    ff_output_options oo = {.threads = threads,
                            .write_threads = threads < FF_WRITER_MAX_THREADS ? threads : FF_WRITER_MAX_THREADS,
                            .write_method = run->opt.write_method};
    if (run->opt.radiosity_path) { /* solved in memory: no file (ff_solve.h) */
        rad_status st = ff_comm_agree(run->comm, ff_solve_begin(&info, &run->mesh, run->plan.block_begin,
                                                                run->plan.block_end, &run->solve));
        if (st != RAD_OK) return st;
        return ff_output_open_held(run->comm, &info, ff_solve_rows, run->solve, &oo, &files->matrix);
    }
    rad_status st = ff_output_open(run->comm, run->opt.output, run->opt.format, &info, &run->mesh, &oo,
                                   &files->matrix);
    if (st == RAD_OK && run->opt.errors_path) {
        rad_ff_info error_info = info;
        error_info.element_type = RAD_ELEMENT_F32;
        error_info.flags |= RAD_FF_FLAG_STANDARD_ERRORS; /* the matrix's flags besides: solve matches them */
        ff_format format = run->opt.format == FF_FORMAT_SPARSE ? FF_FORMAT_SPARSE : FF_FORMAT_DENSE;
        st = ff_output_open(run->comm, run->opt.errors_path, format, &error_info, &run->mesh, &oo, &files->errors);
        if (st != RAD_OK) files->errors = NULL;
    }
    return st;
}

/* This rank's background writes of one file, into the stats. */
static void add_written(ff_rank_stats *stats, const ff_output *output)
{
    ff_output_write_stats w = ff_output_written(output);
    stats->write += w.seconds;
    stats->write_bytes += w.bytes;
    stats->write_mapped = w.method && w.method[0] == 'm';
}

/* Collective: both files are written and closed before either is renamed;
 * the errors file is renamed first, so a failure there leaves the old
 * matrix in place too. (Both destinations were checked up front.) */
static rad_status commit_outputs(ff_run *run, const ff_files *files, rad_status st)
{
    if (files->matrix) st = ff_output_close(files->matrix, st);
    if (files->errors) st = ff_output_close(files->errors, st);
    if (files->matrix) add_written(&run->stats, files->matrix);
    if (files->errors) add_written(&run->stats, files->errors);
    if (files->errors) st = ff_output_commit(files->errors, st);
    if (files->matrix) st = ff_output_commit(files->matrix, st);
    return st;
}

static rad_status run_formfactor(ff_run *run)
{
    int rank = ff_comm_rank(run->comm);
    run->start = rad_clock_seconds();
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
    double t_cuda = rad_clock_seconds();
    run->gpus = run->opt.backend != FF_BACKEND_CPU ? ff_cuda_device_count() : 0;
    run->stats.cuda_start = rad_clock_seconds() - t_cuda;
    ff_progress_init(&run->progress, run->comm, (uint32_t)run->mesh.patch_count, run->opt.progress_seconds);
    if ((st = ff_comm_agree(run->comm, setup(run))) != RAD_OK) return st;
    if (rank == 0)
        rad_info("%s: %zu patches from %zu faces, %u samples and %u shadow rays per pair, %d rank(s) x %d thread(s), "
                 "backend %s",
                 run->opt.scene_path ? run->opt.scene_path : rad_default_scene_name, run->mesh.patch_count,
                 run->scene.face_count, run->opt.samples, run->opt.shadow_rays, ff_comm_size(run->comm),
                 run->stats.threads, run->backend->name);
    if (run->opt.dry_run) {
        if (rank == 0)
            rad_info("dry run: load %.3f s, contacts and mesh %.3f s, patches and occluders' BVH %.3f s; %zu faces, "
                     "%zu patches; nothing computed or written",
                     run->stats.load, run->stats.subdivide, run->stats.setup, run->scene.face_count,
                     run->mesh.patch_count);
        return RAD_OK;
    }
    double t_estimate = rad_clock_seconds();
    /* Under -q only for --max-seconds, which needs the time (the line is not shown). */
    if (rank == 0 && (rad_log_get_level() >= RAD_LOG_INFO || run->opt.max_seconds > 0)) {
        ff_estimate_inputs inputs = {.backend = run->backend, .backend_state = run->backend_state,
                                     .records = run->records, .want_errors = run->want_errors, .plan = &run->plan,
                                     .options = &run->opt};
        st = ff_progress_estimate(&run->progress, &inputs);
    }
    run->stats.estimate = rad_clock_seconds() - t_estimate;
    if (run->opt.max_seconds > 0) st = ff_comm_agree(run->comm, st); /* every rank knows the option */
    if (st != RAD_OK) return st;

    ff_files files = {0};
    double t0 = rad_clock_seconds();
    st = open_outputs(run, &files);
    run->stats.io += rad_clock_seconds() - t0;
    ff_progress_start(&run->progress);
    if (st == RAD_OK) st = compute_and_write(run, &files);
    ff_progress_finish(&run->progress);
    t0 = rad_clock_seconds();
    st = commit_outputs(run, &files, st);
    run->stats.io += rad_clock_seconds() - t0;
    run->stats.total = rad_clock_seconds() - run->start;
    if (st == RAD_OK && !run->solve && rank == 0)
        rad_info("wrote %s%s%s", run->opt.output, run->opt.errors_path ? " and " : "",
                 run->opt.errors_path ? run->opt.errors_path : "");
    if (st == RAD_OK) st = write_stats(run);
    if (st == RAD_OK && run->solve) {
        /* The GPU's memory back before solve's upload; then the solve. */
        run->backend->destroy(run->backend_state);
        run->backend_state = NULL;
        st = ff_solve_run(run->comm, run->solve, run->row_begin, &run->opt, run->stats.threads);
    }
    return st;
}

static void run_free(ff_run *run)
{
    if (run->backend && run->backend_state) run->backend->destroy(run->backend_state);
    free(run->patches);
    free(run->area);
    ff_refinement_free(&run->refinement);
    free(run->triangles);
    free(run->triangle_face);
    free(run->row_begin);
    ff_solve_free(run->solve);
    rad_mesh_free(&run->mesh);
    rad_scene_free(&run->scene);
}

/* --method auto: hierarchical where the --subdiv mesh would have more
 * than FF_AUTO_HIERARCHICAL_PATCHES patches (counted from the scene, which
 * every rank loads the same), said on stderr with the reason. */
static ff_method resolve_method(ff_comm *comm, const ff_options *options)
{
    if (options->method != FF_METHOD_AUTO) return options->method;
    if (options->refine_path || options->reuse_path || options->errors_path || options->subdiv_only)
        return FF_METHOD_FULL; /* options of full matrices */
    int rank = ff_comm_rank(comm);
    rad_log_level level = rad_log_get_level();
    if (rank != 0) rad_log_set_level(RAD_LOG_NONE);
    rad_scene scene;
    uint64_t n = 0;
    if (ff_load_scene(options, &scene) == RAD_OK) {
        rad_mesh_options mo = {.subdiv = options->subdiv, .contacts = options->contacts};
        n = rad_mesh_count_patches(&scene, &mo);
        rad_scene_free(&scene);
    }
    if (rank != 0) rad_log_set_level(level);
    ff_method method = n > FF_AUTO_HIERARCHICAL_PATCHES ? FF_METHOD_HIERARCHICAL : FF_METHOD_FULL;
    if (rank == 0)
        rad_info("--method auto: %s (the --subdiv %d mesh has %llu patches, %s %u)", ff_method_name(method),
                 options->subdiv, (unsigned long long)n, method == FF_METHOD_FULL ? "at most" : "over",
                 FF_AUTO_HIERARCHICAL_PATCHES);
    return method;
}

rad_status ff_driver_run(ff_comm *comm, const ff_options *options)
{
    /* --dry-run: the stages both methods share (load, contacts, mesh, BVH), the full path's way */
    if (!options->dry_run && resolve_method(comm, options) == FF_METHOD_HIERARCHICAL)
        return ff_hierarchical_run(comm, options);
    ff_run run = {.comm = comm, .opt = *options};
    rad_status status = run_formfactor(&run);
    run_free(&run);
    return status;
}
