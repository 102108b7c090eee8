/* ff_cuda_none.c - builds without nvcc: no GPUs, and a CUDA backend that
 * says so when asked for. */
#include "ff_backend.h"
#include "ff_cuda.h"
#include "rad_log.h"

int ff_cuda_device_count(void) { return 0; }
void ff_cuda_prestart(int rank) { (void)rank; }
void ff_cuda_prestart_join(void) {}

static rad_status none_create(const ff_setup *setup, void **out_state)
{
    (void)setup;
    (void)out_state;
    rad_error("--backend cuda: this build has no CUDA (nvcc was not found when it was configured)");
    return RAD_ERR_UNSUPPORTED;
}

static rad_status none_compute_rows(void *state, uint32_t row_begin, uint32_t row_count, double *out,
                                    double *errors, ff_counters *counters)
{
    (void)state, (void)row_begin, (void)row_count, (void)out, (void)errors, (void)counters;
    return RAD_ERR_UNSUPPORTED;
}

static void none_destroy(void *state) { (void)state; }

static double *none_alloc_rows(void *state, size_t count)
{
    (void)state, (void)count;
    return NULL;
}

static void none_free_rows(void *state, double *rows) { (void)state, (void)rows; }

const ff_backend ff_backend_cuda = {"cuda",          none_create,    none_compute_rows, none_destroy,
                                    none_alloc_rows, none_free_rows, NULL,              NULL,
                                    NULL,           NULL,            NULL};
