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
 * Sample k of the unordered pair {a, b} (a < b) is keyed by
 * (a, b, k, seed): the point on patch a comes from the first two numbers,
 * the point on patch b from the last two. Rows i and j therefore use the
 * very same point pairs, which makes A_i F_ij = A_j F_ji hold to rounding
 * and lets the matrix be computed by any split of rows.
 */
#ifndef RAD_FF_KERNEL_H
#define RAD_FF_KERNEL_H

#include <stdint.h>

#include "rad_math.h"
#include "rad_rng.h"

/* A patch as the estimators need it: flat, no pointers. */
typedef struct rad_ff_patch {
    rad_vec3 p[4];         /* vertices in winding order (p[3] = p[2] for triangles) */
    rad_vec3 normal;       /* unit */
    double area;
    double split;          /* area of triangle (p0,p1,p2) / area; 1 for triangles */
    double inv_split;      /* 1 / split */
    double inv_rest;       /* 1 / (1 - split); 0 for triangles */
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
    int front_j = 0, front_i = 0;
    for (uint32_t k = 0; k < pj->vertex_count; k++)
        front_j |= rad_v3_dot(pi->normal, rad_v3_sub(pj->p[k], pi->p[0])) > eps;
    for (uint32_t k = 0; k < pi->vertex_count; k++)
        front_i |= rad_v3_dot(pj->normal, rad_v3_sub(pi->p[k], pj->p[0])) > eps;
    return front_i && front_j;
}

#endif
