/* ff_cuda.h - the C-callable face of the CUDA code (ff_cuda_*.cu).
 * No CUDA types here: callers are plain C. The backend itself is
 * ff_backend_cuda (ff_backend.h). */
#ifndef FF_CUDA_H
#define FF_CUDA_H

/* Number of CUDA devices usable by this process; 0 when there is no GPU or
 * no driver (never an error: `--backend auto` then picks the CPU). */
int ff_cuda_device_count(void);

/* Starting CUDA (driver, then the device's primary context) takes about
 * 0.35 s, as long as everything else of a paper-size run. main() calls
 * ff_cuda_prestart first thing: a thread creates the context of the
 * device rank `rank` will use (rank mod devices, as the driver picks it)
 * while MPI starts and the scene loads. ff_cuda_device_count and the CUDA
 * backend wait for it; ff_cuda_prestart_join (before main returns) too.
 * Nothing is reported from the thread: a failure there only means the
 * backend starts CUDA itself later and reports what it finds. */
void ff_cuda_prestart(int rank);
void ff_cuda_prestart_join(void);

#endif
