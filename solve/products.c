/* products.c - F·x for several vectors in one pass over F, on the host's
 * threads: the final verification and the energy balance of every channel
 * (solver.c) and the GPU rounds' verification (rounds.c) need F·B with the
 * double matrix, and reading F once for all channels is what a pass costs.
 * y_c[i] is summed exactly as solve_row_dot(F, i, x_c, 0, n): the same
 * bits as one vector at a time, whatever the thread count. */
#include "products.h"

#include "run.h" /* SOLVE_PARALLEL_MIN_ROWS */

void solve_rows_multiply(const solve_rows *F, size_t begin, size_t end, size_t count, const double *const *x,
                         double *const *y)
{
    const size_t n = F->n;
#pragma omp parallel for schedule(dynamic, 64) if (end - begin >= SOLVE_PARALLEL_MIN_ROWS)
    for (size_t i = begin; i < end; i++) {
        size_t c = 0;
        const size_t spans = solve_row_span_count(F, i);
        for (; c + 3 <= count; c += 3) { /* three strict-order sums interleaved (cg.c, cg_products) */
            const double *x0 = x[c], *x1 = x[c + 1], *x2 = x[c + 2];
            double s0 = 0, s1 = 0, s2 = 0;
            for (size_t t = 0; t < spans; t++) {
                solve_span sp = solve_row_span(F, i, t);
                for (size_t j = sp.begin; j < sp.end; j++) {
                    double f = sp.values[j - sp.begin];
                    s0 += f * x0[j];
                    s1 += f * x1[j];
                    s2 += f * x2[j];
                }
            }
            y[c][i] = s0, y[c + 1][i] = s1, y[c + 2][i] = s2;
        }
        for (; c < count; c++) y[c][i] = solve_row_dot(F, i, x[c], 0, n);
    }
}
