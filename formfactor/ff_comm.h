/* ff_comm.h - everything formfactor needs from MPI, and nothing else.
 *
 * The only header of the stage that stands between the numerics and MPI:
 * ff_comm_mpi.c is the only file that includes <mpi.h>. A plain
 * `./formfactor` runs solo: one rank, without initialising MPI.
 *
 * Failure protocol: every phase ends with ff_comm_agree(), which returns the
 * same (worst) status on every rank, so ranks leave together and main()
 * alone exits. No MPI_Abort in the call chain.
 */
#ifndef FF_COMM_H
#define FF_COMM_H

#include <stddef.h>
#include <stdint.h>

#include "rad_status.h"

typedef struct ff_comm ff_comm; /* opaque */

rad_status ff_comm_init(int *argc, char ***argv, ff_comm **out_comm);

void ff_comm_finalize(ff_comm *comm);

int ff_comm_rank(const ff_comm *comm);
int ff_comm_size(const ff_comm *comm);
int ff_comm_node_size(const ff_comm *comm); /* ranks sharing this node */

/* Collective: the worst (largest) status over all ranks. */
rad_status ff_comm_agree(ff_comm *comm, rad_status local);
/* Collective: max of a uint64 over all ranks. */
uint64_t ff_comm_max_u64(ff_comm *comm, uint64_t value);
/* Collective: the sum of `value` over the ranks below this one; *total
 * gets the sum over all ranks. */
uint64_t ff_comm_exscan_u64(ff_comm *comm, uint64_t value, uint64_t *total);
/* Collective: rank 0's bytes (at most INT_MAX) to every rank, the others
 * sleeping between looks instead of spinning on a core: for a wait that
 * may last seconds while rank 0 works on its threads. */
void ff_comm_broadcast_idle(ff_comm *comm, void *data, size_t bytes);
/* Collective: root's bytes to every rank (any size). */
void ff_comm_broadcast(ff_comm *comm, void *data, size_t bytes, int root);
/* The cyclic cut of `count` items among the ranks: chunk c (`chunk`
 * items, the last maybe fewer) goes to rank c % size; rank's share. */
uint64_t ff_comm_cyclic_count(uint64_t count, uint32_t chunk, int rank, int size);
/* Where a rank's chunks of the cyclic cut land: `bytes` of its own. Where
 * all ranks share one node, an MPI shared window, so that rank 0 copies
 * chunks straight into and out of every rank's area (no messages); else
 * each rank's own memory, the chunks sent as messages (also where the
 * environment has RAD_MPI_MESSAGES=1: tests of that path on one node).
 * open and close are collective; a rank's area may differ in size from
 * the others'. */
typedef struct ff_comm_area ff_comm_area;
rad_status ff_comm_area_open(ff_comm *comm, size_t bytes, ff_comm_area **out);
void *ff_comm_area_data(ff_comm_area *area);
int ff_comm_area_shared(const ff_comm_area *area); /* 1: a shared window, 0: messages */
void ff_comm_area_close(ff_comm_area *area);
/* Collective: rank 0's `count` items (`item_bytes` each) cut cyclically,
 * each rank's chunks back to back into its area at byte offset at[rank]
 * (every rank passes every rank's offsets, the same count, at most
 * INT_MAX, and chunk). RAD_ERR_INVALID, RAD_ERR_NOMEM or RAD_ERR_BACKEND
 * (logged) on failure. */
rad_status ff_comm_scatter_cyclic(ff_comm *comm, const void *send, uint64_t count, uint32_t chunk, size_t item_bytes,
                                  ff_comm_area *area, const size_t *at);
/* Collective, the other way: each rank's chunks (its area at at[rank])
 * into their places in rank 0's `recv`. */
rad_status ff_comm_gather_cyclic(ff_comm *comm, ff_comm_area *area, const size_t *at, uint64_t count, uint32_t chunk,
                                 size_t item_bytes, void *recv);
/* Collective: every rank's `bytes` into root's `out` (size * bytes), rank order. */
void ff_comm_gather(ff_comm *comm, const void *data, size_t bytes, void *out, int root);
/* Collective: variable-sized blocks of uint64 gathered on root in rank order. */
void ff_comm_gather_u64v(ff_comm *comm, const uint64_t *data, uint64_t count, uint64_t *out, int root);

/* A counter of rows done, kept on rank 0, that every rank adds to without
 * waiting for the others (one-sided), so that rank 0's progress lines
 * count all ranks. open and close are collective; without them (or solo)
 * add and read work on a local counter. */
void ff_comm_progress_open(ff_comm *comm);
void ff_comm_progress_add(ff_comm *comm, uint64_t rows);
uint64_t ff_comm_progress_read(ff_comm *comm); /* rank 0 */
void ff_comm_progress_close(ff_comm *comm);

/* Point to point, both at once: `send_count` doubles to rank `dest` and
 * `recv_count` doubles from rank `source` (each at most FF_COMM_MAX_DOUBLES). */
#define FF_COMM_MAX_DOUBLES ((size_t)1 << 27)
rad_status ff_comm_sendrecv(ff_comm *comm, int dest, const double *send, size_t send_count, int source, double *recv,
                            size_t recv_count);

/* Files: none here. Every rank opens the output itself and writes its
 * own byte ranges (ff_writer.h), which MPI-IO's collective writes had
 * serialised. */

#endif
