/* ff_backend_cuda.cu - the CUDA backend. No MPI here, only CUDA.
 *
 * A group of lanes per patch pair (a few for far pairs, a warp for near
 * ones) runs the shared per-pair procedure (rad_ff_pair.h, the very code
 * the CPU backend runs): its lanes share the quadrature points, samples
 * and shadow rays of the pair, and reduce them with shuffles (every lane
 * gets the same bits, so the adaptive control flow stays uniform); rays go
 * through the flat BVH of ff_bvh.h (any hit, first hit returns). A first
 * kernel classifies every pair as the CPU backend does (ff_pair_class.h)
 * and lists the pairs that can exchange light, far pairs from the front
 * of a list and near ones from the back, so that each gets a launch of its
 * own; culled pairs cost one thread one test and one store. The
 * quadrature estimator runs its two stages in two launches: the
 * quadrature of every listed pair, then the shadow rays of the few that
 * trace (cornell_sphere --subdiv 3: 34 k of 431 k), each kernel with the
 * registers its own code needs.
 *
 * This file is compiled with --fmad=false so each double operation rounds
 * as on the CPU: only atan2, sqrt and sin/cos (a few ulps apart) and
 * borderline ray hits (Moller-Trumbore here, Embree there) differ.
 */
#include <cuda_runtime.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

extern "C" {
#include "ff_backend.h"
#include "ff_bvh.h"
#include "ff_cuda.h"
#include "rad_clock.h"
#include "rad_cuda.h"
#include "rad_log.h"
}
#include "ff_cuda_records.h"
#include "rad_cuda_check.h"
#include "rad_cuda_stage.h"

/* The tracer the shared per-pair procedure calls: the flat BVH, and the
 * calling thread's occluder cache (last: ff_bvh_occluded_cached; set by
 * cuda_thread_tracer). */
struct cuda_tracer {
    const ff_bvh_node *nodes;
    const ff_bvh_tri *tris;
    int32_t root;
    uint32_t root_count;
    double delta; /* ff_segment */
    uint32_t *last;
};

static inline RAD_HD int cuda_occluded(const cuda_tracer *t, rad_vec3 x, rad_vec3 nx, uint32_t a, rad_vec3 y,
                                       rad_vec3 ny, uint32_t b)
{
    ff_segment seg = ff_segment_make(x, nx, a, y, ny, b, t->delta);
    return ff_bvh_occluded_cached(t->nodes, t->tris, t->root, t->root_count, &seg, t->last);
}

/* The kernel's tracer with this thread's cache *last. */
static inline RAD_HD cuda_tracer cuda_thread_tracer(cuda_tracer t, uint32_t *last)
{
    *last = FF_BVH_NO_HIT;
    t.last = last;
    return t;
}

static inline RAD_HD long long cuda_ticks(void)
{
#if defined(__CUDA_ARCH__)
    return clock64();
#else
    return 0;
#endif
}

/* Sums over the `lanes` lanes (a power of two, <= 32) of a warp that
 * share a pair: an xor butterfly within the group, whose mask names only
 * the group's lanes, so groups of one warp may diverge from each other
 * (the procedure's control flow is uniform within a group). The butterfly
 * adds the same two numbers on both sides at each step: same bits on
 * every lane. */
#if defined(__CUDA_ARCH__)
__device__ static inline unsigned cuda_group_mask(unsigned lanes)
{
    unsigned lane = threadIdx.x & 31u;
    return lanes >= 32 ? 0xffffffffu : ((1u << lanes) - 1u) << (lane & ~(lanes - 1u));
}
#endif

template <typename T> static inline RAD_HD T cuda_lane_sum(T v, unsigned lanes)
{
#if defined(__CUDA_ARCH__)
    if (lanes > 1) {
        unsigned mask = cuda_group_mask(lanes);
        for (unsigned offset = lanes / 2; offset > 0; offset >>= 1) v += __shfl_xor_sync(mask, v, offset);
    }
#else
    (void)lanes;
#endif
    return v;
}

#define RAD_FF_LANE_SUM(x, lanes) cuda_lane_sum(x, lanes)
#define RAD_FF_TRACER cuda_tracer
#define RAD_FF_OCCLUDED(t, x, nx, a, y, ny, b) cuda_occluded(t, x, nx, a, y, ny, b)
#define RAD_FF_TICKS() cuda_ticks()
#include "rad_ff_pair.h"

#include "ff_pair_class.h"
#include "ff_openness.h"

enum { FF_CUDA_BLOCK = 256 };
/* Lanes per pair: far pairs (a few quadrature points) in groups of
 * FF_CUDA_FAR_LANES, eight pairs to a warp; near pairs (adaptive cells of
 * up to 100 points) a whole warp each. Measured on an H100
 * (docs/performance.md, session 5): 4 and 8 lanes alike, 16 about 10 %
 * slower, 32 half again. */
#ifndef FF_CUDA_FAR_LANES
#define FF_CUDA_FAR_LANES 4
#endif
/* Lanes per near pair: adaptive cells of up to 100 points, or the
 * contour integral's work items (rad_ff_contour.h). */
#ifndef FF_CUDA_NEAR_LANES
#define FF_CUDA_NEAR_LANES 32
#endif
/* Blocks per SM the pair kernel is compiled for: bounds its registers
 * (65536 / (256 * blocks) per thread), trading spills for occupancy. */
#ifndef FF_CUDA_MIN_BLOCKS
#define FF_CUDA_MIN_BLOCKS 2
#endif
/* The same for the quadrature estimator's kernels: the first holds no
 * tracing code (80 registers at 3 blocks; 2 and 4 are slower), the second
 * all of it (64 registers at 4 blocks: 1.8 ms of rays against 2.1 at 3
 * and 2.7 at 2). */
#ifndef FF_CUDA_QUAD_MIN_BLOCKS
#define FF_CUDA_QUAD_MIN_BLOCKS 3
#endif
#ifndef FF_CUDA_RAY_MIN_BLOCKS
#define FF_CUDA_RAY_MIN_BLOCKS 4
#endif
/* Lanes per pair in the ray kernel: the first batch (32 rays) in one round. */
#ifndef FF_CUDA_RAY_LANES
#define FF_CUDA_RAY_LANES 32
#endif
/* The kernels' counters (d_counters, and each block's in shared memory),
 * one slot each; cuda_counters turns them into ff_counters. */
enum { C_SAMPLES, C_RAYS, C_OCCLUDED, C_NEAR, C_OPEN_SCENE, C_OPEN_BOX, C_SAVED, C_CYCLES, C_RAY_CYCLES, C_REFINED,
       C_CAPPED, C_COUNT };
/* The listing kernel's counts (d_pair_counts), one slot each. */
enum {
    L_FAR,       /* far pairs, listed from the front of d_pairs */
    L_NEAR,      /* near (costly) pairs, listed from the back */
    L_TRACED,    /* listed pairs culling left open to occlusion (FF_PAIR_TRACED) */
    L_RAY_PAIRS, /* the quadrature pairs pass 2 appended to d_ray_pairs (they trace rays) */
    L_COUNT
};

/* A quadrature pair that traces rays: stage 1's result for stage 2
 * (rad_ff_pair_quad_finish). */
struct cuda_ray_pair {
    double g, error;
    uint32_t t; /* r * n + j */
    uint32_t capped;
};

struct cuda_params {
    const rad_ff_patch *patches;
    uint32_t n;
    cuda_tracer tracer;
    rad_ff_pair_params pair;       /* the run's settings (rad_ff_pair.h) */
    ff_pair_rules rules;           /* which pairs are computed, and how (ff_pair_class.h) */
    uint32_t row_begin, row_count;
    double *out;                   /* row_count * n */
    double *errors;                /* row_count * n standard errors, or NULL */
    unsigned long long *counters;  /* C_COUNT */
    const uint32_t *pairs;         /* facing pairs: r * n + j, pair_count of them */
    const uint8_t *verdict;        /* beside each listed pair: its ff_pair_verdict */
    cuda_ray_pair *ray_pairs;      /* quadrature: the pairs that trace, appended by the first stage */
    uint32_t *ray_count;           /* their number (device) */
    int64_t step;                  /* +1: the far list, read forwards; -1: the near list, backwards */
    unsigned lanes;                /* threads per pair (a power of two, <= 32) */
    uint32_t pair_count;
};

/* A device copy of a hierarchy's elements, as far as uploaded (they are
 * only appended to, ff_backend.h), and their keys (NULL in a copy kept
 * without them). */
struct cuda_elements {
    rad_ff_patch *patches;
    uint32_t *keys;
    size_t capacity, uploaded;
};

struct cuda_state {
    ff_setup setup;
    int device; /* the CUDA device, set again by calls that may come from another host thread */
    rad_ff_patch *d_patches;
    ff_bvh_node *d_nodes;
    ff_bvh_tri *d_tris;
    int32_t root;
    uint32_t root_count;
    double *d_out;
    double *d_errors;    /* standard errors, allocated on the first call that asks */
    size_t errors_capacity; /* doubles */
    uint32_t *d_pairs;   /* facing-pair list, out_capacity entries */
    uint8_t *d_verdict;  /* beside d_pairs: each listed pair's ff_pair_verdict */
    uint32_t *d_pair_counts; /* L_COUNT: the listing's counts */
    cuda_ray_pair *d_ray_pairs; /* the quadrature estimator's tracing pairs, ray_capacity of them */
    size_t ray_capacity;
    size_t out_capacity; /* doubles */
    unsigned long long *d_counters;
    cudaEvent_t start, middle, stop;
    double *d_area;             /* the patches' areas, contiguous (compute_records) */
    ff_cuda_records *records;   /* compute_records' buffers; NULL until its first call */
    /* compute_pairs: the elements as far as uploaded (they are appended,
     * never changed, ff_backend.h), the jobs, their outcomes and lists. */
    cuda_elements elements;
    ff_pair_job *d_jobs;
    ff_pair_outcome *d_outcomes;
    uint32_t *d_job_list;
    size_t job_capacity;
    /* cluster_draws' own copies (it may run beside compute_pairs): the
     * cluster tree (once), the elements as far as uploaded, the jobs and
     * their outcomes */
    ff_cluster *d_clusters;
    uint32_t *d_roots;
    double *d_area_before;
    cuda_elements cluster_elements;
    ff_pair_job *d_cluster_jobs;
    ff_cluster_drawn *d_drawn;
    size_t cluster_job_capacity;
    int clusters_uploaded;
    /* compute_pairs and cluster_draws run on host threads of their own,
     * each on a stream of its own that does not wait for the legacy
     * default stream: one's kernels run beside the other's, and one's
     * copies beside the other's kernels (on the default stream each call
     * waited for the other's work, and its copies ran with the GPU idle). */
    cudaStream_t pair_stream, cluster_stream;
    cudaEvent_t pair_start, pair_stop;
    /* The two streams' buffers (round_alloc), from a pool of this state's
     * own where the device has memory pools, else NULL (cudaMalloc). */
    cudaMemPool_t pool;
    rad_cuda_stage pair_stage, cluster_stage; /* the two streams' copies of outcomes and jobs */
};

/* A buffer the pairs' or the clusters' calls grow, on their stream:
 * stream-ordered from s->pool, so that growing one stream's buffers does
 * not wait for the other stream's kernels (cudaFree waits for the whole
 * device: each growth of the element pairs' buffers waited for the
 * cluster draws under way), else cudaMalloc. */
static cudaError_t round_alloc(const cuda_state *s, void **p, size_t bytes, cudaStream_t stream)
{
    return s->pool ? cudaMallocFromPoolAsync(p, bytes, s->pool, stream) : cudaMalloc(p, bytes);
}

/* round_alloc's buffer freed after `stream`'s work so far; NULL is none. */
static void round_free(const cuda_state *s, void *p, cudaStream_t stream)
{
    if (!p) return;
    if (s->pool)
        cudaFreeAsync(p, stream);
    else
        cudaFree(p);
}

/* s->pool, where the device has memory pools: freed memory stays in it
 * for the next growth (until cuda_trim gives it back). */
static cudaError_t round_pool_create(cuda_state *s)
{
    int pools = 0;
    cudaError_t err = cudaDeviceGetAttribute(&pools, cudaDevAttrMemoryPoolsSupported, s->device);
    if (err != cudaSuccess || !pools) return cudaSuccess;
    cudaMemPoolProps props = {};
    props.allocType = cudaMemAllocationTypePinned;
    props.location.type = cudaMemLocationTypeDevice;
    props.location.id = s->device;
    if ((err = cudaMemPoolCreate(&s->pool, &props)) != cudaSuccess) return err;
    uint64_t keep = UINT64_MAX;
    return cudaMemPoolSetAttribute(s->pool, cudaMemPoolAttrReleaseThreshold, &keep);
}

/* Pass 1: thread per pair, the classification (ff_pair_class.h) the CPU
 * backend makes; zeros for pairs that are not computed; computed pairs
 * listed, far ones from the front of p.pairs, near (costly) ones from the
 * back, so each list gets a launch of its own: near pairs (adaptive
 * quadrature, contour terms) take far longer and would hold up the warps
 * of far ones; in the far list a costly pair held its warp's other seven
 * pairs (suzanne_subsurf, H100: form factors 0.72 -> 0.52 s). Order
 * within a list is irrelevant: a pair's value depends only on (i, j).
 * Culling (the convex-enclosure rule, then the shaft test of ff_shaft.h,
 * which clears most pairs that only look blocked and spares them their
 * rays, confirming batches included) runs here, one thread per pair, as
 * on the CPU; the verdict goes beside the pair. Walking the shaft in
 * pass 2, by every lane, cost more (H100, cornell_sphere --subdiv 3: 21
 * ms of kernels against 18). */
__global__ static void ff_facing_kernel(cuda_params p, uint32_t *pairs, uint8_t *verdicts, uint32_t *counts,
                                        uint64_t capacity)
{
    uint64_t t = (uint64_t)blockIdx.x * blockDim.x + threadIdx.x;
    if (t >= (uint64_t)p.row_count * p.n) return;
    uint32_t j = (uint32_t)(t % p.n), i = p.row_begin + (uint32_t)(t / p.n);
    if (p.errors) p.errors[t] = 0.0; /* listed pairs overwrite it */
    int near = 0;
    ff_pair_verdict v = ff_pair_classify(&p.rules, i, j, &near);
    if (!ff_pair_computed(v)) {
        p.out[t] = 0.0; /* not facing, or row j computes this pair: no thread here */
        return;
    }
    uint64_t at = near ? capacity - 1 - atomicAdd(&counts[L_NEAR], 1u) : atomicAdd(&counts[L_FAR], 1u);
    pairs[at] = (uint32_t)t;
    verdicts[at] = (uint8_t)v;
    if (v == FF_PAIR_TRACED) atomicAdd(&counts[L_TRACED], 1u);
}

#ifdef FF_CUDA_PROFILE
/* A study build's account (-DFF_CUDA_PROFILE): per list (far, near) and
 * log2 of the quadrature points, pairs, clock cycles and points. */
__device__ unsigned long long ff_cuda_profile[2][24][3];
#endif

/* A pair's counters into its block's; the verdict says whether culling
 * spared it its rays, and why. */
__device__ static void cuda_count_pair(unsigned long long *block_counts, const rad_ff_pair_result *r,
                                       ff_pair_verdict v, long long cycles)
{
    unsigned long long c[C_COUNT] = {0};
    c[C_SAMPLES] = r->samples;
    c[C_RAYS] = r->rays;
    c[C_OCCLUDED] = r->rays_blocked;
    c[C_NEAR] = (unsigned long long)r->near;
    c[C_OPEN_SCENE] = (unsigned long long)(v == FF_PAIR_OPEN_SCENE);
    c[C_OPEN_BOX] = (unsigned long long)(v == FF_PAIR_OPEN_BOX);
    c[C_SAVED] = r->rays_skipped;
    c[C_REFINED] = (unsigned long long)r->refined;
    c[C_CAPPED] = (unsigned long long)r->capped;
    c[C_RAY_CYCLES] = (unsigned long long)r->ray_ticks;
    c[C_CYCLES] = (unsigned long long)cycles;
    for (int m = 0; m < C_COUNT; m++)
        if (c[m]) atomicAdd(&block_counts[m], c[m]);
}

/* The listed pair `group` of this launch: its index t = r * n + j, its
 * patches and its verdict (pass 1). */
__device__ static uint32_t cuda_listed_pair(const cuda_params &p, uint64_t group, uint32_t *i, uint32_t *j,
                                            ff_pair_verdict *v)
{
    uint32_t t = p.pairs[p.step * (int64_t)group];
    *j = t % p.n, *i = p.row_begin + t / p.n;
    *v = (ff_pair_verdict)p.verdict[p.step * (int64_t)group];
    return t;
}

/* The pair kernels' frame. Every thread of a pair kernel calls
 * cuda_pair_kernel_begin first - it zeroes the block's counters (shared
 * memory, C_COUNT) and says which group of p.lanes threads (one pair) and
 * which lane of it the thread is - and cuda_pair_kernel_end last, which
 * adds the block's counters to the launch's (p.counters). */
struct cuda_group {
    uint64_t group; /* the pair's index in this launch's list */
    unsigned lane;  /* 0 .. p.lanes - 1 */
};

__device__ static cuda_group cuda_pair_kernel_begin(unsigned lanes, unsigned long long *block_counts)
{
    if (threadIdx.x < C_COUNT) block_counts[threadIdx.x] = 0;
    __syncthreads();
    uint64_t thread = (uint64_t)blockIdx.x * blockDim.x + threadIdx.x;
    cuda_group g;
    g.group = thread / lanes;
    g.lane = (unsigned)(thread % lanes);
    return g;
}

__device__ static void cuda_pair_kernel_end(unsigned long long *counters, const unsigned long long *block_counts)
{
    __syncthreads();
    if (threadIdx.x < C_COUNT) atomicAdd(&counters[threadIdx.x], block_counts[threadIdx.x]);
}

/* The run's settings for this lane of a group (rad_ff_pair.h, "Lanes"). */
__device__ static rad_ff_pair_params cuda_lane_params(const rad_ff_pair_params &run, unsigned lane, unsigned lanes)
{
    rad_ff_pair_params pp = run;
    pp.lane = lane;
    pp.lanes = lanes;
    return pp;
}

/* Pass 2 of the Monte Carlo estimators: a group of p.lanes threads per
 * listed pair, the shared per-pair procedure. Pairs culling cleared
 * (pass 1) trace nothing. */
__global__ static void __launch_bounds__(FF_CUDA_BLOCK, FF_CUDA_MIN_BLOCKS) ff_pairs_kernel(cuda_params p)
{
    __shared__ unsigned long long block_counts[C_COUNT];
    cuda_group g = cuda_pair_kernel_begin(p.lanes, block_counts);
    if (g.group < p.pair_count) { /* uniform within the group */
        long long start = clock64();
        uint32_t i, j;
        ff_pair_verdict v;
        uint32_t t = cuda_listed_pair(p, g.group, &i, &j, &v);
        rad_ff_pair_params pp = cuda_lane_params(p.pair, g.lane, p.lanes);
        rad_ff_pair_result r;
        uint32_t last;
        const cuda_tracer tracer = cuda_thread_tracer(p.tracer, &last);
        rad_ff_pair_compute(&pp, &p.patches[i], &p.patches[j], i, j, v == FF_PAIR_TRACED ? &tracer : NULL, &r);
        if (g.lane == 0) {
            p.out[t] = r.coupling;
            if (p.errors) p.errors[t] = r.error;
            cuda_count_pair(block_counts, &r, v, clock64() - start);
        }
    }
    cuda_pair_kernel_end(p.counters, block_counts);
}

/* Pass 2 of the quadrature estimator, stage 1 (rad_ff_pair.h): G0 of
 * every listed pair, a group of p.lanes threads each; pairs that need no
 * rays are finished here, the others appended to p.ray_pairs for pass 3.
 * Without the tracing code this kernel holds fewer registers, and pairs
 * whose rays refine no longer hold up the warps of those that trace none. */
__global__ static void __launch_bounds__(FF_CUDA_BLOCK, FF_CUDA_QUAD_MIN_BLOCKS) ff_quad_kernel(cuda_params p)
{
    __shared__ unsigned long long block_counts[C_COUNT];
    cuda_group g = cuda_pair_kernel_begin(p.lanes, block_counts);
    if (g.group < p.pair_count) { /* uniform within the group */
        long long start = clock64();
        uint32_t i, j;
        ff_pair_verdict v;
        uint32_t t = cuda_listed_pair(p, g.group, &i, &j, &v);
        rad_ff_pair_params pp = cuda_lane_params(p.pair, g.lane, p.lanes);
        const rad_ff_patch *pi = &p.patches[i], *pj = &p.patches[j];
        rad_ff_quad_result g0 = rad_ff_pair_quad_unoccluded(&pp, pi, pj, i, j);
#ifdef FF_CUDA_PROFILE
        if (g.lane == 0) {
            int bucket = 0;
            while (bucket < 23 && (1u << bucket) < g0.points) bucket++;
            unsigned long long *slot = ff_cuda_profile[p.step < 0][bucket];
            atomicAdd(&slot[0], 1ull);
            atomicAdd(&slot[1], (unsigned long long)(clock64() - start));
            atomicAdd(&slot[2], (unsigned long long)g0.points);
        }
#endif
        if (g.lane == 0) {
            rad_ff_pair_result r = {0};
            if (v == FF_PAIR_TRACED && rad_ff_pair_quad_traces(&pp, &g0)) {
                cuda_ray_pair *rp = &p.ray_pairs[atomicAdd(p.ray_count, 1u)];
                rp->g = g0.g, rp->error = g0.error, rp->t = t, rp->capped = (uint32_t)g0.capped;
                r.samples = g0.points; /* the rest comes from pass 3 */
            } else {
                rad_ff_pair_quad_finish(&pp, pi, pj, i, j, &g0, (const cuda_tracer *)NULL, &r);
                p.out[t] = r.coupling;
                if (p.errors) p.errors[t] = r.error;
            }
            cuda_count_pair(block_counts, &r, v, clock64() - start);
        }
    }
    cuda_pair_kernel_end(p.counters, block_counts);
}

/* Pass 3 of the quadrature estimator, stage 2: the shadow rays of the
 * pairs pass 2 appended, a group of p.lanes threads each. Launched for as
 * many pairs as culling left open (an upper bound); groups past
 * *p.ray_count return at once. */
__global__ static void __launch_bounds__(FF_CUDA_BLOCK, FF_CUDA_RAY_MIN_BLOCKS) ff_quad_rays_kernel(cuda_params p)
{
    __shared__ unsigned long long block_counts[C_COUNT];
    cuda_group g = cuda_pair_kernel_begin(p.lanes, block_counts);
    if (g.group < *p.ray_count) { /* uniform within the group */
        long long start = clock64();
        cuda_ray_pair rp = p.ray_pairs[g.group];
        uint32_t j = rp.t % p.n, i = p.row_begin + rp.t / p.n;
        rad_ff_pair_params pp = cuda_lane_params(p.pair, g.lane, p.lanes);
        rad_ff_quad_result g0;
        g0.g = rp.g, g0.error = rp.error, g0.points = 0, g0.cells = 0, g0.capped = (int)rp.capped;
        rad_ff_pair_result r = {0};
        uint32_t last;
        const cuda_tracer tracer = cuda_thread_tracer(p.tracer, &last);
        rad_ff_pair_quad_finish(&pp, &p.patches[i], &p.patches[j], i, j, &g0, &tracer, &r);
        if (g.lane == 0) {
            p.out[rp.t] = r.coupling;
            if (p.errors) p.errors[rp.t] = r.error;
            r.samples = 0; /* counted in pass 2 */
            cuda_count_pair(block_counts, &r, FF_PAIR_TRACED, clock64() - start); /* no culling counts twice */
        }
    }
    cuda_pair_kernel_end(p.counters, block_counts);
}

/* Hierarchical radiosity's element pairs (compute_pairs), as the CPU
 * backend's cpu_compute_pairs: a listing kernel classifies each job
 * (ff_pair_class.h over the elements), computes the oracle's geometry
 * of the computed ones (rad_ff_spread.h) and lists them, far
 * from the front and near (costly) from the back; a pair kernel per list
 * runs the per-pair procedure with the elements' keys, a group of lanes
 * per job. A job's outcome depends only on its own two elements, so the
 * list's order (atomics) changes nothing. */
struct cuda_link_params {
    const rad_ff_patch *patches; /* the hierarchy's elements (device copy) */
    const uint32_t *keys;        /* beside them: each element's key (ff_backend.compute_pairs) */
    const ff_pair_job *jobs;
    ff_pair_outcome *out;        /* beside the jobs; the listing kernel sets each verdict */
    const uint32_t *list;        /* this launch's jobs: indices into jobs, read with step */
    int64_t step;                /* +1: the far list, forwards; -1: the near list, backwards */
    uint32_t job_count, count;   /* all jobs; this launch's */
    unsigned lanes;
    cuda_tracer tracer;
    rad_ff_pair_params pair;
    ff_pair_rules rules;         /* over the elements: every ordered pair its own, nothing reused */
    unsigned long long *counters; /* C_COUNT */
};

__global__ static void ff_link_facing_kernel(cuda_link_params p, uint32_t *list, uint32_t *counts)
{
    uint64_t k = (uint64_t)blockIdx.x * blockDim.x + threadIdx.x;
    if (k >= p.job_count) return;
    const ff_pair_job job = p.jobs[k];
    int near = 0;
    ff_pair_verdict v = ff_pair_classify(&p.rules, job.a, job.b, &near);
    ff_pair_outcome o = {};
    o.verdict = (uint32_t)v;
    if (ff_pair_computed(v) && job.spread) { /* the oracle's geometry, one thread per pair */
        o.spread_ab = rad_ff_factor_spread(&p.patches[job.a], &p.patches[job.b]);
        o.spread_ba = rad_ff_factor_spread(&p.patches[job.b], &p.patches[job.a]);
    }
    p.out[k] = o;
    if (!ff_pair_computed(v)) return;
    uint64_t at = near ? p.job_count - 1 - atomicAdd(&counts[L_NEAR], 1u) : atomicAdd(&counts[L_FAR], 1u);
    list[at] = (uint32_t)k;
    if (v == FF_PAIR_TRACED) atomicAdd(&counts[L_TRACED], 1u);
}

__global__ static void __launch_bounds__(FF_CUDA_BLOCK, FF_CUDA_MIN_BLOCKS) ff_link_pairs_kernel(cuda_link_params p)
{
    __shared__ unsigned long long block_counts[C_COUNT];
    cuda_group g = cuda_pair_kernel_begin(p.lanes, block_counts);
    if (g.group < p.count) { /* uniform within the group */
        long long start = clock64();
        const uint32_t k = p.list[p.step * (int64_t)g.group];
        const ff_pair_job job = p.jobs[k];
        const ff_pair_verdict v = (ff_pair_verdict)p.out[k].verdict;
        rad_ff_pair_params pp = cuda_lane_params(p.pair, g.lane, p.lanes);
        pp.ray_floor = job.ray_floor;
        rad_ff_pair_result r;
        uint32_t last;
        const cuda_tracer tracer = cuda_thread_tracer(p.tracer, &last);
        rad_ff_pair_compute(&pp, &p.patches[job.a], &p.patches[job.b], p.keys[job.a], p.keys[job.b],
                            v == FF_PAIR_TRACED ? &tracer : NULL, &r);
        if (g.lane == 0) {
            ff_pair_outcome *o = &p.out[k];
            o->coupling = r.coupling;
            o->error = r.error;
            o->rays = r.rays;
            o->rays_blocked = r.rays_blocked;
            cuda_count_pair(block_counts, &r, v, clock64() - start);
        }
    }
    cuda_pair_kernel_end(p.counters, block_counts);
}

/* ff_cuda.h: CUDA's early start is core's (rad_cuda.h). */
extern "C" void ff_cuda_prestart(int rank) { rad_cuda_prestart(rank); }
extern "C" void ff_cuda_prestart_join(void) { rad_cuda_prestart_join(); }
extern "C" int ff_cuda_device_count(void) { return rad_cuda_device_count(); }

static void cuda_destroy(void *state)
{
    cuda_state *s = (cuda_state *)state;
    if (!s) return;
    cudaFree(s->d_patches);
    cudaFree(s->d_nodes);
    cudaFree(s->d_tris);
    cudaFree(s->d_out);
    cudaFree(s->d_errors);
    cudaFree(s->d_pairs);
    cudaFree(s->d_verdict);
    cudaFree(s->d_pair_counts);
    cudaFree(s->d_ray_pairs);
    cudaFree(s->d_counters);
    cudaFree(s->d_area);
    cudaFree(s->d_clusters);
    cudaFree(s->d_roots);
    cudaFree(s->d_area_before);
    round_free(s, s->elements.patches, s->pair_stream);
    round_free(s, s->elements.keys, s->pair_stream);
    round_free(s, s->d_jobs, s->pair_stream);
    round_free(s, s->d_outcomes, s->pair_stream);
    round_free(s, s->d_job_list, s->pair_stream);
    round_free(s, s->cluster_elements.patches, s->cluster_stream);
    round_free(s, s->d_cluster_jobs, s->cluster_stream);
    round_free(s, s->d_drawn, s->cluster_stream);
    if (s->pair_stream) cudaStreamSynchronize(s->pair_stream);
    if (s->cluster_stream) cudaStreamSynchronize(s->cluster_stream);
    rad_cuda_stage_free(&s->pair_stage);
    rad_cuda_stage_free(&s->cluster_stage);
    if (s->pool) cudaMemPoolDestroy(s->pool);
    if (s->pair_stream) cudaStreamDestroy(s->pair_stream);
    if (s->cluster_stream) cudaStreamDestroy(s->cluster_stream);
    if (s->pair_start) cudaEventDestroy(s->pair_start);
    if (s->pair_stop) cudaEventDestroy(s->pair_stop);
    ff_cuda_records_free(s->records);
    if (s->start) cudaEventDestroy(s->start);
    if (s->middle) cudaEventDestroy(s->middle);
    if (s->stop) cudaEventDestroy(s->stop);
    delete s;
}

/* Every buffer a round grows, freed (ff_backend.trim); each is grown
 * again where its capacity falls short. The scene's BVH, patches and the
 * uploaded elements stay. */
static void cuda_trim(void *state)
{
    cuda_state *s = (cuda_state *)state;
    if (!s) return;
    cudaFree(s->d_out), cudaFree(s->d_pairs), cudaFree(s->d_verdict);
    s->d_out = NULL, s->d_pairs = NULL, s->d_verdict = NULL, s->out_capacity = 0;
    cudaFree(s->d_errors);
    s->d_errors = NULL, s->errors_capacity = 0;
    cudaFree(s->d_ray_pairs);
    s->d_ray_pairs = NULL, s->ray_capacity = 0;
    round_free(s, s->d_jobs, s->pair_stream), round_free(s, s->d_outcomes, s->pair_stream);
    round_free(s, s->d_job_list, s->pair_stream);
    s->d_jobs = NULL, s->d_outcomes = NULL, s->d_job_list = NULL, s->job_capacity = 0;
    round_free(s, s->d_cluster_jobs, s->cluster_stream), round_free(s, s->d_drawn, s->cluster_stream);
    s->d_cluster_jobs = NULL, s->d_drawn = NULL, s->cluster_job_capacity = 0;
    if (s->pool) { /* the memory back to the device, for what runs next (the links' solve) */
        cudaStreamSynchronize(s->pair_stream);
        cudaStreamSynchronize(s->cluster_stream);
        cudaMemPoolTrimTo(s->pool, 0);
    }
    rad_cuda_stage_free(&s->pair_stage); /* and the page-locked buffers to the host */
    rad_cuda_stage_free(&s->cluster_stage);
}

static rad_status cuda_create(const ff_setup *setup, void **out_state)
{
    rad_status status = RAD_OK;
    ff_bvh bvh = {};
    cuda_state *s = new cuda_state();
    s->setup = *setup;
    int count = ff_cuda_device_count();
    if (count == 0) {
        rad_error("--backend cuda: no CUDA device is visible to this process");
        status = RAD_ERR_UNSUPPORTED;
        goto done;
    }
    s->device = setup->device % count;
    RAD_CUDA_TRY(cudaSetDevice(s->device));
    if ((status = ff_bvh_build(setup->triangles, setup->triangle_face, setup->triangle_count, &bvh)) != RAD_OK)
        goto done;
    s->root = bvh.root;
    s->root_count = bvh.root_count;
    RAD_CUDA_TRY(cudaMalloc(&s->d_patches, sizeof(rad_ff_patch) * setup->patch_count));
    RAD_CUDA_TRY(cudaMalloc(&s->d_nodes, sizeof(ff_bvh_node) * (bvh.node_count ? bvh.node_count : 1)));
    RAD_CUDA_TRY(cudaMalloc(&s->d_tris, sizeof(ff_bvh_tri) * (bvh.tri_count ? bvh.tri_count : 1)));
    RAD_CUDA_TRY(cudaMalloc(&s->d_counters, sizeof(unsigned long long) * C_COUNT));
    RAD_CUDA_TRY(cudaMalloc(&s->d_pair_counts, L_COUNT * sizeof(uint32_t)));
    RAD_CUDA_TRY(cudaMemcpy(s->d_patches, setup->patches, sizeof(rad_ff_patch) * setup->patch_count,
                        cudaMemcpyHostToDevice));
    {
        double *area = (double *)malloc(sizeof(double) * (setup->patch_count ? setup->patch_count : 1));
        if (!area) {
            rad_error("out of memory for %u patch areas", setup->patch_count);
            status = RAD_ERR_NOMEM;
            goto done;
        }
        for (uint32_t j = 0; j < setup->patch_count; j++) area[j] = setup->patches[j].area;
        cudaError_t err = cudaMalloc(&s->d_area, sizeof(double) * (setup->patch_count ? setup->patch_count : 1));
        if (err == cudaSuccess)
            err = cudaMemcpy(s->d_area, area, sizeof(double) * setup->patch_count, cudaMemcpyHostToDevice);
        free(area);
        RAD_CUDA_TRY(err);
    }
    if (bvh.node_count)
        RAD_CUDA_TRY(cudaMemcpy(s->d_nodes, bvh.nodes, sizeof(ff_bvh_node) * bvh.node_count, cudaMemcpyHostToDevice));
    if (bvh.tri_count)
        RAD_CUDA_TRY(cudaMemcpy(s->d_tris, bvh.tris, sizeof(ff_bvh_tri) * bvh.tri_count, cudaMemcpyHostToDevice));
    RAD_CUDA_TRY(cudaEventCreate(&s->start));
    RAD_CUDA_TRY(cudaEventCreate(&s->middle));
    RAD_CUDA_TRY(cudaEventCreate(&s->stop));
    RAD_CUDA_TRY(cudaEventCreate(&s->pair_start));
    RAD_CUDA_TRY(cudaEventCreate(&s->pair_stop));
    RAD_CUDA_TRY(cudaStreamCreateWithFlags(&s->pair_stream, cudaStreamNonBlocking));
    RAD_CUDA_TRY(cudaStreamCreateWithFlags(&s->cluster_stream, cudaStreamNonBlocking));
    RAD_CUDA_TRY(round_pool_create(s));
    { /* Load the kernels now (CUDA loads modules lazily, at a kernel's
       * first launch), so that setup, not the kernels' time, pays for it. */
        cudaFuncAttributes attributes;
        RAD_CUDA_TRY(cudaFuncGetAttributes(&attributes, ff_facing_kernel));
        RAD_CUDA_TRY(cudaFuncGetAttributes(&attributes, ff_pairs_kernel));
        RAD_CUDA_TRY(cudaFuncGetAttributes(&attributes, ff_quad_kernel));
        RAD_CUDA_TRY(cudaFuncGetAttributes(&attributes, ff_quad_rays_kernel));
        RAD_CUDA_TRY(cudaFuncGetAttributes(&attributes, ff_link_facing_kernel));
        RAD_CUDA_TRY(cudaFuncGetAttributes(&attributes, ff_link_pairs_kernel));
    }
    /* The copies above ran on the legacy stream, from pageable memory: a
     * call returns once its bytes are staged, not landed, and the pairs'
     * and clusters' streams do not wait for that stream. */
    RAD_CUDA_TRY(cudaDeviceSynchronize());
done:
    ff_bvh_free(&bvh);
    if (status != RAD_OK) {
        cuda_destroy(s);
        return status;
    }
    *out_state = s;
    return RAD_OK;
}

/* One call's counters from the kernels' slots and the listing's counts;
 * `computed`: the pairs the call's rows compute (listed or not facing). */
static ff_counters cuda_counters(const unsigned long long counts[C_COUNT], const uint32_t pair_counts[L_COUNT],
                                 uint64_t computed)
{
    ff_counters c = {};
    c.pairs = computed;
    c.pairs_not_facing = computed - pair_counts[L_FAR] - pair_counts[L_NEAR];
    c.samples = counts[C_SAMPLES];
    c.pairs_refined = counts[C_REFINED];
    c.pairs_capped = counts[C_CAPPED];
    c.rays = counts[C_RAYS];
    c.rays_occluded = counts[C_OCCLUDED];
    c.pairs_near = counts[C_NEAR];
    c.pairs_open_scene = counts[C_OPEN_SCENE];
    c.pairs_open_box = counts[C_OPEN_BOX];
    c.rays_saved = counts[C_SAVED];
    return c;
}

/* Rows [row_begin, row_begin + row_count) into s->d_out (and their
 * standard errors into s->d_errors when `errors`), on the device; the
 * counters added to *counters. */
static rad_status run_kernels(cuda_state *s, uint32_t row_begin, uint32_t row_count, int errors,
                              ff_counters *counters)
{
    const ff_setup *su = &s->setup;
    rad_status status = RAD_OK;
    size_t need = (size_t)row_count * su->patch_count, ray_room;
    unsigned long long counts[C_COUNT] = {0};
    ff_counters call = {}; /* this call's, added to *counters at the end */
    double ray_share = 0.0;
    float kernel_ms = 0;
    uint32_t pair_counts[L_COUNT] = {0};
    float rays_ms = 0;
    int quadrature = su->estimator == RAD_ESTIMATOR_QUADRATURE;
    uint64_t computed = 0; /* pairs this call computes */
    cuda_params p;
    double t_mem = rad_clock_seconds();
    if (need == 0) return RAD_OK;
    if (need > UINT32_MAX) {
        rad_error("cuda: %u rows of %u patches exceed one launch's pair index range", row_count, su->patch_count);
        return RAD_ERR_INVALID;
    }
    if (need > s->out_capacity) {
        cudaFree(s->d_out);
        cudaFree(s->d_pairs);
        cudaFree(s->d_verdict);
        s->d_out = NULL;
        s->d_pairs = NULL;
        s->d_verdict = NULL;
        s->out_capacity = 0;
        RAD_CUDA_TRY(cudaMalloc(&s->d_out, sizeof(double) * need));
        RAD_CUDA_TRY(cudaMalloc(&s->d_pairs, sizeof(uint32_t) * need));
        RAD_CUDA_TRY(cudaMalloc(&s->d_verdict, need));
        s->out_capacity = need;
    }
    /* Room for the tracing pairs, sized with the rows (a sixteenth of the
     * pairs: cornell_sphere --subdiv 3 traces 0.4 %), so that a run does
     * not allocate between its kernels; grown below if a round needs more. */
    ray_room = need / 16 > 65536 ? need / 16 : 65536;
    if (su->estimator == RAD_ESTIMATOR_QUADRATURE && ray_room > s->ray_capacity) {
        cudaFree(s->d_ray_pairs);
        s->d_ray_pairs = NULL;
        s->ray_capacity = 0;
        RAD_CUDA_TRY(cudaMalloc(&s->d_ray_pairs, sizeof(cuda_ray_pair) * ray_room));
        s->ray_capacity = ray_room;
    }
    if (errors && need > s->errors_capacity) {
        cudaFree(s->d_errors);
        s->d_errors = NULL;
        s->errors_capacity = 0;
        RAD_CUDA_TRY(cudaMalloc(&s->d_errors, sizeof(double) * need));
        s->errors_capacity = need;
    }
    RAD_CUDA_TRY(cudaMemset(s->d_counters, 0, sizeof(unsigned long long) * C_COUNT));
    RAD_CUDA_TRY(cudaMemset(s->d_pair_counts, 0, L_COUNT * sizeof(uint32_t)));
    p.patches = s->d_patches;
    p.n = su->patch_count;
    p.tracer.nodes = s->d_nodes;
    p.tracer.tris = s->d_tris;
    p.tracer.root = s->root;
    p.tracer.root_count = s->root_count;
    p.tracer.delta = su->ray_delta;
    p.tracer.last = NULL; /* each thread's own: cuda_thread_tracer */
    p.pair = ff_pair_params(su);
    p.rules = ff_pair_rules_make(su, s->d_patches, s->d_nodes, s->d_tris, s->root, s->root_count);
    p.rules.reuse_old = NULL; /* this backend computes every pair (ff_setup.reuse_old) */
    p.row_begin = row_begin;
    p.row_count = row_count;
    p.out = s->d_out;
    p.errors = errors ? s->d_errors : NULL;
    p.counters = s->d_counters;
    p.pairs = s->d_pairs;
    p.verdict = s->d_verdict;
    p.step = 1;
    p.pair_count = 0;
    counters->memory_seconds += rad_clock_seconds() - t_mem;

    RAD_CUDA_TRY(cudaEventRecord(s->start));
    ff_facing_kernel<<<(unsigned)((need + FF_CUDA_BLOCK - 1) / FF_CUDA_BLOCK), FF_CUDA_BLOCK>>>(
        p, s->d_pairs, s->d_verdict, s->d_pair_counts, need);
    RAD_CUDA_TRY(cudaGetLastError()); /* launch configuration errors */
    RAD_CUDA_TRY(cudaMemcpy(pair_counts, s->d_pair_counts, sizeof pair_counts, cudaMemcpyDeviceToHost));
    if (quadrature && pair_counts[L_TRACED] > s->ray_capacity) { /* grows only */
        cudaFree(s->d_ray_pairs);
        s->d_ray_pairs = NULL;
        s->ray_capacity = 0;
        RAD_CUDA_TRY(cudaMalloc(&s->d_ray_pairs, sizeof(cuda_ray_pair) * pair_counts[L_TRACED]));
        s->ray_capacity = pair_counts[L_TRACED];
    }
    p.ray_pairs = s->d_ray_pairs;
    p.ray_count = &s->d_pair_counts[L_RAY_PAIRS];
    for (int list = L_FAR; list <= L_NEAR; list++) { /* far pairs, then near ones */
        if (pair_counts[list] == 0) continue;
        p.pair_count = pair_counts[list];
        p.pairs = list == L_FAR ? s->d_pairs : s->d_pairs + need - 1;
        p.verdict = list == L_FAR ? s->d_verdict : s->d_verdict + need - 1;
        p.step = list == L_FAR ? 1 : -1;
        p.lanes = list == L_FAR ? FF_CUDA_FAR_LANES : FF_CUDA_NEAR_LANES;
        uint64_t per_block = FF_CUDA_BLOCK / p.lanes;
        uint64_t blocks = ((uint64_t)p.pair_count + per_block - 1) / per_block;
#ifdef FF_CUDA_PROFILE
        RAD_CUDA_TRY(cudaDeviceSynchronize());
        double t_list = rad_clock_seconds();
#endif
        if (quadrature)
            ff_quad_kernel<<<(unsigned)blocks, FF_CUDA_BLOCK>>>(p);
        else
            ff_pairs_kernel<<<(unsigned)blocks, FF_CUDA_BLOCK>>>(p);
        RAD_CUDA_TRY(cudaGetLastError());
#ifdef FF_CUDA_PROFILE
        RAD_CUDA_TRY(cudaDeviceSynchronize());
        fprintf(stderr, "ff_cuda_profile: %s list: %u pairs, %u lanes, %.3f ms\n", list == L_NEAR ? "near" : "far",
                pair_counts[list], p.lanes, 1e3 * (rad_clock_seconds() - t_list));
#endif
    }
    RAD_CUDA_TRY(cudaEventRecord(s->middle));
#ifdef FF_CUDA_PROFILE
    {
        unsigned long long prof[2][24][3];
        RAD_CUDA_TRY(cudaDeviceSynchronize());
        RAD_CUDA_TRY(cudaMemcpyFromSymbol(prof, ff_cuda_profile, sizeof prof));
        for (int list = 0; list < 2; list++)
            for (int b = 0; b < 24; b++)
                if (prof[list][b][0])
                    fprintf(stderr, "ff_cuda_profile: %s points<=2^%d: %llu pairs, %.3g Gcycles, %.1f points/pair, %.0f cycles/pair\n",
                            list ? "near" : "far", b, prof[list][b][0], prof[list][b][1] * 1e-9,
                            (double)prof[list][b][2] / prof[list][b][0], (double)prof[list][b][1] / prof[list][b][0]);
        float ms = 0.0f;
        RAD_CUDA_TRY(cudaEventElapsedTime(&ms, s->start, s->middle));
        fprintf(stderr, "ff_cuda_profile: far %u + near %u pairs: %.3f ms\n", pair_counts[L_FAR], pair_counts[L_NEAR],
                ms);
    }
#endif
    if (quadrature && pair_counts[L_TRACED] > 0) { /* pass 3: the rays of the pairs pass 2 appended */
        p.lanes = FF_CUDA_RAY_LANES;
        uint64_t per_block = FF_CUDA_BLOCK / p.lanes;
        uint64_t blocks = ((uint64_t)pair_counts[L_TRACED] + per_block - 1) / per_block;
        ff_quad_rays_kernel<<<(unsigned)blocks, FF_CUDA_BLOCK>>>(p);
        RAD_CUDA_TRY(cudaGetLastError());
    }
    RAD_CUDA_TRY(cudaEventRecord(s->stop));
    RAD_CUDA_TRY(cudaEventSynchronize(s->stop)); /* execution errors surface here */
    RAD_CUDA_TRY(cudaEventElapsedTime(&rays_ms, s->middle, s->stop));
    RAD_CUDA_TRY(cudaEventElapsedTime(&kernel_ms, s->start, s->stop));

    RAD_CUDA_TRY(cudaMemcpy(counts, s->d_counters, sizeof counts, cudaMemcpyDeviceToHost));
    computed = need;
    if (su->pairs_once) {
        computed = 0;
        for (uint32_t r = 0; r < row_count; r++) computed += rad_ff_row_computes_count(row_begin + r, su->patch_count);
    }
    call = cuda_counters(counts, pair_counts, computed);
    /* Kernel time split: the quadrature estimator's ray launch (pass 3)
     * is visibility; the Monte Carlo estimators trace inside pass 2, whose
     * time is split by where the warps spent their cycles. */
    if (quadrature)
        ray_share = kernel_ms > 0 ? rays_ms / kernel_ms : 0.0;
    else
        ray_share = counts[C_CYCLES] ? (double)counts[C_RAY_CYCLES] / (double)counts[C_CYCLES] : 0.0;
    call.kernel_seconds = kernel_ms * 1e-3 * (1.0 - ray_share);
    call.visibility_seconds = kernel_ms * 1e-3 * ray_share;
    ff_counters_add(counters, &call);
done:
    return status;
}

static rad_status cuda_compute_rows(void *state, uint32_t row_begin, uint32_t row_count, double *out,
                                    double *errors, ff_counters *counters)
{
    cuda_state *s = (cuda_state *)state;
    size_t need = (size_t)row_count * s->setup.patch_count;
    rad_status status = run_kernels(s, row_begin, row_count, errors != NULL, counters);
    if (status != RAD_OK || need == 0) return status;
    double t_mem = rad_clock_seconds();
    RAD_CUDA_TRY(cudaMemcpy(out, s->d_out, sizeof(double) * need, cudaMemcpyDeviceToHost));
    if (errors) RAD_CUDA_TRY(cudaMemcpy(errors, s->d_errors, sizeof(double) * need, cudaMemcpyDeviceToHost));
    counters->memory_seconds += rad_clock_seconds() - t_mem;
    if (s->setup.progress) s->setup.progress(s->setup.progress_user, row_count);
done:
    return status;
}

/* compute_rows, then finished and encoded on the device (ff_cuda_records.h):
 * only the records come back. */
static rad_status cuda_compute_records(void *state, uint32_t row_begin, uint32_t row_count, uint32_t element,
                                       ff_records *values, ff_records *errors, ff_rows_summary *summary,
                                       ff_counters *counters)
{
    cuda_state *s = (cuda_state *)state;
    int want_errors = s->setup.errors;
    *values = ff_records{NULL, NULL, 0};
    if (errors) *errors = ff_records{NULL, NULL, 0};
    if (s->setup.pairs_once) {
        rad_error("internal: compute_records cannot mirror pairs (pairs_once)");
        return RAD_ERR_INVALID;
    }
    if (!s->records && !(s->records = ff_cuda_records_new())) {
        rad_error("out of memory");
        return RAD_ERR_NOMEM;
    }
    rad_status status = run_kernels(s, row_begin, row_count, want_errors, counters);
    if (status != RAD_OK || row_count == 0) return status;
    double t_mem = rad_clock_seconds();
    status = ff_cuda_records_make(s->records, s->d_out, want_errors ? s->d_errors : NULL, s->d_area,
                                  s->setup.patch_count, row_begin, row_count, element, values,
                                  want_errors ? errors : NULL, summary);
    counters->memory_seconds += rad_clock_seconds() - t_mem;
    if (status == RAD_OK && s->setup.progress) s->setup.progress(s->setup.progress_user, row_count);
    return status;
}

/* Elements [0, count) and their keys on the device: the buffers grown
 * (keeping what is there), the elements past those uploaded copied, on
 * `stream` (the copies done when it returns). */
static rad_status upload_elements(const cuda_state *s, cuda_elements *e, const rad_ff_patch *patches,
                                  const uint32_t *keys, size_t count, cudaStream_t stream)
{
    rad_status status = RAD_OK;
    if (count > e->capacity) {
        size_t cap = e->capacity ? 2 * e->capacity : 4096;
        while (cap < count) cap *= 2;
        void *elements = NULL, *element_keys = NULL;
        cudaError_t err = round_alloc(s, &elements, cap * sizeof *patches, stream);
        if (err == cudaSuccess && keys) err = round_alloc(s, &element_keys, cap * sizeof *keys, stream);
        if (err == cudaSuccess && e->uploaded) {
            err = cudaMemcpyAsync(elements, e->patches, e->uploaded * sizeof *patches, cudaMemcpyDeviceToDevice,
                                  stream);
            if (err == cudaSuccess && keys)
                err = cudaMemcpyAsync(element_keys, e->keys, e->uploaded * sizeof *keys, cudaMemcpyDeviceToDevice,
                                      stream);
            /* before the old copies go (a pool's free follows the copies on the stream) */
            if (err == cudaSuccess && !s->pool) err = cudaStreamSynchronize(stream);
        }
        if (err != cudaSuccess) {
            round_free(s, elements, stream);
            round_free(s, element_keys, stream);
        }
        RAD_CUDA_TRY(err);
        round_free(s, e->patches, stream);
        round_free(s, e->keys, stream);
        e->patches = (rad_ff_patch *)elements;
        e->keys = (uint32_t *)element_keys;
        e->capacity = cap;
    }
    if (count > e->uploaded) {
        const size_t from = e->uploaded, more = count - from;
        RAD_CUDA_TRY(cudaMemcpyAsync(e->patches + from, patches + from, more * sizeof *patches, cudaMemcpyHostToDevice,
                                     stream));
        if (keys)
            RAD_CUDA_TRY(
                cudaMemcpyAsync(e->keys + from, keys + from, more * sizeof *keys, cudaMemcpyHostToDevice, stream));
        RAD_CUDA_TRY(cudaStreamSynchronize(stream));
        e->uploaded = count;
    }
done:
    return status;
}

/* ff_backend.compute_pairs on the GPU: the jobs up, the listing kernel,
 * a pair launch per list, the outcomes back. */
static rad_status cuda_compute_pairs(void *state, const rad_ff_patch *patches, const uint32_t *keys,
                                     const ff_pair_job *jobs, size_t count, ff_pair_outcome *out,
                                     ff_counters *counters)
{
    cuda_state *s = (cuda_state *)state;
    const ff_setup *su = &s->setup;
    const cudaStream_t st = s->pair_stream;
    rad_status status = RAD_OK;
    unsigned long long counts[C_COUNT] = {0};
    uint32_t pair_counts[L_COUNT] = {0};
    float kernel_ms = 0;
    double t_mem = rad_clock_seconds();
    cuda_link_params p;
    ff_counters call = {};
    size_t elements = 0;
    if (count == 0) return RAD_OK;
    if (count > UINT32_MAX) {
        rad_error("cuda: %zu element pairs exceed one launch's index range", count);
        return RAD_ERR_INVALID;
    }
    /* the hierarchy calls from a thread beside the cluster pairs' (ff_links.c);
     * the current device is per host thread */
    RAD_CUDA_TRY(cudaSetDevice(s->device));
    for (size_t k = 0; k < count; k++) {
        const size_t top = (jobs[k].a > jobs[k].b ? jobs[k].a : jobs[k].b) + (size_t)1;
        if (top > elements) elements = top;
    }
    if ((status = upload_elements(s, &s->elements, patches, keys, elements, st)) != RAD_OK) return status;
    if (count > s->job_capacity) {
        round_free(s, s->d_jobs, st);
        round_free(s, s->d_outcomes, st);
        round_free(s, s->d_job_list, st);
        s->d_jobs = NULL;
        s->d_outcomes = NULL;
        s->d_job_list = NULL;
        s->job_capacity = 0;
        size_t cap = count < 65536 ? 65536 : count + count / 4;
        RAD_CUDA_TRY(round_alloc(s, (void **)&s->d_jobs, cap * sizeof *s->d_jobs, st));
        RAD_CUDA_TRY(round_alloc(s, (void **)&s->d_outcomes, cap * sizeof *s->d_outcomes, st));
        RAD_CUDA_TRY(round_alloc(s, (void **)&s->d_job_list, cap * sizeof *s->d_job_list, st));
        s->job_capacity = cap;
    }
    if ((status = rad_cuda_stage_up(&s->pair_stage, s->d_jobs, jobs, count * sizeof *jobs, st)) != RAD_OK)
        return status;
    RAD_CUDA_TRY(cudaMemsetAsync(s->d_counters, 0, sizeof(unsigned long long) * C_COUNT, st));
    RAD_CUDA_TRY(cudaMemsetAsync(s->d_pair_counts, 0, L_COUNT * sizeof(uint32_t), st));
    p.patches = s->elements.patches;
    p.keys = s->elements.keys;
    p.jobs = s->d_jobs;
    p.out = s->d_outcomes;
    p.list = s->d_job_list;
    p.step = 1;
    p.job_count = (uint32_t)count;
    p.count = 0;
    p.lanes = 1;
    p.tracer.nodes = s->d_nodes;
    p.tracer.tris = s->d_tris;
    p.tracer.root = s->root;
    p.tracer.root_count = s->root_count;
    p.tracer.delta = su->ray_delta;
    p.tracer.last = NULL; /* each thread's own: cuda_thread_tracer */
    p.pair = ff_pair_params(su);
    p.rules = ff_pair_rules_make(su, s->elements.patches, s->d_nodes, s->d_tris, s->root, s->root_count);
    p.rules.pairs_once = 0;
    p.rules.reuse_old = NULL;
    p.counters = s->d_counters;
    counters->memory_seconds += rad_clock_seconds() - t_mem;

    RAD_CUDA_TRY(cudaEventRecord(s->pair_start, st));
    ff_link_facing_kernel<<<(unsigned)((count + FF_CUDA_BLOCK - 1) / FF_CUDA_BLOCK), FF_CUDA_BLOCK, 0, st>>>(
        p, s->d_job_list, s->d_pair_counts);
    RAD_CUDA_TRY(cudaGetLastError());
    RAD_CUDA_TRY(cudaMemcpyAsync(pair_counts, s->d_pair_counts, sizeof pair_counts, cudaMemcpyDeviceToHost, st));
    RAD_CUDA_TRY(cudaStreamSynchronize(st));
    for (int list = L_FAR; list <= L_NEAR; list++) {
        if (pair_counts[list] == 0) continue;
        p.count = pair_counts[list];
        p.list = list == L_FAR ? s->d_job_list : s->d_job_list + count - 1;
        p.step = list == L_FAR ? 1 : -1;
        p.lanes = list == L_FAR ? FF_CUDA_FAR_LANES : FF_CUDA_NEAR_LANES;
        uint64_t per_block = FF_CUDA_BLOCK / p.lanes;
        uint64_t blocks = ((uint64_t)p.count + per_block - 1) / per_block;
        ff_link_pairs_kernel<<<(unsigned)blocks, FF_CUDA_BLOCK, 0, st>>>(p);
        RAD_CUDA_TRY(cudaGetLastError());
    }
    RAD_CUDA_TRY(cudaEventRecord(s->pair_stop, st));
    RAD_CUDA_TRY(cudaEventSynchronize(s->pair_stop)); /* execution errors surface here */
    RAD_CUDA_TRY(cudaEventElapsedTime(&kernel_ms, s->pair_start, s->pair_stop));
    t_mem = rad_clock_seconds();
    RAD_CUDA_TRY(cudaMemcpyAsync(counts, s->d_counters, sizeof counts, cudaMemcpyDeviceToHost, st));
    if ((status = rad_cuda_stage_down(&s->pair_stage, out, s->d_outcomes, count * sizeof *out, st)) != RAD_OK)
        return status;
    counters->memory_seconds += rad_clock_seconds() - t_mem;
    call = cuda_counters(counts, pair_counts, count);
    {
        const double ray_share = counts[C_CYCLES] ? (double)counts[C_RAY_CYCLES] / (double)counts[C_CYCLES] : 0.0;
        call.kernel_seconds = kernel_ms * 1e-3 * (1.0 - ray_share);
        call.visibility_seconds = kernel_ms * 1e-3 * ray_share;
    }
    ff_counters_add(counters, &call);
done:
    return status;
}

/* ff_backend.cluster_draws: a thread per pair (ff_cluster_pair). */
__global__ static void ff_cluster_draws_kernel(ff_cluster_view v, cuda_tracer t, const ff_pair_job *jobs,
                                               uint32_t count, ff_cluster_drawn *out)
{
    uint32_t k = blockIdx.x * blockDim.x + threadIdx.x;
    if (k >= count) return;
    ff_cluster_drawn o;
    ff_cluster_pair(&v, t.nodes, t.tris, t.root, t.root_count, jobs[k].a, jobs[k].b, &o);
    out[k] = o;
}

static rad_status cuda_cluster_draws(void *state, const ff_cluster_view *v, const ff_pair_job *jobs, size_t count,
                                     ff_cluster_drawn *out)
{
    cuda_state *s = (cuda_state *)state;
    const cudaStream_t st = s->cluster_stream;
    rad_status status = RAD_OK;
    cuda_tracer t;
    ff_cluster_view dv;
    if (count == 0) return RAD_OK;
    if (count > UINT32_MAX) {
        rad_error("cuda: %zu cluster pairs exceed one launch's index range", count);
        return RAD_ERR_INVALID;
    }
    RAD_CUDA_TRY(cudaSetDevice(s->device)); /* per host thread */
    if (!s->clusters_uploaded) { /* the tree: the same on every call of a run */
        const size_t clusters = v->cluster_count ? v->cluster_count : 1, roots = (size_t)v->root_count + 1;
        if (!s->d_clusters) RAD_CUDA_TRY(cudaMalloc(&s->d_clusters, clusters * sizeof *s->d_clusters));
        if (!s->d_roots) RAD_CUDA_TRY(cudaMalloc(&s->d_roots, roots * sizeof *s->d_roots));
        if (!s->d_area_before) RAD_CUDA_TRY(cudaMalloc(&s->d_area_before, roots * sizeof *s->d_area_before));
        RAD_CUDA_TRY(cudaMemcpyAsync(s->d_clusters, v->clusters, v->cluster_count * sizeof *s->d_clusters,
                                     cudaMemcpyHostToDevice, st));
        RAD_CUDA_TRY(cudaMemcpyAsync(s->d_roots, v->roots, v->root_count * sizeof *s->d_roots, cudaMemcpyHostToDevice,
                                     st));
        RAD_CUDA_TRY(cudaMemcpyAsync(s->d_area_before, v->area_before, roots * sizeof *s->d_area_before,
                                     cudaMemcpyHostToDevice, st));
        s->clusters_uploaded = 1;
    }
    if ((status = upload_elements(s, &s->cluster_elements, v->patches, NULL, v->element_count, st)) != RAD_OK)
        return status;
    if (count > s->cluster_job_capacity) {
        round_free(s, s->d_cluster_jobs, st);
        round_free(s, s->d_drawn, st);
        s->d_cluster_jobs = NULL;
        s->d_drawn = NULL;
        s->cluster_job_capacity = 0;
        size_t cap = count < 65536 ? 65536 : count + count / 4;
        RAD_CUDA_TRY(round_alloc(s, (void **)&s->d_cluster_jobs, cap * sizeof *s->d_cluster_jobs, st));
        RAD_CUDA_TRY(round_alloc(s, (void **)&s->d_drawn, cap * sizeof *s->d_drawn, st));
        s->cluster_job_capacity = cap;
    }
    if ((status = rad_cuda_stage_up(&s->cluster_stage, s->d_cluster_jobs, jobs, count * sizeof *jobs, st)) != RAD_OK)
        return status;
    dv = *v;
    dv.clusters = s->d_clusters;
    dv.roots = s->d_roots;
    dv.area_before = s->d_area_before;
    dv.patches = s->cluster_elements.patches;
    t.nodes = s->d_nodes;
    t.tris = s->d_tris;
    t.root = s->root;
    t.root_count = s->root_count;
    t.delta = s->setup.ray_delta;
    t.last = NULL; /* ff_cluster_pair keeps its own */
    ff_cluster_draws_kernel<<<(unsigned)((count + FF_CUDA_BLOCK - 1) / FF_CUDA_BLOCK), FF_CUDA_BLOCK, 0, st>>>(
        dv, t, s->d_cluster_jobs, (uint32_t)count, s->d_drawn);
    RAD_CUDA_TRY(cudaGetLastError());
    status = rad_cuda_stage_down(&s->cluster_stage, out, s->d_drawn, count * sizeof *out, st); /* errors surface here */
done:
    return status;
}

/* ff_backend.openness: a thread per face (ff_face_openness). */
__global__ static void ff_openness_kernel(cuda_tracer t, const rad_ff_patch *patches, uint32_t count, double reach,
                                          float *open)
{
    uint32_t f = blockIdx.x * blockDim.x + threadIdx.x;
    if (f >= count) return;
    open[f] = ff_face_openness(&patches[f], f, reach, t.delta, t.nodes, t.tris, t.root, t.root_count);
}

static rad_status cuda_openness(void *state, const rad_ff_patch *patches, uint32_t count, double reach, float *open)
{
    cuda_state *s = (cuda_state *)state;
    const cudaStream_t st = s->pair_stream;
    rad_status status = RAD_OK;
    rad_ff_patch *d_patches = NULL;
    float *d_open = NULL;
    cuda_tracer t = {s->d_nodes, s->d_tris, s->root, s->root_count, s->setup.ray_delta, NULL};
    if (count == 0) return RAD_OK;
    RAD_CUDA_TRY(cudaSetDevice(s->device));
    RAD_CUDA_TRY(round_alloc(s, (void **)&d_patches, count * sizeof *patches, st));
    RAD_CUDA_TRY(round_alloc(s, (void **)&d_open, count * sizeof *open, st));
    if ((status = rad_cuda_stage_up(&s->pair_stage, d_patches, patches, count * sizeof *patches, st)) != RAD_OK)
        goto done;
    ff_openness_kernel<<<(count + FF_CUDA_BLOCK - 1) / FF_CUDA_BLOCK, FF_CUDA_BLOCK, 0, st>>>(t, d_patches, count,
                                                                                          reach, d_open);
    RAD_CUDA_TRY(cudaGetLastError());
    status = rad_cuda_stage_down(&s->pair_stage, open, d_open, count * sizeof *open, st); /* errors surface here */
done:
    round_free(s, d_patches, st);
    round_free(s, d_open, st);
    return status;
}

/* Row buffers in page-locked host memory: results stream back by DMA. */
static double *cuda_alloc_rows(void *state, size_t count)
{
    (void)state;
    void *p = NULL;
    if (cudaMallocHost(&p, sizeof(double) * count) != cudaSuccess) {
        cudaGetLastError();
        return NULL;
    }
    return (double *)p;
}

static void cuda_free_rows(void *state, double *rows)
{
    (void)state;
    if (rows) cudaFreeHost(rows);
}

extern "C" const ff_backend ff_backend_cuda = {"cuda",          cuda_create,    cuda_compute_rows, cuda_destroy,
                                               cuda_alloc_rows, cuda_free_rows, cuda_compute_records, cuda_compute_pairs,
                                               cuda_cluster_draws, cuda_trim, cuda_openness};
