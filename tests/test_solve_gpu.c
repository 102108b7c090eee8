/* test_solve_gpu.c - solve --backend cuda against --backend cpu (label
 * gpu). Exits 77 (skipped) when no GPU is visible; never fails for that.
 *
 * usage: test_solve_gpu DIR [FILE.ff ...]
 * DIR: working folder; FILE.ff: more form-factor files to compare on
 * (tests/CMakeLists.txt passes formfactor-made sparse files, f32 and f64).
 *
 * One run on a GPU machine says whether the backend works, piece by piece:
 *  1. The product kernel (gpu.h solve_gpu_multiply), three vectors in one
 *     pass, against the host's sum of float(F_ij) x_j: equal within
 *     1e-12 of sum_j |F_ij x_j| (the same products, summed in another
 *     order); repeated, the same bits; the device matrix exact for f32
 *     files and not for f64 ones. Dense and sparse, N not a multiple of
 *     the tile width (padding), tiles left out (two rooms).
 *  2. The stage, cuda against cpu, for every file and cg and jacobi:
 *     converged; the residual the CPU verified with the stored matrix
 *     <= tolerance; the method asked for; per patch and channel
 *     |B_cuda - B_cpu| <= error_bound_cuda + error_bound_cpu (each B is
 *     within its bound omega ||E|| / (1 - max rho rowsum) of the exact
 *     one: solver.h) + 64 N eps max|B| (the rounding of the residual's
 *     evaluation, which the bound leaves out); iterations within 2 + 10 % of the CPU's for exact
 *     (f32) matrices, and for f64 ones at most 2x + 10 (refinement rounds
 *     add some); rounds 1..2 for exact matrices, >= 2 for f64 files at
 *     tolerance 1e-12 (the refinement is exercised); stats say cuda.
 *  3. The same cuda solve twice: the same file, byte for byte.
 *  4. gauss-seidel under cuda runs on the CPU: the same file as cpu's.
 */
#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "gpu.h"
#include "matrix.h"
#include "rad_ffile.h"
#include "rad_rfile.h"
#include "rad_test.h"
#include "stage.h"
#include "test_solve_fixtures.h"

static char work[1024];

/* ---- 1. the product ---- */

static void check_product(const char *path, int expect_exact)
{
    rad_ff_file *file = NULL;
    solve_matrix m;
    memset(&m, 0, sizeof m);
    RAD_CHECK(rad_ff_open(path, &file) == RAD_OK);
    if (!file) return;
    RAD_CHECK(solve_matrix_load(file, path, 0, rad_ff_file_info(file)->patch_count, &m) == RAD_OK);
    const size_t n = m.patch_count;
    solve_gpu *gpu = NULL;
    solve_gpu_tiles tiles;
    memset(&tiles, 0, sizeof tiles);
    RAD_CHECK(solve_gpu_tiles_make(&m.rows, &tiles) == RAD_OK);
    RAD_CHECK(solve_gpu_create(&tiles, m.area, &gpu) == RAD_OK);
    solve_gpu_tiles_free(&tiles);
    double *x = malloc(3 * n * sizeof(double)), *y = malloc(3 * n * sizeof(double)),
           *again = malloc(3 * n * sizeof(double));
    if (gpu && x && y && again) {
        if (expect_exact >= 0) RAD_CHECK(solve_gpu_exact(gpu) == expect_exact);
        uint64_t state = 12345;
        for (size_t k = 0; k < 3 * n; k++) { /* positive and negative, 6 decades */
            state = state * 6364136223846793005ull + 1442695040888963407ull;
            double u = (double)(state >> 11) / 9007199254740992.0;
            x[k] = (u - 0.3) * pow(10.0, 6 * u - 3);
        }
        const double *xs[3] = {x, x + n, x + 2 * n};
        double *ys[3] = {y, y + n, y + 2 * n}, *as[3] = {again, again + n, again + 2 * n};
        RAD_CHECK(solve_gpu_multiply(gpu, 3, xs, ys) == RAD_OK);
        RAD_CHECK(solve_gpu_multiply(gpu, 3, xs, as) == RAD_OK);
        RAD_CHECK(memcmp(y, again, 3 * n * sizeof(double)) == 0);
        double worst = 0;
        size_t bad = 0;
        for (size_t c = 0; c < 3; c++)
            for (size_t i = 0; i < n; i++) {
                long double sum = 0, size = 0;
                for (size_t k = 0; k < solve_row_span_count(&m.rows, i); k++) {
                    solve_span sp = solve_row_span(&m.rows, i, k);
                    for (size_t j = sp.begin; j < sp.end; j++) {
                        long double t = (long double)(float)sp.values[j - sp.begin] * xs[c][j];
                        sum += t;
                        size += fabsl(t);
                    }
                }
                double diff = fabs(ys[c][i] - (double)sum), scale = (double)size;
                if (scale > 0 && diff / scale > worst) worst = diff / scale;
                bad += !(diff <= 1e-12 * scale);
            }
        fprintf(stderr, "%s: product of 3 vectors, N = %zu: worst |gpu - host| / sum|F x| = %.2e, %zu rows off; %s\n",
                path, n, worst, bad, solve_gpu_exact(gpu) ? "exact" : "rounded to float");
        RAD_CHECK(bad == 0);
    }
    free(x);
    free(y);
    free(again);
    solve_gpu_destroy(gpu);
    solve_matrix_free(&m);
    rad_ff_close(file);
}

/* ---- 2. the stage, cuda against cpu ---- */

static rad_status run_stage(const char *input, const char *output, const char *stats, solve_backend backend,
                            solve_method method, double tolerance)
{
    solve_options o;
    memset(&o, 0, sizeof o);
    o.input = input;
    o.output = output;
    o.stats = stats;
    o.backend = backend;
    o.params.method = method;
    o.params.tolerance = tolerance;
    return solve_stage_run(&o);
}

/* The numbers after every "key": in a stats file, in order (null: NAN). */
static size_t json_numbers(const char *text, const char *key, double *out, size_t max)
{
    char pattern[64];
    snprintf(pattern, sizeof pattern, "\"%s\": ", key);
    size_t k = 0;
    for (const char *p = text; k < max && (p = strstr(p, pattern)) != NULL;) {
        p += strlen(pattern);
        out[k++] = strncmp(p, "null", 4) == 0 ? NAN : strtod(p, NULL);
    }
    return k;
}

static char *read_text(const char *path)
{
    size_t size = 0;
    unsigned char *bytes = rad_test_read_file(path, &size);
    char *text = bytes ? realloc(bytes, size + 1) : NULL;
    if (text) text[size] = 0;
    return text;
}

static int same_bytes(const char *a, const char *b)
{
    size_t sa = 0, sb = 0;
    unsigned char *x = rad_test_read_file(a, &sa), *y = rad_test_read_file(b, &sb);
    int same = x && y && sa == sb && memcmp(x, y, sa) == 0;
    free(x);
    free(y);
    return same;
}

/* cuda against cpu on one file, method and tolerance. A fixture (exact,
 * reciprocal) must keep the method asked for; a formfactor-made file the
 * one the CPU ended with (its CG check may pick gauss-seidel). */
static void compare(const char *path, solve_method method, double tolerance, int expect_rounds_min, int fixture)
{
    char name[256];
    const char *base = strrchr(path, '/') ? strrchr(path, '/') + 1 : path;
    snprintf(name, sizeof name, "%s_%s_%g", base, solve_method_name(method), tolerance);
    char cpu_rad[1400], gpu_rad[1400], cpu_json[1400], gpu_json[1400], again_rad[1400];
    snprintf(cpu_rad, sizeof cpu_rad, "%s/%s.cpu.rad", work, name);
    snprintf(gpu_rad, sizeof gpu_rad, "%s/%s.cuda.rad", work, name);
    snprintf(cpu_json, sizeof cpu_json, "%s/%s.cpu.json", work, name);
    snprintf(gpu_json, sizeof gpu_json, "%s/%s.cuda.json", work, name);
    snprintf(again_rad, sizeof again_rad, "%s/%s.again.rad", work, name);
    RAD_CHECK(run_stage(path, cpu_rad, cpu_json, SOLVE_BACKEND_CPU, method, tolerance) == RAD_OK);
    rad_status st = run_stage(path, gpu_rad, gpu_json, SOLVE_BACKEND_CUDA, method, tolerance);
    RAD_CHECK(st == RAD_OK);
    rad_radiosity rc, rg;
    memset(&rc, 0, sizeof rc);
    memset(&rg, 0, sizeof rg);
    char *jc = read_text(cpu_json), *jg = read_text(gpu_json);
    if (rad_rf_read(cpu_rad, &rc) != RAD_OK || rad_rf_read(gpu_rad, &rg) != RAD_OK || !jc || !jg) {
        fprintf(stderr, "%s: no results to compare\n", name);
        rad_test_failures++;
        goto done;
    }
    RAD_CHECK(strstr(jg, "\"backend\": \"cuda\"") != NULL);
    RAD_CHECK(strstr(jc, "\"backend\": \"cpu\"") != NULL);
    int exact = strstr(jg, "\"device_exact\": true") != NULL;
    double bound_c[3] = {0}, bound_g[3] = {0}, rounds[3] = {0};
    uint32_t channels = rg.channel_count;
    RAD_CHECK(rc.channel_count == channels && rc.mesh.patch_count == rg.mesh.patch_count);
    RAD_CHECK(json_numbers(jc, "error_bound", bound_c, 3) == channels);
    RAD_CHECK(json_numbers(jg, "error_bound", bound_g, 3) == channels);
    RAD_CHECK(json_numbers(jg, "rounds", rounds, 3) == channels);
    RAD_CHECK(rg.converged == 1);
    const uint32_t asked = method == SOLVE_CG ? RAD_SOLVE_CG : RAD_SOLVE_JACOBI;
    for (uint32_t c = 0; c < channels && c < 3; c++) {
        const size_t n = rg.mesh.patch_count;
        double worst = 0, worst_rel = 0, brightest = 0;
        for (size_t i = 0; i < n; i++) brightest = fmax(brightest, fabs(rc.radiosity[3 * i + c]));
        /* each B within its bound of the exact one, plus what evaluating
         * the residual rounds (N eps |B|, amplified: B large against E) */
        const double allowed = bound_c[c] + bound_g[c] + 64.0 * (double)n * DBL_EPSILON * brightest;
        size_t off = 0;
        for (size_t i = 0; i < n; i++) {
            double a = rg.radiosity[3 * i + c], b = rc.radiosity[3 * i + c], d = fabs(a - b);
            if (d > worst) worst = d;
            if (b != 0 && d / fabs(b) > worst_rel) worst_rel = d / fabs(b);
            off += !(d <= allowed);
        }
        uint32_t ic = rc.iterations[c], ig = rg.iterations[c];
        fprintf(stderr,
                "%s (%s) channel %u: iterations cpu %u cuda %u, residual cpu %.3g cuda %.3g (tolerance %.3g), "
                "rounds %.0f, max |dB| %.3g (relative %.3g) against bound %.3g: %zu patches beyond\n",
                name, exact ? "exact" : "f64", c, ic, ig, rc.residual[c], rg.residual[c], tolerance, rounds[c], worst,
                worst_rel, allowed, off);
        RAD_CHECK(off == 0);
        RAD_CHECK(rg.residual[c] <= tolerance);
        RAD_CHECK(rg.channel_method[c] == rc.channel_method[c]);
        if (fixture) RAD_CHECK(rc.channel_method[c] == asked);
        if (exact) {
            RAD_CHECK(ig <= ic + 2 + ic / 10 && ic <= ig + 2 + ig / 10);
            RAD_CHECK(rounds[c] >= 1 && rounds[c] <= 2);
        } else {
            RAD_CHECK(ig <= 2 * ic + 10 && ic <= ig + 2 + ig / 10);
            RAD_CHECK(rounds[c] >= expect_rounds_min);
        }
    }
    /* 3. the same run again: the same bits */
    RAD_CHECK(run_stage(path, again_rad, NULL, SOLVE_BACKEND_CUDA, method, tolerance) == RAD_OK);
    RAD_CHECK(same_bytes(gpu_rad, again_rad));
done:
    free(jc);
    free(jg);
    rad_radiosity_free(&rc);
    rad_radiosity_free(&rg);
}

/* 4. gauss-seidel asked of cuda: the CPU's, bit for bit. */
static void check_gauss_seidel(const char *path)
{
    char cpu_rad[1400], gpu_rad[1400], gpu_json[1400];
    snprintf(cpu_rad, sizeof cpu_rad, "%s/gs.cpu.rad", work);
    snprintf(gpu_rad, sizeof gpu_rad, "%s/gs.cuda.rad", work);
    snprintf(gpu_json, sizeof gpu_json, "%s/gs.cuda.json", work);
    RAD_CHECK(run_stage(path, cpu_rad, NULL, SOLVE_BACKEND_CPU, SOLVE_GAUSS_SEIDEL, 0) == RAD_OK);
    rad_test_capture_log();
    RAD_CHECK(run_stage(path, gpu_rad, gpu_json, SOLVE_BACKEND_CUDA, SOLVE_GAUSS_SEIDEL, 0) == RAD_OK);
    RAD_CHECK(rad_test_log_contains("gauss-seidel is sequential, row after row: it runs on the CPU"));
    rad_log_set_sink(NULL, NULL);
    RAD_CHECK(same_bytes(cpu_rad, gpu_rad));
}

/* ---- the fixtures ---- */

static void fill3(double out[3], double r, double g, double b) { out[0] = r, out[1] = g, out[2] = b; }

static int write_file(const char *name, const solve_fx_scene *scene, rad_element_type type, int sparse)
{
    rad_status st = solve_fx_write_layout(solve_fx_path(work, name), scene, type, sparse);
    RAD_CHECK(st == RAD_OK);
    return st == RAD_OK;
}

/* A coloured box with a light (rho = 0 there: the CG eliminates it), N =
 * 6 * cells^2. */
static int make_box(int cells, solve_fx_scene *out)
{
    solve_fx_box_spec spec = {.cells = cells, .light_face = 5, .open_face = -1};
    for (int f = 0; f < 6; f++) fill3(spec.rho[f], f == 0 ? 0.63 : 0.75, f == 1 ? 0.2 : 0.7, 0.5 + 0.07 * f);
    fill3(spec.light_emission, 17, 12, 4);
    fill3(spec.light_rho, 0, 0, 0);
    return solve_fx_box(&spec, out);
}

int main(int argc, char **argv)
{
    if (!solve_gpu_built() || solve_gpu_device_count() == 0) {
        fprintf(stderr, "test_solve_gpu: no CUDA device visible (or a build without CUDA): skipped\n");
        return 77;
    }
    if (!solve_fx_work_dir(argc > 1 ? 2 : argc, argv, "test_solve_gpu", work, sizeof work)) return 1;
    solve_fx_scene box, small, rooms, sphere;
    memset(&box, 0, sizeof box), memset(&small, 0, sizeof small), memset(&rooms, 0, sizeof rooms),
        memset(&sphere, 0, sizeof sphere);
    /* N = 294 (4 tiles a row, the last of 38 columns); two rooms of 150 and
     * 96 patches, coupled: whole tiles left out of a sparse file */
    if (!make_box(7, &box) || !make_box(5, &small) || !solve_fx_sphere(12, 16, 0.99, 1, &sphere)) {
        fprintf(stderr, "cannot build the fixtures\n");
        return 1;
    }
    solve_fx_scene four;
    memset(&four, 0, sizeof four);
    if (!make_box(4, &four) || !solve_fx_join(&small, &four, 2.0, &rooms)) {
        fprintf(stderr, "cannot build the fixtures\n");
        return 1;
    }
    solve_fx_couple(&rooms, 3, small.mesh.patch_count + 5, 1e-3);
    write_file("box_f32.ff", &box, RAD_ELEMENT_F32, 0);
    write_file("box_f64.ff", &box, RAD_ELEMENT_F64, 0);
    write_file("rooms_f32_sparse.ff", &rooms, RAD_ELEMENT_F32, 1);
    write_file("rooms_f64_sparse.ff", &rooms, RAD_ELEMENT_F64, 1);
    write_file("sphere_f32_sparse.ff", &sphere, RAD_ELEMENT_F32, 1);

    check_product(solve_fx_path(work, "box_f32.ff"), 1);
    check_product(solve_fx_path(work, "box_f64.ff"), 0);
    check_product(solve_fx_path(work, "rooms_f32_sparse.ff"), 1);
    check_product(solve_fx_path(work, "rooms_f64_sparse.ff"), 0);
    check_product(solve_fx_path(work, "sphere_f32_sparse.ff"), 1);
    for (int k = 2; k < argc; k++) check_product(argv[k], -1);

    static const char *const files[] = {"box_f32.ff", "box_f64.ff", "rooms_f32_sparse.ff", "rooms_f64_sparse.ff",
                                        "sphere_f32_sparse.ff"};
    for (size_t f = 0; f < sizeof files / sizeof files[0]; f++) {
        char path[1400];
        snprintf(path, sizeof path, "%s", solve_fx_path(work, files[f]));
        compare(path, SOLVE_CG, 1e-10, 1, 1);
        compare(path, SOLVE_JACOBI, 1e-10, 1, 1);
    }
    /* f64 at 1e-12: the float matrix alone cannot get there (F - F32 ~ 6e-8):
     * a second round is needed and must get there */
    compare(solve_fx_path(work, "box_f64.ff"), SOLVE_CG, 1e-12, 2, 1);
    compare(solve_fx_path(work, "rooms_f64_sparse.ff"), SOLVE_CG, 1e-12, 2, 1);
    compare(solve_fx_path(work, "rooms_f64_sparse.ff"), SOLVE_JACOBI, 1e-12, 2, 1);
    for (int k = 2; k < argc; k++) {
        compare(argv[k], SOLVE_CG, 1e-10, 1, 0);
        compare(argv[k], SOLVE_JACOBI, 1e-10, 1, 0);
    }
    check_gauss_seidel(solve_fx_path(work, "box_f64.ff"));

    solve_fx_free(&box);
    solve_fx_free(&small);
    solve_fx_free(&four);
    solve_fx_free(&rooms);
    solve_fx_free(&sphere);
    return rad_test_finish();
}
