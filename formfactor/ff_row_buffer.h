/* ff_row_buffer.h - buffers of matrix rows (doubles) for a backend to
 * compute into: up to FF_BACKEND_BUFFER_MAX (ff_plan.h) from the backend
 * itself (page-locked on the GPU, so rows come back by DMA), larger ones -
 * a rank's whole block of rows with --reciprocity on - from malloc.
 *
 *     double *rows = ff_row_buffer_alloc(backend, state, count);
 *     ...
 *     ff_row_buffer_free(backend, state, count, rows); // the same count
 */
#ifndef FF_ROW_BUFFER_H
#define FF_ROW_BUFFER_H

#include <stddef.h>

#include "ff_backend.h"

/* `count` doubles (at least one), or NULL; freed by ff_row_buffer_free
 * with the same count. */
double *ff_row_buffer_alloc(const ff_backend *backend, void *backend_state, size_t count);
void ff_row_buffer_free(const ff_backend *backend, void *backend_state, size_t count, double *buffer);

#endif
