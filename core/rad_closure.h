/* rad_closure.h - closure for the solves on links: in a closed scene every
 * leaf's row of the transport sums to 1 (whatever leaves a face's front
 * lands on some face's front), but a hierarchy's rows do not: a coarse
 * link gives every leaf under it the node's mean form factor, and a
 * cluster link one estimate for all its faces, so a leaf's row may sum to
 * 0.83 or 1.45 (the furnace cube at --link-tol's default). A closed room
 * at rho 0.9 then comes out up to +90 % bright where B = E / (1 - rho)
 * holds exactly.
 *
 * The cure is the one radiative-exchange codes use for Monte Carlo
 * exchange factors (closure and reciprocity enforcement: Larsen and
 * Howell 1986; Loehrke et al. 1995; Daun et al. 2005): scale the leaf
 * operator K symmetrically, K' = S K S with S = diag(s), s > 0, so that
 * every row of K' sums to 1,
 *
 *     s_i (K s)_i = 1 for every leaf i,
 *
 * found by the symmetric Sinkhorn iteration s <- sqrt(s / (K s)) (Knight
 * 2008). K' keeps K's reciprocity (A_i K'_ij = s_i s_j A_i K_ij =
 * A_j K'_ji), so the energy still balances, and its rows are those of the
 * closed scene, so the furnace is exact: B = E / (1 - rho) to the solve's
 * tolerance.
 *
 * The solves apply K' without new operators: B = E + rho S K S B is,
 * for C = S B, C = S E + rho S^2 K C - the operator they have, with
 * each leaf's emission times s and its gathered light times s^2; B is
 * C / s. rad_lsolve and solve_shaped do that when asked (their `closure`
 * option; the form-factor file says whether formfactor found the scene
 * closed, RAD_FF_FLAG_CLOSED). The scaling is found for the operator the
 * solve applies (flat or shaped), each application one sweep.
 *
 *     rad_closure_result r;
 *     rad_closure_scales(leaf_count, apply, ctx, 1e-10, 0, s, row, &r);
 */
#ifndef RAD_CLOSURE_H
#define RAD_CLOSURE_H

#include <stddef.h>
#include <stdint.h>

#include "rad_status.h"

/* y = K x over the leaves (by leaf patch), x > 0. A status other than
 * RAD_OK (a device that failed: logged by the callback) stops the
 * iteration, which returns it. */
typedef rad_status (*rad_closure_apply)(void *ctx, const double *x, double *y);

#define RAD_CLOSURE_TOLERANCE 1e-10      /* max |s_i (K s)_i - 1| to reach */
#define RAD_CLOSURE_MAX_ITERATIONS 2000u

typedef struct rad_closure_result {
    uint32_t iterations;  /* applications of K */
    double row_before[2]; /* the smallest and largest row sum of K */
    double deviation;     /* max |s_i (K s)_i - 1| of the s returned */
    double scale[2];      /* the smallest and largest s */
    size_t empty;         /* leaves without links (row 0): left out, s = 1 */
    double seconds;
} rad_closure_result;

/* Finds s (leaf_count values) with s_i (K s)_i = 1 to `tolerance` (0:
 * RAD_CLOSURE_TOLERANCE) within max_iterations (0: the default), and
 * leaves K s's rows s_i (K s)_i in row[] (NULL: not wanted). A leaf whose
 * row of K is 0 (no links reach it) keeps s = 1 and row 0, with a
 * warning; a row that is negative or not finite gives RAD_ERR_INVALID;
 * RAD_ERR_NOT_CONVERGED where the tolerance was not met (s, row and *out
 * then the last iterate's, with a warning: the solves go on with them);
 * RAD_ERR_NOMEM; the callback's own failure. Logged. */
rad_status rad_closure_scales(size_t leaf_count, rad_closure_apply apply, void *ctx, double tolerance,
                              uint32_t max_iterations, double *s, double *row, rad_closure_result *out);

#endif
