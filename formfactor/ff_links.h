/* ff_links.h - hierarchical radiosity's links (issue 26,
 * docs/hierarchy.md): element quadtrees over the --subdiv 0 mesh, and
 * links between elements at the coarsest pair of levels whose error
 * estimate meets --link-tol.
 *
 *     ff_links links;
 *     ff_links_init(&links, &scene, &base, centre, &config, backend, state);
 *     ff_links_refine(&links, NULL, &counters);        // pass 1: B = E
 *     ... solve on ff_links_export's links, then:
 *     ff_links_refine(&links, leaf_radiosity, &counters);  // pass 2: B of the solution
 *     ff_links_export(&links, &out_links, &leaves);
 *     ff_links_free(&links);
 *
 * Refinement goes in rounds, breadth first (Meyer et al. 2009): a round's
 * candidate pairs are computed together by the backend (compute_pairs,
 * any thread count), then decided: a pair whose estimate meets the
 * tolerance becomes a link, any other is replaced by its children's pairs
 * in the next round (the larger element split, both where their areas are
 * within 2x). The decisions run on the threads by chunks with the result
 * of deciding in list order (the elements a split makes, one thread in
 * that order; the links and pairs at the chunks' offsets), so the elements,
 * their numbering and the links are the same for any number of threads,
 * ranks or backends. A candidate's estimate is its coupling c
 * and, per direction, the error e of F (the spread of the point-to-element
 * factor over the receiver's corners and centre, the partial-visibility
 * term and the quadrature's error); the oracle weighs it (ff_oracle).
 */
#ifndef FF_LINKS_H
#define FF_LINKS_H

#include <stddef.h>
#include <stdint.h>

#include "ff_backend.h"
#include "ff_clusters.h"
#include "ff_counters.h"
#include "ff_rank_rounds.h"
#include "rad_hierarchy.h"
#include "rad_links.h"
#include "rad_mem.h"
#include "rad_mesh.h"
#include "rad_scene.h"
#include "rad_status.h"

/* --oracle: what a link's estimate is weighed by before it is held against
 * link_tol. B_mean is the mean radiosity of the surfaces that do not emit
 * (area-weighted, brightest channel; the emitted power over the scene's
 * area before a solution exists), P the emitted power (sum of A E), B_s the
 * source's radiosity (E before a solution exists), e_rs the error of F_rs
 * (above), both directions of a pair taken.
 *   error: rho_r B_s e_rs > link_tol B_mean (what the link's error may move r's
 *                                            radiosity by, against the scene's
 *                                            typical radiosity; auto's pick
 *                                            with adaptive leaves)
 *   power: rho_r A_r B_s F_rs > link_tol P  (transported power, BF: HSA 1991)
 *   factor: F_rs > link_tol                 (form factor alone: the unweighted 1991 oracle)
 *   gather: rho_r B_s g_rs > link_tol B_mean (error's test on g_rs, what is left of e_rs after
 *                                            solve's shaped solve, solve/shaped.h: that
 *                                            solve spreads a link over r's leaves by the point
 *                                            factor, so of the factor's variation over r only
 *                                            what a leaf's centre misses of the leaf remains,
 *                                            estimated from the curvature over r's sample points
 *                                            times 4^-d (d: levels from r down to its leaves, known
 *                                            with uniform leaves; 0 otherwise: g = e); the
 *                                            partial-visibility and quadrature terms stay whole;
 *                                            plus rho_r F_rs dB_s min(1, e_sr / F_sr), the
 *                                            source's spread of B, which no shape removes) */
typedef enum ff_oracle {
    FF_ORACLE_ERROR = 0,
    FF_ORACLE_POWER = 1,
    FF_ORACLE_FACTOR = 2,
    FF_ORACLE_GATHER = 3
} ff_oracle;
const char *ff_oracle_name(ff_oracle oracle);
/* --oracle auto: gather where the leaves are known in advance (uniform or
 * sized leaves: the shaped solve spreads coarse links over them), else error
 * (adaptive leaves: a coarse receiver is often its own leaf, with nothing
 * to spread over, and the sender term costs links: docs/hierarchy.md). */
#define FF_ORACLE_AUTO (-1)
static inline ff_oracle ff_oracle_resolve(int asked, int leaves_known)
{
    return asked != FF_ORACLE_AUTO ? (ff_oracle)asked : leaves_known ? FF_ORACLE_GATHER : FF_ORACLE_ERROR;
}

typedef struct ff_links_config {
    double link_tol;    /* >= 0; 0: every pair to the finest elements */
    ff_oracle oracle;
    uint32_t max_level; /* elements split at most this often (--subdiv in hierarchical runs) */
    double min_area;    /* scene units^2: no element is split into children smaller than this */
    int uniform_leaves; /* every root split to max_level first: the leaves of the full matrix at
                           --subdiv max_level, whatever the tolerance (to compare the two) */
    int sized_leaves;   /* every root split first until its elements are no larger than the
                           largest root's at max_level: leaves of about one size, known in
                           advance as uniform ones are (fewer where the roots differ in size) */
    int clusters;       /* refinement starts from the self-link of a cluster tree over the roots
                           (ff_clusters.h) instead of every pair of roots */
    double cluster_cone; /* radians: a cluster whose normals spread more than this from their mean
                            links nothing and is split (by orientation in the tree); 0 or pi: none */
    double ray_delta;    /* scene units: the cluster links' shadow segments' (ff_segment) */
    double cluster_open; /* a cluster whose faces' openness (ff_openness.h) spreads more than this
                            links nothing and is split; 1 or more: none (nothing measured) */
    const double *triangles;       /* the occluders (ff_occluders_build), for the openness */
    const uint32_t *triangle_face;
    uint32_t triangle_count;
} ff_links_config;

/* --clusters auto turns clusters on from this many roots up: below, the
 * k^2 pairs of roots cost less than the cluster links' rays (measured,
 * docs/hierarchy.md "Clusters"). */
#define FF_CLUSTERS_AUTO_ROOTS 2048u

/* The quadrature tolerance of a hierarchy's pairs (ff_setup.quad_rtol):
 * under a link tolerance a relative 1e-5 (or --quad-rtol where it asks
 * less), not the full matrix's 1e-8. A link's error goes to the oracle,
 * whose tolerance is 1e-2 of the mean radiosity by default, and the
 * quadrature then stays 1000 times under anything it weighs. On the 10^4
 * interior the quadrature's time fell 2.4x for the same image to the last
 * digit printed, and cluttered_room's error against its full matrix is
 * the same to four digits at every link-tol from 1e-1 to 1e-4
 * (docs/performance.md). The shadow rays stop where the oracle has no use
 * for more: each element pair's job carries a ray floor (ff_pair_job,
 * ff_links.c's ray_floor), an eighth of the coupling error the oracle
 * would split it for; fewer rays for every pair alike had left the
 * leaves' links a floor of visibility noise that the tolerance no longer
 * moved. Under --link-tol 0 the run's tolerance and batches stand: the
 * links are then the full matrix of the leaves, entry for entry. */
#define FF_LINK_QUAD_RTOL 1e-5
static inline double ff_links_quad_rtol(double link_tol, double quad_rtol)
{
    return link_tol > 0 && quad_rtol < FF_LINK_QUAD_RTOL ? FF_LINK_QUAD_RTOL : quad_rtol;
}

/* Pair ids and FF_CLUSTER_RAYS: ff_cluster_math.h. */

/* A link as refinement holds it: both directions of one pair (24 bytes;
 * the gather oracle's g of each direction is beside it, ff_links.link_left:
 * at 10^6 triangles the links are most of the host's memory). */
typedef struct ff_link_pair {
    uint32_t a, b;           /* pair ids (elements or clusters), a < b */
    double coupling;         /* c_ab = F_ab / A_b = F_ba / A_a */
    float error_ab, error_ba; /* e of F_ab, of F_ba (F units) */
} ff_link_pair;

/* What refinement did, all passes (the stats'). */
typedef struct ff_links_tally {
    uint64_t candidates, refined_pairs, rounds;
    uint64_t cluster_pairs, cluster_rays; /* candidates with a cluster at an end, their segments */
    double cluster_seconds;               /* their wall (the backend's cluster_draws) */
    double open_seconds;                  /* the faces' openness (ff_backend.openness), before the cluster tree */
    /* the rounds' wall by part: the candidates sorted into element and
     * cluster pairs, the backend's calls (both kinds, beside each other),
     * the decisions (links kept, pairs split, new elements), and a later
     * pass's links re-weighed; of the last two, the new elements made
     * (one thread, in order) */
    double seconds_sort, seconds_backend, seconds_decide, seconds_reweigh, seconds_elements;
} ff_links_tally;

typedef struct ff_links {
    const rad_scene *scene;
    double centre[3];
    ff_links_config config;
    const ff_backend *backend;
    void *backend_state;
    ff_rank_rounds *ranks; /* NULL: this process computes every round's pairs; else the ranks share them
                              (ff_rank_rounds.h), rank 0 refining: set by the caller after ff_links_init */
    rad_hierarchy tree;
    rad_ff_patch *patches; /* per element, the backend's frame */
    uint32_t *keys;        /* per element: its first leaf's patch index in the mesh of the leaves
                              (uniform or sized leaves; else the --subdiv mesh's) */
    uint32_t *root_key;    /* per root, with exact_keys: its key */
    size_t patch_cap;
    int exact_keys;        /* the leaves' count fits 32 bits: keys are those indices, else element indices */
    uint8_t *leaf_level;   /* per root, the level of its leaves where they are made in advance
                              (uniform or sized leaves), else NULL (leaves by refinement) */
    double *radiosity;     /* per element, RGB: the oracle's B (E until a solution is given) */
    double *spread;        /* per element: max - min of B over its leaves, the largest channel's (0 until then) */
    double emitted_power;  /* P */
    double total_area;     /* of the roots */
    double reflected;      /* B_mean: the mean radiosity of what does not emit (area-weighted,
                              brightest channel): P / area until a solution is given */
    ff_cluster_tree clusters;  /* config.clusters: the tree over the roots */
    double *cluster_radiosity; /* per cluster, RGB: the largest B of its roots (the oracle's B_s) */
    double *cluster_rho;       /* per cluster, RGB: the largest rho of its roots */
    double *cluster_spread;    /* per cluster: largest - smallest B of its roots' leaves (gather oracle) */
    ff_link_pair *links;
    float *link_left;      /* the gather oracle only (else NULL): 2 per link, g of F_ab and of F_ba, what
                              solve's shaped solve leaves of them; link_cap pairs of room */
    size_t link_count, link_cap;
    rad_mem_span link_span, left_span; /* links and link_left: grown in place (rad_mem_grow) */
    ff_links_tally tally;
    uint32_t passes;
} ff_links;

/* Roots from `base` (the --subdiv 0 mesh, which must outlive the links),
 * element patches through ff_patch_make, the backend (already created
 * over the scene's occluders) through its compute_pairs, and with
 * config.clusters the cluster pairs through its cluster_draws. */
rad_status ff_links_init(ff_links *links, const rad_scene *scene, const rad_mesh *base, const double centre[3],
                         const ff_links_config *config, const ff_backend *backend, void *backend_state);

/* One pass of refinement. The first pass starts from every pair of roots
 * (from the root cluster's self-link with config.clusters);
 * later ones re-weigh the links made so far with `leaf_radiosity` (3 per
 * leaf of the last ff_links_export, in its order; NULL keeps the previous
 * B) and refine those now over the tolerance. *out_refined: the pairs
 * this pass refined (0: nothing changed). */
rad_status ff_links_refine(ff_links *links, const double *leaf_radiosity, ff_counters *counters, uint64_t *out_refined);

/* B (3 per leaf, in ff_links_export's order) from the elements' values:
 * the last solution's where a leaf was one, else its nearest ancestor's
 * (a warm start for the solve of the next export). 0 where out of memory
 * (B untouched). */
int ff_links_leaf_radiosity(const ff_links *links, double *B);

/* The links as rad_links (nodes in element order, then the clusters;
 * links sorted by receiver then source) and the leaves mesh
 * (rad_hierarchy_leaves). */
rad_status ff_links_export(const ff_links *links, rad_links *out_links, rad_mesh *out_leaves);

/* A bound on the solution's error against the full matrix of the same
 * leaves, relative to the mean radiosity of the leaves that do not emit
 * (area-weighted, brightest channel), for the solution B (3
 * per leaf, export order). With K the links' operator and F the leaves'
 * matrix, B - B_F = (I - rho F)^-1 rho (K - F) B, and rows of F sum to at
 * most 1, so the bound is max over leaves x of beta_x / (1 - rho_max), where
 * beta_x = rho_x sum over the links of x's ancestors (a split receiver r)
 * of e_rs B_s,max, plus over every link of x and its ancestors with a split
 * source s of min(1, e_sr / F_sr)(F_rs + e_rs) dB_s: e_rs bounds how far
 * the factor from x may lie from F_rs, and the second term what the spread
 * dB_s of B over s's leaves adds where the factor varies over s (at most
 * (F_rs + e_rs) dB_s, the factors to s's leaves being >= 0: a cluster
 * link's F can be far below its error). Links at clusters count for every
 * leaf under the cluster's roots. A scene that nothing lights (B = 0
 * everywhere, so every beta is 0) has bound 0. */
double ff_links_error_bound(const ff_links *links, const rad_links *exported, const double *leaf_radiosity);

void ff_links_free(ff_links *links);

#endif
