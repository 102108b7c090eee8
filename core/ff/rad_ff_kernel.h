/* rad_ff_kernel.h - the form-factor math, written once for CPU and GPU.
 *
 * Estimator (context.md, "Estimator"): for a patch pair (i, j), K point
 * pairs (x_k on i, y_k on j), each uniform by area, give
 *
 *     F_ij ~= (A_j / K) * sum_k G(x_k, y_k),
 *     G(x, y) = max(0, n_i.(y-x)) * max(0, n_j.(x-y)) / (pi * |y-x|^4)
 *
 * (G is the usual cos*cos/(pi r^2)). The first R of those K pairs also
 * carry a shadow ray; the kernel-weighted visible fraction
 * sum_r G_r V_r / sum_r G_r over them scales the sum, so occlusion is
 * estimated on the same points as the kernel.
 *
 * That plain point-pair estimator has unbounded variance where patches
 * touch (G ~ 1/r^2 at a shared edge or corner): rows of a closed box sum
 * to 1 +- 30% at 512 pairs, occasionally 2. Near pairs (centres closer than
 * RAD_FF_NEAR_FACTOR times the sum of their radii) therefore use the
 * near-field estimator: the inner integral over one patch in closed form
 * (Lambert's contour integral, rad_ff_point_polygon), from both sides,
 * weighted towards the smaller patch, over K/8 point pairs (see
 * rad_ff_near_sample):
 *
 *     A_i F_ij = A_j F_ji ~= (1/K') sum_k A_i A_j / (A_i + A_j) (F(x_k -> P_j) + F(y_k -> P_i)),
 *
 * bounded and smooth, so K' = K / RAD_FF_NEAR_DIVISOR samples suffice and
 * the pair costs about what K plain samples cost. Its shadow rays still
 * weigh the segment x_k -> y_k by G(x_k, y_k): the visible fraction is the
 * G-weighted mean of V over point pairs, whichever estimator gives the
 * unoccluded part. (Weighing segments by the near-field term, as this code
 * once did, estimates a different ratio: a sphere facet beside a wall got
 * F = 0.23 instead of 0.65; found by the accuracy study.)
 *
 * Sample k of the unordered pair {a, b} (a < b) is keyed by
 * (a, b, k, seed): the point on patch a comes from the first two numbers,
 * the point on patch b from the last two. Rows i and j therefore use the
 * very same point pairs, which makes A_i F_ij = A_j F_ji hold to rounding
 * and lets the matrix be computed by any split of rows.
 */
#ifndef RAD_FF_KERNEL_H
#define RAD_FF_KERNEL_H

#include <stdint.h>

#include "rad_estimator.h" /* the ids the estimators go by */
#include "rad_math.h"
#include "rad_rng.h"

/* What every pair of a run shares (rad_ff_pair.h). */
typedef struct rad_ff_pair_params {
    uint32_t estimator;   /* rad_estimator_id */
    uint32_t samples;     /* K point pairs (Monte Carlo estimators) */
    uint32_t rays;        /* R shadow rays of the first batch; 0 = no occlusion */
    uint32_t max_samples; /* --target-error cap, as a multiple base: samples (and rays) <= first * max / samples */
    uint64_t seed;
    double target_error;  /* 0 = one batch */
    double quad_rtol, quad_atol; /* rad_ff_quad_unoccluded tolerances; 0 = RAD_FF_QUAD_RTOL, _ATOL */
    double ray_floor;     /* a coupling error (F_ij / A_j) the pair's shadow rays need not go below, where
                             the caller knows what it can use (hierarchical links: ff_links.c); 0 = none */
    unsigned lane, lanes; /* this thread's share of the pair (rad_ff_quad.h, "Lanes"); 0 of 1 on the CPU */
} rad_ff_pair_params;

/* A patch as the estimators need it: flat, no pointers. */
typedef struct rad_ff_patch {
    rad_vec3 p[4];         /* vertices in winding order (p[3] = p[2] for triangles) */
    rad_vec3 normal;       /* unit */
    double area;
    double split;          /* area of triangle (p0,p1,p2) / area; 1 for triangles */
    double inv_split;      /* 1 / split */
    double inv_rest;       /* 1 / (1 - split); 0 for triangles */
    rad_vec3 centre;       /* vertex average */
    double radius;         /* largest distance from centre to a vertex */
    uint32_t face;         /* scene face it lies on (shadow rays ignore it) */
    uint32_t vertex_count; /* 3 or 4 */
} rad_ff_patch;

/* Uniform point on the patch from two numbers in (0, 1). Quads are split
 * into (p0,p1,p2) and (p0,p2,p3) by area, so the density is uniform for
 * any planar convex quad, not only parallelograms (the paper's bilinear map
 * was not). */
static inline RAD_HD rad_vec3 rad_ff_sample_point(const rad_ff_patch *patch, double u1, double u2)
{
    /* Branch-free (selects, not jumps) so that CPU compilers vectorize it
     * and GPU warps do not diverge. */
    int second = u1 >= patch->split;
    rad_vec3 a = patch->p[0];
    rad_vec3 b = second ? patch->p[2] : patch->p[1];
    rad_vec3 c = second ? patch->p[3] : patch->p[2];
    double t = second ? (u1 - patch->split) * patch->inv_rest : u1 * patch->inv_split;
    t = t < 1.0 ? t : 1.0; /* the reciprocal may round t just past 1 */
    /* Barycentric weights of a uniform point: wa = 1 - sqrt(t), wb = u2 sqrt(t). */
    double s = sqrt(t);
    double wa = 1.0 - s, wb = u2 * s, wc = s - wb;
    return rad_v3(wa * a.x + wb * b.x + wc * c.x, wa * a.y + wb * b.y + wc * c.y, wa * a.z + wb * b.z + wc * c.z);
}

/* The point pair of sample k for patches i and j, keyed on the unordered pair. */
static inline RAD_HD void rad_ff_sample_pair(const rad_ff_patch *pi, const rad_ff_patch *pj, uint32_t i, uint32_t j,
                                            uint32_t k, uint64_t seed, rad_vec3 *x, rad_vec3 *y)
{
    rad_u32x4 ctr;
    ctr.v[0] = i < j ? i : j;
    ctr.v[1] = i < j ? j : i;
    ctr.v[2] = k;
    ctr.v[3] = 0;
    rad_u32x4 r = rad_philox4x32(ctr, (uint32_t)seed, (uint32_t)(seed >> 32));
    int lower = i < j; /* patch i is the pair's first: it takes numbers 0 and 1 */
    double ua1 = rad_u01(r.v[0]), ua2 = rad_u01(r.v[1]);
    double ub1 = rad_u01(r.v[2]), ub2 = rad_u01(r.v[3]);
    *x = rad_ff_sample_point(pi, lower ? ua1 : ub1, lower ? ua2 : ub2);
    *y = rad_ff_sample_point(pj, lower ? ub1 : ua1, lower ? ub2 : ua2);
}

/* Radical inverse of k in a small prime base: the k-th Halton coordinate. */
static inline RAD_HD double rad_radical_inverse(uint32_t k, uint32_t base)
{
    double inv = 1.0 / base, f = inv, r = 0.0;
    while (k > 0) {
        r += (double)(k % base) * f;
        k /= base;
        f *= inv;
    }
    return r;
}

/* x mod 1 for x in [0, 2). */
static inline RAD_HD double rad_wrap01(double x) { return x >= 1.0 ? x - 1.0 : x; }

/* Sample k of pair (i, j) from the 4-D Halton sequence (bases 2, 3 for the
 * lower-numbered patch, 5, 7 for the other), shifted by a random vector
 * drawn once per unordered pair (Cranley-Patterson rotation): every point
 * is still uniform, so the estimate stays unbiased, while the points of one
 * pair spread evenly, so the error falls faster than 1/sqrt(K) for smooth
 * integrands. Keyed like the MC points, so rows i and j share them. */
static inline RAD_HD void rad_ff_sample_pair_qmc(const rad_ff_patch *pi, const rad_ff_patch *pj, uint32_t i, uint32_t j,
                                                uint32_t k, uint64_t seed, rad_vec3 *x, rad_vec3 *y)
{
    rad_u32x4 ctr;
    ctr.v[0] = i < j ? i : j;
    ctr.v[1] = i < j ? j : i;
    ctr.v[2] = 0xFFFFFFFFu; /* a counter no MC sample uses */
    ctr.v[3] = 1;
    rad_u32x4 r = rad_philox4x32(ctr, (uint32_t)seed, (uint32_t)(seed >> 32));
    uint32_t index = k + 1; /* index 0 is the all-zero point */
    double ua1 = rad_wrap01(rad_radical_inverse(index, 2) + rad_u01(r.v[0]));
    double ua2 = rad_wrap01(rad_radical_inverse(index, 3) + rad_u01(r.v[1]));
    double ub1 = rad_wrap01(rad_radical_inverse(index, 5) + rad_u01(r.v[2]));
    double ub2 = rad_wrap01(rad_radical_inverse(index, 7) + rad_u01(r.v[3]));
    int lower = i < j;
    *x = rad_ff_sample_point(pi, lower ? ua1 : ub1, lower ? ua2 : ub2);
    *y = rad_ff_sample_point(pj, lower ? ub1 : ua1, lower ? ub2 : ua2);
}

/* The point pair of sample k for the estimator's sequence. */
static inline RAD_HD void rad_ff_pair_points(uint32_t estimator, const rad_ff_patch *pi, const rad_ff_patch *pj,
                                             uint32_t i, uint32_t j, uint32_t k, uint64_t seed, rad_vec3 *x,
                                             rad_vec3 *y)
{
    if (estimator == RAD_ESTIMATOR_QMC)
        rad_ff_sample_pair_qmc(pi, pj, i, j, k, seed, x, y);
    else
        rad_ff_sample_pair(pi, pj, i, j, k, seed, x, y);
}

/* G(x, y) = cos_i cos_j / (pi r^2), zero for back-facing directions. */
static inline RAD_HD double rad_ff_point_kernel(rad_vec3 x, rad_vec3 nx, rad_vec3 y, rad_vec3 ny)
{
    rad_vec3 d = rad_v3_sub(y, x);
    double r2 = rad_v3_dot(d, d);
    double ci = rad_v3_dot(nx, d), cj = -rad_v3_dot(ny, d);
    double g = ci * cj / (RAD_PI * r2 * r2);
    /* A select, not a branch (see above); r2 = 0 gives NaN, discarded here. */
    return ci > 0.0 && cj > 0.0 && r2 > 0.0 ? g : 0.0;
}

/* Can the two patches exchange light at all? No if every vertex of one lies
 * on or behind the other's plane (within eps, scene units); this also makes
 * coplanar pairs and i == j exactly zero. */
static inline RAD_HD int rad_ff_pair_facing(const rad_ff_patch *pi, const rad_ff_patch *pj, double eps)
{
    /* Pieces of one face (its patches, its contact-cut pieces) lie in one
     * plane: the loader accepts a face only when it is planar to 1e-6 of
     * its size, so their vertices may sit off each other's planes by more
     * than eps, but they cannot see each other. F = 0 by definition. */
    if (pi->face == pj->face) return 0;
    int front_j = 0, front_i = 0;
    for (uint32_t k = 0; k < pj->vertex_count; k++)
        front_j |= rad_v3_dot(pi->normal, rad_v3_sub(pj->p[k], pi->p[0])) > eps;
    for (uint32_t k = 0; k < pi->vertex_count; k++)
        front_i |= rad_v3_dot(pj->normal, rad_v3_sub(pi->p[k], pj->p[0])) > eps;
    return front_i && front_j;
}

/* What the backends return for a pair: the coupling c_ij = F_ij / A_j
 * = F_ji / A_i (the mean of G over the point pairs, times the visible
 * fraction), symmetric in (i, j) to the bit because every sum and product
 * behind it is. The driver turns it into F_ij = c_ij * A_j, so entries
 * (i, j) and (j, i) get identical bits whether both rows compute the pair
 * or one row computes it and the other copies it (--reciprocity). */
static inline RAD_HD double rad_ff_coupling_far(double kernel_sum, uint32_t samples)
{
    return kernel_sum / samples;
}

/* The near-field terms estimate A_i F_ij; divided by A_i A_j they give c_ij. */
static inline RAD_HD double rad_ff_coupling_near(double term_sum, uint32_t samples, const rad_ff_patch *a,
                                                 const rad_ff_patch *b)
{
    return term_sum / samples / (a->area * b->area);
}

/* Running sums of one pair's estimate: enough for its value and its
 * standard error. Sample terms t_k are G(x_k, y_k) for far pairs and the
 * near-field terms for near ones; the R shadow rays add their term g_r
 * and visibility V_r in {0, 1}. Every sum is symmetric in (i, j). */
typedef struct rad_ff_sums {
    double terms, terms_sq;            /* sum t_k, sum t_k^2 */
    double ray_terms, ray_seen;        /* sum g_r, sum g_r V_r */
    double ray_terms_sq, ray_seen_sq;  /* sum g_r^2, sum g_r^2 V_r */
    uint32_t samples, rays, visible;
} rad_ff_sums;

/* Coupling c = c_u * V and its standard error from the sums: c_u is the
 * sample mean (its variance the sample variance / K), V the
 * kernel-weighted visible fraction sum g V / sum g (a ratio estimator:
 * variance ~ sum g^2 (V - V^)^2 / (sum g)^2), combined to first order as
 * independent. Without rays V = 1 exactly. The value's bits are those of
 * rad_ff_coupling_* times the fraction, whatever is asked of the error. */
static inline RAD_HD double rad_ff_estimate(const rad_ff_sums *s, int near, const rad_ff_patch *a, const rad_ff_patch *b,
                                            double *standard_error)
{
    double k = (double)s->samples;
    double c = near ? rad_ff_coupling_near(s->terms, s->samples, a, b) : rad_ff_coupling_far(s->terms, s->samples);
    double scale = near ? 1.0 / (a->area * b->area) : 1.0;
    double var_c = 0.0;
    if (s->samples > 1) {
        double spread = s->terms_sq - s->terms * s->terms / k; /* sum (t - mean)^2 */
        var_c = (spread > 0.0 ? spread : 0.0) / (k * (k - 1.0)) * scale * scale;
    } else {
        var_c = c * c; /* one sample says nothing of its error: as large as the value */
    }
    double fraction = 1.0, var_v = 0.0;
    if (s->rays > 0 && s->ray_terms > 0.0) {
        fraction = s->ray_seen / s->ray_terms;
        double hidden = s->ray_terms_sq - s->ray_seen_sq; /* sum g^2 (1 - V), >= 0 but for rounding */
        hidden = hidden > 0.0 ? hidden : 0.0;
        double spread = s->ray_seen_sq * (1.0 - fraction) * (1.0 - fraction) + hidden * fraction * fraction;
        var_v = spread / (s->ray_terms * s->ray_terms);
    } else if (s->rays > 0) { /* no kept sample has weight (all grazing): the plain fraction */
        fraction = (double)s->visible / s->rays;
        var_v = fraction * (1.0 - fraction) / s->rays;
    }
    if (standard_error) *standard_error = sqrt(fraction * fraction * var_c + c * c * var_v);
    return c * fraction;
}

/* --target-error: has the pair's estimate reached it? The larger of its
 * two entries' errors (F_ij = c A_j, F_ji = c A_i) decides, so rows i and
 * j stop at the same sample count. */
static inline RAD_HD int rad_ff_error_reached(double coupling_error, const rad_ff_patch *a, const rad_ff_patch *b,
                                              double target)
{
    double area = a->area > b->area ? a->area : b->area;
    return !(coupling_error * area > target);
}

/* --target-error schedule: the next batch takes the pair from s->samples
 * to twice that (samples_to), and its shadow rays in the same proportion
 * to the first batch's (rays_to); the pair's cap is its first batch scaled
 * by max_samples / samples (a near pair's smaller first batch included).
 * None (0 is returned) once the pair holds its cap. */
static inline RAD_HD int rad_ff_next_batch(const rad_ff_sums *s, uint32_t first_samples, uint32_t first_rays,
                                           uint32_t samples, uint32_t max_samples, uint32_t *samples_to,
                                           uint32_t *rays_to)
{
    uint64_t cap = (uint64_t)first_samples * max_samples / samples;
    if (s->samples >= cap) return 0;
    uint64_t to = 2 * (uint64_t)s->samples < cap ? 2 * (uint64_t)s->samples : cap;
    uint64_t rays = (uint64_t)first_rays * to / first_samples;
    *samples_to = (uint32_t)to;
    *rays_to = (uint32_t)(rays < to ? rays : to);
    return 1;
}

/* Which row computes the unordered pair {i, j} when each pair is computed
 * once: the lower-numbered row when i + j is odd, the higher one when it
 * is even (row i itself for i == j). Every row then computes about half
 * of its entries, spread evenly over all columns, so the contiguous row
 * blocks of the ranks stay balanced without a triangular split. */
static inline RAD_HD int rad_ff_row_computes(uint32_t i, uint32_t j)
{
    uint32_t lower = i < j ? i : j, upper = i < j ? j : i;
    return ((i ^ j) & 1u) ? i == lower : i == upper;
}

/* How many entries of row i (of n) rad_ff_row_computes assigns to row i:
 * itself, the columns above it of the other parity, those below of the same. */
static inline RAD_HD uint64_t rad_ff_row_computes_count(uint32_t i, uint32_t n)
{
    return 1u + (uint64_t)((n - i) / 2) + (uint64_t)(i / 2);
}

/* Near-field rule and sample budget (see the top of this file). */
#define RAD_FF_NEAR_FACTOR 2.0
#define RAD_FF_NEAR_DIVISOR 8u
#define RAD_FF_NEAR_MIN_SAMPLES 16u

static inline RAD_HD int rad_ff_pair_near(const rad_ff_patch *a, const rad_ff_patch *b)
{
    rad_vec3 d = rad_v3_sub(a->centre, b->centre);
    double reach = RAD_FF_NEAR_FACTOR * (a->radius + b->radius);
    return rad_v3_dot(d, d) < reach * reach;
}

/* Does the pair take the contour (near-field) estimator? `analytic`: every
 * pair; `auto`: near pairs; `mc`, `qmc`: none. */
static inline RAD_HD int rad_ff_pair_uses_contour(uint32_t estimator, const rad_ff_patch *a, const rad_ff_patch *b)
{
    return estimator == RAD_ESTIMATOR_ANALYTIC || (estimator == RAD_ESTIMATOR_AUTO && rad_ff_pair_near(a, b));
}

/* Samples a near pair takes when far pairs take `samples`. */
static inline RAD_HD uint32_t rad_ff_near_samples(uint32_t samples)
{
    uint32_t k = samples / RAD_FF_NEAR_DIVISOR;
    if (k < RAD_FF_NEAR_MIN_SAMPLES) k = samples < RAD_FF_NEAR_MIN_SAMPLES ? samples : RAD_FF_NEAR_MIN_SAMPLES;
    return k;
}

/* Unoccluded form factor from a differential area at x (unit normal n) to
 * the patch `to`: Lambert's contour integral
 *     F = (1/2pi) sum_edges gamma_e n.(r_e x r_e+1) / |r_e x r_e+1|
 * over the part of `to` in front of x's tangent plane (clipped). Zero when
 * x is on or behind the plane of `to`. Bounded (<= 1) however close x is. */
static inline RAD_HD double rad_ff_point_polygon(rad_vec3 x, rad_vec3 n, const rad_ff_patch *to)
{
    if (!(rad_v3_dot(to->normal, rad_v3_sub(x, to->p[0])) > 0.0)) return 0.0;
    /* Each edge adds at most two vertices, whatever the signs of ha and hb
     * come out as: with x in the target's plane to within rounding they
     * may alternate around the polygon, so the bound is 2 per vertex, not
     * the 5 that exact arithmetic gives a quad cut by one plane. */
    rad_vec3 clipped[2 * 4];
    int m = 0;
    uint32_t count = to->vertex_count;
    for (uint32_t e = 0; e < count; e++) {
        rad_vec3 a = to->p[e], b = to->p[e + 1 < count ? e + 1 : 0];
        double ha = rad_v3_dot(n, rad_v3_sub(a, x)), hb = rad_v3_dot(n, rad_v3_sub(b, x));
        if (ha >= 0.0) clipped[m++] = a;
        if ((ha >= 0.0) != (hb >= 0.0)) clipped[m++] = rad_v3_lerp(a, b, ha / (ha - hb));
    }
    double sum = 0.0;
    for (int e = 0; e < m; e++) {
        rad_vec3 ra = rad_v3_sub(clipped[e], x), rb = rad_v3_sub(clipped[e + 1 < m ? e + 1 : 0], x);
        rad_vec3 c = rad_v3_cross(ra, rb);
        double cl = rad_v3_length(c);
        if (cl > 0.0) sum += atan2(cl, rad_v3_dot(ra, rb)) * rad_v3_dot(n, c) / cl;
    }
    return fabs(sum) / (2.0 * RAD_PI);
}

/* Near-field sample k of pair (i, j): an estimate of A_i F_ij = A_j F_ji
 * from the point factors of both sides, weighted towards the smaller patch:
 *
 *     S_k = A_i A_j / (A_i + A_j) * (F(x_k -> P_j) + F(y_k -> P_i))
 *
 * (unbiased: the two expectations are F_ij and F_ji = A_i F_ij / A_j).
 * Equal areas give the plain two-sided average, which cancels much of each
 * side's variance; very unequal ones lean on the smaller patch, where the
 * point factor is smooth - from the larger one it peaks where the patches
 * meet (a thin strip beside a tall wall), and that side's term then weighs
 * A_small / (A_i + A_j) of its already small share. Symmetric in (i, j), so
 * rows i and j get the same bits. x on i and y on j are the sample's point
 * pair (for its shadow ray). */
static inline RAD_HD double rad_ff_near_sample(const rad_ff_patch *pi, const rad_ff_patch *pj, uint32_t i, uint32_t j,
                                               uint32_t k, uint64_t seed, rad_vec3 *x, rad_vec3 *y)
{
    rad_ff_sample_pair(pi, pj, i, j, k, seed, x, y);
    double weight = pi->area * pj->area / (pi->area + pj->area);
    return weight * (rad_ff_point_polygon(*x, pi->normal, pj) + rad_ff_point_polygon(*y, pj->normal, pi));
}

#endif
