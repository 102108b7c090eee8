/* rad_polygon.h - one planar convex polygon of 3 or 4 corners: its
 * geometry and its 1 -> 4 split, the one rule that the mesh, contact
 * cutting and refinement all use.
 *
 * Usage (splitting polygon v, whose corners lie at corner[0..n-1]):
 *     uint32_t child[4][4];
 *     rad_polygon_split(v, corner, n, make_vertex, context, child);
 *     for (int i = 0; i < 4; i++) ... child[i][0..n-1] ...
 *
 * Corners are vertex indices (uint32_t) into the caller's positions, in
 * winding order; a triangle's unused fourth index is RAD_NO_VERTEX. The
 * split must give the same positions, bit for bit, wherever it runs: a
 * face's contact-cutting grid (rad_contact.c) is the mesh of that face
 * (rad_mesh.c), and refinement (rad_refine.c) continues the mesh's
 * subdivision, so midpoints shared between them are one vertex.
 */
#ifndef RAD_POLYGON_H
#define RAD_POLYGON_H

#include <stdint.h>

#include "rad_math.h"

/* "No vertex here": a triangle's fourth corner (rad_patch.v[3]), an empty
 * slot of a table of vertex indices. Indices are uint32_t, so meshes stop
 * at UINT32_MAX - 1 vertices. */
#define RAD_NO_VERTEX UINT32_MAX

/* Area, unit normal (Newell's; for a quad the cross product of the
 * diagonals, following the winding) and area centroid of the polygon
 * v[0..n-1], n = 3 or 4, planar. */
void rad_polygon_geometry(const rad_vec3 *v, int n, double *out_area, rad_vec3 *out_normal, rad_vec3 *out_centroid);

/* out_v[0..3] = v[0..n-1], then RAD_NO_VERTEX up to 4 (n = 3 or 4): the
 * corners as a patch or piece stores them. */
void rad_polygon_corners_store(const uint32_t *v, uint32_t n, uint32_t out_v[4]);

/* The new vertex of a split, made (or found) by the caller: the midpoint
 * of the edge a-b (a, b corners of the polygon), or, with a == b ==
 * RAD_NO_VERTEX, a quad's centre. `at` is its position; the caller keeps
 * it as given (one vertex per edge: the edge's other polygon asks for the
 * same edge, maybe as b-a, and gets the same bits). */
typedef uint32_t (*rad_polygon_vertex_fn)(void *context, uint32_t a, uint32_t b, rad_vec3 at);

/* Splits polygon v (n = 3 or 4 corners at corner[0..n-1]) into 4 of n
 * corners each, keeping its winding:
 *   triangle: its edge midpoints ab, bc, ca; children (a, ab, ca),
 *             (ab, b, bc), (ca, bc, c), (ab, bc, ca);
 *   quad:     its edge midpoints ab, bc, cd, da and its centre m, the mean
 *             of its corners; children (a, ab, m, da), (ab, b, bc, m),
 *             (m, bc, c, cd), (da, m, cd, d).
 * A midpoint is (p + q) * 0.5 (symmetric in p and q), the centre
 * (((0 + a) + b) + c + d) * 0.25. make_vertex is called in that order
 * (the edges from corner 0 on, then the centre), which fixes the order in
 * which callers number new vertices. out_child[i][0..n-1] are the
 * children's corners. */
void rad_polygon_split(const uint32_t *v, const rad_vec3 *corner, int n, rad_polygon_vertex_fn make_vertex,
                       void *context, uint32_t out_child[4][4]);

#endif
