/* test_lsolve.c - the solve on links (core/rad_lsolve.h): against a dense
 * direct solve of the same system, leaf links and links at mixed levels;
 * push and pull against a hand-solved case; the furnace with the cube's
 * exact form factors; the energy balance; Jacobi against Gauss-Seidel;
 * the same bytes on 1 and 2 threads; the edges (grey, no light, limits,
 * warm start, a mesh that does not match).
 *
 * The scenes are the closed unit cube, its 6 faces the roots of element
 * trees made by rad_hierarchy (uniform to some depth per face, one face
 * refined unevenly). Links carry F_rs = c_rs A_s with a symmetric coupling
 * c (reciprocal by construction). A set of links is equivalent to the
 * dense leaf matrix F_lm = sum over the links (r, s) with l under r and m
 * under s of F_rs A_m / A_s, which the test solves directly.
 *
 * Clusters (issue 27): the faces grouped in a small cluster tree, with
 * links at and from clusters, against the same links expanded to the
 * roots (a cluster receiver's link at each of its roots, a cluster
 * source's split over its roots by area); the furnace with clusters; the
 * same bytes on 1 and 2 threads with clusters.
 */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "rad_hierarchy.h"
#include "rad_lsolve.h"
#include "rad_polygon.h"
#include "rad_test.h"

/* rad_links_free lives in core/rad_links.c, built beside this test
 * (issue 26); the test frees what it made itself. */
static void test_links_free(rad_links *links)
{
    free(links->nodes);
    free(links->clusters);
    free(links->cluster_roots);
    free(links->first_link);
    free(links->links);
    memset(links, 0, sizeof *links);
}

/* ---- the cube and its trees ---- */

#define FACES 6
/* Faces: 0: x = 0, 1: x = 1, 2: y = 0, 3: y = 1, 4: z = 0, 5: z = 1. */
static const double cube_corner[8][3] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0},
                                         {0, 0, 1}, {1, 0, 1}, {1, 1, 1}, {0, 1, 1}};
static const uint32_t cube_face[FACES][4] = {{0, 3, 7, 4}, {1, 2, 6, 5}, {0, 1, 5, 4},
                                             {3, 2, 6, 7}, {0, 1, 2, 3}, {4, 5, 6, 7}};
static const double cube_inward[FACES][3] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
/* The exact form factors between faces of the unit cube (Howell C-14, C-11). */
#define CUBE_F_ADJACENT 0.20004377607540316
#define CUBE_F_OPPOSITE 0.19982489569838732

typedef struct cube_case {
    rad_mesh base, leaves;
    rad_hierarchy h;
    rad_links links;
} cube_case;

typedef struct link_triple {
    uint32_t receiver, source;
    double factor;
} link_triple;

static void cube_free(cube_case *cc)
{
    rad_hierarchy_free(&cc->h);
    rad_mesh_free(&cc->base);
    rad_mesh_free(&cc->leaves);
    test_links_free(&cc->links);
}

/* Numbers the leaves of `node`'s subtree depth first, as rad_hierarchy_leaves orders them. */
static void number_leaves(rad_links *L, uint32_t node, uint32_t *next)
{
    rad_link_node *e = &L->nodes[node];
    if (e->first_child == RAD_NO_ELEMENT) {
        e->leaf = (*next)++;
        return;
    }
    for (uint32_t k = 0; k < 4; k++) number_leaves(L, e->first_child + k, next);
}

/* The cube with face f split uniformly to depth[f]; with `uneven`, face 5's
 * first leaf is split once more. Materials per face and channel. */
static int cube_make(cube_case *cc, const int depth[FACES], int uneven, const double rho[FACES][3],
                     const double emission[FACES][3])
{
    memset(cc, 0, sizeof *cc);
    rad_mesh *m = &cc->base;
    m->positions = malloc(sizeof cube_corner);
    m->patches = calloc(FACES, sizeof *m->patches);
    if (!m->positions || !m->patches) return 0;
    memcpy(m->positions, cube_corner, sizeof cube_corner);
    m->vertex_count = 8;
    m->patch_count = FACES;
    for (int f = 0; f < FACES; f++) {
        rad_patch *p = &m->patches[f];
        rad_vec3 corner[4];
        for (int k = 0; k < 4; k++) {
            const double *c = cube_corner[cube_face[f][k]];
            corner[k] = rad_v3(c[0], c[1], c[2]);
        }
        p->vertex_count = 4;
        memcpy(p->v, cube_face[f], sizeof p->v);
        p->source_face = (uint32_t)f;
        rad_polygon_geometry(corner, 4, &p->area, &p->normal, &p->centroid);
        memcpy(p->rho, rho[f], sizeof p->rho);
        memcpy(p->emission, emission[f], sizeof p->emission);
    }
    if (rad_hierarchy_init(m, &cc->h) != RAD_OK) return 0;
    for (uint32_t f = 0; f < FACES; f++)
        if (rad_hierarchy_split_to(&cc->h, f, (uint32_t)depth[f]) != RAD_OK) return 0;
    if (uneven) { /* face 5's first leaf, down the first children, split once more */
        uint32_t e = 5, first;
        while (cc->h.elements[e].first_child != RAD_NO_ELEMENT) e = cc->h.elements[e].first_child;
        if (rad_hierarchy_split(&cc->h, e, &first) != RAD_OK) return 0;
    }
    if (rad_hierarchy_leaves(&cc->h, &cc->leaves) != RAD_OK) return 0;
    rad_links *L = &cc->links;
    L->node_count = (uint32_t)cc->h.element_count;
    L->root_count = FACES;
    L->leaf_count = (uint32_t)cc->leaves.patch_count;
    L->nodes = calloc(L->node_count, sizeof *L->nodes);
    if (!L->nodes) return 0;
    for (uint32_t i = 0; i < L->node_count; i++) {
        const rad_element *e = &cc->h.elements[i];
        rad_link_node *n = &L->nodes[i];
        n->parent = e->parent, n->first_child = e->first_child, n->root = e->root, n->level = e->level;
        n->vertex_count = e->vertex_count;
        memcpy(n->v, e->v, sizeof n->v);
        n->area = e->area;
        n->leaf = RAD_NO_ELEMENT;
    }
    uint32_t next = 0;
    for (uint32_t f = 0; f < FACES; f++) number_leaves(L, f, &next);
    for (uint32_t i = 0; i < L->node_count; i++) /* the numbering is rad_hierarchy_leaves' */
        if (L->nodes[i].leaf != RAD_NO_ELEMENT && cc->leaves.patches[L->nodes[i].leaf].area != L->nodes[i].area)
            return 0;
    return next == L->leaf_count;
}

static int triple_order(const void *a, const void *b)
{
    const link_triple *x = a, *y = b;
    if (x->receiver != y->receiver) return x->receiver < y->receiver ? -1 : 1;
    return x->source < y->source ? -1 : x->source > y->source;
}

/* The triples as the links' CSR table over the ids (nodes, then
 * clusters), sorted by receiver and source. */
static int links_set(rad_links *L, link_triple *t, size_t count)
{
    const size_t ids = rad_links_id_count(L);
    qsort(t, count, sizeof *t, triple_order);
    free(L->first_link);
    free(L->links);
    L->first_link = calloc(ids + 1, sizeof *L->first_link);
    L->links = malloc((count ? count : 1) * sizeof *L->links);
    if (!L->first_link || !L->links) return 0;
    for (size_t k = 0; k < count; k++) {
        L->first_link[t[k].receiver + 1]++;
        L->links[k].source = t[k].source;
        L->links[k].error = 0;
        L->links[k].factor = t[k].factor;
    }
    for (size_t i = 0; i < ids; i++) L->first_link[i + 1] += L->first_link[i];
    L->link_count = count;
    return 1;
}

/* A cover of tree f: 0 the root, 1 the root's children (the root if it is
 * a leaf), 2 its leaves. Returns the count written to out. */
static size_t cover(const rad_links *L, uint32_t f, int kind, uint32_t *out)
{
    size_t count = 0;
    uint32_t stack[4096], top = 0;
    const rad_link_node *root = &L->nodes[f];
    if (kind == 0 || root->first_child == RAD_NO_ELEMENT) {
        out[0] = f;
        return 1;
    }
    if (kind == 1) {
        for (uint32_t k = 0; k < 4; k++) out[k] = root->first_child + k;
        return 4;
    }
    stack[top++] = f;
    while (top > 0) { /* the leaves, in any order */
        uint32_t i = stack[--top];
        if (L->nodes[i].first_child == RAD_NO_ELEMENT)
            out[count++] = i;
        else
            for (uint32_t k = 0; k < 4; k++) stack[top++] = L->nodes[i].first_child + k;
    }
    return count;
}

/* The symmetric point coupling of two elements on different faces:
 * cos cos / (pi r^2) between their centroids. */
static double coupling(const cube_case *cc, uint32_t a, uint32_t b)
{
    const rad_element *ea = &cc->h.elements[a], *eb = &cc->h.elements[b];
    rad_vec3 d = rad_v3_sub(eb->centroid, ea->centroid);
    double r2 = rad_v3_dot(d, d), r = sqrt(r2);
    const double *na = cube_inward[ea->root], *nb = cube_inward[eb->root];
    double ca = (na[0] * d.x + na[1] * d.y + na[2] * d.z) / r;
    double cb = -(nb[0] * d.x + nb[1] * d.y + nb[2] * d.z) / r;
    return ca * cb / (RAD_PI * r2);
}

/* The leaf cluster holding root r (cluster_count: none). */
static uint32_t leaf_cluster_of(const rad_links *L, uint32_t r)
{
    for (uint32_t c = 0; c < L->cluster_count; c++)
        if (L->clusters[c].child_count == 0)
            for (uint32_t q = L->clusters[c].root_begin; q < L->clusters[c].root_end; q++)
                if (L->cluster_roots[q] == r) return c;
    return L->cluster_count;
}

/* Each leaf's row sum: its links', its ancestors' and its root's
 * clusters' F. */
static double largest_row_sum(const rad_links *L)
{
    const uint32_t n = L->node_count;
    double *s = calloc(rad_links_id_count(L), sizeof *s), largest = 0;
    for (uint32_t c = 0; c < L->cluster_count; c++) {
        for (uint64_t k = L->first_link[n + c]; k < L->first_link[n + c + 1]; k++) s[n + c] += L->links[k].factor;
        if (L->clusters[c].parent != RAD_NO_ELEMENT) s[n + c] += s[n + L->clusters[c].parent];
    }
    for (uint32_t i = 0; i < n; i++) {
        for (uint64_t k = L->first_link[i]; k < L->first_link[i + 1]; k++) s[i] += L->links[k].factor;
        if (L->nodes[i].parent != RAD_NO_ELEMENT) s[i] += s[L->nodes[i].parent];
        else if (L->cluster_count) s[i] += s[n + leaf_cluster_of(L, i)];
        if (L->nodes[i].first_child == RAD_NO_ELEMENT && s[i] > largest) largest = s[i];
    }
    free(s);
    return largest;
}

/* The area of id i: a node's or a cluster's. */
static double id_area(const rad_links *L, uint32_t i)
{
    return i < L->node_count ? L->nodes[i].area : L->clusters[i - L->node_count].area;
}

/* A growing list of triples. */
typedef struct triple_list {
    link_triple *t;
    size_t count, cap;
} triple_list;

static int triple_add(triple_list *l, uint32_t receiver, uint32_t source, double factor)
{
    if (l->count == l->cap) {
        size_t cap = l->cap ? 2 * l->cap : 1024;
        link_triple *grown = realloc(l->t, cap * sizeof *grown);
        if (!grown) return 0;
        l->t = grown, l->cap = cap;
    }
    l->t[l->count++] = (link_triple){receiver, source, factor};
    return 1;
}

/* The pair of links a <- b, b <- a of the symmetric coupling c:
 * F_ab = c A_b, F_ba = c A_a (reciprocal by construction). */
static int pair_add(triple_list *l, const rad_links *L, uint32_t a, uint32_t b, double c)
{
    return triple_add(l, a, b, c * id_area(L, b)) && triple_add(l, b, a, c * id_area(L, a));
}

/* Links between two faces at the covers kind[f][g] (face f's side of the
 * pair f-g), for every two faces, or with `group` only for two of the
 * same group. furnace: F = the exact face-to-face factor spread by area;
 * else the point coupling. */
static int face_triples(cube_case *cc, int kind[FACES][FACES], int furnace, const int *group, triple_list *out)
{
    rad_links *L = &cc->links;
    uint32_t *a = malloc(L->node_count * sizeof *a), *b = malloc(L->node_count * sizeof *b);
    int ok = a && b;
    for (uint32_t f = 0; f < FACES && ok; f++)
        for (uint32_t g = f + 1; g < FACES && ok; g++) {
            if (group && group[f] != group[g]) continue;
            size_t na = cover(L, f, kind[f][g], a), nb = cover(L, g, kind[g][f], b);
            double F = f / 2 == g / 2 ? CUBE_F_OPPOSITE : CUBE_F_ADJACENT; /* faces 2k, 2k+1 are opposite */
            for (size_t i = 0; i < na && ok; i++)
                for (size_t j = 0; j < nb && ok; j++)
                    ok = pair_add(out, L, a[i], b[j], furnace ? F : coupling(cc, a[i], b[j])); /* faces have area 1 */
        }
    free(a);
    free(b);
    return ok;
}

/* Scales every link so that the largest row sum is `target`. */
static void links_scale(rad_links *L, double target)
{
    double scale = target / largest_row_sum(L);
    for (uint64_t k = 0; k < L->link_count; k++) L->links[k].factor *= scale;
}

/* Links between every two faces at the covers kind[f][g] (face_triples);
 * without furnace scaled so that the largest row sums to 0.95. */
static int links_between_faces(cube_case *cc, int kind[FACES][FACES], int furnace)
{
    triple_list list = {0};
    int ok = face_triples(cc, kind, furnace, NULL, &list) && links_set(&cc->links, list.t, list.count);
    if (ok && !furnace) links_scale(&cc->links, 0.95);
    free(list.t);
    return ok;
}

static void kinds_all(int kind[FACES][FACES], int value)
{
    for (int f = 0; f < FACES; f++)
        for (int g = 0; g < FACES; g++) kind[f][g] = value;
}

/* A fixed mixture of covers: every level meets every other somewhere. */
static void kinds_mixed(int kind[FACES][FACES])
{
    for (int f = 0; f < FACES; f++)
        for (int g = 0; g < FACES; g++) kind[f][g] = (f + 2 * g) % 3;
}

/* ---- the reference: the equivalent dense system, solved directly ---- */

/* The leaves under node i (their leaf numbers) and their areas summed. */
static size_t leaves_under(const rad_links *L, uint32_t i, uint32_t *out, double *area)
{
    uint32_t nodes[4096];
    size_t count = cover(L, i, 2, nodes);
    *area = 0;
    for (size_t k = 0; k < count; k++) {
        out[k] = L->nodes[nodes[k]].leaf;
        *area += L->nodes[nodes[k]].area;
    }
    return count;
}

/* F_lm = sum over links (r, s), l under r, m under s, of F_rs A_m / A_s. */
static double *dense_equivalent(const cube_case *cc)
{
    const rad_links *L = &cc->links;
    const size_t n = L->leaf_count;
    double *F = calloc(n * n, sizeof *F);
    uint32_t *under_r = malloc(n * sizeof *under_r), *under_s = malloc(n * sizeof *under_s);
    if (F && under_r && under_s)
        for (uint32_t r = 0; r < L->node_count; r++) {
            double area_r, area_s;
            size_t nr = leaves_under(L, r, under_r, &area_r);
            for (uint64_t k = L->first_link[r]; k < L->first_link[r + 1]; k++) {
                size_t ns = leaves_under(L, L->links[k].source, under_s, &area_s);
                for (size_t i = 0; i < nr; i++)
                    for (size_t j = 0; j < ns; j++)
                        F[under_r[i] * n + under_s[j]] +=
                            L->links[k].factor * cc->leaves.patches[under_s[j]].area / area_s;
            }
        }
    free(under_r);
    free(under_s);
    return F;
}

/* x with (I - diag(rho) F) x = E, Gaussian elimination with partial
 * pivoting in long double. */
static int dense_solve(size_t n, const double *F, const double *rho, const double *E, double *x)
{
    long double *M = malloc(n * (n + 1) * sizeof *M);
    if (!M) return 0;
    for (size_t i = 0; i < n; i++) {
        for (size_t j = 0; j < n; j++) M[i * (n + 1) + j] = (i == j) - (long double)rho[i] * F[i * n + j];
        M[i * (n + 1) + n] = E[i];
    }
    for (size_t k = 0; k < n; k++) {
        size_t p = k;
        for (size_t i = k + 1; i < n; i++)
            if (fabsl(M[i * (n + 1) + k]) > fabsl(M[p * (n + 1) + k])) p = i;
        for (size_t j = 0; j <= n; j++) {
            long double t = M[k * (n + 1) + j];
            M[k * (n + 1) + j] = M[p * (n + 1) + j];
            M[p * (n + 1) + j] = t;
        }
        for (size_t i = k + 1; i < n; i++) {
            long double q = M[i * (n + 1) + k] / M[k * (n + 1) + k];
            for (size_t j = k; j <= n; j++) M[i * (n + 1) + j] -= q * M[k * (n + 1) + j];
        }
    }
    for (size_t i = n; i-- > 0;) {
        long double s = M[i * (n + 1) + n];
        for (size_t j = i + 1; j < n; j++) s -= M[i * (n + 1) + j] * x[j];
        x[i] = (double)(s / M[i * (n + 1) + i]);
    }
    free(M);
    return 1;
}

/* The largest relative difference of the solve's B from the direct solve,
 * over the leaves and channels; the worst scaled residual of B against F
 * (max |E + rho F B - B| / ||E||) into *residual. */
static double worst_against_dense(const cube_case *cc, const double *B, double *residual)
{
    const size_t n = cc->leaves.patch_count;
    double *F = dense_equivalent(cc);
    double *rho = malloc(n * sizeof *rho), *E = malloc(n * sizeof *E), *x = malloc(n * sizeof *x);
    double worst = INFINITY;
    *residual = INFINITY;
    if (F && rho && E && x) {
        worst = 0;
        *residual = 0;
        for (int c = 0; c < 3; c++) {
            double e_norm = 0;
            for (size_t l = 0; l < n; l++) {
                rho[l] = cc->leaves.patches[l].rho[c];
                E[l] = cc->leaves.patches[l].emission[c];
                if (E[l] > e_norm) e_norm = E[l];
            }
            if (!dense_solve(n, F, rho, E, x)) return INFINITY;
            for (size_t l = 0; l < n; l++) {
                double d = fabs(B[3 * l + c] - x[l]) / fabs(x[l]);
                if (d > worst) worst = d;
                double g = 0;
                for (size_t m = 0; m < n; m++) g += F[l * n + m] * B[3 * m + c];
                double r = fabs(E[l] + rho[l] * g - B[3 * l + c]) / e_norm;
                if (r > *residual) *residual = r;
            }
        }
    }
    free(F);
    free(rho);
    free(E);
    free(x);
    return worst;
}

/* ---- the tests ---- */

/* An RGB closed cube: one face lit (more in red), the others dimly, every
 * face its own reflectances. */
static void rgb_materials(double rho[FACES][3], double emission[FACES][3])
{
    for (int f = 0; f < FACES; f++)
        for (int c = 0; c < 3; c++) {
            rho[f][c] = 0.3 + 0.1 * f + 0.05 * c;
            emission[f][c] = f == 5 ? 10.0 - 2 * c : 0.01 * (f + 1) * (c + 1);
        }
}

/* Gauss-Seidel's groups of trees for run_lsolve: at least this share of
 * the links each (rad_lsolve_options.group_links); 0: rad_lsolve's default. */
static double group_share;

static rad_status run_lsolve(const cube_case *cc, rad_lsolve_method method, double tol, int threads, double *B,
                             rad_lsolve_result *r)
{
    rad_lsolve_options o = rad_lsolve_defaults();
    o.group_links = group_share > 0 ? (uint64_t)ceil(group_share * (double)cc->links.link_count) : 0;
    o.method = method;
    o.tolerance = tol;
    o.max_iterations = 200000;
    o.threads = threads;
    return rad_lsolve(&cc->links, &cc->leaves, &o, B, r);
}

static void check_against_dense(const char *name, int kind[FACES][FACES])
{
    static const int depth[FACES] = {2, 1, 2, 0, 2, 1};
    double rho[FACES][3], emission[FACES][3];
    rgb_materials(rho, emission);
    cube_case cc;
    int made = cube_make(&cc, depth, 1, rho, emission) && links_between_faces(&cc, kind, 0);
    RAD_CHECK(made);
    if (!made) {
        cube_free(&cc);
        return;
    }
    const size_t n = cc.leaves.patch_count;
    double *B[2] = {malloc(3 * n * sizeof(double)), malloc(3 * n * sizeof(double))};
    rad_lsolve_result r[2];
    for (int m = 0; m < 2; m++) {
        rad_lsolve_method method = m == 0 ? RAD_LSOLVE_JACOBI : RAD_LSOLVE_GAUSS_SEIDEL;
        RAD_CHECK(run_lsolve(&cc, method, 1e-13, 0, B[m], &r[m]) == RAD_OK);
        double residual;
        double worst = worst_against_dense(&cc, B[m], &residual);
        printf("%s, %s: %zu leaves, %u nodes, %llu links: iterations %u/%u/%u, residual %.2g (measured %.2g), "
               "worst %.2g against the direct solve, imbalance %.2g\n",
               name, m == 0 ? "jacobi" : "gauss-seidel", n, cc.links.node_count,
               (unsigned long long)cc.links.link_count, r[m].iterations[0], r[m].iterations[1], r[m].iterations[2],
               r[m].residual[0], residual, worst, r[m].imbalance);
        RAD_CHECK(r[m].converged);
        RAD_CHECK(worst <= 1e-10);
        RAD_CHECK(residual <= 2e-13); /* the test's own sums round otherwise */
        for (int c = 0; c < 3; c++) RAD_CHECK(r[m].residual[c] <= 1e-13);
        RAD_CHECK(fabs(r[m].imbalance) <= 1e-9);
        RAD_CHECK(r[m].emitted > 0 && r[m].absorbed > 0);
    }
    /* Jacobi and Gauss-Seidel agree */
    double apart = 0;
    for (size_t k = 0; k < 3 * n; k++) {
        double d = fabs(B[0][k] - B[1][k]) / fabs(B[1][k]);
        if (d > apart) apart = d;
    }
    RAD_CHECK(apart <= 1e-10);
    RAD_CHECK(r[1].iterations[0] < r[0].iterations[0]); /* Gauss-Seidel needs fewer sweeps */
    free(B[0]);
    free(B[1]);
    cube_free(&cc);
}

/* Links between leaves only: the full matrix on the leaves. */
static void test_leaf_links(void)
{
    int kind[FACES][FACES];
    kinds_all(kind, 2);
    check_against_dense("leaf links", kind);
}

/* Links at the roots, their children and the leaves, mixed. */
static void test_mixed_links(void)
{
    int kind[FACES][FACES];
    kinds_mixed(kind);
    check_against_dense("mixed links", kind);
}

/* Two roots: A split into 4 children of areas 0.1 .. 0.4, B a leaf. Links
 * A <-> B at the roots and child 2 <-> B: the children differ, A's B is
 * their area-weighted mean. Closed form for x = B_B:
 *   B_child k = E_A + rho_A (F_AB + [k = 2] f) x
 *   mean_A    = E_A + rho_A (F_AB + a_2 f / A_A) x
 *   x         = E_B + rho_B (F_BA mean_A + F_B2 B_child 2)
 */
static void test_push_pull_by_hand(void)
{
    const double area[6] = {1.0, 2.0, 0.1, 0.2, 0.3, 0.4};
    const double rho_A = 0.6, rho_B = 0.8, E_A = 0.25, E_B = 3.0, F_AB = 0.3, f = 0.2;
    const double F_BA = area[0] * F_AB / area[1], F_B2 = area[4] * f / area[1];
    rad_links L;
    memset(&L, 0, sizeof L);
    L.node_count = 6, L.root_count = 2, L.leaf_count = 5;
    L.nodes = calloc(6, sizeof *L.nodes);
    rad_mesh leaves;
    memset(&leaves, 0, sizeof leaves);
    leaves.patch_count = 5;
    leaves.patches = calloc(5, sizeof *leaves.patches);
    if (!L.nodes || !leaves.patches) {
        RAD_CHECK(0);
        return;
    }
    for (uint32_t i = 0; i < 6; i++) {
        rad_link_node *e = &L.nodes[i];
        e->parent = i < 2 ? RAD_NO_ELEMENT : 0;
        e->root = i < 2 ? i : 0;
        e->level = i >= 2;
        e->first_child = i == 0 ? 2 : RAD_NO_ELEMENT;
        e->leaf = i == 0 ? RAD_NO_ELEMENT : i == 1 ? 4 : i - 2;
        e->area = area[i];
        e->vertex_count = 4;
        if (e->leaf == RAD_NO_ELEMENT) continue;
        rad_patch *p = &leaves.patches[e->leaf];
        p->area = area[i];
        for (int c = 0; c < 3; c++) {
            p->rho[c] = i == 1 ? rho_B : rho_A;
            p->emission[c] = i == 1 ? E_B : E_A;
        }
    }
    link_triple t[4] = {{0, 1, F_AB}, {1, 0, F_BA}, {4, 1, f}, {1, 4, F_B2}};
    RAD_CHECK(links_set(&L, t, 4));
    double x = (E_B + rho_B * E_A * (F_BA + F_B2)) /
               (1 - rho_B * rho_A * (F_BA * (F_AB + area[4] * f / area[0]) + F_B2 * (F_AB + f)));
    double B[15];
    rad_lsolve_result r;
    rad_lsolve_options o = rad_lsolve_defaults();
    o.tolerance = 1e-15;
    o.channels = 1;
    RAD_CHECK(rad_lsolve(&L, &leaves, &o, B, &r) == RAD_OK);
    RAD_CHECK_REL(B[3 * 4], x, 1e-13);
    for (uint32_t k = 0; k < 4; k++) {
        double expected = E_A + rho_A * (F_AB + (k == 2 ? f : 0)) * x;
        RAD_CHECK_REL(B[3 * k], expected, 1e-13);
        RAD_CHECK(B[3 * k + 1] == B[3 * k] && B[3 * k + 2] == B[3 * k]); /* grey: copied */
    }
    RAD_CHECK(fabs(r.imbalance) <= 1e-12);
    /* one Jacobi sweep from B = E: the children gather E_B through A's link
     * and child 2's own; B gathers A's mean of E (= E_A) and child 2's E */
    o.method = RAD_LSOLVE_JACOBI;
    o.max_iterations = 1;
    RAD_CHECK(rad_lsolve(&L, &leaves, &o, B, &r) == RAD_ERR_NOT_CONVERGED);
    RAD_CHECK(r.iterations[0] == 1 && !r.converged);
    for (uint32_t k = 0; k < 4; k++) RAD_CHECK_REL(B[3 * k], E_A + rho_A * (F_AB + (k == 2 ? f : 0)) * E_B, 1e-15);
    RAD_CHECK_REL(B[3 * 4], E_B + rho_B * (F_BA * E_A + F_B2 * E_A), 1e-15);
    test_links_free(&L);
    rad_mesh_free(&leaves);
}

/* E = 1 and one rho everywhere in the closed cube: B = 1 / (1 - rho). */
static void check_furnace(const char *name, const int depth[FACES], int uneven, int kind[FACES][FACES])
{
    static const double rhos[3] = {0.5, 0.9, 0.999};
    for (int k = 0; k < 3; k++) {
        double rho[FACES][3], emission[FACES][3];
        for (int f = 0; f < FACES; f++)
            for (int c = 0; c < 3; c++) rho[f][c] = rhos[k], emission[f][c] = 1;
        cube_case cc;
        int made = cube_make(&cc, depth, uneven, rho, emission) && links_between_faces(&cc, kind, 1);
        RAD_CHECK(made);
        if (!made) {
            cube_free(&cc);
            return;
        }
        const size_t n = cc.leaves.patch_count;
        double *B = malloc(3 * n * sizeof *B);
        for (int m = 0; m < 2; m++) {
            rad_lsolve_method method = m == 0 ? RAD_LSOLVE_JACOBI : RAD_LSOLVE_GAUSS_SEIDEL;
            rad_lsolve_result r;
            RAD_CHECK(run_lsolve(&cc, method, 1e-11, 0, B, &r) == RAD_OK);
            double worst = 0;
            for (size_t l = 0; l < 3 * n; l++) {
                double d = fabs(B[l] * (1 - rhos[k]) - 1);
                if (d > worst) worst = d;
            }
            printf("furnace, %s, rho %g, %s: %zu leaves, %llu links: %u iterations, worst %.2g, imbalance %.2g, "
                   "escaped %.2g of emitted\n",
                   name, rhos[k], m == 0 ? "jacobi" : "gauss-seidel", n, (unsigned long long)cc.links.link_count,
                   r.iterations[0], worst, r.imbalance, r.escaped / r.emitted);
            RAD_CHECK(worst <= 1e-9);
            RAD_CHECK(fabs(r.imbalance) <= 1e-9);
            RAD_CHECK(fabs(r.escaped) <= 1e-9 * r.emitted); /* closed */
            RAD_CHECK_REL(r.emitted, 3.0 * 6, 1e-12);       /* 3 channels, 6 faces of area 1 */
        }
        free(B);
        cube_free(&cc);
    }
}

static void test_furnace(void)
{
    static const int roots[FACES] = {0, 0, 0, 0, 0, 0}, deep[FACES] = {2, 2, 2, 2, 2, 2};
    int kind[FACES][FACES];
    kinds_all(kind, 0);
    check_furnace("links at the roots", roots, 0, kind);
    kinds_mixed(kind);
    check_furnace("leaves at depth 2, links mixed", deep, 1, kind);
}

/* Both methods on 1 and 2 threads: the same bytes (B, residual,
 * iterations, balance), the imbalance within max_imbalance. On 2 threads
 * small trees' channels run at once (rad_lsolve.c, channels_in_parallel). */
static void threads_identical(cube_case *cc, const char *what, double max_imbalance)
{
    const size_t n = cc->leaves.patch_count;
    double *one = malloc(3 * n * sizeof *one), *two = malloc(3 * n * sizeof *two);
    for (int m = 0; m < 2; m++) {
        rad_lsolve_method method = m == 0 ? RAD_LSOLVE_JACOBI : RAD_LSOLVE_GAUSS_SEIDEL;
        rad_lsolve_result r1, r2;
        RAD_CHECK(run_lsolve(cc, method, 1e-9, 1, one, &r1) == RAD_OK);
        RAD_CHECK(run_lsolve(cc, method, 1e-9, 2, two, &r2) == RAD_OK);
        printf("%s, %s: %zu leaves, %u nodes, %llu links: %u iterations, imbalance %.2g, %.3f s on 1 thread, "
               "%.3f s on 2\n",
               what, m == 0 ? "jacobi" : "gauss-seidel", n, cc->links.node_count,
               (unsigned long long)cc->links.link_count, r1.iterations[0], r1.imbalance, r1.seconds, r2.seconds);
        RAD_CHECK(memcmp(one, two, 3 * n * sizeof *one) == 0);
        RAD_CHECK(memcmp(r1.residual, r2.residual, sizeof r1.residual) == 0);
        RAD_CHECK(r1.iterations[0] == r2.iterations[0] && r1.imbalance == r2.imbalance);
        RAD_CHECK(fabs(r1.imbalance) <= max_imbalance);
    }
    free(one);
    free(two);
}

/* 1 and 2 threads: the same bytes, both methods. Leaf links at depth 3
 * (122,880 links: the gathers run in parallel), and depth 5 with links at
 * mixed levels (8,190 nodes: Jacobi pushes and pulls trees in parallel). */
static void test_threads(void)
{
    static const int depth3[FACES] = {3, 3, 3, 3, 3, 3}, depth5[FACES] = {5, 5, 5, 5, 5, 5};
    double rho[FACES][3], emission[FACES][3];
    rgb_materials(rho, emission);
    for (int config = 0; config < 2; config++) {
        int kind[FACES][FACES];
        if (config == 0)
            kinds_all(kind, 2);
        else
            kinds_mixed(kind);
        cube_case cc;
        int made = cube_make(&cc, config == 0 ? depth3 : depth5, 0, rho, emission) && links_between_faces(&cc, kind, 0);
        RAD_CHECK(made);
        if (!made) {
            cube_free(&cc);
            return;
        }
        threads_identical(&cc, "threads", INFINITY);
        cube_free(&cc);
    }
}

/* Gauss-Seidel in groups of consecutive trees (rad_lsolve.c; what it does
 * from 4 M links up): groups of a third of the links (two or three trees
 * each), then the six trees in one group, which is Jacobi's sweep: the
 * direct solve's B to 1e-10 (check_against_dense; fewer sweeps than
 * Jacobi where the groups are several), and the same bytes on 1 and 2
 * threads. */
static void test_groups(void)
{
    static const int depth3[FACES] = {3, 3, 3, 3, 3, 3};
    int kind[FACES][FACES];
    kinds_mixed(kind);
    group_share = 1.0 / 3;
    check_against_dense("groups of a third of the links", kind);
    double rho[FACES][3], emission[FACES][3];
    rgb_materials(rho, emission);
    cube_case cc;
    kinds_all(kind, 2);
    int made = cube_make(&cc, depth3, 0, rho, emission) && links_between_faces(&cc, kind, 0);
    RAD_CHECK(made);
    if (made) threads_identical(&cc, "threads, groups of a third", INFINITY);
    cube_free(&cc);
    group_share = 1.0;
    if (cube_make(&cc, depth3, 0, rho, emission) && links_between_faces(&cc, kind, 0)) {
        const size_t n = cc.leaves.patch_count;
        double *g = malloc(3 * n * sizeof *g), *j = malloc(3 * n * sizeof *j);
        rad_lsolve_result rg, rj;
        RAD_CHECK(g && j && run_lsolve(&cc, RAD_LSOLVE_GAUSS_SEIDEL, 1e-12, 2, g, &rg) == RAD_OK &&
                  run_lsolve(&cc, RAD_LSOLVE_JACOBI, 1e-12, 2, j, &rj) == RAD_OK);
        printf("one group of all six trees: %u sweeps, Jacobi %u\n", rg.iterations[0], rj.iterations[0]);
        RAD_CHECK(rg.iterations[0] == rj.iterations[0]);
        RAD_CHECK(g && j && memcmp(g, j, 3 * n * sizeof *g) == 0);
        free(g);
        free(j);
    } else {
        RAD_CHECK(0);
    }
    cube_free(&cc);
    group_share = 0;
}

/* Grey channels, no light, the iteration limit, a warm start, bad input. */
static void test_edges(void)
{
    static const int depth[FACES] = {1, 1, 1, 1, 1, 1};
    double rho[FACES][3], emission[FACES][3];
    rgb_materials(rho, emission);
    int kind[FACES][FACES];
    kinds_mixed(kind);
    cube_case cc;
    int made = cube_make(&cc, depth, 0, rho, emission) && links_between_faces(&cc, kind, 0);
    RAD_CHECK(made);
    if (!made) {
        cube_free(&cc);
        return;
    }
    const size_t n = cc.leaves.patch_count;
    double *B = malloc(3 * n * sizeof *B), *again = malloc(3 * n * sizeof *again);
    rad_lsolve_result r;
    rad_lsolve_options o = rad_lsolve_defaults();
    RAD_CHECK(o.method == RAD_LSOLVE_GAUSS_SEIDEL && o.tolerance == 1e-6 && o.max_iterations == 10000 &&
              o.channels == 3 && o.threads == 0 && o.warm_start == 0);

    /* channels 1: channel 0 solved and copied */
    o.channels = 1;
    o.tolerance = 1e-12;
    RAD_CHECK(rad_lsolve(&cc.links, &cc.leaves, &o, B, &r) == RAD_OK);
    for (size_t l = 0; l < n; l++) RAD_CHECK(B[3 * l + 1] == B[3 * l] && B[3 * l + 2] == B[3 * l]);
    RAD_CHECK(r.iterations[1] == r.iterations[0] && r.residual[2] == r.residual[0]);
    o.channels = 3;
    RAD_CHECK(rad_lsolve(&cc.links, &cc.leaves, &o, again, &r) == RAD_OK);
    for (size_t l = 0; l < n; l++) RAD_CHECK(again[3 * l] == B[3 * l]); /* the same channel 0 */

    /* a warm start from the solution: converged before any sweep */
    o.warm_start = 1;
    RAD_CHECK(rad_lsolve(&cc.links, &cc.leaves, &o, again, &r) == RAD_OK);
    RAD_CHECK(r.iterations[0] == 0 && r.iterations[1] == 0 && r.iterations[2] == 0 && r.converged);
    o.warm_start = 0;

    /* the limit: the last measured iterate, marked unconverged */
    o.max_iterations = 3;
    rad_test_capture_log();
    RAD_CHECK(rad_lsolve(&cc.links, &cc.leaves, &o, B, &r) == RAD_ERR_NOT_CONVERGED);
    RAD_CHECK(!r.converged && r.iterations[0] == 3 && r.residual[0] > 1e-12);
    RAD_CHECK(rad_test_log_contains("not converged after 3 iterations"));
    o.max_iterations = 0; /* zero: the default */

    /* no light: B = 0, converged at once */
    for (size_t l = 0; l < n; l++) memset(cc.leaves.patches[l].emission, 0, sizeof cc.leaves.patches[l].emission);
    RAD_CHECK(rad_lsolve(&cc.links, &cc.leaves, &o, B, &r) == RAD_OK);
    for (size_t l = 0; l < 3 * n; l++) RAD_CHECK(B[l] == 0);
    RAD_CHECK(r.converged && r.iterations[0] == 0 && r.imbalance == 0);

    /* a mesh that does not match, a broken tree, options out of range: refused, B untouched */
    B[0] = 42;
    cc.leaves.patch_count--;
    RAD_CHECK(rad_lsolve(&cc.links, &cc.leaves, &o, B, &r) == RAD_ERR_INVALID);
    RAD_CHECK(rad_test_log_contains("leaves mesh has"));
    cc.leaves.patch_count++;
    cc.links.nodes[7].parent = 8;
    RAD_CHECK(rad_lsolve(&cc.links, &cc.leaves, &o, B, &r) == RAD_ERR_INVALID);
    cc.links.nodes[7].parent = cc.h.elements[7].parent;
    uint32_t source = cc.links.links[0].source;
    cc.links.links[0].source = cc.links.node_count;
    RAD_CHECK(rad_lsolve(&cc.links, &cc.leaves, &o, B, &r) == RAD_ERR_INVALID);
    cc.links.links[0].source = source;
    o.channels = 2;
    RAD_CHECK(rad_lsolve(&cc.links, &cc.leaves, &o, B, &r) == RAD_ERR_INVALID);
    RAD_CHECK(B[0] == 42);
    rad_log_set_sink(NULL, NULL);

    free(B);
    free(again);
    cube_free(&cc);
}

/* ---- clusters (issue 27) ---- */

/* The half of the cube holding face f in cube_clusters' tree. */
static const int cube_half[FACES] = {0, 1, 0, 1, 0, 1};

/* The cube's faces in a cluster tree: cluster 0 over all, its children 1
 * (faces 0, 2, 4: x, y, z = 0; a leaf cluster) and 2 (faces 1, 3, 5),
 * whose children are the leaf clusters 3 (face 1) and 4 (faces 3, 5).
 * Each face of one half is opposite one face of the other and adjacent
 * to the rest, and to the faces of its own half. */
static int cube_clusters(rad_links *L)
{
    static const uint32_t order[FACES] = {0, 2, 4, 1, 3, 5};
    static const rad_link_cluster tree[5] = {
        {.parent = RAD_NO_ELEMENT, .first_child = 1, .child_count = 2, .root_begin = 0, .root_end = 6},
        {.parent = 0, .first_child = RAD_NO_ELEMENT, .root_begin = 0, .root_end = 3},
        {.parent = 0, .first_child = 3, .child_count = 2, .root_begin = 3, .root_end = 6},
        {.parent = 2, .first_child = RAD_NO_ELEMENT, .root_begin = 3, .root_end = 4},
        {.parent = 2, .first_child = RAD_NO_ELEMENT, .root_begin = 4, .root_end = 6}};
    L->cluster_count = 5;
    L->clusters = malloc(sizeof tree);
    L->cluster_roots = malloc(sizeof order);
    if (!L->clusters || !L->cluster_roots) return 0;
    memcpy(L->clusters, tree, sizeof tree);
    memcpy(L->cluster_roots, order, sizeof order);
    for (uint32_t c = 0; c < 5; c++)
        for (uint32_t q = tree[c].root_begin; q < tree[c].root_end; q++) L->clusters[c].area += L->nodes[order[q]].area;
    return 1;
}

/* Links at and from cube_clusters' clusters, reciprocal pairs of coupling
 * k: the halves (clusters 1 and 2), a leaf cluster and the other half (4
 * and 1), cluster 0 with itself, face 0's first child with half 2, the
 * last leaf with cluster 3; with every_leaf also every leaf node with
 * clusters 0, 1 and 2. */
static int cluster_triples(const rad_links *L, double k, int every_leaf, triple_list *out)
{
    const uint32_t n = L->node_count;
    const uint32_t x = L->nodes[0].first_child != RAD_NO_ELEMENT ? L->nodes[0].first_child : 0;
    uint32_t y = 0;
    for (uint32_t i = 0; i < n; i++)
        if (L->nodes[i].leaf == L->leaf_count - 1) y = i;
    int ok = pair_add(out, L, n + 1, n + 2, k) && pair_add(out, L, n + 4, n + 1, k) &&
             triple_add(out, n, n, k * id_area(L, n)) && pair_add(out, L, x, n + 2, k) && pair_add(out, L, y, n + 3, k);
    for (uint32_t i = 0; i < n && ok && every_leaf; i++)
        if (L->nodes[i].first_child == RAD_NO_ELEMENT)
            for (uint32_t c = 0; c < 3 && ok; c++) ok = pair_add(out, L, i, n + c, k);
    return ok;
}

/* L's links expanded to its roots, into flat (the same nodes, no
 * clusters): a link at cluster c is at each root of c, a link from
 * cluster s is one from each root j of s with F A_j / A_s; links that
 * land on the same receiver and source are summed. */
static int links_expand(const rad_links *L, rad_links *flat)
{
    const uint32_t n = L->node_count;
    memset(flat, 0, sizeof *flat);
    flat->node_count = n, flat->root_count = L->root_count, flat->leaf_count = L->leaf_count;
    flat->nodes = malloc(n * sizeof *flat->nodes);
    if (!flat->nodes) return 0;
    memcpy(flat->nodes, L->nodes, n * sizeof *flat->nodes);
    triple_list list = {0};
    int ok = 1;
    for (uint32_t r = 0; r < rad_links_id_count(L) && ok; r++) {
        const rad_link_cluster *cr = r < n ? NULL : &L->clusters[r - n];
        for (uint32_t qr = cr ? cr->root_begin : 0; qr < (cr ? cr->root_end : 1) && ok; qr++) {
            const uint32_t receiver = cr ? L->cluster_roots[qr] : r;
            for (uint64_t k = L->first_link[r]; k < L->first_link[r + 1] && ok; k++) {
                const uint32_t s = L->links[k].source;
                const rad_link_cluster *cs = s < n ? NULL : &L->clusters[s - n];
                for (uint32_t qs = cs ? cs->root_begin : 0; qs < (cs ? cs->root_end : 1) && ok; qs++) {
                    const uint32_t source = cs ? L->cluster_roots[qs] : s;
                    const double w = cs ? L->nodes[source].area / cs->area : 1;
                    ok = triple_add(&list, receiver, source, L->links[k].factor * w);
                }
            }
        }
    }
    size_t m = 0;
    if (ok && list.count) {
        qsort(list.t, list.count, sizeof *list.t, triple_order);
        for (size_t k = 1; k < list.count; k++) {
            if (list.t[k].receiver == list.t[m].receiver && list.t[k].source == list.t[m].source)
                list.t[m].factor += list.t[k].factor;
            else
                list.t[++m] = list.t[k];
        }
        m++;
    }
    ok = ok && links_set(flat, list.t, m);
    free(list.t);
    return ok;
}

/* Every face lit a little and its own reflectances: B of one order
 * everywhere, so that B is compared relatively at 1e-12. */
static void cluster_materials(double rho[FACES][3], double emission[FACES][3])
{
    for (int f = 0; f < FACES; f++)
        for (int c = 0; c < 3; c++) {
            rho[f][c] = 0.3 + 0.1 * f + 0.05 * c;
            emission[f][c] = 1.0 + 0.2 * f + 0.1 * c;
        }
}

static double worst_relative(const double *a, const double *b, size_t count)
{
    double worst = 0;
    for (size_t k = 0; k < count; k++) {
        double d = fabs(a[k] - b[k]) / fabs(b[k]);
        if (!(d <= worst)) worst = d;
    }
    return worst;
}

/* Links at mixed levels inside each half of the cube and links at and from
 * clusters (cluster_triples) against the same links expanded to the roots;
 * the expansion also against the direct solve. Then cluster tables the
 * solve refuses. */
static void test_cluster_links(void)
{
    static const int depth[FACES] = {2, 1, 2, 0, 2, 1};
    double rho[FACES][3], emission[FACES][3];
    cluster_materials(rho, emission);
    int kind[FACES][FACES];
    kinds_mixed(kind);
    cube_case cc;
    triple_list list = {0};
    rad_links flat;
    memset(&flat, 0, sizeof flat);
    int made = cube_make(&cc, depth, 1, rho, emission) && cube_clusters(&cc.links) &&
               face_triples(&cc, kind, 0, cube_half, &list) && cluster_triples(&cc.links, 0.1, 0, &list) &&
               links_set(&cc.links, list.t, list.count);
    free(list.t);
    if (made) links_scale(&cc.links, 0.95);
    made = made && links_expand(&cc.links, &flat);
    RAD_CHECK(made);
    if (!made) {
        test_links_free(&flat);
        cube_free(&cc);
        return;
    }
    const size_t n = cc.leaves.patch_count;
    double *B[2] = {malloc(3 * n * sizeof(double)), malloc(3 * n * sizeof(double))};
    double *B_flat = malloc(3 * n * sizeof(double));
    for (int m = 0; m < 2; m++) {
        rad_lsolve_method method = m == 0 ? RAD_LSOLVE_JACOBI : RAD_LSOLVE_GAUSS_SEIDEL;
        rad_lsolve_result r, rf;
        RAD_CHECK(run_lsolve(&cc, method, 1e-14, 0, B[m], &r) == RAD_OK);
        rad_links clustered = cc.links;
        cc.links = flat; /* the expansion, solved and solved directly */
        RAD_CHECK(run_lsolve(&cc, method, 1e-14, 0, B_flat, &rf) == RAD_OK);
        double residual, dense = worst_against_dense(&cc, B_flat, &residual);
        cc.links = clustered;
        double worst = worst_relative(B[m], B_flat, 3 * n);
        printf("clusters, %s: %zu leaves, %u nodes, %u clusters, %llu links (%llu expanded): iterations %u (%u "
               "expanded), worst %.2g against the expansion (which is %.2g from the direct solve), imbalance %.2g\n",
               m == 0 ? "jacobi" : "gauss-seidel", n, cc.links.node_count, cc.links.cluster_count,
               (unsigned long long)cc.links.link_count, (unsigned long long)flat.link_count, r.iterations[0],
               rf.iterations[0], worst, dense, r.imbalance);
        RAD_CHECK(worst <= 1e-12);
        RAD_CHECK(dense <= 1e-10);
        for (int c = 0; c < 3; c++) RAD_CHECK(r.residual[c] <= 1e-14);
        RAD_CHECK(fabs(r.imbalance) <= 1e-12 && fabs(rf.imbalance) <= 1e-12);
        RAD_CHECK(r.emitted == rf.emitted);
        RAD_CHECK_REL(r.absorbed, rf.absorbed, 1e-12);
        RAD_CHECK_REL(r.escaped, rf.escaped, 1e-12);
    }
    RAD_CHECK(worst_relative(B[0], B[1], 3 * n) <= 1e-12); /* Jacobi and Gauss-Seidel agree */

    /* cluster tables the solve cannot index: refused, B untouched */
    rad_links *L = &cc.links;
    rad_lsolve_result r;
    B[0][0] = 42;
    rad_test_capture_log();
    L->cluster_roots[1] = L->cluster_roots[0];
    RAD_CHECK(run_lsolve(&cc, RAD_LSOLVE_JACOBI, 1e-9, 0, B[0], &r) == RAD_ERR_INVALID);
    RAD_CHECK(rad_test_log_contains("out of range or twice"));
    L->cluster_roots[1] = 2;
    L->clusters[4].root_begin = 5;
    RAD_CHECK(run_lsolve(&cc, RAD_LSOLVE_JACOBI, 1e-9, 0, B[0], &r) == RAD_ERR_INVALID);
    L->clusters[4].root_begin = 4;
    L->clusters[3].parent = 1;
    RAD_CHECK(run_lsolve(&cc, RAD_LSOLVE_JACOBI, 1e-9, 0, B[0], &r) == RAD_ERR_INVALID);
    L->clusters[3].parent = 2;
    const uint32_t source = L->links[0].source;
    L->links[0].source = (uint32_t)rad_links_id_count(L);
    RAD_CHECK(run_lsolve(&cc, RAD_LSOLVE_JACOBI, 1e-9, 0, B[0], &r) == RAD_ERR_INVALID);
    L->links[0].source = source;
    rad_log_set_sink(NULL, NULL);
    RAD_CHECK(B[0][0] == 42);
    RAD_CHECK(run_lsolve(&cc, RAD_LSOLVE_JACOBI, 1e-9, 0, B[0], &r) == RAD_OK); /* mended */

    free(B[0]);
    free(B[1]);
    free(B_flat);
    test_links_free(&flat);
    cube_free(&cc);
}

/* The closed cube's furnace with the two halves joined by cluster links
 * alone: halves 1 <-> 2 (a leaf cluster and an inner one), or half 1 with
 * each of 2's leaf clusters 3 and 4. Every leaf then gathers 1 (each face
 * sees the other half with F_opposite + 2 F_adjacent), so
 * B = 1 / (1 - rho), nothing escapes and the energy balances. */
static void test_cluster_furnace(void)
{
    static const int depth[FACES] = {2, 1, 2, 0, 2, 1};
    static const double rhos[2] = {0.5, 0.9};
    const double across = (CUBE_F_OPPOSITE + 2 * CUBE_F_ADJACENT) / 3; /* coupling of the halves (area 3 each) */
    for (int variant = 0; variant < 2; variant++)
        for (int k = 0; k < 2; k++) {
            double rho[FACES][3], emission[FACES][3];
            for (int f = 0; f < FACES; f++)
                for (int c = 0; c < 3; c++) rho[f][c] = rhos[k], emission[f][c] = 1;
            int kind[FACES][FACES];
            kinds_mixed(kind);
            cube_case cc;
            triple_list list = {0};
            int made = cube_make(&cc, depth, 1, rho, emission) && cube_clusters(&cc.links) &&
                       face_triples(&cc, kind, 1, cube_half, &list);
            const uint32_t n = cc.links.node_count;
            if (made && variant == 0) made = pair_add(&list, &cc.links, n + 1, n + 2, across);
            if (made && variant == 1)
                made = pair_add(&list, &cc.links, n + 1, n + 3, across) &&
                       pair_add(&list, &cc.links, n + 1, n + 4, across);
            made = made && links_set(&cc.links, list.t, list.count);
            free(list.t);
            RAD_CHECK(made);
            if (!made) {
                cube_free(&cc);
                return;
            }
            const size_t count = cc.leaves.patch_count;
            double *B = malloc(3 * count * sizeof *B);
            for (int m = 0; m < 2; m++) {
                rad_lsolve_method method = m == 0 ? RAD_LSOLVE_JACOBI : RAD_LSOLVE_GAUSS_SEIDEL;
                rad_lsolve_result r;
                RAD_CHECK(run_lsolve(&cc, method, 1e-11, 0, B, &r) == RAD_OK);
                double worst = 0;
                for (size_t l = 0; l < 3 * count; l++) worst = fmax(worst, fabs(B[l] * (1 - rhos[k]) - 1));
                printf("furnace with clusters %s, rho %g, %s: %u iterations, worst %.2g, imbalance %.2g, escaped %.2g "
                       "of emitted\n",
                       variant == 0 ? "1 <-> 2" : "1 <-> 3, 4", rhos[k], m == 0 ? "jacobi" : "gauss-seidel",
                       r.iterations[0], worst, r.imbalance, r.escaped / r.emitted);
                RAD_CHECK(worst <= 1e-9);
                RAD_CHECK(fabs(r.imbalance) <= 1e-9);
                RAD_CHECK(fabs(r.escaped) <= 1e-9 * r.emitted);
                RAD_CHECK_REL(r.emitted, 3.0 * 6, 1e-12);
            }
            free(B);
            cube_free(&cc);
        }
}

/* 1 and 2 threads with clusters: the same bytes, both methods. Depth 5,
 * links at mixed levels inside each half, every leaf linked with clusters
 * 0, 1 and 2 (18,432 links at clusters: their gathers run in parallel). */
static void test_cluster_threads(void)
{
    static const int depth5[FACES] = {5, 5, 5, 5, 5, 5};
    double rho[FACES][3], emission[FACES][3];
    rgb_materials(rho, emission);
    int kind[FACES][FACES];
    kinds_mixed(kind);
    cube_case cc;
    triple_list list = {0};
    int made = cube_make(&cc, depth5, 0, rho, emission) && cube_clusters(&cc.links) &&
               face_triples(&cc, kind, 0, cube_half, &list) && cluster_triples(&cc.links, 0.01, 1, &list) &&
               links_set(&cc.links, list.t, list.count);
    free(list.t);
    RAD_CHECK(made);
    if (!made) {
        cube_free(&cc);
        return;
    }
    links_scale(&cc.links, 0.95);
    const uint32_t nodes = cc.links.node_count;
    RAD_CHECK(cc.links.first_link[nodes + 5] - cc.links.first_link[nodes] >= 16384);
    threads_identical(&cc, "threads with clusters", 1e-8);
    cube_free(&cc);
}

int main(void)
{
    test_push_pull_by_hand();
    test_leaf_links();
    test_mixed_links();
    test_furnace();
    test_threads();
    test_groups();
    test_edges();
    test_cluster_links();
    test_cluster_furnace();
    test_cluster_threads();
    return rad_test_finish();
}
