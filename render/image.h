/* image.h - image files through OpenImageIO, behind a C interface.
 *
 * image_oiio.cpp is the only file that includes OpenImageIO; nothing here
 * mentions its types.
 *
 * Usage:
 *     render_image_attr attrs[] = {{"rad:camera", "eye 278 273 -800; ..."}};
 *     rad_status s = render_image_write("cornell.png", rgb, 512, 512, attrs, 1);
 *
 * The format follows the extension (case-insensitive):
 *   .png  8-bit RGB. `rgb` must already be display-encoded (tonemap.h) in
 *         [0, 1]; each value becomes round(255 * v). Tagged sRGB.
 *   .exr  RGB half float, linear, ZIP-compressed; `rgb` is written as is.
 * Anything else is RAD_ERR_USAGE. Every file gets Software = "radiosity
 * render" and a fixed DateTime (RENDER_IMAGE_DATETIME) so that identical
 * inputs give identical files, plus the caller's string attributes (PNG
 * stores them as text chunks, EXR as header attributes).
 *
 * Writing goes to a temporary name beside `path` (rad_fs.h) and is renamed
 * over `path` only after the file was completely written and closed; a
 * failure (bad directory, full disk, ...) is logged as "path: why", removes
 * the temporary and leaves any existing `path` untouched.
 */
#ifndef RENDER_IMAGE_H
#define RENDER_IMAGE_H

#include <stddef.h>

#include "rad_status.h"

#ifdef __cplusplus
extern "C" {
#endif

#define RENDER_IMAGE_DATETIME "2000:01:01 00:00:00"

typedef enum render_image_format {
    RENDER_IMAGE_UNKNOWN = 0,
    RENDER_IMAGE_PNG = 1,
    RENDER_IMAGE_EXR = 2
} render_image_format;

typedef struct render_image_attr {
    const char *name;  /* e.g. "rad:camera", "ImageDescription" */
    const char *value;
} render_image_attr;

/* The format `path` asks for by its extension. */
render_image_format render_image_format_of(const char *path);

/* rgb: width * height * 3 floats, rows from the top. */
rad_status render_image_write(const char *path, const float *rgb, int width, int height,
                              const render_image_attr *attrs, size_t attr_count);

/* Reads the first three channels of any image OpenImageIO knows as floats
 * (8-bit values v become v / 255). *out_rgb is freed with free(). */
rad_status render_image_read(const char *path, float **out_rgb, int *out_width, int *out_height);

/* Copies a string attribute of an image file into out (truncated to
 * size); RAD_ERR_INVALID if the file has no such attribute. */
rad_status render_image_read_attr(const char *path, const char *name, char *out, size_t size);

#ifdef __cplusplus
}
#endif

#endif
