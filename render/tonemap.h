/* tonemap.h - from linear radiosity to 8-bit-ready sRGB values.
 *
 * Display value = sRGB_OETF(clamp(B * scale, 0, 1)) per channel, where
 *   scale = 2^EV * auto_scale
 * and auto_scale (unless turned off) maps the RENDER_AUTO_PERCENTILE-th
 * percentile, by area, of the brightest channel of the non-emitting
 * patches to RENDER_AUTO_TARGET. The brightest channel, not luminance,
 * because clamping acts per channel: a warm light would otherwise clip the
 * red channel of pale walls and shift their hue. The 95th, not the
 * maximum, because the few patches right beside an emitter are far
 * brighter than the rest of the room (and carry the most Monte Carlo
 * noise); they may clip. Radiosity does not depend on scene units, but it does
 * scale with the emitters' strength (the Cornell box's light emits 17, the
 * paper's scene 1.27), and this makes both look right with no flags.
 * Clamping (not a compressive curve such as Reinhard) keeps the classic
 * radiosity look: surfaces keep their colours and only the light, far
 * brighter than any surface, saturates to white.
 *
 * A grey scene's file stores its one channel in all three, so the brightest
 * channel is that channel. A colour scene drawn grey (render --channels
 * grey) is drawn from its Rec. 709 luminance Y per patch, stored the same
 * way (render_luminance_radiosity), so the key is then Y's percentile.
 *
 * The sRGB OETF (IEC 61966-2-1): 12.92 x for x <= 0.0031308, else
 * 1.055 x^(1/2.4) - 0.055. OpenImageIO's float -> uint8 conversion does not
 * apply it; image.h quantizes the encoded values with round-to-nearest.
 */
#ifndef RENDER_TONEMAP_H
#define RENDER_TONEMAP_H

#include <stddef.h>

#include "rad_mesh.h"

#define RENDER_AUTO_PERCENTILE 0.95
#define RENDER_AUTO_TARGET 0.90

/* The automatic exposure scale (> 0); 1 when the scene has no lit
 * non-emitting surface. radiosity: patch_count * 3. */
double render_tonemap_auto_scale(const rad_mesh *mesh, const double *radiosity);

/* out[3 * p + c] = rad_luminance(&radiosity[3 * p]) for every patch p and
 * c = 0, 1, 2: a colour solution turned into a grey one, laid out as a grey
 * scene's file stores it. out may not alias radiosity. */
void render_luminance_radiosity(const double *radiosity, size_t patch_count, double *out);

/* sRGB OETF of a linear value; input clamped to [0, 1]. */
double render_srgb_encode(double linear);

/* In place over pixel_count pixels of `channels` values each (3: RGB,
 * 1: grey): multiply by scale, clamp to [0, 1], sRGB-encode. */
void render_tonemap_apply(float *values, size_t pixel_count, int channels, double scale);

#endif
