/* stage.c - the solve stage: read and validate the form factors, solve
 * the channels together (once for grey scenes; solve_channels), write the
 * radiosity and stats. */
#include "stage.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "groups.h"
#include "matrix.h"
#include "rad_ffile.h"
#include "rad_log.h"
#include "rad_rfile.h"
#include "rad_scene.h"
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

static int scene_is_grey(const rad_mesh *mesh)
{
    for (size_t i = 0; i < mesh->patch_count; i++) {
        const rad_patch *p = &mesh->patches[i];
        if (p->rho[0] != p->rho[1] || p->rho[0] != p->rho[2] || p->emission[0] != p->emission[1] ||
            p->emission[0] != p->emission[2])
            return 0;
    }
    return 1;
}

/* Everything the stage allocates, freed in one place. */
typedef struct stage_state {
    rad_ff_file *file;
    solve_matrix matrix;
    solve_gpu *gpu;                     /* the matrix on the GPU (--backend cuda), or NULL */
    double *rho, *emission, *channel_b; /* 3 * N each, channel c at c * N */
    double *radiosity;                  /* N * 3 */
    solve_report reports[3];
} stage_state;

static void stage_state_free(stage_state *s)
{
    solve_gpu_destroy(s->gpu);
    rad_ff_close(s->file);
    solve_matrix_free(&s->matrix);
    free(s->rho);
    free(s->emission);
    free(s->channel_b);
    free(s->radiosity);
    for (int c = 0; c < 3; c++) solve_report_free(&s->reports[c]);
}

/* Solves the channels (one when grey) of `sys` into s->radiosity. */
static rad_status solve_system_all(stage_state *s, const solve_system *sys, const char *input, const rad_mesh *mesh,
                                   uint32_t channels, int grey, const solve_params *base, const char *const *labels)
{
    const size_t n = mesh->patch_count;
    const double *rho[3], *emission[3];
    double *b[3];
    solve_params p[3];
    for (uint32_t c = 0; c < channels; c++) {
        double *rc = s->rho + c * n, *ec = s->emission + c * n;
        for (size_t i = 0; i < n; i++) {
            rc[i] = mesh->patches[i].rho[c];
            ec[i] = mesh->patches[i].emission[c];
        }
        rho[c] = rc;
        emission[c] = ec;
        b[c] = s->channel_b + c * n;
        p[c] = *base;
        p[c].label = labels[c];
    }
    solve_channels_result joint;
    const char *backend = sys->gpu ? "cuda" : "cpu";
    rad_status status = solve_channels(sys, channels, rho, emission, p, b, s->reports, &joint);
    if (status != RAD_OK && status != RAD_ERR_NOT_CONVERGED) return status;
    for (uint32_t c = 0; c < channels; c++) {
        for (size_t i = 0; i < n; i++)
            for (uint32_t k = grey ? 0 : c; k <= (grey ? 2 : c); k++) s->radiosity[3 * i + k] = b[c][i];
        const solve_report *r = &s->reports[c];
        char rounds[48] = "";
        if (r->rounds > 1) snprintf(rounds, sizeof rounds, " (%u rounds)", r->rounds);
        rad_info("%s: %s: %s, %u iterations, residual %.3g, %.3f s, backend %s%s", input, labels[c],
                 solve_method_name(r->method_used), r->iterations, r->residual, r->seconds, backend, rounds);
        rad_info("%s: %s: energy: emitted %.9g, absorbed %.9g, escaped %.9g (imbalance %.2g)", input, labels[c],
                 r->balance.emitted, r->balance.absorbed, r->balance.escaped, r->balance.imbalance);
    }
    if (joint.lockstep_channels > 1)
        rad_info("%s: %s on %zu channels in lockstep (one pass over the matrix per iteration): %.3f s", input,
                 sys->gpu ? "the GPU" : "CG", joint.lockstep_channels, joint.lockstep_seconds);
    return status;
}

/* Solves the channels (one when grey) into s->radiosity. */
static rad_status solve_all(stage_state *s, const char *input, const rad_mesh *mesh, uint32_t channels, int grey,
                            const solve_params *base, const char *const *labels)
{
    solve_system sys = solve_matrix_system(&s->matrix);
    sys.gpu = s->gpu;
    return solve_system_all(s, &sys, input, mesh, channels, grey, base, labels);
}

/* The backend to use, before anything is read: auto resolved; cuda
 * without a visible GPU refused. */
static rad_status resolve_backend(solve_backend asked, solve_backend *out_backend)
{
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
        *out_backend = solve_gpu_built() && solve_gpu_device_count() > 0 ? SOLVE_BACKEND_CUDA : SOLVE_BACKEND_CPU;
    else
        *out_backend = asked;
    return RAD_OK;
}

/* The matrix onto the GPU for the cuda backend. Under auto a failure (not
 * enough GPU memory, say) leaves the CPU to do the work; under cuda it is
 * the stage's failure. */
static rad_status upload_matrix(stage_state *s, const char *input, solve_backend asked, solve_backend *backend,
                                double *out_seconds)
{
    double t = solve_now();
    *out_seconds = 0;
    if (*backend != SOLVE_BACKEND_CUDA) return RAD_OK;
    solve_gpu_tiles tiles;
    rad_status status = solve_gpu_tiles_make(&s->matrix.rows, &tiles);
    if (status == RAD_OK) {
        status = solve_gpu_create(&tiles, s->matrix.area, &s->gpu);
        solve_gpu_tiles_free(&tiles);
    }
    if (status != RAD_OK) {
        if (asked == SOLVE_BACKEND_CUDA) return status;
        rad_warn("%s: the matrix could not go to the GPU (above): --backend auto solves on the CPU", input);
        *backend = SOLVE_BACKEND_CPU;
        return RAD_OK;
    }
    *out_seconds = solve_now() - t;
    rad_info("%s: backend cuda: %s, the matrix resident as float tiles (%.2f GiB, %s) in %.2f s", input,
             solve_gpu_device_name(s->gpu), solve_gpu_matrix_bytes(s->gpu) / 1073741824.0,
             solve_gpu_exact(s->gpu) ? "exact: the file stores f32"
                                     : "rounded from double: results refined against the double matrix",
             *out_seconds);
    return RAD_OK;
}

rad_status solve_stage_run(const solve_options *options)
{
    static const char *const rgb_names[3] = {"red", "green", "blue"};
    const char *input = options->input ? options->input : SOLVE_DEFAULT_INPUT;
    const char *output = options->output ? options->output : SOLVE_DEFAULT_OUTPUT;
    rad_status status, solved = RAD_OK;
    stage_state s;
    memset(&s, 0, sizeof s);
    double t0 = solve_now(), upload_seconds = 0;
    solve_backend backend;

    status = resolve_backend(options->backend, &backend);
    if (status != RAD_OK) goto done;
    status = rad_ff_open(input, &s.file);
    if (status != RAD_OK) goto done;
    if (rad_ff_file_info(s.file)->flags & RAD_FF_FLAG_STANDARD_ERRORS) {
        rad_error("%s: holds the standard errors of a form-factor matrix (formfactor --errors), not form factors",
                  input);
        status = RAD_ERR_INVALID;
        goto done;
    }
    if (options->by_group && rad_ff_file_mesh(s.file)->group_count == 0) {
        rad_error("%s: has no group table (the OBJ groups of its patches, which formfactor records since "
                  "form-factor file version 2): --by-group needs one; run formfactor again",
                  input);
        status = RAD_ERR_INVALID;
        goto done;
    }
    status = solve_matrix_load(s.file, input, &s.matrix);
    if (status != RAD_OK) goto done;
    if (options->errors) {
        status = solve_matrix_load_errors(&s.matrix, s.file, input, options->errors);
        if (status != RAD_OK) goto done;
    }
    double load_seconds = solve_now() - t0;
    const rad_mesh *mesh = rad_ff_file_mesh(s.file);
    const size_t n = mesh->patch_count;
    status = solve_matrix_check_reflectance(&s.matrix, mesh, input);
    if (status != RAD_OK) goto done;
    const solve_row_sum_summary row_sums = solve_matrix_warn_row_sums(&s.matrix, input);
    s.rho = malloc(3 * n * sizeof(double));
    s.emission = malloc(3 * n * sizeof(double));
    s.channel_b = malloc(3 * n * sizeof(double));
    s.radiosity = malloc(3 * n * sizeof(double));
    if (!s.rho || !s.emission || !s.channel_b || !s.radiosity) {
        rad_error("%s: out of memory for %zu patches", input, n);
        status = RAD_ERR_NOMEM;
        goto done;
    }
    int emits = 0;
    for (size_t i = 0; i < n && !emits; i++)
        emits = mesh->patches[i].emission[0] > 0 || mesh->patches[i].emission[1] > 0 || mesh->patches[i].emission[2] > 0;
    if (!emits)
        rad_warn("%s: no patch emits light (no material has Ke > 0; Blender exports before 2.9 write no Ke): every "
                 "radiosity is 0 and an image of it is black",
                 input);
    const int grey = scene_is_grey(mesh);
    const uint32_t channels = grey ? 1 : 3;
    rad_info("%s: %zu patches, %s, loaded in %.2f s", input, n, grey ? "grey (solved once)" : "RGB", load_seconds);
    status = upload_matrix(&s, input, options->backend, &backend, &upload_seconds);
    if (status != RAD_OK) goto done;
    static const char *const grey_names[1] = {"grey"};
    status = solve_all(&s, input, mesh, channels, grey, &options->params, grey ? grey_names : rgb_names);
    if (status == RAD_ERR_NOT_CONVERGED)
        solved = status;
    else if (status != RAD_OK)
        goto done;

    rad_radiosity out;
    memset(&out, 0, sizeof out);
    out.mesh = *mesh; /* borrowed from the file; not freed here */
    out.radiosity = s.radiosity;
    out.channel_count = channels;
    out.method = (uint32_t)s.reports[0].method_used;
    out.converged = solved == RAD_OK;
    out.tolerance = options->params.tolerance > 0 ? options->params.tolerance : SOLVE_DEFAULT_TOLERANCE;
    out.scene_fingerprint = rad_ff_file_info(s.file)->scene_fingerprint;
    /* The scene's path, for render's camera sidecar: only a real path that
     * fits whole (not the built-in box's name). */
    const char *scene = rad_ff_file_info(s.file)->scene_name;
    if (strcmp(scene, rad_default_scene_name) != 0 && strlen(scene) < sizeof out.scene_path)
        memcpy(out.scene_path, scene, strlen(scene) + 1);
    for (uint32_t c = 0; c < 3; c++) {
        const solve_report *r = &s.reports[grey ? 0 : c];
        out.iterations[c] = r->iterations;
        out.residual[c] = r->residual;
        out.channel_method[c] = (uint32_t)r->method_used;
    }
    status = rad_rf_write(output, &out);
    if (status != RAD_OK) goto done;

    if (options->stats) {
        solve_stats st = {
            .input = input,
            .output = output,
            .errors = options->errors,
            .row_sums = row_sums,
            .patch_count = n,
            .method = options->params.method,
            .tolerance = out.tolerance,
            .max_iterations = options->params.max_iterations ? options->params.max_iterations
                                                             : SOLVE_DEFAULT_MAX_ITERATIONS,
            .load_seconds = load_seconds,
            .backend = solve_backend_name(backend),
            .device = s.gpu ? solve_gpu_device_name(s.gpu) : NULL,
            .device_exact = s.gpu ? solve_gpu_exact(s.gpu) : -1,
            .upload_seconds = upload_seconds,
            .total_seconds = solve_now() - t0,
            .converged = out.converged != 0,
            .channel_count = channels,
        };
        for (uint32_t c = 0; c < channels; c++) {
            st.channel_names[c] = grey ? "grey" : rgb_names[c];
            st.reports[c] = &s.reports[c];
        }
        status = solve_stats_write(options->stats, &st);
        if (status != RAD_OK) goto done;
    }
    if (options->by_group) {
        solve_system sys = solve_matrix_system(&s.matrix);
        status = solve_groups_write(options->by_group, &sys, mesh, s.radiosity);
        if (status != RAD_OK) goto done;
    }
    if (solved != RAD_OK) {
        rad_error("%s: not converged; wrote %s marked unconverged (raise --max-iter or try --method cg)", input,
                  output);
        status = solved;
    } else {
        rad_info("%s: wrote %s%s%s", input, output, options->by_group ? " and " : "",
                 options->by_group ? options->by_group : "");
    }
done:
    stage_state_free(&s);
    return status;
}
