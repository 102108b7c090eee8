#include "shade.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "rad_log.h"

/* Same material: rho and emission equal to this relative precision.
 * Patches of one face copy their face's material, so in practice they are
 * identical; the tolerance only absorbs materials printed and reparsed. */
#define RENDER_MATERIAL_REL_TOL 1e-9

static int close_rel(double a, double b) { return fabs(a - b) <= RENDER_MATERIAL_REL_TOL * fmax(fabs(a), fabs(b)); }

static int same_surface(const rad_patch *a, const rad_patch *b, double crease_cos)
{
    if (rad_v3_dot(a->normal, b->normal) < crease_cos) return 0;
    for (int c = 0; c < 3; c++)
        if (!close_rel(a->rho[c], b->rho[c]) || !close_rel(a->emission[c], b->emission[c])) return 0;
    return 1;
}

/* vertex -> incident patches, as compressed rows: patches of vertex v are
 * list[start[v] .. start[v + 1]). */
typedef struct vertex_patches {
    size_t *start;
    uint32_t *list;
} vertex_patches;

static rad_status build_vertex_patches(const rad_mesh *mesh, vertex_patches *out)
{
    rad_status status = RAD_OK;
    size_t nv = mesh->vertex_count;
    size_t *start = calloc(nv + 1, sizeof *start);
    uint32_t *list = NULL;
    size_t *fill = NULL;
    if (!start) goto nomem;
    for (size_t p = 0; p < mesh->patch_count; p++) {
        const rad_patch *patch = &mesh->patches[p];
        for (uint32_t k = 0; k < patch->vertex_count; k++) {
            if (patch->v[k] >= nv) {
                rad_error("patch %zu: vertex index %u out of range (%zu vertices)", p, patch->v[k], nv);
                status = RAD_ERR_INVALID;
                goto done;
            }
            start[patch->v[k] + 1]++;
        }
    }
    for (size_t v = 0; v < nv; v++) start[v + 1] += start[v];
    list = malloc((start[nv] ? start[nv] : 1) * sizeof *list);
    fill = malloc((nv ? nv : 1) * sizeof *fill);
    if (!list || !fill) goto nomem;
    memcpy(fill, start, nv * sizeof *fill);
    for (size_t p = 0; p < mesh->patch_count; p++) {
        const rad_patch *patch = &mesh->patches[p];
        for (uint32_t k = 0; k < patch->vertex_count; k++) list[fill[patch->v[k]]++] = (uint32_t)p;
    }
    out->start = start;
    out->list = list;
    start = NULL;
    list = NULL;
    goto done;
nomem:
    rad_error("out of memory building vertex adjacency (%zu vertices)", nv);
    status = RAD_ERR_NOMEM;
done:
    free(start);
    free(list);
    free(fill);
    return status;
}

rad_status render_shade_corners(const rad_mesh *mesh, const double *radiosity, int channels, render_shading shading,
                                double *out_corners)
{
    rad_status status = RAD_OK;
    vertex_patches adj = {NULL, NULL};
    const size_t nc = (size_t)channels;
    if (channels != 1 && channels != 3) {
        rad_error("%d colour channels (expected 1 or 3)", channels);
        return RAD_ERR_INVALID;
    }
    memset(out_corners, 0, mesh->patch_count * 4 * nc * sizeof *out_corners);
    for (size_t p = 0; p < mesh->patch_count; p++) {
        if (mesh->patches[p].vertex_count < 3 || mesh->patches[p].vertex_count > 4) {
            rad_error("patch %zu has %u vertices (expected 3 or 4)", p, mesh->patches[p].vertex_count);
            status = RAD_ERR_INVALID;
            goto done;
        }
    }
    if (shading == RENDER_SHADING_FLAT) {
        for (size_t p = 0; p < mesh->patch_count; p++)
            for (uint32_t k = 0; k < mesh->patches[p].vertex_count; k++)
                memcpy(&out_corners[(4 * p + k) * nc], &radiosity[3 * p], nc * sizeof *radiosity);
        goto done;
    }
    status = build_vertex_patches(mesh, &adj);
    if (status != RAD_OK) goto done;
    double crease_cos = cos(RENDER_CREASE_DEGREES * RAD_PI / 180.0);
    for (size_t p = 0; p < mesh->patch_count; p++) {
        const rad_patch *patch = &mesh->patches[p];
        for (uint32_t k = 0; k < patch->vertex_count; k++) {
            uint32_t v = patch->v[k];
            double sum[3] = {0, 0, 0}, area = 0.0;
            for (size_t e = adj.start[v]; e < adj.start[v + 1]; e++) {
                uint32_t q = adj.list[e];
                if (q != p && !same_surface(patch, &mesh->patches[q], crease_cos)) continue;
                double a = mesh->patches[q].area;
                area += a;
                for (size_t c = 0; c < nc; c++) sum[c] += a * radiosity[3 * (size_t)q + c];
            }
            double *dst = &out_corners[(4 * p + k) * nc];
            for (size_t c = 0; c < nc; c++) dst[c] = area > 0.0 ? sum[c] / area : radiosity[3 * p + c];
        }
    }
done:
    free(adj.start);
    free(adj.list);
    return status;
}
