/* rad_hierarchy.h - element quadtrees over a mesh: the hierarchy that
 * hierarchical radiosity (issue 26) links at many levels.
 *
 * Usage:
 *     rad_hierarchy h;
 *     if (rad_hierarchy_init(&base, &h) != RAD_OK) ...;   // a root per patch of base
 *     uint32_t first;
 *     if (rad_hierarchy_split(&h, e, &first) != RAD_OK) ...;  // children first .. first + 3
 *     ... h.elements[first + k] ...
 *     rad_mesh leaves;
 *     rad_hierarchy_leaves(&h, &leaves);                   // what solve and render draw
 *     rad_hierarchy_free(&h);
 *
 * Each patch of the base mesh (a face, or a piece of one after contact
 * cutting: rad_mesh_build at --subdiv 0) is the root of a quadtree whose
 * children come from the one 1 -> 4 split rule (rad_polygon.h), made on
 * demand. Midpoints are shared across the whole hierarchy (one vertex per
 * edge, whichever element asked first), so a tree split uniformly to
 * depth d has the geometry of rad_mesh_build's --subdiv d to the bit: the
 * same corners, areas, normals and centroids, in the same order
 * (tests/test_hierarchy.c). Elements never move: an index stays valid
 * while the hierarchy grows.
 */
#ifndef RAD_HIERARCHY_H
#define RAD_HIERARCHY_H

#include <stddef.h>
#include <stdint.h>

#include "rad_edge_map.h"
#include "rad_math.h"
#include "rad_mesh.h"
#include "rad_status.h"

/* "No element": a root's parent, a leaf's children. */
#define RAD_NO_ELEMENT UINT32_MAX

typedef struct rad_element {
    uint32_t parent;       /* RAD_NO_ELEMENT for a root */
    uint32_t first_child;  /* its 4 children are first_child .. + 3; RAD_NO_ELEMENT: a leaf */
    uint32_t root;         /* the base mesh's patch it refines (= its root's index) */
    uint32_t level;        /* 0 for a root */
    uint32_t vertex_count; /* 3 or 4 */
    uint32_t v[4];         /* corners into rad_hierarchy.positions; v[3] = RAD_NO_VERTEX for triangles */
    double area;
    rad_vec3 normal, centroid;
} rad_element;

typedef struct rad_hierarchy {
    const rad_mesh *base;  /* the roots' mesh (materials, source faces); not owned */
    double *positions;     /* xyz per vertex: the base's, then midpoints and centres as made */
    size_t vertex_count, vertex_cap;
    rad_element *elements; /* the roots (elements 0 .. base->patch_count - 1), then children */
    size_t element_count, element_cap;
    size_t leaf_count;
    rad_edge_map midpoints; /* edge -> its midpoint vertex */
    size_t midpoint_count;
} rad_hierarchy;

/* A root per patch of `base`, which must outlive the hierarchy. Fails
 * with RAD_ERR_NOMEM (logged) or RAD_ERR_INVALID for a patch that is not
 * a triangle or quad, or names a vertex out of range; *out is then empty. */
rad_status rad_hierarchy_init(const rad_mesh *base, rad_hierarchy *out);

/* Splits leaf `element` into 4 children (rad_polygon_split) and returns
 * the first one's index; an element already split returns its children.
 * RAD_ERR_NOMEM (logged), RAD_ERR_INVALID for an element out of range or
 * the 2^32 - 1 elements or vertices a hierarchy holds at most. */
rad_status rad_hierarchy_split(rad_hierarchy *h, uint32_t element, uint32_t *out_first_child);

/* Splits every leaf of `root`'s tree down to `depth` levels below the
 * root, depth first (child 0's subtree before child 1's): the order in
 * which rad_mesh_build makes a face's --subdiv vertices. */
rad_status rad_hierarchy_split_to(rad_hierarchy *h, uint32_t root, uint32_t depth);

/* The leaves as a mesh, root by root, each tree's leaves depth first:
 * positions (all vertices, also those only split elements use), patches
 * with the root's material and source face, the base's groups. */
rad_status rad_hierarchy_leaves(const rad_hierarchy *h, rad_mesh *out);

/* The leaves' elements in that order (h->leaf_count of them), found on
 * the threads, root by root; NULL (logged) for lack of memory. Freed with
 * free. */
uint32_t *rad_hierarchy_leaf_elements(const rad_hierarchy *h);

/* rad_hierarchy_leaves from the leaves' elements `order` already found
 * (rad_hierarchy_leaf_elements), for a caller that needs them too. */
rad_status rad_hierarchy_leaves_of(const rad_hierarchy *h, const uint32_t *order, rad_mesh *out);

void rad_hierarchy_free(rad_hierarchy *h); /* safe on zeroed */

#endif
