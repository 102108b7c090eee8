/* ff_comm_mpi.c - ff_comm.h on Open MPI; the only file that includes mpi.h. */
#include <limits.h>
#include <mpi.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "ff_comm.h"
#include "rad_log.h"

struct ff_comm {
    int rank, size, node_size;
    int we_initialized;
};

struct ff_comm_file {
    ff_comm *comm;
    MPI_File fh;
    char path[4096];
    rad_status status; /* first local failure */
};

/* MPI counts are int: large writes go in pieces of at most this many bytes. */
#define FF_MPI_MAX_BYTES ((size_t)1 << 30)

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
    int initialized = 0;
    MPI_Initialized(&initialized);
    if (!initialized) {
        if (MPI_Init(argc, argv) != MPI_SUCCESS) {
            rad_error("MPI_Init failed");
            free(c);
            return RAD_ERR_BACKEND;
        }
        c->we_initialized = 1;
    }
    MPI_Comm_set_errhandler(MPI_COMM_WORLD, MPI_ERRORS_RETURN);
    MPI_Comm_rank(MPI_COMM_WORLD, &c->rank);
    MPI_Comm_size(MPI_COMM_WORLD, &c->size);
    MPI_Comm node;
    MPI_Comm_split_type(MPI_COMM_WORLD, MPI_COMM_TYPE_SHARED, c->rank, MPI_INFO_NULL, &node);
    MPI_Comm_size(node, &c->node_size);
    MPI_Comm_free(&node);
    *out_comm = c;
    return RAD_OK;
}

void ff_comm_finalize(ff_comm *comm)
{
    if (!comm) return;
    if (comm->we_initialized) MPI_Finalize();
    free(comm);
}

int ff_comm_rank(const ff_comm *comm) { return comm->rank; }
int ff_comm_size(const ff_comm *comm) { return comm->size; }
int ff_comm_node_size(const ff_comm *comm) { return comm->node_size; }
double ff_comm_time(void) { return MPI_Wtime(); }

rad_status ff_comm_agree(ff_comm *comm, rad_status local)
{
    (void)comm;
    int in = (int)local, out = 0;
    MPI_Allreduce(&in, &out, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
    return (rad_status)out;
}

uint64_t ff_comm_max_u64(ff_comm *comm, uint64_t value)
{
    (void)comm;
    uint64_t out = 0;
    MPI_Allreduce(&value, &out, 1, MPI_UINT64_T, MPI_MAX, MPI_COMM_WORLD);
    return out;
}

rad_status ff_comm_sendrecv(ff_comm *comm, int dest, const double *send, size_t send_count, int source, double *recv,
                            size_t recv_count)
{
    (void)comm;
    if (send_count > FF_COMM_MAX_DOUBLES || recv_count > FF_COMM_MAX_DOUBLES) return RAD_ERR_INVALID;
    int code = MPI_Sendrecv(send, (int)send_count, MPI_DOUBLE, dest, 7, recv, (int)recv_count, MPI_DOUBLE, source, 7,
                            MPI_COMM_WORLD, MPI_STATUS_IGNORE);
    if (code != MPI_SUCCESS) {
        log_mpi_error("exchanging mirrored form factors", "MPI_Sendrecv", code);
        return RAD_ERR_BACKEND;
    }
    return RAD_OK;
}

void ff_comm_broadcast(ff_comm *comm, void *data, size_t bytes, int root)
{
    (void)comm;
    MPI_Bcast(data, (int)bytes, MPI_BYTE, root, MPI_COMM_WORLD);
}

void ff_comm_gather(ff_comm *comm, const void *data, size_t bytes, void *out, int root)
{
    (void)comm;
    MPI_Gather(data, (int)bytes, MPI_BYTE, out, (int)bytes, MPI_BYTE, root, MPI_COMM_WORLD);
}

void ff_comm_gather_u64v(ff_comm *comm, const uint64_t *data, uint64_t count, uint64_t *out, int root)
{
    int n = (int)count;
    int *counts = NULL, *displs = NULL;
    if (comm->rank == root) {
        counts = calloc((size_t)comm->size, sizeof *counts);
        displs = calloc((size_t)comm->size, sizeof *displs);
    }
    MPI_Gather(&n, 1, MPI_INT, counts, 1, MPI_INT, root, MPI_COMM_WORLD);
    if (comm->rank == root)
        for (int r = 1; r < comm->size; r++) displs[r] = displs[r - 1] + counts[r - 1];
    MPI_Gatherv(data, n, MPI_UINT64_T, out, counts, displs, MPI_UINT64_T, root, MPI_COMM_WORLD);
    free(counts);
    free(displs);
}

rad_status ff_comm_file_open(ff_comm *comm, const char *path, ff_comm_file **out_file)
{
    ff_comm_file *f = calloc(1, sizeof *f);
    rad_status status = f ? RAD_OK : RAD_ERR_NOMEM;
    if (f) {
        f->comm = comm;
        snprintf(f->path, sizeof f->path, "%s", path);
        int rc = MPI_File_open(MPI_COMM_WORLD, path, MPI_MODE_CREATE | MPI_MODE_WRONLY, MPI_INFO_NULL, &f->fh);
        if (rc != MPI_SUCCESS) {
            if (comm->rank == 0) log_mpi_error("cannot create", path, rc);
            status = RAD_ERR_IO;
        } else {
            MPI_File_set_errhandler(f->fh, MPI_ERRORS_RETURN);
            MPI_File_set_size(f->fh, 0); /* collective: a stale file of this name is emptied */
        }
    }
    status = ff_comm_agree(comm, status);
    if (status != RAD_OK) {
        free(f);
        return status;
    }
    *out_file = f;
    return RAD_OK;
}

static rad_status write_pieces(ff_comm_file *file, uint64_t offset, const void *data, size_t bytes, int collective)
{
    const char *p = data;
    do {
        size_t piece = bytes < FF_MPI_MAX_BYTES ? bytes : FF_MPI_MAX_BYTES;
        MPI_Status st;
        int rc = collective ? MPI_File_write_at_all(file->fh, (MPI_Offset)offset, p, (int)piece, MPI_BYTE, &st)
                            : MPI_File_write_at(file->fh, (MPI_Offset)offset, p, (int)piece, MPI_BYTE, &st);
        int written = 0;
        if (rc == MPI_SUCCESS) MPI_Get_count(&st, MPI_BYTE, &written);
        if (rc != MPI_SUCCESS || (size_t)written != piece) {
            if (file->status == RAD_OK) {
                if (rc != MPI_SUCCESS)
                    log_mpi_error("write failed", file->path, rc);
                else
                    rad_error("%s: short write (%d of %zu bytes; disk full?)", file->path, written, piece);
            }
            file->status = RAD_ERR_IO;
            return RAD_ERR_IO;
        }
        p += piece;
        offset += piece;
        bytes -= piece;
    } while (bytes > 0 && !collective);
    return RAD_OK;
}

rad_status ff_comm_file_write_all(ff_comm_file *file, uint64_t offset, const void *data, size_t bytes)
{
    /* Collective calls must match across ranks: callers keep bytes below
     * FF_MPI_MAX_BYTES (one piece), which the chunking in main guarantees. */
    if (bytes > FF_MPI_MAX_BYTES) {
        rad_error("internal: collective write of %zu bytes exceeds one piece", bytes);
        file->status = RAD_ERR_INVALID;
        return RAD_ERR_INVALID;
    }
    return write_pieces(file, offset, data, bytes, 1);
}

rad_status ff_comm_file_write(ff_comm_file *file, uint64_t offset, const void *data, size_t bytes)
{
    return write_pieces(file, offset, data, bytes, 0);
}

rad_status ff_comm_file_close(ff_comm_file *file)
{
    rad_status status = file->status;
    int rc = MPI_File_close(&file->fh);
    if (rc != MPI_SUCCESS && status == RAD_OK) {
        log_mpi_error("close failed", file->path, rc);
        status = RAD_ERR_IO;
    }
    status = ff_comm_agree(file->comm, status);
    free(file);
    return status;
}
