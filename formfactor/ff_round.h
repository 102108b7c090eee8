/* ff_round.h - one refinement round's pairs through a backend, on this
 * process: the element pairs (ff_backend.compute_pairs) and the pairs with
 * a cluster at an end (ff_backend.cluster_draws), the first on a thread of
 * its own beside the second where the backend is a GPU.
 *
 * ff_links.c calls it for a whole round; with several ranks, every rank
 * calls it for its block of the round (ff_rank_rounds.h). A pair's outcome
 * depends on the pair alone, not on the others in the call, so any cut of
 * a round gives the same outcomes. */
#ifndef FF_ROUND_H
#define FF_ROUND_H

#include <stddef.h>

#include "ff_backend.h"
#include "ff_counters.h"
#include "rad_status.h"

typedef struct ff_round_work {
    const ff_backend *backend;
    void *backend_state;
    const rad_ff_patch *patches; /* the elements (by element id) */
    const uint32_t *keys;        /* per element (ff_backend.compute_pairs) */
    const ff_cluster_view *view; /* the cluster tree and the same elements; NULL where cluster_count is 0 */
    const ff_pair_job *pairs;    /* element pairs */
    size_t pair_count;
    ff_pair_outcome *out;        /* pair_count */
    const ff_pair_job *cluster_pairs; /* pairs with a cluster at an end */
    size_t cluster_count;
    ff_cluster_drawn *cluster_out; /* cluster_count */
} ff_round_work;

/* Both kinds of w's pairs. *counters gets the element pairs' counters
 * added, and the cluster pairs' wall in visibility_seconds;
 * *cluster_seconds that wall alone. The first failure's status. */
rad_status ff_round_compute(const ff_round_work *w, ff_counters *counters, double *cluster_seconds);

#endif
