/* test_bvh.c - the flat BVH and its traversal (the code the GPU runs),
 * checked on the host against Embree's rtcOccluded1.
 *
 * Up to 200 000 segments between area-uniform points of random facing patch pairs of
 * cornell_sphere (--subdiv 2) and of the Cornell box (--subdiv 1), with the
 * source and target faces skipped as the backends do. Both answer "is the
 * segment blocked?"; they may differ only for segments that graze an edge
 * or vertex (Moller-Trumbore here, Embree's watertight test there), which
 * at these sizes is well under 1e-4 of the segments. Also: the structure
 * is consistent (every triangle in exactly one leaf, children inside their
 * parents' boxes) and an empty scene blocks nothing.
 */
#include <embree3/rtcore.h>
#include <stdlib.h>
#include <string.h>

#include "ff_bvh.h"
#include "ff_setup.h"
#include "rad_test.h"

typedef struct skip_context {
    struct RTCIntersectContext base;
    const uint32_t *face;
    uint32_t a, b;
} skip_context;

static void skip_filter(const struct RTCFilterFunctionNArguments *args)
{
    const skip_context *c = (const skip_context *)args->context;
    for (unsigned k = 0; k < args->N; k++) {
        unsigned prim = ((const unsigned *)args->hit)[5 * args->N + k];
        if (args->valid[k] == -1 && (c->face[prim] == c->a || c->face[prim] == c->b)) args->valid[k] = 0;
    }
}

static int in_box(const float lo[3], const float hi[3], const float p[3])
{
    for (int a = 0; a < 3; a++)
        if (p[a] < lo[a] - 1e-3f || p[a] > hi[a] + 1e-3f) return 0;
    return 1;
}

/* Every triangle's vertices lie inside the boxes on its path from the root. */
static int check_subtree(const ff_bvh *b, int32_t ref, uint32_t count, const float lo[3], const float hi[3],
                         int *seen)
{
    if (ref < 0) {
        for (uint32_t k = 0; k < count; k++) {
            const ff_bvh_tri *t = &b->tris[~ref + (int32_t)k];
            float v1[3], v2[3];
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

static void compare_with_embree(const char *path, int subdiv)
{
    rad_scene scene;
    rad_mesh mesh;
    rad_mesh_options mo = {.subdiv = subdiv};
    rad_ff_patch *patches = NULL;
    float *tris = NULL;
    uint32_t *face = NULL, tri_count = 0;
    RAD_CHECK(rad_scene_load_file(path, NULL, &scene) == RAD_OK);
    RAD_CHECK(rad_mesh_build(&scene, &mo, &mesh) == RAD_OK);
    double centre[3];
    ff_frame_centre(&mesh, centre);
    RAD_CHECK(ff_patches_build(&mesh, centre, &patches) == RAD_OK);
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

    RTCDevice dev = rtcNewDevice(NULL);
    RTCScene es = rtcNewScene(dev);
    rtcSetSceneFlags(es, RTC_SCENE_FLAG_CONTEXT_FILTER_FUNCTION);
    RTCGeometry g = rtcNewGeometry(dev, RTC_GEOMETRY_TYPE_TRIANGLE);
    float *v = rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 12, 3 * (size_t)tri_count);
    unsigned *ix = rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 12, tri_count);
    memcpy(v, tris, 36 * (size_t)tri_count);
    for (unsigned k = 0; k < 3 * tri_count; k++) ix[k] = k;
    rtcCommitGeometry(g);
    rtcAttachGeometry(es, g);
    rtcReleaseGeometry(g);
    rtcCommitScene(es);

    enum { SEGMENTS = 200000 };
    int blocked = 0, differ = 0, culled = 0, culled_blocked = 0, culled_any = 0, culled_any_blocked = 0;
    float margin = ff_cull_margin(&mesh, centre, ff_plane_eps(&mesh));
    uint32_t n = (uint32_t)mesh.patch_count;
    for (uint32_t s = 0; s < SEGMENTS; s++) {
        rad_u32x4 ctr = {{s, 99, 0, 0}};
        rad_u32x4 r = rad_philox4x32(ctr, 5, 6);
        uint32_t i = r.v[0] % n, j = r.v[1] % n;
        /* Only pairs the backends trace: facing each other (not coplanar). */
        if (i == j || !rad_ff_pair_facing(&patches[i], &patches[j], ff_plane_eps(&mesh))) continue;
        rad_vec3 x, y;
        rad_ff_sample_pair(&patches[i], &patches[j], i, j, s, 11, &x, &y);
        /* The culling claim is about the segments that carry weight: each
         * end in front of the other patch (the estimators trace no other). */
        int weighted = rad_v3_dot(patches[i].normal, rad_v3_sub(y, patches[i].p[0])) > 0.0 &&
                       rad_v3_dot(patches[j].normal, rad_v3_sub(x, patches[j].p[0])) > 0.0;
        float o[3] = {(float)x.x, (float)x.y, (float)x.z};
        float d[3] = {(float)y.x - o[0], (float)y.y - o[1], (float)y.z - o[2]};
        int ours = ff_bvh_occluded(bvh.nodes, bvh.tris, bvh.root, bvh.root_count, o, d, patches[i].face,
                                   patches[j].face);
        skip_context ctx;
        rtcInitIntersectContext(&ctx.base);
        ctx.base.filter = skip_filter;
        ctx.face = face;
        ctx.a = patches[i].face;
        ctx.b = patches[j].face;
        struct RTCRay ray = {.org_x = o[0], .org_y = o[1], .org_z = o[2], .tnear = FF_RAY_T_MIN, .dir_x = d[0],
                             .dir_y = d[1], .dir_z = d[2], .tfar = FF_RAY_T_MAX, .mask = ~0u};
        rtcOccluded1(es, &ctx.base, &ray);
        int theirs = ray.tfar < 0;
        blocked += theirs;
        differ += ours != theirs;
        /* The shaft test is conservative: a pair it culls has no blocked segment. */
        if (!ff_pair_may_be_occluded(bvh.nodes, bvh.tris, bvh.root, bvh.root_count, &patches[i], &patches[j], margin, 1, 1)) {
            culled++;
            culled_blocked += theirs && weighted;
        }
        /* The Monte Carlo estimators count every segment. */
        if (!ff_pair_may_be_occluded(bvh.nodes, bvh.tris, bvh.root, bvh.root_count, &patches[i], &patches[j], margin, 1, 0)) {
            culled_any++;
            culled_any_blocked += theirs;
        }
    }
    fprintf(stderr,
            "%s --subdiv %d: %u triangles, %u nodes; %d of %d segments blocked, %d differ from Embree; "
            "%d between pairs the shaft test culls, %d of those with weight blocked; %d, %d blocked (every segment counts)\n",
            path, subdiv, tri_count, bvh.node_count, blocked, SEGMENTS, differ, culled, culled_blocked, culled_any,
            culled_any_blocked);
    RAD_CHECK(culled > 0 && culled_blocked == 0);
    RAD_CHECK(culled_any > 0 && culled_any_blocked == 0 && culled_any <= culled);
    RAD_CHECK(blocked > SEGMENTS / 100); /* the scenes do occlude */
    RAD_CHECK(differ <= SEGMENTS / 10000);
    rtcReleaseScene(es);
    rtcReleaseDevice(dev);
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
    float outside[9] = {0.1f, 0.4f, 0.9f, 0.3f, 0.4f, 0.9f, 0.2f, 0.6f, 0.9f};
    float inside[9] = {1.4f, 0.4f, 0.5f, 1.6f, 0.4f, 0.5f, 1.5f, 0.6f, 0.5f};
    uint32_t face = 2;
    ff_bvh b;
    RAD_CHECK(ff_bvh_build(outside, &face, 1, &b) == RAD_OK);
    RAD_CHECK(!ff_pair_may_be_occluded(b.nodes, b.tris, b.root, b.root_count, &floor_patch, &ceiling, 1e-5f, 1, 1));
    RAD_CHECK(ff_pair_may_be_occluded(b.nodes, b.tris, b.root, b.root_count, &floor_patch, &ceiling, 1e-5f, 0, 1)); /* box only */
    ff_bvh_free(&b);
    RAD_CHECK(ff_bvh_build(inside, &face, 1, &b) == RAD_OK);
    RAD_CHECK(ff_pair_may_be_occluded(b.nodes, b.tris, b.root, b.root_count, &floor_patch, &ceiling, 1e-5f, 1, 1));
    ff_bvh_free(&b);
}

int main(void)
{
    check_shaft_hull();
    compare_with_embree(RAD_SCENES "/cornell_sphere.obj", 2);
    compare_with_embree(RAD_SCENES "/cornell_box.obj", 1);
    compare_with_embree(RAD_SCENES "/cluttered_room.obj", 1);

    ff_bvh empty;
    RAD_CHECK(ff_bvh_build(NULL, NULL, 0, &empty) == RAD_OK);
    float o[3] = {0, 0, 0}, d[3] = {1, 1, 1};
    RAD_CHECK(ff_bvh_occluded(empty.nodes, empty.tris, empty.root, empty.root_count, o, d, 0, 0) == 0);
    ff_bvh_free(&empty);

    /* One triangle: the root is a leaf. */
    float tri[9] = {-1, -1, 0.5f, 2, -1, 0.5f, -1, 2, 0.5f};
    uint32_t tri_face = 7;
    ff_bvh one;
    RAD_CHECK(ff_bvh_build(tri, &tri_face, 1, &one) == RAD_OK);
    float o2[3] = {0.1f, 0.1f, 0}, d2[3] = {0, 0, 1};
    RAD_CHECK(ff_bvh_occluded(one.nodes, one.tris, one.root, one.root_count, o2, d2, 0, 1) == 1);
    RAD_CHECK(ff_bvh_occluded(one.nodes, one.tris, one.root, one.root_count, o2, d2, 7, 1) == 0); /* own face */
    float d3[3] = {0, 0, 0.4f}; /* stops short of the plane */
    RAD_CHECK(ff_bvh_occluded(one.nodes, one.tris, one.root, one.root_count, o2, d3, 0, 1) == 0);
    ff_bvh_free(&one);
    return rad_test_finish();
}
