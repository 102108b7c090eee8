/* rad_closure.c - the symmetric Sinkhorn iteration of rad_closure.h. */
#include "rad_closure.h"

#include <math.h>
#include <stdlib.h>

#include "rad_clock.h"
#include "rad_log.h"

rad_status rad_closure_scales(size_t leaf_count, rad_closure_apply apply, void *ctx, double tolerance,
                              uint32_t max_iterations, double *s, double *row, rad_closure_result *out)
{
    const double start = rad_clock_seconds();
    if (tolerance <= 0) tolerance = RAD_CLOSURE_TOLERANCE;
    if (max_iterations == 0) max_iterations = RAD_CLOSURE_MAX_ITERATIONS;
    rad_closure_result r = {.row_before = {INFINITY, 0}};
    double *Ks = malloc((leaf_count ? leaf_count : 1) * sizeof *Ks);
    if (!Ks) {
        rad_error("closure: out of memory for %zu leaves", leaf_count);
        return RAD_ERR_NOMEM;
    }
    for (size_t i = 0; i < leaf_count; i++) s[i] = 1;
    rad_status status = RAD_OK;
    for (;;) {
        const rad_status applied = apply(ctx, s, Ks);
        if (applied != RAD_OK) {
            free(Ks);
            return applied;
        }
        r.iterations++;
        double most = 0, lo = INFINITY, hi = 0;
        size_t empty = 0;
        for (size_t i = 0; i < leaf_count; i++) {
            const double sum = s[i] * Ks[i];
            if (!isfinite(sum) || sum < 0) {
                rad_error("closure: leaf %zu's row sums to %g", i, sum);
                free(Ks);
                return RAD_ERR_INVALID;
            }
            if (sum == 0) { /* no links: nothing to scale (s stays 1) */
                empty++;
                continue;
            }
            most = fmax(most, fabs(sum - 1));
            lo = fmin(lo, s[i]);
            hi = fmax(hi, s[i]);
            if (r.iterations == 1) {
                r.row_before[0] = fmin(r.row_before[0], sum);
                r.row_before[1] = fmax(r.row_before[1], sum);
            }
        }
        r.deviation = most;
        r.empty = empty;
        r.scale[0] = lo, r.scale[1] = hi;
        if (most <= tolerance || r.iterations >= max_iterations) {
            if (row)
                for (size_t i = 0; i < leaf_count; i++) row[i] = s[i] * Ks[i];
            if (most > tolerance) {
                rad_warn("closure: rows within %.3g of 1 after %u sweeps (target %.3g): solved with those scales",
                         most, r.iterations, tolerance);
                status = RAD_ERR_NOT_CONVERGED;
            }
            break;
        }
        for (size_t i = 0; i < leaf_count; i++)
            if (Ks[i] > 0) s[i] = sqrt(s[i] / Ks[i]);
    }
    free(Ks);
    r.seconds = rad_clock_seconds() - start;
    *out = r;
    rad_info("closure: rows of %.4g to %.4g balanced to 1 within %.2g in %u sweeps (scales %.4g to %.4g), %.2f s",
             r.row_before[0], r.row_before[1], r.deviation, r.iterations, r.scale[0], r.scale[1], r.seconds);
    if (r.empty)
        rad_warn("closure: %zu of %zu leaves have no links (their rows stay 0: the light they take is lost)", r.empty,
                 leaf_count);
    return status;
}
