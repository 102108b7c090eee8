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
 * y on q (point r of a scrambled Sobol' sequence, below) weighted by the
 * area element, then a point x on p:
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

/* Reverses the 32 bits of x. */
static inline RAD_HD uint32_t rad_reverse_bits(uint32_t x)
{
    x = (x << 16) | (x >> 16);
    x = ((x & 0x00ff00ffu) << 8) | ((x & 0xff00ff00u) >> 8);
    x = ((x & 0x0f0f0f0fu) << 4) | ((x & 0xf0f0f0f0u) >> 4);
    x = ((x & 0x33333333u) << 2) | ((x & 0xccccccccu) >> 2);
    return ((x & 0x55555555u) << 1) | ((x & 0xaaaaaaaau) >> 1);
}

/* Owen's nested uniform scramble of the bits of x, keyed by seed: each
 * bit flipped by a hash of the bits above it (Laine and Karras 2011 on
 * the reversed bits; Burley 2020, "Practical Hash-based Owen
 * Scrambling"). Keeps every (t, m, s)-net one. */
static inline RAD_HD uint32_t rad_owen_scramble(uint32_t x, uint32_t seed)
{
    x = rad_reverse_bits(x);
    x += seed;
    x ^= x * 0x6c50b47cu;
    x ^= x * 0xb82f1e52u;
    x ^= x * 0xc7afe638u;
    x ^= x * 0x8d22f6e6u;
    return rad_reverse_bits(x);
}

#if defined(__CUDA_ARCH__)
#define RAD_SOBOL_STORAGE
#else
#define RAD_SOBOL_STORAGE static
#endif

/* Coordinate dim (0-3) of point `index` of the 4-D Sobol' sequence (Joe
 * and Kuo's direction numbers, new-joe-kuo-6.21201: dimension 1 is the van
 * der Corput sequence). */
static inline RAD_HD uint32_t rad_sobol4(uint32_t index, int dim)
{
    if (dim == 0) return rad_reverse_bits(index);
    /* static on the host: as an automatic array the compiler copied the
     * 384 bytes onto the stack at every call (three a shadow ray). */
    RAD_SOBOL_STORAGE const uint32_t directions[3][32] = {
       {0x80000000u, 0xc0000000u, 0xa0000000u, 0xf0000000u, 0x88000000u, 0xcc000000u,
        0xaa000000u, 0xff000000u, 0x80800000u, 0xc0c00000u, 0xa0a00000u, 0xf0f00000u,
        0x88880000u, 0xcccc0000u, 0xaaaa0000u, 0xffff0000u, 0x80008000u, 0xc000c000u,
        0xa000a000u, 0xf000f000u, 0x88008800u, 0xcc00cc00u, 0xaa00aa00u, 0xff00ff00u,
        0x80808080u, 0xc0c0c0c0u, 0xa0a0a0a0u, 0xf0f0f0f0u, 0x88888888u, 0xccccccccu,
        0xaaaaaaaau, 0xffffffffu},
       {0x80000000u, 0xc0000000u, 0x60000000u, 0x90000000u, 0xe8000000u, 0x5c000000u,
        0x8e000000u, 0xc5000000u, 0x68800000u, 0x9cc00000u, 0xee600000u, 0x55900000u,
        0x80680000u, 0xc09c0000u, 0x60ee0000u, 0x90550000u, 0xe8808000u, 0x5cc0c000u,
        0x8e606000u, 0xc5909000u, 0x6868e800u, 0x9c9c5c00u, 0xeeee8e00u, 0x5555c500u,
        0x8000e880u, 0xc0005cc0u, 0x60008e60u, 0x9000c590u, 0xe8006868u, 0x5c009c9cu,
        0x8e00eeeeu, 0xc5005555u},
       {0x80000000u, 0xc0000000u, 0x20000000u, 0x50000000u, 0xf8000000u, 0x74000000u,
        0xa2000000u, 0x93000000u, 0xd8800000u, 0x25400000u, 0x59e00000u, 0xe6d00000u,
        0x78080000u, 0xb40c0000u, 0x82020000u, 0xc3050000u, 0x208f8000u, 0x51474000u,
        0xfbea2000u, 0x75d93000u, 0xa0858800u, 0x914e5400u, 0xdbe79e00u, 0x25db6d00u,
        0x58800080u, 0xe54000c0u, 0x79e00020u, 0xb6d00050u, 0x800800f8u, 0xc00c0074u,
        0x200200a2u, 0x50050093u}};
    uint32_t x = 0;
    for (int k = 0; index; k++, index >>= 1)
        if (index & 1u) x ^= directions[dim - 1][k];
    return x;
}

/* Shadow rays of a pair: ray r is the segment y -> x (y on q, x on p) with
 * its weight (0: no ray needed, the sample carries no weight). Ray r takes
 * point r of the 4-D Sobol' sequence, Owen-scrambled per pair (its key,
 * from the pair's indices a, b and the seed) and per coordinate: (u, v) place y on q's square, (s, t) x on p
 * (by area or by solid angle). The first 2^m rays of a pair - its first
 * batch and each doubling - form a scrambled (t, m, 4)-net, stratified in
 * the joint 4-D space and not only in q's square, and still unbiased. A
 * fraction whose edge is a smooth shadow boundary has a variance that falls
 * faster than 1/n then (Owen 1997). Measured on cornell_sphere --subdiv 3
 * (worst |row sum - 1|, seeds 1-4, partly hidden pairs up to 64x their
 * first batch): 6.3e-4 ... 1.1e-3 with jittered cells of q and of p
 * paired by a permutation, 2.4e-4 ... 4.1e-4 with these points, which
 * reach the former's accuracy with a quarter of the refinement rays. */
static inline RAD_HD rad_u32x4 rad_ff_vis_key(uint32_t a, uint32_t b, uint64_t seed)
{
    rad_u32x4 ctr;
    ctr.v[0] = a < b ? a : b;
    ctr.v[1] = a < b ? b : a;
    ctr.v[2] = 0;
    ctr.v[3] = 2; /* a stream of its own (MC samples use 0, the QMC shift 1) */
    return rad_philox4x32(ctr, (uint32_t)seed, (uint32_t)(seed >> 32));
}

/* Ray r of the pair whose scrambles are key (rad_ff_vis_key: once a pair,
 * not once a ray). */
static inline RAD_HD double rad_ff_vis_ray(const rad_ff_patch *q, const rad_ff_patch *p, rad_u32x4 key, uint32_t r,
                                           int near, rad_vec3 *y_out, rad_vec3 *x_out)
{
    double u = rad_u01(rad_owen_scramble(rad_sobol4(r, 0), key.v[0]));
    double v = rad_u01(rad_owen_scramble(rad_sobol4(r, 1), key.v[1]));
    double s2 = rad_u01(rad_owen_scramble(rad_sobol4(r, 2), key.v[2]));
    double t2 = rad_u01(rad_owen_scramble(rad_sobol4(r, 3), key.v[3]));
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
