/* rad_adjacency.c - vertex-to-patch adjacency and smooth surfaces
 * (contract in rad_adjacency.h). */
#include "rad_adjacency.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "rad_log.h"

#define SAME_MATERIAL_REL_TOL 1e-9

static int close_rel(double a, double b) { return fabs(a - b) <= SAME_MATERIAL_REL_TOL * fmax(fabs(a), fabs(b)); }

int rad_same_material(const rad_patch *a, const rad_patch *b)
{
    for (int c = 0; c < 3; c++)
        if (!close_rel(a->rho[c], b->rho[c]) || !close_rel(a->emission[c], b->emission[c])) return 0;
    return 1;
}

int rad_same_surface(const rad_patch *a, const rad_patch *b, double crease_cos)
{
    return !(rad_v3_dot(a->normal, b->normal) < crease_cos) && rad_same_material(a, b);
}

rad_status rad_vertex_patches_build(const rad_mesh *mesh, rad_vertex_patches *out)
{
    rad_status status = RAD_OK;
    size_t nv = mesh->vertex_count;
    size_t *start = calloc(nv + 1, sizeof *start);
    uint32_t *list = NULL;
    size_t *fill = NULL;
    if (!start) goto nomem;
    for (size_t p = 0; p < mesh->patch_count; p++) {
        const rad_patch *patch = &mesh->patches[p];
        for (uint32_t k = 0; k < patch->vertex_count && k < 4; k++) {
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
        for (uint32_t k = 0; k < patch->vertex_count && k < 4; k++) list[fill[patch->v[k]]++] = (uint32_t)p;
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

void rad_vertex_patches_free(rad_vertex_patches *adj)
{
    if (!adj) return;
    free(adj->start);
    free(adj->list);
    adj->start = NULL;
    adj->list = NULL;
}
