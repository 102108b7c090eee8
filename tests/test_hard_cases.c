/* test_hard_cases.c - geometry that breaks naive form-factor code, through
 * every estimator (mc, qmc, auto, analytic, quadrature) on the CPU backend.
 * The quadrature estimator is held to the closed forms at 1e-8 relative
 * (1e-6 for the far tiny pair, whose reference formula is itself good to
 * (s/d)^2 = 1e-8).
 *
 * For every case and estimator: every entry finite and >= 0, F_ii = 0,
 * every row sum <= 1 + 0.02 (two-patch scenes: well below 1 physically;
 * 0.02 allows the Monte Carlo noise of the worst case, the shared edge at
 * 10 degrees, measured 0.006 over three seeds), A_i F_ij = A_j F_ji to
 * 1e-12 (reported), and occluded F never above unoccluded F. Cases with a
 * closed form or a tight physical bound check it too, each with the
 * tolerance stated where it is asserted.
 */
#include <stdio.h>

#include "ff_fixture.h"
#include "rad_test.h"

static const rad_estimator_id ESTIMATORS[] = {RAD_ESTIMATOR_MC, RAD_ESTIMATOR_QMC, RAD_ESTIMATOR_AUTO,
                                              RAD_ESTIMATOR_ANALYTIC, RAD_ESTIMATOR_QUADRATURE};
static const char *const ESTIMATOR_NAMES[] = {"mc", "qmc", "auto", "analytic", "quadrature"};
enum { ESTIMATOR_COUNT = sizeof ESTIMATORS / sizeof *ESTIMATORS };

typedef struct hard_case {
    const char *name;
    char obj[1024];
} hard_case;

/* Two unit squares sharing the edge x = 0..1 on the x axis: A in the plane
 * z = 0 (normal +z), B hinged at angle `degrees` between the two (180 = flat,
 * 90 = perpendicular, small = a sharp wedge), facing A. */
static void make_wedge(hard_case *c, const char *name, double degrees)
{
    double a = degrees * RAD_PI / 180.0;
    double y = cos(a), z = sin(a);
    c->name = name;
    snprintf(c->obj, sizeof c->obj,
             "mtllib s.mtl\nusemtl grey\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n"
             "v 0 %.17g %.17g\nv 1 %.17g %.17g\nf 1 5 6 2\n",
             y, z, y, z);
}

/* Two squares of side s, parallel and facing, at distance d (centred). */
static void make_parallel(hard_case *c, const char *name, double s, double d)
{
    c->name = name;
    snprintf(c->obj, sizeof c->obj,
             "mtllib s.mtl\nusemtl grey\nv 0 0 0\nv %.17g 0 0\nv %.17g %.17g 0\nv 0 %.17g 0\nf 1 2 3 4\n"
             "v 0 0 %.17g\nv 0 %.17g %.17g\nv %.17g %.17g %.17g\nv %.17g 0 %.17g\nf 5 6 7 8\n",
             s, s, s, s, d, s, d, s, s, d, s, d);
}

/* expect < 0: no closed form; else F_01 within rel_tol[estimator] of it
 * (rel_tol 0: not checked for that estimator). */
static int run_case(const hard_case *c, double expect, const double rel_tol[ESTIMATOR_COUNT])
{
    fixture fx;
    int ok = fixture_load(&fx, c->obj, "s.obj", 0);
    RAD_CHECK(ok);
    if (!ok) return 0;
    uint32_t n = (uint32_t)fx.mesh.patch_count;
    for (size_t e = 0; e < sizeof ESTIMATORS / sizeof *ESTIMATORS; e++) {
        double *with = compute_estimator(&ff_backend_cpu, &fx, 4096, 64, 1, ESTIMATORS[e], NULL);
        double *without = compute_estimator(&ff_backend_cpu, &fx, 4096, 0, 1, ESTIMATORS[e], NULL);
        RAD_CHECK(with && without);
        if (!with || !without) continue;
        double worst_row = 0, recip = 0, largest = 0;
        int bad = 0;
        for (uint32_t i = 0; i < n; i++) {
            double row = 0, ai = fx.mesh.patches[i].area;
            for (uint32_t j = 0; j < n; j++) {
                double f = with[i * n + j];
                bad += !isfinite(f) || f < 0 || f > without[i * n + j];
                row += f;
                largest = fmax(largest, ai * f);
                recip = fmax(recip, fabs(ai * f - fx.mesh.patches[j].area * with[j * n + i]));
            }
            bad += with[i * n + i] != 0;
            worst_row = fmax(worst_row, row);
        }
        double rel_recip = largest > 0 ? recip / largest : 0;
        fprintf(stderr, "%-28s %-10s F_01 = %.12g  max row sum %.6f  reciprocity %.1e\n", c->name, ESTIMATOR_NAMES[e],
                with[1], worst_row, rel_recip);
        RAD_CHECK(bad == 0);
        RAD_CHECK(worst_row <= 1.02);
        RAD_CHECK(rel_recip <= 1e-12);
        if (expect >= 0 && rel_tol[e] > 0) RAD_CHECK_NEAR(with[1], expect, rel_tol[e] * expect);
        free(with);
        free(without);
    }
    fixture_free(&fx);
    return 1;
}

int main(void)
{
    hard_case c;
    static const double none[ESTIMATOR_COUNT] = {0, 0, 0, 0, 0};

    /* Shared edges: the 1/r^2 singularity. Closed form for two unit squares
     * at 90 degrees: 0.200044. Point pairs are heavy-tailed there (mc at
     * 4096 samples, seed 1: -7 %; qmc +3 %), the near-field estimator is
     * not: 10 % / 5 % / 2 % / 2 % for mc / qmc / auto / analytic. */
    static const double edge_tol[ESTIMATOR_COUNT] = {0.10, 0.05, 0.02, 0.02, 1e-8};
    make_wedge(&c, "shared edge, 90 deg", 90);
    run_case(&c, 0.20004377607540315, edge_tol);
    /* Sharp wedge (10 deg): most of what leaves A lands on B. Bound only. */
    make_wedge(&c, "shared edge, 10 deg", 10);
    run_case(&c, -1, none);
    /* Shallow (170 deg, nearly flat): little exchange, still finite. */
    make_wedge(&c, "shared edge, 170 deg", 170);
    run_case(&c, -1, none);
    /* Nearly coplanar: hinged at 180 - 1e-6 rad. True F ~ 1e-7; must not
     * blow up (it may be culled as coplanar: 0 is fine). */
    make_wedge(&c, "nearly coplanar (1e-6 rad)", 180.0 - 1e-6 * 180.0 / RAD_PI);
    run_case(&c, -1, none);

    /* Shared corner only: A in z = 0, B in x = 0 above the corner (0,0,0)
     * but offset so only that vertex is common. */
    c.name = "shared corner only";
    snprintf(c.obj, sizeof c.obj,
             "mtllib s.mtl\nusemtl grey\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n"
             "v 0 0 0\nv 0 -1 0\nv 0 -1 1\nv 0 0 1\nf 5 8 7 6\n");
    run_case(&c, -1, none);

    /* Far, tiny: squares of side 0.01 at distance 100: F = A cos cos / (pi r^2)
     * = 1e-4 / (pi 1e4) = 3.1831e-9 to 1e-8 relative; checked to 1 %. */
    make_parallel(&c, "far tiny (F ~ 3e-9)", 0.01, 100);
    static const double far_tol[ESTIMATOR_COUNT] = {0.01, 0.01, 0.01, 0.01, 1e-6};
    run_case(&c, 1e-4 / (RAD_PI * 1e4), far_tol);

    /* Area ratio 1e6: a 1e-3 square under a unit square at distance 1,
     * centred: F(small -> big) = the point-to-square factor 0.239456 (1 %). */
    c.name = "area ratio 1e6";
    snprintf(c.obj, sizeof c.obj,
             "mtllib s.mtl\nusemtl grey\nv 0.4995 0.4995 0\nv 0.5005 0.4995 0\nv 0.5005 0.5005 0\nv 0.4995 0.5005 0\n"
             "f 1 2 3 4\nv 0 0 1\nv 0 1 1\nv 1 1 1\nv 1 0 1\nf 5 6 7 8\n");
    static const double ratio_tol[ESTIMATOR_COUNT] = {0.01, 0.01, 0.01, 0.01, 1e-8};
    run_case(&c, 0.23945642489633106, ratio_tol);

    /* Thin strip (1 x 0.001) beside a tall wall (1 x 100), sharing the
     * strip's long edge: F(strip -> wall) = 0.498661856216 (catalogue
     * C-14, W = 0.001, H = 100, in 30 digits). Point pairs
     * cannot see it (the integrand lives in the wall's bottom 0.001: mc
     * gives 0.0008, qmc 0.003 - a known limit, not checked); auto and
     * analytic must, to 2 %; quadrature to 1e-8. */
    static const double strip_tol[ESTIMATOR_COUNT] = {0, 0, 0.02, 0.02, 1e-8};
    c.name = "thin strip by tall wall";
    snprintf(c.obj, sizeof c.obj,
             "mtllib s.mtl\nusemtl grey\nv 0 0 0\nv 1 0 0\nv 1 0.001 0\nv 0 0.001 0\nf 1 2 3 4\n"
             "v 0 0 100\nv 1 0 100\nf 1 5 6 2\n");
    run_case(&c, 0.498661856216165576, strip_tol);

    /* Sliver triangles (aspect 1e-4) facing each other at distance 0.1. */
    c.name = "slivers (aspect 1e-4)";
    snprintf(c.obj, sizeof c.obj,
             "mtllib s.mtl\nusemtl grey\nv 0 0 0\nv 1 0 0\nv 0.5 0.0001 0\nf 1 2 3\n"
             "v 0 0 0.1\nv 0.5 0.0001 0.1\nv 1 0 0.1\nf 4 5 6\n");
    run_case(&c, -1, none);

    /* Grazing: B stands perpendicular to A's plane far out along it, so
     * rays leave A at almost 90 degrees from its normal. */
    c.name = "grazing";
    snprintf(c.obj, sizeof c.obj,
             "mtllib s.mtl\nusemtl grey\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n"
             "v 50 0 0\nv 50 0 0.01\nv 50 1 0.01\nv 50 1 0\nf 5 6 7 8\n");
    run_case(&c, -1, none);
    return rad_test_finish();
}
