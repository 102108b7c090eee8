/* rad_cpu.c - the cores one rank may use (rad_cpu.h). */
#define _GNU_SOURCE /* sched_getaffinity */
#include "rad_cpu.h"

#include <sched.h>
#include <unistd.h>

int rad_cpu_threads_per_rank(int threads, int node_ranks)
{
    if (threads > 0) return threads;
    long cores = sysconf(_SC_NPROCESSORS_ONLN);
    long t = cores / (node_ranks > 0 ? node_ranks : 1);
#ifdef CPU_COUNT
    cpu_set_t mask;
    if (sched_getaffinity(0, sizeof mask, &mask) == 0 && CPU_COUNT(&mask) < t) t = CPU_COUNT(&mask);
#endif
    return t > 0 ? (int)t : 1;
}
