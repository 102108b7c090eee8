#include "ff_setup.h"

#include <float.h>
#include <math.h>
#include <stdlib.h>

#include "ff_bvh.h"
#include "rad_box.h"
#include "rad_log.h"

void ff_frame_centre(const rad_mesh *mesh, double centre[3])
{
    rad_box box = rad_box_of_points(mesh->positions, mesh->vertex_count);
    rad_box_centre(&box, centre);
}

/* A mesh vertex in patch p's corner k, in the backends' frame; a vertex
 * that is not one of the source face's own (a midpoint, a contact-cut
 * vertex, another face's vertex a cut piece reuses) is put into the face's
 * plane. Contact cutting can leave such vertices off it by the rounding of
 * the other face's geometry (1e-8 in a model with a double-sided sheet:
 * its two coincident faces then faced each other, F = 1, rows of 2). */
static rad_vec3 patch_corner(const rad_scene *scene, const double *positions, const rad_patch *p, uint32_t k,
                             rad_vec3 face_normal, rad_vec3 face_point, const double centre[3])
{
    uint32_t v = p->v[k < p->vertex_count ? k : 2];
    rad_vec3 x = rad_v3(positions[3 * (size_t)v], positions[3 * (size_t)v + 1], positions[3 * (size_t)v + 2]);
    const rad_face *face = &scene->faces[p->source_face];
    /* By position: the mesh numbers its vertices its own way (unused scene
     * vertices left out, midpoints in the order they were made), so an
     * index says nothing about the scene's. */
    int own = 0;
    for (uint32_t c = 0; c < face->vertex_count; c++) {
        const double *s = scene->positions + 3 * (size_t)face->v[c];
        own |= s[0] == x.x && s[1] == x.y && s[2] == x.z;
    }
    if (!own) x = rad_v3_sub(x, rad_v3_scale(face_normal, rad_v3_dot(face_normal, rad_v3_sub(x, face_point))));
    return rad_v3(x.x - centre[0], x.y - centre[1], x.z - centre[2]);
}

void ff_patch_make(const rad_scene *scene, const double *positions, const rad_patch *p, const double centre[3],
                   rad_ff_patch *q)
{
    const rad_face *face = &scene->faces[p->source_face];
    rad_vec3 fv[4], face_normal, face_point;
    double face_area;
    for (uint32_t c = 0; c < face->vertex_count; c++)
        fv[c] = rad_v3(scene->positions[3 * (size_t)face->v[c]], scene->positions[3 * (size_t)face->v[c] + 1],
                       scene->positions[3 * (size_t)face->v[c] + 2]);
    rad_polygon_geometry(fv, (int)face->vertex_count, &face_area, &face_normal, &face_point);
    for (uint32_t k = 0; k < 4; k++) q->p[k] = patch_corner(scene, positions, p, k, face_normal, face_point, centre);
    q->normal = p->normal;
    q->centre = rad_v3(0, 0, 0);
    for (uint32_t k = 0; k < p->vertex_count; k++) q->centre = rad_v3_add(q->centre, q->p[k]);
    q->centre = rad_v3_scale(q->centre, 1.0 / p->vertex_count);
    q->radius = 0;
    for (uint32_t k = 0; k < p->vertex_count; k++) {
        double r = rad_v3_length(rad_v3_sub(q->p[k], q->centre));
        q->radius = r > q->radius ? r : q->radius;
    }
    q->area = p->area;
    q->face = p->source_face;
    q->vertex_count = p->vertex_count;
    q->split = 1.0;
    if (p->vertex_count == 4) {
        double first = 0.5 * rad_v3_length(rad_v3_cross(rad_v3_sub(q->p[1], q->p[0]), rad_v3_sub(q->p[2], q->p[0])));
        double second = 0.5 * rad_v3_length(rad_v3_cross(rad_v3_sub(q->p[2], q->p[0]), rad_v3_sub(q->p[3], q->p[0])));
        q->split = first / (first + second);
    }
    q->inv_split = 1.0 / q->split;
    q->inv_rest = q->split < 1.0 ? 1.0 / (1.0 - q->split) : 0.0;
}

rad_status ff_patches_build(const rad_scene *scene, const rad_mesh *mesh, const double centre[3],
                            rad_ff_patch **out_patches)
{
    rad_ff_patch *out = malloc(sizeof *out * (mesh->patch_count ? mesh->patch_count : 1));
    if (!out) {
        rad_error("out of memory for %zu patches", mesh->patch_count);
        return RAD_ERR_NOMEM;
    }
    for (size_t i = 0; i < mesh->patch_count; i++) ff_patch_make(scene, mesh->positions, &mesh->patches[i], centre, &out[i]);
    *out_patches = out;
    return RAD_OK;
}

rad_status ff_occluders_build(const rad_scene *scene, const double centre[3], double **out_triangles,
                              uint32_t **out_triangle_face, uint32_t *out_triangle_count)
{
    uint32_t count = 0;
    for (size_t f = 0; f < scene->face_count; f++) count += scene->faces[f].vertex_count - 2;
    double *tri = malloc(sizeof *tri * 9 * (count ? count : 1));
    uint32_t *face = malloc(sizeof *face * (count ? count : 1));
    if (!tri || !face) {
        free(tri);
        free(face);
        rad_error("out of memory for %u occluder triangles", count);
        return RAD_ERR_NOMEM;
    }
    uint32_t t = 0;
    for (size_t f = 0; f < scene->face_count; f++) {
        const rad_face *fc = &scene->faces[f];
        for (uint32_t k = 1; k + 1 < fc->vertex_count; k++, t++) {
            uint32_t corner[3] = {fc->v[0], fc->v[k], fc->v[k + 1]};
            for (int c = 0; c < 3; c++)
                for (int a = 0; a < 3; a++)
                    tri[9 * t + 3 * c + a] = scene->positions[3 * corner[c] + a] - centre[a];
            face[t] = (uint32_t)f;
        }
    }
    *out_triangles = tri;
    *out_triangle_face = face;
    *out_triangle_count = count;
    return RAD_OK;
}

/* The bounding-box diagonal of the mesh. */
static double mesh_diagonal(const rad_mesh *mesh)
{
    rad_box box = rad_box_of_points(mesh->positions, mesh->vertex_count);
    return rad_box_diagonal(&box);
}

double ff_plane_eps(const rad_mesh *mesh)
{
    return 1e-11 * mesh_diagonal(mesh);
}

double ff_ray_delta(const rad_mesh *mesh)
{
    return FF_RAY_DELTA * mesh_diagonal(mesh);
}

float ff_cull_margin(const rad_mesh *mesh, const double centre[3], double eps)
{
    double largest = 0;
    for (size_t k = 0; k < 3 * mesh->vertex_count; k++) largest = fmax(largest, fabs(mesh->positions[k] - centre[k % 3]));
    return (float)fmax(1e4 * eps, 8.0 * FLT_EPSILON * largest);
}

rad_status ff_partition_rows(const rad_ff_patch *patches, uint32_t n, double eps, int ranks, uint32_t *out_begin)
{
    double *prefix = malloc(sizeof *prefix * ((size_t)n + 1));
    if (!prefix) {
        rad_error("out of memory partitioning %u rows", n);
        return RAD_ERR_NOMEM;
    }
    uint32_t probes = n < FF_PARTITION_PROBES ? n : FF_PARTITION_PROBES;
    prefix[0] = 0;
    /* Each row's cost on the threads (N x probes tests: 0.7 s on one core
     * at N = 188 416), then their running sum in row order. */
#pragma omp parallel for schedule(static) if (n >= 1024)
    for (uint32_t i = 0; i < n; i++) {
        uint32_t facing = 0;
        for (uint32_t p = 0; p < probes; p++) {
            uint32_t j = (uint32_t)((uint64_t)p * n / probes);
            facing += j != i && rad_ff_pair_facing(&patches[i], &patches[j], eps);
        }
        /* Every row also costs its loop and its write: at least one unit. */
        prefix[i + 1] = 1.0 + (double)facing * n / (probes ? probes : 1);
    }
    for (uint32_t i = 0; i < n; i++) prefix[i + 1] += prefix[i];
    out_begin[0] = 0;
    uint32_t i = 0;
    for (int r = 1; r < ranks; r++) {
        double target = prefix[n] * r / ranks;
        while (i < n && prefix[i + 1] <= target) i++;
        out_begin[r] = i;
    }
    out_begin[ranks] = n;
    free(prefix);
    return RAD_OK;
}

