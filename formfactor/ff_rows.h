/* ff_rows.h - from what the backends compute to finished matrix rows.
 *
 * Backends return couplings c_ij = F_ij / A_j, symmetric to the bit
 * (rad_ff_kernel.h). With every pair computed by both of its rows, a
 * round of rows only needs ff_rows_finish. With each unordered pair
 * computed once (ff_setup.pairs_once), row i holds the entries that
 * rad_ff_row_computes(i, j) gives it, and the others come from row j:
 *
 *     compute the rank's rows [begin, end) into one block (rows x N)
 *     ff_rows_mirror_local(n, begin, end, block)       pairs inside the block
 *     ff_rows_exchange(comm, row_begin, n, block, ...)  pairs with other ranks
 *     ff_rows_finish(area, n, begin, ..., block, ...)    couplings -> F, stats
 *
 * The copied entry is the very double the other row computed, so the
 * matrix is byte-identical to computing every entry (tested).
 */
#ifndef FF_ROWS_H
#define FF_ROWS_H

#include <stdint.h>

#include "ff_comm.h"
#include "rad_ff_kernel.h"
#include "rad_status.h"

/* What finished rows hold, for the stats: row sums, and the standard
 * errors of the entries F_ij > 0 (error_count = 0 when none were computed). */
typedef struct ff_rows_summary {
    double row_sum_min, row_sum_max, row_sum_total;
    uint64_t rows;
    double error_sum, error_relative_sum, error_max, error_max_value;
    uint64_t error_count;
    uint32_t error_max_row, error_max_column;
} ff_rows_summary;

/* Adds `from` to `into` (either may be empty). */
void ff_rows_summary_merge(ff_rows_summary *into, const ff_rows_summary *from);

/* Scales rows [row_begin, row_begin + row_count) held in `rows` and, if not
 * NULL, their standard errors into form factors (F_ij = c_ij A_j, `area`:
 * the N patch areas, contiguous) and adds them to *summary; one pass over
 * the memory, `threads` OpenMP threads. */
void ff_rows_finish(const double *area, uint32_t n, uint32_t row_begin, uint32_t row_count, double *rows,
                    double *errors, int threads, ff_rows_summary *summary);

/* Fills the entries (i, j), i and j both in [begin, end), that row j
 * computed; block row r is matrix row begin + r. Returns how many.
 * `threads` OpenMP threads. */
uint64_t ff_rows_mirror_local(uint32_t n, uint32_t begin, uint32_t end, double *block, int threads);

/* Collective: fills the entries of this rank's rows that rows of other
 * ranks computed, exchanging them pairwise in pieces of at most
 * FF_COMM_MAX_DOUBLES. row_begin has ranks + 1 entries (rank r owns
 * [row_begin[r], row_begin[r + 1])). Adds the entries received to
 * *mirrored (if not NULL). */
rad_status ff_rows_exchange(ff_comm *comm, const uint32_t *row_begin, uint32_t n, double *block, uint64_t *mirrored);

#endif
