/* shaped_gpu.h - the shaped solve's point factors and Jacobi sweeps as
 * the GPU runs them (shaped.h; docs/solve.md, "On links"): one table of
 * steps, two implementations. solve_shaped_jacobi_cuda runs them on a
 * CUDA device (shaped_cuda.cu; shaped_gpu_none.c in builds without nvcc
 * says there is none); solve_shaped_jacobi_host is its twin on the host
 * (shaped_host.c), item by item through the same functions
 * (shaped_math.h) in the same order, which is how tests check the GPU's
 * algorithm on machines without a GPU. No CUDA types here.
 *
 * The plan (shaped_plan.c) stays the host's: which ends are shaped, the
 * leaf ranges, the pairs. A step takes host arrays and returns what the
 * host needs next; shaped.c drives them:
 *
 *     const solve_shaped_jacobi *b = &solve_shaped_jacobi_cuda;
 *     void *state;
 *     b->create(&plan, device, &state);     // copies the plan's arrays
 *     b->factors(state, inv_mean);          // the ends' f; 1 / their mean back
 *     ... the host lists the ends whose factors sum to 0 ...
 *     b->drop(state, dropped, count, row_sum); // those dropped; the leaves' row sums back
 *     b->load(state, B, Q);                 // the flat solution
 *     for (;;) { b->sweep(state, change); ... stop? ...; b->accept(state); }
 *     b->store(state, B, H);
 *     b->destroy(state);
 *
 * A sweep, every channel at once, from the iterate B (its leaves' Q):
 * (a) T of every end: what it sends along the pair (shaped_end_sum), one
 * item per end; (b) per receiver id, the unshaped links gathered into H
 * and the shaped ones' S kept (from T; a warp per id, its lanes' sums
 * added in the shuffles' order: shaped_gather_part, shaped_gather_lanes
 * on the host); (c) H pushed
 * down, id by id in order of depth (shaped_push); (d) per leaf, the
 * shaped links of it and its ancestors added, next = E + rho H,
 * and the largest |next - Q| per channel (shaped_update_leaf): the change,
 * which is the residual of B. accept: Q = next, the leaves' B, and B
 * pulled up in reverse order of depth (shaped_pull). Every sum is made by
 * one item in a fixed order and the maxima are exact, so the same inputs
 * give the same bits, run after run, on either implementation.
 */
#ifndef SOLVE_SHAPED_GPU_H
#define SOLVE_SHAPED_GPU_H

#include "rad_status.h"
#include "shaped_math.h"

/* What the device backends need beyond shaped_view's plan, made by
 * shaped.c once it has chosen one. */
typedef struct solve_shaped_device_plan {
    shaped_view view;              /* host pointers; f and inv_mean not made yet */
    size_t vertex_count;           /* of view.positions */
    uint64_t weight_count;         /* point factors: the f array */
    uint32_t depth_count;          /* depths of the ids: cluster 0 (or the roots) at 0 */
    const uint32_t *depth_order;   /* id_count: the ids by depth, each depth's ascending */
    const uint32_t *depth_first;   /* depth_count + 1: depth d's are depth_order[depth_first[d] .. [d + 1]) */
} solve_shaped_device_plan;

typedef struct solve_shaped_jacobi {
    const char *name; /* "cuda", "host" */
    /* Copies what the steps read from `plan` (host arrays) to device
     * `device` (mod the devices). The host's twin ignores `device` and
     * reads the plan's arrays in place, so they must outlive the state.
     * Errors (no device, not enough memory, a failed CUDA call) are
     * logged; *out_state is set only on success. */
    rad_status (*create)(const solve_shaped_device_plan *plan, int device, void **out_state);
    /* The ends' point factors, then inv_mean (host, end_count): 1 / the
     * mean of each end's factors (shaped_end_inv_mean), 0 where they sum
     * to 0. */
    rad_status (*factors)(void *state, double *inv_mean);
    /* The ends `dropped` (host, count of them, ascending: those whose
     * inv_mean is 0) dropped (shaped_drop_end), once; row_sum (host,
     * leaf_count): every leaf's row sum with the shape, leaf-list order. */
    rad_status (*drop)(void *state, const uint64_t *dropped, uint64_t count, double *row_sum);
    /* The nodes' rho and E again (host, node_count * 3 each), changed since
     * create: closure's scaled leaves (rad_closure.h). */
    rad_status (*materials)(void *state, const double *rho, const double *E);
    /* The iterate to start from: B (id_count * 3), Q (leaf_count * 3, leaf-list order). */
    rad_status (*load)(void *state, const double *B, const double *Q);
    /* One sweep from the current iterate; change[c]: the largest
     * |next - B| over the leaves in channel c (infinite for a NaN). */
    rad_status (*sweep)(void *state, double change[3]);
    /* The iterate becomes the last sweep's next (leaves, and the ids above pulled). */
    rad_status (*accept)(void *state);
    /* The current iterate's B and the last sweep's H (id_count * 3 each, host). */
    rad_status (*store)(void *state, double *B, double *H);
    /* Where it runs ("host", or the GPU's name). */
    const char *(*device_name)(void *state);
    void (*destroy)(void *state); /* safe on NULL */
} solve_shaped_jacobi;

extern const solve_shaped_jacobi solve_shaped_jacobi_host;
extern const solve_shaped_jacobi solve_shaped_jacobi_cuda;

#endif
