/* test_solve_truth.c - solve tells the truth (issue 13, item 5):
 *
 *  - with exact form factors a closed scene is SPD, auto picks CG, and CG
 *    converges at rho = 0.5 ... 0.999 in a bounded number of iterations
 *    (TRUTH_CG_BUDGET, far below the issue's 1,000), furnace error <= 2 tol;
 *    the same with form factors off by 1e-7 (the quadrature estimator's
 *    accuracy), reciprocal or not;
 *  - a matrix with rho * row sum >= 1 is refused before any iteration,
 *    with the count, the worst rows and the remedy, and nothing is written;
 *  - the reason CG is not used is the real one: no diagonal-dominance
 *    margin, or not reciprocal enough, each said as such;
 *  - row sums above 1 are warned about only beyond the matrix's accuracy:
 *    1.001 without an errors file, 3 standard errors + 1e-6 with one;
 *    an errors file of another matrix is refused;
 *  - the energy balance (emitted = absorbed + escaped) in the report, the
 *    stats file and on stderr.
 *
 * usage: test_solve_truth [DIR]      DIR receives the files (default: a new
 *                                    directory under /tmp)
 *        test_solve_truth furnace-check FILE.rad RHO REL_TOL MAX_ITERATIONS
 *            checks a solved furnace (every patch and channel E = 1, rho
 *            RHO): B = 1/(1 - RHO) within REL_TOL, converged, solved by CG
 *            in at most MAX_ITERATIONS (tests/furnace.sh).
 */
#define _POSIX_C_SOURCE 200809L
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "iterate.h"
#include "rad_clock.h"
#include "matrix.h"
#include "rad_fs.h"
#include "rad_rfile.h"
#include "rad_test.h"
#include "solver.h"
#include "stage.h"
#include "test_solve_fixtures.h"

#define TRUTH_TOL SOLVE_DEFAULT_TOLERANCE
/* CG iterations allowed on the closed scenes below at any rho up to 0.999
 * (measured at most 23, docs/solve.md "CG as rho -> 1"); the issue's
 * target is 1,000 and the textbook bound for a condition number
 * (1 + rho)/(1 - rho) = 1999 is sqrt(1999)/2 ln(2/tol) ~ 530. */
#define TRUTH_CG_BUDGET 40
/* Relative error the quadrature estimator leaves in F (issue 13). */
#define TRUTH_QUADRATURE_ERROR 1e-7
/* The closed unit cube's exact form factors (Howell C-11 and C-14). */
#define CUBE_F_OPPOSITE 0.19982489569838738
#define CUBE_F_ADJACENT 0.20004377607540315

static const double truth_rho[4] = {0.5, 0.9, 0.99, 0.999};
static char g_dir[1024];

static const char *path_in_dir(const char *name) { return solve_fx_path(g_dir, name); }

static int file_exists(const char *path)
{
    struct stat sb;
    return stat(path, &sb) == 0;
}

/* Solves channel 0 of a fixture in memory with `method`. */
static rad_status fx_solve(const solve_fx_scene *s, solve_method method, double *B, solve_report *rep)
{
    size_t n = s->mesh.patch_count;
    double *rho = malloc(n * sizeof(double)), *E = malloc(n * sizeof(double));
    for (size_t i = 0; i < n; i++) {
        rho[i] = s->mesh.patches[i].rho[0];
        E[i] = s->mesh.patches[i].emission[0];
    }
    solve_params p = {.method = method, .tolerance = TRUTH_TOL, .progress_seconds = -1};
    solve_system sys = {.patch_count = n, .form_factors = s->F, .area = s->area, .row_sum = s->row_sum};
    rad_status st = solve_channel(&sys, rho, E, &p, B, rep);
    free(rho);
    free(E);
    return st;
}

static void set_rho(solve_fx_scene *s, double rho)
{
    for (size_t i = 0; i < s->mesh.patch_count; i++)
        for (int c = 0; c < 3; c++) s->mesh.patches[i].rho[c] = rho;
}

/* Largest |B_i - B*_i| against the dense direct solve of channel 0. */
static double direct_error(const solve_fx_scene *s, const double *B, double *out_b_max)
{
    size_t n = s->mesh.patch_count;
    double *rho = malloc(n * sizeof(double)), *E = malloc(n * sizeof(double)), *x = malloc(n * sizeof(double));
    double err = INFINITY;
    *out_b_max = 0;
    for (size_t i = 0; rho && E && i < n; i++) {
        rho[i] = s->mesh.patches[i].rho[0];
        E[i] = s->mesh.patches[i].emission[0];
    }
    if (rho && E && x && solve_fx_direct(n, s->F, rho, E, x)) {
        err = 0;
        for (size_t i = 0; i < n; i++) {
            err = fmax(err, fabs(B[i] - x[i]));
            *out_b_max = fmax(*out_b_max, fabs(x[i]));
        }
    }
    free(rho);
    free(E);
    free(x);
    return err;
}

/* Deterministic numbers in [-1, 1] (xorshift64). */
static double noise(uint64_t *state)
{
    *state ^= *state << 13;
    *state ^= *state >> 7;
    *state ^= *state << 17;
    return (double)(*state >> 11) / (double)(1ull << 52) - 1;
}

/* Multiplies every F_ij by (1 + eps u_ij), u in [-1, 1]: independently per
 * entry (not reciprocal), or the same for F_ij and F_ji (reciprocal). */
static void perturb(solve_fx_scene *s, double eps, int reciprocal, uint64_t seed)
{
    size_t n = s->mesh.patch_count;
    uint64_t state = seed;
    for (size_t i = 0; i < n; i++)
        for (size_t j = reciprocal ? i : 0; j < n; j++) {
            double f = 1 + eps * noise(&state);
            s->F[i * n + j] *= f;
            if (reciprocal && j != i) s->F[j * n + i] *= f;
        }
    for (size_t i = 0; i < n; i++) {
        double sum = 0;
        for (size_t j = 0; j < n; j++) sum += s->F[i * n + j];
        s->row_sum[i] = sum;
    }
}

/* ---- the closed unit cube, one patch per face: exact F ---- */
static void test_cube_form_factors(void)
{
    solve_fx_box_spec spec = {.cells = 1, .light_face = -1, .open_face = -1};
    solve_fx_scene cube;
    RAD_CHECK(solve_fx_box(&spec, &cube));
    for (size_t i = 0; i < 6; i++) {
        for (size_t j = 0; j < 6; j++) {
            double expected = i == j ? 0 : (i ^ 1) == j ? CUBE_F_OPPOSITE : CUBE_F_ADJACENT;
            RAD_CHECK_NEAR(cube.F[i * 6 + j], expected, 2e-15);
        }
        RAD_CHECK_NEAR(cube.row_sum[i], 1, 1e-15);
    }
    solve_fx_free(&cube);
}

/* One CG case: auto must pick CG, converge within the budget, and agree
 * with the direct solve within the report's error bound. */
static uint32_t cg_case(const char *name, solve_fx_scene *s, double rho, double furnace_tol)
{
    size_t n = s->mesh.patch_count;
    double *B = malloc(n * sizeof(double));
    solve_report rep;
    rad_status st = fx_solve(s, SOLVE_AUTO, B, &rep);
    RAD_CHECK(st == RAD_OK);
    if (st != RAD_OK) {
        free(B);
        return UINT32_MAX;
    }
    double b_max, err = direct_error(s, B, &b_max);
    double furnace_err = 0;
    for (size_t i = 0; furnace_tol > 0 && i < n; i++) furnace_err = fmax(furnace_err, fabs(B[i] * (1 - rho) - 1));
    printf("%-34s rho=%-5g %zu patches: %-3s %3u iterations, delta/m %.1e, margin %.2e, |B - direct| %.1e "
           "(bound %.1e)",
           name, rho, n, solve_method_name(rep.method_used), rep.iterations, rep.reciprocity, rep.margin, err,
           rep.error_bound);
    if (furnace_tol > 0) printf(", furnace rel. error %.1e", furnace_err);
    printf("\n");
    RAD_CHECK(rep.method_used == SOLVE_CG && !rep.fell_back && rep.converged);
    RAD_CHECK(rep.reciprocity >= 0 && rep.reciprocity <= SOLVE_CG_RECIPROCITY && rep.margin > 0);
    RAD_CHECK(rep.iterations <= TRUTH_CG_BUDGET);
    RAD_CHECK(err <= rep.error_bound + 1e-12 * b_max);
    if (furnace_tol > 0) RAD_CHECK(furnace_err <= furnace_tol);
    uint32_t it = rep.iterations;
    solve_report_free(&rep);
    free(B);
    return it;
}

static void test_cg_exact(void)
{
    solve_fx_box_spec furnace = {.cells = 1, .light_face = -1, .open_face = -1};
    solve_fx_box_spec lit = {.cells = 1, .light_face = 5, .light_emission = {1, 1, 1}, .open_face = -1};
    solve_fx_box_spec lit_graded = {.cells = 8, .light_face = 5, .light_emission = {1, 1, 1}, .open_face = -1};
    solve_fx_scene cube, lit_cube, graded;
    RAD_CHECK(solve_fx_box(&furnace, &cube) && solve_fx_box(&lit, &lit_cube) && solve_fx_box(&lit_graded, &graded));
    for (int r = 0; r < 4; r++) {
        double rho = truth_rho[r];
        solve_fx_set_uniform(&cube, rho, 1.0);
        cg_case("cube furnace (6 patches, exact)", &cube, rho, 2 * TRUTH_TOL);
        set_rho(&lit_cube, rho);
        cg_case("cube, top face emits (exact)", &lit_cube, rho, 0);
        set_rho(&graded, rho);
        cg_case("graded box 8x8, ceiling light", &graded, rho, 0);
    }
    solve_fx_free(&cube);
    solve_fx_free(&lit_cube);
    solve_fx_free(&graded);
}

/* Form factors off by up to 1e-7 relative: rows sum to 1 +- 1e-7. The
 * furnace is then off by at most rho 1e-7 / (1 - rho) (1e-4 at 0.999),
 * inside the issue's limits 1e-5 / 1e-4 / 1e-3 / 1e-3. */
static void test_cg_quadrature_accuracy(void)
{
    static const double issue_limit[4] = {1e-5, 1e-4, 1e-3, 1e-3};
    for (int reciprocal = 0; reciprocal < 2; reciprocal++) {
        solve_fx_box_spec spec = {.cells = 4, .light_face = -1, .open_face = -1};
        solve_fx_scene box;
        RAD_CHECK(solve_fx_box(&spec, &box));
        perturb(&box, TRUTH_QUADRATURE_ERROR, reciprocal, 42);
        for (int r = 0; r < 4; r++) {
            solve_fx_set_uniform(&box, truth_rho[r], 1.0);
            double limit = truth_rho[r] * 2 * TRUTH_QUADRATURE_ERROR / (1 - truth_rho[r]);
            RAD_CHECK(limit <= issue_limit[r]);
            cg_case(reciprocal ? "furnace 4x4, F +-1e-7 reciprocal" : "furnace 4x4, F +-1e-7 one-sided", &box,
                    truth_rho[r], limit);
        }
        solve_fx_free(&box);
    }
}

/* ---- rho * row sum >= 1: refused before iterating ---- */
static void test_refusal(void)
{
    solve_fx_box_spec spec = {.cells = 2, .light_face = -1, .open_face = -1};
    solve_fx_scene s;
    RAD_CHECK(solve_fx_box(&spec, &s));
    size_t n = s.mesh.patch_count;
    solve_fx_set_uniform(&s, 0.999, 1.0);
    /* Monte Carlo-like rows: 1 +- 1 % (rows 3 and 17 the worst) */
    perturb(&s, 0.01, 1, 7);
    for (size_t j = 0; j < n; j++) s.F[3 * n + j] *= 1.02, s.F[17 * n + j] *= 1.015;
    s.row_sum[3] *= 1.02;
    s.row_sum[17] *= 1.015;
    size_t failing = 0;
    for (size_t i = 0; i < n; i++) failing += 0.999 * s.row_sum[i] >= 1;
    RAD_CHECK(failing >= 2);
    RAD_CHECK(solve_fx_write(path_in_dir("refused.ff"), &s, RAD_ELEMENT_F64) == RAD_OK);

    rad_test_capture_log();
    solve_options opt = {.input = path_in_dir("refused.ff"), .output = path_in_dir("refused.rad"),
                         .stats = path_in_dir("refused.json")};
    double t0 = rad_clock_seconds();
    RAD_CHECK(solve_stage_run(&opt) == RAD_ERR_INVALID);
    double seconds = rad_clock_seconds() - t0;
    char count[64];
    snprintf(count, sizeof count, "%zu of %zu rows have rho * row sum >= 1", failing, n);
    RAD_CHECK(rad_test_log_contains(count));
    RAD_CHECK(rad_test_log_contains("worst: row 3 (rho 0.999, row sum "));
    RAD_CHECK(rad_test_log_contains("row 17 (rho 0.999"));
    RAD_CHECK(rad_test_log_contains("Lower the reflectance") && rad_test_log_contains("--estimator quadrature") &&
              rad_test_log_contains("--target-error"));
    RAD_CHECK(!rad_test_log_contains("residual")); /* refused before any iteration */
    rad_log_set_sink(NULL, NULL);
    RAD_CHECK(!file_exists(opt.output) && !file_exists(opt.stats));
    printf("refused %zu of %zu rows with rho * row sum >= 1 in %.3f s, nothing written\n", failing, n, seconds);

    /* coloured: the channel that fails is named */
    for (size_t i = 0; i < n; i++) s.mesh.patches[i].rho[0] = s.mesh.patches[i].rho[2] = 0.5;
    RAD_CHECK(solve_fx_write(path_in_dir("refused_green.ff"), &s, RAD_ELEMENT_F64) == RAD_OK);
    rad_test_capture_log();
    opt = (solve_options){.input = path_in_dir("refused_green.ff"), .output = path_in_dir("refused_green.rad")};
    RAD_CHECK(solve_stage_run(&opt) == RAD_ERR_INVALID);
    RAD_CHECK(rad_test_log_contains("worst: row 3 (rho 0.999 green, row sum"));
    rad_log_set_sink(NULL, NULL);
    RAD_CHECK(!file_exists(opt.output));

    /* the library refuses too, before iterating */
    double *B = malloc(n * sizeof(double));
    solve_report rep;
    memset(&rep, 0, sizeof rep);
    solve_fx_set_uniform(&s, 0.999, 1.0);
    rad_test_capture_log();
    RAD_CHECK(fx_solve(&s, SOLVE_GAUSS_SEIDEL, B, &rep) == RAD_ERR_INVALID);
    RAD_CHECK(rad_test_log_contains("row 3: rho * row sum = "));
    rad_log_set_sink(NULL, NULL);
    RAD_CHECK(rep.history == NULL && rep.iterations == 0);
    free(B);
    solve_fx_free(&s);
}

/* ---- why CG is not used, in words ---- */
static void test_cg_reasons(void)
{
    /* not reciprocal: row 5 scaled by 0.7 (as test_solve's fallback) */
    solve_fx_box_spec spec = {.cells = 3, .light_face = -1, .open_face = -1};
    solve_fx_scene s;
    RAD_CHECK(solve_fx_box(&spec, &s));
    solve_fx_set_uniform(&s, 0.9, 1.0);
    size_t n = s.mesh.patch_count;
    for (size_t j = 0; j < n; j++) s.F[5 * n + j] *= 0.7;
    s.row_sum[5] *= 0.7;
    double *B = malloc(n * sizeof(double));
    solve_report rep;
    rad_test_capture_log();
    RAD_CHECK(fx_solve(&s, SOLVE_CG, B, &rep) == RAD_OK);
    RAD_CHECK(rad_test_log_contains("matrix not reciprocal enough for CG: row 5 has delta_i/m_i = "));
    RAD_CHECK(rad_test_log_contains("against margin m_i = 1/rho_i - sum_j F_ij ="));
    RAD_CHECK(!rad_test_log_contains("no diagonal-dominance margin"));
    rad_log_set_sink(NULL, NULL);
    RAD_CHECK(rep.fell_back && rep.method_used == SOLVE_GAUSS_SEIDEL && isfinite(rep.reciprocity) &&
              rep.reciprocity > SOLVE_CG_RECIPROCITY && rep.margin > 0);
    printf("CG refused, not reciprocal: %s\n", rep.fallback_reason);
    solve_report_free(&rep);

    /* no margin: rho_i * (row sum over reflecting columns) >= 1 on one row,
     * perfectly reciprocal. solve_channel refuses such a system before the
     * check, so the check is called directly. */
    double rho[2] = {0.9, 0.9}, area[2] = {1, 1}, F[4] = {0, 1.2, 1.2, 0}, work[2];
    solve_run run = {.n = 2, .F = {.n = 2, .dense = F}, .area = area, .rho = rho, .work = work};
    solve_cg_check check = solve_cg_check_matrix(&run);
    RAD_CHECK(check.no_margin_count == 2 && check.margin < 0 && !solve_cg_check_passes(&check));
    char why[320];
    solve_cg_check_describe(&check, why, sizeof why);
    printf("CG refused, no margin: %s\n", why);
    RAD_CHECK(strstr(why, "no diagonal-dominance margin for CG: 2 rows") && !strstr(why, "reciprocal"));
    /* the reciprocal, dominant case passes with delta = 0 */
    F[1] = F[2] = 0.5;
    check = solve_cg_check_matrix(&run);
    RAD_CHECK(solve_cg_check_passes(&check) && check.ratio == 0 && fabs(check.margin - (1 / 0.9 - 0.5)) < 1e-15);
    free(B);
    solve_fx_free(&s);
}

/* ---- row-sum warnings: beyond the matrix's accuracy only ---- */

/* The standard-error file of solve_fx_write's matrix: sigma holds N * N
 * values; `seed` other than 0 makes it belong to another run. */
static rad_status write_errors(const char *path, const solve_fx_scene *s, const double *sigma, uint64_t seed)
{
    rad_ff_info info;
    memset(&info, 0, sizeof info);
    info.patch_count = s->mesh.patch_count;
    info.vertex_count = s->mesh.vertex_count;
    info.element_type = RAD_ELEMENT_F32;
    info.estimator = RAD_ESTIMATOR_MC;
    info.scene_fingerprint = 0x5eed;
    info.seed = seed;
    info.flags = RAD_FF_FLAG_STANDARD_ERRORS;
    strcpy(info.scene_name, "test_solve fixture");
    return rad_ff_write_serial(path, &info, &s->mesh, sigma);
}

/* Runs the stage on `input` (with `errors` if not NULL); returns its status
 * and leaves the log captured for the caller to inspect. */
static rad_status run_captured(const char *input, const char *errors, const char *stats)
{
    rad_test_capture_log();
    solve_options opt = {.input = path_in_dir(input), .output = path_in_dir("warn.rad"),
                         .errors = errors ? path_in_dir(errors) : NULL, .stats = stats ? path_in_dir(stats) : NULL};
    return solve_stage_run(&opt);
}

static void test_row_sum_warnings(void)
{
    solve_fx_box_spec spec = {.cells = 2, .light_face = -1, .open_face = -1};
    solve_fx_scene s;
    RAD_CHECK(solve_fx_box(&spec, &s));
    solve_fx_set_uniform(&s, 0.5, 1.0);
    size_t n = s.mesh.patch_count;
    double *sigma = calloc(n * n, sizeof(double));

    /* exact, stored as float32 (rows move by <= 6e-8): no warning, with or
     * without an all-zero errors file */
    RAD_CHECK(solve_fx_write(path_in_dir("exact_f32.ff"), &s, RAD_ELEMENT_F32) == RAD_OK);
    RAD_CHECK(write_errors(path_in_dir("exact_f32.err"), &s, sigma, 0) == RAD_OK);
    RAD_CHECK(run_captured("exact_f32.ff", NULL, NULL) == RAD_OK && !rad_test_log_contains("rows sum to more"));
    RAD_CHECK(run_captured("exact_f32.ff", "exact_f32.err", "exact.json") == RAD_OK &&
              !rad_test_log_contains("rows sum to more"));
    rad_log_set_sink(NULL, NULL);
    char *json = NULL;
    size_t size = 0;
    RAD_CHECK(rad_fs_read_all(path_in_dir("exact.json"), &json, &size) == RAD_OK);
    RAD_CHECK(json && strstr(json, "\"warned\": 0, \"rule\": \"errors\"") && strstr(json, "exact_f32.err"));
    free(json);

    /* row 2 at 1.0005 (inside 1.001), row 5 at 1.002: fixed rule warns row 5 only */
    for (size_t j = 0; j < n; j++) s.F[2 * n + j] *= 1.0005, s.F[5 * n + j] *= 1.002;
    RAD_CHECK(solve_fx_write(path_in_dir("rows.ff"), &s, RAD_ELEMENT_F64) == RAD_OK);
    rad_log_set_level(RAD_LOG_INFO); /* below 1.05 it is a note */
    RAD_CHECK(run_captured("rows.ff", NULL, NULL) == RAD_OK);
    rad_log_set_level(RAD_LOG_WARN);
    RAD_CHECK(rad_test_log_contains("1 rows sum to more than 1.001 (largest: row 5, 1.002"));
    RAD_CHECK(rad_test_log_contains("the Monte Carlo noise of the form factors, below 1.05"));
    RAD_CHECK(!rad_test_log_contains("which exact form factors do not"));
    rad_log_set_sink(NULL, NULL);

    /* row 5 at 1.06: beyond noise that does not show, a warning with the remedy */
    for (size_t j = 0; j < n; j++) s.F[5 * n + j] *= 1.06 / 1.002;
    RAD_CHECK(solve_fx_write(path_in_dir("rows_high.ff"), &s, RAD_ELEMENT_F64) == RAD_OK);
    RAD_CHECK(run_captured("rows_high.ff", NULL, NULL) == RAD_OK);
    RAD_CHECK(rad_test_log_contains("1 rows sum to more than 1.001, which exact form factors do not (largest: row 5, 1.06"));
    RAD_CHECK(rad_test_log_contains("More formfactor --shadow-rays"));
    for (size_t j = 0; j < n; j++) s.F[5 * n + j] *= 1.002 / 1.06;
    rad_log_set_sink(NULL, NULL);

    /* with errors: row 5's noise (sigma 1e-3 on 4 entries: 3 sqrt(4e-6) =
     * 6e-3) explains its 2e-3; row 2's (zero) does not explain 5e-4 */
    for (size_t j = 0; j < 4; j++) sigma[5 * n + j + 8] = 1e-3;
    RAD_CHECK(write_errors(path_in_dir("rows.err"), &s, sigma, 0) == RAD_OK);
    RAD_CHECK(run_captured("rows.ff", "rows.err", NULL) == RAD_OK);
    RAD_CHECK(rad_test_log_contains("1 rows sum to more than 1 beyond 3 standard errors + 1e-06, where noise alone "
                                    "would put about 0.0 of 24 rows (worst: row 2 sums to 1.0005"));
    RAD_CHECK(!rad_test_log_contains("row 5"));
    rad_log_set_sink(NULL, NULL);

    /* another run's errors, or a matrix given as the errors: refused */
    RAD_CHECK(write_errors(path_in_dir("other.err"), &s, sigma, 99) == RAD_OK);
    RAD_CHECK(run_captured("rows.ff", "other.err", NULL) == RAD_ERR_INVALID);
    RAD_CHECK(rad_test_log_contains("other.err: not the standard errors of") &&
              rad_test_log_contains("different formfactor settings"));
    RAD_CHECK(run_captured("rows.ff", "rows.ff", NULL) == RAD_ERR_INVALID);
    RAD_CHECK(rad_test_log_contains("it holds form factors, not their standard errors"));
    RAD_CHECK(run_captured("rows.ff", "missing.err", NULL) == RAD_ERR_IO);
    RAD_CHECK(rad_test_log_contains("missing.err"));
    rad_log_set_sink(NULL, NULL);
    free(sigma);
    solve_fx_free(&s);
}

/* ---- energy balance: report, stats file, stderr ---- */
static void test_energy_balance(void)
{
    /* an open box with a black light and coloured walls */
    solve_fx_box_spec spec = {.cells = 4, .light_face = 5, .light_emission = {17, 12, 4}, .open_face = 2};
    for (int f = 0; f < 6; f++)
        for (int c = 0; c < 3; c++) spec.rho[f][c] = f == 0 ? (c == 0 ? 0.63 : 0.06) : 0.72;
    solve_fx_scene s;
    RAD_CHECK(solve_fx_box(&spec, &s));
    size_t n = s.mesh.patch_count;
    double *B = malloc(n * sizeof(double));
    solve_report rep;
    RAD_CHECK(fx_solve(&s, SOLVE_AUTO, B, &rep) == RAD_OK);
    double emitted = 0, absorbed = 0, escaped = 0;
    for (size_t i = 0; i < n; i++) {
        double H = 0;
        for (size_t j = 0; j < n; j++) H += s.F[i * n + j] * B[j];
        emitted += s.area[i] * s.mesh.patches[i].emission[0];
        absorbed += s.area[i] * (1 - s.mesh.patches[i].rho[0]) * H;
        escaped += s.area[i] * B[i] * (1 - s.row_sum[i]);
    }
    const solve_balance *b = &rep.balance;
    printf("open box red: emitted %.9g, absorbed %.9g, escaped %.9g, imbalance %.1e\n", b->emitted, b->absorbed,
           b->escaped, b->imbalance);
    RAD_CHECK_REL(b->emitted, emitted, 1e-15);
    RAD_CHECK_REL(b->absorbed, absorbed, 1e-12);
    RAD_CHECK_REL(b->escaped, escaped, 1e-12);
    RAD_CHECK(b->escaped > 0.1 * b->emitted && b->absorbed > 0.1 * b->emitted);
    /* the imbalance is sum A_i r_i / emitted: at most tol ||E|| A / emitted */
    RAD_CHECK(fabs(b->imbalance) <= 2 * TRUTH_TOL * 17 * 5 / b->emitted + 1e-13);
    solve_report_free(&rep);

    /* closed furnace: nothing escapes, all is absorbed */
    solve_fx_box_spec closed = {.cells = 3, .light_face = -1, .open_face = -1};
    solve_fx_scene furnace;
    RAD_CHECK(solve_fx_box(&closed, &furnace));
    solve_fx_set_uniform(&furnace, 0.999, 1.0);
    RAD_CHECK(fx_solve(&furnace, SOLVE_AUTO, B, &rep) == RAD_OK);
    printf("furnace 0.999: emitted %.9g, absorbed %.9g, escaped %.3g, imbalance %.1e\n", rep.balance.emitted,
           rep.balance.absorbed, rep.balance.escaped, rep.balance.imbalance);
    RAD_CHECK_REL(rep.balance.emitted, 6, 1e-12);
    RAD_CHECK(fabs(rep.balance.escaped) < 1e-8 * rep.balance.emitted);
    RAD_CHECK(fabs(rep.balance.imbalance) < 1e-8);
    solve_report_free(&rep);

    /* through the stage: every channel in the stats file, a line on stderr */
    RAD_CHECK(solve_fx_write(path_in_dir("balance.ff"), &s, RAD_ELEMENT_F64) == RAD_OK);
    rad_log_set_level(RAD_LOG_INFO);
    RAD_CHECK(run_captured("balance.ff", NULL, "balance.json") == RAD_OK);
    RAD_CHECK(rad_test_log_contains("balance.ff: red: energy: emitted ") &&
              rad_test_log_contains("balance.ff: blue: energy: emitted ") && rad_test_log_contains("imbalance"));
    rad_log_set_sink(NULL, NULL);
    rad_log_set_level(RAD_LOG_WARN);
    char *json = NULL;
    size_t size = 0;
    RAD_CHECK(rad_fs_read_all(path_in_dir("balance.json"), &json, &size) == RAD_OK);
    size_t energy = 0;
    for (const char *p = json; p && (p = strstr(p, "\"energy\": {\"emitted\": ")); p++) energy++;
    RAD_CHECK(energy == 3 && strstr(json, "\"absorbed\": ") && strstr(json, "\"escaped\": ") &&
              strstr(json, "\"imbalance\": ") && strstr(json, "\"margin\": "));
    free(json);
    free(B);
    solve_fx_free(&s);
    solve_fx_free(&furnace);
}

/* furnace-check FILE.rad RHO REL_TOL MAX_ITERATIONS [any] (see the top;
 * `any`: whatever method solved it - the solve on links sweeps). */
static int furnace_check(int argc, char **argv)
{
    if (argc != 6 && !(argc == 7 && strcmp(argv[6], "any") == 0)) {
        fprintf(stderr, "usage: test_solve_truth furnace-check FILE.rad RHO REL_TOL MAX_ITERATIONS [any]\n");
        return 2;
    }
    int any_method = argc == 7;
    double rho = atof(argv[3]), tol = atof(argv[4]);
    uint32_t max_it = (uint32_t)atol(argv[5]);
    rad_radiosity r;
    if (rad_rf_read(argv[2], &r) != RAD_OK) return 1;
    double exact = 1 / (1 - rho), worst = 0;
    for (size_t i = 0; i < r.mesh.patch_count; i++)
        for (int c = 0; c < 3; c++) {
            double e = fabs(r.radiosity[3 * i + c] - exact) / exact;
            if (!(e <= worst)) worst = e;
        }
    uint32_t it = 0;
    int cg = 1;
    for (uint32_t c = 0; c < r.channel_count; c++) {
        if (r.iterations[c] > it) it = r.iterations[c];
        cg &= r.channel_method[c] == RAD_SOLVE_CG;
    }
    int ok = r.converged && (cg || any_method) && it <= max_it && worst <= tol;
    printf("%s: rho %g, %zu patches: %s, %u iterations (limit %u), max relative error %.2e (limit %.0e): %s\n",
           argv[2], rho, r.mesh.patch_count, cg ? "cg" : "NOT cg", it, max_it, worst, tol, ok ? "ok" : "FAIL");
    rad_radiosity_free(&r);
    return ok ? 0 : 1;
}

int main(int argc, char **argv)
{
    if (argc > 1 && strcmp(argv[1], "furnace-check") == 0) return furnace_check(argc, argv);
    if (!solve_fx_work_dir(argc, argv, "test_solve_truth", g_dir, sizeof g_dir)) return 1;
    rad_log_set_level(RAD_LOG_WARN);
    test_cube_form_factors();
    test_cg_exact();
    test_cg_quadrature_accuracy();
    test_refusal();
    test_cg_reasons();
    test_row_sum_warnings();
    test_energy_balance();
    return rad_test_finish();
}
