/* shaped_cuda.cu - the shaped solve's steps on a CUDA device
 * (shaped_gpu.h, solve_shaped_jacobi_cuda). No OpenMP or MPI here, only
 * CUDA; the plan and the stopping rule stay on the host (shaped.c).
 *
 * One kernel per loop of the host twin (shaped_host.c), one thread per
 * item, each calling the shaped_math.h function the twin calls; the point
 * factors take a block per end, its threads striding over the end's
 * leaves. Every sum is one thread's, in the twin's order; the change's
 * maxima are reduced per block in shared memory, then by one block over
 * the blocks' (a maximum is exact in any order). Compiled with
 * --fmad=false (solve/CMakeLists.txt), so products and sums round as on
 * the host: the same inputs give the twin's bits, but where a point
 * factor's float rounds the other way because the device's atan2 differs
 * from the host's in the last bit.
 *
 * The arrays live on the device for the whole solve; per sweep only the
 * three maxima come back. Kernels run in order on the default stream, so
 * each step sees the last one's writes; a launch is checked where it is
 * made (cudaGetLastError), a fault inside a kernel at the next copy.
 */
#include <cuda_runtime.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

extern "C" {
#include "rad_cuda.h"
#include "rad_log.h"
#include "shaped_gpu.h"
}
#include "rad_cuda_check.h"
#include "rad_cuda_stage.h"

/* Threads per block of the item kernels (a power of two: the block
 * reduction halves it). */
#define SHAPED_BLOCK 256
/* Threads per end of the point factors' kernel. */
#define SHAPED_FACTOR_BLOCK 128
/* Blocks of the point factors' kernel at most; more ends are strided. */
#define SHAPED_FACTOR_GRID (1u << 20)
/* Device arrays one solve allocates (create). */
#define SHAPED_MAX_ARRAYS 48

struct cuda_state {
    solve_shaped_device_plan plan; /* plan.view, depth_order: device pointers */
    uint32_t *depth_first;         /* host (plan.depth_first): plan.depth_count + 1, the launches' ranges */
    int device;
    char name[256];
    void *owned[SHAPED_MAX_ARRAYS]; /* every device array, freed by destroy */
    int owned_count;
    uint32_t *end, *pair_end;      /* link_count (writable: drop); NULL in a flat solve */
    float *f;                      /* weight_count */
    double *inv_mean;              /* end_count */
    double *B, *H;                 /* id_count * 3 */
    double *Q, *next;              /* leaf_count * 3 */
    double *T, *S;                 /* end_count * 3 */
    double *row_sum;               /* leaf_count */
    double *partial;               /* leaf blocks * 3: each block's maxima */
    double *change;                /* 3 */
    int dropped;                   /* drop ran */
    rad_cuda_stage stage;          /* the plan's arrays up, B and H back (the legacy stream) */
};

/* Blocks of `per` threads for `items` items. */
static unsigned blocks_for(uint64_t items, unsigned per) { return (unsigned)((items + per - 1) / per); }

/* ---- kernels ---- */

/* The point factors of every end: a block per end, its threads over the
 * receiver's leaves. */
__global__ void __launch_bounds__(SHAPED_FACTOR_BLOCK) shaped_factors_kernel(shaped_view v, float *f)
{
    for (uint64_t e = blockIdx.x; e < v.end_count; e += gridDim.x) {
        const uint32_t r = v.end_receiver[e];
        rad_ff_patch P;
        shaped_node_polygon(&v, v.links[v.end_link[e]].source, &P);
        for (uint32_t q = threadIdx.x; q < v.count[r]; q += blockDim.x)
            f[v.end_at[e] + q] = shaped_point_factor(&v, v.first[r] + q, &P);
    }
}

/* 1 / the mean of every end's factors: a thread per end. */
__global__ void __launch_bounds__(SHAPED_BLOCK) shaped_inv_mean_kernel(shaped_view v, double *inv_mean)
{
    const uint64_t e = blockIdx.x * (uint64_t)blockDim.x + threadIdx.x;
    if (e < v.end_count) inv_mean[e] = shaped_end_inv_mean(&v, e, v.end_receiver[e]);
}

/* The ends whose factors sum to 0 dropped: a thread per dropped end. */
__global__ void __launch_bounds__(SHAPED_BLOCK)
    shaped_drop_kernel(shaped_view v, const uint64_t *dropped, uint64_t count, uint32_t *end, uint32_t *pair_end)
{
    const uint64_t d = blockIdx.x * (uint64_t)blockDim.x + threadIdx.x;
    if (d < count) shaped_drop_end(&v, dropped[d], end, pair_end);
}

/* Every leaf's row sum, leaf-list order: a thread per leaf. */
__global__ void __launch_bounds__(SHAPED_BLOCK) shaped_row_sum_kernel(shaped_view v, double *row_sum)
{
    const uint64_t q = blockIdx.x * (uint64_t)blockDim.x + threadIdx.x;
    if (q < v.leaf_count) row_sum[q] = shaped_leaf_row_sum(&v, v.leaf_nodes[q]);
}

/* (a) T of every end: a thread per end. */
__global__ void __launch_bounds__(SHAPED_BLOCK) shaped_end_sum_kernel(shaped_view v, const double *Q, double *T)
{
    const uint64_t e = blockIdx.x * (uint64_t)blockDim.x + threadIdx.x;
    if (e < v.end_count) shaped_end_sum(&v, e, v.end_receiver[e], Q, &T[3 * e]);
}

/* (b) every receiver id's gather: a warp per id (shaped_gather_part per
 * lane, then the shuffles' tree that shaped_gather_lanes follows). */
__global__ void __launch_bounds__(SHAPED_BLOCK)
    shaped_gather_kernel(shaped_view v, const double *B, const double *Q, const double *T, double *H, double *S)
{
    const uint64_t i = (blockIdx.x * (uint64_t)blockDim.x + threadIdx.x) / SHAPED_GATHER_LANES;
    const uint32_t lane = threadIdx.x % SHAPED_GATHER_LANES;
    if (i >= v.id_count) return; /* the whole warp: i is the warp's */
    double h[3];
    shaped_gather_part(&v, (uint32_t)i, lane, SHAPED_GATHER_LANES, B, Q, T, S, h);
    for (unsigned w = SHAPED_GATHER_LANES / 2; w > 0; w >>= 1)
        for (int c = 0; c < 3; c++) h[c] = h[c] + __shfl_down_sync(0xffffffffu, h[c], w);
    if (lane == 0)
        for (int c = 0; c < 3; c++) H[3 * i + c] = h[c];
}

/* (c) H pushed into the ids of one depth: a thread per id. */
__global__ void __launch_bounds__(SHAPED_BLOCK)
    shaped_push_kernel(shaped_view v, const uint32_t *ids, uint32_t count, double *H)
{
    const uint32_t t = blockIdx.x * blockDim.x + threadIdx.x;
    if (t < count) shaped_push(&v, ids[t], H);
}

/* The largest of each of 3 values over the block (a fixed tree in shared
 * memory; blockDim.x == SHAPED_BLOCK); thread 0 gets them in out. */
__device__ static void block_max3(const double w[3], double out[3])
{
    __shared__ double s[3][SHAPED_BLOCK];
    const unsigned t = threadIdx.x;
    for (int c = 0; c < 3; c++) s[c][t] = w[c];
    __syncthreads();
    for (unsigned half = SHAPED_BLOCK / 2; half > 0; half >>= 1) {
        if (t < half)
            for (int c = 0; c < 3; c++) s[c][t] = fmax(s[c][t], s[c][t + half]);
        __syncthreads();
    }
    if (t == 0)
        for (int c = 0; c < 3; c++) out[c] = s[c][0];
}

/* (d) every leaf: next and |next - Q|; each block's maxima in partial. */
__global__ void __launch_bounds__(SHAPED_BLOCK)
    shaped_update_kernel(shaped_view v, double *H, const double *S, const double *Q, double *next, double *partial)
{
    const uint64_t q = blockIdx.x * (uint64_t)blockDim.x + threadIdx.x;
    double d[3] = {0, 0, 0}, worst[3] = {0, 0, 0};
    if (q < v.leaf_count) shaped_update_leaf(&v, (uint32_t)q, H, S, Q, &next[3 * q], d);
    block_max3(d, worst); /* every thread of the block takes part */
    if (threadIdx.x == 0)
        for (int c = 0; c < 3; c++) partial[3 * (uint64_t)blockIdx.x + c] = worst[c];
}

/* The blocks' maxima into change[3]: one block. */
__global__ void __launch_bounds__(SHAPED_BLOCK)
    shaped_change_kernel(const double *partial, unsigned blocks, double *change)
{
    double w[3] = {0, 0, 0}, worst[3] = {0, 0, 0};
    for (unsigned b = threadIdx.x; b < blocks; b += blockDim.x)
        for (int c = 0; c < 3; c++) w[c] = fmax(w[c], partial[3 * (uint64_t)b + c]);
    block_max3(w, worst);
    if (threadIdx.x == 0)
        for (int c = 0; c < 3; c++) change[c] = worst[c];
}

/* accept: the leaves' B from Q: a thread per leaf. */
__global__ void __launch_bounds__(SHAPED_BLOCK) shaped_scatter_kernel(shaped_view v, const double *Q, double *B)
{
    const uint64_t q = blockIdx.x * (uint64_t)blockDim.x + threadIdx.x;
    if (q >= v.leaf_count) return;
    const uint32_t x = v.leaf_nodes[q];
    for (int c = 0; c < 3; c++) B[3 * (uint64_t)x + c] = Q[3 * q + c];
}

/* accept: B pulled into the ids of one depth: a thread per id. */
__global__ void __launch_bounds__(SHAPED_BLOCK)
    shaped_pull_kernel(shaped_view v, const uint32_t *ids, uint32_t count, double *B)
{
    const uint32_t t = blockIdx.x * blockDim.x + threadIdx.x;
    if (t < count) shaped_pull(&v, ids[t], B);
}

/* ---- host ---- */

/* A device array of `bytes` (at least 1), owned by the state; with `src`,
 * copied from the host. */
static rad_status device_alloc(cuda_state *s, void **out, const void *src, size_t bytes)
{
    rad_status status = RAD_OK;
    void *p = NULL;
    if (s->owned_count == SHAPED_MAX_ARRAYS) {
        rad_error("internal: the shaped solve's GPU state holds %d arrays at most", SHAPED_MAX_ARRAYS);
        return RAD_ERR_INVALID;
    }
    RAD_CUDA_TRY(cudaMalloc(&p, bytes ? bytes : 1));
    s->owned[s->owned_count++] = p;
    if (src && bytes && (status = rad_cuda_stage_up(&s->stage, p, src, bytes, 0)) != RAD_OK) return status;
    *out = p;
done:
    return status;
}

/* device_alloc for `count` values of T; *out set only on success. */
template <typename T> static rad_status device_array(cuda_state *s, T **out, const T *src, uint64_t count)
{
    void *p = NULL;
    rad_status status = device_alloc(s, &p, src, (size_t)count * sizeof(T));
    if (status == RAD_OK) *out = (T *)p;
    return status;
}

/* The same, for a view's read-only array. */
template <typename T> static rad_status device_copy(cuda_state *s, const T **out, const T *src, uint64_t count)
{
    T *p = NULL;
    rad_status status = device_array(s, &p, src, count);
    if (status == RAD_OK) *out = p;
    return status;
}

static void cuda_destroy(void *state)
{
    cuda_state *s = (cuda_state *)state;
    if (!s) return;
    cudaSetDevice(s->device); /* the arrays' device; nothing to report from a teardown */
    rad_cuda_stage_free(&s->stage);
    for (int k = 0; k < s->owned_count; k++) cudaFree(s->owned[k]);
    free(s->depth_first);
    free(s);
}

/* The plan's arrays onto the device; the vectors allocated. */
static rad_status upload_plan(cuda_state *s, const solve_shaped_device_plan *plan)
{
    rad_status status = RAD_OK;
    const shaped_view *h = &plan->view;
    shaped_view *v = &s->plan.view;
    const uint64_t n = h->node_count, leaves = h->leaf_count, ids = h->id_count, links = h->link_count;
    const uint64_t ends = h->end_count;
    const uint64_t children = h->pull_first[ids];
#define SHAPED_TRY(call)                         \
    do {                                         \
        if ((status = (call)) != RAD_OK) return status; \
    } while (0)
    SHAPED_TRY(device_copy(s, &v->nodes, h->nodes, n));
    SHAPED_TRY(device_copy(s, &v->positions, h->positions, 3 * (uint64_t)plan->vertex_count));
    SHAPED_TRY(device_copy(s, &v->leaf_centroid, h->leaf_centroid, leaves));
    SHAPED_TRY(device_copy(s, &v->leaf_normal, h->leaf_normal, leaves));
    SHAPED_TRY(device_copy(s, &v->links, h->links, links));
    SHAPED_TRY(device_copy(s, &v->first_link, h->first_link, ids + 1));
    SHAPED_TRY(device_copy(s, &v->up, h->up, ids));
    SHAPED_TRY(device_copy(s, &v->leaf_nodes, h->leaf_nodes, leaves));
    SHAPED_TRY(device_copy(s, &v->first, h->first, n));
    SHAPED_TRY(device_copy(s, &v->count, h->count, n));
    SHAPED_TRY(device_copy(s, &v->leaf_area, h->leaf_area, n));
    SHAPED_TRY(device_copy(s, &v->area_q, h->area_q, leaves));
    SHAPED_TRY(device_copy(s, &v->rho, h->rho, 3 * n));
    SHAPED_TRY(device_copy(s, &v->E, h->E, 3 * n));
    SHAPED_TRY(device_copy(s, &v->pull_first, h->pull_first, ids + 1));
    SHAPED_TRY(device_copy(s, &v->pull_child, h->pull_child, children));
    SHAPED_TRY(device_copy(s, &v->id_area, h->id_area, ids));
    if (h->end) { /* flat: neither (shaped_link_end) */
        SHAPED_TRY(device_array(s, &s->end, h->end, links));
        SHAPED_TRY(device_array(s, &s->pair_end, h->pair_end, links));
    }
    SHAPED_TRY(device_copy(s, &v->end_link, h->end_link, ends));
    SHAPED_TRY(device_copy(s, &v->end_receiver, h->end_receiver, ends));
    SHAPED_TRY(device_copy(s, &v->end_at, h->end_at, ends));
    SHAPED_TRY(device_copy(s, &v->shaped_first, h->shaped_first, ids + 1));
    SHAPED_TRY(device_copy(s, &s->plan.depth_order, plan->depth_order, ids));
    SHAPED_TRY(device_array(s, &s->f, (const float *)NULL, plan->weight_count));
    SHAPED_TRY(device_array(s, &s->inv_mean, (const double *)NULL, ends));
    SHAPED_TRY(device_array(s, &s->B, (const double *)NULL, 3 * ids));
    SHAPED_TRY(device_array(s, &s->H, (const double *)NULL, 3 * ids));
    SHAPED_TRY(device_array(s, &s->Q, (const double *)NULL, 3 * leaves));
    SHAPED_TRY(device_array(s, &s->next, (const double *)NULL, 3 * leaves));
    SHAPED_TRY(device_array(s, &s->T, (const double *)NULL, 3 * ends));
    SHAPED_TRY(device_array(s, &s->S, (const double *)NULL, 3 * ends));
    SHAPED_TRY(device_array(s, &s->row_sum, (const double *)NULL, leaves));
    SHAPED_TRY(device_array(s, &s->partial, (const double *)NULL, 3 * (uint64_t)blocks_for(leaves, SHAPED_BLOCK)));
    SHAPED_TRY(device_array(s, &s->change, (const double *)NULL, 3));
#undef SHAPED_TRY
    /* a dropped end's S is never gathered: zero, as the host's */
    status = RAD_CUDA_CHECK(cudaMemset(s->S, 0, 3 * ends * sizeof(double)));
    v->end = s->end;
    v->pair_end = s->pair_end;
    v->f = s->f;
    v->inv_mean = s->inv_mean;
    return status;
}

static rad_status cuda_create(const solve_shaped_device_plan *plan, int device, void **out_state)
{
    rad_status status = RAD_OK;
    const int devices = rad_cuda_device_count(); /* waits for solve_gpu_prestart's thread */
    cudaDeviceProp prop;
    cuda_state *s = (cuda_state *)calloc(1, sizeof *s);
    if (!s) {
        rad_error("out of memory");
        return RAD_ERR_NOMEM;
    }
    if (devices <= 0) {
        rad_error("--backend cuda: no CUDA device is visible (no GPU, no driver, or CUDA_VISIBLE_DEVICES hides them); "
                  "--backend cpu or auto solves on the CPU");
        status = RAD_ERR_BACKEND;
        goto done;
    }
    s->device = (device < 0 ? 0 : device) % devices;
    s->plan = *plan;
    s->depth_first = (uint32_t *)malloc(((size_t)plan->depth_count + 1) * sizeof(uint32_t));
    if (!s->depth_first) {
        rad_error("out of memory");
        status = RAD_ERR_NOMEM;
        goto done;
    }
    memcpy(s->depth_first, plan->depth_first, ((size_t)plan->depth_count + 1) * sizeof(uint32_t));
    s->plan.depth_first = s->depth_first;
    RAD_CUDA_TRY(cudaSetDevice(s->device));
    RAD_CUDA_TRY(cudaGetDeviceProperties(&prop, s->device));
    snprintf(s->name, sizeof s->name, "%s", prop.name);
    if ((status = upload_plan(s, plan)) != RAD_OK) {
        if (status == RAD_ERR_NOMEM)
            rad_error("--backend cuda: %s has too little free memory for the shaped solve (%llu point factors, "
                      "%llu links, %llu ends)",
                      s->name, (unsigned long long)plan->weight_count, (unsigned long long)plan->view.link_count,
                      (unsigned long long)plan->view.end_count);
        goto done;
    }
    *out_state = s;
    s = NULL;
done:
    cuda_destroy(s);
    return status;
}

static rad_status cuda_factors(void *state, double *inv_mean)
{
    cuda_state *s = (cuda_state *)state;
    rad_status status = RAD_OK;
    const shaped_view *v = &s->plan.view;
    const uint64_t ends = v->end_count;
    if (ends > 0) {
        const unsigned grid = ends < SHAPED_FACTOR_GRID ? (unsigned)ends : SHAPED_FACTOR_GRID;
        shaped_factors_kernel<<<grid, SHAPED_FACTOR_BLOCK>>>(*v, s->f);
        RAD_CUDA_TRY(cudaGetLastError());
        shaped_inv_mean_kernel<<<blocks_for(ends, SHAPED_BLOCK), SHAPED_BLOCK>>>(*v, s->inv_mean);
        RAD_CUDA_TRY(cudaGetLastError());
    }
    /* waits for the kernels; a fault in one of them is reported here */
    status = rad_cuda_stage_down(&s->stage, inv_mean, s->inv_mean, ends * sizeof(double), 0);
done:
    return status;
}

static rad_status cuda_drop(void *state, const uint64_t *dropped, uint64_t count, double *row_sum)
{
    cuda_state *s = (cuda_state *)state;
    rad_status status = RAD_OK;
    const shaped_view *v = &s->plan.view;
    uint64_t *d_dropped = NULL;
    if (s->dropped) {
        rad_error("internal: the shaped solve's ends are dropped once");
        return RAD_ERR_INVALID;
    }
    s->dropped = 1;
    if (count > 0) {
        RAD_CUDA_TRY(cudaMalloc(&d_dropped, count * sizeof(uint64_t)));
        RAD_CUDA_TRY(cudaMemcpy(d_dropped, dropped, count * sizeof(uint64_t), cudaMemcpyHostToDevice));
        shaped_drop_kernel<<<blocks_for(count, SHAPED_BLOCK), SHAPED_BLOCK>>>(*v, d_dropped, count, s->end,
                                                                              s->pair_end);
        RAD_CUDA_TRY(cudaGetLastError());
    }
    if (v->leaf_count > 0) {
        shaped_row_sum_kernel<<<blocks_for(v->leaf_count, SHAPED_BLOCK), SHAPED_BLOCK>>>(*v, s->row_sum);
        RAD_CUDA_TRY(cudaGetLastError());
    }
    RAD_CUDA_TRY(cudaMemcpy(row_sum, s->row_sum, v->leaf_count * sizeof(double), cudaMemcpyDeviceToHost));
done:
    if (d_dropped) cudaFree(d_dropped);
    return status;
}

static rad_status cuda_materials(void *state, const double *rho, const double *E)
{
    cuda_state *s = (cuda_state *)state;
    rad_status status = RAD_OK;
    const shaped_view *v = &s->plan.view;
    RAD_CUDA_TRY(cudaMemcpy((double *)v->rho, rho, 3 * (size_t)v->node_count * sizeof(double), cudaMemcpyHostToDevice));
    RAD_CUDA_TRY(cudaMemcpy((double *)v->E, E, 3 * (size_t)v->node_count * sizeof(double), cudaMemcpyHostToDevice));
done:
    return status;
}

static rad_status cuda_load(void *state, const double *B, const double *Q)
{
    cuda_state *s = (cuda_state *)state;
    rad_status status = RAD_OK;
    const shaped_view *v = &s->plan.view;
    RAD_CUDA_TRY(cudaMemcpy(s->B, B, 3 * v->id_count * sizeof(double), cudaMemcpyHostToDevice));
    RAD_CUDA_TRY(cudaMemcpy(s->Q, Q, 3 * (size_t)v->leaf_count * sizeof(double), cudaMemcpyHostToDevice));
done:
    return status;
}

static rad_status cuda_sweep(void *state, double change[3])
{
    cuda_state *s = (cuda_state *)state;
    rad_status status = RAD_OK;
    const solve_shaped_device_plan *p = &s->plan;
    const shaped_view *v = &p->view;
    const unsigned leaf_blocks = blocks_for(v->leaf_count, SHAPED_BLOCK);
    if (v->end_count > 0) {
        shaped_end_sum_kernel<<<blocks_for(v->end_count, SHAPED_BLOCK), SHAPED_BLOCK>>>(*v, s->Q, s->T);
        RAD_CUDA_TRY(cudaGetLastError());
    }
    shaped_gather_kernel<<<blocks_for(v->id_count * SHAPED_GATHER_LANES, SHAPED_BLOCK), SHAPED_BLOCK>>>(
        *v, s->B, s->Q, s->T, s->H, s->S);
    RAD_CUDA_TRY(cudaGetLastError());
    for (uint32_t d = 1; d < p->depth_count; d++) { /* depth 0 has nothing above it */
        const uint32_t first = s->depth_first[d], count = s->depth_first[d + 1] - first;
        if (count == 0) continue;
        shaped_push_kernel<<<blocks_for(count, SHAPED_BLOCK), SHAPED_BLOCK>>>(*v, p->depth_order + first, count, s->H);
        RAD_CUDA_TRY(cudaGetLastError());
    }
    if (leaf_blocks > 0) {
        shaped_update_kernel<<<leaf_blocks, SHAPED_BLOCK>>>(*v, s->H, s->S, s->Q, s->next, s->partial);
        RAD_CUDA_TRY(cudaGetLastError());
    }
    shaped_change_kernel<<<1, SHAPED_BLOCK>>>(s->partial, leaf_blocks, s->change);
    RAD_CUDA_TRY(cudaGetLastError());
    /* waits for the kernels; a fault in one of them is reported here */
    RAD_CUDA_TRY(cudaMemcpy(change, s->change, 3 * sizeof(double), cudaMemcpyDeviceToHost));
done:
    return status;
}

static rad_status cuda_accept(void *state)
{
    cuda_state *s = (cuda_state *)state;
    rad_status status = RAD_OK;
    const solve_shaped_device_plan *p = &s->plan;
    const shaped_view *v = &p->view;
    double *swap = s->Q;
    s->Q = s->next;
    s->next = swap;
    if (v->leaf_count > 0) {
        shaped_scatter_kernel<<<blocks_for(v->leaf_count, SHAPED_BLOCK), SHAPED_BLOCK>>>(*v, s->Q, s->B);
        RAD_CUDA_TRY(cudaGetLastError());
    }
    for (uint32_t d = p->depth_count; d-- > 0;) { /* deepest first: children before parents */
        const uint32_t first = s->depth_first[d], count = s->depth_first[d + 1] - first;
        if (count == 0) continue;
        shaped_pull_kernel<<<blocks_for(count, SHAPED_BLOCK), SHAPED_BLOCK>>>(*v, p->depth_order + first, count, s->B);
        RAD_CUDA_TRY(cudaGetLastError());
    }
done:
    return status;
}

static rad_status cuda_store(void *state, double *B, double *H)
{
    cuda_state *s = (cuda_state *)state;
    const size_t bytes = 3 * s->plan.view.id_count * sizeof(double);
    rad_status status = rad_cuda_stage_down(&s->stage, B, s->B, bytes, 0);
    return status == RAD_OK ? rad_cuda_stage_down(&s->stage, H, s->H, bytes, 0) : status;
}

static const char *cuda_device_name(void *state) { return ((cuda_state *)state)->name; }

extern "C" const solve_shaped_jacobi solve_shaped_jacobi_cuda = {
    "cuda", cuda_create, cuda_factors, cuda_drop, cuda_materials, cuda_load, cuda_sweep, cuda_accept, cuda_store, cuda_device_name,
    cuda_destroy};
