/* cg_check.h - the reciprocity check that decides whether CG may run on a
 * channel (cg_check.c; SOLVE_CG_RECIPROCITY in solver.h). Internal to
 * solve/.
 *
 * Over patches with rho > 0:
 *   delta_i = sum_j |A_i F_ij - A_j F_ji| / (2 A_i)   (skew part of K)
 *   m_i     = 1/rho_i - sum_j F_ij                     (diagonal-dominance margin)
 * with sums over reflecting columns. Two different failures: a row with
 * m_i <= 0 (K need not be positive definite, however reciprocal F is),
 * and delta_i > SOLVE_CG_RECIPROCITY * m_i (F not reciprocal enough for
 * the margin it has). */
#ifndef SOLVE_CG_CHECK_H
#define SOLVE_CG_CHECK_H

#include <stddef.h>

#include "rad_status.h"
#include "run.h"

typedef struct solve_cg_check {
    double ratio;             /* max delta_i / m_i over rows with m_i > 0; 0 if none */
    size_t ratio_row;         /* where, with its delta_i and m_i: */
    double ratio_delta, ratio_margin;
    double margin;            /* min m_i; +inf if no patch reflects */
    size_t margin_row;
    size_t no_margin_count;   /* rows with m_i <= 0 */
    rad_status status;        /* RAD_OK; else the check could not be made (logged; the same on every rank) */
} solve_cg_check;

/* The check of run's matrix for run's rho, using run->work as scratch and
 * run->skew (when set) to share the skew term between channels. Across
 * ranks each rank checks its rows (the skew term needs F_ji for them: the
 * transposed tiles come from their owners, solve_comm_exchange) and the
 * results are combined, the same bits as one process alone. A run with
 * row_end 0 checks all n rows. */
solve_cg_check solve_cg_check_matrix(const solve_run *run);
/* 1 if CG may run. */
int solve_cg_check_passes(const solve_cg_check *check);
/* Why CG may not run, in words (the two cases above), into why. */
void solve_cg_check_describe(const solve_cg_check *check, char *why, size_t why_size);

#endif
