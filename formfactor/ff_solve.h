/* ff_solve.h - formfactor --radiosity: scene to radiosity without the
 * round trip through the N x N file (issue 28, item 3). Each rank keeps
 * its block of rows in memory as the sparse file's records
 * (ff_output_open_held); they go to solve's stage (solve/stage.h) as a
 * matrix held in memory, each rank its rows, and the stage solves and
 * writes the radiosity file exactly as `solve` would from the file: the
 * same checks, method, backend choice and bytes.
 *
 *     ff_solve_align_split(row_begin, ranks, n);   // before the rows are computed
 *     ... compute, ff_output_take_held(out, name, &held) ...
 *     status = ff_solve_held(comm, held, row_begin, options);
 */
#ifndef FF_SOLVE_H
#define FF_SOLVE_H

#include <stdint.h>

#include "ff_comm.h"
#include "ff_options.h"
#include "rad_ffile.h"
#include "rad_status.h"

/* What solve's messages call the held matrix. */
#define FF_SOLVE_NAME "the matrix in memory"

/* The split of rows among ranks (ranks + 1 entries) moved to the chunks
 * solve's GPU backend adds (solve_stage_align_split), so that the
 * radiosity is the same bits for any number of ranks. */
void ff_solve_align_split(uint32_t *row_begin, int ranks, uint32_t n);

/* Collective: solves the held matrix (rank r holds rows [row_begin[r],
 * row_begin[r + 1])) with solve's defaults and writes options->radiosity_path;
 * the backend follows --backend (cpu, cuda, or auto as solve's), on
 * `threads` OpenMP threads per rank (formfactor's). `held` stays the
 * caller's. */
rad_status ff_solve_held(ff_comm *comm, rad_ff_file *held, const uint32_t *row_begin, const ff_options *options,
                         int threads);

#endif
