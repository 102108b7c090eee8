/* ff_counters.h - what the form-factor backends did, counted: one struct,
 * and the one way two of them are summed (ff_counters_add), for threads,
 * calls, kernels and ranks alike.
 */
#ifndef FF_COUNTERS_H
#define FF_COUNTERS_H

#include <stdint.h>

/* What a backend did; summed over calls, ranks and threads. */
typedef struct ff_counters {
    uint64_t pairs;          /* ordered pairs (i, j) computed (with pairs_once: about half) */
    uint64_t pairs_mirrored; /* entries copied from the other row's (reciprocity; driver) */
    uint64_t pairs_not_facing; /* of those, zero by the facing test (and i = j), not sampled;
                                  the stats' "pairs_culled" (not --cull's occlusion culling) */
    uint64_t pairs_reused;   /* of those, copied from the refined-from matrix (--reuse) */
    uint64_t pairs_near;     /* of those, computed by the near-field estimator */
    uint64_t pairs_open_scene; /* facing pairs without rays: the scene is a convex enclosure */
    uint64_t pairs_open_box;   /* facing pairs without rays: nothing else meets their box */
    uint64_t rays_saved;     /* shadow rays those pairs would have cast */
    uint64_t samples;        /* point pairs evaluated */
    uint64_t pairs_refined;  /* pairs that took more than one batch (--target-error) */
    uint64_t pairs_capped;   /* --target-error: pairs whose error was still above the
                                target when they stopped at max_samples (refined or
                                not); without it: pairs whose quadrature stopped at its
                                limit (rad_ff_pair_result.capped) */
    uint64_t rays;           /* shadow rays traced */
    uint64_t rays_occluded;  /* of those, blocked */
    double kernel_seconds;   /* time sampling points and evaluating the kernel */
    double visibility_seconds; /* time tracing shadow rays (CUDA: the kernels' time split by
                                  the warps' clock cycles spent on each part) */
    double memory_seconds;   /* CUDA: device allocation and transfers */
} ff_counters;

/* into += from, every field: counts and times. */
static inline void ff_counters_add(ff_counters *into, const ff_counters *from)
{
    into->pairs += from->pairs;
    into->pairs_mirrored += from->pairs_mirrored;
    into->pairs_not_facing += from->pairs_not_facing;
    into->pairs_reused += from->pairs_reused;
    into->pairs_near += from->pairs_near;
    into->pairs_open_scene += from->pairs_open_scene;
    into->pairs_open_box += from->pairs_open_box;
    into->rays_saved += from->rays_saved;
    into->samples += from->samples;
    into->pairs_refined += from->pairs_refined;
    into->pairs_capped += from->pairs_capped;
    into->rays += from->rays;
    into->rays_occluded += from->rays_occluded;
    into->kernel_seconds += from->kernel_seconds;
    into->visibility_seconds += from->visibility_seconds;
    into->memory_seconds += from->memory_seconds;
}

#endif
