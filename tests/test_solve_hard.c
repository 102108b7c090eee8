/* test_solve_hard.c - the solver's hard cases (issue #6), every answer
 * checked patch by patch against a dense direct solve:
 *
 *  - rho = 0.999: a furnace (closed box, rows sum to 1, B = E / (1 - rho)
 *    exactly) and a lit closed box (no closed form);
 *  - emitters 1e6 and 1e-6 bright in one scene: two closed rooms in one
 *    matrix, unconnected and weakly connected, and one open room;
 *  - patches with rho = 0 (black lights, a black floor patch): B = E
 *    exactly;
 *  - every method (jacobi, gauss-seidel, cg, auto), grey and coloured
 *    materials, through the whole stage (file in, radiosity file out).
 *
 * Stated tolerances (tol = SOLVE_DEFAULT_TOLERANCE = 1e-10):
 *  - every B finite and >= 0; rho_i = 0 => B_i == E_i bit for bit;
 *  - every channel converged: residual <= tol, converged flag set;
 *  - per patch: |B_i - B*_i| <= 2 tol a_i + 4 eps |B*_i|, where B* is the
 *    direct solve and a = (I - diag(rho)F)^-1 min(||E||_inf, B*) is what
 *    the stopping rule guarantees (docs/solve.md: |r_i| <= tol
 *    min(||E||_inf, s_i) and s_i -> B*_i; 2 covers rounding of the
 *    residual); a patch with B*_i = 0 must be exactly 0;
 *  - on these scenes that is a relative error of at most 2 tol / (1 - 0.999)
 *    = 2e-7 per patch, also checked (HARD_MAX_REL_ERROR);
 *  - furnace: |B_i - E/(1 - rho)| <= 2 tol E/(1 - rho) (as test_solve).
 *
 * usage: test_solve_hard [DIR]   DIR receives the files (default: a new
 * directory under /tmp).
 */
#define _POSIX_C_SOURCE 200809L
#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "rad_rfile.h"
#include "rad_test.h"
#include "solver.h"
#include "stage.h"
#include "test_solve_fixtures.h"

#define HARD_TOL SOLVE_DEFAULT_TOLERANCE
#define HARD_MAX_REL_ERROR (2 * HARD_TOL / (1 - 0.999))
#define HARD_BRIGHT 1e6
#define HARD_DIM 1e-6
/* A_i F_ij between the rooms of the weakly connected case: the bright
 * room then adds a few per cent to the dim room's light. */
#define HARD_COUPLING 1e-12

static char g_dir[1024];

static const char *path_in_dir(const char *name)
{
    static char buf[4][2200];
    static int next;
    char *p = buf[next++ % 4];
    int len = snprintf(p, sizeof buf[0], "%s/%s", g_dir, name);
    RAD_CHECK(len > 0 && (size_t)len < sizeof buf[0]);
    return p;
}

static const solve_method hard_methods[4] = {SOLVE_JACOBI, SOLVE_GAUSS_SEIDEL, SOLVE_CG, SOLVE_AUTO};

/* ---- scenes ---- */

typedef struct hard_scene {
    const char *name; /* names the files and the printed lines */
    solve_fx_scene fx;
    int furnace; /* uniform rho and E per channel in a closed scene */
} hard_scene;

static void set_material(solve_fx_scene *s, size_t i, const double rho[3], const double emission[3])
{
    for (int c = 0; c < 3; c++) {
        s->mesh.patches[i].rho[c] = rho[c];
        s->mesh.patches[i].emission[c] = emission[c];
    }
}

/* Index of cell (cu, cv) of face f in a solve_fx_box scene. */
static size_t box_patch(const solve_fx_box_spec *spec, int f, int cu, int cv)
{
    int before = f - (spec->open_face >= 0 && spec->open_face < f ? 1 : 0);
    return ((size_t)before * (size_t)spec->cells + (size_t)cu) * (size_t)spec->cells + (size_t)cv;
}

static void fill3(double out[3], double r, double g, double b)
{
    out[0] = r;
    out[1] = g;
    out[2] = b;
}

/* A closed box, rho and E the same on every patch (per channel). */
static int make_furnace(int grey, hard_scene *out)
{
    solve_fx_box_spec spec = {.cells = 3, .light_face = -1, .open_face = -1};
    double rho[3], e[3];
    if (grey) {
        fill3(rho, 0.999, 0.999, 0.999);
        fill3(e, 1, 1, 1);
    } else {
        fill3(rho, 0.999, 0.9, 0.5);
        fill3(e, 1, HARD_BRIGHT, HARD_DIM);
    }
    for (int f = 0; f < 6; f++) {
        memcpy(spec.rho[f], rho, sizeof rho);
        memcpy(spec.emission[f], e, sizeof e);
    }
    out->name = grey ? "furnace-0.999-grey" : "furnace-0.999-colour";
    out->furnace = 1;
    return solve_fx_box(&spec, &out->fx);
}

/* A closed box at rho = 0.999 lit by its ceiling light. */
static int make_lit_box(int grey, hard_scene *out)
{
    solve_fx_box_spec spec = {.cells = 4, .light_face = 5, .open_face = -1};
    for (int f = 0; f < 6; f++) {
        if (grey)
            fill3(spec.rho[f], 0.999, 0.999, 0.999);
        else
            fill3(spec.rho[f], 0.999, f == 0 ? 0.3 : 0.99, f == 1 ? 0.2 : 0.9);
    }
    fill3(spec.light_rho, 0.999, grey ? 0.999 : 0.5, grey ? 0.999 : 0);
    fill3(spec.light_emission, 1, grey ? 1 : HARD_BRIGHT, grey ? 1 : HARD_DIM);
    out->name = grey ? "lit-box-0.999-grey" : "lit-box-0.999-colour";
    out->furnace = 0;
    return solve_fx_box(&spec, &out->fx);
}

/* Two closed rooms in one matrix: a black 1e6 light over rho = 0.5 walls,
 * and a 1e-6 light (rho 0.8) over rho = 0.999 walls with one black floor
 * patch. coupled: two wall patches, one per room, exchange a little light
 * (HARD_COUPLING), so the matrix is connected. */
static int make_two_rooms(int grey, int coupled, hard_scene *out)
{
    solve_fx_box_spec bright = {.cells = 3, .light_face = 5, .open_face = -1};
    solve_fx_box_spec dim = bright;
    for (int f = 0; f < 6; f++) {
        if (grey) {
            fill3(bright.rho[f], 0.5, 0.5, 0.5);
            fill3(dim.rho[f], 0.999, 0.999, 0.999);
        } else {
            fill3(bright.rho[f], 0.5, 0.7, 0.3);
            fill3(dim.rho[f], 0.999, 0.9, 0.99);
        }
    }
    fill3(bright.light_rho, 0, 0, 0);
    fill3(bright.light_emission, HARD_BRIGHT, HARD_BRIGHT, grey ? HARD_BRIGHT : 2 * HARD_BRIGHT);
    fill3(dim.light_rho, 0.8, 0.8, grey ? 0.8 : 0.6);
    fill3(dim.light_emission, HARD_DIM, HARD_DIM, grey ? HARD_DIM : 3 * HARD_DIM);
    solve_fx_scene a, b;
    int ok = solve_fx_box(&bright, &a);
    ok = ok && solve_fx_box(&dim, &b);
    if (ok) {
        const double black[3] = {0, 0, 0};
        set_material(&b, box_patch(&dim, 4, 0, 0), black, black);
        ok = solve_fx_join(&a, &b, 2.0, &out->fx);
    }
    if (ok && coupled) /* a side wall of each room */
        solve_fx_couple(&out->fx, box_patch(&bright, 1, 1, 1), a.mesh.patch_count + box_patch(&dim, 0, 1, 1),
                        HARD_COUPLING);
    solve_fx_free(&a);
    solve_fx_free(&b);
    static const char *const names[2][2] = {{"two-rooms-apart-colour", "two-rooms-apart-grey"},
                                            {"two-rooms-coupled-colour", "two-rooms-coupled-grey"}};
    out->name = names[coupled != 0][grey != 0];
    out->furnace = 0;
    return ok;
}

/* One open room (no wall at y = 0): a black 1e6 ceiling light, a 1e-6
 * emitter (rho 0.5) and a black patch on the floor. */
static int make_open_room(int grey, hard_scene *out)
{
    solve_fx_box_spec spec = {.cells = 4, .light_face = 5, .open_face = 2};
    for (int f = 0; f < 6; f++) {
        if (grey)
            fill3(spec.rho[f], 0.725, 0.725, 0.725);
        else if (f == 0)
            fill3(spec.rho[f], 0.63, 0.065, 0.05);
        else if (f == 1)
            fill3(spec.rho[f], 0.14, 0.45, 0.091);
        else
            fill3(spec.rho[f], 0.725, 0.71, 0.68);
    }
    fill3(spec.light_rho, 0, 0, 0);
    fill3(spec.light_emission, HARD_BRIGHT, HARD_BRIGHT, HARD_BRIGHT);
    int ok = solve_fx_box(&spec, &out->fx);
    if (ok) {
        double rho[3], e[3];
        fill3(rho, 0.5, 0.5, 0.5);
        fill3(e, HARD_DIM, HARD_DIM, HARD_DIM);
        set_material(&out->fx, box_patch(&spec, 4, 0, 0), rho, e);
        fill3(rho, 0, 0, 0);
        fill3(e, 0, 0, 0);
        set_material(&out->fx, box_patch(&spec, 4, 3, 3), rho, e);
    }
    out->name = grey ? "open-room-grey" : "open-room-colour";
    out->furnace = 0;
    return ok;
}

/* ---- the reference ---- */

/* Per channel: B* by the direct solve, and the per-patch error allowance
 * 2 tol a_i + 4 eps |B*_i| with a = (I - diag(rho)F)^-1 min(||E||, B*). */
typedef struct hard_reference {
    double *exact[3], *allowed[3];
} hard_reference;

static void hard_reference_free(hard_reference *ref)
{
    for (int c = 0; c < 3; c++) {
        free(ref->exact[c]);
        free(ref->allowed[c]);
    }
    memset(ref, 0, sizeof *ref);
}

static int hard_reference_make(const solve_fx_scene *s, hard_reference *out)
{
    const size_t n = s->mesh.patch_count;
    memset(out, 0, sizeof *out);
    double *rho = malloc(n * sizeof(double)), *e = malloc(n * sizeof(double)), *capped = malloc(n * sizeof(double));
    int ok = rho && e && capped;
    for (int c = 0; ok && c < 3; c++) {
        out->exact[c] = malloc(n * sizeof(double));
        out->allowed[c] = malloc(n * sizeof(double));
        ok = out->exact[c] && out->allowed[c];
        double e_norm = 0;
        for (size_t i = 0; ok && i < n; i++) {
            rho[i] = s->mesh.patches[i].rho[c];
            e[i] = s->mesh.patches[i].emission[c];
            e_norm = fmax(e_norm, e[i]);
        }
        ok = ok && solve_fx_direct(n, s->F, rho, e, out->exact[c]);
        for (size_t i = 0; ok && i < n; i++) capped[i] = fmin(e_norm, out->exact[c][i]);
        ok = ok && solve_fx_direct(n, s->F, rho, capped, out->allowed[c]);
        for (size_t i = 0; ok && i < n; i++)
            out->allowed[c][i] = 2 * HARD_TOL * out->allowed[c][i] + 4 * DBL_EPSILON * fabs(out->exact[c][i]);
    }
    free(rho);
    free(e);
    free(capped);
    if (!ok) hard_reference_free(out);
    return ok;
}

/* ---- checking one channel of one solve ---- */

typedef struct hard_worst {
    double rel_error;      /* max_i |B_i - B*_i| / B*_i */
    size_t patch;          /* where */
    double rel_allowed;    /* max_i allowed_i / B*_i */
    double allowance_used; /* max_i |B_i - B*_i| / allowed_i (must be <= 1) */
} hard_worst;

static hard_worst check_channel(const hard_scene *hs, int c, const double *B, size_t stride,
                                const hard_reference *ref, const char *what)
{
    const solve_fx_scene *s = &hs->fx;
    const size_t n = s->mesh.patch_count;
    hard_worst w = {0, 0, 0, 0};
    int finite = 1, non_negative = 1, black_exact = 1, within = 1, zero_exact = 1, furnace_ok = 1;
    for (size_t i = 0; i < n; i++) {
        const rad_patch *p = &s->mesh.patches[i];
        double b = B[i * stride], exact = ref->exact[c][i], allowed = ref->allowed[c][i];
        finite &= isfinite(b);
        non_negative &= b >= 0;
        if (p->rho[c] == 0) black_exact &= b == p->emission[c];
        if (exact == 0) {
            zero_exact &= b == 0;
            continue;
        }
        double err = fabs(b - exact);
        within &= err <= allowed;
        w.allowance_used = fmax(w.allowance_used, err / allowed);
        if (err / exact > w.rel_error) {
            w.rel_error = err / exact;
            w.patch = i;
        }
        w.rel_allowed = fmax(w.rel_allowed, allowed / exact);
        if (hs->furnace) {
            double identity = p->emission[c] / (1 - p->rho[c]);
            furnace_ok &= fabs(b - identity) <= 2 * HARD_TOL * identity;
        }
    }
    fflush(stdout);
    if (!(finite && non_negative && black_exact && zero_exact && within && furnace_ok &&
          w.rel_error <= HARD_MAX_REL_ERROR))
        fprintf(stderr,
                "%s: finite %d, >= 0 %d, black B == E %d, zero %d, within allowance %d, furnace %d, "
                "worst rel error %.3g at patch %zu (B %.17g, direct %.17g)\n",
                what, finite, non_negative, black_exact, zero_exact, within, furnace_ok, w.rel_error, w.patch,
                B[w.patch * stride], ref->exact[c][w.patch]);
    RAD_CHECK(finite && non_negative);
    RAD_CHECK(black_exact && zero_exact);
    RAD_CHECK(within);
    RAD_CHECK(w.rel_error <= HARD_MAX_REL_ERROR);
    RAD_CHECK(furnace_ok);
    return w;
}

/* ---- one scene, every method, through the stage ---- */

static void run_scene(hard_scene *hs)
{
    const solve_fx_scene *s = &hs->fx;
    hard_reference ref;
    RAD_CHECK(hard_reference_make(s, &ref));
    if (!ref.exact[0]) return;
    char ff_name[96];
    snprintf(ff_name, sizeof ff_name, "%s.ff", hs->name);
    RAD_CHECK(solve_fx_write(path_in_dir(ff_name), s, RAD_ELEMENT_F64) == RAD_OK);
    int grey = 1;
    for (size_t i = 0; i < s->mesh.patch_count; i++) {
        const rad_patch *p = &s->mesh.patches[i];
        grey &= p->rho[0] == p->rho[1] && p->rho[1] == p->rho[2] && p->emission[0] == p->emission[1] &&
                p->emission[1] == p->emission[2];
    }
    for (int m = 0; m < 4; m++) {
        char rad_name[128], what[160];
        snprintf(rad_name, sizeof rad_name, "%s-%s.rad", hs->name, solve_method_name(hard_methods[m]));
        solve_options opt = {.input = path_in_dir(ff_name), .output = path_in_dir(rad_name),
                             .params = {.method = hard_methods[m], .tolerance = HARD_TOL}};
        rad_status st = solve_stage_run(&opt);
        RAD_CHECK(st == RAD_OK);
        rad_radiosity r;
        if (st != RAD_OK || rad_rf_read(opt.output, &r) != RAD_OK) {
            RAD_CHECK(0);
            continue;
        }
        RAD_CHECK(r.converged == 1 && r.channel_count == (grey ? 1u : 3u));
        for (uint32_t c = 0; c < 3; c++) {
            uint32_t k = grey ? 0 : c; /* a grey file reports one channel */
            snprintf(what, sizeof what, "%s %s channel %u", hs->name, solve_method_name(hard_methods[m]), c);
            RAD_CHECK(r.residual[k] <= HARD_TOL);
            hard_worst w = check_channel(hs, (int)c, r.radiosity + c, 3, &ref, what);
            /* CG may hand over to Gauss-Seidel (docs/solve.md); nothing else */
            solve_method used = (solve_method)r.channel_method[k];
            int cg_asked = hard_methods[m] == SOLVE_CG || hard_methods[m] == SOLVE_AUTO;
            RAD_CHECK(used == hard_methods[m] || (cg_asked && (used == SOLVE_CG || used == SOLVE_GAUSS_SEIDEL)));
            if (grey && c > 0) continue;
            printf("%-24s %-12s ch %u: %-12s %6u it, omega %.1e, worst rel error %.1e (B* %8.2e), "
                   "max rel allowed %.1e, allowance used %.2f\n",
                   hs->name, solve_method_name(hard_methods[m]), c, solve_method_name(used), r.iterations[k],
                   r.residual[k], w.rel_error, ref.exact[c][w.patch], w.rel_allowed, w.allowance_used);
        }
        rad_radiosity_free(&r);
    }
    hard_reference_free(&ref);
}

/* The reference itself: the direct solve meets the furnace identity and
 * two-squares closed forms (test_solve), so its answers can be trusted. */
static void test_direct_solve(void)
{
    hard_scene hs;
    RAD_CHECK(make_furnace(1, &hs));
    size_t n = hs.fx.mesh.patch_count;
    double *rho = malloc(n * sizeof(double)), *e = malloc(n * sizeof(double)), *x = malloc(n * sizeof(double));
    for (size_t i = 0; i < n; i++) {
        rho[i] = 0.999;
        e[i] = 1;
    }
    RAD_CHECK(solve_fx_direct(n, hs.fx.F, rho, e, x));
    double worst = 0;
    for (size_t i = 0; i < n; i++) worst = fmax(worst, fabs(x[i] - 1000) / 1000);
    printf("direct solve, furnace rho = 0.999: max rel error %.2e\n", worst);
    RAD_CHECK(worst <= 1e-12); /* rows sum to 1 within ~2e-15, amplified by 1/(1 - rho) */
    free(rho);
    free(e);
    free(x);
    solve_fx_free(&hs.fx);

    solve_fx_scene sq;
    RAD_CHECK(solve_fx_two_squares(0.5, 2.0, &sq));
    double r2[2] = {0.5, 0.5}, e2[2] = {2, 0}, b[2], f = 0.199824895698;
    RAD_CHECK(solve_fx_direct(2, sq.F, r2, e2, b));
    RAD_CHECK_REL(b[0], 2.0 / (1 - 0.25 * f * f), 1e-11);
    RAD_CHECK_REL(b[1], 0.5 * f * b[0], 1e-11);
    solve_fx_free(&sq);
}

static void test_scenes(void)
{
    for (int grey = 1; grey >= 0; grey--) {
        hard_scene scenes[5];
        int made = 0;
        RAD_CHECK(make_furnace(grey, &scenes[made++]));
        RAD_CHECK(make_lit_box(grey, &scenes[made++]));
        RAD_CHECK(make_two_rooms(grey, 0, &scenes[made++]));
        RAD_CHECK(make_two_rooms(grey, 1, &scenes[made++]));
        RAD_CHECK(make_open_room(grey, &scenes[made++]));
        for (int k = 0; k < made; k++) {
            run_scene(&scenes[k]);
            solve_fx_free(&scenes[k].fx);
        }
    }
}

int main(int argc, char **argv)
{
    if (!solve_fx_work_dir(argc, argv, "test_solve_hard", g_dir, sizeof g_dir)) return 1;
    rad_log_set_level(RAD_LOG_WARN);
    test_direct_solve();
    test_scenes();
    return rad_test_finish();
}
