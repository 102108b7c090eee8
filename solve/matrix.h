/* matrix.h - the form-factor matrix as solve needs it: read whole from an
 * open form-factor file, converted to double and validated.
 *
 * Validation, row by row, stops at the first offending row and names the
 * file, the row and the entry:
 *   - every F_ij finite;
 *   - F_ij >= -SOLVE_NEGATIVE_TOLERANCE (a sign flip of a zero entry in
 *     the last bits is rounding; anything below is an error);
 *   - sum_j F_ij <= SOLVE_ROW_SUM_LIMIT (a closed scene sums to 1; Monte
 *     Carlo noise exceeds it, which gets one warning above
 *     SOLVE_ROW_SUM_WARN). The limit is loose on purpose: with point-pair
 *     sampling (512 pairs) rows of patches at shared edges and corners,
 *     where the kernel is singular, reach 1.3 at --subdiv 3 (measured on
 *     the Cornell box). Above 1.5 a row is not noise but a broken matrix.
 */
#ifndef SOLVE_MATRIX_H
#define SOLVE_MATRIX_H

#include <stddef.h>

#include "rad_ffile.h"
#include "rad_status.h"
#include "solver.h"

#define SOLVE_NEGATIVE_TOLERANCE 1e-12
#define SOLVE_ROW_SUM_LIMIT 1.5
#define SOLVE_ROW_SUM_WARN 1.001

typedef struct solve_matrix {
    size_t patch_count;
    double *form_factors; /* N * N, row-major */
    double *area;         /* N, from the patch table */
    double *row_sum;      /* N */
} solve_matrix;

/* Reads all N rows of `file` (opened from `path`, used in messages).
 * *out_matrix is set only on success; free with solve_matrix_free. */
rad_status solve_matrix_load(rad_ff_file *file, const char *path, solve_matrix *out_matrix);
void solve_matrix_free(solve_matrix *matrix); /* safe on zeroed */

/* The solver's view of the matrix (borrows its arrays). */
solve_system solve_matrix_system(const solve_matrix *matrix);

#endif
