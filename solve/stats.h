/* stats.h - the --stats JSON file: what was solved, how, and the residual
 * history of every channel (schema in docs/solve.md). */
#ifndef SOLVE_STATS_H
#define SOLVE_STATS_H

#include <stddef.h>
#include <stdint.h>

#include "matrix.h"
#include "rad_status.h"
#include "shaped.h"
#include "solver.h"

/* A file of links (links.c): what it held and the balance of its solve. */
typedef struct solve_stats_links {
    uint64_t node_count, leaf_count, link_count;
    double link_tol;          /* the --link-tol formfactor refined to */
    double error_bound;       /* formfactor's bound on B's relative error from the links' errors; 0: unknown */
    solve_balance balance;    /* over the leaves, summed over the channels solved (rad_lsolve_result),
                                 of the shaped solve where it ran, else of the flat one */
    const solve_shaped_result *shaped; /* the shaped solve's (shaped.h); NULL where it did not run */
    const rad_closure_result *closure; /* the rows balanced to 1 (rad_closure.h); NULL: closure off */
} solve_stats_links;

typedef struct solve_stats {
    const char *input;            /* form-factor file */
    const char *output;           /* radiosity file */
    const char *errors;           /* standard-error file (--errors); NULL = none */
    solve_row_sum_summary row_sums;
    size_t patch_count;
    solve_method method;          /* as asked (auto stays auto) */
    double tolerance;
    uint32_t max_iterations;
    double load_seconds;          /* reading and validating the matrix */
    const char *backend;          /* "cpu" or "cuda": where the iterations ran (auto resolved) */
    const char *device;           /* the GPU's name; NULL on the CPU */
    int device_exact;             /* the GPU's float matrix is the file's (1) or rounded (0); -1 on the CPU */
    double upload_seconds;        /* copying the matrix to the GPU; 0 on the CPU */
    double total_seconds;
    int converged;                /* every channel */
    uint32_t channel_count;       /* 1 (grey) or 3 */
    const char *channel_names[3];
    const solve_report *reports[3];
    uint32_t rank_count;           /* MPI ranks (1 alone; 0 is read as 1) */
    const uint64_t *rank_rows;     /* rank_count: rows each rank held; NULL = not known */
    const uint64_t *rank_entries;  /* rank_count: stored entries each rank held */
    const solve_stats_links *links; /* a file of links; NULL for a matrix */
} solve_stats;

/* Writes `stats` as JSON to `path` (temporary name + rename). */
rad_status solve_stats_write(const char *path, const solve_stats *stats);

#endif
