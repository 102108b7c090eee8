/* cuda_start_cost.cu - what starting and ending CUDA costs on this machine
 * (issue 14's fixed costs; docs/performance.md). Prints the seconds of
 * cudaGetDeviceCount (driver start), cudaSetDevice + cudaFree(0) (the
 * primary context), a 64 MiB page-locked allocation and its release, then
 * ends by returning from main (the runtime tears the context down) or, with
 * the argument "_exit", by _exit (it does not); time the process from
 * outside to see the difference. Build: nvcc -O2 -o cuda_start_cost
 * tools/cuda_start_cost.cu */
#include <cuda_runtime.h>
#include <stdio.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

static double now(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

int main(int argc, char **argv)
{
    double t0 = now();
    int count = 0;
    cudaError_t e = cudaGetDeviceCount(&count);
    double t1 = now();
    if (e != cudaSuccess || count == 0) {
        printf("no CUDA device (%s)\n", cudaGetErrorString(e));
        return 1;
    }
    cudaSetDevice(0);
    cudaFree(0);
    double t2 = now();
    void *p = NULL;
    cudaMallocHost(&p, (size_t)64 << 20);
    memset(p, 0, (size_t)64 << 20);
    double t3 = now();
    cudaFreeHost(p);
    double t4 = now();
    printf("driver %.3f s, context %.3f s, 64 MiB page-locked %.3f s + free %.3f s\n", t1 - t0, t2 - t1, t3 - t2,
           t4 - t3);
    fflush(stdout);
    if (argc > 1 && strcmp(argv[1], "_exit") == 0) _exit(0);
    return 0;
}
