/* rad_cuda_stage.h - large copies between pageable host memory and the
 * device through page-locked staging, for .cu files (it includes
 * cuda_runtime.h; C files never include it). Shared by formfactor's
 * rounds (ff_backend_cuda.cu) and solve's shaped solve (shaped_cuda.cu).
 *
 *     rad_cuda_stage g = {};                          // one per stream
 *     status = rad_cuda_stage_up(&g, d_jobs, jobs, bytes, stream);
 *     ... kernels on stream ...
 *     status = rad_cuda_stage_down(&g, out, d_out, bytes, stream);
 *     rad_cuda_stage_free(&g);
 *
 * The driver's own copies from and to pageable memory go through a small
 * buffer of its own, on the calling thread: 13-14 GB/s from the device and
 * 8 GB/s to it on an H200 host, and 4.3 GB/s in formfactor's rounds (3.9 GB
 * of a 10^5-face interior's outcomes: 0.9 s), against 55 GB/s page-locked.
 * Here two page-locked buffers of RAD_CUDA_STAGE_BYTES take turns: the
 * device fills (or empties) one while the host's threads (rad_mem_copy)
 * empty (or fill) the other, 30 GB/s on the same host. Copies of at most
 * one buffer, and any where no page-locked memory could be had, are the
 * driver's.
 */
#ifndef RAD_CUDA_STAGE_H
#define RAD_CUDA_STAGE_H

#include <cuda_runtime.h>
#include <stddef.h>

extern "C" {
#include "rad_status.h"
}

#define RAD_CUDA_STAGE_BYTES ((size_t)16 << 20)

/* Zero-initialised; buffers allocated at the first copy that needs them. */
typedef struct rad_cuda_stage {
    unsigned char *host; /* 2 * RAD_CUDA_STAGE_BYTES, page-locked; NULL until needed */
    cudaEvent_t done[2]; /* each buffer's last copy on the stream */
    int failed;          /* no page-locked memory: the driver's copies */
} rad_cuda_stage;

/* `bytes` from the device's src into the host's dst, landed when it
 * returns; an execution error of earlier work on the stream surfaces here
 * (logged, as RAD_CUDA_CHECK does). */
rad_status rad_cuda_stage_down(rad_cuda_stage *g, void *dst, const void *src, size_t bytes, cudaStream_t stream);

/* `bytes` from the host's src to the device's dst, ordered on the stream;
 * src may change once it returns. */
rad_status rad_cuda_stage_up(rad_cuda_stage *g, void *dst, const void *src, size_t bytes, cudaStream_t stream);

/* Waits for the buffers' last copies, then frees them; g zeroed. */
void rad_cuda_stage_free(rad_cuda_stage *g);

#endif
