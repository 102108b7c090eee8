/* stationary.h - Jacobi and Gauss-Seidel sweeps on one channel's run
 * (stationary.c). Internal to solve/. */
#ifndef SOLVE_STATIONARY_H
#define SOLVE_STATIONARY_H

#include <stddef.h>

#include "gpu.h"
#include "rad_status.h"
#include "run.h"

/* Iterate until converged or the limit; RAD_OK either way (the caller
 * checks), another status on failure. run->B holds the last iterate. */
rad_status solve_jacobi(solve_run *run);
rad_status solve_gauss_seidel(solve_run *run);

/* Jacobi for `count` channels on the GPU in lockstep, one pass over F per
 * sweep for SOLVE_GPU_LANES channels; each stops on its own, as
 * solve_jacobi. Without `gpu`, solve_jacobi one by one. */
rad_status solve_jacobi_many(solve_run *const *runs, size_t count, solve_gpu *gpu);

#endif
