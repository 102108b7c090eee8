/* rad_lsolve.c - the radiosity solve on links (rad_lsolve.h): Jacobi and
 * Gauss-Seidel sweeps of gather, push and pull over the element trees and
 * the clusters above their roots.
 *
 * The plan, made once per call, is what makes a sweep O(nodes + clusters +
 * links): every tree's nodes in index order (a parent comes before its
 * children, rad_links.h, so that order pushes down and its reverse pulls
 * up), a leaf patch under every node (whose material is the node's), each
 * split node's children's area sum, and the row sum of every node's links
 * and its ancestors' (for the energy balance). With clusters (rad_links.h)
 * also each root's leaf cluster and each cluster's pull weights summed;
 * clusters too come after their parent, so index order pushes down the
 * cluster tree and its reverse pulls up, and a root's "parent" for pushes
 * and row sums is its leaf cluster. Per channel the vectors run over the
 * ids (nodes, then clusters): B (the leaves' values; split nodes and
 * clusters hold the area-weighted mean of their children), `old` (the
 * iterate the sweep started from) and the gathered G, pushed down in place
 * into D. A node's G is rho sum F B; a cluster's is the irradiance
 * H = sum F B alone (its roots' rho differ), pushed down the cluster tree
 * and into each root as rho_root H.
 *
 * The residual of the iterate a sweep starts from comes with the sweep, as
 * in solve/stationary.c: Jacobi gathers from `old` alone, so its D gives
 * r = E + D - old at the leaves; Gauss-Seidel gathers from the newest B
 * and, in the same pass over the links, from `old`. A sweep whose measured
 * iterate meets the tolerance returns that iterate, not the newer one.
 * Gauss-Seidel gathers the clusters first, when the newest B is still
 * `old` (so one H serves both), and pulls them last: within a sweep a
 * cluster's B is the sweep's start value, which is its value in `old` too.
 *
 * Threads do not change the bytes: each receiver's gather is summed by one
 * thread in link order, each tree is pushed and pulled by one thread, the
 * cluster tree by one, and the residual is a maximum. Jacobi gathers every
 * node and cluster in parallel, then pushes and pulls the trees in
 * parallel; Gauss-Seidel gathers the clusters in parallel where they
 * receive enough links, then goes tree by tree and gathers a tree's nodes
 * in parallel where the tree receives enough links. Where the links are
 * many (LSOLVE_GS_GROUPED_MIN_LINKS; or as rad_lsolve_options.group_links
 * asks) Gauss-Seidel goes group by group of consecutive trees instead
 * (a group closes once its trees receive LSOLVE_GS_GROUP_LINKS links; the
 * last may hold fewer): a group's nodes gather from the newest B in parallel,
 * then its trees are pushed and pulled in parallel, so the trees of a
 * group see each other's values of the sweep before (a scene of many
 * faces is many small trees, which tree by tree ran on one thread). The
 * groups depend on the links alone, not on the threads. Where most links
 * sit in groups too small for those threads (channels_in_parallel: a few
 * hundred thousand links in trees of a few thousand), the three channels
 * run at once on three threads instead, each the same arithmetic.
 */
#include "rad_lsolve.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>
#ifdef _OPENMP
#include <omp.h>
#endif

#include "rad_clock.h"
#include "rad_log.h"

#define LSOLVE_DEFAULT_TOLERANCE 1e-6
#define LSOLVE_DEFAULT_MAX_ITERATIONS 10000u
/* Seconds between progress messages of a long solve (as solve's). */
#define LSOLVE_PROGRESS_SECONDS 2.0
/* Gathers run on OpenMP threads from this many links up (all links for a
 * Jacobi sweep, a tree's for Gauss-Seidel), pushes and pulls from this many
 * nodes up: below, waking the threads (~40 us, docs/solve.md "Threads")
 * costs about what the work takes on one (a link is ~1 ns). */
#define LSOLVE_PARALLEL_MIN_LINKS 16384u
#define LSOLVE_PARALLEL_MIN_NODES 4096u
/* Gauss-Seidel in groups of trees (above) from this many links, each
 * group at least LSOLVE_GS_GROUP_LINKS (the last may have fewer). */
#define LSOLVE_GS_GROUPED_MIN_LINKS (4u << 20)
#define LSOLVE_GS_GROUP_LINKS 65536u

rad_lsolve_options rad_lsolve_defaults(void)
{
    rad_lsolve_options o = {.method = RAD_LSOLVE_GAUSS_SEIDEL,
                            .tolerance = LSOLVE_DEFAULT_TOLERANCE,
                            .max_iterations = LSOLVE_DEFAULT_MAX_ITERATIONS,
                            .threads = 0,
                            .warm_start = 0,
                            .channels = 3};
    return o;
}

/* What every sweep reads (see the top of the file). */
typedef struct lsolve_plan {
    const rad_links *links;
    uint32_t *tree_first; /* root_count + 1: tree t is tree_nodes[tree_first[t] .. tree_first[t + 1]) */
    uint32_t *tree_nodes; /* node_count: every tree's nodes in index order, parents first */
    uint64_t *tree_links; /* root_count: the links the tree's nodes receive */
    uint32_t *group_first; /* group_count + 1: Gauss-Seidel's group g is trees group_first[g] .. [g + 1] */
    uint64_t *group_links; /* group_count: the links its nodes receive */
    uint32_t group_count;
    uint32_t *patch_of;   /* node_count: a leaf patch under the node (the node's material) */
    double *child_area;   /* node_count: a split node's 4 children's areas summed; 0 for a leaf */
    double *row_sum;      /* ids: sum of F over the links of the node (cluster) and of its ancestors,
                             a root's ancestors being the clusters that hold it */
    uint32_t *root_cluster; /* root_count: the leaf cluster holding the root; NULL without clusters */
    double *cluster_area; /* cluster_count: the areas a cluster's pull weighs, summed */
    uint64_t cluster_links; /* the links the clusters receive */
    int threads;          /* >= 1 */
    /* Closure (rad_closure.h), NULL without: per node, a leaf's scale s
     * (1 at split nodes) and its row of S K S (for the escaped power). */
    double *scale, *closed_row;
} lsolve_plan;

/* One channel's vectors over the ids (nodes, then clusters). */
typedef struct lsolve_vectors {
    double *rho, *E;  /* the node's material; E is read at leaves only; unused at clusters */
    double *B, *old;  /* the iterate, and the one the sweep started from */
    double *G, *G_old; /* rho sum F B (clusters: sum F B) gathered from B and from old, then pushed down (D);
                          G_old is not used at clusters: Gauss-Seidel's G there is gathered from old */
    double e_norm;    /* ||E||_inf over the leaves, > 0 while iterating */
} lsolve_vectors;

static int lsolve_threads(int asked)
{
#ifdef _OPENMP
    return asked > 0 ? asked : omp_get_max_threads();
#else
    (void)asked;
    return 1;
#endif
}

#ifdef _OPENMP /* only the parallel loops' num_threads clauses ask */
/* Threads for `links` links of work: one per LSOLVE_PARALLEL_MIN_LINKS at
 * most (64 threads woken for a tree of 20 000 links cost more than the
 * gather: 2.3 s instead of 0.05 s for 17 sweeps on 64 cores). */
static int threads_for(const lsolve_plan *p, uint64_t links)
{
    uint64_t most = 1 + links / LSOLVE_PARALLEL_MIN_LINKS;
    return most < (uint64_t)p->threads ? (int)most : p->threads;
}
#endif

/* sum over r's links of F_rs x_s, in link order. */
static inline double gather_one(const rad_links *L, uint32_t r, const double *x)
{
    double s = 0;
    for (uint64_t k = L->first_link[r]; k < L->first_link[r + 1]; k++) s += L->links[k].factor * x[L->links[k].source];
    return s;
}

/* The same from two vectors in one pass over the links. */
static inline void gather_two(const rad_links *L, uint32_t r, const double *x, const double *y, double *sx, double *sy)
{
    double a = 0, b = 0;
    for (uint64_t k = L->first_link[r]; k < L->first_link[r + 1]; k++) {
        const double f = L->links[k].factor;
        const uint32_t s = L->links[k].source;
        a += f * x[s];
        b += f * y[s];
    }
    *sx = a;
    *sy = b;
}

/* Split node i's B: the area-weighted mean of its children's. */
static inline void pull_node(const lsolve_plan *p, uint32_t i, double *B)
{
    const rad_link_node *nodes = p->links->nodes;
    const uint32_t c = nodes[i].first_child;
    B[i] = (nodes[c].area * B[c] + nodes[c + 1].area * B[c + 1] + nodes[c + 2].area * B[c + 2] +
            nodes[c + 3].area * B[c + 3]) /
           p->child_area[i];
}

/* Cluster c's B (id node_count + c): the area-weighted mean of its child
 * clusters', or of its roots' for a leaf cluster. */
static inline void pull_cluster(const lsolve_plan *p, uint32_t c, double *B)
{
    const rad_links *L = p->links;
    const rad_link_cluster *k = &L->clusters[c];
    const uint32_t n = L->node_count;
    double s = 0;
    if (k->child_count == 0) {
        for (uint32_t q = k->root_begin; q < k->root_end; q++) {
            const uint32_t r = L->cluster_roots[q];
            s += L->nodes[r].area * B[r];
        }
    } else {
        for (uint32_t j = k->first_child; j < k->first_child + k->child_count; j++) s += L->clusters[j].area * B[n + j];
    }
    B[n + c] = s / p->cluster_area[c];
}

/* Every cluster's B from the roots' B, children before parents. */
static void pull_clusters(const lsolve_plan *p, double *B)
{
    for (uint32_t c = p->links->cluster_count; c-- > 0;) pull_cluster(p, c, B);
}

/* G at the clusters = sum F x over their links (in parallel where they
 * receive enough links), then pushed down the cluster tree: each cluster's
 * G becomes the sum over it and the clusters above it. */
static void gather_clusters(const lsolve_plan *p, const double *x, double *G)
{
    const rad_links *L = p->links;
    const uint32_t n = L->node_count, count = L->cluster_count;
#pragma omp parallel for schedule(dynamic, 16) num_threads(threads_for(p, p->cluster_links)) \
    if (p->cluster_links >= LSOLVE_PARALLEL_MIN_LINKS)
    for (uint32_t c = 0; c < count; c++) G[n + c] = gather_one(L, n + c, x);
    for (uint32_t c = 1; c < count; c++) G[n + c] += G[n + L->clusters[c].parent];
}

/* ---- checks and the plan ---- */

static rad_status bad_node(uint32_t i, const char *what)
{
    rad_error("links: node %u: %s", i, what);
    return RAD_ERR_INVALID;
}

/* The cluster tree, as rad_links_check checks it (rad_links_check_cluster_tree):
 * so the leaf clusters' ranges partition the roots and every root has
 * one leaf cluster. */
static rad_status check_clusters(const rad_links *L)
{
    if (!L->clusters || !L->cluster_roots || rad_links_id_count(L) > UINT32_MAX) {
        rad_error("links: %u clusters without their table, or more ids than a link's source can name",
                  L->cluster_count);
        return RAD_ERR_INVALID;
    }
    rad_status status = rad_links_check_cluster_tree(L, "links");
    return status == RAD_ERR_FORMAT ? RAD_ERR_INVALID : status;
}

/* What the sweeps index, and the match with the leaves mesh. The rest of
 * rad_links_check (corners, sorted sources, errors) the sweeps do not
 * depend on. */
static rad_status check_links(const rad_links *L, const rad_mesh *leaves)
{
    if (!L->nodes || !L->first_link || (L->link_count && !L->links) || L->root_count == 0 ||
        L->root_count > L->node_count) {
        rad_error("links: %u nodes, %u roots: no trees to solve on", L->node_count, L->root_count);
        return RAD_ERR_INVALID;
    }
    if (L->leaf_count != leaves->patch_count) {
        rad_error("links: %u leaves, but the leaves mesh has %zu patches", L->leaf_count, leaves->patch_count);
        return RAD_ERR_INVALID;
    }
    const uint32_t n = L->node_count;
    unsigned char *seen = calloc(L->leaf_count ? L->leaf_count : 1, 1);
    if (!seen) {
        rad_error("links: out of memory checking %u leaves", L->leaf_count);
        return RAD_ERR_NOMEM;
    }
    rad_status status = RAD_OK;
    uint32_t leaf_nodes = 0;
    for (uint32_t i = 0; i < n && status == RAD_OK; i++) {
        const rad_link_node *e = &L->nodes[i];
        if (i < L->root_count) {
            if (e->parent != RAD_NO_ELEMENT || e->root != i) status = bad_node(i, "a root with a parent, or of another tree");
        } else if (e->parent >= i || e->root != L->nodes[e->parent].root) {
            status = bad_node(i, "its parent does not come before it in its tree");
        } else {
            uint32_t first = L->nodes[e->parent].first_child;
            if (first == RAD_NO_ELEMENT || i < first || i - first > 3) status = bad_node(i, "not among its parent's children");
        }
        if (status != RAD_OK) break;
        if (e->first_child == RAD_NO_ELEMENT) {
            if (e->leaf >= L->leaf_count || seen[e->leaf]++) status = bad_node(i, "its leaf patch is out of range or another node's");
            leaf_nodes++;
        } else if (e->first_child <= i || (uint64_t)e->first_child + 4 > n || e->leaf != RAD_NO_ELEMENT) {
            status = bad_node(i, "its children are out of range, or it is split and a leaf");
        } else {
            for (uint32_t k = 0; k < 4; k++)
                if (L->nodes[e->first_child + k].parent != i) status = bad_node(i, "a child names another parent");
        }
        if (status == RAD_OK && !(e->area > 0 && isfinite(e->area))) status = bad_node(i, "area not finite and > 0");
        if (status == RAD_OK && L->first_link[i + 1] < L->first_link[i]) status = bad_node(i, "its links end before they begin");
    }
    free(seen);
    if (status != RAD_OK) return status;
    if (leaf_nodes != L->leaf_count) {
        rad_error("links: %u leaf nodes for %u leaf patches", leaf_nodes, L->leaf_count);
        return RAD_ERR_INVALID;
    }
    if (L->cluster_count && (status = check_clusters(L)) != RAD_OK) return status;
    const uint64_t ids = rad_links_id_count(L);
    for (uint64_t i = n; i < ids; i++)
        if (L->first_link[i + 1] < L->first_link[i])
        {
            rad_error("links: cluster %u: its links end before they begin", (uint32_t)(i - n));
            return RAD_ERR_INVALID;
        }
    if (L->first_link[0] != 0 || L->first_link[ids] != L->link_count) {
        rad_error("links: the link table does not span the %llu links", (unsigned long long)L->link_count);
        return RAD_ERR_INVALID;
    }
    for (uint64_t k = 0; k < L->link_count; k++) {
        if (L->links[k].source >= ids || !isfinite(L->links[k].factor)) {
            rad_error("links: link %llu: source out of range or form factor not finite", (unsigned long long)k);
            return RAD_ERR_INVALID;
        }
    }
    return RAD_OK;
}

static void plan_free(lsolve_plan *p)
{
    free(p->tree_first);
    free(p->tree_nodes);
    free(p->tree_links);
    free(p->group_first);
    free(p->group_links);
    free(p->patch_of);
    free(p->child_area);
    free(p->row_sum);
    free(p->root_cluster);
    free(p->cluster_area);
    free(p->scale);
    free(p->closed_row);
}

/* The id above node i: its parent; for a root its leaf cluster (with
 * clusters), else RAD_NO_ELEMENT. */
static inline uint32_t node_up(const lsolve_plan *p, uint32_t i)
{
    const uint32_t up = p->links->nodes[i].parent;
    if (up != RAD_NO_ELEMENT || !p->root_cluster) return up;
    return p->links->node_count + p->root_cluster[i];
}

/* The clusters' part of the plan: each root's leaf cluster, each
 * cluster's pull weights summed, the links they receive. */
static void plan_clusters(const rad_links *L, lsolve_plan *p)
{
    const uint32_t n = L->node_count;
    for (uint32_t c = L->cluster_count; c-- > 0;) {
        const rad_link_cluster *k = &L->clusters[c];
        double area = 0;
        if (k->child_count == 0) {
            for (uint32_t q = k->root_begin; q < k->root_end; q++) {
                p->root_cluster[L->cluster_roots[q]] = c;
                area += L->nodes[L->cluster_roots[q]].area;
            }
        } else {
            for (uint32_t j = k->first_child; j < k->first_child + k->child_count; j++) area += L->clusters[j].area;
        }
        p->cluster_area[c] = area;
        p->cluster_links += L->first_link[n + c + 1] - L->first_link[n + c];
    }
}

static rad_status plan_make(const rad_links *L, int threads, uint64_t group_links, lsolve_plan *p)
{
    const uint32_t n = L->node_count, roots = L->root_count, clusters = L->cluster_count;
    const size_t ids = rad_links_id_count(L);
    memset(p, 0, sizeof *p);
    p->links = L;
    p->threads = lsolve_threads(threads);
    if (clusters) {
        p->root_cluster = malloc((size_t)roots * sizeof *p->root_cluster);
        p->cluster_area = malloc((size_t)clusters * sizeof *p->cluster_area);
    }
    p->tree_first = calloc((size_t)roots + 1, sizeof *p->tree_first);
    p->tree_nodes = malloc((size_t)n * sizeof *p->tree_nodes);
    p->tree_links = calloc(roots, sizeof *p->tree_links);
    p->group_first = malloc(((size_t)roots + 1) * sizeof *p->group_first);
    p->group_links = malloc((roots ? roots : 1) * sizeof *p->group_links);
    p->patch_of = malloc((size_t)n * sizeof *p->patch_of);
    p->child_area = malloc((size_t)n * sizeof *p->child_area);
    p->row_sum = malloc(ids * sizeof *p->row_sum);
    if (!p->tree_first || !p->tree_nodes || !p->tree_links || !p->group_first || !p->group_links || !p->patch_of ||
        !p->child_area || !p->row_sum ||
        (clusters && (!p->root_cluster || !p->cluster_area))) {
        rad_error("links: out of memory for the solve's plan of %u nodes and %u clusters", n, clusters);
        plan_free(p);
        return RAD_ERR_NOMEM;
    }
    /* the trees' node lists: counted, then filled in index order */
    for (uint32_t i = 0; i < n; i++) p->tree_first[L->nodes[i].root + 1]++;
    for (uint32_t t = 0; t < roots; t++) p->tree_first[t + 1] += p->tree_first[t];
    uint32_t *fill = p->tree_nodes;
    for (uint32_t i = 0; i < n; i++) {
        uint32_t t = L->nodes[i].root;
        /* tree_first[t] counts up as tree t fills; set back below */
        fill[p->tree_first[t]++] = i;
        p->tree_links[t] += L->first_link[i + 1] - L->first_link[i];
    }
    for (uint32_t t = roots; t > 0; t--) p->tree_first[t] = p->tree_first[t - 1];
    p->tree_first[0] = 0;
    /* Gauss-Seidel's groups: a tree each, or consecutive trees to
     * LSOLVE_GS_GROUP_LINKS where the links are many */
    const int grouped = group_links > 0 || L->link_count >= LSOLVE_GS_GROUPED_MIN_LINKS;
    const uint64_t group = !grouped ? 0 : group_links > 0 ? group_links : LSOLVE_GS_GROUP_LINKS;
    p->group_count = rad_links_tree_groups(p->tree_links, roots, group, p->group_first, p->group_links);
    /* children after parents: a reverse pass sees every child before its parent */
    for (uint32_t i = n; i-- > 0;) {
        const rad_link_node *e = &L->nodes[i];
        if (e->first_child == RAD_NO_ELEMENT) {
            p->patch_of[i] = e->leaf;
            p->child_area[i] = 0;
        } else {
            const rad_link_node *c = &L->nodes[e->first_child];
            p->patch_of[i] = p->patch_of[e->first_child];
            p->child_area[i] = c[0].area + c[1].area + c[2].area + c[3].area;
        }
    }
    plan_clusters(L, p);
    /* row sums down from cluster 0, then down every tree from its root's leaf cluster */
    for (uint32_t c = 0; c < clusters; c++) {
        double s = 0;
        for (uint64_t k = L->first_link[n + c]; k < L->first_link[n + c + 1]; k++) s += L->links[k].factor;
        const uint32_t up = L->clusters[c].parent;
        p->row_sum[n + c] = s + (up != RAD_NO_ELEMENT ? p->row_sum[n + up] : 0);
    }
    for (uint32_t i = 0; i < n; i++) {
        double s = 0;
        for (uint64_t k = L->first_link[i]; k < L->first_link[i + 1]; k++) s += L->links[k].factor;
        uint32_t up = node_up(p, i);
        p->row_sum[i] = s + (up != RAD_NO_ELEMENT ? p->row_sum[up] : 0);
    }
    return RAD_OK;
}

/* ---- the sweeps ---- */

/* Tree t once its nodes and the clusters have gathered: G (from the
 * newest B) and G_old (from old; the same array for Jacobi) pushed down,
 * the root taking rho times its clusters' G into both, the leaves' B =
 * E + D and their residual E + D_old - old, the split nodes pulled up.
 * Returns the tree's largest |residual|, NaN if one is NaN. */
static double tree_update(const lsolve_plan *p, const lsolve_vectors *v, double *G_old, uint32_t t)
{
    const rad_link_node *nodes = p->links->nodes;
    const uint32_t n = p->links->node_count;
    const uint32_t *list = p->tree_nodes + p->tree_first[t];
    const uint32_t count = p->tree_first[t + 1] - p->tree_first[t];
    const int both = G_old != v->G;
    double rmax = 0;
    int not_a_number = 0;
    for (uint32_t k = 0; k < count; k++) {
        const uint32_t i = list[k], up = nodes[i].parent;
        if (up != RAD_NO_ELEMENT) {
            v->G[i] += v->G[up];
            if (both) G_old[i] += G_old[up];
        } else if (p->root_cluster && v->rho[i] != 0) { /* the root, under clusters */
            const double h = v->rho[i] * v->G[n + p->root_cluster[i]];
            v->G[i] += h;
            if (both) G_old[i] += h;
        }
        if (nodes[i].first_child != RAD_NO_ELEMENT) continue;
        const double gain = p->scale ? p->scale[i] * p->scale[i] : 1; /* closure: C = S E + rho S^2 K C */
        v->B[i] = v->E[i] + gain * v->G[i];
        /* closure: C's residual over s is B's */
        double r = fabs(v->E[i] + gain * G_old[i] - v->old[i]);
        if (p->scale) r /= p->scale[i];
        if (r > rmax) rmax = r;
        not_a_number |= isnan(r);
    }
    for (uint32_t k = count; k-- > 0;)
        if (nodes[list[k]].first_child != RAD_NO_ELEMENT) pull_node(p, list[k], v->B);
    return not_a_number ? NAN : rmax;
}

/* One Jacobi sweep: old <- B, then B <- the next iterate (clusters
 * pulled last). Returns the largest |residual| of old. */
static double jacobi_sweep(const lsolve_plan *p, lsolve_vectors *v)
{
    const rad_links *L = p->links;
    const uint32_t n = L->node_count, roots = L->root_count;
    double *t = v->old;
    v->old = v->B;
    v->B = t;
    const double *old = v->old, *rho = v->rho;
    double *G = v->G;
#pragma omp parallel for schedule(dynamic, 64) num_threads(threads_for(p, L->link_count)) \
    if (L->link_count >= LSOLVE_PARALLEL_MIN_LINKS)
    for (uint32_t r = 0; r < n; r++) G[r] = rho[r] != 0 ? rho[r] * gather_one(L, r, old) : 0;
    gather_clusters(p, old, G);
    double rmax = 0;
    int not_a_number = 0;
#pragma omp parallel for schedule(dynamic, 16) num_threads(p->threads) reduction(max : rmax) \
    reduction(| : not_a_number) if (n >= LSOLVE_PARALLEL_MIN_NODES)
    for (uint32_t tree = 0; tree < roots; tree++) {
        double r = tree_update(p, v, v->G, tree);
        if (r > rmax) rmax = r;
        not_a_number |= isnan(r);
    }
    pull_clusters(p, v->B);
    return not_a_number ? NAN : rmax;
}

/* One Gauss-Seidel sweep: the clusters gathered first (from B, which is
 * still old), then tree by tree in root order, each gathering from the
 * newest B (the trees before it already swept; a cluster source at its
 * start value) and publishing its new B at once; the clusters pulled last.
 * Returns the largest |residual| of the iterate it started from (left in
 * old). */
static double gauss_seidel_sweep(const lsolve_plan *p, lsolve_vectors *v)
{
    const rad_links *L = p->links;
    memcpy(v->old, v->B, (size_t)rad_links_id_count(L) * sizeof(double));
    const double *old = v->old, *B = v->B, *rho = v->rho;
    double *G = v->G, *G_old = v->G_old;
    gather_clusters(p, old, G);
    double rmax = 0;
    int not_a_number = 0;
    for (uint32_t g = 0; g < p->group_count; g++) {
        const uint32_t t0 = p->group_first[g], t1 = p->group_first[g + 1];
        const uint32_t *list = p->tree_nodes;
        const uint32_t k0 = p->tree_first[t0], k1 = p->tree_first[t1];
        const uint64_t links = p->group_links[g];
        (void)links; /* read by the OpenMP clauses only */
#pragma omp parallel for schedule(dynamic, 16) num_threads(threads_for(p, links)) \
    if (links >= LSOLVE_PARALLEL_MIN_LINKS)
        for (uint32_t k = k0; k < k1; k++) {
            const uint32_t r = list[k];
            double now = 0, before = 0;
            if (rho[r] != 0) gather_two(L, r, B, old, &now, &before);
            G[r] = rho[r] * now;
            G_old[r] = rho[r] * before;
        }
        double gmax = 0;
        int gnan = 0;
#pragma omp parallel for schedule(dynamic, 4) num_threads(threads_for(p, links)) reduction(max : gmax) \
    reduction(| : gnan) if (t1 - t0 > 1 && links >= LSOLVE_PARALLEL_MIN_LINKS)
        for (uint32_t tree = t0; tree < t1; tree++) {
            double r = tree_update(p, v, G_old, tree);
            if (r > gmax) gmax = r;
            gnan |= isnan(r);
        }
        if (gmax > rmax) rmax = gmax;
        not_a_number |= gnan;
    }
    pull_clusters(p, v->B);
    return not_a_number ? NAN : rmax;
}

/* ---- one channel ---- */

/* The channel's material and start: B = E at the leaves (or the caller's
 * B), pulled up the trees and the clusters. */
static void channel_start(const lsolve_plan *p, const rad_mesh *leaves, int c, int warm_start, const double *B_in,
                          lsolve_vectors *v)
{
    const rad_links *L = p->links;
    v->e_norm = 0;
    for (uint32_t i = 0; i < L->node_count; i++) {
        const rad_patch *patch = &leaves->patches[p->patch_of[i]];
        v->rho[i] = patch->rho[c];
        v->E[i] = patch->emission[c];
        if (L->nodes[i].first_child != RAD_NO_ELEMENT) continue;
        if (v->E[i] > v->e_norm) v->e_norm = v->E[i];
        if (p->scale) v->E[i] *= p->scale[i]; /* closure: the solve runs on C = S B */
        v->B[i] = warm_start ? B_in[3 * (size_t)L->nodes[i].leaf + c] * (p->scale ? p->scale[i] : 1) : v->E[i];
    }
    if (v->e_norm == 0) /* nothing emits: B = 0 */
        for (uint32_t i = 0; i < L->node_count; i++) v->B[i] = 0;
    for (uint32_t i = L->node_count; i-- > 0;)
        if (L->nodes[i].first_child != RAD_NO_ELEMENT) pull_node(p, i, v->B);
    pull_clusters(p, v->B);
}

typedef struct lsolve_channel_run {
    uint32_t iterations;
    double residual;
    int converged;
} lsolve_channel_run;

/* Sweeps until the measured iterate meets the tolerance or the iteration
 * limit; leaves that iterate in v->B. RAD_ERR_INVALID for a residual that
 * is not finite (diverging: rho * row sum > 1 somewhere, or overflow). */
static rad_status channel_iterate(const lsolve_plan *p, lsolve_vectors *v, const rad_lsolve_options *o,
                                  const char *label, lsolve_channel_run *out)
{
    memset(out, 0, sizeof *out);
    if (v->e_norm == 0) {
        out->converged = 1;
        return RAD_OK;
    }
    const double start = rad_clock_seconds();
    double last_progress = start;
    for (uint32_t k = 0;; k++) {
        double residual = (o->method == RAD_LSOLVE_JACOBI ? jacobi_sweep(p, v) : gauss_seidel_sweep(p, v)) / v->e_norm;
        if (!isfinite(residual)) {
            rad_error("links: %s: residual is not finite at iteration %u (some rho * row sum above 1, or overflow)",
                      label, k);
            return RAD_ERR_INVALID;
        }
        const double now = rad_clock_seconds();
        if (now - last_progress >= LSOLVE_PROGRESS_SECONDS) {
            rad_info("links: %s: iteration %u, residual %.3g (target %.3g), %.0f s", label, k, residual, o->tolerance,
                     now - start);
            last_progress = now;
        }
        if (residual <= o->tolerance || k >= o->max_iterations) {
            double *t = v->B; /* back to the measured iterate */
            v->B = v->old;
            v->old = t;
            out->iterations = k;
            out->residual = residual;
            out->converged = residual <= o->tolerance;
            return RAD_OK;
        }
    }
}

/* Adds the channel's emitted, absorbed and escaped power (rad_lsolve.h)
 * to sums[0..2]; `scratch` holds one double per id. */
static void channel_balance(const lsolve_plan *p, const lsolve_vectors *v, double *scratch, double sums[3])
{
    const rad_links *L = p->links;
    const uint32_t n = L->node_count;
    const double *B = v->B;
#pragma omp parallel for schedule(dynamic, 64) num_threads(threads_for(p, L->link_count)) \
    if (L->link_count >= LSOLVE_PARALLEL_MIN_LINKS)
    for (uint32_t r = 0; r < n; r++) scratch[r] = gather_one(L, r, B);
    gather_clusters(p, B, scratch);
    for (uint32_t i = 0; i < n; i++) {
        const rad_link_node *e = &L->nodes[i];
        const uint32_t up = node_up(p, i);
        if (up != RAD_NO_ELEMENT) scratch[i] += scratch[up]; /* H: pushed down */
        if (e->first_child != RAD_NO_ELEMENT) continue;
        if (p->scale) { /* closure: B = C / s, H = s K C, rows those of S K S */
            const double si = p->scale[i];
            sums[0] += e->area * v->E[i] / si;
            sums[1] += e->area * (1 - v->rho[i]) * si * scratch[i];
            sums[2] += e->area * B[i] / si * (1 - p->closed_row[i]);
            continue;
        }
        sums[0] += e->area * v->E[i];
        sums[1] += e->area * (1 - v->rho[i]) * scratch[i];
        sums[2] += e->area * B[i] * (1 - p->row_sum[i]);
    }
}

/* ---- the call ---- */

/* The options with zeros as defaults; RAD_ERR_INVALID for values out of range. */
static rad_status resolve_options(const rad_lsolve_options *asked, rad_lsolve_options *o)
{
    *o = asked ? *asked : rad_lsolve_defaults();
    const rad_lsolve_options d = rad_lsolve_defaults();
    if (o->method == 0) o->method = d.method;
    if (o->tolerance == 0) o->tolerance = d.tolerance;
    if (o->max_iterations == 0) o->max_iterations = d.max_iterations;
    if (o->channels == 0) o->channels = d.channels;
    if ((o->method != RAD_LSOLVE_JACOBI && o->method != RAD_LSOLVE_GAUSS_SEIDEL) || !(o->tolerance > 0) ||
        (o->channels != 1 && o->channels != 3)) {
        rad_error("links: solve options out of range (method %d, tolerance %g, channels %d)", (int)o->method,
                  o->tolerance, o->channels);
        return RAD_ERR_INVALID;
    }
    return RAD_OK;
}

/* One channel c solved into solved[3 l + c] (by leaf), its balance in
 * sums[3], with `block` (6 doubles per id) for its vectors. */
static rad_status solve_channel(const lsolve_plan *p, const rad_mesh *leaves, const rad_lsolve_options *o, int c,
                                const double *B_in, double *block, double *solved, double sums[3],
                                lsolve_channel_run *run)
{
    static const char *const rgb_names[3] = {"red", "green", "blue"};
    const rad_links *links = p->links;
    const size_t n = rad_links_id_count(links);
    lsolve_vectors v = {.rho = block, .E = block + n, .B = block + 2 * n, .old = block + 3 * n,
                        .G = block + 4 * n, .G_old = block + 5 * n};
    const char *label = o->channels == 1 ? "grey" : rgb_names[c];
    channel_start(p, leaves, c, o->warm_start, B_in, &v);
    rad_status status = channel_iterate(p, &v, o, label, run);
    if (status != RAD_OK) return status;
    if (!run->converged)
        rad_info("links: %s: not converged after %u iterations (residual %.3g, target %.3g)", label, run->iterations,
                 run->residual, o->tolerance);
    sums[0] = sums[1] = sums[2] = 0;
    channel_balance(p, &v, v.G, sums);
    for (uint32_t i = 0; i < links->node_count; i++)
        if (links->nodes[i].first_child == RAD_NO_ELEMENT)
            solved[3 * (size_t)links->nodes[i].leaf + c] = p->scale ? v.B[i] / p->scale[i] : v.B[i];
    return RAD_OK;
}

/* ---- closure (rad_closure.h) ---- */

typedef struct lsolve_apply_ctx {
    const lsolve_plan *p;
    lsolve_vectors v;    /* rho 1, E 0: one Jacobi sweep maps old to K old */
    const uint32_t *node_of; /* leaf patch -> its node */
} lsolve_apply_ctx;

/* y = K x by leaf patch: x at the leaves, pulled up; one Jacobi sweep. */
static rad_status lsolve_apply(void *ctx, const double *x, double *y)
{
    lsolve_apply_ctx *a = ctx;
    const lsolve_plan *p = a->p;
    const rad_links *L = p->links;
    for (uint32_t l = 0; l < L->leaf_count; l++) a->v.B[a->node_of[l]] = x[l];
    for (uint32_t i = L->node_count; i-- > 0;)
        if (L->nodes[i].first_child != RAD_NO_ELEMENT) pull_node(p, i, a->v.B);
    pull_clusters(p, a->v.B);
    jacobi_sweep(p, &a->v);
    for (uint32_t l = 0; l < L->leaf_count; l++) y[l] = a->v.B[a->node_of[l]];
    return RAD_OK;
}

/* The plan's scale and closed_row, from the scales s of K with `block`
 * (6 doubles per id) for the sweeps' vectors. */
static rad_status plan_closure(lsolve_plan *p, double *block, rad_closure_result *out)
{
    const rad_links *L = p->links;
    const size_t n = rad_links_id_count(L), m = L->leaf_count;
    uint32_t *node_of = malloc((m ? m : 1) * sizeof *node_of);
    double *s = malloc((m ? m : 1) * sizeof *s), *row = malloc((m ? m : 1) * sizeof *row);
    if (!node_of || !s || !row) {
        free(node_of), free(s), free(row);
        rad_error("links: out of memory for the closure's scales of %zu leaves", m);
        return RAD_ERR_NOMEM;
    }
    /* the sweeps run without closure: p->scale is set only once s is found */
    lsolve_apply_ctx a = {.p = p, .node_of = node_of,
                          .v = {.rho = block, .E = block + n, .B = block + 2 * n, .old = block + 3 * n,
                                .G = block + 4 * n, .G_old = block + 4 * n}};
    for (size_t i = 0; i < n; i++) a.v.rho[i] = 1, a.v.E[i] = 0;
    for (uint32_t i = 0; i < L->node_count; i++)
        if (L->nodes[i].first_child == RAD_NO_ELEMENT) node_of[L->nodes[i].leaf] = i;
    rad_status status = rad_closure_scales(m, lsolve_apply, &a, 0, 0, s, row, out);
    if (status == RAD_ERR_NOT_CONVERGED) status = RAD_OK; /* the last scales, said so */
    if (status == RAD_OK) {
        p->scale = malloc((size_t)L->node_count * sizeof *p->scale);
        p->closed_row = malloc((size_t)L->node_count * sizeof *p->closed_row);
        if (!p->scale || !p->closed_row) { /* plan_free frees either */
            rad_error("links: out of memory for the closure's scales of %u nodes", L->node_count);
            status = RAD_ERR_NOMEM;
        }
    }
    if (status == RAD_OK) {
        for (uint32_t i = 0; i < L->node_count; i++) p->scale[i] = 1, p->closed_row[i] = 0;
        for (size_t l = 0; l < m; l++) p->scale[node_of[l]] = s[l], p->closed_row[node_of[l]] = row[l];
    }
    free(node_of), free(s), free(row);
    return status;
}

/* Whether the three channels go on up to three threads at once (of the
 * threads given): Gauss-Seidel where most of the links are gathered in
 * groups too small for the sweeps' own threads (a scene of a few hundred
 * thousand links, whose Gauss-Seidel runs tree by tree on one thread;
 * Jacobi's sweeps are parallel whole). Each channel is the same
 * arithmetic either way, so B's bytes do not change; a channel's own
 * loops then run on its one thread (OpenMP's nesting is off by default;
 * where a user turns it on they open teams of their own, the same bytes). */
static int channels_in_parallel(const lsolve_plan *p, const rad_lsolve_options *o)
{
    if (o->channels != 3 || p->threads < 2 || o->method != RAD_LSOLVE_GAUSS_SEIDEL) return 0;
    uint64_t alone = 0;
    for (uint32_t g = 0; g < p->group_count; g++)
        if (p->group_links[g] < LSOLVE_PARALLEL_MIN_LINKS) alone += p->group_links[g];
    return 2 * alone >= p->links->link_count;
}

rad_status rad_lsolve(const rad_links *links, const rad_mesh *leaves, const rad_lsolve_options *options, double *B,
                      rad_lsolve_result *out)
{
    const double start = rad_clock_seconds();
    rad_lsolve_options o;
    rad_status status = resolve_options(options, &o);
    if (status == RAD_OK) status = check_links(links, leaves);
    if (status != RAD_OK) return status;
    lsolve_plan plan;
    status = plan_make(links, o.threads, o.group_links, &plan);
    if (status != RAD_OK) return status;
    const size_t n = rad_links_id_count(links), leaf_count = links->leaf_count; /* vectors over the ids */
    const int parallel = channels_in_parallel(&plan, &o);
    double *block = malloc((parallel ? 3 : 1) * 6 * n * sizeof(double));
    double *solved = malloc((leaf_count ? 3 * leaf_count : 1) * sizeof(double)); /* B is written on success only */
    if (!block || !solved) {
        rad_error("links: out of memory for the solve's vectors over %zu nodes and clusters", n);
        status = RAD_ERR_NOMEM;
    }
    rad_lsolve_result result;
    memset(&result, 0, sizeof result);
    result.converged = 1;
    if (status == RAD_OK && o.closure) status = plan_closure(&plan, block, &result.closure);
    double sums[3][3] = {{0}};
    rad_status channel_status[3] = {RAD_OK, RAD_OK, RAD_OK};
    lsolve_channel_run runs[3];
    memset(runs, 0, sizeof runs);
    if (status == RAD_OK && parallel) {
#pragma omp parallel for schedule(static, 1) num_threads(plan.threads < 3 ? plan.threads : 3)
        for (int c = 0; c < 3; c++)
            channel_status[c] = solve_channel(&plan, leaves, &o, c, B, block + 6 * n * (size_t)c, solved, sums[c], &runs[c]);
    } else {
        for (int c = 0; c < o.channels && status == RAD_OK; c++)
            status = channel_status[c] = solve_channel(&plan, leaves, &o, c, B, block, solved, sums[c], &runs[c]);
    }
    for (int c = 0; c < o.channels && status == RAD_OK; c++) status = channel_status[c];
    if (status == RAD_OK) {
        for (int c = 0; c < o.channels; c++) {
            result.iterations[c] = runs[c].iterations;
            result.residual[c] = runs[c].residual;
            result.converged &= runs[c].converged;
        }
        if (o.channels == 1)
            for (size_t l = 0; l < leaf_count; l++) solved[3 * l + 1] = solved[3 * l + 2] = solved[3 * l];
        for (int c = o.channels; c < 3; c++) {
            result.iterations[c] = result.iterations[0];
            result.residual[c] = result.residual[0];
        }
        memcpy(B, solved, 3 * leaf_count * sizeof(double));
        /* a grey solve's balance is its one channel's, as solve reports it;
         * the channels' sums added in channel order */
        for (int c = 0; c < o.channels; c++) {
            result.emitted += sums[c][0];
            result.absorbed += sums[c][1];
            result.escaped += sums[c][2];
        }
        result.imbalance =
            result.emitted > 0 ? (result.absorbed + result.escaped - result.emitted) / result.emitted : 0;
        result.seconds = rad_clock_seconds() - start;
        *out = result;
        if (!result.converged) status = RAD_ERR_NOT_CONVERGED;
    }
    free(block);
    free(solved);
    plan_free(&plan);
    return status;
}
