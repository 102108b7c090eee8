/* ff_cuda_none.c - builds without nvcc: no GPUs. */
#include "ff_cuda.h"

int ff_cuda_device_count(void) { return 0; }
