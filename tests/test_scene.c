/* test_scene.c - the OBJ/MTL loader: every error message, index forms,
 * tolerated encodings, face clean-up (zero area, triangulation) and the
 * shipped scenes (the .obj files in scenes/ and the built-in Cornell box).
 *
 * Small inputs are served from memory through the read_file callback
 * (vfs below); the shipped scenes come from the file system. */
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "rad_mesh.h"
#include "rad_scene.h"
#include "rad_test.h"

/* ---- an in-memory file system: {name, text} pairs, NULL-terminated ---- */

typedef struct vfile {
    const char *name;
    const char *text;
    size_t size; /* 0 = strlen(text) */
} vfile;

static rad_status vfs_read(const char *path, char **out_data, size_t *out_size, void *user)
{
    for (const vfile *f = user; f->name; f++) {
        if (strcmp(f->name, path) != 0) continue;
        size_t n = f->size ? f->size : strlen(f->text);
        *out_data = malloc(n ? n : 1); /* not terminated: the loader must cope */
        if (!*out_data) return RAD_ERR_NOMEM;
        memcpy(*out_data, f->text, n);
        *out_size = n;
        return RAD_OK;
    }
    *out_data = NULL;
    return RAD_ERR_IO;
}

/* Loads `obj` (named x.obj) with `mtl` as x.mtl and the options' clamp,
 * flip and Ke reading (NULL: none); captures the log. */
static rad_status load_text_with(const char *obj, const char *mtl, const rad_scene_options *with, rad_scene *scene)
{
    vfile files[] = {{"x.obj", obj, 0}, {"x.mtl", mtl ? mtl : "", 0}, {NULL, NULL, 0}};
    rad_scene_options opt = {.read_file = vfs_read, .read_file_user = files};
    if (with) opt.clamp_rho = with->clamp_rho, opt.flip_normals = with->flip_normals, opt.ke_radiance = with->ke_radiance,
                  opt.flip_groups = with->flip_groups;
    rad_test_capture_log();
    memset(scene, 0, sizeof *scene);
    return rad_scene_load_file("x.obj", &opt, scene);
}

static rad_status load_text(const char *obj, const char *mtl, rad_scene *scene)
{
    return load_text_with(obj, mtl, NULL, scene);
}

static int count_in_log(const char *text)
{
    int n = 0;
    for (const char *p = strstr(rad_test_log, text); p; p = strstr(p + 1, text)) n++;
    return n;
}

/* Checks that loading fails with `status` and logs `message`. */
static void expect_error(const char *obj, const char *mtl, rad_status status, const char *message)
{
    rad_scene scene;
    rad_status got = load_text(obj, mtl, &scene);
    RAD_CHECK(got == status);
    if (!rad_test_log_contains(message)) {
        fprintf(stderr, "expected message \"%s\", log was:\n%s", message, rad_test_log);
        rad_test_failures++;
    }
    RAD_CHECK(scene.faces == NULL && scene.face_count == 0); /* out_scene untouched on failure */
    rad_scene_free(&scene);
}

#define QUAD "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n"

static void test_errors(void)
{
    expect_error(QUAD "f 1 2 3\nf 0 1 2\n", NULL, RAD_ERR_INVALID, "x.obj:6: face index 0 is invalid (indices are 1-based)");
    expect_error("v 0 0 0\nv 1 abc 0\n", NULL, RAD_ERR_PARSE, "x.obj:2: bad number 'abc'");
    expect_error("v 0 0 0\nv 1 2\n", NULL, RAD_ERR_PARSE, "x.obj:2: 'v' needs 3 numbers, got 2");
    expect_error(QUAD QUAD "\nf 1 2 9\n", NULL, RAD_ERR_INVALID, "x.obj:10: vertex index 9 out of range (8 vertices so far)");
    expect_error(QUAD "f 1 2 -5\n", NULL, RAD_ERR_INVALID, "x.obj:5: vertex index -5 out of range (4 vertices so far)");
    expect_error(QUAD "f 1 2 x3\n", NULL, RAD_ERR_PARSE, "x.obj:5: bad index 'x3'");
    expect_error(QUAD "f 1/1 2/1 3/1\n", NULL, RAD_ERR_INVALID, "x.obj:5: texture index 1 out of range (0 texture coordinates so far)");
    expect_error(QUAD "vn 0 0 1\nf 1//1 2//2 3//1\n", NULL, RAD_ERR_INVALID, "x.obj:6: normal index 2 out of range (1 normals so far)");
    expect_error("# comment\nmtllib missing.mtl\n" QUAD "f 1 2 3\n", NULL, RAD_ERR_IO, "x.obj:2: mtllib 'missing.mtl': cannot open");
    expect_error("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nv nan 0 0\n", NULL, RAD_ERR_INVALID, "x.obj:5: coordinate is NaN or infinite");
    expect_error("v 0 0 0\nv 1 0 inf\n", NULL, RAD_ERR_INVALID, "x.obj:2: coordinate is NaN or infinite");
    expect_error("v 0 0 0\nv 1e999 0 0\n", NULL, RAD_ERR_INVALID, "x.obj:2: coordinate is NaN or infinite");
    expect_error(QUAD "\n\n\n\nf 1 2\n", NULL, RAD_ERR_PARSE, "x.obj:9: face has 2 vertices, needs at least 3");
    expect_error("mtllib x.mtl\n" QUAD "f 1 2 3\n", "newmtl a\nKd 0.5 0.5 0.5\nnewmtl b\nKd 0.5 1.0 0.5\n", RAD_ERR_INVALID,
                 "x.mtl:4: Kd 1.0 out of range [0,1) (reflectance 1 makes the system singular; formfactor --clamp-rho "
                 "0.99 clamps it)");
    expect_error("mtllib x.mtl\n" QUAD "f 1 2 3\n", "newmtl a\nKd -0.1 0 0\n", RAD_ERR_INVALID, "x.mtl:2: Kd -0.1 out of range [0,1)");
    expect_error("mtllib x.mtl\n" QUAD "f 1 2 3\n", "newmtl a\nKe 1 -2 0\n", RAD_ERR_INVALID, "x.mtl:2: Ke -2 out of range [0, 1e+30]");
    expect_error("mtllib x.mtl\n" QUAD "f 1 2 3\n", "Kd 0.5 0.5 0.5\n", RAD_ERR_PARSE, "x.mtl:1: Kd before any newmtl");
    expect_error("mtllib x.mtl\n" QUAD "f 1 2 3\n", "newmtl a\nnewmtl a\n", RAD_ERR_INVALID, "x.mtl:2: material 'a' defined twice");
    expect_error("mtllib x.mtl\n" QUAD "usemtl foo\nf 1 2 3\n", "newmtl a\nKd 0.5 0.5 0.5\n", RAD_ERR_INVALID,
                 "x.obj:6: usemtl 'foo': no such material");
    expect_error(QUAD "usemtl\n", NULL, RAD_ERR_PARSE, "x.obj:5: 'usemtl' needs a name");
    expect_error(QUAD "g a_very_long_group_name_that_does_not_fit_in_sixty_four_bytes_at_all\n", NULL, RAD_ERR_INVALID,
                 "x.obj:5: name 'a_very_long_group_na...' too long (at most 63 bytes)");
    expect_error(QUAD, NULL, RAD_ERR_INVALID, "x.obj: no faces");
    /* A bow-tie (planar, crossing itself) cannot be triangulated. */
    expect_error("v 0 0 0\nv 4 0 0\nv 4 2 0\nv 1 -1 0\nv 0 2 0\nf 1 2 3 4 5\n", NULL, RAD_ERR_INVALID,
                 "x.obj:6: face crosses itself; cannot triangulate");

    /* A NUL byte: not a text file (reported with its line). */
    static const char binary[] = "v 0 0 0\nv 1 0 0\nv 1\0 1 0\nf 1 2 3\n";
    vfile files[] = {{"b.obj", binary, sizeof binary - 1}, {NULL, NULL, 0}};
    rad_scene_options opt = {.read_file = vfs_read, .read_file_user = files};
    rad_scene scene = {0};
    rad_test_capture_log();
    RAD_CHECK(rad_scene_load_file("b.obj", &opt, &scene) == RAD_ERR_PARSE);
    RAD_CHECK(rad_test_log_contains("b.obj:3: contains a NUL byte (not a text file)"));

    /* A missing OBJ, and the real file system's reader. */
    rad_test_capture_log();
    RAD_CHECK(rad_scene_load_file(RAD_TEST_DATA "/does_not_exist.obj", NULL, &scene) == RAD_ERR_IO);
    RAD_CHECK(rad_test_log_contains("does_not_exist.obj: cannot open"));
    RAD_CHECK(rad_scene_load_file(RAD_TEST_DATA "/missing_mtllib.obj", NULL, &scene) == RAD_ERR_IO);
    RAD_CHECK(rad_test_log_contains("missing_mtllib.obj:2: mtllib 'missing.mtl': cannot open"));
    rad_scene_free(&scene);
}

static void test_index_forms(void)
{
    rad_scene s;
    const char *obj = QUAD "vt 0 0\nvt 1 0\nvn 0 0 1\n"
                           "f 1 2 3\n"             /* line 8 */
                           "f 1/1 2/2 3/1\n"       /* 9 */
                           "f 1//1 2//1 3//1\n"    /* 10 */
                           "f 1/2/1 2/1/1 3/2/1\n" /* 11 */
                           "f -4 -3 -2\n"          /* 12: 1 2 3 */
                           "f -4/-2/-1 -3/-1/-1 -1/-2/-1\n" /* 13: 1 2 4 */
                           "f 3 4 1\n";            /* 14 */
    RAD_CHECK(load_text(obj, NULL, &s) == RAD_OK);
    RAD_CHECK(s.face_count == 7 && s.vertex_count == 4);
    for (size_t f = 0; f < s.face_count && f < 5; f++) {
        RAD_CHECK(s.faces[f].vertex_count == 3);
        RAD_CHECK(s.faces[f].v[0] == 0 && s.faces[f].v[1] == 1 && s.faces[f].v[2] == 2);
        RAD_CHECK(s.faces[f].line == 8 + f);
    }
    RAD_CHECK(s.face_count == 7 && s.faces[5].v[0] == 0 && s.faces[5].v[1] == 1 && s.faces[5].v[2] == 3);
    RAD_CHECK(s.face_count == 7 && s.faces[6].v[0] == 2 && s.faces[6].v[1] == 3 && s.faces[6].v[2] == 0);
    RAD_CHECK(s.faces[0].material == 0 && strcmp(s.materials[0].name, "default") == 0);
    RAD_CHECK_NEAR(s.materials[0].rho[1], 0.5, 0);
    /* Faces before any usemtl: one warning per file. */
    RAD_CHECK(count_in_log("face before any usemtl uses material 'default'") == 1);
    RAD_CHECK(rad_test_log_contains("x.obj:8: face before any usemtl"));
    rad_scene_free(&s);
    rad_scene_free(&s); /* safe twice */
}

static void test_encodings(void)
{
    const char *mtl = "newmtl m\nKd 0.25 0.5 0.75\nKe 1 2 3\n";
    const char *plain = "mtllib x.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\ng top\nusemtl m\nf 1 2 3 4\n";
    const char *crlf = "\xEF\xBB\xBF" "mtllib x.mtl\r\nv 0 0 0\r\nv 1 0 0  \r\nv 1 1 0\r\n\tv 0 1 0 # trailing comment\r\n"
                       "g top\r\nusemtl m\r\nf 1 2 3 4";
    rad_scene a, b;
    RAD_CHECK(load_text(plain, mtl, &a) == RAD_OK);
    RAD_CHECK(load_text(crlf, "\xEF\xBB\xBFnewmtl m\r\nKd 0.25 0.5 0.75\r\nKe 1 2 3", &b) == RAD_OK);
    RAD_CHECK(rad_test_log[0] == 0); /* no warnings at all */
    RAD_CHECK(a.face_count == 1 && b.face_count == 1 && b.faces[0].vertex_count == 4);
    RAD_CHECK(a.fingerprint == b.fingerprint && a.fingerprint != 0);
    RAD_CHECK(b.material_count == 2 && strcmp(b.materials[1].name, "m") == 0);
    RAD_CHECK_NEAR(b.materials[1].rho[2], 0.75, 0);
    RAD_CHECK_NEAR(b.materials[1].emission[1], 2.0, 0);
    RAD_CHECK(b.group_count == 2 && strcmp(b.groups[b.faces[0].group], "top") == 0);
    /* The fingerprint sees positions and materials. */
    rad_scene c;
    RAD_CHECK(load_text(plain, "newmtl m\nKd 0.25 0.5 0.7\nKe 1 2 3\n", &c) == RAD_OK);
    RAD_CHECK(c.fingerprint != a.fingerprint);
    rad_scene_free(&c);
    RAD_CHECK(load_text("mtllib x.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 1e-300\ng top\nusemtl m\nf 1 2 3 4\n", mtl, &c) == RAD_OK);
    RAD_CHECK(c.fingerprint != a.fingerprint);
    rad_scene_free(&a);
    rad_scene_free(&b);
    rad_scene_free(&c);
}

static void test_warnings(void)
{
    rad_scene s;
    const char *obj = "mtllib x.mtl x.mtl\nvp 0.5\n" QUAD "usemtl m\ns 1\nfoo 1\nl 1 2\nfoo 2\nf 1 2 3 4\n";
    const char *mtl = "newmtl m\nKa 0 0 0\nKs 1 1 1\nNs 10\nNi 1.5\nd 1\nTr 0\nillum 2\nmap_Kd a.png\nTf 1 1 1\n"
                      "Kd 0.5 0.5 0.5\nbump b.png\nnewmtl n\n";
    RAD_CHECK(load_text(obj, mtl, &s) == RAD_OK);
    RAD_CHECK(count_in_log("unknown key 'foo' ignored") == 1);
    RAD_CHECK(rad_test_log_contains("x.obj:9: unknown key 'foo' ignored"));
    RAD_CHECK(rad_test_log_contains("x.obj:2: unknown key 'vp' ignored"));
    RAD_CHECK(rad_test_log_contains("x.obj:10: unknown key 'l' ignored"));
    RAD_CHECK(rad_test_log_contains("x.mtl:12: unknown key 'bump' ignored"));
    RAD_CHECK(rad_test_log_contains("x.mtl:13: material 'n' has no Kd; using grey 0.5"));
    RAD_CHECK(count_in_log("\n") == 5); /* those five and nothing for Ka..Tf, s, or the repeated mtllib */
    RAD_CHECK(s.material_count == 3 && s.face_count == 1);
    rad_scene_free(&s);
}

static double face_area(const rad_scene *s, const rad_face *f, rad_vec3 *normal)
{
    rad_vec3 p[4], c;
    double area;
    for (uint32_t i = 0; i < f->vertex_count; i++)
        p[i] = rad_v3(s->positions[3 * f->v[i]], s->positions[3 * f->v[i] + 1], s->positions[3 * f->v[i] + 2]);
    rad_polygon_geometry(p, (int)f->vertex_count, &area, normal, &c);
    return area;
}

static double total_area(const rad_scene *s, rad_vec3 expect_normal)
{
    double sum = 0;
    for (size_t f = 0; f < s->face_count; f++) {
        rad_vec3 n;
        sum += face_area(s, &s->faces[f], &n);
        RAD_CHECK_NEAR(rad_v3_dot(n, expect_normal), 1.0, 1e-12);
    }
    return sum;
}

static void test_cleanup(void)
{
    rad_scene s;
    /* Zero-area faces (collinear, repeated corner) are dropped with a warning. */
    RAD_CHECK(load_text("v 0 0 0\nv 1 0 0\nv 2 0 0\nv 0 1 0\nf 1 2 3\nf 1 2 4\nf 1 1 1\n", NULL, &s) == RAD_OK);
    RAD_CHECK(s.face_count == 1);
    RAD_CHECK(rad_test_log_contains("x.obj:5: face has zero area; dropped"));
    RAD_CHECK(rad_test_log_contains("x.obj:7: face has zero area; dropped"));
    RAD_CHECK(!rad_test_log_contains("x.obj:6:"));
    rad_scene_free(&s);
    /* A triangle written as a quad with a repeated corner stays one triangle. */
    RAD_CHECK(load_text(QUAD "f 1 2 3 3\n", NULL, &s) == RAD_OK);
    RAD_CHECK(s.face_count == 1 && s.faces[0].vertex_count == 3);
    RAD_CHECK(rad_test_log_contains("x.obj:5: face repeats a corner; repeat removed"));
    rad_scene_free(&s);

    /* A non-planar quad (one corner lifted by 0.01) becomes two triangles. */
    RAD_CHECK(load_text("v 0 0 0\nv 1 0 0\nv 1 1 0.01\nv 0 1 0\nf 1 2 3 4\n", NULL, &s) == RAD_OK);
    RAD_CHECK(s.face_count == 2 && s.faces[0].vertex_count == 3 && s.faces[1].vertex_count == 3);
    RAD_CHECK(rad_test_log_contains("x.obj:5: 1 non-planar polygons (this is the first; the farthest off its plane "
                                    "by 0.0018 of its size, beyond rounding) were split into 2 triangles: 2 faces "
                                    "where the file has 1 polygons, 100% more patches"));
    rad_scene_free(&s);
    /* Off its plane by less than the rounding of 6 decimals (Blender's
     * exporter: 2.2e-6 of the face's size) it stays a quad, quietly; the
     * same offset written in full is split. */
    RAD_CHECK(load_text("v 0.000000 0.000000 0.000000\nv 0.100000 0.000000 0.000000\nv 0.100000 0.100000 0.000000\n"
                        "v 0.000000 0.100000 0.000001\nf 1 2 3 4\n", NULL, &s) == RAD_OK);
    RAD_CHECK(s.face_count == 1 && s.faces[0].vertex_count == 4 && !rad_test_log_contains("non-planar"));
    rad_scene_free(&s);
    RAD_CHECK(load_text("v 0 0 0\nv 1e-1 0 0\nv 1e-1 1e-1 0\nv 0 1e-1 1e-6\nf 1 2 3 4\n", NULL, &s) == RAD_OK);
    RAD_CHECK(s.face_count == 2 && rad_test_log_contains("1 non-planar polygons"));
    rad_scene_free(&s);
    /* Within the planarity tolerance (1e-6 of the size) it stays a quad. */
    RAD_CHECK(load_text("v 0 0 0\nv 1 0 0\nv 1 1 1e-8\nv 0 1 0\nf 1 2 3 4\n", NULL, &s) == RAD_OK);
    RAD_CHECK(s.face_count == 1 && s.faces[0].vertex_count == 4 && !rad_test_log_contains("triangulated"));
    rad_scene_free(&s);

    /* A non-convex L-shaped hexagon (area 3), wound clockwise seen from +z:
     * 4 triangles covering exactly its area, all facing -z. */
    RAD_CHECK(load_text("v 0 0 0\nv 0 2 0\nv 1 2 0\nv 1 1 0\nv 2 1 0\nv 2 0 0\nf 1 2 3 4 5 6\n", NULL, &s) == RAD_OK);
    RAD_CHECK(s.face_count == 4);
    RAD_CHECK_REL(total_area(&s, rad_v3(0, 0, -1)), 3.0, 1e-14);
    RAD_CHECK(rad_test_log_contains("x.obj:7: 6-vertex face triangulated into 4 triangles (non-convex)"));
    rad_scene_free(&s);
    /* A non-convex quad (a dart, area 1) in the y-z plane: 2 triangles. */
    RAD_CHECK(load_text("v 0 0 0\nv 0 2 0\nv 0 1 0.5\nv 0 0 2\nf 1 2 3 4\n", NULL, &s) == RAD_OK);
    RAD_CHECK(s.face_count == 2);
    RAD_CHECK_REL(total_area(&s, rad_v3(1, 0, 0)), 1.5, 1e-14);
    RAD_CHECK(rad_test_log_contains("(non-convex)"));
    rad_scene_free(&s);
    /* A convex planar pentagon (a unit square with a roof of height 1/2). */
    RAD_CHECK(load_text(QUAD "v 0.5 1.5 0\nf 1 2 3 5 4\n", NULL, &s) == RAD_OK);
    RAD_CHECK(s.face_count == 3);
    RAD_CHECK_REL(total_area(&s, rad_v3(0, 0, 1)), 1.25, 1e-14);
    RAD_CHECK(rad_test_log_contains("x.obj:6: 5-vertex face triangulated into 3 triangles (more than 4 vertices)"));
    rad_scene_free(&s);
    /* A collinear extra corner on a quad's edge: 2 triangles, nothing lost. */
    RAD_CHECK(load_text(QUAD "v 0.5 0 0\nf 1 5 2 3 4\n", NULL, &s) == RAD_OK);
    RAD_CHECK_REL(total_area(&s, rad_v3(0, 0, 1)), 1.0, 1e-14);
    rad_scene_free(&s);
}

/* How many faces have their centroid strictly inside the convex polygon
 * hole[0..count) of the plane of axes (u, v): none may, for a hole. */
static int centroids_in_hole(const rad_scene *s, int u, int v, const double (*hole)[2], int count)
{
    int inside_count = 0;
    for (size_t f = 0; f < s->face_count; f++) {
        const rad_face *face = &s->faces[f];
        double c[2] = {0, 0};
        for (uint32_t i = 0; i < face->vertex_count; i++) {
            c[0] += s->positions[3 * face->v[i] + u] / face->vertex_count;
            c[1] += s->positions[3 * face->v[i] + v] / face->vertex_count;
        }
        int positive = 0, negative = 0;
        for (int i = 0; i < count; i++) {
            const double *a = hole[i], *b = hole[(i + 1) % count];
            double t = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
            positive += t > 0;
            negative += t < 0;
        }
        inside_count += positive == count || negative == count;
    }
    return inside_count;
}

/* Polygons with holes as exporters write them (LightWave, the assimp test
 * corpus): one `f` with an outer ring, a bridge edge to an inner ring wound
 * the other way, and back along the same edge. Once refused as "face
 * crosses itself"; now triangulated over the polygon minus its holes. */
static void test_holes(void)
{
    rad_scene s;
    /* A 4 x 4 square (+z) with a 2 x 2 square hole, bridged from corner 1
     * to corner 5: area 16 - 4. */
    const char *ring = "v 0 0 0\nv 4 0 0\nv 4 4 0\nv 0 4 0\nv 1 1 0\nv 3 1 0\nv 3 3 0\nv 1 3 0\n";
    const double square_hole[4][2] = {{1, 1}, {3, 1}, {3, 3}, {1, 3}};
    char obj[512];
    snprintf(obj, sizeof obj, "%sf 1 2 3 4 1 5 8 7 6 5\n", ring);
    RAD_CHECK(load_text(obj, NULL, &s) == RAD_OK);
    RAD_CHECK_REL(total_area(&s, rad_v3(0, 0, 1)), 12.0, 1e-12);
    RAD_CHECK(centroids_in_hole(&s, 0, 1, square_hole, 4) == 0);
    RAD_CHECK(s.face_count == 8); /* 8 corners, 1 hole: 8 + 2 - 2 triangles */
    RAD_CHECK(rad_test_log_contains("x.obj:9: 10-vertex face triangulated into 8 triangles (1 hole joined by bridge edges)"));
    RAD_CHECK(!rad_test_log_contains("crosses itself"));
    rad_scene_free(&s);

    /* LightWave's form, with normals: the list starts mid-ring, the bridge
     * (2 -> 8) in the middle. An L (area 20) in the plane x = 2 facing +x,
     * a triangular hole (area 1) in its foot. */
    const char *l_shape = "v 2 0 0\nv 2 6 0\nv 2 6 2\nv 2 2 2\nv 2 2 6\nv 2 0 6\n"
                          "v 2 3 0.5\nv 2 5 0.5\nv 2 4 1.5\nvn 1 0 0\n"
                          "f 3//1 4//1 5//1 6//1 1//1 2//1 8//1 7//1 9//1 8//1 2//1\n";
    const double triangle_hole[3][2] = {{3, 0.5}, {5, 0.5}, {4, 1.5}};
    RAD_CHECK(load_text(l_shape, NULL, &s) == RAD_OK);
    RAD_CHECK_REL(total_area(&s, rad_v3(1, 0, 0)), 19.0, 1e-12);
    RAD_CHECK(centroids_in_hole(&s, 1, 2, triangle_hole, 3) == 0);
    RAD_CHECK(!rad_test_log_contains("wound against"));
    rad_scene_free(&s);

    /* Two holes, bridged from two corners of an 8 x 4 rectangle in the
     * plane y = 0 facing +y: area 32 - 4 - 4. */
    const char *two = "v 0 0 0\nv 0 0 4\nv 8 0 4\nv 8 0 0\n"
                      "v 1 0 1\nv 3 0 1\nv 3 0 3\nv 1 0 3\n"
                      "v 5 0 1\nv 7 0 1\nv 7 0 3\nv 5 0 3\n"
                      "f 1 5 6 7 8 5 1 2 3 4 10 11 12 9 10 4\n";
    const double hole_a[4][2] = {{1, 1}, {3, 1}, {3, 3}, {1, 3}}, hole_b[4][2] = {{5, 1}, {7, 1}, {7, 3}, {5, 3}};
    RAD_CHECK(load_text(two, NULL, &s) == RAD_OK);
    RAD_CHECK_REL(total_area(&s, rad_v3(0, 1, 0)), 24.0, 1e-12);
    RAD_CHECK(centroids_in_hole(&s, 0, 2, hole_a, 4) == 0 && centroids_in_hole(&s, 0, 2, hole_b, 4) == 0);
    RAD_CHECK(rad_test_log_contains("(2 holes joined by bridge edges)"));
    rad_scene_free(&s);

    /* Warped (one outer corner lifted): triangulated with the note, the
     * hole still empty. */
    RAD_CHECK(load_text("v 0 0 0\nv 4 0 0\nv 4 4 0.01\nv 0 4 0\nv 1 1 0\nv 3 1 0\nv 3 3 0\nv 1 3 0\n"
                        "f 1 2 3 4 1 5 8 7 6 5\n",
                        NULL, &s) == RAD_OK);
    RAD_CHECK(centroids_in_hole(&s, 0, 1, square_hole, 4) == 0);
    RAD_CHECK(rad_test_log_contains("(non-planar, 1 hole joined by bridge edges; off its plane"));
    rad_scene_free(&s);

    /* Still refused: an inner ring wound the same way as the outer one
     * (not a hole: the rings overlap), and a "hole" reaching outside. */
    snprintf(obj, sizeof obj, "%sf 1 2 3 4 1 5 6 7 8 5\n", ring);
    expect_error(obj, NULL, RAD_ERR_INVALID,
                 "x.obj:9: face crosses itself; cannot triangulate (it has an edge walked both ways, a bridge to a "
                 "hole: the hole's ring must wind the other way round from the outer one and lie inside it)");
    expect_error("v 0 0 0\nv 4 0 0\nv 4 4 0\nv 0 4 0\nv 1 1 0\nv 5 1 0\nv 5 3 0\nv 1 3 0\nf 1 2 3 4 1 5 8 7 6 5\n",
                 NULL, RAD_ERR_INVALID, "x.obj:9: face crosses itself; cannot triangulate");
    /* A ring and the same ring back: no area, dropped as before. */
    snprintf(obj, sizeof obj, "%sf 1 2 3 4 1 4 3 2\nf 1 2 3\n", ring);
    RAD_CHECK(load_text(obj, NULL, &s) == RAD_OK && s.face_count == 1);
    RAD_CHECK(rad_test_log_contains("x.obj:9: face has zero area; dropped"));
    rad_scene_free(&s);
}

/* `o`/`g` (and material) names run to the end of the line: two objects
 * "Wall left" and "Wall right" were both cut to "Wall" and merged. */
static void test_names_with_blanks(void)
{
    rad_scene s;
    const char *obj = QUAD "o Wall left\nf 1 2 3\n"
                      "o Wall right\nf 1 3 4\n"
                      "g \t Wall   centre \t # a comment\nf 1 2 4\n"
                      "g a b\nf 2 3 4\n"
                      "g Wall#2\nf 1 2 3\n";
    RAD_CHECK(load_text(obj, NULL, &s) == RAD_OK);
    RAD_CHECK(s.face_count == 5 && s.group_count == 6);
    const char *expect[5] = {"Wall left", "Wall right", "Wall   centre", "a b", "Wall#2"};
    for (size_t f = 0; f < s.face_count && f < 5; f++) {
        if (strcmp(s.groups[s.faces[f].group], expect[f]) != 0) {
            fprintf(stderr, "face %zu: group '%s', expected '%s'\n", f, s.groups[s.faces[f].group], expect[f]);
            rad_test_failures++;
        }
    }
    rad_scene_free(&s);
    /* Material names the same way ("Red" and "Red paint" are two). */
    RAD_CHECK(load_text("mtllib x.mtl\n" QUAD "usemtl Red paint\nf 1 2 3\n",
                        "newmtl Red paint\nKd 0.5 0 0\nnewmtl Red\nKd 0.2 0 0\n", &s) == RAD_OK);
    RAD_CHECK(s.face_count == 1 && s.material_count == 3);
    if (s.face_count == 1) {
        RAD_CHECK(strcmp(s.materials[s.faces[0].material].name, "Red paint") == 0);
        RAD_CHECK_NEAR(s.materials[s.faces[0].material].rho[0], 0.5, 0);
    }
    rad_scene_free(&s);
    /* `o` alone: back to "default", as before. */
    RAD_CHECK(load_text(QUAD "o A\nf 1 2 3\no\nf 1 3 4\n", NULL, &s) == RAD_OK);
    RAD_CHECK(s.group_count == 2 && s.faces[1].group == 0 && strcmp(s.groups[0], "default") == 0);
    rad_scene_free(&s);
    /* The limit (the form-factor file's 64-byte group names) counts the
     * whole name: refused, not cut short. */
    expect_error(QUAD "o Wall on the left side of the room, behind the tall bookcase by the door\n", NULL,
                 RAD_ERR_INVALID, "x.obj:5: name 'Wall on the left sid...' too long (at most 63 bytes)");
    char exact[128];
    snprintf(exact, sizeof exact, QUAD "o %s\nf 1 2 3\n",
             "Wall 6789 123456789 123456789 123456789 123456789 123456789 123");
    RAD_CHECK(load_text(exact, NULL, &s) == RAD_OK && strlen(s.groups[1]) == 63);
    rad_scene_free(&s);
}

/* UTF-16 and UTF-32 files are named as such, not just "not a text file". */
static void expect_wide(const char *name, const char *data, size_t size, const char *message)
{
    vfile files[] = {{name, data, size}, {NULL, NULL, 0}};
    rad_scene_options opt = {.read_file = vfs_read, .read_file_user = files};
    rad_scene scene = {0};
    rad_test_capture_log();
    RAD_CHECK(rad_scene_load_file(name, &opt, &scene) == RAD_ERR_PARSE);
    if (!rad_test_log_contains(message)) {
        fprintf(stderr, "expected message \"%s\", log was:\n%s", message, rad_test_log);
        rad_test_failures++;
    }
    RAD_CHECK(!rad_test_log_contains("NUL byte"));
    rad_scene_free(&scene);
}

static void test_wide_encodings(void)
{
    const char *text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
    size_t n = strlen(text);
    char le[128], be[128], le_bom[130], be_bom[130], utf32[260];
    for (size_t i = 0; i < n; i++) {
        le[2 * i] = text[i], le[2 * i + 1] = 0;
        be[2 * i] = 0, be[2 * i + 1] = text[i];
        memcpy(utf32 + 4 + 4 * i, (const char[4]){text[i], 0, 0, 0}, 4);
    }
    memcpy(le_bom, "\xFF\xFE", 2), memcpy(le_bom + 2, le, 2 * n);
    memcpy(be_bom, "\xFE\xFF", 2), memcpy(be_bom + 2, be, 2 * n);
    memcpy(utf32, "\xFF\xFE\0\0", 4);
    expect_wide("scene.obj", le_bom, 2 + 2 * n,
                "scene.obj: is UTF-16 text (byte-order mark FF FE); save it as UTF-8 or ASCII");
    expect_wide("scene.obj", be_bom, 2 + 2 * n,
                "scene.obj: is UTF-16 text (byte-order mark FE FF); save it as UTF-8 or ASCII");
    expect_wide("scene.obj", le, 2 * n, "scene.obj: is UTF-16 text (little-endian, no byte-order mark); save it as UTF-8");
    expect_wide("scene.obj", be, 2 * n, "scene.obj: is UTF-16 text (big-endian, no byte-order mark); save it as UTF-8");
    expect_wide("scene.obj", utf32, 4 + 4 * n, "scene.obj: is UTF-32 text (byte-order mark FF FE 00 00)");
    /* An MTL file too; a plain NUL further on stays "not a text file". */
    rad_scene s;
    vfile files[] = {{"x.obj", "mtllib x.mtl\n", 0}, {"x.mtl", le_bom, 2 + 2 * n}, {NULL, NULL, 0}};
    rad_scene_options opt = {.read_file = vfs_read, .read_file_user = files};
    rad_test_capture_log();
    memset(&s, 0, sizeof s);
    RAD_CHECK(rad_scene_load_file("x.obj", &opt, &s) == RAD_ERR_PARSE);
    RAD_CHECK(rad_test_log_contains("x.mtl: is UTF-16 text (byte-order mark FF FE)"));
    static const char one_nul[] = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\0\n";
    vfile binary[] = {{"b.obj", one_nul, sizeof one_nul - 1}, {NULL, NULL, 0}};
    opt.read_file_user = binary;
    rad_test_capture_log();
    RAD_CHECK(rad_scene_load_file("b.obj", &opt, &s) == RAD_ERR_PARSE);
    RAD_CHECK(rad_test_log_contains("b.obj:4: contains a NUL byte (not a text file)"));
    /* A UTF-8 byte-order mark is skipped without a word. */
    RAD_CHECK(load_text("\xEF\xBB\xBFv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", NULL, &s) == RAD_OK && s.face_count == 1);
    RAD_CHECK(!rad_test_log_contains("x.obj:1:"));
    rad_scene_free(&s);
}

/* Returns the summed area of the faces of group `name` and checks their
 * normals: inward (toward `centre`) when sign = +1, outward when -1. */
static double group_area(const rad_scene *s, const char *name, rad_vec3 centre, double sign, size_t *out_faces)
{
    double sum = 0;
    size_t count = 0;
    for (size_t f = 0; f < s->face_count; f++) {
        const rad_face *face = &s->faces[f];
        if (strcmp(s->groups[face->group], name) != 0) continue;
        rad_vec3 n, p[4], c;
        double area;
        for (uint32_t i = 0; i < face->vertex_count; i++)
            p[i] = rad_v3(s->positions[3 * face->v[i]], s->positions[3 * face->v[i] + 1], s->positions[3 * face->v[i] + 2]);
        rad_polygon_geometry(p, (int)face->vertex_count, &area, &n, &c);
        double toward = rad_v3_dot(n, rad_v3_normalize(rad_v3_sub(centre, c)));
        if (!(sign * toward > 0.05)) {
            fprintf(stderr, "%s face (line %u) points the wrong way (%g)\n", name, face->line, toward);
            rad_test_failures++;
        }
        sum += area;
        count++;
    }
    *out_faces = count;
    return sum;
}

static rad_vec3 block_centre(const rad_scene *s, const char *name)
{
    rad_vec3 sum = rad_v3(0, 0, 0);
    double n = 0;
    for (size_t f = 0; f < s->face_count; f++) {
        if (strcmp(s->groups[s->faces[f].group], name) != 0) continue;
        for (uint32_t i = 0; i < s->faces[f].vertex_count; i++, n++)
            sum = rad_v3_add(sum, rad_v3(s->positions[3 * s->faces[f].v[i]], s->positions[3 * s->faces[f].v[i] + 1],
                                         s->positions[3 * s->faces[f].v[i] + 2]));
    }
    return rad_v3_scale(sum, 1.0 / n);
}

static void test_cornell_box(void)
{
    rad_scene s, d;
    size_t n;
    rad_test_capture_log();
    RAD_CHECK(rad_scene_load_file(RAD_SCENES "/cornell_box.obj", NULL, &s) == RAD_OK);
    RAD_CHECK(rad_test_log[0] == 0); /* clean: no warning, nothing triangulated */
    RAD_CHECK(s.face_count == 20 && s.vertex_count == 28 && s.material_count == 5 && s.group_count == 9);
    rad_vec3 room = rad_v3(278, 274.4, 279.6);
    RAD_CHECK_REL(group_area(&s, "floor", room, 1, &n), 559.2 * (552.8 + 549.6) / 2, 1e-14);
    RAD_CHECK(n == 1);
    RAD_CHECK_REL(group_area(&s, "ceiling", room, 1, &n), 556.0 * 559.2 - 130.0 * 105.0, 1e-14);
    RAD_CHECK(n == 4);
    RAD_CHECK_REL(group_area(&s, "light", room, 1, &n), 130.0 * 105.0, 1e-14);
    RAD_CHECK(n == 1);
    RAD_CHECK_REL(group_area(&s, "back_wall", room, 1, &n), 548.8 * (549.6 + 556.0) / 2, 1e-14);
    RAD_CHECK(n == 1);
    RAD_CHECK_REL(group_area(&s, "green_wall", room, 1, &n), 548.8 * 559.2, 1e-14);
    RAD_CHECK(n == 1);
    double red = group_area(&s, "red_wall", room, 1, &n);
    RAD_CHECK(n == 2);
    RAD_CHECK_REL(red, 306904.5143864398, 1e-12); /* the two triangles, computed in Python */
    /* Blocks: top (shoelace) + height * perimeter of the top, computed in Python. */
    RAD_CHECK_REL(group_area(&s, "short_block", block_centre(&s, "short_block"), -1, &n), 27633.0 + 165 * 664.9449063088564, 1e-12);
    RAD_CHECK(n == 5);
    RAD_CHECK_REL(group_area(&s, "tall_block", block_centre(&s, "tall_block"), -1, &n), 27626.5 + 330 * 664.8604368858378, 1e-12);
    RAD_CHECK(n == 5);
    rad_vec3 nrm;
    RAD_CHECK_NEAR(face_area(&s, &s.faces[10], &nrm), 27633.0, 1e-9); /* short block top faces up */
    RAD_CHECK_NEAR(nrm.y, 1.0, 1e-15);
    /* Materials: the light emits 17 12 4; the red wall is red. */
    const rad_face *light = &s.faces[5];
    RAD_CHECK(strcmp(s.groups[light->group], "light") == 0);
    RAD_CHECK(strcmp(s.materials[light->material].name, "light") == 0);
    RAD_CHECK_NEAR(s.materials[light->material].emission[0], 17, 0);
    RAD_CHECK_NEAR(s.materials[light->material].emission[1], 12, 0);
    RAD_CHECK_NEAR(s.materials[light->material].emission[2], 4, 0);
    RAD_CHECK_NEAR(s.materials[light->material].rho[0], 0.78, 0);
    RAD_CHECK_NEAR(s.materials[s.faces[8].material].rho[0], 0.63, 0);
    RAD_CHECK_NEAR(s.materials[s.faces[7].material].rho[1], 0.45, 0);
    /* The built-in copy is the same scene. */
    rad_test_capture_log();
    RAD_CHECK(rad_scene_load_default(&d) == RAD_OK);
    RAD_CHECK(rad_test_log[0] == 0);
    RAD_CHECK(d.fingerprint == s.fingerprint && d.face_count == s.face_count);
    RAD_CHECK(strcmp(d.path, "cornell_box.obj") == 0);
    RAD_CHECK(strstr(rad_default_scene_name, "cornell_box.obj") != NULL);
    rad_scene_free(&s);
    rad_scene_free(&d);
}

static void test_cornell_sphere_and_closed_box(void)
{
    rad_scene s;
    size_t n, tris = 0, quads = 0;
    rad_test_capture_log();
    RAD_CHECK(rad_scene_load_file(RAD_SCENES "/cornell_sphere.obj", NULL, &s) == RAD_OK);
    RAD_CHECK(rad_test_log[0] == 0); /* all 24 band quads pass the planarity test */
    RAD_CHECK(s.face_count == 46 && s.vertex_count == 42);
    RAD_CHECK_REL(group_area(&s, "box", rad_v3(0, 0, 0), 1, &n), 24.0, 1e-15);
    RAD_CHECK(n == 6);
    rad_vec3 centre = rad_v3(0.2, -0.5, -0.3);
    double sphere = group_area(&s, "sphere", centre, -1, &n);
    RAD_CHECK(n == 40);
    RAD_CHECK(sphere < RAD_PI && sphere > 0.85 * RAD_PI); /* inscribed polyhedron of a sphere of area pi */
    for (size_t f = 0; f < s.face_count; f++) {
        if (strcmp(s.groups[s.faces[f].group], "sphere") != 0) continue;
        tris += s.faces[f].vertex_count == 3;
        quads += s.faces[f].vertex_count == 4;
        for (uint32_t i = 0; i < s.faces[f].vertex_count; i++) {
            const double *p = s.positions + 3 * s.faces[f].v[i];
            RAD_CHECK_NEAR(rad_v3_length(rad_v3_sub(rad_v3(p[0], p[1], p[2]), centre)), 0.5, 1e-15);
        }
    }
    RAD_CHECK(tris == 16 && quads == 24);
    /* The light is the top face (z = +1) and emits 1.27; red at x = -1, blue at x = +1. */
    for (size_t f = 0; f < 6; f++) {
        rad_vec3 nrm;
        face_area(&s, &s.faces[f], &nrm);
        const rad_material *m = &s.materials[s.faces[f].material];
        RAD_CHECK((m->emission[0] == 1.27) == (nrm.z < -0.5));
        RAD_CHECK((m->rho[0] == 0.75 && m->rho[2] == 0.1) == (nrm.x > 0.5));
        RAD_CHECK((m->rho[2] == 0.75 && m->rho[0] == 0.1) == (nrm.x < -0.5));
    }
    rad_scene_free(&s);

    RAD_CHECK(rad_scene_load_file(RAD_SCENES "/closed_box.obj", NULL, &s) == RAD_OK);
    RAD_CHECK(rad_test_log[0] == 0);
    RAD_CHECK(s.face_count == 6);
    RAD_CHECK_REL(group_area(&s, "box", rad_v3(0.5, 0.5, 0.5), 1, &n), 6.0, 1e-15);
    size_t emitters = 0;
    for (size_t f = 0; f < s.face_count; f++) {
        rad_vec3 nrm;
        face_area(&s, &s.faces[f], &nrm);
        const rad_material *m = &s.materials[s.faces[f].material];
        RAD_CHECK_NEAR(m->rho[1], 0.5, 0);
        if (m->emission[0] > 0) {
            emitters++;
            RAD_CHECK_NEAR(nrm.z, -1.0, 1e-15);
        }
    }
    RAD_CHECK(emitters == 1);
    rad_scene_free(&s);
}

static void discard(rad_log_level level, const char *message, void *user)
{
    (void)level, (void)message, (void)user;
}

/* Mutated copies of a small scene must load or fail cleanly (run under
 * AddressSanitizer in CI); a deterministic stand-in for a fuzzer. */
static void test_mutations(void)
{
    const char *seed = "mtllib x.mtl\n" QUAD "v 0.5 1.5 0\nvt 0 0\nvn 0 0 1\ng a\nusemtl m\nf 1 2 3 4\nf -1 -2 -3\nf 1/1/1 2//1 5\n"
                       "o b\nf 1 2 3 5 4\n";
    const char *mtl = "newmtl m\nKd 0.5 0.5 0.5\nKe 1 1 1\n";
    const char alphabet[] = "0123456789 -/\n\r#.fvgeE\xEF";
    uint64_t state = 12345;
    size_t len = strlen(seed), ok = 0;
    char buf[256];
    for (int iter = 0; iter < 3000; iter++) {
        memcpy(buf, seed, len + 1);
        for (int m = 0; m < 1 + iter % 4; m++) {
            state = state * 6364136223846793005u + 1442695040888963407u;
            buf[(state >> 33) % len] = alphabet[(state >> 20) % (sizeof alphabet - 1)];
        }
        vfile files[] = {{"x.obj", buf, 0}, {"x.mtl", mtl, 0}, {NULL, NULL, 0}};
        rad_scene_options opt = {.read_file = vfs_read, .read_file_user = files};
        rad_scene s = {0};
        rad_log_set_sink(discard, NULL);
        rad_status st = rad_scene_load_file("x.obj", &opt, &s);
        ok += st == RAD_OK;
        RAD_CHECK(st == RAD_OK || (s.faces == NULL && s.positions == NULL));
        RAD_CHECK(st != RAD_OK || s.face_count > 0);
        rad_scene_free(&s);
    }
    RAD_CHECK(ok > 100 && ok < 3000); /* the mutations hit both outcomes */
    rad_log_set_sink(NULL, NULL);
}

/* ---- hostile input (issue 16): limits, line endings, what is echoed ---- */
static void test_hostile(void)
{
    /* Coordinates the float ray tracers cannot take, named with the limit. */
    const char *big[] = {"1e39", "1e100", "1e154", "-2e12"};
    for (int k = 0; k < 4; k++) {
        char obj[256], msg[160];
        snprintf(obj, sizeof obj, "v 0 0 0\nv %s 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 3\n", big[k]);
        snprintf(msg, sizeof msg, "x.obj:2: coordinate %s beyond the supported range |x| <= 1e+12", big[k]);
        expect_error(obj, NULL, RAD_ERR_INVALID, msg);
    }
    rad_scene scene;
    RAD_CHECK(load_text("v 0 0 0\nv 1e12 0 0\nv 0 1e12 0\nf 1 2 3\n", NULL, &scene) == RAD_OK); /* the limit itself */
    rad_scene_free(&scene);
    /* Emission that would overflow the solve. */
    expect_error("mtllib x.mtl\n" QUAD "usemtl a\nf 1 2 3\n", "newmtl a\nKd 0.5 0.5 0.5\nKe 1e308 1 1\n",
                 RAD_ERR_INVALID, "x.mtl:3: Ke 1e308 out of range [0, 1e+30]");
    /* Classic Mac OS (CR) and Windows (CRLF) line endings read as lines. */
    RAD_CHECK(load_text("v 0 0 0\rv 1 0 0\rv 0 1 0\rf 1 2 3\r", NULL, &scene) == RAD_OK && scene.face_count == 1);
    rad_scene_free(&scene);
    RAD_CHECK(load_text("v 0 0 0\r\nv 1 0 0\r\nv 0 1 0\r\nf 1 2 3\r\n", NULL, &scene) == RAD_OK &&
              scene.face_count == 1);
    rad_scene_free(&scene);
    expect_error("v 0 0 0\rv 1 0\r", NULL, RAD_ERR_PARSE, "x.obj:2: 'v' needs 3 numbers, got 2");
    /* A system file given as mtllib: lines counted, never echoed; and a
     * flood of warnings summarised. */
    size_t lines = 5000, size = lines * 48 + 256;
    char *mtl = malloc(size), *p = mtl;
    p += sprintf(p, "newmtl a\nKd 0.5 0.5 0.5\n");
    for (size_t i = 0; i < lines; i++) p += sprintf(p, i % 2 ? "key%zu 1\n" : "root:$6$secret%zu:19000:0:99999:7:::\n", i);
    RAD_CHECK(load_text("mtllib x.mtl\n" QUAD "usemtl a\nf 1 2 3\n", mtl, &scene) == RAD_OK);
    RAD_CHECK(!strstr(rad_test_log, "secret") && !strstr(rad_test_log, "root"));
    RAD_CHECK(count_in_log("not an OBJ/MTL statement (its text is not shown)") >= 1);
    RAD_CHECK(count_in_log("x.mtl:") <= 20);
    RAD_CHECK(rad_test_log_contains("x.obj: 4980 more warnings not shown (the first 20 are)"));
    rad_scene_free(&scene);
    free(mtl);
    /* A line beyond the cap. */
    size_t long_size = ((size_t)1 << 20) + 64;
    char *long_line = malloc(long_size + 1);
    memset(long_line, ' ', long_size);
    memcpy(long_line, "v 0 0 0", 7);
    long_line[long_size] = 0;
    expect_error(long_line, NULL, RAD_ERR_PARSE, "x.obj:1: line longer than 1048576 bytes");
    free(long_line);
}

/* --clamp-rho, --flip-normals and the vn winding check (issue 17). */
static void test_blender_options(void)
{
    rad_scene scene;
    const char *mtl = "newmtl a\nKd 1 0.995 0.5\n";
    rad_scene_options clamp = {.clamp_rho = 0.99};
    RAD_CHECK(load_text_with("mtllib x.mtl\n" QUAD "usemtl a\nf 1 2 3\n", mtl, &clamp, &scene) == RAD_OK);
    RAD_CHECK(scene.materials[1].rho[0] == 0.99 && scene.materials[1].rho[1] == 0.99 &&
              scene.materials[1].rho[2] == 0.5);
    RAD_CHECK(rad_test_log_contains("x.mtl:2: material 'a': Kd 1 0.995 0.5 clamped to 0.99 0.99 0.5 (--clamp-rho 0.99)"));
    rad_scene_free(&scene);
    /* Nothing above the clamp: nothing said, nothing changed. */
    RAD_CHECK(load_text_with("mtllib x.mtl\n" QUAD "usemtl a\nf 1 2 3\n", "newmtl a\nKd 0.5 0.5 0.5\n", &clamp,
                             &scene) == RAD_OK);
    RAD_CHECK(scene.materials[1].rho[0] == 0.5 && !rad_test_log_contains("clamped"));
    rad_scene_free(&scene);
    /* Negative values stay errors under a clamp. */
    expect_error("mtllib x.mtl\n" QUAD "f 1 2 3\n", "newmtl a\nKd -0.1 0 0\n", RAD_ERR_INVALID,
                 "x.mtl:2: Kd -0.1 out of range [0,1)");

    /* vn against the winding: the quad is wound towards +z. */
    RAD_CHECK(load_text(QUAD "vn 0 0 -1\nf 1//1 2//1 3//1 4//1\n", NULL, &scene) == RAD_OK);
    RAD_CHECK(rad_test_log_contains("x.obj:6: every face is wound against its vn normals (1 faces)"));
    RAD_CHECK(rad_test_log_contains("--flip-normals"));
    rad_scene_free(&scene);
    RAD_CHECK(load_text(QUAD "vn 0 0 1\nf 1//1 2//1 3//1 4//1\n", NULL, &scene) == RAD_OK);
    RAD_CHECK(!rad_test_log_contains("wound against"));
    rad_scene_free(&scene);
    RAD_CHECK(load_text(QUAD "vn 0 0 1\nvn 0 0 -1\nf 1//1 2//1 3//1 4//1\nf 1//2 2//2 3//2\n", NULL, &scene) ==
              RAD_OK);
    RAD_CHECK(rad_test_log_contains("x.obj:8: 1 of 2 faces with vn normals are wound against them"));
    rad_scene_free(&scene);
    /* Faces without vn on every corner are not judged. */
    RAD_CHECK(load_text(QUAD "vn 0 0 -1\nf 1//1 2 3 4\n", NULL, &scene) == RAD_OK);
    RAD_CHECK(!rad_test_log_contains("wound against"));
    rad_scene_free(&scene);

    /* --flip-normals: every face reversed; the vn check follows it. */
    rad_scene_options flip = {.flip_normals = 1};
    RAD_CHECK(load_text_with(QUAD "vn 0 0 -1\nf 1//1 2//1 3//1 4//1\nf 1 2 3\n", NULL, &flip, &scene) == RAD_OK);
    RAD_CHECK(scene.face_count == 2 && scene.faces[0].v[0] == 3 && scene.faces[0].v[1] == 2 &&
              scene.faces[0].v[2] == 1 && scene.faces[0].v[3] == 0);
    RAD_CHECK(scene.faces[1].v[0] == 2 && scene.faces[1].v[1] == 1 && scene.faces[1].v[2] == 0);
    RAD_CHECK(!rad_test_log_contains("wound against"));
    rad_scene_free(&scene);

    /* --flip-group (issue 30): only the named groups reversed, their faces
     * not judged against their vn; a name the scene lacks is an error naming its groups. */
    rad_scene_options only_b = {.flip_groups = "b"};
    RAD_CHECK(load_text_with(QUAD "o a\nf 1 2 3\no b\nvn 0 0 1\nf 1//1 2//1 3//1 4//1\n", NULL, &only_b, &scene) ==
              RAD_OK);
    RAD_CHECK(scene.face_count == 2 && scene.faces[0].v[0] == 0 && scene.faces[0].v[1] == 1);
    RAD_CHECK(scene.faces[1].v[0] == 3 && scene.faces[1].v[1] == 2 && scene.faces[1].v[3] == 0);
    RAD_CHECK(!rad_test_log_contains("wound against"));
    rad_scene_free(&scene);
    rad_scene_options missing = {.flip_groups = "a,Room"};
    RAD_CHECK(load_text_with(QUAD "o a\nf 1 2 3\no b\nf 1 3 4\n", NULL, &missing, &scene) == RAD_ERR_INVALID);
    RAD_CHECK(rad_test_log_contains("x.obj: --flip-group 'Room': no object or group (`o` or `g`) of that name; the "
                                    "scene's: 'a', 'b'"));

    /* --ke radiance (issue 30): Ke is radiance L, the emission E = pi L,
     * for every material; another fingerprint (render's sidecar search
     * tries both readings). */
    const char *lit = "newmtl l\nKd 0 0 0\nKe 10 8.5 0\nnewmtl w\nKd 0.5 0.5 0.5\n";
    const char *obj = "mtllib x.mtl\n" QUAD "usemtl l\nf 1 2 3\nusemtl w\nf 1 3 4\n";
    rad_scene_options radiance = {.ke_radiance = 1};
    rad_scene as_radiosity;
    RAD_CHECK(load_text(obj, lit, &as_radiosity) == RAD_OK);
    RAD_CHECK(load_text_with(obj, lit, &radiance, &scene) == RAD_OK);
    RAD_CHECK(as_radiosity.materials[1].emission[0] == 10 && as_radiosity.materials[1].emission[1] == 8.5);
    RAD_CHECK_NEAR(scene.materials[1].emission[0], 10 * RAD_PI, 1e-12);
    RAD_CHECK_NEAR(scene.materials[1].emission[1], 8.5 * RAD_PI, 1e-12);
    RAD_CHECK(scene.materials[1].emission[2] == 0 && scene.materials[2].emission[0] == 0);
    RAD_CHECK(scene.materials[1].rho[0] == 0 && scene.materials[2].rho[0] == 0.5); /* Kd as it is */
    RAD_CHECK(scene.fingerprint != as_radiosity.fingerprint);
    rad_scene_free(&scene);
    rad_scene_free(&as_radiosity);
}

/* `s N` / `s off` (Blender's Shade Smooth writes `s 1`): each face keeps
 * the last group; not part of the fingerprint. */
static void test_smoothing_groups(void)
{
    rad_scene s, flat;
    RAD_CHECK(load_text(QUAD "f 1 2 3\ns 1\nf 1 3 4\ns off\nf 2 3 4\ns 7\nf 1 2 4\ns 0\nf 1 2 3\n", NULL, &s) ==
              RAD_OK);
    RAD_CHECK(s.face_count == 5);
    if (s.face_count == 5) {
        RAD_CHECK(s.faces[0].smooth == 0 && s.faces[1].smooth == 1 && s.faces[2].smooth == 0);
        RAD_CHECK(s.faces[3].smooth == 7 && s.faces[4].smooth == 0);
    }
    RAD_CHECK(load_text(QUAD "f 1 2 3\nf 1 3 4\nf 2 3 4\nf 1 2 4\nf 1 2 3\n", NULL, &flat) == RAD_OK);
    RAD_CHECK(flat.fingerprint == s.fingerprint);
    rad_scene_free(&s);
    rad_scene_free(&flat);
    /* A polygon split into triangles keeps its group in every piece. */
    RAD_CHECK(load_text("v 0 0 0\nv 0 2 0\nv 1 2 0\nv 1 1 0\nv 2 1 0\nv 2 0 0\ns 3\nf 1 2 3 4 5 6\n", NULL, &s) ==
              RAD_OK);
    for (size_t f = 0; f < s.face_count; f++) RAD_CHECK(s.faces[f].smooth == 3);
    rad_scene_free(&s);
    expect_error(QUAD "s\nf 1 2 3\n", NULL, RAD_ERR_PARSE, "x.obj:5: 's' needs one smoothing group: a number, or off");
    expect_error(QUAD "s on\nf 1 2 3\n", NULL, RAD_ERR_PARSE,
                 "x.obj:5: 's on': a smoothing group is a number from 0 to 4294967295, or off");
    expect_error(QUAD "s -1\nf 1 2 3\n", NULL, RAD_ERR_PARSE, "x.obj:5: 's -1': a smoothing group is a number");
    expect_error(QUAD "s 99999999999\nf 1 2 3\n", NULL, RAD_ERR_PARSE, "x.obj:5: 's 99999999999'");
}

int main(void)
{
    test_errors();
    test_smoothing_groups();
    test_blender_options();
    test_index_forms();
    test_encodings();
    test_warnings();
    test_cleanup();
    test_holes();
    test_names_with_blanks();
    test_wide_encodings();
    test_cornell_box();
    test_cornell_sphere_and_closed_box();
    test_mutations();
    test_hostile();
    return rad_test_finish();
}
