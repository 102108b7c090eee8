/* rad_patch_table.h - the vertex and patch tables that the form-factor file
 * and the radiosity file share (docs/formats.md): one codec and one
 * validator, so that both files store a mesh the same way and refuse the
 * same damage with the same message and status.
 *
 *     vertex table: vertex_count x 3 float64 (x, y, z)
 *     patch table:  patch_count records of RAD_PATCH_RECORD_BYTES:
 *                   u32 vertex count, u32[4] vertex indices, u32 source
 *                   face, f64 area, f64[3] normal, f64[3] centroid,
 *                   f64[3] rho, f64[3] emission
 *
 * All fields little-endian, written field by field (not as struct memory).
 */
#ifndef RAD_PATCH_TABLE_H
#define RAD_PATCH_TABLE_H

#include <stddef.h>

#include "rad_mesh.h"
#include "rad_status.h"

#define RAD_PATCH_RECORD_BYTES 128u
#define RAD_VERTEX_RECORD_BYTES 24u
/* |length of a stored normal - 1| allowed (they are normalised in double). */
#define RAD_PATCH_NORMAL_TOLERANCE 1e-6

/* mesh's vertices into `vertices` (vertex_count x 24 bytes) and patches
 * into `patches` (patch_count x 128 bytes). */
void rad_patch_table_encode(const rad_mesh *mesh, unsigned char *vertices, unsigned char *patches);

/* The reverse, into mesh->positions and mesh->patches (allocated by the
 * caller for mesh->vertex_count and mesh->patch_count). */
void rad_patch_table_decode(const unsigned char *vertices, const unsigned char *patches, rad_mesh *mesh);

/* Every vertex finite; every patch 3 or 4 vertices in range (a triangle's
 * fourth RAD_NO_VERTEX), positive finite area, unit normal, centroid inside,
 * rho in [0, 1) and E finite and >= 0. The first fault is logged as
 * "path: patch i: what is wrong" (or "path: vertex i: ..."), RAD_ERR_FORMAT. */
rad_status rad_patch_table_check(const char *path, const rad_mesh *mesh);

#endif
