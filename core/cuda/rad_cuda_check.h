/* rad_cuda_check.h - the one check of a CUDA runtime call, for .cu files
 * (it includes cuda_runtime.h; C files never include it).
 *
 *     rad_status status = RAD_OK;
 *     RAD_CUDA_TRY(cudaMalloc(&p, bytes));   // on failure: status set, goto done
 *     ...
 * done:
 *     cudaFree(p);
 *     return status;
 *
 * A failed call is logged once, where it failed: "cuda: CALL (FILE:LINE):
 * CUDA's message". Its status is RAD_ERR_NOMEM when CUDA ran out of
 * memory, RAD_ERR_BACKEND otherwise.
 */
#ifndef RAD_CUDA_CHECK_H
#define RAD_CUDA_CHECK_H

#include <cuda_runtime.h>
#include <string.h>

extern "C" {
#include "rad_log.h"
#include "rad_status.h"
}

/* RAD_OK for cudaSuccess; otherwise logs what (the call's text) at
 * file:line (the file's name without its folders) and returns the status. */
static inline rad_status rad_cuda_check(cudaError_t err, const char *what, const char *file, int line)
{
    if (err == cudaSuccess) return RAD_OK;
    const char *slash = strrchr(file, '/');
    rad_error("cuda: %s (%s:%d): %s", what, slash ? slash + 1 : file, line, cudaGetErrorString(err));
    return err == cudaErrorMemoryAllocation ? RAD_ERR_NOMEM : RAD_ERR_BACKEND;
}

#define RAD_CUDA_CHECK(call) rad_cuda_check((call), #call, __FILE__, __LINE__)

/* Sets the caller's `status`; on failure jumps to its `done` label. */
#define RAD_CUDA_TRY(call)                                         \
    do {                                                           \
        if ((status = RAD_CUDA_CHECK(call)) != RAD_OK) goto done;  \
    } while (0)

/* Sets the caller's `status`; on failure returns it. */
#define RAD_CUDA_TRY_RETURN(call)                                  \
    do {                                                           \
        if ((status = RAD_CUDA_CHECK(call)) != RAD_OK) return status; \
    } while (0)

#endif
