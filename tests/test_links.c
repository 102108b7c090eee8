/* test_links.c - formfactor/ff_links.h, hierarchical radiosity's links.
 *
 * Exactness at the form-factor level: at --link-tol 0 every pair is
 * refined to the finest level, so on a uniform hierarchy (the Cornell
 * box's faces, contacts kept, split to depth d) the links are the full
 * matrix of --subdiv d: one link per facing leaf pair, each the very
 * double the CPU backend computes for that entry (the elements' keys are
 * the leaves' patch indices). The links are the same bytes for 1 and 2
 * threads. Coarser tolerances make fewer links, all between facing
 * elements, in pairs that are reciprocal to the bit. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "ff_backend.h"
#include "ff_links.h"
#include "ff_rows.h"
#include "ff_setup.h"
#include "rad_mesh.h"
#include "rad_scene.h"
#include "rad_test.h"

typedef struct world {
    rad_scene scene;
    rad_mesh base;
    double centre[3];
    double *triangles;
    uint32_t *triangle_face, triangle_count;
} world;

static ff_setup world_setup(const world *w, int threads)
{
    double eps = ff_plane_eps(&w->base);
    ff_setup su = {.triangles = w->triangles, .triangle_face = w->triangle_face, .triangle_count = w->triangle_count,
                   .samples = 512, .shadow_rays = 32, .seed = 1, .estimator = RAD_ESTIMATOR_QUADRATURE,
                   .max_samples = 64 * 512, .errors = 1, .plane_eps = eps, .cull = 1,
                   .scene_convex = ff_scene_is_convex_enclosure(&w->scene, eps),
                   .cull_margin = ff_cull_margin(&w->base, w->centre, eps), .ray_delta = ff_ray_delta(&w->base),
                   .threads = threads};
    return su;
}

static int world_load(world *w)
{
    memset(w, 0, sizeof *w);
    rad_mesh_options mo = {.subdiv = 0, .contacts = RAD_MESH_CONTACTS_KEEP};
    if (rad_scene_load_default(&w->scene) != RAD_OK || rad_mesh_build(&w->scene, &mo, &w->base) != RAD_OK) return 0;
    ff_frame_centre(&w->base, w->centre);
    return ff_occluders_build(&w->scene, w->centre, &w->triangles, &w->triangle_face, &w->triangle_count) == RAD_OK;
}

static void world_free(world *w)
{
    free(w->triangles);
    free(w->triangle_face);
    rad_mesh_free(&w->base);
    rad_scene_free(&w->scene);
}

/* Links of the world at (tol, depth) on `threads` threads, one pass. */
static int make_links(const world *w, double tol, uint32_t depth, int threads, rad_links *out, rad_mesh *leaves)
{
    ff_setup su = world_setup(w, threads);
    void *state = NULL;
    if (ff_backend_cpu.create(&su, &state) != RAD_OK) return 0;
    ff_links L;
    ff_links_config config = {.link_tol = tol, .oracle = FF_ORACLE_ERROR, .max_level = depth, .min_area = 0};
    ff_counters counters = {0};
    int ok = ff_links_init(&L, &w->scene, &w->base, w->centre, &config, &ff_backend_cpu, state) == RAD_OK &&
             ff_links_refine(&L, NULL, &counters, NULL) == RAD_OK && ff_links_export(&L, out, leaves) == RAD_OK;
    ff_links_free(&L);
    ff_backend_cpu.destroy(state);
    return ok;
}

/* The full matrix of --subdiv depth (contacts kept) from the CPU backend. */
static double *full_matrix(const world *w, uint32_t depth, rad_mesh *mesh)
{
    rad_mesh_options mo = {.subdiv = (int)depth, .contacts = RAD_MESH_CONTACTS_KEEP};
    if (rad_mesh_build(&w->scene, &mo, mesh) != RAD_OK) return NULL;
    uint32_t n = (uint32_t)mesh->patch_count;
    rad_ff_patch *patches = NULL;
    if (ff_patches_build(&w->scene, mesh, w->centre, &patches) != RAD_OK) return NULL;
    ff_setup su = world_setup(w, 2);
    su.patches = patches;
    su.patch_count = n;
    void *state = NULL;
    double *f = malloc(sizeof(double) * n * n), *area = malloc(sizeof(double) * n);
    ff_counters c = {0};
    if (!f || !area || ff_backend_cpu.create(&su, &state) != RAD_OK ||
        ff_backend_cpu.compute_rows(state, 0, n, f, NULL, &c) != RAD_OK) {
        free(f);
        f = NULL;
    } else {
        for (uint32_t j = 0; j < n; j++) area[j] = patches[j].area;
        ff_rows_summary unused = {0};
        ff_rows_finish(area, n, 0, n, f, NULL, 1, &unused);
    }
    if (state) ff_backend_cpu.destroy(state);
    free(area);
    free(patches);
    return f;
}

static void test_exact(const world *w, uint32_t depth)
{
    rad_links links;
    rad_mesh leaves, mesh;
    RAD_CHECK(make_links(w, 0.0, depth, 2, &links, &leaves));
    double *F = full_matrix(w, depth, &mesh);
    RAD_CHECK(F != NULL);
    if (!F) return;
    uint32_t n = (uint32_t)mesh.patch_count;
    RAD_CHECK(leaves.patch_count == n && links.leaf_count == n);
    uint64_t nonzero = 0, differ = 0, not_leaf = 0;
    for (uint64_t k = 0; k < (uint64_t)n * n; k++) nonzero += F[k] != 0;
    for (uint32_t r = 0; r < links.node_count; r++)
        for (uint64_t k = links.first_link[r]; k < links.first_link[r + 1]; k++) {
            const rad_link *l = &links.links[k];
            uint32_t i = links.nodes[r].leaf, j = links.nodes[l->source].leaf;
            if (i == RAD_NO_ELEMENT || j == RAD_NO_ELEMENT) {
                not_leaf++;
                continue;
            }
            if (memcmp(&l->factor, &F[(size_t)i * n + j], sizeof(double)) != 0) {
                if (differ < 5)
                    fprintf(stderr, "depth %u: link %u <- %u: %.17g, matrix %.17g\n", depth, i, j, l->factor,
                            F[(size_t)i * n + j]);
                differ++;
            }
        }
    /* Zero entries may have links (pairs facing but hidden): count only non-zero ones. */
    uint64_t nonzero_links = 0;
    for (uint64_t k = 0; k < links.link_count; k++) nonzero_links += links.links[k].factor != 0;
    fprintf(stderr, "depth %u: %u leaves, %llu links, %llu non-zero entries\n", depth, n,
            (unsigned long long)links.link_count, (unsigned long long)nonzero);
    RAD_CHECK(not_leaf == 0);
    RAD_CHECK(differ == 0);
    RAD_CHECK(nonzero_links == nonzero);
    free(F);
    rad_mesh_free(&mesh);
    rad_mesh_free(&leaves);
    rad_links_free(&links);
}

/* 1 and 2 threads: the same nodes, links and leaves, byte for byte. */
static void test_threads(const world *w)
{
    rad_links a, b;
    rad_mesh la, lb;
    RAD_CHECK(make_links(w, 1e-3, 4, 1, &a, &la));
    RAD_CHECK(make_links(w, 1e-3, 4, 2, &b, &lb));
    RAD_CHECK(a.node_count == b.node_count && a.link_count == b.link_count);
    if (a.node_count != b.node_count || a.link_count != b.link_count) return;
    RAD_CHECK(memcmp(a.nodes, b.nodes, a.node_count * sizeof *a.nodes) == 0);
    RAD_CHECK(memcmp(a.first_link, b.first_link, (a.node_count + 1) * sizeof *a.first_link) == 0);
    RAD_CHECK(memcmp(a.links, b.links, a.link_count * sizeof *a.links) == 0);
    RAD_CHECK(la.vertex_count == lb.vertex_count &&
              memcmp(la.positions, lb.positions, 3 * la.vertex_count * sizeof(double)) == 0);
    /* Coarser than the leaves, reciprocal to the bit, errors present. */
    uint64_t coarse = 0, unmatched = 0;
    for (uint32_t r = 0; r < a.node_count; r++)
        for (uint64_t k = a.first_link[r]; k < a.first_link[r + 1]; k++) {
            const rad_link *l = &a.links[k];
            coarse += a.nodes[r].leaf == RAD_NO_ELEMENT || a.nodes[l->source].leaf == RAD_NO_ELEMENT;
            int found = 0;
            for (uint64_t m = a.first_link[l->source]; m < a.first_link[l->source + 1]; m++)
                if (a.links[m].source == r) {
                    double x = a.nodes[r].area * l->factor, y = a.nodes[l->source].area * a.links[m].factor;
                    found = fabs(x - y) <= 4e-16 * fmax(x, y) && l->error >= 0;
                }
            unmatched += !found;
        }
    fprintf(stderr, "tol 1e-3: %u nodes, %u leaves, %llu links, %llu above the leaves\n", a.node_count, a.leaf_count,
            (unsigned long long)a.link_count, (unsigned long long)coarse);
    RAD_CHECK(coarse > 0);
    RAD_CHECK(unmatched == 0);
    rad_links_free(&a);
    rad_links_free(&b);
    rad_mesh_free(&la);
    rad_mesh_free(&lb);
}

int main(void)
{
    world w;
    RAD_CHECK(world_load(&w));
    test_exact(&w, 1);
    test_exact(&w, 2);
    test_threads(&w);
    world_free(&w);
    return rad_test_finish();
}
