/* ff_solve.c - a rank's rows into solve's matrix, then solve's stage (ff_solve.h). */
#include "ff_solve.h"

#include <stdlib.h>

#include "comm.h"
#include "links.h"
#include "matrix.h"
#include "rad_log.h"
#include "stage.h"

struct ff_solve {
    rad_ff_info info;
    const rad_mesh *mesh;
    solve_matrix matrix;
    uint64_t bytes; /* the records' bytes so far */
};

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

rad_status ff_solve_begin(const rad_ff_info *info, const rad_mesh *mesh, uint32_t row_begin, uint32_t row_end,
                          ff_solve **out_solve)
{
    *out_solve = NULL;
    ff_solve *s = calloc(1, sizeof *s);
    if (!s) {
        rad_error("out of memory");
        return RAD_ERR_NOMEM;
    }
    s->info = *info;
    s->mesh = mesh;
    rad_status status = solve_matrix_begin(info, mesh, row_begin, row_end, &s->matrix);
    if (status != RAD_OK) {
        free(s);
        return status;
    }
    *out_solve = s;
    return RAD_OK;
}

rad_status ff_solve_rows(void *solve, uint32_t row, uint32_t rows, const unsigned char *records, const uint64_t *at)
{
    ff_solve *s = solve;
    s->bytes += at[rows] - at[0];
    return solve_matrix_append(&s->matrix, FF_SOLVE_NAME, row, rows, records, at);
}

static solve_backend solve_backend_of(ff_backend_choice backend)
{
    switch (backend) {
    case FF_BACKEND_CPU: return SOLVE_BACKEND_CPU;
    case FF_BACKEND_CUDA: return SOLVE_BACKEND_CUDA;
    default: return SOLVE_BACKEND_AUTO;
    }
}

rad_status ff_solve_run(ff_comm *comm, ff_solve *s, const uint32_t *row_begin, const ff_options *options,
                        int threads)
{
    int ranks = ff_comm_size(comm);
    size_t *split = malloc(((size_t)ranks + 1) * sizeof *split);
    solve_comm *sc = NULL;
    rad_ff_file *tables = NULL;
    uint64_t total = 0;
    ff_comm_exscan_u64(comm, s->bytes, &total); /* every rank's records: what a file's header would say */
    s->info.matrix_bytes = total;
    rad_status status = split ? solve_matrix_end(&s->matrix, FF_SOLVE_NAME) : RAD_ERR_NOMEM;
    if (status == RAD_OK) status = rad_ff_open_tables(FF_SOLVE_NAME, &s->info, s->mesh, &tables);
    if (status == RAD_OK) status = solve_comm_init(NULL, NULL, &sc); /* MPI is up already (or not used) */
    status = ff_comm_agree(comm, status);
    if (status == RAD_OK) {
        for (int r = 0; r <= ranks; r++) split[r] = row_begin[r];
        solve_options so = {.input = FF_SOLVE_NAME,
                            .output = options->radiosity_path,
                            .backend = solve_backend_of(options->backend),
                            .comm = sc,
                            .matrix = tables,
                            .loaded = &s->matrix,
                            .row_split = ranks > 1 ? split : NULL,
                            .threads = threads};
        status = solve_stage_run(&so);
    }
    solve_comm_finalize(sc);
    rad_ff_close(tables);
    free(split);
    return ff_comm_agree(comm, status);
}

void ff_solve_free(ff_solve *s)
{
    if (!s) return;
    solve_matrix_free(&s->matrix);
    free(s);
}

int ff_solve_channels(const rad_mesh *leaves) { return solve_mesh_is_grey(leaves) ? 1 : 3; }

int ff_solve_flat_on_gpu(const ff_options *options, uint64_t link_count)
{
    return solve_links_flat_on_gpu(solve_backend_of(options->backend), 1, link_count);
}

rad_status ff_solve_links(const rad_ff_info *info, const rad_mesh *leaves, const rad_links *links,
                          const solve_links_flat *flat, const ff_options *options, int threads)
{
    solve_options so = {.input = FF_SOLVE_LINKS_NAME,
                        .output = options->radiosity_path,
                        .backend = solve_backend_of(options->backend),
                        .threads = threads};
    rad_ff_info header; /* the file's, after the writer's checks */
    rad_status status = rad_ff_links_info(FF_SOLVE_LINKS_NAME, info, leaves, links, &header);
    if (status != RAD_OK) return status;
    solve_links_input in = {.info = &header, .leaves = leaves, .links = links, .load_seconds = 0, .flat = flat};
    return solve_links_solve(&so, &in);
}
