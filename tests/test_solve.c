/* test_solve.c - the solve stage: exact form factors, the furnace identity
 * for every method, agreement of the methods, energy balance of an open
 * box, grey detection, non-convergence, the CG fallback, bad input files
 * and the radiosity file format.
 *
 * usage: test_solve [DIR]   DIR receives the generated files (default: a
 * new directory under /tmp); the CLI tests in CMakeLists.txt reuse them.
 */
#define _POSIX_C_SOURCE 200809L
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "matrix.h"
#include "rad_fs.h"
#include "rad_rfile.h"
#include "rad_test.h"
#include "solver.h"
#include "stage.h"
#include "test_solve_fixtures.h"

static char g_dir[1024];

static const char *path_in_dir(const char *name) { return solve_fx_path(g_dir, name); }

static solve_system fx_system(const solve_fx_scene *s)
{
    solve_system sys = {.patch_count = s->mesh.patch_count, .form_factors = s->F, .area = s->area, .row_sum = s->row_sum};
    return sys;
}

/* Solves channel c of a fixture in memory. */
static rad_status fx_solve(const solve_fx_scene *s, int c, solve_method method, double tol, uint32_t max_iter,
                           double *B, solve_report *rep)
{
    size_t n = s->mesh.patch_count;
    double *rho = malloc(n * sizeof(double)), *E = malloc(n * sizeof(double));
    for (size_t i = 0; i < n; i++) {
        rho[i] = s->mesh.patches[i].rho[c];
        E[i] = s->mesh.patches[i].emission[c];
    }
    solve_params p = {.method = method, .tolerance = tol, .max_iterations = max_iter, .progress_seconds = -1};
    solve_system sys = fx_system(s);
    rad_status st = solve_channel(&sys, rho, E, &p, B, rep);
    free(rho);
    free(E);
    return st;
}

/* ---- the analytic form factors themselves ---- */
static void test_exact_form_factors(void)
{
    rad_vec3 lower[4] = {rad_v3(0, 0, 0), rad_v3(1, 0, 0), rad_v3(1, 1, 0), rad_v3(0, 1, 0)};
    rad_vec3 upper[4] = {rad_v3(0, 0, 1), rad_v3(0, 1, 1), rad_v3(1, 1, 1), rad_v3(1, 0, 1)};
    rad_vec3 wall[4] = {rad_v3(0, 0, 0), rad_v3(0, 1, 0), rad_v3(0, 1, 1), rad_v3(0, 0, 1)};
    RAD_CHECK_NEAR(solve_fx_rect_form_factor_area(lower, upper), 0.199824895698, 1e-11); /* Howell C-11 */
    RAD_CHECK_NEAR(solve_fx_rect_form_factor_area(lower, wall), 0.200043776075, 1e-11); /* Howell C-14 */

    solve_fx_box_spec spec = {.cells = 4, .light_face = -1, .open_face = -1};
    solve_fx_scene box;
    RAD_CHECK(solve_fx_box(&spec, &box));
    double worst = 0, min_area = 1, max_area = 0;
    for (size_t i = 0; i < box.mesh.patch_count; i++) {
        worst = fmax(worst, fabs(box.row_sum[i] - 1));
        min_area = fmin(min_area, box.area[i]);
        max_area = fmax(max_area, box.area[i]);
    }
    printf("box 4x4 graded: %zu patches, areas %.4f..%.4f, max |row sum - 1| = %.2e\n", box.mesh.patch_count,
           min_area, max_area, worst);
    RAD_CHECK(worst < 1e-12);
    RAD_CHECK(max_area > 2 * min_area);
    solve_fx_free(&box);
}

/* ---- the furnace: closed, uniform rho and E => B = E / (1 - rho) ---- */
static const double furnace_rho[4] = {0.5, 0.9, 0.99, 0.999};
static const solve_method all_methods[3] = {SOLVE_JACOBI, SOLVE_GAUSS_SEIDEL, SOLVE_CG};
/* The furnace runs at the default tolerance. Iteration budgets: Jacobi
 * needs ceil(ln(tol)/ln(rho)) - 1 in a furnace (the residual of iterate k is
 * rho^(k+1)); near rho = 1 the residual falls by only (1 - rho) of itself
 * per iteration, comparable to its rounding, so allow 1 % more. Gauss-Seidel
 * needs no more than Jacobi, CG at most 10. */
#define FURNACE_TOL SOLVE_DEFAULT_TOLERANCE
static uint32_t furnace_budget(solve_method m, double rho)
{
    uint32_t jacobi = (uint32_t)(1.01 * ceil(log(FURNACE_TOL) / log(rho)));
    return m == SOLVE_CG ? 10 : jacobi;
}

static void furnace_case(const char *name, solve_fx_scene *s, uint32_t counts[4][3])
{
    size_t n = s->mesh.patch_count;
    double *B = malloc(n * sizeof(double));
    for (int r = 0; r < 4; r++) {
        solve_fx_set_uniform(s, furnace_rho[r], 1.0);
        double exact = 1 / (1 - furnace_rho[r]);
        for (int m = 0; m < 3; m++) {
            solve_report rep;
            rad_status st = fx_solve(s, 0, all_methods[m], FURNACE_TOL, 50000, B, &rep);
            RAD_CHECK(st == RAD_OK);
            if (st != RAD_OK) continue;
            double err = 0;
            for (size_t i = 0; i < n; i++) err = fmax(err, fabs(B[i] - exact) / exact);
            printf("furnace %s rho=%-5g %-12s %6u iterations, residual %.2e, max rel error %.2e\n", name,
                   furnace_rho[r], solve_method_name(all_methods[m]), rep.iterations, rep.residual, err);
            RAD_CHECK(rep.converged && rep.method_used == all_methods[m] && !rep.fell_back);
            RAD_CHECK(err <= 2 * FURNACE_TOL); /* stated: relative error <= 2 * tol */
            RAD_CHECK(rep.iterations <= furnace_budget(all_methods[m], furnace_rho[r]));
            RAD_CHECK(rep.history_count == rep.iterations + 1 && rep.history[rep.iterations] == rep.residual);
            counts[r][m] = rep.iterations;
            solve_report_free(&rep);
        }
    }
    free(B);
}

static void test_furnace(void)
{
    uint32_t box_counts[4][3] = {{0}}, sphere_counts[4][3] = {{0}};
    solve_fx_box_spec spec = {.cells = 4, .light_face = -1, .open_face = -1};
    solve_fx_scene box, sphere;
    RAD_CHECK(solve_fx_box(&spec, &box));
    furnace_case("box", &box, box_counts);
    RAD_CHECK(solve_fx_sphere(6, 8, 0.5, 1.0, &sphere));
    furnace_case("sphere", &sphere, sphere_counts);
    /* CG must need far fewer iterations than Jacobi at rho = 0.999 */
    RAD_CHECK(box_counts[3][2] * 100 < box_counts[3][0]);
    RAD_CHECK(sphere_counts[3][2] * 100 < sphere_counts[3][0]);
    solve_fx_free(&box);
    solve_fx_free(&sphere);
}

/* ---- a lit closed box: only a ceiling light emits (no closed form, but
 * a closed scene absorbs exactly what it emits) ---- */
static void test_lit_box(void)
{
    solve_fx_box_spec spec = {.cells = 6, .light_face = 5, .light_emission = {1, 1, 1}, .open_face = -1};
    solve_fx_scene box;
    RAD_CHECK(solve_fx_box(&spec, &box));
    size_t n = box.mesh.patch_count;
    double *B = malloc(n * sizeof(double));
    for (int r = 0; r < 4; r++) {
        for (size_t i = 0; i < n; i++)
            for (int c = 0; c < 3; c++) box.mesh.patches[i].rho[c] = furnace_rho[r];
        for (int m = 0; m < 3; m++) {
            solve_report rep;
            RAD_CHECK(fx_solve(&box, 0, all_methods[m], FURNACE_TOL, 50000, B, &rep) == RAD_OK);
            double emitted = 0, absorbed = 0;
            for (size_t i = 0; i < n; i++) {
                emitted += box.area[i] * box.mesh.patches[i].emission[0];
                absorbed += box.area[i] * (1 - furnace_rho[r]) * (B[i] - box.mesh.patches[i].emission[0]) /
                            furnace_rho[r];
            }
            printf("lit box %zu patches rho=%-5g %-12s %6u iterations, absorbed/emitted - 1 = %.1e\n", n,
                   furnace_rho[r], solve_method_name(all_methods[m]), rep.iterations, absorbed / emitted - 1);
            RAD_CHECK(rep.converged);
            /* |d absorbed| <= (1 - rho)/rho * total area (6) * ||B - B_exact||_inf */
            RAD_CHECK_NEAR(absorbed, emitted, (1 - furnace_rho[r]) / furnace_rho[r] * 6 * rep.error_bound);
            solve_report_free(&rep);
        }
    }
    free(B);
    solve_fx_free(&box);
}

/* A Cornell-like box: open at y = 0, red and green side walls, a black
 * light (rho = 0, eliminated from CG) in the ceiling. */
static solve_fx_box_spec cornell_like(void)
{
    solve_fx_box_spec s = {.cells = 4, .light_face = 5, .light_rho = {0, 0, 0},
                           .light_emission = {17, 12, 4}, .open_face = 2};
    const double white[3] = {0.725, 0.71, 0.68}, red[3] = {0.63, 0.065, 0.05}, green[3] = {0.14, 0.45, 0.091};
    for (int f = 0; f < 6; f++)
        for (int c = 0; c < 3; c++) s.rho[f][c] = f == 0 ? red[c] : f == 1 ? green[c] : white[c];
    return s;
}

/* ---- Jacobi, Gauss-Seidel and CG agree; energy balance of the open box ---- */
static void test_open_box(void)
{
    solve_fx_box_spec spec = cornell_like();
    solve_fx_scene box;
    RAD_CHECK(solve_fx_box(&spec, &box));
    size_t n = box.mesh.patch_count;
    const double tol = SOLVE_DEFAULT_TOLERANCE;
    double *B[3];
    for (int m = 0; m < 3; m++) B[m] = malloc(n * sizeof(double));
    for (int c = 0; c < 3; c++) {
        solve_report rep[3];
        for (int m = 0; m < 3; m++) {
            RAD_CHECK(fx_solve(&box, c, all_methods[m], tol, 10000, B[m], &rep[m]) == RAD_OK);
            printf("open box channel %d %-12s %4u iterations\n", c, solve_method_name(all_methods[m]),
                   rep[m].iterations);
        }
        RAD_CHECK(rep[2].method_used == SOLVE_CG && rep[2].reciprocity < 1e-12);
        /* each solution is within its error bound of the exact one */
        double bound = rep[0].error_bound + rep[2].error_bound, bound_gs = rep[1].error_bound + rep[2].error_bound;
        double dj = 0, dg = 0;
        for (size_t i = 0; i < n; i++) {
            dj = fmax(dj, fabs(B[0][i] - B[2][i]));
            dg = fmax(dg, fabs(B[1][i] - B[2][i]));
        }
        RAD_CHECK(dj <= bound && dg <= bound_gs);
        RAD_CHECK(bound < 1e-7);
        /* emitted = absorbed + escaped through the opening */
        double emitted = 0, absorbed = 0, escaped = 0;
        for (size_t i = 0; i < n; i++) {
            const rad_patch *p = &box.mesh.patches[i];
            double H = 0;
            for (size_t j = 0; j < n; j++) H += box.F[i * n + j] * B[2][j];
            emitted += box.area[i] * p->emission[c];
            absorbed += box.area[i] * (1 - p->rho[c]) * H;
            escaped += box.area[i] * B[2][i] * (1 - box.row_sum[i]);
        }
        printf("open box channel %d: emitted %.9g, absorbed %.9g + escaped %.9g\n", c, emitted, absorbed, escaped);
        RAD_CHECK_REL(absorbed + escaped, emitted, 1e-8);
        RAD_CHECK(escaped > 0.1 * emitted);
        for (int m = 0; m < 3; m++) solve_report_free(&rep[m]);
    }
    for (int m = 0; m < 3; m++) free(B[m]);
    solve_fx_free(&box);
}

/* ---- two facing squares: B1 = E / (1 - rho^2 F^2), B2 = rho F B1 ---- */
static void test_two_squares(void)
{
    solve_fx_scene s;
    RAD_CHECK(solve_fx_two_squares(0.5, 2.0, &s));
    double B[2], F = 0.199824895698, rho = 0.5;
    solve_report rep;
    RAD_CHECK(fx_solve(&s, 0, SOLVE_AUTO, 1e-12, 100, B, &rep) == RAD_OK);
    double b1 = 2.0 / (1 - rho * rho * F * F);
    RAD_CHECK_REL(B[0], b1, 1e-9);
    RAD_CHECK_REL(B[1], rho * F * b1, 1e-9);
    solve_report_free(&rep);
    solve_fx_free(&s);
}

/* ---- the whole stage through files ---- */
static void test_stage_grey_and_rgb(void)
{
    solve_fx_box_spec spec = {.cells = 3, .light_face = -1, .open_face = -1};
    solve_fx_scene s;
    RAD_CHECK(solve_fx_box(&spec, &s));
    solve_fx_set_uniform(&s, 0.9, 1.0);
    RAD_CHECK(solve_fx_write(path_in_dir("furnace_09.ff"), &s, RAD_ELEMENT_F64) == RAD_OK);
    solve_fx_set_uniform(&s, 0.99, 1.0);
    RAD_CHECK(solve_fx_write(path_in_dir("furnace_099.ff"), &s, RAD_ELEMENT_F64) == RAD_OK);
    solve_fx_set_uniform(&s, 0.5, 1.0);
    RAD_CHECK(solve_fx_write(path_in_dir("furnace_05_f32.ff"), &s, RAD_ELEMENT_F32) == RAD_OK);
    size_t n = s.mesh.patch_count;
    solve_fx_free(&s);

    solve_options opt = {.input = path_in_dir("furnace_09.ff"), .output = path_in_dir("furnace_09.rad"),
                         .stats = path_in_dir("furnace_09.json")};
    RAD_CHECK(solve_stage_run(&opt) == RAD_OK);
    rad_radiosity r;
    RAD_CHECK(rad_rf_read(opt.output, &r) == RAD_OK);
    RAD_CHECK(r.channel_count == 1 && r.converged == 1 && r.mesh.patch_count == n);
    RAD_CHECK(r.method == RAD_SOLVE_CG && r.scene_fingerprint == 0x5eed);
    for (size_t i = 0; i < n; i++)
        for (int c = 0; c < 3; c++) RAD_CHECK_REL(r.radiosity[3 * i + c], 10.0, 2e-6);
    rad_radiosity_free(&r);
    char *json = NULL;
    size_t json_size = 0;
    RAD_CHECK(rad_fs_read_all(opt.stats, &json, &json_size) == RAD_OK);
    RAD_CHECK(json && strstr(json, "\"grey\": true") && strstr(json, "\"history\": [") &&
              strstr(json, "\"method\": \"cg\""));
    free(json);

    /* float32 storage: read back as double, solved in double */
    opt = (solve_options){.input = path_in_dir("furnace_05_f32.ff"), .output = path_in_dir("furnace_05.rad")};
    RAD_CHECK(solve_stage_run(&opt) == RAD_OK);
    RAD_CHECK(rad_rf_read(opt.output, &r) == RAD_OK);
    for (size_t i = 0; i < n; i++) RAD_CHECK_REL(r.radiosity[3 * i], 2.0, 1e-6);
    rad_radiosity_free(&r);

    /* RGB: three channels, each agreeing with the in-memory solve */
    spec = cornell_like();
    RAD_CHECK(solve_fx_box(&spec, &s));
    RAD_CHECK(solve_fx_write(path_in_dir("open_box.ff"), &s, RAD_ELEMENT_F64) == RAD_OK);
    opt = (solve_options){.input = path_in_dir("open_box.ff"), .output = path_in_dir("open_box.rad"),
                          .params = {.method = SOLVE_GAUSS_SEIDEL, .tolerance = 1e-10}};
    RAD_CHECK(solve_stage_run(&opt) == RAD_OK);
    RAD_CHECK(rad_rf_read(opt.output, &r) == RAD_OK);
    RAD_CHECK(r.channel_count == 3 && r.method == RAD_SOLVE_GAUSS_SEIDEL);
    double *B = malloc(s.mesh.patch_count * sizeof(double));
    for (int c = 0; c < 3; c++) {
        solve_report rep;
        RAD_CHECK(fx_solve(&s, c, SOLVE_CG, 1e-10, 1000, B, &rep) == RAD_OK);
        for (size_t i = 0; i < s.mesh.patch_count; i++)
            RAD_CHECK_NEAR(r.radiosity[3 * i + c], B[i], 2 * 17 * 1e-10 / (1 - 0.725));
        solve_report_free(&rep);
    }
    free(B);
    rad_radiosity_free(&r);
    solve_fx_free(&s);
}

/* ---- iteration limit: output still written, marked unconverged ---- */
static void test_unconverged(void)
{
    rad_test_capture_log();
    solve_options opt = {.input = path_in_dir("furnace_099.ff"), .output = path_in_dir("unconverged.rad"),
                         .params = {.method = SOLVE_JACOBI, .max_iterations = 5}};
    RAD_CHECK(solve_stage_run(&opt) == RAD_ERR_NOT_CONVERGED);
    RAD_CHECK(rad_test_log_contains("not converged") && rad_test_log_contains("furnace_099.ff"));
    rad_log_set_sink(NULL, NULL);
    rad_radiosity r;
    RAD_CHECK(rad_rf_read(opt.output, &r) == RAD_OK);
    RAD_CHECK(r.converged == 0 && r.iterations[0] == 5 && r.residual[0] > 1e-6);
    rad_radiosity_free(&r);
}

/* ---- a matrix too far from reciprocal for CG: warn and fall back ---- */
static void test_cg_fallback(void)
{
    solve_fx_box_spec spec = {.cells = 3, .light_face = -1, .open_face = -1};
    solve_fx_scene s;
    RAD_CHECK(solve_fx_box(&spec, &s));
    solve_fx_set_uniform(&s, 0.9, 1.0);
    size_t n = s.mesh.patch_count;
    for (size_t j = 0; j < n; j++) s.F[5 * n + j] *= 0.7; /* row 5 no longer matches its column */
    s.row_sum[5] *= 0.7;
    double *B = malloc(n * sizeof(double));
    solve_report rep;
    rad_test_capture_log();
    RAD_CHECK(fx_solve(&s, 0, SOLVE_CG, 1e-8, 10000, B, &rep) == RAD_OK);
    RAD_CHECK(rad_test_log_contains("not reciprocal enough for CG"));
    rad_log_set_sink(NULL, NULL);
    RAD_CHECK(rep.fell_back && rep.method_used == SOLVE_GAUSS_SEIDEL && rep.converged && rep.reciprocity > 0.1);
    solve_report_free(&rep);
    free(B);
    solve_fx_free(&s);
}

/* ---- channels together (solve_channels) = channels one at a time ---- */
/* The Cornell-like box's three channels in lockstep CG give the bits each
 * gives alone (the same dot products in the same order), with the same
 * iterations and histories; a fourth channel on Gauss-Seidel and a fifth
 * stopped by a 1-iteration limit come out as alone too. */
static void test_channels_together(void)
{
    solve_fx_box_spec spec = cornell_like();
    solve_fx_scene s;
    RAD_CHECK(solve_fx_box(&spec, &s));
    size_t n = s.mesh.patch_count;
    enum { COUNT = 5 };
    double *rho_buf = malloc(COUNT * n * sizeof(double)), *e_buf = malloc(COUNT * n * sizeof(double));
    double *together = malloc(COUNT * n * sizeof(double)), *alone = malloc(n * sizeof(double));
    const double *rho[COUNT], *E[COUNT];
    double *B[COUNT];
    solve_params p[COUNT];
    for (int c = 0; c < COUNT; c++) {
        for (size_t i = 0; i < n; i++) {
            rho_buf[c * n + i] = s.mesh.patches[i].rho[c % 3];
            e_buf[c * n + i] = s.mesh.patches[i].emission[c % 3];
        }
        rho[c] = rho_buf + c * n;
        E[c] = e_buf + c * n;
        B[c] = together + c * n;
        p[c] = (solve_params){.method = c == 3 ? SOLVE_GAUSS_SEIDEL : SOLVE_CG, .tolerance = 1e-12,
                              .max_iterations = c == 4 ? 1 : 0, .progress_seconds = -1};
    }
    solve_report reps[COUNT];
    solve_channels_result joint;
    solve_system sys = fx_system(&s);
    rad_test_capture_log();
    rad_status st = solve_channels(&sys, COUNT, rho, E, p, B, reps, &joint);
    rad_log_set_sink(NULL, NULL);
    RAD_CHECK(st == RAD_ERR_NOT_CONVERGED); /* channel 4: one iteration allowed */
    RAD_CHECK(joint.lockstep_channels == 4);
    for (int c = 0; c < COUNT; c++) {
        solve_report rep;
        rad_test_capture_log();
        rad_status one = solve_channel(&sys, rho[c], E[c], &p[c], alone, &rep);
        rad_log_set_sink(NULL, NULL);
        RAD_CHECK(one == (c == 4 ? RAD_ERR_NOT_CONVERGED : RAD_OK));
        RAD_CHECK(memcmp(alone, B[c], n * sizeof(double)) == 0);
        RAD_CHECK(rep.iterations == reps[c].iterations && rep.method_used == reps[c].method_used);
        RAD_CHECK(rep.history_count == reps[c].history_count &&
                  memcmp(rep.history, reps[c].history, rep.history_count * sizeof(double)) == 0);
        printf("channel %d together and alone: %s, %u iterations, identical bits\n", c,
               solve_method_name(rep.method_used), rep.iterations);
        solve_report_free(&rep);
        solve_report_free(&reps[c]);
    }
    free(rho_buf);
    free(e_buf);
    free(together);
    free(alone);
    solve_fx_free(&s);
}

/* ---- bad input files: each with its message and status ---- */
static int write_bytes(const char *path, const void *data, size_t size)
{
    FILE *f = fopen(path, "wb");
    if (!f) return 0;
    int ok = fwrite(data, 1, size, f) == size;
    return (fclose(f) == 0) && ok;
}

static void expect_failure(const char *name, rad_status expected, const char *message)
{
    rad_test_capture_log();
    solve_options opt = {.input = path_in_dir(name), .output = path_in_dir("never.rad")};
    rad_status st = solve_stage_run(&opt);
    int named = rad_test_log_contains(name), said = rad_test_log_contains(message);
    rad_log_set_sink(NULL, NULL);
    if (st != expected || !named || !said)
        fprintf(stderr, "%s: status %s (expected %s), names file %d, says '%s' %d\n", name, rad_status_str(st),
                rad_status_str(expected), named, message, said);
    RAD_CHECK(st == expected && named && said);
    struct stat sb;
    RAD_CHECK(stat(path_in_dir("never.rad"), &sb) != 0);
}

static void write_bad_matrix(const char *name, size_t row, size_t col, double value, solve_fx_scene *s)
{
    size_t n = s->mesh.patch_count;
    double saved = s->F[row * n + col];
    s->F[row * n + col] = value;
    RAD_CHECK(solve_fx_write(path_in_dir(name), s, RAD_ELEMENT_F64) == RAD_OK);
    s->F[row * n + col] = saved;
}

static void test_bad_inputs(void)
{
    solve_fx_box_spec spec = {.cells = 2, .light_face = -1, .open_face = -1};
    solve_fx_scene s;
    RAD_CHECK(solve_fx_box(&spec, &s));
    solve_fx_set_uniform(&s, 0.5, 1.0);
    RAD_CHECK(solve_fx_write(path_in_dir("good.ff"), &s, RAD_ELEMENT_F64) == RAD_OK);
    write_bad_matrix("bad_nan.ff", 3, 7, NAN, &s);
    write_bad_matrix("bad_inf.ff", 4, 2, INFINITY, &s);
    write_bad_matrix("bad_negative.ff", 5, 9, -0.01, &s);
    write_bad_matrix("bad_rowsum.ff", 7, 7, 0.75, &s);
    solve_fx_free(&s);

    char *good = NULL;
    size_t size = 0;
    RAD_CHECK(rad_fs_read_all(path_in_dir("good.ff"), &good, &size) == RAD_OK);
    RAD_CHECK(write_bytes(path_in_dir("bad_truncated.ff"), good, size - 100));
    RAD_CHECK(write_bytes(path_in_dir("bad_short.ff"), good, 100));
    const char text[] = "# not a matrix\nv 0 0 0\n";
    RAD_CHECK(write_bytes(path_in_dir("bad_foreign.ff"), text, sizeof text - 1));
    good[16] ^= 0x01; /* N in the header: 24 -> 25 */
    RAD_CHECK(write_bytes(path_in_dir("bad_n.ff"), good, size));
    good[16] ^= 0x01;
    good[size - 24 * 8 - 300] ^= 0x40; /* a matrix byte, inside the last rows */
    RAD_CHECK(write_bytes(path_in_dir("bad_corrupt.ff"), good, size));
    free(good);

    expect_failure("missing.ff", RAD_ERR_IO, "cannot open");
    expect_failure("bad_truncated.ff", RAD_ERR_FORMAT, "truncated");
    expect_failure("bad_short.ff", RAD_ERR_FORMAT, "truncated");
    expect_failure("bad_foreign.ff", RAD_ERR_FORMAT, "not a form-factor file");
    expect_failure("bad_corrupt.ff", RAD_ERR_FORMAT, "checksum mismatch");
    expect_failure("bad_n.ff", RAD_ERR_FORMAT, "header checksum mismatch");
    expect_failure("bad_nan.ff", RAD_ERR_INVALID, "row 3: F[3][7] is NaN");
    expect_failure("bad_inf.ff", RAD_ERR_INVALID, "row 4: F[4][2] is infinite");
    expect_failure("bad_negative.ff", RAD_ERR_INVALID, "row 5: F[5][9] = -0.01 is negative");
    expect_failure("bad_rowsum.ff", RAD_ERR_INVALID, "row 7: form factors sum to");
    expect_failure("furnace_09.rad", RAD_ERR_FORMAT, "not a form-factor file");
}

/* ---- the radiosity file: round trip and damage ---- */
static void test_radiosity_file(void)
{
    rad_radiosity r;
    RAD_CHECK(rad_rf_read(path_in_dir("open_box.rad"), &r) == RAD_OK);
    RAD_CHECK(rad_rf_write(path_in_dir("copy.rad"), &r) == RAD_OK);
    rad_radiosity back;
    RAD_CHECK(rad_rf_read(path_in_dir("copy.rad"), &back) == RAD_OK);
    RAD_CHECK(back.mesh.patch_count == r.mesh.patch_count && back.channel_count == 3);
    RAD_CHECK(memcmp(back.radiosity, r.radiosity, 3 * r.mesh.patch_count * sizeof(double)) == 0);
    RAD_CHECK(memcmp(back.mesh.patches, r.mesh.patches, r.mesh.patch_count * sizeof(rad_patch)) == 0);
    RAD_CHECK(back.tolerance == r.tolerance && back.iterations[2] == r.iterations[2]);
    rad_radiosity_free(&back);
    rad_radiosity_free(&r);

    char *bytes = NULL;
    size_t size = 0;
    RAD_CHECK(rad_fs_read_all(path_in_dir("copy.rad"), &bytes, &size) == RAD_OK);
    struct {
        const char *name, *message;
        size_t offset, keep; /* flip a bit at offset; keep: bytes written */
        rad_status status;
    } cases[] = {
        {"rf_truncated.rad", "truncated", 0, size - 8, RAD_ERR_FORMAT},
        {"rf_header.rad", "header checksum mismatch", 20, size, RAD_ERR_FORMAT},
        {"rf_payload.rad", "payload checksum mismatch", size - 5, size, RAD_ERR_FORMAT},
        {"rf_magic.rad", "not a radiosity file", 1, size, RAD_ERR_FORMAT},
        {"rf_tiny.rad", "too short", 0, 10, RAD_ERR_FORMAT},
    };
    for (size_t k = 0; k < sizeof cases / sizeof cases[0]; k++) {
        if (cases[k].offset) bytes[cases[k].offset] ^= 0x10;
        RAD_CHECK(write_bytes(path_in_dir(cases[k].name), bytes, cases[k].keep));
        if (cases[k].offset) bytes[cases[k].offset] ^= 0x10;
        rad_test_capture_log();
        rad_status st = rad_rf_read(path_in_dir(cases[k].name), &r);
        RAD_CHECK(st == cases[k].status && rad_test_log_contains(cases[k].message) &&
                  rad_test_log_contains(cases[k].name));
        rad_log_set_sink(NULL, NULL);
    }
    free(bytes);
    rad_test_capture_log();
    RAD_CHECK(rad_rf_read(path_in_dir("good.ff"), &r) == RAD_ERR_FORMAT);
    RAD_CHECK(rad_test_log_contains("is a form-factor file"));
    rad_log_set_sink(NULL, NULL);
}

int main(int argc, char **argv)
{
    if (!solve_fx_work_dir(argc, argv, "test_solve", g_dir, sizeof g_dir)) return 1;
    rad_log_set_level(RAD_LOG_WARN);
    test_exact_form_factors();
    test_furnace();
    test_lit_box();
    test_open_box();
    test_two_squares();
    test_stage_grey_and_rgb();
    test_unconverged();
    test_cg_fallback();
    test_channels_together();
    test_bad_inputs();
    test_radiosity_file();
    return rad_test_finish();
}
