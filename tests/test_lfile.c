/* test_lfile.c - the form-factor file's links layout (hierarchical
 * radiosity, rad_ff_write_links / rad_ff_read_links) and rad_links_check.
 *
 * A small hierarchy built by hand: two unit quads facing each other (the
 * floor z = 0, the light z = 1), each split once (2 roots + 8 children,
 * 18 vertices), whose 8 children are the leaves mesh's patches (the
 * light's in reverse order, so that node.leaf is no identity), with
 * symmetric links between roots, children and both. Written, read back
 * field by field, rewritten byte for byte; then every truncation and every
 * single-byte change of the file (three XOR patterns at every offset) is
 * refused by rad_ff_open + rad_ff_read_links with RAD_ERR_FORMAT or
 * RAD_ERR_IO and a message naming the file: every byte lies under a
 * checksum. Damage behind valid checksums (a file resealed after an edit)
 * is refused by the structural checks; rad_links_check refuses each kind
 * of structural fault; a matrix file and a links file refuse each
 * other's reader.
 *
 * Clusters (issue 27, version 5): a strip of 5 plates (5 roots, the first
 * split once: 9 nodes, 8 leaves, 25 vertices) under a cluster tree of 5
 * clusters (0 over {1, 2}, 2 over {3, 4}; the roots in the order 3 0 4 1 2),
 * with links at and from clusters. The same round trip, damage and
 * structural checks; without clusters the file stays version 4, the very
 * bytes of the seed below.
 *
 *     test_lfile [KEEP [SEED [KEEP_CLUSTERS]]]
 * KEEP: where to leave a copy of the valid file (the tools' and solve's
 * tests read it); SEED: a links file that must read as valid and equal
 * KEEP byte for byte (the fuzz regressions' seed,
 * tests/fuzz/regressions/ffile/links-small); KEEP_CLUSTERS: where to
 * leave the valid file with clusters.
 */
#define _POSIX_C_SOURCE 200809L
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "rad_bytes.h"
#include "rad_ffile.h"
#include "rad_hash.h"
#include "rad_lfile.h"
#include "rad_links.h"
#include "rad_test.h"

#define NODES 10u
#define ROOTS 2u
#define LEAVES 8u
#define VERTICES 18u

static double positions[3 * VERTICES];
static rad_patch patches[LEAVES];
static char group_names[2][RAD_NAME_MAX] = {"floor", "light"};
static uint32_t patch_group[LEAVES] = {0, 0, 0, 0, 1, 1, 1, 1};

/* Grid vertex (i, j) of plate p (0: the floor, 1: the light), i, j in 0..2. */
static uint32_t grid(uint32_t p, uint32_t i, uint32_t j) { return 9 * p + 3 * j + i; }

/* The corners of cell (ci, cj) of plate p (size s = 1: the cell; 2: the
 * whole plate from (0, 0)), wound up for the floor and down for the light. */
static void corners(uint32_t p, uint32_t ci, uint32_t cj, uint32_t s, uint32_t v[4])
{
    uint32_t ring[4] = {grid(p, ci, cj), grid(p, ci + s, cj), grid(p, ci + s, cj + s), grid(p, ci, cj + s)};
    for (int k = 0; k < 4; k++) v[k] = p == 0 ? ring[k] : ring[3 - k];
}

/* Node 2 + 4 p + k is child k of root p (cell k % 2, k / 2); its leaf. */
static uint32_t leaf_of(uint32_t p, uint32_t k) { return p == 0 ? k : 4 + (3 - k); }

static rad_mesh leaves_mesh(void)
{
    for (uint32_t p = 0; p < 2; p++)
        for (uint32_t j = 0; j < 3; j++)
            for (uint32_t i = 0; i < 3; i++) {
                double *x = &positions[3 * grid(p, i, j)];
                x[0] = 0.5 * i, x[1] = 0.5 * j, x[2] = p;
            }
    memset(patches, 0, sizeof patches);
    for (uint32_t p = 0; p < 2; p++)
        for (uint32_t k = 0; k < 4; k++) {
            rad_patch *q = &patches[leaf_of(p, k)];
            q->vertex_count = 4;
            corners(p, k % 2, k / 2, 1, q->v);
            q->source_face = p;
            q->area = 0.25;
            q->normal = rad_v3(0, 0, p == 0 ? 1 : -1);
            q->centroid = rad_v3(0.25 + 0.5 * (k % 2), 0.25 + 0.5 * (k / 2), p);
            for (int c = 0; c < 3; c++) {
                q->rho[c] = p == 0 ? 0.5 + 0.125 * c : 0.25;
                q->emission[c] = p == 1 ? 1.0 + c : 0.0;
            }
        }
    return (rad_mesh){.positions = positions, .vertex_count = VERTICES, .patches = patches,
                      .patch_count = LEAVES, .group_names = group_names, .group_count = 2,
                      .patch_group = patch_group};
}

/* A symmetric coupling between ids a and b: F_ab = c A_b, F_ba = c A_a. */
typedef struct coupling {
    uint32_t a, b;
    double c;
} coupling;

static double id_area(const rad_links *l, uint32_t id)
{
    return id < l->node_count ? l->nodes[id].area : l->clusters[id - l->node_count].area;
}

/* l's first_link and links from `count` couplings: CSR by receiver,
 * sources ascending; each link's error from its place in the list. */
static void fill_links(rad_links *l, const coupling *couplings, size_t count)
{
    uint64_t ids = rad_links_id_count(l);
    l->link_count = 2 * count;
    l->first_link = calloc(ids + 1, sizeof *l->first_link);
    l->links = calloc(2 * count, sizeof *l->links);
    if (!l->first_link || !l->links) abort();
    uint64_t at = 0;
    for (uint32_t r = 0; r < ids; r++) {
        l->first_link[r] = at;
        for (uint32_t s = 0; s < ids; s++)
            for (size_t k = 0; k < 2 * count; k++) {
                const coupling *c = &couplings[k / 2];
                uint32_t receiver = k % 2 ? c->b : c->a, source = k % 2 ? c->a : c->b;
                if (receiver == r && source == s)
                    l->links[at++] = (rad_link){.source = s, .error = (float)(1e-3 * (k + 1)),
                                                .factor = c->c * id_area(l, s)};
            }
    }
    l->first_link[ids] = at;
}

/* Symmetric couplings (r, s, c): F_rs = c A_s and F_sr = c A_r. */
static const coupling pairs[] = {
    {0, 1, 0.2}, {2, 6, 0.3}, {2, 7, 0.1}, {3, 8, 0.25}, {4, 1, 0.05}, {5, 9, 0.15}, {0, 9, 0.02},
};
#define PAIRS (sizeof pairs / sizeof pairs[0])

static rad_links make_links(void)
{
    rad_links l = {.node_count = NODES, .root_count = ROOTS, .leaf_count = LEAVES,
                   .link_tol = 0.0625, .error_bound = 1.5e-3};
    l.nodes = calloc(NODES, sizeof *l.nodes);
    if (!l.nodes) abort();
    for (uint32_t p = 0; p < ROOTS; p++) {
        rad_link_node *root = &l.nodes[p];
        *root = (rad_link_node){.parent = RAD_NO_ELEMENT, .first_child = 2 + 4 * p, .leaf = RAD_NO_ELEMENT,
                                .root = p, .level = 0, .vertex_count = 4, .area = 1.0};
        corners(p, 0, 0, 2, root->v);
        for (uint32_t k = 0; k < 4; k++) {
            rad_link_node *child = &l.nodes[2 + 4 * p + k];
            *child = (rad_link_node){.parent = p, .first_child = RAD_NO_ELEMENT, .leaf = leaf_of(p, k), .root = p,
                                     .level = 1, .vertex_count = 4, .area = 0.25};
            corners(p, k % 2, k / 2, 1, child->v);
        }
    }
    fill_links(&l, pairs, PAIRS);
    return l;
}

/* ---- the strip with clusters ---- */

#define S_NODES 9u
#define S_ROOTS 5u
#define S_LEAVES 8u
#define S_VERTICES 25u
#define S_CLUSTERS 5u

static double s_positions[3 * S_VERTICES];
static rad_patch s_patches[S_LEAVES];
static char s_group_names[2][RAD_NAME_MAX] = {"wide", "narrow"};
static uint32_t s_patch_group[S_LEAVES] = {0, 0, 0, 0, 1, 1, 1, 1};

/* Plate p >= 1: x in [2p, 2p + 1], y in [0, its height]; plate 0 the unit
 * square, split into 4 cells (grid vertices 3 j + i). */
static double s_height(uint32_t p) { return 0.5 + 0.25 * p; }

/* The corners of plate p >= 1, or of cell (ci, cj) (s = 1) or the whole
 * (s = 2) of plate 0; counter-clockwise from +z. */
static void s_corners(uint32_t p, uint32_t ci, uint32_t cj, uint32_t s, uint32_t v[4])
{
    if (p == 0) {
        uint32_t ring[4] = {3 * cj + ci, 3 * cj + ci + s, 3 * (cj + s) + ci + s, 3 * (cj + s) + ci};
        memcpy(v, ring, sizeof ring);
    } else {
        for (uint32_t k = 0; k < 4; k++) v[k] = 9 + 4 * (p - 1) + k;
    }
}

static rad_mesh strip_mesh(void)
{
    for (uint32_t j = 0; j < 3; j++)
        for (uint32_t i = 0; i < 3; i++) {
            double *x = &s_positions[3 * (3 * j + i)];
            x[0] = 0.5 * i, x[1] = 0.5 * j, x[2] = 0;
        }
    for (uint32_t p = 1; p < S_ROOTS; p++) {
        const double corner[4][2] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
        for (uint32_t k = 0; k < 4; k++) {
            double *x = &s_positions[3 * (9 + 4 * (p - 1) + k)];
            x[0] = 2.0 * p + corner[k][0], x[1] = s_height(p) * corner[k][1], x[2] = 0;
        }
    }
    memset(s_patches, 0, sizeof s_patches);
    for (uint32_t k = 0; k < S_LEAVES; k++) {
        rad_patch *q = &s_patches[k];
        uint32_t p = k < 4 ? 0 : k - 3; /* patches 0-3: plate 0's cells; 4-7: plates 1-4 */
        q->vertex_count = 4;
        s_corners(p, k % 2, k / 2 % 2, 1, q->v);
        q->source_face = p;
        q->area = p == 0 ? 0.25 : s_height(p);
        q->normal = rad_v3(0, 0, 1);
        q->centroid = p == 0 ? rad_v3(0.25 + 0.5 * (k % 2), 0.25 + 0.5 * (k / 2), 0)
                             : rad_v3(2.0 * p + 0.5, 0.5 * s_height(p), 0);
        for (int c = 0; c < 3; c++) {
            q->rho[c] = 0.125 * (p + 1);
            q->emission[c] = p == 4 ? 2.0 : 0.0;
        }
    }
    return (rad_mesh){.positions = s_positions, .vertex_count = S_VERTICES, .patches = s_patches,
                      .patch_count = S_LEAVES, .group_names = s_group_names, .group_count = 2,
                      .patch_group = s_patch_group};
}

/* Ids 0-8 the nodes, 9-13 clusters 0-4: links between nodes, from nodes to
 * clusters, between clusters, and cluster 0 with a root inside it. */
static const coupling s_pairs[] = {
    {0, 1, 0.2}, {5, 10, 0.05}, {1, 12, 0.1}, {11, 10, 0.03}, {6, 13, 0.07}, {9, 4, 0.02}, {7, 8, 0.3}, {12, 13, 0.04},
};
#define S_PAIRS (sizeof s_pairs / sizeof s_pairs[0])

static rad_links make_strip_links(void)
{
    rad_links l = {.node_count = S_NODES, .root_count = S_ROOTS, .leaf_count = S_LEAVES,
                   .cluster_count = S_CLUSTERS, .link_tol = 0.125, .error_bound = 2.5e-3};
    l.nodes = calloc(S_NODES, sizeof *l.nodes);
    l.clusters = calloc(S_CLUSTERS, sizeof *l.clusters);
    l.cluster_roots = calloc(S_ROOTS, sizeof *l.cluster_roots);
    if (!l.nodes || !l.clusters || !l.cluster_roots) abort();
    for (uint32_t p = 0; p < S_ROOTS; p++) {
        rad_link_node *root = &l.nodes[p];
        *root = (rad_link_node){.parent = RAD_NO_ELEMENT, .first_child = p == 0 ? 5 : RAD_NO_ELEMENT,
                                .leaf = p == 0 ? RAD_NO_ELEMENT : 3 + p, .root = p, .level = 0, .vertex_count = 4,
                                .area = p == 0 ? 1.0 : s_height(p)};
        s_corners(p, 0, 0, 2, root->v);
    }
    for (uint32_t k = 0; k < 4; k++) {
        rad_link_node *child = &l.nodes[5 + k];
        *child = (rad_link_node){.parent = 0, .first_child = RAD_NO_ELEMENT, .leaf = k, .root = 0, .level = 1,
                                 .vertex_count = 4, .area = 0.25};
        s_corners(0, k % 2, k / 2, 1, child->v);
    }
    /* roots in cluster order 3 0 | 4 | 1 2: areas 1.25 + 1 | 1.5 | 0.75 + 1 */
    static const uint32_t order[S_ROOTS] = {3, 0, 4, 1, 2};
    memcpy(l.cluster_roots, order, sizeof order);
    const rad_link_cluster clusters[S_CLUSTERS] = {
        {.parent = RAD_NO_ELEMENT, .first_child = 1, .child_count = 2, .root_begin = 0, .root_end = 5, .area = 5.5},
        {.parent = 0, .first_child = RAD_NO_ELEMENT, .root_begin = 0, .root_end = 2, .area = 2.25},
        {.parent = 0, .first_child = 3, .child_count = 2, .root_begin = 2, .root_end = 5, .area = 3.25},
        {.parent = 2, .first_child = RAD_NO_ELEMENT, .root_begin = 2, .root_end = 3, .area = 1.5},
        {.parent = 2, .first_child = RAD_NO_ELEMENT, .root_begin = 3, .root_end = 5, .area = 1.75},
    };
    memcpy(l.clusters, clusters, sizeof clusters);
    fill_links(&l, s_pairs, S_PAIRS);
    return l;
}

static rad_ff_info strip_info(void)
{
    rad_ff_info info = {.patch_count = S_LEAVES, .vertex_count = S_VERTICES, .estimator = RAD_ESTIMATOR_QUADRATURE,
                        .shadow_rays = 8, .seed = 12, .scene_fingerprint = 0x5151, .flags = RAD_FF_FLAG_RECIPROCAL,
                        .group_count = 2, .layout = RAD_FF_LAYOUT_LINKS};
    strcpy(info.scene_name, "strip of plates");
    return info;
}

/* ---- both ---- */

static void *copy_of(const void *data, size_t size)
{
    void *copy = malloc(size ? size : 1);
    if (!copy) abort();
    if (size) memcpy(copy, data, size);
    return copy;
}

static rad_links copy_links(const rad_links *in)
{
    rad_links l = *in;
    uint64_t ids = rad_links_id_count(in);
    l.nodes = copy_of(in->nodes, in->node_count * sizeof *l.nodes);
    l.clusters = in->cluster_count ? copy_of(in->clusters, in->cluster_count * sizeof *l.clusters) : NULL;
    l.cluster_roots = in->cluster_count ? copy_of(in->cluster_roots, in->root_count * sizeof *l.cluster_roots) : NULL;
    l.first_link = copy_of(in->first_link, (ids + 1) * sizeof *l.first_link);
    l.links = copy_of(in->links, in->link_count * sizeof *l.links);
    return l;
}

static int same_links(const rad_links *a, const rad_links *b)
{
    uint64_t ids = rad_links_id_count(a);
    int clusters = a->cluster_count > 0;
    return a->node_count == b->node_count && a->root_count == b->root_count && a->leaf_count == b->leaf_count &&
           a->cluster_count == b->cluster_count && a->link_count == b->link_count &&
           memcmp(&a->link_tol, &b->link_tol, sizeof a->link_tol) == 0 &&
           memcmp(&a->error_bound, &b->error_bound, sizeof a->error_bound) == 0 &&
           memcmp(a->nodes, b->nodes, a->node_count * sizeof *a->nodes) == 0 &&
           (clusters ? b->clusters && b->cluster_roots &&
                           memcmp(a->clusters, b->clusters, a->cluster_count * sizeof *a->clusters) == 0 &&
                           memcmp(a->cluster_roots, b->cluster_roots, a->root_count * sizeof *a->cluster_roots) == 0
                     : !b->clusters && !b->cluster_roots) &&
           memcmp(a->first_link, b->first_link, (ids + 1) * sizeof *a->first_link) == 0 &&
           memcmp(a->links, b->links, a->link_count * sizeof *a->links) == 0;
}

static rad_ff_info links_info(void)
{
    rad_ff_info info = {.patch_count = LEAVES, .vertex_count = VERTICES, .estimator = RAD_ESTIMATOR_QUADRATURE,
                        .samples = 0, .shadow_rays = 16, .seed = 11, .scene_fingerprint = 0xabcdef, .subdiv = 1,
                        .flags = RAD_FF_FLAG_RECIPROCAL, .group_count = 2, .layout = RAD_FF_LAYOUT_LINKS};
    strcpy(info.scene_name, "two plates");
    return info;
}

/* Without echoing thousands of expected refusals to stderr. */
static void quiet_sink(rad_log_level level, const char *message, void *user)
{
    (void)level, (void)user;
    size_t used = strlen(rad_test_log);
    snprintf(rad_test_log + used, sizeof rad_test_log - used, "%s\n", message);
}

static void capture_quietly(void)
{
    rad_test_log[0] = 0;
    rad_log_set_sink(quiet_sink, NULL);
}

/* Opens `path` and reads its links: the status of the first step that
 * fails (RAD_OK: both succeeded, and *out holds the links). */
static rad_status open_and_read(const char *path, rad_links *out)
{
    rad_ff_file *ff = NULL;
    memset(out, 0, sizeof *out);
    rad_status st = rad_ff_open(path, &ff);
    if (st == RAD_OK) st = rad_ff_read_links(ff, out);
    rad_ff_close(ff);
    return st;
}

/* 1 if `path` is refused as damaged (FORMAT or IO) with a message naming it;
 * counts acceptances and unnamed refusals. */
static void expect_refused(const char *path, int *accepted, int *unnamed, int *other_status)
{
    rad_links got;
    capture_quietly();
    rad_status st = open_and_read(path, &got);
    if (st == RAD_OK) {
        (*accepted)++;
        rad_links_free(&got);
        return;
    }
    if (st != RAD_ERR_FORMAT && st != RAD_ERR_IO) (*other_status)++;
    if (!rad_test_log_contains(path)) (*unnamed)++;
}

/* Recomputes every checksum of a links file after an edit: sections and
 * blocks (each with its padding, as one run of bytes), their table's
 * digest, tables, header. */
static void reseal(unsigned char *bytes)
{
    rad_ff_info info = {.patch_count = rad_get_u64(bytes + 16), .vertex_count = rad_get_u64(bytes + 24),
                        .element_type = rad_get_u32(bytes + 32), .group_count = rad_get_u32(bytes + 232),
                        .layout = rad_get_u32(bytes + 236), .node_count = rad_get_u32(bytes + 192),
                        .root_count = rad_get_u32(bytes + 196), .link_count = rad_get_u64(bytes + 200),
                        .cluster_count = rad_get_u32(bytes + 8) >= 5 ? rad_get_u32(bytes + 188) : 0};
    rad_ff_layout l = rad_ff_layout_of(&info);
    uint64_t starts[6], count = 0; /* the sections' starts, then the checksum table's */
    starts[count++] = l.matrix_offset;
    if (info.cluster_count) starts[count++] = l.cluster_offset, starts[count++] = l.cluster_root_offset;
    starts[count++] = l.first_link_offset;
    starts[count++] = l.link_offset; /* one block of links here */
    starts[count] = l.row_checksum_offset;
    for (uint64_t k = 0; k < count; k++)
        rad_put_u64(bytes + l.row_checksum_offset + 8 * k,
                    rad_hash64(RAD_HASH_SEED, bytes + starts[k], (size_t)(starts[k + 1] - starts[k])));
    rad_put_u64(bytes + 112, rad_hash64(RAD_HASH_SEED, bytes + 256, (size_t)(l.matrix_offset - 256)));
    rad_put_u64(bytes + 120, rad_hash64(RAD_HASH_SEED, bytes + l.row_checksum_offset, (size_t)l.index_bytes));
    rad_put_u64(bytes + 248, rad_hash64(RAD_HASH_SEED, bytes, 248));
}

static void test_round_trip(const char *path, const rad_mesh *mesh, const rad_links *links)
{
    rad_ff_info info = links_info();
    RAD_CHECK(rad_ff_write_links(path, &info, mesh, links) == RAD_OK);
    rad_ff_file *ff = NULL;
    RAD_CHECK(rad_ff_open(path, &ff) == RAD_OK);
    if (!ff) return;
    const rad_ff_info *got = rad_ff_file_info(ff);
    const rad_ff_info kept = *got;
    RAD_CHECK(got->layout == RAD_FF_LAYOUT_LINKS && got->element_type == RAD_ELEMENT_F64);
    RAD_CHECK(got->patch_count == LEAVES && got->vertex_count == VERTICES && got->group_count == 2);
    RAD_CHECK(got->node_count == NODES && got->root_count == ROOTS && got->link_count == 2 * PAIRS);
    RAD_CHECK(got->link_tol == 0.0625 && got->error_bound == 1.5e-3);
    RAD_CHECK(got->estimator == RAD_ESTIMATOR_QUADRATURE && got->shadow_rays == 16 && got->seed == 11);
    RAD_CHECK(got->scene_fingerprint == 0xabcdef && got->subdiv == 1 && got->flags == RAD_FF_FLAG_RECIPROCAL);
    RAD_CHECK(strcmp(got->scene_name, "two plates") == 0 && got->matrix_bytes > 0);
    const rad_mesh *m = rad_ff_file_mesh(ff);
    RAD_CHECK(m->patch_count == LEAVES && memcmp(m->patches, patches, sizeof patches) == 0);
    RAD_CHECK(m->vertex_count == VERTICES && memcmp(m->positions, positions, sizeof positions) == 0);
    RAD_CHECK(m->group_count == 2 && memcmp(m->patch_group, patch_group, sizeof patch_group) == 0);
    rad_links back;
    RAD_CHECK(rad_ff_read_links(ff, &back) == RAD_OK && same_links(&back, links));
    rad_links_free(&back);
    RAD_CHECK(back.nodes == NULL && back.node_count == 0);
    /* read twice: the reader keeps nothing between calls */
    RAD_CHECK(rad_ff_read_links(ff, &back) == RAD_OK && same_links(&back, links));
    rad_links_free(&back);

    /* the matrix readers refuse it, with a message */
    capture_quietly();
    double row[LEAVES];
    RAD_CHECK(rad_ff_read_rows(ff, 0, 1, row) == RAD_ERR_INVALID && rad_test_log_contains("holds links, not a matrix"));
    unsigned char record[64];
    RAD_CHECK(rad_ff_read_records(ff, 0, 1, record) == RAD_ERR_INVALID);
    rad_log_set_sink(NULL, NULL);
    rad_ff_close(ff);

    /* the bytes: version 4, 64-byte aligned sections, the same on a rewrite */
    size_t size = 0, size2 = 0;
    unsigned char *bytes = rad_test_read_file(path, &size);
    RAD_CHECK(rad_ff_write_links("test_lfile.again", &info, mesh, links) == RAD_OK);
    unsigned char *again = rad_test_read_file("test_lfile.again", &size2);
    RAD_CHECK(bytes && again && size == size2 && memcmp(bytes, again, size) == 0);
    rad_ff_layout l = rad_ff_layout_of(&kept);
    RAD_CHECK(l.file_bytes == size);
    RAD_CHECK(l.matrix_offset % 64 == 0 && l.first_link_offset % 64 == 0 && l.link_offset % 64 == 0 &&
              l.row_checksum_offset % 64 == 0);
    RAD_CHECK(l.first_link_offset - l.matrix_offset == 512 && l.link_offset - l.first_link_offset == 128);
    RAD_CHECK(l.index_bytes == 3 * 8 && size == l.row_checksum_offset + 24);
    if (bytes) RAD_CHECK(rad_get_u32(bytes + 8) == RAD_FF_VERSION_LINKS && rad_get_u32(bytes + 236) == 2);
    free(bytes);
    free(again);
    remove("test_lfile.again");
}

/* An edit behind valid checksums: `bits` at `offset` (wide: the high word
 * of the double there), and what the refusal must say. */
typedef struct edit {
    uint64_t offset;
    uint32_t bits;
    int wide;
    const char *message;
} edit;

/* Every truncation, single-byte change and trailing bytes of `path`
 * refused; then each edit, resealed, refused with its message; the
 * unedited bytes, resealed, read. */
static void test_damage(const char *path, const edit *edits, size_t edit_count)
{
    /* The 11,000 damaged copies go to a folder in /dev/shm where there is
     * one: on a busy disk they take half a minute, in memory half a second. */
    char dir[64] = "", damaged[128];
    if (access("/dev/shm", W_OK) == 0) {
        snprintf(dir, sizeof dir, "/dev/shm/test_lfile.XXXXXX");
        if (!mkdtemp(dir)) dir[0] = 0;
    }
    snprintf(damaged, sizeof damaged, "%s%stest_lfile.damaged", dir, dir[0] ? "/" : "");
    size_t size = 0;
    unsigned char *bytes = rad_test_read_file(path, &size);
    RAD_CHECK(bytes != NULL);
    if (!bytes) {
        if (dir[0]) rmdir(dir);
        return;
    }
    int accepted = 0, unnamed = 0, other = 0;
    for (size_t len = 0; len < size; len++) {
        rad_test_write_file(damaged, bytes, len);
        expect_refused(damaged, &accepted, &unnamed, &other);
    }
    RAD_CHECK(accepted == 0 && unnamed == 0 && other == 0);
    fprintf(stderr, "links file: %zu truncations: %d accepted, %d unnamed, %d other statuses\n", size, accepted,
            unnamed, other);

    static const unsigned char patterns[] = {0x01, 0x80, 0xff};
    int flips = 0;
    accepted = unnamed = other = 0;
    for (size_t k = 0; k < size; k++)
        for (size_t p = 0; p < sizeof patterns; p++) {
            bytes[k] ^= patterns[p];
            rad_test_write_file(damaged, bytes, size);
            bytes[k] ^= patterns[p];
            expect_refused(damaged, &accepted, &unnamed, &other);
            flips++;
        }
    RAD_CHECK(accepted == 0 && unnamed == 0 && other == 0);
    fprintf(stderr, "links file: %d single-byte changes: %d accepted, %d unnamed, %d other statuses\n", flips,
            accepted, unnamed, other);

    unsigned char *longer = calloc(1, size + 64);
    if (longer) {
        memcpy(longer, bytes, size);
        rad_test_write_file(damaged, longer, size + 64);
        expect_refused(damaged, &accepted, &unnamed, &other);
        RAD_CHECK(accepted == 0 && rad_test_log_contains("trailing"));
        free(longer);
    }

    /* Behind valid checksums: each edit resealed, refused by the checks of
     * structure, counts or leaves, with the message asked for. */
    for (size_t e = 0; e < edit_count; e++) {
        unsigned char *copy = malloc(size);
        if (!copy) break;
        memcpy(copy, bytes, size);
        if (edits[e].wide)
            rad_put_u32(copy + edits[e].offset + 4, edits[e].bits); /* the high word of a double */
        else
            rad_put_u32(copy + edits[e].offset, edits[e].bits);
        if (edits[e].offset < RAD_FF_HEADER_BYTES) /* a header field: its own checksum */
            rad_put_u64(copy + 248, rad_hash64(RAD_HASH_SEED, copy, 248));
        else
            reseal(copy);
        rad_test_write_file(damaged, copy, size);
        accepted = unnamed = other = 0;
        expect_refused(damaged, &accepted, &unnamed, &other);
        RAD_CHECK(accepted == 0 && unnamed == 0 && other == 0);
        if (!rad_test_log_contains(edits[e].message)) {
            fprintf(stderr, "edit %zu: expected \"%s\", got: %s", e, edits[e].message, rad_test_log);
            RAD_CHECK(rad_test_log_contains(edits[e].message));
        }
        free(copy);
    }
    /* and the unedited bytes, resealed, still read */
    reseal(bytes);
    rad_test_write_file(damaged, bytes, size);
    rad_links back;
    RAD_CHECK(open_and_read(damaged, &back) == RAD_OK);
    rad_links_free(&back);
    free(bytes);
    remove(damaged);
    if (dir[0]) rmdir(dir);
    rad_log_set_sink(NULL, NULL);
}

/* rad_links_check refuses each kind of fault, naming it. */
static void test_check(const rad_links *good)
{
    RAD_CHECK(rad_links_check(good, VERTICES, "good") == RAD_OK);
    enum { BAD_PARENT, CHILD_FIRST, ROOT_MISSING, LEAF_TWICE, UNSORTED, NEGATIVE, NAN_ERROR, FIRST_LINK_DOWN,
           FIRST_LINK_END, CORNER, AREA, SOURCE, ROOTS_WRONG, LEVEL, KINDS };
    static const char *expect[KINDS] = {
        "bad: node 0: a child whose parent is another node",
        "bad: node 0: children not after their parent",
        "bad: node 1: no parent, but not among the roots",
        "bad: node 3: leaf's patch already the leaf of another node",
        "bad: node 0: link 1: sources not strictly ascending",
        "bad: node 1: link 3: factor not finite and >= 0",
        "bad: node 1: link 2: error not finite and >= 0",
        "bad: node 2: link 4: first_link decreases here or passes the link count",
        "bad: first_link runs from 0 to 13, not from 0 to the link count 14",
        "bad: node 5: a corner beyond the vertex table",
        "bad: node 9: area not finite and positive",
        "bad: node 5: link 8: source beyond the node table",
        "bad: node 2: a root with a parent",
        "bad: node 8: level is not its parent's + 1",
    };
    for (int kind = 0; kind < KINDS; kind++) {
        rad_links l = copy_links(good);
        switch (kind) {
        case BAD_PARENT: l.nodes[3].parent = 1; break;
        case CHILD_FIRST: l.nodes[0].first_child = 0; break;
        case ROOT_MISSING: l.root_count = 1; break;
        case LEAF_TWICE: l.nodes[3].leaf = l.nodes[2].leaf; break;
        case UNSORTED: {
            rad_link t = l.links[0];
            l.links[0] = l.links[1], l.links[1] = t;
            break;
        }
        case NEGATIVE: l.links[3].factor = -0.01; break;
        case NAN_ERROR: l.links[2].error = NAN; break;
        case FIRST_LINK_DOWN: l.first_link[3] = l.first_link[2] - 1; break;
        case FIRST_LINK_END: l.first_link[NODES] = 13; break;
        case CORNER: l.nodes[5].v[2] = VERTICES; break;
        case AREA: l.nodes[9].area = 0; break;
        case SOURCE: l.links[8].source = NODES; break;
        case ROOTS_WRONG: l.root_count = 3; break;
        case LEVEL: l.nodes[8].level = 2; break;
        }
        capture_quietly();
        rad_status st = rad_links_check(&l, VERTICES, "bad");
        RAD_CHECK(st == RAD_ERR_FORMAT);
        if (!rad_test_log_contains(expect[kind])) {
            fprintf(stderr, "kind %d: expected \"%s\", got: %s", kind, expect[kind], rad_test_log);
            RAD_CHECK(rad_test_log_contains(expect[kind]));
        }
        /* the writer refuses what a reader would, and writes nothing */
        rad_mesh mesh = leaves_mesh();
        rad_ff_info info = links_info();
        remove("test_lfile.refused");
        RAD_CHECK(rad_ff_write_links("test_lfile.refused", &info, &mesh, &l) == RAD_ERR_INVALID);
        RAD_CHECK(fopen("test_lfile.refused", "rb") == NULL);
        rad_links_free(&l);
    }
    rad_log_set_sink(NULL, NULL);
    rad_links zero;
    memset(&zero, 0, sizeof zero);
    rad_links_free(&zero); /* safe on zeroed */
    rad_links_free(NULL);
}

/* Each kind of file refuses the other kind's reader; the writer refuses a
 * mismatched leaves mesh or layout. */
static void test_kinds(const rad_mesh *mesh, const rad_links *links)
{
    rad_ff_info dense = {.patch_count = LEAVES, .vertex_count = VERTICES, .element_type = RAD_ELEMENT_F64,
                         .estimator = RAD_ESTIMATOR_MC, .samples = 8, .group_count = 2};
    double matrix[LEAVES * LEAVES] = {0};
    RAD_CHECK(rad_ff_write_serial("test_lfile.dense", &dense, mesh, matrix) == RAD_OK);
    rad_ff_file *ff = NULL;
    RAD_CHECK(rad_ff_open("test_lfile.dense", &ff) == RAD_OK);
    capture_quietly();
    rad_links out;
    if (ff) {
        RAD_CHECK(rad_ff_file_info(ff)->layout == RAD_FF_LAYOUT_DENSE);
        RAD_CHECK(rad_ff_read_links(ff, &out) == RAD_ERR_INVALID && out.nodes == NULL);
        RAD_CHECK(rad_test_log_contains("test_lfile.dense: holds a matrix, not links"));
    }
    rad_ff_close(ff);
    remove("test_lfile.dense");

    rad_ff_info info = links_info();
    info.layout = RAD_FF_LAYOUT_SPARSE;
    RAD_CHECK(rad_ff_write_links("test_lfile.refused", &info, mesh, links) == RAD_ERR_INVALID);
    info = links_info();
    RAD_CHECK(rad_ff_write_serial("test_lfile.refused", &info, mesh, matrix) == RAD_ERR_INVALID);
    rad_mesh fewer = *mesh;
    fewer.patch_count = LEAVES - 1;
    info.patch_count = LEAVES - 1;
    RAD_CHECK(rad_ff_write_links("test_lfile.refused", &info, &fewer, links) == RAD_ERR_INVALID);
    RAD_CHECK(fopen("test_lfile.refused", "rb") == NULL);
    rad_log_set_sink(NULL, NULL);
}

/* The two plates' file behind valid checksums. */
static void test_damage_plates(const char *path)
{
    rad_ff_info info = links_info();
    info.node_count = NODES, info.link_count = 2 * PAIRS, info.element_type = RAD_ELEMENT_F64;
    rad_ff_layout l = rad_ff_layout_of(&info);
    const edit edits[] = {
        {l.link_offset + 16 * 3 + 8, 0xbff00000u, 1, "link 3: factor not finite and >= 0"}, /* -1.0 */
        {l.link_offset + 16 * 5 + 4, 0x7fc00000u, 0, "link 5: error not finite and >= 0"},   /* NaN */
        {l.link_offset + 16 * 0, 10, 0, "node 0: link 0: source beyond the node table"},
        {l.matrix_offset + 48 * 3 + 0, 1, 0, "node 0: a child whose parent is another node"},
        {l.matrix_offset + 48 * 7 + 24, 2, 0, "node 7 (leaf, patch 6): corners differ from its patch's"},
        {l.first_link_offset + 8 * 10, 13, 0, "first_link runs from 0 to 13"},
        {192, 11, 0, "implausible sizes (11 nodes"},
        {196, 6, 0, "do not make trees of quadtrees"},
        {32, RAD_ELEMENT_F32, 0, "element type 1 in the links layout"},
        {8, 3, 0, "the links layout in a version-3 file"},
        /* version 5 reads a cluster count where version 4 has the name's bytes (zero here) */
        {8, 5, 0, "a version-5 links file without clusters"},
    };
    test_damage(path, edits, sizeof edits / sizeof edits[0]);
}

/* The strip with clusters: written as version 5 with the cluster count at
 * byte 188, sections in place, read back whole, the same bytes on a
 * rewrite; a changed byte of the cluster table, the cluster roots or the
 * roots' padding refused by its section's checksum; then the damage of
 * every byte and the edits behind valid checksums. */
static void test_clusters_file(const char *path, const rad_mesh *mesh, const rad_links *links)
{
    rad_ff_info info = strip_info();
    RAD_CHECK(rad_ff_write_links(path, &info, mesh, links) == RAD_OK);
    rad_ff_file *ff = NULL;
    RAD_CHECK(rad_ff_open(path, &ff) == RAD_OK);
    if (!ff) return;
    const rad_ff_info kept = *rad_ff_file_info(ff);
    RAD_CHECK(kept.layout == RAD_FF_LAYOUT_LINKS && kept.cluster_count == S_CLUSTERS);
    RAD_CHECK(kept.node_count == S_NODES && kept.root_count == S_ROOTS && kept.link_count == 2 * S_PAIRS);
    RAD_CHECK(kept.link_tol == 0.125 && kept.error_bound == 2.5e-3 && strcmp(kept.scene_name, "strip of plates") == 0);
    rad_links back;
    RAD_CHECK(rad_ff_read_links(ff, &back) == RAD_OK && same_links(&back, links));
    RAD_CHECK(rad_links_id_count(&back) == S_NODES + S_CLUSTERS);
    rad_links_free(&back);
    RAD_CHECK(back.clusters == NULL && back.cluster_roots == NULL && back.cluster_count == 0);
    rad_ff_close(ff);

    size_t size = 0, size2 = 0;
    unsigned char *bytes = rad_test_read_file(path, &size);
    RAD_CHECK(rad_ff_write_links("test_lfile.again", &info, mesh, links) == RAD_OK);
    unsigned char *again = rad_test_read_file("test_lfile.again", &size2);
    RAD_CHECK(bytes && again && size == size2 && memcmp(bytes, again, size) == 0);
    free(again);
    remove("test_lfile.again");
    rad_ff_layout l = rad_ff_layout_of(&kept);
    RAD_CHECK(l.file_bytes == size);
    /* nodes 9 x 48 = 432, clusters 5 x 32 = 160, roots 5 x 4 = 20, first_link 15 x 8 = 120: each to 64 */
    RAD_CHECK(l.cluster_offset == l.matrix_offset + 448 && l.cluster_root_offset == l.cluster_offset + 192 &&
              l.first_link_offset == l.cluster_root_offset + 64 && l.link_offset == l.first_link_offset + 128);
    RAD_CHECK(l.index_bytes == 5 * 8 && size == l.row_checksum_offset + 40);
    if (!bytes) return;
    RAD_CHECK(rad_get_u32(bytes + 8) == RAD_FF_VERSION_CLUSTERS && rad_get_u32(bytes + 188) == S_CLUSTERS);
    RAD_CHECK(rad_get_u32(bytes + 236) == RAD_FF_LAYOUT_LINKS);

    /* each section's checksum names it */
    const struct { uint64_t offset; const char *message; } flips[] = {
        {l.cluster_offset + 32 * 2 + 8, "cluster table: checksum mismatch"},
        {l.cluster_root_offset + 4 * 3, "cluster roots: checksum mismatch"},
        {l.cluster_root_offset + 4 * S_ROOTS + 1, "cluster roots: checksum mismatch"}, /* its padding */
        {l.first_link_offset + 8 * 12, "first_link table: checksum mismatch"},
    };
    for (size_t k = 0; k < sizeof flips / sizeof flips[0]; k++) {
        bytes[flips[k].offset] ^= 0x04;
        rad_test_write_file("test_lfile.flipped", bytes, size);
        bytes[flips[k].offset] ^= 0x04;
        capture_quietly();
        rad_links got;
        RAD_CHECK(open_and_read("test_lfile.flipped", &got) == RAD_ERR_FORMAT);
        RAD_CHECK(rad_test_log_contains("test_lfile.flipped") && rad_test_log_contains(flips[k].message));
        rad_log_set_sink(NULL, NULL);
    }
    remove("test_lfile.flipped");
    free(bytes);

    uint64_t c1_links = links->first_link[S_NODES + 1]; /* cluster 1's first link */
    const edit edits[] = {
        {l.cluster_offset + 32 * 3 + 0, 0, 0, "cluster 2: a child whose parent is another cluster"},
        {l.cluster_offset + 32 * 1 + 24, 0x40030000u, 1, "cluster 1: area 2.375 is not its roots' 2.25"},
        {l.cluster_offset + 32 * 4 + 20, 1, 0, "cluster 4: pad not zero"},
        {l.cluster_offset + 32 * 0 + 8, 1, 0, "cluster 0: an inner cluster with one child"},
        {l.cluster_root_offset + 4 * 4, 3, 0, "cluster roots: entry 4 (3): a root listed twice"},
        {l.cluster_root_offset + 4 * 1, 5, 0, "cluster roots: entry 1 (5): not a root"},
        {l.link_offset + 16 * c1_links, 14, 0, "source beyond the node and cluster tables"},
        {l.first_link_offset + 8 * (S_NODES + S_CLUSTERS), 15, 0, "first_link runs from 0 to 15"},
        {188, 0, 0, "a version-5 links file without clusters"},
        {188, 10, 0, "more clusters than a cluster tree over the roots has"},
        {188, 4, 0, "section offsets disagree"},
        {8, 4, 0, "section offsets disagree"}, /* read as version 4: no clusters, a shorter layout */
    };
    test_damage(path, edits, sizeof edits / sizeof edits[0]);
}

/* rad_links_check on clusters: the strip passes (and an area off by 1e-12
 * relative); each kind of fault is refused, naming it, and the writer
 * writes nothing for it. */
static void test_check_clusters(const rad_links *good, const rad_mesh *mesh)
{
    RAD_CHECK(rad_links_check(good, S_VERTICES, "good") == RAD_OK);
    rad_links near = copy_links(good);
    near.clusters[2].area *= 1 + 1e-12;
    RAD_CHECK(rad_links_check(&near, S_VERTICES, "near") == RAD_OK);
    rad_links_free(&near);
    enum { CHILD_PARENT, ROOT_TWICE, ROOT_BEYOND, SOURCE, AREA, ONE_CHILD, PAD, PARTITION, ROOT_PARENT, LEAF_CHILD,
           ORPHAN, UNSORTED, NEGATIVE, FIRST_LINK_END, TOO_MANY, ROOT_RANGE, KINDS };
    static const char *expect[KINDS] = {
        "bad: cluster 2: a child whose parent is another cluster",
        "bad: cluster roots: entry 4 (3): a root listed twice",
        "bad: cluster roots: entry 1 (5): not a root (beyond the root count)",
        "bad: cluster 3: link ", /* + "N: source beyond the node and cluster tables" */
        "bad: cluster 2: area 3.2500000325 is not its roots' 3.25",
        "bad: cluster 2: an inner cluster with one child (at least 2)",
        "bad: cluster 1: pad not zero",
        "bad: cluster 2: its children's root ranges do not partition its own in order",
        "bad: cluster 0: a parent, but cluster 0 is the tree's root",
        "bad: cluster 1: a leaf cluster (no children) with a first child",
        "bad: cluster 3: not among its parent's children",
        "bad: cluster 1: link ", /* + "N: sources not strictly ascending" */
        "bad: cluster 4: link ", /* + "N: factor not finite and >= 0" */
        "bad: first_link runs from 0 to 15, not from 0 to the link count 16",
        "bad: 10 clusters over 5 roots (9 nodes): implausible",
        "bad: cluster 0: not every root, but cluster 0 holds them all",
    };
    static const char *then[KINDS] = {[SOURCE] = "source beyond the node and cluster tables",
                                      [UNSORTED] = "sources not strictly ascending",
                                      [NEGATIVE] = "factor not finite and >= 0"};
    for (int kind = 0; kind < KINDS; kind++) {
        rad_links l = copy_links(good);
        uint64_t c1 = l.first_link[S_NODES + 1], c3 = l.first_link[S_NODES + 3], c4 = l.first_link[S_NODES + 4];
        switch (kind) {
        case CHILD_PARENT: l.clusters[3].parent = 0; break;
        case ROOT_TWICE: l.cluster_roots[4] = l.cluster_roots[0]; break;
        case ROOT_BEYOND: l.cluster_roots[1] = S_ROOTS; break;
        case SOURCE: l.links[c3].source = S_NODES + S_CLUSTERS; break;
        case AREA: l.clusters[2].area = 3.25 * (1 + 1e-8); break;
        case ONE_CHILD: l.clusters[2].child_count = 1; break;
        case PAD: l.clusters[1].pad = 7; break;
        case PARTITION: l.clusters[4].root_begin = 2; break;
        case ROOT_PARENT: l.clusters[0].parent = 1; break;
        case LEAF_CHILD: l.clusters[1].first_child = 3; break;
        case ORPHAN: /* cluster 2 a leaf cluster: 3 and 4 in no cluster's children */
            l.clusters[2].first_child = RAD_NO_ELEMENT, l.clusters[2].child_count = 0;
            break;
        case UNSORTED: {
            RAD_CHECK(l.first_link[S_NODES + 2] - c1 == 2);
            rad_link t = l.links[c1];
            l.links[c1] = l.links[c1 + 1], l.links[c1 + 1] = t;
            break;
        }
        case NEGATIVE: l.links[c4].factor = -1e-3; break;
        case FIRST_LINK_END: l.first_link[S_NODES + S_CLUSTERS] = 15; break;
        case TOO_MANY: l.cluster_count = 2 * S_ROOTS; break;
        case ROOT_RANGE: l.clusters[0].root_end = S_ROOTS - 1; break;
        }
        capture_quietly();
        RAD_CHECK(rad_links_check(&l, S_VERTICES, "bad") == RAD_ERR_FORMAT);
        if (!rad_test_log_contains(expect[kind]) || (then[kind] && !rad_test_log_contains(then[kind]))) {
            fprintf(stderr, "cluster kind %d: expected \"%s\"%s, got: %s", kind, expect[kind],
                    then[kind] ? then[kind] : "", rad_test_log);
            RAD_CHECK(0);
        }
        rad_ff_info info = strip_info();
        remove("test_lfile.refused");
        RAD_CHECK(rad_ff_write_links("test_lfile.refused", &info, mesh, &l) == RAD_ERR_INVALID);
        RAD_CHECK(fopen("test_lfile.refused", "rb") == NULL);
        rad_log_set_sink(NULL, NULL);
        rad_links_free(&l);
    }
}

/* The scene name: 63 bytes in a links file, 59 with clusters (the cluster
 * count takes the name field's last 4 bytes). */
static void test_long_names(const rad_mesh *plates, const rad_links *plain, const rad_mesh *strip,
                            const rad_links *clustered)
{
    for (int with_clusters = 0; with_clusters < 2; with_clusters++) {
        rad_ff_info info = with_clusters ? strip_info() : links_info();
        memset(info.scene_name, 'n', sizeof info.scene_name - 1);
        RAD_CHECK(rad_ff_write_links("test_lfile.named", &info, with_clusters ? strip : plates,
                                     with_clusters ? clustered : plain) == RAD_OK);
        rad_ff_file *ff = NULL;
        RAD_CHECK(rad_ff_open("test_lfile.named", &ff) == RAD_OK);
        if (ff) {
            size_t len = strlen(rad_ff_file_info(ff)->scene_name);
            RAD_CHECK(len == (with_clusters ? 59u : 63u));
            RAD_CHECK(rad_ff_file_info(ff)->cluster_count == (with_clusters ? S_CLUSTERS : 0));
            rad_links back;
            RAD_CHECK(rad_ff_read_links(ff, &back) == RAD_OK);
            rad_links_free(&back);
        }
        rad_ff_close(ff);
    }
    remove("test_lfile.named");
}

int main(int argc, char **argv)
{
    const char *keep = argc > 1 ? argv[1] : NULL, *seed = argc > 2 ? argv[2] : NULL;
    const char *keep_clusters = argc > 3 ? argv[3] : NULL;
    const char *path = "test_lfile.links", *clusters_path = "test_lfile.clusters";
    rad_mesh mesh = leaves_mesh();
    rad_links links = make_links();
    test_check(&links);
    test_round_trip(path, &mesh, &links);
    test_damage_plates(path);
    test_kinds(&mesh, &links);

    rad_mesh strip = strip_mesh();
    rad_links clustered = make_strip_links();
    test_check_clusters(&clustered, &strip);
    test_clusters_file(clusters_path, &strip, &clustered);
    test_long_names(&mesh, &links, &strip, &clustered);
    if (keep) {
        rad_ff_info info = links_info();
        RAD_CHECK(rad_ff_write_links(keep, &info, &mesh, &links) == RAD_OK);
    }
    if (seed) {
        /* valid, and what the writer writes today: version 4, byte for byte */
        rad_links back;
        RAD_CHECK(open_and_read(seed, &back) == RAD_OK);
        rad_links_free(&back);
        size_t size = 0, seed_size = 0;
        unsigned char *bytes = rad_test_read_file(path, &size), *seed_bytes = rad_test_read_file(seed, &seed_size);
        RAD_CHECK(bytes && seed_bytes && size == seed_size && memcmp(bytes, seed_bytes, size) == 0);
        free(bytes);
        free(seed_bytes);
    }
    if (keep_clusters) {
        rad_ff_info info = strip_info();
        RAD_CHECK(rad_ff_write_links(keep_clusters, &info, &strip, &clustered) == RAD_OK);
    }
    rad_links_free(&links);
    rad_links_free(&clustered);
    remove(path);
    remove(clusters_path);
    return rad_test_finish();
}
