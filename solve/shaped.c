/* shaped.c - links solved with their shape (shaped.h): the CPU's
 * sweeps, the driver of the device backends (shaped_gpu.h), the balance.
 * The plan is shaped_plan.c's, the per-item math shaped_math.h's.
 *
 * A sweep on the CPU, every channel at once: the nodes' B (leaves', then
 * area-weighted means up the trees); per receiver, in parallel, S of
 * every link (a shaped source summed over its leaves with the weights
 * stored at the pair's other link), the unshaped links gathered into the
 * node's H, the shaped links' S kept; H pushed down the trees; per leaf,
 * in parallel, H plus its and its ancestors' shaped links, F u_x S; B =
 * E + rho H. Each sum is made by one thread in a fixed order, so the
 * bytes do not depend on threads.
 *
 * Clusters (rad_links.h) take part flat, as in rad_lsolve: a cluster
 * gathers its links into its H, which is pushed down the cluster tree and
 * into each root's H. A Gauss-Seidel sweep gathers the clusters first
 * (from the B it starts from) and pulls them last.
 */
#include "shaped.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#ifdef _OPENMP
#include <omp.h>
#endif

#include "gpu.h"
#include "rad_clock.h"
#include "rad_log.h"
#include "shaped_gpu.h"
#include "shaped_math.h"
#include "shaped_plan.h"

#define SHAPED_PROGRESS_SECONDS 2.0
/* A Gauss-Seidel group's gather, pushes and pulls go parallel from this
 * much work (links and point factors, shaped_plan.tree_work), its update
 * from this many leaves (waking the threads costs ~40 us, docs/solve.md
 * "Threads"). */
#define SHAPED_PARALLEL_MIN_LINKS 16384u
#define SHAPED_PARALLEL_MIN_LEAVES 4096u

/* ---- the CPU's sweeps ---- */

typedef struct shaped_vectors {
    double *B;    /* ids * 3: leaves' B, split nodes' and clusters' means */
    double *Q;    /* leaf_count * 3: the leaves' B in leaf-list order (what shaped sums stream) */
    double *H;    /* ids * 3: unshaped links gathered, pushed down (clusters' into their roots); at leaves, all of H */
    double *S;    /* shaped links * 3: what each shaped link's source sends */
    double *next; /* leaf_count * 3, leaf-list order: E + rho H */
} shaped_vectors;

/* Receiver i's links gathered from v->B and v->Q (shaped sources summed here). */
static inline void gather_node(const shaped_plan *p, shaped_vectors *v, uint32_t i)
{
    shaped_gather(&p->view, i, v->B, v->Q, NULL, v->H, v->S);
}

/* The clusters' H pushed down the cluster tree (parents first): each
 * cluster's H becomes the sum over it and the clusters above it. */
static void push_clusters(const shaped_plan *p, double *H)
{
    for (uint32_t c = 1; c < p->L->cluster_count; c++) shaped_push(&p->view, p->L->node_count + c, H);
}

/* One Jacobi sweep from v->B: v->H and v->next at the leaves; the largest
 * |next - B| per channel in r[3] (the residual of v->B; infinite where one
 * is not a number). */
static void sweep(const shaped_plan *p, shaped_vectors *v, double r[3])
{
    const rad_links *L = p->L;
    const uint32_t n = L->node_count, leaf_count = L->leaf_count, ids = (uint32_t)rad_links_id_count(L);
#pragma omp parallel for schedule(dynamic, 64) num_threads(p->threads)
    for (uint32_t i = 0; i < ids; i++) gather_node(p, v, i);
    push_clusters(p, v->H);
    for (uint32_t i = 0; i < n; i++) shaped_push(&p->view, i, v->H); /* parents first: pushed down */
    double r0 = 0, r1 = 0, r2 = 0;
#pragma omp parallel for schedule(dynamic, 256) num_threads(p->threads) reduction(max : r0, r1, r2)
    for (uint32_t q = 0; q < leaf_count; q++) {
        double d[3];
        shaped_update_leaf(&p->view, q, v->H, v->S, v->Q, &v->next[3 * (size_t)q], d);
        r0 = fmax(r0, d[0]);
        r1 = fmax(r1, d[1]);
        r2 = fmax(r2, d[2]);
    }
    r[0] = r0, r[1] = r1, r[2] = r2;
}

/* Tree t's split nodes' B pulled up from its leaves' (v->Q). */
static void pull_tree(const shaped_plan *p, shaped_vectors *v, uint32_t t)
{
    for (uint32_t k = p->tree_first[t + 1]; k-- > p->tree_first[t];) {
        const uint32_t i = p->tree_nodes[k];
        if (shaped_plan_is_leaf(p, i))
            memcpy(&v->B[3 * (size_t)i], &v->Q[3 * (size_t)p->first[i]], 3 * sizeof *v->B);
        else
            shaped_pull(&p->view, i, v->B);
    }
}

/* Gauss-Seidel's groups of consecutive trees (rad_links_tree_groups) by
 * their work (shaped_plan.tree_work: links and point factors a sweep
 * reads), closing at the options' group_work. */
typedef struct shaped_groups {
    uint32_t *first; /* count + 1: group g is trees first[g] .. first[g + 1] */
    uint64_t *work;  /* count */
    uint32_t count;
} shaped_groups;

static rad_status groups_make(const shaped_plan *p, uint64_t group_work, shaped_groups *g)
{
    const uint32_t roots = p->L->root_count;
    g->first = malloc(((size_t)roots + 1) * sizeof *g->first);
    g->work = malloc((roots ? roots : 1) * sizeof *g->work);
    g->count = 0;
    if (!g->first || !g->work) {
        rad_error("links: out of memory for the shaped solve's groups of %u trees", roots);
        return RAD_ERR_NOMEM;
    }
    g->count = rad_links_tree_groups(p->tree_work, roots, group_work, g->first, g->work);
    return RAD_OK;
}

static void groups_free(shaped_groups *g)
{
    free(g->first);
    free(g->work);
    memset(g, 0, sizeof *g);
}

/* Trees t0 .. t1's H pushed down, parents first (one thread a tree). */
static void push_trees(const shaped_plan *p, shaped_vectors *v, uint32_t t0, uint32_t t1, int wide)
{
#pragma omp parallel for schedule(dynamic, 1) num_threads(p->threads) if (wide && t1 - t0 > 1)
    for (uint32_t t = t0; t < t1; t++)
        for (uint32_t k = p->tree_first[t]; k < p->tree_first[t + 1]; k++) shaped_push(&p->view, p->tree_nodes[k], v->H);
}

/* One Gauss-Seidel sweep: the clusters gathered and pushed down their
 * tree from the B it starts from, then group by group of trees in root
 * order: a group's nodes gather from the newest B (the groups before it
 * already updated, its own trees at the sweep's start; a cluster source
 * at its start value), its leaves update in place and its trees pull
 * their nodes; the clusters pulled last. The roots are nodes 0 ..
 * root_count - 1, so a group's leaves are one range of the leaf list.
 * r[3]: the largest change per channel (infinite where one is not a
 * number). */
static void gauss_seidel_sweep(const shaped_plan *p, const shaped_groups *g, shaped_vectors *v, double r[3])
{
    const rad_links *L = p->L;
    const uint32_t n = L->node_count, clusters = L->cluster_count;
    double r0 = 0, r1 = 0, r2 = 0;
#pragma omp parallel for schedule(dynamic, 16) num_threads(p->threads) \
    if (p->cluster_links >= SHAPED_PARALLEL_MIN_LINKS)
    for (uint32_t c = 0; c < clusters; c++) gather_node(p, v, n + c);
    push_clusters(p, v->H);
    for (uint32_t grp = 0; grp < g->count; grp++) {
        const uint32_t t0 = g->first[grp], t1 = g->first[grp + 1];
        const uint32_t k0 = p->tree_first[t0], k1 = p->tree_first[t1];
        const int wide = g->work[grp] >= SHAPED_PARALLEL_MIN_LINKS;
#pragma omp parallel for schedule(dynamic, 16) num_threads(p->threads) if (wide)
        for (uint32_t k = k0; k < k1; k++) gather_node(p, v, p->tree_nodes[k]);
        push_trees(p, v, t0, t1, wide);
        const uint32_t q0 = p->first[t0], q1 = p->first[t1 - 1] + p->count[t1 - 1];
#pragma omp parallel for schedule(dynamic, 256) num_threads(p->threads) reduction(max : r0, r1, r2) \
    if (q1 - q0 >= SHAPED_PARALLEL_MIN_LEAVES)
        for (uint32_t q = q0; q < q1; q++) {
            double d[3];
            /* in place: this group's S and H are made */
            shaped_update_leaf(&p->view, q, v->H, v->S, v->Q, &v->Q[3 * (size_t)q], d);
            r0 = fmax(r0, d[0]);
            r1 = fmax(r1, d[1]);
            r2 = fmax(r2, d[2]);
        }
#pragma omp parallel for schedule(dynamic, 1) num_threads(p->threads) if (wide && t1 - t0 > 1)
        for (uint32_t t = t0; t < t1; t++) pull_tree(p, v, t);
    }
    shaped_plan_pull_clusters(p, v->B);
    r[0] = r0, r[1] = r1, r[2] = r2;
}

/* The largest change over the channels, each over its ||E||_inf. */
static double scaled_change(const double r[3], const double e_norm[3])
{
    double worst = 0;
    for (int c = 0; c < 3; c++) worst = fmax(worst, e_norm[c] > 0 ? r[c] / e_norm[c] : 0);
    return worst;
}

/* A progress line every SHAPED_PROGRESS_SECONDS. */
static void progress(uint32_t it, double worst, double tolerance, double start, double *last)
{
    const double now = rad_clock_seconds();
    if (now - *last < SHAPED_PROGRESS_SECONDS) return;
    rad_info("links: shaped solve: iteration %u, change %.3g (target %.3g), %.0f s", it, worst, tolerance, now - start);
    *last = now;
}

/* ---- closure (rad_closure.h) ---- */

/* What K x needs: the CPU's sweep on v, or a device backend's. */
typedef struct shaped_apply_ctx {
    const shaped_plan *p;
    shaped_vectors *v;              /* the CPU sweeps v (its B, Q, H, S, next) */
    const solve_shaped_jacobi *b;   /* a device backend, or NULL: the CPU */
    void *state;
    shaped_vectors scratch;         /* a device's B, Q, H on the host */
} shaped_apply_ctx;

/* v->Q = x in every channel (leaf-list order), v->B its leaves' and the
 * nodes' and clusters' means. */
static void set_leaves(const shaped_plan *p, shaped_vectors *v, const double *x)
{
    const uint32_t leaf_count = p->L->leaf_count, roots = p->L->root_count;
    for (uint32_t q = 0; q < leaf_count; q++)
        for (int c = 0; c < 3; c++) v->Q[3 * (size_t)q + c] = x[3 * (size_t)q + c];
#pragma omp parallel for schedule(dynamic, 64) num_threads(p->threads) if (leaf_count >= SHAPED_PARALLEL_MIN_LEAVES)
    for (uint32_t t = 0; t < roots; t++) pull_tree(p, v, t);
    shaped_plan_pull_clusters(p, v->B);
}

/* y = K x (leaf-list order): x in every channel, one Jacobi sweep; K x is
 * the leaves' H, whatever rho and E are. */
static rad_status shaped_apply(void *ctx, const double *x, double *y)
{
    shaped_apply_ctx *a = ctx;
    const shaped_plan *p = a->p;
    const uint32_t leaf_count = p->L->leaf_count;
    double *x3 = a->v->next; /* leaf_count * 3, free between sweeps */
    for (uint32_t q = 0; q < leaf_count; q++) x3[3 * (size_t)q] = x3[3 * (size_t)q + 1] = x3[3 * (size_t)q + 2] = x[q];
    const double *H;
    double r[3];
    if (!a->b) {
        set_leaves(p, a->v, x3);
        sweep(p, a->v, r);
        H = a->v->H;
    } else {
        set_leaves(p, &a->scratch, x3);
        rad_status s = a->b->load(a->state, a->scratch.B, a->scratch.Q);
        if (s == RAD_OK) s = a->b->sweep(a->state, r);
        if (s == RAD_OK) s = a->b->store(a->state, a->scratch.B, a->scratch.H);
        if (s != RAD_OK) return s; /* logged by the backend */
        H = a->scratch.H;
    }
    for (uint32_t q = 0; q < leaf_count; q++) y[q] = H[3 * (size_t)p->leaf_nodes[q]];
    return RAD_OK;
}

/* The closure's scales s of the shaped operator (device backend b, or the
 * CPU where NULL), then the leaves' rho s^2 and E s in the plan (and on
 * the device), and the start C = s B_flat in v->B and v->Q. */
static rad_status shaped_closure(shaped_plan *p, shaped_vectors *v, const solve_shaped_jacobi *b, void *state,
                                 const double *B_flat, solve_shaped_result *res)
{
    const rad_links *L = p->L;
    const uint32_t m = L->leaf_count, n = L->node_count;
    const size_t ids = rad_links_id_count(L);
    shaped_apply_ctx a = {.p = p, .v = v, .b = b, .state = state};
    double *s = malloc((m ? m : 1) * sizeof *s), *row = malloc((m ? m : 1) * sizeof *row);
    double *scratch = b ? malloc((6 * ids + 3 * (size_t)m) * sizeof *scratch) : NULL;
    p->scale = malloc((size_t)n * sizeof *p->scale);
    p->closed_row = malloc((size_t)n * sizeof *p->closed_row);
    if (!s || !row || (b && !scratch) || !p->scale || !p->closed_row) {
        free(s), free(row), free(scratch);
        rad_error("links: out of memory for the closure's scales of %u leaves", m);
        return RAD_ERR_NOMEM;
    }
    if (b) a.scratch.B = scratch, a.scratch.H = scratch + 3 * ids, a.scratch.Q = scratch + 6 * ids;
    rad_status status = rad_closure_scales(m, shaped_apply, &a, 0, 0, s, row, &res->closure);
    if (status == RAD_ERR_NOT_CONVERGED) status = RAD_OK; /* the last scales, said so */
    if (status == RAD_OK) {
        for (uint32_t i = 0; i < n; i++) p->scale[i] = 1, p->closed_row[i] = 0;
        for (uint32_t q = 0; q < m; q++) {
            const uint32_t i = p->leaf_nodes[q];
            p->scale[i] = s[q], p->closed_row[i] = row[q];
            for (int c = 0; c < 3; c++) {
                p->rho[3 * (size_t)i + c] *= s[q] * s[q];
                p->E[3 * (size_t)i + c] *= s[q];
            }
        }
        double *x3 = v->next;
        for (uint32_t q = 0; q < m; q++)
            for (int c = 0; c < 3; c++)
                x3[3 * (size_t)q + c] = s[q] * B_flat[3 * (size_t)L->nodes[p->leaf_nodes[q]].leaf + c];
        set_leaves(p, v, x3);
        if (b) status = b->materials(state, p->rho, p->E);
    }
    free(s), free(row), free(scratch);
    return status;
}

/* The CPU: the point factors and the trees' work on the host, then Gauss-Seidel
 * sweeps until their change meets the tolerance, then a Jacobi sweep
 * measures the residual of the iterate to return (as the flat solve
 * returns a measured iterate); short of it, on. */
static rad_status solve_on_cpu(shaped_plan *p, shaped_vectors *v, const solve_shaped_options *o,
                               const double e_norm[3], const double *B_flat, double start, solve_shaped_result *res)
{
    const double t0 = rad_clock_seconds();
    rad_status status = shaped_plan_factors(p);
    if (status != RAD_OK) return status;
    shaped_plan_work(p);
    shaped_plan_row_sums(p);
    shaped_groups groups;
    if ((status = groups_make(p, o->group_work ? o->group_work : SOLVE_SHAPED_GROUP_WORK, &groups)) != RAD_OK) {
        groups_free(&groups);
        return status;
    }
    v->S = calloc(3 * (p->end_count ? p->end_count : 1), sizeof *v->S);
    if (!v->S) {
        rad_error("links: out of memory for the shaped solve's %llu shaped ends", (unsigned long long)p->end_count);
        groups_free(&groups);
        return RAD_ERR_NOMEM;
    }
    const double t1 = rad_clock_seconds();
    res->factor_seconds = t1 - t0;
    if (o->closure && (status = shaped_closure(p, v, NULL, NULL, B_flat, res)) != RAD_OK) {
        groups_free(&groups);
        return status;
    }
    double last_progress = start;
    for (uint32_t it = 0;; it++) {
        double r[3];
        gauss_seidel_sweep(p, &groups, v, r);
        double worst = scaled_change(r, e_norm);
        const int last = it + 1 >= o->max_iterations;
        if (isfinite(worst) && (worst <= o->tolerance || last)) {
            sweep(p, v, r); /* v->H: the gather of v->B, kept for the balance */
            worst = scaled_change(r, e_norm);
            if (isfinite(worst) && (worst <= o->tolerance || last)) {
                res->iterations = it + 2;
                res->residual = worst;
                res->converged = worst <= o->tolerance;
                break;
            }
        }
        if (!isfinite(worst)) {
            rad_error("links: shaped solve: residual is not finite at iteration %u", it);
            status = RAD_ERR_INVALID;
            break;
        }
        progress(it, worst, o->tolerance, start, &last_progress);
    }
    groups_free(&groups);
    res->sweep_seconds = rad_clock_seconds() - t1;
    res->backend = SOLVE_SHAPED_CPU;
    snprintf(res->device, sizeof res->device, "cpu");
    return status;
}

/* ---- the device backends' driver (shaped_gpu.h) ---- */

/* A device backend (shaped_gpu.h): the point factors there, the ends that
 * sum to 0 dropped (listed here), then Jacobi sweeps until the
 * change, the residual of the iterate swept from, meets the tolerance;
 * that iterate is returned with the H its last sweep gathered. */
static rad_status solve_on_device(shaped_plan *p, shaped_vectors *v, const solve_shaped_jacobi *b,
                                  const solve_shaped_options *o, const double e_norm[3], const double *B_flat,
                                  double start, solve_shaped_result *res)
{
    const double t0 = rad_clock_seconds();
    const rad_links *L = p->L;
    shaped_device_arrays arrays = {0};
    solve_shaped_device_plan plan;
    void *state = NULL;
    double *row_q = NULL;
    uint64_t *dropped = NULL;
    rad_status status = shaped_plan_device(p, &arrays, &plan);
    if (status == RAD_OK) status = b->create(&plan, o->device, &state);
    if (status == RAD_OK) status = b->factors(state, p->inv_mean);
    if (status == RAD_OK) {
        p->dropped = 0;
        for (uint64_t e = 0; e < p->end_count; e++) p->dropped += p->inv_mean[e] == 0;
        row_q = malloc((L->leaf_count ? L->leaf_count : 1) * sizeof *row_q);
        dropped = malloc((p->dropped ? p->dropped : 1) * sizeof *dropped);
        if (!row_q || !dropped) {
            rad_error("links: out of memory for %u row sums", L->leaf_count);
            status = RAD_ERR_NOMEM;
        }
    }
    if (status == RAD_OK) {
        uint64_t d = 0;
        for (uint64_t e = 0; e < p->end_count; e++)
            if (p->inv_mean[e] == 0) dropped[d++] = e;
        status = b->drop(state, dropped, d, row_q);
    }
    if (status == RAD_OK)
        for (uint32_t q = 0; q < L->leaf_count; q++) p->row_sum[p->leaf_nodes[q]] = row_q[q];
    const double t1 = rad_clock_seconds();
    res->factor_seconds = t1 - t0;
    if (status == RAD_OK && o->closure) status = shaped_closure(p, v, b, state, B_flat, res);
    if (status == RAD_OK) status = b->load(state, v->B, v->Q);
    double last_progress = start;
    for (uint32_t it = 0; status == RAD_OK; it++) {
        double r[3];
        status = b->sweep(state, r);
        if (status != RAD_OK) break;
        const double worst = scaled_change(r, e_norm);
        if (isfinite(worst) && (worst <= o->tolerance || it + 1 >= o->max_iterations)) {
            res->iterations = it + 1;
            res->residual = worst;
            res->converged = worst <= o->tolerance;
            break;
        }
        if (!isfinite(worst)) {
            rad_error("links: shaped solve: residual is not finite at iteration %u", it);
            status = RAD_ERR_INVALID;
            break;
        }
        status = b->accept(state);
        progress(it, worst, o->tolerance, start, &last_progress);
    }
    if (status == RAD_OK) status = b->store(state, v->B, v->H);
    if (status == RAD_OK) snprintf(res->device, sizeof res->device, "%s", b->device_name(state));
    res->sweep_seconds = rad_clock_seconds() - t1;
    b->destroy(state);
    free(row_q);
    free(dropped);
    shaped_device_arrays_free(&arrays);
    return status;
}

/* ---- the solve ---- */

const char *solve_shaped_backend_name(solve_shaped_backend backend)
{
    static const char *const names[] = {"cpu", "auto", "cuda", "host"};
    return (unsigned)backend < sizeof names / sizeof names[0] ? names[backend] : "unknown";
}

/* The backend for `weights` point factors (shaped.h: auto's rule). */
static solve_shaped_backend choose_backend(solve_shaped_backend asked, uint64_t weights)
{
    if (asked != SOLVE_SHAPED_AUTO) return asked;
    return weights >= SOLVE_SHAPED_GPU_MIN_WEIGHTS && solve_gpu_built() && solve_gpu_device_count() > 0
               ? SOLVE_SHAPED_CUDA
               : SOLVE_SHAPED_CPU;
}

/* Emitted, absorbed and escaped over the leaves (as rad_lsolve's), and
 * how far B moved from the flat solution; B (by leaf patch) set from the
 * solution v->B. */
static void balance(const shaped_plan *p, const shaped_vectors *v, const solve_shaped_options *o, double *B,
                    solve_shaped_result *res)
{
    const rad_links *links = p->L;
    double most = 0, moved = 0, sums[3] = {0, 0, 0};
    for (uint32_t i = 0; i < links->node_count; i++) {
        const rad_link_node *e = &links->nodes[i];
        if (e->first_child != RAD_NO_ELEMENT) continue;
        /* closure: the solve ran on C = S B with rho s^2 and E s; back to B, H = s K C, rho, E */
        const double s = p->scale ? p->scale[i] : 1, row = p->scale ? p->closed_row[i] : p->row_sum[i];
        for (int c = 0; c < 3; c++) {
            const size_t at = 3 * (size_t)i + c;
            v->B[at] /= s;
            const double b = v->B[at], before = B[3 * (size_t)e->leaf + c];
            most = fmax(most, fabs(before));
            moved = fmax(moved, fabs(b - before));
            if (o->channels == 1 && c > 0) continue;
            sums[0] += e->area * p->E[at] / s;
            sums[1] += e->area * (1 - p->rho[at] / (s * s)) * s * v->H[at];
            sums[2] += e->area * b * (1 - row);
        }
    }
    for (uint32_t i = 0; i < links->node_count; i++)
        if (links->nodes[i].first_child == RAD_NO_ELEMENT)
            memcpy(&B[3 * (size_t)links->nodes[i].leaf], &v->B[3 * (size_t)i], 3 * sizeof *B);
    res->change = most > 0 ? moved / most : 0;
    res->emitted = sums[0];
    res->absorbed = sums[1];
    res->escaped = sums[2];
    res->imbalance = sums[0] > 0 ? (sums[1] + sums[2] - sums[0]) / sums[0] : 0;
}

rad_status solve_shaped(const rad_links *links, const rad_mesh *leaves, const solve_shaped_options *options, double *B,
                        solve_shaped_result *out)
{
    const double start = rad_clock_seconds();
    if (links->leaf_count != leaves->patch_count || links->node_count == 0 || !(options->tolerance > 0) ||
        options->max_iterations == 0 || (unsigned)options->backend > SOLVE_SHAPED_HOST) {
        rad_error("links: %u leaves against %zu patches, or shaped solve options out of range", links->leaf_count,
                  leaves->patch_count);
        return RAD_ERR_INVALID;
    }
    int threads = options->threads;
#ifdef _OPENMP
    if (threads <= 0) threads = omp_get_max_threads();
#else
    threads = 1;
#endif
    const uint32_t n = links->node_count;
    const size_t ids = rad_links_id_count(links); /* B and H run over the nodes, then the clusters */
    shaped_vectors v = {0};
    const size_t m = links->leaf_count;
    double *block = malloc((6 * ids + 6 * m) * sizeof *block);
    if (!block) {
        rad_error("links: out of memory for the shaped solve's vectors over %zu nodes and clusters", ids);
        return RAD_ERR_NOMEM;
    }
    v.B = block, v.H = block + 3 * ids, v.Q = block + 6 * ids, v.next = v.Q + 3 * m;
    shaped_plan p;
    rad_status status = shaped_plan_make(links, leaves, B, options->gate, options->flat, threads, &p, v.B);
    if (status != RAD_OK) {
        free(block);
        return status;
    }
    for (size_t q = 0; q < m; q++) memcpy(&v.Q[3 * q], &v.B[3 * (size_t)p.leaf_nodes[q]], 3 * sizeof *v.Q);
    double e_norm[3] = {0, 0, 0};
    for (uint32_t i = 0; i < n; i++)
        for (int c = 0; c < 3; c++) e_norm[c] = fmax(e_norm[c], p.E[3 * (size_t)i + c]);
    solve_shaped_result res = {.weights = p.weight_count};
    const solve_shaped_backend backend = choose_backend(options->backend, p.weight_count);
    if (backend == SOLVE_SHAPED_CUDA || backend == SOLVE_SHAPED_HOST) {
        const solve_shaped_jacobi *b =
            backend == SOLVE_SHAPED_CUDA ? &solve_shaped_jacobi_cuda : &solve_shaped_jacobi_host;
        status = solve_on_device(&p, &v, b, options, e_norm, B, start, &res);
        res.backend = backend;
    } else {
        status = solve_on_cpu(&p, &v, options, e_norm, B, start, &res);
    }
    res.shaped_ends = p.end_count - p.dropped;
    if (status == RAD_OK) {
        balance(&p, &v, options, B, &res);
        res.seconds = rad_clock_seconds() - start;
        *out = res;
        if (!res.converged) status = RAD_ERR_NOT_CONVERGED;
    }
    free(v.S);
    free(block);
    shaped_plan_free(&p);
    if (options->backend == SOLVE_SHAPED_AUTO && backend == SOLVE_SHAPED_CUDA &&
        (status == RAD_ERR_BACKEND || status == RAD_ERR_NOMEM)) {
        /* B is untouched: solve again from the flat solution */
        rad_warn("links: the shaped solve could not run on the GPU (above): --backend auto solves it on the CPU");
        solve_shaped_options cpu = *options;
        cpu.backend = SOLVE_SHAPED_CPU;
        return solve_shaped(links, leaves, &cpu, B, out);
    }
    return status;
}
