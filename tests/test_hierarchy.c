/* test_hierarchy.c - core/rad_hierarchy.h, the element quadtrees of
 * hierarchical radiosity. A tree split uniformly to depth d is
 * rad_mesh_build's --subdiv d to the bit (corners, areas, normals,
 * centroids, materials, source faces, groups, shared vertices) on the
 * Cornell box and the cluttered room; lazy splits keep parents, children,
 * levels and areas consistent, share midpoints across faces, and grow the
 * midpoint table past its first size. */
#include <stdint.h>
#include <string.h>

#include "rad_hierarchy.h"
#include "rad_mesh.h"
#include "rad_scene.h"
#include "rad_test.h"

static int same_vec(rad_vec3 a, rad_vec3 b) { return a.x == b.x && a.y == b.y && a.z == b.z; }

static int same_point(const rad_mesh *a, uint32_t va, const rad_mesh *b, uint32_t vb)
{
    return memcmp(a->positions + 3 * (size_t)va, b->positions + 3 * (size_t)vb, 3 * sizeof(double)) == 0;
}

/* The leaves of `h` split to `depth` against rad_mesh_build at --subdiv depth. */
static void check_uniform(const rad_scene *scene, const rad_mesh *base, uint32_t depth)
{
    rad_hierarchy h;
    RAD_CHECK(rad_hierarchy_init(base, &h) == RAD_OK);
    for (uint32_t r = 0; r < base->patch_count; r++) RAD_CHECK(rad_hierarchy_split_to(&h, r, depth) == RAD_OK);
    rad_mesh leaves, mesh;
    rad_mesh_options mo = {.subdiv = (int)depth, .contacts = RAD_MESH_CONTACTS_KEEP};
    RAD_CHECK(rad_hierarchy_leaves(&h, &leaves) == RAD_OK);
    RAD_CHECK(rad_mesh_build(scene, &mo, &mesh) == RAD_OK);
    RAD_CHECK(leaves.patch_count == mesh.patch_count && h.leaf_count == mesh.patch_count);
    /* Every vertex a leaf uses, once: the mesh's count (it keeps no other). */
    RAD_CHECK(h.vertex_count == mesh.vertex_count);
    int mismatched = 0;
    for (size_t i = 0; i < mesh.patch_count && i < leaves.patch_count; i++) {
        const rad_patch *a = &leaves.patches[i], *b = &mesh.patches[i];
        int same = a->vertex_count == b->vertex_count && a->source_face == b->source_face && a->area == b->area &&
                   same_vec(a->normal, b->normal) && same_vec(a->centroid, b->centroid) &&
                   memcmp(a->rho, b->rho, sizeof a->rho) == 0 && memcmp(a->emission, b->emission, sizeof a->emission) == 0 &&
                   leaves.patch_group[i] == mesh.patch_group[i];
        for (uint32_t k = 0; same && k < a->vertex_count; k++) same = same_point(&leaves, a->v[k], &mesh, b->v[k]);
        /* Two corners are one vertex in both or in neither. */
        for (uint32_t k = 0; same && k < a->vertex_count; k++)
            for (uint32_t l = 0; same && l < a->vertex_count; l++) same = (a->v[k] == a->v[l]) == (b->v[k] == b->v[l]);
        mismatched += !same;
    }
    if (mismatched) fprintf(stderr, "depth %u: %d of %zu leaves differ from the mesh's patches\n", depth, mismatched,
                            mesh.patch_count);
    RAD_CHECK(mismatched == 0);
    RAD_CHECK(leaves.group_count == mesh.group_count);
    for (size_t g = 0; g < mesh.group_count && g < leaves.group_count; g++)
        RAD_CHECK(strcmp(leaves.group_names[g], mesh.group_names[g]) == 0);
    rad_mesh_free(&leaves);
    rad_mesh_free(&mesh);
    rad_hierarchy_free(&h);
}

static void test_uniform(const char *path, uint32_t max_depth)
{
    rad_scene scene;
    rad_status st = path ? rad_scene_load_file(path, NULL, &scene) : rad_scene_load_default(&scene);
    RAD_CHECK(st == RAD_OK);
    if (st != RAD_OK) return;
    rad_mesh base;
    rad_mesh_options mo = {.subdiv = 0, .contacts = RAD_MESH_CONTACTS_KEEP};
    RAD_CHECK(rad_mesh_build(&scene, &mo, &base) == RAD_OK);
    for (uint32_t d = 0; d <= max_depth; d++) check_uniform(&scene, &base, d);
    rad_mesh_free(&base);
    rad_scene_free(&scene);
}

/* Two unit squares sharing the edge x = 1, split lazily. */
static void test_lazy(void)
{
    double positions[] = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0, 2, 0, 0, 2, 1, 0};
    rad_patch patches[2];
    memset(patches, 0, sizeof patches);
    const uint32_t corners[2][4] = {{0, 1, 2, 3}, {1, 4, 5, 2}};
    for (int p = 0; p < 2; p++) {
        patches[p].vertex_count = 4;
        memcpy(patches[p].v, corners[p], sizeof corners[p]);
        patches[p].source_face = (uint32_t)p;
        patches[p].area = 1.0;
        patches[p].normal = rad_v3(0, 0, 1);
        patches[p].centroid = rad_v3(0.5 + p, 0.5, 0);
        patches[p].rho[0] = 0.5;
    }
    rad_mesh base = {positions, 6, patches, 2, NULL, 0, NULL};
    rad_hierarchy h;
    RAD_CHECK(rad_hierarchy_init(&base, &h) == RAD_OK);
    RAD_CHECK(h.element_count == 2 && h.leaf_count == 2 && h.vertex_count == 6);
    uint32_t first, again;
    RAD_CHECK(rad_hierarchy_split(&h, 0, &first) == RAD_OK && first == 2);
    RAD_CHECK(h.vertex_count == 11); /* 4 midpoints and a centre */
    RAD_CHECK(rad_hierarchy_split(&h, 0, &again) == RAD_OK && again == first && h.element_count == 6);
    uint32_t second;
    RAD_CHECK(rad_hierarchy_split(&h, 1, &second) == RAD_OK && second == 6);
    RAD_CHECK(h.vertex_count == 15); /* the shared edge's midpoint is made once */
    RAD_CHECK(h.leaf_count == 8);
    double area = 0.0;
    for (uint32_t i = 0; i < 4; i++) {
        const rad_element *c = &h.elements[first + i];
        RAD_CHECK(c->parent == 0 && c->root == 0 && c->level == 1 && c->first_child == RAD_NO_ELEMENT);
        RAD_CHECK(same_vec(c->normal, rad_v3(0, 0, 1)));
        area += c->area;
    }
    RAD_CHECK(area == 1.0);
    /* Deeper, on one branch only: leaves 8 - 1 + 4 per split. */
    uint32_t e = first + 2;
    for (int level = 2; level <= 12; level++) {
        uint32_t c;
        RAD_CHECK(rad_hierarchy_split(&h, e, &c) == RAD_OK);
        RAD_CHECK(h.elements[c].level == (uint32_t)level && h.elements[c].root == 0 && h.elements[c].parent == e);
        e = c + 3;
    }
    RAD_CHECK(h.leaf_count == 8 + 11 * 3);
    rad_test_capture_log();
    RAD_CHECK(rad_hierarchy_split(&h, (uint32_t)h.element_count, &first) == RAD_ERR_INVALID);
    RAD_CHECK(rad_test_log_contains("hierarchy: element 54 of 54"));
    rad_log_set_sink(NULL, NULL);
    rad_mesh leaves;
    RAD_CHECK(rad_hierarchy_leaves(&h, &leaves) == RAD_OK);
    RAD_CHECK(leaves.patch_count == h.leaf_count && leaves.group_count == 0 && leaves.patch_group == NULL);
    double total = 0.0;
    for (size_t i = 0; i < leaves.patch_count; i++) {
        total += leaves.patches[i].area;
        RAD_CHECK(leaves.patches[i].rho[0] == 0.5);
    }
    RAD_CHECK_NEAR(total, 2.0, 1e-14);
    rad_mesh_free(&leaves);
    rad_hierarchy_free(&h);
    rad_hierarchy_free(&h); /* safe twice */
    /* A base patch that is not a triangle or quad. */
    rad_test_capture_log();
    patches[1].vertex_count = 5;
    RAD_CHECK(rad_hierarchy_init(&base, &h) == RAD_ERR_INVALID && h.elements == NULL);
    RAD_CHECK(rad_test_log_contains("patch 1 of the base mesh is not a triangle or quad"));
    rad_log_set_sink(NULL, NULL);
}

int main(void)
{
    test_lazy();
    test_uniform(NULL, 5); /* the built-in Cornell box: 32 768 leaves at depth 5 grow the midpoint table */
    test_uniform(RAD_SCENES "/cluttered_room.obj", 3);
    test_uniform(RAD_SCENES "/cornell_sphere.obj", 2);
    return rad_test_finish();
}
