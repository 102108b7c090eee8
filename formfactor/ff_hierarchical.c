/* ff_hierarchical.c - formfactor --method hierarchical (ff_hierarchical.h):
 * the refinement loop of docs/hierarchy.md. Pass 1 links the roots and
 * refines by B = E; each later pass solves on the links made so far
 * (rad_lsolve) and refines the links the solution's B makes too coarse,
 * until a pass refines nothing or --passes are done. The last solution
 * gives the error bound the file records; solve solves again from the
 * file. Rank 0 refines; every rank computes its share of each round's
 * pairs on its own backend (ff_rank_rounds.h): the links are the same
 * bytes whatever the ranks and threads. */
#include "ff_hierarchical.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "ff_backend.h"
#include "ff_cuda.h"
#include "ff_limits.h"
#include "rad_cpu.h"
#include "ff_links.h"
#include "ff_rank_rounds.h"
#include "ff_load.h"
#include "ff_setup.h"
#include "ff_solve.h"
#include "rad_clock.h"
#include "rad_ffile.h"
#include "rad_fs.h"
#include "rad_json.h"
#include "rad_log.h"
#include "rad_mem.h"
#include "shaped.h"
#include "rad_lsolve.h"

typedef struct hier_run {
    const ff_options *opt;
    rad_scene scene;
    rad_mesh base;
    double *triangles;
    uint32_t *triangle_face, triangle_count;
    const ff_backend *backend; /* element pairs: CUDA's under --backend cuda|auto with a GPU, else the CPU's */
    void *backend_state;
    ff_links links;
    rad_links exported;
    rad_mesh leaves;
    double *B; /* 3 per leaf */
    rad_lsolve_result solution;
    ff_counters counters;
    double error_bound;
    rad_lsolve_options solved_with; /* the last flat solve's (from B = E unless warm_start: ff_solve_links
                                       may take such a one as its own) */
    int threads;
    int ranks;          /* sharing the rounds' pairs (ff_rank_rounds.h) */
    ff_rank_times rank_times; /* theirs, rank 0's view; zero on one rank */
    int cpu_first;      /* --backend auto takes the CPU without asking CUDA (cpu_first_under_auto) */
    ff_closed_result closed; /* --closure: closed 1 marks the file (RAD_FF_FLAG_CLOSED); rays 0: not tested */
    double most_leaves; /* faces x 4^level: what it decides by */
    double seconds_load, seconds_setup, seconds_links, seconds_export, seconds_bound, seconds_solve, seconds_write,
        seconds_total; /* seconds_bound: the error bound's share of seconds_export */
    double peak_load, peak_refine, peak_export, peak_total; /* the resident peak after each (rad_mem_peak_bytes) */
    uint32_t gpu_solves; /* the passes' flat solves the GPU made (solve_links_flat_gpu) */
    int last_solve_gpu;  /* the last of them was one */
    char solved_on[128]; /* its GPU's name */
    uint64_t refined[64];
} hier_run;

/* Are two leaf meshes the same patches, in the same order? */
static int same_leaves(const rad_mesh *a, const rad_mesh *b)
{
    if (a->patch_count != b->patch_count || !a->patches) return 0;
    for (size_t k = 0; k < a->patch_count; k++) {
        const rad_patch *p = &a->patches[k], *q = &b->patches[k];
        if (p->area != q->area || p->centroid.x != q->centroid.x || p->centroid.y != q->centroid.y ||
            p->centroid.z != q->centroid.z)
            return 0;
    }
    return 1;
}

/* The passes' flat solves: a pass that another follows solves only for
 * the oracle's weights (B to 1e-4 moves a link's weight by 1e-4 of
 * itself); the last one, whose B gives the file's error bound and the
 * stats' balance, to 1e-6. */
#define HIER_ORACLE_TOL 1e-4
#define HIER_FINAL_TOL 1e-6

/* The oracle's solves (a pass that another follows) run on the GPU where
 * the pairs are computed there and there are this many links: the flat
 * operator's Jacobi sweeps (solve_links_flat_gpu), 16 bytes a link on the
 * GPU and none more on the host. The last pass's solve runs where solve
 * would run it on the file (ff_solve_flat_on_gpu), so that --radiosity
 * stays the same bytes as the two stages. */
#define HIER_GPU_SOLVE_MIN_LINKS ((uint64_t)4 << 20)

/* The flat solve of the exported links to `tol`, from h->B where `warm`;
 * a grey scene once (solve's options, so that ff_solve_links may take a
 * cold one as its own). On the GPU where above; one that fails there
 * (memory, a CUDA error: a warning) is solved on the CPU. */
static rad_status solve_flat(hier_run *h, double tol, int warm)
{
    rad_lsolve_options o = rad_lsolve_defaults();
    o.threads = h->threads;
    o.tolerance = tol;
    o.warm_start = warm;
    o.channels = ff_solve_channels(&h->leaves);
    const double t0 = rad_clock_seconds();
    rad_status st = RAD_ERR_BACKEND;
    const uint64_t gpu_from = h->opt->gpu_solve_links ? h->opt->gpu_solve_links : HIER_GPU_SOLVE_MIN_LINKS;
    const uint64_t links = h->exported.link_count;
    const int gpu = tol <= HIER_FINAL_TOL ? ff_solve_flat_on_gpu(h->opt, links)
                                          : h->backend == &ff_backend_cuda && links >= gpu_from;
    h->last_solve_gpu = 0;
    if (gpu) {
        if (h->backend->trim) h->backend->trim(h->backend_state); /* the rounds' buffers, beside the links */
        st = solve_links_flat_gpu(&h->exported, &h->leaves, &o, 0, h->B, &h->solution, h->solved_on);
        if (st == RAD_OK || st == RAD_ERR_NOT_CONVERGED) h->gpu_solves++, h->last_solve_gpu = 1;
    }
    if (st == RAD_ERR_BACKEND) st = rad_lsolve(&h->exported, &h->leaves, &o, h->B, &h->solution);
    h->seconds_solve += rad_clock_seconds() - t0;
    h->solved_with = o;
    return st;
}

/* Exports the links and solves on them to `tol`: from the last pass's B
 * where the leaves did not change (uniform or sized leaves: every pass
 * after the first), else, but for the last pass, from the elements' B
 * (ff_links_leaf_radiosity: a new leaf starts at its parent's value). The
 * last pass of new leaves solves from B = E, as solve does on the file,
 * so that --radiosity can take that solution as its own. */
static rad_status export_and_solve(hier_run *h, double tol, int last)
{
    double t0 = rad_clock_seconds();
    rad_mesh old_leaves = h->leaves;
    double *old_B = h->B;
    memset(&h->leaves, 0, sizeof h->leaves);
    h->B = NULL;
    rad_links_free(&h->exported);
    rad_status st = ff_links_export(&h->links, &h->exported, &h->leaves);
    h->seconds_export += rad_clock_seconds() - t0;
    if (st == RAD_OK && !(h->B = malloc(3 * (h->leaves.patch_count ? h->leaves.patch_count : 1) * sizeof *h->B)))
        st = RAD_ERR_NOMEM;
    int warm = st == RAD_OK && old_B && same_leaves(&old_leaves, &h->leaves);
    if (warm) {
        memcpy(h->B, old_B, 3 * h->leaves.patch_count * sizeof *h->B);
    } else if (st == RAD_OK && old_B && !last) {
        warm = ff_links_leaf_radiosity(&h->links, h->B);
    }
    rad_mesh_free(&old_leaves);
    free(old_B);
    return st == RAD_OK ? solve_flat(h, tol, warm) : st;
}

/* The last pass's links exported again (a pass that refined nothing: the
 * same links, the same leaves, whose solution h->B stands). */
static rad_status export_again(hier_run *h)
{
    const double t0 = rad_clock_seconds();
    rad_mesh leaves = {0};
    rad_status st = ff_links_export(&h->links, &h->exported, &leaves);
    if (st == RAD_OK && !same_leaves(&leaves, &h->leaves)) {
        rad_error("internal: the links exported again have other leaves");
        st = RAD_ERR_INVALID;
    }
    rad_mesh_free(&leaves);
    h->seconds_export += rad_clock_seconds() - t0;
    return st;
}

/* --closure on marks the file closed where the scene is (a convex
 * enclosure seen from inside is without a ray; else ff_scene_is_closed);
 * an open scene's is left unmarked, with a warning. */
static rad_status decide_closure(hier_run *h, const ff_setup *su, const double centre[3])
{
    if (h->opt->closure <= 0) return RAD_OK;
    if (su->scene_convex) {
        h->closed.closed = 1;
        h->closed.open_patch = -1;
        rad_info("--closure on: the scene is closed (a convex enclosure seen from inside): the solve balances every "
                 "leaf's row to 1");
        return RAD_OK;
    }
    const double t0 = rad_clock_seconds();
    rad_status st = ff_scene_is_closed(&h->base, centre, h->triangles, h->triangle_face, h->triangle_count, &h->closed);
    if (st != RAD_OK) return st;
    if (h->closed.closed) {
        rad_info("--closure on: the scene is closed (%llu rays from its %zu faces all met fronts, %.2f s): the solve "
                 "balances every leaf's row to 1",
                 (unsigned long long)h->closed.rays, h->base.patch_count, rad_clock_seconds() - t0);
    } else {
        const rad_patch *p = &h->base.patches[h->closed.open_patch];
        rad_warn("--closure on: the scene is open, so its rows are not all 1 and the links are left as they are: a ray "
                 "from the face of line %u %s (%.2f s)",
                 h->scene.faces[p->source_face].line, h->closed.escaped ? "leaves the scene" : "meets a face's back",
                 rad_clock_seconds() - t0);
    }
    return RAD_OK;
}

/* Whether --backend auto takes the CPU without asking CUDA: where the
 * leaves may reach fewer than FF_HIER_CPU_LEAVES_PER_THREAD a thread
 * (faces x 4^level, *most), the CPU's threads finish before CUDA has
 * started, and that start slows the CPU's run beside it. */
static int cpu_first_under_auto(const hier_run *h, double *most)
{
    const ff_options *opt = h->opt;
    const uint32_t level = opt->subdiv_given ? (uint32_t)opt->subdiv : FF_HIER_MAX_LEVEL;
    *most = (double)h->base.patch_count * ldexp(1.0, 2 * (int)level);
    return opt->backend == FF_BACKEND_AUTO && *most < (double)FF_HIER_CPU_LEAVES_PER_THREAD * h->threads;
}

/* The occluders and the backend's setup from the loaded scene: every
 * rank's, the same. */
static rad_status prepare_setup(hier_run *h, ff_setup *su, double centre[3])
{
    const ff_options *opt = h->opt;
    ff_frame_centre(&h->base, centre);
    rad_status st = ff_occluders_build(&h->scene, centre, &h->triangles, &h->triangle_face, &h->triangle_count);
    if (st != RAD_OK) return st;
    double eps = ff_plane_eps(&h->base);
    *su = (ff_setup){.patches = NULL, .patch_count = 0, .triangles = h->triangles,
                     .triangle_face = h->triangle_face, .triangle_count = h->triangle_count,
                     .samples = opt->samples, .shadow_rays = opt->shadow_rays, .seed = opt->seed,
                     .estimator = opt->estimator, .quad_rtol = ff_links_quad_rtol(opt->link_tol, opt->quad_rtol),
                     .quad_atol = opt->quad_atol,
                     .target_error = opt->target_error, .max_samples = opt->max_samples, .errors = 1,
                     .cull = opt->cull == FF_CULL_ALL,
                     .scene_convex = opt->cull == FF_CULL_ALL && ff_scene_is_convex_enclosure(&h->scene, eps),
                     .cull_margin = ff_cull_margin(&h->base, centre, eps), .plane_eps = eps,
                     .ray_delta = ff_ray_delta(&h->base), .threads = h->threads};
    return RAD_OK;
}

/* Every rank's backend, of rank 0's kind (collective): CUDA's where rank
 * 0 sees a GPU under --backend cuda, or auto that does not take the CPU
 * first; else the CPU's. The ranks must agree on it, for a pair's outcome
 * may differ between the two in the last bits. A rank's GPU: its rank
 * modulo the GPUs it sees. */
static rad_status open_backend(hier_run *h, ff_comm *comm, ff_setup *su)
{
    const ff_options *opt = h->opt;
    const int rank = ff_comm_rank(comm);
    const int will_ask = opt->backend != FF_BACKEND_CPU && !h->cpu_first;
    const int gpus = will_ask ? ff_cuda_device_count() : 0; /* waits for the start */
    int gpu = gpus > 0;
    ff_comm_broadcast(comm, &gpu, sizeof gpu, 0);
    if (opt->backend == FF_BACKEND_CUDA && gpus == 0) {
        rad_error("--backend cuda: no CUDA device is visible to rank %d", rank);
        return RAD_ERR_UNSUPPORTED;
    }
    if (gpu && gpus == 0) {
        rad_error("--method hierarchical: rank 0 computes on a GPU and rank %d sees none; the ranks' pairs must be "
                  "computed alike (--backend cpu runs every rank on its CPU)",
                  rank);
        return RAD_ERR_UNSUPPORTED;
    }
    if (h->cpu_first && rank == 0)
        rad_info("--backend auto: the CPU (at most %.0f leaves, under %u a thread on %d threads; a GPU from there)",
                 h->most_leaves, FF_HIER_CPU_LEAVES_PER_THREAD, h->threads);
    su->device = gpu ? rank % gpus : 0;
    h->backend = gpu ? &ff_backend_cuda : &ff_backend_cpu;
    return h->backend->create(su, &h->backend_state);
}

/* Rank 0: the passes, the other ranks computing their share of each
 * round (ff_rank_rounds.h) until they are done. */
static rad_status build_links(hier_run *h, ff_comm *comm, const ff_setup *su, const double centre[3])
{
    const ff_options *opt = h->opt;
    const double t_setup = rad_clock_seconds();
    rad_status st = decide_closure(h, su, centre);
    double total_area = 0;
    for (size_t k = 0; k < h->base.patch_count; k++) total_area += h->base.patches[k].area;
    ff_links_config config = {.link_tol = opt->link_tol, .oracle = ff_oracle_resolve(opt->oracle, opt->uniform_leaves || opt->sized_leaves),
                              .max_level = opt->subdiv_given ? (uint32_t)opt->subdiv : FF_HIER_MAX_LEVEL,
                              .min_area = opt->min_area * total_area, .uniform_leaves = opt->uniform_leaves,
                              .sized_leaves = opt->sized_leaves,
                              .cluster_cone = opt->cluster_cone >= 180.0 ? RAD_PI : opt->cluster_cone * (RAD_PI / 180.0),
                              .cluster_open = opt->cluster_open, .triangles = h->triangles,
                              .triangle_face = h->triangle_face, .triangle_count = h->triangle_count,
                              .clusters = opt->clusters >= 0 ? opt->clusters
                                                             : h->base.patch_count >= FF_CLUSTERS_AUTO_ROOTS,
                              .ray_delta = su->ray_delta};
    if (st == RAD_OK && opt->clusters < 0)
        rad_info("--clusters auto: %s (%zu faces; on from %u)", config.clusters ? "on" : "off", h->base.patch_count,
                 FF_CLUSTERS_AUTO_ROOTS);
    char each[48] = "";
    if (h->ranks > 1) snprintf(each, sizeof each, " of each of %d ranks", h->ranks);
    if (st == RAD_OK)
        rad_info("element pairs%s on the %s backend%s", config.clusters ? " and cluster pairs" : "", h->backend->name,
                 each);
    if (st == RAD_OK)
        st = ff_links_init(&h->links, &h->scene, &h->base, centre, &config, h->backend, h->backend_state);
    if (st == RAD_OK && h->ranks > 1) st = ff_rank_rounds_open(comm, &h->links.ranks);
    h->seconds_setup += rad_clock_seconds() - t_setup;
    for (uint32_t pass = 0; pass < opt->passes && st == RAD_OK; pass++) {
        /* the last export is not needed while the links refine (h->B and
         * h->leaves are): freed, it is not beside the refinement's pairs */
        rad_links_free(&h->exported);
        double t0 = rad_clock_seconds();
        uint64_t refined = 0;
        st = ff_links_refine(&h->links, pass ? h->B : NULL, &h->counters, &refined);
        h->seconds_links += rad_clock_seconds() - t0;
        h->peak_refine = rad_mem_peak_bytes();
        if (pass < 64) h->refined[pass] = refined;
        if (st == RAD_OK && pass > 0 && refined == 0) {
            rad_info("pass %u: nothing refined; the links and their solution stand", pass + 1);
            st = export_again(h);
            break;
        }
        const int last = pass + 1 == opt->passes;
        if (st == RAD_OK) st = export_and_solve(h, last ? HIER_FINAL_TOL : HIER_ORACLE_TOL, last);
        if (st == RAD_OK)
            rad_info("pass %u: %llu pairs refined; %u elements, %u leaves, %llu links (%.1f per leaf); %llu candidate "
                     "pairs, %llu shadow rays so far; links %.2f s, solved in %u sweeps%s",
                     pass + 1, (unsigned long long)refined, h->exported.node_count, h->exported.leaf_count,
                     (unsigned long long)h->exported.link_count,
                     (double)h->exported.link_count / (h->exported.leaf_count ? h->exported.leaf_count : 1),
                     (unsigned long long)h->links.tally.candidates, (unsigned long long)h->counters.rays,
                     h->seconds_links, h->solution.iterations[0], h->last_solve_gpu ? " (Jacobi on the GPU)" : "");
    }
    if (h->links.ranks) {
        ff_rank_rounds_times_get(h->links.ranks, &h->rank_times);
        const ff_rank_times *t = &h->rank_times;
        rad_info("ranks: %llu exchanges (rounds, or pieces of large ones) shared by %d; sent %.2f s, computed %.2f s "
                 "(rank 0), %.2f s (the slowest rank each time), %.2f s (the fastest); collected %.2f s",
                 (unsigned long long)t->rounds, h->ranks, t->send, t->own, t->slowest, t->fastest, t->collect);
    }
    ff_rank_rounds_close(comm, h->links.ranks); /* the other ranks are done, whatever failed */
    h->links.ranks = NULL;
    /* a pass that refined nothing left the last solution at the oracle's tolerance */
    if (st == RAD_OK && h->solved_with.tolerance > HIER_FINAL_TOL) st = solve_flat(h, HIER_FINAL_TOL, 1);
    if (st == RAD_OK) {
        const double t0 = rad_clock_seconds();
        h->error_bound = ff_links_error_bound(&h->links, &h->exported, h->B);
        h->exported.error_bound = h->error_bound;
        h->seconds_bound = rad_clock_seconds() - t0;
        h->seconds_export += h->seconds_bound;
    }
    h->peak_export = rad_mem_peak_bytes();
    return st;
}

/* The header of the links' file. */
static rad_ff_info links_info(const hier_run *h)
{
    const ff_options *opt = h->opt;
    rad_ff_info info = {.patch_count = h->leaves.patch_count, .vertex_count = h->leaves.vertex_count,
                        .element_type = RAD_ELEMENT_F64, .estimator = opt->estimator, .samples = opt->samples,
                        .shadow_rays = opt->shadow_rays, .seed = opt->seed,
                        .scene_fingerprint = h->scene.fingerprint, .subdiv = (int32_t)h->links.config.max_level,
                        .flags = RAD_FF_FLAG_RECIPROCAL | (opt->ke_radiance ? RAD_FF_FLAG_KE_RADIANCE : 0) |
                                 (h->closed.closed ? RAD_FF_FLAG_CLOSED : 0),
                        .group_count = (uint32_t)h->leaves.group_count, .layout = RAD_FF_LAYOUT_LINKS};
    snprintf(info.scene_name, sizeof info.scene_name, "%s", opt->scene_path ? opt->scene_path : rad_default_scene_name);
    return info;
}

/* The links to -o, or with --radiosity solved in memory (ff_solve.h) and
 * the radiosity written instead. */
static rad_status write_links(hier_run *h)
{
    const ff_options *opt = h->opt;
    const rad_ff_info info = links_info(h);
    double t0 = rad_clock_seconds();
    const rad_lsolve_options *o = &h->solved_with;
    const solve_links_flat flat = {.B = h->B,
                                   .result = h->solution,
                                   .tolerance = o->tolerance,
                                   .method = o->method,
                                   .channels = o->channels,
                                   .gpu = h->last_solve_gpu,
                                   .device = h->solved_on};
    rad_status st = opt->radiosity_path ? ff_solve_links(&info, &h->leaves, &h->exported, o->warm_start ? NULL : &flat,
                                                         opt, h->threads)
                                        : rad_ff_write_links(opt->output, &info, &h->leaves, &h->exported);
    h->seconds_write = rad_clock_seconds() - t0;
    return st;
}

static void json_counters(rad_json_writer *w, const ff_counters *c)
{
    rad_json_key(w, "pairs");
    rad_json_uint(w, c->pairs);
    rad_json_key(w, "pairs_not_facing");
    rad_json_uint(w, c->pairs_not_facing);
    rad_json_key(w, "pairs_open_scene");
    rad_json_uint(w, c->pairs_open_scene);
    rad_json_key(w, "pairs_open_box");
    rad_json_uint(w, c->pairs_open_box);
    rad_json_key(w, "rays");
    rad_json_uint(w, c->rays);
    rad_json_key(w, "rays_occluded");
    rad_json_uint(w, c->rays_occluded);
}

static rad_status write_stats(const hier_run *h)
{
    const ff_options *opt = h->opt;
    const rad_links *x = &h->exported;
    uint32_t levels = 0;
    for (uint32_t e = 0; e < x->node_count; e++) levels = x->nodes[e].level + 1 > levels ? x->nodes[e].level + 1 : levels;
    rad_info("hierarchical: %u roots, %u levels, %u elements, %u leaves, %llu links (%.1f per leaf, %.1f per element), "
             "%llu candidate pairs in %llu rounds, %llu shadow rays; error bound %.3g; links %.2f s, solves %.2f s, "
             "%s %.2f s",
             x->root_count, levels, x->node_count, x->leaf_count, (unsigned long long)x->link_count,
             (double)x->link_count / x->leaf_count, (double)x->link_count / x->node_count,
             (unsigned long long)h->links.tally.candidates, (unsigned long long)h->links.tally.rounds,
             (unsigned long long)h->counters.rays, h->error_bound, h->seconds_links, h->seconds_solve,
             opt->radiosity_path ? "solved and written (--radiosity)" : "write", h->seconds_write);
    if (!opt->stats_path) return RAD_OK;
    FILE *f = NULL;
    char temp[4096];
    rad_status st = rad_fs_create_temp(opt->stats_path, temp, sizeof temp, &f);
    if (st != RAD_OK) return st;
    rad_json_writer w;
    rad_json_writer_init_file(&w, f);
    rad_json_begin_object(&w, RAD_JSON_BLOCK);
    rad_json_key(&w, "scene");
    rad_json_string(&w, opt->scene_path ? opt->scene_path : rad_default_scene_name);
    rad_json_key(&w, "method");
    rad_json_string(&w, "hierarchical");
    rad_json_key(&w, "oracle");
    rad_json_string(&w, ff_oracle_name(h->links.config.oracle));
    rad_json_key(&w, "link_tol");
    rad_json_number(&w, opt->link_tol);
    rad_json_key(&w, "max_level");
    rad_json_uint(&w, h->links.config.max_level);
    rad_json_key(&w, "leaves_made");
    rad_json_string(&w, h->links.config.uniform_leaves ? "uniform" : h->links.config.sized_leaves ? "sized" : "by refinement");
    rad_json_key(&w, "min_area");
    rad_json_number(&w, opt->min_area);
    rad_json_key(&w, "passes");
    rad_json_uint(&w, h->links.passes);
    rad_json_key(&w, "refined_per_pass");
    rad_json_begin_array(&w, RAD_JSON_INLINE);
    for (uint32_t p = 0; p < h->links.passes && p < 64; p++) rad_json_uint(&w, h->refined[p]);
    rad_json_end_array(&w);
    rad_json_key(&w, "roots");
    rad_json_uint(&w, x->root_count);
    rad_json_key(&w, "levels");
    rad_json_uint(&w, levels);
    rad_json_key(&w, "elements");
    rad_json_uint(&w, x->node_count);
    rad_json_key(&w, "leaves");
    rad_json_uint(&w, x->leaf_count);
    rad_json_key(&w, "links");
    rad_json_uint(&w, x->link_count);
    rad_json_key(&w, "links_per_leaf");
    rad_json_number(&w, (double)x->link_count / x->leaf_count);
    rad_json_key(&w, "links_per_element");
    rad_json_number(&w, (double)x->link_count / x->node_count);
    rad_json_key(&w, "clusters");
    rad_json_uint(&w, x->cluster_count);
    rad_json_key(&w, "closed"); /* --closure: the file marked closed (RAD_FF_FLAG_CLOSED) */
    rad_json_bool(&w, h->closed.closed);
    rad_json_key(&w, "closure_rays");
    rad_json_uint(&w, h->closed.rays);
    rad_json_key(&w, "cluster_pairs");
    rad_json_uint(&w, h->links.tally.cluster_pairs);
    rad_json_key(&w, "cluster_rays");
    rad_json_uint(&w, h->links.tally.cluster_rays);
    rad_json_key(&w, "cluster_seconds"); /* their wall */
    rad_json_number_fixed(&w, h->links.tally.cluster_seconds, 3);
    rad_json_key(&w, "open_seconds"); /* the faces' openness, once */
    rad_json_number_fixed(&w, h->links.tally.open_seconds, 3);
    rad_json_key(&w, "candidate_pairs");
    rad_json_uint(&w, h->links.tally.candidates);
    rad_json_key(&w, "rounds");
    rad_json_uint(&w, h->links.tally.rounds);
    json_counters(&w, &h->counters);
    rad_json_key(&w, "error_bound");
    rad_json_number(&w, h->error_bound);
    rad_json_key(&w, "gpu_solves"); /* the passes' flat solves made on the GPU (solve_links_flat_gpu) */
    rad_json_uint(&w, h->gpu_solves);
    rad_json_key(&w, "solve_sweeps");
    rad_json_uint(&w, h->solution.iterations[0]);
    rad_json_key(&w, "imbalance");
    rad_json_number(&w, h->solution.imbalance);
    rad_json_key(&w, "threads");
    rad_json_int(&w, h->threads);
    rad_json_key(&w, "ranks"); /* each computing its share of every round's pairs */
    rad_json_int(&w, h->ranks);
    if (h->ranks > 1) { /* the rounds' backend time, as rank 0 saw it (ff_rank_times) */
        const ff_rank_times *t = &h->rank_times;
        rad_json_key(&w, "ranks_seconds");
        rad_json_begin_object(&w, RAD_JSON_INLINE);
        rad_json_key(&w, "send");
        rad_json_number(&w, t->send);
        rad_json_key(&w, "rank0");
        rad_json_number(&w, t->own);
        rad_json_key(&w, "slowest");
        rad_json_number(&w, t->slowest);
        rad_json_key(&w, "fastest");
        rad_json_number(&w, t->fastest);
        rad_json_key(&w, "collect");
        rad_json_number(&w, t->collect);
        rad_json_end_object(&w);
    }
    rad_json_key(&w, "backend");
    rad_json_string(&w, h->backend->name);
    rad_json_key(&w, "times");
    rad_json_begin_object(&w, RAD_JSON_INLINE);
    rad_json_key(&w, "load");
    rad_json_number(&w, h->seconds_load);
    rad_json_key(&w, "setup"); /* occluders, the backend (a GPU's start), the roots */
    rad_json_number(&w, h->seconds_setup);
    rad_json_key(&w, "links");
    rad_json_number(&w, h->seconds_links);
    rad_json_key(&w, "rounds"); /* of the links: the rounds' parts (ff_links.h) */
    rad_json_begin_object(&w, RAD_JSON_INLINE);
    rad_json_key(&w, "sort");
    rad_json_number(&w, h->links.tally.seconds_sort);
    rad_json_key(&w, "backend");
    rad_json_number(&w, h->links.tally.seconds_backend);
    rad_json_key(&w, "decide");
    rad_json_number(&w, h->links.tally.seconds_decide);
    rad_json_key(&w, "reweigh");
    rad_json_number(&w, h->links.tally.seconds_reweigh);
    rad_json_key(&w, "elements"); /* of decide and reweigh */
    rad_json_number(&w, h->links.tally.seconds_elements);
    rad_json_end_object(&w);
    rad_json_key(&w, "export"); /* the links handed to the solves, and the error bound */
    rad_json_number(&w, h->seconds_export);
    rad_json_key(&w, "error_bound"); /* of which the error bound */
    rad_json_number(&w, h->seconds_bound);
    rad_json_key(&w, "form_factors");
    rad_json_number(&w, h->counters.kernel_seconds);
    rad_json_key(&w, "visibility");
    rad_json_number(&w, h->counters.visibility_seconds);
    rad_json_key(&w, "gpu_memory"); /* CUDA: the element pairs' transfers and device allocations */
    rad_json_number(&w, h->counters.memory_seconds);
    rad_json_key(&w, "solves");
    rad_json_number(&w, h->seconds_solve);
    rad_json_key(&w, opt->radiosity_path ? "radiosity" : "io"); /* --radiosity: the solve in memory, and its file */
    rad_json_number(&w, h->seconds_write);
    rad_json_key(&w, "total");
    rad_json_number(&w, h->seconds_total);
    rad_json_end_object(&w);
    /* the resident peak after each phase: the phase where it rises set it */
    rad_json_key(&w, "peak_bytes");
    rad_json_begin_object(&w, RAD_JSON_INLINE);
    rad_json_key(&w, "load");
    rad_json_number(&w, h->peak_load);
    rad_json_key(&w, "refine"); /* the last pass's refinement (earlier passes' exports and solves before it) */
    rad_json_number(&w, h->peak_refine);
    rad_json_key(&w, "export"); /* the last export, its flat solve and the error bound */
    rad_json_number(&w, h->peak_export);
    rad_json_key(&w, opt->radiosity_path ? "radiosity" : "io");
    rad_json_number(&w, h->peak_total);
    rad_json_end_object(&w);
    rad_json_end_object(&w);
    rad_status written = rad_json_finish(&w);
    st = rad_fs_close_commit(f, temp, opt->stats_path);
    return st != RAD_OK ? st : written;
}

/* The refinement's storage - the link pairs, the elements, the clusters:
 * a third of the peak at 10^6 faces - once the last pass has exported its
 * links: the write (or --radiosity's solve) reads only the export. The
 * counters and the settings stay, for the stats. */
static void release_refinement(hier_run *h)
{
    const ff_links kept = h->links;
    ff_links_free(&h->links); /* zeroes it */
    h->links.config = kept.config;
    h->links.tally = kept.tally;
    h->links.passes = kept.passes;
}

/* The backends' states (and a GPU's buffers); the links stay. */
static void release_backends(hier_run *h)
{
    if (h->backend_state) h->backend->destroy(h->backend_state);
    h->backend_state = NULL;
}

rad_status ff_hierarchical_run(ff_comm *comm, const ff_options *opt)
{
    const int rank = ff_comm_rank(comm), ranks = ff_comm_size(comm);
    hier_run h;
    memset(&h, 0, sizeof h);
    h.opt = opt;
    h.threads = rad_cpu_threads_per_rank(opt->threads, ff_comm_node_size(comm));
    h.ranks = ranks;
    double t0 = rad_clock_seconds();
    /* Every rank loads the scene and makes the backend's setup: each
     * computes its share of the rounds' pairs on its own backend. Rank 0
     * refines, solves and writes. CUDA starts while the scene loads under
     * --backend cuda, once its size is known under auto. */
    if (opt->backend == FF_BACKEND_CUDA) ff_cuda_prestart(rank);
    rad_status st = ff_load_scene(opt, &h.scene);
    rad_mesh_options mo = {.subdiv = 0, .contacts = opt->contacts};
    if (st == RAD_OK) st = rad_mesh_build(&h.scene, &mo, &h.base);
    if (st == RAD_OK) h.cpu_first = cpu_first_under_auto(&h, &h.most_leaves);
    if (st == RAD_OK && opt->backend == FF_BACKEND_AUTO && !h.cpu_first) ff_cuda_prestart(rank);
    if (st == RAD_OK && h.base.patch_count == 0) {
        if (rank == 0) rad_error("%s: the scene has no faces", h.scene.path);
        st = RAD_ERR_INVALID;
    }
    h.seconds_load = rad_clock_seconds() - t0;
    h.peak_load = rad_mem_peak_bytes();
    ff_setup su;
    double centre[3];
    const double t_setup = rad_clock_seconds();
    if ((st = ff_comm_agree(comm, st)) == RAD_OK) st = prepare_setup(&h, &su, centre);
    if ((st = ff_comm_agree(comm, st)) == RAD_OK) st = open_backend(&h, comm, &su);
    h.seconds_setup = rad_clock_seconds() - t_setup;
    if ((st = ff_comm_agree(comm, st)) == RAD_OK && rank > 0) {
        st = ff_rank_rounds_serve(comm, h.backend, h.backend_state);
        release_backends(&h);
        int rank0 = RAD_OK; /* rank 0's end, asleep until it comes (a spinning wait takes a core from its threads) */
        ff_comm_broadcast_idle(comm, &rank0, sizeof rank0);
    } else if (st == RAD_OK) {
        /* On GPUs, the other ranks sleep while this one's threads work
         * (decisions, exports, solves): they take all of this node's
         * cores. CPU backends compute the rounds side by side and share
         * them. */
        if (ranks > 1 && h.backend == &ff_backend_cuda) h.threads = rad_cpu_threads_per_rank(opt->threads, 1);
        st = build_links(&h, comm, &su, centre);
        release_backends(&h); /* the GPU's memory, before --radiosity's solve needs it */
        release_refinement(&h);
        if (st == RAD_OK) st = write_links(&h);
        h.seconds_total = rad_clock_seconds() - t0;
        h.peak_total = rad_mem_peak_bytes();
        if (st == RAD_OK && !opt->radiosity_path) rad_info("wrote %s", opt->output);
        if (st == RAD_OK) st = write_stats(&h);
        int end = (int)st;
        if (ranks > 1) ff_comm_broadcast_idle(comm, &end, sizeof end);
    }
    st = ff_comm_agree(comm, st);
    release_backends(&h);
    ff_links_free(&h.links);
    rad_links_free(&h.exported);
    rad_mesh_free(&h.leaves);
    rad_mesh_free(&h.base);
    free(h.B);
    free(h.triangles);
    free(h.triangle_face);
    rad_scene_free(&h.scene);
    return st;
}
