/* iterate.h - what the solver's method files share (internal to solve/).
 *
 * solver.c owns a solve_run: the problem of one channel, the iterate and
 * the residual history. Each method (stationary.c: Jacobi, Gauss-Seidel;
 * cg.c: conjugate gradients) advances run->B and reports the residual of
 * every iterate through solve_run_record, which keeps the history, prints
 * progress and decides when to stop. Invariant: history[k] is the scaled
 * residual omega (solve_patch_residual) of iterate k, and run->iterations
 * is the index of the iterate in run->B.
 */
#ifndef SOLVE_ITERATE_H
#define SOLVE_ITERATE_H

#include <math.h>
#include <stddef.h>
#include <stdint.h>

#include "gpu.h"
#include "rad_status.h"
#include "residual.h"
#include "solver.h"

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

/* y_c = F x_c for c < count, n values each, in one pass over F on the
 * threads (products.c); each y_c[i] summed as solve_row_dot. */
/* Rows [begin, end) (those held: under mpirun a rank's block) of y_c = F·x_c. */
void solve_rows_multiply(const solve_rows *F, size_t begin, size_t end, size_t count, const double *const *x,
                         double *const *y);

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

/* Iterate until converged or the limit; RAD_OK either way (the caller
 * checks), another status on failure. run->B holds the last iterate. */
rad_status solve_jacobi(solve_run *run);
rad_status solve_gauss_seidel(solve_run *run);

/* Conjugate gradients as above. When CG cannot go on (stall, curvature
 * <= 0, recurrence drift), it returns RAD_OK with *out_stopped = 1 and the
 * reason in `why`; run->B then holds its best effort, to be finished by
 * another method. */
rad_status solve_cg(solve_run *run, int *out_stopped, char *why, size_t why_size);
/* The same for `count` channels of one matrix in lockstep: one pass over F
 * per iteration for all of them (cg.c). out_stopped[c] and why[c] (each
 * why_size bytes) per channel; a failure status if any channel failed.
 * With `gpu` (not NULL) the vector work runs there, SOLVE_GPU_LANES
 * channels at a time, from and back into run->B; the control (stopping,
 * restarts, stalls) is the same code as on the CPU. */
rad_status solve_cg_many(solve_run *const *runs, size_t count, solve_gpu *gpu, int *out_stopped, char *const *why,
                         size_t why_size);
/* Jacobi for `count` channels on the GPU in lockstep (stationary.c), one
 * pass over F per sweep for SOLVE_GPU_LANES channels; each stops on its
 * own, as solve_jacobi. Without `gpu`, solve_jacobi one by one. */
rad_status solve_jacobi_many(solve_run *const *runs, size_t count, solve_gpu *gpu);

/* The GPU backend's solve of `count` channels (rounds.c; docs/solve.md,
 * "On the GPU"): CG or Jacobi lanes on the device, each result verified on
 * the host with the double matrix (solve_rows_multiply), and rounds of
 * mixed-precision refinement until the verified omega meets the
 * tolerance. */
typedef struct solve_gpu_channel {
    solve_run *run;
    solve_method method;   /* SOLVE_CG or SOLVE_JACOBI */
    char *why;             /* CG: why it stopped, why_size bytes */
    size_t why_size;
    int stopped;           /* out: CG stopped; run->B is its best effort, for Gauss-Seidel to finish */
    double verified;       /* out: omega of run->B with the double matrix; NAN if not measured */
    double *product;       /* n values (the caller's): F·B with the double matrix, of the B verified */
    uint32_t rounds;       /* out: rounds on the GPU */
} solve_gpu_channel;

/* Rounds at most; each costs a pass over the double matrix on the host
 * (two when the device's floats are not exact). Two suffice for the
 * tolerances solve allows (docs/solve.md). */
#define SOLVE_GPU_MAX_ROUNDS 4
/* Rounds after the first aim this much below the tolerance, so that the
 * host's verification, which sums in another order, agrees: where B is
 * large against E (rho near 1) the two omegas differ by ~1e-12, and a slow
 * Jacobi can stop within 1 % of the tolerance (measured: emulated, a
 * sphere at rho = 0.99). It costs log(0.5)/log(rate) more iterations, and
 * only when a second round is needed anyway. */
#define SOLVE_GPU_ROUND_MARGIN 0.5

rad_status solve_gpu_channels(solve_gpu *gpu, solve_gpu_channel *channels, size_t count);

/* The check that decides whether CG may run (SOLVE_CG_RECIPROCITY in
 * solver.h), over patches with rho > 0:
 *   delta_i = sum_j |A_i F_ij - A_j F_ji| / (2 A_i)   (skew part of K)
 *   m_i     = 1/rho_i - sum_j F_ij                     (diagonal-dominance margin)
 * with sums over reflecting columns. Two different failures: a row with
 * m_i <= 0 (K need not be positive definite, however reciprocal F is),
 * and delta_i > SOLVE_CG_RECIPROCITY * m_i (F not reciprocal enough for
 * the margin it has). */
typedef struct solve_cg_check {
    double ratio;             /* max delta_i / m_i over rows with m_i > 0; 0 if none */
    size_t ratio_row;         /* where, with its delta_i and m_i: */
    double ratio_delta, ratio_margin;
    double margin;            /* min m_i; +inf if no patch reflects */
    size_t margin_row;
    size_t no_margin_count;   /* rows with m_i <= 0 */
    rad_status status;        /* RAD_OK; else the check could not be made (logged; the same on every rank) */
} solve_cg_check;

/* Across ranks each rank checks its rows (the skew term needs F_ji for
 * them: the transposed tiles come from their owners, solve_comm_exchange)
 * and the results are combined, the same bits as one process alone. A
 * run with row_end 0 checks all n rows. */
solve_cg_check solve_cg_check_matrix(const solve_run *run);
/* 1 if CG may run. */
int solve_cg_check_passes(const solve_cg_check *check);
/* Why CG may not run, in words (the two cases above), into why. */
void solve_cg_check_describe(const solve_cg_check *check, char *why, size_t why_size);

#endif
