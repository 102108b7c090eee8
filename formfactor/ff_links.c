/* ff_links.c - hierarchical radiosity's links (ff_links.h). */
#include "ff_links.h"

#include <float.h>
#include <math.h>
#include <stddef.h>
#include <stdlib.h>
#include <string.h>

#include "ff_openness.h"
#include "ff_pair_class.h" /* ff_pair_verdict */
#include "ff_rank_rounds.h"
#include "ff_round.h"
#include "ff_setup.h"
#include "rad_clock.h"
#include "rad_log.h"
#include "rad_mem.h"

const char *ff_oracle_name(ff_oracle oracle)
{
    switch (oracle) {
    case FF_ORACLE_ERROR: return "error";
    case FF_ORACLE_POWER: return "power";
    case FF_ORACLE_FACTOR: return "factor";
    case FF_ORACLE_GATHER: return "gather";
    }
    return "unknown";
}

/* ---- elements ---- */

/* The level of root r's leaves: where they are made in advance (uniform or
 * sized leaves) their level, else the finest (max_level). */
static uint32_t finest_level(const ff_links *L, uint32_t root)
{
    return L->leaf_level ? L->leaf_level[root] : L->config.max_level;
}

/* Patch, key and oracle radiosity of elements [from, tree.element_count). */
static rad_status elements_added(ff_links *L, size_t from)
{
    rad_hierarchy *h = &L->tree;
    if (h->element_count > L->patch_cap) {
        size_t cap = L->patch_cap ? L->patch_cap : 256;
        while (cap < h->element_count) cap *= 2;
        rad_ff_patch *p = realloc(L->patches, cap * sizeof *p);
        if (p) L->patches = p;
        uint32_t *k = realloc(L->keys, cap * sizeof *k);
        if (k) L->keys = k;
        double *b = realloc(L->radiosity, 3 * cap * sizeof *b);
        if (b) L->radiosity = b;
        double *d = realloc(L->spread, cap * sizeof *d);
        if (d) L->spread = d;
        if (!p || !k || !b || !d) {
            rad_error("hierarchy: out of memory for %zu elements", h->element_count);
            return RAD_ERR_NOMEM;
        }
        L->patch_cap = cap;
    }
    /* the patches on the threads; the keys and values in order (a parent
     * may come before its children in the same call) */
    const ptrdiff_t first = (ptrdiff_t)from, end = (ptrdiff_t)h->element_count;
#pragma omp parallel for schedule(static) if (end - first > 4096)
    for (ptrdiff_t e = first; e < end; e++) {
        const rad_element *el = &h->elements[e];
        const rad_patch *root = &h->base->patches[el->root];
        rad_patch p;
        memset(&p, 0, sizeof p);
        p.vertex_count = el->vertex_count;
        memcpy(p.v, el->v, sizeof p.v);
        p.source_face = root->source_face;
        p.area = el->area;
        p.normal = el->normal;
        p.centroid = el->centroid;
        ff_patch_make(L->scene, h->positions, &p, L->centre, &L->patches[e]);
    }
    for (size_t e = from; e < h->element_count; e++) {
        const rad_element *el = &h->elements[e];
        const rad_patch *root = &h->base->patches[el->root];
        if (el->parent == RAD_NO_ELEMENT) {
            L->keys[e] = L->exact_keys ? L->root_key[el->root] : (uint32_t)e;
            memcpy(&L->radiosity[3 * e], root->emission, 3 * sizeof(double));
            L->spread[e] = 0;
        } else {
            /* child k of parent p: p's key + k 4^(finest - level) */
            uint32_t k = (uint32_t)e - h->elements[el->parent].first_child;
            L->keys[e] = L->exact_keys ? L->keys[el->parent] + (k << (2 * (finest_level(L, el->root) - el->level)))
                                       : (uint32_t)e;
            memcpy(&L->radiosity[3 * e], &L->radiosity[3 * (size_t)el->parent], 3 * sizeof(double));
            L->spread[e] = L->spread[el->parent];
        }
    }
    return RAD_OK;
}

static int splittable(const ff_links *L, uint32_t e)
{
    if (ff_is_cluster(e)) return 1; /* into its child clusters or its roots */
    const rad_element *el = &L->tree.elements[e];
    return el->level < finest_level(L, el->root) && 0.25 * el->area >= L->config.min_area;
}

/* A leaf of the tree that no pass can split (at the finest level, or at
 * --min-area): a leaf of the solution for good. (Leaves made in advance
 * ignore --min-area, so an element that may not be split can have children.) */
static int final_leaf(const ff_links *L, uint32_t e)
{
    return !ff_is_cluster(e) && L->tree.elements[e].first_child == RAD_NO_ELEMENT && !splittable(L, e);
}

/* The cluster tree over the roots (their patches are elements 0 .. roots - 1),
 * each cluster's largest rho, and its oracle B from the roots' E. */
static void cluster_values(ff_links *L, const double *lo, const double *hi);

static rad_status clusters_init(ff_links *L)
{
    if (!L->backend->cluster_draws || !L->backend->openness) {
        rad_error("the %s backend cannot compute cluster links", L->backend->name);
        return RAD_ERR_UNSUPPORTED;
    }
    if (L->tree.base->patch_count >= FF_CLUSTER_BIT / 2) {
        rad_error("clusters: %zu faces, more than a hierarchy with clusters numbers", L->tree.base->patch_count);
        return RAD_ERR_UNSUPPORTED;
    }
    const uint32_t roots = (uint32_t)L->tree.base->patch_count;
    float *open = NULL;
    rad_status st = RAD_OK;
    if (L->config.cluster_open < 1.0) { /* openness can spread by at most 1: nothing to measure */
        const double t0 = rad_clock_seconds();
        open = malloc((roots ? roots : 1) * sizeof *open);
        if (!open) {
            rad_error("clusters: out of memory for the openness of %u faces", roots);
            return RAD_ERR_NOMEM;
        }
        st = L->backend->openness(L->backend_state, L->patches, roots, ff_openness_reach(L->patches, roots), open);
        L->tally.open_seconds = rad_clock_seconds() - t0;
    }
    if (st == RAD_OK) st = ff_clusters_build(L->patches, open, roots, L->config.cluster_cone, &L->clusters);
    free(open);
    if (st != RAD_OK) return st;
    size_t n = L->clusters.count;
    L->cluster_radiosity = malloc(3 * n * sizeof *L->cluster_radiosity);
    L->cluster_rho = malloc(3 * n * sizeof *L->cluster_rho);
    L->cluster_spread = calloc(n, sizeof *L->cluster_spread);
    if (!L->cluster_radiosity || !L->cluster_rho || !L->cluster_spread) {
        rad_error("clusters: out of memory for %zu clusters", n);
        return RAD_ERR_NOMEM;
    }
    cluster_values(L, NULL, NULL);
    size_t mixed = 0; /* by openness alone: no cone is wider than pi */
    for (size_t c = 0; c < n; c++) mixed += ff_cluster_bound_mixed(&L->clusters.clusters[c].bound, RAD_PI, L->config.cluster_open);
    rad_info("clusters: %zu over %zu faces, %zu of them partly hidden (openness %.3f s)", n,
             L->tree.base->patch_count, mixed, L->tally.open_seconds);
    return RAD_OK;
}

/* The leaves' level per root where they are made in advance: max_level
 * (uniform), or the fewest splits that bring the root's elements to the
 * largest root's area at max_level (sized; the 1 -> 4 split quarters the
 * area, so a root of a quarter of the largest's area stops a level above). */
static rad_status leaves_in_advance(ff_links *L)
{
    const size_t n = L->tree.base->patch_count;
    if (!(L->leaf_level = malloc(n ? n : 1))) {
        rad_error("hierarchy: out of memory for %zu roots' leaf levels", n);
        return RAD_ERR_NOMEM;
    }
    double largest = 0;
    for (size_t r = 0; r < n; r++) largest = fmax(largest, L->tree.base->patches[r].area);
    const uint32_t top = L->config.max_level;
    const double leaf = ldexp(largest, -2 * (int)top) * (1 + 1e-9);
    for (size_t r = 0; r < n; r++) {
        uint32_t level = top;
        if (L->config.sized_leaves)
            for (level = 0; level < top && ldexp(L->tree.base->patches[r].area, -2 * (int)level) > leaf;) level++;
        L->leaf_level[r] = (uint8_t)level;
    }
    return RAD_OK;
}

/* Each root's key: the index of its first leaf in the mesh of the leaves
 * (each root's 4^finest leaves after the roots' before it), so that an
 * element's key is its first leaf's patch index there and a link between
 * two leaves gets the full matrix's entry of those leaves (seeds and
 * tie-breaks). Exact where the leaves number below 2^32, else keys are
 * element indices. */
static rad_status root_keys(ff_links *L)
{
    const size_t n = L->tree.base->patch_count;
    if (!(L->root_key = malloc((n ? n : 1) * sizeof *L->root_key))) {
        rad_error("hierarchy: out of memory for %zu roots' keys", n);
        return RAD_ERR_NOMEM;
    }
    uint64_t at = 0;
    for (size_t r = 0; r < n; r++) {
        L->root_key[r] = (uint32_t)at;
        at += (uint64_t)1 << (2 * finest_level(L, (uint32_t)r));
    }
    L->exact_keys = at < UINT32_MAX;
    return RAD_OK;
}

rad_status ff_links_init(ff_links *L, const rad_scene *scene, const rad_mesh *base, const double centre[3],
                         const ff_links_config *config, const ff_backend *backend, void *backend_state)
{
    memset(L, 0, sizeof *L);
    L->scene = scene;
    memcpy(L->centre, centre, sizeof L->centre);
    L->config = *config;
    if (!(L->config.cluster_cone > 0)) L->config.cluster_cone = RAD_PI; /* 0: no cone, as pi */
    if (!(L->config.cluster_open > 0)) L->config.cluster_open = 1.0;    /* 0: no openness rule, as 1 */
    if (config->clusters && L->config.cluster_open < 1.0 && !config->triangles && config->triangle_count) {
        rad_error("internal: --cluster-open without the occluders (ff_links_config.triangles)");
        return RAD_ERR_INVALID;
    }
    L->backend = backend;
    L->backend_state = backend_state;
    if (config->clusters && !(config->ray_delta > 0)) {
        rad_error("internal: clusters without the shadow segments' delta (ff_links_config.ray_delta)");
        return RAD_ERR_INVALID;
    }
    if (!backend->compute_pairs) {
        rad_error("the %s backend cannot compute hierarchical links", backend->name);
        return RAD_ERR_UNSUPPORTED;
    }
    if (config->max_level > 15) {
        rad_error("--subdiv %u: hierarchical runs take at most 15 levels", config->max_level);
        return RAD_ERR_USAGE;
    }
    rad_status st = rad_hierarchy_init(base, &L->tree);
    if (st == RAD_OK && (config->uniform_leaves || config->sized_leaves)) st = leaves_in_advance(L);
    if (st == RAD_OK) st = root_keys(L);
    if (st != RAD_OK) return st;
    for (size_t r = 0; r < base->patch_count; r++) {
        const rad_patch *p = &base->patches[r];
        double e = fmax(p->emission[0], fmax(p->emission[1], p->emission[2]));
        L->emitted_power += p->area * e;
        L->total_area += p->area;
    }
    L->reflected = L->total_area > 0 ? L->emitted_power / L->total_area : 0;
    st = elements_added(L, 0);
    for (size_t r = 0; st == RAD_OK && L->leaf_level && r < base->patch_count; r++) {
        size_t before = L->tree.element_count;
        st = rad_hierarchy_split_to(&L->tree, (uint32_t)r, L->leaf_level[r]);
        if (st == RAD_OK) st = elements_added(L, before);
    }
    if (st == RAD_OK && config->clusters) st = clusters_init(L);
    return st;
}

void ff_links_free(ff_links *L)
{
    rad_hierarchy_free(&L->tree);
    free(L->patches);
    free(L->keys);
    free(L->leaf_level);
    free(L->root_key);
    free(L->radiosity);
    free(L->spread);
    rad_mem_span_free(L->links, &L->link_span);
    rad_mem_span_free(L->link_left, &L->left_span);
    ff_clusters_free(&L->clusters);
    free(L->cluster_radiosity);
    free(L->cluster_rho);
    free(L->cluster_spread);
    memset(L, 0, sizeof *L);
}

/* ---- what the oracle reads of an element or a cluster ---- */

static double node_area(const ff_links *L, uint32_t id)
{
    return ff_is_cluster(id) ? L->clusters.clusters[ff_cluster_of(id)].link.area : L->tree.elements[id].area;
}

static const double *node_rho(const ff_links *L, uint32_t id)
{
    return ff_is_cluster(id) ? &L->cluster_rho[3 * (size_t)ff_cluster_of(id)]
                             : L->tree.base->patches[L->tree.elements[id].root].rho;
}

static const double *node_radiosity(const ff_links *L, uint32_t id)
{
    return ff_is_cluster(id) ? &L->cluster_radiosity[3 * (size_t)ff_cluster_of(id)] : &L->radiosity[3 * (size_t)id];
}

static double node_spread(const ff_links *L, uint32_t id)
{
    return ff_is_cluster(id) ? L->cluster_spread[ff_cluster_of(id)] : L->spread[id];
}

static ff_cluster_bound node_bound(const ff_links *L, uint32_t id)
{
    return ff_is_cluster(id) ? L->clusters.clusters[ff_cluster_of(id)].bound : ff_element_bound(&L->patches[id]);
}

/* Per cluster (children after parents: one pass from the end): the
 * largest rho and B of its roots, and the spread of B over their leaves
 * (lo, hi: per element, RGB; NULL before a solution: 0). Before a
 * solution a cluster's B is at least the scene's mean radiosity
 * (reflected, P / area then): a cluster that emits nothing still sends
 * what it reflects, and pass 1 weighing its links by 0 would take every
 * cluster link the bounds allow, however poor (an element pair's estimate
 * is good enough for that; a cluster's bounds are not). */
static void cluster_values(ff_links *L, const double *lo, const double *hi)
{
    const ff_cluster_tree *t = &L->clusters;
    /* each cluster's least and largest B (lo, hi) for its parent: the
     * values from the children, each root read once (a cluster's roots
     * again at each level of the tree were most of a pass's serial time
     * at 10^6 faces); from the roots themselves without the memory */
    double *range = lo ? malloc(6 * (t->count ? t->count : 1) * sizeof *range) : NULL;
    for (uint32_t c = t->count; c-- > 0;) {
        const rad_link_cluster *l = &t->clusters[c].link;
        double *rho = &L->cluster_rho[3 * (size_t)c], *B = &L->cluster_radiosity[3 * (size_t)c];
        double low[3] = {INFINITY, INFINITY, INFINITY}, high[3] = {-INFINITY, -INFINITY, -INFINITY};
        for (int k = 0; k < 3; k++) rho[k] = B[k] = 0;
        if (l->child_count && (range || !lo)) {
            for (uint32_t j = l->first_child; j < l->first_child + l->child_count; j++)
                for (int k = 0; k < 3; k++) {
                    rho[k] = fmax(rho[k], L->cluster_rho[3 * (size_t)j + k]);
                    B[k] = fmax(B[k], L->cluster_radiosity[3 * (size_t)j + k]);
                    if (lo) low[k] = fmin(low[k], range[6 * (size_t)j + k]), high[k] = fmax(high[k], range[6 * (size_t)j + 3 + k]);
                }
        } else {
            for (uint32_t i = l->root_begin; i < l->root_end; i++) {
                uint32_t r = t->roots[i];
                const double *root_rho = L->tree.base->patches[r].rho, *root_B = &L->radiosity[3 * (size_t)r];
                for (int k = 0; k < 3; k++) {
                    rho[k] = fmax(rho[k], root_rho[k]);
                    B[k] = fmax(B[k], root_B[k]);
                    if (lo) low[k] = fmin(low[k], lo[3 * (size_t)r + k]), high[k] = fmax(high[k], hi[3 * (size_t)r + k]);
                }
            }
        }
        if (range)
            for (int k = 0; k < 3; k++) range[6 * (size_t)c + k] = low[k], range[6 * (size_t)c + 3 + k] = high[k];
        double d = 0;
        for (int k = 0; lo && k < 3; k++) d = fmax(d, high[k] - low[k]);
        L->cluster_spread[c] = d;
        for (int k = 0; !lo && k < 3; k++) B[k] = fmax(B[k], L->reflected);
    }
    free(range);
}

/* ---- the oracle ---- */

/* The visible fraction the pair's shadow rays saw (1 without rays). */
static double visible_fraction(const ff_pair_outcome *o)
{
    return o->rays ? 1.0 - (double)o->rays_blocked / o->rays : 1.0;
}

/* The oracle's geometry of a pair of two leaves no pass splits, which the
 * backend does not compute (ff_pair_job.spread): the factor's spread over a
 * leaf is what the full matrix of those leaves has too (the same entry), so
 * only the visibility and the estimate's own error are left, with F / V as
 * the unoccluded mean. */
static rad_ff_spread leaf_pair_geometry(const ff_pair_outcome *o, double area_s)
{
    const double V = visible_fraction(o);
    return (rad_ff_spread){o->coupling * area_s * (V > 0 ? 1.0 / V : 0.0), 0.0, 0.0};
}

/* Error of F_rs (F units) from a pair's outcome: the factor's spread over
 * r, scaled by the visible fraction V; where rays saw the pair partly
 * hidden, what V of a part may differ from V of the whole (each of the
 * 4 children holds a quarter: |V_k - V| <= 4 min(V, 1 - V), at most 1),
 * times the mean unoccluded factor; and the estimate's own error. */
static double factor_error(const ff_pair_outcome *o, double spread, double mean, double area_s)
{
    double V = visible_fraction(o);
    double partial = 4.0 * fmin(V, 1.0 - V);
    return spread * V + mean * (partial < 1.0 ? partial : 1.0) + o->error * area_s;
}

/* What the shaped solve leaves of that error where r's leaves lie `depth`
 * levels below r: the spread becomes what a leaf's centre misses of the
 * leaf's mean, a quadratic's (4/3) curvature 4^-depth; depth 0 (r is its
 * own leaf: nothing to spread over) leaves the error whole. */
static double gather_error(const ff_pair_outcome *o, double spread, double curvature, double mean, double area_s,
                           uint32_t depth)
{
    if (depth > 0) spread = fmin(spread, curvature * (4.0 / 3.0) * ldexp(1.0, -2 * (int)depth));
    return factor_error(o, spread, mean, area_s);
}

/* Levels from element e down to its leaves where the leaves are known in
 * advance (uniform or sized leaves), else 0. */
static uint32_t leaf_depth(const ff_links *L, uint32_t e)
{
    if (ff_is_cluster(e) || !L->leaf_level) return 0;
    const rad_element *el = &L->tree.elements[e];
    const uint32_t finest = finest_level(L, el->root);
    return finest > el->level ? finest - el->level : 0;
}

/* How much the oracle weighs r <- s: in radiosity (error: what the link's
 * error may move r's leaves by) or power (BF), or F alone. (Per unit of the
 * factor the link carries, rho B_s e_rs / (F_rs + e_rs), bounds a
 * receiver's links together, but refined the Cornell box at finest level
 * 4 to 450 links per leaf at link-tol 1 and 3000 at 0.1: more than the
 * full matrix's 7424.) */
static double weight(const ff_links *L, uint32_t r, uint32_t s, double F_rs, double e_rs)
{
    if (L->config.oracle == FF_ORACLE_FACTOR) return F_rs;
    const double *rho = node_rho(L, r), *B = node_radiosity(L, s);
    double rb = fmax(rho[0] * B[0], fmax(rho[1] * B[1], rho[2] * B[2]));
    if (L->config.oracle == FF_ORACLE_POWER) return rb * node_area(L, r) * F_rs;
    return rb * e_rs;
}

/* The gather oracle's weight of r <- s: what the shaped solve leaves of
 * the factor's error at r's leaves (g_rs, B_s), plus what it cannot
 * shape, the part of s's spread dB_s that the factor's variation over s
 * (e_sr of F_sr) lets differ between r's leaves. */
static double gather_weight(const ff_links *L, uint32_t r, uint32_t s, double F_rs, double g_rs, double F_sr,
                            double e_sr)
{
    const double *rho = node_rho(L, r);
    const double varies = F_sr > 0 ? fmin(1.0, e_sr / F_sr) : 1.0;
    return weight(L, r, s, F_rs, g_rs) + fmax(rho[0], fmax(rho[1], rho[2])) * F_rs * node_spread(L, s) * varies;
}

/* Does the pair (a, b) need finer elements? link_tol 0: always. left: its
 * g_ab, g_ba (the gather oracle's; NULL for the others). */
static int over_tolerance(const ff_links *L, const ff_link_pair *p, const float *left)
{
    if (L->config.link_tol <= 0) return 1;
    double Fab = p->coupling * node_area(L, p->b), Fba = p->coupling * node_area(L, p->a);
    double w;
    if (L->config.oracle == FF_ORACLE_GATHER)
        w = fmax(gather_weight(L, p->a, p->b, Fab, left[0], Fba, p->error_ba),
                 gather_weight(L, p->b, p->a, Fba, left[1], Fab, p->error_ab));
    else
        w = fmax(weight(L, p->a, p->b, Fab, p->error_ab), weight(L, p->b, p->a, Fba, p->error_ba));
    double scale = L->config.oracle == FF_ORACLE_FACTOR ? 1.0
                 : L->config.oracle == FF_ORACLE_POWER  ? L->emitted_power
                                                        : L->reflected;
    return w > L->config.link_tol * scale;
}

/* The share of a link's tolerance its shadow rays may leave as the
 * visible fraction's error (ff_pair_job.ray_floor). cluttered_room's rms
 * error against its full matrix at link-tol 1e-3 (docs/performance.md):
 * 2.24e-4 with the matrix's rays, 2.91e-4 at 1/16, 3.55e-4 at 1/8, 4.73e-4
 * at 1/4; at 1e-2 3.7x fewer rays than the matrix's at 1/8. */
#define FF_LINK_RAY_SHARE 0.125

/* How far the shadow rays of element pair (a, b) need to take its
 * coupling's error: a coupling error dc is an error A_s dc of F_rs, which
 * the error oracle (and gather's first term) weighs (`weight`) in each
 * direction against link-tol x the mean reflected radiosity; rays that
 * leave dc at a FF_LINK_RAY_SHARE of that are all the oracle can use. 0
 * (the run's batches) under link-tol 0 and for the oracles that weigh no
 * error. */
static float ray_floor(const ff_links *L, uint32_t a, uint32_t b)
{
    if (!(L->config.link_tol > 0) || !(L->reflected > 0)) return 0.0f;
    if (L->config.oracle != FF_ORACLE_ERROR && L->config.oracle != FF_ORACLE_GATHER) return 0.0f;
    const double w = fmax(weight(L, a, b, 0.0, node_area(L, b)), weight(L, b, a, 0.0, node_area(L, a)));
    const double floor_c = FF_LINK_RAY_SHARE * L->config.link_tol * L->reflected / w; /* inf where w = 0 */
    return floor_c < FLT_MAX ? (float)floor_c : FLT_MAX;
}

/* ---- rounds ---- */

typedef struct job_list {
    ff_pair_job *jobs;
    size_t count, cap;
    rad_mem_span span;
} job_list;

/* A cluster whose faces face apart (normals beyond config.cluster_cone of
 * their mean): one irradiance for all of them would give faces turned away
 * from a source its light and the faces facing it too little (a table's
 * bottom what falls on its top). Measured on an interior of 10 270
 * triangles: walls and ceiling 5-9 % dark, objects 2-5 % bright at
 * link-tol 0.1 with such links; within 1 % without (docs/hierarchy.md). */
static int mixed_end(const ff_links *L, uint32_t id)
{
    return ff_is_cluster(id) && ff_cluster_bound_mixed(&L->clusters.clusters[ff_cluster_of(id)].bound,
                                                       L->config.cluster_cone, L->config.cluster_open);
}

/* A pair is split into its children's pairs (split_elements makes the
 * elements that needs, split_jobs lists the pairs).
 *
 * Two elements: the larger element split, both where their areas are
 * within 2x (and both can be).
 *
 * A pair with a cluster at an end: a cluster's self-link becomes the
 * pairs of its children (each with itself too) or of its roots (a flat
 * face does not see itself); another pair the pairs of its cluster's parts
 * (the wider cluster's, by bounding sphere, where both ends are clusters)
 * with the other end, a cluster's parts being its child clusters or its
 * roots. An element is not split against a cluster: what a cluster link
 * cannot resolve is the cluster's faces (their orientations, their
 * distances), and cutting a wall into its finest elements around every
 * object in front of it (measured: 15x the elements of the interior at
 * 5 000 faces) resolves nothing; face pairs are computed exactly, and
 * their own estimates split elements where the light varies. */
static void element_sides(const ff_links *L, uint32_t a, uint32_t b, int *out_sa, int *out_sb)
{
    double Aa = L->tree.elements[a].area, Ab = L->tree.elements[b].area;
    int sa = splittable(L, a), sb = splittable(L, b);
    int both = sa && sb && Aa <= 2 * Ab && Ab <= 2 * Aa;
    if (!both && sa && sb) {
        sa = Aa >= Ab;
        sb = !sa;
    }
    *out_sa = sa, *out_sb = sb;
}

/* The end split of a pair (a != b) with a cluster at an end. */
static uint32_t cluster_side(const ff_links *L, uint32_t a, uint32_t b)
{
    ff_cluster_bound ba = node_bound(L, a), bb = node_bound(L, b);
    int sa = splittable(L, a), sb = splittable(L, b);
    if (ff_is_cluster(a) != ff_is_cluster(b)) sa = ff_is_cluster(a), sb = !sa;
    const int ma = mixed_end(L, a), mb = mixed_end(L, b);
    if (ma != mb) sa = ma, sb = mb;
    return sa && (!sb || ba.radius >= bb.radius) ? a : b;
}

/* Makes the elements the split of (a, b) needs (rad_hierarchy_split: none
 * where they exist); their patches, keys and values are left to
 * elements_added. */
static rad_status split_elements(ff_links *L, uint32_t a, uint32_t b)
{
    uint32_t first;
    if (ff_is_cluster(a) || ff_is_cluster(b)) {
        if (a == b) return RAD_OK;
        const uint32_t side = cluster_side(L, a, b);
        return ff_is_cluster(side) ? RAD_OK : rad_hierarchy_split(&L->tree, side, &first);
    }
    int sa, sb;
    element_sides(L, a, b, &sa, &sb);
    rad_status st = sa ? rad_hierarchy_split(&L->tree, a, &first) : RAD_OK;
    if (st == RAD_OK && sb) st = rad_hierarchy_split(&L->tree, b, &first);
    return st;
}

static void put_job(ff_pair_job *out, size_t *n, uint32_t a, uint32_t b)
{
    if (out) out[*n] = (ff_pair_job){a < b ? a : b, a < b ? b : a, 1, 0.0f};
    (*n)++;
}

/* The children's pairs that replace (a, b), in order, into out (NULL:
 * only counted); the count. Once split_elements has run, where out is
 * given. *makes (may be NULL): whether the split makes elements (an end to
 * split without children yet), which only the one thread may do. */
static size_t split_jobs(const ff_links *L, uint32_t a, uint32_t b, ff_pair_job *out, int *makes)
{
    size_t n = 0;
    if (makes) *makes = 0;
    if (ff_is_cluster(a) || ff_is_cluster(b)) {
        if (a == b) {
            const rad_link_cluster *c = &L->clusters.clusters[ff_cluster_of(a)].link;
            if (c->child_count) {
                for (uint32_t i = 0; i < c->child_count; i++)
                    for (uint32_t j = i; j < c->child_count; j++)
                        put_job(out, &n, FF_CLUSTER_ID(c->first_child + i), FF_CLUSTER_ID(c->first_child + j));
            } else {
                for (uint32_t i = c->root_begin; i < c->root_end; i++)
                    for (uint32_t j = i + 1; j < c->root_end; j++)
                        put_job(out, &n, L->clusters.roots[i], L->clusters.roots[j]);
            }
            return n;
        }
        const uint32_t side = cluster_side(L, a, b), other = side == a ? b : a;
        if (ff_is_cluster(side)) {
            const rad_link_cluster *c = &L->clusters.clusters[ff_cluster_of(side)].link;
            if (c->child_count)
                for (uint32_t i = 0; i < c->child_count; i++) put_job(out, &n, FF_CLUSTER_ID(c->first_child + i), other);
            else
                for (uint32_t i = c->root_begin; i < c->root_end; i++) put_job(out, &n, L->clusters.roots[i], other);
            return n;
        }
        const uint32_t first = L->tree.elements[side].first_child;
        if (makes) *makes = first == RAD_NO_ELEMENT;
        for (uint32_t i = 0; i < 4; i++) put_job(out, &n, first + i, other);
        return n;
    }
    int sa, sb;
    element_sides(L, a, b, &sa, &sb);
    if (makes)
        *makes = (sa && L->tree.elements[a].first_child == RAD_NO_ELEMENT) ||
                 (sb && L->tree.elements[b].first_child == RAD_NO_ELEMENT);
    const uint32_t ca = sa ? L->tree.elements[a].first_child : a;
    const uint32_t cb = sb ? L->tree.elements[b].first_child : b;
    for (uint32_t i = 0; i < (sa ? 4u : 1u); i++)
        for (uint32_t j = 0; j < (sb ? 4u : 1u); j++) put_job(out, &n, ca + i, cb + j);
    return n;
}

/* Room for `need` items of `size` bytes in `array` (its first `count`
 * kept; capacity *cap): *out is the array, moved where it had to grow
 * past its span (logged and untouched for lack of memory). In place
 * almost always (rad_mem_grow): the links reach gigabytes. */
static rad_status grow(void *array, rad_mem_span *span, size_t *cap, size_t count, size_t need, size_t size,
                       const char *what, void **out)
{
    *out = array;
    if (need <= *cap) return RAD_OK;
    if (need < 1024) need = 1024;
    void *q = rad_mem_grow(array, count * size, need * size, span);
    if (!q) {
        rad_error("hierarchy: out of memory for %zu %s", need, what);
        return RAD_ERR_NOMEM;
    }
    *out = q;
    *cap = span->bytes / size;
    return RAD_OK;
}

/* Room in `l` for `more` pairs past its count. */
static rad_status job_reserve(job_list *l, size_t more)
{
    void *jobs;
    const rad_status st =
        grow(l->jobs, &l->span, &l->cap, l->count, l->count + more, sizeof *l->jobs, "candidate pairs", &jobs);
    l->jobs = jobs;
    return st;
}

static void job_free(job_list *l)
{
    rad_mem_span_free(l->jobs, &l->span);
    *l = (job_list){0};
}

static rad_status job_push(job_list *l, uint32_t a, uint32_t b)
{
    const rad_status st = job_reserve(l, 1);
    if (st == RAD_OK) put_job(l->jobs, &l->count, a, b);
    return st;
}

/* ---- a round's pairs through the backend ---- */

/* The cluster tree and the elements, as cluster_draws takes them. */
static ff_cluster_view cluster_view(const ff_links *L)
{
    return (ff_cluster_view){.clusters = L->clusters.clusters,
                             .roots = L->clusters.roots,
                             .area_before = L->clusters.area_before,
                             .patches = L->patches,
                             .cluster_count = L->clusters.count,
                             .root_count = L->clusters.root_count,
                             .element_count = L->tree.element_count,
                             .cone = L->config.cluster_cone,
                             .open_spread = L->config.cluster_open,
                             .delta = L->config.ray_delta};
}

/* The element pairs into out, the cluster pairs into cout: on this
 * process, or shared by the ranks (L->ranks). */
static rad_status backend_round(ff_links *L, const job_list *pairs, const job_list *cpairs, ff_pair_outcome *out,
                                ff_cluster_drawn *cout, ff_counters *counters)
{
    const ff_cluster_view v = cluster_view(L);
    const ff_round_work w = {.backend = L->backend, .backend_state = L->backend_state, .patches = L->patches,
                             .keys = L->keys, .view = cpairs->count ? &v : NULL, .pairs = pairs->jobs,
                             .pair_count = pairs->count, .out = out, .cluster_pairs = cpairs->jobs,
                             .cluster_count = cpairs->count, .cluster_out = cout};
    double seconds = 0;
    const rad_status st = L->ranks ? ff_rank_rounds_compute(L->ranks, &w, L->tree.element_count, counters, &seconds)
                                   : ff_round_compute(&w, counters, &seconds);
    if (cpairs->count) {
        L->tally.cluster_seconds += seconds;
        L->tally.cluster_pairs += cpairs->count;
        uint64_t rays = 0; /* a read of every outcome: gigabytes in a large round, one thread's second */
#pragma omp parallel for schedule(static) reduction(+ : rays)
        for (size_t i = 0; i < (st == RAD_OK ? cpairs->count : 0); i++) rays += cout[i].rays;
        L->tally.cluster_rays += rays;
    }
    return st;
}

/* ---- a round on the threads ----
 *
 * A round's candidates are sorted into element and cluster pairs, and
 * decided, in chunks on the threads, with the serial order's result for
 * any thread count: (1) each candidate's verdict (no link, a link, or
 * split) and what it adds (links, the next round's pairs), counted by
 * chunk; (2) in list order, one thread, the elements the splits need
 * (their numbering is the order in which they are first needed); (3) each
 * chunk's links and next pairs written at its chunk's offsets, in list
 * order. At 10^6 triangles the rounds decide about 10^9 candidates. */
#define ROUND_CHUNK 16384

static size_t chunk_begin(size_t c, size_t n) { return c * ROUND_CHUNK < n ? c * ROUND_CHUNK : n; }

/* A candidate's verdict: no link (not facing), a link, a split, or a
 * split that makes elements (split_jobs' makes). */
enum { VERDICT_NONE = 0, VERDICT_LINK = 1, VERDICT_SPLIT = 2, VERDICT_SPLIT_NEW = 3 };

typedef struct round_chunk {
    size_t elements, clusters;  /* its element pairs, its cluster pairs; (1): the index of its first of each */
    size_t links, jobs;          /* what it adds; (3): where its first goes */
    size_t splits, makers, near, element_splits, cluster_links; /* makers: its VERDICT_SPLIT_NEW */
} round_chunk;

/* (1) of a split (a, b): counted into its chunk, its verdict returned. */
static uint8_t split_verdict(const ff_links *L, uint32_t a, uint32_t b, round_chunk *ch)
{
    int makes;
    ch->splits++;
    ch->jobs += split_jobs(L, a, b, NULL, &makes);
    ch->makers += makes;
    return makes ? VERDICT_SPLIT_NEW : VERDICT_SPLIT;
}

/* (2): the elements that the splits of chunks [0, chunk_count) need, made
 * in order; their patches, keys and values after. The pairs: a round's
 * candidates (jobs) or a pass's links (links), the other NULL. */
static rad_status make_elements(ff_links *L, const uint8_t *verdict, const ff_pair_job *jobs,
                                const ff_link_pair *links, size_t n, const round_chunk *chunks, size_t chunk_count)
{
    const double t0 = rad_clock_seconds();
    const size_t before = L->tree.element_count;
    rad_status st = RAD_OK;
    for (size_t c = 0; c < chunk_count && st == RAD_OK; c++) {
        if (!chunks[c].makers) continue;
        for (size_t k = chunk_begin(c, n); k < chunk_begin(c + 1, n) && st == RAD_OK; k++)
            if (verdict[k] == VERDICT_SPLIT_NEW)
                st = jobs ? split_elements(L, jobs[k].a, jobs[k].b) : split_elements(L, links[k].a, links[k].b);
    }
    if (st == RAD_OK && L->tree.element_count > before) st = elements_added(L, before);
    L->tally.seconds_elements += rad_clock_seconds() - t0;
    return st;
}

typedef struct round_state {
    const job_list *list;            /* the candidates, in list order */
    const ff_pair_job *pairs;        /* its element pairs, in list order (their spread flags) */
    const ff_pair_outcome *out;      /* per element pair */
    const ff_cluster_drawn *cout;    /* per cluster pair */
    uint8_t *verdict;                /* per candidate */
    round_chunk *chunks;
    size_t chunk_count;
} round_state;

/* Candidate k's verdict, and its link in *p and its g in left[0 .. 1]
 * where it has one (or is split: the estimate split on). ke, kc: its index
 * among the element pairs, the cluster pairs. */
static int candidate_verdict(const ff_links *L, const round_state *r, size_t k, size_t ke, size_t kc, ff_link_pair *p,
                             float *left)
{
    const uint32_t a = r->list->jobs[k].a, b = r->list->jobs[k].b;
    *p = (ff_link_pair){.a = a, .b = b};
    if (ff_is_cluster(a) || ff_is_cluster(b)) {
        const ff_cluster_drawn *c = &r->cout[kc];
        if (!c->facing) return VERDICT_NONE;
        if (c->must_split) return VERDICT_SPLIT;
        p->coupling = c->coupling;
        p->error_ab = left[0] = (float)c->error_ab;
        p->error_ba = left[1] = (float)c->error_ba;
    } else {
        const ff_pair_outcome *o = &r->out[ke];
        const int weighed = r->pairs[ke].spread;
        if (o->verdict == FF_PAIR_NOT_FACING) return VERDICT_NONE;
        double Aa = L->tree.elements[a].area, Ab = L->tree.elements[b].area;
        const rad_ff_spread ab = weighed ? o->spread_ab : leaf_pair_geometry(o, Ab);
        const rad_ff_spread ba = weighed ? o->spread_ba : leaf_pair_geometry(o, Aa);
        p->coupling = o->coupling;
        p->error_ab = (float)factor_error(o, ab.spread, ab.mean, Ab);
        p->error_ba = (float)factor_error(o, ba.spread, ba.mean, Aa);
        left[0] = (float)gather_error(o, ab.spread, ab.curvature, ab.mean, Ab, leaf_depth(L, a));
        left[1] = (float)gather_error(o, ba.spread, ba.curvature, ba.mean, Aa, leaf_depth(L, b));
    }
    return (splittable(L, a) || splittable(L, b)) && over_tolerance(L, p, left) ? VERDICT_SPLIT : VERDICT_LINK;
}

/* The candidates sorted into element pairs and cluster pairs, each in
 * list order; the chunks' first index of each. */
static rad_status sort_round(const ff_links *L, round_state *r, job_list *pairs, job_list *cpairs)
{
    const size_t n = r->list->count;
    const ff_pair_job *jobs = r->list->jobs;
#pragma omp parallel for schedule(dynamic, 1)
    for (size_t c = 0; c < r->chunk_count; c++) {
        size_t clustered = 0;
        for (size_t k = chunk_begin(c, n); k < chunk_begin(c + 1, n); k++)
            clustered += ff_is_cluster(jobs[k].a) || ff_is_cluster(jobs[k].b);
        r->chunks[c] = (round_chunk){.elements = chunk_begin(c + 1, n) - chunk_begin(c, n) - clustered,
                                     .clusters = clustered};
    }
    size_t e = 0, q = 0;
    for (size_t c = 0; c < r->chunk_count; c++) {
        const size_t ce = r->chunks[c].elements, cc = r->chunks[c].clusters;
        r->chunks[c].elements = e, r->chunks[c].clusters = q;
        e += ce, q += cc;
    }
    pairs->count = cpairs->count = 0;
    rad_status st = job_reserve(pairs, e);
    if (st == RAD_OK) st = job_reserve(cpairs, q);
    if (st != RAD_OK) return st;
    pairs->count = e, cpairs->count = q;
#pragma omp parallel for schedule(dynamic, 1)
    for (size_t c = 0; c < r->chunk_count; c++) {
        size_t ke = r->chunks[c].elements, kc = r->chunks[c].clusters;
        for (size_t k = chunk_begin(c, n); k < chunk_begin(c + 1, n); k++) {
            const ff_pair_job *j = &jobs[k];
            if (ff_is_cluster(j->a) || ff_is_cluster(j->b)) {
                cpairs->jobs[kc++] = *j;
            } else {
                /* two leaves no pass can split need no oracle: their link is the leaves' entry */
                pairs->jobs[ke++] = (ff_pair_job){j->a, j->b, !final_leaf(L, j->a) || !final_leaf(L, j->b),
                                                   ray_floor(L, j->a, j->b)};
            }
        }
    }
    return RAD_OK;
}

/* (1): the verdicts, and by chunk what they add. */
static void decide_round(const ff_links *L, round_state *r)
{
    const size_t n = r->list->count;
#pragma omp parallel for schedule(dynamic, 1)
    for (size_t c = 0; c < r->chunk_count; c++) {
        round_chunk *ch = &r->chunks[c];
        size_t ke = ch->elements, kc = ch->clusters;
        for (size_t k = chunk_begin(c, n); k < chunk_begin(c + 1, n); k++) {
            const uint32_t a = r->list->jobs[k].a, b = r->list->jobs[k].b;
            const int clustered = ff_is_cluster(a) || ff_is_cluster(b);
            ff_link_pair p;
            float left[2];
            const int v = candidate_verdict(L, r, k, ke, kc, &p, left);
            r->verdict[k] = (uint8_t)v;
            if (v == VERDICT_LINK) {
                ch->links++;
                ch->cluster_links += clustered;
            } else if (v == VERDICT_SPLIT) {
                ch->near += clustered && r->cout[kc].must_split;
                ch->element_splits += !clustered;
                r->verdict[k] = split_verdict(L, a, b, ch);
            }
            clustered ? kc++ : ke++;
        }
    }
}

/* (3): the links and the next round's pairs, at their chunks' offsets. A
 * link's estimate is worked out again from its outcome rather than kept
 * from (1): keeping it would cost 32 bytes a candidate beside the links. */
static void write_round(ff_links *L, const round_state *r, job_list *next)
{
    const size_t n = r->list->count;
#pragma omp parallel for schedule(dynamic, 1)
    for (size_t c = 0; c < r->chunk_count; c++) {
        const round_chunk *ch = &r->chunks[c];
        size_t ke = ch->elements, kc = ch->clusters, link = ch->links, job = ch->jobs;
        for (size_t k = chunk_begin(c, n); k < chunk_begin(c + 1, n); k++) {
            const uint32_t a = r->list->jobs[k].a, b = r->list->jobs[k].b;
            const int clustered = ff_is_cluster(a) || ff_is_cluster(b);
            if (r->verdict[k] == VERDICT_LINK) {
                float scratch[2];
                candidate_verdict(L, r, k, ke, kc, &L->links[link], L->link_left ? &L->link_left[2 * link] : scratch);
                link++;
            } else if (r->verdict[k] >= VERDICT_SPLIT) {
                job += split_jobs(L, a, b, next->jobs + job, NULL);
            }
            clustered ? kc++ : ke++;
        }
    }
}

/* Room for `more` links past link_count (and their g under the gather
 * oracle). */
static rad_status link_reserve(ff_links *L, size_t more)
{
    void *links;
    rad_status st = grow(L->links, &L->link_span, &L->link_cap, L->link_count, L->link_count + more,
                         sizeof *L->links, "links", &links);
    L->links = links;
    if (st == RAD_OK && L->config.oracle == FF_ORACLE_GATHER) {
        void *left;
        size_t cap = L->left_span.bytes / sizeof *L->link_left; /* floats, 2 a link */
        st = grow(L->link_left, &L->left_span, &cap, 2 * L->link_count, 2 * (L->link_count + more),
                  sizeof *L->link_left, "links' g", &left);
        L->link_left = left;
    }
    return st;
}

/* A round's verdicts into links, new elements and the next round's pairs
 * (next: emptied first). */
static rad_status apply_round(ff_links *L, round_state *r, job_list *next, round_chunk *total)
{
    *total = (round_chunk){0};
    for (size_t c = 0; c < r->chunk_count; c++) {
        round_chunk *ch = &r->chunks[c];
        const size_t links = ch->links, jobs = ch->jobs;
        ch->links = L->link_count + total->links, ch->jobs = total->jobs;
        total->links += links, total->jobs += jobs;
        total->splits += ch->splits, total->near += ch->near;
        total->element_splits += ch->element_splits, total->cluster_links += ch->cluster_links;
    }
    rad_status st = make_elements(L, r->verdict, r->list->jobs, NULL, r->list->count, r->chunks, r->chunk_count);
    next->count = 0;
    if (st == RAD_OK) st = link_reserve(L, total->links);
    if (st == RAD_OK) st = job_reserve(next, total->jobs);
    if (st != RAD_OK) return st;
    write_round(L, r, next);
    L->link_count += total->links;
    next->count = total->jobs;
    return RAD_OK;
}

/* A round's outcomes, kept from round to round: the backend writes
 * gigabytes of them a round at 10^6 faces, and into fresh pages every
 * write is a fault and a cleared page first (at 10^6 faces on one H200,
 * most of what the element pairs' transfers took). Each round takes the
 * bytes it needs; the pages past them are given back (rad_mem_trim), so
 * that the resident size follows the round as malloc's did. */
typedef struct round_buffer {
    void *data;
    size_t bytes;
    int mapped; /* rad_mem_reserve's (else malloc's) */
} round_buffer;

static void round_buffer_free(round_buffer *b)
{
    if (b->mapped)
        rad_mem_release(b->data, b->bytes);
    else
        free(b->data);
    *b = (round_buffer){0};
}

/* The pages past the first `bytes` given back. */
static void round_buffer_trim(round_buffer *b, size_t bytes)
{
    if (b->mapped && bytes < b->bytes) rad_mem_trim(b->data, bytes, b->bytes);
}

/* Room for `bytes`; NULL (nothing logged) where there is no memory. */
static void *round_buffer_take(round_buffer *b, size_t bytes)
{
    if (bytes > b->bytes || !b->data) {
        round_buffer_free(b);
        const size_t room = bytes + bytes / 4 + 4096;
        b->data = rad_mem_reserve(room);
        b->mapped = b->data != NULL;
        if (!b->data) b->data = malloc(room);
        b->bytes = b->data ? room : 0;
        return b->data;
    }
    round_buffer_trim(b, bytes);
    return b->data;
}

/* Candidates through the backend, then decided (above). */
static rad_status run_rounds(ff_links *L, job_list *list, ff_counters *counters, uint64_t *refined)
{
    rad_status st = RAD_OK;
    round_state r = {.list = list};
    size_t verdict_cap = 0, chunk_cap = 0;
    job_list next = {0}, pairs = {0}, cpairs = {0};
    round_buffer out_buffer = {0}, cout_buffer = {0};
    while (st == RAD_OK && list->count > 0) {
        const size_t n = list->count;
        r.chunk_count = (n + ROUND_CHUNK - 1) / ROUND_CHUNK;
        if (n > verdict_cap) {
            free(r.verdict);
            r.verdict = malloc(n);
            verdict_cap = r.verdict ? n : 0;
        }
        if (r.chunk_count > chunk_cap) {
            free(r.chunks);
            r.chunks = malloc(r.chunk_count * sizeof *r.chunks);
            chunk_cap = r.chunks ? r.chunk_count : 0;
        }
        if (!r.verdict || !r.chunks) {
            rad_error("hierarchy: out of memory for %zu candidate pairs", n);
            st = RAD_ERR_NOMEM;
            break;
        }
        const double t_sort = rad_clock_seconds();
        if ((st = sort_round(L, &r, &pairs, &cpairs)) != RAD_OK) break;
        const size_t clustered = cpairs.count;
        ff_pair_outcome *out = round_buffer_take(&out_buffer, pairs.count * sizeof *out);
        ff_cluster_drawn *cout = round_buffer_take(&cout_buffer, clustered * sizeof *cout);
        if (!out || !cout) {
            rad_error("hierarchy: out of memory for %zu candidate pairs", n);
            st = RAD_ERR_NOMEM;
            break;
        }
        const double t_backend = rad_clock_seconds();
        L->tally.seconds_sort += t_backend - t_sort;
        rad_status bst = backend_round(L, &pairs, &cpairs, out, cout, counters);
        const double t_decide = rad_clock_seconds();
        L->tally.seconds_backend += t_decide - t_backend;
        round_chunk total = {0};
        if ((st = bst) == RAD_OK) {
            L->tally.candidates += n;
            L->tally.rounds++;
            r.pairs = pairs.jobs, r.out = out, r.cout = cout;
            decide_round(L, &r);
            st = apply_round(L, &r, &next, &total);
        }
        if (st != RAD_OK) break;
        *refined += total.splits;
        if (clustered && n >= 100000) /* progress, where rounds take seconds */
            rad_info("round %llu: %zu candidates: %zu element pairs (%zu refined), %zu with a cluster (%zu too near, "
                     "%zu linked); %zu links, %zu elements",
                     (unsigned long long)L->tally.rounds, n, n - clustered, total.element_splits, clustered, total.near,
                     total.cluster_links, total.links, L->tree.element_count);
        L->tally.seconds_decide += rad_clock_seconds() - t_decide;
        job_list t = *list;
        *list = next;
        next = t;
        /* no more resident while the next round is sorted than it may use */
        round_buffer_trim(&out_buffer, list->count * sizeof(ff_pair_outcome));
        round_buffer_trim(&cout_buffer, list->count * sizeof(ff_cluster_drawn));
    }
    free(r.verdict);
    free(r.chunks);
    job_free(&next);
    job_free(&pairs);
    job_free(&cpairs);
    round_buffer_free(&out_buffer);
    round_buffer_free(&cout_buffer);
    return st;
}

/* The oracle's B per element from a solution on the leaves: leaves take
 * theirs, split elements the area-weighted mean of their children
 * (children come after their parent: one pass from the end). */
static void set_radiosity(ff_links *L, const double *leaf_radiosity)
{
    const rad_hierarchy *h = &L->tree;
    uint32_t *leaves = rad_hierarchy_leaf_elements(h);
    if (!leaves) return;
    for (size_t k = 0; k < h->leaf_count; k++)
        memcpy(&L->radiosity[3 * (size_t)leaves[k]], &leaf_radiosity[3 * k], 3 * sizeof(double));
    free(leaves);
    double *lo = malloc(6 * (h->element_count ? h->element_count : 1) * sizeof *lo), *hi = lo ? lo + 3 * h->element_count : NULL;
    for (size_t e = h->element_count; e-- > 0;) {
        const rad_element *el = &h->elements[e];
        if (el->first_child == RAD_NO_ELEMENT) {
            if (lo) {
                memcpy(&lo[3 * e], &L->radiosity[3 * e], 3 * sizeof *lo);
                memcpy(&hi[3 * e], &L->radiosity[3 * e], 3 * sizeof *hi);
            }
            L->spread[e] = 0;
            continue;
        }
        double d = 0;
        for (int c = 0; c < 3; c++) {
            double sum = 0, l = INFINITY, u = -INFINITY;
            for (uint32_t i = 0; i < 4; i++) {
                const size_t ch = el->first_child + i;
                sum += h->elements[ch].area * L->radiosity[3 * ch + c];
                if (lo) l = fmin(l, lo[3 * ch + c]), u = fmax(u, hi[3 * ch + c]);
            }
            L->radiosity[3 * e + c] = sum / el->area;
            if (lo) lo[3 * e + c] = l, hi[3 * e + c] = u, d = fmax(d, u - l);
        }
        L->spread[e] = lo ? d : INFINITY; /* without memory for the spread: refine as if unknown */
    }
    if (L->config.clusters) cluster_values(L, lo, hi);
    free(lo);
    /* The error oracle's scale: the mean radiosity of what does not emit
     * (brightest channel, area-weighted over the roots). */
    double sum = 0, area = 0, all = 0;
    for (size_t r = 0; r < h->base->patch_count; r++) {
        const rad_patch *p = &h->base->patches[r];
        const double *B = &L->radiosity[3 * r];
        double b = p->area * fmax(B[0], fmax(B[1], B[2]));
        all += b;
        if (p->emission[0] > 0 || p->emission[1] > 0 || p->emission[2] > 0) continue;
        sum += b;
        area += p->area;
    }
    if (area == 0) sum = all, area = L->total_area; /* everything emits (the furnace) */
    if (sum > 0) L->reflected = sum / area;
}

int ff_links_leaf_radiosity(const ff_links *L, double *B)
{
    const rad_hierarchy *h = &L->tree;
    uint32_t *leaves = rad_hierarchy_leaf_elements(h);
    if (!leaves) return 0;
    for (size_t k = 0; k < h->leaf_count; k++) memcpy(&B[3 * k], &L->radiosity[3 * (size_t)leaves[k]], 3 * sizeof(double));
    free(leaves);
    return 1;
}

/* The links not split (verdict below VERDICT_SPLIT), kept in order, on
 * the threads: window by window of chunks, each gathered into a buffer
 * and then copied down to its place, which lies below every link not yet
 * read. chunks[c].links: the links chunk c keeps. */
#define KEEP_WINDOW 64 /* chunks: a 32 MiB buffer */
static rad_status keep_links(ff_links *L, const uint8_t *verdict, round_chunk *chunks, size_t chunk_count)
{
    const size_t n = L->link_count;
    ff_link_pair *buffer = malloc((size_t)KEEP_WINDOW * ROUND_CHUNK * sizeof *buffer);
    float *left = L->link_left ? malloc((size_t)KEEP_WINDOW * ROUND_CHUNK * 2 * sizeof *left) : NULL;
    size_t kept = 0;
    if (!buffer || (L->link_left && !left)) {
        free(buffer);
        free(left);
        rad_error("hierarchy: out of memory for the links kept");
        return RAD_ERR_NOMEM;
    }
    for (size_t w = 0; w < chunk_count; w += KEEP_WINDOW) {
        const size_t end = w + KEEP_WINDOW < chunk_count ? w + KEEP_WINDOW : chunk_count;
        size_t m = 0;
        for (size_t c = w; c < end; c++) {
            const size_t keeps = chunks[c].links;
            chunks[c].links = m;
            m += keeps;
        }
#pragma omp parallel for schedule(dynamic, 1)
        for (size_t c = w; c < end; c++) {
            size_t j = chunks[c].links;
            for (size_t k = chunk_begin(c, n); k < chunk_begin(c + 1, n); k++)
                if (verdict[k] < VERDICT_SPLIT) {
                    if (left) left[2 * j] = L->link_left[2 * k], left[2 * j + 1] = L->link_left[2 * k + 1];
                    buffer[j++] = L->links[k];
                }
        }
#pragma omp parallel for schedule(static)
        for (size_t i = 0; i < m; i++) {
            L->links[kept + i] = buffer[i];
            if (left) L->link_left[2 * (kept + i)] = left[2 * i], L->link_left[2 * (kept + i) + 1] = left[2 * i + 1];
        }
        kept += m;
    }
    free(buffer);
    free(left);
    L->link_count = kept;
    return RAD_OK;
}

/* Links now over the tolerance make way for their children's pairs (at
 * the end of `list`), on the threads as a round's candidates are: the
 * verdicts, the elements the splits need in link order, the pairs at
 * their chunks' offsets; then the links kept, in order. */
static rad_status reweigh_links(ff_links *L, job_list *list, uint64_t *refined)
{
    const size_t n = L->link_count, chunks = (n + ROUND_CHUNK - 1) / ROUND_CHUNK;
    uint8_t *verdict = malloc(n ? n : 1);
    round_chunk *chunk = malloc((chunks ? chunks : 1) * sizeof *chunk);
    if (!verdict || !chunk) {
        free(verdict);
        free(chunk);
        rad_error("hierarchy: out of memory for %zu links", n);
        return RAD_ERR_NOMEM;
    }
#pragma omp parallel for schedule(dynamic, 1)
    for (size_t c = 0; c < chunks; c++) {
        round_chunk *ch = &chunk[c];
        *ch = (round_chunk){0};
        for (size_t k = chunk_begin(c, n); k < chunk_begin(c + 1, n); k++) {
            const ff_link_pair *p = &L->links[k];
            const int split = (splittable(L, p->a) || splittable(L, p->b)) &&
                              over_tolerance(L, p, L->link_left ? &L->link_left[2 * k] : NULL);
            verdict[k] = split ? split_verdict(L, p->a, p->b, ch) : VERDICT_LINK;
            ch->links += !split;
        }
    }
    size_t total = 0, splits = 0;
    for (size_t c = 0; c < chunks; c++) {
        const size_t m = chunk[c].jobs;
        chunk[c].jobs = list->count + total;
        total += m;
        splits += chunk[c].splits;
    }
    rad_status st = make_elements(L, verdict, NULL, L->links, n, chunk, chunks);
    if (st == RAD_OK) st = job_reserve(list, total);
    if (st == RAD_OK) {
#pragma omp parallel for schedule(dynamic, 1)
        for (size_t c = 0; c < chunks; c++) {
            size_t j = chunk[c].jobs;
            for (size_t k = chunk_begin(c, n); k < chunk_begin(c + 1, n); k++)
                if (verdict[k] >= VERDICT_SPLIT) j += split_jobs(L, L->links[k].a, L->links[k].b, list->jobs + j, NULL);
        }
        list->count += total;
        st = keep_links(L, verdict, chunk, chunks);
        *refined += splits;
    }
    free(verdict);
    free(chunk);
    return st;
}

rad_status ff_links_refine(ff_links *L, const double *leaf_radiosity, ff_counters *counters, uint64_t *out_refined)
{
    job_list list = {0};
    rad_status st = RAD_OK;
    uint64_t refined = 0;
    if (L->passes == 0 && L->config.clusters) {
        st = job_push(&list, FF_CLUSTER_ID(0), FF_CLUSTER_ID(0));
    } else if (L->passes == 0) {
        uint32_t roots = (uint32_t)L->tree.base->patch_count;
        for (uint32_t a = 0; a < roots && st == RAD_OK; a++)
            for (uint32_t b = a + 1; b < roots && st == RAD_OK; b++) st = job_push(&list, a, b);
    } else {
        const double t0 = rad_clock_seconds();
        if (leaf_radiosity) set_radiosity(L, leaf_radiosity);
        st = reweigh_links(L, &list, &refined);
        L->tally.seconds_reweigh += rad_clock_seconds() - t0;
    }
    if (st == RAD_OK) st = run_rounds(L, &list, counters, &refined);
    job_free(&list);
    L->tally.refined_pairs += refined;
    L->passes++;
    if (out_refined) *out_refined = refined;
    return st;
}

/* ---- export ---- */

/* By source; a total order (a receiver links a source once, but were it
 * twice, the scatter's order on the threads would not decide theirs). */
static inline int link_before(const rad_link *a, const rad_link *b)
{
    if (a->source != b->source) return a->source < b->source;
    if (a->factor != b->factor) return a->factor < b->factor;
    return a->error < b->error;
}

static int by_source(const void *x, const void *y)
{
    const rad_link *a = x, *b = y;
    return link_before(a, b) ? -1 : link_before(b, a);
}

/* A receiver's links by source: a quicksort with the order inline (qsort's
 * calls through a pointer were most of the export: 820 M links at 10^6
 * triangles), insertion sort below 24, qsort where the partitions go
 * badly (depth); in a parallel region, parts of SORT_TASK_MIN links or
 * more as tasks. The order is total, so any sort gives the same bytes. */
#define SORT_TASK_MIN ((size_t)1 << 15) /* links: a part this large is sorted as a task of its own */

static void sort_links(rad_link *x, size_t n, int depth)
{
    while (n > 24) {
        if (depth-- == 0) {
            qsort(x, n, sizeof *x, by_source);
            return;
        }
        rad_link *lo = x, *mid = x + n / 2, *hi = x + n - 1, t;
        if (link_before(mid, lo)) t = *mid, *mid = *lo, *lo = t;
        if (link_before(hi, mid)) {
            t = *hi, *hi = *mid, *mid = t;
            if (link_before(mid, lo)) t = *mid, *mid = *lo, *lo = t;
        }
        const rad_link pivot = *mid;
        size_t i = 0, j = n - 1;
        for (;;) { /* Hoare: x[0, j] <= pivot <= x[j + 1, n) */
            while (link_before(&x[i], &pivot)) i++;
            while (link_before(&pivot, &x[j])) j--;
            if (i >= j) break;
            t = x[i], x[i] = x[j], x[j] = t;
            i++, j--;
        }
        const size_t left = j + 1;
        rad_link *small = x;
        size_t small_n = left;
        if (left < n - left) { /* the smaller side apart, the larger in the loop */
            x += left, n -= left;
        } else {
            small = x + left, small_n = n - left;
            n = left;
        }
        if (small_n >= SORT_TASK_MIN) { /* a large cluster's list: its parts on idle threads */
#pragma omp task default(none) firstprivate(small, small_n, depth) untied
            sort_links(small, small_n, depth);
        } else {
            sort_links(small, small_n, depth);
        }
    }
    for (size_t i = 1; i < n; i++) {
        const rad_link v = x[i];
        size_t j = i;
        for (; j > 0 && link_before(&v, &x[j - 1]); j--) x[j] = x[j - 1];
        x[j] = v;
    }
}

/* The export counts and places the links in groups of EXPORT_GROUP pairs,
 * the lines of the next group's counters (and its ends' areas) asked for
 * while this one's are used: a locked add waits for the stores before it
 * and takes its line alone, so one pair at a time the counts and places
 * went at one cache miss each (most of the export at 10^6 triangles). */
#define EXPORT_GROUP 32

/* The end of the group of pairs from `from`. */
static size_t export_group_end(const ff_links *L, size_t from)
{
    return from + EXPORT_GROUP < L->link_count ? from + EXPORT_GROUP : L->link_count;
}

static void export_prefetch(const ff_links *L, uint64_t *counts, uint32_t n, size_t from, int areas)
{
    const size_t to = export_group_end(L, from);
    for (size_t k = from; k < to; k++) {
        const uint32_t ids[2] = {L->links[k].a, L->links[k].b};
        for (int i = 0; i < 2; i++) {
            const uint32_t id = ids[i];
            __builtin_prefetch(&counts[ff_is_cluster(id) ? n + ff_cluster_of(id) : id], 1);
            if (areas)
                __builtin_prefetch(ff_is_cluster(id) ? (const void *)&L->clusters.clusters[ff_cluster_of(id)].link.area
                                                     : (const void *)&L->tree.elements[id].area);
        }
    }
}

rad_status ff_links_export(const ff_links *L, rad_links *out, rad_mesh *leaves)
{
    const rad_hierarchy *h = &L->tree;
    memset(out, 0, sizeof *out);
    uint32_t *order = rad_hierarchy_leaf_elements(h); /* the leaves mesh's order, and each node's leaf */
    rad_status st = order ? rad_hierarchy_leaves_of(h, order, leaves) : RAD_ERR_NOMEM;
    if (st != RAD_OK) {
        free(order);
        return st;
    }
    size_t n = h->element_count, C = L->clusters.count, ids = n + C;
    out->nodes = rad_mem_alloc(n * sizeof *out->nodes);
    out->first_link = calloc(ids + 1, sizeof *out->first_link);
    rad_mem_advise_huge(out->first_link, (ids + 1) * sizeof *out->first_link); /* calloc's fresh pages, untouched */
    out->links = rad_mem_alloc(2 * L->link_count * sizeof *out->links); /* gigabytes, filled once */
    if (C) {
        out->clusters = malloc(C * sizeof *out->clusters);
        out->cluster_roots = malloc(L->clusters.root_count * sizeof *out->cluster_roots);
    }
    if (!out->nodes || !out->first_link || !out->links || (C && (!out->clusters || !out->cluster_roots))) {
        free(order);
        rad_links_free(out);
        rad_mesh_free(leaves);
        rad_error("hierarchy: out of memory for %zu nodes and %zu links", n, 2 * L->link_count);
        return RAD_ERR_NOMEM;
    }
    out->node_count = (uint32_t)n;
    out->root_count = (uint32_t)h->base->patch_count;
    out->leaf_count = (uint32_t)leaves->patch_count;
    out->link_tol = L->config.link_tol;
#pragma omp parallel for schedule(static)
    for (size_t e = 0; e < n; e++) {
        const rad_element *el = &h->elements[e];
        rad_link_node *d = &out->nodes[e];
        d->parent = el->parent;
        d->first_child = el->first_child;
        d->leaf = RAD_NO_ELEMENT;
        d->root = el->root;
        d->level = el->level;
        d->vertex_count = el->vertex_count;
        memcpy(d->v, el->v, sizeof d->v);
        d->area = el->area;
    }
#pragma omp parallel for schedule(static)
    for (uint32_t k = 0; k < out->leaf_count; k++) out->nodes[order[k]].leaf = k;
    free(order);
    out->cluster_count = (uint32_t)C;
    for (size_t c = 0; c < C; c++) out->clusters[c] = L->clusters.clusters[c].link;
    if (C) memcpy(out->cluster_roots, L->clusters.roots, L->clusters.root_count * sizeof *out->cluster_roots);
    /* pair ids -> the file's: clusters after the nodes */
#define EXPORT_ID(id) (ff_is_cluster(id) ? (uint32_t)n + ff_cluster_of(id) : (id))
    /* Counted and scattered on the threads: a receiver's links land in
     * any order, which the sort by source below makes one (a receiver
     * links a source once). */
    const size_t groups = (L->link_count + EXPORT_GROUP - 1) / EXPORT_GROUP;
#pragma omp parallel for schedule(static)
    for (size_t g = 0; g < groups; g++) {
        const size_t k0 = g * EXPORT_GROUP, k1 = export_group_end(L, k0);
        export_prefetch(L, out->first_link + 1, (uint32_t)n, k1, 0);
        for (size_t k = k0; k < k1; k++) {
            const uint32_t a = EXPORT_ID(L->links[k].a) + 1, b = EXPORT_ID(L->links[k].b) + 1;
#pragma omp atomic
            out->first_link[a]++;
#pragma omp atomic
            out->first_link[b]++;
        }
    }
    for (size_t e = 0; e < ids; e++) out->first_link[e + 1] += out->first_link[e];
    out->link_count = out->first_link[ids];
    uint64_t *fill = rad_mem_alloc((ids ? ids : 1) * sizeof *fill);
    if (!fill) {
        rad_links_free(out);
        rad_mesh_free(leaves);
        return RAD_ERR_NOMEM;
    }
    memcpy(fill, out->first_link, ids * sizeof *fill);
#pragma omp parallel for schedule(static)
    for (size_t g = 0; g < groups; g++) {
        const size_t k0 = g * EXPORT_GROUP, k1 = export_group_end(L, k0);
        uint64_t at[EXPORT_GROUP][2];
        export_prefetch(L, fill, (uint32_t)n, k1, 1);
        for (size_t k = k0; k < k1; k++) { /* the places, each line asked for before its store */
            const ff_link_pair *p = &L->links[k];
            uint64_t *to = at[k - k0];
#pragma omp atomic capture
            to[0] = fill[EXPORT_ID(p->a)]++;
#pragma omp atomic capture
            to[1] = fill[EXPORT_ID(p->b)]++;
            __builtin_prefetch(&out->links[to[0]], 1);
            __builtin_prefetch(&out->links[to[1]], 1);
        }
        for (size_t k = k0; k < k1; k++) {
            const ff_link_pair *p = &L->links[k];
            const uint64_t *to = at[k - k0];
            out->links[to[0]] = (rad_link){.source = EXPORT_ID(p->b), .error = p->error_ab,
                                           .factor = p->coupling * node_area(L, p->b)};
            out->links[to[1]] = (rad_link){.source = EXPORT_ID(p->a), .error = p->error_ba,
                                           .factor = p->coupling * node_area(L, p->a)};
        }
    }
#undef EXPORT_ID
    free(fill);
    /* each receiver's links by source (a total order, so the same bytes
     * for any thread count): the clusters first, whose lists run to
     * millions of links at 10^6 faces, their large parts as tasks that
     * the threads done with the elements take up; last in the loop, one
     * thread sorted each alone while the others waited */
#pragma omp parallel for schedule(dynamic, 64)
    for (size_t i = 0; i < ids; i++) {
        const size_t e = i < C ? n + i : i - C;
        sort_links(out->links + out->first_link[e], out->first_link[e + 1] - out->first_link[e], 64);
    }
    return RAD_OK;
}

/* ---- the error bound ---- */

/* What a link's bound reads of its source: B's largest value over its
 * leaves, and how far B there strays from its mean (0 at a leaf). */
typedef struct bound_source {
    double hi[3], spread[3];
} bound_source;

/* Receiver r's links' beta (rad_links_pairing's walk of a block: `at`
 * its cursors): for each link the receiver term (0 at a leaf receiver),
 * and the source's spread times the link's factor and error, scaled by
 * the back link's relative error (1 without one). A source without
 * spread (a leaf, or B even over its leaves) adds 0 whatever the back
 * link: not looked up then, for any receiver, as the walk allows. */
static void receiver_beta(const rad_links *x, uint32_t *at, uint32_t r, const bound_source *src, const double rho[3],
                          int leaf, double out[3])
{
    out[0] = out[1] = out[2] = 0;
    for (uint64_t k = x->first_link[r]; k < x->first_link[r + 1]; k++) {
        const rad_link *l = &x->links[k];
        const bound_source *s = &src[l->source];
        double rel = 1.0;
        if (s->spread[0] > 0 || s->spread[1] > 0 || s->spread[2] > 0) {
            const uint64_t j = rad_links_pair_next(x, at, r, k);
            if (j != UINT64_MAX && x->links[j].factor > 0) rel = fmin(1.0, x->links[j].error / x->links[j].factor);
        }
        const double receiver_error = leaf ? 0.0 : l->error;
        for (int c = 0; c < 3; c++)
            out[c] += rho[c] * (receiver_error * s->hi[c] + rel * (l->factor + l->error) * s->spread[c]);
    }
}

double ff_links_error_bound(const ff_links *L, const rad_links *x, const double *leaf_radiosity)
{
    size_t n = x->node_count, ids = (size_t)rad_links_id_count(x);
    double *mean = calloc(3 * ids, sizeof *mean), *lo = malloc(3 * ids * sizeof *lo), *hi = malloc(3 * ids * sizeof *hi);
    double *beta = calloc(3 * ids, sizeof *beta);
    double *own = malloc(3 * (n ? n : 1) * sizeof *own);
    bound_source *src = malloc((ids ? ids : 1) * sizeof *src);
    uint32_t *leaf_cluster = x->cluster_count ? malloc(x->root_count * sizeof *leaf_cluster) : NULL;
    double bound = INFINITY;
    if (!mean || !lo || !hi || !beta || !own || !src || (x->cluster_count && !leaf_cluster)) goto done;
    /* B's mean, least and largest over each node's leaves (children after parents). */
    for (size_t e = n; e-- > 0;) {
        const rad_link_node *d = &x->nodes[e];
        for (int c = 0; c < 3; c++) {
            if (d->leaf != RAD_NO_ELEMENT) {
                mean[3 * e + c] = lo[3 * e + c] = hi[3 * e + c] = leaf_radiosity[3 * (size_t)d->leaf + c];
                continue;
            }
            double s = 0, l = INFINITY, h = -INFINITY;
            for (uint32_t i = 0; i < 4; i++) {
                size_t k = d->first_child + i;
                s += x->nodes[k].area * mean[3 * k + c];
                l = fmin(l, lo[3 * k + c]);
                h = fmax(h, hi[3 * k + c]);
            }
            mean[3 * e + c] = s / d->area, lo[3 * e + c] = l, hi[3 * e + c] = h;
        }
    }
    /* Clusters: B over their roots (each cluster on its own: on the
     * threads), then their links' beta, each cluster's parent's added
     * (parents first), and each root's leaf cluster, whose beta it takes
     * before its own links. */
#pragma omp parallel for schedule(dynamic, 64)
    for (size_t c = 0; c < x->cluster_count; c++) {
        const rad_link_cluster *k = &x->clusters[c];
        double *m = &mean[3 * (n + c)], *l = &lo[3 * (n + c)], *h = &hi[3 * (n + c)];
        for (int ch = 0; ch < 3; ch++) m[ch] = 0, l[ch] = INFINITY, h[ch] = -INFINITY;
        for (uint32_t i = k->root_begin; i < k->root_end; i++) {
            uint32_t r = x->cluster_roots[i];
            if (!k->child_count) leaf_cluster[r] = (uint32_t)c;
            for (int ch = 0; ch < 3; ch++) {
                m[ch] += x->nodes[r].area * mean[3 * r + ch];
                l[ch] = fmin(l[ch], lo[3 * r + ch]);
                h[ch] = fmax(h[ch], hi[3 * r + ch]);
            }
        }
        for (int ch = 0; ch < 3; ch++) m[ch] /= k->area;
    }
    /* what the links read of a source, side by side: one cache line */
#pragma omp parallel for schedule(static)
    for (size_t s = 0; s < ids; s++)
        for (int c = 0; c < 3; c++) {
            src[s].hi[c] = hi[3 * s + c];
            src[s].spread[c] = fmax(hi[3 * s + c] - mean[3 * s + c], mean[3 * s + c] - lo[3 * s + c]);
        }
    /* Each node's and cluster's own links, receiver by receiver in link
     * order (the blocks of rad_links_pairing on the threads); then each
     * cluster's parent's beta added (parents first), and to each node
     * what its root's clusters and its ancestors add. A leaf receiver's
     * F_rs is the sum of its leaves' F over s (the factor adds up over the
     * source): only the spread of B over s is left. */
    rad_links_pairing w;
    if (rad_links_pairing_make(x, 0, &w) != RAD_OK) goto done;
#pragma omp parallel for schedule(dynamic, 1)
    for (uint32_t b = 0; b < w.blocks; b++) {
        uint32_t *at = rad_links_pairing_cursors(&w, b);
        for (uint32_t r = w.begin[b]; r < w.begin[b + 1]; r++) {
            if (r < n)
                receiver_beta(x, at, r, src, L->tree.base->patches[x->nodes[r].root].rho,
                              x->nodes[r].leaf != RAD_NO_ELEMENT, &own[3 * (size_t)r]);
            else
                receiver_beta(x, at, r, src, &L->cluster_rho[3 * ((size_t)r - n)], 0, &beta[3 * (size_t)r]);
        }
    }
    rad_links_pairing_free(&w);
    for (size_t c = 0; c < x->cluster_count; c++)
        if (x->clusters[c].parent != RAD_NO_ELEMENT)
            for (int ch = 0; ch < 3; ch++) beta[3 * (n + c) + ch] += beta[3 * (n + x->clusters[c].parent) + ch];
    double q = 0, bmean = 0, area = 0, all_mean = 0, all_area = 0, worst = 0;
    for (size_t r = 0; r < n; r++) {
        const double *rho = L->tree.base->patches[x->nodes[r].root].rho;
        if (leaf_cluster && r < x->root_count)
            for (int c = 0; c < 3; c++) beta[3 * r + c] += beta[3 * (n + leaf_cluster[r]) + c];
        for (int c = 0; c < 3; c++) beta[3 * r + c] += own[3 * r + c];
        const rad_link_node *d = &x->nodes[r];
        if (d->parent != RAD_NO_ELEMENT)
            for (int c = 0; c < 3; c++) beta[3 * r + c] += beta[3 * (size_t)d->parent + c];
        if (d->leaf != RAD_NO_ELEMENT) {
            const double *B = &leaf_radiosity[3 * (size_t)d->leaf];
            const double *E = L->tree.base->patches[d->root].emission;
            for (int c = 0; c < 3; c++) {
                q = fmax(q, rho[c]);
                worst = fmax(worst, beta[3 * r + c]);
            }
            double b = d->area * fmax(B[0], fmax(B[1], B[2]));
            all_mean += b;
            all_area += d->area;
            if (!(E[0] > 0 || E[1] > 0 || E[2] > 0)) {
                bmean += b;
                area += d->area;
            }
        }
    }
    if (area == 0) bmean = all_mean, area = all_area; /* everything emits (the furnace) */
    if (worst == 0) bound = 0; /* nothing lit: B = 0 everywhere, and exactly so */
    else if (q < 1 && bmean > 0) bound = worst / (1 - q) / (bmean / area);
done:
    free(mean);
    free(lo);
    free(hi);
    free(beta);
    free(own);
    free(src);
    free(leaf_cluster);
    return bound;
}
