/* render - draws a solved radiosity file into a PNG or EXR image.
 *
 * The only file of this stage that exits or prints outside the logger
 * (--help). See docs/render.md.
 */
#define _POSIX_C_SOURCE 200809L
#include <errno.h>
#include <inttypes.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "camera.h"
#include "rad_fs.h"
#include "rad_parse.h"
#include "frame.h"
#include "image.h"
#include "rad_log.h"
#include "rad_rfile.h"
#include "rad_status.h"
#include "raster.h"
#include "tonemap.h"

#define RENDER_DEFAULT_INPUT "radiosity"
#define RENDER_DEFAULT_OUTPUT "cornell.png"
#define RENDER_MAX_EXPOSURE 64.0 /* |EV| beyond this is surely a typo */

static const char usage_text[] =
    "usage: render [RADIOSITY] [options]\n"
    "Draws a radiosity solution (from solve) into a PNG or EXR image.\n"
    "\n"
    "  RADIOSITY            radiosity file to draw (default: " RENDER_DEFAULT_INPUT ")\n"
    "  -o, --output FILE    image to write; .png (8-bit sRGB) or .exr (linear half)\n"
    "                       (default: " RENDER_DEFAULT_OUTPUT ")\n"
    "  --channels MODE      auto (default): one grey channel when the radiosity file\n"
    "                       says the scene was solved as grey (channel count 1), RGB\n"
    "                       otherwise; rgb: always R, G, B (grey scenes: R = G = B);\n"
    "                       grey: always one channel (8-bit grey PNG, EXR channel Y);\n"
    "                       a colour scene is then drawn from its Rec. 709 luminance\n"
    "                       Y = 0.2126 R + 0.7152 G + 0.0722 B (linear B, per patch)\n"
    "  --width N            image width in pixels (default: 512)\n"
    "  --height N           image height in pixels (default: 512)\n"
    "  --spp N              samples per pixel, a square: 1, 4, 9, 16, ... 256 (default: 16)\n"
    "  --camera FILE|auto   camera file (lines: eye X Y Z, look_at X Y Z, up X Y Z,\n"
    "                       fov_y DEGREES; # comments). Default: the scene's sidecar\n"
    "                       <scene>.camera beside its OBJ when there is one, else the\n"
    "                       measured camera for the Cornell box, automatic framing\n"
    "                       for other scenes; auto: the default without the sidecar\n"
    "  --eye X,Y,Z          camera position (overrides the camera file or default)\n"
    "  --look-at X,Y,Z      point at the image centre\n"
    "  --up X,Y,Z           up direction\n"
    "  --fov DEGREES        vertical field of view\n"
    "  --exposure EV        multiply the PNG's values by 2^EV (default: 0)\n"
    "  --no-auto-exposure   use 2^EV alone instead of 2^EV times the automatic scale\n"
    "  --shading MODE       smooth (Gouraud between patches, default) or flat (patches)\n"
    "  -q, --quiet          report errors only\n"
    "  -h, --help           show this help\n"
    "  --version            print the version\n"
    "\n"
    "PNG: sRGB(clamp(B * scale)); EXR: radiosity B per channel, unscaled.\n"
    "Exit status: 0 success, 2 usage error (a bad option or value), 1 anything else.\n";

typedef enum render_channels_mode {
    RENDER_CHANNELS_AUTO = 0, /* what the radiosity file says */
    RENDER_CHANNELS_RGB = 1,
    RENDER_CHANNELS_GREY = 2
} render_channels_mode;

typedef struct render_cli {
    const char *input, *output, *camera_path;
    render_frame_options frame;
    int have_eye, have_look_at, have_up, have_fov;
    rad_vec3 eye, look_at, up;
    double fov_y;
    double exposure;
    int auto_exposure;
    int quiet, help, version;
    render_channels_mode channels;
} render_cli;

static rad_status parse_int(const char *opt, const char *text, int lo, int hi, int *out)
{
    uint64_t v = 0;
    rad_status status = rad_parse_uint(opt, text, (uint64_t)lo, (uint64_t)hi, &v);
    *out = (int)v;
    return status;
}

static rad_status parse_double(const char *opt, const char *text, double *out)
{
    return rad_parse_real(opt, text, -HUGE_VAL, 0, HUGE_VAL, 0, out);
}

/* "X,Y,Z" */
static rad_status parse_vec3(const char *opt, const char *text, rad_vec3 *out)
{
    double v[3];
    const char *p = text;
    for (int i = 0; i < 3; i++) {
        char *end = NULL;
        v[i] = strtod(p, &end);
        if (end == p || !isfinite(v[i]) || (i < 2 ? *end != ',' : *end != 0)) {
            rad_error("%s: '%s' is not three numbers X,Y,Z", opt, text);
            return RAD_ERR_USAGE;
        }
        p = end + 1;
    }
    *out = rad_v3(v[0], v[1], v[2]);
    return RAD_OK;
}

/* Matches "--name VALUE" and "--name=VALUE"; *io_index advances past what
 * was consumed. Returns 1 on a match (with *out_value, or a logged usage
 * error in *out_status), 0 if argv[i] is another option. */
static int match_value(int argc, char **argv, int *io_index, const char *name, const char *alias,
                       const char **out_value, rad_status *out_status)
{
    const char *arg = argv[*io_index];
    size_t len = strlen(name);
    if (strncmp(arg, name, len) == 0 && arg[len] == '=') {
        *out_value = arg + len + 1;
        return 1;
    }
    if (strcmp(arg, name) != 0 && !(alias && strcmp(arg, alias) == 0)) return 0;
    if (*io_index + 1 >= argc) {
        rad_error("%s needs a value (see --help)", arg);
        *out_status = RAD_ERR_USAGE;
        return 1;
    }
    *out_value = argv[++*io_index];
    return 1;
}

static rad_status parse_args(int argc, char **argv, render_cli *cli)
{
    rad_status status = RAD_OK;
    const render_cli defaults = {RENDER_DEFAULT_INPUT, RENDER_DEFAULT_OUTPUT, NULL, {0, 0, 0, RENDER_SHADING_SMOOTH, 0},
                                 0, 0, 0, 0, {0, 0, 0}, {0, 0, 0}, {0, 0, 0}, 0.0, 0.0, 1, 0, 0, 0,
                                 RENDER_CHANNELS_AUTO};
    int have_input = 0;
    *cli = defaults;
    for (int i = 1; i < argc && status == RAD_OK; i++) {
        const char *arg = argv[i], *v = NULL;
        if (strcmp(arg, "-h") == 0 || strcmp(arg, "--help") == 0) {
            cli->help = 1;
        } else if (strcmp(arg, "--version") == 0) {
            cli->version = 1;
        } else if (strcmp(arg, "-q") == 0 || strcmp(arg, "--quiet") == 0) {
            cli->quiet = 1;
        } else if (strcmp(arg, "--no-auto-exposure") == 0) {
            cli->auto_exposure = 0;
        } else if (match_value(argc, argv, &i, "--output", "-o", &v, &status)) {
            if (v) cli->output = v;
        } else if (match_value(argc, argv, &i, "--width", NULL, &v, &status)) {
            if (v) status = parse_int("--width", v, 1, RENDER_MAX_SAMPLE_DIM, &cli->frame.width);
        } else if (match_value(argc, argv, &i, "--height", NULL, &v, &status)) {
            if (v) status = parse_int("--height", v, 1, RENDER_MAX_SAMPLE_DIM, &cli->frame.height);
        } else if (match_value(argc, argv, &i, "--spp", NULL, &v, &status)) {
            if (v) status = parse_int("--spp", v, 1, RENDER_MAX_SPP, &cli->frame.spp);
        } else if (match_value(argc, argv, &i, "--camera", NULL, &v, &status)) {
            if (v) cli->camera_path = v;
        } else if (match_value(argc, argv, &i, "--eye", NULL, &v, &status)) {
            if (v) status = parse_vec3("--eye", v, &cli->eye);
            cli->have_eye = 1;
        } else if (match_value(argc, argv, &i, "--look-at", NULL, &v, &status)) {
            if (v) status = parse_vec3("--look-at", v, &cli->look_at);
            cli->have_look_at = 1;
        } else if (match_value(argc, argv, &i, "--up", NULL, &v, &status)) {
            if (v) status = parse_vec3("--up", v, &cli->up);
            cli->have_up = 1;
        } else if (match_value(argc, argv, &i, "--fov", NULL, &v, &status)) {
            if (v) status = parse_double("--fov", v, &cli->fov_y);
            cli->have_fov = 1;
        } else if (match_value(argc, argv, &i, "--exposure", NULL, &v, &status)) {
            if (v) status = parse_double("--exposure", v, &cli->exposure);
            if (status == RAD_OK && fabs(cli->exposure) > RENDER_MAX_EXPOSURE) {
                rad_error("--exposure: %g stops is out of range (|EV| <= %g)", cli->exposure, RENDER_MAX_EXPOSURE);
                status = RAD_ERR_USAGE;
            }
        } else if (match_value(argc, argv, &i, "--shading", NULL, &v, &status)) {
            if (v && strcmp(v, "smooth") == 0) {
                cli->frame.shading = RENDER_SHADING_SMOOTH;
            } else if (v && strcmp(v, "flat") == 0) {
                cli->frame.shading = RENDER_SHADING_FLAT;
            } else if (v) {
                rad_error("--shading: '%s' is not smooth or flat", v);
                status = RAD_ERR_USAGE;
            }
        } else if (match_value(argc, argv, &i, "--channels", NULL, &v, &status)) {
            if (v && strcmp(v, "auto") == 0) {
                cli->channels = RENDER_CHANNELS_AUTO;
            } else if (v && strcmp(v, "rgb") == 0) {
                cli->channels = RENDER_CHANNELS_RGB;
            } else if (v && strcmp(v, "grey") == 0) {
                cli->channels = RENDER_CHANNELS_GREY;
            } else if (v) {
                rad_error("--channels: '%s' is not auto, rgb or grey", v);
                status = RAD_ERR_USAGE;
            }
        } else if (arg[0] == '-' && arg[1] != 0) {
            rad_error("unknown option '%s' (see --help)", arg);
            status = RAD_ERR_USAGE;
        } else if (have_input) {
            rad_error("more than one radiosity file given ('%s' and '%s')", cli->input, arg);
            status = RAD_ERR_USAGE;
        } else {
            cli->input = arg;
            have_input = 1;
        }
    }
    return status;
}

static double seconds_now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* A black image is never silent: it says whether nothing emits (every
 * radiosity 0) or the camera sees nothing lit. */
static void warn_if_black(const char *input, const rad_mesh *mesh, const double *radiosity, uint32_t channels,
                          const float *pixels, size_t values, const char *camera_text)
{
    for (size_t k = 0; k < values; k++)
        if (pixels[k] != 0.0f) return;
    int lit = 0;
    for (size_t k = 0; k < mesh->patch_count * channels && !lit; k++) lit = radiosity[k] != 0.0;
    if (!lit)
        rad_warn("%s: the image is black: every radiosity is 0, so nothing emits light (no material with Ke > 0; "
                 "Blender exports before 2.9 write no Ke)",
                 input);
    else
        rad_warn("%s: the image is black: the camera sees nothing lit (%s); try the automatic framing "
                 "(--camera auto) or other --eye/--look-at",
                 input, camera_text);
}

/* The camera: file or default, then the flags on top. */
static rad_status choose_camera(const render_cli *cli, const rad_mesh *mesh, const char *scene_path, double aspect,
                                render_camera *out)
{
    rad_status status = RAD_OK;
    int cornell = 0;
    char source[600];
    char sidecar[400];
    int automatic = cli->camera_path && strcmp(cli->camera_path, "auto") == 0;
    if (cli->camera_path && !automatic) {
        status = render_camera_load(cli->camera_path, out);
        if (status != RAD_OK) return status;
        snprintf(source, sizeof source, "from %s", cli->camera_path);
    } else if (!automatic && render_camera_sidecar(scene_path, sidecar, sizeof sidecar)) {
        status = render_camera_load(sidecar, out);
        if (status != RAD_OK) {
            rad_error("%s: the camera sidecar of scene %s; fix it, or give --camera FILE or --camera auto",
                      sidecar, scene_path);
            return status;
        }
        snprintf(source, sizeof source, "from %s, the scene's sidecar (--camera auto ignores it)", sidecar);
    } else {
        render_camera_default(mesh, aspect, out, &cornell);
        snprintf(source, sizeof source, "%s", cornell ? "the Cornell box's measured camera" : "automatic framing");
    }
    if (cli->have_eye) out->eye = cli->eye;
    if (cli->have_look_at) out->look_at = cli->look_at;
    if (cli->have_up) out->up = cli->up;
    if (cli->have_fov) out->fov_y = cli->fov_y;
    int overridden = cli->have_eye || cli->have_look_at || cli->have_up || cli->have_fov;
    /* --eye/--look-at along the up that came with the camera (the default
     * frames with z or y up): without --up of their own, take the axis
     * most across the view instead of refusing. */
    rad_vec3 dir = rad_v3_sub(out->look_at, out->eye);
    double dir_len = rad_v3_length(dir), up_len = rad_v3_length(out->up);
    if (!cli->have_up && dir_len > 0 && up_len > 0 &&
        rad_v3_length(rad_v3_cross(dir, out->up)) <= 1e-3 * dir_len * up_len) {
        const rad_vec3 axes[3] = {rad_v3(0, 1, 0), rad_v3(0, 0, 1), rad_v3(1, 0, 0)};
        int best = 0;
        for (int k = 1; k < 3; k++)
            if (fabs(rad_v3_dot(axes[k], dir)) < fabs(rad_v3_dot(axes[best], dir))) best = k;
        out->up = axes[best];
        rad_info("camera: the view runs along its up direction; using up %s (give --up to choose)",
                 best == 0 ? "+y" : best == 1 ? "+z" : "+x");
    }
    rad_info("camera: %s%s", source, overridden ? ", with --eye/--look-at/--up/--fov on top" : "");
    return render_camera_validate(out, "camera (after --eye/--look-at/--up/--fov)");
}

static rad_status run(const render_cli *cli)
{
    rad_status status = RAD_OK;
    rad_radiosity rf;
    float *rgb = NULL;
    double *luminance = NULL;
    memset(&rf, 0, sizeof rf);
    double t0 = seconds_now();
    render_image_format format = render_image_format_of(cli->output);
    if (format == RENDER_IMAGE_UNKNOWN) {
        rad_error("%s: unknown image type (the name must end in .png or .exr)", cli->output);
        status = RAD_ERR_USAGE;
        goto done;
    }
    render_frame_options frame = render_frame_options_resolve(&cli->frame);
    status = render_raster_check(&(render_raster_options){frame.width, frame.height, frame.spp, 1, 1.0, 0}, NULL);
    if (status != RAD_OK) {
        status = RAD_ERR_USAGE;
        goto done;
    }
    status = rad_rf_read(cli->input, &rf);
    if (status != RAD_OK) goto done;
    if (rf.mesh.patch_count == 0) {
        rad_error("%s: no patches to draw", cli->input);
        status = RAD_ERR_INVALID;
        goto done;
    }

    render_camera camera;
    status = choose_camera(cli, &rf.mesh, rf.scene_path, (double)frame.width / frame.height, &camera);
    if (status != RAD_OK) goto done;
    char camera_text[512];
    render_camera_format(&camera, camera_text, sizeof camera_text);
    rad_info("%s: %zu patches; %s", cli->input, rf.mesh.patch_count, camera_text);

    /* Channels: a grey scene (solved once) is drawn once, as one channel,
     * unless RGB is asked for; a colour scene asked to be grey is drawn from
     * its luminance, stored as a grey scene's file stores its one channel. */
    const double *radiosity = rf.radiosity;
    const char *channels_name = "rgb";
    frame.channels = 3;
    if (cli->channels == RENDER_CHANNELS_GREY || (cli->channels == RENDER_CHANNELS_AUTO && rf.channel_count == 1)) {
        frame.channels = 1;
        channels_name = "grey";
        if (rf.channel_count != 1) {
            luminance = malloc(3 * rf.mesh.patch_count * sizeof *luminance);
            if (!luminance) {
                rad_error("out of memory for %zu patches", rf.mesh.patch_count);
                status = RAD_ERR_NOMEM;
                goto done;
            }
            render_luminance_radiosity(rf.radiosity, rf.mesh.patch_count, luminance);
            radiosity = luminance;
            channels_name = "luminance";
        }
    }
    const char *drawing = frame.channels == 3 ? "R, G, B"
                          : luminance         ? "one channel, Rec. 709 luminance (--channels grey)"
                                              : "one grey channel";
    rad_info("%s: %s scene; drawing %s", cli->input, rf.channel_count == 1 ? "grey (solved once)" : "colour", drawing);

    size_t pixels = (size_t)frame.width * (size_t)frame.height;
    rgb = malloc((size_t)frame.channels * pixels * sizeof *rgb);
    if (!rgb) {
        rad_error("out of memory for a %dx%d image", frame.width, frame.height);
        status = RAD_ERR_NOMEM;
        goto done;
    }
    double t_draw = seconds_now();
    status = render_frame_draw(&rf.mesh, radiosity, &camera, &frame, rgb);
    if (status != RAD_OK) goto done;
    t_draw = seconds_now() - t_draw;
    warn_if_black(cli->input, &rf.mesh, radiosity, rf.channel_count, rgb, (size_t)frame.channels * pixels, camera_text);

    double scale = pow(2.0, cli->exposure);
    if (cli->auto_exposure) scale *= render_tonemap_auto_scale(&rf.mesh, radiosity);
    if (format == RENDER_IMAGE_PNG) render_tonemap_apply(rgb, pixels, frame.channels, scale);

    char fingerprint[32], scale_text[32], spp_text[16];
    snprintf(fingerprint, sizeof fingerprint, "%016" PRIx64, rf.scene_fingerprint);
    snprintf(scale_text, sizeof scale_text, "%.9g", scale);
    snprintf(spp_text, sizeof spp_text, "%d", frame.spp);
    const render_image_attr attrs[] = {
        {"ImageDescription", "radiosity solution rendered by render (radiosity project)"},
        {"rad:camera", camera_text},
        {"rad:scene_fingerprint", fingerprint},
        {"rad:shading", frame.shading == RENDER_SHADING_FLAT ? "flat" : "smooth"},
        {"rad:spp", spp_text},
        {"rad:display_scale", scale_text},
        {"rad:channels", channels_name},
        {"rad:values", format == RENDER_IMAGE_PNG
                           ? (luminance ? "sRGB(clamp(Y * rad:display_scale)), Y = 0.2126 B_r + 0.7152 B_g + 0.0722 B_b"
                                        : "sRGB(clamp(B * rad:display_scale))")
                           : (luminance ? "Y = 0.2126 B_r + 0.7152 B_g + 0.0722 B_b, linear, unscaled"
                                        : "radiosity B per channel, linear, unscaled")},
    };
    status = render_image_write(cli->output, rgb, frame.width, frame.height, frame.channels, attrs,
                                sizeof attrs / sizeof attrs[0]);
    if (status != RAD_OK) goto done;
    rad_info("wrote %s: %dx%d, %s, %d spp, %s shading, scale %.4g; draw %.3f s, total %.3f s", cli->output,
             frame.width, frame.height, channels_name, frame.spp,
             frame.shading == RENDER_SHADING_FLAT ? "flat" : "smooth", scale, t_draw, seconds_now() - t0);
done:
    free(rgb);
    free(luminance);
    rad_radiosity_free(&rf);
    return status;
}

int main(int argc, char **argv)
{
    render_cli cli;
    rad_log_set_program("render");
    rad_status status = parse_args(argc, argv, &cli);
    if (status == RAD_OK && cli.version) {
        printf("render %s\n", RAD_VERSION);
        return 0;
    }
    if (status == RAD_OK && cli.help) {
        fputs(usage_text, stdout);
        return 0;
    }
    if (status == RAD_OK) { /* before any work: docs/reliability.md, "Threat model: files on disk" */
        rad_fs_role roles[] = {{"the radiosity file", cli.input, 0}, {"--camera", cli.camera_path && strcmp(cli.camera_path, "auto") != 0 ? cli.camera_path : NULL, 0},
                               {"-o", cli.output, 1}};
        status = rad_fs_check_output("-o", cli.output);
        if (status == RAD_OK) status = rad_fs_check_roles(roles, sizeof roles / sizeof roles[0]);
    }
    if (status == RAD_OK) {
        if (cli.quiet) rad_log_set_level(RAD_LOG_ERROR);
        status = run(&cli);
    }
    return rad_status_exit_code(status);
}
