/* comm_mpi.c - comm.h on MPI; the only file of solve/ that includes mpi.h
 * (starting and ending MPI: core/mpi/rad_mpi.h, shared with formfactor).
 *
 * A process that no MPI launcher started (a plain `./solve`) runs alone:
 * one rank, no MPI_Init (an Open MPI singleton init costs 0.3 s). With one rank, launched or not, no call reaches MPI after init:
 * the results are those of a process alone, bit for bit. */
#include <limits.h>
#include <math.h>
#include <mpi.h>
#include <stdlib.h>
#include <string.h>

#include "comm.h"
#include "rad_log.h"
#include "rad_mpi.h"

struct solve_comm {
    rad_mpi_start mpi;  /* rank and size; solo: no MPI, one rank */
    size_t *row_begin;  /* size + 1: the row split (solve_comm_set_rows) */
    int *counts, *displs; /* size each: MPI_Allgatherv's */
    double *pack;       /* scratch for gathering several vectors at once */
    size_t pack_cap;
};

static int alone(const solve_comm *comm) { return !comm || comm->mpi.size == 1; }

rad_status solve_comm_init(int *argc, char ***argv, solve_comm **out_comm)
{
    solve_comm *c = calloc(1, sizeof *c);
    if (!c) return RAD_ERR_NOMEM;
    /* Funneled: MPI is called between the OpenMP loops, by the main thread. */
    rad_status status = rad_mpi_init(argc, argv, &c->mpi);
    if (status != RAD_OK) {
        free(c);
        return status;
    }
    *out_comm = c;
    return RAD_OK;
}

void solve_comm_finalize(solve_comm *comm)
{
    if (!comm) return;
    rad_mpi_finalize(&comm->mpi, 1);
    free(comm->row_begin);
    free(comm->counts);
    free(comm->displs);
    free(comm->pack);
    free(comm);
}

int solve_comm_rank(const solve_comm *comm) { return comm ? comm->mpi.rank : 0; }
int solve_comm_size(const solve_comm *comm) { return comm ? comm->mpi.size : 1; }

int solve_comm_node_size(const solve_comm *comm)
{
    if (alone(comm)) return 1;
    MPI_Comm node;
    int size = 1;
    if (MPI_Comm_split_type(MPI_COMM_WORLD, MPI_COMM_TYPE_SHARED, comm->mpi.rank, MPI_INFO_NULL, &node) !=
        MPI_SUCCESS)
        return 1;
    MPI_Comm_size(node, &size);
    MPI_Comm_free(&node);
    return size;
}

rad_status solve_comm_agree(solve_comm *comm, rad_status local)
{
    if (alone(comm)) return local;
    int in = (int)local, out = in;
    if (MPI_Allreduce(&in, &out, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD) != MPI_SUCCESS) return RAD_ERR_BACKEND;
    return (rad_status)out;
}

void solve_comm_sum(solve_comm *comm, double *values, size_t count)
{
    if (alone(comm) || count == 0) return;
    MPI_Allreduce(MPI_IN_PLACE, values, (int)count, MPI_DOUBLE, MPI_SUM, MPI_COMM_WORLD);
}

double solve_comm_max(solve_comm *comm, double value)
{
    if (alone(comm)) return value;
    /* MPI_MAX need not propagate NaN: a flag beside the value does. */
    double in[2] = {value != value ? 1.0 : 0.0, value != value ? -INFINITY : value}, out[2];
    MPI_Allreduce(in, out, 2, MPI_DOUBLE, MPI_MAX, MPI_COMM_WORLD);
    return out[0] > 0 ? NAN : out[1];
}

void solve_comm_allgather_bytes(solve_comm *comm, const void *mine, size_t bytes, void *out)
{
    if (alone(comm)) {
        memmove(out, mine, bytes);
        return;
    }
    MPI_Allgather(mine, (int)bytes, MPI_BYTE, out, (int)bytes, MPI_BYTE, MPI_COMM_WORLD);
}

rad_status solve_comm_set_rows(solve_comm *comm, const size_t *row_begin)
{
    if (alone(comm)) return RAD_OK;
    const size_t size = (size_t)comm->mpi.size;
    free(comm->row_begin);
    free(comm->counts);
    free(comm->displs);
    comm->row_begin = malloc((size + 1) * sizeof *comm->row_begin);
    comm->counts = malloc(size * sizeof *comm->counts);
    comm->displs = malloc(size * sizeof *comm->displs);
    int ok = comm->row_begin && comm->counts && comm->displs;
    if (ok) memcpy(comm->row_begin, row_begin, (size + 1) * sizeof *row_begin);
    if (!ok) rad_error("out of memory for the row split of %zu ranks", size);
    return solve_comm_agree(comm, ok ? RAD_OK : RAD_ERR_NOMEM);
}

const size_t *solve_comm_row_split(const solve_comm *comm) { return alone(comm) ? NULL : comm->row_begin; }

rad_status solve_comm_gather_rows(solve_comm *comm, double *const *vectors, size_t count)
{
    if (alone(comm)) return RAD_OK;
    return solve_comm_gather_split(comm, comm->row_begin, vectors, count);
}

rad_status solve_comm_gather_split(solve_comm *comm, const size_t *rb, double *const *vectors, size_t count)
{
    if (alone(comm) || count == 0) return RAD_OK;
    const size_t size = (size_t)comm->mpi.size, n = rb[size];
    if (n > INT_MAX / count) {
        rad_error("%zu rows x %zu vectors: too many for one MPI_Allgatherv (int counts)", n, count);
        return RAD_ERR_NOMEM;
    }
    for (size_t r = 0; r < size; r++) {
        comm->counts[r] = (int)((rb[r + 1] - rb[r]) * count);
        comm->displs[r] = (int)(rb[r] * count);
    }
    int rc;
    if (count == 1) {
        rc = MPI_Allgatherv(MPI_IN_PLACE, 0, MPI_DATATYPE_NULL, vectors[0], comm->counts, comm->displs, MPI_DOUBLE,
                            MPI_COMM_WORLD);
    } else {
        /* Rank r's block: its rows of vector 0, of vector 1, ... */
        if (n * count > comm->pack_cap) { /* on every rank at the same call: agreed */
            free(comm->pack);
            comm->pack = malloc(n * count * sizeof *comm->pack);
            comm->pack_cap = comm->pack ? n * count : 0;
            if (!comm->pack) rad_error("out of memory gathering %zu vectors of %zu values", count, n);
            rad_status status = solve_comm_agree(comm, comm->pack ? RAD_OK : RAD_ERR_NOMEM);
            if (status != RAD_OK) return status;
        }
        const size_t me = (size_t)comm->mpi.rank, mine = rb[me + 1] - rb[me];
        double *own = comm->pack + rb[me] * count;
        for (size_t v = 0; v < count; v++) memcpy(own + v * mine, vectors[v] + rb[me], mine * sizeof(double));
        rc = MPI_Allgatherv(MPI_IN_PLACE, 0, MPI_DATATYPE_NULL, comm->pack, comm->counts, comm->displs, MPI_DOUBLE,
                            MPI_COMM_WORLD);
        for (size_t r = 0; r < size && rc == MPI_SUCCESS; r++) {
            const size_t rows = rb[r + 1] - rb[r];
            for (size_t v = 0; v < count; v++)
                memcpy(vectors[v] + rb[r], comm->pack + rb[r] * count + v * rows, rows * sizeof(double));
        }
    }
    if (rc != MPI_SUCCESS) {
        rad_error("MPI_Allgatherv of the iterate failed");
        return RAD_ERR_BACKEND;
    }
    return RAD_OK;
}

rad_status solve_comm_exchange(solve_comm *comm, const uint64_t *send, const uint64_t *words_to,
                               uint64_t **out_received, uint64_t *out_received_count)
{
    if (alone(comm)) {
        uint64_t *copy = malloc((words_to[0] ? words_to[0] : 1) * sizeof *copy);
        if (!copy) return RAD_ERR_NOMEM;
        memcpy(copy, send, words_to[0] * sizeof *copy);
        *out_received = copy;
        *out_received_count = words_to[0];
        return RAD_OK;
    }
    const size_t size = (size_t)comm->mpi.size;
    rad_status status = RAD_OK;
    uint64_t *words_from = malloc(size * sizeof *words_from), *received = NULL;
    int *sc = malloc(4 * size * sizeof *sc);
    if (!words_from || !sc) status = RAD_ERR_NOMEM;
    status = solve_comm_agree(comm, status);
    if (status != RAD_OK) goto done;
    MPI_Alltoall(words_to, 1, MPI_UINT64_T, words_from, 1, MPI_UINT64_T, MPI_COMM_WORLD);
    int *sd = sc + size, *rc = sc + 2 * size, *rd = sc + 3 * size;
    uint64_t sent = 0, got = 0;
    for (size_t r = 0; r < size; r++) {
        sc[r] = (int)words_to[r];
        sd[r] = (int)sent;
        rc[r] = (int)words_from[r];
        rd[r] = (int)got;
        sent += words_to[r];
        got += words_from[r];
    }
    if (sent > INT_MAX || got > INT_MAX) {
        rad_error("the transposed tiles exchanged for the CG check (%llu and %llu words) are too many for one "
                  "MPI_Alltoallv (int counts): use more ranks",
                  (unsigned long long)sent, (unsigned long long)got);
        status = RAD_ERR_NOMEM;
    } else if (!(received = malloc((got ? got : 1) * sizeof *received))) {
        rad_error("out of memory for %llu words of transposed tiles", (unsigned long long)got);
        status = RAD_ERR_NOMEM;
    }
    status = solve_comm_agree(comm, status);
    if (status != RAD_OK) goto done;
    if (MPI_Alltoallv(send, sc, sd, MPI_UINT64_T, received, rc, rd, MPI_UINT64_T, MPI_COMM_WORLD) != MPI_SUCCESS) {
        rad_error("MPI_Alltoallv of the transposed tiles failed");
        status = RAD_ERR_BACKEND;
        goto done;
    }
    *out_received = received;
    *out_received_count = got;
    received = NULL;
done:
    free(received);
    free(words_from);
    free(sc);
    return status;
}
