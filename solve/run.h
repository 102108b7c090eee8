/* run.h - one channel's run: the problem, the iterate, the residual
 * history, and the bookkeeping every method calls (run.c). Internal to
 * solve/.
 *
 * solver.c sets up a solve_run per channel; each method (stationary.c:
 * Jacobi, Gauss-Seidel; cg.c: conjugate gradients; rounds.c: the GPU's
 * rounds) advances run->B and reports the residual of every iterate
 * through solve_run_record, which keeps the history, prints progress and
 * decides when to stop. Invariant: history[k] is the scaled residual omega
 * (solve_patch_residual) of iterate k, and run->iterations is the index of
 * the iterate in run->B.
 *
 * Nothing here calls back into solver.c: the methods depend on this file,
 * and solver.c on them (docs/architecture.md, "solve").
 */
#ifndef SOLVE_RUN_H
#define SOLVE_RUN_H

#include <math.h>
#include <stddef.h>
#include <stdint.h>

#include "comm.h"
#include "rad_status.h"
#include "residual.h"
#include "rows.h"

/* The CG check's skew term delta and each row's sum over reflecting
 * columns (below) depend on F, A and which patches reflect, not on rho's
 * values: channels that share those share them, and solve_channels
 * computes them once for them (each a pass over F: 6 s at N = 188 416). */
typedef struct solve_skew_cache {
    const double *rho; /* the channel it was computed for (its zero pattern); NULL: empty */
    double *delta;     /* n values (owned by whoever made the cache) */
    double *active;    /* n values: sum_j F_ij over reflecting j (owned likewise) */
} solve_skew_cache;

typedef struct solve_run {
    /* the problem (borrowed) */
    size_t n;
    solve_rows F;           /* the matrix (rows.h): rows [row_begin, row_end) */
    size_t row_begin, row_end; /* the rows this rank updates (0, n alone) */
    solve_comm *comm;       /* the ranks; NULL alone (comm.h) */
    const double *area;     /* n */
    const double *row_sum;  /* n */
    const double *rho;      /* n, this channel */
    const double *E;        /* n, this channel */
    double e_norm;          /* ||E||_inf > 0 */
    solve_skew_cache *skew; /* shared with other channels, or NULL */
    double reciprocity_bound; /* solve_system's: > 0, the skew term is bounded, not measured */
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

/* omega of B (see solve_patch_residual) from FB = F·B (solve_rows_multiply);
 * NaN if some patch's share is NaN. */
double solve_run_residual_of(const solve_run *run, const double *B, const double *FB);

/* solve_patch_residual and SOLVE_SCALE_FLOOR: residual.h (shared with the GPU). */

/* Row loops (Jacobi sweeps, CG's K·p) run on OpenMP threads only from this
 * many rows up. Below it a pass over F costs less than waking the threads:
 * measured (docs/solve.md, "Threads"), a parallel region costs ~40 us with
 * OMP_WAIT_POLICY=passive on 16 cores while a serial Jacobi sweep of 216
 * rows takes ~30 us; from ~300 rows up the threads win. Each row is summed by
 * one thread either way, so results are the same bit for bit. */
#define SOLVE_PARALLEL_MIN_ROWS 256

/* sum_{j in [begin, end)} row[j] * x[j], left to right. */
static inline double solve_dot(const double *row, const double *x, size_t begin, size_t end)
{
    double s = 0;
    for (size_t j = begin; j < end; j++) s += row[j] * x[j];
    return s;
}

#endif
