/* stage.h - the solve stage as one call: form-factor file in, radiosity
 * file (and optionally a stats JSON) out. main.c only parses the command
 * line into solve_options; tests call this directly.
 *
 * Before solving, the matrix is checked against the patch table: rows
 * summing above 1 beyond their accuracy get a warning, rows with
 * rho * row sum >= 1 in any channel are refused (nothing is written).
 *
 * With by_group, a form-factor file without a group table (version 1) is
 * refused before solving; the per-group file is written after the
 * radiosity file and the stats.
 *
 * Grey scenes (rho and E equal in all three channels on every patch) are
 * solved once and stored in all three channels. A channel that does not
 * converge does not stop the others; the radiosity file is still written,
 * marked unconverged, and the result is RAD_ERR_NOT_CONVERGED.
 *
 * Across ranks each rank reads only its rows; rank 0 alone logs and
 * writes the outputs; every rank returns the same status.
 *
 * A file of links (hierarchical radiosity, issue 26) is solved on its
 * links instead, once open (links.h).
 */
#ifndef SOLVE_STAGE_H
#define SOLVE_STAGE_H

#include "rad_ffile.h"
#include "rad_rfile.h"
#include "rad_status.h"
#include "solver.h"

#define SOLVE_DEFAULT_INPUT "formfactors"
#define SOLVE_DEFAULT_OUTPUT "radiosity"

/* Where the iterations run (docs/solve.md, "On the GPU"). */
typedef enum solve_backend {
    SOLVE_BACKEND_AUTO = 0, /* cuda when this build has CUDA, a GPU is visible and the matrix stores at least
                               SOLVE_GPU_AUTO_MIN_ENTRIES entries (gpu.h), else cpu */
    SOLVE_BACKEND_CPU,
    SOLVE_BACKEND_CUDA      /* cg and jacobi on the GPU; gauss-seidel and every verification on the CPU */
} solve_backend;

/* "auto", "cpu", "cuda". */
const char *solve_backend_name(solve_backend backend);
/* Parses one of those names; RAD_ERR_USAGE (logged) otherwise, and for
 * "cuda" in a build without CUDA. */
rad_status solve_backend_parse(const char *name, solve_backend *out_backend);

struct solve_matrix; /* matrix.h */

typedef struct solve_options {
    const char *input;   /* form-factor file; NULL = SOLVE_DEFAULT_INPUT */
    const char *output;  /* radiosity file; NULL = SOLVE_DEFAULT_OUTPUT */
    const char *stats;   /* JSON statistics file; NULL = none */
    const char *errors;  /* standard errors of the form factors (formfactor --errors); NULL = none:
                            row sums are then judged by a fixed threshold (matrix.h) */
    const char *by_group; /* results per OBJ group, .csv or .npy (groups.h); NULL = none. The
                             form-factor file must have a group table (version 2) */
    solve_backend backend; /* 0 = auto. cuda without a visible GPU: RAD_ERR_BACKEND before anything is read */
    solve_params params; /* zero = defaults (solver.h) */
    solve_comm *comm;    /* the ranks of `mpirun -n K solve` (comm.h); NULL = this process alone.
                            Every rank calls solve_stage_run with the same options */
    /* A matrix already open instead of `input` (which then only names it in
     * messages): formfactor --radiosity hands over the rows it holds in
     * memory (rad_ff_open_held). Borrowed: the caller closes it. NULL =
     * open `input`. */
    rad_ff_file *matrix;
    /* With `matrix`: this rank's rows already in memory (solve_matrix_begin,
     * append, end; formfactor --radiosity), taken over by the stage (left
     * zeroed); `matrix` then only gives the header and the patch table
     * (rad_ff_open_tables). NULL: the rows are read from `matrix`. */
    struct solve_matrix *loaded;
    /* With `matrix` under several ranks: ranks + 1 entries, each rank's
     * first row - the rows `matrix` holds on each rank - aligned by
     * solve_stage_align_split. NULL: the stage splits the rows itself. */
    const size_t *row_split;
    int threads; /* OpenMP threads of this rank; 0 = OpenMP's own default (OMP_NUM_THREADS, else every core) */
    /* Links only: after the flat sweeps, solve again with every link
     * spread over its elements' leaves (shaped.h). 0 = on (the default),
     * 1 = off (--shape off: the flat solution). */
    int no_shape;
    /* Links only: balance every leaf's row to 1 first (rad_closure.h).
     * SOLVE_CLOSURE_AUTO (0, the default): where the file says the scene
     * is closed (RAD_FF_FLAG_CLOSED). */
    int closure;
} solve_options;

enum { SOLVE_CLOSURE_AUTO = 0, SOLVE_CLOSURE_ON = 1, SOLVE_CLOSURE_OFF = 2 };

/* A row split (ranks + 1 entries, row_split[ranks] = n) moved to the
 * chunks the GPU backend's reductions add (solve_gpu_row_quantum), so that
 * the results are the same bits for any number of ranks; the stage splits
 * so, and a caller that gives row_split must too. */
void solve_stage_align_split(size_t *row_split, size_t ranks, size_t n);

rad_status solve_stage_run(const solve_options *options);

/* Is every patch grey (rho and E equal in the three channels)? Then one
 * channel is solved and stored in all three. */
int solve_mesh_is_grey(const rad_mesh *mesh);

/* The radiosity file's fields that come from the form-factor file `info`
 * (opened as `input`): the scene fingerprint, the Ke flag and the scene's
 * path (none, with a warning when `speak`, where it does not fit). Shared
 * by matrix and link files (links.c). */
void solve_radiosity_describe(const rad_ff_info *info, const char *input, int speak, rad_radiosity *out);

#endif
