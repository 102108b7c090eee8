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
 *     test_lfile [KEEP [SEED]]
 * KEEP: where to leave a copy of the valid file (the tools' and solve's
 * tests read it); SEED: a links file that must read as valid (the fuzz
 * regressions' seed, tests/fuzz/regressions/ffile/links-small).
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

/* Symmetric couplings (r, s, c): F_rs = c A_s and F_sr = c A_r. */
static const struct { uint32_t a, b; double c; } pairs[] = {
    {0, 1, 0.2}, {2, 6, 0.3}, {2, 7, 0.1}, {3, 8, 0.25}, {4, 1, 0.05}, {5, 9, 0.15}, {0, 9, 0.02},
};
#define PAIRS (sizeof pairs / sizeof pairs[0])

static rad_links make_links(void)
{
    rad_links l = {.node_count = NODES, .root_count = ROOTS, .leaf_count = LEAVES, .link_count = 2 * PAIRS,
                   .link_tol = 0.0625, .error_bound = 1.5e-3};
    l.nodes = calloc(NODES, sizeof *l.nodes);
    l.first_link = calloc(NODES + 1, sizeof *l.first_link);
    l.links = calloc(2 * PAIRS, sizeof *l.links);
    if (!l.nodes || !l.first_link || !l.links) abort();
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
    /* CSR by receiver, sources ascending: count, place, then sort each row */
    uint32_t receiver[2 * PAIRS], source[2 * PAIRS];
    for (size_t k = 0; k < PAIRS; k++) {
        receiver[2 * k] = pairs[k].a, source[2 * k] = pairs[k].b;
        receiver[2 * k + 1] = pairs[k].b, source[2 * k + 1] = pairs[k].a;
    }
    uint64_t at = 0;
    for (uint32_t r = 0; r < NODES; r++) {
        l.first_link[r] = at;
        for (uint32_t s = 0; s < NODES; s++)
            for (size_t k = 0; k < 2 * PAIRS; k++)
                if (receiver[k] == r && source[k] == s)
                    l.links[at++] = (rad_link){.source = s, .error = (float)(1e-3 * (k + 1)),
                                               .factor = pairs[k / 2].c * l.nodes[s].area};
    }
    l.first_link[NODES] = at;
    return l;
}

static rad_links copy_links(const rad_links *in)
{
    rad_links l = *in;
    l.nodes = malloc(NODES * sizeof *l.nodes);
    l.first_link = malloc((NODES + 1) * sizeof *l.first_link);
    l.links = malloc(in->link_count * sizeof *l.links);
    if (!l.nodes || !l.first_link || !l.links) abort();
    memcpy(l.nodes, in->nodes, NODES * sizeof *l.nodes);
    memcpy(l.first_link, in->first_link, (NODES + 1) * sizeof *l.first_link);
    memcpy(l.links, in->links, in->link_count * sizeof *l.links);
    return l;
}

static int same_links(const rad_links *a, const rad_links *b)
{
    return a->node_count == b->node_count && a->root_count == b->root_count && a->leaf_count == b->leaf_count &&
           a->link_count == b->link_count && memcmp(&a->link_tol, &b->link_tol, sizeof a->link_tol) == 0 &&
           memcmp(&a->error_bound, &b->error_bound, sizeof a->error_bound) == 0 &&
           memcmp(a->nodes, b->nodes, a->node_count * sizeof *a->nodes) == 0 &&
           memcmp(a->first_link, b->first_link, (a->node_count + 1) * sizeof *a->first_link) == 0 &&
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
 * blocks, their table's digest, tables, header. */
static void reseal(unsigned char *bytes)
{
    rad_ff_info info = {.patch_count = rad_get_u64(bytes + 16), .vertex_count = rad_get_u64(bytes + 24),
                        .element_type = rad_get_u32(bytes + 32), .group_count = rad_get_u32(bytes + 232),
                        .layout = rad_get_u32(bytes + 236), .node_count = rad_get_u32(bytes + 192),
                        .root_count = rad_get_u32(bytes + 196), .link_count = rad_get_u64(bytes + 200)};
    rad_ff_layout l = rad_ff_layout_of(&info);
    uint64_t starts[] = {l.matrix_offset, l.first_link_offset, l.link_offset, l.row_checksum_offset};
    for (int k = 0; k < 3; k++) /* one block of links here */
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

static void test_damage(const char *path)
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
    rad_ff_info info = links_info();
    info.node_count = NODES, info.link_count = 2 * PAIRS, info.element_type = RAD_ELEMENT_F64;
    rad_ff_layout l = rad_ff_layout_of(&info);
    struct { uint64_t offset; uint32_t bits; int wide; const char *message; } edits[] = {
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
    };
    for (size_t e = 0; e < sizeof edits / sizeof edits[0]; e++) {
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

int main(int argc, char **argv)
{
    const char *keep = argc > 1 ? argv[1] : NULL, *seed = argc > 2 ? argv[2] : NULL;
    const char *path = "test_lfile.links";
    rad_mesh mesh = leaves_mesh();
    rad_links links = make_links();
    test_check(&links);
    test_round_trip(path, &mesh, &links);
    test_damage(path);
    test_kinds(&mesh, &links);
    if (keep) {
        rad_ff_info info = links_info();
        RAD_CHECK(rad_ff_write_links(keep, &info, &mesh, &links) == RAD_OK);
    }
    if (seed) {
        rad_links back;
        RAD_CHECK(open_and_read(seed, &back) == RAD_OK);
        rad_links_free(&back);
    }
    rad_links_free(&links);
    remove(path);
    return rad_test_finish();
}
