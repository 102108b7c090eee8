/* rad_ff_contour.h - the unoccluded interchange area of two touching or
 * near patches by the double contour integral (host and device).
 *
 * Stokes' theorem applied twice (Sparrow 1963; Mitalas & Stephenson 1967)
 * turns the area integral of cos cos / (pi r^2) into one over the two
 * boundaries:
 *
 *     G = A_q F_qp = 1/(2 pi) sum_k sum_l (e_k . f_l) int_0^1 int_0^1 ln |c_kl(s) - t f_l| dt ds,
 *     c_kl(s) = a_k + s e_k - b_l,
 *
 * over the edges e_k = a_k+1 - a_k of q and f_l = b_l+1 - b_l of p, both
 * wound as the patches are (counter-clockwise about their own normals).
 * It holds when each patch lies on or in front of the other's plane; a
 * pair where one patch's plane cuts the other is first clipped:
 * the kernel vanishes unless each point is in front of the other's plane,
 * so G(q, p) = G(q in front of p, p in front of q), two convex polygons
 * that meet, if at all, along the planes' intersection line - a collinear
 * edge pair. (The area rule meets a kink there, inside q, that no grading
 * follows: straddling pairs of Suzanne cost it 27 000 - 33 000 point
 * factors each, 99 % of the whole run.)
 * Perpendicular edge pairs drop out. For each remaining pair:
 *  - collinear edges (a shared edge, or two edges on one line): the whole
 *    double integral in closed form, from H(z) = z^2 ln|z| / 2 - 3 z^2 / 4;
 *  - otherwise the inner integral over t in closed form,
 *        int ln(A (u^2 + D)) / 2 du = [u ln(A (u^2 + D)) - 2 u + 2 sqrt(D) atan(u / sqrt(D))] / 2,
 *    A = |f|^2, D = |c x f|^2 / A^2 (the squared distance from c to f's
 *    line over A), and the outer integral over s by Gauss-Legendre on
 *    pieces graded (s = s* +- (..) tau^3) towards the point s* of e_k
 *    nearest f_l, where the integrand behaves like (s - s*) ln |s - s*|
 *    when the edges meet (a shared vertex, a T-junction), and towards
 *    where the foot of c(s) on f passes f's ends (close parallel edges).
 * Orders 10 and 12 on the same pieces give the error estimate (the sum of
 * their differences, plus the rounding of the terms, which cancel:
 * 16 ulps of their magnitudes); level L splits every piece into 2^L.
 *
 * Why: the area quadrature (rad_ff_quad.h) needs thousands of point
 * factors for a pair that shares an edge or vertex at rtol 1e-8 (measured:
 * 3 000 - 11 000 for two triangles hinged at 10 ... 179 degrees, against
 * 13 - 60 for a far pair); this needs at most (16 edge pairs) x 2 pieces x
 * 20 nodes at level 0. Far apart, the edge terms (|e|^2 ln d) cancel down
 * to G ~ |e|^4 / d^2 and lose digits: used for near pairs only
 * (rad_ff_contour_applies), where the area rule is kept as the fallback.
 */
#ifndef RAD_FF_CONTOUR_H
#define RAD_FF_CONTOUR_H

#include <float.h>
#include <stdint.h>

#include "rad_ff_kernel.h"
#include "rad_ff_quad.h" /* the Gauss-Legendre tables, RAD_FF_LANE_SUM */
#include "rad_math.h"

#define RAD_FF_CONTOUR_MAX_LEVEL 4
#define RAD_FF_CONTOUR_LO 10 /* Gauss-Legendre orders of the estimate (rad_ff_quad.h's tables) */
#define RAD_FF_CONTOUR_HI 12
#define RAD_FF_CONTOUR_SIZE_RATIO 0.01 /* smaller radius over larger, at least */
#define RAD_FF_CONTOUR_SLIVER 1e-3     /* area over radius squared, at least */
#define RAD_FF_CONTOUR_GAP 0.25        /* near pairs closer than this times the smaller radius */
#define RAD_FF_CONTOUR_CUTS 3 /* interior breakpoints of one edge pair's outer integral, at most */

/* H(z) = z^2 ln|z| / 2 - 3 z^2 / 4, with H(0) = 0. */
static inline RAD_HD double rad_ff_contour_h(double z)
{
    double z2 = z * z;
    return z2 > 0.0 ? 0.5 * z2 * log(fabs(z)) - 0.75 * z2 : 0.0;
}

/* int_{x0}^{x1} int_{y0}^{y1} ln|x - y| dy dx. */
static inline RAD_HD double rad_ff_contour_collinear(double x0, double x1, double y0, double y1)
{
    return -(rad_ff_contour_h(x1 - y1) - rad_ff_contour_h(x1 - y0) - rad_ff_contour_h(x0 - y1) +
             rad_ff_contour_h(x0 - y0));
}

/* [u ln(A (u^2 + D)) - 2 u + 2 sqrt(D) atan(u / sqrt(D))] / 2 (D >= 0). */
static inline RAD_HD double rad_ff_contour_antiderivative(double u, double a, double d, double sqrt_d)
{
    double w = u * u + d;
    double log_term = w > 0.0 ? u * log(a * w) : 0.0;
    return 0.5 * (log_term - 2.0 * u + 2.0 * sqrt_d * atan2(u, sqrt_d));
}

/* int_0^1 ln |c - t f| dt (A = f.f > 0). */
static inline RAD_HD double rad_ff_contour_inner(rad_vec3 c, rad_vec3 f, double a)
{
    double along = rad_v3_dot(c, f) / a;
    rad_vec3 x = rad_v3_cross(c, f);
    double d = rad_v3_dot(x, x) / (a * a);
    double sqrt_d = sqrt(d);
    return rad_ff_contour_antiderivative(1.0 - along, a, d, sqrt_d) -
           rad_ff_contour_antiderivative(-along, a, d, sqrt_d);
}

/* Parameter s in [0, 1] of the point of segment a + s e nearest segment
 * b + t f, and that distance. */
static inline RAD_HD double rad_ff_contour_nearest(rad_vec3 a, rad_vec3 e, rad_vec3 b, rad_vec3 f, double *distance)
{
    /* Minimise |a + s e - b - t f| over the square by checking the interior
     * stationary point and the four sides. */
    rad_vec3 w = rad_v3_sub(a, b);
    double ee = rad_v3_dot(e, e), ff = rad_v3_dot(f, f), ef = rad_v3_dot(e, f);
    double we = rad_v3_dot(w, e), wf = rad_v3_dot(w, f);
    double det = ee * ff - ef * ef;
    double best_s = 0.0, best = INFINITY;
    if (det > 1e-14 * ee * ff) {
        double s = (ef * wf - ff * we) / det, t = (ee * wf - ef * we) / det;
        if (s >= 0.0 && s <= 1.0 && t >= 0.0 && t <= 1.0) {
            rad_vec3 g = rad_v3_sub(rad_v3_add(w, rad_v3_scale(e, s)), rad_v3_scale(f, t));
            best = rad_v3_dot(g, g), best_s = s;
        }
    }
    for (int side = 0; side < 4; side++) {
        double s, t;
        if (side < 2) { /* s fixed at 0 or 1: t free */
            s = (double)side;
            t = (wf + s * ef) / ff;
            t = t < 0.0 ? 0.0 : t > 1.0 ? 1.0 : t;
        } else { /* t fixed: s free */
            t = (double)(side - 2);
            s = (t * ef - we) / ee;
            s = s < 0.0 ? 0.0 : s > 1.0 ? 1.0 : s;
        }
        rad_vec3 g = rad_v3_sub(rad_v3_add(w, rad_v3_scale(e, s)), rad_v3_scale(f, t));
        double d2 = rad_v3_dot(g, g);
        if (d2 < best) best = d2, best_s = s;
    }
    *distance = sqrt(best);
    return best_s;
}

/* Is every vertex of a on or in front of b's plane (within eps)? */
static inline RAD_HD int rad_ff_contour_in_front(const rad_ff_patch *a, const rad_ff_patch *b, double eps)
{
    for (uint32_t k = 0; k < a->vertex_count; k++)
        if (rad_v3_dot(b->normal, rad_v3_sub(a->p[k], b->p[0])) < -eps) return 0;
    return 1;
}

/* The distance between two patches that do not cross: the least over
 * their edge pairs and over each vertex above the other's inside. */
static inline RAD_HD double rad_ff_contour_gap(const rad_ff_patch *q, const rad_ff_patch *p)
{
    double best = INFINITY;
    const rad_ff_patch *from[2] = {q, p}, *to[2] = {p, q};
    for (int side = 0; side < 2; side++) {
        const rad_ff_patch *a = from[side], *b = to[side];
        for (uint32_t k = 0; k < a->vertex_count; k++) {
            rad_vec3 x = a->p[k], ea = rad_v3_sub(a->p[k + 1 < a->vertex_count ? k + 1 : 0], x);
            if (side == 0)
                for (uint32_t l = 0; l < b->vertex_count; l++) {
                    rad_vec3 y = b->p[l], eb = rad_v3_sub(b->p[l + 1 < b->vertex_count ? l + 1 : 0], y);
                    double d;
                    rad_ff_contour_nearest(x, ea, y, eb, &d);
                    best = d < best ? d : best;
                }
            /* x over b's inside: every edge of b has x on its inner side. */
            int inside = 1;
            for (uint32_t l = 0; l < b->vertex_count && inside; l++) {
                rad_vec3 y = b->p[l], eb = rad_v3_sub(b->p[l + 1 < b->vertex_count ? l + 1 : 0], y);
                inside = rad_v3_dot(rad_v3_cross(eb, rad_v3_sub(x, y)), b->normal) >= 0.0;
            }
            if (inside) {
                double h = fabs(rad_v3_dot(b->normal, rad_v3_sub(x, b->p[0])));
                best = h < best ? h : best;
            }
        }
    }
    return best;
}

/* Does q, the patch the area rule integrates over, reach behind p's
 * plane? Then that rule's integrand has a kink inside q, where it crosses
 * the plane. (Where only p reaches behind q's plane, the point factor
 * clips p by q's plane, the same for every point of q: no kink.) */
static inline RAD_HD int rad_ff_contour_straddles(const rad_ff_patch *q, const rad_ff_patch *p)
{
    return !rad_ff_contour_in_front(q, p, 1e-12 * (q->radius + p->radius));
}

/* Does the pair take the contour integral? Near pairs (centres closer
 * than RAD_FF_NEAR_FACTOR times the sum of their radii) and pairs that
 * straddle. Where it does not reach the tolerance, near pairs that do not
 * straddle fall back to the area rule; straddling ones keep the contour's
 * value and error (measured on Suzanne: the area rule is then off by up to
 * 2e-3 relative with error bounds of 1e-21, where the contour integral
 * agrees with a brute-force sum of 1600^2 points to 1e-8). */
static inline RAD_HD int rad_ff_contour_applies(const rad_ff_patch *q, const rad_ff_patch *p)
{
    /* Not for a patch far smaller than the other (radii 1 : 100 or more):
     * its edge terms, |e| |f| ln r, cancel down to G ~ |e|^2 F, and the
     * area rule over the small one converges fast anyway (a straddling one
     * clipped first: rad_ff_pair_quad_unoccluded). */
    double small = q->radius < p->radius ? q->radius : p->radius, large = q->radius < p->radius ? p->radius : q->radius;
    if (small < RAD_FF_CONTOUR_SIZE_RATIO * large) return 0;
    /* Nor for slivers (area under RAD_FF_CONTOUR_SLIVER of the radius
     * squared): their two long edges' terms cancel the same way. */
    if (q->area < RAD_FF_CONTOUR_SLIVER * q->radius * q->radius ||
        p->area < RAD_FF_CONTOUR_SLIVER * p->radius * p->radius)
        return 0;
    if (rad_ff_contour_straddles(q, p)) return 1;
    /* Near pairs that (nearly) touch: there the area rule grades or
     * subdivides at length. Near pairs further apart are cheap for it
     * (13 - 60 point factors; the contour integral takes 150 or more). */
    return rad_ff_pair_near(q, p) && rad_ff_contour_gap(q, p) < RAD_FF_CONTOUR_GAP * small;
}

/* A convex polygon of up to RAD_FF_POLY_MAX vertices: a patch, or a patch
 * clipped by one plane (at most one vertex more). */
#define RAD_FF_POLY_MAX 6
typedef struct rad_ff_poly {
    rad_vec3 v[RAD_FF_POLY_MAX];
    uint32_t n;
} rad_ff_poly;

/* The part of patch a on or in front of b's plane. Heights within eps of
 * the plane count as on it. A convex polygon crosses a plane at most
 * twice; more crossings are rounding, and then only the vertices on or in
 * front are kept, so the bound holds whatever the signs. */
static inline RAD_HD rad_ff_poly rad_ff_poly_in_front(const rad_ff_patch *a, const rad_ff_patch *b, double eps)
{
    rad_ff_poly out;
    out.n = 0;
    uint32_t n = a->vertex_count;
    double h[4];
    int changes = 0;
    for (uint32_t k = 0; k < n; k++) {
        h[k] = rad_v3_dot(b->normal, rad_v3_sub(a->p[k], b->p[0]));
        if (fabs(h[k]) <= eps) h[k] = 0.0;
    }
    for (uint32_t k = 0; k < n; k++) changes += (h[k] >= 0.0) != (h[k + 1 < n ? k + 1 : 0] >= 0.0);
    for (uint32_t k = 0; k < n; k++) {
        uint32_t k1 = k + 1 < n ? k + 1 : 0;
        if (h[k] >= 0.0) out.v[out.n++] = a->p[k];
        if (changes <= 2 && ((h[k] > 0.0 && h[k1] < 0.0) || (h[k] < 0.0 && h[k1] > 0.0)))
            out.v[out.n++] = rad_v3_lerp(a->p[k], a->p[k1], h[k] / (h[k] - h[k1]));
    }
    return out;
}

/* Triangle t (1 .. n - 2) of the fan of poly from its vertex 0, as a
 * patch lying on `like`'s plane (its normal and face). */
static inline RAD_HD rad_ff_patch rad_ff_poly_fan_triangle(const rad_ff_poly *poly, uint32_t t, const rad_ff_patch *like)
{
    rad_ff_patch out = *like;
    out.p[0] = poly->v[0], out.p[1] = poly->v[t], out.p[2] = poly->v[t + 1], out.p[3] = poly->v[t + 1];
    out.vertex_count = 3;
    out.area = 0.5 * rad_v3_length(rad_v3_cross(rad_v3_sub(out.p[1], out.p[0]), rad_v3_sub(out.p[2], out.p[0])));
    out.centre = rad_v3_scale(rad_v3_add(out.p[0], rad_v3_add(out.p[1], out.p[2])), 1.0 / 3.0);
    out.radius = 0.0;
    for (int k = 0; k < 3; k++) {
        double r = rad_v3_length(rad_v3_sub(out.p[k], out.centre));
        out.radius = r > out.radius ? r : out.radius;
    }
    out.split = 1.0, out.inv_split = 1.0, out.inv_rest = 0.0;
    return out;
}

/* What rad_ff_contour_g found. */
typedef struct rad_ff_contour_result {
    double g;        /* G = A_q F_qp */
    double error;    /* estimate of |G - exact| */
    uint32_t points; /* inner integrals evaluated */
    int converged;   /* error <= tolerance by RAD_FF_CONTOUR_MAX_LEVEL */
} rad_ff_contour_result;

/* The edge pair's outer integral over one graded piece: s runs from
 * s_from (the singular end, tau = 0) to s_to, s = s_from + (s_to - s_from)
 * tau^3, tau in [tau0, tau0 + dtau]; both rules at once. Their nodes are
 * numbered 0 .. LO + HI - 1 (the low rule's first); this thread takes
 * those congruent to `sub` modulo `subs` (all of them: sub 0 of 1), and
 * returns its part of each sum. */
static inline RAD_HD void rad_ff_contour_piece(rad_vec3 a, rad_vec3 e, rad_vec3 b, rad_vec3 f, double ff, int graded,
                                               double s_from, double s_to, double tau0, double dtau, unsigned sub,
                                               unsigned subs, double *lo, double *hi, double *magnitude)
{
    double sum_lo = 0.0, sum_hi = 0.0, mag = 0.0;
    rad_vec3 base = rad_v3_sub(a, b);
    for (unsigned node = sub; node < RAD_FF_CONTOUR_LO + RAD_FF_CONTOUR_HI; node += subs) {
        int rule = node >= RAD_FF_CONTOUR_LO;
        int n = rule ? RAD_FF_CONTOUR_HI : RAD_FF_CONTOUR_LO, k = rule ? (int)node - RAD_FF_CONTOUR_LO : (int)node;
        double tau = tau0 + dtau * rad_ff_gl_node(n, k);
        double s = s_from + (s_to - s_from) * (graded ? tau * tau * tau : tau);
        double ds = (s_to - s_from) * (graded ? 3.0 * tau * tau : 1.0) * dtau;
        double v = rad_ff_gl_weight(n, k) * ds * rad_ff_contour_inner(rad_v3_add(base, rad_v3_scale(e, s)), f, ff);
        if (rule)
            sum_hi += v, mag += fabs(v);
        else
            sum_lo += v;
    }
    *lo = sum_lo, *hi = sum_hi, *magnitude = mag;
}

/* Lanes that share one work item of the contour integral (a power of two
 * dividing `lanes`): the fewest that take the level's `items` in the
 * fewest rounds of node evaluations. A work item is LO + HI evaluations
 * of the inner integral; a near pair of two triangles has 9 items at
 * level 0, which one item a lane would leave 23 of a warp's 32 lanes
 * idle; 8 lanes an item take them in 3 rounds of 3 instead of 22. */
static inline RAD_HD unsigned rad_ff_contour_item_lanes(int items, unsigned lanes)
{
    const int nodes = RAD_FF_CONTOUR_LO + RAD_FF_CONTOUR_HI;
    unsigned best = 1;
    long best_cost = -1;
    for (unsigned subs = 1; subs <= lanes; subs *= 2) {
        long groups = (long)(lanes / subs);
        long cost = ((items + groups - 1) / groups) * ((nodes + (long)subs - 1) / (long)subs);
        if (best_cost < 0 || cost < best_cost) best = subs, best_cost = cost;
    }
    return best;
}

/* G of q and p (rad_ff_contour_applies) to max(rtol |G|, atol A_q);
 * this thread is `lane` of `lanes` (rad_ff_quad.h, "Lanes"). */
static inline RAD_HD rad_ff_contour_result rad_ff_contour_g(const rad_ff_patch *q, const rad_ff_patch *p, double rtol,
                                                           double atol, unsigned lane, unsigned lanes)
{
    rad_ff_contour_result out;
    out.g = 0.0, out.error = 0.0, out.points = 0, out.converged = 0;
    double scale = q->radius + p->radius;
    rad_ff_poly qc = rad_ff_poly_in_front(q, p, 1e-14 * scale), pc = rad_ff_poly_in_front(p, q, 1e-14 * scale);
    uint32_t nq = qc.n, np = pc.n;
    if (nq < 3 || np < 3) { /* nothing of one in front of the other */
        out.converged = 1;
        return out;
    }
    /* The closed-form (collinear) part and the breakpoints depend on the
     * geometry only: computed once, by every lane alike. The outer
     * integrand is smooth but where c(s) comes close to f: at the point s*
     * of e nearest f, and where the foot of c(s) on f's line passes f's
     * ends (close, nearly parallel edges: a kink of the width of their
     * distance). Each such point closer than a quarter of the shorter
     * edge is a breakpoint; every interval between breakpoints (and 0, 1)
     * is split in halves graded towards their ends. */
    double exact = 0.0, exact_mag = 0.0;
    double cut[RAD_FF_POLY_MAX * RAD_FF_POLY_MAX][RAD_FF_CONTOUR_CUTS];
    int cuts[RAD_FF_POLY_MAX * RAD_FF_POLY_MAX]; /* -1: dropped (perpendicular, or collinear: in `exact`);
                                                     0: apart, one plain piece; else interior breakpoints + 1 */
    for (uint32_t k = 0; k < nq; k++)
        for (uint32_t l = 0; l < np; l++) {
            int kl = (int)(k * RAD_FF_POLY_MAX + l);
            rad_vec3 a = qc.v[k], e = rad_v3_sub(qc.v[k + 1 < nq ? k + 1 : 0], a);
            rad_vec3 b = pc.v[l], f = rad_v3_sub(pc.v[l + 1 < np ? l + 1 : 0], b);
            double ee = rad_v3_dot(e, e), ff = rad_v3_dot(f, f), ef = rad_v3_dot(e, f);
            cuts[kl] = -1;
            if (!(ee > 0.0 && ff > 0.0) || fabs(ef) <= 1e-15 * sqrt(ee * ff)) continue;
            /* Collinear: both ends of e on f's line. */
            rad_vec3 c0 = rad_v3_cross(rad_v3_sub(a, b), f), c1 = rad_v3_cross(rad_v3_sub(rad_v3_add(a, e), b), f);
            double tol_line = 1e-12 * scale * sqrt(ff);
            if (rad_v3_length(c0) <= tol_line && rad_v3_length(c1) <= tol_line) {
                double lf = sqrt(ff);
                rad_vec3 w = rad_v3_scale(f, 1.0 / lf);
                double x0 = rad_v3_dot(rad_v3_sub(a, b), w), x1 = rad_v3_dot(rad_v3_sub(rad_v3_add(a, e), b), w);
                if (x1 != x0) {
                    double v = ef * rad_ff_contour_collinear(x0, x1, 0.0, lf) / ((x1 - x0) * lf);
                    exact += v, exact_mag += fabs(v);
                }
                continue;
            }
            double near2 = 0.0625 * (ee < ff ? ee : ff), distance;
            double candidates[3];
            int n = 0;
            candidates[n++] = rad_ff_contour_nearest(a, e, b, f, &distance);
            if (distance * distance > near2) n = 0;
            /* The foot of c(s) = a + s e - b on f's line is at t = (c.f)/ff: t = 0 and t = 1. */
            double af = rad_v3_dot(rad_v3_sub(a, b), f);
            for (int end = 0; end < 2; end++) {
                double sc = (end * ff - af) / ef;
                if (!(sc > 0.0 && sc < 1.0)) continue;
                rad_vec3 g = rad_v3_sub(rad_v3_add(a, rad_v3_scale(e, sc)), end ? rad_v3_add(b, f) : b);
                if (rad_v3_dot(g, g) <= near2) candidates[n++] = sc;
            }
            if (n == 0) {
                cuts[kl] = 0;
                continue;
            }
            /* Sorted, distinct, inside (0, 1): the interior breakpoints. */
            int m = 0;
            for (int i = 0; i < n; i++) {
                double x = candidates[i];
                if (!(x > 1e-12 && x < 1.0 - 1e-12)) continue;
                int at = m;
                while (at > 0 && cut[kl][at - 1] > x) at--;
                if ((at > 0 && x - cut[kl][at - 1] < 1e-9) || (at < m && cut[kl][at] - x < 1e-9)) continue;
                for (int j = m; j > at; j--) cut[kl][j] = cut[kl][j - 1];
                cut[kl][at] = x;
                m++;
            }
            cuts[kl] = m + 1;
        }
    double tol = -1.0;
    for (int level = 0; level <= RAD_FF_CONTOUR_MAX_LEVEL; level++) {
        int parts = 1 << level;
        double sum_hi = 0.0, diff = 0.0, mag = 0.0;
        /* Work items: (edge pair, interval half, part), taken by groups
         * of `subs` lanes in turn, each lane of a group some of the item's
         * nodes (rad_ff_contour_item_lanes). */
        int items = 0;
        for (uint32_t k = 0; k < nq; k++)
            for (uint32_t l = 0; l < np; l++) {
                int c = cuts[k * RAD_FF_POLY_MAX + l];
                items += c < 0 ? 0 : (c > 0 ? 2 * c : 1) * parts;
            }
        unsigned subs = rad_ff_contour_item_lanes(items, lanes);
        int groups = (int)(lanes / subs), group = (int)(lane / subs);
        unsigned sub = lane % subs;
        int item = 0;
        for (uint32_t k = 0; k < nq; k++)
            for (uint32_t l = 0; l < np; l++) {
                int kl = (int)(k * RAD_FF_POLY_MAX + l);
                if (cuts[kl] < 0) continue;
                rad_vec3 a = qc.v[k], e = rad_v3_sub(qc.v[k + 1 < nq ? k + 1 : 0], a);
                rad_vec3 b = pc.v[l], f = rad_v3_sub(pc.v[l + 1 < np ? l + 1 : 0], b);
                double ff = rad_v3_dot(f, f), ef = rad_v3_dot(e, f);
                int intervals = cuts[kl] > 0 ? cuts[kl] : 1, halves = cuts[kl] > 0 ? 2 : 1;
                for (int iv = 0; iv < intervals; iv++) {
                    double x = iv == 0 ? 0.0 : cut[kl][iv - 1], y = iv == intervals - 1 ? 1.0 : cut[kl][iv];
                    for (int half = 0; half < halves; half++) {
                        /* graded from s_from (a breakpoint or end) towards the middle; plain: 0 to 1 */
                        double s_from = half ? y : x, s_to = halves == 2 ? 0.5 * (x + y) : 1.0;
                        for (int part = 0; part < parts; part++, item++) {
                            if (item % groups != group) continue;
                            double lo, hi, mg;
                            rad_ff_contour_piece(a, e, b, f, ff, halves == 2, s_from, s_to, (double)part / parts,
                                                 1.0 / parts, sub, subs, &lo, &hi, &mg);
                            lo = RAD_FF_LANE_SUM(lo, subs);
                            hi = RAD_FF_LANE_SUM(hi, subs);
                            mg = RAD_FF_LANE_SUM(mg, subs);
                            if (sub != 0) continue; /* the group's first lane adds the item */
                            /* The piece integrates from s_from to s_to: backwards on an upper half. */
                            double sign = s_to > s_from ? 1.0 : -1.0;
                            sum_hi += sign * ef * hi;
                            diff += fabs(ef * (hi - lo));
                            mag += fabs(ef) * mg;
                            out.points += RAD_FF_CONTOUR_LO + RAD_FF_CONTOUR_HI;
                        }
                    }
                }
            }
        sum_hi = RAD_FF_LANE_SUM(sum_hi, lanes);
        diff = RAD_FF_LANE_SUM(diff, lanes);
        mag = RAD_FF_LANE_SUM(mag, lanes);
        double g = (exact + sum_hi) / (2.0 * RAD_PI);
        double error = (diff + 16.0 * DBL_EPSILON * (mag + exact_mag)) / (2.0 * RAD_PI);
        if (tol < 0.0) {
            double rel = rtol * fabs(g), abs_tol = atol * q->area;
            tol = rel > abs_tol ? rel : abs_tol;
        }
        /* G >= 0: a pair that sees next to nothing may cancel to -1e-16 or so. */
        if (g < 0.0) error += -g, g = 0.0;
        out.g = g, out.error = error;
        if (error <= tol) {
            out.converged = 1;
            break;
        }
    }
    out.points = RAD_FF_LANE_SUM(out.points, lanes);
    return out;
}

#endif
