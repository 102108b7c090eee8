/* rad_cpu.h - the cores one process (one MPI rank) may use.
 *
 * Ranks that share a node share its cores: without a thread count each
 * rank's OpenMP would start a thread per core, K times too many. Both
 * formfactor and solve size their threads so. */
#ifndef RAD_CPU_H
#define RAD_CPU_H

/* The threads of one rank: `threads` where positive (--threads, or
 * OMP_NUM_THREADS), else the cores this process may run on (mpirun binds
 * ranks to cores by default), no more than its share of the node's
 * (node_ranks ranks on it); at least 1. */
int rad_cpu_threads_per_rank(int threads, int node_ranks);

#endif
