/* test_closure.c - rad_closure_scales (rad_closure.h) on explicit
 * operators: a reciprocal K of five leaves of unequal areas whose rows sum
 * to 0.88 .. 1.22, and one leaf without links. The scales must bring every
 * row to 1 within the tolerance, keep A_i K'_ij = A_j K'_ji, leave the
 * empty leaf at s = 1, and say when the iterations run out. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "rad_closure.h"
#include "rad_test.h"

#define N 6

static double K[N][N];
static const double area[N] = {1.0, 0.5, 2.0, 0.25, 1.5, 1.0};

static rad_status apply(void *ctx, const double *x, double *y)
{
    int *calls = ctx;
    (*calls)++;
    for (int i = 0; i < N; i++) {
        y[i] = 0;
        for (int j = 0; j < N; j++) y[i] += K[i][j] * x[j];
    }
    return RAD_OK;
}

/* K_ij = c_ij A_j with a symmetric c (reciprocal); leaf 5 linked to nothing. */
static void make_operator(void)
{
    for (int i = 0; i < N; i++)
        for (int j = 0; j < N; j++) {
            const double c = i == j || i == 5 || j == 5 ? 0 : 1.6 * (0.08 + 0.03 * ((i + 2 * j) % 3 + (j + 2 * i) % 3));
            K[i][j] = c * area[j];
        }
}

int main(void)
{
    rad_test_capture_log();
    make_operator();
    double s[N], row[N];
    int calls = 0;
    rad_closure_result r;
    RAD_CHECK(rad_closure_scales(N, apply, &calls, 1e-12, 0, s, row, &r) == RAD_OK);
    RAD_CHECK(r.iterations == (uint32_t)calls);
    RAD_CHECK(r.empty == 1);
    RAD_CHECK(rad_test_log_contains("1 of 6 leaves have no links"));
    printf("rows %.4f .. %.4f, scales %.4f .. %.4f, %u sweeps\n", r.row_before[0], r.row_before[1], r.scale[0], r.scale[1], r.iterations);
    RAD_CHECK(r.row_before[1] - r.row_before[0] > 0.3); /* there was something to balance */
    RAD_CHECK(r.deviation <= 1e-12);
    for (int i = 0; i < 5; i++) {
        double sum = 0;
        for (int j = 0; j < N; j++) sum += s[i] * K[i][j] * s[j];
        RAD_CHECK_NEAR(sum, 1, 1e-12);
        RAD_CHECK_NEAR(row[i], sum, 1e-15);
        RAD_CHECK(s[i] > r.scale[0] - 1e-15 && s[i] < r.scale[1] + 1e-15);
        for (int j = 0; j < N; j++) /* reciprocity kept */
            RAD_CHECK_NEAR(area[i] * s[i] * K[i][j] * s[j], area[j] * s[j] * K[j][i] * s[i], 1e-15);
    }
    RAD_CHECK(s[5] == 1 && row[5] == 0);
    /* out of iterations: the last iterate, and said so */
    calls = 0;
    RAD_CHECK(rad_closure_scales(N, apply, &calls, 1e-12, 2, s, NULL, &r) == RAD_ERR_NOT_CONVERGED);
    RAD_CHECK(r.iterations == 2 && r.deviation > 1e-12);
    /* a row that is not a number is refused */
    K[2][3] = NAN;
    RAD_CHECK(rad_closure_scales(N, apply, &calls, 0, 0, s, NULL, &r) == RAD_ERR_INVALID);
    return rad_test_finish();
}
