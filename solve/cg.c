/* cg.c - conjugate gradients on K = diag(A/rho) - diag(A)·F (cg.h);
 * whether it may run is cg_check.c's to say.
 *
 * Multiplying row i of (I - diag(rho)·F)·B = E by A_i/rho_i gives K·B = b
 * with K_ij = (A_i/rho_i)·delta_ij - A_i F_ij, symmetric when
 * A_i F_ij = A_j F_ji. Patches with rho_i = 0 keep B_i = E_i and are left
 * out: search directions are zero there, so their B never changes and
 * their contribution to the other rows stays on the right-hand side.
 * The residual of K·B = b is r_K = diag(A/rho)·r, and what patch i gathers
 * is s_i = B_i + r_i, so the stopping rule (omega, run.h) costs nothing
 * extra. Preconditioner: M_i = K_ii.
 *
 * Across ranks (docs/solve.md, "Across ranks") every vector has N values
 * but each rank updates only its rows; before each product the operands
 * (B or p) of all lanes are gathered in one MPI_Allgatherv, and the dot
 * products and residual maxima are reduced over the ranks, so every rank
 * takes the same steps.
 */
#include "cg.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "products.h"
#include "rad_log.h"
#include "solver.h" /* SOLVE_CG_STALL_WINDOW, SOLVE_CG_MAX_RESTARTS */

/* CG runs several channels in lockstep (solve_cg_many): every matrix
 * product of an iteration - K·p for a step, F·B for a true residual - is
 * taken for all channels in one pass over F, which is what a pass costs
 * (the row is read once and used for each channel's dot product from
 * cache). Each channel keeps its own scalars, history, restarts and stall
 * test, and the arithmetic of each is exactly that of a channel alone: the
 * same dot products in the same order, so the same bits. */
typedef enum cg_phase { CG_START, CG_CHECKING, CG_STEPPING, CG_DONE } cg_phase;

typedef struct cg_lane {
    solve_run *run;
    double *r, *z, *p, *q, *y; /* each n; r, z, p, q zero on rows with rho = 0; y = F·(B or p) */
    double rz, best;
    uint32_t best_at;
    int restarts;
    cg_phase phase; /* what the next product is for */
    int stopped;
    rad_status status;
    char *why;
    size_t why_size;
} cg_lane;

/* The vector lane l multiplies: B (start, checking) or p (stepping). */
static const double *cg_operand(const cg_lane *l) { return l->phase == CG_STEPPING ? l->p : l->run->B; }

/* Lanes per pass of cg_products (any number of lanes: passes of this many). */
#define SOLVE_CG_MAX_LANES 12

/* y = F·x for each active lane over the held rows: one pass over F for
 * all of them (solve_rows_multiply: lanes three at a time, each summed left
 * to right, so the same bits as a lane alone). Rows where a lane's rho is 0
 * get a y that its update never reads. */
static void cg_products(cg_lane *lanes, size_t count)
{
    const double *x[SOLVE_CG_MAX_LANES];
    double *y[SOLVE_CG_MAX_LANES];
    const solve_run *run = lanes[0].run;
    for (size_t c0 = 0; c0 < count; c0 += SOLVE_CG_MAX_LANES) {
        size_t k = 0;
        for (size_t c = c0; c < count && c < c0 + SOLVE_CG_MAX_LANES; c++)
            if (lanes[c].phase != CG_DONE) x[k] = cg_operand(&lanes[c]), y[k++] = lanes[c].y;
        if (k) solve_rows_multiply(&run->F, run->row_begin, run->row_end, k, x, y);
    }
}

/* From y = F·B: r_K = diag(A/rho)·(E + diag(rho)·F·B - B) on reflecting
 * rows, z = r_K / M. Returns omega(B) of the unscaled residual. */
static double cg_residual(cg_lane *l)
{
    const solve_run *run = l->run;
    double rmax = 0;
    for (size_t i = run->row_begin; i < run->row_end; i++) {
        double rho = run->rho[i];
        if (rho == 0) {
            l->r[i] = l->z[i] = 0;
            continue;
        }
        double gathered = run->E[i] + rho * l->y[i];
        double r = gathered - run->B[i];
        l->r[i] = run->area[i] / rho * r;
        l->z[i] = l->r[i] / (run->area[i] * (1 / rho - solve_row_entry(&run->F, i, i)));
        double a = solve_patch_residual(r, gathered, run->e_norm);
        if (!(a <= rmax)) rmax = a;
    }
    return solve_comm_max(run->comm, rmax);
}

/* a·b over the run's rows, then over the ranks. */
static double cg_dot(const solve_run *run, const double *a, const double *b)
{
    double s = solve_dot(a, b, run->row_begin, run->row_end);
    solve_comm_sum(run->comm, &s, 1);
    return s;
}

/* From y = F·p: q = K·p, then one CG update of B, r, z, p; returns the
 * new omega (from the recurrence) or NAN when p·Kp <= 0 (K not positive
 * definite). */
static double cg_step(cg_lane *l)
{
    solve_run *run = l->run;
    const size_t begin = run->row_begin, end = run->row_end;
    for (size_t i = begin; i < end; i++) {
        double rho = run->rho[i];
        l->q[i] = rho == 0 ? 0 : run->area[i] * (l->p[i] / rho - l->y[i]);
    }
    double pq = cg_dot(run, l->p, l->q);
    if (!(pq > 0)) return NAN;
    double alpha = l->rz / pq, rmax = 0;
    for (size_t i = begin; i < end; i++) {
        if (run->rho[i] == 0) continue;
        run->B[i] += alpha * l->p[i];
        l->r[i] -= alpha * l->q[i];
        l->z[i] = l->r[i] / (run->area[i] * (1 / run->rho[i] - solve_row_entry(&run->F, i, i)));
        double r = l->r[i] * run->rho[i] / run->area[i];
        double a = solve_patch_residual(r, run->B[i] + r, run->e_norm);
        if (!(a <= rmax)) rmax = a;
    }
    rmax = solve_comm_max(run->comm, rmax);
    double rz_new = cg_dot(run, l->r, l->z);
    double beta = rz_new / l->rz;
    for (size_t i = begin; i < end; i++) l->p[i] = l->z[i] + beta * l->p[i];
    l->rz = rz_new;
    return rmax;
}

/* p = z, rz = r·z: a fresh search direction. */
static void cg_restart_direction(cg_lane *l)
{
    for (size_t i = l->run->row_begin; i < l->run->row_end; i++) l->p[i] = l->z[i];
    l->rz = cg_dot(l->run, l->r, l->z);
}

/* omega of the iterate the lane's product measured: CG's residual of B
 * (start, checking) or a step along p (NAN: p.Kp <= 0). */
static double cg_measure(cg_lane *l) { return l->phase == CG_STEPPING ? cg_step(l) : cg_residual(l); }

/* The lane's control, shared by the CPU and the GPU: takes the omega its
 * product measured and decides what comes next. Returns 1 when the lane
 * needs a fresh search direction (p = z, rz = r.z) before its next
 * product. */
static int cg_take(cg_lane *l, double residual)
{
    solve_run *run = l->run;
    int fresh = 0;
    if (l->phase == CG_START) {
        fresh = 1;
        l->best = INFINITY;
        l->best_at = run->iterations;
    } else if (l->phase == CG_CHECKING) {
        /* the recurrence may drift from the true residual: checked */
        if (residual <= run->tolerance) {
            l->phase = CG_DONE;
            return 0;
        }
        if (++l->restarts > SOLVE_CG_MAX_RESTARTS) {
            snprintf(l->why, l->why_size, "CG residual recurrence drifted (true residual %.3g) after %d restarts",
                     residual, SOLVE_CG_MAX_RESTARTS);
            l->stopped = 1;
            l->phase = CG_DONE;
            return 0;
        }
        fresh = 1; /* and records the true residual of the same iterate */
    } else {
        if (isnan(residual)) {
            snprintf(l->why, l->why_size,
                     "CG met non-positive curvature at iteration %u (matrix not positive definite)", run->iterations);
            l->stopped = 1;
            l->phase = CG_DONE;
            return 0;
        }
        run->iterations++;
    }
    solve_verdict verdict = solve_run_record(run, residual);
    if (verdict == SOLVE_FAILED) {
        l->status = RAD_ERR_INVALID;
        l->phase = CG_DONE;
    } else if (verdict == SOLVE_CONVERGED) {
        l->phase = CG_CHECKING;
    } else if (verdict == SOLVE_LIMIT) {
        l->phase = CG_DONE;
    } else if (residual < l->best) {
        l->best = residual;
        l->best_at = run->iterations;
        l->phase = CG_STEPPING;
    } else if (run->iterations - l->best_at > SOLVE_CG_STALL_WINDOW) {
        snprintf(l->why, l->why_size, "CG stalled at residual %.3g (no progress in %u iterations)", l->best,
                 SOLVE_CG_STALL_WINDOW);
        l->stopped = 1;
        l->phase = CG_DONE;
    } else {
        l->phase = CG_STEPPING;
    }
    return fresh && l->phase != CG_DONE;
}

/* The vector work of one lockstep iteration: every active lane's product
 * (one pass over F) and what it measures, into residual[c]. On the GPU
 * (gpu.h) the vectors stay on the device; the CPU does the same
 * arithmetic in the same order per lane, so a lane's bits do not depend
 * on the others. */
static rad_status cg_iterate(cg_lane *lanes, size_t count, solve_gpu *gpu, double *residual)
{
    if (gpu) {
        solve_gpu_op ops[SOLVE_GPU_LANES] = {SOLVE_GPU_IDLE};
        for (size_t c = 0; c < count; c++)
            ops[c] = lanes[c].phase == CG_DONE       ? SOLVE_GPU_IDLE
                     : lanes[c].phase == CG_STEPPING ? SOLVE_GPU_CG_STEP
                                                     : SOLVE_GPU_CG_RESIDUAL;
        return solve_gpu_lanes_iterate(gpu, ops, residual);
    }
    cg_products(lanes, count);
    for (size_t c = 0; c < count; c++)
        if (lanes[c].phase != CG_DONE) residual[c] = cg_measure(&lanes[c]);
    return RAD_OK;
}

/* p = z, rz = r.z for the lanes with fresh[c] set. */
static rad_status cg_refresh(cg_lane *lanes, size_t count, solve_gpu *gpu, const int *fresh)
{
    if (gpu) return solve_gpu_cg_restart(gpu, fresh);
    for (size_t c = 0; c < count; c++)
        if (fresh[c]) cg_restart_direction(&lanes[c]);
    return RAD_OK;
}

/* Up to SOLVE_GPU_LANES lanes on the GPU, any number on the CPU. */
static rad_status cg_lockstep(solve_run *const *runs, size_t count, solve_gpu *gpu, int *out_stopped,
                              char *const *why, size_t why_size)
{
    rad_status status = RAD_OK;
    const size_t n = runs[0]->n;
    cg_lane *lanes = calloc(count, sizeof *lanes);
    double *residual = calloc(count, sizeof *residual);
    int *fresh = calloc(count > SOLVE_GPU_LANES ? count : SOLVE_GPU_LANES, sizeof *fresh);
    /* on the GPU the vectors live there; the host keeps only the scalars */
    double *block = gpu ? NULL : calloc(5 * n * count, sizeof(double));
    double **operands = calloc(count, sizeof *operands);
    if (!lanes || !residual || !fresh || (!gpu && !block) || !operands) {
        rad_error("%s: out of memory for the CG vectors (%zu patches)", runs[0]->label, n);
        status = RAD_ERR_NOMEM;
    }
    status = solve_comm_agree(runs[0]->comm, status);
    if (status != RAD_OK) goto done;
    for (size_t c = 0; c < count; c++) {
        cg_lane *l = &lanes[c];
        double *b = block ? block + 5 * n * c : NULL;
        *l = (cg_lane){.run = runs[c], .phase = CG_START, .status = RAD_OK, .why = why[c], .why_size = why_size};
        if (b) l->r = b, l->z = b + n, l->p = b + 2 * n, l->q = b + 3 * n, l->y = b + 4 * n;
    }
    if (gpu) {
        const double *rho[SOLVE_GPU_LANES], *E[SOLVE_GPU_LANES], *B[SOLVE_GPU_LANES];
        double e_norm[SOLVE_GPU_LANES];
        for (size_t c = 0; c < count; c++)
            rho[c] = runs[c]->rho, E[c] = runs[c]->E, B[c] = runs[c]->B, e_norm[c] = runs[c]->e_norm;
        if ((status = solve_gpu_lanes_load(gpu, count, rho, E, B, e_norm)) != RAD_OK) goto done;
    }
    for (;;) {
        /* the vectors the products need, every active lane's in one gather */
        size_t active = 0;
        for (size_t c = 0; c < count; c++)
            if (lanes[c].phase != CG_DONE) operands[active++] = (double *)cg_operand(&lanes[c]);
        if (!active) break;
        /* across ranks (with a GPU, the device exchanges them itself: gpu.h) */
        if (!gpu && (status = solve_comm_gather_rows(runs[0]->comm, operands, active)) != RAD_OK) goto done;
        if ((status = cg_iterate(lanes, count, gpu, residual)) != RAD_OK) break;
        for (size_t c = 0; c < count; c++) fresh[c] = lanes[c].phase != CG_DONE && cg_take(&lanes[c], residual[c]);
        if ((status = cg_refresh(lanes, count, gpu, fresh)) != RAD_OK) break;
    }
    for (size_t c = 0; gpu && c < count; c++) {
        rad_status stored = solve_gpu_lanes_store(gpu, c, runs[c]->B);
        if (status == RAD_OK) status = stored;
    }
    for (size_t c = 0; c < count; c++) {
        out_stopped[c] = lanes[c].stopped;
        if (lanes[c].status != RAD_OK && status == RAD_OK) status = lanes[c].status;
        operands[c] = runs[c]->B; /* every rank's rows of the results */
    }
    if (status == RAD_OK) status = solve_comm_gather_rows(runs[0]->comm, operands, count);
done:
    free(operands);
    free(block);
    free(fresh);
    free(residual);
    free(lanes);
    return status;
}

rad_status solve_cg_many(solve_run *const *runs, size_t count, solve_gpu *gpu, int *out_stopped, char *const *why,
                         size_t why_size)
{
    rad_status status = RAD_OK;
    /* the GPU serves SOLVE_GPU_LANES lanes per pass over F: groups of them */
    size_t group = gpu ? SOLVE_GPU_LANES : count;
    for (size_t c = 0; c < count && status == RAD_OK; c += group) {
        size_t k = count - c < group ? count - c : group;
        status = cg_lockstep(runs + c, k, gpu, out_stopped + c, why + c, why_size);
    }
    return status;
}

rad_status solve_cg(solve_run *run, int *out_stopped, char *why, size_t why_size)
{
    return solve_cg_many(&run, 1, NULL, out_stopped, &why, why_size);
}
