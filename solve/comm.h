/* comm.h - everything solve needs from MPI, and nothing else.
 *
 * The only header of the stage between the numerics and MPI: comm_mpi.c
 * is the only file that includes <mpi.h>; comm_none.c is its twin for a
 * build without MPI (one process). A plain `./solve` (no launcher) runs
 * alone without initialising MPI, as formfactor does.
 *
 * Rows: under `mpirun -n K`, rank r holds and updates the contiguous rows
 * [row_begin[r], row_begin[r + 1]) of F (solve_comm_set_rows; stage.c
 * splits them, matrix.h). Every rank keeps whole vectors (B, and CG's
 * search directions) of N values: after each update a rank's rows go to
 * every other rank (solve_comm_gather_rows, MPI_Allgatherv).
 *
 * A NULL solve_comm is one process alone: every call below is then the
 * identity (a sum of one value is that value, bit for bit), so the
 * numerics call them unconditionally and give today's bits with one rank.
 *
 * Failure protocol: a phase that can fail on one rank ends with
 * solve_comm_agree, which gives every rank the same (worst) status, so
 * ranks leave together and only main exits. No MPI_Abort.
 */
#ifndef SOLVE_COMM_H
#define SOLVE_COMM_H

#include <stddef.h>
#include <stdint.h>

#include "rad_status.h"

typedef struct solve_comm solve_comm; /* opaque */

/* Starts MPI when a launcher started this process (else one rank, no MPI).
 * *out_comm is freed by solve_comm_finalize (which ends MPI). */
rad_status solve_comm_init(int *argc, char ***argv, solve_comm **out_comm);
void solve_comm_finalize(solve_comm *comm); /* NULL is fine */

int solve_comm_rank(const solve_comm *comm); /* 0 for NULL */
int solve_comm_size(const solve_comm *comm); /* 1 for NULL */
/* Ranks on this process's node (sharing its memory and cores); 1 alone. */
int solve_comm_node_size(const solve_comm *comm);

/* Collective: the worst (largest) status over all ranks. */
rad_status solve_comm_agree(solve_comm *comm, rad_status local);
/* Collective, in place: values[k] summed over the ranks (one MPI_Allreduce). */
void solve_comm_sum(solve_comm *comm, double *values, size_t count);
/* Collective: the largest value over the ranks; NaN if any rank has NaN. */
double solve_comm_max(solve_comm *comm, double value);
/* Collective: every rank's `bytes` bytes into out (size x bytes, rank order). */
void solve_comm_allgather_bytes(solve_comm *comm, const void *mine, size_t bytes, void *out);

/* Collective: the row split, size + 1 ascending values from 0 to N (copied).
 * Only needed with more than one rank. */
rad_status solve_comm_set_rows(solve_comm *comm, const size_t *row_begin);
/* The row split given to solve_comm_set_rows (size + 1 values); NULL with one rank. */
const size_t *solve_comm_row_split(const solve_comm *comm);
/* Collective: each of the `count` vectors (N values each) receives every
 * rank's rows of it from that rank, all vectors in one MPI_Allgatherv.
 * Identity with one rank. */
rad_status solve_comm_gather_rows(solve_comm *comm, double *const *vectors, size_t count);
/* The same for another split of the vectors' entries (size + 1 ascending
 * values from 0 to their length, the same on every rank): rank r's are
 * [split[r], split[r + 1]). The GPU backend's partial sums travel so. */
rad_status solve_comm_gather_split(solve_comm *comm, const size_t *split, double *const *vectors, size_t count);

/* Collective: words_to[d] uint64 words from `send` (rank after rank, in
 * rank order) to rank d; *out_received (malloc'ed, the caller frees) gets
 * what every rank sent here, in rank order, *out_received_count words.
 * MPI_Alltoallv. With one rank: a copy of `send`. */
rad_status solve_comm_exchange(solve_comm *comm, const uint64_t *send, const uint64_t *words_to,
                               uint64_t **out_received, uint64_t *out_received_count);

#endif
