/* ff_backend_cuda.cu - the CUDA backend. No MPI here, only CUDA.
 *
 * A group of lanes per patch pair (a few for far pairs, a warp for near
 * ones) runs the shared per-pair procedure (rad_ff_pair.h, the very code
 * the CPU backend runs): its lanes share the quadrature points, samples
 * and shadow rays of the pair, and reduce them with shuffles (every lane
 * gets the same bits, so the adaptive control flow stays uniform); rays go
 * through the flat BVH of ff_bvh.h (any hit, first hit returns). A first
 * kernel lists the pairs that can exchange light, far pairs from the front
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
#include "ff_shaft.h"
#include "ff_cuda.h"
#include "rad_clock.h"
#include "rad_cuda.h"
#include "rad_log.h"
}
#include "ff_cuda_records.h"
#include "rad_cuda_check.h"

/* The tracer the shared per-pair procedure calls: the flat BVH. */
struct cuda_tracer {
    const ff_bvh_node *nodes;
    const ff_bvh_tri *tris;
    int32_t root;
    uint32_t root_count;
    double delta; /* ff_segment */
};

static inline RAD_HD int cuda_occluded(const cuda_tracer *t, rad_vec3 x, rad_vec3 nx, uint32_t a, rad_vec3 y,
                                       rad_vec3 ny, uint32_t b)
{
    ff_segment seg = ff_segment_make(x, nx, a, y, ny, b, t->delta);
    return ff_bvh_occluded(t->nodes, t->tris, t->root, t->root_count, &seg);
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
enum { C_SAMPLES, C_RAYS, C_OCCLUDED, C_NEAR, C_OPEN_SCENE, C_OPEN_BOX, C_SAVED, C_CYCLES, C_RAY_CYCLES, C_REFINED,
       C_CAPPED, C_COUNT };

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
    int cull, scene_convex, pairs_once;
    float cull_margin;             /* the shaft's margin (ff_shaft.h) */
    double eps;
    uint32_t row_begin, row_count;
    double *out;                   /* row_count * n */
    double *errors;                /* row_count * n standard errors, or NULL */
    unsigned long long *counters;  /* C_COUNT */
    const uint32_t *pairs;         /* facing pairs: r * n + j, pair_count of them */
    const uint8_t *open;           /* beside each listed pair: 1 = culling proved it unblocked */
    cuda_ray_pair *ray_pairs;      /* quadrature: the pairs that trace, appended by the first stage */
    uint32_t *ray_count;           /* their number (device) */
    int64_t step;                  /* +1: the far list, read forwards; -1: the near list, backwards */
    unsigned lanes;                /* threads per pair (a power of two, <= 32) */
    uint32_t pair_count;
};

struct cuda_state {
    ff_setup setup;
    rad_ff_patch *d_patches;
    ff_bvh_node *d_nodes;
    ff_bvh_tri *d_tris;
    int32_t root;
    uint32_t root_count;
    double *d_out;
    double *d_errors;    /* standard errors, allocated on the first call that asks */
    size_t errors_capacity; /* doubles */
    uint32_t *d_pairs;   /* facing-pair list, out_capacity entries */
    uint8_t *d_open;     /* beside d_pairs: the pair needs no rays (culling) */
    uint32_t *d_pair_counts; /* [0] far pairs, [1] near pairs, [2] pairs culling left open to
                                occlusion, [3] the quadrature pairs that trace rays */
    cuda_ray_pair *d_ray_pairs; /* the quadrature estimator's tracing pairs, ray_capacity of them */
    size_t ray_capacity;
    size_t out_capacity; /* doubles */
    unsigned long long *d_counters;
    cudaEvent_t start, middle, stop;
    double *d_area;             /* the patches' areas, contiguous (compute_records) */
    ff_cuda_records *records;   /* compute_records' buffers; NULL until its first call */
};

/* Does the pair take a warp (the near list)? Near pairs, and pairs whose
 * smaller patch reaches behind the other's plane: the contour integral
 * over their clipped parts, or the area rule over its fan, takes hundreds
 * to thousands of points; in the far list such a pair held its warp's
 * other seven pairs (suzanne_subsurf, H100: form factors 0.72 -> 0.52 s). */
__device__ static int cuda_pair_listed_near(const rad_ff_patch *pi, const rad_ff_patch *pj, uint32_t i, uint32_t j)
{
    if (rad_ff_pair_near(pi, pj)) return 1;
    int i_is_q = rad_ff_quad_roles(pi, pj, i, j);
    return rad_ff_contour_straddles(i_is_q ? pi : pj, i_is_q ? pj : pi);
}

/* Pass 1: thread per pair; zeros for pairs that cannot exchange light; far
 * pairs listed from the front of p.pairs, near pairs from the back, so each
 * list gets a launch of its own: near pairs (adaptive quadrature, contour
 * terms) take far longer and would hold up the warps of far ones. Order
 * within a list is irrelevant: a pair's value depends only on (i, j).
 * Culling runs here, one thread per listed pair, as on the CPU: the
 * convex-enclosure rule, then the shaft test (ff_shaft.h), which clears most
 * pairs that only look blocked and spares them their rays, confirming
 * batches included. Its verdict goes beside the pair in `open`. The walk
 * leaves out the hull's planes (`hull` 0, as on the CPU): on
 * cornell_sphere --subdiv 3 they clear 412 k pairs instead of 397 k but
 * building them cost more than the rays they save (H100: 19 ms of kernels
 * with them, 18 without; 21 with the walk in pass 2, by every lane). */
__global__ static void ff_facing_kernel(cuda_params p, uint32_t *pairs, uint8_t *open, uint32_t *counts,
                                        uint64_t capacity)
{
    uint64_t t = (uint64_t)blockIdx.x * blockDim.x + threadIdx.x;
    if (t >= (uint64_t)p.row_count * p.n) return;
    uint32_t j = (uint32_t)(t % p.n), i = p.row_begin + (uint32_t)(t / p.n);
    const rad_ff_patch *pi = &p.patches[i], *pj = &p.patches[j];
    if (p.errors) p.errors[t] = 0.0; /* listed pairs overwrite it */
    if (p.pairs_once && !rad_ff_row_computes(i, j))
        p.out[t] = 0.0; /* row j computes this pair: no thread here */
    else if (i == j || !rad_ff_pair_facing(pi, pj, p.eps))
        p.out[t] = 0.0;
    else {
        uint8_t clear = p.pair.rays == 0 || (p.cull && p.scene_convex) ||
                        (p.cull && !ff_pair_may_be_occluded(p.tracer.nodes, p.tracer.tris, p.tracer.root,
                                                            p.tracer.root_count, pi, pj, p.cull_margin,
                                                            p.tracer.delta, 0,
                                                            p.pair.estimator == RAD_ESTIMATOR_QUADRATURE));
        uint64_t at = cuda_pair_listed_near(pi, pj, i, j) ? capacity - 1 - atomicAdd(&counts[1], 1u) : atomicAdd(&counts[0], 1u);
        pairs[at] = (uint32_t)t;
        open[at] = clear;
        if (!clear) atomicAdd(&counts[2], 1u);
    }
}

#ifdef FF_CUDA_PROFILE
/* A study build's account (-DFF_CUDA_PROFILE): per list (far, near) and
 * log2 of the quadrature points, pairs, clock cycles and points. */
__device__ unsigned long long ff_cuda_profile[2][24][3];
#endif

/* A pair's counters into its block's. */
__device__ static void cuda_count_pair(unsigned long long *block_counts, const rad_ff_pair_result *r,
                                       int open_scene, int open_box, long long cycles)
{
    unsigned long long c[C_COUNT] = {0};
    c[C_SAMPLES] = r->samples;
    c[C_RAYS] = r->rays;
    c[C_OCCLUDED] = r->rays_blocked;
    c[C_NEAR] = (unsigned long long)r->near;
    c[C_OPEN_SCENE] = (unsigned long long)open_scene;
    c[C_OPEN_BOX] = (unsigned long long)open_box;
    c[C_SAVED] = r->rays_skipped;
    c[C_REFINED] = (unsigned long long)r->refined;
    c[C_CAPPED] = (unsigned long long)r->capped;
    c[C_RAY_CYCLES] = (unsigned long long)r->ray_ticks;
    c[C_CYCLES] = (unsigned long long)cycles;
    for (int m = 0; m < C_COUNT; m++)
        if (c[m]) atomicAdd(&block_counts[m], c[m]);
}

/* The listed pair `group` of this launch: its index t = r * n + j, its
 * patches and whether culling cleared it. */
__device__ static uint32_t cuda_listed_pair(const cuda_params &p, uint64_t group, uint32_t *i, uint32_t *j, int *open)
{
    uint32_t t = p.pairs[p.step * (int64_t)group];
    *j = t % p.n, *i = p.row_begin + t / p.n;
    *open = p.open[p.step * (int64_t)group];
    return t;
}

/* Pass 2 of the Monte Carlo estimators: a group of p.lanes threads per
 * listed pair, the shared per-pair procedure. Pairs culling cleared
 * (pass 1) trace nothing. */
__global__ static void __launch_bounds__(FF_CUDA_BLOCK, FF_CUDA_MIN_BLOCKS) ff_pairs_kernel(cuda_params p)
{
    __shared__ unsigned long long block_counts[C_COUNT];
    if (threadIdx.x < C_COUNT) block_counts[threadIdx.x] = 0;
    __syncthreads();
    uint64_t thread = (uint64_t)blockIdx.x * blockDim.x + threadIdx.x;
    uint64_t group = thread / p.lanes;
    unsigned lane = (unsigned)(thread % p.lanes);
    if (group < p.pair_count) { /* uniform within the group */
        long long start = clock64();
        uint32_t i, j;
        int open;
        uint32_t t = cuda_listed_pair(p, group, &i, &j, &open);
        int open_scene = p.pair.rays > 0 && p.cull && p.scene_convex;
        rad_ff_pair_params pp = p.pair;
        pp.lane = lane;
        pp.lanes = p.lanes;
        rad_ff_pair_result r;
        rad_ff_pair_compute(&pp, &p.patches[i], &p.patches[j], i, j, open ? NULL : &p.tracer, &r);
        if (lane == 0) {
            p.out[t] = r.coupling;
            if (p.errors) p.errors[t] = r.error;
            cuda_count_pair(block_counts, &r, open_scene, p.pair.rays > 0 && open && !open_scene,
                            clock64() - start);
        }
    }
    __syncthreads();
    if (threadIdx.x < C_COUNT) atomicAdd(&p.counters[threadIdx.x], block_counts[threadIdx.x]);
}

/* Pass 2 of the quadrature estimator, stage 1 (rad_ff_pair.h): G0 of
 * every listed pair, a group of p.lanes threads each; pairs that need no
 * rays are finished here, the others appended to p.ray_pairs for pass 3.
 * Without the tracing code this kernel holds fewer registers, and pairs
 * whose rays refine no longer hold up the warps of those that trace none. */
__global__ static void __launch_bounds__(FF_CUDA_BLOCK, FF_CUDA_QUAD_MIN_BLOCKS) ff_quad_kernel(cuda_params p)
{
    __shared__ unsigned long long block_counts[C_COUNT];
    if (threadIdx.x < C_COUNT) block_counts[threadIdx.x] = 0;
    __syncthreads();
    uint64_t thread = (uint64_t)blockIdx.x * blockDim.x + threadIdx.x;
    uint64_t group = thread / p.lanes;
    unsigned lane = (unsigned)(thread % p.lanes);
    if (group < p.pair_count) { /* uniform within the group */
        long long start = clock64();
        uint32_t i, j;
        int open;
        uint32_t t = cuda_listed_pair(p, group, &i, &j, &open);
        int open_scene = p.pair.rays > 0 && p.cull && p.scene_convex;
        rad_ff_pair_params pp = p.pair;
        pp.lane = lane;
        pp.lanes = p.lanes;
        const rad_ff_patch *pi = &p.patches[i], *pj = &p.patches[j];
        rad_ff_quad_result g0 = rad_ff_pair_quad_unoccluded(&pp, pi, pj, i, j);
#ifdef FF_CUDA_PROFILE
        if (lane == 0) {
            int bucket = 0;
            while (bucket < 23 && (1u << bucket) < g0.points) bucket++;
            unsigned long long *slot = ff_cuda_profile[p.step < 0][bucket];
            atomicAdd(&slot[0], 1ull);
            atomicAdd(&slot[1], (unsigned long long)(clock64() - start));
            atomicAdd(&slot[2], (unsigned long long)g0.points);
        }
#endif
        if (lane == 0) {
            rad_ff_pair_result r = {0};
            if (!open && rad_ff_pair_quad_traces(&pp, &g0)) {
                cuda_ray_pair *rp = &p.ray_pairs[atomicAdd(p.ray_count, 1u)];
                rp->g = g0.g, rp->error = g0.error, rp->t = t, rp->capped = (uint32_t)g0.capped;
                r.samples = g0.points; /* the rest comes from pass 3 */
            } else {
                rad_ff_pair_quad_finish(&pp, pi, pj, i, j, &g0, (const cuda_tracer *)NULL, &r);
                p.out[t] = r.coupling;
                if (p.errors) p.errors[t] = r.error;
            }
            cuda_count_pair(block_counts, &r, open_scene, p.pair.rays > 0 && open && !open_scene,
                            clock64() - start);
        }
    }
    __syncthreads();
    if (threadIdx.x < C_COUNT) atomicAdd(&p.counters[threadIdx.x], block_counts[threadIdx.x]);
}

/* Pass 3 of the quadrature estimator, stage 2: the shadow rays of the
 * pairs pass 2 appended, a group of p.lanes threads each. Launched for as
 * many pairs as culling left open (an upper bound); groups past
 * *p.ray_count return at once. */
__global__ static void __launch_bounds__(FF_CUDA_BLOCK, FF_CUDA_RAY_MIN_BLOCKS) ff_quad_rays_kernel(cuda_params p)
{
    __shared__ unsigned long long block_counts[C_COUNT];
    if (threadIdx.x < C_COUNT) block_counts[threadIdx.x] = 0;
    __syncthreads();
    uint64_t thread = (uint64_t)blockIdx.x * blockDim.x + threadIdx.x;
    uint64_t group = thread / p.lanes;
    unsigned lane = (unsigned)(thread % p.lanes);
    if (group < *p.ray_count) { /* uniform within the group */
        long long start = clock64();
        cuda_ray_pair rp = p.ray_pairs[group];
        uint32_t j = rp.t % p.n, i = p.row_begin + rp.t / p.n;
        rad_ff_pair_params pp = p.pair;
        pp.lane = lane;
        pp.lanes = p.lanes;
        rad_ff_quad_result g0;
        g0.g = rp.g, g0.error = rp.error, g0.points = 0, g0.cells = 0, g0.capped = (int)rp.capped;
        rad_ff_pair_result r = {0};
        rad_ff_pair_quad_finish(&pp, &p.patches[i], &p.patches[j], i, j, &g0, &p.tracer, &r);
        if (lane == 0) {
            p.out[rp.t] = r.coupling;
            if (p.errors) p.errors[rp.t] = r.error;
            r.samples = 0; /* counted in pass 2 */
            cuda_count_pair(block_counts, &r, 0, 0, clock64() - start);
        }
    }
    __syncthreads();
    if (threadIdx.x < C_COUNT) atomicAdd(&p.counters[threadIdx.x], block_counts[threadIdx.x]);
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
    cudaFree(s->d_open);
    cudaFree(s->d_pair_counts);
    cudaFree(s->d_ray_pairs);
    cudaFree(s->d_counters);
    cudaFree(s->d_area);
    ff_cuda_records_free(s->records);
    if (s->start) cudaEventDestroy(s->start);
    if (s->middle) cudaEventDestroy(s->middle);
    if (s->stop) cudaEventDestroy(s->stop);
    delete s;
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
    RAD_CUDA_TRY(cudaSetDevice(setup->device % count));
    if ((status = ff_bvh_build(setup->triangles, setup->triangle_face, setup->triangle_count, &bvh)) != RAD_OK)
        goto done;
    s->root = bvh.root;
    s->root_count = bvh.root_count;
    RAD_CUDA_TRY(cudaMalloc(&s->d_patches, sizeof(rad_ff_patch) * setup->patch_count));
    RAD_CUDA_TRY(cudaMalloc(&s->d_nodes, sizeof(ff_bvh_node) * (bvh.node_count ? bvh.node_count : 1)));
    RAD_CUDA_TRY(cudaMalloc(&s->d_tris, sizeof(ff_bvh_tri) * (bvh.tri_count ? bvh.tri_count : 1)));
    RAD_CUDA_TRY(cudaMalloc(&s->d_counters, sizeof(unsigned long long) * C_COUNT));
    RAD_CUDA_TRY(cudaMalloc(&s->d_pair_counts, 4 * sizeof(uint32_t)));
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
    { /* Load the kernels now (CUDA loads modules lazily, at a kernel's
       * first launch), so that setup, not the kernels' time, pays for it. */
        cudaFuncAttributes attributes;
        RAD_CUDA_TRY(cudaFuncGetAttributes(&attributes, ff_facing_kernel));
        RAD_CUDA_TRY(cudaFuncGetAttributes(&attributes, ff_pairs_kernel));
        RAD_CUDA_TRY(cudaFuncGetAttributes(&attributes, ff_quad_kernel));
        RAD_CUDA_TRY(cudaFuncGetAttributes(&attributes, ff_quad_rays_kernel));
    }
done:
    ff_bvh_free(&bvh);
    if (status != RAD_OK) {
        cuda_destroy(s);
        return status;
    }
    *out_state = s;
    return RAD_OK;
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
    double ray_share = 0.0;
    float kernel_ms = 0;
    uint32_t pair_counts[4] = {0, 0, 0, 0};
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
        cudaFree(s->d_open);
        s->d_out = NULL;
        s->d_pairs = NULL;
        s->d_open = NULL;
        s->out_capacity = 0;
        RAD_CUDA_TRY(cudaMalloc(&s->d_out, sizeof(double) * need));
        RAD_CUDA_TRY(cudaMalloc(&s->d_pairs, sizeof(uint32_t) * need));
        RAD_CUDA_TRY(cudaMalloc(&s->d_open, need));
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
    RAD_CUDA_TRY(cudaMemset(s->d_pair_counts, 0, 4 * sizeof(uint32_t)));
    p.patches = s->d_patches;
    p.n = su->patch_count;
    p.tracer.nodes = s->d_nodes;
    p.tracer.tris = s->d_tris;
    p.tracer.root = s->root;
    p.tracer.root_count = s->root_count;
    p.tracer.delta = su->ray_delta;
    p.pair = ff_pair_params(su);
    p.cull = su->cull;
    p.cull_margin = su->cull_margin;
    p.scene_convex = su->scene_convex;
    p.pairs_once = su->pairs_once;
    p.eps = su->plane_eps;
    p.row_begin = row_begin;
    p.row_count = row_count;
    p.out = s->d_out;
    p.errors = errors ? s->d_errors : NULL;
    p.counters = s->d_counters;
    p.pairs = s->d_pairs;
    p.open = s->d_open;
    p.step = 1;
    p.pair_count = 0;
    counters->memory_seconds += rad_clock_seconds() - t_mem;

    RAD_CUDA_TRY(cudaEventRecord(s->start));
    ff_facing_kernel<<<(unsigned)((need + FF_CUDA_BLOCK - 1) / FF_CUDA_BLOCK), FF_CUDA_BLOCK>>>(
        p, s->d_pairs, s->d_open, s->d_pair_counts, need);
    RAD_CUDA_TRY(cudaGetLastError()); /* launch configuration errors */
    RAD_CUDA_TRY(cudaMemcpy(pair_counts, s->d_pair_counts, sizeof pair_counts, cudaMemcpyDeviceToHost));
    if (quadrature && pair_counts[2] > s->ray_capacity) { /* grows only */
        cudaFree(s->d_ray_pairs);
        s->d_ray_pairs = NULL;
        s->ray_capacity = 0;
        RAD_CUDA_TRY(cudaMalloc(&s->d_ray_pairs, sizeof(cuda_ray_pair) * pair_counts[2]));
        s->ray_capacity = pair_counts[2];
    }
    p.ray_pairs = s->d_ray_pairs;
    p.ray_count = s->d_pair_counts + 3;
    for (int list = 0; list < 2; list++) { /* far pairs, then near ones */
        if (pair_counts[list] == 0) continue;
        p.pair_count = pair_counts[list];
        p.pairs = list == 0 ? s->d_pairs : s->d_pairs + need - 1;
        p.open = list == 0 ? s->d_open : s->d_open + need - 1;
        p.step = list == 0 ? 1 : -1;
        p.lanes = list == 0 ? FF_CUDA_FAR_LANES : FF_CUDA_NEAR_LANES;
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
        fprintf(stderr, "ff_cuda_profile: %s list: %u pairs, %u lanes, %.3f ms\n", list ? "near" : "far",
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
        fprintf(stderr, "ff_cuda_profile: far %u + near %u pairs: %.3f ms\n", pair_counts[0], pair_counts[1], ms);
    }
#endif
    if (quadrature && pair_counts[2] > 0) { /* pass 3: the rays of the pairs pass 2 appended */
        p.lanes = FF_CUDA_RAY_LANES;
        uint64_t per_block = FF_CUDA_BLOCK / p.lanes;
        uint64_t blocks = ((uint64_t)pair_counts[2] + per_block - 1) / per_block;
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
    counters->pairs += computed;
    counters->pairs_not_facing += computed - pair_counts[0] - pair_counts[1];
    counters->samples += counts[C_SAMPLES];
    counters->pairs_refined += counts[C_REFINED];
    counters->pairs_capped += counts[C_CAPPED];
    counters->rays += counts[C_RAYS];
    counters->rays_occluded += counts[C_OCCLUDED];
    counters->pairs_near += counts[C_NEAR];
    counters->pairs_open_scene += counts[C_OPEN_SCENE];
    counters->pairs_open_box += counts[C_OPEN_BOX];
    counters->rays_saved += counts[C_SAVED];
    /* Kernel time split: the quadrature estimator's ray launch (pass 3)
     * is visibility; the Monte Carlo estimators trace inside pass 2, whose
     * time is split by where the warps spent their cycles. */
    if (quadrature)
        ray_share = kernel_ms > 0 ? rays_ms / kernel_ms : 0.0;
    else
        ray_share = counts[C_CYCLES] ? (double)counts[C_RAY_CYCLES] / (double)counts[C_CYCLES] : 0.0;
    counters->kernel_seconds += kernel_ms * 1e-3 * (1.0 - ray_share);
    counters->visibility_seconds += kernel_ms * 1e-3 * ray_share;
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
                                               cuda_alloc_rows, cuda_free_rows, cuda_compute_records};
