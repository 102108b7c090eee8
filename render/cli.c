/* cli.c - render's command line (cli.h): the options, their values, and
 * --help. Nothing here reads a file or draws. */
#include "cli.h"

#include <getopt.h>
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "rad_log.h"
#include "rad_parse.h"
#include "raster.h"

#define RENDER_MAX_EXPOSURE 64.0 /* |EV| beyond this is surely a typo */

const char render_cli_usage[] =
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

rad_status render_cli_parse(int argc, char **argv, render_cli *out)
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
    render_cli cli;
    memset(&cli, 0, sizeof cli);
    render_options *o = &cli.options;
    o->frame.shading = RENDER_SHADING_LINEAR;
    o->auto_exposure = 1;
    o->channels = RENDER_CHANNELS_AUTO;
    o->radiance = -1;
    rad_status status = RAD_OK;
    int opt, at = 0;
    opterr = 0; /* our own messages */
    optind = 1;
    while (status == RAD_OK && (opt = getopt_long(argc, argv, ":o:qh", longs, &at)) != -1) {
        const char *value = optarg;
        switch (opt) {
        case 'o': o->output = value; break;
        case 'q': cli.quiet = 1; break;
        case 'h': cli.help = 1; break;
        case O_VERSION: cli.version = 1; break;
        case O_WIDTH: status = parse_int("--width", value, 1, RENDER_MAX_SAMPLE_DIM, &o->frame.width); break;
        case O_HEIGHT: status = parse_int("--height", value, 1, RENDER_MAX_SAMPLE_DIM, &o->frame.height); break;
        case O_SPP: status = parse_int("--spp", value, 1, RENDER_MAX_SPP, &o->frame.spp); break;
        case O_CAMERA: o->camera_path = value; break;
        case O_EYE: status = parse_vec3("--eye", value, &o->eye); o->have_eye = 1; break;
        case O_LOOK_AT: status = parse_vec3("--look-at", value, &o->look_at); o->have_look_at = 1; break;
        case O_UP: status = parse_vec3("--up", value, &o->up); o->have_up = 1; break;
        case O_FOV: status = parse_double("--fov", value, &o->fov_y); o->have_fov = 1; break;
        case O_EXPOSURE: status = parse_exposure(value, &o->exposure); break;
        case O_NO_AUTO_EXPOSURE: o->auto_exposure = 0; break;
        case O_SHADING: status = parse_shading(value, &o->frame.shading); break;
        case O_CHANNELS: status = parse_channels(value, &o->channels); break;
        case O_QUANTITY: status = parse_quantity(value, &o->radiance); break;
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
        if (o->input) {
            rad_error("more than one radiosity file given ('%s' and '%s')", o->input, argv[i]);
            status = RAD_ERR_USAGE;
        } else {
            o->input = argv[i];
        }
    }
    if (status == RAD_OK) *out = cli;
    return status;
}
