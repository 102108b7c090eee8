/* rows.h - the form-factor matrix as the solver walks it: dense (N x N,
 * row-major), or the stored tiles of a sparse file (docs/formats.md,
 * version 3), never expanded.
 *
 * Every use goes row by row over spans of stored columns, in ascending
 * column order:
 *
 *     for (size_t k = 0; k < solve_row_span_count(F, i); k++) {
 *         solve_span s = solve_row_span(F, i, k);   // columns [s.begin, s.end)
 *         for (size_t j = s.begin; j < s.end; j++) ... s.values[j - s.begin] ...
 *     }
 *
 * A dense row is one span of N columns. A sparse row leaves out tiles whose
 * entries are all zero; sums taken left to right over its spans are the
 * same bits as over the dense row (adding +-0 changes no sum), so a sparse
 * file solves to the same B as the dense file of the same matrix (tested).
 *
 * Under mpirun a process holds only its block of rows, [first_row,
 * first_row + its row count); rows are still named by their global index i
 * (columns always run over all N), and only held rows may be asked for.
 */
#ifndef SOLVE_ROWS_H
#define SOLVE_ROWS_H

#include <stddef.h>
#include <stdint.h>

#include "rad_ffile.h" /* RAD_FF_TILE_COLUMNS */

typedef struct solve_rows {
    size_t n;
    const double *dense;         /* held rows x n, F_ij at (i - first_row) * n + j; NULL when sparse */
    const uint64_t *row_tiles;   /* sparse: held rows + 1; row i's tiles are [row_tiles[i - first_row],
                                    row_tiles[i - first_row + 1]) */
    const uint32_t *tile_column; /* sparse: each tile's first column (a multiple of RAD_FF_TILE_COLUMNS) */
    const uint64_t *tile_value;  /* sparse: where its entries start in `values` */
    const double *values;        /* sparse: the stored entries, tile after tile */
    size_t first_row;            /* the first row held (0: all from the first) */
} solve_rows;

typedef struct solve_span {
    const double *values; /* entry of column begin + k at values[k] */
    size_t begin, end;    /* columns [begin, end) */
} solve_span;

static inline size_t solve_row_span_count(const solve_rows *F, size_t i)
{
    const size_t r = i - F->first_row;
    return F->dense ? 1 : (size_t)(F->row_tiles[r + 1] - F->row_tiles[r]);
}

static inline solve_span solve_row_span(const solve_rows *F, size_t i, size_t k)
{
    const size_t r = i - F->first_row;
    if (F->dense) return (solve_span){F->dense + r * F->n, 0, F->n};
    uint64_t t = F->row_tiles[r] + k;
    size_t begin = F->tile_column[t], end = begin + RAD_FF_TILE_COLUMNS < F->n ? begin + RAD_FF_TILE_COLUMNS : F->n;
    return (solve_span){F->values + F->tile_value[t], begin, end};
}

/* sum_{j in [begin, end)} F_ij x_j, left to right. */
static inline double solve_row_dot(const solve_rows *F, size_t i, const double *x, size_t begin, size_t end)
{
    double s = 0;
    size_t spans = solve_row_span_count(F, i);
    for (size_t k = 0; k < spans; k++) {
        solve_span sp = solve_row_span(F, i, k);
        size_t a = sp.begin > begin ? sp.begin : begin, b = sp.end < end ? sp.end : end;
        for (size_t j = a; j < b; j++) s += sp.values[j - sp.begin] * x[j];
    }
    return s;
}

/* Sparse: the entries of row i's tile holding column j (the tile's first
 * column at [0]), or NULL when the row does not store it. Dense: the row
 * from that tile's first column. Binary search over the row's tiles. */
static inline const double *solve_row_tile(const solve_rows *F, size_t i, size_t j)
{
    size_t column = j - j % RAD_FF_TILE_COLUMNS, r = i - F->first_row;
    if (F->dense) return F->dense + r * F->n + column;
    uint64_t lo = F->row_tiles[r], hi = F->row_tiles[r + 1];
    while (lo < hi) {
        uint64_t mid = lo + (hi - lo) / 2;
        if (F->tile_column[mid] < column)
            lo = mid + 1;
        else
            hi = mid;
    }
    if (lo < F->row_tiles[r + 1] && F->tile_column[lo] == column) return F->values + F->tile_value[lo];
    return NULL;
}

/* F_ij (0 where not stored). */
static inline double solve_row_entry(const solve_rows *F, size_t i, size_t j)
{
    const double *tile = solve_row_tile(F, i, j);
    return tile ? tile[j % RAD_FF_TILE_COLUMNS] : 0;
}

#endif
