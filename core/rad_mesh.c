/* rad_mesh.c - a scene's faces subdivided into patches (contract in rad_mesh.h).
 *
 * Sizes are known before anything is allocated: the patch count exactly,
 * the vertex count as an upper bound (every face's own (2^S+1)^2 or
 * (2^S+1)(2^S+2)/2 vertices, as if no vertex were shared). The recursion
 * then cannot fail; positions are shrunk to the real count at the end.
 * Midpoints are shared through a map keyed by the edge's two vertex indices,
 * so faces that share an edge (same OBJ vertex indices) share its midpoints
 * at every level. The faces are first cut along their contacts
 * (rad_contact.c; or kept whole): the builder subdivides pieces, each to
 * its own level, and keeps each piece's scene face for materials and groups.
 */
#include "rad_mesh.h"

#include <assert.h>
#include <stdlib.h>
#include <string.h>

#include "rad_box.h"
#include "rad_contact.h"
#include "rad_edge_map.h"
#include "rad_log.h"
#include "rad_polygon.h"

_Static_assert(sizeof(rad_patch) == 128, "rad_patch is the 128-byte patch record of the file formats");

/* Indices are uint32_t and RAD_NO_VERTEX (UINT32_MAX) is taken. */
#define MESH_LIMIT ((uint64_t)UINT32_MAX - 1)
/* A scene group that owns no patch (collect_groups' scratch): a group index,
 * not a vertex, so not RAD_NO_VERTEX, though of the same value. */
#define NO_GROUP UINT32_MAX

typedef struct builder {
    const rad_scene *scene;
    rad_mesh *mesh;
    rad_edge_map midpoints;  /* edge -> mesh vertex at its middle */
    size_t vertex_cap;       /* room in mesh->positions (the bound) */
    const rad_face *face;
    uint32_t face_index;
} builder;

static int is_subdivided(const rad_scene *scene, const rad_face *face, const char *only_group)
{
    return !only_group || strcmp(scene->groups[face->group], only_group) == 0;
}

static uint64_t add_saturating(uint64_t a, uint64_t b) { return a > UINT64_MAX - b ? UINT64_MAX : a + b; }

static double diameter_of(const double *positions, const uint32_t *v, uint32_t n)
{
    rad_box box = rad_box_of_corners(positions, v, n);
    return rad_box_diagonal(&box);
}

/* The pieces to subdivide (the faces cut along their contacts, or the
 * faces themselves) and each one's level (see rad_mesh.h); *out_level is
 * freed by the caller. */
static rad_status make_pieces(const rad_scene *scene, const rad_mesh_options *options, int log, rad_contact_cut *out_cut,
                              int **out_level)
{
    int subdiv = options ? options->subdiv : 0;
    const char *only_group = options ? options->only_group : NULL;
    rad_mesh_contacts contacts = options ? options->contacts : RAD_MESH_CONTACTS_CUT;
    rad_contact_cut cut;
    memset(&cut, 0, sizeof cut);
    if (contacts == RAD_MESH_CONTACTS_CUT) {
        int *face_level = malloc((scene->face_count ? scene->face_count : 1) * sizeof *face_level);
        if (!face_level) {
            rad_error("mesh: out of memory for %zu faces", scene->face_count);
            return RAD_ERR_NOMEM;
        }
        for (size_t f = 0; f < scene->face_count; f++)
            face_level[f] = is_subdivided(scene, &scene->faces[f], only_group) ? subdiv : 0;
        rad_status st = rad_contact_cut_build(scene, face_level, &cut);
        free(face_level);
        if (st != RAD_OK) return st;
        if (log)
            rad_info("contacts: %zu of %zu faces cut, %zu pieces dropped as hidden (%zu pieces meshed)", cut.faces_cut,
                     scene->face_count, cut.pieces_hidden, cut.piece_count);
        if (log && cut.near_count) {
            const rad_face *f = &scene->faces[cut.near_face], *g = &scene->faces[cut.near_cover];
            rad_warn("%s:%u: a face of '%s' lies %.3g in front of the face of '%s' at line %u, parallel to it and "
                     "facing the same way (%zu such pairs): farther than contact cutting reaches (%.3g here, 1e-3 of "
                     "the scene's size), so the part behind it stays in the mesh, unlit, and the patches along its "
                     "outline average light and shadow (a dark rim). Snap it onto that face (coplanar: then it is "
                     "cut out, as a panel on a ceiling) or within %.3g of it",
                     scene->path, g->line, scene->groups[g->group], cut.near_distance, scene->groups[f->group],
                     f->line, cut.near_count, cut.gap, cut.gap);
        }
    } else {
        cut.positions = malloc((scene->vertex_count ? scene->vertex_count : 1) * 3 * sizeof *cut.positions);
        cut.pieces = malloc((scene->face_count ? scene->face_count : 1) * sizeof *cut.pieces);
        if (!cut.positions || !cut.pieces) {
            rad_contact_cut_free(&cut);
            rad_error("mesh: out of memory for %zu faces", scene->face_count);
            return RAD_ERR_NOMEM;
        }
        memcpy(cut.positions, scene->positions, scene->vertex_count * 3 * sizeof *cut.positions);
        cut.vertex_count = scene->vertex_count;
        for (size_t f = 0; f < scene->face_count; f++) {
            const rad_face *face = &scene->faces[f];
            rad_contact_piece *p = &cut.pieces[f];
            p->vertex_count = face->vertex_count;
            rad_polygon_corners_store(face->v, face->vertex_count, p->v);
            p->source_face = (uint32_t)f;
        }
        cut.piece_count = scene->face_count;
    }
    int *level = malloc((cut.piece_count ? cut.piece_count : 1) * sizeof *level);
    if (!level) {
        rad_contact_cut_free(&cut);
        rad_error("mesh: out of memory for %zu pieces", cut.piece_count);
        return RAD_ERR_NOMEM;
    }
    for (size_t i = 0; i < cut.piece_count; i++) {
        const rad_contact_piece *p = &cut.pieces[i];
        const rad_face *face = &scene->faces[p->source_face];
        level[i] = 0;
        if (!is_subdivided(scene, face, only_group)) continue;
        double d_face = diameter_of(scene->positions, face->v, face->vertex_count);
        double d_piece = diameter_of(cut.positions, p->v, p->vertex_count);
        long drop = d_piece > 0 && d_piece < d_face ? lround(log2(d_face / d_piece)) : 0;
        level[i] = drop >= subdiv ? 0 : subdiv - (int)drop;
    }
    *out_cut = cut;
    *out_level = level;
    return RAD_OK;
}

static uint64_t sum_patches(const int *level, size_t count)
{
    uint64_t total = 0;
    for (size_t i = 0; i < count; i++)
        total = add_saturating(total, level[i] >= 32 ? UINT64_MAX : (uint64_t)1 << (2 * level[i]));
    return total;
}

uint64_t rad_mesh_count_patches(const rad_scene *scene, const rad_mesh_options *options)
{
    if (options && options->subdiv < 0) return 0;
    rad_contact_cut cut;
    int *level = NULL;
    if (make_pieces(scene, options, 0, &cut, &level) != RAD_OK) return UINT64_MAX;
    uint64_t total = sum_patches(level, cut.piece_count);
    free(level);
    rad_contact_cut_free(&cut);
    return total;
}

static rad_vec3 mesh_position(const rad_mesh *mesh, uint32_t i)
{
    const double *p = mesh->positions + 3 * (size_t)i;
    return rad_v3(p[0], p[1], p[2]);
}

static uint32_t add_vertex(builder *B, rad_vec3 p)
{
    rad_mesh *mesh = B->mesh;
    assert(mesh->vertex_count < B->vertex_cap);
    double *q = mesh->positions + 3 * mesh->vertex_count;
    q[0] = p.x;
    q[1] = p.y;
    q[2] = p.z;
    return (uint32_t)mesh->vertex_count++;
}

/* rad_polygon_vertex_fn: an edge's midpoint, one per edge (the midpoint
 * is symmetric in the edge's ends, so it does not depend on which face
 * asked first), or a quad's centre. */
static uint32_t split_vertex(void *context, uint32_t a, uint32_t b, rad_vec3 at)
{
    builder *B = context;
    if (a == RAD_NO_VERTEX) return add_vertex(B, at);
    uint32_t *slot;
    if (rad_edge_map_find(&B->midpoints, a, b, &slot)) return *slot;
    return *slot = add_vertex(B, at);
}

static void emit_patch(builder *B, const uint32_t *v, int n)
{
    rad_mesh *mesh = B->mesh;
    rad_patch *p = &mesh->patches[mesh->patch_count++];
    rad_vec3 corner[4];
    for (int i = 0; i < n; i++) corner[i] = mesh_position(mesh, v[i]);
    memset(p, 0, sizeof *p);
    p->vertex_count = (uint32_t)n;
    rad_polygon_corners_store(v, (uint32_t)n, p->v);
    p->source_face = B->face_index;
    rad_polygon_geometry(corner, n, &p->area, &p->normal, &p->centroid);
    const rad_material *m = &B->scene->materials[B->face->material];
    memcpy(p->rho, m->rho, sizeof p->rho);
    memcpy(p->emission, m->emission, sizeof p->emission);
}

/* Splits polygon v (n corners, in winding order) `level` more times. */
static void split(builder *B, const uint32_t *v, int n, int level)
{
    if (level == 0) {
        emit_patch(B, v, n);
        return;
    }
    rad_vec3 corner[4];
    uint32_t child[4][4];
    for (int i = 0; i < n; i++) corner[i] = mesh_position(B->mesh, v[i]);
    rad_polygon_split(v, corner, n, split_vertex, B, child);
    for (int i = 0; i < 4; i++) split(B, child[i], n, level - 1);
}

/* The groups that own patches, in the scene's order, and each patch's
 * index into them (group_of: scene->group_count entries of scratch). A
 * group whose every face contact cutting dropped (hidden inside or under
 * other geometry, or under a coincident face) owns none and is left out:
 * the files' group table holds no group without patches (the fuzzer's
 * scene of two coincident triangles in two groups). */
static rad_status collect_groups(const rad_scene *scene, rad_mesh *mesh, uint32_t *group_of)
{
    size_t used = 0;
    for (size_t g = 0; g < scene->group_count; g++) group_of[g] = NO_GROUP;
    for (size_t i = 0; i < mesh->patch_count; i++) group_of[scene->faces[mesh->patches[i].source_face].group] = 0;
    for (size_t g = 0; g < scene->group_count; g++)
        if (group_of[g] != NO_GROUP) group_of[g] = (uint32_t)used++;
    mesh->group_names = calloc(used ? used : 1, sizeof *mesh->group_names);
    if (!mesh->group_names) {
        rad_error("mesh: out of memory for %zu group names", used);
        return RAD_ERR_NOMEM;
    }
    for (size_t g = 0; g < scene->group_count; g++)
        for (size_t k = 0; group_of[g] != NO_GROUP && k < RAD_NAME_MAX - 1 && scene->groups[g][k]; k++)
            mesh->group_names[group_of[g]][k] = scene->groups[g][k];
    mesh->group_count = used;
    for (size_t i = 0; i < mesh->patch_count; i++)
        mesh->patch_group[i] = group_of[scene->faces[mesh->patches[i].source_face].group];
    return RAD_OK;
}

rad_status rad_mesh_set_groups(const rad_scene *scene, rad_mesh *mesh)
{
    for (size_t i = 0; i < mesh->patch_count; i++)
        if (mesh->patches[i].source_face >= scene->face_count) {
            rad_error("mesh: patch %zu names face %u of %zu", i, mesh->patches[i].source_face, scene->face_count);
            return RAD_ERR_INVALID;
        }
    free(mesh->group_names);
    free(mesh->patch_group);
    mesh->group_names = NULL;
    mesh->group_count = 0;
    mesh->patch_group = malloc((mesh->patch_count ? mesh->patch_count : 1) * sizeof *mesh->patch_group);
    uint32_t *group_of = malloc((scene->group_count ? scene->group_count : 1) * sizeof *group_of);
    rad_status status = mesh->patch_group && group_of ? collect_groups(scene, mesh, group_of) : RAD_ERR_NOMEM;
    if (status == RAD_ERR_NOMEM && (!mesh->patch_group || !group_of))
        rad_error("mesh: out of memory for the groups of %zu patches", mesh->patch_count);
    free(group_of);
    return status;
}

/* Upper bound on the vertices of one piece after `subdiv` levels (its own,
 * unshared). Only called while the patch count shows subdiv <= 15. */
static uint64_t face_vertex_bound(uint32_t corners, int subdiv)
{
    uint64_t side = ((uint64_t)1 << subdiv) + 1; /* vertices along an edge */
    return corners == 4 ? side * side : side * (side + 1) / 2;
}

rad_status rad_mesh_build(const rad_scene *scene, const rad_mesh_options *options, rad_mesh *out_mesh)
{
    rad_status status = RAD_ERR_NOMEM;
    rad_mesh mesh;
    builder B;
    rad_contact_cut cut;
    int *level = NULL;
    uint32_t *vertex_of = NULL; /* cut vertex (scene vertices first) -> mesh vertex */
    uint32_t *group_of = NULL;  /* scene group -> mesh group (NO_GROUP: owns no patch) */
    memset(&mesh, 0, sizeof mesh);
    memset(&B, 0, sizeof B);
    memset(&cut, 0, sizeof cut);
    int subdiv = options ? options->subdiv : 0;
    const char *only_group = options ? options->only_group : NULL;
    rad_mesh_contacts contacts = options ? options->contacts : RAD_MESH_CONTACTS_CUT;
    if (subdiv < 0) {
        rad_error("mesh: subdivision level %d is negative", subdiv);
        status = RAD_ERR_INVALID;
        goto done;
    }
    if (contacts != RAD_MESH_CONTACTS_CUT && contacts != RAD_MESH_CONTACTS_KEEP) {
        rad_error("mesh: contacts is %d, neither RAD_MESH_CONTACTS_CUT nor RAD_MESH_CONTACTS_KEEP", (int)contacts);
        status = RAD_ERR_INVALID;
        goto done;
    }
    if ((status = make_pieces(scene, options, 1, &cut, &level)) != RAD_OK) goto done;
    status = RAD_ERR_NOMEM;
    uint64_t patches = sum_patches(level, cut.piece_count), vertices = 0, midpoints = 0;
    size_t subdivided = 0;
    for (size_t f = 0; f < scene->face_count; f++) subdivided += is_subdivided(scene, &scene->faces[f], only_group);
    for (size_t i = 0; i < cut.piece_count && patches <= MESH_LIMIT; i++) {
        const rad_contact_piece *piece = &cut.pieces[i];
        assert(piece->vertex_count == 3 || piece->vertex_count == 4);
        uint64_t own = face_vertex_bound(piece->vertex_count, level[i]);
        midpoints += own - piece->vertex_count;
        vertices += own;
    }
    size_t table = 16;
    while (table < 2 * midpoints && table < SIZE_MAX / 4) table *= 2;
    double need = (double)patches * sizeof(rad_patch) + (double)vertices * 3 * sizeof(double) +
                  (double)table * (sizeof(uint64_t) + sizeof(uint32_t)) + (double)cut.vertex_count * sizeof(uint32_t);
    if (patches > MESH_LIMIT || vertices > MESH_LIMIT) {
        int too_many_patches = patches > MESH_LIMIT;
        rad_error("mesh: subdivision level %d gives %llu %s; at most %llu are possible (it would need about %.1f GiB)",
                  subdiv, (unsigned long long)(too_many_patches ? patches : vertices),
                  too_many_patches ? "patches" : "vertices (at most)", (unsigned long long)MESH_LIMIT,
                  need / (1024.0 * 1024 * 1024));
        goto done;
    }
    if (patches == 0 && scene->face_count > 0) {
        rad_error("%s: every face lies hidden inside or under other geometry (contact cutting); nothing is left to "
                  "mesh (--contacts keep meshes the faces as they are)", scene->path);
        status = RAD_ERR_INVALID;
        goto done;
    }
    if (only_group && subdivided == 0) rad_warn("mesh: no face is in group '%s'; nothing is subdivided", only_group);

    mesh.patches = malloc(((size_t)patches ? (size_t)patches : 1) * sizeof *mesh.patches);
    mesh.positions = malloc(((size_t)vertices ? (size_t)vertices : 1) * 3 * sizeof *mesh.positions);
    mesh.patch_group = malloc(((size_t)patches ? (size_t)patches : 1) * sizeof *mesh.patch_group);
    group_of = malloc((scene->group_count ? scene->group_count : 1) * sizeof *group_of);
    vertex_of = malloc((cut.vertex_count ? cut.vertex_count : 1) * sizeof *vertex_of);
    rad_status map = rad_edge_map_init(&B.midpoints, (size_t)midpoints);
    if (!mesh.patches || !mesh.positions || !mesh.patch_group || !group_of || !vertex_of || map != RAD_OK) {
        rad_error("mesh: out of memory (%llu patches need about %.1f MiB)", (unsigned long long)patches,
                  need / (1024.0 * 1024));
        goto done;
    }
    for (size_t i = 0; i < cut.vertex_count; i++) vertex_of[i] = RAD_NO_VERTEX;
    B.scene = scene;
    B.mesh = &mesh;
    B.vertex_cap = (size_t)vertices;

    /* Scene and cut vertices in order of first use, then each piece's new vertices. */
    for (size_t i = 0; i < cut.piece_count; i++) {
        const rad_contact_piece *piece = &cut.pieces[i];
        uint32_t corner[4];
        for (uint32_t k = 0; k < piece->vertex_count; k++) {
            uint32_t s = piece->v[k];
            if (vertex_of[s] == RAD_NO_VERTEX) {
                const double *p = cut.positions + 3 * (size_t)s;
                vertex_of[s] = add_vertex(&B, rad_v3(p[0], p[1], p[2]));
            }
            corner[k] = vertex_of[s];
        }
        B.face = &scene->faces[piece->source_face];
        B.face_index = piece->source_face;
        split(&B, corner, (int)piece->vertex_count, level[i]);
    }
    assert(mesh.patch_count == patches && mesh.vertex_count <= vertices);
    if ((status = collect_groups(scene, &mesh, group_of)) != RAD_OK) goto done;
    double *shrunk = realloc(mesh.positions, (mesh.vertex_count ? mesh.vertex_count : 1) * 3 * sizeof *shrunk);
    if (shrunk) mesh.positions = shrunk;
    *out_mesh = mesh;
    memset(&mesh, 0, sizeof mesh);
    status = RAD_OK;
done:
    rad_mesh_free(&mesh);
    rad_contact_cut_free(&cut);
    free(level);
    free(group_of);
    free(vertex_of);
    rad_edge_map_free(&B.midpoints);
    return status;
}

void rad_mesh_free(rad_mesh *mesh)
{
    if (!mesh) return;
    free(mesh->patches);
    free(mesh->positions);
    free(mesh->group_names);
    free(mesh->patch_group);
    memset(mesh, 0, sizeof *mesh);
}

int rad_patch_centroid_inside(const rad_patch *patch, const double *positions)
{
    const double c[3] = {patch->centroid.x, patch->centroid.y, patch->centroid.z};
    rad_box box = rad_box_of_corners(positions, patch->v, patch->vertex_count);
    for (int a = 0; a < 3; a++) {
        double lo = box.lo[a], hi = box.hi[a];
        double slack = 1e-9 * fmax(hi - lo, fmax(fabs(lo), fabs(hi)));
        if (!(c[a] >= lo - slack && c[a] <= hi + slack)) return 0;
    }
    return 1;
}
