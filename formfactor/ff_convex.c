/* ff_convex.c - whether a scene is one convex enclosure seen from inside
 * (ff_setup.h): every vertex a face uses lies on or in front of every
 * face's plane, to within eps.
 *
 * Every face against every vertex is k^2: a closed room of 10^5 small
 * triangles, which passes, took 42 s of a run's setup on 16 cores. The
 * vertices now go into a tree of boxes (median splits, a few vertices a
 * leaf), and a face skips every box whose lowest point along its normal
 * is already in front of its plane: a flat wall's plane is passed at the
 * root, a curved shell's at a few boxes. The answer is the brute force's
 * to the bit: a box's value is taken at the corner that minimises each
 * term of the same expression (plane_value), and rounding is monotone in
 * each term, so a box's value is never above a vertex's in it. Faces
 * pointing away from the scene's centre go first, so that a scene that is
 * not a convex enclosure fails at once. */
#include "ff_setup.h"

#include <stdlib.h>

#include "rad_box.h"
#include "rad_math.h"
#include "rad_polygon.h"

#define CONVEX_LEAF_VERTICES 8

/* How far p is in front of the plane through c with normal n: the one
 * expression for vertices and box corners alike (see the top), kept out
 * of line so that both get the same instructions. */
__attribute__((noinline)) static double plane_value(rad_vec3 n, rad_vec3 c, rad_vec3 p)
{
    return rad_v3_dot(n, rad_v3_sub(p, c));
}

/* An index and its sort key: a vertex and its coordinate along the axis
 * a node splits; a face and how far its normal points towards the scene's
 * centre (a convex enclosure's all do; the least first). */
typedef struct keyed {
    double key;
    uint32_t index;
} keyed;

static int by_key(const void *a, const void *b)
{
    const keyed *x = a, *y = b;
    if (x->key != y->key) return x->key < y->key ? -1 : 1;
    return (x->index > y->index) - (x->index < y->index);
}

typedef struct vertex_tree {
    const double *positions;
    uint32_t *v;     /* the vertices the faces use, in tree order */
    rad_box *box;    /* per node */
    uint32_t *begin; /* per node: v[begin[i] .. end[i]) */
    uint32_t *end;
    uint32_t *left;  /* per node: its first child (the second is left + 1); 0 for a leaf */
    uint32_t nodes;
    keyed *scratch; /* one per vertex: the sort's */
} vertex_tree;

/* Node `i` over v[begin .. end): its box, and children split at the median
 * of the box's longest axis. */
static void tree_build(vertex_tree *t, uint32_t i, uint32_t begin, uint32_t end)
{
    rad_box box = rad_box_of_corners(t->positions, t->v + begin, end - begin);
    t->box[i] = box;
    t->begin[i] = begin;
    t->end[i] = end;
    t->left[i] = 0;
    if (end - begin <= CONVEX_LEAF_VERTICES) return;
    int axis = 0;
    for (int a = 1; a < 3; a++)
        if (box.hi[a] - box.lo[a] > box.hi[axis] - box.lo[axis]) axis = a;
    for (uint32_t k = begin; k < end; k++)
        t->scratch[k] = (keyed){t->positions[3 * (size_t)t->v[k] + axis], t->v[k]};
    qsort(t->scratch + begin, end - begin, sizeof *t->scratch, by_key);
    for (uint32_t k = begin; k < end; k++) t->v[k] = t->scratch[k].index;
    const uint32_t mid = begin + (end - begin) / 2, left = t->nodes;
    t->nodes += 2;
    t->left[i] = left;
    tree_build(t, left, begin, mid);
    tree_build(t, left + 1, mid, end);
}

/* Whether a vertex of the tree lies more than eps behind the plane (n, c). */
static int any_behind(const vertex_tree *t, rad_vec3 n, rad_vec3 c, double eps, uint32_t *stack)
{
    uint32_t top = 0;
    stack[top++] = 0;
    while (top > 0) {
        const uint32_t i = stack[--top];
        const rad_box *b = &t->box[i];
        const rad_vec3 low = rad_v3(n.x >= 0 ? b->lo[0] : b->hi[0], n.y >= 0 ? b->lo[1] : b->hi[1],
                                    n.z >= 0 ? b->lo[2] : b->hi[2]);
        if (!(plane_value(n, c, low) < -eps)) continue; /* the whole box is in front (a NaN: the brute force's "no") */
        if (t->left[i]) {
            stack[top++] = t->left[i];
            stack[top++] = t->left[i] + 1;
            continue;
        }
        for (uint32_t k = t->begin[i]; k < t->end[i]; k++) {
            const double *p = t->positions + 3 * (size_t)t->v[k];
            if (plane_value(n, c, rad_v3(p[0], p[1], p[2])) < -eps) return 1;
        }
    }
    return 0;
}

int ff_scene_is_convex_enclosure(const rad_scene *scene, double eps)
{
    const size_t nf = scene->face_count, nv = scene->vertex_count;
    rad_vec3 *normal = malloc((nf ? nf : 1) * sizeof *normal), *centroid = malloc((nf ? nf : 1) * sizeof *centroid);
    keyed *order = malloc((nf ? nf : 1) * sizeof *order);
    unsigned char *used = calloc(nv ? nv : 1, 1);
    vertex_tree t = {.positions = scene->positions};
    t.v = malloc((nv ? nv : 1) * sizeof *t.v);
    t.scratch = malloc((nv ? nv : 1) * sizeof *t.scratch);
    const size_t most_nodes = 2 * (nv ? nv : 1);
    t.box = malloc(most_nodes * sizeof *t.box);
    t.begin = malloc(most_nodes * sizeof *t.begin);
    t.end = malloc(most_nodes * sizeof *t.end);
    t.left = malloc(most_nodes * sizeof *t.left);
    uint32_t *stack = malloc((most_nodes + 2) * sizeof *stack);
    int convex = nf > 0;
    if (!normal || !centroid || !order || !used || !t.v || !t.scratch || !t.box || !t.begin || !t.end || !t.left || !stack)
        convex = 0; /* out of memory: not known to be convex, so rays are cast (the safe side) */
    if (convex) {
        uint32_t count = 0;
        for (size_t f = 0; f < nf; f++)
            for (uint32_t k = 0; k < scene->faces[f].vertex_count; k++) used[scene->faces[f].v[k]] = 1;
        for (size_t i = 0; i < nv; i++)
            if (used[i]) t.v[count++] = (uint32_t)i;
        t.nodes = 1;
        tree_build(&t, 0, 0, count);
        rad_box box = rad_box_of_points(scene->positions, nv);
        double c[3];
        rad_box_centre(&box, c);
        const rad_vec3 centre = rad_v3(c[0], c[1], c[2]);
        for (size_t f = 0; f < nf; f++) {
            const rad_face *face = &scene->faces[f];
            rad_vec3 v[4];
            for (uint32_t k = 0; k < face->vertex_count; k++) {
                const double *p = scene->positions + 3 * (size_t)face->v[k];
                v[k] = rad_v3(p[0], p[1], p[2]);
            }
            double area;
            rad_polygon_geometry(v, (int)face->vertex_count, &area, &normal[f], &centroid[f]);
            order[f] = (keyed){-rad_v3_dot(normal[f], rad_v3_sub(centroid[f], centre)), (uint32_t)f}; /* outward first */
        }
        qsort(order, nf, sizeof *order, by_key);
        for (size_t i = 0; i < nf && convex; i++)
            convex = !any_behind(&t, normal[order[i].index], centroid[order[i].index], eps, stack);
    }
    free(normal);
    free(centroid);
    free(order);
    free(used);
    free(t.v);
    free(t.scratch);
    free(t.box);
    free(t.begin);
    free(t.end);
    free(t.left);
    free(stack);
    return convex;
}
