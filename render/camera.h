/* camera.h - the pinhole camera: sidecar files, defaults, projection.
 *
 * Usage:
 *     render_camera cam;
 *     render_camera_default(&mesh, aspect, &cam);        // or:
 *     render_camera_load("scenes/cornell_box.camera", &cam);
 *     render_view view;
 *     if (render_view_init(&cam, aspect, &view) != RAD_OK) ...;
 *
 * Camera file (one statement per line, `#` starts a comment, blank lines
 * are fine, every key at most once):
 *     eye 278 273 -800          # required, scene units
 *     look_at 278 273 0         # required
 *     up 0 1 0                  # optional, default 0 1 0
 *     fov_y 39.3077             # optional, vertical field of view in degrees,
 *                               # default RENDER_DEFAULT_FOV_Y
 *     width 1920                # optional, the picture's size in pixels (both or
 *     height 1080               # neither): render's size when --width and
 *                               # --height are not given (tools/blender_export.py
 *                               # writes Blender's render resolution here)
 * Errors are logged as "file:line: what is wrong" and return RAD_ERR_PARSE
 * (syntax, unknown or repeated key) or RAD_ERR_INVALID (values: a missing
 * required key, fov outside (0, 180), eye == look_at, up parallel to the
 * view direction, width or height not an integer in [1,
 * RENDER_CAMERA_SIZE_MAX] or given without the other).
 *
 * Sidecar: the camera file `<scene>.camera` beside the scene's OBJ
 * (`scenes/room.obj` -> `scenes/room.camera`), which render loads when no
 * --camera is given and the radiosity file names its scene; which file
 * that is, when the path is relative, is sidecar.h's business.
 *
 * Default camera (no file, no sidecar): a scene whose bounding box is the
 * Cornell box's (0..556 x 0..548.8 x 0..559.2 mm, within
 * RENDER_CORNELL_BBOX_TOL) gets the measured Cornell camera; any other
 * scene is framed automatically (see render_camera_auto and
 * docs/render.md).
 *
 * Screen conventions: +x right, +y down in pixel coordinates, pixel (0, 0)
 * is the top-left pixel and its centre is (0.5, 0.5).
 */
#ifndef RENDER_CAMERA_H
#define RENDER_CAMERA_H

#include <stddef.h>

#include "rad_math.h"
#include "rad_mesh.h"
#include "rad_status.h"

/* The Cornell box's measured lens; also the default for files that give no
 * fov_y and for automatic framing (a moderate "normal" lens). */
#define RENDER_DEFAULT_FOV_Y 39.3077
/* How close (scene units, mm) a bounding box must be to the Cornell box's. */
#define RENDER_CORNELL_BBOX_TOL 2.0

typedef struct render_camera {
    rad_vec3 eye;     /* scene units */
    rad_vec3 look_at; /* a point the camera looks at (centre of the image) */
    rad_vec3 up;      /* any vector not parallel to look_at - eye */
    double fov_y;     /* vertical field of view, degrees, in (0, 180) */
    int width, height; /* the file's picture size in pixels; 0 0 = not given */
} render_camera;

/* Largest width or height a camera file may ask for (render refuses sizes
 * its rasterizer cannot take with its own message). */
#define RENDER_CAMERA_SIZE_MAX 32768

/* An orthonormal view basis and the lens, precomputed from a camera. */
typedef struct render_view {
    rad_vec3 eye;
    rad_vec3 right, up, forward; /* right = forward x up_hint, up = right x forward */
    double tan_half_x, tan_half_y;
} render_view;

/* The Cornell Program of Computer Graphics' measured camera
 * (scenes/cornell_box.camera holds the same numbers). */
render_camera render_camera_cornell(void);

/* Parses camera-file text; `name` is used in messages. */
rad_status render_camera_parse(const char *name, const char *text, render_camera *out_camera);
/* Largest camera file read: the four statements take under 200 bytes;
 * 16 KiB leaves room for comments and refuses a stray large file (a
 * sidecar that is really something else) before it is read whole. */
#define RENDER_CAMERA_FILE_MAX 16384

/* Reads and parses a camera file: a regular file (through symlinks) of at
 * most RENDER_CAMERA_FILE_MAX bytes; anything else is refused with
 * "path: why" (RAD_ERR_IO, RAD_ERR_INVALID). */
rad_status render_camera_load(const char *path, render_camera *out_camera);

/* Checks the values (see above); `what` names the camera in messages. */
rad_status render_camera_validate(const render_camera *camera, const char *what);

/* Frames a mesh: looks at the centre of its bounding box from outside,
 * along a horizontal axis (-z when up is y: from the front of a Y-up
 * scene, +x to the right; +y when up is z; +z when up is x), with "up"
 * pointing towards the emitters, from
 * the distance at which the bounding box's cross-section fills the view
 * (plus RENDER_AUTO_MARGIN). Needs at least one patch. */
void render_camera_auto(const rad_mesh *mesh, double aspect, render_camera *out_camera);

/* The default: the measured camera for the Cornell box, else auto framing.
 * *out_is_cornell (may be NULL) tells which. */
void render_camera_default(const rad_mesh *mesh, double aspect, render_camera *out_camera, int *out_is_cornell);

/* One line "eye x y z; look_at x y z; up x y z; fov_y f" (for metadata and
 * messages), truncated to size. */
void render_camera_format(const render_camera *camera, char *out, size_t size);

/* aspect = width / height. Fails (RAD_ERR_INVALID) as render_camera_validate. */
rad_status render_view_init(const render_camera *camera, double aspect, render_view *out_view);

/* World point -> pixel coordinates of a width x height image. Returns 0
 * (and leaves the outputs alone) for points at or behind the eye plane. */
int render_view_project(const render_view *view, int width, int height, rad_vec3 p, double *out_x, double *out_y);

#endif
