/* test_solve_gpu_tiles.c - the matrix as the GPU stores it (solve/gpu.h,
 * gpu_tiles.c), built on the host: no GPU needed, so it runs everywhere.
 * A dense and a sparse matrix (N = 150: the last tile of each row holds
 * 22 columns; whole tiles left out of the sparse one) give the same
 * tiles: every entry rounded to float at its column, zero padding, the
 * diagonal in double, and `exact` set only when every entry is a float.
 * A block of rows (a rank's, solve_gpu_tiles_make_rows) gives those rows'
 * tiles, from a view that holds only them as from one that holds all.
 * The streamed form (the layout alone, the values filled a few rows at a
 * time as the upload copies them) gives the same floats and `exact`. */
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

/* Rows [a, b) of `all` (N rows) are the tiles of rows [a, b): from `rows`,
 * which holds them (all N, or only those). */
static void check_block(const solve_rows *rows, const solve_gpu_tiles *all, size_t a, size_t b, const char *what)
{
    solve_gpu_tiles t;
    RAD_CHECK(solve_gpu_tiles_make_rows(rows, a, b, &t) == RAD_OK);
    RAD_CHECK(t.n == b - a && t.row_tiles[0] == 0);
    size_t wrong = 0;
    for (size_t r = 0; r < b - a; r++) {
        const size_t i = a + r;
        wrong += t.row_tiles[r + 1] - t.row_tiles[r] != all->row_tiles[i + 1] - all->row_tiles[i];
        wrong += t.diag[r] != all->diag[i];
        for (size_t j = 0; j < N; j++) wrong += tile_entry(&t, r, j) != tile_entry(all, i, j);
    }
    fprintf(stderr, "%s, rows [%zu, %zu): %zu tiles, %zu entries wrong\n", what, a, b, t.tile_count, wrong);
    RAD_CHECK(wrong == 0 && t.tile_count == all->row_tiles[b] - all->row_tiles[a]);
    solve_gpu_tiles_free(&t);
}

/* The layout of rows [a, b), its values filled in pieces of `piece` rows
 * (as solve_gpu_create_ranks streams them), against `all`'s. */
static void check_streamed(const solve_rows *rows, const solve_gpu_tiles *all, size_t a, size_t b, size_t piece,
                           int expect_exact, const char *what)
{
    solve_gpu_tiles t;
    RAD_CHECK(solve_gpu_tiles_layout_rows(rows, a, b, &t) == RAD_OK);
    RAD_CHECK(t.values == NULL && t.tile_count == all->row_tiles[b] - all->row_tiles[a]);
    float *values = malloc((t.tile_count ? t.tile_count : 1) * T * sizeof *values);
    RAD_CHECK(values != NULL);
    memset(values, 0xff, t.tile_count * T * sizeof *values); /* NaNs where nothing was filled */
    int exact = 1;
    for (size_t first = 0; first < t.n; first += piece) {
        size_t end = first + piece < t.n ? first + piece : t.n;
        exact = solve_gpu_tiles_fill(&t, first, end, values + t.row_tiles[first] * T) && exact;
    }
    t.values = values; /* freed with t */
    size_t wrong = 0;
    for (size_t r = 0; r < t.n; r++) {
        wrong += t.diag[r] != all->diag[a + r];
        for (uint64_t k = t.row_tiles[r]; k < t.row_tiles[r + 1]; k++) {
            const uint64_t m = all->row_tiles[a + r] + (k - t.row_tiles[r]);
            wrong += t.tile_column[k] != all->tile_column[m];
            wrong += memcmp(values + k * T, all->values + m * T, T * sizeof *values) != 0;
        }
    }
    fprintf(stderr, "%s, rows [%zu, %zu) in pieces of %zu: %zu tiles, %zu wrong, exact %d\n", what, a, b, piece,
            t.tile_count, wrong, exact);
    RAD_CHECK(wrong == 0 && exact == expect_exact);
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
    {
        solve_gpu_tiles whole;
        RAD_CHECK(solve_gpu_tiles_make(&sparse, &whole) == RAD_OK);
        check_streamed(&sparse, &whole, 0, N, 7, 0, "sparse, f64 entries, streamed");
        solve_gpu_tiles_free(&whole);
    }
    for (size_t k = 0; k < N * N; k++) F[k] = (float)F[k];
    for (size_t k = 0; k < used; k++) values[k] = (float)values[k];
    check(&dense, 1, "dense, f32 entries");
    check(&sparse, 1, "sparse, f32 entries");
    /* a rank's block: from the whole matrix, and from a view of its rows only */
    solve_gpu_tiles all;
    RAD_CHECK(solve_gpu_tiles_make(&sparse, &all) == RAD_OK);
    check_block(&sparse, &all, 40, 97, "sparse, a block of the whole");
    solve_rows held = sparse;
    held.row_tiles = row_tiles + 40; /* holds rows [40, 97): its index starts at row 40's */
    held.first_row = 40;
    check_block(&held, &all, 40, 97, "sparse, only the block held");
    check_streamed(&sparse, &all, 0, N, 1, 1, "sparse, f32 entries, streamed");
    { /* a rank without rows (the split leaves the last ones empty) holds no float that is not exact */
        solve_gpu_tiles none;
        RAD_CHECK(solve_gpu_tiles_layout_rows(&sparse, 60, 60, &none) == RAD_OK);
        RAD_CHECK(none.n == 0 && none.tile_count == 0 && none.exact == 1);
        solve_gpu_tiles_free(&none);
    }
    check_streamed(&held, &all, 40, 97, 13, 1, "sparse, only the block held, streamed");
    solve_gpu_tiles_free(&all);
    RAD_CHECK(solve_gpu_tiles_make(&dense, &all) == RAD_OK);
    check_streamed(&dense, &all, 0, N, 150, 1, "dense, f32 entries, streamed whole");
    solve_rows dense_held = {.n = N, .dense = F + 40 * N, .first_row = 40};
    check_block(&dense_held, &all, 40, 97, "dense, only the block held");
    check_streamed(&dense_held, &all, 40, 97, 5, 1, "dense, only the block held, streamed");
    solve_gpu_tiles_free(&all);
    return rad_test_finish();
}
