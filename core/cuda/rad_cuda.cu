/* rad_cuda.cu - starting CUDA early on a thread (rad_cuda.h). Only CUDA
 * here. */
#include <cuda_runtime.h>
#include <pthread.h>

extern "C" {
#include "rad_cuda.h"
}

/* The prestart thread and what it found. */
static pthread_t prestart_thread;
static int prestart_running, prestart_rank;
static int prestart_devices = -1; /* -1: not asked */

static int count_devices(void)
{
    int count = 0;
    if (cudaGetDeviceCount(&count) != cudaSuccess) {
        cudaGetLastError(); /* clear the "no device" error */
        return 0;
    }
    return count;
}

static void *prestart_main(void *unused)
{
    (void)unused;
    int count = count_devices();
    /* cudaFree(0) creates the device's primary context, which the main
     * thread's cudaSetDevice then finds made. */
    if (count > 0 && cudaSetDevice(prestart_rank % count) == cudaSuccess) cudaFree(0);
    cudaGetLastError();
    prestart_devices = count;
    return NULL;
}

extern "C" void rad_cuda_prestart(int rank)
{
    if (prestart_running) return;
    prestart_rank = rank > 0 ? rank : 0;
    prestart_running = pthread_create(&prestart_thread, NULL, prestart_main, NULL) == 0;
}

extern "C" void rad_cuda_prestart_join(void)
{
    if (!prestart_running) return;
    pthread_join(prestart_thread, NULL);
    prestart_running = 0;
}

extern "C" int rad_cuda_device_count(void)
{
    rad_cuda_prestart_join();
    return prestart_devices >= 0 ? prestart_devices : count_devices();
}
