/* ff_backend_cpu.c - the reference backend: the shared kernel on CPU
 * threads (OpenMP) and shadow rays through Embree 3. The only file that
 * includes Embree.
 *
 * A row is computed in column blocks of FF_CPU_BLOCK patches, in two passes
 * so that the paper's "form factor" and "occlusion" times stay separate:
 *   1. kernel: K samples per facing pair, summing G; the first R point
 *      pairs and their G are kept in the thread's scratch;
 *   2. visibility: one rtcOccluded1 per kept point pair, with the source
 *      and target faces excluded by a context filter (no self-intersection,
 *      whatever the angle), then the estimate c = c_unoccluded *
 *      sum(G V) / sum(G) and its standard error (rad_ff_estimate);
 *   3. with --target-error, more batches for pairs still above the target.
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

enum { FF_CPU_BLOCK = 128 };
/* Shadow rays from which a pair's shaft test includes the hull planes
 * (ff_pair_may_be_occluded): below it they cost more than the rays they
 * save (measured, docs/performance.md). Compile-time tunable. */
#ifndef FF_CPU_HULL_MIN_RAYS
#define FF_CPU_HULL_MIN_RAYS 128u
#endif

typedef struct cpu_state {
    ff_setup setup;
    RTCDevice device;
    RTCScene scene;
    ff_bvh bvh; /* the flat BVH, for the occlusion-culling box queries */
} cpu_state;

/* Per-thread scratch for one column block: R point pairs and kernels per column. */
typedef struct cpu_scratch {
    float *rays;     /* FF_CPU_BLOCK * R * 6: x then y */
    double *kernel;  /* FF_CPU_BLOCK * R */
    rad_ff_sums *sums;  /* FF_CPU_BLOCK: each column's running sums */
    double *g;       /* samples: one pair's kernel values */
    uint32_t *ray_count; /* FF_CPU_BLOCK: shadow rays of each column's first batch */
    uint8_t *active;  /* FF_CPU_BLOCK: 0 = not computed here or zero, 1 = far pair, 2 = near pair */
    uint8_t *traced;  /* FF_CPU_BLOCK: its shadow rays are cast (not culled) */
} cpu_scratch;

/* The context handed to Embree's filter: which faces a ray must ignore. */
typedef struct occlusion_context {
    struct RTCIntersectContext base; /* first member: Embree passes &base */
    const uint32_t *triangle_face;
    uint32_t skip_a, skip_b;
} occlusion_context;

static double now_seconds(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

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

/* Terms of samples [k0, k1) of pair (i, j) into g: kernel values for far
 * pairs, near-field terms (A_i F_ij contributions, rad_ff_near_sample)
 * for near ones. A plain loop over independent samples (the shared kernel
 * is branch-free); the caller sums g in order, so the result does not
 * depend on how the compiler schedules it. */
static void sample_terms(uint32_t estimator, int near, const rad_ff_patch *pi, const rad_ff_patch *pj, uint32_t i,
                         uint32_t j, uint32_t k0, uint32_t k1, uint64_t seed, double *restrict g)
{
    if (near) {
        for (uint32_t k = k0; k < k1; k++) {
            rad_vec3 x, y;
            g[k - k0] = rad_ff_near_sample(pi, pj, i, j, k, seed, &x, &y);
        }
    } else {
        for (uint32_t k = k0; k < k1; k++) {
            rad_vec3 x, y;
            rad_ff_pair_points(estimator, pi, pj, i, j, k, seed, &x, &y);
            g[k - k0] = rad_ff_point_kernel(x, pi->normal, y, pj->normal);
        }
    }
}

static void add_terms(rad_ff_sums *sums, const double *g, uint32_t count)
{
    for (uint32_t k = 0; k < count; k++) {
        sums->terms += g[k];
        sums->terms_sq += g[k] * g[k];
    }
    sums->samples += count;
}

/* The segment of sample k, from the lower-numbered patch's point (rows i
 * and j test one segment), as float ray data: origin, then end point; and
 * its weight in the visible fraction, the point kernel G(x, y). (Near
 * pairs too: the visible fraction is the G-weighted mean of V over point
 * pairs, whatever estimates the unoccluded part; weighing a segment by its
 * sample's near-field term instead would not estimate it.) */
static double ray_segment(const ff_setup *su, int near, uint32_t i, uint32_t j, uint32_t k, float ray[6])
{
    const rad_ff_patch *pi = &su->patches[i], *pj = &su->patches[j];
    rad_vec3 x, y;
    if (near)
        rad_ff_sample_pair(pi, pj, i, j, k, su->seed, &x, &y);
    else
        rad_ff_pair_points(su->estimator, pi, pj, i, j, k, su->seed, &x, &y);
    double g = rad_ff_point_kernel(x, pi->normal, y, pj->normal);
    if (i > j) {
        rad_vec3 t = x;
        x = y;
        y = t;
    }
    ray[0] = (float)x.x, ray[1] = (float)x.y, ray[2] = (float)x.z;
    ray[3] = (float)y.x, ray[4] = (float)y.y, ray[5] = (float)y.z;
    return g;
}

/* One shadow ray over t in [FF_RAY_T_MIN, FF_RAY_T_MAX] of the segment:
 * 1 if nothing but the pair's own faces (the context filter) is hit. */
static int segment_visible(RTCScene scene, occlusion_context *ctx, const float p[6])
{
    struct RTCRay ray;
    ray.org_x = p[0], ray.org_y = p[1], ray.org_z = p[2];
    ray.dir_x = p[3] - p[0], ray.dir_y = p[4] - p[1], ray.dir_z = p[5] - p[2];
    ray.tnear = FF_RAY_T_MIN; /* ff_bvh.h: the GPU tests the same span */
    ray.tfar = FF_RAY_T_MAX;
    ray.time = 0.0f;
    ray.mask = ~0u;
    ray.id = 0;
    ray.flags = 0;
    rtcOccluded1(scene, &ctx->base, &ray);
    return ray.tfar >= 0.0f; /* Embree sets tfar = -inf on a hit */
}

static void add_ray(rad_ff_sums *sums, double g, int visible)
{
    sums->ray_terms += g;
    sums->ray_terms_sq += g * g;
    if (visible) {
        sums->ray_seen += g;
        sums->ray_seen_sq += g * g;
    }
    sums->visible += (uint32_t)visible;
    sums->rays++;
}

/* Pass 1 for columns [j0, j1) of row i: the first batch of samples of
 * every pair row i computes, and the point pairs and terms of those that
 * carry shadow rays. Columns it does not compute are 0 and inactive. */
static void kernel_block(const ff_setup *su, uint32_t i, uint32_t j0, uint32_t j1, double *row, cpu_scratch *sc,
                         ff_counters *c)
{
    const rad_ff_patch *pi = &su->patches[i];
    uint32_t R = su->shadow_rays;
    for (uint32_t j = j0; j < j1; j++) {
        const rad_ff_patch *pj = &su->patches[j];
        uint32_t b = j - j0;
        sc->sums[b] = (rad_ff_sums){0};
        sc->active[b] = 0;
        sc->ray_count[b] = 0;
        row[j] = 0;
        if (su->pairs_once && !rad_ff_row_computes(i, j)) continue; /* row j computes this pair */
        c->pairs++;
        if (j == i || !rad_ff_pair_facing(pi, pj, su->plane_eps)) {
            c->pairs_culled++;
            continue;
        }
        int near = rad_ff_pair_uses_contour(su->estimator, pi, pj);
        uint32_t K = near ? rad_ff_near_samples(su->samples) : su->samples;
        sample_terms(su->estimator, near, pi, pj, i, j, 0, K, su->seed, sc->g);
        add_terms(&sc->sums[b], sc->g, K);
        /* The first R point pairs carry shadow rays: keep them and their weights. */
        uint32_t rays = R < K ? R : K;
        for (uint32_t k = 0; k < rays; k++) {
            sc->kernel[(size_t)b * R + k] = ray_segment(su, near, i, j, k, sc->rays + ((size_t)b * R + k) * 6);
        }
        sc->ray_count[b] = rays;
        sc->active[b] = near ? 2 : 1;
        c->samples += K;
        c->pairs_near += (uint64_t)near;
    }
}

/* Does pair (i, j) need shadow rays at all? Not where culling shows that
 * nothing can lie between the patches (their fraction is exactly 1). */
static int pair_needs_rays(const cpu_state *s, uint32_t i, uint32_t j, uint32_t rays, ff_counters *c)
{
    const ff_setup *su = &s->setup;
    if (!su->cull) return 1;
    if (su->scene_convex) {
        c->pairs_open_scene++;
        c->rays_saved += rays;
        return 0;
    }
    if (!ff_pair_may_be_occluded(s->bvh.nodes, s->bvh.tris, s->bvh.root, s->bvh.root_count, &su->patches[i],
                                 &su->patches[j], su->cull_margin, rays >= FF_CPU_HULL_MIN_RAYS)) {
        c->pairs_open_box++;
        c->rays_saved += rays;
        return 0;
    }
    return 1;
}

static void init_context(const cpu_state *s, occlusion_context *ctx, uint32_t i, uint32_t j)
{
    rtcInitIntersectContext(&ctx->base);
    ctx->base.filter = skip_own_faces;
    ctx->triangle_face = s->setup.triangle_face;
    ctx->skip_a = s->setup.patches[i].face;
    ctx->skip_b = s->setup.patches[j].face;
}

/* Pass 2: the kept shadow rays of each pair, then its estimate (and error). */
static void visibility_block(const cpu_state *s, uint32_t i, uint32_t j0, uint32_t j1, double *row, double *errors,
                             cpu_scratch *sc, ff_counters *c)
{
    const ff_setup *su = &s->setup;
    uint32_t R = su->shadow_rays;
    for (uint32_t j = j0; j < j1; j++) {
        uint32_t b = j - j0;
        if (!sc->active[b]) {
            if (errors) errors[j] = 0;
            continue;
        }
        rad_ff_sums *sums = &sc->sums[b];
        uint32_t rays = sc->ray_count[b];
        sc->traced[b] = sums->terms > 0 && rays > 0 && pair_needs_rays(s, i, j, rays, c);
        if (sc->traced[b]) {
            occlusion_context ctx;
            init_context(s, &ctx, i, j);
            for (uint32_t r = 0; r < rays; r++)
                add_ray(sums, sc->kernel[(size_t)b * R + r],
                        segment_visible(s->scene, &ctx, sc->rays + ((size_t)b * R + r) * 6));
            c->rays += rays;
            c->rays_occluded += rays - sums->visible;
        }
        double error = 0;
        row[j] = rad_ff_estimate(sums, sc->active[b] == 2, &su->patches[i], &su->patches[j], &error);
        if (errors) errors[j] = error;
    }
}

/* Pass 3 (--target-error): more batches for the pairs whose error is still
 * above the target; each batch doubles the samples and shadow rays. */
static void refine_block(const cpu_state *s, uint32_t i, uint32_t j0, uint32_t j1, double *row, double *errors,
                         cpu_scratch *sc, ff_counters *c)
{
    const ff_setup *su = &s->setup;
    for (uint32_t j = j0; j < j1; j++) {
        uint32_t b = j - j0;
        if (!sc->active[b]) continue;
        int near = sc->active[b] == 2;
        const rad_ff_patch *pi = &su->patches[i], *pj = &su->patches[j];
        rad_ff_sums *sums = &sc->sums[b];
        uint32_t first = sums->samples, first_rays = sc->ray_count[b];
        double error = 0;
        double value = rad_ff_estimate(sums, near, pi, pj, &error);
        uint32_t to = 0, rays_to = 0, planned = first_rays; /* rays a culled pair would have cast */
        int refined = 0;
        while (!rad_ff_error_reached(error, pi, pj, su->target_error) &&
               rad_ff_next_batch(sums, first, first_rays, su->samples, su->max_samples, &to, &rays_to)) {
            double t0 = now_seconds();
            for (uint32_t k0 = sums->samples; k0 < to; k0 += su->samples) { /* g holds `samples` terms */
                uint32_t k1 = to - k0 < su->samples ? to : k0 + su->samples;
                sample_terms(su->estimator, near, pi, pj, i, j, k0, k1, su->seed, sc->g);
                add_terms(sums, sc->g, k1 - k0);
                c->samples += k1 - k0;
            }
            double t1 = now_seconds();
            if (sc->traced[b]) {
                occlusion_context ctx;
                init_context(s, &ctx, i, j);
                uint32_t visible_before = sums->visible, rays_before = sums->rays;
                for (uint32_t r = sums->rays; r < rays_to; r++) {
                    float ray[6];
                    double g = ray_segment(su, near, i, j, r, ray);
                    add_ray(sums, g, segment_visible(s->scene, &ctx, ray));
                }
                c->rays += sums->rays - rays_before;
                c->rays_occluded += (sums->rays - rays_before) - (sums->visible - visible_before);
            } else if (sums->terms > 0 && first_rays > 0) { /* culled: these rays are saved too */
                c->rays_saved += rays_to - planned;
                planned = rays_to;
            }
            c->kernel_seconds += t1 - t0;
            c->visibility_seconds += now_seconds() - t1;
            value = rad_ff_estimate(sums, near, pi, pj, &error);
            refined = 1;
        }
        c->pairs_refined += (uint64_t)refined;
        c->pairs_capped += (uint64_t)!rad_ff_error_reached(error, pi, pj, su->target_error);
        row[j] = value;
        if (errors) errors[j] = error;
    }
}

static rad_status cpu_compute_rows(void *state, uint32_t row_begin, uint32_t row_count, double *out,
                                   double *errors, ff_counters *counters)
{
    cpu_state *s = state;
    const ff_setup *su = &s->setup;
    uint32_t n = su->patch_count, R = su->shadow_rays;
    int failed = 0;
    uint64_t rows_done = 0;

#pragma omp parallel num_threads(su->threads) reduction(+ : failed)
    {
        cpu_scratch sc;
        ff_counters c = {0};
        sc.rays = malloc(sizeof(float) * 6 * FF_CPU_BLOCK * (R ? R : 1));
        sc.kernel = malloc(sizeof(double) * FF_CPU_BLOCK * (R ? R : 1));
        sc.sums = malloc(sizeof(rad_ff_sums) * FF_CPU_BLOCK);
        sc.active = malloc(FF_CPU_BLOCK);
        sc.traced = malloc(FF_CPU_BLOCK);
        sc.g = malloc(sizeof(double) * su->samples);
        sc.ray_count = malloc(sizeof(uint32_t) * FF_CPU_BLOCK);
        int master = 1;
#ifdef _OPENMP
        master = omp_get_thread_num() == 0;
#endif
        if (!sc.rays || !sc.kernel || !sc.sums || !sc.g || !sc.ray_count || !sc.active || !sc.traced) failed = 1;
#pragma omp for schedule(dynamic, 1)
        for (uint32_t r = 0; r < row_count; r++) {
            if (failed) continue;
            uint32_t i = row_begin + r;
            double *row = out + (size_t)r * n;
            double *row_errors = errors ? errors + (size_t)r * n : NULL;
            for (uint32_t j0 = 0; j0 < n; j0 += FF_CPU_BLOCK) {
                uint32_t j1 = j0 + FF_CPU_BLOCK < n ? j0 + FF_CPU_BLOCK : n;
                double t0 = now_seconds();
                kernel_block(su, i, j0, j1, row, &sc, &c);
                double t1 = now_seconds();
                visibility_block(s, i, j0, j1, row, row_errors, &sc, &c);
                c.kernel_seconds += t1 - t0;
                c.visibility_seconds += now_seconds() - t1;
                if (su->target_error > 0) refine_block(s, i, j0, j1, row, row_errors, &sc, &c); /* times itself */
            }
            uint64_t done;
#pragma omp atomic capture
            done = ++rows_done;
            if (master && su->progress) su->progress(su->progress_user, done);
        }
#pragma omp critical
        {
            counters->pairs += c.pairs;
            counters->pairs_culled += c.pairs_culled;
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
        free(sc.rays);
        free(sc.kernel);
        free(sc.sums);
        free(sc.active);
        free(sc.traced);
        free(sc.g);
        free(sc.ray_count);
    }
    if (failed) {
        rad_error("out of memory for the CPU backend's scratch buffers");
        return RAD_ERR_NOMEM;
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

const ff_backend ff_backend_cpu = {"cpu", cpu_create, cpu_compute_rows, cpu_destroy, cpu_alloc_rows, cpu_free_rows};
