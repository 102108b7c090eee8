/* test_contact.c - contact cutting (core/rad_contact.h) through the patch
 * mesh: the Cornell box's floor loses exactly the blocks' footprints, no
 * patch lies in one, patch counts at --subdiv 0/2/3 (cut and keep), shared
 * cut vertices, pieces' levels; the contact room (tests/data): the cube's
 * bottom pressed on the floor and the wall inside the slab are dropped;
 * scenes without contacts come out as before. Row sums are checked through
 * formfactor in contact_closure.py. */
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "rad_contact.h"
#include "rad_mesh.h"
#include "rad_scene.h"
#include "rad_test.h"

/* The blocks' bottom corners (x, z) as scenes/cornell_box.obj gives them
 * (vertices 17-20 and 25-28, y = 0). */
static const double short_footprint[4][2] = {{130, 65}, {82, 225}, {240, 272}, {290, 114}};
static const double tall_footprint[4][2] = {{423, 247}, {265, 296}, {314, 456}, {472, 406}};
#define CORNELL_FLOOR_AREA 308231.04 /* mm^2, scenes/README.md */

static double shoelace(const double (*p)[2], int n)
{
    double twice = 0;
    for (int i = 0; i < n; i++) twice += p[i][0] * p[(i + 1) % n][1] - p[(i + 1) % n][0] * p[i][1];
    return 0.5 * fabs(twice);
}

/* Strictly inside the convex polygon p (either winding), by 1e-9 of its size. */
static int inside_footprint(const double (*p)[2], int n, double x, double z)
{
    int pos = 0, neg = 0;
    for (int i = 0; i < n; i++) {
        const double *a = p[i], *b = p[(i + 1) % n];
        double cross = (b[0] - a[0]) * (z - a[1]) - (b[1] - a[1]) * (x - a[0]);
        pos += cross > 1e-9 * 1e3, neg += cross < -1e-9 * 1e3;
    }
    return pos == n || neg == n;
}

static size_t group_index(const rad_mesh *m, const char *name)
{
    for (size_t g = 0; g < m->group_count; g++)
        if (strcmp(m->group_names[g], name) == 0) return g;
    return SIZE_MAX;
}

/* How many mesh vertices lie exactly at p. */
static size_t vertices_at(const rad_mesh *m, double x, double y, double z)
{
    size_t count = 0;
    for (size_t v = 0; v < m->vertex_count; v++)
        count += m->positions[3 * v] == x && m->positions[3 * v + 1] == y && m->positions[3 * v + 2] == z;
    return count;
}

static int patch_uses(const rad_mesh *m, const rad_patch *p, double x, double y, double z)
{
    for (uint32_t k = 0; k < p->vertex_count; k++) {
        const double *q = m->positions + 3 * (size_t)p->v[k];
        if (q[0] == x && q[1] == y && q[2] == z) return 1;
    }
    return 0;
}

static void test_cornell_box(void)
{
    rad_scene scene;
    RAD_CHECK(rad_scene_load_default(&scene) == RAD_OK);
    /* Patch counts: keep = 20 x 4^S; cut: the other 19 faces as before,
     * and the floor's grid (1, 16, 64 cells at S = 0, 2, 3) cut along the
     * blocks' 8 footprint edges, less what lies under them: 10, 29, 78
     * patches (at S = 0: 12 pieces, 2 of them the footprints). */
    static const struct { int subdiv; rad_mesh_contacts contacts; size_t patches; } counts[] = {
        {0, RAD_MESH_CONTACTS_KEEP, 20}, {2, RAD_MESH_CONTACTS_KEEP, 320}, {3, RAD_MESH_CONTACTS_KEEP, 1280},
        {0, RAD_MESH_CONTACTS_CUT, 29},  {2, RAD_MESH_CONTACTS_CUT, 333},  {3, RAD_MESH_CONTACTS_CUT, 1294},
    };
    double visible = CORNELL_FLOOR_AREA - shoelace(short_footprint, 4) - shoelace(tall_footprint, 4);
    RAD_CHECK_NEAR(shoelace(short_footprint, 4), 27633.0, 1e-9);
    RAD_CHECK_NEAR(shoelace(tall_footprint, 4), 27626.5, 1e-9);
    for (size_t c = 0; c < sizeof counts / sizeof counts[0]; c++) {
        rad_mesh_options opt = {.subdiv = counts[c].subdiv, .contacts = counts[c].contacts};
        rad_mesh m;
        RAD_CHECK(rad_mesh_count_patches(&scene, &opt) == counts[c].patches);
        RAD_CHECK(rad_mesh_build(&scene, &opt, &m) == RAD_OK);
        if (m.patch_count != counts[c].patches) {
            fprintf(stderr, "cornell_box --subdiv %d --contacts %s: %zu patches, expected %zu\n", counts[c].subdiv,
                    counts[c].contacts == RAD_MESH_CONTACTS_CUT ? "cut" : "keep", m.patch_count, counts[c].patches);
            rad_test_failures++;
        }
        size_t floor = group_index(&m, "floor");
        RAD_CHECK(floor != SIZE_MAX);
        double area = 0;
        size_t in_footprint = 0;
        for (size_t p = 0; p < m.patch_count; p++) {
            const rad_patch *q = &m.patches[p];
            RAD_CHECK(q->vertex_count == 3 || q->vertex_count == 4);
            RAD_CHECK(q->source_face < scene.face_count);
            RAD_CHECK(rad_patch_centroid_inside(q, m.positions));
            if (m.patch_group[p] != floor) continue;
            RAD_CHECK(q->source_face == 0 && q->normal.y > 1 - 1e-12);
            area += q->area;
            in_footprint += inside_footprint(short_footprint, 4, q->centroid.x, q->centroid.z) ||
                            inside_footprint(tall_footprint, 4, q->centroid.x, q->centroid.z);
        }
        if (counts[c].contacts == RAD_MESH_CONTACTS_CUT) {
            /* The visible floor: the floor less the footprints, to 1e-9. */
            RAD_CHECK_REL(area, visible, 1e-9);
            RAD_CHECK(in_footprint == 0);
            /* Each footprint corner is one vertex, shared by the floor's
             * pieces and the block's sides. */
            for (int b = 0; b < 2; b++)
                for (int k = 0; k < 4; k++) {
                    const double *xz = b ? tall_footprint[k] : short_footprint[k];
                    RAD_CHECK(vertices_at(&m, xz[0], 0, xz[1]) == 1);
                    int on_floor = 0, on_side = 0;
                    for (size_t p = 0; p < m.patch_count; p++)
                        if (patch_uses(&m, &m.patches[p], xz[0], 0, xz[1])) {
                            if (m.patch_group[p] == floor)
                                on_floor = 1;
                            else
                                on_side = 1;
                        }
                    RAD_CHECK(on_floor && on_side);
                }
            if (counts[c].subdiv == 0) /* pieces share their cut vertices: no position twice */
                for (size_t v = 0; v < m.vertex_count; v++)
                    RAD_CHECK(vertices_at(&m, m.positions[3 * v], m.positions[3 * v + 1], m.positions[3 * v + 2]) == 1);
        } else {
            RAD_CHECK_REL(area, CORNELL_FLOOR_AREA, 1e-12);
            RAD_CHECK(counts[c].subdiv == 0 || in_footprint > 0); /* patches run under the blocks */
        }
        rad_mesh_free(&m);
    }
    rad_scene_free(&scene);
}

/* The room of tests/data/contact_room.obj: its pieces, and a piece's
 * level by its size. */
static void test_contact_room(void)
{
    rad_scene scene;
    rad_scene_options so = {0};
    RAD_CHECK(rad_scene_load_file(RAD_TEST_DATA "/contact_room.obj", &so, &scene) == RAD_OK);
    rad_contact_cut cut;
    RAD_CHECK(rad_contact_cut_build(&scene, NULL, &cut) == RAD_OK);
    /* Cut: the floor (two footprints), the x = 1 wall (the slab's
     * cross-section) and the slab's 4 faces through it. Hidden: the floor
     * under each cube, the cube's bottom, the wall inside the slab. */
    RAD_CHECK(cut.faces_cut == 6);
    RAD_CHECK(cut.pieces_hidden == 4);
    size_t per_face[64] = {0};
    RAD_CHECK(scene.face_count == 23);
    for (size_t i = 0; i < cut.piece_count; i++) {
        RAD_CHECK(i == 0 || cut.pieces[i].source_face >= cut.pieces[i - 1].source_face);
        per_face[cut.pieces[i].source_face]++;
    }
    RAD_CHECK(per_face[6] == 0); /* the cube's bottom, pressed on the floor */
    for (size_t f = 0; f < scene.face_count; f++) RAD_CHECK(f == 6 || per_face[f] >= 1);
    RAD_CHECK(per_face[1] == 1 && per_face[2] == 1); /* ceiling and a wall: no contact */
    /* Uncut faces keep their scene vertices. */
    for (size_t i = 0; i < cut.piece_count; i++)
        if (per_face[cut.pieces[i].source_face] == 1)
            for (uint32_t k = 0; k < cut.pieces[i].vertex_count; k++)
                RAD_CHECK(cut.pieces[i].v[k] == scene.faces[cut.pieces[i].source_face].v[k]);
    rad_contact_cut_free(&cut);
    rad_contact_cut_free(&cut); /* safe twice */

    /* Levels: at --subdiv 3 a piece of half its face's diameter gets level 2. */
    rad_mesh_options opt = {.subdiv = 3};
    rad_mesh m;
    RAD_CHECK(rad_mesh_build(&scene, &opt, &m) == RAD_OK);
    double face_patch = 1.0 / 64; /* a room face's patch at level 3 */
    for (size_t p = 0; p < m.patch_count; p++)
        if (m.patches[p].source_face == 0) /* floor pieces: patches within 4x of the face's own */
            RAD_CHECK(m.patches[p].area <= 4 * face_patch && m.patches[p].area >= face_patch / 16);
    rad_mesh_free(&m);
    rad_scene_free(&scene);
}

/* Scenes without contacts: cut = keep, patch for patch. */
/* The cluttered room's light panel hangs 1 cm under the ceiling, facing
 * down like the ceiling: the ceiling behind it is shut in (gap contact,
 * RAD_CONTACT_GAP) and gets no patches; the rest of the ceiling keeps
 * 100 - 4 m^2. Kept whole, the ceiling's patches straddle the panel's
 * outline. */
static void test_gap_contact(void)
{
    rad_scene scene;
    rad_scene_options so = {0};
    RAD_CHECK(rad_scene_load_file(RAD_SCENES "/cluttered_room.obj", &so, &scene) == RAD_OK);
    for (int keep = 0; keep < 2; keep++) {
        rad_mesh m;
        rad_mesh_options mo = {.subdiv = 2, .contacts = keep ? RAD_MESH_CONTACTS_KEEP : RAD_MESH_CONTACTS_CUT};
        RAD_CHECK(rad_mesh_build(&scene, &mo, &m) == RAD_OK);
        size_t ceiling = group_index(&m, "ceiling"), behind = 0;
        double area = 0.0;
        for (size_t i = 0; i < m.patch_count; i++) {
            if (m.patch_group[i] != ceiling) continue;
            const rad_patch *p = &m.patches[i];
            area += p->area;
            behind += p->centroid.x > 4 && p->centroid.x < 6 && p->centroid.z > 4 && p->centroid.z < 6;
        }
        if (keep) {
            RAD_CHECK_REL(area, 100.0, 1e-12);
        } else {
            RAD_CHECK(behind == 0);
            RAD_CHECK_REL(area, 96.0, 1e-9);
            RAD_CHECK(m.patch_count == 3088); /* 3084 with the floor cut alone */
        }
        rad_mesh_free(&m);
    }
    rad_scene_free(&scene);
}

/* A double-sided panel (two coincident faces, back to back) is coplanar
 * with a face of opposite facing, but open on both sides: both faces keep
 * their patches. (A box's bottom on the floor, whose back is inside the
 * box, goes: test_contact_room.) */
static void test_double_sided_panel(void)
{
    rad_scene scene;
    rad_scene_options so = {0};
    RAD_CHECK(rad_scene_load_file(RAD_TEST_DATA "/double_sided_room.obj", &so, &scene) == RAD_OK);
    rad_mesh m;
    rad_mesh_options mo = {.subdiv = 1};
    RAD_CHECK(rad_mesh_build(&scene, &mo, &m) == RAD_OK);
    size_t a = group_index(&m, "panel_a"), b = group_index(&m, "panel_b");
    double area_a = 0.0, area_b = 0.0;
    for (size_t i = 0; i < m.patch_count; i++) {
        if (m.patch_group[i] == a) area_a += m.patches[i].area;
        if (m.patch_group[i] == b) area_b += m.patches[i].area;
    }
    RAD_CHECK_REL(area_a, 0.36, 1e-12);
    RAD_CHECK_REL(area_b, 0.36, 1e-12);
    rad_mesh_free(&m);
    rad_scene_free(&scene);
}

/* Coplanar faces of the same facing that overlap: the smaller wins where
 * they do (a panel snapped onto a floor), the later on a tie (a surface
 * given twice); side by side, nothing is cut. */
static const char *const overlap_obj =
    "mtllib s.mtl\nusemtl grey\n"
    "o panel\nv 0.5 0 0.5\nv 0.5 0 1\nv 1 0 1\nv 1 0 0.5\nf 1 2 3 4\n"
    "o floor\nv 0 0 0\nv 0 0 2\nv 2 0 2\nv 2 0 0\nf 5 6 7 8\n"
    "o dup_a\nv 3 0 0\nv 3 0 1\nv 4 0 1\nv 4 0 0\nf 9 10 11 12\n"
    "o dup_b\nf 9 10 11 12\n"
    "o beside\nv 3 0 2\nv 3 0 0\nf 7 13 14\nf 7 14 8\n";

/* A scene read from memory: `user` is the OBJ's text; every .mtl is one grey. */
static rad_status text_read(const char *path, char **out_data, size_t *out_size, void *user)
{
    const char *text = strstr(path, ".mtl") ? "newmtl grey\nKd 0.5 0.5 0.5\n" : (const char *)user;
    *out_size = strlen(text);
    *out_data = malloc(*out_size + 1);
    if (!*out_data) return RAD_ERR_NOMEM;
    memcpy(*out_data, text, *out_size + 1);
    return RAD_OK;
}

static void test_coplanar_overlap(void)
{
    rad_scene scene;
    rad_scene_options so = {.read_file = text_read, .read_file_user = (void *)overlap_obj};
    RAD_CHECK(rad_scene_load_file("overlap.obj", &so, &scene) == RAD_OK);
    rad_mesh m;
    rad_mesh_options mo = {.subdiv = 1};
    RAD_CHECK(rad_mesh_build(&scene, &mo, &m) == RAD_OK);
    const char *names[] = {"panel", "floor", "dup_a", "dup_b", "beside"};
    const double expect[] = {0.25, 4.0 - 0.25, 0.0, 1.0, 2.0};
    for (int k = 0; k < 5; k++) {
        size_t g = group_index(&m, names[k]);
        double area = 0.0;
        for (size_t i = 0; g != SIZE_MAX && i < m.patch_count; i++)
            if (m.patch_group[i] == g) area += m.patches[i].area;
        if (fabs(area - expect[k]) > 1e-12) fprintf(stderr, "%s: area %.17g, expected %g\n", names[k], area, expect[k]);
        RAD_CHECK_NEAR(area, expect[k], 1e-12);
    }
    rad_mesh_free(&m);
    rad_scene_free(&scene);
}

/* Near misses (rad_contact_cut.near_count): faces parallel to the floor,
 * facing up as it does, over it by more than the gap but at most
 * RAD_CONTACT_NEAR. A tall room (10 x 100 x 10 m, walls in 0.5 m quads:
 * 16 800 faces, diameter 101: gap 0.10, near 1.01) makes the face grid's
 * layers 0.84 m high, so a panel 0.95 m over the floor lies in the next
 * layer: only the index of parallel faces finds it. `near` (flat) and
 * `tilted` (its normal 3e-5 off the floor's: parallel by the test, 1 - cos
 * = 4.5e-10, but in the neighbouring bin of the index) are near misses;
 * `far` (1.5 m up), `close` (5 cm: a gap contact) and `down` (facing the
 * other way) are not. */
static void near_quad(char **at, size_t *vertex, const double (*c)[3])
{
    for (int k = 0; k < 4; k++) *at += sprintf(*at, "v %.9g %.9g %.9g\n", c[k][0], c[k][1], c[k][2]);
    *at += sprintf(*at, "f %zu %zu %zu %zu\n", *vertex + 1, *vertex + 2, *vertex + 3, *vertex + 4);
    *vertex += 4;
}

/* The room's OBJ text (malloc'd). */
static char *near_build(void)
{
    char *text = malloc((size_t)8 << 20), *at = text;
    RAD_CHECK(text != NULL);
    if (!text) return NULL;
    size_t vertex = 0;
    const double d = 0.5;
    at += sprintf(at, "mtllib s.mtl\nusemtl grey\no room\n");
    for (int i = 0; i < 20; i++)
        for (int j = 0; j < 20; j++) {
            const double x = i * d, z = j * d;
            const double floor[4][3] = {{x, 0, z}, {x, 0, z + d}, {x + d, 0, z + d}, {x + d, 0, z}};
            const double ceiling[4][3] = {{x, 100, z}, {x + d, 100, z}, {x + d, 100, z + d}, {x, 100, z + d}};
            near_quad(&at, &vertex, floor);
            near_quad(&at, &vertex, ceiling);
        }
    for (int i = 0; i < 20; i++)
        for (int j = 0; j < 200; j++) {
            const double u = i * d, y = j * d;
            const double w0[4][3] = {{0, y, u}, {0, y + d, u}, {0, y + d, u + d}, {0, y, u + d}};
            const double w1[4][3] = {{10, y, u}, {10, y, u + d}, {10, y + d, u + d}, {10, y + d, u}};
            const double w2[4][3] = {{u, y, 0}, {u + d, y, 0}, {u + d, y + d, 0}, {u, y + d, 0}};
            const double w3[4][3] = {{u, y, 10}, {u, y + d, 10}, {u + d, y + d, 10}, {u + d, y, 10}};
            near_quad(&at, &vertex, w0);
            near_quad(&at, &vertex, w1);
            near_quad(&at, &vertex, w2);
            near_quad(&at, &vertex, w3);
        }
    const double panels[5][4][3] = {
        {{1.1, 0.95, 1.1}, {1.1, 0.95, 2.1}, {2.1, 0.95, 2.1}, {2.1, 0.95, 1.1}},                 /* near */
        {{3.1, 1.5, 1.1}, {3.1, 1.5, 2.1}, {4.1, 1.5, 2.1}, {4.1, 1.5, 1.1}},                     /* far */
        {{5.1, 0.949985, 5.1}, {5.1, 0.949985, 6.1}, {6.1, 0.950015, 6.1}, {6.1, 0.950015, 5.1}}, /* tilted */
        {{8.1, 0.05, 8.1}, {8.1, 0.05, 9.1}, {9.1, 0.05, 9.1}, {9.1, 0.05, 8.1}},                 /* close */
        {{1.1, 0.95, 7.1}, {2.1, 0.95, 7.1}, {2.1, 0.95, 8.1}, {1.1, 0.95, 8.1}}};                /* down */
    const char *names[5] = {"near", "far", "tilted", "close", "down"};
    for (int k = 0; k < 5; k++) {
        at += sprintf(at, "o %s\n", names[k]);
        near_quad(&at, &vertex, panels[k]);
    }
    return text;
}

static void test_near_misses(void)
{
    char *text = near_build();
    if (!text) return;
    rad_scene scene;
    rad_scene_options so = {.read_file = text_read, .read_file_user = text};
    RAD_CHECK(rad_scene_load_file("near.obj", &so, &scene) == RAD_OK);
    RAD_CHECK(scene.face_count == 16805);
    const uint32_t first_panel = 16800; /* near, far, tilted, close, down */
    rad_contact_cut cut;
    RAD_CHECK(rad_contact_cut_build(&scene, NULL, &cut) == RAD_OK);
    fprintf(stderr, "near misses: %zu, the first: face %u under face %u, %.6g apart\n", cut.near_count, cut.near_face,
            cut.near_cover, cut.near_distance);
    RAD_CHECK(cut.near_count == 2); /* near and tilted, each over one floor quad */
    RAD_CHECK(cut.near_face < 800 && cut.near_cover == first_panel);
    RAD_CHECK_REL(cut.near_distance, 0.95, 1e-12);
    rad_contact_cut_free(&cut);
    rad_scene_free(&scene);
    free(text);
}

static void test_no_contacts(void)
{
    const char *names[] = {RAD_SCENES "/closed_box.obj", RAD_SCENES "/cornell_sphere.obj"};
    for (int s = 0; s < 2; s++) {
        rad_scene scene;
        rad_scene_options so = {0};
        RAD_CHECK(rad_scene_load_file(names[s], &so, &scene) == RAD_OK);
        rad_mesh cut, keep;
        rad_mesh_options oc = {.subdiv = 2}, ok = {.subdiv = 2, .contacts = RAD_MESH_CONTACTS_KEEP};
        RAD_CHECK(rad_mesh_build(&scene, &oc, &cut) == RAD_OK && rad_mesh_build(&scene, &ok, &keep) == RAD_OK);
        RAD_CHECK(cut.patch_count == keep.patch_count && cut.vertex_count == keep.vertex_count);
        RAD_CHECK(cut.patch_count == keep.patch_count &&
                  memcmp(cut.patches, keep.patches, cut.patch_count * sizeof *cut.patches) == 0);
        RAD_CHECK(cut.vertex_count == keep.vertex_count &&
                  memcmp(cut.positions, keep.positions, 3 * cut.vertex_count * sizeof *cut.positions) == 0);
        rad_mesh_free(&cut);
        rad_mesh_free(&keep);
        rad_scene_free(&scene);
    }
    rad_mesh_options bad = {.contacts = (rad_mesh_contacts)7};
    rad_scene scene;
    rad_mesh m;
    RAD_CHECK(rad_scene_load_default(&scene) == RAD_OK);
    RAD_CHECK(rad_mesh_build(&scene, &bad, &m) == RAD_ERR_INVALID);
    rad_scene_free(&scene);
}

int main(void)
{
    test_near_misses();
    test_cornell_box();
    test_contact_room();
    test_gap_contact();
    test_double_sided_panel();
    test_coplanar_overlap();
    test_no_contacts();
    return rad_test_finish();
}
