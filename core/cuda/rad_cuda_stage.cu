/* rad_cuda_stage.cu - page-locked staging of large copies (rad_cuda_stage.h). */
#include "rad_cuda_stage.h"

#include "rad_cuda_check.h"

extern "C" {
#include "rad_mem.h"
}

/* g's buffers where `bytes` are worth staging; 0 where they are not, or
 * where none can be had (the driver's copy then). */
static int stage_ready(rad_cuda_stage *g, size_t bytes)
{
    if (bytes <= RAD_CUDA_STAGE_BYTES || g->failed) return 0;
    if (g->host) return 1;
    void *host = NULL;
    cudaEvent_t done[2] = {NULL, NULL};
    if (cudaMallocHost(&host, 2 * RAD_CUDA_STAGE_BYTES) != cudaSuccess ||
        cudaEventCreateWithFlags(&done[0], cudaEventDisableTiming) != cudaSuccess ||
        cudaEventCreateWithFlags(&done[1], cudaEventDisableTiming) != cudaSuccess) {
        (void)cudaGetLastError(); /* not an error of the copy: it goes unstaged */
        if (host) cudaFreeHost(host);
        if (done[0]) cudaEventDestroy(done[0]);
        g->failed = 1;
        return 0;
    }
    g->host = (unsigned char *)host;
    g->done[0] = done[0], g->done[1] = done[1];
    return 1;
}

static size_t chunk_bytes(size_t bytes, size_t at)
{
    return bytes - at < RAD_CUDA_STAGE_BYTES ? bytes - at : RAD_CUDA_STAGE_BYTES;
}

rad_status rad_cuda_stage_down(rad_cuda_stage *g, void *dst, const void *src, size_t bytes, cudaStream_t stream)
{
    rad_status status = RAD_OK;
    const size_t chunks = (bytes + RAD_CUDA_STAGE_BYTES - 1) / RAD_CUDA_STAGE_BYTES;
    if (!stage_ready(g, bytes)) {
        RAD_CUDA_TRY(cudaMemcpyAsync(dst, src, bytes, cudaMemcpyDeviceToHost, stream));
        RAD_CUDA_TRY(cudaStreamSynchronize(stream));
        return RAD_OK;
    }
    /* chunk c into buffer c & 1 while the host empties chunk c - 1's */
    for (size_t c = 0; c <= chunks; c++) {
        if (c < chunks) { /* this thread emptied buffer c & 1 (chunk c - 2) before */
            const size_t at = c * RAD_CUDA_STAGE_BYTES;
            RAD_CUDA_TRY(cudaMemcpyAsync(g->host + (c & 1) * RAD_CUDA_STAGE_BYTES, (const unsigned char *)src + at,
                                         chunk_bytes(bytes, at), cudaMemcpyDeviceToHost, stream));
            RAD_CUDA_TRY(cudaEventRecord(g->done[c & 1], stream));
        }
        if (c > 0) {
            const size_t at = (c - 1) * RAD_CUDA_STAGE_BYTES;
            RAD_CUDA_TRY(cudaEventSynchronize(g->done[(c - 1) & 1]));
            rad_mem_copy((unsigned char *)dst + at, g->host + ((c - 1) & 1) * RAD_CUDA_STAGE_BYTES,
                         chunk_bytes(bytes, at), 0);
        }
    }
done:
    return status;
}

rad_status rad_cuda_stage_up(rad_cuda_stage *g, void *dst, const void *src, size_t bytes, cudaStream_t stream)
{
    rad_status status = RAD_OK;
    if (!stage_ready(g, bytes)) {
        RAD_CUDA_TRY(cudaMemcpyAsync(dst, src, bytes, cudaMemcpyHostToDevice, stream));
        return RAD_OK;
    }
    for (size_t at = 0, c = 0; at < bytes; at += RAD_CUDA_STAGE_BYTES, c++) {
        unsigned char *buffer = g->host + (c & 1) * RAD_CUDA_STAGE_BYTES;
        RAD_CUDA_TRY(cudaEventSynchronize(g->done[c & 1])); /* its last copy, either way, done */
        rad_mem_copy(buffer, (const unsigned char *)src + at, chunk_bytes(bytes, at), 0);
        RAD_CUDA_TRY(cudaMemcpyAsync((unsigned char *)dst + at, buffer, chunk_bytes(bytes, at), cudaMemcpyHostToDevice,
                                     stream));
        RAD_CUDA_TRY(cudaEventRecord(g->done[c & 1], stream));
    }
done:
    return status;
}

void rad_cuda_stage_free(rad_cuda_stage *g)
{
    if (g->host) {
        cudaEventSynchronize(g->done[0]);
        cudaEventSynchronize(g->done[1]);
        cudaFreeHost(g->host);
        cudaEventDestroy(g->done[0]);
        cudaEventDestroy(g->done[1]);
    }
    *g = rad_cuda_stage{};
}
