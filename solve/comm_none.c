/* comm_none.c - comm.h without MPI (a build configured without it): one
 * process, every collective the identity. */
#include <stdlib.h>
#include <string.h>

#include "comm.h"

struct solve_comm {
    int unused;
};

rad_status solve_comm_init(int *argc, char ***argv, solve_comm **out_comm)
{
    solve_comm *c = calloc(1, sizeof *c);
    if (!c) return RAD_ERR_NOMEM;
    *out_comm = c;
    return RAD_OK;
}

void solve_comm_finalize(solve_comm *comm) { free(comm); }
int solve_comm_rank(const solve_comm *comm) { return 0; }
int solve_comm_size(const solve_comm *comm) { return 1; }
int solve_comm_node_size(const solve_comm *comm) { return 1; }
rad_status solve_comm_agree(solve_comm *comm, rad_status local) { return local; }
void solve_comm_sum(solve_comm *comm, double *values, size_t count) {}
double solve_comm_max(solve_comm *comm, double value) { return value; }
void solve_comm_allgather_bytes(solve_comm *comm, const void *mine, size_t bytes, void *out) { memmove(out, mine, bytes); }
rad_status solve_comm_set_rows(solve_comm *comm, const size_t *row_begin) { return RAD_OK; }
const size_t *solve_comm_row_split(const solve_comm *comm) { return NULL; }
rad_status solve_comm_gather_rows(solve_comm *comm, double *const *vectors, size_t count) { return RAD_OK; }
rad_status solve_comm_gather_split(solve_comm *comm, const size_t *split, double *const *vectors, size_t count)
{
    return RAD_OK;
}

rad_status solve_comm_exchange(solve_comm *comm, const uint64_t *send, const uint64_t *words_to,
                               uint64_t **out_received, uint64_t *out_received_count)
{
    uint64_t *copy = malloc((words_to[0] ? words_to[0] : 1) * sizeof *copy);
    if (!copy) return RAD_ERR_NOMEM;
    memcpy(copy, send, words_to[0] * sizeof *copy);
    *out_received = copy;
    *out_received_count = words_to[0];
    return RAD_OK;
}
