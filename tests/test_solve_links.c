/* test_solve_links.c - solve on a file of links (solve/links.c), after
 * reading: two facing unit squares at distance 1, one split into 4, linked
 * at the roots; the radiosity file against the closed form, the stats, the
 * options that do not apply, the iteration limit, the refusal of
 * rho * row sum >= 1.
 *
 * usage: test_solve_links [DIR]   DIR receives the files (default: /tmp).
 */
#define _POSIX_C_SOURCE 200809L
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "links.h"
#include "rad_hierarchy.h"
#include "rad_polygon.h"
#include "rad_rfile.h"
#include "rad_test.h"

/* The form factor between unit squares facing each other at distance 1. */
#define SQUARES_F 0.19982489569838732

static char g_dir[900];

static const char *path_in_dir(const char *name)
{
    static char path[4][1024];
    static int next;
    char *p = path[next++ % 4];
    snprintf(p, sizeof path[0], "%s/%s", g_dir, name);
    return p;
}

typedef struct squares {
    rad_mesh base, leaves;
    rad_hierarchy h;
    rad_links links;
    rad_ff_info info;
} squares;

static void squares_free(squares *q)
{
    rad_hierarchy_free(&q->h);
    rad_mesh_free(&q->base);
    rad_mesh_free(&q->leaves);
    free(q->links.nodes);
    free(q->links.first_link);
    free(q->links.links);
}

/* Square A (z = 0, split into 4) and B (z = 1); rho and E per square and
 * channel; links A <-> B at the roots carrying `factor`. */
static int squares_make(squares *q, const double rho[2][3], const double emission[2][3], double factor)
{
    static const double corner[8][3] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0},
                                        {0, 0, 1}, {0, 1, 1}, {1, 1, 1}, {1, 0, 1}};
    memset(q, 0, sizeof *q);
    rad_mesh *m = &q->base;
    m->positions = malloc(sizeof corner);
    m->patches = calloc(2, sizeof *m->patches);
    if (!m->positions || !m->patches) return 0;
    memcpy(m->positions, corner, sizeof corner);
    m->vertex_count = 8, m->patch_count = 2;
    for (uint32_t f = 0; f < 2; f++) {
        rad_patch *p = &m->patches[f];
        rad_vec3 c[4];
        for (uint32_t k = 0; k < 4; k++) {
            p->v[k] = 4 * f + k;
            c[k] = rad_v3(corner[4 * f + k][0], corner[4 * f + k][1], corner[4 * f + k][2]);
        }
        p->vertex_count = 4;
        p->source_face = f;
        rad_polygon_geometry(c, 4, &p->area, &p->normal, &p->centroid);
        memcpy(p->rho, rho[f], sizeof p->rho);
        memcpy(p->emission, emission[f], sizeof p->emission);
    }
    if (rad_hierarchy_init(m, &q->h) != RAD_OK || rad_hierarchy_split_to(&q->h, 0, 1) != RAD_OK ||
        rad_hierarchy_leaves(&q->h, &q->leaves) != RAD_OK)
        return 0;
    /* nodes: the roots A, B; A's children 2..5 are leaves 0..3, B leaf 4 */
    rad_links *L = &q->links;
    L->node_count = 6, L->root_count = 2, L->leaf_count = 5;
    L->nodes = calloc(6, sizeof *L->nodes);
    L->first_link = calloc(7, sizeof *L->first_link);
    L->links = calloc(2, sizeof *L->links);
    if (!L->nodes || !L->first_link || !L->links) return 0;
    for (uint32_t i = 0; i < 6; i++) {
        const rad_element *e = &q->h.elements[i];
        rad_link_node *n = &L->nodes[i];
        n->parent = e->parent, n->first_child = e->first_child, n->root = e->root, n->level = e->level;
        n->vertex_count = e->vertex_count;
        memcpy(n->v, e->v, sizeof n->v);
        n->area = e->area;
        n->leaf = i == 0 ? RAD_NO_ELEMENT : i == 1 ? 4 : i - 2;
    }
    L->links[0] = (rad_link){.source = 1, .factor = factor}; /* A <- B */
    L->links[1] = (rad_link){.source = 0, .factor = factor}; /* B <- A */
    L->link_count = 2;
    L->first_link[1] = 1;
    for (int i = 2; i <= 6; i++) L->first_link[i] = 2;
    L->link_tol = 0.01;
    L->error_bound = 1e-3;
    q->info.scene_fingerprint = 0x1234abcdULL;
    q->info.flags = RAD_FF_FLAG_KE_RADIANCE;
    snprintf(q->info.scene_name, sizeof q->info.scene_name, "squares.obj");
    return 1;
}

static rad_status solve_squares(const squares *q, const solve_options *options)
{
    solve_links_input in = {.info = &q->info, .leaves = &q->leaves, .links = &q->links, .load_seconds = 0};
    return solve_links_solve(options, &in);
}

static int file_exists(const char *path)
{
    struct stat st;
    return stat(path, &st) == 0;
}

static void test_grey_and_rgb(void)
{
    const double F = SQUARES_F;
    for (int rgb = 0; rgb < 2; rgb++) {
        double rho[2][3], E[2][3];
        for (int c = 0; c < 3; c++) {
            rho[0][c] = 0.5 + (rgb ? 0.1 * c : 0), rho[1][c] = 0.8;
            E[0][c] = 1.0, E[1][c] = rgb ? 2.0 + c : 2.0;
        }
        squares q;
        int made = squares_make(&q, rho, E, F);
        RAD_CHECK(made);
        const char *out = path_in_dir(rgb ? "rgb.rad" : "grey.rad"), *stats = path_in_dir("links.json");
        remove(stats);
        solve_options o;
        memset(&o, 0, sizeof o);
        o.input = "squares.links";
        o.output = out;
        o.stats = stats;
        o.params.tolerance = 1e-13;
        RAD_CHECK(made && solve_squares(&q, &o) == RAD_OK);
        rad_radiosity r;
        RAD_CHECK(rad_rf_read(out, &r) == RAD_OK);
        RAD_CHECK(r.channel_count == (rgb ? 3u : 1u) && r.converged && r.mesh.patch_count == 5);
        RAD_CHECK(r.method == RAD_SOLVE_GAUSS_SEIDEL && r.tolerance == 1e-13);
        RAD_CHECK(r.scene_fingerprint == q.info.scene_fingerprint && (r.flags & RAD_RF_FLAG_KE_RADIANCE));
        RAD_CHECK(strcmp(r.scene_path, "squares.obj") == 0);
        for (int c = 0; c < 3 && r.radiosity; c++) {
            double a = (E[0][c] + rho[0][c] * F * E[1][c]) / (1 - rho[0][c] * rho[1][c] * F * F);
            double b = E[1][c] + rho[1][c] * F * a;
            for (int l = 0; l < 4; l++) RAD_CHECK_REL(r.radiosity[3 * l + c], a, 1e-12);
            RAD_CHECK_REL(r.radiosity[3 * 4 + c], b, 1e-12);
        }
        rad_radiosity_free(&r);
        size_t size = 0;
        char *json = (char *)rad_test_read_file(stats, &size);
        RAD_CHECK(json != NULL);
        if (json) {
            json = realloc(json, size + 1);
            json[size] = 0;
            RAD_CHECK(strstr(json, "\"nodes\": 6") && strstr(json, "\"leaves\": 5") && strstr(json, "\"links\": 2"));
            RAD_CHECK(strstr(json, "\"links_per_leaf\": 0.4") && strstr(json, "\"link_tol\": 0.01"));
            RAD_CHECK(strstr(json, "\"error_bound\": 0.001") && strstr(json, "\"balance\""));
            RAD_CHECK(strstr(json, rgb ? "\"channel\": \"blue\"" : "\"channel\": \"grey\""));
            RAD_CHECK(strstr(json, "\"method\": \"gauss-seidel\""));
            free(json);
        }
        squares_free(&q);
    }
}

static void test_refusals_and_limits(void)
{
    double rho[2][3] = {{0.5, 0.5, 0.5}, {0.9, 0.9, 0.9}}, E[2][3] = {{1, 1, 1}, {0, 0, 0}};
    squares q;
    RAD_CHECK(squares_make(&q, rho, E, SQUARES_F));
    const char *out = path_in_dir("refused.rad");
    solve_options o;
    memset(&o, 0, sizeof o);
    o.input = "squares.links";
    o.output = out;
    rad_test_capture_log();

    /* options that do not apply: nothing written */
    remove(out);
    o.params.method = SOLVE_CG;
    RAD_CHECK(solve_squares(&q, &o) == RAD_ERR_USAGE && rad_test_log_contains("--method gauss-seidel"));
    o.params.method = SOLVE_AUTO;
    o.errors = "ff.err";
    RAD_CHECK(solve_squares(&q, &o) == RAD_ERR_USAGE);
    o.errors = NULL;
    o.by_group = "groups.csv";
    RAD_CHECK(solve_squares(&q, &o) == RAD_ERR_USAGE);
    o.by_group = NULL;
    RAD_CHECK(!file_exists(out));

    /* the limit: written, marked unconverged */
    o.params.method = SOLVE_JACOBI;
    o.params.max_iterations = 2;
    RAD_CHECK(solve_squares(&q, &o) == RAD_ERR_NOT_CONVERGED);
    rad_radiosity r;
    RAD_CHECK(rad_rf_read(out, &r) == RAD_OK);
    RAD_CHECK(!r.converged && r.iterations[0] == 2 && r.method == RAD_SOLVE_JACOBI);
    rad_radiosity_free(&r);
    o.params.max_iterations = 0;
    remove(out);
    squares_free(&q);

    /* Leaves gathering more than 1 (coarse links near an element's edge):
     * a note, not a refusal as for a matrix's rows; the sweeps decide. */
    RAD_CHECK(squares_make(&q, rho, E, 1.2));
    rad_status st = solve_squares(&q, &o);
    RAD_CHECK(st == RAD_OK || st == RAD_ERR_NOT_CONVERGED);
    RAD_CHECK(rad_test_log_contains("gather more than 1.001 of their light"));
    RAD_CHECK(file_exists(out));
    remove(out);
    squares_free(&q);
    rad_log_set_sink(NULL, NULL);
}

int main(int argc, char **argv)
{
    snprintf(g_dir, sizeof g_dir, "%s", argc > 1 ? argv[1] : "/tmp/test_solve_links");
    mkdir(g_dir, 0777);
    test_grey_and_rgb();
    test_refusals_and_limits();
    return rad_test_finish();
}
