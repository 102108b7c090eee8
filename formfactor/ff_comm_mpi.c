/* ff_comm_mpi.c - ff_comm.h on Open MPI; the only file of formfactor/
 * that includes mpi.h (starting and ending MPI: core/mpi/rad_mpi.h).
 *
 * A process that no MPI launcher started (no OMPI_COMM_WORLD_SIZE,
 * PMIX_RANK, PMI_RANK or PMI_SIZE in its environment: a plain
 * `./formfactor`) runs solo: one rank, no MPI_Init. An
 * Open MPI singleton init costs 0.3 s (a forked runtime daemon), as much as
 * the whole paper-size run on a GPU, and `formfactor --version` paid it
 * too. The bytes written are the same either way (formfactor_ranks). No
 * files here: each rank writes its part of the output itself (ff_writer.h). */
#include <limits.h>
#include <mpi.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "ff_comm.h"
#include "rad_clock.h"
#include "rad_log.h"
#include "rad_mpi.h"

struct ff_comm {
    rad_mpi_start mpi; /* rank and size; solo: no MPI, one rank */
    int node_size;
    uint64_t progress_local; /* rows done: the whole count solo, or until the window opens */
    MPI_Win progress_win;    /* one uint64 on rank 0 (ff_comm_progress_open) */
    int progress_open;
};

static void log_mpi_error(const char *what, const char *path, int code)
{
    char text[MPI_MAX_ERROR_STRING];
    int len = 0;
    MPI_Error_string(code, text, &len);
    rad_error("%s: %s: %s", path, what, text);
}

rad_status ff_comm_init(int *argc, char ***argv, ff_comm **out_comm)
{
    ff_comm *c = calloc(1, sizeof *c);
    if (!c) return RAD_ERR_NOMEM;
    /* Funneled: the progress counter is updated from inside the CPU
     * backend's OpenMP region, by its master thread (this one). */
    rad_status status = rad_mpi_init(argc, argv, &c->mpi);
    if (status != RAD_OK) {
        free(c);
        return status;
    }
    c->node_size = c->mpi.size;
    if (!c->mpi.solo) {
        MPI_Comm node;
        MPI_Comm_split_type(MPI_COMM_WORLD, MPI_COMM_TYPE_SHARED, c->mpi.rank, MPI_INFO_NULL, &node);
        MPI_Comm_size(node, &c->node_size);
        MPI_Comm_free(&node);
    }
    *out_comm = c;
    return RAD_OK;
}

void ff_comm_finalize(ff_comm *comm)
{
    if (!comm) return;
    rad_mpi_finalize(&comm->mpi, 0);
    free(comm);
}

void ff_comm_progress_open(ff_comm *comm)
{
    if (comm->mpi.solo || comm->progress_open) return;
    uint64_t *base = NULL;
    MPI_Win win;
    int ok = MPI_Win_allocate(comm->mpi.rank == 0 ? (MPI_Aint)sizeof(uint64_t) : 0, sizeof(uint64_t), MPI_INFO_NULL,
                              MPI_COMM_WORLD, &base, &win) == MPI_SUCCESS;
    /* Every rank must agree before using it: a rank whose window failed
     * would leave the others' one-sided calls without a partner. */
    int all = 0;
    MPI_Allreduce(&ok, &all, 1, MPI_INT, MPI_MIN, MPI_COMM_WORLD);
    if (!all) {
        if (ok) MPI_Win_free(&win);
        return;
    }
    MPI_Win_set_errhandler(win, MPI_ERRORS_RETURN);
    if (comm->mpi.rank == 0) {
        MPI_Win_lock(MPI_LOCK_EXCLUSIVE, 0, 0, win);
        *base = 0;
        MPI_Win_unlock(0, win);
    }
    MPI_Barrier(MPI_COMM_WORLD); /* the counter is zero before anyone adds */
    comm->progress_win = win;
    comm->progress_open = 1;
}

void ff_comm_progress_add(ff_comm *comm, uint64_t rows)
{
    if (!comm->progress_open) {
        comm->progress_local += rows;
        return;
    }
    MPI_Win_lock(MPI_LOCK_SHARED, 0, 0, comm->progress_win);
    MPI_Accumulate(&rows, 1, MPI_UINT64_T, 0, 0, 1, MPI_UINT64_T, MPI_SUM, comm->progress_win);
    MPI_Win_unlock(0, comm->progress_win);
}

uint64_t ff_comm_progress_read(ff_comm *comm)
{
    if (!comm->progress_open) return comm->progress_local;
    uint64_t value = 0, unused = 0;
    MPI_Win_lock(MPI_LOCK_SHARED, 0, 0, comm->progress_win);
    MPI_Fetch_and_op(&unused, &value, MPI_UINT64_T, 0, 0, MPI_NO_OP, comm->progress_win);
    MPI_Win_unlock(0, comm->progress_win);
    return value;
}

void ff_comm_progress_close(ff_comm *comm)
{
    if (!comm->progress_open) return;
    MPI_Win_free(&comm->progress_win);
    comm->progress_open = 0;
}

int ff_comm_rank(const ff_comm *comm) { return comm->mpi.rank; }
int ff_comm_size(const ff_comm *comm) { return comm->mpi.size; }
int ff_comm_node_size(const ff_comm *comm) { return comm->node_size; }

rad_status ff_comm_agree(ff_comm *comm, rad_status local)
{
    if (comm->mpi.solo) return local;
    int in = (int)local, out = 0;
    MPI_Allreduce(&in, &out, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
    return (rad_status)out;
}

uint64_t ff_comm_max_u64(ff_comm *comm, uint64_t value)
{
    if (comm->mpi.solo) return value;
    uint64_t out = 0;
    MPI_Allreduce(&value, &out, 1, MPI_UINT64_T, MPI_MAX, MPI_COMM_WORLD);
    return out;
}

uint64_t ff_comm_exscan_u64(ff_comm *comm, uint64_t value, uint64_t *total)
{
    *total = value;
    if (comm->mpi.solo) return 0;
    uint64_t below = 0;
    MPI_Exscan(&value, &below, 1, MPI_UINT64_T, MPI_SUM, MPI_COMM_WORLD);
    if (comm->mpi.rank == 0) below = 0; /* MPI_Exscan leaves rank 0's result undefined */
    MPI_Allreduce(&value, total, 1, MPI_UINT64_T, MPI_SUM, MPI_COMM_WORLD);
    return below;
}

rad_status ff_comm_sendrecv(ff_comm *comm, int dest, const double *send, size_t send_count, int source, double *recv,
                            size_t recv_count)
{
    if (send_count > FF_COMM_MAX_DOUBLES || recv_count > FF_COMM_MAX_DOUBLES) return RAD_ERR_INVALID;
    if (comm->mpi.solo) { /* to and from rank 0 itself */
        memmove(recv, send, sizeof *send * (send_count < recv_count ? send_count : recv_count));
        return RAD_OK;
    }
    int code = MPI_Sendrecv(send, (int)send_count, MPI_DOUBLE, dest, 7, recv, (int)recv_count, MPI_DOUBLE, source, 7,
                            MPI_COMM_WORLD, MPI_STATUS_IGNORE);
    if (code != MPI_SUCCESS) {
        log_mpi_error("exchanging mirrored form factors", "MPI_Sendrecv", code);
        return RAD_ERR_BACKEND;
    }
    return RAD_OK;
}

/* MPI counts are ints: larger messages go in pieces of this many bytes. */
#define COMM_PIECE ((size_t)1 << 30)

void ff_comm_broadcast(ff_comm *comm, void *data, size_t bytes, int root)
{
    if (comm->mpi.solo) return;
    for (size_t at = 0; at < bytes; at += COMM_PIECE) {
        const size_t n = bytes - at < COMM_PIECE ? bytes - at : COMM_PIECE;
        MPI_Bcast((unsigned char *)data + at, (int)n, MPI_BYTE, root, MPI_COMM_WORLD);
    }
}

/* Waits for req; ranks other than 0 asleep between tests, so that a
 * rank waiting for rank 0 leaves the node's cores to rank 0's threads
 * (a rank spinning in MPI beside them slows each of their parallel
 * regions to its slowest thread). */
static void wait_idle(const ff_comm *comm, MPI_Request *req)
{
    if (comm->mpi.rank == 0) {
        MPI_Wait(req, MPI_STATUS_IGNORE);
        return;
    }
    const struct timespec pause = {0, 100000}; /* 0.1 ms: a round is tens of ms at least */
    for (int done = 0;;) {
        MPI_Test(req, &done, MPI_STATUS_IGNORE);
        if (done) break;
        nanosleep(&pause, NULL);
    }
}

void ff_comm_broadcast_idle(ff_comm *comm, void *data, size_t bytes)
{
    if (comm->mpi.solo) return;
    MPI_Request req;
    MPI_Ibcast(data, (int)bytes, MPI_BYTE, 0, MPI_COMM_WORLD, &req);
    wait_idle(comm, &req);
}

/* The cyclic cut: chunk c (of `chunk` items, the last maybe fewer) of
 * `count` items goes to rank c % size. */
static uint64_t chunks_of(uint64_t count, uint32_t chunk) { return (count + chunk - 1) / chunk; }

static uint64_t chunk_items(uint64_t count, uint32_t chunk, uint64_t c)
{
    return count - c * chunk < chunk ? count - c * chunk : chunk;
}

uint64_t ff_comm_cyclic_count(uint64_t count, uint32_t chunk, int rank, int size)
{
    const uint64_t chunks = chunks_of(count, chunk);
    uint64_t n = 0;
    for (uint64_t c = (uint64_t)rank; c < chunks; c += (uint64_t)size) n += chunk_items(count, chunk, c);
    return n;
}

/* An MPI type of rank r's chunks in the whole array of items (`item`);
 * 0 (logged) where it cannot be made. */
static int cyclic_type(uint64_t count, uint32_t chunk, int r, int size, MPI_Datatype item, MPI_Datatype *out)
{
    const uint64_t chunks = chunks_of(count, chunk);
    const int mine = chunks > (uint64_t)r ? (int)((chunks - 1 - (uint64_t)r) / (uint64_t)size + 1) : 0;
    int *len = malloc(((size_t)mine + 1) * sizeof *len), *at = malloc(((size_t)mine + 1) * sizeof *at);
    if (!len || !at) {
        free(len);
        free(at);
        rad_error("MPI: out of memory for a rank's %d pieces", mine);
        return 0;
    }
    int k = 0;
    for (uint64_t c = (uint64_t)r; c < chunks; c += (uint64_t)size, k++) {
        len[k] = (int)chunk_items(count, chunk, c);
        at[k] = (int)(c * chunk);
    }
    MPI_Type_indexed(mine, len, at, item, out);
    MPI_Type_commit(out);
    free(len);
    free(at);
    return 1;
}

/* Chunks between rank 0's whole array and the ranks' areas (bases[r] +
 * at[r]: r's chunks back to back), in one parallel region on rank 0's
 * threads: every rank's (step 1) or rank 0's own (step size). */
static void cyclic_copy(unsigned char *whole, unsigned char *const *bases, const size_t *at, uint64_t count,
                        uint32_t chunk, int size, int step, size_t item_bytes, int to_ranks)
{
    const uint64_t chunks = chunks_of(count, chunk);
#pragma omp parallel for schedule(static)
    for (int64_t c = 0; c < (int64_t)chunks; c += step) {
        const int r = (int)(c % size);
        const uint64_t n = chunk_items(count, chunk, (uint64_t)c);
        unsigned char *w = whole + (uint64_t)c * chunk * item_bytes;
        unsigned char *m = bases[r] + at[r] + (uint64_t)c / (uint64_t)size * chunk * item_bytes;
        if (to_ranks) memcpy(m, w, n * item_bytes);
        else memcpy(w, m, n * item_bytes);
    }
}

/* ---- areas: where the cyclic cut's chunks land ---- */

struct ff_comm_area {
    unsigned char *mine; /* this rank's bytes */
    int shared;          /* an MPI shared window over the node (all ranks on one node) */
    MPI_Win win;
    unsigned char **bases; /* shared: every rank's bytes as this process maps them (rank 0) */
};

rad_status ff_comm_area_open(ff_comm *comm, size_t bytes, ff_comm_area **out)
{
    ff_comm_area *a = calloc(1, sizeof *a);
    int ok = a != NULL;
    const char *messages = getenv("RAD_MPI_MESSAGES"); /* tests: the path of ranks on several nodes */
    if (ok && !comm->mpi.solo && comm->node_size == comm->mpi.size && comm->mpi.size > 1 &&
        !(messages && *messages == '1')) {
        MPI_Info info;
        MPI_Info_create(&info);
        MPI_Info_set(info, "alloc_shared_noncontig", "true"); /* each rank's pages its own (NUMA) */
        a->bases = calloc((size_t)comm->mpi.size, sizeof *a->bases);
        int made = a->bases && MPI_Win_allocate_shared((MPI_Aint)(bytes ? bytes : 64), 1, info, MPI_COMM_WORLD,
                                                       &a->mine, &a->win) == MPI_SUCCESS;
        MPI_Info_free(&info);
        int all = 0;
        MPI_Allreduce(&made, &all, 1, MPI_INT, MPI_MIN, MPI_COMM_WORLD);
        if (all) {
            a->shared = 1;
            MPI_Win_lock_all(MPI_MODE_NOCHECK, a->win);
            for (int r = 0; r < comm->mpi.size; r++) {
                MPI_Aint size = 0;
                int unit = 0;
                MPI_Win_shared_query(a->win, r, &size, &unit, &a->bases[r]);
            }
        } else if (made) {
            MPI_Win_free(&a->win);
        }
        ok = all;
    } else if (ok) {
        a->mine = malloc(bytes ? bytes : 64);
        ok = a->mine != NULL;
    }
    if (!ok) {
        rad_error("MPI: no room for %zu bytes of exchange", bytes);
        if (a) free(a->bases);
        free(a);
        return RAD_ERR_NOMEM;
    }
    *out = a;
    return RAD_OK;
}

void *ff_comm_area_data(ff_comm_area *a) { return a->mine; }
int ff_comm_area_shared(const ff_comm_area *a) { return a->shared; }

void ff_comm_area_close(ff_comm_area *a)
{
    if (!a) return;
    if (a->shared) {
        MPI_Win_unlock_all(a->win);
        MPI_Win_free(&a->win); /* collective */
    } else {
        free(a->mine);
    }
    free(a->bases);
    free(a);
}

/* Shared windows: what one rank wrote is seen by the others after this. */
static void area_fence(const ff_comm *comm, const ff_comm_area *a)
{
    MPI_Win_sync(a->win);
    MPI_Request req;
    MPI_Ibarrier(MPI_COMM_WORLD, &req);
    wait_idle(comm, &req);
    MPI_Win_sync(a->win);
}

/* Both ways of the cyclic cut: rank 0's whole array of items and every
 * rank's area at its offset at[rank] (its chunks back to back). */
static rad_status cyclic_exchange(ff_comm *comm, unsigned char *whole, ff_comm_area *area, const size_t *at,
                                  uint64_t count, uint32_t chunk, size_t item_bytes, int scatter)
{
    const int rank = comm->mpi.rank, size = comm->mpi.size;
    unsigned char *mine = area->mine + at[rank];
    if (comm->mpi.solo || size == 1) {
        if (scatter) memmove(mine, whole, count * item_bytes);
        else memmove(whole, mine, count * item_bytes);
        return RAD_OK;
    }
    if (area->shared) { /* rank 0 copies every rank's chunks itself */
        if (!scatter) area_fence(comm, area); /* their outcomes written */
        if (rank == 0) cyclic_copy(whole, area->bases, at, count, chunk, size, 1, item_bytes, scatter);
        if (scatter) area_fence(comm, area); /* their jobs there */
        return RAD_OK;
    }
    if (count > INT_MAX || item_bytes > INT_MAX || chunk == 0) {
        rad_error("MPI: %llu items of %zu bytes are more than one exchange holds", (unsigned long long)count,
                  item_bytes);
        return RAD_ERR_INVALID;
    }
    MPI_Datatype item;
    MPI_Type_contiguous((int)item_bytes, MPI_BYTE, &item);
    MPI_Type_commit(&item);
    int code = MPI_SUCCESS;
    rad_status st = RAD_OK;
    if (rank == 0) {
        MPI_Request *req = malloc((size_t)size * sizeof *req);
        MPI_Datatype *types = malloc((size_t)size * sizeof *types);
        int made = 0;
        if (!req || !types) {
            rad_error("MPI: out of memory for %d ranks' requests", size);
            st = RAD_ERR_NOMEM;
        }
        for (int r = 1; r < size && st == RAD_OK; r++, made++) {
            if (!cyclic_type(count, chunk, r, size, item, &types[r])) {
                st = RAD_ERR_NOMEM;
                break;
            }
            code = scatter ? MPI_Isend(whole, 1, types[r], r, 11, MPI_COMM_WORLD, &req[r - 1])
                           : MPI_Irecv(whole, 1, types[r], r, 12, MPI_COMM_WORLD, &req[r - 1]);
            if (code != MPI_SUCCESS) {
                MPI_Type_free(&types[r]);
                break;
            }
        }
        cyclic_copy(whole, &mine, &(size_t){0}, count, chunk, size, size, item_bytes, scatter);
        if (made) MPI_Waitall(made, req, MPI_STATUSES_IGNORE);
        for (int r = 1; r <= made; r++) MPI_Type_free(&types[r]);
        free(req);
        free(types);
        if (st == RAD_OK && made < size - 1) st = RAD_ERR_BACKEND; /* an MPI call failed: the others wait on it */
    } else {
        const int n = (int)ff_comm_cyclic_count(count, chunk, rank, size);
        code = scatter ? MPI_Recv(mine, n, item, 0, 11, MPI_COMM_WORLD, MPI_STATUS_IGNORE)
                       : MPI_Send(mine, n, item, 0, 12, MPI_COMM_WORLD);
    }
    MPI_Type_free(&item);
    if (code != MPI_SUCCESS) {
        log_mpi_error(scatter ? "handing out chunks" : "collecting chunks", scatter ? "MPI_Isend" : "MPI_Irecv", code);
        return RAD_ERR_BACKEND;
    }
    return st;
}

rad_status ff_comm_scatter_cyclic(ff_comm *comm, const void *send, uint64_t count, uint32_t chunk, size_t item_bytes,
                                  ff_comm_area *area, const size_t *at)
{
    return cyclic_exchange(comm, (unsigned char *)send, area, at, count, chunk, item_bytes, 1);
}

rad_status ff_comm_gather_cyclic(ff_comm *comm, ff_comm_area *area, const size_t *at, uint64_t count, uint32_t chunk,
                                 size_t item_bytes, void *recv)
{
    return cyclic_exchange(comm, recv, area, at, count, chunk, item_bytes, 0);
}

void ff_comm_gather(ff_comm *comm, const void *data, size_t bytes, void *out, int root)
{
    if (comm->mpi.solo) {
        memmove(out, data, bytes);
        return;
    }
    MPI_Gather(data, (int)bytes, MPI_BYTE, out, (int)bytes, MPI_BYTE, root, MPI_COMM_WORLD);
}

void ff_comm_gather_u64v(ff_comm *comm, const uint64_t *data, uint64_t count, uint64_t *out, int root)
{
    if (comm->mpi.solo) {
        memmove(out, data, sizeof *data * count);
        return;
    }
    int n = (int)count;
    int *counts = NULL, *displs = NULL;
    if (comm->mpi.rank == root) {
        counts = calloc((size_t)comm->mpi.size, sizeof *counts);
        displs = calloc((size_t)comm->mpi.size, sizeof *displs);
    }
    MPI_Gather(&n, 1, MPI_INT, counts, 1, MPI_INT, root, MPI_COMM_WORLD);
    if (comm->mpi.rank == root)
        for (int r = 1; r < comm->mpi.size; r++) displs[r] = displs[r - 1] + counts[r - 1];
    MPI_Gatherv(data, n, MPI_UINT64_T, out, counts, displs, MPI_UINT64_T, root, MPI_COMM_WORLD);
    free(counts);
    free(displs);
}
