/* rad_ff_quad.h - the unoccluded form factor of a patch pair by
 * deterministic, error-controlled quadrature (host and device).
 *
 * For patches q and p (q the smaller; see rad_ff_quad_roles), the
 * interchange area G = A_q F_qp = A_p F_pq is the integral over q of
 * Lambert's closed-form point-to-polygon factor (rad_ff_point_polygon):
 *
 *     G = integral over y in q of F(dA_y -> p) dA_y.
 *
 * The integrand is bounded however close the patches are, smooth where
 * they are apart, and has at worst a log-type derivative singularity at a
 * shared edge or vertex (docs/architecture.md, "Quadrature"). q is mapped
 * from the unit square bilinearly (a triangle is the quad with p[3] = p[2],
 * whose map collapses one side), and the square is covered by cells, each
 * integrated by tensor Gauss-Legendre of two consecutive orders n and n+1.
 * |Q_n - Q_n+1| estimates the error of Q_n, so it bounds that of the
 * Q_n+1 that is kept (by a wide margin for smooth integrands). The order
 * comes from the cell's distance to p against its size; a cell whose
 * estimate exceeds its share of the tolerance (tolerance times its share
 * of the square) is split, depth first: 2-way across the direction its
 * error comes from (an extra order along u only, and v only, tell which),
 * or 4-way when both contribute. The tolerance is
 *     max(rtol |G|, atol A_q)      (atol in units of F),
 * with G from a first pass of the coarse rule. The sum of the kept cells'
 * estimates is returned as the error bound of G.
 *
 * Everything is a pure function of the two patches and the tolerances,
 * summed in one fixed order, so rows i and j get the same bits and CPU
 * and GPU agree to a few ulps (different atan2 and sqrt).
 */
#ifndef RAD_FF_QUAD_H
#define RAD_FF_QUAD_H

#include <stdint.h>

#include "rad_ff_kernel.h"
#include "rad_math.h"

/* Lanes: a group of threads may share one pair (a CUDA warp: each lane
 * takes every lanes-th quadrature point, and RAD_FF_LANE_SUM gives every
 * lane the group's total, the same bits on all, so control flow stays
 * uniform). One thread (the CPU, tests): lane 0 of 1, and the sum of one. */
#ifndef RAD_FF_LANE_SUM
#define RAD_FF_LANE_SUM(x, lanes) (x)
#endif

/* Gauss-Legendre rules of orders 1..12 on [0, 1], weights summing to 1,
 * order n at offset n (n - 1) / 2 (from 40-digit Newton iteration). */
#define RAD_FF_GL_MAX_ORDER 12
#define RAD_FF_GL_NODES { \
    0.5, 0.211324865405187117745, 0.788675134594812882255, 0.112701665379258311482, 0.5, 0.887298334620741688518, \
    0.069431844202973712388, 0.330009478207571867599, 0.669990521792428132401, 0.930568155797026287612, \
    0.0469100770306680036012, 0.230765344947158454482, 0.5, 0.769234655052841545518, 0.953089922969331996399, \
    0.0337652428984239860938, 0.169395306766867743169, 0.380690406958401545685, 0.619309593041598454315, \
    0.830604693233132256831, 0.966234757101576013906, 0.0254460438286207377369, 0.129234407200302780068, \
    0.297077424311301416547, 0.5, 0.702922575688698583453, 0.870765592799697219932, 0.974553956171379262263, \
    0.0198550717512318841582, 0.101666761293186630204, 0.237233795041835507091, 0.40828267875217509753, \
    0.59171732124782490247, 0.762766204958164492909, 0.898333238706813369796, 0.980144928248768115842, \
    0.0159198802461869550822, 0.0819844463366821028503, 0.193314283649704801346, 0.337873288298095535481, 0.5, \
    0.662126711701904464519, 0.806685716350295198654, 0.91801555366331789715, 0.984080119753813044918, \
    0.013046735741414139961, 0.067468316655507744634, 0.160295215850487796883, 0.2833023029353764046, \
    0.425562830509184394558, 0.574437169490815605442, 0.7166976970646235954, 0.839704784149512203117, \
    0.932531683344492255366, 0.986953264258585860039, 0.010885670926971503598, 0.0564687001159523504624, \
    0.134923997212975337953, 0.240451935396594092037, 0.365228422023827513834, 0.5, 0.634771577976172486166, \
    0.759548064603405907963, 0.865076002787024662047, 0.943531299884047649538, 0.989114329073028496402, \
    0.00921968287664037465473, 0.0479413718147625716608, 0.115048662902847656482, 0.206341022856691276352, \
    0.316084250500909903124, 0.437383295744265542264, 0.562616704255734457736, 0.683915749499090096876, \
    0.793658977143308723648, 0.884951337097152343518, 0.952058628185237428339, 0.990780317123359625345 }
#define RAD_FF_GL_WEIGHTS { \
    1.0, 0.5, 0.5, 0.277777777777777777778, 0.444444444444444444444, 0.277777777777777777778, \
    0.173927422568726928687, 0.326072577431273071313, 0.326072577431273071313, 0.173927422568726928687, \
    0.118463442528094543757, 0.239314335249683234021, 0.284444444444444444444, 0.239314335249683234021, \
    0.118463442528094543757, 0.0856622461895851725201, 0.180380786524069303785, 0.233956967286345523695, \
    0.233956967286345523695, 0.180380786524069303785, 0.0856622461895851725201, 0.0647424830844348466353, \
    0.139852695744638333951, 0.190915025252559472475, 0.208979591836734693878, 0.190915025252559472475, \
    0.139852695744638333951, 0.0647424830844348466353, 0.0506142681451881295763, 0.111190517226687235272, \
    0.156853322938943643669, 0.181341891689180991483, 0.181341891689180991483, 0.156853322938943643669, \
    0.111190517226687235272, 0.0506142681451881295763, 0.0406371941807872059859, 0.0903240803474287020292, \
    0.130305348201467731159, 0.156173538520001420034, 0.165119677500629881582, 0.156173538520001420034, \
    0.130305348201467731159, 0.0903240803474287020292, 0.0406371941807872059859, 0.0333356721543440687968, \
    0.0747256745752902965729, 0.109543181257991021998, 0.134633359654998177546, 0.147762112357376435087, \
    0.147762112357376435087, 0.134633359654998177546, 0.109543181257991021998, 0.0747256745752902965729, \
    0.0333356721543440687968, 0.0278342835580868332414, 0.0627901847324523123173, 0.093145105463867125713, \
    0.116596882295995239959, 0.13140227225512333109, 0.136462543388950315357, 0.13140227225512333109, \
    0.116596882295995239959, 0.093145105463867125713, 0.0627901847324523123173, 0.0278342835580868332414, \
    0.0235876681932559135973, 0.0534696629976592154801, 0.0800391642716731131673, 0.101583713361532960875, \
    0.11674626826917740438, 0.1245735229067013925, 0.1245735229067013925, 0.11674626826917740438, \
    0.101583713361532960875, 0.0800391642716731131673, 0.0534696629976592154801, 0.0235876681932559135973 }

#if defined(__CUDACC__)
__device__ static const double rad_ff_gl_nodes_device[] = RAD_FF_GL_NODES;
__device__ static const double rad_ff_gl_weights_device[] = RAD_FF_GL_WEIGHTS;
#endif
static const double rad_ff_gl_nodes_host[] = RAD_FF_GL_NODES;
static const double rad_ff_gl_weights_host[] = RAD_FF_GL_WEIGHTS;

static inline RAD_HD double rad_ff_gl_node(int order, int k)
{
#if defined(__CUDA_ARCH__)
    return rad_ff_gl_nodes_device[order * (order - 1) / 2 + k];
#else
    return rad_ff_gl_nodes_host[order * (order - 1) / 2 + k];
#endif
}

static inline RAD_HD double rad_ff_gl_weight(int order, int k)
{
#if defined(__CUDA_ARCH__)
    return rad_ff_gl_weights_device[order * (order - 1) / 2 + k];
#else
    return rad_ff_gl_weights_host[order * (order - 1) / 2 + k];
#endif
}

/* Default tolerances of the unoccluded factor (formfactor --quad-rtol,
 * --quad-atol): relative to G, and absolute in units of F. The error
 * estimate is conservative (measured: 10-1000x the true error), so the
 * closed forms come out to about 1e-10 (docs/accuracy.md). */
#define RAD_FF_QUAD_RTOL 1e-8
#define RAD_FF_QUAD_ATOL 1e-13
/* Limits of one pair's subdivision: depth of a cell, cells integrated. A
 * pair that reaches either keeps its honest error estimate and counts as
 * capped (ff_counters.pairs_capped). */
#define RAD_FF_QUAD_MAX_DEPTH 48
#define RAD_FF_QUAD_MAX_CELLS 4096u
/* Cells a fallback may take where another estimate is already in hand
 * (rad_ff_pair_quad_unoccluded: a straddling pair's fan after an
 * unfinished contour integral). */
#define RAD_FF_QUAD_FALLBACK_CELLS 256u
#define RAD_FF_QUAD_STACK 64
/* Highest Gauss order a cell apart from p is raised to before it is split. */
#define RAD_FF_QUAD_P_MAX 8

/* Point of patch q at (u, v) in the unit square, and the area element
 * |dX/du x dX/dv| there (bilinear map P0, P1, P2, P3). */
static inline RAD_HD rad_vec3 rad_ff_patch_map(const rad_ff_patch *q, double u, double v, double *jacobian)
{
    rad_vec3 e1 = rad_v3_sub(q->p[1], q->p[0]), e3 = rad_v3_sub(q->p[3], q->p[0]);
    rad_vec3 e13 = rad_v3_add(rad_v3_sub(q->p[0], q->p[1]), rad_v3_sub(q->p[2], q->p[3]));
    rad_vec3 xu = rad_v3_add(e1, rad_v3_scale(e13, v)), xv = rad_v3_add(e3, rad_v3_scale(e13, u));
    *jacobian = fabs(rad_v3_dot(q->normal, rad_v3_cross(xu, xv)));
    return rad_v3_add(q->p[0], rad_v3_add(rad_v3_scale(e1, u), rad_v3_add(rad_v3_scale(e3, v), rad_v3_scale(e13, u * v))));
}

/* Which patch is integrated over (q: the smaller, the lower-numbered on a
 * tie) - a choice symmetric in (i, j). Returns 1 when q is patch a. */
static inline RAD_HD int rad_ff_quad_roles(const rad_ff_patch *a, const rad_ff_patch *b, uint32_t ia, uint32_t ib)
{
    return a->area < b->area || (a->area == b->area && ia < ib);
}

/* One cell [u0, u0 + du] x [v0, v0 + dv] of q's square. */
typedef struct rad_ff_cell {
    double u0, v0, du, dv;
    uint32_t depth;
} rad_ff_cell;

static inline RAD_HD rad_ff_cell rad_ff_cell_make(double u0, double v0, double du, double dv, uint32_t depth)
{
    rad_ff_cell c;
    c.u0 = u0, c.v0 = v0, c.du = du, c.dv = dv, c.depth = depth;
    return c;
}

/* Grading of q's square towards where it touches p (a shared edge or
 * vertex): there F(dA_y -> p) has a derivative singularity of the kind
 * s ln s in the distance s, which Gauss rules converge on only slowly.
 * Each direction of the square is mapped through u = g(t) with g'(t)
 * vanishing to second order at a graded end: g = t^3 towards t = 0,
 * 1 - (1-t)^3 towards t = 1, and both at once piecewise (4 t^3 below
 * 1/2, where the square is split from the start), which turns s ln s into
 * a function twice as smooth. `ends`: 0 none, bit 1 the end t = 0, bit 2
 * the end t = 1. */
static inline RAD_HD double rad_ff_grade(int ends, double t, double *dudt)
{
    if (ends == 3) {
        if (t < 0.5) {
            *dudt = 12.0 * t * t;
            return 4.0 * t * t * t;
        }
        double r = 1.0 - t;
        *dudt = 12.0 * r * r;
        return 1.0 - 4.0 * r * r * r;
    }
    if (ends == 1) {
        *dudt = 3.0 * t * t;
        return t * t * t;
    }
    if (ends == 2) {
        double r = 1.0 - t;
        *dudt = 3.0 * r * r;
        return 1.0 - r * r * r;
    }
    *dudt = 1.0;
    return t;
}

/* Does the segment a-b (a point when a = b) touch patch p, which it lies
 * in the plane of? Clipped against p's edges' inner half-planes, within eps. */
static inline RAD_HD int rad_ff_touches(const rad_ff_patch *p, rad_vec3 a, rad_vec3 b, double eps)
{
    double t0 = 0.0, t1 = 1.0;
    rad_vec3 d = rad_v3_sub(b, a);
    for (uint32_t e = 0; e < p->vertex_count; e++) {
        rad_vec3 pe = p->p[e], edge = rad_v3_sub(p->p[e + 1 < p->vertex_count ? e + 1 : 0], pe);
        rad_vec3 inward = rad_v3_normalize(rad_v3_cross(p->normal, edge));
        double h0 = rad_v3_dot(inward, rad_v3_sub(a, pe)) + eps, dh = rad_v3_dot(inward, d);
        /* keep t with h0 + t dh >= 0 */
        if (dh == 0.0) {
            if (h0 < 0.0) return 0;
        } else if (dh > 0.0) {
            double t = -h0 / dh;
            t0 = t > t0 ? t : t0;
        } else {
            double t = -h0 / dh;
            t1 = t < t1 ? t : t1;
        }
    }
    return t0 <= t1;
}

/* Which ends of u and v to grade: towards each side of q that lies in p's
 * plane and touches p, and each corner that does. Corners p0..p3 sit at
 * (0,0), (1,0), (1,1), (0,1); a triangle's p3 is its p2, so its side
 * v = 1 is the point p2. */
static inline RAD_HD void rad_ff_grade_ends(const rad_ff_patch *q, const rad_ff_patch *p, double eps, int *ends_u,
                                            int *ends_v)
{
    const int corner_u[4] = {1, 2, 2, 1}, corner_v[4] = {1, 1, 2, 2};
    int on_plane[4];
    *ends_u = 0, *ends_v = 0;
    /* Perpendicular planes: the integrand stays smooth at the contact
     * (measured: spectral convergence at 90 degrees), no grading. */
    if (fabs(rad_v3_dot(q->normal, p->normal)) < 1e-12) return;
    for (int k = 0; k < 4; k++) on_plane[k] = fabs(rad_v3_dot(p->normal, rad_v3_sub(q->p[k], p->p[0]))) <= eps;
    for (int k = 0; k < 4; k++) {
        int next = (k + 1) & 3;
        if (on_plane[k] && on_plane[next] && rad_ff_touches(p, q->p[k], q->p[next], eps)) {
            /* side k: v = 0 (k = 0), u = 1 (1), v = 1 (2), u = 0 (3) */
            if (k == 0) *ends_v |= 1;
            if (k == 1) *ends_u |= 2;
            if (k == 2) *ends_v |= 2;
            if (k == 3) *ends_u |= 1;
        }
        if (on_plane[k] && rad_ff_touches(p, q->p[k], q->p[k], eps)) {
            if (q->vertex_count == 3 && k >= 2) {
                *ends_v |= 2; /* the apex: the whole side v = 1 */
            } else {
                *ends_u |= corner_u[k];
                *ends_v |= corner_v[k];
            }
        }
    }
}

/* Tensor Gauss-Legendre over a cell of q, of F(dA_y -> p): order nu
 * along u, nv along v. */
static inline RAD_HD double rad_ff_cell_point(const rad_ff_patch *q, const rad_ff_patch *p, const rad_ff_cell *c, int nu,
                                             int nv, int k, int ends_u, int ends_v)
{
    int a = k / nv, b = k % nv;
    double dudt, u = rad_ff_grade(ends_u, c->u0 + c->du * rad_ff_gl_node(nu, a), &dudt);
    double dvdt, v = rad_ff_grade(ends_v, c->v0 + c->dv * rad_ff_gl_node(nv, b), &dvdt);
    double jac;
    rad_vec3 y = rad_ff_patch_map(q, u, v, &jac);
    return rad_ff_gl_weight(nu, a) * dudt * rad_ff_gl_weight(nv, b) * dvdt * jac * rad_ff_point_polygon(y, q->normal, p);
}

/* Two rules over one cell at once, A (orders nu_a x nv_a) and B: their
 * points form one list that the lanes share, so a group of threads needs
 * as few rounds as the points allow. */
static inline RAD_HD void rad_ff_cell_rules(const rad_ff_patch *q, const rad_ff_patch *p, const rad_ff_cell *c,
                                            int nu_a, int nv_a, int nu_b, int nv_b, int ends_u, int ends_v,
                                            unsigned lane, unsigned lanes, double *rule_a, double *rule_b)
{
    int count_a = nu_a * nv_a, count = count_a + nu_b * nv_b;
    double sum_a = 0.0, sum_b = 0.0;
    for (int k = (int)lane; k < count; k += (int)lanes) {
        if (k < count_a)
            sum_a += rad_ff_cell_point(q, p, c, nu_a, nv_a, k, ends_u, ends_v);
        else
            sum_b += rad_ff_cell_point(q, p, c, nu_b, nv_b, k - count_a, ends_u, ends_v);
    }
    *rule_a = RAD_FF_LANE_SUM(sum_a, lanes) * c->du * c->dv;
    *rule_b = RAD_FF_LANE_SUM(sum_b, lanes) * c->du * c->dv;
}

/* Gauss order for a cell from its distance to p against its size: far
 * cells see a smooth integrand (2 x 2 points, checked against 3 x 3);
 * touching ones start at 6 x 6 against 7 x 7 and are split where that
 * disagrees. */
static inline RAD_HD int rad_ff_cell_order(const rad_ff_patch *q, const rad_ff_patch *p, const rad_ff_cell *c)
{
    double jac;
    rad_vec3 c00 = rad_ff_patch_map(q, c->u0, c->v0, &jac);
    rad_vec3 c10 = rad_ff_patch_map(q, c->u0 + c->du, c->v0, &jac);
    rad_vec3 c01 = rad_ff_patch_map(q, c->u0, c->v0 + c->dv, &jac);
    rad_vec3 c11 = rad_ff_patch_map(q, c->u0 + c->du, c->v0 + c->dv, &jac);
    rad_vec3 mid = rad_v3_scale(rad_v3_add(rad_v3_add(c00, c10), rad_v3_add(c01, c11)), 0.25);
    double r = 0.0;
    rad_vec3 corner[4] = {c00, c10, c01, c11};
    for (int k = 0; k < 4; k++) {
        double l = rad_v3_length(rad_v3_sub(corner[k], mid));
        r = l > r ? l : r;
    }
    double gap = rad_v3_length(rad_v3_sub(mid, p->centre)) - p->radius - r;
    double ratio = gap > 0.0 && r > 0.0 ? gap / r : 0.0;
    return ratio >= 12.0 ? 2 : ratio >= 5.0 ? 3 : ratio >= 2.5 ? 4 : ratio >= 1.0 ? 5 : 6;
}

/* max(rtol |G|, atol A_q) for an estimate g of G. */
static inline RAD_HD double rad_ff_quad_tolerance(double g, double rtol, double atol, const rad_ff_patch *q)
{
    double rel = rtol * fabs(g), abs_tol = atol * q->area;
    return rel > abs_tol ? rel : abs_tol;
}

/* What rad_ff_quad_unoccluded found. */
typedef struct rad_ff_quad_result {
    double g;         /* G = A_q F_qp */
    double error;     /* bound on |G - exact| (sum of the cells' estimates) */
    uint32_t points;  /* point factors evaluated */
    uint32_t cells;   /* cells integrated */
    int capped;       /* stopped at a limit with the error above its tolerance */
} rad_ff_quad_result;

/* G over q towards p (q the smaller patch, rad_ff_quad_roles), to the
 * tolerance max(rtol |G|, atol A_q), in at most about max_cells cells;
 * this thread is `lane` of `lanes`. */
static inline RAD_HD rad_ff_quad_result rad_ff_quad_unoccluded_within(const rad_ff_patch *q, const rad_ff_patch *p,
                                                                      double rtol, double atol, uint32_t max_cells,
                                                                      unsigned lane, unsigned lanes)
{
    rad_ff_quad_result out;
    out.g = 0.0, out.error = 0.0, out.points = 0, out.cells = 0, out.capped = 0;
    rad_ff_cell stack[RAD_FF_QUAD_STACK];
    int top = 0;
    int ends_u, ends_v;
    rad_ff_grade_ends(q, p, 1e-9 * (q->radius + p->radius), &ends_u, &ends_v);
    /* A direction graded at both ends starts split at 1/2 (rad_ff_grade). */
    int halves_u = ends_u == 3 ? 2 : 1, halves_v = ends_v == 3 ? 2 : 1;
    for (int a = halves_u - 1; a >= 0; a--)
        for (int b = halves_v - 1; b >= 0; b--)
            stack[top++] = rad_ff_cell_make(a * (1.0 / halves_u), b * (1.0 / halves_v), 1.0 / halves_u,
                                            1.0 / halves_v, 0);
    /* The tolerance comes from the coarse rule over the whole square: for
     * one starting cell, the loop's own first coarse rule (tol < 0 until
     * then); for several, a pass over them first. */
    double tol = -1.0;
    if (top > 1) {
        double first = 0.0;
        for (int k = 0; k < top; k++) {
            int n = rad_ff_cell_order(q, p, &stack[k]);
            double coarse, unused;
            rad_ff_cell_rules(q, p, &stack[k], n, n, 0, 0, ends_u, ends_v, lane, lanes, &coarse, &unused);
            first += coarse;
            out.points += (uint32_t)(n * n);
        }
        tol = rad_ff_quad_tolerance(first, rtol, atol, q);
    }
    while (top > 0) {
        rad_ff_cell c = stack[--top];
        int n = rad_ff_cell_order(q, p, &c);
        double coarse, fine;
        rad_ff_cell_rules(q, p, &c, n, n, n + 1, n + 1, ends_u, ends_v, lane, lanes, &coarse, &fine);
        double est = fabs(fine - coarse);
        out.points += (uint32_t)(n * n + (n + 1) * (n + 1));
        if (tol < 0.0) tol = rad_ff_quad_tolerance(coarse, rtol, atol, q);
        out.cells++;
        double share = tol * sqrt(c.du * c.dv);
        /* A cell apart from p (order below 6) holds a smooth integrand: one
         * order more converges faster than a split, up to RAD_FF_QUAD_P_MAX. */
        while (est > share && n < 6 && n + 2 <= RAD_FF_QUAD_P_MAX) {
            n++;
            coarse = fine;
            double unused;
            rad_ff_cell_rules(q, p, &c, n + 1, n + 1, 0, 0, ends_u, ends_v, lane, lanes, &fine, &unused);
            est = fabs(fine - coarse);
            out.points += (uint32_t)((n + 1) * (n + 1));
        }
        int room = top + 4 <= RAD_FF_QUAD_STACK && c.depth < RAD_FF_QUAD_MAX_DEPTH &&
                   out.cells + (uint32_t)top < max_cells;
        if (est <= share || !room) {
            if (est > share) out.capped = 1;
            out.g += fine;
            out.error += est;
            continue;
        }
        /* Split across the direction the error comes from: one order more
         * along u only, and along v only, tell them apart. Near a shared
         * edge this grades thin cells towards the edge instead of filling
         * its whole length with small squares. */
        double more_u, more_v;
        rad_ff_cell_rules(q, p, &c, n + 1, n, n, n + 1, ends_u, ends_v, lane, lanes, &more_u, &more_v);
        double along_u = fabs(more_u - coarse), along_v = fabs(more_v - coarse);
        out.points += (uint32_t)(2 * n * (n + 1));
        int split_u = !(along_v > 4.0 * along_u), split_v = !(along_u > 4.0 * along_v);
        int nu = split_u ? 2 : 1, nv = split_v ? 2 : 1;
        double du = c.du / nu, dv = c.dv / nv;
        /* Pushed so that the lower-left child is integrated first. */
        for (int a = nu - 1; a >= 0; a--)
            for (int b = nv - 1; b >= 0; b--)
                stack[top++] = rad_ff_cell_make(c.u0 + a * du, c.v0 + b * dv, du, dv, c.depth + 1);
    }
    return out;
}

/* rad_ff_quad_unoccluded_within at the cell limit RAD_FF_QUAD_MAX_CELLS. */
static inline RAD_HD rad_ff_quad_result rad_ff_quad_unoccluded(const rad_ff_patch *q, const rad_ff_patch *p,
                                                               double rtol, double atol, unsigned lane,
                                                               unsigned lanes)
{
    return rad_ff_quad_unoccluded_within(q, p, rtol, atol, RAD_FF_QUAD_MAX_CELLS, lane, lanes);
}

#endif
