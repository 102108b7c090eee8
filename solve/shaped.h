/* shaped.h - hierarchical radiosity's links solved with their shape
 * (issue 26): every link spread over the leaves of its two elements by the
 * point factor, solved to a stated residual from the flat solution.
 *
 *     rad_lsolve(&links, leaves, &o, B, &r);         // the flat solution
 *     solve_shaped_options so = {.tolerance = 1e-10, .gate = 1e-3};
 *     solve_shaped_result sr;
 *     solve_shaped(&links, leaves, &so, B, &sr);     // B: the shaped solution, in place
 *
 * Why. A link r <- s carries one form factor F_rs for all of r and one
 * source value for all of s. The flat solve (rad_lsolve) therefore gives
 * every leaf under a coarse receiver the same share of what s sends, and
 * takes s's plain area mean as what s sends: an image shows r's outline as
 * a step, and a leaf in a room's corner gets the room's mean view of a
 * wall it sees at a half. The oracle must then refine every link whose
 * factor varies over r, however smooth that variation.
 *
 * What. With f_x the unoccluded factor from leaf x's centroid (its normal)
 * to the other element's polygon, in closed form (rad_ff_point_polygon),
 * and u_x = f_x / (the area-weighted mean of f over the element's leaves),
 * link r <- s gives leaf x under r
 *
 *     F_rs u_x S_rs,     S_rs = sum_{y under s} A_y u_y B_y / A_s
 *
 * (u over s's leaves taken towards r). The leaves under r share the
 * link's power by how well each sees s (the mean of u over r is 1, so a
 * uniform B moves what it moved flat), and the part of s that faces r
 * counts more in what s sends. The operator stays reciprocal:
 * A_x K_xy = c_rs A_x A_y u_x u_y = A_y K_yx, because each end of a pair
 * is shaped or not for both of the pair's links. So a closed scene's
 * energy balances as flat. The visible fraction stays the link's one
 * number: shadows inside a link are the oracle's (it splits partly hidden
 * pairs). A link between two leaves is unchanged (u = 1), so at
 * --link-tol 0 the result is the flat solve's to the bit; so is an end
 * whose point factors all vanish (a grazing link).
 *
 * Which ends. An element end of a pair is shaped where it is split and
 * shaping may move a leaf by at least gate times the mean B of the leaves
 * that do not emit: rho_r e_rs B_s (e_rs the link's bound on how far the
 * factor from a leaf of r may lie from F_rs) or rho_s F_sr (max - min of B
 * over r's leaves), for the pair's either direction.
 *
 * Clusters (rad_links.h, issue 27). A link at or from a cluster is not
 * shaped: its receiver side spreads uniformly over the cluster's leaves
 * and a cluster source sends its area-weighted mean, as in rad_lsolve.
 * Its pair touches the same cluster, so it is flat too, and the flat
 * cluster links are reciprocal with the cluster's area (A_x K_xy =
 * c_rs A_x A_y for x, y under the pair's ends): the operator stays
 * reciprocal and a closed scene still balances. Element-element links
 * are shaped as above.
 *
 * How. Sweeps over the leaves from the flat solution ("Where"): the sources'
 * S (shaped ends summed over their leaves), the unshaped receivers'
 * gathers pushed down the trees as flat, the shaped receivers' added per
 * leaf. The residual is rad_lsolve's: max |E + rho K B - B| over the
 * leaves and channels, over ||E||_inf, of the iterate returned. The point
 * factors are computed once and stored (4 bytes each). The bytes do not
 * depend on the thread count.
 *
 * Where. The CPU (the default) computes the point factors on the host
 * threads and sweeps Gauss-Seidel in groups of consecutive trees (a group
 * closes at SOLVE_SHAPED_GROUP_WORK links and point factors read; a
 * group's trees gather in parallel, from this sweep's values of the groups
 * before it and the last sweep's of their own, so the many small trees of
 * a scene of a few thousand faces fill the threads, which tree by tree ran
 * on one). The cuda backend
 * (shaped_gpu.h) computes them on the GPU and sweeps Jacobi there, every
 * tree at once, copying back three maxima a sweep; the plan (which ends,
 * the ranges, the pairs) stays the host's. Its Jacobi stops where its
 * change, which is the residual of the iterate it swept from, meets the
 * tolerance, and returns that iterate, as the CPU returns the iterate its
 * last sweep measured. The host backend runs the cuda backend's steps on
 * the host, item by item through the same functions (shaped_math.h), for
 * tests without a GPU. The GPU's results are the same bits run after run;
 * against the CPU's they differ by the two methods' stopping points (both
 * within the tolerance) and by a point factor whose float rounds the other
 * way where the GPU's atan2 differs from the host's in the last bit.
 */
#ifndef SOLVE_SHAPED_H
#define SOLVE_SHAPED_H

#include <stdint.h>

#include "rad_closure.h"
#include "rad_links.h"
#include "rad_mesh.h"
#include "rad_status.h"

/* Where the point factors and the sweeps run. */
typedef enum solve_shaped_backend {
    SOLVE_SHAPED_CPU = 0, /* host threads, Gauss-Seidel (the default) */
    SOLVE_SHAPED_AUTO,    /* cuda where this build has CUDA, a GPU is visible and there are at least
                             SOLVE_SHAPED_GPU_MIN_WEIGHTS point factors (falling back to cpu, with a warning,
                             where the GPU fails); else cpu */
    SOLVE_SHAPED_CUDA,    /* the GPU, Jacobi; RAD_ERR_BACKEND (logged) without one, RAD_ERR_UNSUPPORTED in a
                             build without CUDA */
    SOLVE_SHAPED_HOST     /* the cuda backend's steps on the host (shaped_gpu.h): tests */
} solve_shaped_backend;

/* "cpu", "auto", "cuda", "host". */
const char *solve_shaped_backend_name(solve_shaped_backend backend);

/* auto takes the GPU from this many point factors up, where the CPU's
 * shaped solve takes longer than starting CUDA (0.2-0.3 s, less where it
 * overlapped the file's reading): cornell_sphere's 11 776 leaves at
 * link-tol 1e-3 have 2.1 M factors, 0.77 s on 2 cores (factors 0.25 s,
 * sweeps 0.47 s), so 4 M take ~1.5 s there and ~0.2 s on 16 cores; its
 * 188 416 leaves have 47 M, ~11 s on 2 cores. */
#define SOLVE_SHAPED_GPU_MIN_WEIGHTS ((uint64_t)4 << 20)
/* The point factors are known once the ends are chosen; solve starts CUDA
 * while a file of links loads (stage.c) from this many leaves up, where
 * they may reach that (cornell_sphere at link-tol 1e-3: 180 a leaf at
 * 11 776 leaves, 250 at 188 416). */
#define SOLVE_SHAPED_GPU_PRESTART_LEAVES 16384u

/* Gauss-Seidel's groups of trees on the CPU close at this much work: links
 * and point factors a sweep reads, ~1 ns each on one core. The Cornell
 * box at the quick start's flags (3 M point factors): 6 groups instead of
 * 29 trees, 8 sweeps either way, the sweeps 0.10 -> 0.026 s on 16 cores
 * (docs/performance.md, "The Cornell box within the bars"). */
#define SOLVE_SHAPED_GROUP_WORK ((uint64_t)1 << 20)

typedef struct solve_shaped_options {
    int threads;             /* OpenMP threads; 0 = OpenMP's default */
    solve_shaped_backend backend;
    int device;              /* cuda: the GPU, mod the devices (an MPI rank's); 0 alone */
    double gate;             /* shape an end where it may move a leaf by gate x the mean reflected B */
    double tolerance;        /* residual to reach (> 0) */
    uint32_t max_iterations; /* > 0 */
    int channels;            /* 1: a grey scene (the balance is channel 0's, as rad_lsolve's); else 3 */
    uint64_t group_work;     /* cpu: Gauss-Seidel's groups close at this much work; 0 = SOLVE_SHAPED_GROUP_WORK,
                                1 = tree by tree (tests) */
    int closure;             /* 1: the scene is closed; every leaf's row of the shaped operator balanced to 1
                                first (rad_closure.h) */
    int flat;                /* 1: no end shaped - the links' flat operator, swept by the backend (on cuda,
                                formfactor's passes' solves: a flat Jacobi on the GPU); neither the pairs are
                                looked for nor a per-link array kept */
} solve_shaped_options;

typedef struct solve_shaped_result {
    uint64_t shaped_ends;   /* link ends spread over their leaves (each pair's end counted once per link) */
    uint64_t weights;       /* point factors stored: one per leaf of a shaped end */
    uint32_t iterations;
    double residual;        /* the largest over the channels */
    int converged;
    double change;          /* max |B - B_flat| / max |B_flat| over leaves and channels */
    double emitted, absorbed, escaped, imbalance; /* as rad_lsolve_result's, for the shaped operator */
    double seconds;
    double factor_seconds;  /* of those: the point factors and the dropped ends (cuda: with the copies to the GPU) */
    double sweep_seconds;   /* of those: the sweeps (cuda: with the start's and the result's copies) */
    solve_shaped_backend backend; /* the one that ran: cpu, cuda or host (never auto) */
    char device[128];       /* where: "cpu", "host" or the GPU's name */
    rad_closure_result closure; /* with options.closure: the scales (their sweeps inside sweep_seconds) */
} solve_shaped_result;

/* B: 3 values per leaf patch (RGB): the flat solution on entry, the
 * shaped one on return (also when not converged: *out says so, and the
 * status is RAD_ERR_NOT_CONVERGED); untouched on other failures.
 * RAD_ERR_NOMEM (logged); RAD_ERR_INVALID for a leaves mesh that does
 * not match the links, a link without its pair, or a residual that is
 * not finite; RAD_ERR_BACKEND or RAD_ERR_UNSUPPORTED where cuda cannot
 * run (logged). The links must have passed rad_links_check. */
rad_status solve_shaped(const rad_links *links, const rad_mesh *leaves, const solve_shaped_options *options, double *B,
                        solve_shaped_result *out);

#endif
