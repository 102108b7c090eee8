/* solver.c - one channel's solve: defaults, method choice and fallback,
 * the residual history, progress and the final verified residual. The
 * methods themselves live in stationary.c and cg.c. */
#define _POSIX_C_SOURCE 200809L
#include "solver.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

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

double solve_now(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

solve_verdict solve_run_record(solve_run *run, double residual)
{
    size_t k = run->iterations;
    if (k >= run->history_cap) {
        size_t cap = run->history_cap ? 2 * run->history_cap : 256;
        double *grown = realloc(run->history, cap * sizeof(double));
        if (!grown) {
            rad_error("%s: out of memory for the residual history", run->label);
            return SOLVE_FAILED;
        }
        run->history = grown;
        run->history_cap = cap;
    }
    run->history[k] = residual;
    run->history_count = k + 1;
    if (!isfinite(residual)) {
        rad_error("%s: residual is not finite at iteration %zu (overflow: is some emission near the largest "
                  "double?)",
                  run->label, k);
        return SOLVE_FAILED;
    }
    if (run->progress_seconds >= 0) {
        double now = solve_now();
        if (now - run->last_progress_time >= run->progress_seconds) {
            rad_info("%s: iteration %zu, residual %.3g (target %.3g), %.0f s", run->label, k, residual,
                     run->tolerance, now - run->start_time);
            run->last_progress_time = now;
        }
    }
    if (residual <= run->tolerance) return SOLVE_CONVERGED;
    if (k >= run->max_iterations) return SOLVE_LIMIT;
    return SOLVE_CONTINUE;
}

double solve_run_residual(const solve_run *run, const double *B)
{
    const size_t n = run->n;
    double rmax = 0;
    for (size_t i = 0; i < n; i++) {
        double gathered = run->E[i] + run->rho[i] * solve_dot(run->F + i * n, B, 0, n);
        double a = solve_patch_residual(gathered - B[i], gathered, run->e_norm);
        if (!(a <= rmax)) rmax = a; /* keeps NaN */
    }
    return rmax;
}

/* Picks the method to start with; CG only if the reciprocity check passes. */
static solve_method choose_method(solve_run *run, solve_method asked, solve_report *rep)
{
    if (asked != SOLVE_AUTO && asked != SOLVE_CG) return asked;
    solve_cg_check check = solve_cg_check_matrix(run);
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

rad_status solve_channel(const solve_system *system, const double *rho, const double *emission,
                         const solve_params *params, double *out_radiosity, solve_report *out_report)
{
    rad_status status = RAD_OK;
    solve_report rep;
    memset(&rep, 0, sizeof rep);
    rep.reciprocity = -1;
    rep.margin = NAN;
    const size_t n = system->patch_count;
    solve_run run = {
        .n = n,
        .F = system->form_factors,
        .area = system->area,
        .row_sum = system->row_sum,
        .rho = rho,
        .E = emission,
        .tolerance = params->tolerance > 0 ? params->tolerance : SOLVE_DEFAULT_TOLERANCE,
        .max_iterations = params->max_iterations ? params->max_iterations : SOLVE_DEFAULT_MAX_ITERATIONS,
        .label = params->label ? params->label : "channel",
        .progress_seconds = params->progress_seconds ? params->progress_seconds : SOLVE_DEFAULT_PROGRESS_SECONDS,
    };
    double *buffers = NULL;
    if (!(run.tolerance < 1) || !isfinite(run.tolerance)) {
        rad_error("%s: tolerance %g must lie in (0, 1)", run.label, run.tolerance);
        status = RAD_ERR_USAGE;
        goto done;
    }
    size_t worst_row;
    const double c = contraction(&run, &worst_row);
    if (!(c < 1)) {
        rad_error("%s: row %zu: rho * row sum = %.9g >= 1: the patch would reflect at least all the light "
                  "that reaches it, so no iteration is sure to converge (lower rho, or form factors whose rows "
                  "sum to 1; docs/solve.md)",
                  run.label, worst_row, c);
        status = RAD_ERR_INVALID;
        goto done;
    }
    run.start_time = run.last_progress_time = solve_now();
    for (size_t i = 0; i < n; i++)
        if (emission[i] > run.e_norm) run.e_norm = emission[i];
    buffers = malloc(2 * n * sizeof(double));
    if (!buffers) {
        rad_error("%s: out of memory for %zu patches", run.label, n);
        status = RAD_ERR_NOMEM;
        goto done;
    }
    run.B = buffers;
    run.work = buffers + n;
    memcpy(run.B, emission, n * sizeof(double)); /* start from B = E */

    if (run.e_norm == 0) { /* nothing emits: B = 0 exactly */
        rep.method_used = params->method == SOLVE_AUTO ? SOLVE_CG : params->method;
        run.e_norm = 1;
        if (solve_run_record(&run, 0) == SOLVE_FAILED) {
            status = RAD_ERR_NOMEM;
            goto done;
        }
    } else {
        solve_method method = choose_method(&run, params->method, &rep);
        status = run_methods(&run, method, &rep);
        if (status != RAD_OK) goto done;
        rep.residual = solve_run_residual(&run, run.B);
        if (!isfinite(rep.residual)) {
            rad_error("%s: the solution is not finite (overflow: is some emission near the largest double?)",
                      run.label);
            status = RAD_ERR_INVALID;
            goto done;
        }
        run.history[run.iterations] = rep.residual; /* the verified value */
    }
    rep.error_bound = rep.residual * run.e_norm / (1 - c);
    rep.balance = solve_balance_compute(system, rho, emission, run.B, run.work);
    rep.iterations = run.iterations;
    rep.converged = rep.residual <= run.tolerance;
    rep.seconds = solve_now() - run.start_time;
    rep.history = run.history;
    rep.history_count = run.history_count;
    run.history = NULL;
    if (!rep.converged) {
        rad_error("%s: not converged: residual %.3g > tolerance %.3g after %u iterations (%s)", run.label,
                  rep.residual, run.tolerance, rep.iterations, solve_method_name(rep.method_used));
        status = RAD_ERR_NOT_CONVERGED;
    }
    memcpy(out_radiosity, run.B, n * sizeof(double));
    *out_report = rep;
done:
    free(run.history);
    free(buffers);
    return status;
}

void solve_report_free(solve_report *report)
{
    if (!report) return;
    free(report->history);
    memset(report, 0, sizeof *report);
}
