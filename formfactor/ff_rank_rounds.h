/* ff_rank_rounds.h - a hierarchy's rounds shared by the ranks (issue 27,
 * item 4).
 *
 * Rank 0 refines: it holds the elements and the links and decides every
 * round. Each round's pairs are cut into chunks dealt to the ranks in
 * turn (ff_comm_scatter_cyclic); every rank, rank 0 too, computes its
 * chunks on its own backend (one GPU a rank where there are GPUs) with
 * ff_round_compute, and rank 0 collects the outcomes in their places. A pair's outcome depends on the
 * pair alone, so the links are the same bytes for any rank count.
 *
 *     rank 0:                                   the other ranks:
 *     ff_rank_rounds_open(comm, &R);            ff_rank_rounds_serve(comm, backend, state);
 *     ... ff_rank_rounds_compute(R, &work, ...) per round ...
 *     ff_rank_rounds_close(comm, R);            (serve returns)
 *
 * A round of more than 4 M pairs goes in pieces (RANK_PIECE; RAD_MPI_PIECE
 * in the environment sets it for tests), each exchanged as a round.
 * Per round, rank 0 sends the elements made since the last round (192 +
 * 4 bytes each), the cluster tree once, and each rank its chunks of jobs
 * (16 bytes a pair); each rank returns its outcomes (80 bytes an element
 * pair, 40 a cluster pair) and its counters. Every collective is entered
 * by every rank whatever failed, so that the ranks leave together. */
#ifndef FF_RANK_ROUNDS_H
#define FF_RANK_ROUNDS_H

#include "ff_backend.h"
#include "ff_comm.h"
#include "ff_round.h"
#include "rad_status.h"

typedef struct ff_rank_rounds ff_rank_rounds;

/* Rank 0, with the others in ff_rank_rounds_serve. RAD_ERR_NOMEM (logged). */
rad_status ff_rank_rounds_open(ff_comm *comm, ff_rank_rounds **out);

/* Rank 0: ff_round_compute of w shared by the ranks. w->patches and
 * w->keys hold element_count elements, the earlier rounds' ones unchanged;
 * w->view's tree is the same on every call. The counters are summed over
 * the ranks; *cluster_seconds is the slowest rank's. Any rank's failure
 * is returned. */
rad_status ff_rank_rounds_compute(ff_rank_rounds *R, const ff_round_work *w, size_t element_count,
                                  ff_counters *counters, double *cluster_seconds);

/* Rank 0's view of the exchanges so far (a round, or each piece of a
 * large one), in seconds summed over them: the
 * elements, the tree and the chunks sent (with the ranks' agreement that
 * they have room), its own chunks computed, the slowest and the fastest
 * rank's (what the GPUs bound), and the outcomes collected (waiting for
 * the slowest, then the copies). */
typedef struct ff_rank_times {
    double send, own, slowest, fastest, collect;
    uint64_t rounds; /* exchanges */
} ff_rank_times;
void ff_rank_rounds_times_get(const ff_rank_rounds *R, ff_rank_times *out);

/* Rank 0: ends the others' ff_rank_rounds_serve and frees R (which may
 * be NULL: a run that failed before or while opening must end them too). */
void ff_rank_rounds_close(ff_comm *comm, ff_rank_rounds *R);

/* The other ranks: computes their chunks of every round with `backend`
 * until rank 0 closes. The first failure of its own (the others' are rank
 * 0's to report). */
rad_status ff_rank_rounds_serve(ff_comm *comm, const ff_backend *backend, void *backend_state);

#endif
