/* rad_face_grid.h - a uniform grid over faces' bounding boxes: which faces
 * may come near a box, and which lie along a ray, in the order the ray
 * meets the cells. What keeps contact cutting (rad_contact.c) from looking
 * at every pair of faces and tracing every ray against every face.
 *
 *     rad_face_grid grid;
 *     rad_face_grid_build(boxes, face_count, margin, &grid);
 *     uint32_t lo[3], hi[3];
 *     rad_face_grid_cells(&grid, &box, lo, hi);      // the cells box overlaps
 *     ... rad_face_grid_cell(&grid, x, y, z, &count) lists faces, ascending ...
 *     rad_face_grid_ray(&grid, p, d, visit, user);  // cells along p + t d, t > 0
 *     rad_face_grid_free(&grid);
 *
 * A face is listed in every cell its box, grown by `margin`, overlaps; so
 * every face whose box comes within `margin` of a box lies in a cell that
 * box overlaps. About one cell per face, shaped to the scene's bounds (a
 * flat extent gets one layer); faces in a cell come in ascending order.
 */
#ifndef RAD_FACE_GRID_H
#define RAD_FACE_GRID_H

#include <stdint.h>

#include "rad_box.h"
#include "rad_status.h"

typedef struct rad_face_grid {
    double lo[3], hi[3]; /* the grid's bounds: the faces' boxes grown by margin */
    double cell[3];      /* a cell's size per axis */
    uint32_t n[3];       /* cells per axis */
    uint32_t *first;     /* n[0] n[1] n[2] + 1: cell c lists items[first[c] .. first[c + 1]) */
    uint32_t *items;
} rad_face_grid;

/* RAD_ERR_NOMEM (logged). No faces give one empty cell. */
rad_status rad_face_grid_build(const rad_box *boxes, uint32_t count, double margin, rad_face_grid *out);
void rad_face_grid_free(rad_face_grid *grid); /* safe on zeroed */

/* The cells [lo, hi] (inclusive, per axis) that box overlaps, clamped to
 * the grid. */
void rad_face_grid_cells(const rad_face_grid *grid, const rad_box *box, uint32_t lo[3], uint32_t hi[3]);

/* Cell (x, y, z)'s faces, ascending; *count of them. */
static inline const uint32_t *rad_face_grid_cell(const rad_face_grid *g, uint32_t x, uint32_t y, uint32_t z,
                                                 uint32_t *count)
{
    const uint64_t c = ((uint64_t)z * g->n[1] + y) * g->n[0] + x;
    *count = g->first[c + 1] - g->first[c];
    return g->items + g->first[c];
}

/* Visits the cells the ray p + t d (t > 0) passes through, in order, with
 * their faces and the ray's t on leaving the cell; stops when visit
 * returns non-zero or the ray leaves the grid. */
typedef int (*rad_face_grid_visit)(void *user, const uint32_t *faces, uint32_t count, double t_exit);
void rad_face_grid_ray(const rad_face_grid *grid, const double p[3], const double d[3], rad_face_grid_visit visit,
                       void *user);

#endif
