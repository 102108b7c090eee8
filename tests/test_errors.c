/* test_errors.c - the per-entry standard errors and --target-error.
 *
 * The reported standard error is checked against the spread of the
 * estimate over independent seeds (the thing it claims to predict), for
 * unoccluded and half-occluded pairs and each estimator; --target-error
 * must bring every entry to the target (or report it capped), and the
 * result must still match the closed form within a few targets.
 */
#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "ff_fixture.h"
#include "ff_links.h"
#include "rad_ff_quad.h"
#include "rad_test.h"

/* The parallel unit squares with a plate over half of the gap. */
static const char *const half_blocked_obj =
    "mtllib s.mtl\nusemtl grey\n"
    "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n"
    "v 0 0 1\nv 0 1 1\nv 1 1 1\nv 1 0 1\nf 5 6 7 8\n"
    "v -0.5 -0.5 0.5\nv 0.5 -0.5 0.5\nv 0.5 1.5 0.5\nv -0.5 1.5 0.5\nf 9 10 11 12\n";

/* F_01 and its standard error for one seed; counters added to *c. */
static int estimate(const fixture *fx, rad_estimator_id estimator, uint32_t samples, uint32_t rays, uint64_t seed,
                    double target, double *f01, double *se01, ff_counters *c)
{
    uint32_t n = (uint32_t)fx->mesh.patch_count;
    double eps = ff_plane_eps(&fx->mesh);
    ff_setup su = {.patches = fx->patches, .patch_count = n, .triangles = fx->triangles,
                   .triangle_face = fx->triangle_face, .triangle_count = fx->triangle_count, .samples = samples,
                   .shadow_rays = rays, .seed = seed, .estimator = estimator, .plane_eps = eps, .threads = 1,
                   .target_error = target, .max_samples = 64 * samples, .cull = 1,
                   .scene_convex = ff_scene_is_convex_enclosure(&fx->scene, eps), .cull_margin = ff_cull_margin(&fx->mesh, fx->centre, eps), .ray_delta = ff_ray_delta(&fx->mesh)};
    double *f = malloc(sizeof(double) * n * n), *e = malloc(sizeof(double) * n * n);
    void *state = NULL;
    int ok = f && e && ff_backend_cpu.create(&su, &state) == RAD_OK;
    if (ok) {
        ok = ff_backend_cpu.compute_rows(state, 0, n, f, e, c) == RAD_OK;
        ff_backend_cpu.destroy(state);
    }
    if (ok) {
        to_form_factors(fx, f, e);
        *f01 = f[1];
        *se01 = e[1];
        RAD_CHECK(isfinite(e[1]) && e[1] >= 0 && e[0] == 0);
        RAD_CHECK(fabs(e[1] - e[n]) <= 1e-12 * e[1]); /* equal areas: equal errors */
    }
    free(f);
    free(e);
    return ok;
}

/* Over SEEDS independent runs: the mean reported standard error against
 * the standard deviation of the estimates. With 256 seeds the latter is
 * itself known to about 4.4 % (1 / sqrt(2 * 256)), so a ratio within
 * [lo, hi] is a real check. */
static void check_calibration(const char *name, const char *obj, rad_estimator_id estimator, uint32_t samples,
                              uint32_t rays, double lo, double hi)
{
    enum { SEEDS = 256 };
    fixture fx;
    RAD_CHECK(fixture_load(&fx, obj, "s.obj", 0));
    double sum = 0, sum2 = 0, se_sum = 0;
    for (uint64_t seed = 1; seed <= SEEDS; seed++) {
        double f = 0, se = 0;
        ff_counters c = {0};
        RAD_CHECK(estimate(&fx, estimator, samples, rays, seed, 0, &f, &se, &c));
        sum += f;
        sum2 += f * f;
        se_sum += se;
    }
    double mean = sum / SEEDS, spread = sqrt((sum2 - sum * sum / SEEDS) / (SEEDS - 1));
    double reported = se_sum / SEEDS;
    fprintf(stderr, "%s: F = %.6f, spread over seeds %.3g, mean reported error %.3g (ratio %.2f)\n", name, mean,
            spread, reported, reported / spread);
    RAD_CHECK(reported > lo * spread && reported < hi * spread);
    fixture_free(&fx);
}

/* --target-error: the entry reaches the target with more samples than
 * its first batch, and lands within 4 targets of the exact value. */
static void check_target(const char *name, const char *obj, rad_estimator_id estimator, double exact, double target)
{
    fixture fx;
    RAD_CHECK(fixture_load(&fx, obj, "s.obj", 0));
    double f = 0, se = 0;
    ff_counters c = {0};
    RAD_CHECK(estimate(&fx, estimator, 64, 0, 7, target, &f, &se, &c));
    fprintf(stderr, "%s: --target-error %.1e: F = %.6f (exact %.6f), error %.2e, %llu samples, %llu refined, %llu capped\n",
            name, target, f, exact, se, (unsigned long long)c.samples, (unsigned long long)c.pairs_refined,
            (unsigned long long)c.pairs_capped);
    RAD_CHECK(se <= target && c.pairs_capped == 0 && c.pairs_refined == 2); /* rows 0 and 1 */
    RAD_CHECK(c.samples > 2 * 64);
    RAD_CHECK_NEAR(f, exact, 4 * target);
    fixture_free(&fx);
}

/* A cap below what the target needs: stopped there, and reported. */
static void check_cap(void)
{
    fixture fx;
    RAD_CHECK(fixture_load(&fx, parallel_obj, "s.obj", 0));
    double f = 0, se = 0;
    ff_counters c = {0};
    RAD_CHECK(estimate(&fx, RAD_ESTIMATOR_MC, 16, 0, 3, 1e-9, &f, &se, &c));
    /* Both rows compute the pair (no pairs_once here): 2 x the cap of 64 x 16. */
    RAD_CHECK(c.pairs_capped == 2 && se > 1e-9);
    RAD_CHECK(c.samples == 2 * 64 * 16);
    fixture_free(&fx);
}

/* The oracle's ray floor (ff_pair_job.ray_floor): jobs[] as `link` had
 * them (no floor) computed again with a floor, a coupling error the rays
 * need not go below. Without limit every traced pair keeps its first
 * batch (R = 32 rays), partly hidden ones too; at a floor of 1e-2 of the largest
 * coupling the rays fall between, and each coupling stays within three
 * of both errors of the one without a floor. */
static void check_ray_floor(void *state, const fixture *fx, const uint32_t *keys, ff_pair_job *jobs, size_t count,
                            const ff_pair_outcome *link, const ff_counters *c_link)
{
    ff_pair_outcome *out = malloc(sizeof(ff_pair_outcome) * count);
    RAD_CHECK(out != NULL);
    ff_counters c_none = {0}, c_some = {0};
    for (size_t k = 0; k < count; k++) jobs[k].ray_floor = FLT_MAX;
    RAD_CHECK(ff_backend_cpu.compute_pairs(state, fx->patches, keys, jobs, count, out, &c_none) == RAD_OK);
    int first_batch = 1, partial = 0;
    for (size_t k = 0; k < count; k++) {
        first_batch &= out[k].rays == 0 || out[k].rays == 32;
        partial += out[k].rays_blocked > 0 && out[k].rays_blocked < out[k].rays;
    }
    double scale = 0;
    for (size_t k = 0; k < count; k++) scale = fmax(scale, link[k].coupling);
    for (size_t k = 0; k < count; k++) jobs[k].ray_floor = (float)(1e-2 * scale);
    RAD_CHECK(ff_backend_cpu.compute_pairs(state, fx->patches, keys, jobs, count, out, &c_some) == RAD_OK);
    int close = 1;
    for (size_t k = 0; k < count; k++)
        close &= fabs(out[k].coupling - link[k].coupling) <= 3.0 * (out[k].error + link[k].error) + 1e-15;
    fprintf(stderr, "ray floor: %llu rays without a floor, %llu at 1e-2 of the largest coupling, %llu without "
            "limit (%d pairs partly hidden in their first batch)\n", (unsigned long long)c_link->rays,
            (unsigned long long)c_some.rays, (unsigned long long)c_none.rays, partial);
    RAD_CHECK(first_batch && partial > 0);
    RAD_CHECK(c_none.rays < c_some.rays && c_some.rays < c_link->rays);
    RAD_CHECK(close);
    for (size_t k = 0; k < count; k++) jobs[k].ray_floor = 0.0f;
    free(out);
}

/* A hierarchy's pairs (compute_pairs): as matrix entries (--link-tol 0)
 * they are the full matrix's entries to the bit; estimated for the link
 * oracle (under a link tolerance: ff_links_quad_rtol) with fewer
 * quadrature points, each coupling within 1e-4 of the entry's, and within
 * both their errors. */
static void check_link_pairs(void)
{
    fixture fx;
    RAD_CHECK(fixture_load(&fx, half_blocked_obj, "s.obj", 2));
    const uint32_t n = (uint32_t)fx.mesh.patch_count;
    double eps = ff_plane_eps(&fx.mesh);
    ff_setup su = {.patches = fx.patches, .patch_count = n, .triangles = fx.triangles,
                   .triangle_face = fx.triangle_face, .triangle_count = fx.triangle_count, .samples = 512,
                   .shadow_rays = 32, .seed = 1, .estimator = RAD_ESTIMATOR_QUADRATURE,
                   .quad_rtol = RAD_FF_QUAD_RTOL, .quad_atol = RAD_FF_QUAD_ATOL, .plane_eps = eps, .threads = 2,
                   .max_samples = 64 * 512, .cull = 1, .scene_convex = ff_scene_is_convex_enclosure(&fx.scene, eps),
                   .cull_margin = ff_cull_margin(&fx.mesh, fx.centre, eps), .ray_delta = ff_ray_delta(&fx.mesh)};
    double *rows = malloc(sizeof(double) * n * n), *errors = malloc(sizeof(double) * n * n);
    uint32_t *keys = malloc(sizeof(uint32_t) * n);
    ff_pair_job *jobs = malloc(sizeof(ff_pair_job) * n * n);
    ff_pair_outcome *entry = malloc(sizeof(ff_pair_outcome) * n * n), *link = malloc(sizeof(ff_pair_outcome) * n * n);
    void *state = NULL, *oracle_state = NULL;
    ff_counters c = {0}, c_entry = {0}, c_link = {0};
    RAD_CHECK(rows && errors && keys && jobs && entry && link && ff_backend_cpu.create(&su, &state) == RAD_OK);
    su.quad_rtol = ff_links_quad_rtol(1e-2, su.quad_rtol);
    RAD_CHECK(ff_backend_cpu.create(&su, &oracle_state) == RAD_OK);
    RAD_CHECK(ff_backend_cpu.compute_rows(state, 0, n, rows, errors, &c) == RAD_OK);
    size_t count = 0;
    for (uint32_t i = 0; i < n; i++) keys[i] = i;
    for (uint32_t i = 0; i < n; i++)
        for (uint32_t j = i + 1; j < n; j++) jobs[count++] = (ff_pair_job){i, j, 1, 0.0f};
    RAD_CHECK(ff_backend_cpu.compute_pairs(state, fx.patches, keys, jobs, count, entry, &c_entry) == RAD_OK);
    RAD_CHECK(ff_backend_cpu.compute_pairs(oracle_state, fx.patches, keys, jobs, count, link, &c_link) == RAD_OK);
    check_ray_floor(oracle_state, &fx, keys, jobs, count, link, &c_link);
    ff_backend_cpu.destroy(state);
    ff_backend_cpu.destroy(oracle_state);
    int same = 1, close = 1, differ = 0;
    for (size_t k = 0; k < count; k++) {
        const uint32_t i = jobs[k].a, j = jobs[k].b;
        const double full = rows[(size_t)i * n + j], err = errors[(size_t)i * n + j];
        same &= entry[k].coupling == full;
        differ += link[k].coupling != full;
        close &= fabs(link[k].coupling - full) <= fmin(1e-4 * full, 3.0 * (err + link[k].error)) + 1e-15;
    }
    fprintf(stderr, "link pairs: %zu pairs, %d differ from the matrix's entries; %llu quadrature points as entries, "
            "%llu for the oracle\n", count, differ, (unsigned long long)c_entry.samples,
            (unsigned long long)c_link.samples);
    RAD_CHECK(same && close);
    RAD_CHECK(differ > 0 && c_link.samples < c_entry.samples);
    free(rows), free(errors), free(keys), free(jobs), free(entry), free(link);
    fixture_free(&fx);
}

int main(void)
{
    check_link_pairs();
    /* Plain Monte Carlo: the sample variance is the right error. */
    check_calibration("parallel (mc)", parallel_obj, RAD_ESTIMATOR_MC, 256, 0, 0.85, 1.18);
    /* A shared edge: G ~ 1/r^2 there, and the variance of plain point
     * pairs is infinite (the integral of G^2 diverges), so a finite sample
     * variance can only understate it: measured 0.67 of the true spread.
     * The reason `auto` uses the near-field estimator for such pairs. */
    check_calibration("perpendicular (mc)", perpendicular_obj, RAD_ESTIMATOR_MC, 256, 0, 0.4, 1.0);
    /* The near-field estimator (both pairs count as near). */
    check_calibration("perpendicular (auto)", perpendicular_obj, RAD_ESTIMATOR_AUTO, 512, 0, 0.85, 1.18);
    /* Half occluded: the visibility ratio's error joins in. */
    check_calibration("half blocked (mc, 32 rays)", half_blocked_obj, RAD_ESTIMATOR_MC, 512, 32, 0.8, 1.25);
    /* QMC: the sample variance ignores the points' even spread, so it
     * overstates the error (a bound, not an estimate). */
    check_calibration("parallel (qmc)", parallel_obj, RAD_ESTIMATOR_QMC, 256, 0, 1.0, 1e9);
    check_target("parallel (mc)", parallel_obj, RAD_ESTIMATOR_MC, 0.199824895698, 1.5e-3);
    check_target("perpendicular (auto)", perpendicular_obj, RAD_ESTIMATOR_AUTO, 0.200043776075, 4e-3);
    check_cap();
    return rad_test_finish();
}
