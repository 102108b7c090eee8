/* ff_row_buffer.c - row buffers from the backend or malloc, by size
 * (ff_row_buffer.h). */
#include "ff_row_buffer.h"

#include <stdlib.h>

#include "ff_plan.h"

double *ff_row_buffer_alloc(const ff_backend *backend, void *backend_state, size_t count)
{
    if (count == 0) count = 1;
    return count * sizeof(double) <= FF_BACKEND_BUFFER_MAX ? backend->alloc_rows(backend_state, count)
                                                           : malloc(count * sizeof(double));
}

void ff_row_buffer_free(const ff_backend *backend, void *backend_state, size_t count, double *buffer)
{
    if (count == 0) count = 1;
    if (count * sizeof(double) <= FF_BACKEND_BUFFER_MAX)
        backend->free_rows(backend_state, buffer);
    else
        free(buffer);
}
