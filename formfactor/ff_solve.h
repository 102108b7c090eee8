/* ff_solve.h - formfactor --radiosity: scene to radiosity without the
 * round trip through the N x N file (issue 28, item 3). Each rank's block
 * of rows goes, as the sparse file's records, straight into solve's matrix
 * (solve_matrix_begin/append/end: decoded on a background thread while the
 * rank computes its next rows, ff_output_open_held); then solve's stage
 * (solve/stage.h) runs on it exactly as `solve` would on the file: the
 * same checks, method, backend choice and bytes.
 *
 *     ff_solve_align_split(row_begin, ranks, n);         // before the rows are split into rounds
 *     ff_solve *s;
 *     ff_solve_begin(&info, &mesh, row_begin[r], row_begin[r + 1], &s);
 *     ff_output_open_held(comm, &info, ff_solve_rows, s, &options, &out);
 *     ... the rounds; ff_output_close ...
 *     status = ff_solve_run(comm, s, row_begin, &options, threads);
 *     ff_solve_free(s);
 */
#ifndef FF_SOLVE_H
#define FF_SOLVE_H

#include <stdint.h>

#include "ff_comm.h"
#include "ff_options.h"
#include "rad_ffile.h"
#include "rad_links.h"
#include "links.h" /* solve's: solve_links_flat */
#include "rad_lsolve.h"
#include "rad_status.h"

/* What solve's messages call the matrix (the links) in memory. */
#define FF_SOLVE_NAME "the matrix in memory"
#define FF_SOLVE_LINKS_NAME "the links in memory"

/* The split of rows among ranks (ranks + 1 entries) moved to the chunks
 * solve's GPU backend adds (solve_stage_align_split), so that the
 * radiosity is the same bits for any number of ranks. */
void ff_solve_align_split(uint32_t *row_begin, int ranks, uint32_t n);

typedef struct ff_solve ff_solve;

/* This rank's rows [row_begin, row_end) of the matrix described by `info`
 * (the header a file of it would have) over `mesh`. */
rad_status ff_solve_begin(const rad_ff_info *info, const rad_mesh *mesh, uint32_t row_begin, uint32_t row_end,
                          ff_solve **out_solve);
/* ff_handoff_consume: the next rows' records into the matrix. */
rad_status ff_solve_rows(void *solve, uint32_t row, uint32_t rows, const unsigned char *records, const uint64_t *at);
/* Collective, once every rank's rows are in: solves with solve's defaults
 * and writes options->radiosity_path; the backend follows --backend (cpu,
 * cuda, or auto as solve's), on `threads` OpenMP threads per rank
 * (formfactor's). */
rad_status ff_solve_run(ff_comm *comm, ff_solve *solve, const uint32_t *row_begin, const ff_options *options,
                        int threads);
void ff_solve_free(ff_solve *solve); /* NULL is fine */

/* The channels solve solves the leaves in: 1 for a grey scene, else 3. */
int ff_solve_channels(const rad_mesh *leaves);

/* Whether solve would run the flat solve of `link_count` links on the GPU
 * (solve_links_flat_on_gpu: --backend as solve's, one process): the last
 * pass of formfactor --method hierarchical asks, so that --radiosity can
 * take that solve as solve's own. */
int ff_solve_flat_on_gpu(const ff_options *options, uint64_t link_count);

/* formfactor --method hierarchical --radiosity: the links and their
 * leaves, as they would be written with `info` as the header, solved in
 * memory by solve's stage for links (solve/links.h) exactly as `solve`
 * solves that file: the writer's checks (rad_ff_links_info), then the
 * same backend choice and bytes; `flat` (NULL: none) is a flat solve
 * already run from B = E, which solve takes as its own where it is the
 * one it would run. One process (the rank that made the links). */
rad_status ff_solve_links(const rad_ff_info *info, const rad_mesh *leaves, const rad_links *links,
                          const solve_links_flat *flat, const ff_options *options, int threads);

#endif
