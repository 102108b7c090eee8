/* main.c - the `formfactor` command line: form factors F_ij for every
 * patch pair of a subdivided scene.
 *
 *     mpirun -n P formfactor [options] [SCENE.obj]
 *
 * Starts MPI (ff_comm.h; a plain `./formfactor` runs solo), parses the
 * options (ff_options.h) and runs (ff_driver.h); the only place that
 * exits. Every rank parses the same argv and runs; rank 0 speaks for all.
 */
#include <stdio.h>

#include "ff_comm.h"
#include "ff_cuda.h"
#include "ff_driver.h"
#include "ff_options.h"
#include "rad_mpi.h"
#include "rad_log.h"

#define FF_VERSION RAD_VERSION /* the project version (core/CMakeLists.txt) */

int main(int argc, char **argv)
{
    rad_log_set_program("formfactor");
    /* CUDA starts while MPI and the scene do (ff_cuda.h), unless the run
     * will not use it. */
    if (ff_options_may_use_gpu(argc, argv)) ff_cuda_prestart(rad_mpi_launcher_rank());
    ff_comm *comm = NULL;
    rad_status st = ff_comm_init(&argc, &argv, &comm);
    if (st != RAD_OK) {
        ff_cuda_prestart_join();
        return rad_status_exit_code(st);
    }
    int rank = ff_comm_rank(comm);
    ff_options options;
    rad_log_level level = rad_log_get_level();
    if (rank != 0) rad_log_set_level(RAD_LOG_NONE);
    st = ff_options_parse(argc, argv, &options);
    if (rank != 0) rad_log_set_level(level);
    if (st == RAD_OK && (options.help || options.version)) {
        if (rank == 0) {
            if (options.help) fputs(ff_options_help, stdout);
            else printf("formfactor %s\n", FF_VERSION);
        }
    } else if (st == RAD_OK) {
        if (options.quiet) rad_log_set_level(RAD_LOG_ERROR);
        if (rank != 0) rad_log_set_level(RAD_LOG_ERROR);
        st = ff_driver_run(comm, &options);
    } else if (rank == 0) {
        fprintf(stderr, "formfactor: try --help\n");
    }
    ff_cuda_prestart_join();
    ff_comm_finalize(comm);
    return rad_status_exit_code(st);
}
