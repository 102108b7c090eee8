/* products.h - F·x for several vectors in one pass over F, on the host's
 * threads (products.c). Internal to solve/.
 *
 * The final verification and the energy balance of every channel
 * (solver.c), CG's products (cg.c) and the GPU rounds' verification
 * (rounds.c) need F·x with the double matrix; reading F once for all
 * vectors is what a pass costs. */
#ifndef SOLVE_PRODUCTS_H
#define SOLVE_PRODUCTS_H

#include <stddef.h>

#include "rows.h"

/* Rows [begin, end) (those held: under mpirun a rank's block) of
 * y_c = F·x_c for c < count, n values each; each y_c[i] summed as
 * solve_row_dot, so the same bits as one vector at a time, whatever the
 * thread count. */
void solve_rows_multiply(const solve_rows *F, size_t begin, size_t end, size_t count, const double *const *x,
                         double *const *y);

#endif
