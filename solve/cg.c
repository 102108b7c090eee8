/* cg.c - conjugate gradients on K = diag(A/rho) - diag(A)·F, and the
 * reciprocity check that decides whether CG may run.
 *
 * Multiplying row i of (I - diag(rho)·F)·B = E by A_i/rho_i gives K·B = b
 * with K_ij = (A_i/rho_i)·delta_ij - A_i F_ij, symmetric when
 * A_i F_ij = A_j F_ji. Patches with rho_i = 0 keep B_i = E_i and are left
 * out: search directions are zero there, so their B never changes and
 * their contribution to the other rows stays on the right-hand side.
 * The residual of K·B = b is r_K = diag(A/rho)·r, and what patch i gathers
 * is s_i = B_i + r_i, so the stopping rule (omega, iterate.h) costs nothing
 * extra. Preconditioner: M_i = K_ii.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "iterate.h"
#include "rad_log.h"
#include "solver.h"

/* Rows of the reciprocity check handled together, for cache reuse. */
#define CG_TILE 64

solve_cg_check solve_cg_check_matrix(const solve_run *run)
{
    const size_t n = run->n;
    const double *F = run->F, *A = run->area, *rho = run->rho;
    double *delta = run->work; /* sum_j |A_i F_ij - A_j F_ji| per row */
    for (size_t i = 0; i < n; i++) delta[i] = 0;
    for (size_t i0 = 0; i0 < n; i0 += CG_TILE) {
        size_t i1 = i0 + CG_TILE < n ? i0 + CG_TILE : n;
        for (size_t j0 = i0; j0 < n; j0 += CG_TILE) {
            size_t j1 = j0 + CG_TILE < n ? j0 + CG_TILE : n;
            for (size_t i = i0; i < i1; i++) {
                if (rho[i] == 0) continue;
                for (size_t j = (j0 > i + 1 ? j0 : i + 1); j < j1; j++) {
                    if (rho[j] == 0) continue;
                    double d = fabs(A[i] * F[i * n + j] - A[j] * F[j * n + i]);
                    delta[i] += d;
                    delta[j] += d;
                }
            }
        }
    }
    solve_cg_check c = {.margin = INFINITY};
    for (size_t i = 0; i < n; i++) {
        if (rho[i] == 0) continue;
        double active_sum = 0; /* row sum over reflecting columns */
        const double *row = F + i * n;
        for (size_t j = 0; j < n; j++)
            if (rho[j] != 0) active_sum += row[j];
        double margin = 1 / rho[i] - active_sum, skew = delta[i] / (2 * A[i]);
        if (margin < c.margin) {
            c.margin = margin;
            c.margin_row = i;
        }
        if (!(margin > 0)) {
            c.no_margin_count++;
        } else if (skew / margin > c.ratio) {
            c.ratio = skew / margin;
            c.ratio_row = i;
            c.ratio_delta = skew;
            c.ratio_margin = margin;
        }
    }
    return c;
}

int solve_cg_check_passes(const solve_cg_check *check)
{
    return check->no_margin_count == 0 && check->ratio <= SOLVE_CG_RECIPROCITY;
}

void solve_cg_check_describe(const solve_cg_check *check, char *why, size_t why_size)
{
    if (check->no_margin_count)
        snprintf(why, why_size,
                 "no diagonal-dominance margin for CG: %zu rows have m_i = 1/rho_i - sum_j F_ij <= 0 (smallest: "
                 "row %zu, m = %.3g), so K need not be positive definite (see docs/solve.md)",
                 check->no_margin_count, check->margin_row, check->margin);
    else
        snprintf(why, why_size,
                 "matrix not reciprocal enough for CG: row %zu has delta_i/m_i = %.3g > %.3g (skew part "
                 "delta_i = %.3g against margin m_i = 1/rho_i - sum_j F_ij = %.3g; see docs/solve.md)",
                 check->ratio_row, check->ratio, SOLVE_CG_RECIPROCITY, check->ratio_delta, check->ratio_margin);
}

typedef struct cg_vectors {
    double *r, *z, *p, *q; /* each n; zero on rows with rho = 0 */
} cg_vectors;

/* q = K·p over the reflecting rows (p is zero elsewhere). */
static void cg_apply(const solve_run *run, const double *p, double *q)
{
    const size_t n = run->n;
#pragma omp parallel for schedule(static) if (n >= SOLVE_PARALLEL_MIN_ROWS)
    for (size_t i = 0; i < n; i++) {
        double rho = run->rho[i];
        if (rho == 0) {
            q[i] = 0;
            continue;
        }
        const double *row = run->F + i * n;
        q[i] = run->area[i] * (p[i] / rho - solve_dot(row, p, 0, n));
    }
}

/* r_K = diag(A/rho)·(E + diag(rho)·F·B - B) on reflecting rows, then
 * z = r_K / M. Returns omega(B) of the unscaled residual. */
static double cg_residual(const solve_run *run, const double *B, cg_vectors *v)
{
    const size_t n = run->n;
    double rmax = 0;
    for (size_t i = 0; i < n; i++) {
        double rho = run->rho[i];
        if (rho == 0) {
            v->r[i] = v->z[i] = 0;
            continue;
        }
        const double *row = run->F + i * n;
        double gathered = run->E[i] + rho * solve_dot(row, B, 0, n);
        double r = gathered - B[i];
        v->r[i] = run->area[i] / rho * r;
        v->z[i] = v->r[i] / (run->area[i] * (1 / rho - row[i]));
        double a = solve_patch_residual(r, gathered, run->e_norm);
        if (!(a <= rmax)) rmax = a;
    }
    return rmax;
}

static double cg_dot(const double *a, const double *b, size_t n) { return solve_dot(a, b, 0, n); }

/* One CG update of B, r, z, p; returns the new omega (from the
 * recurrence) or NAN when p·Kp <= 0 (K not positive definite). */
static double cg_step(solve_run *run, cg_vectors *v, double *rz)
{
    const size_t n = run->n;
    cg_apply(run, v->p, v->q);
    double pq = cg_dot(v->p, v->q, n);
    if (!(pq > 0)) return NAN;
    double alpha = *rz / pq, rmax = 0;
    for (size_t i = 0; i < n; i++) {
        if (run->rho[i] == 0) continue;
        run->B[i] += alpha * v->p[i];
        v->r[i] -= alpha * v->q[i];
        v->z[i] = v->r[i] / (run->area[i] * (1 / run->rho[i] - run->F[i * n + i]));
        double r = v->r[i] * run->rho[i] / run->area[i];
        double a = solve_patch_residual(r, run->B[i] + r, run->e_norm);
        if (!(a <= rmax)) rmax = a;
    }
    double rz_new = cg_dot(v->r, v->z, n);
    double beta = rz_new / *rz;
    for (size_t i = 0; i < n; i++) v->p[i] = v->z[i] + beta * v->p[i];
    *rz = rz_new;
    return rmax;
}

rad_status solve_cg(solve_run *run, int *out_stopped, char *why, size_t why_size)
{
    rad_status status = RAD_OK;
    const size_t n = run->n;
    int stopped = 0, restarts = 0;
    cg_vectors v = {0};
    double *block = calloc(4 * n, sizeof(double));
    if (!block) {
        rad_error("%s: out of memory for the CG vectors (%zu patches)", run->label, n);
        status = RAD_ERR_NOMEM;
        goto done;
    }
    v.r = block;
    v.z = block + n;
    v.p = block + 2 * n;
    v.q = block + 3 * n;

    double residual = cg_residual(run, run->B, &v);
    for (size_t i = 0; i < n; i++) v.p[i] = v.z[i];
    double rz = cg_dot(v.r, v.z, n);
    double best = INFINITY;
    uint32_t best_at = run->iterations;
    for (;;) {
        solve_verdict verdict = solve_run_record(run, residual);
        if (verdict == SOLVE_FAILED) {
            status = RAD_ERR_INVALID;
            goto done;
        }
        if (verdict == SOLVE_CONVERGED) {
            /* the recurrence may drift from the true residual: check it */
            residual = cg_residual(run, run->B, &v);
            if (residual <= run->tolerance) break;
            if (++restarts > SOLVE_CG_MAX_RESTARTS) {
                snprintf(why, why_size, "CG residual recurrence drifted (true residual %.3g) after %d restarts",
                         residual, SOLVE_CG_MAX_RESTARTS);
                stopped = 1;
                break;
            }
            for (size_t i = 0; i < n; i++) v.p[i] = v.z[i];
            rz = cg_dot(v.r, v.z, n);
            continue; /* records the true residual of the same iterate */
        }
        if (verdict == SOLVE_LIMIT) break;
        if (residual < best) {
            best = residual;
            best_at = run->iterations;
        } else if (run->iterations - best_at > SOLVE_CG_STALL_WINDOW) {
            snprintf(why, why_size, "CG stalled at residual %.3g (no progress in %u iterations)", best,
                     SOLVE_CG_STALL_WINDOW);
            stopped = 1;
            break;
        }
        residual = cg_step(run, &v, &rz);
        if (isnan(residual)) {
            snprintf(why, why_size, "CG met non-positive curvature at iteration %u (matrix not positive definite)",
                     run->iterations);
            stopped = 1;
            break;
        }
        run->iterations++;
    }
    *out_stopped = stopped;
done:
    free(block);
    return status;
}
