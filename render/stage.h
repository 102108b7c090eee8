/* stage.h - the render stage as one call: radiosity file in, PNG or EXR
 * image out. main.c only parses the command line (cli.h) into
 * render_options and exits with what this returns.
 *
 *     render_options options = ...;           // render_cli_parse fills one
 *     rad_status status = render_stage_run(&options);
 *
 * Before any work the names are checked (docs/reliability.md, "Threat
 * model: files on disk"): the output must not be the radiosity file or
 * the camera file. The stage logs what it does and why it fails; it never
 * exits.
 */
#ifndef RENDER_STAGE_H
#define RENDER_STAGE_H

#include "frame.h"
#include "rad_math.h"
#include "rad_status.h"

#define RENDER_DEFAULT_INPUT "radiosity"
#define RENDER_DEFAULT_EXTENSION ".png"
#define RENDER_OUTPUT_NAME_MAX 4096 /* the default output's name, PATH_MAX on Linux */

typedef enum render_channels_mode {
    RENDER_CHANNELS_AUTO = 0, /* what the radiosity file says */
    RENDER_CHANNELS_RGB = 1,
    RENDER_CHANNELS_GREY = 2
} render_channels_mode;

/* What to draw and how. The command line's defaults differ from zero in
 * two fields (frame.shading linear, auto_exposure 1): render_cli_parse
 * sets them. */
typedef struct render_options {
    const char *input;       /* radiosity file; NULL = RENDER_DEFAULT_INPUT */
    const char *output;      /* image, .png or .exr; NULL = the input's file name without its folder and
                                extension, with RENDER_DEFAULT_EXTENSION, in the current directory */
    const char *camera_path; /* NULL: the default camera (the scene's sidecar, the Cornell box's,
                                automatic framing); "auto": it without the sidecar */
    render_frame_options frame; /* size, samples, shading (frame.h) */
    int have_eye, have_look_at, have_up, have_fov; /* these override the camera's */
    rad_vec3 eye, look_at, up;
    double fov_y;            /* degrees */
    double exposure;         /* EV: the PNG's values times 2^EV */
    int auto_exposure;       /* 1: times the automatic scale too */
    render_channels_mode channels;
    int radiance;            /* 1: L = B / pi instead of B; 0: B; -1: not given (the file's Ke decides) */
} render_options;

rad_status render_stage_run(const render_options *options);

#endif
