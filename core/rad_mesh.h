/* rad_mesh.h - the patch mesh: a scene's faces subdivided into patches.
 *
 * Usage:
 *     rad_mesh mesh;
 *     rad_mesh_options opt = {.subdiv = 3};
 *     if (rad_mesh_build(&scene, &opt, &mesh) != RAD_OK) ...;
 *     rad_mesh_free(&mesh);
 *
 * Subdivision level S splits every face into 4^S patches: a triangle into
 * four triangles through its edge midpoints, a quad into four quads through
 * its edge midpoints and its centre (rad_polygon_split, S times).
 * Vertices are shared between patches (one midpoint per mesh edge, also
 * across faces that share the edge), so render can interpolate. Patch vertices keep the face's winding, so
 * normals point the same way as the face's.
 *
 * Contacts (options.contacts, default RAD_MESH_CONTACTS_CUT): before
 * subdividing, every face is cut where other faces touch or cross it and
 * the pieces hidden inside or under geometry are dropped (rad_contact.h
 * says how): the floor under a block gets no patches, and no patch
 * straddles a block's footprint. A cut face is first split into its grid
 * of level min(S, RAD_CONTACT_GRID_MAX) and the cells the cut lines cross
 * are cut. Each piece (cell or part of one) is then subdivided like a
 * face, to the level that gives patches about the size of its face's
 * patches at level S: level = max(0, S - round(log2(face diameter /
 * piece diameter))), diameters being bounding-box diagonals (an uncut
 * face keeps S, a whole cell of the grid at S <= 4 gets 0). So the patch
 * count grows with the cut cells, not with 4^S per piece. Pieces of one
 * face share their cut vertices (one index per position), and the
 * midpoints of edges that pieces share are shared too; a cut cell meets
 * its neighbours with T-junctions (as faces of different levels do), and
 * a cut face's grid vertices on its boundary are not shared with the
 * neighbouring faces' midpoints (the same positions, other indices).
 * RAD_MESH_CONTACTS_KEEP meshes the faces as they are (the mesh before
 * contact cutting: patches run under blocks).
 *
 * Order: patches follow the scene's faces (each face's patches contiguous,
 * source_face ascending; a cut face's pieces one after another); vertices
 * are the used scene and cut vertices in order of first use, then the
 * midpoints. Unused scene vertices are left out.
 *
 * Groups: every patch belongs to its face's OBJ group (the last `g` or `o`
 * name before it). The mesh keeps the groups that own at least one patch,
 * in the scene's order, and each patch's index into them: the surfaces that
 * results are reported by (solve --by-group, tools/ffdump.py). The
 * form-factor file stores them (docs/formats.md, "Group table").
 *
 * rad_patch is laid out exactly as a patch record of the form-factor and
 * radiosity files (128 bytes, see docs/formats.md).
 */
#ifndef RAD_MESH_H
#define RAD_MESH_H

#include <stddef.h>
#include <stdint.h>

#include "rad_math.h"
#include "rad_polygon.h"
#include "rad_scene.h"
#include "rad_status.h"

typedef struct rad_patch {
    uint32_t vertex_count; /* 3 or 4 */
    uint32_t v[4];         /* indices into rad_mesh.positions; v[3] = RAD_NO_VERTEX for triangles */
    uint32_t source_face;  /* index of the scene face it came from */
    double area;           /* scene units^2 */
    rad_vec3 normal;       /* unit */
    rad_vec3 centroid;     /* area centroid */
    double rho[3];         /* reflectance, RGB, in [0, 1) */
    double emission[3];    /* emitted radiosity, RGB, >= 0 */
} rad_patch;

typedef struct rad_mesh {
    double *positions; /* xyz per vertex */
    size_t vertex_count;
    rad_patch *patches;
    size_t patch_count;
    /* The groups (surfaces) of the patches. group_count is 0, and both
     * arrays NULL, where they are unknown: meshes read from a radiosity
     * file or from a form-factor file of version 1, and meshes put
     * together by hand. */
    char (*group_names)[RAD_NAME_MAX]; /* group_count names, NUL-terminated, zero-padded */
    size_t group_count;
    uint32_t *patch_group;             /* patch_count entries: index into group_names */
} rad_mesh;

typedef enum rad_mesh_contacts {
    RAD_MESH_CONTACTS_CUT = 0, /* cut faces along contacts, drop hidden pieces (default) */
    RAD_MESH_CONTACTS_KEEP = 1 /* faces as they are */
} rad_mesh_contacts;

typedef struct rad_mesh_options {
    int subdiv;              /* subdivision level S >= 0 (0 = faces, or pieces, as patches) */
    const char *only_group;  /* NULL = subdivide every face; else only faces of this
                                group (reproduces the paper code, which subdivided
                                the box and not the sphere); pieces of other
                                faces are one patch each */
    rad_mesh_contacts contacts; /* 0 = RAD_MESH_CONTACTS_CUT */
} rad_mesh_options;

/* Fails with RAD_ERR_NOMEM (and the memory it would need in the message)
 * when the patch count, or the vertex count's upper bound, would exceed
 * UINT32_MAX - 1 (checked before allocating) or memory runs out; with
 * RAD_ERR_INVALID for subdiv < 0 or an unknown contacts value. options
 * NULL = {0}. Warns when only_group names no face's group. Logs (info) how
 * many faces were cut and how many pieces dropped as hidden. */
rad_status rad_mesh_build(const rad_scene *scene, const rad_mesh_options *options, rad_mesh *out_mesh);
void rad_mesh_free(rad_mesh *mesh); /* safe on a zeroed or freed mesh */

/* Sets the mesh's group table from the scene, each patch's group being its
 * source face's (as rad_mesh_build does): for meshes read from a radiosity
 * file, which stores no groups. RAD_ERR_INVALID for a source face out of
 * range, RAD_ERR_NOMEM. */
rad_status rad_mesh_set_groups(const rad_scene *scene, rad_mesh *mesh);

/* Patch count that rad_mesh_build would produce, without building the
 * patches (contacts are cut, though); saturates at UINT64_MAX, which it
 * also returns when memory runs out while cutting; 0 for subdiv < 0. */
uint64_t rad_mesh_count_patches(const rad_scene *scene, const rad_mesh_options *options);

/* Does the patch's centroid lie inside the bounding box of its vertices
 * (up to 1e-9 relative rounding)? The area centroid of a planar convex patch
 * always does; both file readers check it, so that solve never writes a
 * file render refuses (a finite centroid at 1e165 once did). */
int rad_patch_centroid_inside(const rad_patch *patch, const double *positions);

#endif
