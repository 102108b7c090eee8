/* test_solve_reciprocal.c - the bound solve takes for files reciprocal by
 * construction (RAD_FF_FLAG_RECIPROCAL, solve_reciprocity_bound) holds on
 * formfactor's own files: for every row, the measured skew term
 * delta_i = sum_j |A_i F_ij - A_j F_ji| is at most b A_i sum_j F_ij.
 *
 *   test_solve_reciprocal FORMFACTORS...   (files formfactor wrote; f32 and f64)
 *
 * And the check trusts the flag: a non-reciprocal matrix given a bound
 * passes, the same matrix without one is refused (so the bound path is the
 * one taken). */
#include <stdint.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "iterate.h"
#include "matrix.h"
#include "rad_test.h"

static void bound_holds(const char *path)
{
    rad_ff_file *file = NULL;
    RAD_CHECK(rad_ff_open(path, &file) == RAD_OK);
    if (!file) return;
    const rad_ff_info *info = rad_ff_file_info(file);
    RAD_CHECK(info->flags & RAD_FF_FLAG_RECIPROCAL);
    solve_matrix m;
    RAD_CHECK(solve_matrix_load(file, path, 0, SIZE_MAX, &m) == RAD_OK);
    const size_t n = m.patch_count;
    double *rho = malloc(n * sizeof *rho), *work = malloc(n * sizeof *work);
    for (size_t i = 0; i < n; i++) rho[i] = 0.5;
    solve_run run = {.n = n, .F = m.rows, .area = m.area, .row_sum = m.row_sum, .rho = rho, .work = work,
                     .row_begin = 0, .row_end = n};
    solve_cg_check measured = solve_cg_check_matrix(&run); /* reciprocity_bound 0: measured into work */
    double worst = 0;
    for (size_t i = 0; i < n; i++) {
        double allowed = m.reciprocity_bound * m.area[i] * m.row_sum[i];
        if (work[i] > allowed) fprintf(stderr, "%s: row %zu: delta %.3g > bound %.3g\n", path, i, work[i], allowed);
        RAD_CHECK(work[i] <= allowed);
        if (allowed > 0 && work[i] / allowed > worst) worst = work[i] / allowed;
    }
    run.reciprocity_bound = m.reciprocity_bound;
    solve_cg_check bounded = solve_cg_check_matrix(&run);
    RAD_CHECK(measured.ratio <= bounded.ratio && solve_cg_check_passes(&bounded));
    printf("%s: %s entries, bound %.3g, measured skew at most %.3f of it; check ratio %.3g measured, %.3g bounded\n",
           path, info->element_type == RAD_ELEMENT_F32 ? "f32" : "f64", m.reciprocity_bound, worst, measured.ratio,
           bounded.ratio);
    free(rho);
    free(work);
    solve_matrix_free(&m);
    rad_ff_close(file);
}

static void flag_is_trusted(void)
{
    double F[4] = {0, 0.5, 0.3, 0}, area[2] = {1, 1}, rho[2] = {0.9, 0.9}, row_sum[2] = {0.5, 0.3}, work[2];
    solve_run run = {.n = 2, .F = {.n = 2, .dense = F}, .area = area, .row_sum = row_sum, .rho = rho,
                     .work = work, .row_begin = 0, .row_end = 2};
    solve_cg_check measured = solve_cg_check_matrix(&run);
    RAD_CHECK(!solve_cg_check_passes(&measured) && measured.ratio > SOLVE_CG_RECIPROCITY);
    run.reciprocity_bound = 1e-7;
    solve_cg_check bounded = solve_cg_check_matrix(&run);
    RAD_CHECK(solve_cg_check_passes(&bounded) && bounded.ratio < 1e-6);
}

int main(int argc, char **argv)
{
    flag_is_trusted();
    for (int k = 1; k < argc; k++) bound_holds(argv[k]);
    RAD_CHECK(argc > 1);
    return rad_test_finish();
}
