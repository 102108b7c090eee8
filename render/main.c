/* render - draws a solved radiosity file into a PNG or EXR image.
 *
 * The only file of this stage that exits or prints outside the logger
 * (--help). See docs/render.md.
 */
#define _POSIX_C_SOURCE 200809L
#include <errno.h>
#include <getopt.h>
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
#include "rad_math.h"
#include "rad_rfile.h"
#include "rad_status.h"
#include "raster.h"
#include "sidecar.h"
#include "tonemap.h"

#define RENDER_DEFAULT_INPUT "radiosity"
#define RENDER_DEFAULT_EXTENSION ".png"
#define RENDER_OUTPUT_NAME_MAX 4096 /* the default output's name, PATH_MAX on Linux */
#define RENDER_MAX_EXPOSURE 64.0 /* |EV| beyond this is surely a typo */

static const char usage_text[] =
    "usage: render [options] [RADIOSITY]\n"
    "\n"
    "Draws the radiosity solution RADIOSITY (from solve; default: " RENDER_DEFAULT_INPUT ")\n"
    "into a PNG or EXR image.\n"
    "\n"
    "options:\n"
    "  -o, --output FILE    image to write; .png (8-bit sRGB) or .exr (linear half)\n"
    "                       (default: RADIOSITY's file name without its folder and\n"
    "                       extension, with " RENDER_DEFAULT_EXTENSION ", in the current directory:\n"
    "                       out/room.rad -> room.png, " RENDER_DEFAULT_INPUT " -> " RENDER_DEFAULT_INPUT
    RENDER_DEFAULT_EXTENSION ")\n"
    "  --channels MODE      auto (default): one grey channel when the radiosity file\n"
    "                       says the scene was solved as grey (channel count 1), RGB\n"
    "                       otherwise; rgb: always R, G, B (grey scenes: R = G = B);\n"
    "                       grey: always one channel (8-bit grey PNG, EXR channel Y);\n"
    "                       a colour scene is then drawn from its Rec. 709 luminance\n"
    "                       Y = 0.2126 R + 0.7152 G + 0.0722 B (linear B, of the\n"
    "                       colour picture's shaded corners)\n"
    "  --width N            image width in pixels (default: the camera file's width,\n"
    "                       else 512; with only --height, the file's aspect ratio)\n"
    "  --height N           image height in pixels (default: the camera file's height,\n"
    "                       else 512; with only --width, the file's aspect ratio)\n"
    "  --spp N              samples per pixel, a square: 1, 4, 9, 16, ... 256 (default: 16)\n"
    "  --camera FILE|auto   camera file (lines: eye X Y Z, look_at X Y Z, up X Y Z,\n"
    "                       fov_y DEGREES, width W, height H; # comments; at most\n"
    "                       16 KiB). Default: the\n"
    "                       scene's sidecar <scene>.camera beside its OBJ when there\n"
    "                       is one, else the measured camera for the Cornell box,\n"
    "                       automatic framing for other scenes; auto: the default\n"
    "                       without the sidecar. The OBJ is the path RADIOSITY\n"
    "                       records (as formfactor was given it): a relative one is\n"
    "                       tried from the current folder and from RADIOSITY's\n"
    "                       folder, and the file that is the scene solved (its\n"
    "                       fingerprint) wins; stderr says which sidecar is used or\n"
    "                       why none, and warns of one whose OBJ is missing or not\n"
    "                       the scene solved, or that lies outside the OBJ's folder.\n"
    "                       Scene paths of 88 bytes or more are not recorded: give\n"
    "                       --camera FILE\n"
    "  --eye X,Y,Z          camera position (overrides the camera file or default)\n"
    "  --look-at X,Y,Z      point at the image centre\n"
    "  --up X,Y,Z           up direction\n"
    "  --fov DEGREES        vertical field of view\n"
    "  --exposure EV        multiply the PNG's values by 2^EV (default: 0)\n"
    "  --no-auto-exposure   use 2^EV alone instead of 2^EV times the automatic scale\n"
    "  --shading MODE       linear (default): each patch corner from the patches'\n"
    "                       least-squares gradients on its surface (exact for linear\n"
    "                       radiosity, surface edges included; limited at shadow\n"
    "                       edges); smooth: corners hold the area-weighted mean of\n"
    "                       the patches around them (off by half a patch's gradient\n"
    "                       at a surface's edges); flat: each patch in its own B.\n"
    "                       Where refined patches meet coarse ones (formfactor\n"
    "                       --refine) corners are anchored to the coarse edge: no seams\n"
    "  --quantity Q         radiosity: the EXR holds B, the exitance, in the\n"
    "                       scene's emission units; radiance: it holds L = B / pi,\n"
    "                       what path tracers and image viewers expect of a diffuse\n"
    "                       surface. Default: radiance when formfactor read Ke as\n"
    "                       radiance (--ke radiance: L is then in Ke's units, as\n"
    "                       Cycles draws it), else radiosity. The PNG is the same\n"
    "                       either way with the automatic exposure; with\n"
    "                       --no-auto-exposure it shows 2^EV times the quantity\n"
    "                       chosen\n"
    "  -q, --quiet          only errors on stderr\n"
    "  -h, --help           this text\n"
    "      --version        print the version\n"
    "\n"
    "PNG: sRGB(clamp(Q * scale)); EXR: Q per channel, unscaled; Q = B or B / pi\n"
    "(--quantity; the file's rad:quantity says which).\n"
    "\n"
    "exit status: 0 success; 1 bad input or I/O error; 2 bad command line\n";

typedef enum render_channels_mode {
    RENDER_CHANNELS_AUTO = 0, /* what the radiosity file says */
    RENDER_CHANNELS_RGB = 1,
    RENDER_CHANNELS_GREY = 2
} render_channels_mode;

typedef struct render_cli {
    const char *input;       /* RENDER_DEFAULT_INPUT unless given */
    const char *output;      /* NULL: the default name (render_default_output) */
    const char *camera_path; /* NULL: the default camera; "auto": it without the sidecar */
    render_frame_options frame;
    int have_eye, have_look_at, have_up, have_fov;
    rad_vec3 eye, look_at, up;
    double fov_y;
    double exposure;
    int auto_exposure;
    int quiet, help, version;
    render_channels_mode channels;
    int radiance; /* --quantity radiance: L = B / pi instead of B; -1: not given (the file's Ke decides) */
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

static rad_status parse_exposure(const char *text, double *out)
{
    rad_status status = parse_double("--exposure", text, out);
    if (status == RAD_OK && fabs(*out) > RENDER_MAX_EXPOSURE) {
        rad_error("--exposure: %g stops is out of range (|EV| <= %g)", *out, RENDER_MAX_EXPOSURE);
        status = RAD_ERR_USAGE;
    }
    return status;
}

static rad_status parse_shading(const char *text, render_shading *out)
{
    if (strcmp(text, "smooth") == 0) {
        *out = RENDER_SHADING_SMOOTH;
    } else if (strcmp(text, "flat") == 0) {
        *out = RENDER_SHADING_FLAT;
    } else if (strcmp(text, "linear") == 0) {
        *out = RENDER_SHADING_LINEAR;
    } else {
        rad_error("--shading: '%s' is not linear, smooth or flat", text);
        return RAD_ERR_USAGE;
    }
    return RAD_OK;
}

static rad_status parse_channels(const char *text, render_channels_mode *out)
{
    if (strcmp(text, "auto") == 0) {
        *out = RENDER_CHANNELS_AUTO;
    } else if (strcmp(text, "rgb") == 0) {
        *out = RENDER_CHANNELS_RGB;
    } else if (strcmp(text, "grey") == 0) {
        *out = RENDER_CHANNELS_GREY;
    } else {
        rad_error("--channels: '%s' is not auto, rgb or grey", text);
        return RAD_ERR_USAGE;
    }
    return RAD_OK;
}

static rad_status parse_quantity(const char *text, int *out_radiance)
{
    if (strcmp(text, "radiosity") == 0) {
        *out_radiance = 0;
    } else if (strcmp(text, "radiance") == 0) {
        *out_radiance = 1;
    } else {
        rad_error("--quantity: '%s' is not radiosity or radiance", text);
        return RAD_ERR_USAGE;
    }
    return RAD_OK;
}

/* getopt_long, as formfactor and solve parse theirs: "--name VALUE",
 * "--name=VALUE", unambiguous abbreviations, "-o VALUE" and "-oVALUE";
 * options and the input in any order. */
static rad_status parse_args(int argc, char **argv, render_cli *out)
{
    enum { O_WIDTH = 256, O_HEIGHT, O_SPP, O_CAMERA, O_EYE, O_LOOK_AT, O_UP, O_FOV, O_EXPOSURE, O_NO_AUTO_EXPOSURE,
           O_SHADING, O_CHANNELS, O_QUANTITY, O_VERSION };
    static const struct option longs[] = {
        {"output", required_argument, 0, 'o'},    {"width", required_argument, 0, O_WIDTH},
        {"height", required_argument, 0, O_HEIGHT}, {"spp", required_argument, 0, O_SPP},
        {"camera", required_argument, 0, O_CAMERA}, {"eye", required_argument, 0, O_EYE},
        {"look-at", required_argument, 0, O_LOOK_AT}, {"up", required_argument, 0, O_UP},
        {"fov", required_argument, 0, O_FOV},     {"exposure", required_argument, 0, O_EXPOSURE},
        {"no-auto-exposure", no_argument, 0, O_NO_AUTO_EXPOSURE},
        {"shading", required_argument, 0, O_SHADING}, {"channels", required_argument, 0, O_CHANNELS},
        {"quantity", required_argument, 0, O_QUANTITY},
        {"quiet", no_argument, 0, 'q'},           {"help", no_argument, 0, 'h'},
        {"version", no_argument, 0, O_VERSION},   {0, 0, 0, 0}};
    render_cli c;
    memset(&c, 0, sizeof c);
    c.input = RENDER_DEFAULT_INPUT;
    c.frame.shading = RENDER_SHADING_LINEAR;
    c.auto_exposure = 1;
    c.channels = RENDER_CHANNELS_AUTO;
    c.radiance = -1;
    rad_status status = RAD_OK;
    int opt, at = 0, have_input = 0;
    opterr = 0; /* our own messages */
    optind = 1;
    while (status == RAD_OK && (opt = getopt_long(argc, argv, ":o:qh", longs, &at)) != -1) {
        const char *value = optarg;
        switch (opt) {
        case 'o': c.output = value; break;
        case 'q': c.quiet = 1; break;
        case 'h': c.help = 1; break;
        case O_VERSION: c.version = 1; break;
        case O_WIDTH: status = parse_int("--width", value, 1, RENDER_MAX_SAMPLE_DIM, &c.frame.width); break;
        case O_HEIGHT: status = parse_int("--height", value, 1, RENDER_MAX_SAMPLE_DIM, &c.frame.height); break;
        case O_SPP: status = parse_int("--spp", value, 1, RENDER_MAX_SPP, &c.frame.spp); break;
        case O_CAMERA: c.camera_path = value; break;
        case O_EYE: status = parse_vec3("--eye", value, &c.eye); c.have_eye = 1; break;
        case O_LOOK_AT: status = parse_vec3("--look-at", value, &c.look_at); c.have_look_at = 1; break;
        case O_UP: status = parse_vec3("--up", value, &c.up); c.have_up = 1; break;
        case O_FOV: status = parse_double("--fov", value, &c.fov_y); c.have_fov = 1; break;
        case O_EXPOSURE: status = parse_exposure(value, &c.exposure); break;
        case O_NO_AUTO_EXPOSURE: c.auto_exposure = 0; break;
        case O_SHADING: status = parse_shading(value, &c.frame.shading); break;
        case O_CHANNELS: status = parse_channels(value, &c.channels); break;
        case O_QUANTITY: status = parse_quantity(value, &c.radiance); break;
        case ':': /* a known option without its value */
            rad_error("%s needs a value", argv[optind - 1]);
            status = RAD_ERR_USAGE;
            break;
        default:
            rad_error("unknown option '%s' (see render --help)", argv[optind - 1]);
            status = RAD_ERR_USAGE;
        }
    }
    for (int i = optind; status == RAD_OK && i < argc; i++) {
        if (have_input) {
            rad_error("more than one radiosity file given ('%s' and '%s')", c.input, argv[i]);
            status = RAD_ERR_USAGE;
        } else {
            c.input = argv[i];
            have_input = 1;
        }
    }
    if (status == RAD_OK) *out = c;
    return status;
}

/* The default image name: the input's file name without its folder and
 * its extension (the last '.' and what follows, unless that '.' starts
 * the name), with RENDER_DEFAULT_EXTENSION, in the current directory:
 * "out/room.rad" -> "room.png", "radiosity" -> "radiosity.png". A name
 * with nothing left ("dir/") gives RENDER_DEFAULT_INPUT's. */
static rad_status render_default_output(const char *input, char *out, size_t out_size)
{
    const char *slash = strrchr(input, '/');
    const char *name = slash ? slash + 1 : input;
    const char *dot = strrchr(name, '.');
    size_t stem = dot && dot != name ? (size_t)(dot - name) : strlen(name);
    if (stem == 0) {
        name = RENDER_DEFAULT_INPUT;
        stem = strlen(name);
    }
    if (stem + sizeof RENDER_DEFAULT_EXTENSION > out_size) {
        rad_error("%s: the name is too long to make the image's name from; give -o FILE", input);
        return RAD_ERR_USAGE;
    }
    memcpy(out, name, stem);
    memcpy(out + stem, RENDER_DEFAULT_EXTENSION, sizeof RENDER_DEFAULT_EXTENSION);
    return RAD_OK;
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

/* The picture's size from a camera file's `width`/`height` (render_camera)
 * where the command line gives neither; with one of them, the other keeps
 * the file's aspect ratio. */
static void size_from_camera(const render_cli *cli, const render_camera *camera, render_frame_options *frame)
{
    if (camera->width <= 0 || camera->height <= 0) return;
    if (!cli->frame.width && !cli->frame.height) {
        frame->width = camera->width;
        frame->height = camera->height;
    } else if (!cli->frame.height) {
        frame->height = (int)fmax(1.0, floor((double)frame->width * camera->height / camera->width + 0.5));
    } else if (!cli->frame.width) {
        frame->width = (int)fmax(1.0, floor((double)frame->height * camera->width / camera->height + 0.5));
    }
}

/* The camera: file or default, then the flags on top; a file's size into
 * *frame (size_from_camera). */
static rad_status choose_camera(const render_cli *cli, const rad_radiosity *rf, render_frame_options *frame,
                                render_camera *out)
{
    rad_status status = RAD_OK;
    int cornell = 0;
    char source[RENDER_SIDECAR_PATH_MAX + 100];
    char sidecar[RENDER_SIDECAR_PATH_MAX];
    const char *scene_path = rf->scene_path;
    const render_sidecar_query query = {scene_path, cli->input, rf->scene_fingerprint};
    int automatic = cli->camera_path && strcmp(cli->camera_path, "auto") == 0;
    if (cli->camera_path && !automatic) {
        status = render_camera_load(cli->camera_path, out);
        if (status != RAD_OK) return status;
        snprintf(source, sizeof source, "from %s", cli->camera_path);
    } else if (!automatic && render_sidecar_find(&query, sidecar, sizeof sidecar)) {
        status = render_camera_load(sidecar, out);
        if (status != RAD_OK) {
            rad_error("%s: the camera sidecar of scene %s; fix it, or give --camera FILE or --camera auto",
                      sidecar, scene_path);
            return status;
        }
        snprintf(source, sizeof source, "from %s, the scene's sidecar (--camera auto ignores it)", sidecar);
    } else {
        render_camera_default(&rf->mesh, (double)frame->width / frame->height, out, &cornell);
        snprintf(source, sizeof source, "%s", cornell ? "the Cornell box's measured camera" : "automatic framing");
    }
    size_from_camera(cli, out, frame);
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
    int luminance = 0; /* one channel drawn from a colour scene's luminance */
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
    status = choose_camera(cli, &rf, &frame, &camera);
    if (status != RAD_OK) goto done;
    status = render_raster_check(&(render_raster_options){frame.width, frame.height, frame.spp, 1, 1.0, 0}, NULL);
    if (status != RAD_OK) goto done; /* a camera file's width and height, times --spp */
    /* What the EXR holds: the file's Ke decides unless --quantity is given. */
    const int radiance = cli->radiance >= 0 ? cli->radiance : (rf.flags & RAD_RF_FLAG_KE_RADIANCE) != 0;
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
            luminance = frame.luminance = 1; /* render_frame_draw draws the corners' luminance */
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

    /* Radiance of a diffuse surface: L = B / pi. The automatic exposure is
     * measured on B and divided by the same factor, so the PNG does not
     * change with the quantity (to float rounding). */
    const double unit = radiance ? 1 / RAD_PI : 1;
    if (unit != 1)
        for (size_t k = 0; k < (size_t)frame.channels * pixels; k++) rgb[k] = (float)(rgb[k] * unit);
    double scale = pow(2.0, cli->exposure);
    if (cli->auto_exposure) {
        /* A luminance picture is exposed by the patches' luminance. */
        double *exposed = luminance ? malloc(3 * (rf.mesh.patch_count ? rf.mesh.patch_count : 1) * sizeof *exposed) : NULL;
        if (exposed) render_luminance_radiosity(rf.radiosity, rf.mesh.patch_count, exposed);
        scale *= render_tonemap_auto_scale(&rf.mesh, exposed ? exposed : radiosity) / unit;
        free(exposed);
    }
    if (format == RENDER_IMAGE_PNG) render_tonemap_apply(rgb, pixels, frame.channels, scale);

    char fingerprint[32], scale_text[32], spp_text[16], values_text[160];
    const char *q = radiance ? "L" : "B", *q_name = radiance ? "radiance L = B / pi" : "radiosity B";
    if (format == RENDER_IMAGE_PNG && luminance)
        snprintf(values_text, sizeof values_text,
                 "sRGB(clamp(Y * rad:display_scale)), Y = 0.2126 %s_r + 0.7152 %s_g + 0.0722 %s_b", q, q, q);
    else if (format == RENDER_IMAGE_PNG)
        snprintf(values_text, sizeof values_text, "sRGB(clamp(%s * rad:display_scale))", q);
    else if (luminance)
        snprintf(values_text, sizeof values_text, "Y = 0.2126 %s_r + 0.7152 %s_g + 0.0722 %s_b, linear, unscaled", q,
                 q, q);
    else
        snprintf(values_text, sizeof values_text, "%s per channel, linear, unscaled", q_name);
    snprintf(fingerprint, sizeof fingerprint, "%016" PRIx64, rf.scene_fingerprint);
    snprintf(scale_text, sizeof scale_text, "%.9g", scale);
    snprintf(spp_text, sizeof spp_text, "%d", frame.spp);
    const render_image_attr attrs[] = {
        {"ImageDescription", "radiosity solution rendered by render (radiosity project)"},
        {"rad:camera", camera_text},
        {"rad:scene_fingerprint", fingerprint},
        {"rad:shading", render_shading_name(frame.shading)},
        {"rad:spp", spp_text},
        {"rad:display_scale", scale_text},
        {"rad:channels", channels_name},
        {"rad:quantity", radiance ? "radiance L = B / pi (per steradian)" : "radiosity B (exitance)"},
        {"rad:values", values_text},
        /* last, and only with --ke radiance: older files' images keep their bytes */
        {"rad:emission", "Ke read as emitted radiance L (formfactor --ke radiance): E = pi Ke, so L is in Ke's units"},
    };
    const size_t attr_count = sizeof attrs / sizeof attrs[0] - ((rf.flags & RAD_RF_FLAG_KE_RADIANCE) ? 0 : 1);
    status = render_image_write(cli->output, rgb, frame.width, frame.height, frame.channels, attrs, attr_count);
    if (status != RAD_OK) goto done;
    rad_info("wrote %s: %dx%d, %s, %d spp, %s shading, scale %.4g; draw %.3f s, total %.3f s", cli->output,
             frame.width, frame.height, channels_name, frame.spp,
             render_shading_name(frame.shading), scale, t_draw, seconds_now() - t0);
done:
    free(rgb);
    rad_radiosity_free(&rf);
    return status;
}

int main(int argc, char **argv)
{
    render_cli cli;
    char default_output[RENDER_OUTPUT_NAME_MAX];
    rad_log_set_program("render");
    rad_status status = parse_args(argc, argv, &cli);
    if (status != RAD_OK) {
        fputs("try 'render --help'\n", stderr);
        return rad_status_exit_code(status);
    }
    if (cli.version) {
        printf("render %s\n", RAD_VERSION);
        return 0;
    }
    if (cli.help) {
        fputs(usage_text, stdout);
        return 0;
    }
    if (!cli.output) {
        status = render_default_output(cli.input, default_output, sizeof default_output);
        cli.output = default_output;
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
