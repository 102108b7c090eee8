/* matrix.c - reads the form-factor matrix into memory and validates it. */
#include "matrix.h"

#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "rad_log.h"
#include "rad_mem.h"
#include "rad_mesh.h"

/* Rows read per rad_ff_read_rows call: about 8 MiB at a time. */
#define MATRIX_READ_BYTES (8u << 20)

/* Rows per rad_ff_read_rows call for rows of n doubles (at least 1). */
static size_t matrix_block_rows(size_t n)
{
    size_t block = MATRIX_READ_BYTES / (n * sizeof(double));
    return block ? block : 1;
}

/* Checks F_ij; logs and returns RAD_ERR_INVALID if it is not finite or negative. */
static rad_status check_entry(const char *path, size_t i, size_t j, double f)
{
    if (!isfinite(f)) {
        rad_error("%s: row %zu: F[%zu][%zu] is %s", path, i, i, j, isnan(f) ? "NaN" : "infinite");
        return RAD_ERR_INVALID;
    }
    if (f < -SOLVE_NEGATIVE_TOLERANCE) {
        rad_error("%s: row %zu: F[%zu][%zu] = %.6g is negative", path, i, i, j, f);
        return RAD_ERR_INVALID;
    }
    return RAD_OK;
}

/* Checks row i of `rows` (every entry, then the sum, left to right);
 * logs and returns RAD_ERR_INVALID at the first problem. */
static rad_status check_row(const char *path, const solve_rows *rows, size_t i, double *out_sum)
{
    double sum = 0;
    for (size_t k = 0; k < solve_row_span_count(rows, i); k++) {
        solve_span sp = solve_row_span(rows, i, k);
        for (size_t j = sp.begin; j < sp.end; j++) {
            double f = sp.values[j - sp.begin];
            if (check_entry(path, i, j, f) != RAD_OK) return RAD_ERR_INVALID;
            sum += f;
        }
    }
    if (sum > SOLVE_ROW_SUM_LIMIT) {
        rad_error("%s: row %zu: form factors sum to %.6g, more than %g (a closed scene sums to 1)", path, i, sum,
                  SOLVE_ROW_SUM_LIMIT);
        return RAD_ERR_INVALID;
    }
    *out_sum = sum;
    return RAD_OK;
}

/* Room for `tiles` more tiles and `values` more entries in m's arrays
 * (reserved ones, solve_matrix_begin's, hold their bound and never move). */
static rad_status grow_sparse(solve_matrix *m, size_t tiles, size_t values)
{
    if ((m->tiles_reserved || m->values_reserved) &&
        (m->tile_count + tiles > m->tile_cap || m->value_count + values > m->value_cap)) {
        rad_error("internal: rows holding more than their room");
        return RAD_ERR_INVALID;
    }
    if (m->tile_count + tiles > m->tile_cap) {
        size_t cap = m->tile_cap ? 2 * m->tile_cap : 4096;
        while (cap < m->tile_count + tiles) cap *= 2;
        uint32_t *column = realloc(m->tile_column, cap * sizeof *column);
        if (column) m->tile_column = column;
        uint64_t *value = column ? realloc(m->tile_value, cap * sizeof *value) : NULL;
        if (value) m->tile_value = value;
        if (!column || !value) return RAD_ERR_NOMEM;
        rad_mem_advise_huge(m->tile_column, cap * sizeof *column);
        rad_mem_advise_huge(m->tile_value, cap * sizeof *value);
        m->tile_cap = cap;
    }
    if (m->value_count + values > m->value_cap) {
        size_t cap = m->value_cap ? 2 * m->value_cap : 1 << 18;
        while (cap < m->value_count + values) cap *= 2;
        if (!m->value_cap) cap = m->value_count + values; /* the first: sized by the caller */
        double *grown = realloc(m->values, cap * sizeof *grown);
        if (!grown) return RAD_ERR_NOMEM;
        m->values = grown;
        rad_mem_advise_huge(m->values, cap * sizeof *grown); /* before its new pages are touched */
        m->value_cap = cap;
    }
    return RAD_OK;
}

/* Records read per rad_ff_read_records call: about 64 MiB at a time. */
#define MATRIX_RECORD_BYTES (64u << 20)

/* Rows [row, row + rows) from their records (record r: at[r + 1] - at[r]
 * bytes at records + at[r] - at[0]): counted (and, read from `file`,
 * checksummed: NULL for records handed over in memory), decoded on the
 * OpenMP threads and appended to m's tiles. A damaged row is named (the
 * first, whatever the threads). `counts` holds 2 rows + 1 values of
 * scratch. */
static rad_status place_records(solve_matrix *m, const rad_ff_file *file, const char *name, size_t row, size_t rows,
                                const unsigned char *records, const uint64_t *at, uint64_t *counts)
{
    const size_t n = m->patch_count;
    const uint64_t base = at[0];
    uint64_t *tiles = counts, *values = counts + rows + 1;
    size_t bad = SIZE_MAX;
    /* Quiet on the threads; the first damaged row is named once, after. */
    rad_log_level level = rad_log_get_level();
    rad_log_set_level(RAD_LOG_NONE);
#pragma omp parallel for schedule(dynamic, 64) reduction(min : bad)
    for (size_t r = 0; r < rows; r++) {
        uint32_t t = 0;
        uint64_t v = 0;
        const unsigned char *record = records + (at[r] - base);
        int ok = file ? rad_ff_record_counts(file, row + r, record, &t, &v) == RAD_OK
                      : !rad_ff_record_sizes(record, at[r + 1] - at[r], n, &t, &v);
        if (!ok) bad = r < bad ? r : bad;
        tiles[r + 1] = t;
        values[r] = v;
    }
    rad_log_set_level(level);
    if (bad != SIZE_MAX) {
        uint32_t t;
        uint64_t v;
        const unsigned char *record = records + (at[bad] - base);
        if (file) return rad_ff_record_counts(file, row + bad, record, &t, &v);
        rad_error("%s: row %zu: %s", name, row + bad, rad_ff_record_sizes(record, at[bad + 1] - at[bad], n, &t, &v));
        return RAD_ERR_FORMAT;
    }
    tiles[0] = 0;
    for (size_t r = 0; r < rows; r++) tiles[r + 1] += tiles[r];
    size_t total = 0;
    for (size_t r = 0; r < rows; r++) {
        uint64_t v = values[r];
        values[r] = total;
        total += v;
    }
    rad_status grown = grow_sparse(m, tiles[rows], total);
    if (grown != RAD_OK) {
        if (grown == RAD_ERR_NOMEM)
            rad_error("%s: out of memory for the stored tiles of %zu rows (%zu entries so far)", name, m->patch_count,
                      m->value_count);
        return grown;
    }
#pragma omp parallel for schedule(dynamic, 64) reduction(min : bad)
    for (size_t r = 0; r < rows; r++) {
        uint32_t *column = m->tile_column + m->tile_count + tiles[r], count = 0;
        uint64_t *where = m->tile_value + m->tile_count + tiles[r], stored = 0;
        uint64_t v = m->value_count + values[r];
        if (rad_ff_record_decode(records + (at[r] - base), at[r + 1] - at[r], n, m->element_type, column, &count,
                                 m->values + v, &stored)) {
            bad = r < bad ? r : bad;
            continue;
        }
        for (uint64_t k = 0; k < count; k++) { /* tile numbers -> first columns, entries */
            size_t first = (size_t)column[k] * RAD_FF_TILE_COLUMNS;
            column[k] = (uint32_t)first;
            where[k] = v;
            v += first + RAD_FF_TILE_COLUMNS < n ? RAD_FF_TILE_COLUMNS : n - first;
        }
    }
    if (bad != SIZE_MAX) {
        uint32_t count;
        uint64_t stored;
        const char *why = rad_ff_record_decode(records + (at[bad] - base), at[bad + 1] - at[bad], n, m->element_type,
                                   m->tile_column + m->tile_count + tiles[bad],
                                   &count, m->values + m->value_count + values[bad], &stored);
        rad_error("%s: row %zu: %s", name, row + bad, why);
        return RAD_ERR_FORMAT;
    }
    for (size_t r = 0; r < rows; r++) m->row_tiles[row - m->row_begin + r + 1] = m->tile_count + tiles[r + 1];
    m->tile_count += tiles[rows];
    m->value_count += total;
    return RAD_OK;
}

/* Rows [first, last) of m: every entry and the sum, on the threads, into
 * m->row_sum; the first bad row named (check_row). */
static rad_status check_rows(solve_matrix *m, const char *name, size_t first, size_t last)
{
    size_t bad = SIZE_MAX;
#pragma omp parallel for schedule(dynamic, 64) reduction(min : bad)
    for (size_t i = first; i < last; i++) {
        double sum = 0;
        int ok = 1;
        for (size_t k = 0; k < solve_row_span_count(&m->rows, i); k++) {
            solve_span sp = solve_row_span(&m->rows, i, k);
            for (size_t j = sp.begin; j < sp.end; j++) {
                double f = sp.values[j - sp.begin];
                ok &= isfinite(f) && f >= -SOLVE_NEGATIVE_TOLERANCE;
                sum += f;
            }
        }
        m->row_sum[i] = sum;
        if (!ok || !(sum <= SOLVE_ROW_SUM_LIMIT)) bad = i < bad ? i : bad;
    }
    if (bad != SIZE_MAX) return check_row(name, &m->rows, bad, &m->row_sum[bad]);
    return RAD_OK;
}

/* A sparse file, in blocks of rows read at once and decoded on the
 * threads, kept as its tiles (rows.h); each row checked as a dense one is. */
static rad_status load_sparse(rad_ff_file *file, const char *path, solve_matrix *m)
{
    const size_t n = m->patch_count, first = m->row_begin, last = m->row_end;
    rad_status status = RAD_OK;
    unsigned char *records = NULL;
    uint64_t *counts = NULL, *at;
    size_t records_cap = 0, counts_cap = 0;
    m->row_tiles = malloc((last - first + 1) * sizeof *m->row_tiles);
    if (!m->row_tiles) {
        rad_error("%s: out of memory for %zu rows", path, last - first);
        return RAD_ERR_NOMEM;
    }
    m->row_tiles[0] = 0;
    /* Room for every entry at once: each takes an element's bytes in its
     * record, so the records' size bounds them (within the tile lists'
     * few per cent); one array, on huge pages before it is touched. */
    size_t element = rad_ff_file_info(file)->element_type == RAD_ELEMENT_F32 ? 4 : 8;
    if (grow_sparse(m, 0, (size_t)((rad_ff_record_offset(file, last) - rad_ff_record_offset(file, first)) / element)) !=
        RAD_OK) {
        rad_error("%s: out of memory for the stored entries of %zu rows", path, last - first);
        return RAD_ERR_NOMEM;
    }
    for (size_t begin = first, end; begin < last && status == RAD_OK; begin = end) {
        /* as many rows as fit in MATRIX_RECORD_BYTES, at least one */
        uint64_t start = rad_ff_record_offset(file, begin);
        for (end = begin + 1; end < last && rad_ff_record_offset(file, end + 1) - start <= MATRIX_RECORD_BYTES; end++) {
        }
        size_t bytes = (size_t)(rad_ff_record_offset(file, end) - start), rows = end - begin;
        if (bytes > records_cap || 3 * rows + 2 > counts_cap) {
            free(records);
            free(counts);
            records_cap = bytes > records_cap ? bytes : records_cap;
            counts_cap = 3 * rows + 2 > counts_cap ? 3 * rows + 2 : counts_cap;
            records = malloc(records_cap ? records_cap : 1);
            counts = malloc(counts_cap * sizeof *counts);
            if (!records || !counts) {
                rad_error("%s: out of memory reading rows", path);
                status = RAD_ERR_NOMEM;
                break;
            }
        }
        status = rad_ff_read_records(file, begin, rows, records);
        at = counts + 2 * rows + 1; /* the records' offsets, for place_records */
        for (size_t r = 0; r <= rows; r++) at[r] = rad_ff_record_offset(file, begin + r);
        if (status == RAD_OK) status = place_records(m, file, path, begin, rows, records, at, counts);
    }
    free(records);
    free(counts);
    if (status != RAD_OK) return status;
    m->rows = (solve_rows){.n = n, .row_tiles = m->row_tiles, .tile_column = m->tile_column,
                           .tile_value = m->tile_value, .values = m->values, .first_row = first};
    return check_rows(m, path, first, last); /* every row's entries and sum; the first bad row named */
}

/* The cost of rows [0, i) for solve_matrix_split_rows. */
static double split_cost_before(const rad_ff_file *file, int sparse, size_t i)
{
    return (double)(sparse ? rad_ff_record_offset(file, i) : 0) + (double)i * SOLVE_SPLIT_ROW_BYTES;
}

void solve_matrix_split_rows(const rad_ff_file *file, size_t parts, size_t *row_begin)
{
    const size_t n = rad_ff_file_mesh(file)->patch_count;
    const int sparse = rad_ff_file_info(file)->layout == RAD_FF_LAYOUT_SPARSE;
    const double total = split_cost_before(file, sparse, n);
    row_begin[0] = 0;
    for (size_t p = 1; p < parts; p++) {
        /* the first row whose cost before it reaches p / parts of the total */
        double target = total * (double)p / (double)parts;
        size_t lo = row_begin[p - 1], hi = n;
        while (lo < hi) {
            size_t mid = lo + (hi - lo) / 2;
            if (split_cost_before(file, sparse, mid) < target)
                lo = mid + 1;
            else
                hi = mid;
        }
        row_begin[p] = lo;
    }
    row_begin[parts] = n;
}

double solve_reciprocity_bound(const rad_ff_info *info)
{
    if (!(info->flags & RAD_FF_FLAG_RECIPROCAL)) return 0;
    /* F_ij = s(fl(c A_j)) and F_ji = s(fl(c A_i)) with c = c_ij = c_ji: two
     * roundings each, u = 2^-53 for the product, v for the storage (2^-24
     * for f32, 0 for f64), so |A_i F_ij - A_j F_ji| <= 2 (u + v)(1 + 2 (u + v))
     * A_i F_ij. Doubled for the check's own arithmetic, plus 1e-12 for
     * couplings from mixed CPU and GPU ranks (their atan2 and sqrt differ
     * by a few ulps, so c_ij and c_ji may too). */
    const double u = 0x1p-53, v = info->element_type == RAD_ELEMENT_F32 ? 0x1p-24 : 0;
    return 4 * (u + v) * (1 + 2 * (u + v)) + 1e-12;
}

rad_status solve_matrix_load(rad_ff_file *file, const char *path, size_t row_begin, size_t row_end,
                             solve_matrix *out_matrix)
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
    if (info->layout == RAD_FF_LAYOUT_LINKS) {
        rad_error("%s: holds links, not a matrix (hierarchical radiosity): solve_matrix_load reads matrices", path);
        status = RAD_ERR_UNSUPPORTED;
        goto done;
    }
    m.patch_count = n;
    m.reciprocity_bound = solve_reciprocity_bound(info);
    m.element_type = info->element_type;
    m.row_begin = row_begin < n ? row_begin : n;
    m.row_end = row_end <= n ? row_end : n;
    if (m.row_begin > m.row_end) m.row_begin = m.row_end;
    m.area = malloc(n * sizeof(double));
    m.row_sum = malloc(n * sizeof(double));
    if (!m.area || !m.row_sum) {
        rad_error("%s: out of memory for %zu patches", path, n);
        status = RAD_ERR_NOMEM;
        goto done;
    }
    for (size_t i = 0; i < n; i++) m.area[i] = mesh->patches[i].area;
    for (size_t i = 0; i < n; i++) m.row_sum[i] = 0; /* rows held elsewhere: from their ranks (stage.c) */
    if (info->layout == RAD_FF_LAYOUT_SPARSE) {
        status = load_sparse(file, path, &m);
        if (status != RAD_OK) goto done;
        *out_matrix = m;
        memset(&m, 0, sizeof m);
        goto done;
    }
    if (n > SIZE_MAX / sizeof(double) / n) {
        rad_error("%s: a %zu x %zu matrix does not fit in memory", path, n, n);
        status = RAD_ERR_NOMEM;
        goto done;
    }
    const size_t held = m.row_end - m.row_begin;
    m.form_factors = malloc((held ? held : 1) * n * sizeof(double));
    m.rows = (solve_rows){.n = n, .dense = m.form_factors, .first_row = m.row_begin};
    if (!m.form_factors) {
        rad_error("%s: out of memory: %zu rows of the %zu x %zu matrix need %.2f GiB as double", path, held, n, n,
                  (double)held * (double)n * 8.0 / (1u << 30));
        status = RAD_ERR_NOMEM;
        goto done;
    }
    size_t block = matrix_block_rows(n);
    for (size_t begin = m.row_begin; begin < m.row_end; begin += block) {
        size_t count = m.row_end - begin < block ? m.row_end - begin : block;
        double *rows = m.form_factors + (begin - m.row_begin) * n;
        status = rad_ff_read_rows(file, begin, count, rows);
        if (status != RAD_OK) goto done;
        for (size_t k = 0; k < count; k++) {
            size_t i = begin + k;
            status = check_row(path, &m.rows, i, &m.row_sum[i]);
            if (status != RAD_OK) goto done;
        }
    }
    *out_matrix = m;
    memset(&m, 0, sizeof m);
done:
    solve_matrix_free(&m);
    return status;
}

rad_status solve_matrix_begin(const rad_ff_info *info, const rad_mesh *mesh, size_t row_begin, size_t row_end,
                              solve_matrix *out_matrix)
{
    solve_matrix m;
    memset(&m, 0, sizeof m);
    memset(out_matrix, 0, sizeof *out_matrix);
    const size_t n = mesh->patch_count, rows = row_end - row_begin;
    const size_t tiles = rows * ((n + RAD_FF_TILE_COLUMNS - 1) / RAD_FF_TILE_COLUMNS);
    m.patch_count = n;
    m.reciprocity_bound = solve_reciprocity_bound(info);
    m.row_begin = row_begin;
    m.row_end = row_end;
    m.element_type = info->element_type;
    m.area = malloc((n ? n : 1) * sizeof(double));
    m.row_sum = calloc(n ? n : 1, sizeof(double));
    m.row_tiles = malloc((rows + 1) * sizeof *m.row_tiles);
    /* at most every entry and every tile of the rows: reserved, touched as filled */
    m.values_reserved = (rows ? rows : 1) * n * sizeof(double);
    m.tiles_reserved = (tiles ? tiles : 1) * sizeof(uint64_t);
    m.values = rad_mem_reserve(m.values_reserved);
    m.tile_value = rad_mem_reserve(m.tiles_reserved);
    m.tile_column = rad_mem_reserve(m.tiles_reserved);
    if (!m.values || !m.tile_value || !m.tile_column) { /* no reservation: the bound, allocated */
        rad_mem_release(m.values, m.values_reserved);
        rad_mem_release(m.tile_value, m.tiles_reserved);
        rad_mem_release(m.tile_column, m.tiles_reserved);
        m.values_reserved = m.tiles_reserved = 0;
        m.values = malloc((rows ? rows : 1) * n * sizeof(double));
        m.tile_value = malloc((tiles ? tiles : 1) * sizeof *m.tile_value);
        m.tile_column = malloc((tiles ? tiles : 1) * sizeof *m.tile_column);
    }
    if (!m.area || !m.row_sum || !m.row_tiles || !m.values || !m.tile_value || !m.tile_column) {
        rad_error("out of memory for %zu rows of %zu form factors", rows, n);
        solve_matrix_free(&m);
        return RAD_ERR_NOMEM;
    }
    m.value_cap = rows * n;
    m.tile_cap = tiles;
    for (size_t i = 0; i < n; i++) m.area[i] = mesh->patches[i].area;
    m.row_tiles[0] = 0;
    m.rows = (solve_rows){.n = n, .row_tiles = m.row_tiles, .tile_column = m.tile_column,
                          .tile_value = m.tile_value, .values = m.values, .first_row = row_begin};
    *out_matrix = m;
    return RAD_OK;
}

rad_status solve_matrix_append(solve_matrix *m, const char *name, size_t row, size_t rows,
                               const unsigned char *records, const uint64_t *at)
{
    if (row != m->row_begin + m->appended || row + rows > m->row_end) {
        rad_error("internal: %s: rows %zu..%zu appended after %zu of [%zu, %zu)", name, row, row + rows,
                  m->appended, m->row_begin, m->row_end);
        return RAD_ERR_INVALID;
    }
    if (rows == 0) return RAD_OK;
    uint64_t *counts = malloc((2 * rows + 1) * sizeof *counts);
    if (!counts) {
        rad_error("%s: out of memory", name);
        return RAD_ERR_NOMEM;
    }
    rad_status status = place_records(m, NULL, name, row, rows, records, at, counts);
    free(counts);
    if (status == RAD_OK) status = check_rows(m, name, row, row + rows);
    if (status == RAD_OK) m->appended += rows;
    return status;
}

rad_status solve_matrix_end(solve_matrix *m, const char *name)
{
    if (m->appended != m->row_end - m->row_begin) {
        rad_error("internal: %s: %zu of %zu rows came", name, m->appended, m->row_end - m->row_begin);
        return RAD_ERR_INVALID;
    }
    return RAD_OK;
}

void solve_matrix_free(solve_matrix *matrix)
{
    if (!matrix) return;
    free(matrix->form_factors);
    free(matrix->row_tiles);
    if (matrix->tiles_reserved) {
        rad_mem_release(matrix->tile_column, matrix->tiles_reserved);
        rad_mem_release(matrix->tile_value, matrix->tiles_reserved);
    } else {
        free(matrix->tile_column);
        free(matrix->tile_value);
    }
    if (matrix->values_reserved)
        rad_mem_release(matrix->values, matrix->values_reserved);
    else
        free(matrix->values);
    free(matrix->area);
    free(matrix->row_sum);
    free(matrix->row_error);
    memset(matrix, 0, sizeof *matrix);
}

/* Why the errors file (info e, mesh em) does not belong to the matrix
 * (info f, mesh fm); NULL if it does. */
static const char *errors_mismatch(const rad_ff_info *f, const rad_mesh *fm, const rad_ff_info *e,
                                   const rad_mesh *em)
{
    if (e->layout == RAD_FF_LAYOUT_LINKS) return "it holds links (hierarchical radiosity), not standard errors";
    if (!(e->flags & RAD_FF_FLAG_STANDARD_ERRORS)) return "it holds form factors, not their standard errors";
    if (e->patch_count != f->patch_count) return "a different patch count";
    if (e->scene_fingerprint != f->scene_fingerprint || e->subdiv != f->subdiv) return "a different scene";
    if (e->estimator != f->estimator || e->samples != f->samples || e->shadow_rays != f->shadow_rays ||
        e->seed != f->seed || (e->flags & ~RAD_FF_FLAG_STANDARD_ERRORS) != f->flags)
        return "different formfactor settings (estimator, samples, shadow rays, seed)";
    if (em->vertex_count != fm->vertex_count ||
        memcmp(em->positions, fm->positions, 3 * fm->vertex_count * sizeof(double)) != 0 ||
        memcmp(em->patches, fm->patches, fm->patch_count * sizeof(rad_patch)) != 0)
        return "a different patch table";
    return NULL;
}

/* row_error[i] = sqrt(sum_j sigma_ij^2) for rows [first, last) of `errors`
 * (the others 0). */
static rad_status read_row_errors(rad_ff_file *errors, size_t n, size_t first, size_t last, double *row_error)
{
    size_t block = matrix_block_rows(n);
    double *rows = malloc(block * n * sizeof(double));
    if (!rows) return RAD_ERR_NOMEM;
    rad_status status = RAD_OK;
    for (size_t i = 0; i < n; i++) row_error[i] = 0;
    for (size_t begin = first; begin < last && status == RAD_OK; begin += block) {
        size_t count = last - begin < block ? last - begin : block;
        status = rad_ff_read_rows(errors, begin, count, rows);
        for (size_t k = 0; k < count && status == RAD_OK; k++) {
            double squares = 0;
            for (size_t j = 0; j < n; j++) squares += rows[k * n + j] * rows[k * n + j];
            row_error[begin + k] = sqrt(squares);
        }
    }
    free(rows);
    return status;
}

rad_status solve_matrix_load_errors(solve_matrix *matrix, const rad_ff_file *file, const char *path,
                                    const char *errors_path)
{
    rad_ff_file *errors = NULL;
    double *row_error = NULL;
    rad_status status = rad_ff_open(errors_path, &errors);
    if (status != RAD_OK) goto done;
    const char *why = errors_mismatch(rad_ff_file_info(file), rad_ff_file_mesh(file), rad_ff_file_info(errors),
                                      rad_ff_file_mesh(errors));
    if (why) {
        rad_error("%s: not the standard errors of %s (%s); pass the file that `formfactor --errors` wrote "
                  "beside it",
                  errors_path, path, why);
        status = RAD_ERR_INVALID;
        goto done;
    }
    const size_t n = matrix->patch_count;
    row_error = malloc(n * sizeof(double));
    status = row_error ? read_row_errors(errors, n, matrix->row_begin, matrix->row_end, row_error) : RAD_ERR_NOMEM;
    if (status == RAD_ERR_NOMEM) rad_error("%s: out of memory reading %zu rows", errors_path, n);
    if (status != RAD_OK) goto done;
    for (size_t i = matrix->row_begin; i < matrix->row_end; i++)
        if (!isfinite(row_error[i])) {
            rad_error("%s: row %zu: a standard error is not finite", errors_path, i);
            status = RAD_ERR_INVALID;
            goto done;
        }
    free(matrix->row_error);
    matrix->row_error = row_error;
    row_error = NULL;
done:
    free(row_error);
    rad_ff_close(errors);
    return status;
}

/* How far row i sums beyond the rule (> 0: warn). */
static double row_sum_excess(const solve_matrix *matrix, size_t i)
{
    if (!matrix->row_error) return matrix->row_sum[i] - SOLVE_ROW_SUM_WARN;
    return matrix->row_sum[i] - 1 - (SOLVE_ROW_SUM_SIGMAS * matrix->row_error[i] + SOLVE_ROW_SUM_SLACK);
}

solve_row_sum_summary solve_matrix_warn_row_sums(const solve_matrix *matrix, const char *path)
{
    solve_row_sum_summary s = {.with_errors = matrix->row_error != NULL};
    size_t worst = 0;
    double worst_excess = 0;
    for (size_t i = 0; i < matrix->patch_count; i++) {
        if (i == 0 || matrix->row_sum[i] > s.max) {
            s.max = matrix->row_sum[i];
            s.max_row = i;
        }
        double excess = row_sum_excess(matrix, i);
        if (excess > 0) {
            if (s.warned == 0 || excess > worst_excess) {
                worst = i;
                worst_excess = excess;
            }
            s.warned++;
        }
    }
    if (s.warned && s.with_errors) {
        const double sigma = matrix->row_error[worst];
        rad_warn("%s: %zu rows sum to more than 1 beyond %g standard errors + %g, where noise alone would put "
                 "about %.1f of %zu rows (worst: row %zu sums to %.9g, standard error of the sum %.3g): the form "
                 "factors may be biased there; solving anyway",
                 path, s.warned, SOLVE_ROW_SUM_SIGMAS, SOLVE_ROW_SUM_SLACK,
                 SOLVE_ROW_SUM_CHANCE * (double)matrix->patch_count, matrix->patch_count, worst,
                 matrix->row_sum[worst], sigma);
    } else if (s.warned && s.max <= SOLVE_ROW_SUM_NOISE) {
        rad_info("%s: %zu rows sum to more than %g (largest: row %zu, %.9g): the Monte Carlo noise of the form "
                 "factors, below %g, which does not show in a picture",
                 path, s.warned, SOLVE_ROW_SUM_WARN, s.max_row, s.max, SOLVE_ROW_SUM_NOISE);
    } else if (s.warned) {
        rad_warn("%s: %zu rows sum to more than %g, which exact form factors do not (largest: row %zu, %.9g, over "
                 "%g): those patches reflect light that was never sent. More formfactor --shadow-rays (or "
                 "--samples with --estimator mc) lowers noise; formfactor --errors FILE, passed to solve as "
                 "--errors, tells noise from bias; solving anyway",
                 path, s.warned, SOLVE_ROW_SUM_WARN, s.max_row, s.max, SOLVE_ROW_SUM_NOISE);
    }
    return s;
}

/* Row i's largest reflectance over the channels, and which channel. */
static double row_rho(const rad_patch *p, int *out_channel)
{
    int c = 0;
    for (int k = 1; k < 3; k++)
        if (p->rho[k] > p->rho[c]) c = k;
    *out_channel = c;
    return p->rho[c];
}

/* Inserts row i into worst[] (at most SOLVE_WORST_ROWS_SHOWN rows, by
 * product, largest first). */
static void keep_worst(size_t *worst, size_t *count, const double *product, size_t i)
{
    size_t k;
    if (*count < SOLVE_WORST_ROWS_SHOWN)
        k = (*count)++;
    else if (product[i] > product[worst[SOLVE_WORST_ROWS_SHOWN - 1]])
        k = SOLVE_WORST_ROWS_SHOWN - 1;
    else
        return;
    for (; k > 0 && product[i] > product[worst[k - 1]]; k--) worst[k] = worst[k - 1];
    worst[k] = i;
}

rad_status solve_matrix_check_reflectance(const solve_matrix *matrix, const rad_mesh *mesh, const char *path)
{
    static const char *const channel_names[3] = {"red", "green", "blue"};
    const size_t n = matrix->patch_count;
    double *product = malloc(n * sizeof(double));
    if (!product) {
        rad_error("%s: out of memory for %zu patches", path, n);
        return RAD_ERR_NOMEM;
    }
    size_t worst[SOLVE_WORST_ROWS_SHOWN], shown = 0, failing = 0;
    for (size_t i = 0; i < n; i++) {
        int c;
        product[i] = row_rho(&mesh->patches[i], &c) * matrix->row_sum[i];
        if (!(product[i] < 1)) {
            failing++;
            keep_worst(worst, &shown, product, i);
        }
    }
    if (failing) {
        char rows[SOLVE_WORST_ROWS_SHOWN * 112] = "";
        size_t used = 0;
        for (size_t k = 0; k < shown && used < sizeof rows; k++) {
            const rad_patch *p = &mesh->patches[worst[k]];
            int c;
            double rho = row_rho(p, &c);
            int grey = p->rho[0] == p->rho[1] && p->rho[0] == p->rho[2];
            used += (size_t)snprintf(rows + used, sizeof rows - used, "%srow %zu (rho %.6g%s%s, row sum %.9g, "
                                     "rho * row sum %.9g)", k ? ", " : "", worst[k], rho, grey ? "" : " ",
                                     grey ? "" : channel_names[c], matrix->row_sum[worst[k]], product[worst[k]]);
        }
        rad_error("%s: %zu of %zu rows have rho * row sum >= 1: those patches would reflect at least all the "
                  "light that reaches them, so no iteration is sure to converge and B would follow the errors of "
                  "F, not the scene; worst: %s. Lower the reflectance (Kd) of those materials, or recompute the "
                  "form factors so that rows sum to 1 (formfactor --estimator quadrature, or a smaller "
                  "--target-error)",
                  path, failing, n, rows);
    }
    free(product);
    return failing ? RAD_ERR_INVALID : RAD_OK;
}

solve_system solve_matrix_system(const solve_matrix *matrix)
{
    solve_system s = {
        .patch_count = matrix->patch_count,
        .form_factors = matrix->form_factors,
        .sparse = matrix->form_factors ? NULL : &matrix->rows,
        .area = matrix->area,
        .row_sum = matrix->row_sum,
        .row_begin = matrix->row_begin,
        .row_end = matrix->row_end,
        .reciprocity_bound = matrix->reciprocity_bound,
    };
    return s;
}
