/* rad_adjacency.h - which patches meet at a vertex, and which lie on one
 * smooth surface: shared by render's smooth shading and the refinement.
 *
 * Usage:
 *     rad_vertex_patches adj;
 *     if (rad_vertex_patches_build(&mesh, &adj) != RAD_OK) ...;
 *     for (size_t e = adj.start[v]; e < adj.start[v + 1]; e++) ... adj.list[e] ...
 *     rad_vertex_patches_free(&adj);
 */
#ifndef RAD_ADJACENCY_H
#define RAD_ADJACENCY_H

#include <stddef.h>
#include <stdint.h>

#include "rad_mesh.h"
#include "rad_status.h"

/* Normals further apart than this are a crease. */
#define RAD_CREASE_DEGREES 1.0

/* vertex -> incident patches, as compressed rows: the patches of vertex v
 * are list[start[v] .. start[v + 1]), ascending. */
typedef struct rad_vertex_patches {
    size_t *start; /* vertex_count + 1 */
    uint32_t *list;
} rad_vertex_patches;

/* Fails with RAD_ERR_INVALID (logged) for a patch with a vertex index out
 * of range, RAD_ERR_NOMEM for lack of memory. */
rad_status rad_vertex_patches_build(const rad_mesh *mesh, rad_vertex_patches *out);
void rad_vertex_patches_free(rad_vertex_patches *adj); /* safe on zeroed */

/* One smooth surface: normals within crease_cos (cos RAD_CREASE_DEGREES)
 * and the same material (rho and emission equal to 1e-9 relative, which
 * absorbs materials printed and reparsed). */
int rad_same_surface(const rad_patch *a, const rad_patch *b, double crease_cos);

/* The same material: rho and emission equal to 1e-9 relative (the half of
 * rad_same_surface that render's smoothing groups use alone). */
int rad_same_material(const rad_patch *a, const rad_patch *b);

#endif
