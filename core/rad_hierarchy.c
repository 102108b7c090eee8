/* rad_hierarchy.c - element quadtrees over a mesh (rad_hierarchy.h). */
#include "rad_hierarchy.h"

#include <stddef.h>
#include <stdlib.h>
#include <string.h>

#include "rad_log.h"
#include "rad_mem.h"
#include "rad_polygon.h"

static rad_vec3 position(const rad_hierarchy *h, uint32_t v)
{
    const double *p = h->positions + 3 * (size_t)v;
    return rad_v3(p[0], p[1], p[2]);
}

/* The next capacity at least `need`, doubling from `cap` (64 at first). */
static size_t grown_cap(size_t cap, size_t need)
{
    size_t grown = cap ? cap : 64;
    while (grown < need) grown *= 2;
    return grown;
}

/* Room for `more` vertices and elements. 0 for lack of memory. */
static int reserve(rad_hierarchy *h, size_t more_vertices, size_t more_elements)
{
    if (h->vertex_count + more_vertices > h->vertex_cap) {
        size_t cap = grown_cap(h->vertex_cap, h->vertex_count + more_vertices);
        double *p = realloc(h->positions, 3 * cap * sizeof *p);
        if (!p) return 0;
        h->positions = p;
        h->vertex_cap = cap;
    }
    if (h->element_count + more_elements > h->element_cap) {
        size_t cap = grown_cap(h->element_cap, h->element_count + more_elements);
        rad_element *e = realloc(h->elements, cap * sizeof *e);
        if (!e) return 0;
        h->elements = e;
        h->element_cap = cap;
    }
    return 1;
}

static uint32_t add_vertex(rad_hierarchy *h, rad_vec3 at)
{
    double *p = h->positions + 3 * h->vertex_count;
    p[0] = at.x, p[1] = at.y, p[2] = at.z;
    return (uint32_t)h->vertex_count++;
}

/* The midpoint table at twice its entries or more: rehashed into one of
 * twice the size when it would fill past half. */
static rad_status grow_midpoints(rad_hierarchy *h)
{
    size_t table = h->midpoints.mask + 1;
    if (2 * (h->midpoint_count + 5) <= table) return RAD_OK;
    rad_edge_map grown;
    if (rad_edge_map_init(&grown, table) != RAD_OK) {
        rad_edge_map_free(&grown);
        return RAD_ERR_NOMEM;
    }
    for (size_t i = 0; i < table; i++) {
        uint64_t key = h->midpoints.keys[i];
        if (key == RAD_EDGE_MAP_EMPTY) continue;
        uint32_t *slot;
        rad_edge_map_find(&grown, (uint32_t)(key >> 32), (uint32_t)key, &slot);
        *slot = h->midpoints.vertex[i];
    }
    rad_edge_map_free(&h->midpoints);
    h->midpoints = grown;
    return RAD_OK;
}

/* rad_polygon_vertex_fn: an edge's midpoint, one per edge; a quad's centre.
 * The caller made room for the 5 vertices and midpoints a split adds. */
static uint32_t split_vertex(void *context, uint32_t a, uint32_t b, rad_vec3 at)
{
    rad_hierarchy *h = context;
    if (a == RAD_NO_VERTEX) return add_vertex(h, at);
    uint32_t *slot;
    if (rad_edge_map_find(&h->midpoints, a, b, &slot)) return *slot;
    h->midpoint_count++;
    return *slot = add_vertex(h, at);
}

static void set_geometry(rad_hierarchy *h, rad_element *e)
{
    rad_vec3 corner[4];
    for (uint32_t k = 0; k < e->vertex_count; k++) corner[k] = position(h, e->v[k]);
    rad_polygon_geometry(corner, (int)e->vertex_count, &e->area, &e->normal, &e->centroid);
}

rad_status rad_hierarchy_init(const rad_mesh *base, rad_hierarchy *out)
{
    rad_hierarchy h;
    memset(&h, 0, sizeof h);
    memset(out, 0, sizeof *out);
    h.base = base;
    size_t n = base->patch_count;
    for (size_t p = 0; p < n; p++) {
        const rad_patch *patch = &base->patches[p];
        int bad = patch->vertex_count < 3 || patch->vertex_count > 4;
        for (uint32_t k = 0; !bad && k < patch->vertex_count; k++) bad = patch->v[k] >= base->vertex_count;
        if (bad) {
            rad_error("hierarchy: patch %zu of the base mesh is not a triangle or quad of its %zu vertices", p,
                      base->vertex_count);
            return RAD_ERR_INVALID;
        }
    }
    if (n >= RAD_NO_ELEMENT || base->vertex_count >= RAD_NO_VERTEX) {
        rad_error("hierarchy: %zu patches and %zu vertices; at most %u of each", n, base->vertex_count,
                  RAD_NO_ELEMENT - 1);
        return RAD_ERR_INVALID;
    }
    int ok = reserve(&h, base->vertex_count + 1, n + 1) && rad_edge_map_init(&h.midpoints, 2 * n + 16) == RAD_OK;
    if (!ok) {
        rad_error("hierarchy: out of memory for %zu roots", n);
        rad_hierarchy_free(&h);
        return RAD_ERR_NOMEM;
    }
    memcpy(h.positions, base->positions, 3 * base->vertex_count * sizeof *h.positions);
    h.vertex_count = base->vertex_count;
    for (size_t p = 0; p < n; p++) {
        const rad_patch *patch = &base->patches[p];
        rad_element *e = &h.elements[p];
        memset(e, 0, sizeof *e);
        e->parent = e->first_child = RAD_NO_ELEMENT;
        e->root = (uint32_t)p;
        e->vertex_count = patch->vertex_count;
        rad_polygon_corners_store(patch->v, patch->vertex_count, e->v);
        /* The base's own geometry, as the mesh computed it. */
        e->area = patch->area, e->normal = patch->normal, e->centroid = patch->centroid;
    }
    h.element_count = h.leaf_count = n;
    *out = h;
    return RAD_OK;
}

rad_status rad_hierarchy_split(rad_hierarchy *h, uint32_t element, uint32_t *out_first_child)
{
    if (element >= h->element_count) {
        rad_error("hierarchy: element %u of %zu", element, h->element_count);
        return RAD_ERR_INVALID;
    }
    if (h->elements[element].first_child != RAD_NO_ELEMENT) {
        *out_first_child = h->elements[element].first_child;
        return RAD_OK;
    }
    /* A split adds 4 elements, at most 5 vertices (4 midpoints, a centre). */
    if (h->element_count + 4 >= RAD_NO_ELEMENT || h->vertex_count + 5 >= RAD_NO_VERTEX) {
        rad_error("hierarchy: %zu elements and %zu vertices; at most %u of each", h->element_count,
                  h->vertex_count, RAD_NO_ELEMENT - 1);
        return RAD_ERR_INVALID;
    }
    if (!reserve(h, 5, 4) || grow_midpoints(h) != RAD_OK) {
        rad_error("hierarchy: out of memory for element %zu (%zu vertices)", h->element_count + 4, h->vertex_count);
        return RAD_ERR_NOMEM;
    }
    rad_element parent = h->elements[element];
    rad_vec3 corner[4];
    for (uint32_t k = 0; k < parent.vertex_count; k++) corner[k] = position(h, parent.v[k]);
    uint32_t child[4][4];
    rad_polygon_split(parent.v, corner, (int)parent.vertex_count, split_vertex, h, child);
    uint32_t first = (uint32_t)h->element_count;
    for (int i = 0; i < 4; i++) {
        rad_element *c = &h->elements[first + (uint32_t)i];
        memset(c, 0, sizeof *c);
        c->parent = element;
        c->first_child = RAD_NO_ELEMENT;
        c->root = parent.root;
        c->level = parent.level + 1;
        c->vertex_count = parent.vertex_count;
        rad_polygon_corners_store(child[i], parent.vertex_count, c->v);
        set_geometry(h, c);
    }
    h->elements[element].first_child = first;
    h->element_count += 4;
    h->leaf_count += 3;
    *out_first_child = first;
    return RAD_OK;
}

rad_status rad_hierarchy_split_to(rad_hierarchy *h, uint32_t root, uint32_t depth)
{
    if (depth == 0) return RAD_OK;
    uint32_t first;
    rad_status status = rad_hierarchy_split(h, root, &first);
    for (uint32_t i = 0; i < 4 && status == RAD_OK; i++) status = rad_hierarchy_split_to(h, first + i, depth - 1);
    return status;
}

/* The leaves of `element`'s subtree, depth first, into out (NULL: only
 * counted); their number. */
static size_t subtree_leaves(const rad_hierarchy *h, uint32_t element, uint32_t *out)
{
    const uint32_t first = h->elements[element].first_child;
    if (first == RAD_NO_ELEMENT) {
        if (out) *out = element;
        return 1;
    }
    size_t n = 0;
    for (uint32_t i = 0; i < 4; i++) n += subtree_leaves(h, first + i, out ? out + n : NULL);
    return n;
}

uint32_t *rad_hierarchy_leaf_elements(const rad_hierarchy *h)
{
    const size_t roots = h->base->patch_count;
    uint32_t *order = rad_mem_alloc((h->leaf_count ? h->leaf_count : 1) * sizeof *order);
    size_t *at = malloc((roots + 1) * sizeof *at);
    if (!order || !at) {
        free(order);
        free(at);
        rad_error("hierarchy: out of memory for %zu leaves", h->leaf_count);
        return NULL;
    }
    at[0] = 0;
#pragma omp parallel for schedule(dynamic, 1024)
    for (size_t r = 0; r < roots; r++) at[r + 1] = subtree_leaves(h, (uint32_t)r, NULL);
    for (size_t r = 0; r < roots; r++) at[r + 1] += at[r];
#pragma omp parallel for schedule(dynamic, 1024)
    for (size_t r = 0; r < roots; r++) subtree_leaves(h, (uint32_t)r, order + at[r]);
    free(at);
    return order;
}

rad_status rad_hierarchy_leaves_of(const rad_hierarchy *h, const uint32_t *order, rad_mesh *out)
{
    rad_mesh m;
    memset(&m, 0, sizeof m);
    memset(out, 0, sizeof *out);
    const rad_mesh *base = h->base;
    size_t leaves = h->leaf_count ? h->leaf_count : 1;
    m.positions = rad_mem_alloc((h->vertex_count ? h->vertex_count : 1) * 3 * sizeof *m.positions);
    m.patches = rad_mem_alloc(leaves * sizeof *m.patches);
    int groups = base->group_count > 0 && base->patch_group && base->group_names;
    if (groups) {
        m.patch_group = malloc(leaves * sizeof *m.patch_group);
        m.group_names = malloc(base->group_count * sizeof *m.group_names);
    }
    if (!m.positions || !m.patches || (groups && (!m.patch_group || !m.group_names))) {
        rad_error("hierarchy: out of memory for %zu leaves", h->leaf_count);
        rad_mesh_free(&m);
        return RAD_ERR_NOMEM;
    }
    memcpy(m.positions, h->positions, h->vertex_count * 3 * sizeof *m.positions);
    m.vertex_count = h->vertex_count;
    if (groups) {
        memcpy(m.group_names, base->group_names, base->group_count * sizeof *m.group_names);
        m.group_count = base->group_count;
    }
    m.patch_count = h->leaf_count;
    const ptrdiff_t count = (ptrdiff_t)h->leaf_count;
#pragma omp parallel for schedule(static)
    for (ptrdiff_t k = 0; k < count; k++) {
        const rad_element *e = &h->elements[order[k]];
        const rad_patch *root = &base->patches[e->root];
        rad_patch *p = &m.patches[k];
        memset(p, 0, sizeof *p);
        p->vertex_count = e->vertex_count;
        memcpy(p->v, e->v, sizeof p->v);
        p->source_face = root->source_face;
        p->area = e->area, p->normal = e->normal, p->centroid = e->centroid;
        memcpy(p->rho, root->rho, sizeof p->rho);
        memcpy(p->emission, root->emission, sizeof p->emission);
        if (groups) m.patch_group[k] = base->patch_group[e->root];
    }
    *out = m;
    return RAD_OK;
}

rad_status rad_hierarchy_leaves(const rad_hierarchy *h, rad_mesh *out)
{
    uint32_t *order = rad_hierarchy_leaf_elements(h);
    if (!order) {
        memset(out, 0, sizeof *out);
        return RAD_ERR_NOMEM;
    }
    rad_status st = rad_hierarchy_leaves_of(h, order, out);
    free(order);
    return st;
}

void rad_hierarchy_free(rad_hierarchy *h)
{
    if (!h) return;
    free(h->positions);
    free(h->elements);
    rad_edge_map_free(&h->midpoints);
    memset(h, 0, sizeof *h);
}
