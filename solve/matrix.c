/* matrix.c - reads the form-factor matrix into memory and validates it. */
#include "matrix.h"

#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "rad_log.h"

/* Rows read per rad_ff_read_rows call: about 8 MiB at a time. */
#define MATRIX_READ_BYTES (8u << 20)

/* Checks row i; logs and returns RAD_ERR_INVALID at the first problem. */
static rad_status check_row(const char *path, size_t i, const double *row, size_t n, double *out_sum)
{
    double sum = 0;
    for (size_t j = 0; j < n; j++) {
        double f = row[j];
        if (!isfinite(f)) {
            rad_error("%s: row %zu: F[%zu][%zu] is %s", path, i, i, j, isnan(f) ? "NaN" : "infinite");
            return RAD_ERR_INVALID;
        }
        if (f < -SOLVE_NEGATIVE_TOLERANCE) {
            rad_error("%s: row %zu: F[%zu][%zu] = %.6g is negative", path, i, i, j, f);
            return RAD_ERR_INVALID;
        }
        sum += f;
    }
    if (sum > SOLVE_ROW_SUM_LIMIT) {
        rad_error("%s: row %zu: form factors sum to %.6g, more than %g (a closed scene sums to 1)", path, i, sum,
                  SOLVE_ROW_SUM_LIMIT);
        return RAD_ERR_INVALID;
    }
    *out_sum = sum;
    return RAD_OK;
}

rad_status solve_matrix_load(rad_ff_file *file, const char *path, solve_matrix *out_matrix)
{
    rad_status status = RAD_OK;
    solve_matrix m;
    memset(&m, 0, sizeof m);
    const rad_mesh *mesh = rad_ff_file_mesh(file);
    const rad_ff_info *info = rad_ff_file_info(file);
    const size_t n = mesh->patch_count;
    if (n == 0 || info->patch_count != n) {
        rad_error("%s: header says %llu patches, patch table holds %zu", path,
                  (unsigned long long)info->patch_count, n);
        status = RAD_ERR_FORMAT;
        goto done;
    }
    if (n > SIZE_MAX / sizeof(double) / n) {
        rad_error("%s: a %zu x %zu matrix does not fit in memory", path, n, n);
        status = RAD_ERR_NOMEM;
        goto done;
    }
    m.patch_count = n;
    m.form_factors = malloc(n * n * sizeof(double));
    m.area = malloc(n * sizeof(double));
    m.row_sum = malloc(n * sizeof(double));
    if (!m.form_factors || !m.area || !m.row_sum) {
        rad_error("%s: out of memory: the %zu x %zu matrix needs %.2f GiB as double", path, n, n,
                  (double)n * (double)n * 8.0 / (1u << 30));
        status = RAD_ERR_NOMEM;
        goto done;
    }
    for (size_t i = 0; i < n; i++) m.area[i] = mesh->patches[i].area;

    size_t block = MATRIX_READ_BYTES / (n * sizeof(double));
    if (block == 0) block = 1;
    size_t warned_rows = 0, worst_row = 0;
    for (size_t begin = 0; begin < n; begin += block) {
        size_t count = n - begin < block ? n - begin : block;
        double *rows = m.form_factors + begin * n;
        status = rad_ff_read_rows(file, begin, count, rows);
        if (status != RAD_OK) goto done;
        for (size_t k = 0; k < count; k++) {
            size_t i = begin + k;
            status = check_row(path, i, rows + k * n, n, &m.row_sum[i]);
            if (status != RAD_OK) goto done;
            if (m.row_sum[i] > SOLVE_ROW_SUM_WARN) {
                if (warned_rows == 0 || m.row_sum[i] > m.row_sum[worst_row]) worst_row = i;
                warned_rows++;
            }
        }
    }
    if (warned_rows)
        rad_warn("%s: %zu rows sum to more than %g (largest: row %zu, %.6g); solving anyway", path, warned_rows,
                 SOLVE_ROW_SUM_WARN, worst_row, m.row_sum[worst_row]);
    *out_matrix = m;
    memset(&m, 0, sizeof m);
done:
    solve_matrix_free(&m);
    return status;
}

void solve_matrix_free(solve_matrix *matrix)
{
    if (!matrix) return;
    free(matrix->form_factors);
    free(matrix->area);
    free(matrix->row_sum);
    memset(matrix, 0, sizeof *matrix);
}

solve_system solve_matrix_system(const solve_matrix *matrix)
{
    solve_system s = {
        .patch_count = matrix->patch_count,
        .form_factors = matrix->form_factors,
        .area = matrix->area,
        .row_sum = matrix->row_sum,
    };
    return s;
}
