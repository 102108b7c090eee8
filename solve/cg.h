/* cg.h - conjugate gradients on one or several channels' runs (cg.c).
 * Internal to solve/. Whether CG may run at all is cg_check.h's to say. */
#ifndef SOLVE_CG_H
#define SOLVE_CG_H

#include <stddef.h>

#include "gpu.h"
#include "rad_status.h"
#include "run.h"

/* Iterate until converged or the limit; RAD_OK either way (the caller
 * checks), another status on failure. When CG cannot go on (stall,
 * curvature <= 0, recurrence drift), it returns RAD_OK with
 * *out_stopped = 1 and the reason in `why`; run->B then holds its best
 * effort, to be finished by another method. */
rad_status solve_cg(solve_run *run, int *out_stopped, char *why, size_t why_size);
/* The same for `count` channels of one matrix in lockstep: one pass over F
 * per iteration for all of them. out_stopped[c] and why[c] (each why_size
 * bytes) per channel; a failure status if any channel failed. With `gpu`
 * (not NULL) the vector work runs there, SOLVE_GPU_LANES channels at a
 * time, from and back into run->B; the control (stopping, restarts,
 * stalls) is the same code as on the CPU. */
rad_status solve_cg_many(solve_run *const *runs, size_t count, solve_gpu *gpu, int *out_stopped, char *const *why,
                         size_t why_size);

#endif
