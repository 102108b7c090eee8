/* rad_polygon.c - a polygon's geometry and its 1 -> 4 split (contract in
 * rad_polygon.h). */
#include "rad_polygon.h"

#include <assert.h>

void rad_polygon_geometry(const rad_vec3 *v, int n, double *out_area, rad_vec3 *out_normal, rad_vec3 *out_centroid)
{
    assert(n == 3 || n == 4);
    /* Newell's normal; for a quad it equals the cross product of the diagonals. */
    rad_vec3 N = n == 3 ? rad_v3_cross(rad_v3_sub(v[1], v[0]), rad_v3_sub(v[2], v[0]))
                        : rad_v3_cross(rad_v3_sub(v[2], v[0]), rad_v3_sub(v[3], v[1]));
    double length = rad_v3_length(N);
    rad_vec3 unit = rad_v3_normalize(N);
    rad_vec3 centroid = rad_v3_scale(rad_v3_add(rad_v3_add(v[0], v[1]), v[2]), 1.0 / 3);
    if (n == 4) {
        /* Area-weighted centroids of the triangles (0,1,2) and (0,2,3). */
        rad_vec3 c2 = rad_v3_scale(rad_v3_add(rad_v3_add(v[0], v[2]), v[3]), 1.0 / 3);
        double a1 = rad_v3_dot(rad_v3_cross(rad_v3_sub(v[1], v[0]), rad_v3_sub(v[2], v[0])), unit);
        double a2 = rad_v3_dot(rad_v3_cross(rad_v3_sub(v[2], v[0]), rad_v3_sub(v[3], v[0])), unit);
        centroid = a1 + a2 != 0 ? rad_v3_scale(rad_v3_add(rad_v3_scale(centroid, a1), rad_v3_scale(c2, a2)), 1.0 / (a1 + a2))
                                : rad_v3_scale(rad_v3_add(rad_v3_add(rad_v3_add(v[0], v[1]), v[2]), v[3]), 0.25);
    }
    *out_area = 0.5 * length;
    *out_normal = unit;
    *out_centroid = centroid;
}

void rad_polygon_corners_store(const uint32_t *v, uint32_t n, uint32_t out_v[4])
{
    assert(n == 3 || n == 4);
    for (uint32_t k = 0; k < 4; k++) out_v[k] = k < n ? v[k] : RAD_NO_VERTEX;
}

void rad_polygon_split(const uint32_t *v, const rad_vec3 *corner, int n, rad_polygon_vertex_fn make_vertex,
                       void *context, uint32_t out_child[4][4])
{
    assert(n == 3 || n == 4);
    uint32_t mid[4];
    for (int k = 0; k < n; k++) {
        int k1 = (k + 1) % n;
        mid[k] = make_vertex(context, v[k], v[k1], rad_v3_scale(rad_v3_add(corner[k], corner[k1]), 0.5));
    }
    if (n == 3) {
        const uint32_t ab = mid[0], bc = mid[1], ca = mid[2];
        const uint32_t child[4][3] = {{v[0], ab, ca}, {ab, v[1], bc}, {ca, bc, v[2]}, {ab, bc, ca}};
        for (int i = 0; i < 4; i++) rad_polygon_corners_store(child[i], 3, out_child[i]);
        return;
    }
    rad_vec3 sum = rad_v3(0, 0, 0);
    for (int k = 0; k < 4; k++) sum = rad_v3_add(sum, corner[k]);
    const uint32_t m = make_vertex(context, RAD_NO_VERTEX, RAD_NO_VERTEX, rad_v3_scale(sum, 0.25));
    const uint32_t ab = mid[0], bc = mid[1], cd = mid[2], da = mid[3];
    const uint32_t child[4][4] = {{v[0], ab, m, da}, {ab, v[1], bc, m}, {m, bc, v[2], cd}, {da, m, cd, v[3]}};
    for (int i = 0; i < 4; i++) rad_polygon_corners_store(child[i], 4, out_child[i]);
}
