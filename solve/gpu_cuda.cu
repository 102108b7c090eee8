/* gpu_cuda.cu - solve's CUDA code (gpu.h). No OpenMP or MPI here, only
 * CUDA; the iteration control (when to stop, restart, fall back) stays on
 * the host, in cg.c, stationary.c and rounds.c.
 *
 * The matrix lives on the device as 64-column tiles padded to 64 floats
 * (a sparse file's stored tiles; a dense row as all its tiles), with
 * row_tiles and tile_column as the file has them. The product kernel
 * gives each row a warp: lane k takes entries 2k and 2k + 1 of every tile
 * of the row (one 256-byte load of the tile per warp), multiplies them by
 * the operand of each lane (up to three channels: the matrix is read once
 * for all of them), sums in double, and the warp adds its 32 partial sums
 * with an xor butterfly. The vector kernels (CG's updates, Jacobi's) give
 * each block one chunk of solve_gpu_row_quantum(N) rows, whatever the
 * rank holding it; each block leaves one partial maximum and one partial
 * sum; a second kernel adds every chunk's in a fixed order. No atomics: a
 * given N gives the same bits, run after run and for any number of ranks.
 *
 * Under mpirun each rank's GPU holds its rows, whole vectors and every
 * chunk's partials; what a pass changed goes to the other ranks through
 * the host (the caller's gather, gpu.h) before anything reads it: the
 * operand of a product before the product, a reduction's partials before
 * its finishing kernel.
 *
 * Compiled with --fmad=false (solve/CMakeLists.txt), so the vector
 * updates round as the host code they mirror (cg.c, stationary.c); only
 * the order of the sums differs from the CPU.
 */
#include <cuda_runtime.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

extern "C" {
#include "gpu.h"
#include "rad_cuda.h"
#include "rad_log.h"
#include "residual.h"
}
#include "rad_cuda_check.h"

/* Threads per block of every kernel; the product kernel's rows per block
 * are its warps. */
#define GPU_BLOCK 256
#define GPU_WARPS (GPU_BLOCK / 32)
/* Tile width: the file's (docs/formats.md); a warp covers it in two
 * entries per lane. */
#define GPU_TILE 64
/* Chunks of rows of the vector kernels, at most: each leaves one partial
 * result per quantity; 512 blocks of 256 threads keep an H100's 132 SMs
 * busy. */
#define GPU_PARTIALS 512
/* Vectors per lane: B, next, r, z, p, q, y, rho, E. */
#define GPU_LANE_VECTORS 9

static_assert(RAD_FF_TILE_COLUMNS == GPU_TILE, "the tile width of the file format");
static_assert(sizeof(uint64_t) == sizeof(unsigned long long), "row_tiles as the file has them");

/* An op beyond solve_gpu_op's, for solve_gpu_cg_restart. */
#define GPU_RESTART 100

/* What finishes a vector kernel's partial results into a lane's scalars. */
enum gpu_finish { FINISH_OMEGA, FINISH_CURVATURE, FINISH_UPDATE, FINISH_RESTART };

/* One lane's scalars, on the device (host copies after each pass). */
struct gpu_scalars {
    double rz;    /* r.z of the current search direction */
    double pq;    /* p.Kp of the last step */
    double alpha; /* rz / pq */
    double beta;  /* the new rz / the old */
    double omega; /* omega of the last measured iterate */
    int ok;       /* pq > 0: the last step was taken */
    int pad;
};

/* One lane's vectors on the device, each n_pad doubles (zero beyond n). */
struct gpu_lane {
    double *B, *next, *r, *z, *p, *q, *y;
    double *rho, *E;
    double e_norm;
};

/* The kernels' view of every lane and what it does in this launch. */
struct gpu_lanes {
    gpu_lane lane[SOLVE_GPU_LANES];
    int op[SOLVE_GPU_LANES]; /* solve_gpu_op, or GPU_RESTART */
    const double *area, *diag; /* N each */
    size_t n;             /* N */
    size_t chunk;         /* rows per block of the vector kernels (solve_gpu_row_quantum) */
    unsigned chunk_begin; /* this rank's first chunk: block b takes chunk chunk_begin + b */
    unsigned chunks;      /* every rank's: the partials a finish adds, <= GPU_PARTIALS */
    double *partial;      /* [lane][max, sum][GPU_PARTIALS], by chunk */
    gpu_scalars *scalars; /* [lane] */
};

/* The product's operands: x[k] in, y[k] out, for k < the template's K. */
struct gpu_operands {
    const double *x[SOLVE_GPU_LANES];
    double *y[SOLVE_GPU_LANES];
};

struct gpu_matrix {
    size_t n;                            /* rows held */
    size_t row_begin;                    /* the first one's index: y[row_begin + r] */
    const unsigned long long *row_tiles; /* n + 1 */
    const uint32_t *tile_column;         /* per tile: its first column */
    const float *values;                 /* per tile: GPU_TILE entries, zero-padded */
};

struct solve_gpu {
    char name[256];
    int exact;
    size_t n, n_pad, tile_count, matrix_bytes; /* n: N */
    size_t rows, row_begin;                   /* the rows held: [row_begin, row_begin + rows) */
    size_t chunk, chunk_begin, chunk_end, chunks; /* this rank's chunks [chunk_begin, chunk_end) of all */
    unsigned long long *row_tiles;
    uint32_t *tile_column;
    float *values;
    double *area, *diag; /* N each (diag: zero outside the rows held) */
    double *vectors;     /* SOLVE_GPU_LANES * GPU_LANE_VECTORS * n_pad */
    double *partial;
    gpu_scalars *scalars;
    gpu_scalars host_scalars[SOLVE_GPU_LANES];
    gpu_lane lane[SOLVE_GPU_LANES];
    size_t lane_count;
    /* With ranks (NULL gather: alone) */
    rad_status (*gather)(void *user, const size_t *split, double *const *arrays, size_t count);
    void *user;
    size_t *row_split, *chunk_split; /* ranks + 1 each */
    double *host_vectors;            /* SOLVE_GPU_LANES * N: what crosses to the other ranks */
    double *host_partial;            /* SOLVE_GPU_LANES * 2 * GPU_PARTIALS */
};

/* ---- kernels ---- */

/* The larger of two residuals; NaN wins (a NaN anywhere is the answer). */
__device__ static inline double gpu_max(double a, double b)
{
    if (isnan(a)) return a;
    if (isnan(b)) return b;
    return a > b ? a : b;
}

/* Reduces one value of each kind over the block (a fixed tree); thread 0
 * gets the results. */
__device__ static void gpu_block_reduce(double *worst, double *sum)
{
    __shared__ double s_max[GPU_BLOCK], s_sum[GPU_BLOCK];
    unsigned t = threadIdx.x;
    s_max[t] = *worst;
    s_sum[t] = *sum;
    __syncthreads();
    for (unsigned half = GPU_BLOCK / 2; half > 0; half >>= 1) {
        if (t < half) {
            s_max[t] = gpu_max(s_max[t], s_max[t + half]);
            s_sum[t] += s_sum[t + half];
        }
        __syncthreads();
    }
    *worst = s_max[0];
    *sum = s_sum[0];
}

/* This block's partial maximum and sum for lane c, at its chunk. */
__device__ static void gpu_store_partials(const gpu_lanes &L, unsigned c, double worst, double sum)
{
    gpu_block_reduce(&worst, &sum);
    if (threadIdx.x == 0) {
        L.partial[(2 * c) * GPU_PARTIALS + L.chunk_begin + blockIdx.x] = worst;
        L.partial[(2 * c + 1) * GPU_PARTIALS + L.chunk_begin + blockIdx.x] = sum;
    }
}

/* y_k = F x_k for k < K: a warp per row (above). x_k hold n_pad entries,
 * zero beyond n, so a padded tile needs no bounds test. */
template <int K> __global__ void __launch_bounds__(GPU_BLOCK) gpu_product_kernel(gpu_matrix m, gpu_operands v)
{
    size_t row = (blockIdx.x * (size_t)blockDim.x + threadIdx.x) / 32;
    unsigned lane = threadIdx.x & 31u;
    if (row >= m.n) return; /* the whole warp */
    double s[K];
#pragma unroll
    for (int k = 0; k < K; k++) s[k] = 0;
    const unsigned long long end = m.row_tiles[row + 1];
#pragma unroll 4
    for (unsigned long long t = m.row_tiles[row]; t < end; t++) {
        float2 f = reinterpret_cast<const float2 *>(m.values + t * GPU_TILE)[lane];
        size_t column = (size_t)m.tile_column[t] + 2 * lane;
#pragma unroll
        for (int k = 0; k < K; k++) {
            double2 x = *reinterpret_cast<const double2 *>(v.x[k] + column);
            s[k] += (double)f.x * x.x;
            s[k] += (double)f.y * x.y;
        }
    }
#pragma unroll
    for (int k = 0; k < K; k++)
        for (int offset = 16; offset > 0; offset >>= 1) s[k] += __shfl_xor_sync(0xffffffffu, s[k], offset);
    if (lane == 0) {
#pragma unroll
        for (int k = 0; k < K; k++) v.y[k][m.row_begin + row] = s[k];
    }
}

/* The rows of this thread: its block's chunk of L.chunk rows (chunk
 * L.chunk_begin + blockIdx.x), a thread per row, left to right in steps
 * of the block - the same for a chunk whichever rank holds it. */
#define GPU_ROWS_OF_THIS_THREAD(i, L)                                                                      \
    for (size_t i##_first = ((size_t)(L).chunk_begin + blockIdx.x) * (L).chunk,                            \
                i##_end = i##_first + (L).chunk < (L).n ? i##_first + (L).chunk : (L).n,                     \
                i = i##_first + threadIdx.x;                                                               \
         i < i##_end; i += blockDim.x)

/* After y = F B: CG's residual (cg.c cg_residual) or a Jacobi update
 * (stationary.c jacobi_sweep), and omega of B. Lane = blockIdx.y. */
__global__ void gpu_measure_kernel(gpu_lanes L)
{
    unsigned c = blockIdx.y;
    int op = L.op[c];
    if (op != SOLVE_GPU_CG_RESIDUAL && op != SOLVE_GPU_JACOBI) return; /* the whole block */
    gpu_lane l = L.lane[c];
    double worst = 0, none = 0;
    GPU_ROWS_OF_THIS_THREAD(i, L)
    {
        double rho = l.rho[i];
        if (rho == 0) {
            if (op == SOLVE_GPU_JACOBI)
                l.next[i] = l.B[i];
            else
                l.r[i] = l.z[i] = 0;
            continue;
        }
        double gathered = l.E[i] + rho * l.y[i];
        double r = gathered - l.B[i];
        if (op == SOLVE_GPU_JACOBI) {
            l.next[i] = l.B[i] + r / (1 - rho * L.diag[i]);
        } else {
            l.r[i] = L.area[i] / rho * r;
            l.z[i] = l.r[i] / (L.area[i] * (1 / rho - L.diag[i]));
        }
        worst = gpu_max(worst, solve_patch_residual(r, gathered, l.e_norm));
    }
    gpu_store_partials(L, c, worst, none);
}

/* After y = F p: q = K p and the partial sums of p.q (cg.c cg_step). */
__global__ void gpu_curvature_kernel(gpu_lanes L)
{
    unsigned c = blockIdx.y;
    if (L.op[c] != SOLVE_GPU_CG_STEP) return;
    gpu_lane l = L.lane[c];
    double none = 0, pq = 0;
    GPU_ROWS_OF_THIS_THREAD(i, L)
    {
        double rho = l.rho[i];
        double q = rho == 0 ? 0 : L.area[i] * (l.p[i] / rho - l.y[i]);
        l.q[i] = q;
        pq += l.p[i] * q;
    }
    gpu_store_partials(L, c, none, pq);
}

/* When p.q > 0: B += alpha p, r -= alpha q, z = r / K_ii; omega of the
 * new B (from the recurrence) and the partial sums of r.z. */
__global__ void gpu_update_kernel(gpu_lanes L)
{
    unsigned c = blockIdx.y;
    if (L.op[c] != SOLVE_GPU_CG_STEP || !L.scalars[c].ok) return;
    gpu_lane l = L.lane[c];
    const double alpha = L.scalars[c].alpha;
    double worst = 0, rz = 0;
    GPU_ROWS_OF_THIS_THREAD(i, L)
    {
        double rho = l.rho[i];
        if (rho == 0) continue; /* r = z = p = 0 there */
        l.B[i] += alpha * l.p[i];
        l.r[i] -= alpha * l.q[i];
        l.z[i] = l.r[i] / (L.area[i] * (1 / rho - L.diag[i]));
        double r = l.r[i] * rho / L.area[i];
        worst = gpu_max(worst, solve_patch_residual(r, l.B[i] + r, l.e_norm));
        rz += l.r[i] * l.z[i];
    }
    gpu_store_partials(L, c, worst, rz);
}

/* When p.q > 0: p = z + beta p. */
__global__ void gpu_direction_kernel(gpu_lanes L)
{
    unsigned c = blockIdx.y;
    if (L.op[c] != SOLVE_GPU_CG_STEP || !L.scalars[c].ok) return;
    gpu_lane l = L.lane[c];
    const double beta = L.scalars[c].beta;
    GPU_ROWS_OF_THIS_THREAD(i, L) l.p[i] = l.z[i] + beta * l.p[i];
}

/* p = z and the partial sums of r.z (cg.c cg_restart_direction). */
__global__ void gpu_restart_kernel(gpu_lanes L)
{
    unsigned c = blockIdx.y;
    if (L.op[c] != GPU_RESTART) return;
    gpu_lane l = L.lane[c];
    double none = 0, rz = 0;
    GPU_ROWS_OF_THIS_THREAD(i, L)
    {
        l.p[i] = l.z[i];
        rz += l.r[i] * l.z[i];
    }
    gpu_store_partials(L, c, none, rz);
}

/* Adds the partial results of lane blockIdx.x in a fixed order and sets
 * its scalars. */
__global__ void gpu_finish_kernel(gpu_lanes L, int finish)
{
    unsigned c = blockIdx.x;
    int op = L.op[c];
    int applies = finish == FINISH_OMEGA ? op == SOLVE_GPU_CG_RESIDUAL || op == SOLVE_GPU_JACOBI
                  : finish == FINISH_RESTART ? op == GPU_RESTART
                                             : op == SOLVE_GPU_CG_STEP;
    if (!applies || (finish == FINISH_UPDATE && !L.scalars[c].ok)) return;
    const double *worst_of = L.partial + (2 * c) * GPU_PARTIALS, *sum_of = worst_of + GPU_PARTIALS;
    double worst = 0, sum = 0;
    for (unsigned b = threadIdx.x; b < L.chunks; b += blockDim.x) {
        worst = gpu_max(worst, worst_of[b]);
        sum += sum_of[b];
    }
    gpu_block_reduce(&worst, &sum);
    if (threadIdx.x != 0) return;
    gpu_scalars *s = &L.scalars[c];
    switch (finish) {
    case FINISH_OMEGA: s->omega = worst; break;
    case FINISH_CURVATURE:
        s->pq = sum;
        s->ok = sum > 0;
        s->alpha = s->ok ? s->rz / sum : 0;
        break;
    case FINISH_UPDATE:
        s->omega = worst;
        s->beta = sum / s->rz;
        s->rz = sum;
        break;
    default: s->rz = sum; break;
    }
}

/* ---- host ---- */

extern "C" int solve_gpu_built(void) { return 1; }

/* gpu.h: CUDA's early start is core's (rad_cuda.h), on the rank's device. */
extern "C" void solve_gpu_prestart(int rank) { rad_cuda_prestart(rank); }
extern "C" void solve_gpu_prestart_join(void) { rad_cuda_prestart_join(); }
extern "C" int solve_gpu_device_count(void) { return rad_cuda_device_count(); }

extern "C" int solve_gpu_exact(const solve_gpu *gpu) { return gpu->exact; }
extern "C" void solve_gpu_set_exact(solve_gpu *gpu, int exact) { gpu->exact = exact; }
extern "C" const char *solve_gpu_device_name(const solve_gpu *gpu) { return gpu->name; }
extern "C" size_t solve_gpu_matrix_bytes(const solve_gpu *gpu) { return gpu->matrix_bytes; }

extern "C" size_t solve_gpu_row_quantum(size_t n)
{
    const size_t per_chunk = (size_t)GPU_BLOCK * GPU_PARTIALS;
    size_t blocks = (n + per_chunk - 1) / per_chunk; /* blocks of 256 rows per chunk */
    return GPU_BLOCK * (blocks ? blocks : 1);
}

extern "C" void solve_gpu_destroy(solve_gpu *gpu)
{
    if (!gpu) return;
    cudaFree(gpu->row_tiles);
    cudaFree(gpu->tile_column);
    cudaFree(gpu->values);
    cudaFree(gpu->area);
    cudaFree(gpu->diag);
    cudaFree(gpu->vectors);
    cudaFree(gpu->partial);
    cudaFree(gpu->scalars);
    free(gpu->row_split);
    free(gpu->chunk_split);
    free(gpu->host_vectors);
    free(gpu->host_partial);
    free(gpu);
}

extern "C" rad_status solve_gpu_create(const solve_gpu_tiles *tiles, const double *area, solve_gpu **out_gpu)
{
    return solve_gpu_create_ranks(tiles, area, NULL, out_gpu);
}

/* The split over ranks: this rank's rows and chunks, and the host buffers
 * the exchanges go through. Alone: all rows, no exchange. */
static rad_status set_ranks(solve_gpu *g, const solve_gpu_tiles *tiles, const solve_gpu_ranks *ranks)
{
    const size_t n = ranks ? ranks->n : tiles->n, q = solve_gpu_row_quantum(n);
    g->n = n;
    g->chunk = q;
    g->chunks = (n + q - 1) / q;
    g->rows = tiles->n;
    if (!ranks || ranks->ranks <= 1 || !ranks->gather) {
        if (tiles->n != n) {
            rad_error("internal: %zu rows of tiles for a matrix of %zu rows, without ranks", tiles->n, n);
            return RAD_ERR_INVALID;
        }
        g->chunk_end = g->chunks;
        return RAD_OK;
    }
    const size_t P = ranks->ranks, *split = ranks->row_split;
    g->row_split = (size_t *)malloc((P + 1) * sizeof(size_t));
    g->chunk_split = (size_t *)malloc((P + 1) * sizeof(size_t));
    g->host_vectors = (double *)malloc(SOLVE_GPU_LANES * (n ? n : 1) * sizeof(double));
    g->host_partial = (double *)malloc(SOLVE_GPU_LANES * 2 * GPU_PARTIALS * sizeof(double));
    if (!g->row_split || !g->chunk_split || !g->host_vectors || !g->host_partial) {
        rad_error("out of memory");
        return RAD_ERR_NOMEM;
    }
    for (size_t r = 0; r <= P; r++) {
        const size_t first = split[r];
        if (first > n || (r > 0 && first < split[r - 1]) || (r == P && first != n) || (first < n && first % q)) {
            rad_error("internal: the rows split over ranks at row %zu, not a multiple of %zu (solve_gpu_row_quantum)",
                      first, q);
            return RAD_ERR_INVALID;
        }
        g->row_split[r] = first;
        g->chunk_split[r] = first == n ? g->chunks : first / q;
    }
    g->row_begin = split[ranks->rank];
    g->chunk_begin = g->chunk_split[ranks->rank];
    g->chunk_end = g->chunk_split[ranks->rank + 1];
    if (split[ranks->rank + 1] - g->row_begin != tiles->n) {
        rad_error("internal: %zu rows of tiles for rank %zu's %zu rows", tiles->n, ranks->rank,
                  split[ranks->rank + 1] - g->row_begin);
        return RAD_ERR_INVALID;
    }
    g->gather = ranks->gather;
    g->user = ranks->user;
    return RAD_OK;
}

/* Bytes of each page-locked buffer a streamed upload fills in turn. */
#define STREAM_STAGE_BYTES ((size_t)64 << 20)

/* The values of streamed tiles (values NULL): converted from the source
 * rows by the host's threads into one page-locked buffer while the other
 * is copied to the device; sets g->exact from what they held. */
static rad_status stream_values(solve_gpu *g, const solve_gpu_tiles *tiles)
{
    rad_status status = RAD_OK;
    const size_t tile_bytes = GPU_TILE * sizeof(float), rows = tiles->n;
    size_t stage_bytes = STREAM_STAGE_BYTES;
    for (size_t r = 0; r < rows; r++) { /* a row's tiles must fit one buffer */
        size_t bytes = (size_t)(tiles->row_tiles[r + 1] - tiles->row_tiles[r]) * tile_bytes;
        if (bytes > stage_bytes) stage_bytes = bytes;
    }
    float *stage[2] = {NULL, NULL};
    cudaEvent_t copied[2] = {NULL, NULL};
    cudaStream_t stream = NULL;
    int used[2] = {0, 0}, exact = 1;
    RAD_CUDA_TRY(cudaStreamCreateWithFlags(&stream, cudaStreamNonBlocking));
    for (int k = 0; k < 2; k++) {
        RAD_CUDA_TRY(cudaMallocHost(&stage[k], stage_bytes));
        RAD_CUDA_TRY(cudaEventCreateWithFlags(&copied[k], cudaEventDisableTiming));
    }
    for (size_t first = 0, k = 0; first < rows; k ^= 1) {
        size_t end = first + 1;
        while (end < rows && (tiles->row_tiles[end + 1] - tiles->row_tiles[first]) * tile_bytes <= stage_bytes) end++;
        if (used[k]) RAD_CUDA_TRY(cudaEventSynchronize(copied[k])); /* its last copy is done */
        exact = solve_gpu_tiles_fill(tiles, first, end, stage[k]) && exact;
        const size_t bytes = (size_t)(tiles->row_tiles[end] - tiles->row_tiles[first]) * tile_bytes;
        RAD_CUDA_TRY(cudaMemcpyAsync(g->values + tiles->row_tiles[first] * GPU_TILE, stage[k], bytes,
                                     cudaMemcpyHostToDevice, stream));
        RAD_CUDA_TRY(cudaEventRecord(copied[k], stream));
        used[k] = 1;
        first = end;
    }
    RAD_CUDA_TRY(cudaStreamSynchronize(stream));
    g->exact = exact;
done:
    if (stream) cudaStreamSynchronize(stream); /* no copy left reading a buffer freed below */
    for (int k = 0; k < 2; k++) {
        if (copied[k]) cudaEventDestroy(copied[k]);
        cudaFreeHost(stage[k]);
    }
    if (stream) cudaStreamDestroy(stream);
    return status;
}

extern "C" rad_status solve_gpu_create_ranks(const solve_gpu_tiles *tiles, const double *area,
                                             const solve_gpu_ranks *ranks, solve_gpu **out_gpu)
{
    rad_status status = RAD_OK;
    const size_t count = tiles->tile_count, rows = tiles->n;
    const int device = ranks ? ranks->device : 0;
    size_t n;
    solve_gpu *g = (solve_gpu *)calloc(1, sizeof *g);
    if (!g) {
        rad_error("out of memory");
        return RAD_ERR_NOMEM;
    }
    if (solve_gpu_device_count() == 0) {
        rad_error("--backend cuda: no CUDA device is visible (no GPU, no driver, or CUDA_VISIBLE_DEVICES hides "
                  "them); --backend auto or cpu solves on the CPU");
        status = RAD_ERR_BACKEND;
        goto done;
    }
    if ((status = set_ranks(g, tiles, ranks)) != RAD_OK) goto done;
    n = g->n;
    g->n_pad = (n + GPU_TILE - 1) / GPU_TILE * GPU_TILE;
    g->tile_count = count;
    g->exact = tiles->exact;
    g->matrix_bytes = count * (GPU_TILE * sizeof(float) + sizeof(uint32_t)) + (rows + 1) * sizeof(uint64_t);
    {
        cudaDeviceProp prop;
        RAD_CUDA_TRY(cudaSetDevice(device));
        RAD_CUDA_TRY(cudaGetDeviceProperties(&prop, device));
        snprintf(g->name, sizeof g->name, "%s", prop.name);
        size_t free_bytes = 0, total_bytes = 0;
        RAD_CUDA_TRY(cudaMemGetInfo(&free_bytes, &total_bytes));
        size_t need = g->matrix_bytes + SOLVE_GPU_LANES * GPU_LANE_VECTORS * g->n_pad * sizeof(double) +
                      2 * n * sizeof(double);
        if (need > free_bytes) {
            rad_error("--backend cuda: the matrix needs %.2f GiB on the GPU (%zu tiles of %d floats and the "
                      "vectors), %s has %.2f GiB free",
                      need / 1073741824.0, count, GPU_TILE, g->name, free_bytes / 1073741824.0);
            status = RAD_ERR_NOMEM;
            goto done;
        }
    }
    RAD_CUDA_TRY(cudaMalloc(&g->row_tiles, (rows + 1) * sizeof(uint64_t)));
    RAD_CUDA_TRY(cudaMalloc(&g->tile_column, (count ? count : 1) * sizeof(uint32_t)));
    RAD_CUDA_TRY(cudaMalloc(&g->values, (count ? count : 1) * GPU_TILE * sizeof(float)));
    RAD_CUDA_TRY(cudaMalloc(&g->area, (n ? n : 1) * sizeof(double)));
    RAD_CUDA_TRY(cudaMalloc(&g->diag, (n ? n : 1) * sizeof(double)));
    RAD_CUDA_TRY(cudaMalloc(&g->vectors, SOLVE_GPU_LANES * GPU_LANE_VECTORS * (g->n_pad ? g->n_pad : 1) * sizeof(double)));
    RAD_CUDA_TRY(cudaMalloc(&g->partial, SOLVE_GPU_LANES * 2 * GPU_PARTIALS * sizeof(double)));
    RAD_CUDA_TRY(cudaMalloc(&g->scalars, SOLVE_GPU_LANES * sizeof(gpu_scalars)));
    /* zero vectors: the padding beyond n stays zero (kernels write rows < n only) */
    RAD_CUDA_TRY(cudaMemset(g->vectors, 0, SOLVE_GPU_LANES * GPU_LANE_VECTORS * g->n_pad * sizeof(double)));
    RAD_CUDA_TRY(cudaMemset(g->scalars, 0, SOLVE_GPU_LANES * sizeof(gpu_scalars)));
    RAD_CUDA_TRY(cudaMemset(g->partial, 0, SOLVE_GPU_LANES * 2 * GPU_PARTIALS * sizeof(double)));
    RAD_CUDA_TRY(cudaMemset(g->diag, 0, (n ? n : 1) * sizeof(double)));
    RAD_CUDA_TRY(cudaMemcpy(g->row_tiles, tiles->row_tiles, (rows + 1) * sizeof(uint64_t), cudaMemcpyHostToDevice));
    if (count) {
        RAD_CUDA_TRY(cudaMemcpy(g->tile_column, tiles->tile_column, count * sizeof(uint32_t), cudaMemcpyHostToDevice));
        if (tiles->values)
            RAD_CUDA_TRY(cudaMemcpy(g->values, tiles->values, count * GPU_TILE * sizeof(float), cudaMemcpyHostToDevice));
        else if ((status = stream_values(g, tiles)) != RAD_OK)
            goto done;
    }
    if (rows)
        RAD_CUDA_TRY(cudaMemcpy(g->diag + g->row_begin, tiles->diag, rows * sizeof(double), cudaMemcpyHostToDevice));
    RAD_CUDA_TRY(cudaMemcpy(g->area, area, n * sizeof(double), cudaMemcpyHostToDevice));
    for (size_t c = 0; c < SOLVE_GPU_LANES; c++) {
        double *v = g->vectors + c * GPU_LANE_VECTORS * g->n_pad;
        g->lane[c] = gpu_lane{v, v + g->n_pad, v + 2 * g->n_pad, v + 3 * g->n_pad, v + 4 * g->n_pad,
                              v + 5 * g->n_pad, v + 6 * g->n_pad, v + 7 * g->n_pad, v + 8 * g->n_pad, 1.0};
    }
    *out_gpu = g;
    g = NULL;
done:
    solve_gpu_destroy(g);
    return status;
}

/* The kernels' argument for `ops` (NULL entries: idle). */
static gpu_lanes lanes_arg(const solve_gpu *g, const int *ops)
{
    gpu_lanes L;
    memset(&L, 0, sizeof L);
    for (size_t c = 0; c < g->lane_count; c++) {
        L.lane[c] = g->lane[c];
        L.op[c] = ops[c];
    }
    L.area = g->area;
    L.diag = g->diag;
    L.n = g->n;
    L.chunk = g->chunk;
    L.chunk_begin = (unsigned)g->chunk_begin;
    L.chunks = (unsigned)g->chunks;
    L.partial = g->partial;
    L.scalars = g->scalars;
    return L;
}

/* The vector kernels' grid: this rank's chunks, one lane each in y. */
static dim3 vector_grid(const solve_gpu *g) { return dim3((unsigned)(g->chunk_end - g->chunk_begin), (unsigned)g->lane_count); }
static int has_chunks(const solve_gpu *g) { return g->chunk_end > g->chunk_begin; }

/* With ranks: every rank's rows of these device vectors (N each) onto
 * every GPU, through the host. Alone: nothing. */
static rad_status gather_vectors(solve_gpu *g, double *const *vectors, size_t count)
{
    rad_status status = RAD_OK;
    double *host[SOLVE_GPU_LANES];
    if (!g->gather || count == 0) return RAD_OK;
    for (size_t c = 0; c < count; c++) {
        host[c] = g->host_vectors + c * g->n;
        if (g->rows)
            RAD_CUDA_TRY(cudaMemcpy(host[c] + g->row_begin, vectors[c] + g->row_begin, g->rows * sizeof(double),
                                    cudaMemcpyDeviceToHost));
    }
    if ((status = g->gather(g->user, g->row_split, host, count)) != RAD_OK) return status;
    for (size_t c = 0; c < count; c++)
        RAD_CUDA_TRY(cudaMemcpy(vectors[c], host[c], g->n * sizeof(double), cudaMemcpyHostToDevice));
done:
    return status;
}

/* With ranks: every rank's chunk partials of every lane onto every GPU,
 * before a finishing kernel adds them. */
static rad_status gather_partials(solve_gpu *g)
{
    rad_status status = RAD_OK;
    double *arrays[2 * SOLVE_GPU_LANES];
    const size_t count = 2 * g->lane_count, bytes = count * GPU_PARTIALS * sizeof(double);
    if (!g->gather || count == 0) return RAD_OK;
    RAD_CUDA_TRY(cudaMemcpy(g->host_partial, g->partial, bytes, cudaMemcpyDeviceToHost));
    for (size_t k = 0; k < count; k++) arrays[k] = g->host_partial + k * GPU_PARTIALS;
    if ((status = g->gather(g->user, g->chunk_split, arrays, count)) != RAD_OK) return status;
    RAD_CUDA_TRY(cudaMemcpy(g->partial, g->host_partial, bytes, cudaMemcpyHostToDevice));
done:
    return status;
}

/* y_k = F x_k for k < count, one pass over this rank's rows of F. */
static rad_status launch_product(const solve_gpu *g, const gpu_operands *v, int count)
{
    rad_status status = RAD_OK;
    gpu_matrix m = {g->rows, g->row_begin, g->row_tiles, g->tile_column, g->values};
    unsigned blocks = (unsigned)((g->rows + GPU_WARPS - 1) / GPU_WARPS);
    if (blocks == 0) return RAD_OK;
    if (count == 1) gpu_product_kernel<1><<<blocks, GPU_BLOCK>>>(m, *v);
    if (count == 2) gpu_product_kernel<2><<<blocks, GPU_BLOCK>>>(m, *v);
    if (count == 3) gpu_product_kernel<3><<<blocks, GPU_BLOCK>>>(m, *v);
    RAD_CUDA_TRY(cudaGetLastError());
done:
    return status;
}

extern "C" rad_status solve_gpu_lanes_load(solve_gpu *g, size_t count, const double *const *rho,
                                           const double *const *E, const double *const *B, const double *e_norm)
{
    rad_status status = RAD_OK;
    const size_t bytes = g->n * sizeof(double);
    if (count > SOLVE_GPU_LANES) {
        rad_error("solve_gpu_lanes_load: %zu lanes, at most %d", count, SOLVE_GPU_LANES);
        return RAD_ERR_INVALID;
    }
    for (size_t c = 0; c < count; c++) {
        RAD_CUDA_TRY(cudaMemcpy(g->lane[c].rho, rho[c], bytes, cudaMemcpyHostToDevice));
        RAD_CUDA_TRY(cudaMemcpy(g->lane[c].E, E[c], bytes, cudaMemcpyHostToDevice));
        RAD_CUDA_TRY(cudaMemcpy(g->lane[c].B, B[c], bytes, cudaMemcpyHostToDevice));
        g->lane[c].e_norm = e_norm[c];
    }
    g->lane_count = count;
done:
    return status;
}

extern "C" rad_status solve_gpu_lanes_store(solve_gpu *g, size_t lane, double *out_B)
{
    rad_status status = RAD_OK;
    double *B = g->lane[lane].B;
    if ((status = gather_vectors(g, &B, 1)) != RAD_OK) return status;
    RAD_CUDA_TRY(cudaMemcpy(out_B, B, g->n * sizeof(double), cudaMemcpyDeviceToHost));
done:
    return status;
}

extern "C" void solve_gpu_jacobi_accept(solve_gpu *g, size_t lane)
{
    double *t = g->lane[lane].B;
    g->lane[lane].B = g->lane[lane].next;
    g->lane[lane].next = t;
}

extern "C" rad_status solve_gpu_multiply(solve_gpu *g, size_t count, const double *const *x, double *const *y)
{
    rad_status status = RAD_OK;
    const size_t bytes = g->n * sizeof(double);
    gpu_operands v;
    double *ys[SOLVE_GPU_LANES];
    memset(&v, 0, sizeof v);
    if (count > SOLVE_GPU_LANES) {
        rad_error("solve_gpu_multiply: %zu vectors, at most %d", count, SOLVE_GPU_LANES);
        return RAD_ERR_INVALID;
    }
    for (size_t c = 0; c < count; c++) {
        RAD_CUDA_TRY(cudaMemcpy(g->lane[c].B, x[c], bytes, cudaMemcpyHostToDevice));
        v.x[c] = g->lane[c].B;
        v.y[c] = ys[c] = g->lane[c].y;
    }
    if (count == 0) return RAD_OK;
    if ((status = launch_product(g, &v, (int)count)) != RAD_OK) goto done;
    if ((status = gather_vectors(g, ys, count)) != RAD_OK) goto done;
    for (size_t c = 0; c < count; c++) RAD_CUDA_TRY(cudaMemcpy(y[c], g->lane[c].y, bytes, cudaMemcpyDeviceToHost));
done:
    return status;
}

extern "C" rad_status solve_gpu_lanes_iterate(solve_gpu *g, const solve_gpu_op *ops, double *out_omega)
{
    rad_status status = RAD_OK;
    int op[SOLVE_GPU_LANES] = {0}, count = 0, measure = 0, step = 0;
    gpu_operands v;
    double *operands[SOLVE_GPU_LANES];
    memset(&v, 0, sizeof v);
    for (size_t c = 0; c < g->lane_count; c++) {
        op[c] = ops[c];
        if (ops[c] == SOLVE_GPU_IDLE) continue;
        double *x = ops[c] == SOLVE_GPU_CG_STEP ? g->lane[c].p : g->lane[c].B;
        operands[count] = x;
        v.x[count] = x;
        v.y[count++] = g->lane[c].y;
        step |= ops[c] == SOLVE_GPU_CG_STEP;
        measure |= ops[c] != SOLVE_GPU_CG_STEP;
    }
    if (count == 0) return RAD_OK;
    gpu_lanes L = lanes_arg(g, op);
    dim3 grid = vector_grid(g);
    unsigned lanes = (unsigned)g->lane_count;
    /* the operands whole on every GPU: each rank updated only its rows */
    if ((status = gather_vectors(g, operands, (size_t)count)) != RAD_OK) goto done;
    if ((status = launch_product(g, &v, count)) != RAD_OK) goto done;
    if (measure) {
        if (has_chunks(g)) gpu_measure_kernel<<<grid, GPU_BLOCK>>>(L);
        if ((status = gather_partials(g)) != RAD_OK) goto done;
        gpu_finish_kernel<<<lanes, GPU_BLOCK>>>(L, FINISH_OMEGA);
    }
    if (step) {
        if (has_chunks(g)) gpu_curvature_kernel<<<grid, GPU_BLOCK>>>(L);
        if ((status = gather_partials(g)) != RAD_OK) goto done;
        gpu_finish_kernel<<<lanes, GPU_BLOCK>>>(L, FINISH_CURVATURE);
        if (has_chunks(g)) gpu_update_kernel<<<grid, GPU_BLOCK>>>(L);
        if ((status = gather_partials(g)) != RAD_OK) goto done;
        gpu_finish_kernel<<<lanes, GPU_BLOCK>>>(L, FINISH_UPDATE);
        if (has_chunks(g)) gpu_direction_kernel<<<grid, GPU_BLOCK>>>(L);
    }
    RAD_CUDA_TRY(cudaGetLastError());
    /* waits for the kernels; a fault in one of them is reported here */
    RAD_CUDA_TRY(cudaMemcpy(g->host_scalars, g->scalars, g->lane_count * sizeof(gpu_scalars), cudaMemcpyDeviceToHost));
    for (size_t c = 0; c < g->lane_count; c++) {
        if (ops[c] == SOLVE_GPU_IDLE) continue;
        const gpu_scalars *s = &g->host_scalars[c];
        out_omega[c] = ops[c] == SOLVE_GPU_CG_STEP && !s->ok ? NAN : s->omega;
    }
done:
    return status;
}

extern "C" rad_status solve_gpu_cg_restart(solve_gpu *g, const int *restart)
{
    rad_status status = RAD_OK;
    int op[SOLVE_GPU_LANES] = {0}, any = 0;
    for (size_t c = 0; c < g->lane_count; c++) {
        op[c] = restart[c] ? GPU_RESTART : SOLVE_GPU_IDLE;
        any |= restart[c] != 0;
    }
    if (!any) return RAD_OK;
    gpu_lanes L = lanes_arg(g, op);
    if (has_chunks(g)) gpu_restart_kernel<<<vector_grid(g), GPU_BLOCK>>>(L);
    if ((status = gather_partials(g)) != RAD_OK) goto done;
    gpu_finish_kernel<<<(unsigned)g->lane_count, GPU_BLOCK>>>(L, FINISH_RESTART);
    RAD_CUDA_TRY(cudaGetLastError());
done:
    return status;
}
