/* ff_backend_cpu.c - the reference backend: the shared per-pair procedure
 * (rad_ff_pair.h) on CPU threads (OpenMP), shadow rays through Embree 3.
 * The only file that includes Embree.
 *
 * Rows are handed to threads one at a time; a row's pairs run in column
 * order. Each facing pair first goes through culling (the convex-scene
 * rule and the shaft test of ff_bvh.h); pairs it clears are computed
 * without a tracer (visible fraction exactly 1), the others with one
 * rtcOccluded1 per shadow ray, the source and target faces excluded by a
 * context filter (no self-intersection, whatever the angle). The time in
 * the tracer is the paper's "occlusion" phase, the rest its "form factor"
 * phase.
 */
#define _POSIX_C_SOURCE 200809L
#include <embree3/rtcore.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#ifdef _OPENMP
#include <omp.h>
#endif

#include "ff_backend.h"
#include "ff_bvh.h"
#include "rad_log.h"

typedef struct cpu_state {
    ff_setup setup;
    RTCDevice device;
    RTCScene scene;
    ff_bvh bvh; /* the flat BVH, for the occlusion-culling box queries */
} cpu_state;

/* The context handed to Embree's filter: which faces a ray must ignore. */
typedef struct occlusion_context {
    struct RTCIntersectContext base; /* first member: Embree passes &base */
    const uint32_t *triangle_face;
    uint32_t skip_a, skip_b;
} occlusion_context;

/* Embree's RTCHitN_primID accessor is C++ only; RTCHitN is SoA with
 * Ng_x, Ng_y, Ng_z, u, v, primID, ... arrays of N each (rtcore_ray.h). */
static unsigned hit_prim_id(const struct RTCHitN *hit, unsigned n, unsigned k)
{
    return ((const unsigned *)hit)[5 * n + k];
}

static void skip_own_faces(const struct RTCFilterFunctionNArguments *args)
{
    const occlusion_context *ctx = (const occlusion_context *)args->context;
    for (unsigned k = 0; k < args->N; k++) {
        if (args->valid[k] != -1) continue;
        uint32_t face = ctx->triangle_face[hit_prim_id(args->hit, args->N, k)];
        if (face == ctx->skip_a || face == ctx->skip_b) args->valid[k] = 0;
    }
}

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

static void embree_error(void *user, enum RTCError code, const char *message)
{
    (void)user;
    rad_error("embree: %s (error %d): %s", embree_error_name(code), (int)code, message ? message : "");
}

static rad_status cpu_create(const ff_setup *setup, void **out_state)
{
    cpu_state *s = calloc(1, sizeof *s);
    if (!s) return RAD_ERR_NOMEM;
    s->setup = *setup;
    s->device = rtcNewDevice(NULL);
    if (!s->device) {
        enum RTCError code = rtcGetDeviceError(NULL);
        rad_error("embree: cannot create a device: %s (error %d)", embree_error_name(code), (int)code);
        free(s);
        return RAD_ERR_BACKEND;
    }
    rtcSetDeviceErrorFunction(s->device, embree_error, NULL);
    s->scene = rtcNewScene(s->device);
    rtcSetSceneFlags(s->scene, RTC_SCENE_FLAG_CONTEXT_FILTER_FUNCTION);
    rtcSetSceneBuildQuality(s->scene, RTC_BUILD_QUALITY_HIGH);
    if (setup->triangle_count > 0) {
        RTCGeometry geom = rtcNewGeometry(s->device, RTC_GEOMETRY_TYPE_TRIANGLE);
        float *v = rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float),
                                           3 * (size_t)setup->triangle_count);
        unsigned *ix = rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                               3 * sizeof(unsigned), setup->triangle_count);
        if (v && ix) {
            memcpy(v, setup->triangles, 9 * sizeof(float) * (size_t)setup->triangle_count);
            for (unsigned t = 0; t < 3 * setup->triangle_count; t++) ix[t] = t;
        }
        rtcCommitGeometry(geom);
        rtcAttachGeometry(s->scene, geom);
        rtcReleaseGeometry(geom);
    }
    rtcCommitScene(s->scene);
    if (ff_bvh_build(setup->triangles, setup->triangle_face, setup->triangle_count, &s->bvh) != RAD_OK) {
        rtcReleaseScene(s->scene);
        rtcReleaseDevice(s->device);
        free(s);
        return RAD_ERR_BACKEND;
    }
    if (rtcGetDeviceError(s->device) != RTC_ERROR_NONE) {
        rad_error("embree: building the occluder BVH failed");
        /* The scene and device are deliberately not released: after a failed
         * commit (seen: pthread_create failing under `ulimit -v`), releasing
         * them makes TBB abort the process ("wait() was not called on the
         * structured_task_group"), which would turn a clean error into a
         * crash. The caller exits on this error; the OS reclaims them. */
        ff_bvh_free(&s->bvh);
        free(s);
        return RAD_ERR_BACKEND;
    }
    *out_state = s;
    return RAD_OK;
}

static void cpu_destroy(void *state)
{
    cpu_state *s = state;
    if (!s) return;
    ff_bvh_free(&s->bvh);
    rtcReleaseScene(s->scene);
    rtcReleaseDevice(s->device);
    free(s);
}

/* The tracer the shared per-pair procedure (rad_ff_pair.h) calls. */
typedef struct cpu_tracer {
    RTCScene scene;
    const uint32_t *triangle_face;
} cpu_tracer;

/* One shadow ray over t in [FF_RAY_T_MIN, FF_RAY_T_MAX] of o + t d: 1 if
 * something other than faces a and b (the context filter) is hit. */
static int cpu_occluded(const cpu_tracer *t, const float o[3], const float d[3], uint32_t a, uint32_t b)
{
    occlusion_context ctx;
    rtcInitIntersectContext(&ctx.base);
    ctx.base.filter = skip_own_faces;
    ctx.triangle_face = t->triangle_face;
    ctx.skip_a = a;
    ctx.skip_b = b;
    struct RTCRay ray;
    ray.org_x = o[0], ray.org_y = o[1], ray.org_z = o[2];
    ray.dir_x = d[0], ray.dir_y = d[1], ray.dir_z = d[2];
    ray.tnear = FF_RAY_T_MIN; /* ff_bvh.h: the GPU tests the same span */
    ray.tfar = FF_RAY_T_MAX;
    ray.time = 0.0f;
    ray.mask = ~0u;
    ray.id = 0;
    ray.flags = 0;
    rtcOccluded1(t->scene, &ctx.base, &ray);
    return !(ray.tfar >= 0.0f); /* Embree sets tfar = -inf on a hit */
}

static long long cpu_ticks(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (long long)t.tv_sec * 1000000000ll + t.tv_nsec;
}

#define RAD_FF_TRACER cpu_tracer
#define RAD_FF_OCCLUDED(t, o, d, a, b) cpu_occluded(t, o, d, a, b)
#define RAD_FF_TICKS() cpu_ticks()
#include "rad_ff_pair.h"

/* Can something block pair (i, j)? Not where culling proves that nothing
 * can lie between the patches: the scene is one convex enclosure, or no
 * other triangle meets the pair's shaft. */
static int pair_needs_rays(const cpu_state *s, uint32_t i, uint32_t j, ff_counters *c)
{
    const ff_setup *su = &s->setup;
    if (su->shadow_rays == 0) return 0;
    if (!su->cull) return 1;
    if (su->scene_convex) {
        c->pairs_open_scene++;
        return 0;
    }
    if (!ff_pair_may_be_occluded(s->bvh.nodes, s->bvh.tris, s->bvh.root, s->bvh.root_count, &su->patches[i],
                                 &su->patches[j], su->cull_margin, 0,
                                 su->estimator == RAD_ESTIMATOR_QUADRATURE)) {
        c->pairs_open_box++;
        return 0;
    }
    return 1;
}

/* Row i, every column: the shared per-pair procedure for each pair the
 * row computes; zeros elsewhere. */
static void compute_row(const cpu_state *s, uint32_t i, double *row, double *errors, ff_counters *c)
{
    const ff_setup *su = &s->setup;
    const rad_ff_patch *pi = &su->patches[i];
    rad_ff_pair_params pp = ff_pair_params(su);
    cpu_tracer tracer = {s->scene, su->triangle_face};
    long long t0 = cpu_ticks(), ray_ticks = 0;
    for (uint32_t j = 0; j < su->patch_count; j++) {
        const rad_ff_patch *pj = &su->patches[j];
        row[j] = 0;
        if (errors) errors[j] = 0;
        if (su->pairs_once && !rad_ff_row_computes(i, j)) continue; /* row j computes this pair */
        c->pairs++;
        if (j == i || !rad_ff_pair_facing(pi, pj, su->plane_eps)) {
            c->pairs_culled++;
            continue;
        }
        if (su->reuse_old && su->reuse_old[i] != FF_REUSE_NONE && su->reuse_old[j] != FF_REUSE_NONE) {
            row[j] = su->reuse_coupling[(size_t)su->reuse_old[i] * su->reuse_n + su->reuse_old[j]];
            c->pairs_reused++;
            continue;
        }
        int rays = pair_needs_rays(s, i, j, c);
        rad_ff_pair_result r;
        rad_ff_pair_compute(&pp, pi, pj, i, j, rays ? &tracer : NULL, &r);
        row[j] = r.coupling;
        if (errors) errors[j] = r.error;
        c->samples += r.samples;
        c->rays += r.rays;
        c->rays_occluded += r.rays_blocked;
        c->rays_saved += r.rays_skipped;
        c->pairs_near += (uint64_t)r.near;
        c->pairs_refined += (uint64_t)r.refined;
        c->pairs_capped += (uint64_t)r.capped;
        ray_ticks += r.ray_ticks;
    }
    double total = 1e-9 * (double)(cpu_ticks() - t0), rays_time = 1e-9 * (double)ray_ticks;
    c->kernel_seconds += total - rays_time;
    c->visibility_seconds += rays_time;
}

static rad_status cpu_compute_rows(void *state, uint32_t row_begin, uint32_t row_count, double *out,
                                   double *errors, ff_counters *counters)
{
    cpu_state *s = state;
    const ff_setup *su = &s->setup;
    uint32_t n = su->patch_count;
    uint64_t rows_done = 0;

#pragma omp parallel num_threads(su->threads)
    {
        ff_counters c = {0};
        int master = 1;
#ifdef _OPENMP
        master = omp_get_thread_num() == 0;
#endif
#pragma omp for schedule(dynamic, 1)
        for (uint32_t r = 0; r < row_count; r++) {
            compute_row(s, row_begin + r, out + (size_t)r * n, errors ? errors + (size_t)r * n : NULL, &c);
            uint64_t done;
#pragma omp atomic capture
            done = ++rows_done;
            if (master && su->progress) su->progress(su->progress_user, done);
        }
#pragma omp critical
        {
            counters->pairs += c.pairs;
            counters->pairs_culled += c.pairs_culled;
            counters->pairs_reused += c.pairs_reused;
            counters->pairs_near += c.pairs_near;
            counters->pairs_open_scene += c.pairs_open_scene;
            counters->pairs_open_box += c.pairs_open_box;
            counters->rays_saved += c.rays_saved;
            counters->samples += c.samples;
            counters->pairs_refined += c.pairs_refined;
            counters->pairs_capped += c.pairs_capped;
            counters->rays += c.rays;
            counters->rays_occluded += c.rays_occluded;
            counters->kernel_seconds += c.kernel_seconds / su->threads;
            counters->visibility_seconds += c.visibility_seconds / su->threads;
        }
    }
    if (rtcGetDeviceError(s->device) != RTC_ERROR_NONE) return RAD_ERR_BACKEND;
    return RAD_OK;
}

static double *cpu_alloc_rows(void *state, size_t count)
{
    (void)state;
    return malloc(sizeof(double) * (count ? count : 1));
}

static void cpu_free_rows(void *state, double *rows)
{
    (void)state;
    free(rows);
}

const ff_backend ff_backend_cpu = {"cpu",          cpu_create,    cpu_compute_rows, cpu_destroy,
                                   cpu_alloc_rows, cpu_free_rows, NULL};
