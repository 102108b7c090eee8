/* run.c - the bookkeeping of one channel's run (run.h): the residual
 * history, progress messages, the stopping verdict, a verified residual,
 * and the clock they time with. */
#define _POSIX_C_SOURCE 200809L
#include "run.h"

#include <math.h>
#include <stdlib.h>

#include "rad_log.h"
#include "rad_clock.h"

solve_verdict solve_run_record(solve_run *run, double residual)
{
    size_t k = run->iterations;
    if (k >= run->history_cap) { /* at the same iteration on every rank: agreed */
        size_t cap = run->history_cap ? 2 * run->history_cap : 256;
        double *grown = realloc(run->history, cap * sizeof(double));
        if (grown) {
            run->history = grown;
            run->history_cap = cap;
        }
        if (solve_comm_agree(run->comm, grown ? RAD_OK : RAD_ERR_NOMEM) != RAD_OK) {
            rad_error("%s: out of memory for the residual history", run->label);
            return SOLVE_FAILED;
        }
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
        double now = rad_clock_seconds();
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

double solve_run_residual_of(const solve_run *run, const double *B, const double *FB)
{
    const size_t begin = run->row_begin, end = run->row_end;
    double rmax = 0;
    int not_finite = 0;
    for (size_t i = begin; i < end; i++) {
        double gathered = run->E[i] + run->rho[i] * FB[i];
        double a = solve_patch_residual(gathered - B[i], gathered, run->e_norm);
        if (a > rmax) rmax = a;
        not_finite |= isnan(a);
    }
    return solve_comm_max(run->comm, not_finite ? NAN : rmax); /* a NaN anywhere is the answer */
}
