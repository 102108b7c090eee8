/* ff_cuda.h - the C-callable face of the CUDA code (ff_cuda_*.cu).
 * No CUDA types here: callers are plain C. The backend itself is
 * ff_backend_cuda (ff_backend.h). */
#ifndef FF_CUDA_H
#define FF_CUDA_H

/* Number of CUDA devices usable by this process; 0 when there is no GPU or
 * no driver (never an error: `--backend auto` then picks the CPU). */
int ff_cuda_device_count(void);

#endif
