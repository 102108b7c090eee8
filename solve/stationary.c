/* stationary.c - Jacobi and Gauss-Seidel sweeps.
 *
 * Both update B_i += r_i / (1 - rho_i F_ii), with the residual
 * r_i = s_i - B_i and s_i = E_i + rho_i sum_j F_ij B_j (what patch i
 * gathers); Jacobi takes every B_j from the previous iterate, Gauss-Seidel
 * the newest values. Each sweep also yields the exact residual of the
 * iterate it started from (the same pass over the row), so the stopping
 * test costs no extra product. When that
 * residual meets the tolerance, the method returns that iterate, not the
 * newer one whose residual is unknown. Rows with rho_i = 0 are B_i = E_i
 * from the start and never change.
 *
 * Across ranks (docs/solve.md, "Across ranks") each rank sweeps its own
 * rows and the new values then go to every rank (solve_comm_gather_rows):
 * Jacobi is unchanged; Gauss-Seidel takes the newest values within the
 * rank's block and the previous iterate's from other blocks (Gauss-Seidel
 * within a block, Jacobi between blocks), which still contracts in the
 * max norm because rho_i sum_j F_ij < 1 on every row.
 */
#include "stationary.h"

#include <math.h>
#include <string.h>

/* One Jacobi sweep: next = B + r(B) / d; returns omega(B) (run.h). */
static double jacobi_sweep(const solve_run *run, const double *B, double *next)
{
    const size_t n = run->n, begin = run->row_begin, end = run->row_end;
    double rmax = 0;
#pragma omp parallel for schedule(static) reduction(max : rmax) if (end - begin >= SOLVE_PARALLEL_MIN_ROWS)
    for (size_t i = begin; i < end; i++) {
        double rho = run->rho[i];
        if (rho == 0) {
            next[i] = B[i];
            continue;
        }
        double gathered = run->E[i] + rho * solve_row_dot(&run->F, i, B, 0, n);
        double r = gathered - B[i];
        next[i] = B[i] + r / (1 - rho * solve_row_entry(&run->F, i, i));
        double a = solve_patch_residual(r, gathered, run->e_norm);
        if (!(a <= rmax)) rmax = a; /* lets NaN through to the caller */
    }
    return solve_comm_max(run->comm, rmax);
}

rad_status solve_jacobi(solve_run *run)
{
    for (;;) {
        double residual = jacobi_sweep(run, run->B, run->work);
        if (solve_comm_gather_rows(run->comm, &run->work, 1) != RAD_OK) return RAD_ERR_BACKEND;
        solve_verdict v = solve_run_record(run, residual);
        if (v == SOLVE_FAILED) return RAD_ERR_INVALID;
        if (v != SOLVE_CONTINUE) return RAD_OK; /* run->B is the measured iterate */
        double *t = run->B;
        run->B = run->work;
        run->work = t;
        run->iterations++;
    }
}

/* One Gauss-Seidel sweep over B in place; `old` holds the iterate it
 * starts from. Returns omega(old) (run.h). */
static double gauss_seidel_sweep(const solve_run *run, double *B, const double *old)
{
    const size_t n = run->n;
    double rmax = 0;
    for (size_t i = run->row_begin; i < run->row_end; i++) {
        double rho = run->rho[i];
        if (rho == 0) continue;
        /* columns j < i already hold new values in B, the rest old ones */
        double lower_new = solve_row_dot(&run->F, i, B, 0, i);
        double lower_old = solve_row_dot(&run->F, i, old, 0, i);
        double upper = solve_row_dot(&run->F, i, B, i, n);
        double gathered_old = run->E[i] + rho * (lower_old + upper);
        double r_now = run->E[i] + rho * (lower_new + upper) - B[i];
        B[i] += r_now / (1 - rho * solve_row_entry(&run->F, i, i));
        double a = solve_patch_residual(gathered_old - old[i], gathered_old, run->e_norm);
        if (!(a <= rmax)) rmax = a;
    }
    return solve_comm_max(run->comm, rmax);
}

rad_status solve_gauss_seidel(solve_run *run)
{
    const size_t bytes = run->n * sizeof(double);
    for (;;) {
        memcpy(run->work, run->B, bytes);
        double residual = gauss_seidel_sweep(run, run->B, run->work);
        if (solve_comm_gather_rows(run->comm, &run->B, 1) != RAD_OK) return RAD_ERR_BACKEND;
        solve_verdict v = solve_run_record(run, residual);
        if (v == SOLVE_FAILED) return RAD_ERR_INVALID;
        if (v != SOLVE_CONTINUE) {
            memcpy(run->B, run->work, bytes); /* back to the measured iterate */
            return RAD_OK;
        }
        run->iterations++;
    }
}

/* Up to SOLVE_GPU_LANES channels on the GPU: one pass over F per sweep
 * for all; a lane that stops keeps the iterate it measured. */
static rad_status jacobi_lockstep(solve_run *const *runs, size_t count, solve_gpu *gpu)
{
    rad_status status = RAD_OK;
    const double *rho[SOLVE_GPU_LANES], *E[SOLVE_GPU_LANES], *B[SOLVE_GPU_LANES];
    double e_norm[SOLVE_GPU_LANES], omega[SOLVE_GPU_LANES];
    solve_gpu_op ops[SOLVE_GPU_LANES] = {SOLVE_GPU_IDLE};
    for (size_t c = 0; c < count; c++) {
        rho[c] = runs[c]->rho, E[c] = runs[c]->E, B[c] = runs[c]->B, e_norm[c] = runs[c]->e_norm;
        ops[c] = SOLVE_GPU_JACOBI;
    }
    if ((status = solve_gpu_lanes_load(gpu, count, rho, E, B, e_norm)) != RAD_OK) return status;
    for (size_t active = count; active > 0 && status == RAD_OK;) {
        if ((status = solve_gpu_lanes_iterate(gpu, ops, omega)) != RAD_OK) break;
        for (size_t c = 0; c < count; c++) {
            if (ops[c] == SOLVE_GPU_IDLE) continue;
            solve_verdict v = solve_run_record(runs[c], omega[c]);
            if (v == SOLVE_CONTINUE) {
                solve_gpu_jacobi_accept(gpu, c);
                runs[c]->iterations++;
                continue;
            }
            ops[c] = SOLVE_GPU_IDLE; /* B is the measured iterate */
            active--;
            if (v == SOLVE_FAILED) status = RAD_ERR_INVALID;
        }
    }
    for (size_t c = 0; c < count; c++) {
        rad_status stored = solve_gpu_lanes_store(gpu, c, runs[c]->B);
        if (status == RAD_OK) status = stored;
    }
    return status;
}

rad_status solve_jacobi_many(solve_run *const *runs, size_t count, solve_gpu *gpu)
{
    rad_status status = RAD_OK;
    for (size_t c = 0; c < count && status == RAD_OK;) {
        size_t k = gpu ? (count - c < SOLVE_GPU_LANES ? count - c : SOLVE_GPU_LANES) : 1;
        status = gpu ? jacobi_lockstep(runs + c, k, gpu) : solve_jacobi(runs[c]);
        c += k;
    }
    return status;
}
