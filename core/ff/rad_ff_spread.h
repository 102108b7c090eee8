/* rad_ff_spread.h - how the unoccluded factor from the points of one
 * element to another varies over the first: the geometry hierarchical
 * radiosity's oracle weighs (formfactor/ff_links.c), computed beside each
 * element pair by the backend that computes the pair (ff_backend.h,
 * compute_pairs), host or device: written once for both.
 *
 *     rad_ff_spread s = rad_ff_factor_spread(&from, &to);
 */
#ifndef RAD_FF_SPREAD_H
#define RAD_FF_SPREAD_H

#include <math.h>

#include "rad_ff_kernel.h"
#include "rad_math.h"

typedef struct rad_ff_spread {
    double mean;      /* over the centres: the element's and its 4 parts' (3 and its own for a triangle) */
    double spread;    /* largest - smallest over the centres and corners; infinite if not a number */
    double curvature; /* |the parts' mean - the centre's|, a quadratic's second difference; the spread at a kink */
} rad_ff_spread;

/* Mean and spread (largest - smallest) of the unoccluded factor
 * (rad_ff_point_polygon) from the points of `from` to `to`: its corners,
 * the centres of its 4 children (a split's parts, what one more level
 * tells apart) and its own centre. The corners see what the parts at
 * `from`'s edges see: a part in a room's corner sees the adjacent wall at
 * a half and the rest of the room at less than the element's mean, and
 * without them the links to the rest, kept at the mean, sum to 1.3 there
 * (Cornell box). A corner on `to`'s plane (an edge the two share) counts
 * 0. A spread that is not a number is infinite (refine). */
static inline RAD_HD rad_ff_spread rad_ff_factor_spread(const rad_ff_patch *from, const rad_ff_patch *to)
{
    rad_vec3 x[9];
    const rad_vec3 *p = from->p;
    int m = 0;
    if (from->vertex_count == 4) {
        for (int k = 0; k < 4; k++) { /* (u, v) = (1/4 or 3/4, 1/4 or 3/4), counter-clockwise */
            const double u = k == 1 || k == 2 ? 0.75 : 0.25, v = k >= 2 ? 0.75 : 0.25;
            x[m++] = rad_v3_add(rad_v3_add(rad_v3_scale(p[0], (1 - u) * (1 - v)), rad_v3_scale(p[1], u * (1 - v))),
                                rad_v3_add(rad_v3_scale(p[2], u * v), rad_v3_scale(p[3], (1 - u) * v)));
        }
    } else {
        for (int k = 0; k < 3; k++)
            x[m++] = rad_v3_scale(rad_v3_add(rad_v3_scale(p[k], 4.0), rad_v3_add(p[(k + 1) % 3], p[(k + 2) % 3])),
                                  1.0 / 6.0);
        x[m++] = from->centre;
    }
    x[m++] = from->centre;
    const int centres = m;
    for (uint32_t k = 0; k < from->vertex_count; k++) x[m++] = p[k];
    double lo = INFINITY, hi = -INFINITY, sum = 0, parts = 0, centre = 0, corner_lo = INFINITY, corner_hi = 0;
    for (int k = 0; k < m; k++) {
        const double f = rad_ff_point_polygon(x[k], from->normal, to);
        lo = f < lo ? f : lo;
        hi = f > hi ? f : hi;
        if (k < centres) sum += f;
        if (k < centres - 1) parts += f;
        if (k == centres - 1) centre = f;
        if (k >= centres) corner_lo = fmin(corner_lo, f), corner_hi = fmax(corner_hi, f);
    }
    rad_ff_spread s;
    s.mean = sum / centres;
    s.spread = isfinite(hi - lo) ? hi - lo : INFINITY;
    /* The parts' mean against the centre: the second difference, what a
     * quadratic's curvature gives over half the element. A corner that
     * sees nothing of `to` while another sees it (a shared edge, `to`'s
     * plane crossing `from`) is a kink no curvature describes: the spread. */
    const double c = fabs(parts / (centres - 1) - centre);
    s.curvature = corner_lo == 0 && corner_hi > 0 ? s.spread : isfinite(c) ? fmin(c, s.spread) : INFINITY;
    return s;
}

#endif
