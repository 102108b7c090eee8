/* rad_patch_table.c - the shared vertex and patch tables (rad_patch_table.h). */
#include "rad_patch_table.h"

#include <math.h>

#include "rad_bytes.h"
#include "rad_log.h"

/* The tables run to hundreds of megabytes at 10^6 faces (0.27 s of a
 * formfactor --radiosity run on one thread): encoded and decoded on the
 * threads, each record where it goes. */
#define TABLE_THREADS_FROM 65536 /* records: fewer on one thread */

void rad_patch_table_encode(const rad_mesh *mesh, unsigned char *vertices, unsigned char *patches)
{
#pragma omp parallel for schedule(static) if (mesh->vertex_count > TABLE_THREADS_FROM)
    for (size_t i = 0; i < 3 * mesh->vertex_count; i++) rad_put_f64(vertices + 8 * i, mesh->positions[i]);
#pragma omp parallel for schedule(static) if (mesh->patch_count > TABLE_THREADS_FROM)
    for (size_t i = 0; i < mesh->patch_count; i++) {
        const rad_patch *patch = &mesh->patches[i];
        unsigned char *p = patches + RAD_PATCH_RECORD_BYTES * i;
        rad_put_u32(p + 0, patch->vertex_count);
        for (int k = 0; k < 4; k++) rad_put_u32(p + 4 + 4 * k, patch->v[k]);
        rad_put_u32(p + 20, patch->source_face);
        rad_put_f64(p + 24, patch->area);
        const double vec[6] = {patch->normal.x,   patch->normal.y,   patch->normal.z,
                               patch->centroid.x, patch->centroid.y, patch->centroid.z};
        for (int k = 0; k < 6; k++) rad_put_f64(p + 32 + 8 * k, vec[k]);
        for (int c = 0; c < 3; c++) rad_put_f64(p + 80 + 8 * c, patch->rho[c]);
        for (int c = 0; c < 3; c++) rad_put_f64(p + 104 + 8 * c, patch->emission[c]);
    }
}

void rad_patch_table_decode(const unsigned char *vertices, const unsigned char *patches, rad_mesh *mesh)
{
#pragma omp parallel for schedule(static) if (mesh->vertex_count > TABLE_THREADS_FROM)
    for (size_t i = 0; i < 3 * mesh->vertex_count; i++) mesh->positions[i] = rad_get_f64(vertices + 8 * i);
#pragma omp parallel for schedule(static) if (mesh->patch_count > TABLE_THREADS_FROM)
    for (size_t i = 0; i < mesh->patch_count; i++) {
        const unsigned char *p = patches + RAD_PATCH_RECORD_BYTES * i;
        rad_patch *patch = &mesh->patches[i];
        patch->vertex_count = rad_get_u32(p + 0);
        for (int k = 0; k < 4; k++) patch->v[k] = rad_get_u32(p + 4 + 4 * k);
        patch->source_face = rad_get_u32(p + 20);
        patch->area = rad_get_f64(p + 24);
        patch->normal = rad_v3(rad_get_f64(p + 32), rad_get_f64(p + 40), rad_get_f64(p + 48));
        patch->centroid = rad_v3(rad_get_f64(p + 56), rad_get_f64(p + 64), rad_get_f64(p + 72));
        for (int c = 0; c < 3; c++) patch->rho[c] = rad_get_f64(p + 80 + 8 * c);
        for (int c = 0; c < 3; c++) patch->emission[c] = rad_get_f64(p + 104 + 8 * c);
    }
}

/* What is wrong with patch p (NULL: nothing); `positions` checked finite. */
static const char *patch_fault(const rad_patch *p, const rad_mesh *mesh)
{
    if (p->vertex_count != 3 && p->vertex_count != 4) return "vertex count is not 3 or 4";
    if (p->vertex_count == 3 && p->v[3] != RAD_NO_VERTEX) return "triangle has a fourth vertex";
    for (uint32_t k = 0; k < p->vertex_count; k++)
        if (p->v[k] >= mesh->vertex_count) return "vertex index out of range";
    if (!(p->area > 0) || !isfinite(p->area)) return "area is not positive and finite";
    if (!(fabs(rad_v3_length(p->normal) - 1) <= RAD_PATCH_NORMAL_TOLERANCE)) return "normal is not a unit vector";
    if (!rad_patch_centroid_inside(p, mesh->positions)) return "centroid is not inside the patch";
    for (int c = 0; c < 3; c++) {
        if (!(p->rho[c] >= 0 && p->rho[c] < 1)) return "reflectance outside [0,1)";
        if (!(p->emission[c] >= 0) || !isfinite(p->emission[c])) return "emission negative or not finite";
    }
    return NULL;
}

rad_status rad_patch_table_check(const char *path, const rad_mesh *mesh)
{
    for (size_t i = 0; i < 3 * mesh->vertex_count; i++)
        if (!isfinite(mesh->positions[i])) {
            rad_error("%s: vertex %zu: coordinate is not finite", path, i / 3);
            return RAD_ERR_FORMAT;
        }
    for (size_t i = 0; i < mesh->patch_count; i++) {
        const char *why = patch_fault(&mesh->patches[i], mesh);
        if (why) {
            rad_error("%s: patch %zu: %s", path, i, why);
            return RAD_ERR_FORMAT;
        }
    }
    return RAD_OK;
}
