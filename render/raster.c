#include "raster.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "rad_log.h"

/* Vertex coordinates are snapped to 1/2^SUBPIXEL_BITS of a sample. With
 * the guard band and RENDER_MAX_SAMPLE_DIM, |coordinate| < 2^27 in these
 * units, so edge functions (products of two differences) stay below 2^56. */
#define SUBPIXEL_BITS 8
#define SUBPIXEL_ONE ((int64_t)1 << SUBPIXEL_BITS)
#define SUBPIXEL_HALF (SUBPIXEL_ONE / 2)
/* Clipping keeps |x| <= GUARD_BAND * w and |y| <= GUARD_BAND * w. */
#define GUARD_BAND 16.0
/* Output pixel rows per band: small enough that a band's samples stay in
 * cache-friendly buffers, large enough that per-band triangle setup is
 * negligible. */
#define BAND_ROWS 16
/* A triangle clipped by 5 planes has at most 3 + 5 vertices. */
#define CLIP_MAX 8

typedef struct raster_tri {
    int64_t x[3], y[3];      /* snapped sample coordinates, counter-clockwise on screen (area > 0) */
    int64_t area2;           /* twice the signed area, > 0 */
    int64_t bias[3];         /* 0 for top-left edges, -1 for the others */
    int64_t i0, i1, j0, j1;  /* sample index bounds (inclusive), clamped to the image */
    double inv_w[3];
    double color_w[3][3];    /* color / w; the first `channels` of each row are set */
} raster_tri;

typedef struct raster_tri_list {
    raster_tri *items;
    size_t count, capacity;
} raster_tri_list;

rad_status render_raster_check(const render_raster_options *options, int *out_n)
{
    int spp = options->spp ? options->spp : RENDER_DEFAULT_SPP;
    int n = (int)lround(sqrt((double)spp));
    if (spp < 1 || spp > RENDER_MAX_SPP || n * n != spp) {
        rad_error("spp %d is not a square number between 1 and %d (1, 4, 9, 16, ...)", spp, RENDER_MAX_SPP);
        return RAD_ERR_INVALID;
    }
    if (options->width < 1 || options->height < 1 || options->width > RENDER_MAX_SAMPLE_DIM / n ||
        options->height > RENDER_MAX_SAMPLE_DIM / n) {
        rad_error("image size %dx%d at %d spp is outside 1..%d samples per side", options->width, options->height,
                  spp, RENDER_MAX_SAMPLE_DIM);
        return RAD_ERR_INVALID;
    }
    if (!(options->near_w > 0.0) || !isfinite(options->near_w)) {
        rad_error("near clipping distance %g is not positive", options->near_w);
        return RAD_ERR_INVALID;
    }
    if (options->channels != 0 && options->channels != 1 && options->channels != 3) {
        rad_error("%d channels per pixel (expected 1 or 3)", options->channels);
        return RAD_ERR_INVALID;
    }
    if (out_n) *out_n = n;
    return RAD_OK;
}

/* Values per pixel: 1 or 3 (0 means 3). */
static int channels_of(const render_raster_options *options) { return options->channels == 1 ? 1 : 3; }

static int64_t floor_div(int64_t a, int64_t b) { return a >= 0 ? a / b : -((-a + b - 1) / b); }

/* Signed distance-like value of a clip vertex against plane k (inside >= 0). */
static double plane_value(const render_vertex *v, int plane, double near_w)
{
    switch (plane) {
    case 0: return v->w - near_w;
    case 1: return GUARD_BAND * v->w - v->x;
    case 2: return GUARD_BAND * v->w + v->x;
    case 3: return GUARD_BAND * v->w - v->y;
    default: return GUARD_BAND * v->w + v->y;
    }
}

/* The point where edge (in -> out) crosses the plane, always computed from
 * the inside vertex so that an edge shared by two triangles gets the same
 * point in both (no cracks along clipped edges). */
static render_vertex clip_point(const render_vertex *in, double d_in, const render_vertex *out, double d_out,
                                int nc)
{
    double t = d_in / (d_in - d_out);
    render_vertex r = {0, 0, 0, {0, 0, 0}};
    r.x = in->x + t * (out->x - in->x);
    r.y = in->y + t * (out->y - in->y);
    r.w = in->w + t * (out->w - in->w);
    for (int c = 0; c < nc; c++) r.color[c] = (float)(in->color[c] + t * (out->color[c] - in->color[c]));
    return r;
}

/* Sutherland-Hodgman against the near plane and the guard band. */
static int clip_polygon(const render_vertex *tri, double near_w, int nc, render_vertex *out_poly)
{
    render_vertex buf[2][CLIP_MAX];
    int count = 3;
    memcpy(buf[0], tri, 3 * sizeof *tri);
    int cur = 0;
    for (int plane = 0; plane < 5 && count > 0; plane++) {
        const render_vertex *src = buf[cur];
        render_vertex *dst = buf[1 - cur];
        double d[CLIP_MAX];
        int n = 0, changes = 0;
        for (int k = 0; k < count; k++) d[k] = plane_value(&src[k], plane, near_w);
        for (int k = 0; k < count; k++) changes += (d[k] >= 0) != (d[(k + 1) % count] >= 0);
        /* A convex polygon crosses a plane at most twice, adding at most one
         * vertex. More crossings are rounding of vertices that lie in the
         * plane (values alternating around 0): keep the inside ones only,
         * so the buffer's bound holds whatever the signs come out as. */
        int split = changes <= 2;
        for (int k = 0; k < count; k++) {
            const render_vertex *a = &src[k], *b = &src[(k + 1) % count];
            double da = d[k], db = d[(k + 1) % count];
            if (da >= 0) dst[n++] = *a;
            if (split && (da >= 0) != (db >= 0))
                dst[n++] = da >= 0 ? clip_point(a, da, b, db, nc) : clip_point(b, db, a, da, nc);
        }
        count = n;
        cur = 1 - cur;
    }
    memcpy(out_poly, buf[cur], (size_t)count * sizeof *out_poly);
    return count;
}

static int is_top_left(int64_t dx, int64_t dy) { return dy < 0 || (dy == 0 && dx > 0); }

/* Screen-space setup of one clipped triangle; returns 0 if it is culled,
 * degenerate or covers no sample centre. */
static int setup_triangle(const render_vertex *v0, const render_vertex *v1, const render_vertex *v2, int ws,
                          int hs, int cull, int nc, raster_tri *out)
{
    const render_vertex *v[3] = {v0, v1, v2};
    raster_tri t;
    memset(t.color_w, 0, sizeof t.color_w);
    for (int k = 0; k < 3; k++) {
        double sx = 0.5 * (v[k]->x / v[k]->w + 1.0) * ws;
        double sy = 0.5 * (1.0 - v[k]->y / v[k]->w) * hs;
        t.x[k] = llround(sx * SUBPIXEL_ONE);
        t.y[k] = llround(sy * SUBPIXEL_ONE);
        t.inv_w[k] = 1.0 / v[k]->w;
        for (int c = 0; c < nc; c++) t.color_w[k][c] = v[k]->color[c] * t.inv_w[k];
    }
    /* With +y down, a counter-clockwise (front-facing) triangle has a
     * negative edge-function area; flip it to positive. */
    int64_t area2 = (t.x[1] - t.x[0]) * (t.y[2] - t.y[0]) - (t.y[1] - t.y[0]) * (t.x[2] - t.x[0]);
    if (area2 == 0 || (cull && area2 > 0)) return 0;
    if (area2 < 0) {
        int64_t sx = t.x[1], sy = t.y[1];
        double iw = t.inv_w[1], cw[3] = {t.color_w[1][0], t.color_w[1][1], t.color_w[1][2]};
        t.x[1] = t.x[2]; t.y[1] = t.y[2]; t.inv_w[1] = t.inv_w[2];
        memcpy(t.color_w[1], t.color_w[2], sizeof cw);
        t.x[2] = sx; t.y[2] = sy; t.inv_w[2] = iw;
        memcpy(t.color_w[2], cw, sizeof cw);
        area2 = -area2;
    }
    t.area2 = area2;
    for (int k = 0; k < 3; k++) {
        int k1 = (k + 1) % 3;
        t.bias[k] = is_top_left(t.x[k1] - t.x[k], t.y[k1] - t.y[k]) ? 0 : -1;
    }
    int64_t xmin = t.x[0], xmax = t.x[0], ymin = t.y[0], ymax = t.y[0];
    for (int k = 1; k < 3; k++) {
        xmin = t.x[k] < xmin ? t.x[k] : xmin;
        xmax = t.x[k] > xmax ? t.x[k] : xmax;
        ymin = t.y[k] < ymin ? t.y[k] : ymin;
        ymax = t.y[k] > ymax ? t.y[k] : ymax;
    }
    /* Sample i is centred at i * ONE + HALF. */
    t.i0 = -floor_div(-(xmin - SUBPIXEL_HALF), SUBPIXEL_ONE);
    t.i1 = floor_div(xmax - SUBPIXEL_HALF, SUBPIXEL_ONE);
    t.j0 = -floor_div(-(ymin - SUBPIXEL_HALF), SUBPIXEL_ONE);
    t.j1 = floor_div(ymax - SUBPIXEL_HALF, SUBPIXEL_ONE);
    t.i0 = t.i0 < 0 ? 0 : t.i0;
    t.j0 = t.j0 < 0 ? 0 : t.j0;
    t.i1 = t.i1 > ws - 1 ? ws - 1 : t.i1;
    t.j1 = t.j1 > hs - 1 ? hs - 1 : t.j1;
    if (t.i0 > t.i1 || t.j0 > t.j1) return 0;
    *out = t;
    return 1;
}

static rad_status tri_list_push(raster_tri_list *list, const raster_tri *t)
{
    if (list->count == list->capacity) {
        size_t cap = list->capacity ? 2 * list->capacity : 1024;
        raster_tri *grown = realloc(list->items, cap * sizeof *grown);
        if (!grown) {
            rad_error("out of memory setting up %zu triangles", cap);
            return RAD_ERR_NOMEM;
        }
        list->items = grown;
        list->capacity = cap;
    }
    list->items[list->count++] = *t;
    return RAD_OK;
}

/* Clips, projects and sets up every input triangle, in input order. */
static rad_status setup_all(const render_raster_options *opt, int n, const render_vertex *vertices, size_t tri_count,
                            raster_tri_list *out_list)
{
    rad_status status = RAD_OK;
    int ws = opt->width * n, hs = opt->height * n, nc = channels_of(opt);
    for (size_t t = 0; t < tri_count; t++) {
        render_vertex poly[CLIP_MAX];
        int count = clip_polygon(&vertices[3 * t], opt->near_w, nc, poly);
        for (int k = 1; k + 1 < count; k++) {
            raster_tri tri;
            if (!setup_triangle(&poly[0], &poly[k], &poly[k + 1], ws, hs, opt->cull_backfaces, nc, &tri)) continue;
            status = tri_list_push(out_list, &tri);
            if (status != RAD_OK) goto done;
        }
    }
done:
    return status;
}

/* Makes the compiler expand a function at each call, so that the channel
 * count passed as a constant folds the `nc == 3` tests below (draw_band).
 * Channel 0 is written out and channels 1 and 2 sit under `if (nc == 3)`
 * rather than in a loop over c < nc: at -O2 GCC does not unroll such a loop
 * and then keeps the sums in memory, which made the RGB draw 30 % slower. */
#if defined(__GNUC__)
#define RASTER_EXPAND static inline __attribute__((always_inline))
#else
#define RASTER_EXPAND static inline __attribute__((always_inline))
#endif

/* Rasterizes the sample rows [row0, row1) of a ws-wide sample grid. With
 * `counts`, only counts covering triangles; else depth-tests into
 * depth/color (band-relative rows, nc values per sample). */
RASTER_EXPAND void raster_band_nc(const raster_tri_list *list, int ws, int64_t row0, int64_t row1, double *depth,
                                  float *color, uint32_t *counts, int nc)
{
    for (size_t ti = 0; ti < list->count; ti++) {
        const raster_tri *t = &list->items[ti];
        int64_t j0 = t->j0 > row0 ? t->j0 : row0, j1 = t->j1 < row1 - 1 ? t->j1 : row1 - 1;
        if (j0 > j1) continue;
        /* Edge k runs from vertex k to k+1: E = dx * (py - y) - dy * (px - x). */
        int64_t ex[3], ey[3], e_row[3];
        int64_t px = t->i0 * SUBPIXEL_ONE + SUBPIXEL_HALF, py = j0 * SUBPIXEL_ONE + SUBPIXEL_HALF;
        for (int k = 0; k < 3; k++) {
            int k1 = (k + 1) % 3;
            int64_t dx = t->x[k1] - t->x[k], dy = t->y[k1] - t->y[k];
            ex[k] = -dy * SUBPIXEL_ONE;
            ey[k] = dx * SUBPIXEL_ONE;
            e_row[k] = dx * (py - t->y[k]) - dy * (px - t->x[k]) + t->bias[k];
        }
        double inv_area = 1.0 / (double)t->area2;
        for (int64_t j = j0; j <= j1; j++) {
            int64_t e0 = e_row[0], e1 = e_row[1], e2 = e_row[2];
            for (int64_t i = t->i0; i <= t->i1; i++, e0 += ex[0], e1 += ex[1], e2 += ex[2]) {
                if ((e0 | e1 | e2) < 0) continue;
                size_t s = (size_t)(j - row0) * (size_t)ws + (size_t)i;
                if (counts) {
                    counts[s]++;
                    continue;
                }
                /* Barycentric weight of vertex k is the edge function of
                 * the opposite edge (bias removed). */
                double b0 = (double)(e1 - t->bias[1]) * inv_area;
                double b1 = (double)(e2 - t->bias[2]) * inv_area;
                double b2 = (double)(e0 - t->bias[0]) * inv_area;
                double iw = b0 * t->inv_w[0] + b1 * t->inv_w[1] + b2 * t->inv_w[2];
                if (!(iw > depth[s])) continue;
                depth[s] = iw;
                float *dst = &color[(size_t)nc * s];
                dst[0] = (float)((b0 * t->color_w[0][0] + b1 * t->color_w[1][0] + b2 * t->color_w[2][0]) / iw);
                if (nc == 3) {
                    dst[1] = (float)((b0 * t->color_w[0][1] + b1 * t->color_w[1][1] + b2 * t->color_w[2][1]) / iw);
                    dst[2] = (float)((b0 * t->color_w[0][2] + b1 * t->color_w[1][2] + b2 * t->color_w[2][2]) / iw);
                }
            }
            for (int k = 0; k < 3; k++) e_row[k] += ey[k];
        }
    }
}

/* Box filter: pixel rows [py0, py1) from the band's samples (nc values
 * each). */
RASTER_EXPAND void resolve_band_nc(const float *color, int width, int n, int py0, int py1, float *out, int nc)
{
    int ws = width * n;
    double inv = 1.0 / (double)(n * n);
    for (int py = py0; py < py1; py++) {
        for (int px = 0; px < width; px++) {
            double sum0 = 0, sum1 = 0, sum2 = 0;
            for (int sj = 0; sj < n; sj++) {
                const float *row = &color[(size_t)nc * ((size_t)((py - py0) * n + sj) * (size_t)ws + (size_t)px * n)];
                for (int si = 0; si < nc * n; si += nc) {
                    sum0 += row[si];
                    if (nc == 3) {
                        sum1 += row[si + 1];
                        sum2 += row[si + 2];
                    }
                }
            }
            float *dst = &out[(size_t)nc * ((size_t)py * (size_t)width + (size_t)px)];
            dst[0] = (float)(sum0 * inv);
            if (nc == 3) {
                dst[1] = (float)(sum1 * inv);
                dst[2] = (float)(sum2 * inv);
            }
        }
    }
}

/* One band, drawn and resolved: the code above written once for any channel
 * count and expanded here for the two there are, so that a grey picture does
 * a third of the colour work per sample and per pixel. */
static void draw_band(const raster_tri_list *list, int width, int n, int height, int b, int nc, double *depth,
                      float *color, float *out)
{
    int ws = width * n;
    int py0 = b * BAND_ROWS, py1 = py0 + BAND_ROWS < height ? py0 + BAND_ROWS : height;
    size_t used = (size_t)ws * (size_t)((py1 - py0) * n);
    memset(depth, 0, used * sizeof *depth);
    memset(color, 0, (size_t)nc * used * sizeof *color);
    if (nc == 1) {
        raster_band_nc(list, ws, (int64_t)py0 * n, (int64_t)py1 * n, depth, color, NULL, 1);
        resolve_band_nc(color, width, n, py0, py1, out, 1);
    } else {
        raster_band_nc(list, ws, (int64_t)py0 * n, (int64_t)py1 * n, depth, color, NULL, 3);
        resolve_band_nc(color, width, n, py0, py1, out, 3);
    }
}

rad_status render_raster_draw(const render_raster_options *options, const render_vertex *vertices, size_t tri_count,
                              float *out_rgb)
{
    raster_tri_list list = {NULL, 0, 0};
    int n = 1;
    int failed = 0;
    rad_status status = render_raster_check(options, &n);
    if (status != RAD_OK) goto done;
    status = setup_all(options, n, vertices, tri_count, &list);
    if (status != RAD_OK) goto done;

    int width = options->width, height = options->height, ws = width * n, nc = channels_of(options);
    int band_count = (height + BAND_ROWS - 1) / BAND_ROWS;
    size_t band_samples = (size_t)ws * (size_t)(BAND_ROWS * n);
#if defined(_OPENMP)
#pragma omp parallel
#endif
    {
        double *depth = malloc(band_samples * sizeof *depth);
        float *color = malloc((size_t)nc * band_samples * sizeof *color);
        if (!depth || !color) {
#if defined(_OPENMP)
#pragma omp atomic write
#endif
            failed = 1;
        }
#if defined(_OPENMP)
#pragma omp for schedule(dynamic)
#endif
        for (int b = 0; b < band_count; b++) {
            if (!depth || !color) continue;
            draw_band(&list, width, n, height, b, nc, depth, color, out_rgb);
        }
        free(depth);
        free(color);
    }
    if (failed) {
        rad_error("out of memory for the sample buffers (%zu samples per band)", band_samples);
        status = RAD_ERR_NOMEM;
    }
done:
    free(list.items);
    return status;
}

rad_status render_raster_coverage(const render_raster_options *options, const render_vertex *vertices,
                                  size_t tri_count, uint32_t *out_counts)
{
    raster_tri_list list = {NULL, 0, 0};
    int n = 1;
    rad_status status = render_raster_check(options, &n);
    if (status != RAD_OK) goto done;
    status = setup_all(options, n, vertices, tri_count, &list);
    if (status != RAD_OK) goto done;
    int ws = options->width * n, hs = options->height * n;
    memset(out_counts, 0, (size_t)ws * (size_t)hs * sizeof *out_counts);
    raster_band_nc(&list, ws, 0, hs, NULL, NULL, out_counts, 3);
done:
    free(list.items);
    return status;
}
