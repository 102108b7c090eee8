/* test_solve_gpu_tiles.c - the matrix as the GPU stores it (solve/gpu.h,
 * gpu_tiles.c), built on the host: no GPU needed, so it runs everywhere.
 * A dense and a sparse matrix (N = 150: the last tile of each row holds
 * 22 columns; whole tiles left out of the sparse one) give the same
 * tiles: every entry rounded to float at its column, zero padding, the
 * diagonal in double, and `exact` set only when every entry is a float. */
#include <stdlib.h>
#include <string.h>

#include "gpu.h"
#include "rad_test.h"

enum { N = 150, T = RAD_FF_TILE_COLUMNS };

static double F[N * N];

/* Entry (i, j) of the tiles, 0 where no tile is stored. */
static double tile_entry(const solve_gpu_tiles *t, size_t i, size_t j)
{
    for (uint64_t k = t->row_tiles[i]; k < t->row_tiles[i + 1]; k++)
        if (j >= t->tile_column[k] && j < t->tile_column[k] + T) return t->values[k * T + (j - t->tile_column[k])];
    return 0;
}

static void check(const solve_rows *rows, int expect_exact, const char *what)
{
    solve_gpu_tiles t;
    RAD_CHECK(solve_gpu_tiles_make(rows, &t) == RAD_OK);
    RAD_CHECK(t.n == N && t.exact == expect_exact);
    size_t wrong = 0, padding = 0;
    for (size_t i = 0; i < N; i++) {
        for (size_t j = 0; j < N; j++) wrong += tile_entry(&t, i, j) != (float)F[i * N + j];
        wrong += t.diag[i] != F[i * N + i];
        for (uint64_t k = t.row_tiles[i]; k < t.row_tiles[i + 1]; k++) {
            RAD_CHECK(t.tile_column[k] % T == 0);
            for (size_t e = 0; e < T; e++) padding += t.tile_column[k] + e >= N && t.values[k * T + e] != 0;
        }
    }
    fprintf(stderr, "%s: %zu tiles, %zu entries wrong, %zu padding entries not zero\n", what, t.tile_count, wrong,
            padding);
    RAD_CHECK(wrong == 0 && padding == 0);
    solve_gpu_tiles_free(&t);
}

int main(void)
{
    /* rows 0..63 touch only columns 64..127; the rest are full */
    for (size_t i = 0; i < N; i++)
        for (size_t j = 0; j < N; j++)
            F[i * N + j] = (i < 64 && (j < 64 || j >= 128)) ? 0 : 1.0 / (3.0 + (double)(i * N + j));
    /* the sparse view: every tile with a non-zero entry */
    uint64_t row_tiles[N + 1], tile_value[N * 3];
    uint32_t tile_column[N * 3];
    double values[N * N];
    size_t tiles = 0, used = 0;
    for (size_t i = 0; i < N; i++) {
        row_tiles[i] = tiles;
        for (size_t c = 0; c < N; c += T) {
            size_t end = c + T < N ? c + T : N;
            int any = 0;
            for (size_t j = c; j < end; j++) any |= F[i * N + j] != 0;
            if (!any) continue;
            tile_column[tiles] = (uint32_t)c;
            tile_value[tiles++] = used;
            for (size_t j = c; j < end; j++) values[used++] = F[i * N + j];
        }
    }
    row_tiles[N] = tiles;
    solve_rows dense = {.n = N, .dense = F};
    solve_rows sparse = {.n = N, .row_tiles = row_tiles, .tile_column = tile_column, .tile_value = tile_value,
                         .values = values};
    check(&dense, 0, "dense, f64 entries");
    check(&sparse, 0, "sparse, f64 entries");
    for (size_t k = 0; k < N * N; k++) F[k] = (float)F[k];
    for (size_t k = 0; k < used; k++) values[k] = (float)values[k];
    check(&dense, 1, "dense, f32 entries");
    check(&sparse, 1, "sparse, f32 entries");
    return rad_test_finish();
}
