/* rad_contact.h - faces cut where other geometry touches or crosses them.
 *
 * Usage (rad_mesh_build does this; other code rarely needs it):
 *     rad_contact_cut cut;
 *     if (rad_contact_cut_build(&scene, face_level, &cut) != RAD_OK) ...;
 *     ... cut.pieces[i], cut.positions ...
 *     rad_contact_cut_free(&cut);
 *
 * For every face F, the other faces G that touch or cross F's plane inside
 * F give cut lines: G's polygon meets F's plane in a segment (an edge of G
 * lying in the plane: a footprint edge, like a block's side resting on a
 * floor; or G crossing the plane: an intersection line), clipped to F.
 * Segments along F's boundary or shorter than RAD_CONTACT_MIN_LENGTH x the
 * scene diameter are ignored. A face G coplanar with F and facing the
 * other way (a box's bottom on the floor) gives its edges as cut lines,
 * and so does, moved onto F's plane, a face G parallel to F and facing the
 * same way at most RAD_CONTACT_GAP x the scene diameter in front of F (a
 * light panel hung 1 cm under a ceiling: the ceiling behind it is shut in).
 * F is first split into its grid at level g = min(face_level[f],
 * RAD_CONTACT_GRID_MAX), the cells rad_mesh makes of a face at level g
 * (same midpoints, bit for bit); then each segment, in turn, splits every
 * current piece that it passes through, along its whole line within that
 * piece (BSP style), so every piece stays convex and no cut line runs
 * further than the cell it crosses (no long slivers across the face). The
 * cells no segment crosses stay whole. Collinear corners are merged,
 * zero-area pieces dropped, and pieces of more than 4 corners fanned into
 * quads (and one triangle) from their first corner.
 *
 * Hidden pieces are dropped: those of a face with contacts whose centroid,
 * moved RAD_CONTACT_OFFSET x the scene diameter along the normal, is
 * inside a solid (most of RAD_CONTACT_RAYS rays into the normal's
 * hemisphere first hit a back face: one whose normal points along the
 * ray; a ray that leaves the scene counts as open), and those pressed
 * against a coplanar face of opposite facing (centroid inside it) whose
 * own back side is inside a solid (the same test, behind the piece): a
 * box's bottom on the floor goes, the two faces of a double-sided wall
 * (back to back, open space on either side) stay. So the
 * floor under a block (a top seen from below), the bottom of a box
 * resting on the floor and the ceiling behind a panel hung just under it
 * (the panel's back seen from the ceiling) disappear.
 *
 * Such a face a little farther than the gap is counted as a near miss
 * (not cut; the caller names it). Distances below RAD_CONTACT_TOL x the scene diameter (the bounding-box
 * diagonal of all faces' vertices) count as zero. Faces without contacts
 * come out as one piece, their own corners (same scene vertex indices).
 */
#ifndef RAD_CONTACT_H
#define RAD_CONTACT_H

#include <stddef.h>
#include <stdint.h>

#include "rad_scene.h"
#include "rad_status.h"

#define RAD_CONTACT_TOL 1e-6        /* x scene diameter: "on the plane", "on the line" */
#define RAD_CONTACT_MIN_LENGTH 1e-5 /* x scene diameter: shorter cut segments are ignored */
#define RAD_CONTACT_GAP 1e-3        /* x scene diameter: a parallel face facing the same way this
                                       close in front of a face shuts in what is behind it */
#define RAD_CONTACT_NEAR 1e-2       /* x scene diameter: such a face farther than the gap but at
                                       most this far is a near miss (rad_contact_cut.near_count) */
#define RAD_CONTACT_OFFSET 1e-5     /* x scene diameter: how far off a piece the inside test starts */
#define RAD_CONTACT_RAYS 7          /* rays of the inside test: the normal and 6 at 50 degrees */
#define RAD_CONTACT_GRID_MAX 4      /* deepest grid a cut face starts from (256 cells) */

typedef struct rad_contact_piece {
    uint32_t vertex_count; /* 3 or 4 */
    uint32_t v[4];         /* indices into rad_contact_cut.positions, the face's winding */
    uint32_t source_face;  /* the scene face it is part of */
} rad_contact_piece;

typedef struct rad_contact_cut {
    double *positions;        /* xyz: the scene's vertices (same indices), then the cut vertices */
    size_t vertex_count;      /* each cut vertex once: equal positions share one index */
    rad_contact_piece *pieces; /* each face's pieces contiguous, source_face ascending */
    size_t piece_count;
    size_t faces_cut;         /* faces with at least one cut line */
    size_t pieces_hidden;     /* pieces (grid cells or parts of them, whole faces) dropped as hidden */
    /* Near misses: faces g parallel to a face f, facing the same way, in
     * front of it over f (g's centre inside f) by more than the gap but at
     * most RAD_CONTACT_NEAR x the scene diameter: not cut, so f's region
     * behind g stays, unlit (a light panel hung 1 cm under a 5 m room's
     * ceiling, whose gap is 8.7 mm). The count of such pairs, the first. */
    size_t near_count;
    uint32_t near_face, near_cover; /* f, g */
    double near_distance;           /* g's farthest corner from f's plane, scene units */
    double gap;                     /* RAD_CONTACT_GAP x the scene diameter, scene units */
} rad_contact_cut;

/* face_level: per face, the subdivision level it is meshed at (its grid
 * is cut, see above); NULL = 0 for every face. RAD_ERR_NOMEM (logged) when
 * memory runs out. */
rad_status rad_contact_cut_build(const rad_scene *scene, const int *face_level, rad_contact_cut *out_cut);
void rad_contact_cut_free(rad_contact_cut *cut); /* safe on a zeroed or freed cut */

#endif
