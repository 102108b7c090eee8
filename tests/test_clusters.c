/* test_clusters.c - the cluster tree above the faces and its link bounds
 * (formfactor/ff_clusters.h, issue 27).
 *
 * The bounds are checked against the exact unoccluded factor: from many
 * points of one cluster's faces to every face of the other (Lambert's
 * contour integral, rad_ff_point_polygon), the factor must lie within
 * [lo, hi] - for blobs of randomly oriented triangles, for flat walls of
 * many triangles and for a mix, at several distances. The estimate of a
 * flat wall's coupling must be close (it is exact up to the distance's
 * variation); the tree must keep rad_link_cluster's rules. A face's
 * openness (ff_openness.h) must be 1 in the open, near 0 under a plate
 * 1 cm above it and in between at the foot of a wall, the same for every
 * call, and a cluster holding both must count as mixed.
 *
 * `test_clusters gpu`: the CUDA backend's openness (ff_backend.openness,
 * the same ff_face_openness in a kernel) against the host's on that
 * scene: a face may differ by a ray (the device's sin and cos a few ulps
 * from the C library's can tip a ray that grazes an edge), at most 4 of
 * the 138 faces; 77 (skipped) without a GPU. */
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "ff_backend.h"
#include "ff_clusters.h"
#include "ff_openness.h"
#include "rad_test.h"

static uint64_t rng_state = 0x2545F4914F6CDD1Dull;
static double uniform(void)
{
    rng_state ^= rng_state << 13;
    rng_state ^= rng_state >> 7;
    rng_state ^= rng_state << 17;
    return (double)(rng_state >> 11) * 0x1.0p-53;
}

static rad_ff_patch triangle(rad_vec3 a, rad_vec3 b, rad_vec3 c, uint32_t face)
{
    rad_ff_patch p;
    memset(&p, 0, sizeof p);
    p.p[0] = a, p.p[1] = b, p.p[2] = c, p.p[3] = c;
    rad_vec3 n = rad_v3_cross(rad_v3_sub(b, a), rad_v3_sub(c, a));
    p.area = 0.5 * rad_v3_length(n);
    p.normal = rad_v3_normalize(n);
    p.split = 1, p.inv_split = 1, p.inv_rest = 0;
    p.centre = rad_v3_scale(rad_v3_add(a, rad_v3_add(b, c)), 1.0 / 3.0);
    p.radius = 0;
    for (int k = 0; k < 3; k++) p.radius = fmax(p.radius, rad_v3_length(rad_v3_sub(p.p[k], p.centre)));
    p.face = face;
    p.vertex_count = 3;
    return p;
}

/* count random triangles of size ~size in a ball of radius 1 around at */
static void blob(rad_ff_patch *out, int count, rad_vec3 at, double size)
{
    for (int k = 0; k < count; k++) {
        rad_vec3 c;
        do c = rad_v3(2 * uniform() - 1, 2 * uniform() - 1, 2 * uniform() - 1);
        while (rad_v3_dot(c, c) > 1);
        c = rad_v3_add(c, at);
        rad_vec3 v[3];
        for (int i = 0; i < 3; i++)
            v[i] = rad_v3_add(c, rad_v3(size * (uniform() - 0.5), size * (uniform() - 0.5), size * (uniform() - 0.5)));
        out[k] = triangle(v[0], v[1], v[2], (uint32_t)k);
    }
}

/* an n x n grid of square cells (2 triangles each) of side `side`, centred
 * at `at`, in the plane z = at.z, facing +z (up) or -z */
static int wall(rad_ff_patch *out, int n, rad_vec3 at, double side, int up)
{
    int m = 0;
    double h = side / n;
    for (int i = 0; i < n; i++)
        for (int j = 0; j < n; j++) {
            rad_vec3 a = rad_v3(at.x - side / 2 + i * h, at.y - side / 2 + j * h, at.z);
            rad_vec3 b = rad_v3_add(a, rad_v3(h, 0, 0)), c = rad_v3_add(a, rad_v3(h, h, 0)), d = rad_v3_add(a, rad_v3(0, h, 0));
            if (up) {
                out[m] = triangle(a, b, c, (uint32_t)m), m++;
                out[m] = triangle(a, c, d, (uint32_t)m), m++;
            } else {
                out[m] = triangle(a, c, b, (uint32_t)m), m++;
                out[m] = triangle(a, d, c, (uint32_t)m), m++;
            }
        }
    return m;
}

/* The exact factor from point x (normal n) to every face of s. */
static double point_to_all(rad_vec3 x, rad_vec3 n, const rad_ff_patch *s, int count)
{
    double f = 0;
    for (int k = 0; k < count; k++) f += rad_ff_point_polygon(x, n, &s[k]);
    return f;
}

/* Checks the tree's rules and returns its root bound. */
static ff_cluster_bound tree_bound(const rad_ff_patch *p, int count)
{
    ff_cluster_tree t;
    RAD_CHECK(ff_clusters_build(p, NULL, (uint32_t)count, RAD_PI, &t) == RAD_OK);
    unsigned char *seen = calloc((size_t)count, 1);
    for (uint32_t k = 0; k < t.root_count; k++) {
        RAD_CHECK(t.roots[k] < (uint32_t)count && !seen[t.roots[k]]);
        seen[t.roots[k]] = 1;
    }
    free(seen);
    RAD_CHECK(t.clusters[0].link.parent == RAD_NO_ELEMENT && t.clusters[0].link.root_begin == 0 &&
              t.clusters[0].link.root_end == (uint32_t)count);
    for (uint32_t c = 0; c < t.count; c++) {
        const rad_link_cluster *l = &t.clusters[c].link;
        double area = 0;
        for (uint32_t k = l->root_begin; k < l->root_end; k++) area += p[t.roots[k]].area;
        RAD_CHECK_REL(l->area, area, 1e-12);
        if (c > 0) RAD_CHECK(l->parent < c);
        if (l->child_count == 0) {
            RAD_CHECK(l->root_end - l->root_begin <= FF_CLUSTER_LEAF_ROOTS && l->first_child == RAD_NO_ELEMENT);
            continue;
        }
        RAD_CHECK(l->child_count == 2 && l->first_child > c);
        const rad_link_cluster *a = &t.clusters[l->first_child].link, *b = &t.clusters[l->first_child + 1].link;
        RAD_CHECK(a->parent == c && b->parent == c && a->root_begin == l->root_begin && a->root_end == b->root_begin &&
                  b->root_end == l->root_end);
        /* every vertex of every face within the bounding sphere, every normal within the cone */
        const ff_cluster_bound *bd = &t.clusters[c].bound;
        for (uint32_t k = l->root_begin; k < l->root_end; k++) {
            const rad_ff_patch *f = &p[t.roots[k]];
            for (int i = 0; i < 3; i++) RAD_CHECK(rad_v3_length(rad_v3_sub(f->p[i], bd->centre)) <= bd->radius);
            RAD_CHECK(acos(fmin(1.0, rad_v3_dot(f->normal, bd->axis))) <= bd->cone_angle);
        }
    }
    /* a root drawn by area: the first and last of the whole range */
    RAD_CHECK(ff_cluster_pick_in(t.clusters, t.roots, t.area_before, 0, 0.0) == t.roots[0]);
    RAD_CHECK(ff_cluster_pick_in(t.clusters, t.roots, t.area_before, 0, 1.0 - 1e-15) == t.roots[count - 1]);
    ff_cluster_bound b = t.clusters[0].bound;
    ff_clusters_free(&t);
    return b;
}

/* Every sampled point's factor within [lo, hi], both directions; returns
 * the exact cluster factor F_rs (area-weighted mean over r's points). */
static double check_bounds(const char *what, const rad_ff_patch *r, int nr, const rad_ff_patch *s, int ns,
                           double *estimate)
{
    ff_cluster_bound br = tree_bound(r, nr), bs = tree_bound(s, ns);
    ff_cluster_pair_bound pb = ff_cluster_pair_estimate(&br, &bs);
    RAD_CHECK(pb.facing);
    int outside = 0;
    double sum = 0, area = 0;
    for (int side = 0; side < 2; side++) {
        const rad_ff_patch *from = side ? s : r, *to = side ? r : s;
        int nf = side ? ns : nr, nt = side ? nr : ns;
        double lo = side ? pb.lo_sr : pb.lo_rs, hi = side ? pb.hi_sr : pb.hi_rs;
        for (int k = 0; k < nf; k++)
            for (int m = 0; m < 16; m++) {
                rad_vec3 x = rad_ff_sample_point(&from[k], uniform(), uniform());
                double f = point_to_all(x, from[k].normal, to, nt);
                if (f < lo * (1 - 1e-12) || f > hi * (1 + 1e-12)) {
                    if (outside++ < 3)
                        fprintf(stderr, "%s: a point's factor %.6g outside [%.6g, %.6g] (side %d)\n", what, f, lo, hi,
                                side);
                }
                if (!side) sum += from[k].area * f, area += from[k].area;
            }
    }
    RAD_CHECK(outside == 0);
    *estimate = pb.coupling * bs.area;
    return sum / area;
}

/* A floor of 8 x 8 cells (4 x 4, facing up), a plate 1 cm above its
 * middle (1 x 1, facing down) and a wall along its x = 2 edge (2 high,
 * facing -x): the floor's openness under the plate, at the wall and in
 * the open. */
enum { FLOOR = 128, COUNT = FLOOR + 2 + 8 };

/* The scene: its faces, and their triangles as occluders. */
static void openness_scene(rad_ff_patch p[COUNT], double tri[9 * COUNT], uint32_t face[COUNT])
{
    int n = wall(p, 8, rad_v3(0, 0, 0), 4.0, 1);
    rad_vec3 a = rad_v3(-0.5, -0.5, 0.01), b = rad_v3(0.5, -0.5, 0.01), c = rad_v3(0.5, 0.5, 0.01), d = rad_v3(-0.5, 0.5, 0.01);
    p[n] = triangle(a, c, b, (uint32_t)n), n++;
    p[n] = triangle(a, d, c, (uint32_t)n), n++;
    for (int k = 0; k < 4; k++) { /* the wall: 4 cells along y, facing -x */
        rad_vec3 w0 = rad_v3(2, -2 + k, 0), w1 = rad_v3(2, -1 + k, 0), w2 = rad_v3(2, -1 + k, 2), w3 = rad_v3(2, -2 + k, 2);
        p[n] = triangle(w0, w2, w1, (uint32_t)n), n++;
        p[n] = triangle(w0, w3, w2, (uint32_t)n), n++;
    }
    RAD_CHECK(n == COUNT);
    for (int k = 0; k < n; k++) {
        for (int i = 0; i < 3; i++) {
            tri[9 * k + 3 * i] = p[k].p[i].x, tri[9 * k + 3 * i + 1] = p[k].p[i].y, tri[9 * k + 3 * i + 2] = p[k].p[i].z;
        }
        face[k] = p[k].face;
    }
}

static void check_openness(void)
{
    rad_ff_patch p[COUNT];
    double tri[9 * COUNT];
    uint32_t face[COUNT];
    openness_scene(p, tri, face);
    float open[COUNT], again[COUNT];
    RAD_CHECK(ff_openness(p, COUNT, tri, face, COUNT, 1e-9, open) == RAD_OK);
    RAD_CHECK(ff_openness(p, COUNT, tri, face, COUNT, 1e-9, again) == RAD_OK);
    RAD_CHECK(memcmp(open, again, sizeof open) == 0);
    int under = 0, at_wall = 0, free_cells = 0;
    for (int k = 0; k < FLOOR; k++) {
        rad_vec3 m = p[k].centre;
        if (fabs(m.x) < 0.5 && fabs(m.y) < 0.5) { /* under the plate */
            RAD_CHECK(open[k] <= 0.1f); /* 2 of 32 rays at most, from points near its edge */
            under++;
        } else if (m.x > 1.5) { /* the cells at the wall's foot */
            RAD_CHECK(open[k] > 0.3f && open[k] < 0.9f);
            at_wall++;
        } else if (m.x < 0 && (m.x < -1.0 || fabs(m.y) > 1.0)) { /* far from the plate's and the wall's reach */
            RAD_CHECK(open[k] == 1.0f);
            free_cells++;
        }
    }
    RAD_CHECK(under == 8 && at_wall == 16 && free_cells > 20);
    ff_cluster_tree t;
    RAD_CHECK(ff_clusters_build(p, open, FLOOR, RAD_PI, &t) == RAD_OK);
    const ff_cluster_bound *root = &t.clusters[0].bound;
    RAD_CHECK(root->open_lo <= 0.1f && root->open_hi == 1.0f);
    RAD_CHECK(ff_cluster_bound_mixed(root, RAD_PI, 0.6) && !ff_cluster_bound_mixed(root, RAD_PI, 1.0));
    ff_clusters_free(&t);
    RAD_CHECK(ff_clusters_build(p, NULL, FLOOR, RAD_PI, &t) == RAD_OK); /* no openness: nothing mixed by it */
    RAD_CHECK(t.clusters[0].bound.open_lo == 1.0f && !ff_cluster_bound_mixed(&t.clusters[0].bound, RAD_PI, 0.0));
    ff_clusters_free(&t);
}

/* The CUDA backend's openness against the host's; 77 without a GPU. */
static int check_openness_gpu(void)
{
    rad_ff_patch p[COUNT];
    double tri[9 * COUNT];
    uint32_t face[COUNT];
    openness_scene(p, tri, face);
    const ff_setup setup = {.patches = p, .patch_count = COUNT, .triangles = tri, .triangle_face = face,
                            .triangle_count = COUNT, .samples = 1, .ray_delta = 1e-9};
    void *state = NULL;
    if (ff_backend_cuda.create(&setup, &state) != RAD_OK) return 77;
    float host[COUNT], device[COUNT];
    for (int k = 0; k < COUNT; k++) device[k] = -1.0f;
    RAD_CHECK(ff_backend_cuda.openness != NULL);
    RAD_CHECK(ff_openness(p, COUNT, tri, face, COUNT, 1e-9, host) == RAD_OK);
    RAD_CHECK(ff_backend_cuda.openness &&
              ff_backend_cuda.openness(state, p, COUNT, ff_openness_reach(p, COUNT), device) == RAD_OK);
    int differ = 0;
    for (int k = 0; k < COUNT; k++) {
        RAD_CHECK(fabsf(host[k] - device[k]) <= 1.0f / FF_OPEN_RAYS);
        differ += host[k] != device[k];
    }
    RAD_CHECK(differ <= 4);
    ff_backend_cuda.destroy(state);
    return rad_test_finish();
}

int main(int argc, char **argv)
{
    if (argc > 1 && strcmp(argv[1], "gpu") == 0) return check_openness_gpu();
    check_openness();
    enum { N = 48 };
    rad_ff_patch r[2 * 8 * 8], s[2 * 8 * 8];
    double est, exact;
    /* blobs of random triangles, from touching distance out */
    const double distances[] = {2.6, 4, 8, 20};
    for (size_t d = 0; d < sizeof distances / sizeof *distances; d++) {
        blob(r, N, rad_v3(0, 0, 0), 0.4);
        blob(s, N, rad_v3(distances[d], 0.3, -0.2), 0.4);
        exact = check_bounds("blobs", r, N, s, N, &est);
        /* random orientations: the estimate is the middle of the range, within 3x at worst far away */
        if (distances[d] >= 8) RAD_CHECK(est < 3 * exact && exact < 3 * est);
    }
    /* flat walls of 128 triangles facing each other: the estimate is the
     * polygon's, exact but for the distance over the walls */
    int nr = wall(r, 8, rad_v3(0, 0, 0), 1.0, 1), ns = wall(s, 8, rad_v3(0.2, 0.1, 10), 1.0, 0);
    exact = check_bounds("walls", r, nr, s, ns, &est);
    RAD_CHECK_REL(est, exact, 0.01);
    nr = wall(r, 8, rad_v3(0, 0, 0), 1.0, 1);
    ns = wall(s, 8, rad_v3(3, 0, 2.5), 1.0, 0);
    exact = check_bounds("walls, oblique", r, nr, s, ns, &est);
    RAD_CHECK_REL(est, exact, 0.1);
    /* a wall facing away: nothing to link */
    nr = wall(r, 8, rad_v3(0, 0, 0), 1.0, 0);
    ns = wall(s, 8, rad_v3(0, 0, 10), 1.0, 1);
    ff_cluster_bound br = tree_bound(r, nr), bs = tree_bound(s, ns);
    RAD_CHECK(!ff_cluster_pair_estimate(&br, &bs).facing);
    /* perpendicular walls of a closed room near their shared edge (the
     * furnace cube's cluster links): floor cells against wall cells */
    for (int k = 0; k < 4; k++) {
        double off = 0.1 + 0.2 * k;
        nr = wall(r, 2, rad_v3(off + 0.05, 0.5, 0), 0.1, 1);
        int m = 0;
        for (int i = 0; i < 2; i++)
            for (int j = 0; j < 2; j++) {
                double y0 = 0.45 + 0.05 * i, z0 = 0.1 + 0.05 * j + 0.1 * k;
                rad_vec3 a = rad_v3(0, y0, z0), b = rad_v3(0, y0 + 0.05, z0), c = rad_v3(0, y0 + 0.05, z0 + 0.05),
                         d = rad_v3(0, y0, z0 + 0.05);
                s[m] = triangle(a, b, c, (uint32_t)m), m++;
                s[m] = triangle(a, c, d, (uint32_t)m), m++;
            }
        exact = check_bounds("perpendicular walls", r, nr, s, m, &est);
        RAD_CHECK_REL(est, exact, 0.1); /* measured: +6 % at the edge, within 1 % from the next cells on */
    }
    /* a cluster around a room's corner (faces of two walls, normals 90
     * degrees apart) and a floor triangle beside one wall: the furnace
     * cube's worst case before each face took its own direction */
    {
        rad_vec3 q[8] = {rad_v3(0.917, 1, 0.25), rad_v3(1, 1, 0.25), rad_v3(1, 1, 0.333),
                         rad_v3(1, 0.917, 0.25), rad_v3(1, 0.917, 0.333), rad_v3(1, 0.917, 0.167)};
        s[0] = triangle(q[0], q[1], q[2], 0);
        s[1] = triangle(q[3], q[2], q[1], 1);
        s[2] = triangle(q[3], q[4], q[2], 2);
        s[3] = triangle(q[5], q[3], q[1], 3);
        r[0] = triangle(rad_v3(0.75, 0.917, 0), rad_v3(0.833, 1, 0), rad_v3(0.75, 1, 0), 0);
        check_bounds("corner", r, 1, s, 4, &est);
    }
    /* a wall and a blob */
    nr = wall(r, 8, rad_v3(0, 0, 0), 2.0, 1);
    blob(s, N, rad_v3(0.5, 0, 6), 0.3);
    check_bounds("wall and blob", r, nr, s, N, &est);
    return rad_test_finish();
}
