/* rad_mpi.c - rad_mpi.h. */
#include "rad_mpi.h"

#include <mpi.h>
#include <stdlib.h>

#include "rad_log.h"

int rad_mpi_launched(void)
{
    static const char *const vars[] = {"OMPI_COMM_WORLD_SIZE", "PMIX_RANK", "PMI_RANK", "PMI_SIZE"};
    for (size_t k = 0; k < sizeof vars / sizeof vars[0]; k++)
        if (getenv(vars[k])) return 1;
    return 0;
}

int rad_mpi_launcher_rank(void)
{
    static const char *const vars[] = {"OMPI_COMM_WORLD_RANK", "PMIX_RANK", "PMI_RANK"};
    for (size_t k = 0; k < sizeof vars / sizeof vars[0]; k++) {
        const char *v = getenv(vars[k]);
        if (v && *v >= '0' && *v <= '9') return atoi(v);
    }
    return 0;
}

rad_status rad_mpi_init(int *argc, char ***argv, rad_mpi_start *out)
{
    *out = (rad_mpi_start){.solo = 0, .we_initialized = 0, .rank = 0, .size = 1};
    int initialized = 0;
    MPI_Initialized(&initialized);
    if (!initialized && !rad_mpi_launched()) {
        out->solo = 1;
        return RAD_OK;
    }
    if (!initialized) {
        int provided = 0;
        if (MPI_Init_thread(argc, argv, MPI_THREAD_FUNNELED, &provided) != MPI_SUCCESS) {
            rad_error("MPI_Init failed");
            return RAD_ERR_BACKEND;
        }
        out->we_initialized = 1;
    }
    MPI_Comm_set_errhandler(MPI_COMM_WORLD, MPI_ERRORS_RETURN);
    MPI_Comm_rank(MPI_COMM_WORLD, &out->rank);
    MPI_Comm_size(MPI_COMM_WORLD, &out->size);
    return RAD_OK;
}

void rad_mpi_finalize(const rad_mpi_start *start, int barrier)
{
    if (start->solo || !start->we_initialized) return;
    if (barrier) MPI_Barrier(MPI_COMM_WORLD);
    MPI_Finalize();
}
