/* rad_lsolve.h - the radiosity solve on links (hierarchical radiosity,
 * issue 26): gather along the links, push down, pull up, per channel, to
 * a stated residual. solve runs it on a link file; formfactor runs it
 * between refinement passes (B for the BF oracle).
 *
 *     rad_lsolve_options o = rad_lsolve_defaults();
 *     rad_lsolve_result r;
 *     double *B = malloc(sizeof(double) * 3 * leaves->patch_count);
 *     rad_lsolve(&links, leaves, &o, B, &r);     // B[3 * leaf + c]
 *
 * One sweep, per channel c (rho, E: the leaf patches' values; a split
 * node's are its root's, which all its leaves share):
 *   gather  G_r = rho_r * sum over r's links of F_rs * B_s   (every node r)
 *           H_c = sum over c's links of F_cs * B_s           (every cluster c)
 *   push    down the cluster tree: H_c summed over c and the clusters above;
 *           into each root: G_root += rho_root * H of its leaf cluster;
 *           down each tree: D_leaf = sum of G over the leaf and its ancestors
 *           B_leaf = E_leaf + D_leaf
 *   pull    up each tree: B_node = area-weighted mean of its children's B;
 *           up the cluster tree: B_c = area-weighted mean of its roots' B
 * (sources s range over nodes and clusters; without clusters their lines
 * do nothing and the bytes are those of a solve that has none). Jacobi
 * gathers every G and H from the previous sweep's B; Gauss-Seidel gathers
 * the clusters' H from the sweep's start, then goes tree by tree (roots in
 * order) and gathers from the newest B, the trees already swept included
 * (a cluster's B stays its start value until the sweep's end, where the
 * clusters are pulled). The residual is today's solve's: the largest
 * |E + rho sum F B - B| over the leaves, scaled by ||E||_inf, of the
 * iterate returned (docs/solve.md). At --link-tol 0 on a uniform
 * hierarchy every link joins two leaves and this is the full matrix's
 * Jacobi / Gauss-Seidel on the same leaves.
 */
#ifndef RAD_LSOLVE_H
#define RAD_LSOLVE_H

#include <stdint.h>

#include "rad_closure.h"
#include "rad_links.h"
#include "rad_mesh.h"
#include "rad_status.h"

typedef enum rad_lsolve_method { RAD_LSOLVE_JACOBI = 1, RAD_LSOLVE_GAUSS_SEIDEL = 2 } rad_lsolve_method;

typedef struct rad_lsolve_options {
    rad_lsolve_method method;  /* default Gauss-Seidel */
    double tolerance;          /* scaled residual to reach; default 1e-6 */
    uint32_t max_iterations;   /* default 10000 */
    int threads;               /* OpenMP threads; 0 = the default */
    int warm_start;            /* 1: B holds a start iterate; 0: start from E */
    int channels;              /* 1: solve channel 0 and copy it (grey scene); 3 (default) */
    uint64_t group_links;      /* Gauss-Seidel in groups of consecutive trees of at least this many links
                                  (rad_lsolve.c); 0 (default): tree by tree below 4 M links, groups of
                                  65 536 links from there */
    int closure;               /* 1: the scene is closed; every leaf's row balanced to 1 first (rad_closure.h) */
} rad_lsolve_options;

rad_lsolve_options rad_lsolve_defaults(void);

typedef struct rad_lsolve_result {
    uint32_t iterations[3];
    double residual[3];
    int converged;             /* every channel met the tolerance */
    /* The energy balance over the leaves (as solve's, docs/solve.md):
     * emitted = sum A E, absorbed = sum A (1 - rho) H, escaped =
     * sum A B (1 - s) with s a leaf's row sum (its, its ancestors' and
     * its root's clusters' links' F), summed over the channels;
     * imbalance = (absorbed + escaped - emitted) / emitted. */
    double emitted, absorbed, escaped, imbalance;
    rad_closure_result closure; /* with options.closure: the scales found (their sweeps' time included in seconds) */
    double seconds;
} rad_lsolve_result;

/* Solves into B (3 values per leaf, RGB). RAD_ERR_NOMEM; RAD_ERR_INVALID
 * for a leaves mesh that does not match the links, or trees, clusters or
 * a link table it cannot index (rad_links.h). Logs progress (info)
 * on long runs. Zero fields of options (options NULL: all) are the
 * defaults. A channel that stops at max_iterations gives
 * RAD_ERR_NOT_CONVERGED with B and *out filled (the last iterate
 * measured; converged 0); other failures leave B and *out untouched. With
 * channels 1 the balance is channel 0's (as solve reports a grey scene). */
rad_status rad_lsolve(const rad_links *links, const rad_mesh *leaves, const rad_lsolve_options *options, double *B,
                      rad_lsolve_result *out);

#endif
