/* ff_round.c - one round's pairs through a backend (ff_round.h). */
#include "ff_round.h"

#include <pthread.h>

#include "rad_clock.h"

typedef struct element_call {
    const ff_round_work *w;
    ff_counters counters;
    rad_status status;
} element_call;

static void *element_pairs(void *arg)
{
    element_call *c = arg;
    const ff_round_work *w = c->w;
    c->status = w->backend->compute_pairs(w->backend_state, w->patches, w->keys, w->pairs, w->pair_count, w->out,
                                          &c->counters);
    return NULL;
}

rad_status ff_round_compute(const ff_round_work *w, ff_counters *counters, double *cluster_seconds)
{
    /* On a GPU the element pairs' call runs on a thread of its own: the
     * two calls' kernels then queue on the device one after the other,
     * the host's copies and setup beside them. On the CPU, in turn. */
    element_call call = {w, {0}, RAD_OK};
    pthread_t thread;
    const int overlap = w->pair_count && w->cluster_count && w->backend != &ff_backend_cpu &&
                        pthread_create(&thread, NULL, element_pairs, &call) == 0;
    if (w->pair_count && !overlap) element_pairs(&call);
    rad_status cst = RAD_OK;
    double seconds = 0;
    if (w->cluster_count) {
        const long long t0 = rad_clock_ns();
        cst = w->backend->cluster_draws(w->backend_state, w->view, w->cluster_pairs, w->cluster_count,
                                        w->cluster_out);
        seconds = 1e-9 * (double)(rad_clock_ns() - t0);
    }
    if (overlap) pthread_join(thread, NULL);
    ff_counters_add(counters, &call.counters);
    counters->visibility_seconds += seconds;
    *cluster_seconds = seconds;
    return call.status != RAD_OK ? call.status : cst;
}
