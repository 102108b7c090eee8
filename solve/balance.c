/* balance.c - the energy balance of a solution: what is emitted, absorbed
 * and escapes through openings (docs/solve.md, "Energy balance").
 *
 * With H_i = sum_j F_ij B_j, B_i = E_i + rho_i H_i + r_i (r the residual).
 * Summing A_i B_i and using reciprocity, sum_i A_i H_i =
 * sum_j B_j sum_i A_j F_ji = sum_j A_j B_j s_j with s_j the row sum of j, so
 *   emitted = sum A_i B_i - sum A_i rho_i H_i - sum A_i r_i
 *           = absorbed + escaped - sum A_i r_i,
 * absorbed = sum A_i (1 - rho_i) H_i, escaped = sum A_j B_j (1 - s_j).
 * Across ranks each rank sums its rows and the three sums are added over
 * the ranks (one MPI_Allreduce).
 */
#include <stddef.h>

#include "run.h" /* SOLVE_PARALLEL_MIN_ROWS */
#include "solver.h"

solve_balance solve_balance_compute(const solve_system *system, const double *rho, const double *emission,
                                    const double *radiosity, double *scratch)
{
    const size_t n = system->patch_count;
    const solve_rows F = solve_system_rows(system);
    size_t begin, end;
    solve_system_held(system, &begin, &end);
    double *H = scratch;
#pragma omp parallel for schedule(static) if (end - begin >= SOLVE_PARALLEL_MIN_ROWS)
    for (size_t i = begin; i < end; i++) H[i] = solve_row_dot(&F, i, radiosity, 0, n);
    return solve_balance_of(system, rho, emission, radiosity, H);
}

solve_balance solve_balance_of(const solve_system *system, const double *rho, const double *emission,
                               const double *radiosity, const double *H)
{
    size_t begin, end;
    solve_system_held(system, &begin, &end);
    double sums[3] = {0, 0, 0}; /* emitted, absorbed, escaped: this rank's rows, then over the ranks */
    for (size_t i = begin; i < end; i++) {
        const double A = system->area[i];
        sums[0] += A * emission[i];
        sums[1] += A * (1 - rho[i]) * H[i];
        sums[2] += A * radiosity[i] * (1 - system->row_sum[i]);
    }
    solve_comm_sum(system->comm, sums, 3);
    solve_balance b = {.emitted = sums[0], .absorbed = sums[1], .escaped = sums[2]};
    b.imbalance = b.emitted > 0 ? (b.absorbed + b.escaped - b.emitted) / b.emitted : 0;
    return b;
}
