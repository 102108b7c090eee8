/* iterate.h - what the solver's method files share (internal to solve/).
 *
 * solver.c owns a solve_run: the problem of one channel, the iterate and
 * the residual history. Each method (stationary.c: Jacobi, Gauss-Seidel;
 * cg.c: conjugate gradients) advances run->B and reports the residual of
 * every iterate through solve_run_record, which keeps the history, prints
 * progress and decides when to stop. Invariant: history[k] is the relative
 * residual of iterate k, and run->iterations is the index of the iterate in
 * run->B.
 */
#ifndef SOLVE_ITERATE_H
#define SOLVE_ITERATE_H

#include <stddef.h>
#include <stdint.h>

#include "rad_status.h"
#include "solver.h"

typedef struct solve_run {
    /* the problem (borrowed) */
    size_t n;
    const double *F;        /* n * n */
    const double *area;     /* n */
    const double *row_sum;  /* n */
    const double *rho;      /* n, this channel */
    const double *E;        /* n, this channel */
    double e_norm;          /* ||E||_inf > 0 */
    double tolerance;
    uint32_t max_iterations;
    /* state (owned by solver.c) */
    double *B;              /* current iterate */
    double *work;           /* n scratch, the methods' to use */
    uint32_t iterations;
    double *history;
    size_t history_count, history_cap;
    /* progress */
    const char *label;
    double progress_seconds; /* < 0: never */
    double start_time, last_progress_time;
} solve_run;

typedef enum solve_verdict {
    SOLVE_CONTINUE = 0,
    SOLVE_CONVERGED, /* residual <= tolerance */
    SOLVE_LIMIT,     /* iterations == max_iterations */
    SOLVE_FAILED     /* residual not finite, or out of memory (logged) */
} solve_verdict;

/* Records `residual` as history[run->iterations] (replacing an earlier value
 * for the same iterate), logs progress now and then, and says whether to
 * go on. */
solve_verdict solve_run_record(solve_run *run, double residual);

/* ||E + diag(rho)·F·B - B||_inf / ||E||_inf, computed afresh. */
double solve_run_residual(const solve_run *run, const double *B);

/* sum_{j in [begin, end)} row[j] * x[j], left to right. */
static inline double solve_dot(const double *row, const double *x, size_t begin, size_t end)
{
    double s = 0;
    for (size_t j = begin; j < end; j++) s += row[j] * x[j];
    return s;
}

/* Iterate until converged or the limit; RAD_OK either way (the caller
 * checks), another status on failure. run->B holds the last iterate. */
rad_status solve_jacobi(solve_run *run);
rad_status solve_gauss_seidel(solve_run *run);

/* Conjugate gradients as above. When CG cannot go on (stall, curvature
 * <= 0, recurrence drift), it returns RAD_OK with *out_stopped = 1 and the
 * reason in `why`; run->B then holds its best effort, to be finished by
 * another method. */
rad_status solve_cg(solve_run *run, int *out_stopped, char *why, size_t why_size);

/* max_i delta_i / m_i over patches with rho > 0 (see SOLVE_CG_RECIPROCITY
 * in solver.h); +inf if some margin m_i <= 0; 0 if no patch reflects. */
double solve_cg_reciprocity(const solve_run *run);

#endif
