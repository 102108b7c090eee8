/* shaped_plan.c - the shaped solve's plan (shaped_plan.h): the host's
 * bookkeeping before any sweep. Clusters (rad_links.h) take part flat: B
 * and H run over the ids (nodes, then clusters), a cluster's B is the
 * area-weighted mean of its roots', a link at or from a cluster is never
 * shaped, and a root's up (where its H comes from when pushed) is its
 * leaf cluster.
 */
#include "shaped_plan.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "rad_log.h"
#include "rad_mem.h"

static inline double max3(const double *v) { return fmax(v[0], fmax(v[1], v[2])); }

void shaped_plan_free(shaped_plan *p)
{
    free(p->leaf_nodes);
    free(p->first);
    free(p->count);
    free(p->leaf_area);
    free(p->end);
    free(p->pair_end);
    free(p->end_link);
    free(p->end_receiver);
    free(p->end_at);
    free(p->inv_mean);
    free(p->f);
    free(p->shaped_first);
    free(p->row_sum);
    free(p->rho);
    free(p->E);
    free(p->scale);
    free(p->closed_row);
    free(p->area_q);
    free(p->leaf_centroid);
    free(p->leaf_normal);
    free(p->up);
    free(p->pull_first);
    free(p->pull_child);
    free(p->id_area);
    free(p->tree_first);
    free(p->tree_nodes);
    free(p->tree_work);
    free(p->root_cluster);
    memset(p, 0, sizeof *p);
}

/* The plan's arrays as shaped_math.h reads them; f and the shaped lists
 * are set where they are made. */
static void plan_view(shaped_plan *p)
{
    const rad_links *L = p->L;
    shaped_view *v = &p->view;
    memset(v, 0, sizeof *v);
    v->node_count = L->node_count;
    v->leaf_count = L->leaf_count;
    v->id_count = rad_links_id_count(L);
    v->link_count = L->link_count;
    v->nodes = L->nodes;
    v->positions = p->leaves->positions;
    v->leaf_centroid = p->leaf_centroid;
    v->leaf_normal = p->leaf_normal;
    v->links = L->links;
    v->first_link = L->first_link;
    v->up = p->up;
    v->leaf_nodes = p->leaf_nodes;
    v->first = p->first;
    v->count = p->count;
    v->leaf_area = p->leaf_area;
    v->area_q = p->area_q;
    v->rho = p->rho;
    v->E = p->E;
    v->pull_first = p->pull_first;
    v->pull_child = p->pull_child;
    v->id_area = p->id_area;
    v->end_count = p->end_count;
    v->end = p->end;
    v->pair_end = p->pair_end;
    v->end_link = p->end_link;
    v->end_receiver = p->end_receiver;
    v->end_at = p->end_at;
    v->inv_mean = p->inv_mean;
    v->shaped_first = p->shaped_first;
}

/* Every cluster's B (3 values; id node_count + c), children before
 * parents: the area-weighted mean of its child clusters', or of its roots'
 * for a leaf cluster. */
void shaped_plan_pull_clusters(const shaped_plan *p, double *B)
{
    for (uint32_t c = p->L->cluster_count; c-- > 0;) shaped_pull(&p->view, p->L->node_count + c, B);
}

/* Each root's leaf cluster and the links the clusters receive; every id's
 * up, area and pull list (shaped_view). */
static void plan_ids(shaped_plan *p)
{
    const rad_links *L = p->L;
    const uint32_t n = L->node_count;
    for (uint32_t c = 0; c < L->cluster_count; c++) {
        const rad_link_cluster *k = &L->clusters[c];
        if (k->child_count == 0)
            for (uint32_t q = k->root_begin; q < k->root_end; q++) p->root_cluster[L->cluster_roots[q]] = c;
        p->cluster_links += L->first_link[n + c + 1] - L->first_link[n + c];
    }
    uint64_t m = 0;
    for (uint32_t i = 0; i < n; i++) {
        const rad_link_node *e = &L->nodes[i];
        p->up[i] = e->parent != RAD_NO_ELEMENT ? e->parent : p->root_cluster ? n + p->root_cluster[i] : SHAPED_NONE;
        p->id_area[i] = e->area;
        p->pull_first[i] = m;
        if (e->first_child != RAD_NO_ELEMENT)
            for (uint32_t k = 0; k < 4; k++) p->pull_child[m++] = e->first_child + k;
    }
    for (uint32_t c = 0; c < L->cluster_count; c++) {
        const rad_link_cluster *k = &L->clusters[c];
        p->up[n + c] = k->parent != RAD_NO_ELEMENT ? n + k->parent : SHAPED_NONE;
        p->id_area[n + c] = k->area;
        p->pull_first[n + c] = m;
        if (k->child_count == 0)
            for (uint32_t q = k->root_begin; q < k->root_end; q++) p->pull_child[m++] = L->cluster_roots[q];
        else
            for (uint32_t j = k->first_child; j < k->first_child + k->child_count; j++) p->pull_child[m++] = n + j;
    }
    p->pull_first[rad_links_id_count(L)] = m;
}

/* The leaves' ranges, areas and materials; node B (3 per id) from the
 * leaves' B (3 per leaf patch) pulled up the trees and the clusters, and
 * each node's spread of B (largest max - min over the channels); the
 * leaves' areas, centroids and normals in leaf-list order. */
static void plan_trees(shaped_plan *p, const double *B, double *node_B, double *spread, double *lo)
{
    const rad_links *L = p->L;
    const uint32_t n = L->node_count;
    double *hi = lo + 3 * (size_t)n;
    /* the leaves first, on the threads (each reads its patch: a cache miss) */
#pragma omp parallel for schedule(static) num_threads(p->threads)
    for (uint32_t i = 0; i < n; i++) {
        const rad_link_node *e = &L->nodes[i];
        if (e->first_child != RAD_NO_ELEMENT) continue;
        const rad_patch *patch = &p->leaves->patches[e->leaf];
        double *b = &node_B[3 * (size_t)i], *bl = &lo[3 * (size_t)i], *bh = &hi[3 * (size_t)i];
        p->count[i] = 1;
        p->leaf_area[i] = e->area;
        for (int c = 0; c < 3; c++) {
            b[c] = bl[c] = bh[c] = B[3 * (size_t)e->leaf + c];
            p->rho[3 * (size_t)i + c] = patch->rho[c];
            p->E[3 * (size_t)i + c] = patch->emission[c];
        }
        spread[i] = 0;
    }
    /* then the split nodes from their children (after their parents) */
    for (uint32_t i = n; i-- > 0;) {
        const rad_link_node *e = &L->nodes[i];
        if (e->first_child == RAD_NO_ELEMENT) continue;
        double *bl = &lo[3 * (size_t)i], *bh = &hi[3 * (size_t)i];
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
        shaped_pull(&p->view, i, node_B);
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
    shaped_plan_pull_clusters(p, node_B);
#pragma omp parallel for schedule(static) num_threads(p->threads)
    for (uint32_t q = 0; q < L->leaf_count; q++) {
        const uint32_t x = p->leaf_nodes[q];
        const rad_patch *patch = &p->leaves->patches[L->nodes[x].leaf];
        p->area_q[q] = L->nodes[x].area;
        p->leaf_centroid[q] = patch->centroid;
        p->leaf_normal[q] = patch->normal;
    }
}

/* Every tree's nodes in index order, and the links they receive (the
 * start of its work, shaped_plan_lists adds the rest). */
static void plan_tree_lists(shaped_plan *p)
{
    const rad_links *L = p->L;
    const uint32_t n = L->node_count, roots = L->root_count;
    for (uint32_t i = 0; i < n; i++) p->tree_first[L->nodes[i].root + 1]++;
    for (uint32_t t = 0; t < roots; t++) p->tree_first[t + 1] += p->tree_first[t];
    for (uint32_t i = 0; i < n; i++) {
        const uint32_t t = L->nodes[i].root;
        p->tree_nodes[p->tree_first[t]++] = i; /* counts up; set back below */
        p->tree_work[t] += L->first_link[i + 1] - L->first_link[i];
    }
    for (uint32_t t = roots; t > 0; t--) p->tree_first[t] = p->tree_first[t - 1];
    p->tree_first[0] = 0;
}

/* The first link that has no link back at its source (shaped_pair_link),
 * for the message: searched only once plan_pairs has found one. */
static uint64_t first_unpaired(const shaped_plan *p)
{
    const rad_links *L = p->L;
    uint32_t r = 0;
    for (uint64_t k = 0; k < L->link_count; k++) {
        while (L->first_link[r + 1] <= k) r++;
        if (shaped_pair_link(&p->view, k, r) == UINT64_MAX) return k;
    }
    return UINT64_MAX;
}

/* The pair of every link (reverse, link_count): the link at its source
 * back to its receiver, by the transpose of rad_links_pairing, its blocks
 * on the threads. RAD_ERR_INVALID for a link without its pair (the first
 * such link named), or RAD_ERR_NOMEM (logged). */
static rad_status plan_pairs(const shaped_plan *p, uint64_t *reverse)
{
    const rad_links *L = p->L;
    rad_links_pairing w;
    if (rad_links_pairing_make(L, p->threads, &w) != RAD_OK) return RAD_ERR_NOMEM;
    int unpaired = 0;
#pragma omp parallel for schedule(dynamic, 1) num_threads(p->threads) reduction(|| : unpaired)
    for (uint32_t b = 0; b < w.blocks; b++) {
        uint32_t *at = rad_links_pairing_cursors(&w, b);
        for (uint32_t r = w.begin[b]; r < w.begin[b + 1] && !unpaired; r++)
            for (uint64_t k = L->first_link[r]; k < L->first_link[r + 1]; k++)
                if ((reverse[k] = rad_links_pair_next(L, at, r, k)) == UINT64_MAX) {
                    unpaired = 1;
                    break;
                }
    }
    rad_links_pairing_free(&w);
    if (unpaired) {
        const uint64_t bad = first_unpaired(p);
        if (bad != UINT64_MAX)
            rad_error("links: link %llu (id %u <- %u) has no link back: links come in pairs", (unsigned long long)bad,
                      rad_links_receiver_of(L, bad), L->links[bad].source);
        else
            rad_error("links: the links do not come in pairs");
        return RAD_ERR_INVALID;
    }
    return RAD_OK;
}

/* The per-end arrays for `ends` ends (at least one of each, so that a
 * plan without ends copies and frees them like any other). RAD_ERR_NOMEM
 * (logged). */
static rad_status alloc_ends(shaped_plan *p, uint64_t ends)
{
    const size_t n = ends ? ends : 1;
    p->end_link = rad_mem_alloc(n * sizeof *p->end_link); /* link-sized arrays: huge pages, fewer faults */
    p->end_receiver = rad_mem_alloc(n * sizeof *p->end_receiver);
    p->end_at = rad_mem_alloc(n * sizeof *p->end_at);
    p->inv_mean = calloc(n, sizeof *p->inv_mean); /* large: mapped untouched, so advised in time */
    rad_mem_advise_huge(p->inv_mean, n * sizeof *p->inv_mean);
    if (p->end_link && p->end_receiver && p->end_at && p->inv_mean) return RAD_OK;
    rad_error("links: out of memory for the shaped solve's %llu ends", (unsigned long long)ends);
    return RAD_ERR_NOMEM;
}

/* Which receiver ends to shape (shaped.h, "Which ends"), decided on the
 * threads receiver by receiver (a link at or from a cluster stays flat,
 * so does its pair); then the ends numbered in link order with their
 * point factors' offsets (prefix sums over the receivers, so the numbers
 * are one pass's), and every link's pair_end. RAD_ERR_NOMEM, or
 * RAD_ERR_INVALID for more ends than 32 bits number (logged). */
static rad_status plan_ends(shaped_plan *p, const double *node_B, const double *spread, double floor,
                            const uint64_t *reverse)
{
    const rad_links *L = p->L;
    const uint64_t ids = rad_links_id_count(L);
    /* per receiver: its point factors, then where they start */
    uint64_t *weights = malloc((ids + 1) * sizeof *weights);
    if (!weights) {
        rad_error("links: out of memory for the shaped solve's ends over %llu ids", (unsigned long long)ids);
        return RAD_ERR_NOMEM;
    }
#pragma omp parallel for schedule(dynamic, 1024) num_threads(p->threads)
    for (uint64_t r = 0; r < ids; r++) {
        uint64_t shaped = 0;
        for (uint64_t k = L->first_link[r]; k < L->first_link[r + 1]; k++) {
            const rad_link *l = &L->links[k], *back = &L->links[reverse[k]];
            if (r >= L->node_count || l->source >= L->node_count) {
                p->end[k] = SHAPED_NO_END;
                continue;
            }
            const double rho_r = max3(&p->rho[3 * r]), rho_s = max3(&p->rho[3 * (size_t)l->source]);
            const int shape = !shaped_plan_is_leaf(p, (uint32_t)r) &&
                              (rho_r * l->error * max3(&node_B[3 * (size_t)l->source]) >= floor ||
                               rho_s * back->factor * spread[r] >= floor);
            p->end[k] = shape ? 0 : SHAPED_NO_END;
            shaped += shape;
        }
        p->shaped_first[r + 1] = shaped;
        weights[r] = r < L->node_count ? shaped * p->count[r] : 0;
    }
    uint64_t total = 0, ends = 0;
    p->shaped_first[0] = 0;
    for (uint64_t r = 0; r < ids; r++) {
        const uint64_t w = weights[r];
        weights[r] = total;
        total += w;
        ends += p->shaped_first[r + 1];
        p->shaped_first[r + 1] = ends;
    }
    p->weight_count = total;
    p->end_count = ends;
    if (ends > SHAPED_MAX_ENDS) {
        free(weights);
        rad_error("links: %llu shaped ends, more than the shaped solve numbers (%llu)", (unsigned long long)ends,
                  (unsigned long long)SHAPED_MAX_ENDS);
        return RAD_ERR_INVALID;
    }
    if (alloc_ends(p, ends) != RAD_OK) {
        free(weights);
        return RAD_ERR_NOMEM;
    }
#pragma omp parallel for schedule(dynamic, 1024) num_threads(p->threads)
    for (uint64_t r = 0; r < L->node_count; r++) {
        uint64_t at = weights[r], e = p->shaped_first[r];
        for (uint64_t k = L->first_link[r]; k < L->first_link[r + 1]; k++)
            if (p->end[k] != SHAPED_NO_END) {
                p->end[k] = (uint32_t)e;
                p->end_link[e] = k;
                p->end_receiver[e] = (uint32_t)r;
                p->end_at[e] = at;
                at += p->count[r];
                e++;
            }
    }
    free(weights);
    const uint64_t links = L->link_count;
#pragma omp parallel for schedule(static) num_threads(p->threads)
    for (uint64_t k = 0; k < links; k++) p->pair_end[k] = p->end[reverse[k]];
    plan_view(p);
    return RAD_OK;
}

/* The shaped ends' point factors on the host (in parallel over the
 * receivers that have any, one at a time: the roots come first and hold
 * most of them); an end whose factors sum to 0 is left flat. */
rad_status shaped_plan_factors(shaped_plan *p)
{
    const rad_links *L = p->L;
    const uint32_t n = L->node_count;
    p->f = rad_mem_alloc(p->weight_count * sizeof *p->f);
    if (!p->f) {
        rad_error("links: out of memory for the shaped solve's %llu point factors",
                  (unsigned long long)p->weight_count);
        return RAD_ERR_NOMEM;
    }
    p->view.f = p->f;
    const shaped_view *v = &p->view;
    uint32_t *receivers = malloc((n ? n : 1) * sizeof *receivers), count = 0;
    if (!receivers) {
        rad_error("links: out of memory for the shaped solve's list of %u receivers", n);
        return RAD_ERR_NOMEM;
    }
    for (uint32_t r = 0; r < n; r++)
        if (p->shaped_first[r + 1] > p->shaped_first[r]) receivers[count++] = r;
#pragma omp parallel for schedule(dynamic, 1) num_threads(p->threads)
    for (uint32_t i = 0; i < count; i++) {
        const uint32_t r = receivers[i];
        for (uint64_t e = p->shaped_first[r]; e < p->shaped_first[r + 1]; e++) {
            rad_ff_patch P;
            shaped_node_polygon(v, L->links[p->end_link[e]].source, &P);
            float *f = &p->f[p->end_at[e]];
            for (uint32_t q = 0; q < p->count[r]; q++) f[q] = shaped_point_factor(v, p->first[r] + q, &P);
            p->inv_mean[e] = shaped_end_inv_mean(v, e, r);
        }
    }
    free(receivers);
    shaped_plan_drop(p);
    return RAD_OK;
}

void shaped_plan_drop(shaped_plan *p)
{
    p->dropped = 0;
    for (uint64_t e = 0; e < p->end_count; e++)
        if (p->inv_mean[e] == 0) {
            shaped_drop_end(&p->view, e, p->end, p->pair_end);
            p->dropped++;
        }
}

/* A sweep reads, for a link k at receiver r < s in r's tree: r's point
 * factors where k's end is shaped (the update of r's leaves), s's where
 * the pair's other end is (S, what s sends, summed over s's leaves). */
void shaped_plan_work(shaped_plan *p)
{
    const rad_links *L = p->L;
    if (!p->end) return; /* flat: the links alone, counted already */
#pragma omp parallel for schedule(dynamic, 1024) num_threads(p->threads)
    for (uint32_t r = 0; r < L->node_count; r++) {
        uint64_t work = 0;
        for (uint64_t k = L->first_link[r]; k < L->first_link[r + 1]; k++) {
            const uint32_t s = L->links[k].source;
            if (p->end[k] != SHAPED_NO_END) work += p->count[r];
            if (s < L->node_count && p->pair_end[k] != SHAPED_NO_END) work += p->count[s];
        }
        if (work) {
#pragma omp atomic
            p->tree_work[L->nodes[r].root] += work;
        }
    }
}

/* Every leaf's row sum with the shape, from the point factors on the host. */
void shaped_plan_row_sums(shaped_plan *p)
{
    const uint32_t n = p->L->node_count;
#pragma omp parallel for schedule(dynamic, 256) num_threads(p->threads)
    for (uint32_t x = 0; x < n; x++)
        if (shaped_plan_is_leaf(p, x)) p->row_sum[x] = shaped_leaf_row_sum(&p->view, x);
}

/* The plan up to the choice of ends (the point factors and the lists are
 * made by the backend that runs: plan_factors, or a device's). node_B: 3
 * values per id, the flat solution pulled up. */
rad_status shaped_plan_make(const rad_links *L, const rad_mesh *leaves, const double *B, double gate, int flat,
                            int threads, shaped_plan *p, double *node_B)
{
    const uint32_t n = L->node_count, leaf_count = L->leaf_count ? L->leaf_count : 1;
    const uint64_t links = L->link_count ? L->link_count : 1, ids = rad_links_id_count(L);
    memset(p, 0, sizeof *p);
    p->L = L;
    p->leaves = leaves;
    p->threads = threads;
    p->leaf_nodes = malloc(leaf_count * sizeof *p->leaf_nodes);
    p->first = malloc((size_t)n * sizeof *p->first);
    p->count = malloc((size_t)n * sizeof *p->count);
    p->leaf_area = malloc((size_t)n * sizeof *p->leaf_area);
    uint64_t *reverse = NULL; /* until the ends are numbered */
    if (!flat) { /* flat: no ends, no per-link array at all (shaped_link_end) */
        p->end = rad_mem_alloc(links * sizeof *p->end);
        p->pair_end = rad_mem_alloc(links * sizeof *p->pair_end);
        reverse = rad_mem_alloc(links * sizeof *reverse);
    }
    p->shaped_first = calloc(ids + 1, sizeof *p->shaped_first);
    if (L->cluster_count) p->root_cluster = malloc((size_t)L->root_count * sizeof *p->root_cluster);
    p->row_sum = malloc((size_t)n * sizeof *p->row_sum);
    p->rho = malloc(3 * (size_t)n * sizeof *p->rho);
    p->E = malloc(3 * (size_t)n * sizeof *p->E);
    p->area_q = malloc(leaf_count * sizeof *p->area_q);
    p->leaf_centroid = malloc(leaf_count * sizeof *p->leaf_centroid);
    p->leaf_normal = malloc(leaf_count * sizeof *p->leaf_normal);
    p->up = malloc(ids * sizeof *p->up);
    p->pull_first = malloc((ids + 1) * sizeof *p->pull_first);
    p->pull_child = malloc((4 * (size_t)n + L->root_count + L->cluster_count + 1) * sizeof *p->pull_child);
    p->id_area = malloc(ids * sizeof *p->id_area);
    p->tree_first = calloc((size_t)L->root_count + 1, sizeof *p->tree_first);
    p->tree_nodes = malloc((size_t)n * sizeof *p->tree_nodes);
    p->tree_work = calloc(L->root_count ? L->root_count : 1, sizeof *p->tree_work);
    double *spread = malloc((size_t)n * sizeof *spread), *lo = malloc(6 * (size_t)n * sizeof *lo);
    rad_status status = RAD_OK;
    if (!p->leaf_nodes || !p->first || !p->count || !p->leaf_area ||
        (!flat && (!p->end || !p->pair_end || !reverse)) ||
        !p->shaped_first || !p->row_sum || !p->rho || !p->E || !p->area_q || !p->leaf_centroid ||
        !p->leaf_normal || !p->up || !p->pull_first || !p->pull_child || !p->id_area || !p->tree_first ||
        !p->tree_nodes || !p->tree_work || !spread || !lo || (L->cluster_count && !p->root_cluster)) {
        rad_error("links: out of memory for the shaped solve over %u nodes and %llu links", n,
                  (unsigned long long)L->link_count);
        status = RAD_ERR_NOMEM;
    } else {
        plan_view(p);
        plan_ids(p);
        plan_trees(p, B, node_B, spread, lo);
        plan_tree_lists(p);
        if (!flat) status = plan_pairs(p, reverse);
    }
    if (status == RAD_OK && flat) {
        if ((status = alloc_ends(p, 0)) == RAD_OK) plan_view(p);
    } else if (status == RAD_OK) {
        double reflected = 0, area = 0, all = 0, all_area = 0;
        for (uint32_t i = 0; i < n; i++) {
            if (!shaped_plan_is_leaf(p, i)) continue;
            const double y = max3(&node_B[3 * (size_t)i]) * L->nodes[i].area;
            all += y;
            all_area += L->nodes[i].area;
            if (max3(&p->E[3 * (size_t)i]) > 0) continue;
            reflected += y;
            area += L->nodes[i].area;
        }
        const double mean = area > 0 ? reflected / area : all_area > 0 ? all / all_area : 0;
        status = plan_ends(p, node_B, spread, gate * mean, reverse);
    }
    free(reverse);
    free(spread);
    free(lo);
    if (status != RAD_OK) shaped_plan_free(p);
    return status;
}

void shaped_device_arrays_free(shaped_device_arrays *a)
{
    free(a->depth);
    free(a->depth_order);
    free(a->depth_first);
}

/* The device plan: the ids by depth (an id's up is one shallower:
 * clusters come after their parent, nodes after theirs, and a root's leaf
 * cluster is a cluster). */
rad_status shaped_plan_device(const shaped_plan *p, shaped_device_arrays *a, solve_shaped_device_plan *out)
{
    const rad_links *L = p->L;
    const uint32_t n = L->node_count, ids = (uint32_t)rad_links_id_count(L);
    memset(a, 0, sizeof *a);
    a->depth = malloc((size_t)ids * sizeof *a->depth);
    a->depth_order = malloc((size_t)ids * sizeof *a->depth_order);
    a->depth_first = calloc((size_t)ids + 2, sizeof *a->depth_first);
    if (!a->depth || !a->depth_order || !a->depth_first) {
        rad_error("links: out of memory for the shaped solve's device plan over %u ids", ids);
        return RAD_ERR_NOMEM;
    }
    uint32_t depths = 0;
    for (uint32_t t = 0; t < ids; t++) { /* the clusters first, then the nodes */
        const uint32_t i = t < L->cluster_count ? n + t : t - L->cluster_count;
        a->depth[i] = p->up[i] == SHAPED_NONE ? 0 : a->depth[p->up[i]] + 1;
        if (a->depth[i] + 1 > depths) depths = a->depth[i] + 1;
    }
    for (uint32_t i = 0; i < ids; i++) a->depth_first[a->depth[i] + 1]++;
    for (uint32_t d = 0; d < depths; d++) a->depth_first[d + 1] += a->depth_first[d];
    for (uint32_t i = 0; i < ids; i++) a->depth_order[a->depth_first[a->depth[i]]++] = i; /* counts up; set back */
    for (uint32_t d = depths; d > 0; d--) a->depth_first[d] = a->depth_first[d - 1];
    a->depth_first[0] = 0;
    memset(out, 0, sizeof *out);
    out->view = p->view;
    out->vertex_count = p->leaves->vertex_count;
    out->weight_count = p->weight_count;
    out->depth_count = depths;
    out->depth_order = a->depth_order;
    out->depth_first = a->depth_first;
    return RAD_OK;
}
