/* image.h - image files through OpenImageIO, behind a C interface.
 *
 * image_oiio.cpp is the only file that includes OpenImageIO; nothing here
 * mentions its types.
 *
 * Usage:
 *     render_image_attr attrs[] = {{"rad:camera", "eye 278 273 -800; ..."}};
 *     rad_status s = render_image_write("cornell.png", rgb, 512, 512, 3, attrs, 1);
 *
 * The format follows the extension (case-insensitive); images have 3
 * channels (RGB) or 1 (grey):
 *   .png  8-bit RGB or 8-bit grey. The values must already be
 *         display-encoded (tonemap.h) in [0, 1]; each becomes
 *         round(255 * v). Tagged sRGB.
 *   .exr  half float, linear, ZIP-compressed, channels R, G, B or a single
 *         channel Y; the values are written as is.
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

/* values: width * height * channels floats (channels 3: RGB, 1: grey),
 * interleaved, rows from the top. */
rad_status render_image_write(const char *path, const float *values, int width, int height, int channels,
                              const render_image_attr *attrs, size_t attr_count);

/* Reads any image OpenImageIO knows as floats (8-bit values v become
 * v / 255): a file of one or two channels (grey, grey + alpha) as its first
 * channel (*out_channels = 1), any other as its first three (3). *out_values
 * (width * height * *out_channels floats) is freed with free(). */
rad_status render_image_read(const char *path, float **out_values, int *out_width, int *out_height,
                             int *out_channels);

/* The file's channel names joined by commas ("R,G,B", "Y") into names and
 * its pixel type ("uint8", "half", ...) into type; both truncated to size. */
rad_status render_image_read_layout(const char *path, char *names, size_t names_size, char *type, size_t type_size);

/* Copies a string attribute of an image file into out (truncated to
 * size); RAD_ERR_INVALID if the file has no such attribute. */
rad_status render_image_read_attr(const char *path, const char *name, char *out, size_t size);

#ifdef __cplusplus
}
#endif

#endif
