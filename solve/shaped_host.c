/* shaped_host.c - the cuda backend's steps of the shaped solve on the host
 * (shaped_gpu.h, solve_shaped_jacobi_host): each of shaped_cuda.cu's
 * kernels as a loop over its items, calling the same shaped_math.h
 * function on the same arrays in the same order, so that a test without
 * a GPU runs the GPU's algorithm (the ends' factors per leaf, the sums T
 * beforehand, the gather in a warp's order, the push and pull by depth,
 * the row sums per leaf). The items of a loop are independent, so they
 * run on OpenMP threads; the bytes do not depend on the thread count. It reads the plan's arrays in
 * place: the plan outlives the state, and drop changes its end and
 * pair_end (the plan's own, which the host lends it writable) as the
 * GPU's copy is changed.
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "rad_log.h"
#include "rad_mem.h"
#include "shaped_gpu.h"

typedef struct host_state {
    solve_shaped_device_plan plan; /* its view: the plan's arrays, then f and inv_mean */
    float *f;
    double *inv_mean;
    double *B, *Q, *next, *H, *S, *T;
} host_state;

static void host_destroy(void *state)
{
    host_state *h = state;
    if (!h) return;
    free(h->f);
    free(h->inv_mean);
    free(h->B);
    free(h->Q);
    free(h->next);
    free(h->H);
    free(h->S);
    free(h->T);
    free(h);
}

static rad_status host_create(const solve_shaped_device_plan *plan, int device, void **out_state)
{
    (void)device;
    const shaped_view *v = &plan->view;
    host_state *h = calloc(1, sizeof *h);
    if (h) {
        h->plan = *plan;
        h->f = rad_mem_alloc(plan->weight_count * sizeof *h->f);
        h->inv_mean = calloc(v->end_count ? v->end_count : 1, sizeof *h->inv_mean);
        h->B = malloc(3 * v->id_count * sizeof *h->B);
        h->H = malloc(3 * v->id_count * sizeof *h->H);
        h->Q = malloc(3 * (v->leaf_count ? v->leaf_count : 1) * sizeof *h->Q);
        h->next = malloc(3 * (v->leaf_count ? v->leaf_count : 1) * sizeof *h->next);
        h->T = malloc(3 * (v->end_count ? v->end_count : 1) * sizeof *h->T);
        h->S = calloc(3 * (v->end_count ? v->end_count : 1), sizeof *h->S);
    }
    if (!h || !h->f || !h->inv_mean || !h->B || !h->H || !h->Q || !h->next || !h->T || !h->S) {
        rad_error("links: out of memory for the shaped solve's host sweeps");
        host_destroy(h);
        return RAD_ERR_NOMEM;
    }
    h->plan.view.f = h->f;
    h->plan.view.inv_mean = h->inv_mean;
    *out_state = h;
    return RAD_OK;
}

/* The kernels' items: an end's factors per leaf, then its mean. */
static rad_status host_factors(void *state, double *inv_mean)
{
    host_state *h = state;
    const shaped_view *v = &h->plan.view;
    const int64_t ends = (int64_t)v->end_count;
#pragma omp parallel for schedule(dynamic, 16)
    for (int64_t e = 0; e < ends; e++) {
        const uint32_t r = v->end_receiver[e];
        rad_ff_patch P;
        shaped_node_polygon(v, v->links[v->end_link[e]].source, &P);
        for (uint32_t q = 0; q < v->count[r]; q++) h->f[v->end_at[e] + q] = shaped_point_factor(v, v->first[r] + q, &P);
    }
#pragma omp parallel for schedule(dynamic, 256)
    for (int64_t e = 0; e < ends; e++) h->inv_mean[e] = shaped_end_inv_mean(v, (uint64_t)e, v->end_receiver[e]);
    memcpy(inv_mean, h->inv_mean, (size_t)ends * sizeof *inv_mean);
    return RAD_OK;
}

static rad_status host_drop(void *state, const uint64_t *dropped, uint64_t count, double *row_sum)
{
    host_state *h = state;
    const shaped_view *v = &h->plan.view;
    const int64_t n = (int64_t)count;
#pragma omp parallel for schedule(static)
    for (int64_t d = 0; d < n; d++) shaped_drop_end(v, dropped[d], (uint32_t *)v->end, (uint32_t *)v->pair_end);
    const int64_t leaves = v->leaf_count;
#pragma omp parallel for schedule(dynamic, 256)
    for (int64_t q = 0; q < leaves; q++) row_sum[q] = shaped_leaf_row_sum(v, v->leaf_nodes[q]);
    return RAD_OK;
}

static rad_status host_materials(void *state, const double *rho, const double *E)
{
    host_state *h = state; /* read in place, as create's plan */
    h->plan.view.rho = rho;
    h->plan.view.E = E;
    return RAD_OK;
}

static rad_status host_load(void *state, const double *B, const double *Q)
{
    host_state *h = state;
    const shaped_view *v = &h->plan.view;
    memcpy(h->B, B, 3 * v->id_count * sizeof *h->B);
    memcpy(h->Q, Q, 3 * (size_t)v->leaf_count * sizeof *h->Q);
    return RAD_OK;
}

/* (a) T, (b) gather, (c) push by depth, (d) the leaves and the change. */
static rad_status host_sweep(void *state, double change[3])
{
    host_state *h = state;
    const solve_shaped_device_plan *p = &h->plan;
    const shaped_view *v = &p->view;
    const int64_t ends = (int64_t)v->end_count, ids = (int64_t)v->id_count, leaves = v->leaf_count;
#pragma omp parallel for schedule(dynamic, 64)
    for (int64_t e = 0; e < ends; e++) shaped_end_sum(v, (uint64_t)e, v->end_receiver[e], h->Q, &h->T[3 * e]);
#pragma omp parallel for schedule(dynamic, 64)
    for (int64_t i = 0; i < ids; i++) shaped_gather_lanes(v, (uint32_t)i, h->B, h->Q, h->T, h->H, h->S);
    for (uint32_t d = 1; d < p->depth_count; d++) { /* depth 0 has nothing above it */
        const int64_t begin = p->depth_first[d], end = p->depth_first[d + 1];
#pragma omp parallel for schedule(static)
        for (int64_t t = begin; t < end; t++) shaped_push(v, p->depth_order[t], h->H);
    }
    double r0 = 0, r1 = 0, r2 = 0;
#pragma omp parallel for schedule(dynamic, 256) reduction(max : r0, r1, r2)
    for (int64_t q = 0; q < leaves; q++) {
        double d[3];
        shaped_update_leaf(v, (uint32_t)q, h->H, h->S, h->Q, &h->next[3 * q], d);
        r0 = fmax(r0, d[0]);
        r1 = fmax(r1, d[1]);
        r2 = fmax(r2, d[2]);
    }
    change[0] = r0, change[1] = r1, change[2] = r2;
    return RAD_OK;
}

/* Q = next; the leaves' B; B pulled up, deepest first. */
static rad_status host_accept(void *state)
{
    host_state *h = state;
    const solve_shaped_device_plan *p = &h->plan;
    const shaped_view *v = &p->view;
    double *swap = h->Q;
    h->Q = h->next;
    h->next = swap;
    for (uint32_t q = 0; q < v->leaf_count; q++)
        memcpy(&h->B[3 * (size_t)v->leaf_nodes[q]], &h->Q[3 * (size_t)q], 3 * sizeof *h->B);
    for (uint32_t d = p->depth_count; d-- > 0;) {
        const int64_t begin = p->depth_first[d], end = p->depth_first[d + 1];
#pragma omp parallel for schedule(static)
        for (int64_t t = begin; t < end; t++) shaped_pull(v, p->depth_order[t], h->B);
    }
    return RAD_OK;
}

static rad_status host_store(void *state, double *B, double *H)
{
    host_state *h = state;
    const shaped_view *v = &h->plan.view;
    memcpy(B, h->B, 3 * v->id_count * sizeof *B);
    memcpy(H, h->H, 3 * v->id_count * sizeof *H);
    return RAD_OK;
}

static const char *host_device_name(void *state)
{
    (void)state;
    return "host";
}

const solve_shaped_jacobi solve_shaped_jacobi_host = {"host",     host_create, host_factors,     host_drop,
                                                      host_materials, host_load,  host_sweep,  host_accept,      host_store,
                                                      host_device_name, host_destroy};
