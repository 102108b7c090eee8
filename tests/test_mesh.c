/* test_mesh.c - the patch mesh: polygon geometry, 4^S patches per face,
 * shared vertices (within a face and across faces), conserved areas and
 * centroids, normals and materials carried over, only_group, the limits. */
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "rad_mesh.h"
#include "rad_scene.h"
#include "rad_test.h"

static void test_polygon_geometry(void)
{
    double area;
    rad_vec3 n, c;
    rad_vec3 square[4] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
    rad_polygon_geometry(square, 4, &area, &n, &c);
    RAD_CHECK_NEAR(area, 1.0, 1e-15);
    RAD_CHECK_NEAR(n.z, 1.0, 1e-15);
    RAD_CHECK_NEAR(c.x, 0.5, 1e-15);
    RAD_CHECK_NEAR(c.y, 0.5, 1e-15);
    /* Trapezoid, bases 4 (y = 0) and 2 (y = 2): area 6, centroid height
     * h (b1 + 2 b2) / (3 (b1 + b2)) = 8/9 (the vertex mean would give 1). */
    rad_vec3 trap[4] = {{0, 0, 5}, {4, 0, 5}, {3, 2, 5}, {1, 2, 5}};
    rad_polygon_geometry(trap, 4, &area, &n, &c);
    RAD_CHECK_NEAR(area, 6.0, 1e-14);
    RAD_CHECK_NEAR(c.x, 2.0, 1e-14);
    RAD_CHECK_NEAR(c.y, 8.0 / 9.0, 1e-14);
    RAD_CHECK_NEAR(c.z, 5.0, 1e-14);
    /* Clockwise triangle in the x-y plane: normal -z. */
    rad_vec3 tri[3] = {{0, 0, 0}, {0, 3, 0}, {3, 0, 0}};
    rad_polygon_geometry(tri, 3, &area, &n, &c);
    RAD_CHECK_NEAR(area, 4.5, 1e-15);
    RAD_CHECK_NEAR(n.z, -1.0, 1e-15);
    RAD_CHECK_NEAR(c.x, 1.0, 1e-15);
    RAD_CHECK_NEAR(c.y, 1.0, 1e-15);
    /* A tilted quad: normal (0, -1, 1)/sqrt 2, area sqrt 2. */
    rad_vec3 tilt[4] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 1}, {0, 1, 1}};
    rad_polygon_geometry(tilt, 4, &area, &n, &c);
    RAD_CHECK_NEAR(area, sqrt(2.0), 1e-15);
    RAD_CHECK_NEAR(n.y, -sqrt(0.5), 1e-15);
    RAD_CHECK_NEAR(n.z, sqrt(0.5), 1e-15);
}

/* A hand-made scene (no loader): `positions` has `nv` vertices; faces are
 * given as rows of 4 indices (-1 in the last for a triangle). */
typedef struct test_scene {
    rad_scene scene;
    rad_face faces[8];
    rad_material materials[2];
    char groups[2][RAD_NAME_MAX];
} test_scene;

static void make_scene(test_scene *t, const double *positions, size_t nv, const int (*faces)[4], size_t nf)
{
    memset(t, 0, sizeof *t);
    t->scene.positions = (double *)positions;
    t->scene.vertex_count = nv;
    for (size_t f = 0; f < nf; f++) {
        rad_face *face = &t->faces[f];
        face->vertex_count = faces[f][3] < 0 ? 3 : 4;
        for (uint32_t i = 0; i < face->vertex_count; i++) face->v[i] = (uint32_t)faces[f][i];
        face->material = 1;
        face->group = f == 0 ? 1 : 0;
    }
    t->scene.faces = t->faces;
    t->scene.face_count = nf;
    t->materials[0] = (rad_material){.name = "default", .rho = {0.5, 0.5, 0.5}};
    t->materials[1] = (rad_material){.name = "m", .rho = {0.1, 0.2, 0.3}, .emission = {4, 5, 6}};
    t->scene.materials = t->materials;
    t->scene.material_count = 2;
    strcpy(t->groups[0], "default");
    strcpy(t->groups[1], "first");
    t->scene.groups = t->groups;
    t->scene.group_count = 2;
}

/* Builds at level S; checks counts, and returns the mesh (caller frees).
 * build_whole: the same with the faces kept whole (no contact cutting). */
static void build_with(const rad_scene *scene, int subdiv, const char *only_group, rad_mesh_contacts contacts,
                       size_t patches, size_t vertices, rad_mesh *mesh)
{
    rad_mesh_options opt = {.subdiv = subdiv, .only_group = only_group, .contacts = contacts};
    RAD_CHECK(rad_mesh_count_patches(scene, &opt) == patches);
    RAD_CHECK(rad_mesh_build(scene, &opt, mesh) == RAD_OK);
    RAD_CHECK(mesh->patch_count == patches);
    if (vertices && mesh->vertex_count != vertices) {
        fprintf(stderr, "S=%d: %zu vertices, expected %zu\n", subdiv, mesh->vertex_count, vertices);
        rad_test_failures++;
    }
}

static void build(const rad_scene *scene, int subdiv, const char *only_group, size_t patches, size_t vertices, rad_mesh *mesh)
{
    build_with(scene, subdiv, only_group, RAD_MESH_CONTACTS_CUT, patches, vertices, mesh);
}

static void build_whole(const rad_scene *scene, int subdiv, const char *only_group, size_t patches, size_t vertices,
                        rad_mesh *mesh)
{
    build_with(scene, subdiv, only_group, RAD_MESH_CONTACTS_KEEP, patches, vertices, mesh);
}

static void test_shared_vertices(void)
{
    /* Two unit squares sharing the edge x = 1, and a triangle on top of the
     * first sharing its edge y = 1; vertex 6 is unused. */
    static const double pos[] = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0, 2, 0, 0, 2, 1, 0, 9, 9, 9, 0.5, 2, 0};
    static const int quad[][4] = {{0, 1, 2, 3}};
    static const int two_quads[][4] = {{0, 1, 2, 3}, {1, 4, 5, 2}};
    static const int tri[][4] = {{3, 2, 7, -1}};
    static const int quad_tri[][4] = {{0, 1, 2, 3}, {3, 2, 7, -1}};
    test_scene t;
    rad_mesh m;
    make_scene(&t, pos, 8, quad, 1);
    build(&t.scene, 0, NULL, 1, 4, &m);
    rad_mesh_free(&m);
    build(&t.scene, 1, NULL, 4, 9, &m);
    rad_mesh_free(&m);
    build(&t.scene, 2, NULL, 16, 25, &m);
    rad_mesh_free(&m);
    build(&t.scene, 5, NULL, 1024, 33 * 33, &m);
    rad_mesh_free(&m);
    make_scene(&t, pos, 8, two_quads, 2);
    build(&t.scene, 1, NULL, 8, 15, &m);
    rad_mesh_free(&m);
    build(&t.scene, 2, NULL, 32, 9 * 5, &m);
    rad_mesh_free(&m);
    build(&t.scene, 2, "first", 17, 25 + 2, &m); /* the second quad is one patch, adds 2 corners */
    rad_mesh_free(&m);
    make_scene(&t, pos, 8, tri, 1);
    build(&t.scene, 1, NULL, 4, 6, &m);
    for (size_t p = 0; p < m.patch_count; p++) RAD_CHECK(m.patches[p].vertex_count == 3 && m.patches[p].v[3] == RAD_NO_VERTEX);
    rad_mesh_free(&m);
    build(&t.scene, 3, NULL, 64, 45, &m);
    rad_mesh_free(&m);
    make_scene(&t, pos, 8, quad_tri, 2);
    build(&t.scene, 1, NULL, 8, 9 + 6 - 3, &m);
    rad_mesh_free(&m);
    build(&t.scene, 2, NULL, 32, 25 + 15 - 5, &m);
    /* Every patch vertex is one of the grid's: no two vertices coincide. */
    for (size_t i = 0; i < m.vertex_count; i++)
        for (size_t j = i + 1; j < m.vertex_count; j++)
            RAD_CHECK(memcmp(m.positions + 3 * i, m.positions + 3 * j, 3 * sizeof(double)) != 0);
    rad_mesh_free(&m);
    rad_mesh_free(&m); /* safe twice */
}

/* The invariants every mesh must satisfy against its scene. */
static void check_mesh(const rad_scene *s, const rad_mesh *m)
{
    size_t p = 0;
    for (size_t f = 0; f < s->face_count; f++) {
        const rad_face *face = &s->faces[f];
        rad_vec3 corner[4], fn, fc, weighted = rad_v3(0, 0, 0);
        double fa, sum = 0;
        for (uint32_t i = 0; i < face->vertex_count; i++) {
            const double *q = s->positions + 3 * (size_t)face->v[i];
            corner[i] = rad_v3(q[0], q[1], q[2]);
        }
        rad_polygon_geometry(corner, (int)face->vertex_count, &fa, &fn, &fc);
        double size = sqrt(fa);
        const rad_material *mat = &s->materials[face->material];
        size_t first = p;
        for (; p < m->patch_count && m->patches[p].source_face == f; p++) {
            const rad_patch *patch = &m->patches[p];
            RAD_CHECK(patch->vertex_count == face->vertex_count);
            RAD_CHECK_NEAR(rad_v3_dot(patch->normal, fn), 1.0, 1e-12);
            RAD_CHECK_NEAR(rad_v3_length(patch->normal), 1.0, 1e-15);
            for (uint32_t i = 0; i < patch->vertex_count; i++) {
                RAD_CHECK(patch->v[i] < m->vertex_count);
                const double *q = m->positions + 3 * (size_t)patch->v[i];
                RAD_CHECK_NEAR(rad_v3_dot(rad_v3_sub(rad_v3(q[0], q[1], q[2]), fc), fn), 0.0, 1e-12 * size);
            }
            RAD_CHECK(patch->vertex_count == 4 || patch->v[3] == RAD_NO_VERTEX);
            for (int c = 0; c < 3; c++) {
                RAD_CHECK(patch->rho[c] == mat->rho[c] && patch->emission[c] == mat->emission[c]);
            }
            sum += patch->area;
            weighted = rad_v3_add(weighted, rad_v3_scale(patch->centroid, patch->area));
        }
        RAD_CHECK(p > first); /* faces come in order, each with its patches */
        for (size_t k = first; k < p && m->group_count; k++) /* each patch in its face's group */
            RAD_CHECK(m->patch_group[k] < m->group_count &&
                      strcmp(m->group_names[m->patch_group[k]], s->groups[face->group]) == 0);
        RAD_CHECK_REL(sum, fa, 1e-12);
        RAD_CHECK_NEAR(rad_v3_length(rad_v3_sub(rad_v3_scale(weighted, 1.0 / sum), fc)), 0.0, 1e-12 * size + 1e-12);
    }
    RAD_CHECK(p == m->patch_count);
    /* Groups: those that own a face, each once, in the scene's order. */
    size_t used = 0, last = 0;
    for (size_t g = 0; g < s->group_count; g++) {
        int owns = 0;
        for (size_t f = 0; f < s->face_count && !owns; f++) owns = s->faces[f].group == g;
        if (!owns) continue;
        RAD_CHECK(used < m->group_count && strcmp(m->group_names[used], s->groups[g]) == 0);
        RAD_CHECK(used == 0 || g > last);
        last = g;
        used++;
    }
    RAD_CHECK(m->group_count == used && used > 0 && m->patch_group != NULL);
}

static void test_scenes(void)
{
    rad_scene box, sphere;
    rad_mesh m;
    RAD_CHECK(rad_scene_load_file(RAD_SCENES "/cornell_box.obj", NULL, &box) == RAD_OK);
    RAD_CHECK(rad_scene_load_file(RAD_SCENES "/cornell_sphere.obj", NULL, &sphere) == RAD_OK);
    /* The Cornell box's faces whole (--contacts keep): its blocks stand on
     * the floor, so cut (the default, test_contact.c) the floor is pieces. */
    for (int S = 0; S <= 4; S++) {
        size_t per = (size_t)1 << (2 * S);
        build_whole(&box, S, NULL, 20 * per, 0, &m);
        check_mesh(&box, &m);
        if (S == 2) {
            /* Shared midpoints across faces: no two mesh vertices coincide. */
            for (size_t i = 0; i < m.vertex_count; i++)
                for (size_t j = i + 1; j < m.vertex_count; j++)
                    RAD_CHECK(memcmp(m.positions + 3 * i, m.positions + 3 * j, 3 * sizeof(double)) != 0);
        }
        rad_mesh_free(&m);
        build(&sphere, S, NULL, 46 * per, 0, &m);
        check_mesh(&sphere, &m);
        rad_mesh_free(&m);
    }
    /* The paper's counts: its code subdivided only the box (424), the text
     * claims all 46 faces (2944). */
    build(&sphere, 3, "box", 424, 0, &m);
    check_mesh(&sphere, &m);
    RAD_CHECK(m.group_count == 2 && strcmp(m.group_names[0], "box") == 0 && strcmp(m.group_names[1], "sphere") == 0);
    rad_mesh_free(&m);
    /* The Cornell box's eight objects; "default" (no face) is left out. */
    build_whole(&box, 0, NULL, 20, 0, &m);
    static const char *const objects[] = {"floor", "ceiling", "light", "back_wall", "green_wall", "red_wall",
                                          "short_block", "tall_block"};
    RAD_CHECK(m.group_count == 8);
    for (size_t g = 0; g < 8 && g < m.group_count; g++) RAD_CHECK(strcmp(m.group_names[g], objects[g]) == 0);
    rad_mesh_free(&m);
    build(&sphere, 3, NULL, 2944, 0, &m);
    rad_mesh_free(&m);
    build(&sphere, 1, "sphere", 6 + 160, 0, &m);
    rad_mesh_free(&m);
    /* closed box at S=1: a cube's surface as a 3x3 grid per face shares
     * everything: 6*9 - 12*3 + 8 = 26 vertices. */
    rad_scene cube;
    RAD_CHECK(rad_scene_load_file(RAD_SCENES "/closed_box.obj", NULL, &cube) == RAD_OK);
    build(&cube, 1, NULL, 24, 26, &m);
    check_mesh(&cube, &m);
    rad_mesh_free(&m);
    build(&cube, 3, NULL, 384, 6 * 81 - 12 * 9 + 8, &m);
    rad_mesh_free(&m);
    /* A group no face is in: a warning, nothing subdivided. */
    rad_test_capture_log();
    build(&cube, 2, "nope", 6, 8, &m);
    RAD_CHECK(rad_test_log_contains("mesh: no face is in group 'nope'"));
    rad_log_set_sink(NULL, NULL);
    rad_mesh_free(&m);
    rad_scene_free(&cube);
    rad_scene_free(&box);
    rad_scene_free(&sphere);
}

static void test_limits(void)
{
    static const double pos[] = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0, 2, 0, 0, 2, 1, 0};
    static const int quad[][4] = {{0, 1, 2, 3}};
    /* Side by side (a face given twice would count once: contact cutting
     * keeps one copy of coplanar overlapping faces). */
    static const int two[][4] = {{0, 1, 2, 3}, {1, 4, 5, 2}};
    test_scene t;
    rad_mesh m = {0};
    make_scene(&t, pos, 6, quad, 1);
    rad_mesh_options opt = {.subdiv = 16};
    RAD_CHECK(rad_mesh_count_patches(&t.scene, &opt) == UINT64_C(4294967296));
    rad_test_capture_log();
    RAD_CHECK(rad_mesh_build(&t.scene, &opt, &m) == RAD_ERR_NOMEM);
    RAD_CHECK(rad_test_log_contains("mesh: subdivision level 16 gives 4294967296 patches; at most 4294967294 are possible"));
    RAD_CHECK(rad_test_log_contains("(it would need about 512.0 GiB)"));
    RAD_CHECK(m.patches == NULL && m.patch_count == 0);
    opt.subdiv = 40; /* 4^40 saturates */
    RAD_CHECK(rad_mesh_count_patches(&t.scene, &opt) == UINT64_MAX);
    RAD_CHECK(rad_mesh_build(&t.scene, &opt, &m) == RAD_ERR_NOMEM);
    make_scene(&t, pos, 6, two, 2);
    opt.subdiv = 15;
    RAD_CHECK(rad_mesh_count_patches(&t.scene, &opt) == UINT64_C(2147483648));
    opt.only_group = "first";
    opt.subdiv = 40; /* only the first face: still saturated */
    RAD_CHECK(rad_mesh_count_patches(&t.scene, &opt) == UINT64_MAX);
    opt.subdiv = -1;
    RAD_CHECK(rad_mesh_count_patches(&t.scene, &opt) == 0);
    RAD_CHECK(rad_mesh_build(&t.scene, &opt, &m) == RAD_ERR_INVALID);
    RAD_CHECK(rad_test_log_contains("mesh: subdivision level -1 is negative"));
    rad_log_set_sink(NULL, NULL);
    /* NULL options: the faces as patches. */
    RAD_CHECK(rad_mesh_count_patches(&t.scene, NULL) == 2);
    RAD_CHECK(rad_mesh_build(&t.scene, NULL, &m) == RAD_OK && m.patch_count == 2 && m.vertex_count == 6);
    rad_mesh_free(&m);
}

int main(void)
{
    test_polygon_geometry();
    test_shared_vertices();
    test_scenes();
    test_limits();
    return rad_test_finish();
}
