/* ff_cuda_device.cu - CUDA device discovery. No MPI here, only CUDA. */
#include <cuda_runtime.h>

extern "C" {
#include "ff_cuda.h"
}

extern "C" int ff_cuda_device_count(void)
{
    int count = 0;
    if (cudaGetDeviceCount(&count) != cudaSuccess) {
        cudaGetLastError(); /* clear the sticky "no device" error */
        return 0;
    }
    return count;
}
