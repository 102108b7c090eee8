/* rad_ff_pair.h - one patch pair from start to finish, for every
 * estimator: the one per-pair procedure both backends run (host and
 * device), so the estimators cannot drift between CPU and GPU. The
 * backends keep only their loops over pairs and their culling.
 *
 * The including file supplies the two things that differ:
 *
 *     #define RAD_FF_TRACER     my_tracer      (a type; passed by pointer)
 *     #define RAD_FF_OCCLUDED(tracer, x, nx, face_x, y, ny, face_y)  ...
 *         1 if the segment from x (on face_x, unit normal nx) to y (on
 *         face_y, normal ny), rad_vec3 each, hits an occluder on neither
 *         face (formfactor/ff_bvh.h, ff_segment: what counts as a hit)
 *     #define RAD_FF_TICKS()    a long long clock (time spent tracing)
 *     #define RAD_FF_LANE_SUM(x, lanes)
 *         optional: sums over the threads that share a pair (rad_ff_quad.h)
 *     #include "rad_ff_pair.h"
 *
 * Estimators (docs/architecture.md):
 *  - quadrature (the default): G0 by adaptive quadrature
 *    (rad_ff_quad.h), deterministic and error-controlled; where the
 *    backend cannot rule out occlusion, times the visible fraction from
 *    stratified, bounded-weight shadow rays (rad_ff_visibility.h);
 *  - mc, qmc, auto, analytic: the Monte Carlo point-pair and near-field
 *    estimators (rad_ff_kernel.h), kept for the study and the paper.
 */
#ifndef RAD_FF_PAIR_H
#define RAD_FF_PAIR_H

#include <stdint.h>

#include "rad_ff_contour.h"
#include "rad_ff_kernel.h"
#include "rad_ff_quad.h"
#include "rad_ff_visibility.h"

/* Default refinement of partly hidden pairs (quadrature estimator,
 * without --target-error): their shadow rays double until the standard
 * error of both entries is at most RAD_FF_PARTIAL_TARGET, or until they
 * reach RAD_FF_PARTIAL_RAYS times the first batch. */
#define RAD_FF_PARTIAL_TARGET 2e-5
#ifndef RAD_FF_PARTIAL_RAYS
#define RAD_FF_PARTIAL_RAYS 16u
#endif
#ifndef RAD_FF_CONFIRM_RAYS
#define RAD_FF_CONFIRM_RAYS 4u
#endif
#ifndef RAD_FF_CONFIRM_TARGET
#define RAD_FF_CONFIRM_TARGET 1e-4
#endif


/* What one pair gave. */
typedef struct rad_ff_pair_result {
    double coupling;       /* c_ij = F_ij / A_j */
    double error;          /* its standard error (quadrature: bound + standard error of the fraction) */
    uint32_t samples;      /* point pairs or point factors evaluated */
    uint32_t rays;         /* shadow rays traced */
    uint32_t rays_blocked;
    uint32_t rays_skipped; /* rays the pair would have cast without a tracer (culled) */
    int near;              /* took the near-field (contour) estimator, or near-pair ray sampling */
    int refined;           /* took more than one batch */
    int capped;            /* --target-error: its error still above the target when it stopped;
                              without: the quadrature stopped at its limit (rad_ff_quad.h) */
    long long ray_ticks;   /* RAD_FF_TICKS spent tracing */
} rad_ff_pair_result;

/* One thread's share of a batch of shadow rays, added to the pair's sums
 * over all lanes at the end of the batch (rad_ff_pair_rays_add). */
typedef struct rad_ff_ray_batch {
    double terms, terms_sq, seen, seen_sq;
    uint32_t traced, visible;
} rad_ff_ray_batch;

static inline RAD_HD void rad_ff_pair_add_ray(rad_ff_ray_batch *b, double g, int visible)
{
    b->terms += g;
    b->terms_sq += g * g;
    if (visible) {
        b->seen += g;
        b->seen_sq += g * g;
    }
    b->visible += (uint32_t)visible;
    b->traced++;
}

/* The batch of rays [r0, r1) into the pair's sums and counts. */
static inline RAD_HD void rad_ff_pair_rays_add(const rad_ff_pair_params *pp, const rad_ff_ray_batch *b, uint32_t r0,
                                               uint32_t r1, rad_ff_sums *sums, rad_ff_pair_result *out)
{
    sums->ray_terms += RAD_FF_LANE_SUM(b->terms, pp->lanes);
    sums->ray_terms_sq += RAD_FF_LANE_SUM(b->terms_sq, pp->lanes);
    sums->ray_seen += RAD_FF_LANE_SUM(b->seen, pp->lanes);
    sums->ray_seen_sq += RAD_FF_LANE_SUM(b->seen_sq, pp->lanes);
    uint32_t traced = RAD_FF_LANE_SUM(b->traced, pp->lanes), visible = RAD_FF_LANE_SUM(b->visible, pp->lanes);
    sums->visible += visible;
    sums->rays += r1 - r0;
    out->rays += traced;
    out->rays_blocked += traced - visible;
}

/* One shadow segment from a on patch pa to b on patch pb. */
static inline RAD_HD int rad_ff_pair_visible(const RAD_FF_TRACER *tracer, rad_vec3 a, const rad_ff_patch *pa,
                                             rad_vec3 b, const rad_ff_patch *pb)
{
    return !(RAD_FF_OCCLUDED(tracer, a, pa->normal, pa->face, b, pb->normal, pb->face));
}

/* Monte Carlo terms of samples [k0, k1): G(x, y) (far) or near-field terms. */
static inline RAD_HD void rad_ff_pair_mc_terms(const rad_ff_pair_params *pp, int near, const rad_ff_patch *pi,
                                               const rad_ff_patch *pj, uint32_t i, uint32_t j, uint32_t k0,
                                               uint32_t k1, rad_ff_sums *sums)
{
    double sum = 0.0, sum_sq = 0.0;
    for (uint32_t k = k0 + pp->lane; k < k1; k += pp->lanes) {
        rad_vec3 x, y;
        double g;
        if (near) {
            g = rad_ff_near_sample(pi, pj, i, j, k, pp->seed, &x, &y);
        } else {
            rad_ff_pair_points(pp->estimator, pi, pj, i, j, k, pp->seed, &x, &y);
            g = rad_ff_point_kernel(x, pi->normal, y, pj->normal);
        }
        sum += g;
        sum_sq += g * g;
    }
    sums->terms += RAD_FF_LANE_SUM(sum, pp->lanes);
    sums->terms_sq += RAD_FF_LANE_SUM(sum_sq, pp->lanes);
    sums->samples += k1 - k0;
}

/* Monte Carlo shadow rays of samples [r0, r1): the segment between the
 * sample's points, from the lower-numbered patch, weighted by G(x, y)
 * (near pairs too: the visible fraction is the G-weighted mean of V). */
static inline RAD_HD void rad_ff_pair_mc_rays(const rad_ff_pair_params *pp, int near, const rad_ff_patch *pi,
                                              const rad_ff_patch *pj, uint32_t i, uint32_t j, uint32_t r0,
                                              uint32_t r1, const RAD_FF_TRACER *tracer, rad_ff_pair_result *out,
                                              rad_ff_sums *sums)
{
    long long t0 = RAD_FF_TICKS();
    rad_ff_ray_batch b = {0};
    for (uint32_t k = r0 + pp->lane; k < r1; k += pp->lanes) {
        rad_vec3 x, y;
        if (near)
            rad_ff_sample_pair(pi, pj, i, j, k, pp->seed, &x, &y);
        else
            rad_ff_pair_points(pp->estimator, pi, pj, i, j, k, pp->seed, &x, &y);
        double g = rad_ff_point_kernel(x, pi->normal, y, pj->normal);
        int visible = i < j ? rad_ff_pair_visible(tracer, x, pi, y, pj)
                            : rad_ff_pair_visible(tracer, y, pj, x, pi);
        rad_ff_pair_add_ray(&b, g, visible);
    }
    rad_ff_pair_rays_add(pp, &b, r0, r1, sums, out);
    out->ray_ticks += RAD_FF_TICKS() - t0;
}

/* The Monte Carlo estimators: K samples, the first R with shadow rays,
 * then (--target-error) batches doubling both until the error is met. */
static inline RAD_HD void rad_ff_pair_monte_carlo(const rad_ff_pair_params *pp, const rad_ff_patch *pi,
                                                  const rad_ff_patch *pj, uint32_t i, uint32_t j,
                                                  const RAD_FF_TRACER *tracer, rad_ff_pair_result *out)
{
    int near = rad_ff_pair_uses_contour(pp->estimator, pi, pj);
    uint32_t K = near ? rad_ff_near_samples(pp->samples) : pp->samples;
    uint32_t R = pp->rays < K ? pp->rays : K;
    rad_ff_sums sums = {0};
    rad_ff_pair_mc_terms(pp, near, pi, pj, i, j, 0, K, &sums);
    int traced = tracer && R > 0 && sums.terms > 0.0;
    if (traced)
        rad_ff_pair_mc_rays(pp, near, pi, pj, i, j, 0, R, tracer, out, &sums);
    else if (sums.terms > 0.0)
        out->rays_skipped += R;
    double error = 0.0;
    double value = rad_ff_estimate(&sums, near, pi, pj, &error);
    if (pp->target_error > 0.0) {
        uint32_t to = 0, rays_to = 0, planned = R;
        while (!rad_ff_error_reached(error, pi, pj, pp->target_error) &&
               rad_ff_next_batch(&sums, K, R, pp->samples, pp->max_samples, &to, &rays_to)) {
            rad_ff_pair_mc_terms(pp, near, pi, pj, i, j, sums.samples, to, &sums);
            if (traced) {
                rad_ff_pair_mc_rays(pp, near, pi, pj, i, j, sums.rays, rays_to, tracer, out, &sums);
            } else if (sums.terms > 0.0 && R > 0) {
                out->rays_skipped += rays_to - planned;
                planned = rays_to;
            }
            value = rad_ff_estimate(&sums, near, pi, pj, &error);
            out->refined = 1;
        }
        out->capped = !rad_ff_error_reached(error, pi, pj, pp->target_error);
    }
    out->near = near;
    out->samples = sums.samples;
    out->coupling = value;
    out->error = error;
}

/* The quadrature estimator's shadow rays [r0, r1). */
static inline RAD_HD void rad_ff_pair_quad_rays(const rad_ff_pair_params *pp, const rad_ff_patch *q,
                                                const rad_ff_patch *p, uint32_t iq, uint32_t ip,
                                                int near, uint32_t r0, uint32_t r1, const RAD_FF_TRACER *tracer,
                                                rad_ff_pair_result *out, rad_ff_sums *sums)
{
    long long t0 = RAD_FF_TICKS();
    rad_ff_ray_batch b = {0};
    const rad_u32x4 key = rad_ff_vis_key(iq, ip, pp->seed);
    for (uint32_t r = r0 + pp->lane; r < r1; r += pp->lanes) {
        rad_vec3 y, x;
        double w = rad_ff_vis_ray(q, p, key, r, near, &y, &x);
        if (w > 0.0) rad_ff_pair_add_ray(&b, w, rad_ff_pair_visible(tracer, y, q, x, p));
    }
    rad_ff_pair_rays_add(pp, &b, r0, r1, sums, out);
    out->ray_ticks += RAD_FF_TICKS() - t0;
}

/* The quadrature estimator, stage 1: G0 of the pair to the quadrature
 * tolerance (rad_ff_quad.h), over the smaller patch q. Stage 2
 * (rad_ff_pair_quad_finish) needs only this result, so a backend may run
 * the stages apart (the CUDA backend: a launch for the quadrature of
 * every pair, then one for the rays of the pairs that trace). */
static inline RAD_HD rad_ff_quad_result rad_ff_pair_quad_unoccluded(const rad_ff_pair_params *pp,
                                                                    const rad_ff_patch *pi, const rad_ff_patch *pj,
                                                                    uint32_t i, uint32_t j)
{
    int i_is_q = rad_ff_quad_roles(pi, pj, i, j);
    const rad_ff_patch *q = i_is_q ? pi : pj, *p = i_is_q ? pj : pi;
    double rtol = pp->quad_rtol > 0.0 ? pp->quad_rtol : RAD_FF_QUAD_RTOL; /* 0: the defaults */
    double atol = pp->quad_atol > 0.0 ? pp->quad_atol : RAD_FF_QUAD_ATOL;
    /* Near pairs (shared edges and vertices among them) and pairs that
     * straddle: the double contour integral, which needs a few hundred
     * analytic inner integrals where the area rule needs thousands of
     * point factors (tens of thousands, and then wrong, for a straddling
     * pair); the area rule for a near pair it does not bring to the
     * tolerance (rad_ff_contour.h). */
    uint32_t contour_points = 0;
    int contour_tried = rad_ff_contour_applies(q, p);
    rad_ff_contour_result c;
    c.g = 0.0, c.error = 0.0, c.points = 0, c.converged = 0;
    if (contour_tried) {
        c = rad_ff_contour_g(q, p, rtol, atol, pp->lane, pp->lanes);
        if (c.converged) {
            rad_ff_quad_result out;
            out.g = c.g, out.error = c.error, out.points = c.points, out.cells = 0, out.capped = 0;
            return out;
        }
        contour_points = c.points;
    }
    if (rad_ff_contour_straddles(q, p)) {
        /* The area rule over the part of q in front of p, fanned into
         * triangles: its integrand has no kink inside them (the one
         * across p's plane is now an edge, graded towards). Where the
         * contour integral ran and did not finish, the fan gets
         * RAD_FF_QUAD_FALLBACK_CELLS a triangle, not the full limit, and
         * the smaller error wins: on the subdivided Suzanne 8 of 21 M
         * pairs took 470 000 - 535 000 points each at the full limit,
         * 100 ms of one warp each, for an answer no better. */
        uint32_t cells = contour_tried ? RAD_FF_QUAD_FALLBACK_CELLS : RAD_FF_QUAD_MAX_CELLS;
        rad_ff_poly qc = rad_ff_poly_in_front(q, p, 1e-14 * (q->radius + p->radius));
        rad_ff_quad_result out;
        out.g = 0.0, out.error = 0.0, out.points = contour_points, out.cells = 0, out.capped = 0;
        for (uint32_t t = 1; t + 1 < qc.n; t++) {
            rad_ff_patch tri = rad_ff_poly_fan_triangle(&qc, t, q);
            if (!(tri.area > 0.0)) continue;
            rad_ff_quad_result part = rad_ff_quad_unoccluded_within(&tri, p, rtol, atol, cells, pp->lane, pp->lanes);
            out.g += part.g, out.error += part.error, out.points += part.points, out.cells += part.cells;
            out.capped |= part.capped;
        }
        if (contour_tried && c.error < out.error) out.g = c.g, out.error = c.error, out.capped = 1;
        return out;
    }
    /* A near pair the contour integral did not finish: the area rule, at
     * the fallback limit, and the smaller error wins (as above). */
    rad_ff_quad_result out = rad_ff_quad_unoccluded_within(
        q, p, rtol, atol, contour_tried ? RAD_FF_QUAD_FALLBACK_CELLS : RAD_FF_QUAD_MAX_CELLS, pp->lane, pp->lanes);
    out.points += contour_points;
    if (contour_tried && c.error < out.error) out.g = c.g, out.error = c.error, out.capped = 1;
    if (out.capped && !contour_tried) {
        /* The area rule stopped at its cell limit: over a sliver along a
         * shared edge it is then up to 1 % off with an error 7 times too
         * small (tests/fuzz/pair_cases.h, cases 3158, 3245, 7803), where
         * the contour integral, not taken for slivers because its terms
         * cancel, still converges to 1e-9. The one with the smaller error. */
        c = rad_ff_contour_g(q, p, rtol, atol, pp->lane, pp->lanes);
        out.points += c.points;
        if (c.error < out.error) out.g = c.g, out.error = c.error, out.capped = !c.converged;
    }
    return out;
}

/* Does stage 2 trace rays for G0 (given a tracer)? */
static inline RAD_HD int rad_ff_pair_quad_traces(const rad_ff_pair_params *pp, const rad_ff_quad_result *g0)
{
    return pp->rays > 0 && g0->g > 0.0;
}

/* The quadrature estimator, stage 2: with a tracer (the backend could not
 * rule out occlusion), G = G0 nu^ with the visible fraction from
 * stratified shadow rays, doubled under --target-error until the error is
 * met or the rays reach their cap; without one, G = G0. */
static inline RAD_HD void rad_ff_pair_quad_finish(const rad_ff_pair_params *pp, const rad_ff_patch *pi,
                                                  const rad_ff_patch *pj, uint32_t i, uint32_t j,
                                                  const rad_ff_quad_result *g0, const RAD_FF_TRACER *tracer,
                                                  rad_ff_pair_result *out)
{
    int i_is_q = rad_ff_quad_roles(pi, pj, i, j);
    const rad_ff_patch *q = i_is_q ? pi : pj, *p = i_is_q ? pj : pi;
    uint32_t iq = i_is_q ? i : j, ip = i_is_q ? j : i;
    double scale = 1.0 / (pi->area * pj->area);
    double nu = 1.0, nu_error = 0.0;
    uint32_t R = pp->rays;
    int near = rad_ff_pair_near(pi, pj);
    out->samples = g0->points;
    out->capped = g0->capped;
    if (rad_ff_pair_quad_traces(pp, g0) && !tracer) out->rays_skipped += R;
    if (rad_ff_pair_quad_traces(pp, g0) && tracer) {
        rad_ff_sums sums = {0};
        rad_ff_pair_quad_rays(pp, q, p, iq, ip, near, 0, R, tracer, out, &sums);
        nu = rad_ff_fraction(&sums, &nu_error);
        /* More rays (doubling) while the error is above the target: by
         * default RAD_FF_PARTIAL_TARGET, for the pairs their first rays
         * found partly hidden (0 < nu^ < 1), or learnt nothing of (no ray
         * with weight) - the only ones whose fraction is uncertain beyond
         * its one-ray floor - else RAD_FF_CONFIRM_TARGET; --target-error
         * only adds rays (up to its cap) where the default would stop, so
         * a loose target is never worse than none. */
        double area = pi->area > pj->area ? pi->area : pj->area;
        const double enough = pp->ray_floor * area; /* what the caller can use, in err's units */
        for (;;) {
            uint64_t cap, least = 0;
            double target;
            int partial = nu > 0.0 && nu < 1.0;
            if (partial || !(sums.ray_terms > 0.0)) {
                target = RAD_FF_PARTIAL_TARGET;
                cap = (uint64_t)R * RAD_FF_PARTIAL_RAYS;
            } else {
                target = RAD_FF_CONFIRM_TARGET;
                cap = (uint64_t)R * RAD_FF_CONFIRM_RAYS;
            }
            /* A caller's floor above the default target stands for it,
             * and spares partly hidden pairs their doubling unless their
             * error asks for it. */
            if (enough > target)
                target = enough;
            else if (partial)
                least = 2 * (uint64_t)R < cap ? 2 * (uint64_t)R : cap;
            double err = (g0->error + g0->g * nu_error) * scale * area;
            int more = sums.rays < cap && (sums.rays < least || err > target);
            if (pp->target_error > 0.0) {
                uint64_t user_cap = (uint64_t)R * (pp->max_samples / pp->samples);
                more |= sums.rays < user_cap && err > pp->target_error;
                if (user_cap > cap) cap = user_cap;
            }
            if (!more) break;
            uint64_t to = 2 * (uint64_t)sums.rays < cap ? 2 * (uint64_t)sums.rays : cap;
            rad_ff_pair_quad_rays(pp, q, p, iq, ip, near, sums.rays, (uint32_t)to, tracer, out, &sums);
            nu = rad_ff_fraction(&sums, &nu_error);
            out->refined = 1;
        }
        out->near = near;
    }
    out->coupling = g0->g * nu * scale;
    out->error = (g0->error * nu + g0->g * nu_error) * scale;
    /* Under --target-error, capped counts a missed target only (a
     * quadrature limit whose error still meets the target is no miss). */
    if (pp->target_error > 0.0) out->capped = !rad_ff_error_reached(out->error, pi, pj, pp->target_error);
}

/* The quadrature estimator, both stages at once. */
static inline RAD_HD void rad_ff_pair_quadrature(const rad_ff_pair_params *pp, const rad_ff_patch *pi,
                                                 const rad_ff_patch *pj, uint32_t i, uint32_t j,
                                                 const RAD_FF_TRACER *tracer, rad_ff_pair_result *out)
{
    rad_ff_quad_result g0 = rad_ff_pair_quad_unoccluded(pp, pi, pj, i, j);
    rad_ff_pair_quad_finish(pp, pi, pj, i, j, &g0, tracer, out);
}

/* Pair (i, j), i != j, facing (rad_ff_pair_facing): its coupling and
 * error. tracer NULL: the backend proved that nothing blocks the pair. */
static inline RAD_HD void rad_ff_pair_compute(const rad_ff_pair_params *pp, const rad_ff_patch *pi,
                                              const rad_ff_patch *pj, uint32_t i, uint32_t j,
                                              const RAD_FF_TRACER *tracer, rad_ff_pair_result *out)
{
    rad_ff_pair_result zero = {0};
    *out = zero;
    if (pp->estimator == RAD_ESTIMATOR_QUADRATURE)
        rad_ff_pair_quadrature(pp, pi, pj, i, j, tracer, out);
    else
        rad_ff_pair_monte_carlo(pp, pi, pj, i, j, tracer, out);
}

#endif
