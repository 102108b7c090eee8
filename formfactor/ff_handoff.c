/* ff_handoff.c - rows to a consumer on a background thread (ff_handoff.h). */
#include "ff_handoff.h"

#include <pthread.h>
#include <stdlib.h>

#include "rad_clock.h"
#include "rad_log.h"

struct ff_handoff {
    ff_handoff_consume consume;
    void *user;
    pthread_t thread;
    pthread_mutex_t lock;
    pthread_cond_t changed;
    int pending, busy, quit;  /* a batch waiting; one being consumed; the thread should end */
    uint32_t row, rows;       /* the batch */
    const unsigned char *records;
    const uint64_t *at;
    rad_status status;        /* the first failure */
    double seconds;
};

static void *consumer(void *arg)
{
    ff_handoff *h = arg;
    pthread_mutex_lock(&h->lock);
    for (;;) {
        while (!h->pending && !h->quit) pthread_cond_wait(&h->changed, &h->lock);
        if (!h->pending) break; /* quit, nothing left */
        h->pending = 0;
        h->busy = 1;
        int skip = h->status != RAD_OK;
        uint32_t row = h->row, rows = h->rows;
        const unsigned char *records = h->records;
        const uint64_t *at = h->at;
        pthread_mutex_unlock(&h->lock);
        double t0 = rad_clock_seconds();
        rad_status st = skip ? RAD_OK : h->consume(h->user, row, rows, records, at);
        double t = rad_clock_seconds() - t0;
        pthread_mutex_lock(&h->lock);
        if (h->status == RAD_OK) h->status = st;
        h->seconds += t;
        h->busy = 0;
        pthread_cond_broadcast(&h->changed);
    }
    pthread_mutex_unlock(&h->lock);
    return NULL;
}

rad_status ff_handoff_open(ff_handoff_consume consume, void *user, ff_handoff **out_handoff)
{
    *out_handoff = NULL;
    ff_handoff *h = calloc(1, sizeof *h);
    if (!h) {
        rad_error("out of memory");
        return RAD_ERR_NOMEM;
    }
    h->consume = consume;
    h->user = user;
    pthread_mutex_init(&h->lock, NULL);
    pthread_cond_init(&h->changed, NULL);
    if (pthread_create(&h->thread, NULL, consumer, h) != 0) {
        rad_error("cannot start a thread to hand the rows over");
        pthread_mutex_destroy(&h->lock);
        pthread_cond_destroy(&h->changed);
        free(h);
        return RAD_ERR_NOMEM;
    }
    *out_handoff = h;
    return RAD_OK;
}

/* Waits, the lock held, until no batch is waiting or being consumed. */
static void drain(ff_handoff *h)
{
    while (h->pending || h->busy) pthread_cond_wait(&h->changed, &h->lock);
}

rad_status ff_handoff_submit(ff_handoff *h, uint32_t row, uint32_t rows, const unsigned char *records,
                             const uint64_t *at)
{
    pthread_mutex_lock(&h->lock);
    drain(h);
    rad_status status = h->status;
    if (status == RAD_OK && rows > 0) {
        h->row = row;
        h->rows = rows;
        h->records = records;
        h->at = at;
        h->pending = 1;
        pthread_cond_broadcast(&h->changed);
    }
    pthread_mutex_unlock(&h->lock);
    return status;
}

rad_status ff_handoff_wait(ff_handoff *h)
{
    pthread_mutex_lock(&h->lock);
    drain(h);
    rad_status status = h->status;
    pthread_mutex_unlock(&h->lock);
    return status;
}

double ff_handoff_seconds(const ff_handoff *h) { return h->seconds; }

rad_status ff_handoff_close(ff_handoff *h)
{
    if (!h) return RAD_OK;
    pthread_mutex_lock(&h->lock);
    drain(h);
    h->quit = 1;
    pthread_cond_broadcast(&h->changed);
    rad_status status = h->status;
    pthread_mutex_unlock(&h->lock);
    pthread_join(h->thread, NULL);
    pthread_mutex_destroy(&h->lock);
    pthread_cond_destroy(&h->changed);
    free(h);
    return status;
}
