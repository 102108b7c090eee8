/* test_render.c - tests of render/: rasterizer, shading, tone map, camera,
 * image files; and the reference-free checks of a rendered Cornell box.
 *
 *   test_render                        unit tests
 *   test_render check-cornell IMAGE    checks a Cornell box picture taken
 *                                      with the default (measured) camera
 *   test_render check-grey GREY RGB    GREY (a grey scene drawn with
 *                                      --channels auto) is one channel equal
 *                                      to RGB's (--channels rgb) red channel
 *   test_render check-luminance Y RGB  Y (an EXR of a colour scene drawn with
 *                                      --channels grey) is RGB's luminance
 *   test_render check-layout IMAGE NAMES TYPE
 *                                      channel names ("R,G,B") and pixel type
 *   test_render cli RENDER RADIOSITY DIR
 *                                      render's command line: --channels
 *                                      (help text, bad values: exit 2,
 *                                      message, no file), the getopt forms
 *                                      (-oFILE, --name=VALUE, any order),
 *                                      unknown options, the default image
 *                                      name (<input without extension>.png)
 */
#define _POSIX_C_SOURCE 200809L
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>
#include <unistd.h>

#include "camera.h"
#include "frame.h"
#include "image.h"
#include "rad_color.h"
#include "rad_fs.h"
#include "rad_test.h"
#include "raster.h"
#include "shade.h"
#include "tonemap.h"

/* ---- rasterizer ---- */

static render_vertex vtx(double x, double y, double w, float r, float g, float b)
{
    render_vertex v = {x * w, y * w, w, {r, g, b}};
    return v;
}

static uint32_t lcg_next(uint32_t *state)
{
    *state = *state * 1664525u + 1013904223u;
    return *state >> 8;
}

/* A jittered grid of points covering more than the screen, triangulated
 * with random diagonals and random winding: every sample must be covered
 * exactly once. Some points sit exactly on sample centres and some edges
 * run exactly through them, to exercise the tie rules. */
static void test_fill_rule_watertight(int spp)
{
    enum { G = 7 };
    const int width = 23, height = 17;
    int n = (int)lround(sqrt(spp));
    double px[G][G], py[G][G];
    uint32_t seed = 12345u + (uint32_t)spp;
    for (int j = 0; j < G; j++) {
        for (int i = 0; i < G; i++) {
            double x = -1.6 + 3.2 * i / (G - 1), y = -1.6 + 3.2 * j / (G - 1);
            if (i > 0 && i < G - 1 && j > 0 && j < G - 1) {
                uint32_t r = lcg_next(&seed);
                if (r % 3 == 0) { /* snap to a sample centre */
                    int si = (int)((x + 1) / 2 * width * n), sj = (int)((1 - y) / 2 * height * n);
                    x = 2.0 * (si + 0.5) / (width * n) - 1.0;
                    y = 1.0 - 2.0 * (sj + 0.5) / (height * n);
                } else {
                    x += 0.15 * ((r & 0xffff) / 65536.0 - 0.5);
                    y += 0.15 * (((r >> 12) & 0xfff) / 4096.0 - 0.5);
                }
            }
            px[j][i] = x;
            py[j][i] = y;
        }
    }
    render_vertex tris[2 * (G - 1) * (G - 1) * 3];
    size_t count = 0;
    for (int j = 0; j + 1 < G; j++) {
        for (int i = 0; i + 1 < G; i++) {
            render_vertex a = vtx(px[j][i], py[j][i], 1, 1, 1, 1), b = vtx(px[j][i + 1], py[j][i + 1], 1, 1, 1, 1);
            render_vertex c = vtx(px[j + 1][i + 1], py[j + 1][i + 1], 1, 1, 1, 1);
            render_vertex d = vtx(px[j + 1][i], py[j + 1][i], 1, 1, 1, 1);
            uint32_t r = lcg_next(&seed);
            render_vertex q[2][3] = {{a, b, c}, {a, c, d}};
            if (r & 1) {
                render_vertex alt[2][3] = {{a, b, d}, {b, c, d}};
                memcpy(q, alt, sizeof q);
            }
            for (int t = 0; t < 2; t++) {
                if (r & (4u << t)) { /* reverse winding */
                    render_vertex tmp = q[t][1];
                    q[t][1] = q[t][2];
                    q[t][2] = tmp;
                }
                memcpy(&tris[3 * count++], q[t], sizeof q[t]);
            }
        }
    }
    render_raster_options opt = {width, height, spp, 0, 1e-3, 3};
    size_t samples = (size_t)width * n * height * n;
    uint32_t *counts = malloc(samples * sizeof *counts);
    RAD_CHECK(counts != NULL);
    if (!counts) return;
    RAD_CHECK(render_raster_coverage(&opt, tris, count, counts) == RAD_OK);
    size_t wrong = 0;
    for (size_t s = 0; s < samples; s++) wrong += counts[s] != 1;
    if (wrong) fprintf(stderr, "spp %d: %zu of %zu samples not covered exactly once\n", spp, wrong, samples);
    RAD_CHECK(wrong == 0);
    free(counts);
}

/* A sample exactly on a shared edge goes to one triangle only; a sample
 * on an outer edge goes in by the top-left rule only. */
static void test_fill_rule_ties(void)
{
    /* 4x4 pixels, spp 1: sample centres at ndc -0.75, -0.25, 0.25, 0.75.
     * The square [-0.75, 0.25]^2 has its edges through sample centres. */
    render_vertex q[6] = {vtx(-0.75, -0.75, 1, 1, 1, 1), vtx(0.25, -0.75, 1, 1, 1, 1), vtx(0.25, 0.25, 1, 1, 1, 1),
                          vtx(-0.75, -0.75, 1, 1, 1, 1), vtx(0.25, 0.25, 1, 1, 1, 1), vtx(-0.75, 0.25, 1, 1, 1, 1)};
    render_raster_options opt = {4, 4, 1, 1, 1e-3, 3};
    uint32_t counts[16];
    RAD_CHECK(render_raster_coverage(&opt, q, 2, counts) == RAD_OK);
    /* Columns 0..2 lie on or inside the x range; rows 1..3 (y down) the y
     * range. Top edge (row 1) and left edge (column 0) are in; the right
     * edge (column 2) and bottom edge (row 3) are out: a 2x2 block. */
    for (int j = 0; j < 4; j++)
        for (int i = 0; i < 4; i++) RAD_CHECK(counts[4 * j + i] == ((i <= 1 && j >= 1 && j <= 2) ? 1u : 0u));
}

static void test_culling(void)
{
    render_vertex ccw[3] = {vtx(-1, -1, 1, 1, 1, 1), vtx(1, -1, 1, 1, 1, 1), vtx(0, 1, 1, 1, 1, 1)};
    render_vertex cw[3] = {ccw[0], ccw[2], ccw[1]};
    render_raster_options opt = {8, 8, 1, 1, 1e-3, 3};
    uint32_t counts[64];
    size_t covered = 0;
    RAD_CHECK(render_raster_coverage(&opt, ccw, 1, counts) == RAD_OK);
    for (int s = 0; s < 64; s++) covered += counts[s];
    RAD_CHECK(covered > 20);
    RAD_CHECK(render_raster_coverage(&opt, cw, 1, counts) == RAD_OK);
    covered = 0;
    for (int s = 0; s < 64; s++) covered += counts[s];
    RAD_CHECK(covered == 0);
}

static void test_zbuffer(void)
{
    /* Two screen-filling triangles: red far (w = 4), green near (w = 2). */
    render_vertex far_near[6] = {vtx(-3, -3, 4, 1, 0, 0), vtx(3, -3, 4, 1, 0, 0), vtx(0, 3, 4, 1, 0, 0),
                                 vtx(-3, -3, 2, 0, 1, 0), vtx(3, -3, 2, 0, 1, 0), vtx(0, 3, 2, 0, 1, 0)};
    render_vertex near_far[6];
    memcpy(near_far, far_near + 3, 3 * sizeof *near_far);
    memcpy(near_far + 3, far_near, 3 * sizeof *near_far);
    float rgb[4 * 4 * 3];
    render_raster_options opt = {4, 4, 4, 1, 1e-3, 3};
    for (int order = 0; order < 2; order++) {
        RAD_CHECK(render_raster_draw(&opt, order ? near_far : far_near, 2, rgb) == RAD_OK);
        for (int p = 0; p < 16; p++) {
            RAD_CHECK_NEAR(rgb[3 * p + 0], 0.0, 1e-6);
            RAD_CHECK_NEAR(rgb[3 * p + 1], 1.0, 1e-6);
        }
    }
    /* Interpenetrating: a plane tilted in depth crosses a flat one at
     * ndc x = 0; left of it the tilted one (nearer there) wins. */
    render_vertex cross[9] = {vtx(-3, -3, 3, 0, 1, 0),  vtx(3, -3, 3, 0, 1, 0),  vtx(0, 3, 3, 0, 1, 0),
                              vtx(-1, -30, 1, 1, 0, 0), vtx(1, -30, 5, 1, 0, 0), vtx(1, 30, 5, 1, 0, 0),
                              vtx(-1, -30, 1, 1, 0, 0), vtx(1, 30, 5, 1, 0, 0),  vtx(-1, 30, 1, 1, 0, 0)};
    RAD_CHECK(render_raster_draw(&(render_raster_options){4, 4, 1, 0, 1e-3, 3}, cross, 3, rgb) == RAD_OK);
    /* The red quad goes from w = 1 at ndc x = -1 to w = 5 at ndc x = +1:
     * at ndc x = -0.75 its w is below 3 (red wins), at +0.75 above (green). */
    RAD_CHECK(rgb[3 * (4 * 1 + 0) + 0] > 0.5f && rgb[3 * (4 * 1 + 3) + 1] > 0.5f);
}

static void test_perspective_and_clipping(void)
{
    /* View-space points (X, Y, Z) with tan(half fov) = 1: clip = (X, Y, Z).
     * P0 = (-1,-2,1), P1 = (-1,2,1) have colour 0, P2 = (3,0,3) colour 1;
     * the ray through the image centre meets the plane at X = 0, where the
     * world-linear colour is (X + 1) / 4 = 0.25 (affine would give 0.5). */
    render_vertex t[3] = {{-1, -2, 1, {0, 0, 0}}, {3, 0, 3, {1, 1, 1}}, {-1, 2, 1, {0, 0, 0}}};
    float rgb[3 * 3 * 3];
    RAD_CHECK(render_raster_draw(&(render_raster_options){3, 3, 1, 0, 1e-3, 3}, t, 1, rgb) == RAD_OK);
    RAD_CHECK_NEAR(rgb[3 * 4], 0.25, 1e-6);
    /* A triangle reaching behind the eye is clipped, not mirrored: the part
     * in front still shows, nothing appears where only the hidden part would
     * project. */
    render_vertex behind[3] = {{-1, -1, 1, {1, 1, 1}}, {1, -1, 1, {1, 1, 1}}, {0, 5, -1, {1, 1, 1}}};
    uint32_t counts[9 * 9];
    RAD_CHECK(render_raster_coverage(&(render_raster_options){9, 9, 1, 0, 1e-3, 3}, behind, 1, counts) == RAD_OK);
    RAD_CHECK(counts[9 * 8 + 4] == 1); /* bottom centre: the front part */
    RAD_CHECK(counts[9 * 0 + 4] == 1); /* the clipped part runs up off-screen */
}

static void test_raster_options(void)
{
    rad_test_capture_log();
    RAD_CHECK(render_raster_check(&(render_raster_options){8, 8, 3, 1, 1, 3}, NULL) == RAD_ERR_INVALID);
    RAD_CHECK(rad_test_log_contains("not a square"));
    RAD_CHECK(render_raster_check(&(render_raster_options){0, 8, 1, 1, 1, 3}, NULL) == RAD_ERR_INVALID);
    RAD_CHECK(render_raster_check(&(render_raster_options){8, 8, 4, 1, 0, 3}, NULL) == RAD_ERR_INVALID);
    int n = 0;
    RAD_CHECK(render_raster_check(&(render_raster_options){8, 8, 0, 1, 1, 3}, &n) == RAD_OK && n == 4);
    RAD_CHECK(render_raster_check(&(render_raster_options){8, 8, 1, 1, 1, 2}, NULL) == RAD_ERR_INVALID);
    RAD_CHECK(rad_test_log_contains("2 channels per pixel (expected 1 or 3)"));
    RAD_CHECK(render_raster_check(&(render_raster_options){8, 8, 1, 1, 1, 1}, NULL) == RAD_OK);
    RAD_CHECK(render_raster_check(&(render_raster_options){8, 8, 1, 1, 1, 0}, NULL) == RAD_OK);
    rad_log_set_sink(NULL, NULL);
}

/* Drawing one channel gives channel 0 of the RGB drawing, bit for bit:
 * random overlapping and interpenetrating triangles of both windings, some
 * reaching behind the eye (clipped), with a different value in every
 * channel, at 1, 4 and 9 spp. Nothing is written past the one-channel
 * image. */
static void test_raster_grey(void)
{
    enum { W = 29, H = 19, T = 40 };
    render_vertex tris[3 * T];
    uint32_t seed = 777u;
    for (int i = 0; i < 3 * T; i++) {
        double x = 4.0 * (lcg_next(&seed) / 16777216.0) - 2.0, y = 4.0 * (lcg_next(&seed) / 16777216.0) - 2.0;
        double w = 3.5 * (lcg_next(&seed) / 16777216.0) - 0.5;
        float r = 2.0f * (float)(lcg_next(&seed) / 16777216.0), g = 1.0f - r, b = r * r;
        tris[i] = vtx(x, y, w == 0.0 ? 0.5 : w, r, g, b);
    }
    float *rgb = malloc(3 * W * H * sizeof *rgb), *grey = malloc((W * H + 8) * sizeof *grey);
    RAD_CHECK(rgb && grey);
    if (!rgb || !grey) goto done;
    for (int spp = 1; spp <= 9; spp += spp == 1 ? 3 : 5) {
        for (int i = 0; i < W * H + 8; i++) grey[i] = -7.0f;
        RAD_CHECK(render_raster_draw(&(render_raster_options){W, H, spp, 0, 1e-3, 3}, tris, T, rgb) == RAD_OK);
        RAD_CHECK(render_raster_draw(&(render_raster_options){W, H, spp, 0, 1e-3, 1}, tris, T, grey) == RAD_OK);
        size_t differ = 0, lit = 0, distinct = 0;
        for (int p = 0; p < W * H; p++) {
            differ += memcmp(&grey[p], &rgb[3 * p], sizeof *grey) != 0;
            lit += grey[p] > 0.0f;
            distinct += rgb[3 * p] != rgb[3 * p + 1];
        }
        if (differ) fprintf(stderr, "spp %d: %zu of %d grey pixels differ from the red channel\n", spp, differ, W * H);
        RAD_CHECK(differ == 0);
        RAD_CHECK(lit > W * H / 4 && distinct > W * H / 4); /* not vacuous: drawn, and channels differ */
        for (int i = W * H; i < W * H + 8; i++) RAD_CHECK(grey[i] == -7.0f);
    }
done:
    free(rgb);
    free(grey);
}

/* ---- tone map ---- */

static void test_srgb(void)
{
    RAD_CHECK_NEAR(render_srgb_encode(0.0), 0.0, 1e-12);
    RAD_CHECK_NEAR(render_srgb_encode(1.0), 1.0, 1e-12);
    RAD_CHECK_NEAR(render_srgb_encode(0.0031308), 0.040449936, 1e-9); /* the linear segment's end */
    RAD_CHECK_NEAR(render_srgb_encode(0.18), 0.4613561, 1e-6);
    RAD_CHECK_NEAR(render_srgb_encode(0.5), 0.7353570, 1e-6);
    RAD_CHECK_NEAR(render_srgb_encode(2.0), 1.0, 1e-12);
    RAD_CHECK_NEAR(render_srgb_encode(-1.0), 0.0, 1e-12);
    RAD_CHECK_NEAR(render_srgb_encode(NAN), 0.0, 1e-12);
    double prev = -1;
    int monotone = 1;
    for (int i = 0; i <= 1000; i++) {
        double v = render_srgb_encode(i / 1000.0);
        monotone &= v > prev;
        prev = v;
    }
    RAD_CHECK(monotone);
    float px[3] = {0.25f, 0.5f, 4.0f};
    render_tonemap_apply(px, 1, 3, 2.0);
    RAD_CHECK_NEAR(px[0], 0.7353570, 1e-6);
    RAD_CHECK_NEAR(px[1], 1.0, 1e-6);
    RAD_CHECK_NEAR(px[2], 1.0, 1e-6);
    /* One channel: two grey pixels are two values; the third is not touched. */
    float grey[3] = {0.25f, 0.5f, 0.125f};
    render_tonemap_apply(grey, 2, 1, 2.0);
    RAD_CHECK_NEAR(grey[0], 0.7353570, 1e-6);
    RAD_CHECK_NEAR(grey[1], 1.0, 1e-6);
    RAD_CHECK(grey[2] == 0.125f);
}

/* ---- synthetic meshes ---- */

typedef struct test_mesh {
    rad_mesh mesh;
    size_t vcap, pcap;
} test_mesh;

static uint32_t add_vertex(test_mesh *t, rad_vec3 p)
{
    if (t->mesh.vertex_count == t->vcap) {
        t->vcap = t->vcap ? 2 * t->vcap : 64;
        t->mesh.positions = realloc(t->mesh.positions, 3 * t->vcap * sizeof(double));
    }
    double *dst = &t->mesh.positions[3 * t->mesh.vertex_count];
    dst[0] = p.x;
    dst[1] = p.y;
    dst[2] = p.z;
    return (uint32_t)t->mesh.vertex_count++;
}

static rad_patch *add_quad(test_mesh *t, const uint32_t v[4], const double rho[3], const double emission[3])
{
    if (t->mesh.patch_count == t->pcap) {
        t->pcap = t->pcap ? 2 * t->pcap : 64;
        t->mesh.patches = realloc(t->mesh.patches, t->pcap * sizeof(rad_patch));
    }
    rad_patch *p = &t->mesh.patches[t->mesh.patch_count++];
    memset(p, 0, sizeof *p);
    p->vertex_count = 4;
    rad_vec3 c[4];
    for (int k = 0; k < 4; k++) {
        p->v[k] = v[k];
        const double *x = &t->mesh.positions[3 * v[k]];
        c[k] = rad_v3(x[0], x[1], x[2]);
    }
    rad_vec3 n = rad_v3_add(rad_v3_cross(rad_v3_sub(c[1], c[0]), rad_v3_sub(c[2], c[0])),
                            rad_v3_cross(rad_v3_sub(c[2], c[0]), rad_v3_sub(c[3], c[0])));
    p->area = 0.5 * rad_v3_length(n);
    p->normal = rad_v3_normalize(n);
    p->centroid = rad_v3_scale(rad_v3_add(rad_v3_add(c[0], c[1]), rad_v3_add(c[2], c[3])), 0.25);
    memcpy(p->rho, rho, sizeof p->rho);
    memcpy(p->emission, emission, sizeof p->emission);
    return p;
}

/* A wall with corners a, b, c, d (counter-clockwise seen from the front)
 * cut into k x k patches on a shared vertex grid. */
static void add_wall(test_mesh *t, rad_vec3 a, rad_vec3 b, rad_vec3 c, rad_vec3 d, int k, const double rho[3],
                     const double emission[3])
{
    uint32_t grid[9][9];
    for (int j = 0; j <= k; j++) {
        for (int i = 0; i <= k; i++) {
            rad_vec3 ab = rad_v3_lerp(a, b, (double)i / k), dc = rad_v3_lerp(d, c, (double)i / k);
            grid[j][i] = add_vertex(t, rad_v3_lerp(ab, dc, (double)j / k));
        }
    }
    for (int j = 0; j < k; j++) {
        for (int i = 0; i < k; i++) {
            uint32_t v[4] = {grid[j][i], grid[j][i + 1], grid[j + 1][i + 1], grid[j + 1][i]};
            add_quad(t, v, rho, emission);
        }
    }
}

static void test_shade_creases(void)
{
    const double white[3] = {0.7, 0.7, 0.7}, red[3] = {0.6, 0.1, 0.1}, none[3] = {0, 0, 0}, glow[3] = {5, 5, 5};
    test_mesh t = {{0}, 0, 0};
    /* Floor (normal +y): two patches [0,1] and [1,3] in x, sharing the edge
     * x = 1. A wall at x = 0 (normal +x) shares the floor's edge x = 0.
     * An emitting patch beside the floor, coplanar, shares the edge x = 3. */
    uint32_t f[6] = {add_vertex(&t, rad_v3(0, 0, 0)), add_vertex(&t, rad_v3(1, 0, 0)), add_vertex(&t, rad_v3(3, 0, 0)),
                     add_vertex(&t, rad_v3(0, 0, -1)), add_vertex(&t, rad_v3(1, 0, -1)),
                     add_vertex(&t, rad_v3(3, 0, -1))};
    uint32_t up0 = add_vertex(&t, rad_v3(0, 1, 0)), up1 = add_vertex(&t, rad_v3(0, 1, -1));
    uint32_t e0 = add_vertex(&t, rad_v3(4, 0, 0)), e1 = add_vertex(&t, rad_v3(4, 0, -1));
    add_quad(&t, (uint32_t[4]){f[0], f[1], f[4], f[3]}, white, none);  /* area 1 */
    add_quad(&t, (uint32_t[4]){f[1], f[2], f[5], f[4]}, white, none);  /* area 2 */
    add_quad(&t, (uint32_t[4]){f[0], f[3], up1, up0}, red, none);      /* wall */
    add_quad(&t, (uint32_t[4]){f[2], e0, e1, f[5]}, white, glow);      /* emitter */
    RAD_CHECK(rad_v3_dot(t.mesh.patches[0].normal, rad_v3(0, 1, 0)) > 0.999);
    RAD_CHECK(rad_v3_dot(t.mesh.patches[2].normal, rad_v3(1, 0, 0)) > 0.999);
    double b[4 * 3] = {1, 1, 1, 4, 4, 4, 10, 1, 1, 50, 50, 50};
    double corners[4 * 12];
    RAD_CHECK(render_shade_corners(&t.mesh, b, 3, RENDER_SHADING_SMOOTH, corners) == RAD_OK);
    /* Floor patch 0: corner at x = 0 sees only itself (the wall is a
     * crease); corner at x = 1 averages 1 and 4 by area: (1 + 2*4) / 3. */
    RAD_CHECK_NEAR(corners[(4 * 0 + 0) * 3], 1.0, 1e-12);
    RAD_CHECK_NEAR(corners[(4 * 0 + 1) * 3], 3.0, 1e-12);
    RAD_CHECK_NEAR(corners[(4 * 1 + 0) * 3], 3.0, 1e-12);
    /* Floor patch 1 at x = 3: the coplanar emitter is another material. */
    RAD_CHECK_NEAR(corners[(4 * 1 + 1) * 3], 4.0, 1e-12);
    /* The wall keeps its own colour at the crease; the emitter its own. */
    RAD_CHECK_NEAR(corners[(4 * 2 + 0) * 3 + 0], 10.0, 1e-12);
    RAD_CHECK_NEAR(corners[(4 * 2 + 0) * 3 + 1], 1.0, 1e-12);
    RAD_CHECK_NEAR(corners[(4 * 3 + 0) * 3], 50.0, 1e-12);
    /* One channel: channel 0 of every corner, packed one value per corner. */
    double grey[4 * 4];
    RAD_CHECK(render_shade_corners(&t.mesh, b, 1, RENDER_SHADING_SMOOTH, grey) == RAD_OK);
    for (int c = 0; c < 16; c++) RAD_CHECK(grey[c] == corners[3 * c]);
    RAD_CHECK(render_shade_corners(&t.mesh, b, 3, RENDER_SHADING_FLAT, corners) == RAD_OK);
    RAD_CHECK_NEAR(corners[(4 * 0 + 1) * 3], 1.0, 1e-12);
    RAD_CHECK_NEAR(corners[(4 * 1 + 0) * 3], 4.0, 1e-12);
    RAD_CHECK(render_shade_corners(&t.mesh, b, 1, RENDER_SHADING_FLAT, grey) == RAD_OK);
    for (int c = 0; c < 16; c++) RAD_CHECK(grey[c] == corners[3 * c]);
    rad_test_capture_log();
    RAD_CHECK(render_shade_corners(&t.mesh, b, 2, RENDER_SHADING_FLAT, corners) == RAD_ERR_INVALID);
    RAD_CHECK(rad_test_log_contains("2 colour channels"));
    rad_log_set_sink(NULL, NULL);
    /* Auto exposure ignores the emitter (50) and uses the brightest
     * channel: by area, {1: 1, 4: 2, 10: 1}; the 95th percentile is 10,
     * the 70th would be 4. */
    RAD_CHECK_NEAR(render_tonemap_auto_scale(&t.mesh, b), RENDER_AUTO_TARGET / 10.0, 1e-12);
    b[6] = 0.5; /* the wall now darkest: {0.5: 1, 1: 1, 4: 2} -> 4 */
    RAD_CHECK_NEAR(render_tonemap_auto_scale(&t.mesh, b), RENDER_AUTO_TARGET / 4.0, 1e-12);
    RAD_CHECK_NEAR(rad_luminance(b), 1.0, 1e-12);
    rad_mesh_free(&t.mesh);
}

/* A Cornell-sized room (floor, ceiling with a light, back, red left wall
 * at x = 556, green right wall at x = 0), patches with made-up radiosity. */
/* Smoothing groups (OBJ `s`, Blender's Shade Smooth): two faces of a
 * curved surface 30 degrees apart blend at their shared edge only when
 * both are in one group and of one material; a face turned away (a thin
 * plate's back) never does. */
static void test_shade_smoothing_groups(void)
{
    const double white[3] = {0.7, 0.7, 0.7}, grey[3] = {0.5, 0.5, 0.5}, none[3] = {0, 0, 0};
    test_mesh t = {{0}, 0, 0};
    /* Patch 0 in y = 0 (normal +y), x in [-1, 0]; patch 1 bent up 30 degrees
     * about the shared edge x = 0. Equal areas. */
    double c = cos(RAD_PI / 6), sn = sin(RAD_PI / 6);
    uint32_t a0 = add_vertex(&t, rad_v3(-1, 0, 0)), a1 = add_vertex(&t, rad_v3(0, 0, 0));
    uint32_t a2 = add_vertex(&t, rad_v3(0, 0, -1)), a3 = add_vertex(&t, rad_v3(-1, 0, -1));
    uint32_t b1 = add_vertex(&t, rad_v3(c, sn, 0)), b2 = add_vertex(&t, rad_v3(c, sn, -1));
    add_quad(&t, (uint32_t[4]){a0, a1, a2, a3}, white, none)->source_face = 0;
    add_quad(&t, (uint32_t[4]){a1, b1, b2, a2}, white, none)->source_face = 1;
    RAD_CHECK(rad_v3_dot(t.mesh.patches[0].normal, t.mesh.patches[1].normal) < 0.9);
    double b[2 * 3] = {1, 1, 1, 3, 3, 3}, corners[2 * 4 * 3];
    /* Patch 0's corner 1 (vertex a1) lies on the shared edge. */
    const size_t at = (4 * 0 + 1) * 3;
    uint32_t one_group[2] = {1, 1}, two_groups[2] = {1, 2}, flat[2] = {0, 0};
    render_smoothing same = {one_group, 2}, apart = {two_groups, 2}, none_set = {flat, 2};
    for (int shading = 0; shading < 3; shading++) {
        if (shading == RENDER_SHADING_FLAT) continue;
        RAD_CHECK(render_shade_corners_smoothed(&t.mesh, b, 3, (render_shading)shading, NULL, corners) == RAD_OK);
        RAD_CHECK_NEAR(corners[at], 1.0, 1e-12); /* a crease without groups */
        RAD_CHECK(render_shade_corners_smoothed(&t.mesh, b, 3, (render_shading)shading, &apart, corners) == RAD_OK);
        RAD_CHECK_NEAR(corners[at], 1.0, 1e-12);
        RAD_CHECK(render_shade_corners_smoothed(&t.mesh, b, 3, (render_shading)shading, &none_set, corners) == RAD_OK);
        RAD_CHECK_NEAR(corners[at], 1.0, 1e-12);
    }
    RAD_CHECK(render_shade_corners_smoothed(&t.mesh, b, 3, RENDER_SHADING_SMOOTH, &same, corners) == RAD_OK);
    RAD_CHECK_NEAR(corners[at], 2.0, 1e-12); /* (1 + 3) / 2: equal areas */
    RAD_CHECK_NEAR(corners[(4 * 1 + 0) * 3], 2.0, 1e-12);
    RAD_CHECK_NEAR(corners[(4 * 0 + 0) * 3], 1.0, 1e-12); /* away from the edge */
    /* Another material in the same group: no blending. */
    memcpy(t.mesh.patches[1].rho, grey, sizeof grey);
    RAD_CHECK(render_shade_corners_smoothed(&t.mesh, b, 3, RENDER_SHADING_SMOOTH, &same, corners) == RAD_OK);
    RAD_CHECK_NEAR(corners[at], 1.0, 1e-12);
    memcpy(t.mesh.patches[1].rho, white, sizeof white);
    /* A face out of the group table's range: as without groups. */
    render_smoothing short_table = {one_group, 1};
    RAD_CHECK(render_shade_corners_smoothed(&t.mesh, b, 3, RENDER_SHADING_SMOOTH, &short_table, corners) == RAD_OK);
    RAD_CHECK_NEAR(corners[at], 1.0, 1e-12);
    /* Folded back on itself (normals apart): never blended. */
    t.mesh.patches[1].normal = rad_v3_scale(t.mesh.patches[0].normal, -1.0);
    RAD_CHECK(render_shade_corners_smoothed(&t.mesh, b, 3, RENDER_SHADING_SMOOTH, &same, corners) == RAD_OK);
    RAD_CHECK_NEAR(corners[at], 1.0, 1e-12);
    free(t.mesh.positions);
    free(t.mesh.patches);
}

static void make_room(test_mesh *t, double **out_b)
{
    const double white[3] = {0.7, 0.7, 0.7}, red[3] = {0.6, 0.06, 0.05}, green[3] = {0.14, 0.45, 0.09};
    const double none[3] = {0, 0, 0}, light[3] = {17, 12, 4};
    const double X = 556, Y = 548.8, Z = 559.2;
    add_wall(t, rad_v3(X, 0, 0), rad_v3(0, 0, 0), rad_v3(0, 0, Z), rad_v3(X, 0, Z), 4, white, none);    /* floor */
    add_wall(t, rad_v3(X, Y, 0), rad_v3(X, Y, Z), rad_v3(0, Y, Z), rad_v3(0, Y, 0), 4, white, none);    /* ceiling */
    add_wall(t, rad_v3(X, 0, Z), rad_v3(0, 0, Z), rad_v3(0, Y, Z), rad_v3(X, Y, Z), 4, white, none);    /* back */
    add_wall(t, rad_v3(0, 0, Z), rad_v3(0, 0, 0), rad_v3(0, Y, 0), rad_v3(0, Y, Z), 4, green, none);    /* right */
    add_wall(t, rad_v3(X, 0, 0), rad_v3(X, 0, Z), rad_v3(X, Y, Z), rad_v3(X, Y, 0), 4, red, none);      /* left */
    add_wall(t, rad_v3(343, Y - 1, 227), rad_v3(343, Y - 1, 332), rad_v3(213, Y - 1, 332),
             rad_v3(213, Y - 1, 227), 1, white, light);                                                   /* light */
    double *b = malloc(3 * t->mesh.patch_count * sizeof *b);
    for (size_t p = 0; p < t->mesh.patch_count; p++) {
        const rad_patch *patch = &t->mesh.patches[p];
        /* Brighter towards the top, plus a hint of the left wall's red. */
        double h = 0.2 + 0.2 * patch->centroid.y / Y, bleed = 0.05 * patch->centroid.x / X;
        for (int c = 0; c < 3; c++)
            b[3 * p + c] = patch->emission[c] + patch->rho[c] * h + (c == 0 ? bleed : 0.0);
    }
    *out_b = b;
}

/* ---- camera ---- */

static void test_camera_parse(void)
{
    render_camera cam;
    const char good[] = "\xEF\xBB\xBF# comment\r\neye 1 2 3   # trailing comment\r\n\n  look_at 1 2 4\nfov_y 50";
    RAD_CHECK(render_camera_parse("good.camera", good, &cam) == RAD_OK);
    RAD_CHECK_NEAR(cam.eye.z, 3, 0);
    RAD_CHECK_NEAR(cam.look_at.z, 4, 0);
    RAD_CHECK_NEAR(cam.up.y, 1, 0); /* default up */
    RAD_CHECK_NEAR(cam.fov_y, 50, 0);
    /* The camera render writes into the image's metadata reads back as a
     * camera file, to the bit. */
    render_camera written = {rad_v3(278, 273, -800), rad_v3(278.5, 273, 0), rad_v3(0.1, 1, 0), 39.3077, 0, 0}, again;
    char meta[512];
    render_camera_format(&written, meta, sizeof meta);
    RAD_CHECK(render_camera_parse("meta", meta, &again) == RAD_OK && memcmp(&again, &written, sizeof again) == 0);
    static const struct {
        const char *text, *message;
        rad_status status;
    } bad[] = {
        {"eye 0 0 0\nlook_at 0 0 1\nzoom 2\n", "bad.camera:3: unknown key 'zoom'", RAD_ERR_PARSE},
        {"eye 0 0\nlook_at 0 0 1\n", "bad.camera:1: 'eye' takes 3 numbers", RAD_ERR_PARSE},
        {"eye 0 0 0 0\nlook_at 0 0 1\n", "bad.camera:1: 'eye' takes 3 numbers", RAD_ERR_PARSE},
        {"eye 0 0 0\nlook_at 0 abc 1\n", "bad.camera:2: 'abc' is not a finite number", RAD_ERR_PARSE},
        {"eye 0 0 0\nlook_at 0 0 1\neye 1 1 1\n", "bad.camera:3: 'eye' given twice (first on line 1)", RAD_ERR_PARSE},
        {"eye 0 0 0\nlook_at 0 0 inf\n", "bad.camera:2: 'inf' is not a finite number", RAD_ERR_PARSE},
        {"look_at 0 0 1\n", "bad.camera: missing 'eye'", RAD_ERR_INVALID},
        {"eye 0 0 0\nlook_at 0 0 1\nfov_y 180\n", "bad.camera:3: fov_y 180 is outside (0, 180)", RAD_ERR_INVALID},
        {"eye 0 0 0\nlook_at 0 0 0\n", "bad.camera: eye and look_at are the same point", RAD_ERR_INVALID},
        {"eye 0 0 0\nlook_at 0 5 0\n", "bad.camera: up (0 1 0) is zero or parallel", RAD_ERR_INVALID},
        {"eye 0 0 0\nlook_at 0 0 1\nwidth 640\n", "bad.camera:3: 'width' without 'height'", RAD_ERR_INVALID},
        {"eye 0 0 0\nlook_at 0 0 1\nheight 480\n", "bad.camera:3: 'height' without 'width'", RAD_ERR_INVALID},
        {"eye 0 0 0\nlook_at 0 0 1\nwidth 0\nheight 4\n", "bad.camera:3: width 0 is not a whole number of pixels",
         RAD_ERR_INVALID},
        {"eye 0 0 0\nlook_at 0 0 1\nwidth 6\nheight 4.5\n", "bad.camera:4: height 4.5 is not a whole number",
         RAD_ERR_INVALID},
        {"eye 0 0 0\nlook_at 0 0 1\nwidth 40000\nheight 4\n", "bad.camera:3: width 40000 is not a whole", RAD_ERR_INVALID},
        {"eye 0 0 0\nlook_at 0 0 1\nwidth 6 4\n", "bad.camera:3: 'width' takes 1 number", RAD_ERR_PARSE},
    };
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        rad_test_capture_log();
        cam.eye = rad_v3(42, 42, 42);
        rad_status s = render_camera_parse("bad.camera", bad[i].text, &cam);
        if (s != bad[i].status || !rad_test_log_contains(bad[i].message))
            fprintf(stderr, "case %zu: status %d, log: %s", i, (int)s, rad_test_log);
        RAD_CHECK(s == bad[i].status);
        RAD_CHECK(rad_test_log_contains(bad[i].message));
        RAD_CHECK(cam.eye.x == 42); /* untouched on failure */
    }
    /* The picture's size (tools/blender_export.py writes Blender's); none
     * given reads as 0 0. */
    RAD_CHECK(render_camera_parse("size", "eye 0 0 0\nlook_at 0 0 1\nwidth 1920\nheight 1080\n", &cam) == RAD_OK);
    RAD_CHECK(cam.width == 1920 && cam.height == 1080);
    RAD_CHECK(render_camera_parse("nosize", "eye 0 0 0\nlook_at 0 0 1\n", &cam) == RAD_OK);
    RAD_CHECK(cam.width == 0 && cam.height == 0);
    rad_test_capture_log();
    RAD_CHECK(render_camera_load("/nonexistent/x.camera", &cam) == RAD_ERR_IO);
    rad_log_set_sink(NULL, NULL);

    /* The scene's sidecar holds the built-in measured camera. */
    char path[1024];
    snprintf(path, sizeof path, "%s/cornell_box.camera", RAD_SCENES);
    if (access(path, R_OK) == 0) {
        render_camera ref = render_camera_cornell();
        RAD_CHECK(render_camera_load(path, &cam) == RAD_OK);
        RAD_CHECK(memcmp(&cam, &ref, sizeof cam) == 0);
    }
}

static void test_camera_default(void)
{
    test_mesh t = {{0}, 0, 0};
    double *b = NULL;
    make_room(&t, &b);
    render_camera cam;
    int cornell = 0;
    render_camera_default(&t.mesh, 1.0, &cam, &cornell);
    RAD_CHECK(cornell);
    RAD_CHECK_NEAR(cam.eye.z, -800, 0);

    /* Auto framing: scale and turn the room so that z is up (light at the
     * top); the camera must then use up = +z, stand outside, and see every
     * corner of the box. */
    for (size_t v = 0; v < t.mesh.vertex_count; v++) {
        double *x = &t.mesh.positions[3 * v], y = x[1];
        x[1] = -x[2] * 0.01;
        x[2] = y * 0.01;
        x[0] *= 0.01;
    }
    for (size_t p = 0; p < t.mesh.patch_count; p++) {
        rad_vec3 c = t.mesh.patches[p].centroid;
        t.mesh.patches[p].centroid = rad_v3(c.x * 0.01, -c.z * 0.01, c.y * 0.01);
    }
    render_camera_default(&t.mesh, 1.5, &cam, &cornell);
    RAD_CHECK(!cornell);
    RAD_CHECK(cam.up.z == 1.0);
    RAD_CHECK(cam.eye.y < -5.592);
    render_view view;
    RAD_CHECK(render_view_init(&cam, 1.5, &view) == RAD_OK);
    for (int k = 0; k < 8; k++) {
        rad_vec3 corner = rad_v3(k & 1 ? 5.56 : 0, k & 2 ? 0 : -5.592, k & 4 ? 5.488 : 0);
        double x = -1, y = -1;
        RAD_CHECK(render_view_project(&view, 300, 200, corner, &x, &y));
        RAD_CHECK(x >= 0 && x <= 300 && y >= 0 && y <= 200);
    }
    /* +x to the right with z up too (Blender's own front view). */
    double left = -1, right = -1, y = -1;
    RAD_CHECK(render_view_project(&view, 300, 200, rad_v3(0, -2.8, 2.7), &left, &y));
    RAD_CHECK(render_view_project(&view, 300, 200, rad_v3(5.56, -2.8, 2.7), &right, &y));
    RAD_CHECK(left < 150 && right > 150);
    free(b);
    rad_mesh_free(&t.mesh);
}

/* Auto framing of a Y-up scene (issue 30): from the front, +z, as Blender
 * exports its front view (Blender's -y is the OBJ's +z), so +x is on the
 * right and the scene is not seen from behind, mirrored. */
static void test_camera_front(void)
{
    test_mesh t = {{0}, 0, 0};
    double *b = NULL;
    make_room(&t, &b);
    for (size_t v = 0; v < t.mesh.vertex_count; v++) /* not the Cornell box's bounding box */
        for (int a = 0; a < 3; a++) t.mesh.positions[3 * v + a] *= 0.01;
    for (size_t p = 0; p < t.mesh.patch_count; p++)
        t.mesh.patches[p].centroid = rad_v3_scale(t.mesh.patches[p].centroid, 0.01);
    render_camera cam;
    int cornell = 1;
    render_camera_default(&t.mesh, 1.0, &cam, &cornell);
    RAD_CHECK(!cornell);
    RAD_CHECK(cam.up.y == 1.0);
    RAD_CHECK(cam.eye.z > 5.592 && cam.look_at.z < cam.eye.z); /* in front, looking along -z */
    render_view view;
    RAD_CHECK(render_view_init(&cam, 1.0, &view) == RAD_OK);
    double left = -1, right = -1, low = -1, high = -1, x = -1;
    RAD_CHECK(render_view_project(&view, 200, 200, rad_v3(0, 2.7, 2.8), &left, &high));
    RAD_CHECK(render_view_project(&view, 200, 200, rad_v3(5.56, 2.7, 2.8), &right, &high));
    RAD_CHECK(render_view_project(&view, 200, 200, rad_v3(2.78, 0, 2.8), &x, &low));
    RAD_CHECK(left < 100 && right > 100); /* +x on the right: not mirrored */
    RAD_CHECK(low > 100);                 /* y = 0 below the middle (pixel y runs down) */
    for (int k = 0; k < 8; k++) {
        rad_vec3 corner = rad_v3(k & 1 ? 5.56 : 0, k & 2 ? 5.488 : 0, k & 4 ? 5.592 : 0);
        RAD_CHECK(render_view_project(&view, 200, 200, corner, &x, &high));
        RAD_CHECK(x >= 0 && x <= 200 && high >= 0 && high <= 200);
    }
    free(b);
    rad_mesh_free(&t.mesh);
}

/* ---- images ---- */

static void test_image_files(void)
{
    char dir[] = "/tmp/test_render_XXXXXX";
    RAD_CHECK(mkdtemp(dir) != NULL);
    char png[256], exr[256], exr2[256], bad[256], missing[256];
    snprintf(png, sizeof png, "%s/a.png", dir);
    snprintf(exr, sizeof exr, "%s/a.exr", dir);
    snprintf(exr2, sizeof exr2, "%s/b.EXR", dir);
    snprintf(bad, sizeof bad, "%s/a.bmpx", dir);
    snprintf(missing, sizeof missing, "%s/no/such/dir/a.png", dir);
    enum { W = 5, H = 3 };
    float rgb[W * H * 3];
    for (int i = 0; i < W * H * 3; i++) rgb[i] = (float)i / (W * H * 3 - 1) * 1.25f; /* > 1 at the end */
    render_image_attr attrs[] = {{"rad:camera", "eye 1 2 3"}};
    RAD_CHECK(render_image_write(png, rgb, W, H, 3, attrs, 1) == RAD_OK);
    RAD_CHECK(render_image_write(exr, rgb, W, H, 3, attrs, 1) == RAD_OK);
    RAD_CHECK(render_image_write(exr2, rgb, W, H, 3, attrs, 1) == RAD_OK);
    float *back = NULL;
    int w = 0, h = 0, ch = 0;
    RAD_CHECK(render_image_read(png, &back, &w, &h, &ch) == RAD_OK && w == W && h == H && ch == 3);
    for (int i = 0; back && i < W * H * 3; i++) {
        double want = rgb[i] >= 1.0f ? 255.0 : floor(rgb[i] * 255.0 + 0.5);
        RAD_CHECK_NEAR(back[i] * 255.0, want, 1e-3);
    }
    free(back);
    back = NULL;
    RAD_CHECK(render_image_read(exr, &back, &w, &h, &ch) == RAD_OK && w == W && h == H && ch == 3);
    for (int i = 0; back && i < W * H * 3; i++) RAD_CHECK_NEAR(back[i], rgb[i], 1e-3 * rgb[i] + 1e-6);
    free(back);
    char text[64] = "";
    RAD_CHECK(render_image_read_attr(exr, "rad:camera", text, sizeof text) == RAD_OK);
    RAD_CHECK(strcmp(text, "eye 1 2 3") == 0);
    RAD_CHECK(render_image_read_attr(png, "rad:camera", text, sizeof text) == RAD_OK);
    RAD_CHECK(strcmp(text, "eye 1 2 3") == 0);

    /* Channel names and pixel types: R, G, B for colour. */
    char names[64] = "", type[16] = "";
    RAD_CHECK(render_image_read_layout(png, names, sizeof names, type, sizeof type) == RAD_OK);
    RAD_CHECK(strcmp(names, "R,G,B") == 0 && strcmp(type, "uint8") == 0);
    RAD_CHECK(render_image_read_layout(exr, names, sizeof names, type, sizeof type) == RAD_OK);
    RAD_CHECK(strcmp(names, "R,G,B") == 0 && strcmp(type, "half") == 0);

    /* One channel: an 8-bit grey PNG and an EXR with the one channel Y. */
    char gpng[256], gexr[256], two[256];
    snprintf(gpng, sizeof gpng, "%s/g.png", dir);
    snprintf(gexr, sizeof gexr, "%s/g.exr", dir);
    snprintf(two, sizeof two, "%s/two.exr", dir);
    RAD_CHECK(render_image_write(gpng, rgb, W, H, 1, attrs, 1) == RAD_OK); /* the first W * H values */
    RAD_CHECK(render_image_write(gexr, rgb, W, H, 1, attrs, 1) == RAD_OK);
    RAD_CHECK(render_image_read_layout(gpng, names, sizeof names, type, sizeof type) == RAD_OK);
    RAD_CHECK(strchr(names, ',') == NULL && strcmp(type, "uint8") == 0); /* one channel */
    RAD_CHECK(render_image_read_layout(gexr, names, sizeof names, type, sizeof type) == RAD_OK);
    RAD_CHECK(strcmp(names, "Y") == 0 && strcmp(type, "half") == 0);
    RAD_CHECK(render_image_read(gpng, &back, &w, &h, &ch) == RAD_OK && w == W && h == H && ch == 1);
    for (int i = 0; back && i < W * H; i++) RAD_CHECK_NEAR(back[i] * 255.0, floor(rgb[i] * 255.0 + 0.5), 1e-3);
    free(back);
    back = NULL;
    RAD_CHECK(render_image_read(gexr, &back, &w, &h, &ch) == RAD_OK && w == W && h == H && ch == 1);
    for (int i = 0; back && i < W * H; i++) RAD_CHECK_NEAR(back[i], rgb[i], 1e-3 * rgb[i] + 1e-6);
    free(back);
    back = NULL;
    rad_test_capture_log();
    RAD_CHECK(render_image_write(two, rgb, W, H, 2, NULL, 0) == RAD_ERR_INVALID);
    RAD_CHECK(rad_test_log_contains("2 channels (expected 1 or 3)"));
    RAD_CHECK(access(two, F_OK) != 0);
    rad_log_set_sink(NULL, NULL);

    /* Identical inputs, identical bytes (fixed DateTime). */
    char *a = NULL, *b = NULL;
    size_t na = 0, nb = 0;
    RAD_CHECK(rad_fs_read_all(exr, &a, &na) == RAD_OK && rad_fs_read_all(exr2, &b, &nb) == RAD_OK);
    RAD_CHECK(na == nb && a && b && memcmp(a, b, na) == 0);
    free(a);
    free(b);

    /* Failures: clear message, no file under the final name, no temporary. */
    rad_test_capture_log();
    RAD_CHECK(render_image_write(bad, rgb, W, H, 3, NULL, 0) == RAD_ERR_USAGE);
    RAD_CHECK(rad_test_log_contains("unknown image type"));
    RAD_CHECK(access(bad, F_OK) != 0);
    RAD_CHECK(render_image_write(missing, rgb, W, H, 3, NULL, 0) == RAD_ERR_IO);
    RAD_CHECK(rad_test_log_contains("no/such/dir/a.png: cannot write"));
    RAD_CHECK(access(missing, F_OK) != 0);
    rad_log_set_sink(NULL, NULL);
    char cmd[512];
    snprintf(cmd, sizeof cmd, "ls %s | grep -c tmp- >/dev/null", dir);
    RAD_CHECK(system(cmd) != 0); /* no leftover temporaries */
    snprintf(cmd, sizeof cmd, "rm -rf %s", dir);
    RAD_CHECK(system(cmd) == 0);
}

/* ---- whole frame ---- */

typedef struct window_mean {
    double r, g, b;
} window_mean;

/* Mean colour of the pixels in [x0, x1) x [y0, y1), in image fractions. */
static window_mean mean_in(const float *rgb, int w, int h, double x0, double x1, double y0, double y1)
{
    window_mean m = {0, 0, 0};
    int n = 0;
    for (int y = (int)(y0 * h); y < (int)(y1 * h); y++) {
        for (int x = (int)(x0 * w); x < (int)(x1 * w); x++) {
            const float *p = &rgb[3 * ((size_t)y * w + x)];
            m.r += p[0];
            m.g += p[1];
            m.b += p[2];
            n++;
        }
    }
    if (n) {
        m.r /= n;
        m.g /= n;
        m.b /= n;
    }
    return m;
}

/* The reference-free checks of a Cornell box image taken with the
 * measured camera (docs/render.md); returns the number of failures. */
static int check_cornell(const float *rgb, int w, int h)
{
    int before = rad_test_failures;
    /* Red wall on the left (it spans about 1-21 % of the width at mid
     * height), green wall on the right. */
    window_mean left = mean_in(rgb, w, h, 0.03, 0.12, 0.35, 0.65), right = mean_in(rgb, w, h, 0.88, 0.97, 0.35, 0.65);
    RAD_CHECK(left.r > 2.0 * left.g && left.r > 2.0 * left.b);
    RAD_CHECK(right.g > 1.2 * right.r && right.g > 1.2 * right.b); /* the light is warm */
    /* The light is the brightest region: of 16 x 16 blocks, the brightest
     * is in the top centre, and it is white. */
    int bx = -1, by = -1;
    double best = -1;
    for (int j = 0; j < 16; j++) {
        for (int i = 0; i < 16; i++) {
            window_mean m = mean_in(rgb, w, h, i / 16.0, (i + 1) / 16.0, j / 16.0, (j + 1) / 16.0);
            if (m.r + m.g + m.b > best) {
                best = m.r + m.g + m.b;
                bx = i;
                by = j;
            }
        }
    }
    RAD_CHECK(bx >= 6 && bx <= 9 && by >= 1 && by <= 3);
    /* ... and the brightest pixel is there too, and white. */
    size_t brightest = 0, n = (size_t)w * h;
    for (size_t p = 1; p < n; p++)
        if (rgb[3 * p] + rgb[3 * p + 1] + rgb[3 * p + 2] >
            rgb[3 * brightest] + rgb[3 * brightest + 1] + rgb[3 * brightest + 2])
            brightest = p;
    const float *light = &rgb[3 * brightest];
    double lx = (double)(brightest % (size_t)w) / w, ly = (double)(brightest / (size_t)w) / h;
    RAD_CHECK(lx > 0.35 && lx < 0.65 && ly > 0.05 && ly < 0.25);
    RAD_CHECK(light[0] > 0.95f && light[1] > 0.95f && light[2] > 0.95f);
    /* Not black, not saturated: mean in a sensible range, few clipped or
     * black pixels (only the light may clip). */
    window_mean all = mean_in(rgb, w, h, 0, 1, 0, 1);
    double mean = (all.r + all.g + all.b) / 3.0;
    size_t clipped = 0, black = 0;
    for (size_t p = 0; p < n; p++) {
        const float *c = &rgb[3 * p];
        clipped += c[0] >= 1.0f && c[1] >= 1.0f && c[2] >= 1.0f;
        black += c[0] < 0.02f && c[1] < 0.02f && c[2] < 0.02f;
    }
    RAD_CHECK(mean > 0.15 && mean < 0.8);
    RAD_CHECK(clipped < n / 20);
    RAD_CHECK(black < n / 8); /* the camera sees a thin black margin around the open front */
    /* Colour bleeding: the floor beside the red wall is redder than the
     * floor beside the green wall, and the other way round for green. */
    window_mean floor_red = mean_in(rgb, w, h, 0.08, 0.14, 0.90, 0.95);
    window_mean floor_green = mean_in(rgb, w, h, 0.86, 0.92, 0.90, 0.95);
    RAD_CHECK(floor_red.r / (floor_red.r + floor_red.g + floor_red.b) >
              floor_green.r / (floor_green.r + floor_green.g + floor_green.b));
    RAD_CHECK(floor_green.g / (floor_green.r + floor_green.g + floor_green.b) >
              floor_red.g / (floor_red.r + floor_red.g + floor_red.b));
    if (rad_test_failures != before)
        fprintf(stderr,
                "left %.3f %.3f %.3f, right %.3f %.3f %.3f, brightest block (%d,%d) pixel (%.2f,%.2f), "
                "mean %.3f, clipped %zu, black %zu of %zu, floor red side %.3f %.3f %.3f, green side %.3f %.3f %.3f\n",
                left.r, left.g, left.b, right.r, right.g, right.b, bx, by, lx, ly, mean, clipped, black, n,
                floor_red.r, floor_red.g, floor_red.b, floor_green.r, floor_green.g, floor_green.b);
    return rad_test_failures - before;
}

static void test_frame_room(void)
{
    test_mesh t = {{0}, 0, 0};
    double *b = NULL;
    make_room(&t, &b);
    render_camera cam;
    render_camera_default(&t.mesh, 1.0, &cam, NULL);
    enum { W = 96, H = 96 };
    float *rgb = malloc(W * H * 3 * sizeof *rgb), *rgb2 = malloc(W * H * 3 * sizeof *rgb2);
    render_frame_options opt = {W, H, 4, RENDER_SHADING_SMOOTH, 3, 0, NULL};
    RAD_CHECK(render_frame_draw(&t.mesh, b, &cam, &opt, rgb) == RAD_OK);
    render_tonemap_apply(rgb, W * H, 3, render_tonemap_auto_scale(&t.mesh, b));
    RAD_CHECK(check_cornell(rgb, W, H) == 0);
    /* Flat shading differs, but not in the big picture. */
    opt.shading = RENDER_SHADING_FLAT;
    RAD_CHECK(render_frame_draw(&t.mesh, b, &cam, &opt, rgb2) == RAD_OK);
    render_tonemap_apply(rgb2, W * H, 3, render_tonemap_auto_scale(&t.mesh, b));
    RAD_CHECK(memcmp(rgb, rgb2, W * H * 3 * sizeof *rgb) != 0);
    RAD_CHECK(check_cornell(rgb2, W, H) == 0);
    free(rgb);
    free(rgb2);
    free(b);
    rad_mesh_free(&t.mesh);
}

/* A whole frame drawn for one channel is channel 0 of the RGB frame, bit
 * for bit, before and after the tone map, smooth and flat; drawn from the
 * patches' luminance it is the RGB frame's luminance (to float rounding). */
static void test_frame_grey(void)
{
    test_mesh t = {{0}, 0, 0};
    double *b = NULL, *lum = NULL;
    make_room(&t, &b);
    render_camera cam;
    render_camera_default(&t.mesh, 1.0, &cam, NULL);
    enum { W = 64, H = 48 };
    float *rgb = malloc(W * H * 3 * sizeof *rgb), *grey = malloc(W * H * sizeof *grey);
    lum = malloc(3 * t.mesh.patch_count * sizeof *lum);
    RAD_CHECK(rgb && grey && lum);
    if (!rgb || !grey || !lum) goto done;
    double scale = render_tonemap_auto_scale(&t.mesh, b);
    for (int shading = 0; shading < 2; shading++) {
        render_frame_options opt = {W, H, 4, shading ? RENDER_SHADING_FLAT : RENDER_SHADING_SMOOTH, 3, 0, NULL};
        RAD_CHECK(render_frame_draw(&t.mesh, b, &cam, &opt, rgb) == RAD_OK);
        opt.channels = 1;
        RAD_CHECK(render_frame_draw(&t.mesh, b, &cam, &opt, grey) == RAD_OK);
        size_t differ = 0, differ_png = 0;
        for (int p = 0; p < W * H; p++) differ += memcmp(&grey[p], &rgb[3 * p], sizeof *grey) != 0;
        render_tonemap_apply(rgb, W * H, 3, scale);
        render_tonemap_apply(grey, W * H, 1, scale);
        for (int p = 0; p < W * H; p++) differ_png += memcmp(&grey[p], &rgb[3 * p], sizeof *grey) != 0;
        RAD_CHECK(differ == 0 && differ_png == 0);
    }
    /* Luminance: Rec. 709 weights of the linear RGB frame. */
    render_luminance_radiosity(b, t.mesh.patch_count, lum);
    RAD_CHECK_NEAR(lum[0], 0.2126 * b[0] + 0.7152 * b[1] + 0.0722 * b[2], 1e-15);
    RAD_CHECK(lum[0] == lum[1] && lum[1] == lum[2]);
    render_frame_options opt = {W, H, 4, RENDER_SHADING_SMOOTH, 3, 0, NULL};
    RAD_CHECK(render_frame_draw(&t.mesh, b, &cam, &opt, rgb) == RAD_OK);
    opt.channels = 1;
    RAD_CHECK(render_frame_draw(&t.mesh, lum, &cam, &opt, grey) == RAD_OK);
    double worst = 0.0;
    for (int p = 0; p < W * H; p++) {
        double want = rad_luminance((double[3]){rgb[3 * p], rgb[3 * p + 1], rgb[3 * p + 2]});
        worst = fmax(worst, fabs(grey[p] - want) / (1e-3 + want));
    }
    if (worst > 1e-5) fprintf(stderr, "luminance frame: relative difference %g\n", worst);
    RAD_CHECK(worst <= 1e-5);
    /* Linear shading limits its gradients, which is not linear in B: the
     * luminance picture is then drawn from the RGB corners (opt.luminance),
     * and is still the colour picture's luminance. */
    opt = (render_frame_options){W, H, 4, RENDER_SHADING_LINEAR, 3, 0, NULL};
    RAD_CHECK(render_frame_draw(&t.mesh, b, &cam, &opt, rgb) == RAD_OK);
    opt.channels = 1;
    opt.luminance = 1;
    RAD_CHECK(render_frame_draw(&t.mesh, b, &cam, &opt, grey) == RAD_OK);
    worst = 0.0;
    for (int p = 0; p < W * H; p++) {
        double want = rad_luminance((double[3]){rgb[3 * p], rgb[3 * p + 1], rgb[3 * p + 2]});
        worst = fmax(worst, fabs(grey[p] - want) / (1e-3 + want));
    }
    if (worst > 1e-5) fprintf(stderr, "luminance frame, linear shading: relative difference %g\n", worst);
    RAD_CHECK(worst <= 1e-5);
    opt.luminance = 0;
    rad_test_capture_log();
    opt.channels = 2;
    RAD_CHECK(render_frame_draw(&t.mesh, b, &cam, &opt, rgb) == RAD_ERR_INVALID);
    RAD_CHECK(rad_test_log_contains("2 channels per pixel"));
    rad_log_set_sink(NULL, NULL);
done:
    free(rgb);
    free(grey);
    free(lum);
    free(b);
    rad_mesh_free(&t.mesh);
}

static int check_cornell_file(const char *path)
{
    float *rgb = NULL;
    int w = 0, h = 0, channels = 0;
    if (render_image_read(path, &rgb, &w, &h, &channels) != RAD_OK) return 1;
    RAD_CHECK(channels == 3); /* a colour scene stays RGB */
    if (channels == 3) check_cornell(rgb, w, h);
    free(rgb);
    return rad_test_finish();
}

static int ends_with(const char *s, const char *suffix)
{
    size_t n = strlen(s), m = strlen(suffix);
    return n >= m && strcmp(s + n - m, suffix) == 0;
}

/* GREY: a grey scene as render writes it by default; RGB: the same with
 * --channels rgb. GREY has one channel (PNG: 8-bit; EXR: named Y, half),
 * RGB three equal ones (R, G, B), and GREY's values are RGB's red channel
 * exactly: the same arithmetic on the same numbers. */
static int check_grey_files(const char *grey_path, const char *rgb_path)
{
    float *grey = NULL, *rgb = NULL;
    int w = 0, h = 0, c = 0, w3 = 0, h3 = 0, c3 = 0;
    const int exr = ends_with(grey_path, ".exr");
    char names[64] = "", type[16] = "";
    RAD_CHECK(render_image_read_layout(grey_path, names, sizeof names, type, sizeof type) == RAD_OK);
    RAD_CHECK(strcmp(names, "Y") == 0 || (!exr && strchr(names, ',') == NULL));
    RAD_CHECK(strcmp(type, exr ? "half" : "uint8") == 0);
    if (rad_test_failures) fprintf(stderr, "%s: channels '%s', type '%s'\n", grey_path, names, type);
    RAD_CHECK(render_image_read_layout(rgb_path, names, sizeof names, type, sizeof type) == RAD_OK);
    RAD_CHECK(strcmp(names, "R,G,B") == 0 && strcmp(type, exr ? "half" : "uint8") == 0);
    RAD_CHECK(render_image_read(grey_path, &grey, &w, &h, &c) == RAD_OK && c == 1);
    RAD_CHECK(render_image_read(rgb_path, &rgb, &w3, &h3, &c3) == RAD_OK && c3 == 3);
    if (grey && rgb && c == 1 && c3 == 3 && w == w3 && h == h3) {
        size_t n = (size_t)w * h, differ = 0, unequal = 0, lit = 0;
        float lo = grey[0], hi = grey[0];
        for (size_t p = 0; p < n; p++) {
            differ += memcmp(&grey[p], &rgb[3 * p], sizeof *grey) != 0;
            unequal += rgb[3 * p] != rgb[3 * p + 1] || rgb[3 * p] != rgb[3 * p + 2];
            lit += grey[p] > 0.0f;
            lo = grey[p] < lo ? grey[p] : lo;
            hi = grey[p] > hi ? grey[p] : hi;
        }
        if (differ || unequal)
            fprintf(stderr, "%zu of %zu pixels differ from the red channel; %zu RGB pixels not grey\n", differ, n,
                    unequal);
        RAD_CHECK(differ == 0 && unequal == 0);
        RAD_CHECK(lit > n / 2 && hi > lo); /* a picture, not a blank */
    } else {
        RAD_CHECK(w == w3 && h == h3);
    }
    free(grey);
    free(rgb);
    return rad_test_finish();
}

/* Y: a colour scene's EXR drawn with --channels grey; RGB: the same drawn
 * in colour. Y is 0.2126 R + 0.7152 G + 0.0722 B within half-float
 * rounding (both files are half: 2^-11 relative each). */
static int check_luminance_files(const char *y_path, const char *rgb_path)
{
    float *y = NULL, *rgb = NULL;
    int w = 0, h = 0, c = 0, w3 = 0, h3 = 0, c3 = 0;
    char names[64] = "", type[16] = "";
    RAD_CHECK(render_image_read_layout(y_path, names, sizeof names, type, sizeof type) == RAD_OK);
    RAD_CHECK(strcmp(names, "Y") == 0);
    char values[128] = "";
    RAD_CHECK(render_image_read_attr(y_path, "rad:channels", values, sizeof values) == RAD_OK);
    RAD_CHECK(strcmp(values, "luminance") == 0);
    RAD_CHECK(render_image_read(y_path, &y, &w, &h, &c) == RAD_OK && c == 1);
    RAD_CHECK(render_image_read(rgb_path, &rgb, &w3, &h3, &c3) == RAD_OK && c3 == 3);
    if (y && rgb && c == 1 && c3 == 3 && w == w3 && h == h3) {
        size_t n = (size_t)w * h, bad = 0, lit = 0;
        double worst = 0.0;
        for (size_t p = 0; p < n; p++) {
            double want = rad_luminance((double[3]){rgb[3 * p], rgb[3 * p + 1], rgb[3 * p + 2]});
            double rel = fabs(y[p] - want) / (want + 1e-6);
            worst = fmax(worst, rel);
            bad += rel > 2e-3;
            lit += want > 0.0;
        }
        /* Not vacuous: in a colour scene Y is not the red channel. */
        size_t not_red = 0;
        for (size_t p = 0; p < n; p++) not_red += fabs(y[p] - rgb[3 * p]) > 0.05 * (rgb[3 * p] + 1e-6);
        fprintf(stderr, "luminance: largest relative difference %.3g; %zu of %zu pixels over 2e-3\n", worst, bad, n);
        RAD_CHECK(bad == 0 && lit > n / 2 && not_red > n / 10);
    } else {
        RAD_CHECK(w == w3 && h == h3);
    }
    free(y);
    free(rgb);
    return rad_test_finish();
}

static int check_layout_file(const char *path, const char *want_names, const char *want_type)
{
    char names[64] = "", type[16] = "";
    RAD_CHECK(render_image_read_layout(path, names, sizeof names, type, sizeof type) == RAD_OK);
    if (strcmp(names, want_names) != 0 || strcmp(type, want_type) != 0)
        fprintf(stderr, "%s: channels '%s', type '%s'; expected '%s', '%s'\n", path, names, type, want_names,
                want_type);
    RAD_CHECK(strcmp(names, want_names) == 0 && strcmp(type, want_type) == 0);
    return rad_test_finish();
}

/* Runs `cd CWD && RENDER ARGS > DIR/log.txt 2>&1` (CWD NULL: here);
 * returns the exit status (-1 if it did not exit) and leaves the output in
 * `log` (freed by the caller). */
static int run_render_in(const char *cwd, const char *render, const char *args, const char *dir, char **log)
{
    char cmd[8192], log_path[1024];
    snprintf(log_path, sizeof log_path, "%s/log.txt", dir);
    snprintf(cmd, sizeof cmd, "cd '%s' && '%s' %s > '%s' 2>&1", cwd ? cwd : ".", render, args, log_path);
    int rc = system(cmd);
    size_t n = 0;
    *log = NULL;
    if (rad_fs_read_all(log_path, log, &n) != RAD_OK) *log = NULL;
    return rc != -1 && WIFEXITED(rc) ? WEXITSTATUS(rc) : -1;
}

static int run_render(const char *render, const char *args, const char *dir, char **log)
{
    return run_render_in(NULL, render, args, dir, log);
}

/* Does DIR/NAME exist? */
static int exists_in(const char *dir, const char *name)
{
    char path[2048];
    snprintf(path, sizeof path, "%s/%s", dir, name);
    return access(path, F_OK) == 0;
}

/* The getopt forms, unknown options, the default image name. */
static void check_cli_forms(const char *render, const char *radiosity, const char *dir)
{
    char cmd[4096], args[2048], out[1024];
    char *log = NULL;
    snprintf(out, sizeof out, "%s/out.png", dir);
    /* -oFILE, --name=VALUE, options after the input. */
    static const struct {
        const char *before, *output, *after; /* before the input, -o and its value, after */
    } forms[] = {{"", "-o", "-q --width=16 --height 16 --spp=1"},
                 {"-q --width 16 --height=16 --spp 1 --shading=flat -o ", "", ""},
                 {"", "--output=", "-q --wid 16 --hei 16 --spp 1 --exp=-1"}};
    for (size_t i = 0; i < sizeof forms / sizeof forms[0]; i++) {
        if (forms[i].before[0])
            snprintf(args, sizeof args, "%s'%s' '%s' %s", forms[i].before, out, radiosity, forms[i].after);
        else
            snprintf(args, sizeof args, "'%s' %s'%s' %s", radiosity, forms[i].output, out, forms[i].after);
        int rc = run_render(render, args, dir, &log);
        if (rc != 0 || access(out, F_OK) != 0)
            fprintf(stderr, "render %s: exit %d, output: %s\n", args, rc, log ? log : "(none)");
        RAD_CHECK(rc == 0 && access(out, F_OK) == 0);
        free(log);
        remove(out);
    }
    /* Unknown options and bad values: exit 2, said, nothing written. */
    static const struct {
        const char *args, *message;
    } bad[] = {
        {"--bogus", "render: error: unknown option '--bogus' (see render --help)"},
        {"-x", "unknown option '-x'"},
        {"--width 0", "--width: '0' is not an integer in [1, "},
        {"--eye 1,2", "--eye: '1,2' is not three numbers X,Y,Z"},
        {"--shading", "--shading needs a value"},
        {"-o", "-o needs a value"},
    };
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        snprintf(args, sizeof args, "'%s' --width 16 --height 16 --spp 1 %s", radiosity, bad[i].args);
        int rc = run_render_in(dir, render, args, dir, &log);
        if (rc != 2 || !log || !strstr(log, bad[i].message))
            fprintf(stderr, "render %s: exit %d, output: %s\n", args, rc, log ? log : "(none)");
        RAD_CHECK(rc == 2 && log && strstr(log, bad[i].message) && strstr(log, "try 'render --help'"));
        free(log);
    }
    /* The default name: the input's, without folder and extension, .png,
     * in the current directory; an input without extension keeps its name. */
    snprintf(cmd, sizeof cmd, "mkdir -p '%s/in' && cp '%s' '%s/in/room.rad' && cp '%s' '%s/in/radiosity'", dir,
             radiosity, dir, radiosity, dir);
    RAD_CHECK(system(cmd) == 0);
    static const struct {
        const char *cwd, *input, *image;
    } names[] = {{"", "in/room.rad", "room.png"},     /* out/room.rad -> room.png, here */
                 {"", "in/radiosity", "radiosity.png"},
                 {"/in", "", "radiosity.png"}};     /* no input: radiosity -> radiosity.png */
    for (size_t i = 0; i < sizeof names / sizeof names[0]; i++) {
        char cwd[1024];
        snprintf(cwd, sizeof cwd, "%s%s", dir, names[i].cwd);
        snprintf(args, sizeof args, "%s -q --width 16 --height 16 --spp 1", names[i].input);
        int rc = run_render_in(cwd, render, args, dir, &log);
        int made = exists_in(cwd, names[i].image);
        if (rc != 0 || !made)
            fprintf(stderr, "cd %s && render %s: exit %d, %s %s; output: %s\n", cwd, args, rc, names[i].image,
                    made ? "made" : "missing", log ? log : "(none)");
        RAD_CHECK(rc == 0 && made);
        RAD_CHECK(!exists_in(dir, "cornell.png") && !exists_in(dir, "in/room.png"));
        snprintf(cmd, sizeof cmd, "%s/%s", cwd, names[i].image);
        remove(cmd);
        free(log);
    }
    RAD_CHECK(run_render(render, "--help", dir, &log) == 0);
    RAD_CHECK(log && strstr(log, "out/room.rad -> room.png") && strstr(log, "usage: render [options] [RADIOSITY]"));
    free(log);
}

/* render's command line for --channels: the help documents it; bad values
 * are usage errors (exit 2) with a clear message, and write nothing. */
static int check_cli(const char *render, const char *radiosity, const char *dir)
{
    char cmd[2048], out[1024], args[2048];
    snprintf(cmd, sizeof cmd, "rm -rf '%s' && mkdir -p '%s'", dir, dir);
    RAD_CHECK(system(cmd) == 0);
    snprintf(out, sizeof out, "%s/out.png", dir);
    char *log = NULL;
    RAD_CHECK(run_render(render, "--help", dir, &log) == 0);
    RAD_CHECK(log && strstr(log, "--channels MODE") && strstr(log, "auto (default)") && strstr(log, "luminance"));
    free(log);
    static const struct {
        const char *args, *message;
    } bad[] = {
        {"--channels foo", "render: error: --channels: 'foo' is not auto, rgb or grey"},
        {"--channels RGB", "--channels: 'RGB' is not auto, rgb or grey"},
        {"--channels=", "--channels: '' is not auto, rgb or grey"},
        {"--channels=3", "--channels: '3' is not auto, rgb or grey"},
        {"--channels", "--channels needs a value"},
    };
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        /* The bad option last, so that "--channels" has no value. */
        snprintf(args, sizeof args, "'%s' -o '%s' %s", radiosity, out, bad[i].args);
        int rc = run_render(render, args, dir, &log);
        if (rc != 2 || !log || !strstr(log, bad[i].message))
            fprintf(stderr, "render %s: exit %d, output: %s\n", args, rc, log ? log : "(none)");
        RAD_CHECK(rc == 2);
        RAD_CHECK(log && strstr(log, bad[i].message));
        RAD_CHECK(access(out, F_OK) != 0);
        free(log);
    }
    /* The good values are accepted (and "=" works too). */
    static const char *const good[] = {"--channels auto", "--channels=rgb", "--channels grey"};
    for (size_t i = 0; i < sizeof good / sizeof good[0]; i++) {
        snprintf(args, sizeof args, "'%s' -q --width 16 --height 16 --spp 1 -o '%s' %s", radiosity, out, good[i]);
        int rc = run_render(render, args, dir, &log);
        if (rc != 0) fprintf(stderr, "render %s: exit %d, output: %s\n", args, rc, log ? log : "(none)");
        RAD_CHECK(rc == 0 && access(out, F_OK) == 0);
        free(log);
        remove(out);
    }
    check_cli_forms(render, radiosity, dir);
    return rad_test_finish();
}

/* --quantity: the radiance EXR holds the radiosity EXR's values over pi
 * (to half precision: 2^-11 relative, and half's smallest steps near 0),
 * the PNGs with the automatic exposure are the same pixels (one 8-bit step
 * of float rounding allowed), and each file says what it holds. */
static int check_quantity_files(const char *b_exr, const char *l_exr, const char *b_png, const char *l_png)
{
    float *b = NULL, *l = NULL, *bp = NULL, *lp = NULL;
    int w, h, c, w2, h2, c2;
    RAD_CHECK(render_image_read(b_exr, &b, &w, &h, &c) == RAD_OK);
    RAD_CHECK(render_image_read(l_exr, &l, &w2, &h2, &c2) == RAD_OK && w == w2 && h == h2 && c == c2);
    size_t count = b && l ? (size_t)w * h * c : 0, lit = 0;
    double worst = 0;
    for (size_t k = 0; k < count; k++) {
        double want = b[k] / RAD_PI, err = fabs(l[k] - want);
        if (want > 1e-3) lit++;
        double allowed = 2 * 0x1p-11 * fabs(want) + 1e-7;
        if (err / allowed > worst) worst = err / allowed;
    }
    RAD_CHECK(lit > count / 4 && worst <= 1);
    RAD_CHECK(render_image_read(b_png, &bp, &w, &h, &c) == RAD_OK);
    RAD_CHECK(render_image_read(l_png, &lp, &w2, &h2, &c2) == RAD_OK && w == w2 && h == h2 && c == c2);
    size_t pixels = bp && lp ? (size_t)w * h * c : 0, differ = 0;
    for (size_t k = 0; k < pixels; k++) {
        double d = fabs(bp[k] - lp[k]);
        RAD_CHECK(d <= 1.0 / 255 + 1e-6);
        differ += d > 0;
    }
    char text[128] = "";
    RAD_CHECK(render_image_read_attr(l_exr, "rad:quantity", text, sizeof text) == RAD_OK &&
              strstr(text, "radiance"));
    RAD_CHECK(render_image_read_attr(b_exr, "rad:quantity", text, sizeof text) == RAD_OK &&
              strstr(text, "radiosity"));
    printf("radiance = radiosity / pi within %.2f of half precision over %zu values (%zu lit); PNGs differ in %zu of "
           "%zu values\n",
           worst, count, lit, differ, pixels);
    free(b), free(l), free(bp), free(lp);
    return rad_test_finish();
}

int main(int argc, char **argv)
{
    if (argc == 3 && strcmp(argv[1], "check-cornell") == 0) return check_cornell_file(argv[2]);
    if (argc == 4 && strcmp(argv[1], "check-grey") == 0) return check_grey_files(argv[2], argv[3]);
    if (argc == 4 && strcmp(argv[1], "check-luminance") == 0) return check_luminance_files(argv[2], argv[3]);
    if (argc == 5 && strcmp(argv[1], "check-layout") == 0) return check_layout_file(argv[2], argv[3], argv[4]);
    if (argc == 5 && strcmp(argv[1], "cli") == 0) return check_cli(argv[2], argv[3], argv[4]);
    if (argc == 6 && strcmp(argv[1], "check-quantity") == 0)
        return check_quantity_files(argv[2], argv[3], argv[4], argv[5]);
    if (argc != 1) {
        fprintf(stderr, "usage: test_render [check-cornell IMAGE | check-grey GREY RGB | check-luminance Y RGB |\n"
                        "                    check-layout IMAGE NAMES TYPE | cli RENDER RADIOSITY DIR]\n");
        return 2;
    }
    test_fill_rule_ties();
    test_fill_rule_watertight(1);
    test_fill_rule_watertight(4);
    test_fill_rule_watertight(9);
    test_culling();
    test_zbuffer();
    test_perspective_and_clipping();
    test_raster_options();
    test_raster_grey();
    test_srgb();
    test_shade_creases();
    test_shade_smoothing_groups();
    test_camera_parse();
    test_camera_default();
    test_camera_front();
    test_image_files();
    test_frame_room();
    test_frame_grey();
    return rad_test_finish();
}
