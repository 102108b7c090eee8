/* ff_backend_cpu.c - the reference backend: the shared per-pair procedure
 * (rad_ff_pair.h) on CPU threads (OpenMP), shadow segments through the
 * flat BVH of ff_bvh.h (built by Embree's builder, ff_bvh_build.c) and
 * its double-precision hit test: the very functions the CUDA backend
 * runs, so both count the same hits (ff_segment: the source and target
 * faces excluded, hits within delta of either end plane ignored).
 *
 * Rows are handed to threads one at a time; a row's pairs run in column
 * order. Each pair is first classified as the CUDA backend classifies it
 * (ff_pair_class.h: zero, reused, or computed - and then whether culling,
 * the convex-scene rule and the shaft test of ff_shaft.h, cleared it);
 * pairs culling clears are computed without a tracer (visible fraction
 * exactly 1), the others with one BVH query per shadow ray. The time in the tracer is the paper's
 * "occlusion" phase, the rest its "form factor" phase.
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#ifdef _OPENMP
#include <omp.h>
#endif

#include "ff_backend.h"
#include "ff_bvh.h"
#include "rad_clock.h"
#include "rad_log.h"

/* The tracer the shared per-pair procedure (rad_ff_pair.h) calls: one per
 * thread, for its occluder cache (last: ff_bvh_occluded_cached). */
typedef struct cpu_tracer {
    const ff_bvh *bvh;
    double delta;
    uint32_t *last;
} cpu_tracer;

/* One shadow segment x -> y: 1 if something other than faces a and b is
 * hit (ff_segment). */
static int cpu_occluded(const cpu_tracer *t, rad_vec3 x, rad_vec3 nx, uint32_t a, rad_vec3 y, rad_vec3 ny,
                        uint32_t b)
{
    ff_segment seg = ff_segment_make(x, nx, a, y, ny, b, t->delta);
    return ff_bvh_occluded_cached(t->bvh->nodes, t->bvh->tris, t->bvh->root, t->bvh->root_count, &seg, t->last);
}

#define RAD_FF_TRACER cpu_tracer
#define RAD_FF_OCCLUDED(t, x, nx, a, y, ny, b) cpu_occluded(t, x, nx, a, y, ny, b)
#define RAD_FF_TICKS() rad_clock_ns()
#include "rad_ff_pair.h"

#include "ff_openness.h"
#include "ff_pair_class.h"

typedef struct cpu_state {
    ff_setup setup;
    ff_bvh bvh;          /* occluders: shadow segments and the shaft tests */
    ff_pair_rules rules; /* ff_pair_class.h, over setup's patches and bvh */
} cpu_state;

static rad_status cpu_create(const ff_setup *setup, void **out_state)
{
    cpu_state *s = calloc(1, sizeof *s);
    if (!s) return RAD_ERR_NOMEM;
    s->setup = *setup;
    if (ff_bvh_build(setup->triangles, setup->triangle_face, setup->triangle_count, &s->bvh) != RAD_OK) {
        free(s);
        return RAD_ERR_BACKEND;
    }
    s->rules = ff_pair_rules_make(setup, setup->patches, s->bvh.nodes, s->bvh.tris, s->bvh.root, s->bvh.root_count);
    *out_state = s;
    return RAD_OK;
}

static void cpu_destroy(void *state)
{
    cpu_state *s = state;
    if (!s) return;
    ff_bvh_free(&s->bvh);
    free(s);
}

/* A computed pair's result into the thread's counters. */
static void count_pair(ff_counters *c, const rad_ff_pair_result *r)
{
    c->samples += r->samples;
    c->rays += r->rays;
    c->rays_occluded += r->rays_blocked;
    c->rays_saved += r->rays_skipped;
    c->pairs_near += (uint64_t)r->near;
    c->pairs_refined += (uint64_t)r->refined;
    c->pairs_capped += (uint64_t)r->capped;
}

/* Row i, every column: the shared per-pair procedure for each pair the
 * classification (ff_pair_class.h) leaves to be computed; zeros elsewhere. */
static void compute_row(const cpu_state *s, uint32_t i, double *row, double *errors, ff_counters *c)
{
    const ff_setup *su = &s->setup;
    const rad_ff_patch *pi = &su->patches[i];
    rad_ff_pair_params pp = ff_pair_params(su);
    uint32_t last = FF_BVH_NO_HIT;
    cpu_tracer tracer = {&s->bvh, su->ray_delta, &last};
    long long t0 = rad_clock_ns(), ray_ticks = 0;
    for (uint32_t j = 0; j < su->patch_count; j++) {
        row[j] = 0;
        if (errors) errors[j] = 0;
        ff_pair_verdict v = ff_pair_classify(&s->rules, i, j, NULL);
        if (v == FF_PAIR_OTHER_ROW) continue; /* row j computes this pair */
        c->pairs++;
        if (v == FF_PAIR_NOT_FACING) {
            c->pairs_not_facing++;
            continue;
        }
        if (v == FF_PAIR_REUSED) {
            row[j] = su->reuse_coupling[(size_t)su->reuse_old[i] * su->reuse_n + su->reuse_old[j]];
            c->pairs_reused++;
            continue;
        }
        c->pairs_open_scene += (uint64_t)(v == FF_PAIR_OPEN_SCENE);
        c->pairs_open_box += (uint64_t)(v == FF_PAIR_OPEN_BOX);
        rad_ff_pair_result r;
        rad_ff_pair_compute(&pp, pi, &su->patches[j], i, j, v == FF_PAIR_TRACED ? &tracer : NULL, &r);
        row[j] = r.coupling;
        if (errors) errors[j] = r.error;
        count_pair(c, &r);
        ray_ticks += r.ray_ticks;
    }
    double total = 1e-9 * (double)(rad_clock_ns() - t0), rays_time = 1e-9 * (double)ray_ticks;
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
        /* The threads' times overlap: their mean is the wall-clock time. */
        c.kernel_seconds /= su->threads;
        c.visibility_seconds /= su->threads;
#pragma omp critical
        ff_counters_add(counters, &c);
    }
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

/* Pairs of a hierarchy's elements (ff_backend.compute_pairs): the rules
 * of this run over the given patches, then the per-pair procedure with
 * the elements' keys. */
static rad_status cpu_compute_pairs(void *state, const rad_ff_patch *patches, const uint32_t *keys,
                                    const ff_pair_job *jobs, size_t count, ff_pair_outcome *out,
                                    ff_counters *counters)
{
    cpu_state *s = state;
    const ff_setup *su = &s->setup;
    ff_pair_rules rules = s->rules;
    rules.patches = patches;
    rules.pairs_once = 0;
    rules.reuse_old = NULL;
    const rad_ff_pair_params pp = ff_pair_params(su);
#pragma omp parallel num_threads(su->threads)
    {
        uint32_t last = FF_BVH_NO_HIT;
        cpu_tracer tracer = {&s->bvh, su->ray_delta, &last};
        ff_counters c = {0};
        long long t0 = rad_clock_ns(), ray_ticks = 0;
#pragma omp for schedule(dynamic, 16)
        for (size_t k = 0; k < count; k++) {
            uint32_t a = jobs[k].a, b = jobs[k].b;
            ff_pair_outcome o = {0};
            ff_pair_verdict v = ff_pair_classify(&rules, a, b, NULL);
            o.verdict = (uint32_t)v;
            c.pairs++;
            if (v == FF_PAIR_NOT_FACING) {
                c.pairs_not_facing++;
            } else {
                c.pairs_open_scene += (uint64_t)(v == FF_PAIR_OPEN_SCENE);
                c.pairs_open_box += (uint64_t)(v == FF_PAIR_OPEN_BOX);
                rad_ff_pair_params job_pp = pp;
                job_pp.ray_floor = jobs[k].ray_floor;
                rad_ff_pair_result r;
                rad_ff_pair_compute(&job_pp, &patches[a], &patches[b], keys[a], keys[b],
                                    v == FF_PAIR_TRACED ? &tracer : NULL, &r);
                o.coupling = r.coupling;
                o.error = r.error;
                if (jobs[k].spread) {
                    o.spread_ab = rad_ff_factor_spread(&patches[a], &patches[b]);
                    o.spread_ba = rad_ff_factor_spread(&patches[b], &patches[a]);
                }
                o.rays = r.rays;
                o.rays_blocked = r.rays_blocked;
                count_pair(&c, &r);
                ray_ticks += r.ray_ticks;
            }
            out[k] = o;
        }
        double total = 1e-9 * (double)(rad_clock_ns() - t0), rays_time = 1e-9 * (double)ray_ticks;
        c.kernel_seconds = (total - rays_time) / su->threads;
        c.visibility_seconds = rays_time / su->threads;
#pragma omp critical
        ff_counters_add(counters, &c);
    }
    return RAD_OK;
}

static rad_status cpu_cluster_draws(void *state, const ff_cluster_view *v, const ff_pair_job *jobs, size_t count,
                                    ff_cluster_drawn *out)
{
    const cpu_state *s = state;
#pragma omp parallel for schedule(dynamic, 16) num_threads(s->setup.threads)
    for (size_t k = 0; k < count; k++)
        ff_cluster_pair(v, s->bvh.nodes, s->bvh.tris, s->bvh.root, s->bvh.root_count, jobs[k].a, jobs[k].b, &out[k]);
    return RAD_OK;
}

/* ff_backend.openness through the occluders' BVH built at create. */
static rad_status cpu_openness(void *state, const rad_ff_patch *patches, uint32_t count, double reach, float *open)
{
    const cpu_state *s = state;
    ff_openness_bvh(patches, count, reach, s->setup.ray_delta, &s->bvh, open);
    return RAD_OK;
}

const ff_backend ff_backend_cpu = {"cpu",          cpu_create,    cpu_compute_rows, cpu_destroy,
                                   cpu_alloc_rows, cpu_free_rows, NULL,             cpu_compute_pairs,
                                   cpu_cluster_draws, NULL,             cpu_openness};
