/* solver.h - solves (I - diag(rho)·F)·B = E for one colour channel.
 *
 * Usage:
 *     solve_system sys = {.patch_count = n, .form_factors = F, .area = A,
 *                         .row_sum = s};
 *     solve_params p = {0};                      // zero = defaults
 *     solve_report rep;
 *     rad_status st = solve_channel(&sys, rho, E, &p, B, &rep);
 *     if (st == RAD_OK || st == RAD_ERR_NOT_CONVERGED) { ... B, rep ... }
 *     solve_report_free(&rep);
 *
 * Methods (docs/solve.md):
 *  - Jacobi:        B_i += r_i / (1 - rho_i F_ii), all rows from the old B.
 *  - Gauss-Seidel:  the same update, in place, row by row.
 *  - CG:            conjugate gradients, preconditioned by the diagonal, on
 *                   K = diag(A/rho) - diag(A)·F, which is symmetric positive
 *                   definite when A_i F_ij = A_j F_ji and rho·(row sum) < 1.
 *                   Patches with rho = 0 are eliminated (B = E). CG runs only
 *                   when the reciprocity check passes (SOLVE_CG_RECIPROCITY);
 *                   otherwise, or when CG stalls, the solve says so and
 *                   continues with Gauss-Seidel from where CG stopped.
 *  - auto:          CG when the reciprocity check passes, else Gauss-Seidel.
 * Every method starts from B = E, accumulates in double precision, and stops
 * when the scaled residual of the returned B,
 *     omega = max_i |r_i| / min(||E||_inf, s_i),
 *     r = E + diag(rho)·F·B - B,  s_i = E_i + rho_i sum_j F_ij B_j = B_i + r_i,
 * is <= tolerance (verified with a fresh product at the end), or after
 * max_iterations. The ||E|| part is the normwise rule (error bound below);
 * the s_i part holds every patch to its own brightness, so a 1e-6 light in
 * a room of its own is solved as accurately as a 1e6 one beside it
 * (docs/solve.md, "Stopping rule"). Rows are summed in a fixed order, so
 * results do not depend on the number of OpenMP threads.
 */
#ifndef SOLVE_SOLVER_H
#define SOLVE_SOLVER_H

#include <stddef.h>
#include <stdint.h>

#include "gpu.h"
#include "comm.h"
#include "rad_rfile.h"
#include "rad_status.h"
#include "rows.h"

/* Default stopping tolerance on the scaled residual omega. The solver's error
 * in the displayed image is then at most ~1e-4 of the smallest 8-bit step
 * on the Cornell box, so it never decides a pixel's code (docs/solve.md:
 * the bound, and renders at 1e-6 ... 1e-12 compared pixel by pixel). */
#define SOLVE_DEFAULT_TOLERANCE 1e-10
/* Default iteration limit: Jacobi needs about ln(tol)/ln(rho) iterations,
 * 23,000 at rho = 0.999 and tol = 1e-10; CG needs tens. */
#define SOLVE_DEFAULT_MAX_ITERATIONS 100000u
/* Seconds between progress messages of a long solve. */
#define SOLVE_DEFAULT_PROGRESS_SECONDS 2.0
/* CG is used only if, for every patch i with rho_i > 0,
 *   delta_i = sum_j |A_i F_ij - A_j F_ji| / (2 A_i)  <=  0.1 * m_i,
 *   m_i     = 1/rho_i - sum_j F_ij  (the diagonal-dominance margin),
 * sums over patches with rho > 0. Then the symmetric part of K is provably
 * positive definite (Gershgorin) and its skew part is small against it. */
#define SOLVE_CG_RECIPROCITY 0.1
/* CG has stalled when its residual sets no new minimum for this many
 * iterations (at most 3 restarts after recurrence drift). */
#define SOLVE_CG_STALL_WINDOW 100u
#define SOLVE_CG_MAX_RESTARTS 3

typedef enum solve_method {
    SOLVE_AUTO = 0,
    SOLVE_JACOBI = RAD_SOLVE_JACOBI,
    SOLVE_GAUSS_SEIDEL = RAD_SOLVE_GAUSS_SEIDEL,
    SOLVE_CG = RAD_SOLVE_CG
} solve_method;

/* "auto", "jacobi", "gauss-seidel", "cg". */
const char *solve_method_name(solve_method method);
/* Parses one of those names; RAD_ERR_USAGE (logged) otherwise. */
rad_status solve_method_parse(const char *name, solve_method *out_method);

typedef struct solve_params {
    solve_method method;       /* 0 = auto */
    double tolerance;          /* on omega (above); 0 = SOLVE_DEFAULT_TOLERANCE */
    uint32_t max_iterations;   /* 0 = SOLVE_DEFAULT_MAX_ITERATIONS */
    double progress_seconds;   /* 0 = SOLVE_DEFAULT_PROGRESS_SECONDS; < 0 = never */
    const char *label;         /* names the channel in messages; NULL = "channel" */
} solve_params;

/* The matrix, shared by all channels; nothing here is copied or freed.
 * Under mpirun (comm, docs/solve.md "Across ranks") a process holds and
 * updates only rows [row_begin, row_end); every vector still has N values,
 * and every rank calls the solver with the same arguments but its rows. */
typedef struct solve_system {
    size_t patch_count;          /* N >= 1 */
    const double *form_factors;  /* held rows x N, F_ij at (i - row_begin) * N + j, validated;
                                    NULL when `sparse` */
    const double *area;          /* N patch areas (> 0) */
    const double *row_sum;       /* N row sums of F (every row, also those held elsewhere) */
    const solve_rows *sparse;    /* the stored tiles of a sparse file (rows.h), or NULL */
    solve_gpu *gpu;              /* the same matrix resident on a GPU (gpu.h), or NULL: iterate on
                                    the CPU. Verification stays on the CPU with the matrix above. */
    size_t row_begin, row_end;   /* the rows held here; row_end 0: all N */
    /* > 0: the file is reciprocal by construction (RAD_FF_FLAG_RECIPROCAL):
     * |A_i F_ij - A_j F_ji| <= reciprocity_bound A_i F_ij, and the CG check
     * bounds its skew term with it instead of measuring it (no pass over F
     * and its transpose, no exchange across ranks). 0: measured. */
    double reciprocity_bound;
    solve_comm *comm;            /* the ranks (comm.h); NULL: this process alone */
} solve_system;

/* The rows of `system` (rows.h): its sparse tiles, or its dense matrix. */
static inline solve_rows solve_system_rows(const solve_system *system)
{
    if (system->sparse) return *system->sparse;
    return (solve_rows){.n = system->patch_count, .dense = system->form_factors, .first_row = system->row_begin};
}

/* The rows held: [*begin, *end). */
static inline void solve_system_held(const solve_system *system, size_t *begin, size_t *end)
{
    *begin = system->row_end ? system->row_begin : 0;
    *end = system->row_end ? system->row_end : system->patch_count;
}

/* Where the light of one channel goes (docs/solve.md, "Energy balance").
 * Powers are area x radiosity. With H_i = sum_j F_ij B_j (what patch i
 * receives per unit area) and reciprocity (A_i F_ij = A_j F_ji),
 * emitted = absorbed + escaped holds exactly for the exact B; the
 * imbalance of a solution is its residual, sum_i A_i r_i, plus the
 * matrix's reciprocity defect, relative to what is emitted. */
typedef struct solve_balance {
    double emitted;   /* sum_i A_i E_i */
    double absorbed;  /* sum_i A_i (1 - rho_i) H_i */
    double escaped;   /* sum_j A_j B_j (1 - sum_i F_ji): leaves through openings; < 0 where rows sum above 1 */
    double imbalance; /* (absorbed + escaped - emitted) / emitted; 0 when nothing emits */
} solve_balance;

/* The balance of B (n values) for `system`; `scratch` holds n doubles.
 * Rows are summed in a fixed order, so it does not depend on threads. */
solve_balance solve_balance_compute(const solve_system *system, const double *rho, const double *emission,
                                    const double *radiosity, double *scratch);
/* The same from H = F·B (n values), already computed. */
solve_balance solve_balance_of(const solve_system *system, const double *rho, const double *emission,
                               const double *radiosity, const double *H);

typedef struct solve_report {
    solve_method method_used;  /* the method that produced B */
    int fell_back;             /* 1 if CG was refused or stopped (fallback_reason) */
    char fallback_reason[320];
    uint32_t iterations;       /* updates that produced B (over all methods) */
    double residual;           /* verified final omega (>= ||r||_inf / ||E||_inf) */
    int converged;             /* residual <= tolerance */
    double seconds;            /* wall time of the solve */
    double reciprocity;        /* max_i delta_i / m_i (see above); +inf if some m_i <= 0; -1 if not measured */
    double margin;             /* min_i m_i over patches with rho > 0 (<= 0: K not diagonally
                                  dominant there, CG refused); NAN if not measured */
    double error_bound;        /* bound on ||B - B_exact||_inf: residual·||E||/(1 - max rho·rowsum) */
    uint32_t rounds;           /* rounds on the GPU (mixed-precision refinement, docs/solve.md); 0 on the CPU */
    solve_balance balance;     /* of the returned B */
    double *history;           /* history[k] = omega of iterate k,
                                  k = 0..iterations (owned) */
    size_t history_count;
} solve_report;

/* Solves one channel. rho and emission hold N values (rho in [0, 1),
 * emission >= 0). A system where rho_i * row_sum_i >= 1 for some i is
 * refused before any iteration (RAD_ERR_INVALID, logged; the stage names
 * the worst rows first, solve_matrix_check_reflectance). On RAD_OK and on
 * RAD_ERR_NOT_CONVERGED (iteration limit reached; message logged)
 * out_radiosity (N values) and *out_report are filled, the latter to be
 * released with solve_report_free; on any other status neither is
 * touched. */
rad_status solve_channel(const solve_system *system, const double *rho, const double *emission,
                         const solve_params *params, double *out_radiosity, solve_report *out_report);
void solve_report_free(solve_report *report); /* safe on zeroed */

/* What solving several channels together shared. */
typedef struct solve_channels_result {
    size_t lockstep_channels; /* channels whose CG ran in lockstep */
    double lockstep_seconds;  /* wall time of that joint CG */
} solve_channels_result;

/* Solves `count` channels of one system: channel c has rho[c], emission[c],
 * params[c] and writes out_radiosity[c], out_reports[c], each as
 * solve_channel would. Every channel is checked before any iterates; the
 * channels that use CG iterate in lockstep, one pass over F per iteration
 * for all of them (the same bits as one at a time); the others, and CG
 * channels that stopped and finish with Gauss-Seidel, follow one by one.
 * With system->gpu, CG and Jacobi channels iterate on the GPU in lockstep
 * and are verified (and refined) with the double matrix on the CPU
 * (solve_gpu_channels, rounds.h); Gauss-Seidel runs on the CPU.
 * Status: as solve_channel's, the worst over the channels; on
 * RAD_ERR_NOT_CONVERGED every channel's outputs are filled. A report's
 * seconds run from its channel's start to its end. */
rad_status solve_channels(const solve_system *system, size_t count, const double *const *rho,
                          const double *const *emission, const solve_params *params, double *const *out_radiosity,
                          solve_report *out_reports, solve_channels_result *out_result);

#endif
