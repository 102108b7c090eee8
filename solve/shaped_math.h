/* shaped_math.h - the shaped solve's per-item math (shaped.h), written
 * once for the host and the GPU: static inline functions marked RAD_HD,
 * included by shaped.c (the CPU's Gauss-Seidel), shaped_host.c (the
 * Jacobi sweeps of the device backends, on the host) and shaped_cuda.cu
 * (the same on the GPU). Each function does one item (an end, a receiver,
 * an id, a leaf) in one fixed order, so every backend that calls it gets
 * the same bits for the same inputs.
 *
 * The plan reaches them as shaped_view: flat arrays and counts, host or
 * device pointers alike, no pointer graphs. Ids are rad_links': the nodes,
 * then the clusters. Leaf-list order: every node's leaves are consecutive,
 * node i's are leaf_nodes[first[i] .. first[i] + count[i]) (shaped.c).
 * B, H: 3 values per id; Q: 3 per leaf, leaf-list order; S and T: 3 per
 * end.
 *
 * Ends: a link whose receiver end is shaped has an end, numbered in link
 * order (so receiver i's ends are one range, shaped_first[i] ..
 * shaped_first[i + 1]); what an end needs (its link, receiver, point
 * factors' offset, mean) is stored per end, and per link only its end and
 * the pair's other link's end (4 bytes each): a link of 16 bytes costs
 * 24 in the solve, not 64 (docs/solve.md, "Memory and progress"). An end
 * whose factors sum to 0 is dropped: its link and the pair's other link
 * no longer name it, and its inv_mean is 0.
 */
#ifndef SOLVE_SHAPED_MATH_H
#define SOLVE_SHAPED_MATH_H

#include <math.h>
#include <stdint.h>

#include "rad_ff_kernel.h"
#include "rad_links.h"
#include "rad_math.h"

/* A link whose receiver end is not shaped (end[k], pair_end[k]). */
#define SHAPED_NO_END UINT32_MAX
/* Ends at most: their numbers are 32 bits. */
#define SHAPED_MAX_ENDS ((uint64_t)UINT32_MAX)
/* No id above (up[i]). */
#define SHAPED_NONE UINT32_MAX

typedef struct shaped_view {
    uint32_t node_count, leaf_count;
    uint64_t id_count, link_count;
    /* geometry, for the point factors */
    const rad_link_node *nodes;     /* node_count */
    const double *positions;        /* the leaves mesh's vertex table, 3 per vertex */
    const rad_vec3 *leaf_centroid;  /* leaf_count, leaf-list order */
    const rad_vec3 *leaf_normal;    /* leaf_count, leaf-list order */
    /* the trees and the clusters */
    const rad_link *links;          /* link_count */
    const uint64_t *first_link;     /* id_count + 1: id i's links [first_link[i], first_link[i + 1]) */
    const uint32_t *up;             /* id_count: the id whose H this one adds when pushed down (a node's parent,
                                       a root's leaf cluster, a cluster's parent); SHAPED_NONE at the top */
    const uint32_t *leaf_nodes;     /* leaf_count: the leaf nodes in leaf-list order */
    const uint32_t *first, *count;  /* node_count: each node's leaves in the leaf list */
    const double *leaf_area;        /* node_count: its leaves' areas summed */
    const double *area_q;           /* leaf_count: leaf areas, leaf-list order */
    const double *rho, *E;          /* node_count * 3: the node's material (its root's); E 0 at split nodes */
    const uint64_t *pull_first;     /* id_count + 1: id i's B is the area-weighted mean of the ids */
    const uint32_t *pull_child;     /*   pull_child[pull_first[i] .. [i + 1]) (none at a leaf) */
    const double *id_area;          /* id_count: node and cluster areas */
    /* the ends */
    uint64_t end_count;
    const uint32_t *end;            /* link_count: the link's end, or SHAPED_NO_END; NULL: no ends (flat) */
    const uint32_t *pair_end;       /* link_count: the end of the pair's other link, or SHAPED_NO_END; NULL: flat */
    const uint64_t *end_link;       /* end_count: its link (ascending) */
    const uint32_t *end_receiver;   /* end_count: its link's receiver */
    const uint64_t *end_at;         /* end_count: its point factors f[end_at .. end_at + count[receiver]) */
    const uint64_t *shaped_first;   /* id_count + 1: receiver i's ends are shaped_first[i] .. [i + 1] */
    const float *f;                 /* the point factors */
    const double *inv_mean;         /* end_count: 1 / their area-weighted mean; 0: dropped */
} shaped_view;

/* Node i's polygon as the point factor takes it: corners from the leaves
 * mesh's vertex table, the plane's normal (its first leaf's). */
static inline RAD_HD void shaped_node_polygon(const shaped_view *v, uint32_t i, rad_ff_patch *out)
{
    const rad_link_node *e = &v->nodes[i];
    rad_ff_patch P = {0};
    for (uint32_t k = 0; k < e->vertex_count; k++) {
        const double *p = &v->positions[3 * (size_t)e->v[k]];
        P.p[k] = rad_v3(p[0], p[1], p[2]);
    }
    if (e->vertex_count == 3) P.p[3] = P.p[2];
    P.normal = v->leaf_normal[v->first[i]];
    P.vertex_count = e->vertex_count;
    *out = P;
}

/* The unoccluded point factor from leaf q's centroid (its normal) to P. */
static inline RAD_HD float shaped_point_factor(const shaped_view *v, uint32_t q, const rad_ff_patch *P)
{
    return (float)rad_ff_point_polygon(v->leaf_centroid[q], v->leaf_normal[q], P);
}

/* Link k's end, and the pair's other link's (SHAPED_NO_END where none, or
 * in a flat solve, which stores neither array). */
static inline RAD_HD uint32_t shaped_link_end(const shaped_view *v, uint64_t k)
{
    return v->end ? v->end[k] : SHAPED_NO_END;
}
static inline RAD_HD uint32_t shaped_link_pair_end(const shaped_view *v, uint64_t k)
{
    return v->pair_end ? v->pair_end[k] : SHAPED_NO_END;
}

/* 1 / the area-weighted mean of end e's point factors over its receiver
 * r's leaves (summed in leaf order); 0 where they sum to 0 (the end is
 * then dropped). */
static inline RAD_HD double shaped_end_inv_mean(const shaped_view *v, uint64_t e, uint32_t r)
{
    const float *f = &v->f[v->end_at[e]];
    const double *area = &v->area_q[v->first[r]];
    double sum = 0;
    for (uint32_t q = 0; q < v->count[r]; q++) sum += area[q] * (double)f[q];
    return sum > 0 ? v->leaf_area[r] / sum : 0;
}

/* What end e (receiver r) sends along its pair, from the leaves' Q: sum
 * over r's leaves of A_q u_q Q_q / A_r. */
static inline RAD_HD void shaped_end_sum(const shaped_view *v, uint64_t e, uint32_t r, const double *Q, double out[3])
{
    const float *f = &v->f[v->end_at[e]];
    const double *area = &v->area_q[v->first[r]], *b = &Q[3 * (size_t)v->first[r]];
    double s0 = 0, s1 = 0, s2 = 0;
    for (uint32_t q = 0; q < v->count[r]; q++) {
        const double w = area[q] * (double)f[q];
        s0 += w * b[3 * q];
        s1 += w * b[3 * q + 1];
        s2 += w * b[3 * q + 2];
    }
    const double scale = v->inv_mean[e] / v->leaf_area[r];
    out[0] = s0 * scale;
    out[1] = s1 * scale;
    out[2] = s2 * scale;
}

/* What link k's source sends: its B where the pair's other link has no
 * end; else that end's T where the sums were made beforehand (T not
 * NULL), or the sum made here. */
static inline RAD_HD void shaped_source_value(const shaped_view *v, uint64_t k, const double *B, const double *Q,
                                              const double *T, double out[3])
{
    const uint32_t s = v->links[k].source;
    const uint32_t back = shaped_link_pair_end(v, k);
    if (back == SHAPED_NO_END) {
        for (int c = 0; c < 3; c++) out[c] = B[3 * (size_t)s + c];
    } else if (T) {
        for (int c = 0; c < 3; c++) out[c] = T[3 * (size_t)back + c];
    } else {
        shaped_end_sum(v, back, s, Q, out);
    }
}

/* The pair of link k (receiver r): the link at k's source back to r
 * (sources ascend per receiver), or UINT64_MAX where there is none. */
static inline RAD_HD uint64_t shaped_pair_link(const shaped_view *v, uint64_t k, uint32_t r)
{
    const uint32_t s = v->links[k].source;
    uint64_t lo = v->first_link[s], hi = v->first_link[s + 1];
    while (lo < hi) {
        const uint64_t mid = lo + (hi - lo) / 2;
        if (v->links[mid].source < r) lo = mid + 1;
        else hi = mid;
    }
    return lo < v->first_link[s + 1] && v->links[lo].source == r ? lo : UINT64_MAX;
}

/* End e dropped (its factors sum to 0): its link and the pair's other
 * link no longer name it (end and pair_end: the view's arrays, writable
 * where the caller holds them). */
static inline RAD_HD void shaped_drop_end(const shaped_view *v, uint64_t e, uint32_t *end, uint32_t *pair_end)
{
    const uint64_t k = v->end_link[e], back = shaped_pair_link(v, k, v->end_receiver[e]);
    end[k] = SHAPED_NO_END;
    if (back != UINT64_MAX) pair_end[back] = SHAPED_NO_END;
}

/* Receiver i's links from its `lane`-th on, every `stride`-th (a node's
 * or a cluster's): the unshaped ones summed into h, the shaped ones'
 * source values kept in S (by end). */
static inline RAD_HD void shaped_gather_part(const shaped_view *v, uint32_t i, uint32_t lane, uint32_t stride,
                                             const double *B, const double *Q, const double *T, double *S,
                                             double h[3])
{
    h[0] = h[1] = h[2] = 0;
    for (uint64_t k = v->first_link[i] + lane; k < v->first_link[i + 1]; k += stride) {
        double s[3];
        shaped_source_value(v, k, B, Q, T, s);
        const uint32_t e = shaped_link_end(v, k);
        if (e != SHAPED_NO_END) {
            for (int c = 0; c < 3; c++) S[3 * (size_t)e + c] = s[c];
            continue;
        }
        const double f = v->links[k].factor;
        for (int c = 0; c < 3; c++) h[c] += f * s[c];
    }
}

/* Receiver i's gather in link order (the CPU's sweeps): H[i], and S. */
static inline RAD_HD void shaped_gather(const shaped_view *v, uint32_t i, const double *B, const double *Q,
                                        const double *T, double *H, double *S)
{
    double h[3];
    shaped_gather_part(v, i, 0, 1, B, Q, T, S, h);
    for (int c = 0; c < 3; c++) H[3 * (size_t)i + c] = h[c];
}

/* The GPU gathers a receiver with a warp: lane l takes links first + l,
 * first + l + 32, ... in order (shaped_gather_part), and the lanes' sums
 * are added as the warp's shuffles add them, h[l] += h[l + w] for w = 16,
 * 8, 4, 2, 1 (shaped_gather_lanes, the host twin's). */
#define SHAPED_GATHER_LANES 32

/* Receiver i's gather as a warp makes it (shaped_gather_part per lane,
 * then the shuffles' tree), on one thread: H[i], and S. */
static inline void shaped_gather_lanes(const shaped_view *v, uint32_t i, const double *B, const double *Q,
                                       const double *T, double *H, double *S)
{
    double h[SHAPED_GATHER_LANES][3];
    for (uint32_t l = 0; l < SHAPED_GATHER_LANES; l++)
        shaped_gather_part(v, i, l, SHAPED_GATHER_LANES, B, Q, T, S, h[l]);
    for (uint32_t w = SHAPED_GATHER_LANES / 2; w > 0; w >>= 1)
        for (uint32_t l = 0; l < w; l++)
            for (int c = 0; c < 3; c++) h[l][c] = h[l][c] + h[l + w][c];
    for (int c = 0; c < 3; c++) H[3 * (size_t)i + c] = h[0][c];
}

/* Id i's H plus the H of the id above it (already pushed): down the
 * cluster tree, into the roots, down the trees. */
static inline RAD_HD void shaped_push(const shaped_view *v, uint32_t i, double *H)
{
    const uint32_t up = v->up[i];
    if (up == SHAPED_NONE) return;
    for (int c = 0; c < 3; c++) H[3 * (size_t)i + c] += H[3 * (size_t)up + c];
}

/* Leaf q (node x): H[x] (pushed down) plus its and its ancestors' shaped
 * links, F u_x S, kept in H[x] (the whole gather, the balance's); out =
 * E + rho H; d: |out - Q[q]| per channel, infinite where not a number. */
static inline RAD_HD void shaped_update_leaf(const shaped_view *v, uint32_t q, double *H, const double *S,
                                             const double *Q, double out[3], double d[3])
{
    const uint32_t x = v->leaf_nodes[q];
    double h[3] = {H[3 * (size_t)x], H[3 * (size_t)x + 1], H[3 * (size_t)x + 2]};
    for (uint32_t a = x; a < v->node_count; a = v->up[a]) /* the nodes up to the root; not the clusters */
        for (uint64_t j = v->shaped_first[a]; j < v->shaped_first[a + 1]; j++) {
            if (v->inv_mean[j] == 0) continue; /* dropped: its link gathered flat */
            const double w =
                v->links[v->end_link[j]].factor * v->inv_mean[j] * (double)v->f[v->end_at[j] + q - v->first[a]];
            for (int c = 0; c < 3; c++) h[c] += w * S[3 * j + c];
        }
    for (int c = 0; c < 3; c++) {
        const size_t i = 3 * (size_t)x + c;
        H[i] = h[c];
        const double b = v->E[i] + v->rho[i] * h[c];
        d[c] = fabs(b - Q[3 * (size_t)q + c]);
        if (isnan(d[c])) d[c] = INFINITY;
        out[c] = b;
    }
}

/* Id i's B: the area-weighted mean of its children's (a split node's 4,
 * a leaf cluster's roots, an inner cluster's clusters); a leaf's is left. */
static inline RAD_HD void shaped_pull(const shaped_view *v, uint32_t i, double *B)
{
    const uint64_t begin = v->pull_first[i], end = v->pull_first[i + 1];
    if (begin == end) return;
    double sum[3] = {0, 0, 0}, area = 0;
    for (uint64_t k = begin; k < end; k++) {
        const uint32_t child = v->pull_child[k];
        const double a = v->id_area[child];
        area += a;
        for (int c = 0; c < 3; c++) sum[c] += a * B[3 * (size_t)child + c];
    }
    for (int c = 0; c < 3; c++) B[3 * (size_t)i + c] = sum[c] / area;
}

/* Leaf node x's row sum with the shape: the F of its links and its
 * ancestors', each shaped one times u_x, and of the clusters above its
 * root (never shaped). */
static inline RAD_HD double shaped_leaf_row_sum(const shaped_view *v, uint32_t x)
{
    double s = 0;
    for (uint32_t a = x; a != SHAPED_NONE; a = v->up[a])
        for (uint64_t k = v->first_link[a]; k < v->first_link[a + 1]; k++) {
            const uint32_t e = shaped_link_end(v, k);
            s += v->links[k].factor *
                 (e == SHAPED_NO_END ? 1.0 : v->inv_mean[e] * v->f[v->end_at[e] + v->first[x] - v->first[a]]);
        }
    return s;
}

#endif
