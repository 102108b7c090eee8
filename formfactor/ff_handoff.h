/* ff_handoff.h - one rank's rows handed, as encoded records, to a consumer
 * that runs on a background thread while the rank computes its next rows
 * (formfactor --radiosity: solve's matrix decodes them, ff_solve.h). One
 * batch is in flight at a time, as with the file's writer (ff_writer.h):
 * submit waits for the previous batch first, so a batch's buffers stay in
 * use until the next submit (or wait, or close) returns - two buffers in
 * turn keep the computation going.
 *
 *     ff_handoff *h;
 *     ff_handoff_open(consume, user, &h);
 *     for each round: ff_handoff_submit(h, row, rows, records, at);
 *     status = ff_handoff_wait(h);     // every batch consumed (the first failure)
 *     ff_handoff_close(h);
 *
 * A failed batch is remembered (the consumer logs why) and the later ones
 * are skipped; submit, wait and close return it from then on. */
#ifndef FF_HANDOFF_H
#define FF_HANDOFF_H

#include <stdint.h>

#include "rad_status.h"

/* Rows [row, row + rows); record k: at[k + 1] - at[k] bytes at
 * records + at[k] - at[0]. */
typedef rad_status (*ff_handoff_consume)(void *user, uint32_t row, uint32_t rows, const unsigned char *records,
                                         const uint64_t *at);

typedef struct ff_handoff ff_handoff;

rad_status ff_handoff_open(ff_handoff_consume consume, void *user, ff_handoff **out_handoff);
rad_status ff_handoff_submit(ff_handoff *handoff, uint32_t row, uint32_t rows, const unsigned char *records,
                             const uint64_t *at);
rad_status ff_handoff_wait(ff_handoff *handoff);
/* Seconds the consumer ran, all batches together (mostly behind the computation). */
double ff_handoff_seconds(const ff_handoff *handoff);
rad_status ff_handoff_close(ff_handoff *handoff); /* waits first; NULL is fine */

#endif
