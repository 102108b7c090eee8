/* ff_bvh_build.c - Embree's BVH builder (rtcBuildBVH, binned SAH) turned
 * into the flat layout of ff_bvh.h. Embree builds a pointer tree in its
 * thread-local allocator; one depth-first walk numbers the inner nodes and
 * gathers leaf triangles contiguously. */
#include <embree3/rtcore.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "ff_bvh.h"
#include "rad_log.h"

/* Embree's error codes in words (rtcore_device.h). */
static const char *embree_error_name(enum RTCError code)
{
    switch (code) {
    case RTC_ERROR_NONE: return "no error";
    case RTC_ERROR_INVALID_ARGUMENT: return "invalid argument";
    case RTC_ERROR_INVALID_OPERATION: return "invalid operation";
    case RTC_ERROR_OUT_OF_MEMORY: return "out of memory";
    case RTC_ERROR_UNSUPPORTED_CPU: return "unsupported CPU";
    case RTC_ERROR_CANCELLED: return "cancelled";
    default: return "unknown error";
    }
}

typedef struct build_node {
    int is_leaf;
    void *child[2];
    struct RTCBounds bounds[2];
    uint32_t prim_count; /* leaves */
    uint32_t prims[];    /* leaves: triangle indices */
} build_node;

static void *create_node(RTCThreadLocalAllocator alloc, unsigned child_count, void *user)
{
    (void)child_count;
    (void)user;
    build_node *n = rtcThreadLocalAlloc(alloc, sizeof(build_node), 16);
    memset(n, 0, sizeof *n);
    return n;
}

static void set_children(void *node, void **children, unsigned count, void *user)
{
    (void)user;
    build_node *n = node;
    for (unsigned k = 0; k < count && k < 2; k++) n->child[k] = children[k];
}

static void set_bounds(void *node, const struct RTCBounds **bounds, unsigned count, void *user)
{
    (void)user;
    build_node *n = node;
    for (unsigned k = 0; k < count && k < 2; k++) n->bounds[k] = *bounds[k];
}

static void *create_leaf(RTCThreadLocalAllocator alloc, const struct RTCBuildPrimitive *prims, size_t count,
                         void *user)
{
    (void)user;
    build_node *n = rtcThreadLocalAlloc(alloc, sizeof(build_node) + count * sizeof(uint32_t), 16);
    memset(n, 0, sizeof *n);
    n->is_leaf = 1;
    n->prim_count = (uint32_t)count;
    for (size_t k = 0; k < count; k++) n->prims[k] = prims[k].primID;
    return n;
}

typedef struct flatten_ctx {
    ff_bvh *bvh;
    const double *triangles;
    const uint32_t *triangle_face;
} flatten_ctx;

static void put_tri(flatten_ctx *c, uint32_t src)
{
    const double *v = c->triangles + 9 * (size_t)src;
    ff_bvh_tri *t = &c->bvh->tris[c->bvh->tri_count++];
    memset(t, 0, sizeof *t);
    for (int a = 0; a < 3; a++) {
        t->v0[a] = v[a];
        t->e1[a] = v[3 + a] - v[a];
        t->e2[a] = v[6 + a] - v[a];
    }
    t->face = c->triangle_face[src];
}

/* Returns the child reference of `n` and fills its leaf count. */
static int32_t flatten(flatten_ctx *c, const build_node *n, uint32_t *out_count)
{
    if (n->is_leaf) {
        int32_t ref = ~(int32_t)c->bvh->tri_count;
        for (uint32_t k = 0; k < n->prim_count; k++) put_tri(c, n->prims[k]);
        *out_count = n->prim_count;
        return ref;
    }
    uint32_t index = c->bvh->node_count++;
    ff_bvh_node node;
    memset(&node, 0, sizeof node);
    const struct RTCBounds *b = n->bounds;
    node.lo0[0] = b[0].lower_x, node.lo0[1] = b[0].lower_y, node.lo0[2] = b[0].lower_z;
    node.hi0[0] = b[0].upper_x, node.hi0[1] = b[0].upper_y, node.hi0[2] = b[0].upper_z;
    node.lo1[0] = b[1].lower_x, node.lo1[1] = b[1].lower_y, node.lo1[2] = b[1].lower_z;
    node.hi1[0] = b[1].upper_x, node.hi1[1] = b[1].upper_y, node.hi1[2] = b[1].upper_z;
    node.child0 = flatten(c, n->child[0], &node.count0);
    node.child1 = flatten(c, n->child[1], &node.count1);
    c->bvh->nodes[index] = node;
    *out_count = 0;
    return (int32_t)index;
}

rad_status ff_bvh_build(const double *triangles, const uint32_t *triangle_face, uint32_t triangle_count,
                        ff_bvh *out_bvh)
{
    rad_status status = RAD_OK;
    ff_bvh bvh = {0};
    bvh.root = -1;
    RTCDevice device = NULL;
    RTCBVH handle = NULL;
    struct RTCBuildPrimitive *prims = NULL;
    /* A binary tree over T leaves of >= 1 triangle has < T inner nodes. */
    bvh.nodes = malloc(sizeof *bvh.nodes * (triangle_count ? triangle_count : 1));
    bvh.tris = malloc(sizeof *bvh.tris * (triangle_count ? triangle_count : 1));
    /* RTCBuildPrimitive is a 32-byte aligned type: malloc's 16 is not enough. */
    size_t prim_bytes = sizeof *prims * (triangle_count ? triangle_count : 1);
    prims = aligned_alloc(32, (prim_bytes + 31) / 32 * 32);
    if (!bvh.nodes || !bvh.tris || !prims) {
        rad_error("out of memory for a BVH over %u triangles", triangle_count);
        status = RAD_ERR_NOMEM;
        goto done;
    }
    if (triangle_count == 0) goto done;
    /* Float boxes around double triangles, grown by FF_BVH_PAD of the
     * largest coordinate (ff_bvh.h): the walk in float then never misses
     * a triangle that the double hit test would count. */
    double largest = 0.0;
    for (size_t k = 0; k < 9 * (size_t)triangle_count; k++) largest = fmax(largest, fabs(triangles[k]));
    float pad = (float)(FF_BVH_PAD * largest);
    for (uint32_t t = 0; t < triangle_count; t++) {
        const double *v = triangles + 9 * (size_t)t;
        double lo[3] = {v[0], v[1], v[2]}, hi[3] = {v[0], v[1], v[2]};
        for (int k = 1; k < 3; k++)
            for (int a = 0; a < 3; a++) lo[a] = fmin(lo[a], v[3 * k + a]), hi[a] = fmax(hi[a], v[3 * k + a]);
        struct RTCBuildPrimitive *p = &prims[t];
        p->lower_x = (float)lo[0] - pad, p->lower_y = (float)lo[1] - pad, p->lower_z = (float)lo[2] - pad;
        p->upper_x = (float)hi[0] + pad, p->upper_y = (float)hi[1] + pad, p->upper_z = (float)hi[2] + pad;
        p->geomID = 0;
        p->primID = t;
    }
    device = rtcNewDevice(NULL);
    if (!device) {
        enum RTCError code = rtcGetDeviceError(NULL);
        rad_error("embree: cannot create a device: %s (error %d)", embree_error_name(code), (int)code);
        status = code == RTC_ERROR_OUT_OF_MEMORY ? RAD_ERR_NOMEM : RAD_ERR_BACKEND;
        goto done;
    }
    handle = rtcNewBVH(device);
    if (!handle) {
        enum RTCError code = rtcGetDeviceError(device);
        rad_error("embree: cannot create a BVH builder: %s (error %d)", embree_error_name(code), (int)code);
        status = code == RTC_ERROR_OUT_OF_MEMORY ? RAD_ERR_NOMEM : RAD_ERR_BACKEND;
        goto done;
    }
    struct RTCBuildArguments args = rtcDefaultBuildArguments();
    args.buildQuality = RTC_BUILD_QUALITY_MEDIUM; /* binned SAH, no spatial splits */
    args.maxBranchingFactor = 2;
    args.maxDepth = 32;
    args.minLeafSize = 1;
    args.maxLeafSize = 4;
    args.traversalCost = 1.0f;
    args.intersectionCost = 1.0f;
    args.bvh = handle;
    args.primitives = prims;
    args.primitiveCount = triangle_count;
    args.primitiveArrayCapacity = triangle_count;
    args.createNode = create_node;
    args.setNodeChildren = set_children;
    args.setNodeBounds = set_bounds;
    args.createLeaf = create_leaf;
    build_node *root = rtcBuildBVH(&args);
    enum RTCError build_error = rtcGetDeviceError(device);
    if (!root || build_error != RTC_ERROR_NONE) {
        rad_error("embree: rtcBuildBVH failed: %s", embree_error_name(build_error));
        status = RAD_ERR_BACKEND;
        goto done;
    }
    flatten_ctx ctx = {&bvh, triangles, triangle_face};
    bvh.root = flatten(&ctx, root, &bvh.root_count);
done:
    if (handle) rtcReleaseBVH(handle);
    if (device) rtcReleaseDevice(device);
    free(prims);
    if (status != RAD_OK) {
        ff_bvh_free(&bvh);
        return status;
    }
    *out_bvh = bvh;
    return RAD_OK;
}

void ff_bvh_free(ff_bvh *bvh)
{
    free(bvh->nodes);
    free(bvh->tris);
    memset(bvh, 0, sizeof *bvh);
    bvh->root = -1;
}
