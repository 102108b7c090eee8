/* residual.h - one patch's share of the stopping rule, for host and device
 * (compiled as C11 by solve's C files and as CUDA by gpu_cuda.cu: the math
 * once).
 *
 * The stopping rule measures each patch's residual against the smaller of
 * ||E||_inf and the radiosity it gathers, s_i = E_i + rho_i sum_j F_ij B_j
 * (= B_i + r_i): omega = max_i |r_i| / min(||E||_inf, s_i) (docs/solve.md,
 * "Stopping rule"). The ||E|| part keeps the normwise bound of the error;
 * the s_i part holds a dim patch (a 1e-6 light in a room of its own beside
 * a 1e6 one) to its own brightness. s_i is floored at
 * SOLVE_SCALE_FLOOR * ||E||_inf so omega stays finite where s_i <= 0 (CG
 * iterates may be negative mid-way) - only patches 150 decades dimmer than
 * the brightest emitter fall back to the normwise rule.
 */
#ifndef SOLVE_RESIDUAL_H
#define SOLVE_RESIDUAL_H

#include <math.h>

#include "rad_math.h" /* RAD_HD */

#define SOLVE_SCALE_FLOOR 1e-150

/* |r| / min(||E||_inf, s) for one patch: its share of omega. */
static inline RAD_HD double solve_patch_residual(double r, double gathered, double e_norm)
{
    double lowest = SOLVE_SCALE_FLOOR * e_norm;
    double scale = gathered < e_norm ? gathered : e_norm;
    return fabs(r) / (scale > lowest ? scale : lowest);
}

#endif
