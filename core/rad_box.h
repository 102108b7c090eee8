/* rad_box.h - axis-aligned bounding boxes of points given as xyz triples,
 * and their diagonal: the one length scale of meshes, faces and scenes
 * (the "diameter" that tolerances are relative to).
 *
 *     rad_box box = rad_box_of_points(mesh.positions, mesh.vertex_count);
 *     double eps = 1e-11 * rad_box_diagonal(&box);
 *
 * An empty box has lo = +inf and hi = -inf; its diagonal is 0.
 */
#ifndef RAD_BOX_H
#define RAD_BOX_H

#include <math.h>
#include <stddef.h>
#include <stdint.h>

typedef struct rad_box {
    double lo[3], hi[3];
} rad_box;

static inline rad_box rad_box_empty(void)
{
    rad_box box = {{INFINITY, INFINITY, INFINITY}, {-INFINITY, -INFINITY, -INFINITY}};
    return box;
}

/* Grows box to hold the point p (xyz). */
static inline void rad_box_add(rad_box *box, const double *p)
{
    for (int a = 0; a < 3; a++) box->lo[a] = fmin(box->lo[a], p[a]), box->hi[a] = fmax(box->hi[a], p[a]);
}

/* The box of the points positions[0..count) (xyz each). */
static inline rad_box rad_box_of_points(const double *positions, size_t count)
{
    rad_box box = rad_box_empty();
    for (size_t i = 0; i < count; i++) rad_box_add(&box, positions + 3 * i);
    return box;
}

/* The box of the points positions[v[k]], k < count (a polygon's corners). */
static inline rad_box rad_box_of_corners(const double *positions, const uint32_t *v, size_t count)
{
    rad_box box = rad_box_empty();
    for (size_t k = 0; k < count; k++) rad_box_add(&box, positions + 3 * (size_t)v[k]);
    return box;
}

/* Length of the box's diagonal; 0 for an empty box. */
static inline double rad_box_diagonal(const rad_box *box)
{
    if (!(box->lo[0] <= box->hi[0])) return 0.0;
    double d2 = 0.0;
    for (int a = 0; a < 3; a++) d2 += (box->hi[a] - box->lo[a]) * (box->hi[a] - box->lo[a]);
    return sqrt(d2);
}

/* The box's centre ((lo + hi) / 2 per axis); 0 for an empty box. */
static inline void rad_box_centre(const rad_box *box, double out_centre[3])
{
    int empty = !(box->lo[0] <= box->hi[0]);
    for (int a = 0; a < 3; a++) out_centre[a] = empty ? 0.0 : 0.5 * (box->lo[a] + box->hi[a]);
}

#endif
