/* gpu_tiles.c - the matrix as the GPU stores it, built on the host's
 * OpenMP threads (gpu.h, solve_gpu_tiles): only floats cross to the
 * device, half the bytes of the doubles solve holds. */
#include <stdlib.h>
#include <string.h>

#include "gpu.h"
#include "rad_log.h"
#include "rad_mem.h"

void solve_gpu_tiles_free(solve_gpu_tiles *tiles)
{
    if (!tiles) return;
    free(tiles->row_tiles);
    free(tiles->tile_column);
    free(tiles->values);
    free(tiles->diag);
    memset(tiles, 0, sizeof *tiles);
}

rad_status solve_gpu_tiles_make(const solve_rows *F, solve_gpu_tiles *out_tiles)
{
    return solve_gpu_tiles_make_rows(F, 0, F->n, out_tiles);
}

rad_status solve_gpu_tiles_layout_rows(const solve_rows *F, size_t row_begin, size_t row_end,
                                       solve_gpu_tiles *out_tiles)
{
    /* n: the rows held here; held row r is F's row row_begin + r */
    const size_t n = row_end - row_begin, T = RAD_FF_TILE_COLUMNS, per_row = (F->n + T - 1) / T;
    const size_t r0 = row_begin - F->first_row; /* F's own index of the first */
    solve_gpu_tiles t = {.n = n,
                         .tile_count = F->dense ? n * per_row : (size_t)(F->row_tiles[r0 + n] - F->row_tiles[r0]),
                         .exact = 1, /* until values say otherwise: none (a rank without tiles) are exact */
                         .source = F,
                         .source_begin = row_begin};
    t.row_tiles = malloc((n + 1) * sizeof *t.row_tiles);
    t.tile_column = malloc((t.tile_count ? t.tile_count : 1) * sizeof *t.tile_column);
    t.diag = malloc(n * sizeof *t.diag);
    if (!t.row_tiles || !t.tile_column || !t.diag) {
        rad_error("out of memory for the GPU's copy of the matrix (%zu tiles of %zu floats)", t.tile_count, T);
        solve_gpu_tiles_free(&t);
        return RAD_ERR_NOMEM;
    }
    rad_mem_advise_huge(t.tile_column, t.tile_count * sizeof *t.tile_column);
    for (size_t r = 0; r <= n; r++) t.row_tiles[r] = F->dense ? r * per_row : F->row_tiles[r0 + r] - F->row_tiles[r0];
#pragma omp parallel for schedule(dynamic, 64) if (n >= SOLVE_GPU_PARALLEL_MIN_ROWS)
    for (size_t r = 0; r < n; r++) {
        const size_t i = row_begin + r;
        uint64_t k = t.row_tiles[r];
        for (size_t s = 0; s < solve_row_span_count(F, i); s++) {
            solve_span sp = solve_row_span(F, i, s);
            for (size_t begin = sp.begin; begin < sp.end; begin += T) t.tile_column[k++] = (uint32_t)begin;
        }
        t.diag[r] = solve_row_entry(F, i, i);
    }
    *out_tiles = t;
    return RAD_OK;
}

int solve_gpu_tiles_fill(const solve_gpu_tiles *tiles, size_t first, size_t end, float *to)
{
    const solve_rows *F = tiles->source;
    const size_t T = RAD_FF_TILE_COLUMNS, base = tiles->row_tiles[first];
    int exact = 1;
    /* rows are uneven (a dense span is many tiles): small dynamic chunks */
#pragma omp parallel for schedule(dynamic, 4) reduction(&& : exact) if (end - first >= 64)
    for (size_t r = first; r < end; r++) {
        const size_t i = tiles->source_begin + r;
        float *row = to + (tiles->row_tiles[r] - base) * T;
        for (size_t s = 0; s < solve_row_span_count(F, i); s++) {
            solve_span sp = solve_row_span(F, i, s);
            for (size_t begin = sp.begin; begin < sp.end; begin += T, row += T) {
                size_t width = sp.end - begin < T ? sp.end - begin : T;
                const double *from = sp.values + (begin - sp.begin);
                for (size_t e = 0; e < width; e++) {
                    row[e] = (float)from[e];
                    exact = exact && (double)row[e] == from[e];
                }
                for (size_t e = width; e < T; e++) row[e] = 0;
            }
        }
    }
    return exact;
}

rad_status solve_gpu_tiles_make_rows(const solve_rows *F, size_t row_begin, size_t row_end, solve_gpu_tiles *out_tiles)
{
    solve_gpu_tiles t;
    rad_status status = solve_gpu_tiles_layout_rows(F, row_begin, row_end, &t);
    if (status != RAD_OK) return status;
    const size_t T = RAD_FF_TILE_COLUMNS;
    t.values = malloc((t.tile_count ? t.tile_count : 1) * T * sizeof *t.values);
    if (!t.values) {
        rad_error("out of memory for the GPU's copy of the matrix (%zu tiles of %zu floats)", t.tile_count, T);
        solve_gpu_tiles_free(&t);
        return RAD_ERR_NOMEM;
    }
    rad_mem_advise_huge(t.values, t.tile_count * T * sizeof *t.values);
    t.exact = solve_gpu_tiles_fill(&t, 0, t.n, t.values);
    *out_tiles = t;
    return RAD_OK;
}
