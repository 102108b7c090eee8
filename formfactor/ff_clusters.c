/* ff_clusters.c - clusters above the faces (ff_clusters.h). */
#include "ff_clusters.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "rad_log.h"

/* ---- the median split ---- */

typedef struct split_key {
    double at;     /* the centre's coordinate on the split axis, or the normal's (split_keys) */
    uint32_t root;
} split_key;

static int key_less(const split_key *a, const split_key *b)
{
    return a->at < b->at || (a->at == b->at && a->root < b->root);
}

/* Reorders keys[0 .. n) so that keys[k] is the k-th smallest, the smaller
 * before it and the larger after (Hoare's selection; the order is a total
 * one, so the result does not depend on anything but the keys). */
static void select_kth(split_key *keys, size_t n, size_t k)
{
    size_t lo = 0, hi = n - 1;
    while (lo < hi) {
        size_t mid = lo + (hi - lo) / 2;
        /* median of three as the pivot */
        if (key_less(&keys[mid], &keys[lo])) { split_key t = keys[mid]; keys[mid] = keys[lo]; keys[lo] = t; }
        if (key_less(&keys[hi], &keys[lo])) { split_key t = keys[hi]; keys[hi] = keys[lo]; keys[lo] = t; }
        if (key_less(&keys[hi], &keys[mid])) { split_key t = keys[hi]; keys[hi] = keys[mid]; keys[mid] = t; }
        split_key pivot = keys[mid];
        size_t i = lo, j = hi;
        while (i <= j) {
            while (key_less(&keys[i], &pivot)) i++;
            while (key_less(&pivot, &keys[j])) j--;
            if (i <= j) {
                split_key t = keys[i];
                keys[i] = keys[j];
                keys[j] = t;
                i++;
                if (j == 0) break;
                j--;
            }
        }
        if (k <= j)
            hi = j;
        else if (k >= i)
            lo = i;
        else
            return;
    }
}

/* ---- bounds ---- */

/* Cluster c's bound from its roots' patches. */
static ff_cluster_bound bound_of_roots(const rad_ff_patch *patches, const float *open, const uint32_t *roots,
                                       uint32_t begin, uint32_t end)
{
    ff_cluster_bound b;
    b.open_lo = b.open_hi = 1.0f;
    if (open) {
        b.open_lo = b.open_hi = open[roots[begin]];
        for (uint32_t k = begin + 1; k < end; k++) {
            b.open_lo = fminf(b.open_lo, open[roots[k]]);
            b.open_hi = fmaxf(b.open_hi, open[roots[k]]);
        }
    }
    rad_vec3 lo = rad_v3(INFINITY, INFINITY, INFINITY), hi = rad_v3(-INFINITY, -INFINITY, -INFINITY);
    rad_vec3 v = rad_v3(0, 0, 0);
    double area = 0, m[6] = {0, 0, 0, 0, 0, 0};
    for (uint32_t k = begin; k < end; k++) {
        const rad_ff_patch *p = &patches[roots[k]];
        for (uint32_t i = 0; i < p->vertex_count; i++) {
            rad_vec3 x = p->p[i];
            lo = rad_v3(fmin(lo.x, x.x), fmin(lo.y, x.y), fmin(lo.z, x.z));
            hi = rad_v3(fmax(hi.x, x.x), fmax(hi.y, x.y), fmax(hi.z, x.z));
        }
        v = rad_v3_add(v, rad_v3_scale(p->normal, p->area));
        area += p->area;
        rad_vec3 n = p->normal;
        m[0] += p->area * n.x * n.x, m[1] += p->area * n.y * n.y, m[2] += p->area * n.z * n.z;
        m[3] += p->area * n.x * n.y, m[4] += p->area * n.x * n.z, m[5] += p->area * n.y * n.z;
    }
    memcpy(b.moment, m, sizeof m);
    b.centre = rad_v3_scale(rad_v3_add(lo, hi), 0.5);
    b.area = area;
    b.vector_area = v;
    double r = 0, len = rad_v3_length(v);
    b.axis = len > 1e-12 * area ? rad_v3_scale(v, 1.0 / len) : rad_v3(0, 0, 1);
    double cos_min = len > 1e-12 * area ? 1.0 : -1.0;
    for (uint32_t k = begin; k < end; k++) {
        const rad_ff_patch *p = &patches[roots[k]];
        for (uint32_t i = 0; i < p->vertex_count; i++) r = fmax(r, rad_v3_length(rad_v3_sub(p->p[i], b.centre)));
        cos_min = fmin(cos_min, rad_v3_dot(p->normal, b.axis));
    }
    /* a hair more, for the rounding of what is measured against it */
    b.radius = r * (1 + 1e-12);
    b.cone_angle = fmin(RAD_PI, acos(fmax(-1.0, fmin(1.0, cos_min))) + 1e-9);
    return b;
}

/* ---- the tree ---- */

/* A cluster is split by orientation only where its centres' box is
 * thinner than this fraction of its widest side: a table top, a book, a
 * seat, whose top and bottom faces position splits keep together down to
 * the leaf clusters. Elsewhere orientation splits make clusters of one
 * orientation spread over a room (a closed cube's furnace came out 20 %
 * high with them everywhere, 6 % at 0.25, 2.0 % at 0.1 as with position
 * splits alone: docs/hierarchy.md). */
#define FF_CLUSTER_THIN 0.1

/* The key a cluster's roots are split by: where their normals spread
 * beyond max_cone (half-angle about their area-weighted mean) and their
 * centres' box is thin (FF_CLUSTER_THIN), the normal's component along the
 * axis it varies most on (area-weighted), so that the two halves face
 * apart (a table's top and bottom); else the centre's coordinate along the
 * widest axis of the centres' box. */
static void split_keys(const rad_ff_patch *patches, const uint32_t *roots, uint32_t begin, uint32_t end,
                       double max_cone, split_key *keys)
{
    rad_vec3 v = rad_v3(0, 0, 0), sq = rad_v3(0, 0, 0);
    double area = 0;
    for (uint32_t k = begin; k < end; k++) {
        const rad_ff_patch *p = &patches[roots[k]];
        v = rad_v3_add(v, rad_v3_scale(p->normal, p->area));
        sq = rad_v3_add(sq, rad_v3_scale(rad_v3(p->normal.x * p->normal.x, p->normal.y * p->normal.y,
                                                p->normal.z * p->normal.z), p->area));
        area += p->area;
    }
    const double len = rad_v3_length(v);
    double cos_min = 1.0;
    if (len > 1e-12 * area)
        for (uint32_t k = begin; k < end; k++) cos_min = fmin(cos_min, rad_v3_dot(patches[roots[k]].normal, v) / len);
    else
        cos_min = -1.0;
    rad_vec3 lo = rad_v3(INFINITY, INFINITY, INFINITY), hi = rad_v3(-INFINITY, -INFINITY, -INFINITY);
    for (uint32_t k = begin; k < end; k++) {
        rad_vec3 x = patches[roots[k]].centre;
        lo = rad_v3(fmin(lo.x, x.x), fmin(lo.y, x.y), fmin(lo.z, x.z));
        hi = rad_v3(fmax(hi.x, x.x), fmax(hi.y, x.y), fmax(hi.z, x.z));
    }
    rad_vec3 d = rad_v3_sub(hi, lo);
    const double widest = fmax(d.x, fmax(d.y, d.z)), thinnest = fmin(d.x, fmin(d.y, d.z));
    if (max_cone < RAD_PI && acos(fmax(-1.0, fmin(1.0, cos_min))) > max_cone && area > 0 &&
        thinnest < FF_CLUSTER_THIN * widest) {
        rad_vec3 mean = rad_v3_scale(v, 1.0 / area);
        rad_vec3 var = rad_v3(sq.x / area - mean.x * mean.x, sq.y / area - mean.y * mean.y, sq.z / area - mean.z * mean.z);
        int axis = var.x >= var.y && var.x >= var.z ? 0 : var.y >= var.z ? 1 : 2;
        for (uint32_t k = begin; k < end; k++) {
            rad_vec3 n = patches[roots[k]].normal;
            keys[k - begin] = (split_key){axis == 0 ? n.x : axis == 1 ? n.y : n.z, roots[k]};
        }
        return;
    }
    int axis = d.x >= d.y && d.x >= d.z ? 0 : d.y >= d.z ? 1 : 2;
    for (uint32_t k = begin; k < end; k++) {
        rad_vec3 x = patches[roots[k]].centre;
        keys[k - begin] = (split_key){axis == 0 ? x.x : axis == 1 ? x.y : x.z, roots[k]};
    }
}

rad_status ff_clusters_build(const rad_ff_patch *patches, const float *open, uint32_t root_count, double max_cone,
                             ff_cluster_tree *out)
{
    memset(out, 0, sizeof *out);
    size_t cap = root_count > 0 ? 2 * (size_t)root_count : 1;
    out->clusters = malloc(cap * sizeof *out->clusters);
    out->roots = malloc((root_count ? root_count : 1) * sizeof *out->roots);
    out->area_before = malloc(((size_t)root_count + 1) * sizeof *out->area_before);
    split_key *keys = malloc((root_count ? root_count : 1) * sizeof *keys);
    if (!out->clusters || !out->roots || !out->area_before || !keys) {
        free(keys);
        ff_clusters_free(out);
        rad_error("clusters: out of memory for %u faces", root_count);
        return RAD_ERR_NOMEM;
    }
    out->root_count = root_count;
    for (uint32_t k = 0; k < root_count; k++) out->roots[k] = k;
    out->clusters[0].link = (rad_link_cluster){RAD_NO_ELEMENT, RAD_NO_ELEMENT, 0, 0, root_count, 0, 0};
    out->count = 1;
    /* Clusters are numbered level by level, children after parents and
     * each one's two children consecutive: a level's splits are counted
     * first (a cluster splits where it holds more than
     * FF_CLUSTER_LEAF_ROOTS roots), which numbers the next level, and
     * then made side by side (disjoint ranges of roots and keys). */
    for (uint32_t level_begin = 0; level_begin < out->count;) {
        const uint32_t level_end = (uint32_t)out->count;
        uint32_t next = level_end;
        for (uint32_t c = level_begin; c < level_end; c++) {
            rad_link_cluster *l = &out->clusters[c].link;
            const uint32_t begin = l->root_begin, end = l->root_end, half = (end - begin) / 2;
            if (end - begin <= FF_CLUSTER_LEAF_ROOTS) continue;
            l->first_child = next;
            l->child_count = 2;
            out->clusters[next++].link = (rad_link_cluster){c, RAD_NO_ELEMENT, 0, begin, begin + half, 0, 0};
            out->clusters[next++].link = (rad_link_cluster){c, RAD_NO_ELEMENT, 0, begin + half, end, 0, 0};
        }
#pragma omp parallel for schedule(dynamic, 1) if (next - level_end > 2)
        for (uint32_t c = level_begin; c < level_end; c++) {
            const rad_link_cluster *l = &out->clusters[c].link;
            const uint32_t begin = l->root_begin, end = l->root_end, n = end - begin;
            if (l->child_count == 0) continue;
            split_keys(patches, out->roots, begin, end, max_cone, keys + begin);
            select_kth(keys + begin, n, n / 2);
            for (uint32_t k = 0; k < n; k++) out->roots[begin + k] = keys[begin + k].root;
        }
        level_begin = level_end;
        out->count = next;
    }
    free(keys);
    out->area_before[0] = 0;
    for (uint32_t k = 0; k < root_count; k++) out->area_before[k + 1] = out->area_before[k] + patches[out->roots[k]].area;
#pragma omp parallel for schedule(dynamic, 64)
    for (uint32_t c = 0; c < out->count; c++) {
        ff_cluster *cl = &out->clusters[c];
        cl->bound = bound_of_roots(patches, open, out->roots, cl->link.root_begin, cl->link.root_end);
        /* the file's area: the roots' own areas summed in order (the sum the reader checks) */
        cl->link.area = cl->bound.area;
    }
    return RAD_OK;
}

void ff_clusters_free(ff_cluster_tree *t)
{
    if (!t) return;
    free(t->clusters);
    free(t->roots);
    free(t->area_before);
    memset(t, 0, sizeof *t);
}
