/* test_solve_rows.c - solve on a sparse matrix (solve/rows.h) against the
 * same matrix dense.
 *
 * A matrix of N = 300 patches (five tiles of 64 columns, the last 44 wide)
 * where whole 64 x 64 blocks are zero, some only on one side of the
 * diagonal (F_ij stored, F_ji not), rows are not reciprocal (so the CG
 * check's skew term is not 0), a few patches do not reflect, and one row
 * is all zero. Its tiles are handed to the solver as a sparse file's
 * would be: the CG check (ratio, margin), and every method's B, iteration
 * count and residual must be the same bits as on the dense matrix.
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#ifdef _OPENMP
#include <omp.h>
#endif

#include "iterate.h"
#include "rad_test.h"
#include "rows.h"
#include "solver.h"

#define N 300
#define T RAD_FF_TILE_COLUMNS

static double F[N * N], area[N], row_sum[N], rho[N], emission[N];

/* The sparse view of F: every tile with a non-zero bit, as formfactor
 * --format sparse stores them. */
static uint64_t row_tiles[N + 1];
static uint32_t tile_column[N * ((N + T - 1) / T)];
static uint64_t tile_value[N * ((N + T - 1) / T)];
static double values[N * N];

static solve_rows sparse_of_dense(void)
{
    size_t tiles = 0, stored = 0;
    for (size_t i = 0; i < N; i++) {
        row_tiles[i] = tiles;
        for (size_t c = 0; c < N; c += T) {
            size_t end = c + T < N ? c + T : N;
            int zero = 1;
            for (size_t j = c; j < end; j++) zero &= F[i * N + j] == 0 && !signbit(F[i * N + j]);
            if (zero) continue;
            tile_column[tiles] = (uint32_t)c;
            tile_value[tiles++] = stored;
            for (size_t j = c; j < end; j++) values[stored++] = F[i * N + j];
        }
    }
    row_tiles[N] = tiles;
    return (solve_rows){.n = N, .row_tiles = row_tiles, .tile_column = tile_column, .tile_value = tile_value,
                        .values = values};
}

static uint64_t lcg = 12345;
static double uniform(void)
{
    lcg = lcg * 6364136223846793005u + 1442695040888963407u;
    return (double)(lcg >> 11) / 9007199254740992.0;
}

static int same_bits(const double *a, const double *b, size_t count)
{
    return memcmp(a, b, count * sizeof *a) == 0;
}

int main(void)
{
    /* Block (I, J) of tiles is zero unless (I + 2 J) % 3 != 0; so (0, 1)
     * is stored and (1, 0) is not, (1, 1) is zero, ... Row 130 is zero. */
    for (size_t i = 0; i < N; i++) {
        area[i] = 0.5 + uniform();
        rho[i] = i % 17 == 3 ? 0 : 0.3 + 0.6 * uniform();
        emission[i] = i % 23 == 0 ? 1 + uniform() : 0;
        for (size_t j = 0; j < N; j++)
            if (j != i && i != 130 && ((i / T) + 2 * (j / T)) % 3 != 0) F[i * N + j] = uniform();
    }
    for (size_t i = 0; i < N; i++) { /* rows sum to 0.9 ... 1 */
        double s = 0;
        for (size_t j = 0; j < N; j++) s += F[i * N + j];
        double target = 0.9 + 0.1 * uniform();
        for (size_t j = 0; j < N && s > 0; j++) F[i * N + j] *= target / s;
        row_sum[i] = 0;
        for (size_t j = 0; j < N; j++) row_sum[i] += F[i * N + j];
    }
    solve_rows sparse = sparse_of_dense();
    RAD_CHECK(row_tiles[N] < (size_t)N * 4 && row_tiles[N] > (size_t)N); /* some tiles left out */
    RAD_CHECK(row_tiles[131] == row_tiles[130]);                       /* row 130: none */

    /* The rows themselves. */
    double x[N];
    for (size_t j = 0; j < N; j++) x[j] = uniform() - 0.3;
    int dots = 1, entries = 1;
    for (size_t i = 0; i < N; i++) {
        solve_rows dense = {.n = N, .dense = F};
        double a = solve_row_dot(&dense, i, x, 0, N), b = solve_row_dot(&sparse, i, x, 0, N);
        double c = solve_row_dot(&dense, i, x, 70, 150), d = solve_row_dot(&sparse, i, x, 70, 150);
        dots &= same_bits(&a, &b, 1) && same_bits(&c, &d, 1);
        for (size_t j = 0; j < N; j += 7) entries &= solve_row_entry(&sparse, i, j) == F[i * N + j];
    }
    RAD_CHECK(dots && entries);

    /* The CG check: the skew term of a non-reciprocal matrix, blocks
     * stored on one side only. */
    double work[N];
    solve_run dense_run = {.n = N, .F = {.n = N, .dense = F}, .area = area, .rho = rho, .work = work};
    solve_cg_check dc = solve_cg_check_matrix(&dense_run);
    solve_run sparse_run = dense_run;
    sparse_run.F = sparse;
    solve_cg_check sc = solve_cg_check_matrix(&sparse_run);
    fprintf(stderr, "CG check: ratio %.17g (row %zu), margin %.17g\n", dc.ratio, dc.ratio_row, dc.margin);
#ifdef _OPENMP
    /* ... whatever the number of threads (each row's skew term is summed
     * by one thread, in one order). */
    int threads = omp_get_max_threads();
    omp_set_num_threads(1);
    solve_cg_check single = solve_cg_check_matrix(&sparse_run);
    omp_set_num_threads(5);
    solve_cg_check five = solve_cg_check_matrix(&dense_run);
    omp_set_num_threads(threads);
    RAD_CHECK(same_bits(&single.ratio, &dc.ratio, 1) && same_bits(&five.ratio, &dc.ratio, 1));
#endif
    RAD_CHECK(dc.ratio > 0 && same_bits(&dc.ratio, &sc.ratio, 1) && dc.ratio_row == sc.ratio_row);
    RAD_CHECK(same_bits(&dc.margin, &sc.margin, 1) && dc.margin_row == sc.margin_row);

    /* Every method: the same B, iterations and residual. */
    solve_system dense_system = {.patch_count = N, .form_factors = F, .area = area, .row_sum = row_sum};
    solve_system sparse_system = {.patch_count = N, .area = area, .row_sum = row_sum, .sparse = &sparse};
    solve_method methods[] = {SOLVE_JACOBI, SOLVE_GAUSS_SEIDEL, SOLVE_CG, SOLVE_AUTO};
    for (size_t m = 0; m < sizeof methods / sizeof *methods; m++) {
        solve_params p = {.method = methods[m], .tolerance = 1e-12, .progress_seconds = -1};
        double bd[N], bs[N];
        solve_report rd, rs;
        rad_status sd = solve_channel(&dense_system, rho, emission, &p, bd, &rd);
        rad_status ss = solve_channel(&sparse_system, rho, emission, &p, bs, &rs);
        fprintf(stderr, "%s: %u iterations, residual %.3g\n", solve_method_name(methods[m]), rd.iterations,
                rd.residual);
        RAD_CHECK(sd == RAD_OK && ss == RAD_OK && rd.converged && rs.converged);
        RAD_CHECK(same_bits(bd, bs, N) && rd.iterations == rs.iterations && same_bits(&rd.residual, &rs.residual, 1));
        solve_report_free(&rd);
        solve_report_free(&rs);
    }

    /* Reciprocal (A_i F_ij = A_j F_ji) on a symmetric block pattern: CG
     * runs, three channels in lockstep (one pass over the rows for all). */
    for (size_t i = 0; i < N; i++)
        for (size_t j = 0; j < i; j++) {
            double g = ((i / T) + (j / T)) % 3 != 0 && i != 130 && j != 130 ? uniform() : 0;
            F[i * N + j] = g / area[i];
            F[j * N + i] = g / area[j];
        }
    double top = 0;
    for (size_t i = 0; i < N; i++) {
        row_sum[i] = 0;
        for (size_t j = 0; j < N; j++) row_sum[i] += F[i * N + j];
        if (row_sum[i] > top) top = row_sum[i];
    }
    for (size_t k = 0; k < (size_t)N * N; k++) F[k] *= 0.95 / top;
    for (size_t i = 0; i < N; i++) {
        row_sum[i] = 0;
        for (size_t j = 0; j < N; j++) row_sum[i] += F[i * N + j];
    }
    sparse = sparse_of_dense();
    dense_system = (solve_system){.patch_count = N, .form_factors = F, .area = area, .row_sum = row_sum};
    sparse_system = (solve_system){.patch_count = N, .area = area, .row_sum = row_sum, .sparse = &sparse};
    static double rho3[3][N], e3[3][N], bd3[3][N], bs3[3][N];
    for (int c = 0; c < 3; c++)
        for (size_t i = 0; i < N; i++) {
            rho3[c][i] = c == 2 && i % 11 == 0 ? 0 : 0.2 + 0.25 * c + 0.1 * uniform();
            e3[c][i] = emission[i] * (1 + c);
        }
    const double *rhos[3] = {rho3[0], rho3[1], rho3[2]}, *es[3] = {e3[0], e3[1], e3[2]};
    double *bds[3] = {bd3[0], bd3[1], bd3[2]}, *bss[3] = {bs3[0], bs3[1], bs3[2]};
    solve_params one = {.method = SOLVE_CG, .tolerance = 1e-12, .progress_seconds = -1}, p[3] = {one, one, one};
    solve_report rd[3], rs[3];
    solve_channels_result xd, xs;
    rad_status sd = solve_channels(&dense_system, 3, rhos, es, p, bds, rd, &xd);
    rad_status ss = solve_channels(&sparse_system, 3, rhos, es, p, bss, rs, &xs);
    RAD_CHECK(xd.lockstep_channels == 3 && xs.lockstep_channels == 3);
    RAD_CHECK(sd == RAD_OK && ss == RAD_OK);
    for (int c = 0; c < 3; c++) {
        fprintf(stderr, "lockstep channel %d: %s, %u iterations, residual %.3g\n", c,
                solve_method_name(rd[c].method_used), rd[c].iterations, rd[c].residual);
        RAD_CHECK(rd[c].method_used == SOLVE_CG && !rd[c].fell_back && rd[c].converged);
        RAD_CHECK(same_bits(bd3[c], bs3[c], N) && rd[c].iterations == rs[c].iterations);
        solve_report_free(&rd[c]);
        solve_report_free(&rs[c]);
    }
    return rad_test_finish();
}
