/* test_cuda.c - the CUDA backend against the CPU reference (label gpu).
 * Exits 77 (skipped) when no GPU is visible; never fails for that reason.
 *
 * Both backends evaluate the very same point pairs and, with --fmad=false,
 * the very same per-sample kernel values; they differ only in the order of
 * the final sums (relative 1e-12 at most, K = 512 terms) and in shadow rays
 * that graze an edge (Moller-Trumbore vs Embree). So:
 *   - entries equal to 1e-9 relative, except
 *   - at most 0.5 % of the nonzero entries (borderline rays), which must
 *     still agree within 25 % (one ray of 32 weighs ~1/32 on average);
 *   - culled pairs, samples and rays counted identically.
 * Every estimator: mc, qmc, auto and analytic (near-field contour
 * integrals, where atan2/sqrt may differ in the last bit between libm and
 * CUDA), and quadrature (the same, plus adaptive decisions that may flip
 * on such a bit: entries within its tolerance, counts within 1 %).
 * Plus the closed forms on the GPU, as in test_formfactor.c.
 */
#include <stdlib.h>
#include <string.h>

#include "ff_cuda.h"
#include "ff_fixture.h"
#include "rad_test.h"

static void compare(const char *path, int subdiv, rad_estimator_id estimator)
{
    fixture fx;
    RAD_CHECK(fixture_load(&fx, NULL, path, subdiv));
    uint32_t n = (uint32_t)fx.mesh.patch_count;
    ff_counters cc = {0}, gc = {0};
    double *cpu = compute_estimator(&ff_backend_cpu, &fx, 512, 32, 1, estimator, &cc);
    double *gpu = compute_estimator(&ff_backend_cuda, &fx, 512, 32, 1, estimator, &gc);
    RAD_CHECK(cpu && gpu);
    if (!cpu || !gpu) return;
    uint64_t nonzero = 0, loose = 0, bad = 0;
    double worst_tight = 0;
    for (uint64_t k = 0; k < (uint64_t)n * n; k++) {
        double a = cpu[k], b = gpu[k], diff = fabs(a - b), scale = fmax(fabs(a), fabs(b));
        nonzero += a != 0;
        if (diff <= 1e-9 * scale) {
            worst_tight = fmax(worst_tight, scale > 0 ? diff / scale : 0);
            continue;
        }
        loose++;
        if (diff > 0.25 * scale) bad++;
    }
    fprintf(stderr,
            "%s --subdiv %d (%s): N=%u, %llu nonzero; %llu entries differ beyond 1e-9 (borderline rays), %llu beyond 25%%; "
            "largest tight difference %.2e; rays occluded cpu %llu gpu %llu\n",
            path, subdiv, rad_estimator_name(estimator), n, (unsigned long long)nonzero, (unsigned long long)loose, (unsigned long long)bad,
            worst_tight, (unsigned long long)cc.rays_occluded, (unsigned long long)gc.rays_occluded);
    RAD_CHECK(loose <= nonzero / 200);
    RAD_CHECK(bad == 0);
    RAD_CHECK(cc.pairs == gc.pairs && cc.pairs_not_facing == gc.pairs_not_facing);
    /* Both backends cull with the same rules (ff_bvh.h), in the same
     * double arithmetic: the same pairs, within rounding of borderline
     * triangles. The
     * quadrature estimator's adaptive decisions (a cell's error against its
     * share, a pair found partly hidden) may flip on a last-bit or
     * borderline-ray difference, so its counts agree to 1 %. */
    if (estimator == RAD_ESTIMATOR_QUADRATURE) {
        RAD_CHECK(fabs((double)cc.samples - (double)gc.samples) <= 0.01 * (double)cc.samples);
        RAD_CHECK(fabs((double)(cc.rays + cc.rays_saved) - (double)(gc.rays + gc.rays_saved)) <=
                  0.01 * (double)(cc.rays + cc.rays_saved));
    } else {
        RAD_CHECK(cc.samples == gc.samples && cc.pairs_near == gc.pairs_near);
        RAD_CHECK(cc.rays + cc.rays_saved == gc.rays + gc.rays_saved);
    }
    RAD_CHECK(cc.pairs_open_scene == gc.pairs_open_scene);
    RAD_CHECK(fabs((double)cc.pairs_open_box - (double)gc.pairs_open_box) <= 0.001 * (double)cc.pairs_open_box);
    free(cpu);
    free(gpu);
    fixture_free(&fx);
}

/* Counts entries that differ beyond 1e-9 relative (loose) and beyond 25 % (bad). */
static void count_differences(const double *a, const double *b, uint64_t count, uint64_t *loose, uint64_t *bad)
{
    *loose = *bad = 0;
    for (uint64_t k = 0; k < count; k++) {
        double diff = fabs(a[k] - b[k]), scale = fmax(fabs(a[k]), fabs(b[k]));
        if (diff <= 1e-9 * scale + 1e-15) continue; /* 1e-15: error estimates that are differences of near-equal sums */
        (*loose)++;
        if (diff > 0.25 * scale) (*bad)++;
    }
}

/* Standard errors and --target-error on both backends: the same errors
 * (to the same tolerances as the values), the same refinement decisions
 * but for borderline ones; and each pair computed once on the GPU, then
 * mirrored, gives the GPU's own full matrix to the bit. */
static void compare_errors(const char *path, int subdiv, rad_estimator_id estimator, double target)
{
    fixture fx;
    RAD_CHECK(fixture_load(&fx, NULL, path, subdiv));
    uint64_t n = fx.mesh.patch_count, count = n * n;
    double *ce = NULL, *ge = NULL, *oe = NULL;
    ff_counters cc = {0}, gc = {0}, oc = {0};
    compute_extra cx = {.target_error = target, .errors = &ce}, gx = {.target_error = target, .errors = &ge};
    compute_extra ox = {.target_error = target, .errors = &oe, .pairs_once = 1};
    double *cpu = compute_full(&ff_backend_cpu, &fx, 128, 16, 2, estimator, &cx, &cc);
    double *gpu = compute_full(&ff_backend_cuda, &fx, 128, 16, 2, estimator, &gx, &gc);
    double *once = compute_full(&ff_backend_cuda, &fx, 128, 16, 2, estimator, &ox, &oc);
    RAD_CHECK(cpu && gpu && once && ce && ge && oe);
    if (cpu && gpu && once && ce && ge && oe) {
        uint64_t loose_f, bad_f, loose_e, bad_e;
        count_differences(cpu, gpu, count, &loose_f, &bad_f);
        count_differences(ce, ge, count, &loose_e, &bad_e);
        fprintf(stderr,
                "%s --subdiv %d, --target-error %g: values differ beyond 1e-9 in %llu (beyond 25%%: %llu), errors in "
                "%llu (%llu); refined cpu %llu gpu %llu, capped cpu %llu gpu %llu, samples cpu %llu gpu %llu\n",
                path, subdiv, target, (unsigned long long)loose_f, (unsigned long long)bad_f,
                (unsigned long long)loose_e, (unsigned long long)bad_e, (unsigned long long)cc.pairs_refined,
                (unsigned long long)gc.pairs_refined, (unsigned long long)cc.pairs_capped,
                (unsigned long long)gc.pairs_capped, (unsigned long long)cc.samples, (unsigned long long)gc.samples);
        RAD_CHECK(loose_f <= count / 200 && bad_f <= count / 2000);
        RAD_CHECK(loose_e <= count / 100);
        RAD_CHECK(target == 0 || cc.pairs_refined > 0);
        RAD_CHECK(llabs((long long)cc.pairs_refined - (long long)gc.pairs_refined) <= (long long)(cc.pairs_refined / 100 + 2));
        RAD_CHECK(memcmp(gpu, once, sizeof(double) * count) == 0 && memcmp(ge, oe, sizeof(double) * count) == 0);
        RAD_CHECK(oc.pairs == n + n * (n - 1) / 2);
    }
    free(cpu), free(gpu), free(once), free(ce), free(ge), free(oe);
    fixture_free(&fx);
}

static void closed_form(const char *name, const char *obj, double exact, double max_se)
{
    fixture fx;
    RAD_CHECK(fixture_load(&fx, obj, "s.obj", 0));
    enum { REPLICATES = 16 };
    double sum = 0, sum2 = 0;
    for (int r = 1; r <= REPLICATES; r++) {
        double *f = compute_with(&ff_backend_cuda, &fx, 65536, 0, (uint64_t)r, NULL);
        RAD_CHECK(f != NULL);
        if (!f) break;
        sum += f[1];
        sum2 += f[1] * f[1];
        RAD_CHECK(f[0] == 0 && f[3] == 0);
        free(f);
    }
    double mean = sum / REPLICATES;
    double se = sqrt((sum2 / REPLICATES - mean * mean) / (REPLICATES - 1));
    fprintf(stderr, "cuda %s: F = %.6f +- %.6f (exact %.6f)\n", name, mean, se, exact);
    RAD_CHECK(se < max_se);
    RAD_CHECK_NEAR(mean, exact, 5 * se);
    fixture_free(&fx);
}

int main(void)
{
    if (ff_cuda_device_count() == 0) {
        fprintf(stderr, "no CUDA device: skipped\n");
        return 77;
    }
    compare(RAD_SCENES "/cornell_box.obj", 1, RAD_ESTIMATOR_MC);
    compare(RAD_SCENES "/cornell_sphere.obj", 2, RAD_ESTIMATOR_MC);
    compare(RAD_SCENES "/cornell_box.obj", 2, RAD_ESTIMATOR_AUTO);
    compare(RAD_SCENES "/cornell_sphere.obj", 2, RAD_ESTIMATOR_AUTO);
    compare(RAD_SCENES "/cornell_sphere.obj", 2, RAD_ESTIMATOR_QMC);
    compare(RAD_SCENES "/cornell_box.obj", 1, RAD_ESTIMATOR_ANALYTIC);
    compare(RAD_SCENES "/cornell_box.obj", 2, RAD_ESTIMATOR_QUADRATURE);
    compare(RAD_SCENES "/cornell_sphere.obj", 2, RAD_ESTIMATOR_QUADRATURE);
    compare(RAD_SCENES "/closed_box.obj", 3, RAD_ESTIMATOR_QUADRATURE);
    compare_errors(RAD_SCENES "/cornell_box.obj", 1, RAD_ESTIMATOR_AUTO, 0);
    compare_errors(RAD_SCENES "/cornell_box.obj", 1, RAD_ESTIMATOR_AUTO, 0.002);
    compare_errors(RAD_SCENES "/cornell_sphere.obj", 1, RAD_ESTIMATOR_MC, 0.002);
    compare_errors(RAD_SCENES "/closed_box.obj", 1, RAD_ESTIMATOR_QMC, 0.001);
    compare_errors(RAD_SCENES "/cornell_box.obj", 1, RAD_ESTIMATOR_QUADRATURE, 0.002);
    closed_form("parallel unit squares", parallel_obj, 0.199825, 1.5e-4);
    closed_form("perpendicular unit squares", perpendicular_obj, 0.200044, 2e-3);

    fixture fx;
    RAD_CHECK(fixture_load(&fx, blocked_obj, "s.obj", 0));
    double *f = compute_with(&ff_backend_cuda, &fx, 512, 32, 1, NULL);
    RAD_CHECK(f && f[1] == 0.0 && f[3] == 0.0 && f[5] > 0.1);
    free(f);
    fixture_free(&fx);
    return rad_test_finish();
}
