/* solver.c - the channels' solve (solver.h): defaults, the checks before
 * any iteration, method choice and fallback, CG (and on the GPU Jacobi)
 * channels in lockstep, the final verified residual and the report. The
 * methods live in stationary.c, cg.c and rounds.c, the CG check in
 * cg_check.c, each run's bookkeeping in run.c (iterate.h lists them); none
 * of them calls back into this file. */
#include "solver.h"
#include "rad_clock.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "iterate.h"
#include "rad_log.h"

static const char *const method_names[] = {"auto", "jacobi", "gauss-seidel", "cg"};

const char *solve_method_name(solve_method method)
{
    return (unsigned)method < sizeof method_names / sizeof method_names[0] ? method_names[method] : "unknown";
}

rad_status solve_method_parse(const char *name, solve_method *out_method)
{
    for (unsigned m = 0; m < sizeof method_names / sizeof method_names[0]; m++) {
        if (strcmp(name, method_names[m]) == 0) {
            *out_method = (solve_method)m;
            return RAD_OK;
        }
    }
    rad_error("unknown method '%s' (expected jacobi, gauss-seidel, cg or auto)", name);
    return RAD_ERR_USAGE;
}

/* Picks the method to start with; CG only if the reciprocity check passes. */
static solve_method choose_method(solve_run *run, solve_method asked, solve_report *rep, rad_status *out_status)
{
    *out_status = RAD_OK;
    if (asked != SOLVE_AUTO && asked != SOLVE_CG) return asked;
    solve_cg_check check = solve_cg_check_matrix(run);
    if (check.status != RAD_OK) {
        *out_status = check.status;
        return SOLVE_GAUSS_SEIDEL;
    }
    rep->reciprocity = check.no_margin_count ? INFINITY : check.ratio;
    rep->margin = check.margin;
    if (solve_cg_check_passes(&check)) return SOLVE_CG;
    solve_cg_check_describe(&check, rep->fallback_reason, sizeof rep->fallback_reason);
    rep->fell_back = 1;
    if (asked == SOLVE_CG)
        rad_warn("%s: %s; using gauss-seidel", run->label, rep->fallback_reason);
    else
        rad_info("%s: %s; auto picks gauss-seidel", run->label, rep->fallback_reason);
    return SOLVE_GAUSS_SEIDEL;
}

static rad_status run_methods(solve_run *run, solve_method method, solve_report *rep)
{
    if (method == SOLVE_JACOBI) {
        rep->method_used = SOLVE_JACOBI;
        return solve_jacobi(run);
    }
    if (method == SOLVE_CG) {
        int stopped = 0;
        rep->method_used = SOLVE_CG;
        rad_status status = solve_cg(run, &stopped, rep->fallback_reason, sizeof rep->fallback_reason);
        if (status != RAD_OK || !stopped) return status;
        rep->fell_back = 1;
        rad_warn("%s: %s; continuing with gauss-seidel from iteration %u", run->label, rep->fallback_reason,
                 run->iterations);
    }
    rep->method_used = SOLVE_GAUSS_SEIDEL;
    return solve_gauss_seidel(run);
}

/* max_i rho_i * row_sum_i: ||diag(rho)·F||_inf for F >= 0; *out_row
 * gets the row. */
static double contraction(const solve_run *run, size_t *out_row)
{
    double c = 0;
    *out_row = 0;
    for (size_t i = 0; i < run->n; i++) {
        double ci = run->rho[i] * run->row_sum[i];
        if (!(ci <= c)) { /* keeps NaN */
            c = ci;
            *out_row = i;
        }
    }
    return c;
}

/* One channel's solve from start to end, in three parts so that the CG
 * iterations of several channels can run in lockstep (solve_channels):
 * channel_begin checks and allocates and picks the method, the methods
 * iterate, channel_end verifies and reports. */
typedef struct channel_solve {
    solve_run run;
    solve_report rep;
    double c;          /* max rho_i * row sum_i */
    double *buffers;
    solve_method method;
    int trivial;       /* nothing emits: B = 0, no iteration */
    int has_product;   /* the caller's product holds F·run.B already (the GPU's rounds verified it) */
} channel_solve;

static void channel_free(channel_solve *ch)
{
    free(ch->run.history);
    free(ch->buffers);
    ch->run.history = NULL;
    ch->buffers = NULL;
}

static rad_status channel_begin(const solve_system *system, const double *rho, const double *emission,
                                const solve_params *params, solve_skew_cache *skew, channel_solve *ch)
{
    memset(ch, 0, sizeof *ch);
    ch->rep.reciprocity = -1;
    ch->rep.margin = NAN;
    const size_t n = system->patch_count;
    solve_run *run = &ch->run;
    *run = (solve_run){
        .n = n,
        .F = solve_system_rows(system),
        .comm = system->comm,
        .area = system->area,
        .row_sum = system->row_sum,
        .rho = rho,
        .E = emission,
        .skew = skew,
        .reciprocity_bound = system->reciprocity_bound,
        .tolerance = params->tolerance > 0 ? params->tolerance : SOLVE_DEFAULT_TOLERANCE,
        .max_iterations = params->max_iterations ? params->max_iterations : SOLVE_DEFAULT_MAX_ITERATIONS,
        .label = params->label ? params->label : "channel",
        .progress_seconds = params->progress_seconds ? params->progress_seconds : SOLVE_DEFAULT_PROGRESS_SECONDS,
    };
    solve_system_held(system, &run->row_begin, &run->row_end);
    if (!(run->tolerance < 1) || !isfinite(run->tolerance)) {
        rad_error("%s: tolerance %g must lie in (0, 1)", run->label, run->tolerance);
        return RAD_ERR_USAGE;
    }
    size_t worst_row;
    ch->c = contraction(run, &worst_row);
    if (!(ch->c < 1)) {
        rad_error("%s: row %zu: rho * row sum = %.9g >= 1: the patch would reflect at least all the light "
                  "that reaches it, so no iteration is sure to converge (lower rho, or form factors whose rows "
                  "sum to 1; docs/solve.md)",
                  run->label, worst_row, ch->c);
        return RAD_ERR_INVALID;
    }
    run->start_time = run->last_progress_time = rad_clock_seconds();
    for (size_t i = 0; i < n; i++)
        if (emission[i] > run->e_norm) run->e_norm = emission[i];
    ch->buffers = malloc(2 * n * sizeof(double));
    if (!ch->buffers) rad_error("%s: out of memory for %zu patches", run->label, n);
    rad_status status = solve_comm_agree(run->comm, ch->buffers ? RAD_OK : RAD_ERR_NOMEM);
    if (status != RAD_OK) return status;
    run->B = ch->buffers;
    run->work = ch->buffers + n;
    memcpy(run->B, emission, n * sizeof(double)); /* start from B = E */
    if (run->e_norm == 0) { /* nothing emits: B = 0 exactly */
        ch->trivial = 1;
        ch->rep.method_used = params->method == SOLVE_AUTO ? SOLVE_CG : params->method;
        run->e_norm = 1;
        if (solve_run_record(run, 0) == SOLVE_FAILED) return RAD_ERR_NOMEM;
        return RAD_OK;
    }
    ch->method = choose_method(run, params->method, &ch->rep, &status);
    return status;
}

/* `product` holds F·run.B with the double matrix (solve_rows_multiply). */
static rad_status channel_end(const solve_system *system, channel_solve *ch, const double *product,
                              double *out_radiosity, solve_report *out_report)
{
    solve_run *run = &ch->run;
    solve_report *rep = &ch->rep;
    if (!ch->trivial) {
        rep->residual = solve_run_residual_of(run, run->B, product);
        if (!isfinite(rep->residual)) {
            rad_error("%s: the solution is not finite (overflow: is some emission near the largest double?)",
                      run->label);
            return RAD_ERR_INVALID;
        }
        run->history[run->iterations] = rep->residual; /* the verified value */
    }
    rep->error_bound = rep->residual * run->e_norm / (1 - ch->c);
    rep->balance = solve_balance_of(system, run->rho, run->E, run->B, product);
    rep->iterations = run->iterations;
    rep->converged = rep->residual <= run->tolerance;
    rep->seconds = rad_clock_seconds() - run->start_time;
    rep->history = run->history;
    rep->history_count = run->history_count;
    run->history = NULL;
    rad_status status = RAD_OK;
    if (!rep->converged) {
        rad_error("%s: not converged: residual %.3g > tolerance %.3g after %u iterations (%s)", run->label,
                  rep->residual, run->tolerance, rep->iterations, solve_method_name(rep->method_used));
        status = RAD_ERR_NOT_CONVERGED;
    }
    memcpy(out_radiosity, run->B, run->n * sizeof(double));
    *out_report = *rep;
    return status;
}

rad_status solve_channel(const solve_system *system, const double *rho, const double *emission,
                         const solve_params *params, double *out_radiosity, solve_report *out_report)
{
    rad_status status;
    solve_channels_result result;
    status = solve_channels(system, 1, &rho, &emission, params, &out_radiosity, out_report, &result);
    (void)result;
    return status;
}

rad_status solve_channels(const solve_system *system, size_t count, const double *const *rho,
                          const double *const *emission, const solve_params *params, double *const *out_radiosity,
                          solve_report *out_reports, solve_channels_result *out_result)
{
    rad_status status = RAD_OK;
    channel_solve *ch = calloc(count, sizeof *ch);
    solve_run **cg_runs = calloc(count, sizeof *cg_runs);
    char **cg_why = calloc(count, sizeof *cg_why);
    int *cg_stopped = calloc(count, sizeof *cg_stopped);
    size_t *cg_channel = calloc(count, sizeof *cg_channel);
    solve_gpu_channel *lanes = calloc(count, sizeof *lanes);
    const size_t n = system->patch_count;
    double *products = malloc(count * n * sizeof *products); /* channel c's F·B at c * n */
    const double **product_x = calloc(count, sizeof *product_x);
    double **product_y = calloc(count, sizeof *product_y);
    memset(out_result, 0, sizeof *out_result);
    if (!ch || !cg_runs || !cg_why || !cg_stopped || !cg_channel || !lanes || !products || !product_x || !product_y) {
        rad_error("out of memory for %zu channels", count);
        status = RAD_ERR_NOMEM;
        goto done;
    }
    /* Checks first, every channel: a refused one stops the lot before any
     * iteration. Channels where the same patches reflect share the CG
     * check's skew term (without memory for it, each computes its own). */
    solve_skew_cache skew = {.delta = count > 1 ? malloc(system->patch_count * sizeof(double)) : NULL,
                             .active = count > 1 ? malloc(system->patch_count * sizeof(double)) : NULL};
    if (!skew.delta || !skew.active) { /* both or neither */
        free(skew.delta);
        free(skew.active);
        skew.delta = skew.active = NULL;
    }
    for (size_t c = 0; c < count; c++) {
        solve_params p = params[c];
        if ((status = channel_begin(system, rho[c], emission[c], &p, &skew, &ch[c])) != RAD_OK) break;
    }
    free(skew.delta);
    free(skew.active);
    for (size_t c = 0; c < count; c++) ch[c].run.skew = NULL;
    if (status != RAD_OK) goto done;
    /* CG channels together, one pass over F per iteration for all; on the
     * GPU Jacobi channels too, in rounds verified with the double matrix. */
    size_t cg_count = 0;
    for (size_t c = 0; c < count; c++) {
        int on_gpu = system->gpu && ch[c].method == SOLVE_JACOBI;
        if (ch[c].trivial || (ch[c].method != SOLVE_CG && !on_gpu)) continue;
        ch[c].rep.method_used = ch[c].method;
        lanes[cg_count] = (solve_gpu_channel){.run = &ch[c].run, .method = ch[c].method,
                                              .why = ch[c].rep.fallback_reason,
                                              .why_size = sizeof ch[0].rep.fallback_reason,
                                              .product = products + c * n};
        cg_runs[cg_count] = &ch[c].run;
        cg_why[cg_count] = ch[c].rep.fallback_reason;
        cg_channel[cg_count++] = c;
    }
    if (cg_count) {
        double t = rad_clock_seconds();
        if (system->gpu) {
            status = solve_gpu_channels(system->gpu, lanes, cg_count);
            for (size_t k = 0; k < cg_count; k++) {
                cg_stopped[k] = lanes[k].stopped;
                ch[cg_channel[k]].rep.rounds = lanes[k].rounds;
                ch[cg_channel[k]].has_product = !lanes[k].stopped && !isnan(lanes[k].verified);
            }
        } else {
            status = solve_cg_many(cg_runs, cg_count, NULL, cg_stopped, cg_why, sizeof ch[0].rep.fallback_reason);
        }
        out_result->lockstep_channels = cg_count;
        out_result->lockstep_seconds = rad_clock_seconds() - t;
        if (status != RAD_OK) goto done;
    }
    /* The rest one by one on the CPU: other methods, and CG channels that
     * stopped (finished by Gauss-Seidel from where CG left them). */
    for (size_t k = 0, c = 0; c < count; c++) {
        channel_solve *h = &ch[c];
        if (h->trivial) continue;
        int was_lane = k < cg_count && cg_channel[k] == c;
        if (was_lane) {
            int stopped = cg_stopped[k++];
            if (!stopped) continue;
            h->rep.fell_back = 1;
            rad_warn("%s: %s; continuing with gauss-seidel from iteration %u%s", h->run.label, h->rep.fallback_reason,
                     h->run.iterations, system->gpu ? " (on the CPU)" : "");
            h->rep.method_used = SOLVE_GAUSS_SEIDEL;
            status = solve_gauss_seidel(&h->run);
        } else {
            if (system->gpu)
                rad_info("%s: gauss-seidel is sequential, row after row: it runs on the CPU (the GPU runs cg and "
                         "jacobi)",
                         h->run.label);
            status = run_methods(&h->run, h->method, &h->rep);
        }
        if (status != RAD_OK) goto done;
    }
    /* F·B of every channel not verified yet, in one pass over F: the final
     * verification and the energy balance both come from it */
    size_t todo = 0;
    for (size_t c = 0; c < count; c++) {
        if (ch[c].has_product) continue;
        product_x[todo] = ch[c].run.B;
        product_y[todo++] = products + c * n;
    }
    solve_rows multiplied = solve_system_rows(system);
    size_t begin, end;
    solve_system_held(system, &begin, &end);
    solve_rows_multiply(&multiplied, begin, end, todo, product_x, product_y);
    for (size_t c = 0; c < count; c++) {
        rad_status st = channel_end(system, &ch[c], products + c * n, out_radiosity[c], &out_reports[c]);
        if (st == RAD_ERR_NOT_CONVERGED && status == RAD_OK) {
            status = st;
        } else if (st != RAD_OK && st != RAD_ERR_NOT_CONVERGED) {
            for (size_t d = 0; d < c; d++) solve_report_free(&out_reports[d]);
            status = st;
            goto done;
        }
    }
done:
    if (ch)
        for (size_t c = 0; c < count; c++) channel_free(&ch[c]);
    free(ch);
    free(cg_runs);
    free(cg_why);
    free(cg_stopped);
    free(cg_channel);
    free(lanes);
    free(products);
    free(product_x);
    free(product_y);
    return status;
}

void solve_report_free(solve_report *report)
{
    if (!report) return;
    free(report->history);
    memset(report, 0, sizeof *report);
}
