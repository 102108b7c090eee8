/* ff_cuda_records.h - finished, encoded rows made on the GPU, for the CUDA
 * backend's compute_records (ff_backend.h). Internal to the CUDA sources.
 *
 *     ff_cuda_records *r = ff_cuda_records_new();
 *     ff_cuda_records_make(r, d_values, d_errors, d_area, n, row0, rows, element,
 *                          &values, &errors, &summary);   // per round
 *     ff_cuda_records_free(r);
 */
#ifndef FF_CUDA_RECORDS_H
#define FF_CUDA_RECORDS_H

#ifdef __cplusplus
extern "C" {
#endif
#include "ff_backend.h"
#include "ff_rows.h"
#include "rad_ffile.h"

typedef struct ff_cuda_records ff_cuda_records;

ff_cuda_records *ff_cuda_records_new(void);
void ff_cuda_records_free(ff_cuda_records *records);

/* Rows [row_begin, row_begin + rows) of couplings in d_values (rows x n,
 * device) and, if d_errors is not NULL, their standard errors: scaled into
 * form factors in place (the doubles ff_rows_finish makes), added to
 * *summary, and encoded as sparse records (rad_ff_row_encode's bytes) of
 * `element` into *values and, when `errors` is not NULL, of float32 into
 * *errors. The views point into page-locked buffers of `records`, valid
 * until the call after next (two sets of buffers, used in turn: one
 * round's records can be written while the next round's are made). */
rad_status ff_cuda_records_make(ff_cuda_records *records, double *d_values, double *d_errors, const double *d_area,
                                uint32_t n, uint32_t row_begin, uint32_t rows, uint32_t element, ff_records *values,
                                ff_records *errors, ff_rows_summary *summary);

#ifdef __cplusplus
}
#endif
#endif
