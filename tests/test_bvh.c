/* test_bvh.c - the flat BVH, its traversal and its hit rule (the code both
 * backends run).
 *
 *  - Structure: every triangle in exactly one leaf, inside the (float,
 *    grown) boxes of its path from the root; an empty scene blocks nothing.
 *  - Traversal: up to 200 000 segments between points of random facing
 *    patch pairs of cornell_sphere, the Cornell box and the cluttered room
 *    give exactly the answer of a scan of every triangle with the same hit
 *    test (the float walk is conservative, so it may not lose a hit).
 *  - Culling: a pair the shaft test clears has no blocked segment.
 *  - The hit rule (ff_segment): hits count by their height over the end
 *    planes, not by a fraction of the segment. Two facing squares 1e-2 ...
 *    1e-9 of the scene apart, at scene sizes 1e-3 ... 1e6: every segment
 *    from one square to a point beyond the other is blocked, at every gap
 *    and scale (the old rule, t in [1e-4, 1 - 1e-4], let segments pass
 *    through anything within 1e-4 of their length from either end); one
 *    between the two squares is not; faces that share an edge with the
 *    source face, or lie in its plane, never block.
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "ff_bvh.h"
#include "ff_shaft.h"
#include "ff_setup.h"
#include "rad_test.h"

static int in_box(const float lo[3], const float hi[3], const double p[3])
{
    for (int a = 0; a < 3; a++)
        if (p[a] < lo[a] || p[a] > hi[a]) return 0;
    return 1;
}

/* Every triangle's vertices lie inside the boxes on its path from the root. */
static int check_subtree(const ff_bvh *b, int32_t ref, uint32_t count, const float lo[3], const float hi[3],
                         int *seen)
{
    if (ref < 0) {
        for (uint32_t k = 0; k < count; k++) {
            const ff_bvh_tri *t = &b->tris[~ref + (int32_t)k];
            double v1[3], v2[3];
            for (int a = 0; a < 3; a++) v1[a] = t->v0[a] + t->e1[a], v2[a] = t->v0[a] + t->e2[a];
            if (lo && !(in_box(lo, hi, t->v0) && in_box(lo, hi, v1) && in_box(lo, hi, v2))) return 0;
            seen[~ref + (int32_t)k]++;
        }
        return 1;
    }
    const ff_bvh_node *n = &b->nodes[ref];
    return check_subtree(b, n->child0, n->count0, n->lo0, n->hi0, seen) &&
           check_subtree(b, n->child1, n->count1, n->lo1, n->hi1, seen);
}

/* Every triangle, in order: the reference the walk must agree with. */
static int scan_occluded(const ff_bvh *b, const ff_segment *s)
{
    for (uint32_t t = 0; t < b->tri_count; t++)
        if (b->tris[t].face != s->skip_a && b->tris[t].face != s->skip_b && ff_bvh_hit_tri(&b->tris[t], s)) return 1;
    return 0;
}

static void check_scene(const char *path, int subdiv)
{
    rad_scene scene;
    rad_mesh mesh;
    rad_mesh_options mo = {.subdiv = subdiv};
    rad_ff_patch *patches = NULL;
    double *tris = NULL;
    uint32_t *face = NULL, tri_count = 0;
    RAD_CHECK(rad_scene_load_file(path, NULL, &scene) == RAD_OK);
    RAD_CHECK(rad_mesh_build(&scene, &mo, &mesh) == RAD_OK);
    double centre[3];
    ff_frame_centre(&mesh, centre);
    RAD_CHECK(ff_patches_build(&scene, &mesh, centre, &patches) == RAD_OK);
    RAD_CHECK(ff_occluders_build(&scene, centre, &tris, &face, &tri_count) == RAD_OK);
    ff_bvh bvh;
    RAD_CHECK(ff_bvh_build(tris, face, tri_count, &bvh) == RAD_OK);

    int *seen = calloc(tri_count, sizeof *seen);
    RAD_CHECK(bvh.tri_count == tri_count);
    RAD_CHECK(check_subtree(&bvh, bvh.root, bvh.root_count, NULL, NULL, seen));
    int once = 1;
    for (uint32_t t = 0; t < tri_count; t++) once &= seen[t] == 1;
    RAD_CHECK(once);
    free(seen);

    enum { SEGMENTS = 200000 };
    int traced = 0, blocked = 0, differ = 0, culled = 0, culled_blocked = 0, culled_any = 0, culled_any_blocked = 0;
    int cached_differ = 0, cached_blocked = 0, same_occluder = 0;
    uint32_t last = FF_BVH_NO_HIT;
    double eps = ff_plane_eps(&mesh), delta = ff_ray_delta(&mesh);
    float margin = ff_cull_margin(&mesh, centre, eps);
    uint32_t n = (uint32_t)mesh.patch_count;
    for (uint32_t s = 0; s < SEGMENTS; s++) {
        rad_u32x4 ctr = {{s, 99, 0, 0}};
        rad_u32x4 r = rad_philox4x32(ctr, 5, 6);
        uint32_t i = r.v[0] % n, j = r.v[1] % n;
        /* Only pairs the backends trace: facing each other (not coplanar). */
        if (i == j || !rad_ff_pair_facing(&patches[i], &patches[j], eps)) continue;
        rad_vec3 x, y;
        rad_ff_sample_pair(&patches[i], &patches[j], i, j, s, 11, &x, &y);
        ff_segment seg = ff_segment_make(x, patches[i].normal, patches[i].face, y, patches[j].normal,
                                         patches[j].face, delta);
        int ours = ff_bvh_occluded(bvh.nodes, bvh.tris, bvh.root, bvh.root_count, &seg);
        int scan = scan_occluded(&bvh, &seg);
        traced++;
        blocked += scan;
        differ += ours != scan;
        /* The occluder cache: a pair's segments in a row through one cache
         * that runs on from pair to pair (stale for other faces), the
         * scan's answer every time. */
        for (uint32_t k = 0; s < SEGMENTS / 10 && k < 4; k++) {
            rad_vec3 xk, yk;
            rad_ff_sample_pair(&patches[i], &patches[j], i, j, SEGMENTS + 4 * s + k, 11, &xk, &yk);
            ff_segment sk = ff_segment_make(xk, patches[i].normal, patches[i].face, yk, patches[j].normal,
                                            patches[j].face, delta);
            const uint32_t before = last;
            const int c = ff_bvh_occluded_cached(bvh.nodes, bvh.tris, bvh.root, bvh.root_count, &sk, &last);
            cached_differ += c != scan_occluded(&bvh, &sk);
            cached_blocked += c;
            same_occluder += c && last == before;
        }
        /* The shaft test is conservative: a pair it culls has no blocked segment. */
        if (!ff_pair_may_be_occluded(bvh.nodes, bvh.tris, bvh.root, bvh.root_count, &patches[i], &patches[j], margin,
                                     delta, 1, 1)) {
            culled++;
            culled_blocked += scan;
        }
        if (!ff_pair_may_be_occluded(bvh.nodes, bvh.tris, bvh.root, bvh.root_count, &patches[i], &patches[j], margin,
                                     delta, 1, 0)) {
            culled_any++;
            culled_any_blocked += scan;
        }
    }
    fprintf(stderr,
            "%s --subdiv %d: %u triangles, %u nodes; %d of %d segments blocked, %d differ from the scan; "
            "%d between pairs the shaft test culls (%d blocked); %d, %d blocked (every segment counts)\n",
            path, subdiv, tri_count, bvh.node_count, blocked, traced, differ, culled, culled_blocked, culled_any,
            culled_any_blocked);
    fprintf(stderr, "  occluder cache: %d segments blocked, %d by the last one's occluder, %d differ from the scan\n",
            cached_blocked, same_occluder, cached_differ);
    RAD_CHECK(differ == 0);
    RAD_CHECK(cached_differ == 0);
    RAD_CHECK(cached_blocked > 0 && same_occluder > 0 && same_occluder <= cached_blocked);
    RAD_CHECK(culled > 0 && culled_blocked == 0);
    RAD_CHECK(culled_any > 0 && culled_any_blocked == 0 && culled_any <= culled);
    RAD_CHECK(blocked > traced / 100); /* the scenes do occlude */
    ff_bvh_free(&bvh);
    free(patches);
    free(tris);
    free(face);
    rad_mesh_free(&mesh);
    rad_scene_free(&scene);
}

/* A square on the floor and one on the ceiling, offset: a triangle inside
 * the box around both but outside their hull does not count; one on the
 * line between them does. */
static void check_shaft_hull(void)
{
    rad_ff_patch floor_patch = {.p = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}}, .normal = {0, 0, 1},
                                .area = 1, .face = 0, .vertex_count = 4};
    rad_ff_patch ceiling = {.p = {{2, 0, 1}, {2, 1, 1}, {3, 1, 1}, {3, 0, 1}}, .normal = {0, 0, -1},
                            .area = 1, .face = 1, .vertex_count = 4};
    double outside[9] = {0.1, 0.4, 0.9, 0.3, 0.4, 0.9, 0.2, 0.6, 0.9};
    double inside[9] = {1.4, 0.4, 0.5, 1.6, 0.4, 0.5, 1.5, 0.6, 0.5};
    uint32_t face = 2;
    ff_bvh b;
    RAD_CHECK(ff_bvh_build(outside, &face, 1, &b) == RAD_OK);
    RAD_CHECK(!ff_pair_may_be_occluded(b.nodes, b.tris, b.root, b.root_count, &floor_patch, &ceiling, 1e-5f, 1e-12, 1, 1));
    RAD_CHECK(ff_pair_may_be_occluded(b.nodes, b.tris, b.root, b.root_count, &floor_patch, &ceiling, 1e-5f, 1e-12, 0, 1));
    ff_bvh_free(&b);
    RAD_CHECK(ff_bvh_build(inside, &face, 1, &b) == RAD_OK);
    RAD_CHECK(ff_pair_may_be_occluded(b.nodes, b.tris, b.root, b.root_count, &floor_patch, &ceiling, 1e-5f, 1e-12, 1, 1));
    ff_bvh_free(&b);
}

/* The square [lo, hi]^2 at height z as two triangles (18 doubles) into t. */
static void square(double *t, double lo, double hi, double z)
{
    double q[6][3] = {{lo, lo, z}, {hi, lo, z}, {hi, hi, z}, {lo, lo, z}, {hi, hi, z}, {lo, hi, z}};
    memcpy(t, q, sizeof q);
}

/* Facing squares A (z = 0, up) and B (z = gap, down) of side s/10 in the
 * middle of a scene of size s (a far wall at z = s/2): segments from A to
 * the far wall pass through B. */
static void check_gap(double scale, double gap_rel)
{
    double side = 0.1 * scale, gap = gap_rel * scale, delta = FF_RAY_DELTA * scale * sqrt(3.0);
    double far = 0.5 * scale;
    double all[5 * 9];
    square(all, -side / 2, side / 2, 0.0);      /* A: face 0 */
    square(all + 18, -side / 2, side / 2, gap); /* B: face 1 */
    double wall[9] = {-scale, -scale, far, scale, -scale, far, 0, scale, far}; /* face 2 */
    memcpy(all + 36, wall, sizeof wall);
    uint32_t faces[5] = {0, 0, 1, 1, 2};
    ff_bvh bvh;
    RAD_CHECK(ff_bvh_build(all, faces, 5, &bvh) == RAD_OK);
    int through = 0, between = 0, total = 0;
    for (int k = 0; k < 64; k++) {
        double u = (k % 8 + 0.5) / 8.0 - 0.5, v = (k / 8 + 0.5) / 8.0 - 0.5;
        /* From inside A (not at its edge: there a segment may slip out of the gap). */
        rad_vec3 x = rad_v3(0.8 * u * side, 0.8 * v * side, 0.0);
        rad_vec3 y = rad_v3(0.3 * u * scale, 0.2 * v * scale, far); /* on the far wall */
        ff_segment s = ff_segment_make(x, rad_v3(0, 0, 1), 0, y, rad_v3(0, 0, -1), 2, delta);
        through += ff_bvh_occluded(bvh.nodes, bvh.tris, bvh.root, bvh.root_count, &s);
        /* From A to B itself: nothing between them. */
        rad_vec3 yb = rad_v3(0.7 * v * side, 0.7 * u * side, gap);
        ff_segment sb = ff_segment_make(x, rad_v3(0, 0, 1), 0, yb, rad_v3(0, 0, -1), 1, delta);
        between += ff_bvh_occluded(bvh.nodes, bvh.tris, bvh.root, bvh.root_count, &sb);
        total++;
    }
    if (through != total || between != 0)
        fprintf(stderr, "scale %g, gap %g of it: %d of %d segments to the far wall blocked, %d to B\n", scale,
                gap_rel, through, total, between);
    RAD_CHECK(through == total);
    RAD_CHECK(between == 0);
    ff_bvh_free(&bvh);
}

/* A floor of two coplanar triangles (faces 0 and 1, one seam) and a wall
 * (face 2) sharing the floor's edge: segments from points of face 0 right
 * at the seam and at the wall to anywhere in front never count them. */
static void check_neighbours(void)
{
    double t[3 * 9] = {0, 0, 0, 1, 0, 0, 1, 1, 0,  /* face 0 */
                       0, 0, 0, 1, 1, 0, 0, 1, 0,  /* face 1, across the diagonal */
                       0, 0, 0, 0, 1, 0, 0, 0, 1}; /* face 2: the wall x = 0 (one triangle) */
    uint32_t faces[3] = {0, 1, 2};
    ff_bvh bvh;
    RAD_CHECK(ff_bvh_build(t, faces, 3, &bvh) == RAD_OK);
    double delta = FF_RAY_DELTA * sqrt(3.0);
    int blocked = 0;
    for (int k = 0; k < 1000; k++) {
        double s = (k + 0.5) / 1000.0;
        /* On the seam (x = y) within rounding, and 1e-15 from the wall. */
        rad_vec3 x = rad_v3(s, s * (1.0 - 1e-16), 0.0), xw = rad_v3(1e-15, s, 0.0);
        rad_vec3 y = rad_v3(1.0 - s, 0.5 * s, 1.0);      /* a ceiling point */
        rad_vec3 yl = rad_v3(0.9, 0.1 + 0.8 * s, 1e-9); /* grazing: just above the floor */
        ff_segment a = ff_segment_make(x, rad_v3(0, 0, 1), 0, y, rad_v3(0, 0, -1), 9, delta);
        ff_segment b = ff_segment_make(xw, rad_v3(0, 0, 1), 0, y, rad_v3(0, 0, -1), 9, delta);
        ff_segment c = ff_segment_make(x, rad_v3(0, 0, 1), 0, yl, rad_v3(-1, 0, 0), 9, delta);
        blocked += ff_bvh_occluded(bvh.nodes, bvh.tris, bvh.root, bvh.root_count, &a);
        blocked += ff_bvh_occluded(bvh.nodes, bvh.tris, bvh.root, bvh.root_count, &b);
        blocked += ff_bvh_occluded(bvh.nodes, bvh.tris, bvh.root, bvh.root_count, &c);
    }
    RAD_CHECK(blocked == 0);
    ff_bvh_free(&bvh);
}

int main(void)
{
    check_shaft_hull();
    check_neighbours();
    const double scales[] = {1e-3, 1.0, 1e3, 1e6}, gaps[] = {1e-2, 1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9};
    for (int s = 0; s < 4; s++)
        for (int g = 0; g < 8; g++) check_gap(scales[s], gaps[g]);
    check_scene(RAD_SCENES "/cornell_sphere.obj", 2);
    check_scene(RAD_SCENES "/cornell_box.obj", 1);
    check_scene(RAD_SCENES "/cluttered_room.obj", 1);

    ff_bvh empty;
    RAD_CHECK(ff_bvh_build(NULL, NULL, 0, &empty) == RAD_OK);
    ff_segment s0 = ff_segment_make(rad_v3(0, 0, 0), rad_v3(0, 0, 1), 0, rad_v3(1, 1, 1), rad_v3(0, 0, -1), 1, 1e-12);
    RAD_CHECK(ff_bvh_occluded(empty.nodes, empty.tris, empty.root, empty.root_count, &s0) == 0);
    ff_bvh_free(&empty);

    /* One triangle: the root is a leaf. */
    double tri[9] = {-1, -1, 0.5, 2, -1, 0.5, -1, 2, 0.5};
    uint32_t tri_face = 7;
    ff_bvh one;
    RAD_CHECK(ff_bvh_build(tri, &tri_face, 1, &one) == RAD_OK);
    rad_vec3 up = rad_v3(0, 0, 1), down = rad_v3(0, 0, -1), o = rad_v3(0.1, 0.1, 0);
    ff_segment s1 = ff_segment_make(o, up, 0, rad_v3(0.1, 0.1, 1), down, 1, 1e-12);
    ff_segment s2 = ff_segment_make(o, up, 7, rad_v3(0.1, 0.1, 1), down, 1, 1e-12); /* own face */
    ff_segment s3 = ff_segment_make(o, up, 0, rad_v3(0.1, 0.1, 0.4), down, 1, 1e-12); /* stops short */
    RAD_CHECK(ff_bvh_occluded(one.nodes, one.tris, one.root, one.root_count, &s1) == 1);
    RAD_CHECK(ff_bvh_occluded(one.nodes, one.tris, one.root, one.root_count, &s2) == 0);
    RAD_CHECK(ff_bvh_occluded(one.nodes, one.tris, one.root, one.root_count, &s3) == 0);
    ff_bvh_free(&one);
    return rad_test_finish();
}
