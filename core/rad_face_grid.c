/* rad_face_grid.c - the uniform grid over faces' boxes (rad_face_grid.h):
 * sized to about one cell per face, filled by counting then placing (so a
 * cell's faces stay in face order), walked by rays cell by cell
 * (Amanatides and Woo's traversal). */
#include "rad_face_grid.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "rad_log.h"

/* At most this many cells (32 MiB of offsets); a scene with more faces
 * gets more faces per cell. */
#define FACE_GRID_MAX_CELLS (1u << 23)

static uint32_t clamp_cell(double x, uint32_t n)
{
    if (!(x > 0)) return 0;
    return x >= n ? n - 1 : (uint32_t)x;
}

void rad_face_grid_cells(const rad_face_grid *g, const rad_box *b, uint32_t lo[3], uint32_t hi[3])
{
    for (int a = 0; a < 3; a++) {
        lo[a] = clamp_cell((b->lo[a] - g->lo[a]) / g->cell[a], g->n[a]);
        hi[a] = clamp_cell((b->hi[a] - g->lo[a]) / g->cell[a], g->n[a]);
    }
}

/* Cells per axis: about `target` cells in all, cubes where the bounds
 * allow, one layer along an extent far below the others. */
static void size_grid(rad_face_grid *g, uint32_t target)
{
    double ext[3], longest = 0;
    for (int a = 0; a < 3; a++) ext[a] = g->hi[a] - g->lo[a], longest = fmax(longest, ext[a]);
    double volume = 1;
    int dims = 0;
    for (int a = 0; a < 3; a++)
        if (ext[a] > 1e-3 * longest) volume *= ext[a], dims++;
    const double h = dims ? pow(volume / target, 1.0 / dims) : 1;
    for (int a = 0; a < 3; a++) {
        double cells = ext[a] > 1e-3 * longest && h > 0 ? ceil(ext[a] / h) : 1;
        g->n[a] = cells < 1 ? 1 : cells > 4096 ? 4096 : (uint32_t)cells;
        g->cell[a] = ext[a] > 0 ? ext[a] / g->n[a] : 1;
    }
    while ((uint64_t)g->n[0] * g->n[1] * g->n[2] > FACE_GRID_MAX_CELLS)
        for (int a = 0; a < 3; a++)
            if (g->n[a] > 1) g->n[a] = (g->n[a] + 1) / 2, g->cell[a] = ext[a] > 0 ? ext[a] / g->n[a] : 1;
}

rad_status rad_face_grid_build(const rad_box *boxes, uint32_t count, double margin, rad_face_grid *out)
{
    rad_face_grid g;
    memset(&g, 0, sizeof g);
    for (int a = 0; a < 3; a++) g.lo[a] = INFINITY, g.hi[a] = -INFINITY;
    for (uint32_t f = 0; f < count; f++)
        for (int a = 0; a < 3; a++) {
            g.lo[a] = fmin(g.lo[a], boxes[f].lo[a] - margin);
            g.hi[a] = fmax(g.hi[a], boxes[f].hi[a] + margin);
        }
    if (!count)
        for (int a = 0; a < 3; a++) g.lo[a] = 0, g.hi[a] = 1;
    size_grid(&g, count ? count : 1);
    const uint64_t cells = (uint64_t)g.n[0] * g.n[1] * g.n[2];
    g.first = calloc(cells + 1, sizeof *g.first);
    if (!g.first) goto nomem;
    /* count, then place: faces ascend within each cell */
    for (int pass = 0; pass < 2; pass++) {
        for (uint32_t f = 0; f < count; f++) {
            rad_box b = boxes[f];
            for (int a = 0; a < 3; a++) b.lo[a] -= margin, b.hi[a] += margin;
            uint32_t lo[3], hi[3];
            rad_face_grid_cells(&g, &b, lo, hi);
            for (uint32_t z = lo[2]; z <= hi[2]; z++)
                for (uint32_t y = lo[1]; y <= hi[1]; y++)
                    for (uint32_t x = lo[0]; x <= hi[0]; x++) {
                        const uint64_t c = ((uint64_t)z * g.n[1] + y) * g.n[0] + x;
                        if (pass == 0) {
                            if (g.first[c + 1] == UINT32_MAX) goto nomem;
                            g.first[c + 1]++;
                        } else {
                            g.items[g.first[c]++] = f;
                        }
                    }
        }
        if (pass == 0) {
            uint64_t total = 0;
            for (uint64_t c = 0; c < cells; c++) {
                total += g.first[c + 1];
                if (total > UINT32_MAX) goto nomem;
                g.first[c + 1] = (uint32_t)total;
            }
            g.items = malloc((total ? total : 1) * sizeof *g.items);
            if (!g.items) goto nomem;
        } else { /* first[c] counted up to first[c + 1]: shift back */
            for (uint64_t c = cells; c > 0; c--) g.first[c] = g.first[c - 1];
            g.first[0] = 0;
        }
    }
    *out = g;
    return RAD_OK;
nomem:
    rad_error("face grid: out of memory for %u faces", count);
    rad_face_grid_free(&g);
    return RAD_ERR_NOMEM;
}

void rad_face_grid_free(rad_face_grid *g)
{
    if (!g) return;
    free(g->first);
    free(g->items);
    memset(g, 0, sizeof *g);
}

void rad_face_grid_ray(const rad_face_grid *g, const double p[3], const double d[3], rad_face_grid_visit visit,
                       void *user)
{
    /* the ray's span inside the grid's bounds (slabs), from t = 0 */
    double t0 = 0, t1 = INFINITY;
    for (int a = 0; a < 3; a++) {
        if (d[a] == 0) {
            if (p[a] < g->lo[a] || p[a] > g->hi[a]) return;
            continue;
        }
        double ta = (g->lo[a] - p[a]) / d[a], tb = (g->hi[a] - p[a]) / d[a];
        if (ta > tb) {
            double t = ta;
            ta = tb;
            tb = t;
        }
        t0 = fmax(t0, ta);
        t1 = fmin(t1, tb);
    }
    if (!(t0 <= t1)) return;
    uint32_t c[3];
    int step[3];
    double t_next[3], t_delta[3];
    for (int a = 0; a < 3; a++) {
        c[a] = clamp_cell((p[a] + t0 * d[a] - g->lo[a]) / g->cell[a], g->n[a]);
        if (d[a] > 0) {
            step[a] = 1;
            t_next[a] = (g->lo[a] + (c[a] + 1) * g->cell[a] - p[a]) / d[a];
            t_delta[a] = g->cell[a] / d[a];
        } else if (d[a] < 0) {
            step[a] = -1;
            t_next[a] = (g->lo[a] + c[a] * g->cell[a] - p[a]) / d[a];
            t_delta[a] = -g->cell[a] / d[a];
        } else {
            step[a] = 0;
            t_next[a] = t_delta[a] = INFINITY;
        }
    }
    for (;;) {
        int a = t_next[0] <= t_next[1] ? (t_next[0] <= t_next[2] ? 0 : 2) : (t_next[1] <= t_next[2] ? 1 : 2);
        const double t_exit = fmin(t_next[a], t1);
        uint32_t count;
        const uint32_t *faces = rad_face_grid_cell(g, c[0], c[1], c[2], &count);
        if (visit(user, faces, count, t_exit)) return;
        if (t_next[a] >= t1) return;
        if ((step[a] < 0 && c[a] == 0) || (step[a] > 0 && c[a] + 1 >= g->n[a])) return;
        c[a] = (uint32_t)((int64_t)c[a] + step[a]);
        t_next[a] += t_delta[a];
    }
}
