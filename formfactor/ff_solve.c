/* ff_solve.c - the held matrix to solve's stage (ff_solve.h). */
#include "ff_solve.h"

#include <stdlib.h>

#include "comm.h"
#include "rad_log.h"
#include "stage.h"

void ff_solve_align_split(uint32_t *row_begin, int ranks, uint32_t n)
{
    if (ranks < 2) return;
    size_t *split = malloc(((size_t)ranks + 1) * sizeof *split);
    if (!split) return; /* unaligned: the GPU backend's chunks then differ, not the answer's accuracy */
    for (int r = 0; r <= ranks; r++) split[r] = row_begin[r];
    solve_stage_align_split(split, (size_t)ranks, n);
    for (int r = 0; r <= ranks; r++) row_begin[r] = (uint32_t)split[r];
    free(split);
}

static solve_backend solve_backend_of(ff_backend_choice backend)
{
    switch (backend) {
    case FF_BACKEND_CPU: return SOLVE_BACKEND_CPU;
    case FF_BACKEND_CUDA: return SOLVE_BACKEND_CUDA;
    default: return SOLVE_BACKEND_AUTO;
    }
}

rad_status ff_solve_held(ff_comm *comm, rad_ff_file *held, const uint32_t *row_begin, const ff_options *options,
                         int threads)
{
    int ranks = ff_comm_size(comm);
    size_t *split = malloc(((size_t)ranks + 1) * sizeof *split);
    solve_comm *sc = NULL;
    rad_status status = split ? RAD_OK : RAD_ERR_NOMEM;
    if (status == RAD_OK) status = solve_comm_init(NULL, NULL, &sc); /* MPI is up already (or not used) */
    status = ff_comm_agree(comm, status);
    if (status == RAD_OK) {
        for (int r = 0; r <= ranks; r++) split[r] = row_begin[r];
        solve_options so = {.input = FF_SOLVE_NAME,
                            .output = options->radiosity_path,
                            .backend = solve_backend_of(options->backend),
                            .comm = sc,
                            .matrix = held,
                            .row_split = ranks > 1 ? split : NULL,
                            .threads = threads};
        status = solve_stage_run(&so);
    }
    solve_comm_finalize(sc);
    free(split);
    return ff_comm_agree(comm, status);
}
