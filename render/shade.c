#include "shade.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "rad_adjacency.h"
#include "rad_color.h"
#include "rad_log.h"

/* A vertex lies inside an edge when it is this close to the edge's line
 * (relative to the edge's length) and its parameter is this far from both
 * ends: midpoints computed as (a + b) / 2 and cut points are exact to a
 * few ulps. */
#define T_VERTEX_REL_TOL 1e-8
/* Anchoring passes at most (chains along one line converge in a few). */
#define T_VERTEX_MAX_PASSES 200
/* Anchoring has settled when no corner value moved by more than this
 * fraction of the largest one: about 50 ulps of a double. Rounding of the
 * interpolation (1 - t) a + t b can flip the last bits of a chain on every
 * pass, so "nothing changed at all" may never come; and a change this
 * small is far below what a float image shows (6e-8 relative). */
#define T_VERTEX_SETTLED 1e-14

/* Which neighbours a patch blends with: one smooth surface
 * (rad_same_surface: normals within RAD_CREASE_DEGREES, the same
 * material), or the same material in one of the OBJ's smoothing groups. */
typedef struct surface_rule {
    double crease_cos;
    const render_smoothing *smoothing; /* NULL: none */
} surface_rule;

static int same_surface(const surface_rule *rule, const rad_patch *a, const rad_patch *b)
{
    if (rad_same_surface(a, b, rule->crease_cos)) return 1;
    const render_smoothing *sm = rule->smoothing;
    if (!sm || a->source_face >= sm->face_count || b->source_face >= sm->face_count) return 0;
    uint32_t ga = sm->face_group[a->source_face], gb = sm->face_group[b->source_face];
    /* Facing apart (a thin plate's two sides) never blends. */
    return ga != 0 && ga == gb && rad_v3_dot(a->normal, b->normal) > 0.0 && rad_same_material(a, b);
}

typedef struct loose_edge {
    double length;
    uint32_t patch, corner; /* the edge from corner to corner + 1 of patch */
} loose_edge;

static int by_length_desc(const void *a, const void *b)
{
    const loose_edge *x = a, *y = b;
    if (x->length != y->length) return x->length < y->length ? 1 : -1;
    if (x->patch != y->patch) return x->patch < y->patch ? -1 : 1;
    return x->corner < y->corner ? -1 : x->corner > y->corner;
}

static int by_u64(const void *a, const void *b)
{
    uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
    return x < y ? -1 : x > y;
}

/* Vertices in a uniform grid, as (cell hash, vertex) pairs sorted by hash. */
typedef struct vertex_grid {
    double lo[3], cell;
    uint64_t *entries; /* hash << 32 | vertex; hashes are 32 bits */
    size_t count;
} vertex_grid;

static uint64_t cell_hash(int64_t i, int64_t j, int64_t k)
{
    uint64_t h = (uint64_t)i * UINT64_C(0x9E3779B97F4A7C15) ^ (uint64_t)j * UINT64_C(0xC2B2AE3D27D4EB4F) ^
                 (uint64_t)k * UINT64_C(0x165667B19E3779F9);
    return (h ^ (h >> 29)) & UINT64_C(0xFFFFFFFF);
}

static void cell_of(const vertex_grid *g, const double *p, int64_t c[3])
{
    for (int a = 0; a < 3; a++) c[a] = (int64_t)floor((p[a] - g->lo[a]) / g->cell);
}

static const double *position(const rad_mesh *mesh, uint32_t v) { return mesh->positions + 3 * (size_t)v; }

static uint32_t corner_of(const rad_patch *patch, uint32_t v)
{
    for (uint32_t k = 0; k < patch->vertex_count; k++)
        if (patch->v[k] == v) return k;
    return 0;
}

/* Vertex v lies inside edge (corner ka, corner kb) of patch p, at
 * parameter t. */
typedef struct t_vertex {
    uint32_t patch, ka, kb, v;
    double t;
} t_vertex;

typedef struct t_vertex_list {
    t_vertex *items;
    size_t count, capacity;
    int out_of_memory;
} t_vertex_list;

static void t_vertex_push(t_vertex_list *list, t_vertex item)
{
    if (list->count == list->capacity) {
        size_t capacity = list->capacity ? 2 * list->capacity : 256;
        t_vertex *grown = realloc(list->items, capacity * sizeof *grown);
        if (!grown) {
            list->out_of_memory = 1;
            return;
        }
        list->items = grown;
        list->capacity = capacity;
    }
    list->items[list->count++] = item;
}

/* Anchors a T-vertex to its edge: its corners in the patches of p's
 * surface take the value p's corners interpolate to there. Returns the
 * largest change. */
static double anchor(const rad_mesh *mesh, const rad_vertex_patches *adj, const t_vertex *tv, size_t nc,
                     const surface_rule *rule, double *corners)
{
    const double *va = &corners[(4 * (size_t)tv->patch + tv->ka) * nc];
    const double *vb = &corners[(4 * (size_t)tv->patch + tv->kb) * nc];
    double change = 0.0;
    for (size_t e = adj->start[tv->v]; e < adj->start[tv->v + 1]; e++) {
        uint32_t q = adj->list[e];
        if (!same_surface(rule, &mesh->patches[tv->patch], &mesh->patches[q])) continue;
        double *dst = &corners[(4 * (size_t)q + corner_of(&mesh->patches[q], tv->v)) * nc];
        for (size_t c = 0; c < nc; c++) {
            double value = (1.0 - tv->t) * va[c] + tv->t * vb[c];
            change = fmax(change, fabs(value - dst[c]));
            dst[c] = value;
        }
    }
    return change;
}

/* Searches the cells around the points of edge (a, b) spaced one cell
 * apart - every point of the edge is within half a cell of one - for
 * vertices inside the edge, and lists each. */
static void find_t_vertices(const rad_mesh *mesh, const vertex_grid *g, const loose_edge *edge, t_vertex_list *out)
{
    const rad_patch *patch = &mesh->patches[edge->patch];
    uint32_t ka = edge->corner, kb = (edge->corner + 1) % patch->vertex_count;
    uint32_t a = patch->v[ka], b = patch->v[kb];
    const double *pa = position(mesh, a), *pb = position(mesh, b);
    double d[3] = {pb[0] - pa[0], pb[1] - pa[1], pb[2] - pa[2]};
    double len2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
    if (!(len2 > 0)) return;
    double steps = ceil(edge->length / g->cell);
    if (steps > 1e6) steps = 1e6;
    for (double s = 0; s <= steps; s++) {
        double q[3] = {pa[0] + d[0] * s / steps, pa[1] + d[1] * s / steps, pa[2] + d[2] * s / steps};
        int64_t c[3];
        cell_of(g, q, c);
        for (int dx = -1; dx <= 1; dx++)
            for (int dy = -1; dy <= 1; dy++)
                for (int dz = -1; dz <= 1; dz++) {
                    uint64_t h = cell_hash(c[0] + dx, c[1] + dy, c[2] + dz);
                    size_t lo = 0, hi = g->count; /* first entry with hash >= h */
                    while (lo < hi) {
                        size_t mid = lo + (hi - lo) / 2;
                        if ((g->entries[mid] >> 32) < h) lo = mid + 1;
                        else hi = mid;
                    }
                    for (size_t i = lo; i < g->count && (g->entries[i] >> 32) == h; i++) {
                        uint32_t v = (uint32_t)g->entries[i];
                        if (v == a || v == b) continue;
                        const double *pv = position(mesh, v);
                        double w[3] = {pv[0] - pa[0], pv[1] - pa[1], pv[2] - pa[2]};
                        double t = (w[0] * d[0] + w[1] * d[1] + w[2] * d[2]) / len2;
                        if (t <= T_VERTEX_REL_TOL || t >= 1.0 - T_VERTEX_REL_TOL) continue;
                        double off2 = 0.0;
                        for (int k = 0; k < 3; k++) off2 += (w[k] - t * d[k]) * (w[k] - t * d[k]);
                        if (off2 > T_VERTEX_REL_TOL * T_VERTEX_REL_TOL * len2) continue;
                        t_vertex_push(out, (t_vertex){.patch = edge->patch, .ka = ka, .kb = kb, .v = v, .t = t});
                    }
                }
    }
}

/* T-vertices: a vertex inside another patch's edge on the same surface,
 * where a refined patch meets an unrefined one (or pieces cut from one
 * face meet at different levels). The coarse patch interpolates along its
 * edge, so the fine patches' corners there are set to that interpolation:
 * both sides agree, and the image has no seam. Edges are taken longest
 * first, so that an edge's own ends are anchored before its inside is.
 * Only edges that no second patch shares (a shared edge has no vertex
 * inside it) are searched. */
static rad_status anchor_t_vertices(const rad_mesh *mesh, const rad_vertex_patches *adj, size_t nc, const surface_rule *rule,
                                    double *corners)
{
    size_t n = mesh->patch_count, edges = 0;
    for (size_t p = 0; p < n; p++) edges += mesh->patches[p].vertex_count;
    uint64_t *keys = malloc((edges ? edges : 1) * sizeof *keys);
    loose_edge *loose = malloc((edges ? edges : 1) * sizeof *loose);
    vertex_grid g = {.entries = malloc((mesh->vertex_count ? mesh->vertex_count : 1) * sizeof *g.entries)};
    t_vertex_list found = {0};
    rad_status status = RAD_OK;
    if (!keys || !loose || !g.entries) {
        rad_error("out of memory finding T-vertices (%zu edges)", edges);
        status = RAD_ERR_NOMEM;
        goto done;
    }
    size_t e = 0;
    for (size_t p = 0; p < n; p++) {
        const rad_patch *patch = &mesh->patches[p];
        for (uint32_t k = 0; k < patch->vertex_count; k++) {
            uint32_t a = patch->v[k], b = patch->v[(k + 1) % patch->vertex_count];
            keys[e++] = a < b ? (uint64_t)a << 32 | b : (uint64_t)b << 32 | a;
        }
    }
    qsort(keys, edges, sizeof *keys, by_u64);
    size_t nloose = 0;
    double area = 0.0;
    for (size_t p = 0; p < n; p++) {
        const rad_patch *patch = &mesh->patches[p];
        area += patch->area;
        for (uint32_t k = 0; k < patch->vertex_count; k++) {
            uint32_t a = patch->v[k], b = patch->v[(k + 1) % patch->vertex_count];
            uint64_t key = a < b ? (uint64_t)a << 32 | b : (uint64_t)b << 32 | a;
            uint64_t *hit = bsearch(&key, keys, edges, sizeof *keys, by_u64);
            if ((hit > keys && hit[-1] == key) || (hit + 1 < keys + edges && hit[1] == key)) continue;
            const double *pa = position(mesh, a), *pb = position(mesh, b);
            double len = sqrt((pb[0] - pa[0]) * (pb[0] - pa[0]) + (pb[1] - pa[1]) * (pb[1] - pa[1]) +
                              (pb[2] - pa[2]) * (pb[2] - pa[2]));
            loose[nloose++] = (loose_edge){.length = len, .patch = (uint32_t)p, .corner = k};
        }
    }
    if (nloose == 0 || n == 0) goto done;
    qsort(loose, nloose, sizeof *loose, by_length_desc);
    /* Cells about a patch wide. */
    for (int a = 0; a < 3; a++) g.lo[a] = INFINITY;
    for (size_t v = 0; v < mesh->vertex_count; v++)
        for (int a = 0; a < 3; a++) g.lo[a] = fmin(g.lo[a], mesh->positions[3 * v + a]);
    g.cell = sqrt(area / (double)n);
    if (!(g.cell > 0) || !isfinite(g.cell)) goto done;
    for (size_t v = 0; v < mesh->vertex_count; v++) {
        if (adj->start[v] == adj->start[v + 1]) continue; /* no patch uses it */
        int64_t c[3];
        cell_of(&g, position(mesh, (uint32_t)v), c);
        g.entries[g.count++] = cell_hash(c[0], c[1], c[2]) << 32 | (uint64_t)v;
    }
    qsort(g.entries, g.count, sizeof *g.entries, by_u64);
    for (size_t i = 0; i < nloose && !found.out_of_memory; i++) find_t_vertices(mesh, &g, &loose[i], &found);
    if (found.out_of_memory) {
        rad_error("out of memory listing T-vertices (%zu so far)", found.count);
        status = RAD_ERR_NOMEM;
        goto done;
    }
    /* Where two sides of a line both have vertices inside the other's
     * edges (cut pieces meeting whole cells, refined patches meeting cut
     * ones), anchoring one moves the end of another: repeat until nothing
     * moves, which converges to values linear along the whole line. */
    double scale = 0.0;
    for (size_t k = 0; k < mesh->patch_count * 4 * nc; k++) scale = fmax(scale, fabs(corners[k]));
    for (int pass = 0; pass < T_VERTEX_MAX_PASSES; pass++) {
        double change = 0.0;
        for (size_t i = 0; i < found.count; i++)
            change = fmax(change, anchor(mesh, adj, &found.items[i], nc, rule, corners));
        if (change <= T_VERTEX_SETTLED * scale) break;
    }
done:
    free(found.items);
    free(keys);
    free(loose);
    free(g.entries);
    return status;
}

/* Is edge (a, b) of patch p shared with another patch of its surface? */
static int edge_shared(const rad_mesh *mesh, const rad_vertex_patches *adj, uint32_t p, uint32_t a, uint32_t b,
                       const surface_rule *rule)
{
    for (size_t i = adj->start[a]; i < adj->start[a + 1]; i++) {
        uint32_t q = adj->list[i];
        if (q == p || !same_surface(rule, &mesh->patches[p], &mesh->patches[q])) continue;
        for (size_t j = adj->start[b]; j < adj->start[b + 1]; j++)
            if (adj->list[j] == q) return 1;
    }
    return 0;
}

/* Luminance of channel values (one channel: the value itself). */
static double channel_luminance(const double *b, size_t nc) { return nc == 3 ? rad_luminance(b) : b[0]; }

/* The linear reconstruction (RENDER_SHADING_LINEAR): each patch's
 * in-plane gradient, fitted by weighted least squares to the patches of
 * its surface that share a corner with it (weights 1 / distance^2 between
 * centroids), then its value at corner k, B_p + phi g . (x_k - c_p), with
 * phi in [0, 1] the largest that keeps the corner's luminance - so that
 * shadow edges make no new extrema - inside the range of the luminance over
 * p and those neighbours; at a corner on the surface's edge (where the
 * neighbours lie on one side only, and a linear field runs past their
 * range) inside that range widened by its own width on both sides, and
 * never below 0, in any channel. out: patch_count * 4 * nc, as the corners. */
static void linear_extrapolation(const rad_mesh *mesh, const rad_vertex_patches *adj, const double *radiosity, size_t nc,
                                 const surface_rule *rule, double *out)
{
    for (size_t p = 0; p < mesh->patch_count; p++) {
        const rad_patch *patch = &mesh->patches[p];
        rad_vec3 n = patch->normal;
        rad_vec3 t1 = rad_v3_normalize(fabs(n.x) < 0.9 ? rad_v3_cross(n, rad_v3(1, 0, 0)) : rad_v3_cross(n, rad_v3(0, 1, 0)));
        rad_vec3 t2 = rad_v3_cross(n, t1);
        const double *bp = &radiosity[3 * p];
        double m00 = 0, m01 = 0, m11 = 0, r0[3] = {0, 0, 0}, r1[3] = {0, 0, 0};
        double yp = channel_luminance(bp, nc), lo = yp, hi = yp;
        for (uint32_t k = 0; k < patch->vertex_count; k++) {
            uint32_t v = patch->v[k];
            for (size_t e = adj->start[v]; e < adj->start[v + 1]; e++) {
                uint32_t q = adj->list[e];
                if (q == p || !same_surface(rule, patch, &mesh->patches[q])) continue;
                /* A neighbour sharing two corners is met twice: its weight doubles, as an edge neighbour's should. */
                rad_vec3 d = rad_v3_sub(mesh->patches[q].centroid, patch->centroid);
                double x = rad_v3_dot(d, t1), y = rad_v3_dot(d, t2), d2 = x * x + y * y;
                if (!(d2 > 0)) continue;
                double w = 1.0 / d2;
                const double *bq = &radiosity[3 * (size_t)q];
                m00 += w * x * x, m01 += w * x * y, m11 += w * y * y;
                for (size_t c = 0; c < nc; c++) r0[c] += w * x * (bq[c] - bp[c]), r1[c] += w * y * (bq[c] - bp[c]);
                double yq = channel_luminance(bq, nc);
                lo = fmin(lo, yq), hi = fmax(hi, yq);
            }
        }
        double det = m00 * m11 - m01 * m01;
        int fitted = det > 1e-9 * (m00 + m11) * (m00 + m11);
        double gx[3] = {0, 0, 0}, gy[3] = {0, 0, 0};
        for (size_t c = 0; fitted && c < nc; c++) {
            gx[c] = (m11 * r0[c] - m01 * r1[c]) / det;
            gy[c] = (m00 * r1[c] - m01 * r0[c]) / det;
        }
        uint32_t nv = patch->vertex_count;
        for (uint32_t k = 0; k < nv; k++) {
            const double *pv = mesh->positions + 3 * (size_t)patch->v[k];
            rad_vec3 d = rad_v3_sub(rad_v3(pv[0], pv[1], pv[2]), patch->centroid);
            double x = rad_v3_dot(d, t1), y = rad_v3_dot(d, t2), step[3] = {0, 0, 0};
            for (size_t c = 0; c < nc; c++) step[c] = gx[c] * x + gy[c] * y;
            /* The limiter scales every channel's step by one factor, taken
             * from the luminance: so the luminance of the RGB corners is
             * the corner of the luminance (render --channels grey). */
            double phi = 1.0, dy = channel_luminance(step, nc);
            if (fitted && dy != 0.0) {
                int edge = !edge_shared(mesh, adj, (uint32_t)p, patch->v[k], patch->v[(k + 1) % nv], rule) ||
                           !edge_shared(mesh, adj, (uint32_t)p, patch->v[k], patch->v[(k + nv - 1) % nv], rule);
                double widen = edge ? hi - lo : 0.0;
                double top = hi + widen, bottom = fmax(0.0, lo - widen);
                if (yp + dy > top) phi = (top - yp) / dy;
                if (yp + dy < bottom) phi = (bottom - yp) / dy;
                phi = fmin(1.0, fmax(0.0, phi));
            }
            for (size_t c = 0; c < nc; c++) /* and no channel below 0 */
                if (bp[c] + phi * step[c] < 0.0) phi = fmax(0.0, bp[c] / -step[c]);
            for (size_t c = 0; c < nc; c++) out[(4 * p + k) * nc + c] = bp[c] + phi * step[c];
        }
    }
}

const char *render_shading_name(render_shading shading)
{
    switch (shading) {
    case RENDER_SHADING_SMOOTH: return "smooth";
    case RENDER_SHADING_FLAT: return "flat";
    case RENDER_SHADING_LINEAR: return "linear";
    }
    return "unknown";
}

rad_status render_shade_corners(const rad_mesh *mesh, const double *radiosity, int channels, render_shading shading,
                                double *out_corners)
{
    return render_shade_corners_smoothed(mesh, radiosity, channels, shading, NULL, out_corners);
}

rad_status render_shade_corners_smoothed(const rad_mesh *mesh, const double *radiosity, int channels,
                                         render_shading shading, const render_smoothing *smoothing,
                                         double *out_corners)
{
    rad_status status = RAD_OK;
    rad_vertex_patches adj = {NULL, NULL};
    double *extrapolated = NULL; /* RENDER_SHADING_LINEAR: each patch's value at its corners */
    const size_t nc = (size_t)channels;
    if (channels != 1 && channels != 3) {
        rad_error("%d colour channels (expected 1 or 3)", channels);
        return RAD_ERR_INVALID;
    }
    memset(out_corners, 0, mesh->patch_count * 4 * nc * sizeof *out_corners);
    for (size_t p = 0; p < mesh->patch_count; p++) {
        if (mesh->patches[p].vertex_count < 3 || mesh->patches[p].vertex_count > 4) {
            rad_error("patch %zu has %u vertices (expected 3 or 4)", p, mesh->patches[p].vertex_count);
            status = RAD_ERR_INVALID;
            goto done;
        }
    }
    if (shading == RENDER_SHADING_FLAT) {
        for (size_t p = 0; p < mesh->patch_count; p++)
            for (uint32_t k = 0; k < mesh->patches[p].vertex_count; k++)
                memcpy(&out_corners[(4 * p + k) * nc], &radiosity[3 * p], nc * sizeof *radiosity);
        goto done;
    }
    status = rad_vertex_patches_build(mesh, &adj);
    if (status != RAD_OK) goto done;
    const surface_rule rule_value = {cos(RAD_CREASE_DEGREES * RAD_PI / 180.0), smoothing};
    const surface_rule *rule = &rule_value;
    if (shading == RENDER_SHADING_LINEAR) {
        extrapolated = malloc((mesh->patch_count ? mesh->patch_count : 1) * 4 * nc * sizeof *extrapolated);
        if (!extrapolated) {
            rad_error("out of memory for the linear reconstruction of %zu patches", mesh->patch_count);
            status = RAD_ERR_NOMEM;
            goto done;
        }
        linear_extrapolation(mesh, &adj, radiosity, nc, rule, extrapolated);
    }
    for (size_t p = 0; p < mesh->patch_count; p++) {
        const rad_patch *patch = &mesh->patches[p];
        for (uint32_t k = 0; k < patch->vertex_count; k++) {
            uint32_t v = patch->v[k];
            double sum[3] = {0, 0, 0}, area = 0.0;
            for (size_t e = adj.start[v]; e < adj.start[v + 1]; e++) {
                uint32_t q = adj.list[e];
                if (q != p && !same_surface(rule, patch, &mesh->patches[q])) continue;
                double a = mesh->patches[q].area;
                area += a;
                const double *value = extrapolated ? &extrapolated[(4 * (size_t)q + corner_of(&mesh->patches[q], v)) * nc]
                                                   : &radiosity[3 * (size_t)q];
                for (size_t c = 0; c < nc; c++) sum[c] += a * value[c];
            }
            double *dst = &out_corners[(4 * p + k) * nc];
            for (size_t c = 0; c < nc; c++) dst[c] = area > 0.0 ? sum[c] / area : radiosity[3 * p + c];
        }
    }
    status = anchor_t_vertices(mesh, &adj, nc, rule, out_corners);
done:
    rad_vertex_patches_free(&adj);
    free(extrapolated);
    return status;
}
