/* rad_mpi.h - starting and ending MPI, the part formfactor's and solve's
 * MPI modules (formfactor/ff_comm_mpi.c, solve/comm_mpi.c) share; with
 * them, the only code that includes mpi.h. Built as the static library
 * radmpi where MPI is found; not part of radcore (which has no MPI).
 *
 *     rad_mpi_start mpi;
 *     if (rad_mpi_init(&argc, &argv, &mpi) != RAD_OK) return ...;
 *     ... mpi.solo ? one process : MPI_COMM_WORLD with mpi.rank, mpi.size ...
 *     rad_mpi_finalize(&mpi, 1);
 *
 * A process that no MPI launcher started (none of OMPI_COMM_WORLD_SIZE,
 * PMIX_RANK, PMI_RANK, PMI_SIZE in its environment: a plain `./solve`)
 * runs alone and never calls MPI_Init: an Open MPI singleton init costs
 * 0.3 s. */
#ifndef RAD_MPI_H
#define RAD_MPI_H

#include "rad_status.h"

typedef struct rad_mpi_start {
    int solo;           /* 1: no launcher, no MPI; rank 0 of 1 */
    int we_initialized; /* MPI_Init_thread was ours (so is MPI_Finalize) */
    int rank, size;     /* in MPI_COMM_WORLD */
} rad_mpi_start;

/* Did an MPI launcher start this process? */
int rad_mpi_launched(void);
/* This process's rank as its launcher told it, readable before
 * rad_mpi_init; 0 when started alone. */
int rad_mpi_launcher_rank(void);
/* Starts MPI (MPI_THREAD_FUNNELED: the main thread calls MPI, between or
 * inside OpenMP regions) unless the process runs alone or MPI is already
 * up; errors on MPI_COMM_WORLD return instead of aborting. RAD_ERR_BACKEND
 * (logged) when MPI_Init fails. */
rad_status rad_mpi_init(int *argc, char ***argv, rad_mpi_start *out);
/* Ends what rad_mpi_init started; with `barrier`, every rank waits for the
 * others first (mpirun ends the job as soon as one rank exits non-zero,
 * and rank 0 may still be writing its last words). */
void rad_mpi_finalize(const rad_mpi_start *start, int barrier);

#endif
