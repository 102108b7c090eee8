/* shaped.c - links solved with their shape (shaped.h).
 *
 * The plan: every node's leaves as one range of a depth-first leaf list
 * (children come after their parent, so one forward pass over the nodes
 * places them); each link's pair (the link stored at its source); which
 * receiver ends are shaped and their point factors, stored per link from
 * `at`; per node the list of its shaped links. A sweep, every channel at
 * once: the nodes' B (leaves', then area-weighted means up the trees);
 * per receiver, in parallel, S of every link (a shaped source summed over
 * its leaves with the weights stored at the pair's other link), the
 * unshaped links gathered into the node's H, the shaped links' S kept;
 * H pushed down the trees; per leaf, in parallel, H plus its and its
 * ancestors' shaped links, F u_x S; B = E + rho H. Each sum is made by
 * one thread in a fixed order, so the bytes do not depend on threads.
 *
 * Clusters (rad_links.h) take part flat, as in rad_lsolve: B and H run
 * over the ids (nodes, then clusters), a cluster's B is the area-weighted
 * mean of its roots', a link at or from a cluster is never shaped, a
 * cluster gathers its links into its H, which is pushed down the cluster
 * tree and into each root's H (a root's "parent" is its leaf cluster).
 * A Gauss-Seidel sweep gathers the clusters first (from the B it starts
 * from) and pulls them last.
 */
#include "shaped.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>
#ifdef _OPENMP
#include <omp.h>
#endif

#include "rad_clock.h"
#include "rad_ff_kernel.h"
#include "rad_log.h"

#define NO_WEIGHTS UINT64_MAX
#define SHAPED_PROGRESS_SECONDS 2.0
/* A Gauss-Seidel tree's gather and update go parallel from this many links
 * and leaves up (waking the threads costs ~40 us, docs/solve.md "Threads"). */
#define SHAPED_PARALLEL_MIN_LINKS 16384u
#define SHAPED_PARALLEL_MIN_LEAVES 4096u

typedef struct shaped_plan {
    const rad_links *L;
    const rad_mesh *leaves;
    uint32_t *leaf_nodes;    /* leaf_count: the leaf nodes, each node's leaves consecutive */
    uint32_t *first, *count; /* node_count: node i's leaves are leaf_nodes[first[i] .. first[i] + count[i]) */
    double *leaf_area;       /* node_count: its leaves' areas summed */
    uint64_t *reverse;       /* link_count: the pair's other link */
    uint64_t *at;            /* link_count: the receiver end's point factors f[at .. at + count[r]), or NO_WEIGHTS */
    double *inv_mean;        /* link_count: 1 / the area-weighted mean of those (shaped links) */
    float *f;
    uint64_t weight_count;
    uint64_t *shaped_first;  /* ids + 1: receiver r's shaped links are shaped[shaped_first[r] .. [r + 1]); none
                                at clusters */
    uint64_t *shaped;
    double *row_sum;         /* node_count (leaves): the leaf's row sum with the shape */
    double *rho, *E;         /* node_count * 3: the node's material (its root's) */
    double *area_q;          /* leaf_count: leaf areas in leaf-list order (the sweeps stream them) */
    uint32_t *tree_first;    /* root_count + 1: tree t's nodes are tree_nodes[tree_first[t] .. [t + 1]), */
    uint32_t *tree_nodes;    /* in index order (parents first) */
    uint64_t *tree_links;    /* root_count: the links the tree's nodes receive */
    uint32_t *root_cluster;  /* root_count: the leaf cluster holding the root; NULL without clusters */
    uint64_t cluster_links;  /* the links the clusters receive */
    int threads;
} shaped_plan;

static void plan_free(shaped_plan *p)
{
    free(p->leaf_nodes);
    free(p->first);
    free(p->count);
    free(p->leaf_area);
    free(p->reverse);
    free(p->at);
    free(p->inv_mean);
    free(p->f);
    free(p->shaped_first);
    free(p->shaped);
    free(p->row_sum);
    free(p->rho);
    free(p->E);
    free(p->area_q);
    free(p->tree_first);
    free(p->tree_nodes);
    free(p->tree_links);
    free(p->root_cluster);
}

static inline int is_leaf(const rad_links *L, uint32_t i) { return L->nodes[i].first_child == RAD_NO_ELEMENT; }
static inline double max3(const double *v) { return fmax(v[0], fmax(v[1], v[2])); }

/* Split node i's B (3 values): the area-weighted mean of its children's. */
static void pull_node(const rad_links *L, uint32_t i, double *B)
{
    const uint32_t f = L->nodes[i].first_child;
    double sum[3] = {0, 0, 0}, area = 0;
    for (uint32_t k = 0; k < 4; k++) {
        area += L->nodes[f + k].area;
        for (int c = 0; c < 3; c++) sum[c] += L->nodes[f + k].area * B[3 * (size_t)(f + k) + c];
    }
    for (int c = 0; c < 3; c++) B[3 * (size_t)i + c] = sum[c] / area;
}

/* Every cluster's B (3 values; id node_count + c), children before
 * parents: the area-weighted mean of its child clusters', or of its roots'
 * for a leaf cluster. */
static void pull_clusters(const rad_links *L, double *B)
{
    const uint32_t n = L->node_count;
    for (uint32_t c = L->cluster_count; c-- > 0;) {
        const rad_link_cluster *k = &L->clusters[c];
        double sum[3] = {0, 0, 0}, area = 0;
        if (k->child_count == 0) {
            for (uint32_t q = k->root_begin; q < k->root_end; q++) {
                const uint32_t r = L->cluster_roots[q];
                area += L->nodes[r].area;
                for (int ch = 0; ch < 3; ch++) sum[ch] += L->nodes[r].area * B[3 * (size_t)r + ch];
            }
        } else {
            for (uint32_t j = k->first_child; j < k->first_child + k->child_count; j++) {
                area += L->clusters[j].area;
                for (int ch = 0; ch < 3; ch++) sum[ch] += L->clusters[j].area * B[3 * ((size_t)n + j) + ch];
            }
        }
        for (int ch = 0; ch < 3; ch++) B[3 * ((size_t)n + c) + ch] = sum[ch] / area;
    }
}

/* Each root's leaf cluster, and the links the clusters receive. */
static void plan_clusters(shaped_plan *p)
{
    const rad_links *L = p->L;
    for (uint32_t c = 0; c < L->cluster_count; c++) {
        const rad_link_cluster *k = &L->clusters[c];
        if (k->child_count == 0)
            for (uint32_t q = k->root_begin; q < k->root_end; q++) p->root_cluster[L->cluster_roots[q]] = c;
        p->cluster_links += L->first_link[L->node_count + c + 1] - L->first_link[L->node_count + c];
    }
}

/* Node i's polygon as the point factor takes it: corners from the leaves
 * mesh's vertex table, the plane's normal (its leaves'). */
static void node_polygon(const shaped_plan *p, uint32_t i, rad_ff_patch *out)
{
    const rad_link_node *e = &p->L->nodes[i];
    const double *pos = p->leaves->positions;
    memset(out, 0, sizeof *out);
    for (uint32_t k = 0; k < e->vertex_count; k++)
        out->p[k] = (rad_vec3){pos[3 * (size_t)e->v[k]], pos[3 * (size_t)e->v[k] + 1], pos[3 * (size_t)e->v[k] + 2]};
    if (e->vertex_count == 3) out->p[3] = out->p[2];
    out->normal = p->leaves->patches[p->L->nodes[p->leaf_nodes[p->first[i]]].leaf].normal;
    out->vertex_count = e->vertex_count;
}

/* The leaves' ranges, areas and materials; node B (3 per id) from the
 * leaves' B (3 per leaf patch) pulled up the trees and the clusters, and
 * each node's spread of B (largest max - min over the channels). */
static void plan_trees(shaped_plan *p, const double *B, double *node_B, double *spread, double *lo)
{
    const rad_links *L = p->L;
    const uint32_t n = L->node_count;
    double *hi = lo + 3 * (size_t)n;
    for (uint32_t i = n; i-- > 0;) {
        const rad_link_node *e = &L->nodes[i];
        double *b = &node_B[3 * (size_t)i], *bl = &lo[3 * (size_t)i], *bh = &hi[3 * (size_t)i];
        if (e->first_child == RAD_NO_ELEMENT) {
            const rad_patch *patch = &p->leaves->patches[e->leaf];
            p->count[i] = 1;
            p->leaf_area[i] = e->area;
            for (int c = 0; c < 3; c++) {
                b[c] = bl[c] = bh[c] = B[3 * (size_t)e->leaf + c];
                p->rho[3 * (size_t)i + c] = patch->rho[c];
                p->E[3 * (size_t)i + c] = patch->emission[c];
            }
            spread[i] = 0;
            continue;
        }
        const uint32_t f = e->first_child;
        p->count[i] = 0;
        p->leaf_area[i] = 0;
        for (int c = 0; c < 3; c++) bl[c] = INFINITY, bh[c] = -INFINITY;
        for (uint32_t k = 0; k < 4; k++) {
            p->count[i] += p->count[f + k];
            p->leaf_area[i] += p->leaf_area[f + k];
            for (int c = 0; c < 3; c++) {
                bl[c] = fmin(bl[c], lo[3 * (size_t)(f + k) + c]);
                bh[c] = fmax(bh[c], hi[3 * (size_t)(f + k) + c]);
            }
        }
        pull_node(L, i, node_B);
        for (int c = 0; c < 3; c++) {
            p->rho[3 * (size_t)i + c] = p->rho[3 * (size_t)f + c];
            p->E[3 * (size_t)i + c] = 0;
        }
        spread[i] = fmax(bh[0] - bl[0], fmax(bh[1] - bl[1], bh[2] - bl[2]));
    }
    uint32_t at = 0;
    for (uint32_t i = 0; i < n; i++) {
        const rad_link_node *e = &L->nodes[i];
        if (e->parent == RAD_NO_ELEMENT) {
            p->first[i] = at;
            at += p->count[i];
        }
        if (e->first_child == RAD_NO_ELEMENT) {
            p->leaf_nodes[p->first[i]] = i;
            continue;
        }
        uint32_t f = p->first[i];
        for (uint32_t k = 0; k < 4; k++) {
            p->first[e->first_child + k] = f;
            f += p->count[e->first_child + k];
        }
    }
    pull_clusters(L, node_B);
}

/* Every tree's nodes in index order, and the links they receive. */
static void plan_tree_lists(shaped_plan *p)
{
    const rad_links *L = p->L;
    const uint32_t n = L->node_count, roots = L->root_count;
    for (uint32_t i = 0; i < n; i++) p->tree_first[L->nodes[i].root + 1]++;
    for (uint32_t t = 0; t < roots; t++) p->tree_first[t + 1] += p->tree_first[t];
    for (uint32_t i = 0; i < n; i++) {
        const uint32_t t = L->nodes[i].root;
        p->tree_nodes[p->tree_first[t]++] = i; /* counts up; set back below */
        p->tree_links[t] += L->first_link[i + 1] - L->first_link[i];
    }
    for (uint32_t t = roots; t > 0; t--) p->tree_first[t] = p->tree_first[t - 1];
    p->tree_first[0] = 0;
}

/* The pair of every link: the link at its source back to its receiver
 * (sources ascend per receiver; receivers and sources are ids).
 * RAD_ERR_INVALID for one without. */
static rad_status plan_pairs(shaped_plan *p)
{
    const rad_links *L = p->L;
    const uint32_t ids = (uint32_t)rad_links_id_count(L);
    for (uint32_t r = 0; r < ids; r++)
        for (uint64_t k = L->first_link[r]; k < L->first_link[r + 1]; k++) {
            const uint32_t s = L->links[k].source;
            uint64_t lo = L->first_link[s], hi = L->first_link[s + 1];
            while (lo < hi) {
                const uint64_t mid = lo + (hi - lo) / 2;
                if (L->links[mid].source < r) lo = mid + 1;
                else hi = mid;
            }
            if (lo == L->first_link[s + 1] || L->links[lo].source != r) {
                rad_error("links: link %llu (id %u <- %u) has no link back: links come in pairs",
                          (unsigned long long)k, r, s);
                return RAD_ERR_INVALID;
            }
            p->reverse[k] = lo;
        }
    return RAD_OK;
}

/* Which receiver ends to shape (shaped.h, "Which ends"), their offsets.
 * A link at or from a cluster stays flat (so does its pair). */
static void plan_ends(shaped_plan *p, const double *node_B, const double *spread, double floor)
{
    const rad_links *L = p->L;
    const uint64_t ids = rad_links_id_count(L);
    p->weight_count = 0;
    for (uint32_t r = 0; r < ids; r++)
        for (uint64_t k = L->first_link[r]; k < L->first_link[r + 1]; k++) {
            const rad_link *l = &L->links[k], *back = &L->links[p->reverse[k]];
            if (r >= L->node_count || l->source >= L->node_count) {
                p->at[k] = NO_WEIGHTS;
                continue;
            }
            const double rho_r = max3(&p->rho[3 * (size_t)r]), rho_s = max3(&p->rho[3 * (size_t)l->source]);
            const int shape = !is_leaf(L, r) && (rho_r * l->error * max3(&node_B[3 * (size_t)l->source]) >= floor ||
                                                 rho_s * back->factor * spread[r] >= floor);
            p->at[k] = shape ? p->weight_count : NO_WEIGHTS;
            if (shape) p->weight_count += p->count[r];
        }
}

/* The shaped ends' point factors (in parallel over receivers); an end
 * whose factors sum to 0 is left flat. */
static void plan_factors(shaped_plan *p)
{
    const rad_links *L = p->L;
    const uint32_t n = L->node_count;
#pragma omp parallel for schedule(dynamic, 16) num_threads(p->threads)
    for (uint32_t r = 0; r < n; r++) {
        for (uint64_t k = L->first_link[r]; k < L->first_link[r + 1]; k++) {
            if (p->at[k] == NO_WEIGHTS) continue;
            rad_ff_patch P;
            node_polygon(p, L->links[k].source, &P);
            float *f = &p->f[p->at[k]];
            double sum = 0;
            for (uint32_t q = 0; q < p->count[r]; q++) {
                const uint32_t x = p->leaf_nodes[p->first[r] + q];
                const rad_patch *leaf = &p->leaves->patches[L->nodes[x].leaf];
                f[q] = (float)rad_ff_point_polygon(leaf->centroid, leaf->normal, &P);
                sum += L->nodes[x].area * (double)f[q];
            }
            p->inv_mean[k] = sum > 0 ? p->leaf_area[r] / sum : 0;
            if (!(sum > 0)) p->at[k] = NO_WEIGHTS;
        }
    }
}

/* Every receiver's shaped links listed; every leaf's row sum with the
 * shape (its root's clusters' links flat). */
static void plan_lists(shaped_plan *p)
{
    const rad_links *L = p->L;
    const uint32_t n = L->node_count;
    const uint64_t ids = rad_links_id_count(L);
    uint64_t m = 0;
    for (uint64_t r = 0; r < ids; r++) {
        p->shaped_first[r] = m;
        for (uint64_t k = L->first_link[r]; k < L->first_link[r + 1]; k++)
            if (p->at[k] != NO_WEIGHTS) p->shaped[m++] = k;
    }
    p->shaped_first[ids] = m;
    for (uint32_t x = 0; x < n; x++) {
        if (!is_leaf(L, x)) continue;
        double s = 0;
        for (uint32_t a = x; a != RAD_NO_ELEMENT; a = L->nodes[a].parent)
            for (uint64_t k = L->first_link[a]; k < L->first_link[a + 1]; k++)
                s += L->links[k].factor *
                     (p->at[k] == NO_WEIGHTS ? 1.0 : p->inv_mean[k] * p->f[p->at[k] + p->first[x] - p->first[a]]);
        if (p->root_cluster)
            for (uint32_t c = p->root_cluster[L->nodes[x].root]; c != RAD_NO_ELEMENT; c = L->clusters[c].parent)
                for (uint64_t k = L->first_link[n + c]; k < L->first_link[n + c + 1]; k++) s += L->links[k].factor;
        p->row_sum[x] = s;
    }
}

static rad_status plan_make(const rad_links *L, const rad_mesh *leaves, const double *B, double gate, int threads,
                            shaped_plan *p, double *node_B)
{
    const uint32_t n = L->node_count;
    const uint64_t links = L->link_count ? L->link_count : 1;
    memset(p, 0, sizeof *p);
    p->L = L;
    p->leaves = leaves;
    p->threads = threads;
    p->leaf_nodes = malloc((L->leaf_count ? L->leaf_count : 1) * sizeof *p->leaf_nodes);
    p->first = malloc((size_t)n * sizeof *p->first);
    p->count = malloc((size_t)n * sizeof *p->count);
    p->leaf_area = malloc((size_t)n * sizeof *p->leaf_area);
    p->reverse = malloc(links * sizeof *p->reverse);
    p->at = malloc(links * sizeof *p->at);
    p->inv_mean = malloc(links * sizeof *p->inv_mean);
    p->shaped_first = malloc(((size_t)rad_links_id_count(L) + 1) * sizeof *p->shaped_first);
    if (L->cluster_count) p->root_cluster = malloc((size_t)L->root_count * sizeof *p->root_cluster);
    p->row_sum = malloc((size_t)n * sizeof *p->row_sum);
    p->rho = malloc(3 * (size_t)n * sizeof *p->rho);
    p->E = malloc(3 * (size_t)n * sizeof *p->E);
    p->area_q = malloc((L->leaf_count ? L->leaf_count : 1) * sizeof *p->area_q);
    p->tree_first = calloc((size_t)L->root_count + 1, sizeof *p->tree_first);
    p->tree_nodes = malloc((size_t)n * sizeof *p->tree_nodes);
    p->tree_links = calloc(L->root_count ? L->root_count : 1, sizeof *p->tree_links);
    double *spread = malloc((size_t)n * sizeof *spread), *lo = malloc(6 * (size_t)n * sizeof *lo);
    rad_status status = RAD_OK;
    if (!p->leaf_nodes || !p->first || !p->count || !p->leaf_area || !p->reverse || !p->at || !p->inv_mean ||
        !p->shaped_first || !p->row_sum || !p->rho || !p->E || !p->area_q || !p->tree_first ||
        !p->tree_nodes || !p->tree_links || !spread || !lo || (L->cluster_count && !p->root_cluster)) {
        status = RAD_ERR_NOMEM;
    } else {
        if (L->cluster_count) plan_clusters(p);
        plan_trees(p, B, node_B, spread, lo);
        for (uint32_t q = 0; q < L->leaf_count; q++) p->area_q[q] = L->nodes[p->leaf_nodes[q]].area;
        plan_tree_lists(p);
        status = plan_pairs(p);
    }
    if (status == RAD_OK) {
        double reflected = 0, area = 0, all = 0, all_area = 0;
        for (uint32_t i = 0; i < n; i++) {
            if (!is_leaf(L, i)) continue;
            const double y = max3(&node_B[3 * (size_t)i]) * L->nodes[i].area;
            all += y;
            all_area += L->nodes[i].area;
            if (max3(&p->E[3 * (size_t)i]) > 0) continue;
            reflected += y;
            area += L->nodes[i].area;
        }
        const double mean = area > 0 ? reflected / area : all_area > 0 ? all / all_area : 0;
        plan_ends(p, node_B, spread, gate * mean);
        p->f = malloc((p->weight_count ? p->weight_count : 1) * sizeof *p->f);
        if (!p->f) status = RAD_ERR_NOMEM;
    }
    if (status == RAD_OK) {
        plan_factors(p);
        uint64_t m = 0;
        for (uint64_t k = 0; k < L->link_count; k++) m += p->at[k] != NO_WEIGHTS;
        p->shaped = malloc((m ? m : 1) * sizeof *p->shaped);
        if (!p->shaped) status = RAD_ERR_NOMEM;
    }
    if (status == RAD_OK) plan_lists(p);
    free(spread);
    free(lo);
    if (status == RAD_ERR_NOMEM)
        rad_error("links: out of memory for the shaped solve over %u nodes and %llu links", n,
                  (unsigned long long)L->link_count);
    if (status != RAD_OK) plan_free(p);
    return status;
}

/* ---- the sweep ---- */

typedef struct shaped_vectors {
    double *B;    /* ids * 3: leaves' B, split nodes' and clusters' means */
    double *Q;    /* leaf_count * 3: the leaves' B in leaf-list order (what shaped sums stream) */
    double *H;    /* ids * 3: unshaped links gathered, pushed down (clusters' into their roots); at leaves, all of H */
    double *S;    /* shaped links * 3: what each shaped link's source sends */
    double *next; /* leaf_count * 3, leaf-list order: E + rho H */
} shaped_vectors;

/* What source s sends along link k (receiver r): shaped towards r where the
 * pair's other link shapes s. */
static inline void source_value(const shaped_plan *p, const double *B, const double *Q, uint64_t k, double out[3])
{
    const rad_links *L = p->L;
    const uint32_t s = L->links[k].source;
    const uint64_t back = p->reverse[k];
    if (p->at[back] == NO_WEIGHTS) {
        for (int c = 0; c < 3; c++) out[c] = B[3 * (size_t)s + c];
        return;
    }
    const float *f = &p->f[p->at[back]];
    const double *area = &p->area_q[p->first[s]], *b = &Q[3 * (size_t)p->first[s]];
    double s0 = 0, s1 = 0, s2 = 0;
    for (uint32_t q = 0; q < p->count[s]; q++) {
        const double w = area[q] * (double)f[q];
        s0 += w * b[3 * q];
        s1 += w * b[3 * q + 1];
        s2 += w * b[3 * q + 2];
    }
    const double sum[3] = {s0, s1, s2};
    const double scale = p->inv_mean[back] / p->leaf_area[s];
    for (int c = 0; c < 3; c++) out[c] = sum[c] * scale;
}

/* Receiver i's links (a node's or a cluster's): the unshaped ones gathered
 * into H[i], the shaped ones' S kept, from v->B and v->Q. */
static inline void gather_node(const shaped_plan *p, shaped_vectors *v, uint32_t i)
{
    const rad_links *L = p->L;
    double h[3] = {0, 0, 0};
    uint64_t j = p->shaped_first[i];
    for (uint64_t k = L->first_link[i]; k < L->first_link[i + 1]; k++) {
        double s[3];
        source_value(p, v->B, v->Q, k, s);
        if (p->at[k] != NO_WEIGHTS) {
            memcpy(&v->S[3 * j++], s, sizeof s);
            continue;
        }
        for (int c = 0; c < 3; c++) h[c] += L->links[k].factor * s[c];
    }
    memcpy(&v->H[3 * (size_t)i], h, sizeof h);
}

/* Leaf q (node x): H[x] (pushed down) plus its and its ancestors' shaped
 * links, then out = E + rho H; d: |out - Q[q]| per channel. H[x] keeps
 * the whole gather (the balance's). */
static inline void update_leaf(const shaped_plan *p, shaped_vectors *v, uint32_t q, double *out, double d[3])
{
    const rad_links *L = p->L;
    const uint32_t x = p->leaf_nodes[q];
    double *h = &v->H[3 * (size_t)x];
    for (uint32_t a = x; a != RAD_NO_ELEMENT; a = L->nodes[a].parent)
        for (uint64_t j = p->shaped_first[a]; j < p->shaped_first[a + 1]; j++) {
            const uint64_t k = p->shaped[j];
            const double w = L->links[k].factor * p->inv_mean[k] * (double)p->f[p->at[k] + q - p->first[a]];
            for (int c = 0; c < 3; c++) h[c] += w * v->S[3 * j + c];
        }
    for (int c = 0; c < 3; c++) {
        const size_t i = 3 * (size_t)x + c;
        const double b = p->E[i] + p->rho[i] * h[c];
        d[c] = fabs(b - v->Q[3 * (size_t)q + c]);
        if (isnan(d[c])) d[c] = INFINITY;
        out[c] = b;
    }
}

/* The clusters' H pushed down the cluster tree (parents first): each
 * cluster's H becomes the sum over it and the clusters above it. */
static void push_clusters(const shaped_plan *p, double *H)
{
    const rad_links *L = p->L;
    const size_t n = L->node_count;
    for (uint32_t c = 1; c < L->cluster_count; c++) {
        const size_t up = n + L->clusters[c].parent;
        for (int ch = 0; ch < 3; ch++) H[3 * (n + c) + ch] += H[3 * up + ch];
    }
}

/* Root i's H plus its leaf cluster's (pushed down the cluster tree). */
static inline void push_into_root(const shaped_plan *p, double *H, uint32_t i)
{
    if (!p->root_cluster) return;
    const size_t c = (size_t)p->L->node_count + p->root_cluster[i];
    for (int ch = 0; ch < 3; ch++) H[3 * (size_t)i + ch] += H[3 * c + ch];
}

/* One Jacobi sweep from v->B: v->H and v->next at the leaves; the largest
 * |next - B| per channel in r[3] (the residual of v->B; infinite where one
 * is not a number). */
static void sweep(const shaped_plan *p, shaped_vectors *v, double r[3])
{
    const rad_links *L = p->L;
    const uint32_t n = L->node_count, leaf_count = L->leaf_count, ids = (uint32_t)rad_links_id_count(L);
    double *H = v->H;
#pragma omp parallel for schedule(dynamic, 64) num_threads(p->threads)
    for (uint32_t i = 0; i < ids; i++) gather_node(p, v, i);
    push_clusters(p, H);
    for (uint32_t i = 0; i < n; i++) { /* parents first: pushed down */
        const uint32_t up = L->nodes[i].parent;
        if (up == RAD_NO_ELEMENT)
            push_into_root(p, H, i);
        else
            for (int c = 0; c < 3; c++) H[3 * (size_t)i + c] += H[3 * (size_t)up + c];
    }
    double r0 = 0, r1 = 0, r2 = 0;
#pragma omp parallel for schedule(dynamic, 256) num_threads(p->threads) reduction(max : r0, r1, r2)
    for (uint32_t q = 0; q < leaf_count; q++) {
        double d[3];
        update_leaf(p, v, q, &v->next[3 * (size_t)q], d);
        r0 = fmax(r0, d[0]);
        r1 = fmax(r1, d[1]);
        r2 = fmax(r2, d[2]);
    }
    r[0] = r0, r[1] = r1, r[2] = r2;
}

/* Tree t's split nodes' B pulled up from its leaves' (v->Q). */
static void pull_tree(const shaped_plan *p, shaped_vectors *v, uint32_t t)
{
    const rad_links *L = p->L;
    for (uint32_t k = p->tree_first[t + 1]; k-- > p->tree_first[t];) {
        const uint32_t i = p->tree_nodes[k];
        if (is_leaf(L, i))
            memcpy(&v->B[3 * (size_t)i], &v->Q[3 * (size_t)p->first[i]], 3 * sizeof *v->B);
        else
            pull_node(L, i, v->B);
    }
}

/* One Gauss-Seidel sweep: the clusters gathered and pushed down their
 * tree from the B it starts from, then tree by tree in root order: each
 * tree gathers from the newest B (the trees before it already updated; a
 * cluster source at its start value), updates its leaves in place and
 * pulls its nodes; the clusters pulled last. r[3]: the largest change per
 * channel (infinite where one is not a number). */
static void gauss_seidel_sweep(const shaped_plan *p, shaped_vectors *v, double r[3])
{
    const rad_links *L = p->L;
    const uint32_t n = L->node_count, clusters = L->cluster_count;
    double r0 = 0, r1 = 0, r2 = 0;
#pragma omp parallel for schedule(dynamic, 16) num_threads(p->threads) \
    if (p->cluster_links >= SHAPED_PARALLEL_MIN_LINKS)
    for (uint32_t c = 0; c < clusters; c++) gather_node(p, v, n + c);
    push_clusters(p, v->H);
    for (uint32_t t = 0; t < L->root_count; t++) {
        const uint32_t *list = p->tree_nodes + p->tree_first[t];
        const uint32_t count = p->tree_first[t + 1] - p->tree_first[t], root = list[0];
        const int wide = p->tree_links[t] >= SHAPED_PARALLEL_MIN_LINKS;
#pragma omp parallel for schedule(dynamic, 16) num_threads(p->threads) if (wide)
        for (uint32_t k = 0; k < count; k++) gather_node(p, v, list[k]);
        push_into_root(p, v->H, root);
        for (uint32_t k = 1; k < count; k++) { /* parents first: pushed down */
            const uint32_t i = list[k], up = L->nodes[i].parent;
            for (int c = 0; c < 3; c++) v->H[3 * (size_t)i + c] += v->H[3 * (size_t)up + c];
        }
        const uint32_t q0 = p->first[root], q1 = q0 + p->count[root];
#pragma omp parallel for schedule(dynamic, 256) num_threads(p->threads) reduction(max : r0, r1, r2) \
    if (q1 - q0 >= SHAPED_PARALLEL_MIN_LEAVES)
        for (uint32_t q = q0; q < q1; q++) {
            double d[3];
            update_leaf(p, v, q, &v->Q[3 * (size_t)q], d); /* in place: this tree's S and H are made */
            r0 = fmax(r0, d[0]);
            r1 = fmax(r1, d[1]);
            r2 = fmax(r2, d[2]);
        }
        pull_tree(p, v, t);
    }
    pull_clusters(L, v->B);
    r[0] = r0, r[1] = r1, r[2] = r2;
}

rad_status solve_shaped(const rad_links *links, const rad_mesh *leaves, const solve_shaped_options *options, double *B,
                        solve_shaped_result *out)
{
    const double start = rad_clock_seconds();
    if (links->leaf_count != leaves->patch_count || links->node_count == 0 || !(options->tolerance > 0) ||
        options->max_iterations == 0) {
        rad_error("links: %u leaves against %zu patches, or shaped solve options out of range", links->leaf_count,
                  leaves->patch_count);
        return RAD_ERR_INVALID;
    }
    int threads = options->threads;
#ifdef _OPENMP
    if (threads <= 0) threads = omp_get_max_threads();
#else
    threads = 1;
#endif
    const uint32_t n = links->node_count;
    const size_t ids = rad_links_id_count(links); /* B and H run over the nodes, then the clusters */
    shaped_vectors v = {0};
    const size_t m = links->leaf_count;
    double *block = malloc((6 * ids + 6 * m) * sizeof *block);
    if (!block) {
        rad_error("links: out of memory for the shaped solve's vectors over %zu nodes and clusters", ids);
        return RAD_ERR_NOMEM;
    }
    v.B = block, v.H = block + 3 * ids, v.Q = block + 6 * ids, v.next = v.Q + 3 * m;
    shaped_plan p;
    rad_status status = plan_make(links, leaves, B, options->gate, threads, &p, v.B);
    if (status != RAD_OK) {
        free(block);
        return status;
    }
    for (size_t q = 0; q < m; q++) memcpy(&v.Q[3 * q], &v.B[3 * (size_t)p.leaf_nodes[q]], 3 * sizeof *v.Q);
    const uint64_t shaped = p.shaped_first[ids];
    v.S = malloc(3 * (shaped ? shaped : 1) * sizeof *v.S);
    if (!v.S) {
        rad_error("links: out of memory for the shaped solve's %llu shaped links", (unsigned long long)shaped);
        plan_free(&p);
        free(block);
        return RAD_ERR_NOMEM;
    }
    double e_norm[3] = {0, 0, 0};
    for (uint32_t i = 0; i < n; i++)
        for (int c = 0; c < 3; c++) e_norm[c] = fmax(e_norm[c], p.E[3 * (size_t)i + c]);
    solve_shaped_result res = {.shaped_ends = shaped, .weights = p.weight_count};
    double last_progress = start;
    /* Gauss-Seidel sweeps until their change meets the tolerance, then a
     * Jacobi sweep measures the residual of the iterate to return (as the
     * flat solve returns a measured iterate); short of it, on. */
    for (uint32_t it = 0;; it++) {
        double r[3], worst = 0;
        gauss_seidel_sweep(&p, &v, r);
        for (int c = 0; c < 3; c++) worst = fmax(worst, e_norm[c] > 0 ? r[c] / e_norm[c] : 0);
        const int last = it + 1 >= options->max_iterations;
        if (isfinite(worst) && (worst <= options->tolerance || last)) {
            sweep(&p, &v, r); /* v.H: the gather of v.B, kept for the balance */
            worst = 0;
            for (int c = 0; c < 3; c++) worst = fmax(worst, e_norm[c] > 0 ? r[c] / e_norm[c] : 0);
            if (isfinite(worst) && (worst <= options->tolerance || last)) {
                res.iterations = it + 2;
                res.residual = worst;
                res.converged = worst <= options->tolerance;
                break;
            }
        }
        if (!isfinite(worst)) {
            rad_error("links: shaped solve: residual is not finite at iteration %u", it);
            status = RAD_ERR_INVALID;
            break;
        }
        const double now = rad_clock_seconds();
        if (now - last_progress >= SHAPED_PROGRESS_SECONDS) {
            rad_info("links: shaped solve: iteration %u, change %.3g (target %.3g), %.0f s", it, worst,
                     options->tolerance, now - start);
            last_progress = now;
        }
    }
    if (status == RAD_OK) {
        double most = 0, moved = 0, sums[3] = {0, 0, 0};
        for (uint32_t i = 0; i < n; i++) {
            const rad_link_node *e = &links->nodes[i];
            if (e->first_child != RAD_NO_ELEMENT) continue;
            for (int c = 0; c < 3; c++) {
                const size_t at = 3 * (size_t)i + c;
                const double b = v.B[at], before = B[3 * (size_t)e->leaf + c];
                most = fmax(most, fabs(before));
                moved = fmax(moved, fabs(b - before));
                if (options->channels == 1 && c > 0) continue;
                sums[0] += e->area * p.E[at];
                sums[1] += e->area * (1 - p.rho[at]) * v.H[at];
                sums[2] += e->area * b * (1 - p.row_sum[i]);
            }
        }
        for (uint32_t i = 0; i < n; i++)
            if (links->nodes[i].first_child == RAD_NO_ELEMENT)
                memcpy(&B[3 * (size_t)links->nodes[i].leaf], &v.B[3 * (size_t)i], 3 * sizeof *B);
        res.change = most > 0 ? moved / most : 0;
        res.emitted = sums[0];
        res.absorbed = sums[1];
        res.escaped = sums[2];
        res.imbalance = sums[0] > 0 ? (sums[1] + sums[2] - sums[0]) / sums[0] : 0;
        res.seconds = rad_clock_seconds() - start;
        *out = res;
        if (!res.converged) status = RAD_ERR_NOT_CONVERGED;
    }
    free(v.S);
    free(block);
    plan_free(&p);
    return status;
}
