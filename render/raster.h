/* raster.h - a software triangle rasterizer: clipping, z-buffer, supersampling.
 *
 * Usage:
 *     render_raster_options opt = {.width = 512, .height = 512, .spp = 16,
 *                                  .cull_backfaces = 1, .near_w = 1e-3,
 *                                  .channels = 3};
 *     float *rgb = malloc(512 * 512 * 3 * sizeof *rgb);
 *     render_raster_draw(&opt, vertices, tri_count, rgb);
 *
 * Input: triangles in clip space (three consecutive render_vertex each):
 * ndc = (x / w, y / w) with ndc in [-1, 1]^2 on screen, +y up, and
 * w = distance in front of the eye along the view axis. Triangles are
 * clipped against w >= near_w and against a guard band (|ndc| <= 16), so
 * any input is safe, including vertices behind the eye.
 *
 * Rules, in the order that makes the picture deterministic:
 *  - Samples: each pixel holds an n x n grid of samples (spp = n * n) at
 *    the centres of its n x n sub-cells. Vertices snap to 1/256 of a
 *    sample; coverage is decided exactly in 64-bit integers.
 *  - Fill rule: a sample is inside when it is strictly inside all three
 *    edges, or exactly on a "top" or "left" edge (Direct3D/OpenGL's
 *    top-left rule). Two triangles that share an edge therefore cover
 *    every sample along it exactly once (watertight, no double blending).
 *  - Culling: with cull_backfaces, triangles that appear clockwise on
 *    screen (their front, counter-clockwise side faces away) are dropped.
 *  - Depth: z-buffer on 1/w (exact in screen space); a sample keeps the
 *    first triangle, in input order, among equally near ones.
 *  - Colour: `channels` linear values (3: RGB; 1: grey, from color[0])
 *    interpolated perspective-correctly. Grey does the per-sample and
 *    per-pixel work for one value only; the one channel gets exactly the
 *    arithmetic, and so the bits, of channel 0 of an RGB draw.
 *  - Resolve: box filter, the mean of a pixel's samples; uncovered samples
 *    are black.
 * The image is drawn in horizontal bands, in parallel with OpenMP when the
 * build has it; every band is independent, so the result does not depend on
 * the thread count.
 */
#ifndef RENDER_RASTER_H
#define RENDER_RASTER_H

#include <stddef.h>
#include <stdint.h>

#include "rad_status.h"

#define RENDER_DEFAULT_SPP 16
#define RENDER_MAX_SPP 256           /* 16 x 16 */
#define RENDER_MAX_SAMPLE_DIM 32768  /* width * sqrt(spp) and height * sqrt(spp) */

typedef struct render_vertex {
    double x, y, w;  /* clip space; see above */
    float color[3];  /* linear RGB; only color[0] when drawing one channel */
} render_vertex;

typedef struct render_raster_options {
    int width, height;  /* pixels, >= 1 */
    int spp;            /* samples per pixel, a square (1, 4, 9, 16, ...); 0 = RENDER_DEFAULT_SPP */
    int cull_backfaces; /* nonzero: draw only triangles counter-clockwise on screen */
    double near_w;      /* near clipping distance, > 0 */
    int channels;       /* values per pixel: 3 (RGB) or 1 (grey: color[0]); 0 = 3 */
} render_raster_options;

/* Checks the options (RAD_ERR_INVALID with a message); *out_n (may be NULL)
 * receives sqrt(spp). */
rad_status render_raster_check(const render_raster_options *options, int *out_n);

/* Draws tri_count triangles into out_rgb: width * height * channels floats,
 * linear, interleaved (RGB or grey), rows from the top. */
rad_status render_raster_draw(const render_raster_options *options, const render_vertex *vertices, size_t tri_count,
                              float *out_rgb);

/* For tests: counts, per sample, the triangles that cover it by the fill
 * rule (no depth test). out_counts: (width * n) * (height * n) counters,
 * rows from the top, sample (i, j) centred at pixel coordinates
 * ((i + 0.5) / n, (j + 0.5) / n). */
rad_status render_raster_coverage(const render_raster_options *options, const render_vertex *vertices,
                                  size_t tri_count, uint32_t *out_counts);

#endif
