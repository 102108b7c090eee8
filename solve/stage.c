/* stage.c - the solve stage in three steps: load (open the file, choose
 * the backend, read and check the rows, upload them to the GPU), solve
 * (the channels together, once for grey scenes; solve_channels) and write
 * (the radiosity, the stats, the results by group). A file of links
 * (hierarchical radiosity) goes, once open, to links.c.
 *
 * Across ranks (docs/solve.md, "Across ranks"): every rank opens the file
 * and reads the patch table, then only its block of rows
 * (solve_matrix_split_rows); the row sums (and row errors) are gathered so
 * that the checks before solving run alike on every rank. Rank 0 alone
 * logs what every rank would log alike and writes the outputs; the other
 * ranks log only errors of their own rows. Each phase ends with
 * solve_comm_agree, so every rank returns the same status. */
#include "stage.h"
#include "rad_clock.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#ifdef _OPENMP
#include <omp.h>
#endif

#include "groups.h"
#include "links.h"
#include "matrix.h"
#include "rad_ffile.h"
#include "rad_log.h"
#include "rad_rfile.h"
#include "rad_scene.h"
#include "shaped.h"
#include "stats.h"

static const char *const backend_names[] = {"auto", "cpu", "cuda"};

const char *solve_backend_name(solve_backend backend)
{
    return (unsigned)backend < sizeof backend_names / sizeof backend_names[0] ? backend_names[backend] : "unknown";
}

rad_status solve_backend_parse(const char *name, solve_backend *out_backend)
{
    for (unsigned b = 0; b < sizeof backend_names / sizeof backend_names[0]; b++) {
        if (strcmp(name, backend_names[b]) != 0) continue;
        if (b == SOLVE_BACKEND_CUDA && !solve_gpu_built()) {
            rad_error("--backend cuda: this build of solve has no CUDA (nvcc was not found when it was "
                      "configured, or -DRAD_WITH_CUDA=OFF); --backend cpu or auto solves on the CPU");
            return RAD_ERR_USAGE;
        }
        *out_backend = (solve_backend)b;
        return RAD_OK;
    }
    rad_error("unknown backend '%s' (expected auto, cpu or cuda)", name);
    return RAD_ERR_USAGE;
}

int solve_mesh_is_grey(const rad_mesh *mesh)
{
    for (size_t i = 0; i < mesh->patch_count; i++) {
        const rad_patch *p = &mesh->patches[i];
        if (p->rho[0] != p->rho[1] || p->rho[0] != p->rho[2] || p->emission[0] != p->emission[1] ||
            p->emission[0] != p->emission[2])
            return 0;
    }
    return 1;
}

static const char *const rgb_names[3] = {"red", "green", "blue"};
static const char *const grey_names[1] = {"grey"};

/* What the three steps share; what the stage allocates is freed in one
 * place (stage_state_free). */
typedef struct stage_state {
    /* the run */
    const solve_options *options;
    const char *input, *output;         /* resolved: never NULL */
    solve_comm *comm;
    int rank, ranks;
    rad_log_level asked;                /* the log level the stage was called with */
    double t0;                          /* rad_clock_seconds() at the start */
    /* the load step's */
    solve_backend backend;              /* alone: auto until the matrix is loaded, then cpu or cuda */
    size_t mesh_n;                      /* N, from the file's header */
    double load_seconds, upload_seconds;
    const rad_mesh *mesh;               /* the file's (borrowed from it) */
    solve_row_sum_summary row_sums;
    int grey;                           /* solved once, stored in all three channels */
    uint32_t channels;                  /* 1 when grey, else 3 */
    /* the solve step's */
    rad_status solved;                  /* RAD_OK, or RAD_ERR_NOT_CONVERGED: written all the same */
    /* owned */
    rad_ff_file *file;                  /* options->matrix (borrowed) or opened here */
    solve_matrix matrix;
    solve_gpu *gpu;                     /* the matrix on the GPU (--backend cuda), or NULL */
    size_t *row_split;                  /* ranks + 1: each rank's first row */
    uint64_t *rank_counts;              /* 2 x ranks: rows, then stored entries, of each rank */
    double *rho, *emission, *channel_b; /* 3 * N each, channel c at c * N */
    double *radiosity;                  /* N * 3 */
    solve_report reports[3];
} stage_state;

static void stage_state_free(stage_state *s)
{
    solve_gpu_destroy(s->gpu);
    if (s->file != s->options->matrix) rad_ff_close(s->file);
    solve_matrix_free(&s->matrix);
    free(s->row_split);
    free(s->rank_counts);
    free(s->rho);
    free(s->emission);
    free(s->channel_b);
    free(s->radiosity);
    for (int c = 0; c < 3; c++) solve_report_free(&s->reports[c]);
}

/* Does the file hold links (hierarchical radiosity, issue 26), which
 * links.c solves, rather than a matrix? */
static int file_holds_links(const rad_ff_info *info)
{
    return info->layout == RAD_FF_LAYOUT_LINKS;
}

/* Will a file of links ask for the GPU? --backend cuda for its shaped
 * solve; auto, alone, where it has enough leaves that the point factors
 * may reach SOLVE_SHAPED_GPU_MIN_WEIGHTS (SOLVE_SHAPED_GPU_PRESTART_LEAVES). */
static int links_may_use_gpu(const solve_options *options, int ranks, const rad_ff_info *info)
{
    if (options->no_shape || !solve_gpu_built()) return 0;
    return options->backend == SOLVE_BACKEND_CUDA ||
           (options->backend == SOLVE_BACKEND_AUTO && ranks == 1 &&
            info->patch_count >= SOLVE_SHAPED_GPU_PRESTART_LEAVES);
}

/* Stored entries of the matrix: its header's estimate (a sparse file's
 * record bytes over the element's size), before it is read. */
static uint64_t stored_entries_estimate(const rad_ff_info *info)
{
    if (file_holds_links(info)) return 0; /* solved on the CPU */
    if (info->layout != RAD_FF_LAYOUT_SPARSE) return info->patch_count * info->patch_count;
    return info->matrix_bytes / (info->element_type == RAD_ELEMENT_F32 ? 4 : 8);
}

/* The backend to use, once the file's header is read: cuda without a
 * visible GPU refused; alone, auto stays auto until the matrix is loaded
 * (auto_backend) - or cpu where it cannot be cuda. Under mpirun every
 * rank must take the same (the split of the rows depends on it), so auto
 * decides here, by the header's estimate of the stored entries, and the
 * ranks agree: cuda only where every rank sees a GPU. */
static rad_status resolve_backend(solve_comm *comm, solve_backend asked, int ranks, const rad_ff_info *info,
                                  solve_backend *out_backend)
{
    if (ranks > 1 && asked != SOLVE_BACKEND_CPU) {
        int want = asked == SOLVE_BACKEND_CUDA ||
                   (solve_gpu_built() && stored_entries_estimate(info) >= SOLVE_GPU_AUTO_MIN_ENTRIES);
        int can = want && solve_gpu_built() && solve_gpu_device_count() > 0;
        rad_status status = RAD_OK;
        if (asked == SOLVE_BACKEND_CUDA && !can) {
            rad_error("--backend cuda: rank %d sees no CUDA device (no GPU, no driver, a build without CUDA, or "
                      "CUDA_VISIBLE_DEVICES hides them); --backend cpu solves on the CPUs",
                      solve_comm_rank(comm));
            status = RAD_ERR_BACKEND;
        }
        if ((status = solve_comm_agree(comm, status)) != RAD_OK) return status;
        int all = solve_comm_max(comm, can ? 0.0 : 1.0) == 0.0; /* every rank can */
        *out_backend = want && all ? SOLVE_BACKEND_CUDA : SOLVE_BACKEND_CPU;
        return RAD_OK;
    }
    if (ranks > 1) {
        *out_backend = SOLVE_BACKEND_CPU;
        return RAD_OK;
    }
    if (asked == SOLVE_BACKEND_CUDA && !solve_gpu_built()) {
        rad_error("--backend cuda: this build of solve has no CUDA (nvcc was not found when it was configured, or "
                  "-DRAD_WITH_CUDA=OFF); --backend cpu or auto solves on the CPU");
        return RAD_ERR_UNSUPPORTED;
    }
    if (asked == SOLVE_BACKEND_CUDA && solve_gpu_device_count() == 0) {
        rad_error("--backend cuda: no CUDA device is visible (no GPU, no driver, or CUDA_VISIBLE_DEVICES hides them); "
                  "--backend cpu or auto solves on the CPU");
        return RAD_ERR_BACKEND;
    }
    if (asked == SOLVE_BACKEND_AUTO)
        *out_backend = solve_gpu_built() ? SOLVE_BACKEND_AUTO : SOLVE_BACKEND_CPU;
    else
        *out_backend = asked;
    return RAD_OK;
}

/* auto, once the matrix is loaded: the GPU for matrices large enough to
 * repay starting CUDA and the upload (SOLVE_GPU_AUTO_MIN_ENTRIES), when
 * one is visible; else the CPU. */
static solve_backend auto_backend(const solve_matrix *m)
{
    uint64_t entries = m->form_factors ? (uint64_t)(m->row_end - m->row_begin) * m->patch_count : m->value_count;
    return entries >= SOLVE_GPU_AUTO_MIN_ENTRIES && solve_gpu_device_count() > 0 ? SOLVE_BACKEND_CUDA
                                                                                : SOLVE_BACKEND_CPU;
}

/* gpu.h's exchange between the ranks' GPUs: comm.h's gather. */
static rad_status gather_for_gpu(void *user, const size_t *split, double *const *arrays, size_t count)
{
    return solve_comm_gather_split((solve_comm *)user, split, arrays, count);
}

/* The matrix onto the GPU for the cuda backend: this rank's rows onto its
 * GPU (rank mod the devices) under mpirun. Under auto a failure (not
 * enough GPU memory, say) leaves the CPU to do the work - on every rank,
 * which agree; under cuda it is the stage's failure. */
static rad_status upload_matrix(stage_state *s, const char *input, solve_backend asked, solve_backend *backend,
                                double *out_seconds)
{
    double t = rad_clock_seconds();
    *out_seconds = 0;
    if (*backend != SOLVE_BACKEND_CUDA) return RAD_OK;
    solve_gpu_tiles tiles;
    const solve_matrix *m = &s->matrix;
    /* The layout on the host; the values are converted to floats while they
     * are copied (solve_gpu_tiles_layout_rows), never held whole here. */
    rad_status status = solve_gpu_tiles_layout_rows(&m->rows, m->row_begin, m->row_end, &tiles);
    double built = rad_clock_seconds() - t;
    if (status == RAD_OK) {
        int devices = solve_gpu_device_count();
        solve_gpu_ranks ranks = {.n = m->patch_count, .ranks = (size_t)s->ranks, .row_split = s->row_split,
                                 .rank = (size_t)s->rank, .device = devices > 0 ? s->rank % devices : 0,
                                 .gather = s->ranks > 1 ? gather_for_gpu : NULL, .user = s->comm};
        status = solve_gpu_create_ranks(&tiles, m->area, &ranks, &s->gpu);
        solve_gpu_tiles_free(&tiles);
    }
    /* exact (no refinement rounds) only where every rank's rows are floats */
    double inexact = solve_comm_max(s->comm, status == RAD_OK && !solve_gpu_exact(s->gpu) ? 1.0 : 0.0);
    if (status == RAD_OK) solve_gpu_set_exact(s->gpu, inexact == 0.0);
    if (s->ranks > 1) status = solve_comm_agree(s->comm, status);
    if (status != RAD_OK) {
        solve_gpu_destroy(s->gpu);
        s->gpu = NULL;
        if (asked == SOLVE_BACKEND_CUDA) return status;
        rad_warn("%s: the matrix could not go to the GPU (above): --backend auto solves on the CPU", input);
        *backend = SOLVE_BACKEND_CPU;
        return RAD_OK;
    }
    *out_seconds = rad_clock_seconds() - t;
    char where[64] = "";
    if (s->ranks > 1) snprintf(where, sizeof where, " on each of %d ranks (its rows; rank 0's)", s->ranks);
    rad_info("%s: backend cuda%s: %s, the matrix resident as float tiles (%.2f GiB, %s) in %.2f s (its layout "
             "built on the host in %.2f s, the values converted to floats as they were copied)",
             input, where, solve_gpu_device_name(s->gpu), solve_gpu_matrix_bytes(s->gpu) / 1073741824.0,
             solve_gpu_exact(s->gpu) ? "exact: the file stores f32"
                                     : "rounded from double: results refined against the double matrix",
             *out_seconds, built);
    return RAD_OK;
}

/* Who logs: rank 0 as asked; another rank nothing in phases that every
 * rank goes through alike (rank 0 says it once), and errors only where it
 * works on its own rows. */
typedef enum stage_voice { STAGE_ALIKE, STAGE_OWN_ROWS } stage_voice;

static void stage_speak(solve_comm *comm, rad_log_level asked, stage_voice voice)
{
    if (solve_comm_rank(comm) == 0) return;
    rad_log_set_level(voice == STAGE_OWN_ROWS && asked >= RAD_LOG_ERROR ? RAD_LOG_ERROR : RAD_LOG_NONE);
}

/* The GPU backend's reductions add chunks of solve_gpu_row_quantum rows:
 * each rank's first row at the nearest chunk boundary (the cost balance
 * moves by less than a chunk), so that every chunk lies on one rank.
 * Rank 0 keeps at least one chunk: a system's rows [0, 0) would read as
 * all of them (solver.h), so only the last ranks may be left empty. */
void solve_stage_align_split(size_t *row_split, size_t ranks, size_t n)
{
    const size_t q = solve_gpu_row_quantum(n);
    for (size_t r = 1; r < ranks; r++) {
        size_t at = (row_split[r] + q / 2) / q * q;
        if (r == 1 && at == 0) at = q;
        if (at > n) at = n;
        if (at < row_split[r - 1]) at = row_split[r - 1];
        row_split[r] = at;
    }
}

/* Splits the rows over the ranks and reads this rank's; then every rank
 * gets every row's sum (and error): the checks before solving need them. */
static rad_status load_rows(stage_state *s, solve_comm *comm, const solve_options *options, const char *input,
                            rad_log_level asked)
{
    const size_t ranks = (size_t)solve_comm_size(comm), rank = (size_t)solve_comm_rank(comm);
    s->row_split = malloc((ranks + 1) * sizeof *s->row_split);
    s->rank_counts = calloc(2 * ranks, sizeof *s->rank_counts);
    rad_status status = s->row_split && s->rank_counts ? RAD_OK : RAD_ERR_NOMEM;
    if (status != RAD_OK) rad_error("%s: out of memory for the row split of %zu ranks", input, ranks);
    status = solve_comm_agree(comm, status);
    if (status != RAD_OK) return status;
    if (options->row_split) { /* the rows the caller's matrix holds on each rank */
        memcpy(s->row_split, options->row_split, (ranks + 1) * sizeof *s->row_split);
    } else {
        solve_matrix_split_rows(s->file, ranks, s->row_split);
        if (ranks > 1 && s->backend == SOLVE_BACKEND_CUDA) solve_stage_align_split(s->row_split, ranks, s->mesh_n);
    }
    status = solve_comm_set_rows(comm, s->row_split);
    if (status != RAD_OK) return status;
    stage_speak(comm, asked, STAGE_OWN_ROWS);
    if (options->loaded) { /* the caller's rows, already in memory: taken over */
        s->matrix = *options->loaded;
        memset(options->loaded, 0, sizeof *options->loaded);
        if (s->matrix.row_begin != s->row_split[rank] || s->matrix.row_end != s->row_split[rank + 1]) {
            rad_error("internal: %s: rank %zu holds rows %zu..%zu, the split says %zu..%zu", input, rank,
                      s->matrix.row_begin, s->matrix.row_end, s->row_split[rank], s->row_split[rank + 1]);
            status = RAD_ERR_INVALID;
        }
    } else {
        status = solve_matrix_load(s->file, input, s->row_split[rank], s->row_split[rank + 1], &s->matrix);
    }
    status = solve_comm_agree(comm, status);
    if (status == RAD_OK && options->errors) {
        status = solve_matrix_load_errors(&s->matrix, s->file, input, options->errors);
        status = solve_comm_agree(comm, status);
    }
    stage_speak(comm, asked, STAGE_ALIKE);
    if (status != RAD_OK) return status;
    double *gathered[2] = {s->matrix.row_sum, s->matrix.row_error};
    status = solve_comm_gather_rows(comm, gathered, s->matrix.row_error ? 2 : 1);
    /* what each rank holds, for the stats */
    const solve_matrix *m = &s->matrix;
    uint64_t mine[2] = {m->row_end - m->row_begin,
                        m->form_factors ? (uint64_t)(m->row_end - m->row_begin) * m->patch_count : m->value_count};
    uint64_t *all = malloc(2 * ranks * sizeof *all);
    if (!all) status = RAD_ERR_NOMEM;
    status = solve_comm_agree(comm, status);
    if (status != RAD_OK) {
        free(all);
        return status;
    }
    solve_comm_allgather_bytes(comm, mine, sizeof mine, all);
    for (size_t r = 0; r < ranks; r++) {
        s->rank_counts[r] = all[2 * r];
        s->rank_counts[ranks + r] = all[2 * r + 1];
    }
    free(all);
    return RAD_OK;
}

/* Opens the file and decides the backend; refuses a file of standard
 * errors, and one without a group table under --by-group. */
static rad_status stage_open(stage_state *s)
{
    const solve_options *options = s->options;
    rad_status status = RAD_OK;
    if (options->matrix)
        s->file = options->matrix;
    else
        status = solve_comm_agree(s->comm, rad_ff_open(s->input, &s->file));
    if (status != RAD_OK) return status;
    /* Hierarchical radiosity's links (issue 26): links.c takes the file
     * from here; CUDA starts while the links load where the shaped solve
     * may run on the GPU (links.c, shaped.h). */
    if (file_holds_links(rad_ff_file_info(s->file))) {
        if (links_may_use_gpu(options, s->ranks, rad_ff_file_info(s->file))) solve_gpu_prestart(s->rank);
        return RAD_OK;
    }
    /* CUDA starts while the matrix loads where the GPU will be asked for
     * (under mpirun on the rank's device, rank mod the devices). */
    if (options->backend != SOLVE_BACKEND_CPU && solve_gpu_built() &&
        (options->backend == SOLVE_BACKEND_CUDA ||
         stored_entries_estimate(rad_ff_file_info(s->file)) >= SOLVE_GPU_AUTO_MIN_ENTRIES))
        solve_gpu_prestart(s->rank);
    s->mesh_n = rad_ff_file_mesh(s->file)->patch_count;
    status = solve_comm_agree(s->comm, resolve_backend(s->comm, options->backend, s->ranks,
                                                       rad_ff_file_info(s->file), &s->backend));
    if (status != RAD_OK) return status;
    if (rad_ff_file_info(s->file)->flags & RAD_FF_FLAG_STANDARD_ERRORS) {
        rad_error("%s: holds the standard errors of a form-factor matrix (formfactor --errors), not form factors",
                  s->input);
        return RAD_ERR_INVALID;
    }
    if (options->by_group && rad_ff_file_mesh(s->file)->group_count == 0) {
        rad_error("%s: has no group table (the OBJ groups of its patches, which formfactor records since "
                  "form-factor file version 2): --by-group needs one; run formfactor again",
                  s->input);
        return RAD_ERR_INVALID;
    }
    return RAD_OK;
}

/* The load step, once the file is open: this rank's rows read and checked
 * against the patch table, the channels' buffers, the matrix on the GPU
 * when it goes there. */
static rad_status stage_load(stage_state *s)
{
    rad_status status = load_rows(s, s->comm, s->options, s->input, s->asked);
    if (status != RAD_OK) return status;
    s->load_seconds = rad_clock_seconds() - s->t0;
    const rad_mesh *mesh = s->mesh = rad_ff_file_mesh(s->file);
    const size_t n = mesh->patch_count;
    status = solve_matrix_check_reflectance(&s->matrix, mesh, s->input);
    if (status != RAD_OK) return status;
    s->row_sums = solve_matrix_warn_row_sums(&s->matrix, s->input);
    s->rho = malloc(3 * n * sizeof(double));
    s->emission = malloc(3 * n * sizeof(double));
    s->channel_b = malloc(3 * n * sizeof(double));
    s->radiosity = malloc(3 * n * sizeof(double));
    status = s->rho && s->emission && s->channel_b && s->radiosity ? RAD_OK : RAD_ERR_NOMEM;
    if (status != RAD_OK) rad_error("%s: out of memory for %zu patches", s->input, n);
    status = solve_comm_agree(s->comm, status);
    if (status != RAD_OK) return status;
    int emits = 0;
    for (size_t i = 0; i < n && !emits; i++)
        emits = mesh->patches[i].emission[0] > 0 || mesh->patches[i].emission[1] > 0 || mesh->patches[i].emission[2] > 0;
    if (!emits)
        rad_warn("%s: no patch emits light (no material has Ke > 0): every radiosity is 0 and an image of it is "
                 "black. " RAD_SCENE_NO_LIGHT_HINT,
                 s->input);
    s->grey = solve_mesh_is_grey(mesh);
    s->channels = s->grey ? 1 : 3;
    rad_info("%s: %zu patches, %s, loaded in %.2f s", s->input, n, s->grey ? "grey (solved once)" : "RGB",
             s->load_seconds);
    if (s->backend == SOLVE_BACKEND_AUTO) s->backend = auto_backend(&s->matrix);
    status = upload_matrix(s, s->input, s->options->backend, &s->backend, &s->upload_seconds);
    if (status != RAD_OK) return status;
    if (s->ranks > 1)
        rad_info("%s: rows split over %d ranks: rank 0 holds %llu rows (%llu stored entries)", s->input, s->ranks,
                 (unsigned long long)s->rank_counts[0], (unsigned long long)s->rank_counts[s->ranks]);
    return RAD_OK;
}

/* The solve step: the channels (one when grey) into s->radiosity, each
 * reported. A channel that does not converge sets s->solved and is still
 * written (RAD_OK here); another failure is returned. */
static rad_status stage_solve(stage_state *s)
{
    const size_t n = s->mesh->patch_count;
    const char *const *labels = s->grey ? grey_names : rgb_names;
    solve_system sys = solve_matrix_system(&s->matrix);
    sys.gpu = s->gpu;
    sys.comm = s->comm;
    const double *rho[3], *emission[3];
    double *b[3];
    solve_params p[3];
    for (uint32_t c = 0; c < s->channels; c++) {
        double *rc = s->rho + c * n, *ec = s->emission + c * n;
        for (size_t i = 0; i < n; i++) {
            rc[i] = s->mesh->patches[i].rho[c];
            ec[i] = s->mesh->patches[i].emission[c];
        }
        rho[c] = rc;
        emission[c] = ec;
        b[c] = s->channel_b + c * n;
        p[c] = s->options->params;
        p[c].label = labels[c];
    }
    solve_channels_result joint;
    const char *backend = sys.gpu ? "cuda" : "cpu";
    rad_status status = solve_channels(&sys, s->channels, rho, emission, p, b, s->reports, &joint);
    if (status != RAD_OK && status != RAD_ERR_NOT_CONVERGED) return status;
    s->solved = status;
    for (uint32_t c = 0; c < s->channels; c++) {
        for (size_t i = 0; i < n; i++)
            for (uint32_t k = s->grey ? 0 : c; k <= (s->grey ? 2 : c); k++) s->radiosity[3 * i + k] = b[c][i];
        const solve_report *r = &s->reports[c];
        char rounds[48] = "";
        if (r->rounds > 1) snprintf(rounds, sizeof rounds, " (%u rounds)", r->rounds);
        rad_info("%s: %s: %s, %u iterations, residual %.3g, %.3f s, backend %s%s", s->input, labels[c],
                 solve_method_name(r->method_used), r->iterations, r->residual, r->seconds, backend, rounds);
        rad_info("%s: %s: energy: emitted %.9g, absorbed %.9g, escaped %.9g (imbalance %.2g)", s->input,
                 labels[c], r->balance.emitted, r->balance.absorbed, r->balance.escaped, r->balance.imbalance);
    }
    if (joint.lockstep_channels > 1)
        rad_info("%s: %s on %zu channels in lockstep (one pass over the matrix per iteration): %.3f s", s->input,
                 sys.gpu ? "the GPU" : "CG", joint.lockstep_channels, joint.lockstep_seconds);
    return RAD_OK;
}

/* The tolerance the channels were solved to. */
static double stage_tolerance(const stage_state *s)
{
    return s->options->params.tolerance > 0 ? s->options->params.tolerance : SOLVE_DEFAULT_TOLERANCE;
}

void solve_radiosity_describe(const rad_ff_info *info, const char *input, int speak, rad_radiosity *out)
{
    out->scene_fingerprint = info->scene_fingerprint;
    if (info->flags & RAD_FF_FLAG_KE_RADIANCE) out->flags |= RAD_RF_FLAG_KE_RADIANCE;
    /* The scene's path, for render's camera sidecar: only a real path that
     * fits whole (not the built-in box's name). */
    const char *scene = info->scene_name;
    if (strcmp(scene, rad_default_scene_name) != 0 && strlen(scene) < sizeof out->scene_path)
        memcpy(out->scene_path, scene, strlen(scene) + 1);
    else if (strcmp(scene, rad_default_scene_name) != 0 && speak)
        /* A cut path would name another file; none is better, and said. */
        rad_warn("%s: the scene path %s is %zu bytes%s; the radiosity file holds at most %zu, so it records "
                 "none and render cannot find the scene's camera sidecar: give render --camera FILE",
                 input, scene, strlen(scene),
                 strlen(scene) + 1 == sizeof info->scene_name ? " (or more: formfactor cuts scene names there)" : "",
                 sizeof out->scene_path - 1);
}

/* The radiosity file (rank 0 writes it), marked unconverged when a
 * channel did not converge. */
static rad_status write_radiosity(const stage_state *s)
{
    rad_status status = RAD_OK;
    rad_radiosity out;
    memset(&out, 0, sizeof out);
    out.mesh = *s->mesh; /* borrowed from the file; not freed here */
    out.radiosity = s->radiosity;
    out.channel_count = s->channels;
    out.method = (uint32_t)s->reports[0].method_used;
    out.converged = s->solved == RAD_OK;
    out.tolerance = stage_tolerance(s);
    solve_radiosity_describe(rad_ff_file_info(s->file), s->input, s->rank == 0, &out);
    for (uint32_t c = 0; c < 3; c++) {
        const solve_report *r = &s->reports[s->grey ? 0 : c];
        out.iterations[c] = r->iterations;
        out.residual[c] = r->residual;
        out.channel_method[c] = (uint32_t)r->method_used;
    }
    if (s->rank == 0) status = rad_rf_write(s->output, &out);
    return solve_comm_agree(s->comm, status);
}

/* The --stats JSON (rank 0 writes it). */
static rad_status write_stats(const stage_state *s)
{
    const solve_options *options = s->options;
    rad_status status = RAD_OK;
    solve_stats st = {
        .input = s->input,
        .output = s->output,
        .errors = options->errors,
        .row_sums = s->row_sums,
        .patch_count = s->mesh->patch_count,
        .method = options->params.method,
        .tolerance = stage_tolerance(s),
        .max_iterations = options->params.max_iterations ? options->params.max_iterations
                                                         : SOLVE_DEFAULT_MAX_ITERATIONS,
        .load_seconds = s->load_seconds,
        .backend = solve_backend_name(s->backend),
        .device = s->gpu ? solve_gpu_device_name(s->gpu) : NULL,
        .device_exact = s->gpu ? solve_gpu_exact(s->gpu) : -1,
        .upload_seconds = s->upload_seconds,
        .total_seconds = rad_clock_seconds() - s->t0,
        .converged = s->solved == RAD_OK,
        .channel_count = s->channels,
        .rank_count = (uint32_t)s->ranks,
        .rank_rows = s->rank_counts,
        .rank_entries = s->rank_counts + s->ranks,
    };
    for (uint32_t c = 0; c < s->channels; c++) {
        st.channel_names[c] = s->grey ? "grey" : rgb_names[c];
        st.reports[c] = &s->reports[c];
    }
    if (s->rank == 0) status = solve_stats_write(options->stats, &st);
    return solve_comm_agree(s->comm, status);
}

/* The write step: the radiosity file, then the stats and the results by
 * group when asked for; RAD_ERR_NOT_CONVERGED once all is written if a
 * channel did not converge. */
static rad_status stage_write(stage_state *s)
{
    const solve_options *options = s->options;
    rad_status status = write_radiosity(s);
    if (status == RAD_OK && options->stats) status = write_stats(s);
    if (status == RAD_OK && options->by_group) {
        solve_system sys = solve_matrix_system(&s->matrix);
        sys.comm = s->comm;
        status = solve_groups_write(options->by_group, &sys, s->mesh, s->radiosity);
    }
    if (status != RAD_OK) return status;
    if (s->solved != RAD_OK) {
        rad_error("%s: not converged; wrote %s marked unconverged (raise --max-iter or try --method cg)", s->input,
                  s->output);
        return s->solved;
    }
    rad_info("%s: wrote %s%s%s", s->input, s->output, options->by_group ? " and " : "",
             options->by_group ? options->by_group : "");
    return RAD_OK;
}

rad_status solve_stage_run(const solve_options *options)
{
    stage_state s;
    memset(&s, 0, sizeof s);
    s.options = options;
    s.input = options->input ? options->input : SOLVE_DEFAULT_INPUT;
    s.output = options->output ? options->output : SOLVE_DEFAULT_OUTPUT;
    s.comm = options->comm;
    s.rank = solve_comm_rank(s.comm);
    s.ranks = solve_comm_size(s.comm);
    s.asked = rad_log_get_level();
    s.t0 = rad_clock_seconds();
    s.backend = SOLVE_BACKEND_CPU;
#ifdef _OPENMP
    if (options->threads > 0) omp_set_num_threads(options->threads);
#endif
    stage_speak(s.comm, s.asked, STAGE_ALIKE);
    rad_status status = stage_open(&s);
    if (status == RAD_OK && file_holds_links(rad_ff_file_info(s.file))) {
        /* hierarchical radiosity: links.c reads, solves and writes */
        status = solve_links_run(options, s.file);
    } else {
        if (status == RAD_OK) status = stage_load(&s);
        if (status == RAD_OK) status = stage_solve(&s);
        if (status == RAD_OK) status = stage_write(&s);
    }
    stage_state_free(&s);
    solve_gpu_prestart_join();
    rad_log_set_level(s.asked);
    return status;
}
