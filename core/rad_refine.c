/* rad_refine.c - error-driven refinement of a patch mesh (contract in
 * rad_refine.h). */
#include "rad_refine.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "rad_adjacency.h"
#include "rad_box.h"
#include "rad_color.h"
#include "rad_edge_map.h"
#include "rad_log.h"
#include "rad_polygon.h"

/* The balance pass: a neighbour may be at most this much larger (in
 * sqrt(area)) than a split patch's children; 2 levels apart is a factor 4
 * in size, one level apart 2, so 2.5 allows one level. */
#define BALANCE_RATIO 2.5
#define BALANCE_PASSES 16

rad_refine_options rad_refine_defaults(void)
{
    return (rad_refine_options){.tolerance = 0.05, .min_size = 1.0 / 128, .max_patches = 0};
}

static double scene_diagonal(const rad_mesh *mesh)
{
    rad_box box = rad_box_of_points(mesh->positions, mesh->vertex_count);
    return rad_box_diagonal(&box);
}

typedef struct ranked {
    double weight;
    uint32_t patch;
} ranked;

static int by_weight_desc(const void *a, const void *b)
{
    const ranked *x = a, *y = b;
    if (x->weight != y->weight) return x->weight < y->weight ? 1 : -1;
    return x->patch < y->patch ? -1 : x->patch > y->patch;
}

static int emits(const rad_patch *p) { return p->emission[0] > 0 || p->emission[1] > 0 || p->emission[2] > 0; }

rad_status rad_refine_mark(const rad_mesh *mesh, const double *radiosity, const rad_refine_options *options,
                           uint8_t *out_split, rad_refine_stats *out_stats)
{
    rad_refine_stats st;
    memset(&st, 0, sizeof st);
    size_t n = mesh->patch_count;
    if (!(options->tolerance > 0) || !(options->min_size >= 0) || !isfinite(options->tolerance)) {
        rad_error("refine: tolerance %g must be positive and min_size %g non-negative", options->tolerance,
                  options->min_size);
        return RAD_ERR_INVALID;
    }
    for (size_t p = 0; p < n; p++)
        if (mesh->patches[p].vertex_count < 3 || mesh->patches[p].vertex_count > 4) {
            rad_error("refine: patch %zu has %u vertices (expected 3 or 4)", p, mesh->patches[p].vertex_count);
            return RAD_ERR_INVALID;
        }
    memset(out_split, 0, n);
    rad_vertex_patches adj = {0};
    double *indicator = malloc((n ? n : 1) * sizeof *indicator);
    ranked *order = malloc((n ? n : 1) * sizeof *order);
    rad_status status = indicator && order ? rad_vertex_patches_build(mesh, &adj) : RAD_ERR_NOMEM;
    if (status != RAD_OK) {
        if (status == RAD_ERR_NOMEM) rad_error("refine: out of memory for %zu patches", n);
        goto done;
    }

    /* Ybar: what the image's exposure is made of. */
    double sum = 0.0, area = 0.0;
    for (size_t p = 0; p < n; p++) {
        if (emits(&mesh->patches[p])) continue;
        sum += mesh->patches[p].area * rad_luminance(&radiosity[3 * p]);
        area += mesh->patches[p].area;
    }
    double ybar = area > 0 && sum > 0 ? sum / area : 0.0;
    st.mean_luminance = ybar;
    double crease_cos = cos(RAD_CREASE_DEGREES * RAD_PI / 180.0);
    double min_size = options->min_size * scene_diagonal(mesh);

    /* d_p against the same-surface patches sharing a corner. */
    size_t candidates = 0;
    for (size_t p = 0; p < n; p++) {
        const rad_patch *patch = &mesh->patches[p];
        double y = rad_luminance(&radiosity[3 * p]), d = 0.0, ws = 0.0, wy = 0.0;
        for (uint32_t k = 0; k < patch->vertex_count; k++) {
            uint32_t v = patch->v[k];
            for (size_t e = adj.start[v]; e < adj.start[v + 1]; e++) {
                uint32_t q = adj.list[e];
                if (q == p || !rad_same_surface(patch, &mesh->patches[q], crease_cos)) continue;
                rad_vec3 dc = rad_v3_sub(mesh->patches[q].centroid, patch->centroid);
                double d2 = rad_v3_dot(dc, dc);
                if (!(d2 > 0)) continue;
                ws += 1.0 / d2, wy += rad_luminance(&radiosity[3 * (size_t)q]) / d2;
            }
        }
        if (ws > 0) d = fabs(y - wy / ws);
        indicator[p] = ybar > 0 ? d / ybar : 0.0;
        st.max_indicator = fmax(st.max_indicator, indicator[p]);
        if (!(indicator[p] > options->tolerance)) continue;
        if (sqrt(patch->area) < min_size) {
            st.too_small++;
            continue;
        }
        order[candidates++] = (ranked){.weight = indicator[p] * indicator[p] * patch->area, .patch = (uint32_t)p};
    }
    st.marked = candidates;
    qsort(order, candidates, sizeof *order, by_weight_desc);
    size_t take = candidates;
    if (options->max_patches > 0) {
        size_t room = options->max_patches > n ? (options->max_patches - n) / 3 : 0;
        if (take > room) take = room;
    }
    st.over_budget = candidates - take;
    for (size_t i = 0; i < take; i++) out_split[order[i].patch] = 1;

    /* Balance: an unsplit neighbour more than BALANCE_RATIO times the size
     * of a split patch's children is split too, until nothing changes. */
    for (int pass = 0; pass < BALANCE_PASSES; pass++) {
        size_t added = 0;
        for (size_t p = 0; p < n; p++) {
            if (out_split[p] != 1) continue;
            const rad_patch *patch = &mesh->patches[p];
            double child = 0.5 * sqrt(patch->area);
            for (uint32_t k = 0; k < patch->vertex_count; k++) {
                uint32_t v = patch->v[k];
                for (size_t e = adj.start[v]; e < adj.start[v + 1]; e++) {
                    uint32_t q = adj.list[e];
                    const rad_patch *other = &mesh->patches[q];
                    if (out_split[q] || !rad_same_surface(patch, other, crease_cos)) continue;
                    if (sqrt(other->area) > BALANCE_RATIO * child) {
                        out_split[q] = 2; /* split, counted once this pass is over */
                        added++;
                    }
                }
            }
        }
        for (size_t p = 0; p < n; p++)
            if (out_split[p] == 2) out_split[p] = 1;
        st.balanced += added;
        if (!added) break;
    }
    for (size_t p = 0; p < n; p++) st.split += out_split[p] != 0;
    st.patches_after = n + 3 * st.split;
done:
    rad_vertex_patches_free(&adj);
    free(indicator);
    free(order);
    if (out_stats) *out_stats = st;
    return status;
}

/* Building the refined mesh: positions grow by the midpoints and quad
 * centres; edge midpoints are shared through rad_edge_map, as
 * rad_mesh_build shares them. */
typedef struct splitter {
    rad_mesh *out;
    rad_edge_map midpoints;
} splitter;

static rad_vec3 out_position(const splitter *S, uint32_t v)
{
    const double *q = S->out->positions + 3 * (size_t)v;
    return rad_v3(q[0], q[1], q[2]);
}

static uint32_t push_vertex(splitter *S, rad_vec3 p)
{
    double *q = S->out->positions + 3 * S->out->vertex_count;
    q[0] = p.x, q[1] = p.y, q[2] = p.z;
    return (uint32_t)S->out->vertex_count++;
}

/* rad_polygon_vertex_fn: an edge's midpoint (one per edge) or a quad's centre. */
static uint32_t split_vertex(void *context, uint32_t a, uint32_t b, rad_vec3 at)
{
    splitter *S = context;
    if (a == RAD_NO_VERTEX) return push_vertex(S, at);
    uint32_t *slot;
    if (rad_edge_map_find(&S->midpoints, a, b, &slot)) return *slot;
    return *slot = push_vertex(S, at);
}

static void emit_child(splitter *S, const rad_patch *parent, uint32_t group, const uint32_t *v, int n)
{
    rad_mesh *out = S->out;
    size_t i = out->patch_count++;
    rad_patch *p = &out->patches[i];
    *p = *parent;
    rad_vec3 corner[4];
    rad_polygon_corners_store(v, (uint32_t)n, p->v);
    for (int k = 0; k < n; k++) corner[k] = out_position(S, v[k]);
    rad_polygon_geometry(corner, n, &p->area, &p->normal, &p->centroid);
    if (out->patch_group) out->patch_group[i] = group;
}

rad_status rad_refine_split(const rad_mesh *mesh, const uint8_t *split, rad_mesh *out_mesh, uint32_t **out_parent)
{
    size_t n = mesh->patch_count, count = 0;
    for (size_t p = 0; p < n; p++) count += split[p] != 0;
    size_t patches = n + 3 * count, vertices = mesh->vertex_count + 5 * count;
    rad_mesh out;
    memset(&out, 0, sizeof out);
    splitter S = {.out = &out};
    rad_status map = rad_edge_map_init(&S.midpoints, 4 * count); /* at most 4 new edges per split patch */
    uint32_t *parent = out_parent ? malloc((patches ? patches : 1) * sizeof *parent) : NULL;
    out.patches = malloc((patches ? patches : 1) * sizeof *out.patches);
    out.positions = malloc((vertices ? vertices : 1) * 3 * sizeof *out.positions);
    int groups = mesh->group_count > 0 && mesh->patch_group;
    if (groups) {
        out.patch_group = malloc((patches ? patches : 1) * sizeof *out.patch_group);
        out.group_names = malloc(mesh->group_count * sizeof *out.group_names);
    }
    if (!out.patches || !out.positions || map != RAD_OK || (out_parent && !parent) ||
        (groups && (!out.patch_group || !out.group_names))) {
        rad_error("refine: out of memory for %zu patches", patches);
        rad_mesh_free(&out);
        rad_edge_map_free(&S.midpoints);
        free(parent);
        return RAD_ERR_NOMEM;
    }
    if (groups) {
        memcpy(out.group_names, mesh->group_names, mesh->group_count * sizeof *out.group_names);
        out.group_count = mesh->group_count;
    }
    memcpy(out.positions, mesh->positions, mesh->vertex_count * 3 * sizeof *out.positions);
    out.vertex_count = mesh->vertex_count;
    for (size_t p = 0; p < n; p++) {
        const rad_patch *patch = &mesh->patches[p];
        uint32_t group = groups ? mesh->patch_group[p] : 0;
        size_t first = out.patch_count;
        const uint32_t *v = patch->v;
        if (!split[p]) {
            out.patches[out.patch_count] = *patch;
            if (groups) out.patch_group[out.patch_count] = group;
            out.patch_count++;
        } else {
            int corners = (int)patch->vertex_count;
            rad_vec3 corner[4];
            uint32_t child[4][4];
            for (int k = 0; k < corners; k++) corner[k] = out_position(&S, v[k]);
            rad_polygon_split(v, corner, corners, split_vertex, &S, child);
            for (int c = 0; c < 4; c++) emit_child(&S, patch, group, child[c], corners);
        }
        if (parent)
            for (size_t i = first; i < out.patch_count; i++) parent[i] = (uint32_t)p;
    }
    rad_edge_map_free(&S.midpoints);
    double *shrunk = realloc(out.positions, (out.vertex_count ? out.vertex_count : 1) * 3 * sizeof *shrunk);
    if (shrunk) out.positions = shrunk;
    *out_mesh = out;
    if (out_parent) *out_parent = parent;
    return RAD_OK;
}
