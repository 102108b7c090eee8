/* ff_cuda_records.cu - finished rows on the GPU (ff_cuda_records.h).
 *
 * Three steps per round of rows, each a kernel:
 *  1. finish: c_ij * A_j -> F_ij in place (values and standard errors:
 *     the same doubles as ff_rows_finish), and each row's sums for the
 *     stats. A warp takes 32 rows and one segment of their columns; it
 *     loads 32 x 32 entries at a time (coalesced), each lane sums its own
 *     row's part from shared memory, left to right, and the segments' sums
 *     are added in column order (the row sums may differ from the CPU's
 *     in the last bits; the stored entries do not).
 *  2. tiles: which 64-column tiles of each row have an entry whose stored
 *     bits are not zero (rad_ff_row_encode's rule), each listed tile's
 *     place in its row's record, and the record's size.
 *  3. records: the host scans the sizes into offsets; each row's record is
 *     written there (tile count, tile numbers, entries; padding zero).
 * Only the records come back: at cornell_sphere --subdiv 5, 10 % of the
 * doubles the rows hold. This file, like ff_backend_cuda.cu, is compiled
 * with --fmad=false: a product and a sum round separately, as on the CPU.
 */
#include <cuda_runtime.h>
#include <stdlib.h>
#include <string.h>

#include "ff_cuda_records.h"
#include "rad_cuda_check.h"

extern "C" {
#include "rad_log.h"
}

#define TILE RAD_FF_TILE_COLUMNS
#define NOT_LISTED 0xffffffffu
/* Column segments per row in the finishing kernel: enough one-warp blocks
 * to fill the GPU when a round has few rows (712 rows of 188 416 columns:
 * 23 x 128 blocks), each segment at least 1024 columns. */
#define SEGMENTS_MAX 128u

/* One row's share of ff_rows_summary. */
struct row_stats {
    double sum, error_sum, error_relative_sum, error_max, error_max_value;
    uint32_t error_count, error_max_column;
};

/* The host's records come in two sets used in turn, call after call: the
 * driver writes one round's in the background while the next is made
 * (ff_backend.h: a view lasts until the call after next). [f][set]: f =
 * 0 values, 1 errors. */
struct ff_cuda_records {
    size_t rows_capacity, tiles_capacity, bytes_capacity[2], host_capacity[2][2];
    row_stats *d_stats, *h_stats, *d_segment; /* d_segment: rows x SEGMENTS_MAX */
    uint32_t *d_place;    /* rows x tiles: the tile's place among its row's listed tiles, or NOT_LISTED */
    uint64_t *d_size, *h_size; /* rows: record bytes; then (h_size) offsets, rows + 1 */
    uint64_t *d_at;
    unsigned char *d_bytes[2], *h_bytes[2][2];
    uint64_t *h_at[2][2];
    size_t h_at_rows[2][2]; /* rows + 1 entries each h_at holds */
    unsigned calls;         /* ff_cuda_records_make calls so far: the set is calls % 2 */
};


/* Block (x, y): rows [32 x, 32 x + 32), columns [y cols, (y + 1) cols) -
 * one segment of the row; its partial sums into stats[row * segments + y].
 * Each lane loads its column of the 32 rows before it stores any (32
 * loads in flight per warp: the kernel is bound by memory latency, not
 * bandwidth, with one warp per block). */
__global__ static void finish_kernel(double *__restrict__ values, double *__restrict__ errors,
                                     const double *__restrict__ area, uint32_t n, uint32_t rows, uint32_t cols,
                                     row_stats *__restrict__ stats)
{
    __shared__ double v_tile[32][33], e_tile[32][33];
    const uint32_t lane = threadIdx.x, r0 = blockIdx.x * 32u, mine = r0 + lane;
    const uint32_t here = rows - r0 < 32u ? rows - r0 : 32u;
    const uint32_t c0 = blockIdx.y * cols, c1 = n - c0 < cols ? n : c0 + cols;
    row_stats s = {0, 0, 0, 0, 0, 0, 0};
    for (uint32_t j0 = c0; j0 < c1; j0 += 32u) {
        const uint32_t j = j0 + lane, width = c1 - j0 < 32u ? c1 - j0 : 32u;
        const int inside = j < c1;
        const double a = inside ? area[j] : 0;
        double v[32];
#pragma unroll
        for (uint32_t r = 0; r < 32u; r++) v[r] = r < here && inside ? values[(size_t)(r0 + r) * n + j] : 0;
#pragma unroll
        for (uint32_t r = 0; r < 32u; r++) {
            if (!(r < here && inside)) continue;
            v[r] *= a;
            values[(size_t)(r0 + r) * n + j] = v[r];
            v_tile[r][lane] = v[r];
        }
        if (errors) {
#pragma unroll
            for (uint32_t r = 0; r < 32u; r++) v[r] = r < here && inside ? errors[(size_t)(r0 + r) * n + j] : 0;
#pragma unroll
            for (uint32_t r = 0; r < 32u; r++) {
                if (!(r < here && inside)) continue;
                v[r] *= a;
                errors[(size_t)(r0 + r) * n + j] = v[r];
                e_tile[r][lane] = v[r];
            }
        }
        __syncwarp();
        if (lane < here) {
            for (uint32_t k = 0; k < width; k++) {
                double x = v_tile[lane][k];
                s.sum += x;
                if (!errors || !(x > 0)) continue;
                double e = e_tile[lane][k];
                s.error_sum += e;
                s.error_relative_sum += e / x;
                s.error_count++;
                if (e > s.error_max) {
                    s.error_max = e;
                    s.error_max_value = x;
                    s.error_max_column = j0 + k;
                }
            }
        }
        __syncwarp();
    }
    if (lane < here) stats[(size_t)mine * gridDim.y + blockIdx.y] = s;
}

/* A thread per row: its segments' partial sums, in column order. */
__global__ static void combine_kernel(const row_stats *segment, uint32_t rows, uint32_t segments, row_stats *stats)
{
    const uint32_t row = blockIdx.x * blockDim.x + threadIdx.x;
    if (row >= rows) return;
    row_stats s = segment[(size_t)row * segments];
    for (uint32_t k = 1; k < segments; k++) {
        const row_stats *p = &segment[(size_t)row * segments + k];
        s.sum += p->sum;
        s.error_sum += p->error_sum;
        s.error_relative_sum += p->error_relative_sum;
        s.error_count += p->error_count;
        if (p->error_max > s.error_max) {
            s.error_max = p->error_max;
            s.error_max_value = p->error_max_value;
            s.error_max_column = p->error_max_column;
        }
    }
    stats[row] = s;
}

/* rad_ff_row_encode's test: the entry's stored bits are not all zero. */
__device__ static inline int stored_nonzero(double v, uint32_t element)
{
    if (element == RAD_ELEMENT_F32) return __float_as_uint((float)v) != 0u;
    return __double_as_longlong(v) != 0;
}

__device__ static inline uint64_t align8(uint64_t x) { return (x + 7u) & ~(uint64_t)7u; }

/* Tiles a warp tests at once (TILES_AT_ONCE x 2 loads in flight per lane). */
#define TILES_AT_ONCE 8u

/* A warp per row: which tiles are listed, their places, the record size. */
__global__ static void tiles_kernel(const double *__restrict__ values, uint32_t n, uint32_t rows, uint32_t element,
                                    uint32_t *__restrict__ place, uint64_t *__restrict__ size)
{
    const uint32_t lane = threadIdx.x % 32u, row = (blockIdx.x * blockDim.x + threadIdx.x) / 32u;
    if (row >= rows) return;
    const uint32_t tiles = (n + TILE - 1u) / TILE;
    const double *v = values + (size_t)row * n;
    uint32_t listed = 0;
    uint64_t value_bytes = 0, element_bytes = element == RAD_ELEMENT_F32 ? 4u : 8u;
    for (uint32_t t0 = 0; t0 < tiles; t0 += TILES_AT_ONCE) {
        double lo[TILES_AT_ONCE], hi[TILES_AT_ONCE];
#pragma unroll
        for (uint32_t q = 0; q < TILES_AT_ONCE; q++) {
            const uint32_t j = (t0 + q) * TILE + lane; /* past the row: not stored, so not listed */
            lo[q] = j < n ? v[j] : 0.0;
            hi[q] = j + 32u < n ? v[j + 32u] : 0.0;
        }
#pragma unroll
        for (uint32_t q = 0; q < TILES_AT_ONCE; q++) {
            const uint32_t t = t0 + q;
            if (t >= tiles) break; /* the same t on every lane */
            const uint32_t width = n - t * TILE < TILE ? n - t * TILE : TILE;
            int any = stored_nonzero(lo[q], element) || stored_nonzero(hi[q], element);
            int listed_here = __any_sync(0xffffffffu, any);
            if (lane == 0) place[(size_t)row * tiles + t] = listed_here ? listed : NOT_LISTED;
            if (listed_here) {
                listed++;
                value_bytes += width * element_bytes;
            }
        }
    }
    if (lane == 0) size[row] = align8(4u + 4u * (uint64_t)listed) + align8(value_bytes);
}

/* Listed tiles a warp copies at once (2 loads each in flight per lane). */
#define COPIES_AT_ONCE 4

/* A warp per row: its record at out + at[row] (zeroed before). The warp
 * reads 32 tiles' places at once and copies the listed ones,
 * COPIES_AT_ONCE at a time, loading before it stores. */
__global__ static void records_kernel(const double *__restrict__ values, uint32_t n, uint32_t rows, uint32_t element,
                                      const uint32_t *__restrict__ place, const uint64_t *__restrict__ at,
                                      unsigned char *__restrict__ out)
{
    const uint32_t lane = threadIdx.x % 32u, row = (blockIdx.x * blockDim.x + threadIdx.x) / 32u;
    if (row >= rows) return;
    const uint32_t tiles = (n + TILE - 1u) / TILE;
    const double *v = values + (size_t)row * n;
    const uint32_t *row_place = place + (size_t)row * tiles;
    unsigned char *rec = out + at[row];
    uint32_t listed = 0;
    for (uint32_t t = lane; t < tiles; t += 32u) listed += row_place[t] != NOT_LISTED;
#if __CUDA_ARCH__ >= 800
    listed = __reduce_add_sync(0xffffffffu, listed);
#else /* no warp reduction before compute capability 8.0 (V100: README) */
    for (int lanes = 16; lanes > 0; lanes /= 2) listed += __shfl_xor_sync(0xffffffffu, listed, lanes);
#endif
    const uint64_t values_at = align8(4u + 4u * (uint64_t)listed);
    if (lane == 0) *(uint32_t *)rec = listed;
    for (uint32_t t0 = 0; t0 < tiles; t0 += 32u) {
        const uint32_t k_mine = t0 + lane < tiles ? row_place[t0 + lane] : NOT_LISTED;
        if (k_mine != NOT_LISTED) *(uint32_t *)(rec + 4u + 4u * (uint64_t)k_mine) = t0 + lane;
        uint32_t mask = __ballot_sync(0xffffffffu, k_mine != NOT_LISTED);
        while (mask) { /* the same mask on every lane */
            uint32_t t[COPIES_AT_ONCE], k[COPIES_AT_ONCE];
            double lo[COPIES_AT_ONCE], hi[COPIES_AT_ONCE];
            int count = 0;
#pragma unroll
            for (int q = 0; q < COPIES_AT_ONCE; q++) {
                const int bit = mask ? __ffs(mask) - 1 : 0;
                const int take = mask != 0;
                mask &= mask - 1u;
                t[q] = t0 + (uint32_t)bit;
                k[q] = __shfl_sync(0xffffffffu, k_mine, bit);
                count += take;
                const uint32_t j = t[q] * TILE + lane;
                lo[q] = take && j < n ? v[j] : 0.0;
                hi[q] = take && j + 32u < n ? v[j + 32u] : 0.0;
            }
#pragma unroll
            for (int q = 0; q < COPIES_AT_ONCE; q++) {
                if (q >= count) break;
                const uint32_t j = t[q] * TILE + lane;
                const size_t slot = (size_t)k[q] * TILE + lane;
                if (element == RAD_ELEMENT_F32) {
                    float *to = (float *)(rec + values_at);
                    if (j < n) to[slot] = (float)lo[q];
                    if (j + 32u < n) to[slot + 32u] = (float)hi[q];
                } else {
                    double *to = (double *)(rec + values_at);
                    if (j < n) to[slot] = lo[q];
                    if (j + 32u < n) to[slot + 32u] = hi[q];
                }
            }
        }
    }
}

extern "C" ff_cuda_records *ff_cuda_records_new(void) { return (ff_cuda_records *)calloc(1, sizeof(ff_cuda_records)); }

extern "C" void ff_cuda_records_free(ff_cuda_records *r)
{
    if (!r) return;
    cudaFree(r->d_stats);
    cudaFree(r->d_segment);
    cudaFree(r->d_place);
    cudaFree(r->d_size);
    cudaFree(r->d_at);
    cudaFreeHost(r->h_stats);
    cudaFreeHost(r->h_size);
    for (int f = 0; f < 2; f++) {
        cudaFree(r->d_bytes[f]);
        for (int set = 0; set < 2; set++) {
            cudaFreeHost(r->h_bytes[f][set]);
            free(r->h_at[f][set]);
        }
    }
    free(r);
}

/* Grows the per-row buffers to `rows` rows of `tiles` tiles. */
static rad_status reserve_rows(ff_cuda_records *r, uint32_t rows, uint32_t tiles)
{
    rad_status status = RAD_OK;
    if (rows > r->rows_capacity) {
        cudaFree(r->d_stats), cudaFree(r->d_segment), cudaFree(r->d_size), cudaFree(r->d_at);
        cudaFreeHost(r->h_stats), cudaFreeHost(r->h_size);
        r->d_stats = r->d_segment = NULL, r->d_size = r->d_at = NULL, r->h_stats = NULL, r->h_size = NULL;
        r->rows_capacity = 0;
        RAD_CUDA_TRY_RETURN(cudaMalloc(&r->d_stats, sizeof(row_stats) * rows));
        RAD_CUDA_TRY_RETURN(cudaMalloc(&r->d_segment, sizeof(row_stats) * rows * SEGMENTS_MAX));
        RAD_CUDA_TRY_RETURN(cudaMalloc(&r->d_size, sizeof(uint64_t) * rows));
        RAD_CUDA_TRY_RETURN(cudaMalloc(&r->d_at, sizeof(uint64_t) * (rows + 1)));
        RAD_CUDA_TRY_RETURN(cudaMallocHost(&r->h_stats, sizeof(row_stats) * rows));
        RAD_CUDA_TRY_RETURN(cudaMallocHost(&r->h_size, sizeof(uint64_t) * (rows + 1)));
        r->rows_capacity = rows;
    }
    if ((size_t)rows * tiles > r->tiles_capacity) {
        cudaFree(r->d_place);
        r->d_place = NULL;
        r->tiles_capacity = 0;
        RAD_CUDA_TRY_RETURN(cudaMalloc(&r->d_place, sizeof(uint32_t) * rows * tiles));
        r->tiles_capacity = (size_t)rows * tiles;
    }
    return status;
}

/* Encodes `rows` rows of d_rows as `element` records into h_bytes[f][set]
 * / h_at[f][set] and points *view at them. */
static rad_status encode(ff_cuda_records *r, int f, int set, const double *d_rows, uint32_t n, uint32_t rows,
                         uint32_t element, ff_records *view)
{
    rad_status status = RAD_OK;
    const uint32_t warps_per_block = 8;
    const unsigned blocks = (rows + warps_per_block - 1) / warps_per_block;
    if (rows + 1 > r->h_at_rows[f][set]) {
        free(r->h_at[f][set]);
        r->h_at_rows[f][set] = 0;
        if (!(r->h_at[f][set] = (uint64_t *)malloc(sizeof(uint64_t) * (rows + 1)))) {
            rad_error("out of memory for %u record offsets", rows);
            return RAD_ERR_NOMEM;
        }
        r->h_at_rows[f][set] = rows + 1;
    }
    tiles_kernel<<<blocks, 32 * warps_per_block>>>(d_rows, n, rows, element, r->d_place, r->d_size);
    RAD_CUDA_TRY_RETURN(cudaGetLastError());
    RAD_CUDA_TRY_RETURN(cudaMemcpy(r->h_size, r->d_size, sizeof(uint64_t) * rows, cudaMemcpyDeviceToHost));
    uint64_t *at = r->h_at[f][set];
    at[0] = 0;
    for (uint32_t k = 0; k < rows; k++) at[k + 1] = at[k] + r->h_size[k];
    uint64_t bytes = at[rows];
    if (bytes > r->bytes_capacity[f]) {
        cudaFree(r->d_bytes[f]);
        r->d_bytes[f] = NULL;
        r->bytes_capacity[f] = 0;
        RAD_CUDA_TRY_RETURN(cudaMalloc(&r->d_bytes[f], bytes));
        r->bytes_capacity[f] = bytes;
    }
    if (bytes > r->host_capacity[f][set]) {
        cudaFreeHost(r->h_bytes[f][set]);
        r->h_bytes[f][set] = NULL;
        r->host_capacity[f][set] = 0;
        RAD_CUDA_TRY_RETURN(cudaMallocHost(&r->h_bytes[f][set], bytes));
        r->host_capacity[f][set] = bytes;
    }
    RAD_CUDA_TRY_RETURN(cudaMemcpy(r->d_at, at, sizeof(uint64_t) * (rows + 1), cudaMemcpyHostToDevice));
    RAD_CUDA_TRY_RETURN(cudaMemset(r->d_bytes[f], 0, bytes));
    records_kernel<<<blocks, 32 * warps_per_block>>>(d_rows, n, rows, element, r->d_place, r->d_at, r->d_bytes[f]);
    RAD_CUDA_TRY_RETURN(cudaGetLastError());
    RAD_CUDA_TRY_RETURN(cudaMemcpy(r->h_bytes[f][set], r->d_bytes[f], bytes, cudaMemcpyDeviceToHost));
    view->bytes = r->h_bytes[f][set];
    view->at = at;
    view->rows = rows;
    return status;
}

extern "C" rad_status ff_cuda_records_make(ff_cuda_records *r, double *d_values, double *d_errors,
                                           const double *d_area, uint32_t n, uint32_t row_begin, uint32_t rows,
                                           uint32_t element, ff_records *values, ff_records *errors,
                                           ff_rows_summary *summary)
{
    rad_status status = RAD_OK;
    if (rows == 0) return RAD_OK;
    const uint32_t tiles = (n + TILE - 1u) / TILE;
    if ((status = reserve_rows(r, rows, tiles)) != RAD_OK) return status;
    uint32_t segments = (n + 1023u) / 1024u;
    if (segments > SEGMENTS_MAX) segments = SEGMENTS_MAX;
    if (segments < 1u) segments = 1u;
    uint32_t cols = ((n + segments - 1u) / segments + 31u) / 32u * 32u;
    segments = (n + cols - 1u) / cols;
    finish_kernel<<<dim3((rows + 31u) / 32u, segments), 32>>>(d_values, d_errors, d_area, n, rows, cols,
                                                                r->d_segment);
    RAD_CUDA_TRY_RETURN(cudaGetLastError());
    combine_kernel<<<(rows + 127u) / 128u, 128>>>(r->d_segment, rows, segments, r->d_stats);
    RAD_CUDA_TRY_RETURN(cudaGetLastError());
    RAD_CUDA_TRY_RETURN(cudaMemcpy(r->h_stats, r->d_stats, sizeof(row_stats) * rows, cudaMemcpyDeviceToHost));
    for (uint32_t k = 0; k < rows; k++) {
        const row_stats *s = &r->h_stats[k];
        ff_rows_summary one = {};
        one.row_sum_min = one.row_sum_max = one.row_sum_total = s->sum;
        one.rows = 1;
        one.error_sum = s->error_sum;
        one.error_relative_sum = s->error_relative_sum;
        one.error_max = s->error_max;
        one.error_max_value = s->error_max_value;
        one.error_count = s->error_count;
        one.error_max_row = row_begin + k;
        one.error_max_column = s->error_max_column;
        ff_rows_summary_merge(summary, &one);
    }
    const int set = (int)(r->calls++ % 2u);
    if ((status = encode(r, 0, set, d_values, n, rows, element, values)) != RAD_OK) return status;
    if (errors && d_errors) status = encode(r, 1, set, d_errors, n, rows, RAD_ELEMENT_F32, errors);
    return status;
}
