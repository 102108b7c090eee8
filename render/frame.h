/* frame.h - draws a radiosity solution from a camera into a linear image.
 *
 * Usage:
 *     render_frame_options opt = {.width = 512, .height = 512};  // zero = defaults (RGB)
 *     float *rgb = malloc(3 * sizeof *rgb * 512 * 512);
 *     render_frame_draw(&mesh, radiosity, &camera, &opt, rgb);
 *
 * Ties the stages together: corner colours (shade.h), projection (camera.h)
 * and rasterization (raster.h). Quads are drawn as two triangles split along
 * their v0-v2 diagonal; back faces are culled, which is also what lets a
 * camera outside a closed room see in through the near wall (room faces
 * point inwards). Pixel values are radiosity B, linear, per channel.
 *
 * With channels = 1 the whole frame is drawn for channel 0 alone (a grey
 * scene stores its one solved channel in all three): one value per corner,
 * per sample and per pixel, each computed exactly as channel 0 of the RGB
 * frame, so the grey picture equals the RGB one's red channel bit for bit.
 */
#ifndef RENDER_FRAME_H
#define RENDER_FRAME_H

#include "camera.h"
#include "rad_mesh.h"
#include "rad_status.h"
#include "shade.h"

#define RENDER_DEFAULT_WIDTH 512
#define RENDER_DEFAULT_HEIGHT 512

typedef struct render_frame_options {
    int width, height;      /* pixels; 0 = RENDER_DEFAULT_WIDTH / RENDER_DEFAULT_HEIGHT */
    int spp;                /* samples per pixel, a square; 0 = RENDER_DEFAULT_SPP (raster.h) */
    render_shading shading; /* default (0) smooth */
    int channels;           /* values per pixel: 3 (RGB) or 1 (channel 0, grey); 0 = 3 */
    int luminance;          /* with channels 1: the Rec. 709 luminance of the RGB
                               corners instead of channel 0 (render --channels grey
                               of a colour scene: exactly the colour picture's luminance) */
    const render_smoothing *smoothing; /* the OBJ's smoothing groups (shade.h); NULL: none */
} render_frame_options;

/* Resolves zero fields to their defaults. */
render_frame_options render_frame_options_resolve(const render_frame_options *options);

/* radiosity: patch_count * 3. out_rgb: width * height * channels floats
 * (resolved size and channels), interleaved, rows from the top. */
rad_status render_frame_draw(const rad_mesh *mesh, const double *radiosity, const render_camera *camera,
                             const render_frame_options *options, float *out_rgb);

#endif
