/* ff_backend.h - one interface, several form-factor backends.
 *
 * A backend computes whole matrix rows for a committed setup (patches +
 * occluder triangles). The CPU backend (OpenMP) is the reference; the
 * CUDA backend must agree with it. Both classify a pair the same way
 * (ff_pair_class.h), run the same per-pair procedure (rad_ff_pair.h) and
 * trace the flat BVH of ff_bvh.h, which Embree's builder makes:
 * ff_bvh_build.c is the one file that includes Embree. The driver (ff_driver.c) picks one at run time:
 *
 *     const ff_backend *b = &ff_backend_cpu;
 *     void *state;
 *     if (b->create(&setup, &state) == RAD_OK) {
 *         b->compute_rows(state, row0, rows, out, &counters);
 *         b->destroy(state);
 *     }
 */
#ifndef FF_BACKEND_H
#define FF_BACKEND_H

#include <stddef.h>
#include <stdint.h>

#include "ff_cluster_math.h"
#include "ff_counters.h"
#include "ff_rows.h"
#include "rad_ff_kernel.h"
#include "rad_ff_spread.h"
#include "rad_status.h"

/* Everything a backend needs; flat arrays, owned by the caller, read-only
 * for the backend's lifetime. */
#define FF_REUSE_NONE UINT32_MAX

typedef struct ff_setup {
    const rad_ff_patch *patches; /* patch_count */
    uint32_t patch_count;
    const double *triangles;     /* occluders: triangle_count * 9 doubles (3 vertices) */
    const uint32_t *triangle_face; /* scene face of each triangle (to skip source/target) */
    uint32_t triangle_count;
    uint32_t samples;            /* K point pairs per patch pair, >= 1 */
    uint32_t shadow_rays;        /* R <= K of them carry a shadow ray; 0 = no occlusion */
    uint64_t seed;
    uint32_t estimator;          /* rad_estimator_id (rad_estimator.h) */
    double quad_rtol, quad_atol; /* quadrature tolerances (rad_ff_quad.h) */
    /* --target-error: a pair whose standard error (rad_ff_error_reached)
     * exceeds target_error takes another batch as large as all before it
     * (samples and shadow rays double) until it does not, or until it has
     * max_samples samples. 0 = one batch of `samples`. */
    double target_error;
    uint32_t max_samples;
    /* Standard errors wanted (compute_rows gets an errors buffer): the
     * GPU kernels then also sum squares, which costs kernel time. */
    int errors;
    double plane_eps;            /* rad_ff_pair_facing tolerance, scene units */
    /* Occlusion culling (docs/architecture.md): with cull set, a pair casts
     * no shadow rays when nothing can lie between its patches - the whole
     * scene is one convex enclosure (scene_convex), or no other triangle
     * meets the box around the two patches (grown by cull_margin). Such rays
     * could not have hit anything, so the matrix is byte-identical. */
    int cull;
    int scene_convex;
    float cull_margin;           /* scene units: the float shaft box */
    double ray_delta;            /* scene units: what a shadow segment counts as a hit (ff_segment) */
    /* Compute only the entries rad_ff_row_computes assigns to their row
     * (each unordered pair once); the others are set to 0 and filled in by
     * the driver from the other row (ff_rows.h). */
    int pairs_once;
    /* formfactor --refine --reuse: reuse_old[i] is patch i's index in the
     * mesh it was refined from when it was not split, else FF_REUSE_NONE.
     * A pair of two such patches takes its coupling from reuse_coupling
     * (reuse_n x reuse_n, symmetric to the bit, so the matrix stays
     * reciprocal) instead of being computed. NULL = compute every pair. The
     * CPU backend honours it; the CUDA backend computes every pair. */
    const uint32_t *reuse_old;
    const double *reuse_coupling;
    uint32_t reuse_n;
    int threads;                 /* CPU threads (>= 1) */
    int device;                  /* GPU index for the CUDA backend (rank mod GPUs) */
    /* Called now and then from one thread with the rows finished so far in
     * the current compute_rows call; may be NULL. */
    void (*progress)(void *user, uint64_t rows_done);
    void *progress_user;
} ff_setup;

/* The run's settings as the per-pair procedure takes them, for one thread
 * per pair (a backend that shares a pair among lanes sets lane, lanes). */
static inline rad_ff_pair_params ff_pair_params(const ff_setup *su)
{
    rad_ff_pair_params pp;
    pp.estimator = su->estimator;
    pp.samples = su->samples;
    pp.rays = su->shadow_rays;
    pp.max_samples = su->max_samples;
    pp.seed = su->seed;
    pp.target_error = su->target_error;
    pp.quad_rtol = su->quad_rtol;
    pp.quad_atol = su->quad_atol;
    pp.ray_floor = 0.0;
    pp.lane = 0;
    pp.lanes = 1;
    return pp;
}

/* Rows as the sparse format stores them (rad_ff_row_encode's records),
 * back to back: row r's record is bytes[at[r], at[r + 1]). A view into
 * the backend's buffers. */
typedef struct ff_records {
    const unsigned char *bytes;
    const uint64_t *at; /* rows + 1 */
    uint32_t rows;
} ff_records;

/* One pair of a hierarchy's elements for compute_pairs (ff_links.h):
 * indices into the patches compute_pairs is given. */
typedef struct ff_pair_job {
    uint32_t a, b;
    uint32_t spread; /* 1: compute the oracle's geometry (spread_ab, spread_ba); 0: both are leaves
                        no pass splits, so nothing weighs it: they stay zero */
    float ray_floor; /* rad_ff_pair_params.ray_floor for this pair: the coupling error below which the
                        oracle has no use for more shadow rays (ff_links.c); 0: the run's batches */
} ff_pair_job;

/* What compute_pairs found for a job. */
typedef struct ff_pair_outcome {
    double coupling;   /* c_ab = F_ab / A_b (0 where the pair does not face) */
    double error;      /* its standard error (rad_ff_pair_result.error) */
    rad_ff_spread spread_ab, spread_ba; /* rad_ff_factor_spread(a -> b), (b -> a): the oracle's geometry
                                           (zero where the pair does not face or the job asks none) */
    uint32_t rays, rays_blocked;
    uint32_t verdict;  /* ff_pair_verdict (ff_pair_class.h): FF_PAIR_NOT_FACING, or how it was computed */
    uint32_t pad;
} ff_pair_outcome;

typedef struct ff_backend {
    const char *name;
    rad_status (*create)(const ff_setup *setup, void **out_state);
    /* Rows [row_begin, row_begin + row_count) into out (row_count * N
     * doubles), as couplings c_ij = F_ij / A_j (rad_ff_coupling_far; the
     * driver scales them into form factors with ff_rows_finish), and, when
     * `errors` is not NULL, their standard errors (rad_ff_estimate) into it. */
    rad_status (*compute_rows)(void *state, uint32_t row_begin, uint32_t row_count, double *out, double *errors,
                               ff_counters *counters);
    void (*destroy)(void *state);
    /* The buffer compute_rows writes into (count doubles), allocated where
     * this backend writes fastest (page-locked memory for CUDA); NULL on
     * failure. Freed with free_rows before destroy. */
    double *(*alloc_rows)(void *state, size_t count);
    void (*free_rows)(void *state, double *rows);
    /* Optional (NULL where a backend has none): compute_rows' rows,
     * finished where they were computed - scaled into form factors (the
     * very doubles ff_rows_finish makes), added to *summary, encoded as
     * sparse records of `element` into *values and, when `errors` is not
     * NULL, their standard errors as float32 records into *errors - so
     * that only the stored bytes come back. Not for pairs_once setups (the
     * mirror needs the rows). The views are valid until the call after
     * next: the driver writes one round's records in the background while
     * the backend makes the next round's (ff_output.h). */
    rad_status (*compute_records)(void *state, uint32_t row_begin, uint32_t row_count, uint32_t element,
                                  ff_records *values, ff_records *errors, ff_rows_summary *summary,
                                  ff_counters *counters);
    /* Optional (NULL where a backend has none): hierarchical radiosity's
     * links (ff_links.h). Classifies and computes the pairs jobs[0 ..
     * count) of `patches` (a hierarchy's elements, not the setup's
     * patches) as compute_rows does a matrix's pairs, keys[a] and keys[b]
     * standing for the patch indices the per-pair procedure takes (its
     * seeds and tie-breaks): an element's key is its patch index in the
     * uniform mesh of the same leaves, so a link between two leaves gets
     * the very coupling the full matrix holds. Between calls on one state
     * the elements (patches, keys) are only appended to, never changed:
     * the CUDA backend uploads only those past the last call's. */
    rad_status (*compute_pairs)(void *state, const rad_ff_patch *patches, const uint32_t *keys,
                                const ff_pair_job *jobs, size_t count, ff_pair_outcome *out, ff_counters *counters);
    /* Pairs with a cluster at an end (ff_links.c): out[k] for jobs[k],
     * k < count, as ff_cluster_pair decides, draws, traces and couples it
     * through the occluders' BVH. v holds host arrays: the cluster tree's
     * (the same on every call of a run) and the elements (only ever
     * appended to, as compute_pairs' are). The same math on every backend
     * (the GPU's acos, asin and cos may differ from the C library's in the
     * last bits, as its element pairs' atan2 does); safe beside a
     * compute_pairs call from another thread. NULL: not offered. */
    rad_status (*cluster_draws)(void *state, const ff_cluster_view *v, const ff_pair_job *jobs, size_t count,
                                ff_cluster_drawn *out);
    /* The buffers a round grew (jobs, outcomes, rays), freed between
     * passes for what else needs the device (the hierarchy's flat solves
     * on the GPU); the next round grows them again. NULL: nothing to free. */
    void (*trim)(void *state);
    /* Clusters' openness (ff_openness.h): open[f] = ff_face_openness
     * for the patches 0 .. count - 1 through the setup's occluders, rays
     * of length `reach` (the CPU's threads, or a CUDA thread a face).
     * NULL: not offered (with cluster_draws, what clusters need). */
    rad_status (*openness)(void *state, const rad_ff_patch *patches, uint32_t count, double reach, float *open);
} ff_backend;

extern const ff_backend ff_backend_cpu;
/* In builds without CUDA its create() fails with RAD_ERR_UNSUPPORTED. */
extern const ff_backend ff_backend_cuda;

#endif
