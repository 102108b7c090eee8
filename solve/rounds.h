/* rounds.h - the GPU backend's solve of `count` channels (rounds.c;
 * docs/solve.md, "On the GPU"): CG or Jacobi lanes on the device, each
 * result verified on the host with the double matrix
 * (solve_rows_multiply), and rounds of mixed-precision refinement until
 * the verified omega meets the tolerance. Internal to solve/. */
#ifndef SOLVE_ROUNDS_H
#define SOLVE_ROUNDS_H

#include <stddef.h>
#include <stdint.h>

#include "gpu.h"
#include "rad_status.h"
#include "run.h"
#include "solver.h" /* solve_method */

typedef struct solve_gpu_channel {
    solve_run *run;
    solve_method method;   /* SOLVE_CG or SOLVE_JACOBI */
    char *why;             /* CG: why it stopped, why_size bytes */
    size_t why_size;
    int stopped;           /* out: CG stopped; run->B is its best effort, for Gauss-Seidel to finish */
    double verified;       /* out: omega of run->B with the double matrix; NAN if not measured */
    double *product;       /* n values (the caller's): F·B with the double matrix, of the B verified */
    uint32_t rounds;       /* out: rounds on the GPU */
} solve_gpu_channel;

/* Rounds at most; each costs a pass over the double matrix on the host
 * (two when the device's floats are not exact). Two suffice for the
 * tolerances solve allows (docs/solve.md). */
#define SOLVE_GPU_MAX_ROUNDS 4
/* Rounds after the first aim this much below the tolerance, so that the
 * host's verification, which sums in another order, agrees: where B is
 * large against E (rho near 1) the two omegas differ by ~1e-12, and a slow
 * Jacobi can stop within 1 % of the tolerance (measured: emulated, a
 * sphere at rho = 0.99). It costs log(0.5)/log(rate) more iterations, and
 * only when a second round is needed anyway. */
#define SOLVE_GPU_ROUND_MARGIN 0.5

rad_status solve_gpu_channels(solve_gpu *gpu, solve_gpu_channel *channels, size_t count);

#endif
