/* ff_backend_cuda.cu - the CUDA backend. No MPI here, only CUDA.
 *
 * One warp per patch pair (i, j): the lanes share the K point pairs of the
 * shared kernel (rad_ff_kernel.h, the very code the CPU runs) and reduce
 * them with shuffles; the first R point pairs then carry shadow rays, one
 * per lane, through the flat BVH of ff_bvh.h (any hit, first hit returns).
 * Culled pairs cost one thread one test and one store, no warp.
 *
 * This file is compiled with --fmad=false so each double operation rounds
 * as on the CPU: the per-sample kernel values are bit-identical to the CPU
 * backend's, and only the order of the final sums (and borderline ray
 * hits, Moller-Trumbore here vs Embree there) differs.
 */
#include <cuda_runtime.h>
#include <stdio.h>
#include <string.h>
#include <time.h>

extern "C" {
#include "ff_backend.h"
#include "ff_bvh.h"
#include "ff_cuda.h"
#include "rad_log.h"
}

enum { FF_CUDA_BLOCK = 256, FF_CUDA_WARPS_PER_BLOCK = FF_CUDA_BLOCK / 32 };
/* Blocks per SM the pair kernels are compiled for: bounds their registers
 * (65536 / (256 * blocks) per thread), trading spills for occupancy. */
#ifndef FF_CUDA_MIN_BLOCKS
#define FF_CUDA_MIN_BLOCKS 3 /* measured on H200: 2 -> 10.8 ms, 3 -> 10.3 ms, 4 -> 10.3 ms (N = 2944) */
#endif
enum { C_SAMPLES, C_RAYS, C_OCCLUDED, C_NEAR, C_OPEN_SCENE, C_OPEN_BOX, C_SAVED, C_CYCLES, C_RAY_CYCLES, C_REFINED,
       C_CAPPED, C_COUNT };

struct cuda_params {
    const rad_ff_patch *patches;
    uint32_t n;
    const ff_bvh_node *nodes;
    const ff_bvh_tri *tris;
    int32_t root;
    uint32_t root_count;
    uint32_t samples, rays;
    uint64_t seed;
    uint32_t estimator;
    double target_error;
    uint32_t max_samples;
    int cull, scene_convex, pairs_once;
    float cull_margin;
    double eps;
    uint32_t row_begin, row_count;
    double *out;                   /* row_count * n */
    double *errors;                /* row_count * n standard errors, or NULL */
    unsigned long long *counters;  /* C_COUNT */
    const uint32_t *pairs;         /* facing pairs: r * n + j, pair_count of them */
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
    uint32_t *d_pair_counts; /* [0] far pairs, [1] near pairs */
    size_t out_capacity; /* doubles */
    unsigned long long *d_counters;
    cudaEvent_t start, stop;
};

static double now_seconds(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

/* Logs a failed CUDA call with its place and returns RAD_ERR_BACKEND. */
static rad_status cuda_check(cudaError_t err, const char *what, int line)
{
    if (err == cudaSuccess) return RAD_OK;
    rad_error("cuda: %s (ff_backend_cuda.cu:%d): %s", what, line, cudaGetErrorString(err));
    return RAD_ERR_BACKEND;
}
#define CUDA_TRY(call)                                                         \
    do {                                                                       \
        if ((status = cuda_check((call), #call, __LINE__)) != RAD_OK) goto done; \
    } while (0)

__device__ static double warp_sum(double v)
{
    for (int offset = 16; offset > 0; offset >>= 1) v += __shfl_xor_sync(0xffffffffu, v, offset);
    return v;
}

__device__ static unsigned warp_sum_u(unsigned v)
{
    for (int offset = 16; offset > 0; offset >>= 1) v += __shfl_xor_sync(0xffffffffu, v, offset);
    return v;
}

/* Pass 1: thread per pair; zeros for pairs that cannot exchange light; far
 * pairs listed from the front of p.pairs, near pairs (auto estimator) from
 * the back, so each list gets a kernel of its own: the near-field code
 * (clipping, atan2) would otherwise cost every far pair registers and
 * occupancy. Order within a list is irrelevant: a pair's value depends
 * only on (i, j). */
__global__ static void ff_facing_kernel(cuda_params p, uint32_t *pairs, uint32_t *counts, uint64_t capacity)
{
    uint64_t t = (uint64_t)blockIdx.x * blockDim.x + threadIdx.x;
    if (t >= (uint64_t)p.row_count * p.n) return;
    uint32_t j = (uint32_t)(t % p.n), i = p.row_begin + (uint32_t)(t / p.n);
    const rad_ff_patch *pi = &p.patches[i], *pj = &p.patches[j];
    if (p.errors) p.errors[t] = 0.0; /* listed pairs overwrite it */
    if (p.pairs_once && !rad_ff_row_computes(i, j))
        p.out[t] = 0.0; /* row j computes this pair: no warp here */
    else if (i == j || !rad_ff_pair_facing(pi, pj, p.eps))
        p.out[t] = 0.0;
    else if (rad_ff_pair_uses_contour(p.estimator, pi, pj))
        pairs[capacity - 1 - atomicAdd(&counts[1], 1u)] = (uint32_t)t;
    else
        pairs[atomicAdd(&counts[0], 1u)] = (uint32_t)t;
}

/* Samples [k0, k1) of pair (i, j), spread over the lanes and summed into
 * *sums (every lane gets the same bits: the xor butterfly adds the same
 * two numbers on both sides at each step). Lane l keeps sample l (when
 * k0 == 0) for its first shadow ray. */
template <bool NEAR, bool ERRORS>
__device__ static void warp_samples(const cuda_params &p, const rad_ff_patch *pi, const rad_ff_patch *pj, uint32_t i,
                                    uint32_t j, uint32_t k0, uint32_t k1, unsigned lane, rad_ff_sums *sums,
                                    rad_vec3 *first_x, rad_vec3 *first_y, double *first_g)
{
    double sum = 0.0, sum_sq = 0.0;
    for (uint32_t k = k0 + lane; k < k1; k += 32) {
        rad_vec3 x, y;
        double g;
        if (NEAR) {
            g = rad_ff_near_sample(pi, pj, i, j, k, p.seed, &x, &y);
        } else {
            rad_ff_pair_points(p.estimator, pi, pj, i, j, k, p.seed, &x, &y);
            g = rad_ff_point_kernel(x, pi->normal, y, pj->normal);
        }
        sum += g;
        if (ERRORS) sum_sq += g * g;
        if (k == lane) {
            *first_x = x;
            *first_y = y;
            *first_g = g;
        }
    }
    sums->terms += warp_sum(sum);
    if (ERRORS) sums->terms_sq += warp_sum(sum_sq);
    sums->samples += k1 - k0;
}

/* Shadow rays of samples [r0, r1), one per lane, through the flat BVH,
 * traced from the lower-numbered patch as the CPU does. */
template <bool NEAR, bool ERRORS>
__device__ static void warp_rays(const cuda_params &p, const rad_ff_patch *pi, const rad_ff_patch *pj, uint32_t i,
                                 uint32_t j, uint32_t r0, uint32_t r1, unsigned lane, rad_ff_sums *sums,
                                 rad_vec3 first_x, rad_vec3 first_y, double first_g)
{
    double seen = 0.0, total = 0.0, seen_sq = 0.0, total_sq = 0.0;
    unsigned visible = 0;
    for (uint32_t k = r0 + lane; k < r1; k += 32) {
        rad_vec3 x = first_x, y = first_y;
        double g = first_g;
        if (k != lane) { /* beyond each lane's first sample: recomputed */
            if (NEAR)
                rad_ff_sample_pair(pi, pj, i, j, k, p.seed, &x, &y);
            else
                rad_ff_pair_points(p.estimator, pi, pj, i, j, k, p.seed, &x, &y);
            g = rad_ff_point_kernel(x, pi->normal, y, pj->normal);
        } else if (NEAR) {
            g = rad_ff_point_kernel(x, pi->normal, y, pj->normal); /* the cached g is the near-field term */
        }
        /* The segment's weight is G(x, y) for near pairs too (see ray_segment in ff_backend_cpu.c). */
        if (i > j) {
            rad_vec3 tmp = x;
            x = y;
            y = tmp;
        }
        float o[3] = {(float)x.x, (float)x.y, (float)x.z};
        float d[3] = {(float)y.x - o[0], (float)y.y - o[1], (float)y.z - o[2]};
        int blocked = ff_bvh_occluded(p.nodes, p.tris, p.root, p.root_count, o, d, pi->face, pj->face);
        total += g;
        if (ERRORS) total_sq += g * g;
        if (!blocked) {
            seen += g;
            if (ERRORS) seen_sq += g * g;
            visible++;
        }
    }
    sums->ray_terms += warp_sum(total);
    sums->ray_seen += warp_sum(seen);
    if (ERRORS) {
        sums->ray_terms_sq += warp_sum(total_sq);
        sums->ray_seen_sq += warp_sum(seen_sq);
    }
    sums->visible += warp_sum_u(visible);
    sums->rays += r1 - r0;
}

/* Pass 2: one warp per listed pair; NEAR selects the estimator (the same
 * choice and sample budget as the CPU backend); ERRORS adds the sums of
 * squares behind the standard errors (wanted, or needed by --target-error). */
template <bool NEAR, bool ERRORS>
__global__ static void __launch_bounds__(FF_CUDA_BLOCK, FF_CUDA_MIN_BLOCKS) ff_pairs_kernel(cuda_params p)
{
    __shared__ unsigned long long block_counts[C_COUNT];
    if (threadIdx.x < C_COUNT) block_counts[threadIdx.x] = 0;
    __syncthreads();
    uint64_t warp = ((uint64_t)blockIdx.x * blockDim.x + threadIdx.x) >> 5;
    unsigned lane = threadIdx.x & 31u;
    if (warp < p.pair_count) {
        long long start = clock64(); /* the split of kernel time into sampling and occlusion */
        long long ray_cycles = 0;
        uint32_t t = p.pairs[NEAR ? -(int64_t)warp : (int64_t)warp]; /* near list runs backwards */
        uint32_t j = t % p.n, i = p.row_begin + t / p.n;
        const rad_ff_patch *pi = &p.patches[i], *pj = &p.patches[j];
        uint32_t samples = NEAR ? rad_ff_near_samples(p.samples) : p.samples;
        uint32_t rays = p.rays < samples ? p.rays : samples;
        rad_ff_sums sums = {};
        /* Each lane keeps its first sample (k = lane): when R <= 32 that is
         * the one its shadow ray needs, so the ray loop need not redo it. */
        rad_vec3 first_x = {0, 0, 0}, first_y = {0, 0, 0};
        double first_g = 0.0;
        warp_samples<NEAR, ERRORS>(p, pi, pj, i, j, 0, samples, lane, &sums, &first_x, &first_y, &first_g);
        int traced = rays > 0 && sums.terms > 0.0;
        /* Culling on the GPU: only the convex-enclosure rule. The per-pair
         * shaft test of the CPU backend costs a warp about what its 32
         * rays cost (measured: 5-7 % slower overall), so the GPU traces
         * those rays; the matrix is the same either way. */
        if (traced && p.cull && p.scene_convex) {
            if (lane == 0) {
                atomicAdd(&block_counts[C_OPEN_SCENE], 1ull);
                atomicAdd(&block_counts[C_SAVED], (unsigned long long)rays);
            }
            traced = 0; /* F stays as it is: the visible fraction is exactly 1 */
        }
        if (traced) {
            long long t0 = clock64();
            warp_rays<NEAR, ERRORS>(p, pi, pj, i, j, 0, rays, lane, &sums, first_x, first_y, first_g);
            ray_cycles += clock64() - t0;
        }
        double error = 0.0;
        double value = rad_ff_estimate(&sums, NEAR, pi, pj, ERRORS ? &error : NULL);
        if (ERRORS && p.target_error > 0.0) { /* --target-error: more batches, as the CPU backend's refine_block */
            uint32_t to = 0, rays_to = 0, planned = rays;
            int refined = 0;
            while (!rad_ff_error_reached(error, pi, pj, p.target_error) &&
                   rad_ff_next_batch(&sums, samples, rays, p.samples, p.max_samples, &to, &rays_to)) {
                warp_samples<NEAR, ERRORS>(p, pi, pj, i, j, sums.samples, to, lane, &sums, &first_x, &first_y,
                                           &first_g);
                if (traced) {
                    long long t0 = clock64();
                    warp_rays<NEAR, ERRORS>(p, pi, pj, i, j, sums.rays, rays_to, lane, &sums, first_x, first_y,
                                            first_g);
                    ray_cycles += clock64() - t0;
                } else if (sums.terms > 0.0 && rays > 0 && p.cull && p.scene_convex) {
                    if (lane == 0) atomicAdd(&block_counts[C_SAVED], (unsigned long long)(rays_to - planned));
                    planned = rays_to;
                }
                value = rad_ff_estimate(&sums, NEAR, pi, pj, &error);
                refined = 1;
            }
            if (lane == 0) {
                if (refined) atomicAdd(&block_counts[C_REFINED], 1ull);
                if (!rad_ff_error_reached(error, pi, pj, p.target_error)) atomicAdd(&block_counts[C_CAPPED], 1ull);
            }
        }
        if (lane == 0) {
            long long end = clock64();
            atomicAdd(&block_counts[C_CYCLES], (unsigned long long)(end - start));
            atomicAdd(&block_counts[C_RAY_CYCLES], (unsigned long long)ray_cycles);
            atomicAdd(&block_counts[C_SAMPLES], (unsigned long long)sums.samples);
            if (traced) {
                atomicAdd(&block_counts[C_RAYS], (unsigned long long)sums.rays);
                atomicAdd(&block_counts[C_OCCLUDED], (unsigned long long)(sums.rays - sums.visible));
            }
            if (NEAR) atomicAdd(&block_counts[C_NEAR], 1ull);
            p.out[t] = value;
            if (p.errors) p.errors[t] = error;
        }
    }
    __syncthreads();
    if (threadIdx.x < C_COUNT) atomicAdd(&p.counters[threadIdx.x], block_counts[threadIdx.x]);
}

extern "C" int ff_cuda_device_count(void)
{
    int count = 0;
    if (cudaGetDeviceCount(&count) != cudaSuccess) {
        cudaGetLastError(); /* clear the "no device" error */
        return 0;
    }
    return count;
}

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
    cudaFree(s->d_pair_counts);
    cudaFree(s->d_counters);
    if (s->start) cudaEventDestroy(s->start);
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
    CUDA_TRY(cudaSetDevice(setup->device % count));
    if ((status = ff_bvh_build(setup->triangles, setup->triangle_face, setup->triangle_count, &bvh)) != RAD_OK)
        goto done;
    s->root = bvh.root;
    s->root_count = bvh.root_count;
    CUDA_TRY(cudaMalloc(&s->d_patches, sizeof(rad_ff_patch) * setup->patch_count));
    CUDA_TRY(cudaMalloc(&s->d_nodes, sizeof(ff_bvh_node) * (bvh.node_count ? bvh.node_count : 1)));
    CUDA_TRY(cudaMalloc(&s->d_tris, sizeof(ff_bvh_tri) * (bvh.tri_count ? bvh.tri_count : 1)));
    CUDA_TRY(cudaMalloc(&s->d_counters, sizeof(unsigned long long) * C_COUNT));
    CUDA_TRY(cudaMalloc(&s->d_pair_counts, 2 * sizeof(uint32_t)));
    CUDA_TRY(cudaMemcpy(s->d_patches, setup->patches, sizeof(rad_ff_patch) * setup->patch_count,
                        cudaMemcpyHostToDevice));
    if (bvh.node_count)
        CUDA_TRY(cudaMemcpy(s->d_nodes, bvh.nodes, sizeof(ff_bvh_node) * bvh.node_count, cudaMemcpyHostToDevice));
    if (bvh.tri_count)
        CUDA_TRY(cudaMemcpy(s->d_tris, bvh.tris, sizeof(ff_bvh_tri) * bvh.tri_count, cudaMemcpyHostToDevice));
    CUDA_TRY(cudaEventCreate(&s->start));
    CUDA_TRY(cudaEventCreate(&s->stop));
done:
    ff_bvh_free(&bvh);
    if (status != RAD_OK) {
        cuda_destroy(s);
        return status;
    }
    *out_state = s;
    return RAD_OK;
}

static rad_status cuda_compute_rows(void *state, uint32_t row_begin, uint32_t row_count, double *out,
                                    double *errors, ff_counters *counters)
{
    cuda_state *s = (cuda_state *)state;
    const ff_setup *su = &s->setup;
    rad_status status = RAD_OK;
    size_t need = (size_t)row_count * su->patch_count;
    unsigned long long counts[C_COUNT] = {0};
    double ray_share = 0.0;
    float kernel_ms = 0;
    uint32_t pair_counts[2] = {0, 0};
    uint64_t computed = 0; /* pairs this call computes */
    bool errors_wanted = errors != NULL || su->target_error > 0;
    cuda_params p;
    double t_mem = now_seconds();
    if (need == 0) return RAD_OK;
    if (need > UINT32_MAX) {
        rad_error("cuda: %u rows of %u patches exceed one launch's pair index range", row_count, su->patch_count);
        return RAD_ERR_INVALID;
    }
    if (need > s->out_capacity) {
        cudaFree(s->d_out);
        cudaFree(s->d_pairs);
        s->d_out = NULL;
        s->d_pairs = NULL;
        s->out_capacity = 0;
        CUDA_TRY(cudaMalloc(&s->d_out, sizeof(double) * need));
        CUDA_TRY(cudaMalloc(&s->d_pairs, sizeof(uint32_t) * need));
        s->out_capacity = need;
    }
    if (errors && need > s->errors_capacity) {
        cudaFree(s->d_errors);
        s->d_errors = NULL;
        s->errors_capacity = 0;
        CUDA_TRY(cudaMalloc(&s->d_errors, sizeof(double) * need));
        s->errors_capacity = need;
    }
    CUDA_TRY(cudaMemset(s->d_counters, 0, sizeof(unsigned long long) * C_COUNT));
    CUDA_TRY(cudaMemset(s->d_pair_counts, 0, 2 * sizeof(uint32_t)));
    p.patches = s->d_patches;
    p.n = su->patch_count;
    p.nodes = s->d_nodes;
    p.tris = s->d_tris;
    p.root = s->root;
    p.root_count = s->root_count;
    p.samples = su->samples;
    p.rays = su->shadow_rays;
    p.seed = su->seed;
    p.estimator = su->estimator;
    p.target_error = su->target_error;
    p.max_samples = su->max_samples;
    p.cull = su->cull;
    p.scene_convex = su->scene_convex;
    p.pairs_once = su->pairs_once;
    p.cull_margin = su->cull_margin;
    p.eps = su->plane_eps;
    p.row_begin = row_begin;
    p.row_count = row_count;
    p.out = s->d_out;
    p.errors = errors ? s->d_errors : NULL;
    p.counters = s->d_counters;
    p.pairs = s->d_pairs;
    p.pair_count = 0;
    counters->memory_seconds += now_seconds() - t_mem;

    CUDA_TRY(cudaEventRecord(s->start));
    ff_facing_kernel<<<(unsigned)((need + FF_CUDA_BLOCK - 1) / FF_CUDA_BLOCK), FF_CUDA_BLOCK>>>(
        p, s->d_pairs, s->d_pair_counts, need);
    CUDA_TRY(cudaGetLastError()); /* launch configuration errors */
    CUDA_TRY(cudaMemcpy(pair_counts, s->d_pair_counts, sizeof pair_counts, cudaMemcpyDeviceToHost));
    if (pair_counts[0] > 0) {
        p.pair_count = pair_counts[0];
        uint64_t blocks = ((uint64_t)p.pair_count + FF_CUDA_WARPS_PER_BLOCK - 1) / FF_CUDA_WARPS_PER_BLOCK;
        if (errors_wanted)
            ff_pairs_kernel<false, true><<<(unsigned)blocks, FF_CUDA_BLOCK>>>(p);
        else
            ff_pairs_kernel<false, false><<<(unsigned)blocks, FF_CUDA_BLOCK>>>(p);
        CUDA_TRY(cudaGetLastError());
    }
    if (pair_counts[1] > 0) {
        p.pair_count = pair_counts[1];
        p.pairs = s->d_pairs + need - 1; /* the near list, read backwards */
        uint64_t blocks = ((uint64_t)p.pair_count + FF_CUDA_WARPS_PER_BLOCK - 1) / FF_CUDA_WARPS_PER_BLOCK;
        if (errors_wanted)
            ff_pairs_kernel<true, true><<<(unsigned)blocks, FF_CUDA_BLOCK>>>(p);
        else
            ff_pairs_kernel<true, false><<<(unsigned)blocks, FF_CUDA_BLOCK>>>(p);
        CUDA_TRY(cudaGetLastError());
    }
    CUDA_TRY(cudaEventRecord(s->stop));
    CUDA_TRY(cudaEventSynchronize(s->stop)); /* execution errors surface here */
    CUDA_TRY(cudaEventElapsedTime(&kernel_ms, s->start, s->stop));

    t_mem = now_seconds();
    CUDA_TRY(cudaMemcpy(out, s->d_out, sizeof(double) * need, cudaMemcpyDeviceToHost));
    if (errors) CUDA_TRY(cudaMemcpy(errors, s->d_errors, sizeof(double) * need, cudaMemcpyDeviceToHost));
    CUDA_TRY(cudaMemcpy(counts, s->d_counters, sizeof counts, cudaMemcpyDeviceToHost));
    counters->memory_seconds += now_seconds() - t_mem;
    computed = need;
    if (su->pairs_once) {
        computed = 0;
        for (uint32_t r = 0; r < row_count; r++) computed += rad_ff_row_computes_count(row_begin + r, su->patch_count);
    }
    counters->pairs += computed;
    counters->pairs_culled += computed - pair_counts[0] - pair_counts[1];
    counters->samples += counts[C_SAMPLES];
    counters->pairs_refined += counts[C_REFINED];
    counters->pairs_capped += counts[C_CAPPED];
    counters->rays += counts[C_RAYS];
    counters->rays_occluded += counts[C_OCCLUDED];
    counters->pairs_near += counts[C_NEAR];
    counters->pairs_open_scene += counts[C_OPEN_SCENE];
    counters->pairs_open_box += counts[C_OPEN_BOX];
    counters->rays_saved += counts[C_SAVED];
    /* Kernel time split by where the warps spent their cycles. */
    ray_share = counts[C_CYCLES] ? (double)counts[C_RAY_CYCLES] / (double)counts[C_CYCLES] : 0.0;
    counters->kernel_seconds += kernel_ms * 1e-3 * (1.0 - ray_share);
    counters->visibility_seconds += kernel_ms * 1e-3 * ray_share;
    if (su->progress) su->progress(su->progress_user, row_count);
done:
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

extern "C" const ff_backend ff_backend_cuda = {"cuda", cuda_create, cuda_compute_rows, cuda_destroy,
                                               cuda_alloc_rows, cuda_free_rows};
