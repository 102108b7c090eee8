/* rad_color.h - colour: the luminance of a linear RGB radiosity or
 * radiance, shared by refinement's error indicator (rad_refine.c) and
 * render's grey output, exposure and shading limits (render/).
 */
#ifndef RAD_COLOR_H
#define RAD_COLOR_H

/* Rec. 709 (sRGB primaries) luminance of linear RGB:
 * Y = 0.2126 R + 0.7152 G + 0.0722 B. */
static inline double rad_luminance(const double rgb[3]) { return 0.2126 * rgb[0] + 0.7152 * rgb[1] + 0.0722 * rgb[2]; }

#endif
