/* rad_ff_visibility.h - the visible fraction of a patch pair that
 * something might block, for the quadrature estimator (host and device).
 *
 * With q and p as in rad_ff_quad.h, the pair's factor is G = G0 * nu,
 * where G0 is the unoccluded interchange area (quadrature, exact to its
 * tolerance) and
 *
 *     nu = int_q int_p K(y, x) V(y, x) / int_q int_p K(y, x),
 *
 * K the point kernel cos cos / (pi r^2), V in {0, 1}. Shadow ray r draws
 * y on q, stratified (jittered cells of q's square, every cell the same
 * number of rays) and weighted by the area element, then a point x on p:
 *  - near pairs: a direction uniform in solid angle over p (Arvo 1995,
 *    each triangle of p by its share of the solid angle), weight
 *    cos+(theta_y) Omega / pi, at most 2 whatever the geometry - no heavy
 *    tail where the patches touch;
 *  - far pairs: x uniform by area on p, weight K(y, x) A_p, nearly
 *    constant over p when p is far.
 * Both weights have expectation F(dA_y -> p) at y, so nu^ = sum w V /
 * sum w estimates nu with bounded weights: nu^ lies in [0, 1], is exactly
 * 1 when nothing blocks, and has a finite variance, estimated by the
 * linearised ratio formula (rad_ff_fraction). Every number is keyed on
 * the unordered pair and the ray index, so rows i and j trace the same
 * rays and the estimate is symmetric to the bit.
 */
#ifndef RAD_FF_VISIBILITY_H
#define RAD_FF_VISIBILITY_H

#include <stdint.h>

#include "rad_ff_kernel.h"
#include "rad_ff_quad.h"
#include "rad_math.h"
#include "rad_rng.h"

/* Solid angle of the spherical triangle of unit vectors a, b, c
 * (Van Oosterom & Strackee 1983). */
static inline RAD_HD double rad_sph_triangle_area(rad_vec3 a, rad_vec3 b, rad_vec3 c)
{
    double num = fabs(rad_v3_dot(a, rad_v3_cross(b, c)));
    double den = 1.0 + rad_v3_dot(a, b) + rad_v3_dot(b, c) + rad_v3_dot(c, a);
    return 2.0 * atan2(num, den);
}

/* Unit part of w orthogonal to the unit vector a. */
static inline RAD_HD rad_vec3 rad_v3_orthonormal(rad_vec3 w, rad_vec3 a)
{
    return rad_v3_normalize(rad_v3_sub(w, rad_v3_scale(a, rad_v3_dot(w, a))));
}

/* A direction uniform in solid angle over the spherical triangle a, b, c
 * of solid angle `area`, from xi1, xi2 in [0, 1) (Arvo 1995). */
static inline RAD_HD rad_vec3 rad_sph_triangle_sample(rad_vec3 a, rad_vec3 b, rad_vec3 c, double area, double xi1,
                                                      double xi2)
{
    rad_vec3 tb = rad_v3_sub(b, rad_v3_scale(a, rad_v3_dot(a, b)));
    rad_vec3 tc = rad_v3_sub(c, rad_v3_scale(a, rad_v3_dot(a, c)));
    double alpha = atan2(rad_v3_length(rad_v3_cross(tb, tc)), rad_v3_dot(tb, tc)); /* angle at a */
    double sa = sin(alpha), ca = cos(alpha);
    double sub = xi1 * area; /* area of the sub-triangle a, b, c' */
    double s = sin(sub - alpha), t = cos(sub - alpha);
    double u = t - ca, v = s + sa * rad_v3_dot(a, b);
    double den = (v * s + u * t) * sa;
    double cq = den != 0.0 ? ((v * t - u * s) * ca - v) / den : 1.0;
    cq = cq > 1.0 ? 1.0 : cq < -1.0 ? -1.0 : cq;
    rad_vec3 c2 = rad_v3_add(rad_v3_scale(a, cq), rad_v3_scale(rad_v3_orthonormal(c, a), sqrt(1.0 - cq * cq)));
    double z = 1.0 - xi2 * (1.0 - rad_v3_dot(c2, b));
    z = z > 1.0 ? 1.0 : z < -1.0 ? -1.0 : z;
    double bc2 = rad_v3_dot(c2, b);
    if (bc2 >= 1.0) return b; /* c' = b: the sub-triangle is a point */
    return rad_v3_add(rad_v3_scale(b, z), rad_v3_scale(rad_v3_orthonormal(c2, b), sqrt(1.0 - z * z)));
}

/* Shadow rays are rounded up to a multiple of the strata: the largest
 * power of 4 not above the first batch (at most 64 cells of q). */
static inline RAD_HD uint32_t rad_ff_vis_strata(uint32_t first_rays)
{
    uint32_t s = 1;
    while (s * 4 <= first_rays && s < 64) s *= 4;
    return s;
}

static inline RAD_HD uint32_t rad_ff_vis_round_rays(uint32_t rays)
{
    uint32_t s = rad_ff_vis_strata(rays);
    return (rays + s - 1) / s * s;
}

/* Shadow ray r of the pair: segment y -> x (y on q, x on p) and its weight
 * (0: no ray needed, the sample carries no weight). `strata` from
 * rad_ff_vis_strata of the first batch; a, b the pair's indices. */
static inline RAD_HD double rad_ff_vis_ray(const rad_ff_patch *q, const rad_ff_patch *p, uint32_t a, uint32_t b,
                                           uint32_t r, uint32_t strata, uint64_t seed, int near, rad_vec3 *y_out,
                                           rad_vec3 *x_out)
{
    rad_u32x4 ctr;
    ctr.v[0] = a < b ? a : b;
    ctr.v[1] = a < b ? b : a;
    ctr.v[2] = r;
    ctr.v[3] = 2; /* a stream of its own (MC samples use 0, the QMC shift 1) */
    rad_u32x4 rnd = rad_philox4x32(ctr, (uint32_t)seed, (uint32_t)(seed >> 32));
    uint32_t side = 1;
    while (side * side < strata) side++;
    uint32_t cell = r % strata;
    double u = ((cell % side) + rad_u01(rnd.v[0])) / side, v = ((cell / side) + rad_u01(rnd.v[1])) / side;
    /* p's end is stratified too: within each batch of `strata` rays the
     * cells of q meet the cells of p through a permutation (an odd
     * multiplier and an offset, mod the power of two `strata`), fresh for
     * each batch and pair, so both 2-D margins of the 4-D sample are
     * stratified. */
    uint32_t mix = ctr.v[0] * 0x9E3779B1u ^ ctr.v[1] * 0x85EBCA77u ^ (r / strata) * 0xC2B2AE3Du ^ (uint32_t)seed;
    mix ^= mix >> 15;
    mix *= 0x2C1B3C6Du;
    mix ^= mix >> 12;
    uint32_t cell_p = (cell * ((mix >> 8) | 1u) + (mix >> 20)) & (strata - 1u);
    double s2 = ((cell_p % side) + rad_u01(rnd.v[2])) / side, t2 = ((cell_p / side) + rad_u01(rnd.v[3])) / side;
    double jac;
    rad_vec3 y = rad_ff_patch_map(q, u, v, &jac);
    *y_out = y;
    *x_out = y;
    if (!(rad_v3_dot(p->normal, rad_v3_sub(y, p->p[0])) > 0.0)) return 0.0; /* y on or behind p's plane */
    if (!near) {
        rad_vec3 x = rad_ff_sample_point(p, s2, t2);
        *x_out = x;
        return jac * rad_ff_point_kernel(y, q->normal, x, p->normal) * p->area;
    }
    /* Solid angle: p's triangles (p0, p1, p2) and (p0, p2, p3). */
    rad_vec3 d0 = rad_v3_normalize(rad_v3_sub(p->p[0], y)), d1 = rad_v3_normalize(rad_v3_sub(p->p[1], y));
    rad_vec3 d2 = rad_v3_normalize(rad_v3_sub(p->p[2], y)), d3 = rad_v3_normalize(rad_v3_sub(p->p[3], y));
    double first = rad_sph_triangle_area(d0, d1, d2);
    double second = p->vertex_count == 4 ? rad_sph_triangle_area(d0, d2, d3) : 0.0;
    double omega = first + second;
    if (!(omega > 0.0)) return 0.0;
    double xi = s2 * omega;
    rad_vec3 dir = xi < first ? rad_sph_triangle_sample(d0, d1, d2, first, xi / first, t2)
                              : rad_sph_triangle_sample(d0, d2, d3, second, (xi - first) / second, t2);
    double cos_y = rad_v3_dot(q->normal, dir), cos_p = -rad_v3_dot(p->normal, dir);
    if (!(cos_y > 0.0) || !(cos_p > 0.0)) return 0.0;
    double t = rad_v3_dot(p->normal, rad_v3_sub(p->p[0], y)) / -cos_p;
    *x_out = rad_v3_add(y, rad_v3_scale(dir, t));
    return jac * cos_y * omega / RAD_PI;
}

/* Visible fraction nu^ = sum w V / sum w from the running sums, and its
 * standard error. The linearised ratio variance alone fails where it
 * matters: near nu^ = 0 or 1 it shrinks to nothing, and an adaptive rule
 * that stops once the error is small then stops exactly on the batches
 * that happened to look clear or hidden (1 of 64 rays seen where 15 % are:
 * reported 7 errors off, found by the 64-seed check). So the error is at
 * least a third of the distance from nu^ to the far end of the Wilson
 * score interval at z = 3 (Wilson 1927) for nu^ n successes in n trials,
 * n = (sum w)^2 / sum w^2 the rays' effective count - wide where few rays
 * disagree, about the binomial error elsewhere - and the ratio term is
 * taken with the n / (n - 1) of a sample variance. The error is 1/2 when
 * no ray carried weight (all from points that cannot see p): nothing is
 * known but nu in [0, 1]. Checked against the spread over 64 seeds
 * (tools/seed_spread.py, docs/accuracy.md). */
static inline RAD_HD double rad_ff_fraction(const rad_ff_sums *s, double *standard_error)
{
    if (!(s->ray_terms > 0.0)) {
        *standard_error = 0.5;
        return 1.0;
    }
    double nu = s->ray_seen / s->ray_terms;
    double hidden = s->ray_terms_sq - s->ray_seen_sq;
    hidden = hidden > 0.0 ? hidden : 0.0;
    double spread = s->ray_seen_sq * (1.0 - nu) * (1.0 - nu) + hidden * nu * nu;
    double n = s->ray_terms * s->ray_terms / s->ray_terms_sq;
    double ratio = sqrt(spread / (s->ray_terms * s->ray_terms) * (n > 1.5 ? n / (n - 1.0) : 3.0));
    const double z = 3.0;
    double centre = (nu + z * z / (2.0 * n)) / (1.0 + z * z / n);
    double half = z / (1.0 + z * z / n) * sqrt(nu * (1.0 - nu) / n + z * z / (4.0 * n * n));
    double lower = centre - half, upper = centre + half;
    double reach = upper - nu > nu - lower ? upper - nu : nu - lower;
    double wilson = reach / z;
    *standard_error = ratio > wilson ? ratio : wilson;
    return nu;
}

#endif
