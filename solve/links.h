/* links.h - solve on a file of links (hierarchical radiosity, issue 26;
 * docs/solve.md, "On links"): the links read, checked against the leaves'
 * materials, solved by rad_lsolve (core/rad_lsolve.h) and written as the
 * radiosity file of the leaves mesh, with the --stats JSON. stage.c hands
 * such a file over once it is open.
 *
 * What solve's options mean here: --method gauss-seidel (also auto, the
 * default) or jacobi, sweeps over the links (cg is refused: the system on
 * links is solved by sweeps only); --tol and --max-iter as for a matrix,
 * the residual being max |E + rho sum F B - B| over the leaves, over
 * ||E||_inf; --backend: where the shaped solve runs (cuda: the GPU,
 * refused without one; auto: the GPU for one process from
 * SOLVE_SHAPED_GPU_MIN_WEIGHTS point factors, shaped.h), and with it the
 * flat sweeps that start it (solve_links_flat_on_gpu; --shape off keeps
 * them on the CPU); threads: OpenMP's default (OMP_NUM_THREADS). --errors
 * does not apply (each link carries its own error bound) and --by-group
 * is not available yet: both are refused before anything is solved.
 *
 * Across ranks every rank solves the same links (the bytes do not depend on
 * it) and rank 0 writes; every rank returns the same status.
 */
#ifndef SOLVE_LINKS_H
#define SOLVE_LINKS_H

#include "rad_ffile.h"
#include "rad_links.h"
#include "rad_lsolve.h"
#include "rad_mesh.h"
#include "rad_status.h"
#include "stage.h"

/* Reads the links of `file` (open, of layout links) and solves them as
 * solve_links_solve. The file stays open (the caller closes it). */
rad_status solve_links_run(const solve_options *options, rad_ff_file *file);

/* The flat solve that starts the shaped one runs on the GPU where
 * --backend cuda asks for it, or under auto for one process from this many
 * links up where a GPU is visible: the flat operator's Jacobi sweeps,
 * 16 bytes a link on the GPU (solve_links_flat_gpu), against Gauss-Seidel on
 * the CPU's threads (the 10^6-triangle interior's 410 M links: docs/
 * performance.md). formfactor's last pass asks the same question, so that
 * --radiosity's flat solve is the one solve would run on the file. */
#define SOLVE_LINKS_FLAT_GPU_MIN_LINKS ((uint64_t)4 << 20)
int solve_links_flat_on_gpu(solve_backend backend, int ranks, uint64_t link_count);

/* rad_lsolve's problem (o: tolerance, iterations, channels, threads,
 * warm_start; not closure) solved by Jacobi sweeps on GPU `device` (mod the
 * devices) into B and *out; device_name (128 bytes, may be NULL) gets the
 * GPU's name. RAD_ERR_NOT_CONVERGED as rad_lsolve; RAD_ERR_BACKEND (a
 * warning logged) where the GPU cannot run it, B then untouched (the caller
 * solves on the CPU). */
rad_status solve_links_flat_gpu(const rad_links *links, const rad_mesh *leaves, const rad_lsolve_options *o,
                                int device, double *B, rad_lsolve_result *out, char *device_name);

/* A flat solve already run on the links from B = E (rad_lsolve, or
 * solve_links_flat_gpu where `gpu`; the channels as solve_mesh_is_grey
 * says), which solve_links_solve takes as its own where it converged to
 * the tolerance, by the method and on the device the solve would use: the
 * same sweeps, so the same bytes, run once (formfactor --radiosity's last
 * pass). */
typedef struct solve_links_flat {
    const double *B; /* 3 per leaf */
    rad_lsolve_result result;
    double tolerance;
    rad_lsolve_method method;
    int channels; /* 1 or 3 */
    int gpu;      /* solved by solve_links_flat_gpu */
    const char *device; /* there: the GPU's name */
} solve_links_flat;

/* The links, as read, and where they came from. */
typedef struct solve_links_input {
    const rad_ff_info *info;  /* the file's header: fingerprint, flags, scene path */
    const rad_mesh *leaves;   /* the leaves mesh (the file's patch table) */
    const rad_links *links;
    double load_seconds;      /* reading them */
    const solve_links_flat *flat; /* NULL: none solved yet */
} solve_links_input;

/* Everything after reading: checks, the solve, the radiosity file and the
 * stats. RAD_ERR_NOT_CONVERGED once the outputs are written, marked
 * unconverged; RAD_ERR_USAGE for --method cg, --errors and --by-group;
 * RAD_ERR_BACKEND for --backend cuda without a visible GPU (nothing
 * solved or written);
 * RAD_ERR_INVALID for a leaf with rho * row sum >= 1 (nothing written). */
rad_status solve_links_solve(const solve_options *options, const solve_links_input *in);

#endif
