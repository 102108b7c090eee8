/* rad_cuda.h - starting CUDA early, shared by formfactor and solve
 * (library radcuda, core/cuda/, built only where nvcc is found; not part
 * of radcore, which has no CUDA). No CUDA types here: callers are plain C.
 *
 * Starting CUDA (driver, then the device's primary context) takes
 * 0.2-0.35 s, as long as everything else of a paper-size run. A stage
 * calls rad_cuda_prestart first thing: a thread creates the context of the
 * device it will use while the stage does other work (MPI starts, the
 * scene or the matrix loads). rad_cuda_device_count waits for that thread,
 * and so does rad_cuda_prestart_join, which the stage calls before it
 * returns. Nothing is reported from the thread: a failure there only
 * means the stage starts CUDA itself later and reports what it finds.
 *
 * The stages wrap these in their own C interfaces (formfactor's ff_cuda.h,
 * solve's gpu.h), whose builds without CUDA have stubs instead.
 */
#ifndef RAD_CUDA_H
#define RAD_CUDA_H

/* Starts the thread (once; later calls while it runs do nothing). The
 * device is rank mod the device count, as the driver numbers them (an MPI
 * rank's device; 0 for a single process). */
void rad_cuda_prestart(int rank);
void rad_cuda_prestart_join(void);

/* CUDA devices usable by this process; 0 with no GPU or no driver (never
 * an error: --backend auto then picks the CPU). Waits for the prestart
 * thread and returns what it found, if one ran. */
int rad_cuda_device_count(void);

#endif
