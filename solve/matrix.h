/* matrix.h - the form-factor matrix as solve needs it: read whole from an
 * open form-factor file, converted to double and validated; optionally the
 * standard errors of its entries (formfactor --errors); and the two checks
 * of the matrix against the patch table that come before any iteration.
 *
 * Validation, row by row, stops at the first offending row and names the
 * file, the row and the entry:
 *   - every F_ij finite;
 *   - F_ij >= -SOLVE_NEGATIVE_TOLERANCE (a sign flip of a zero entry in
 *     the last bits is rounding; anything below is an error);
 *   - sum_j F_ij <= SOLVE_ROW_SUM_LIMIT (a closed scene sums to 1). The
 *     limit is loose on purpose: with point-pair sampling (512 pairs) rows
 *     of patches at shared edges and corners, where the kernel is singular,
 *     reach 1.3 at --subdiv 3 (measured on the Cornell box). Above 1.5 a
 *     row is not noise but a broken matrix.
 *
 * Row sums above 1 that the matrix's accuracy does not explain get one
 * warning (solve_matrix_warn_row_sums; docs/solve.md, "Row sums"). Rows
 * that reflect at least what they receive, rho_i * sum_j F_ij >= 1 in some
 * channel, are refused (solve_matrix_check_reflectance): no iteration
 * converges to a meaningful B there.
 */
#ifndef SOLVE_MATRIX_H
#define SOLVE_MATRIX_H

#include <stddef.h>
#include <stdint.h>

#include "rad_ffile.h"
#include "rad_status.h"
#include "solver.h"

#define SOLVE_NEGATIVE_TOLERANCE 1e-12
#define SOLVE_ROW_SUM_LIMIT 1.5
/* Without an errors file a row is warned about above 1 + 1e-3: more than
 * exact form factors leave. An exact matrix (analytic fixtures; the
 * quadrature estimator where nothing occludes) is closed to ~1e-7 and
 * float32 storage moves a row sum by at most 2^-24 of itself (6e-8), so
 * 1e-3 never fires on one; 1e-3 is also the excess at which a rho = 0.999
 * material starts to reflect more than it receives. Monte Carlo noise
 * (point pairs, shadow rays) exceeds it routinely; only the errors file
 * tells that noise from bias (docs/solve.md, "Row sums"). */
#define SOLVE_ROW_SUM_WARN 1.001
/* ...said as a note (info), not a warning, while no row passes this:
 * formfactor's defaults leave curved Blender meshes' rows up to ~1.03
 * (the corpus room with a UV sphere: 1.031), light that nobody can see
 * and no flag needs to remove; beyond it the warning names the settings
 * that lower it (issue 30). */
#define SOLVE_ROW_SUM_NOISE 1.05
/* With an errors file (sigma_ij per entry), row i is warned about when
 *   sum_j F_ij - 1 > SOLVE_ROW_SUM_SIGMAS * sqrt(sum_j sigma_ij^2)
 *                    + SOLVE_ROW_SUM_SLACK,
 * i.e. beyond three standard errors of its Monte Carlo noise (entries
 * treated as independent) plus what an exact estimator and float32
 * storage leave (1e-7 and 6e-8). */
#define SOLVE_ROW_SUM_SIGMAS 3.0
#define SOLVE_ROW_SUM_SLACK 1e-6
/* The share of rows that unbiased Gaussian noise puts beyond 3 standard
 * errors (one-sided), said in the warning: with thousands of rows a few
 * are expected. */
#define SOLVE_ROW_SUM_CHANCE 0.00135
/* Splitting rows over ranks (solve_matrix_split_rows), a row costs the
 * bytes of its stored record plus this many: the vector work of a row
 * (residual, update, CG's vector operations) is the same for every row,
 * about as much as a few dozen stored entries. */
#define SOLVE_SPLIT_ROW_BYTES 64.0
/* How many of the worst rows a refusal names. */
#define SOLVE_WORST_ROWS_SHOWN 3

typedef struct solve_matrix {
    size_t patch_count;
    size_t row_begin, row_end; /* the rows held (all N when alone; docs/solve.md, "Across ranks") */
    double *form_factors; /* held rows x N, row-major; NULL when read from a sparse file */
    /* A sparse file's stored tiles, kept as stored (rows.h); `rows` views
     * them (or form_factors), and solve_matrix_system hands it on. */
    uint64_t *row_tiles;
    uint32_t *tile_column;
    uint64_t *tile_value;
    double *values;
    size_t tile_count, tile_cap, value_count, value_cap;
    solve_rows rows;
    double *area;         /* N, from the patch table */
    double *row_sum;      /* N; the held rows' after loading (others 0 until gathered, stage.c) */
    double *row_error;    /* N: sqrt(sum_j sigma_ij^2), the held rows' (others 0 until gathered);
                             NULL until solve_matrix_load_errors */
    double reciprocity_bound; /* solve_system.reciprocity_bound, from the file's header */
    /* solve_matrix_begin's arrays: reserved address space (rad_mem_reserve),
     * these many bytes each; 0 where malloc'd */
    size_t values_reserved, tiles_reserved;
    size_t appended;      /* solve_matrix_append: rows so far */
    uint32_t element_type; /* solve_matrix_begin: the records' element (rad_element_type) */
} solve_matrix;

/* A matrix built from its records as they are computed, never written
 * (formfactor --radiosity): begin with the rows [row_begin, row_end) this
 * rank will hold, then append them in order, a block of records at a time
 * (any thread; the decoding runs on the OpenMP threads), then end. Each
 * row is decoded and checked as solve_matrix_load checks a file's (`name`
 * stands for the file in messages). The entries' room is reserved, not
 * committed (rad_mem.h): only what the records hold is touched. */
rad_status solve_matrix_begin(const rad_ff_info *info, const rad_mesh *mesh, size_t row_begin, size_t row_end,
                              solve_matrix *out_matrix);
/* Rows [row, row + rows): record k is `at[k + 1] - at[k]` bytes at
 * records + at[k] - at[0]; row must be the next row not yet appended. */
rad_status solve_matrix_append(solve_matrix *matrix, const char *name, size_t row, size_t rows,
                               const unsigned char *records, const uint64_t *at);
/* Every row appended? Then the matrix is ready (as from solve_matrix_load). */
rad_status solve_matrix_end(solve_matrix *matrix, const char *name);

/* For a file whose header says it is reciprocal by construction
 * (RAD_FF_FLAG_RECIPROCAL, set by formfactor): the bound b with
 * |A_i F_ij - A_j F_ji| <= b A_i F_ij for every entry, from the rounding of
 * the products and of the stored element type; 0 for other files (the
 * skew term is then measured). */
double solve_reciprocity_bound(const rad_ff_info *info);

/* Splits the rows of `file` into `parts` contiguous blocks of about equal
 * cost (a sparse row: its record's bytes, i.e. its stored entries, plus
 * SOLVE_SPLIT_ROW_BYTES; dense rows all cost the same), from the file's
 * row index alone: row_begin[0..parts], row_begin[0] = 0,
 * row_begin[parts] = N. A block may be empty (more parts than rows). */
void solve_matrix_split_rows(const rad_ff_file *file, size_t parts, size_t *row_begin);

/* Reads rows [row_begin, row_end) of `file` (opened from `path`, used in
 * messages; row_end SIZE_MAX: to the last; an empty block, [0, 0)
 * included, reads none), and nothing else of the matrix: a
 * dense file into form_factors, a sparse one (version 3) as its tiles.
 * *out_matrix is set only on success; free with solve_matrix_free. */
rad_status solve_matrix_load(rad_ff_file *file, const char *path, size_t row_begin, size_t row_end,
                             solve_matrix *out_matrix);
void solve_matrix_free(solve_matrix *matrix); /* safe on zeroed */

/* Reads the standard-error file `errors_path` (formfactor --errors: flag
 * RAD_FF_FLAG_STANDARD_ERRORS, float32) into matrix->row_error: the held
 * rows' only. It must
 * belong to `file` (the matrix, opened from `path`): same patch table and
 * the same header but for element type and that flag. Errors name the
 * file; on failure matrix->row_error stays NULL. */
rad_status solve_matrix_load_errors(solve_matrix *matrix, const rad_ff_file *file, const char *path,
                                    const char *errors_path);

/* What solve_matrix_warn_row_sums found (also for the stats file). */
typedef struct solve_row_sum_summary {
    double max;        /* largest row sum */
    size_t max_row;
    size_t warned;     /* rows beyond the rule (SOLVE_ROW_SUM_WARN or the errors) */
    int with_errors;   /* the rule used the errors file */
} solve_row_sum_summary;

/* Logs one warning when some rows sum to more than 1 beyond what the
 * matrix's accuracy explains (the rules above); returns the summary. */
solve_row_sum_summary solve_matrix_warn_row_sums(const solve_matrix *matrix, const char *path);

/* Refuses (RAD_ERR_INVALID, one error naming the row count, the worst
 * rows with rho, row sum and their product, and the remedy) a matrix
 * where rho_i^c * sum_j F_ij >= 1 for some row i and channel c. */
rad_status solve_matrix_check_reflectance(const solve_matrix *matrix, const rad_mesh *mesh, const char *path);

/* The solver's view of the matrix (borrows its arrays). */
solve_system solve_matrix_system(const solve_matrix *matrix);

#endif
