/* test_polygon.c - core/rad_polygon.h (the 1 -> 4 split, corners, geometry)
 * and core/rad_box.h. Closed forms: a unit square and a right triangle
 * split once; the order in which the split asks for new vertices (the
 * numbering every caller relies on); the midpoint symmetric in its ends. */
#include <stdint.h>

#include "rad_box.h"
#include "rad_polygon.h"
#include "rad_test.h"

/* A vertex table that numbers new vertices in the order they are asked for
 * and records what was asked. */
typedef struct table {
    rad_vec3 at[16];
    uint32_t a[16], b[16];
    uint32_t count, first_new;
} table;

static uint32_t new_vertex(void *context, uint32_t a, uint32_t b, rad_vec3 at)
{
    table *t = context;
    uint32_t i = t->count - t->first_new;
    t->at[i] = at, t->a[i] = a, t->b[i] = b;
    return t->count++;
}

static int same(rad_vec3 p, double x, double y, double z) { return p.x == x && p.y == y && p.z == z; }

static void test_quad_split(void)
{
    const uint32_t v[4] = {0, 1, 2, 3};
    const rad_vec3 c[4] = {rad_v3(0, 0, 0), rad_v3(1, 0, 0), rad_v3(1, 1, 0), rad_v3(0, 1, 0)};
    table t = {.count = 4, .first_new = 4};
    uint32_t child[4][4];
    rad_polygon_split(v, c, 4, new_vertex, &t, child);
    RAD_CHECK(t.count == 9);
    /* The edges from corner 0 on, then the centre. */
    RAD_CHECK(t.a[0] == 0 && t.b[0] == 1 && same(t.at[0], 0.5, 0, 0));
    RAD_CHECK(t.a[1] == 1 && t.b[1] == 2 && same(t.at[1], 1, 0.5, 0));
    RAD_CHECK(t.a[2] == 2 && t.b[2] == 3 && same(t.at[2], 0.5, 1, 0));
    RAD_CHECK(t.a[3] == 3 && t.b[3] == 0 && same(t.at[3], 0, 0.5, 0));
    RAD_CHECK(t.a[4] == RAD_NO_VERTEX && t.b[4] == RAD_NO_VERTEX && same(t.at[4], 0.5, 0.5, 0));
    const uint32_t want[4][4] = {{0, 4, 8, 7}, {4, 1, 5, 8}, {8, 5, 2, 6}, {7, 8, 6, 3}};
    for (int i = 0; i < 4; i++)
        for (int k = 0; k < 4; k++) RAD_CHECK(child[i][k] == want[i][k]);
}

static void test_triangle_split(void)
{
    const uint32_t v[3] = {10, 11, 12};
    const rad_vec3 c[3] = {rad_v3(0, 0, 0), rad_v3(2, 0, 0), rad_v3(0, 2, 0)};
    table t = {.count = 13, .first_new = 13};
    uint32_t child[4][4];
    rad_polygon_split(v, c, 3, new_vertex, &t, child);
    RAD_CHECK(t.count == 16); /* three midpoints, no centre */
    RAD_CHECK(same(t.at[0], 1, 0, 0) && same(t.at[1], 1, 1, 0) && same(t.at[2], 0, 1, 0));
    const uint32_t want[4][3] = {{10, 13, 15}, {13, 11, 14}, {15, 14, 12}, {13, 14, 15}};
    double total = 0;
    for (int i = 0; i < 4; i++) {
        for (int k = 0; k < 3; k++) RAD_CHECK(child[i][k] == want[i][k]);
        RAD_CHECK(child[i][3] == RAD_NO_VERTEX);
        rad_vec3 corner[3], normal, centroid;
        double area;
        for (int k = 0; k < 3; k++) {
            uint32_t id = child[i][k];
            corner[k] = id < 13 ? c[id - 10] : t.at[id - 13];
        }
        rad_polygon_geometry(corner, 3, &area, &normal, &centroid);
        RAD_CHECK_NEAR(area, 0.5, 1e-15); /* a quarter of the parent's 2 */
        RAD_CHECK(same(normal, 0, 0, 1));  /* the parent's winding */
        total += area;
    }
    RAD_CHECK_NEAR(total, 2.0, 1e-15);
}

/* The midpoint is the same bits whichever end comes first, so an edge's
 * two polygons agree on it. */
static void test_midpoint_symmetric(void)
{
    const rad_vec3 p = rad_v3(0.1, 1e-3, 7.3), q = rad_v3(0.7, 3.3, -2.9), r = rad_v3(5.5, 0.2, 0.01);
    const uint32_t abc[3] = {0, 1, 2}, bac[3] = {1, 0, 2};
    const rad_vec3 c1[3] = {p, q, r}, c2[3] = {q, p, r};
    table t1 = {.count = 3, .first_new = 3}, t2 = {.count = 3, .first_new = 3};
    uint32_t child[4][4];
    rad_polygon_split(abc, c1, 3, new_vertex, &t1, child);
    rad_polygon_split(bac, c2, 3, new_vertex, &t2, child);
    RAD_CHECK(memcmp(&t1.at[0], &t2.at[0], sizeof t1.at[0]) == 0);
}

static void test_geometry_and_corners(void)
{
    const rad_vec3 c[4] = {rad_v3(0, 0, 0), rad_v3(2, 0, 0), rad_v3(2, 1, 0), rad_v3(0, 1, 0)};
    double area;
    rad_vec3 normal, centroid;
    rad_polygon_geometry(c, 4, &area, &normal, &centroid);
    RAD_CHECK_NEAR(area, 2.0, 1e-15);
    RAD_CHECK(same(normal, 0, 0, 1));
    RAD_CHECK_NEAR(centroid.x, 1.0, 1e-15);
    RAD_CHECK_NEAR(centroid.y, 0.5, 1e-15);
    uint32_t out[4];
    rad_polygon_corners_store((const uint32_t[3]){7, 8, 9}, 3, out);
    RAD_CHECK(out[0] == 7 && out[1] == 8 && out[2] == 9 && out[3] == RAD_NO_VERTEX);
}

static void test_box(void)
{
    const double p[] = {1, 2, 3, -1, 4, 3, 0, 0, 5};
    rad_box all = rad_box_of_points(p, 3);
    RAD_CHECK(all.lo[0] == -1 && all.lo[1] == 0 && all.lo[2] == 3);
    RAD_CHECK(all.hi[0] == 1 && all.hi[1] == 4 && all.hi[2] == 5);
    RAD_CHECK_NEAR(rad_box_diagonal(&all), sqrt(4 + 16 + 4), 1e-15);
    double centre[3];
    rad_box_centre(&all, centre);
    RAD_CHECK(centre[0] == 0 && centre[1] == 2 && centre[2] == 4);
    const uint32_t two[2] = {2, 0};
    rad_box some = rad_box_of_corners(p, two, 2);
    RAD_CHECK(some.lo[0] == 0 && some.hi[0] == 1 && some.lo[2] == 3 && some.hi[2] == 5);
    rad_box empty = rad_box_of_points(p, 0);
    RAD_CHECK(rad_box_diagonal(&empty) == 0);
    rad_box_centre(&empty, centre);
    RAD_CHECK(centre[0] == 0 && centre[1] == 0 && centre[2] == 0);
}

int main(void)
{
    test_quad_split();
    test_triangle_split();
    test_midpoint_symmetric();
    test_geometry_and_corners();
    test_box();
    return rad_test_finish();
}
