/* stage.c - the render stage (stage.h) in three steps after the names
 * are checked: load (the radiosity file and the camera), draw (the
 * channels chosen, the image rasterized) and write (exposed, tone-mapped
 * for a PNG, written with its attributes). */
#define _POSIX_C_SOURCE 200809L
#include "stage.h"

#include <inttypes.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "camera.h"
#include "image.h"
#include "rad_clock.h"
#include "rad_fs.h"
#include "rad_log.h"
#include "rad_rfile.h"
#include "rad_scene.h"
#include "raster.h"
#include "sidecar.h"
#include "tonemap.h"

/* What the steps share; freed in one place (render_stage_run). */
typedef struct stage_state {
    const render_options *options;
    const char *input, *output;         /* resolved: never NULL */
    char default_output[RENDER_OUTPUT_NAME_MAX];
    double t0;                          /* rad_clock_seconds() when the load began */
    /* the load step's */
    render_image_format format;
    render_frame_options frame;         /* resolved; the draw step sets its channels and luminance */
    rad_radiosity rf;                   /* owned */
    uint32_t *smooth_groups;            /* owned: the OBJ's smoothing groups by face, or NULL */
    render_smoothing smoothing;         /* over smooth_groups */
    render_camera camera;
    char camera_text[512];
    int framed_automatically; /* the camera is the automatic framing, no --eye/--look-at/--up/--fov on it */
    /* the draw step's */
    int luminance;                      /* one channel drawn from a colour scene's luminance */
    int radiance;                       /* the EXR holds L = B / pi (--quantity, else the file's Ke) */
    const char *channels_name;          /* "rgb", "grey" or "luminance" */
    float *rgb;                         /* owned: frame.channels values per pixel */
    size_t pixels;
    double draw_seconds;
} stage_state;

/* The default image name: the input's file name without its folder and
 * its extension (the last '.' and what follows, unless that '.' starts
 * the name), with RENDER_DEFAULT_EXTENSION, in the current directory:
 * "out/room.rad" -> "room.png", "radiosity" -> "radiosity.png". A name
 * with nothing left ("dir/") gives RENDER_DEFAULT_INPUT's. */
static rad_status default_output(const char *input, char *out, size_t out_size)
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

/* A black image is never silent: it says whether nothing emits (every
 * radiosity 0) or the camera sees nothing lit. */
static void warn_if_black(const char *input, const rad_mesh *mesh, const double *radiosity, uint32_t channels,
                          const float *pixels, size_t values, const char *camera_text, int framed_automatically)
{
    for (size_t k = 0; k < values; k++)
        if (pixels[k] != 0.0f) return;
    int lit = 0;
    for (size_t k = 0; k < mesh->patch_count * channels && !lit; k++) lit = radiosity[k] != 0.0;
    if (!lit)
        rad_warn("%s: the image is black: every radiosity is 0, so nothing emits light (no material with Ke > 0). "
                 RAD_SCENE_NO_LIGHT_HINT, input);
    else if (framed_automatically)
        rad_warn("%s: the image is black: the camera, framed automatically around the whole scene, sees nothing "
                 "lit (%s): the lit faces turn away from it or are hidden (formfactor's warnings name faces that "
                 "point the wrong way); place the camera with --eye/--look-at or a camera sidecar",
                 input, camera_text);
    else
        rad_warn("%s: the image is black: the camera sees nothing lit (%s); try the automatic framing "
                 "(--camera auto) or other --eye/--look-at",
                 input, camera_text);
}

/* The OBJ's smoothing groups (Shade Smooth), when the scene solved is
 * found and has some: corners blend across its groups' edges (shade.h). */
static void load_smoothing(stage_state *s)
{
    if (s->frame.shading == RENDER_SHADING_FLAT) return;
    const render_sidecar_query query = {s->rf.scene_path, s->input, s->rf.scene_fingerprint};
    size_t count = 0;
    if (!render_scene_smoothing(&query, &s->smooth_groups, &count)) return;
    size_t smooth = 0;
    for (size_t f = 0; f < count; f++) smooth += s->smooth_groups[f] != 0;
    s->smoothing.face_group = s->smooth_groups;
    s->smoothing.face_count = count;
    s->frame.smoothing = &s->smoothing;
    rad_info("shading: %zu of %zu faces of %s are in smoothing groups (OBJ `s`, Blender's Shade Smooth): "
             "blended across their edges",
             smooth, count, s->rf.scene_path);
}

/* The picture's size from a camera file's `width`/`height` (render_camera)
 * where the command line gives neither; with one of them, the other keeps
 * the file's aspect ratio. */
static void size_from_camera(const render_options *options, const render_camera *camera, render_frame_options *frame)
{
    if (camera->width <= 0 || camera->height <= 0) return;
    if (!options->frame.width && !options->frame.height) {
        frame->width = camera->width;
        frame->height = camera->height;
    } else if (!options->frame.height) {
        frame->height = (int)fmax(1.0, floor((double)frame->width * camera->height / camera->width + 0.5));
    } else if (!options->frame.width) {
        frame->width = (int)fmax(1.0, floor((double)frame->height * camera->width / camera->height + 0.5));
    }
}

/* The camera: file or default, then the flags on top; a file's size into
 * *frame (size_from_camera). */
static rad_status choose_camera(const render_options *options, const char *input, const rad_radiosity *rf,
                                render_frame_options *frame, render_camera *out, int *out_automatic)
{
    rad_status status = RAD_OK;
    int cornell = 0;
    char source[RENDER_SIDECAR_PATH_MAX + 100];
    char sidecar[RENDER_SIDECAR_PATH_MAX];
    const char *scene_path = rf->scene_path;
    const render_sidecar_query query = {scene_path, input, rf->scene_fingerprint};
    int automatic = options->camera_path && strcmp(options->camera_path, "auto") == 0;
    if (options->camera_path && !automatic) {
        status = render_camera_load(options->camera_path, out);
        if (status != RAD_OK) return status;
        snprintf(source, sizeof source, "from %s", options->camera_path);
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
    size_from_camera(options, out, frame);
    if (options->have_eye) out->eye = options->eye;
    if (options->have_look_at) out->look_at = options->look_at;
    if (options->have_up) out->up = options->up;
    if (options->have_fov) out->fov_y = options->fov_y;
    int overridden = options->have_eye || options->have_look_at || options->have_up || options->have_fov;
    *out_automatic = strcmp(source, "automatic framing") == 0 && !overridden;
    /* --eye/--look-at along the up that came with the camera (the default
     * frames with z or y up): without --up of their own, take the axis
     * most across the view instead of refusing. */
    rad_vec3 dir = rad_v3_sub(out->look_at, out->eye);
    double dir_len = rad_v3_length(dir), up_len = rad_v3_length(out->up);
    if (!options->have_up && dir_len > 0 && up_len > 0 &&
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

/* The output's name (the default one when not given), then the names
 * checked before any work: docs/reliability.md, "Threat model: files on
 * disk". */
static rad_status stage_check_names(stage_state *s)
{
    const render_options *options = s->options;
    rad_status status = RAD_OK;
    s->output = options->output;
    if (!s->output) {
        status = default_output(s->input, s->default_output, sizeof s->default_output);
        s->output = s->default_output;
    }
    if (status != RAD_OK) return status;
    const char *camera_file =
        options->camera_path && strcmp(options->camera_path, "auto") != 0 ? options->camera_path : NULL;
    rad_fs_role roles[] = {{"the radiosity file", s->input, 0}, {"--camera", camera_file, 0}, {"-o", s->output, 1}};
    status = rad_fs_check_output("-o", s->output);
    if (status == RAD_OK) status = rad_fs_check_roles(roles, sizeof roles / sizeof roles[0]);
    return status;
}

/* The load step: the image type and size checked, the radiosity file
 * read, the camera chosen. */
static rad_status stage_load(stage_state *s)
{
    s->t0 = rad_clock_seconds();
    s->format = render_image_format_of(s->output);
    if (s->format == RENDER_IMAGE_UNKNOWN) {
        rad_error("%s: unknown image type (the name must end in .png or .exr)", s->output);
        return RAD_ERR_USAGE;
    }
    s->frame = render_frame_options_resolve(&s->options->frame);
    const render_frame_options *frame = &s->frame;
    rad_status status =
        render_raster_check(&(render_raster_options){frame->width, frame->height, frame->spp, 1, 1.0, 0}, NULL);
    if (status != RAD_OK) return RAD_ERR_USAGE;
    status = rad_rf_read(s->input, &s->rf);
    if (status != RAD_OK) return status;
    if (s->rf.mesh.patch_count == 0) {
        rad_error("%s: no patches to draw", s->input);
        return RAD_ERR_INVALID;
    }
    load_smoothing(s);
    status = choose_camera(s->options, s->input, &s->rf, &s->frame, &s->camera, &s->framed_automatically);
    if (status != RAD_OK) return status;
    /* a camera file's width and height, times --spp */
    status = render_raster_check(&(render_raster_options){frame->width, frame->height, frame->spp, 1, 1.0, 0}, NULL);
    if (status != RAD_OK) return status;
    /* What the EXR holds: the file's Ke decides unless --quantity is given. */
    s->radiance = s->options->radiance >= 0 ? s->options->radiance : (s->rf.flags & RAD_RF_FLAG_KE_RADIANCE) != 0;
    render_camera_format(&s->camera, s->camera_text, sizeof s->camera_text);
    rad_info("%s: %zu patches; %s", s->input, s->rf.mesh.patch_count, s->camera_text);
    return RAD_OK;
}

/* The draw step: the channels chosen, the linear image drawn. */
static rad_status stage_draw(stage_state *s)
{
    render_frame_options *frame = &s->frame;
    const render_channels_mode mode = s->options->channels;
    const rad_radiosity *rf = &s->rf;
    /* Channels: a grey scene (solved once) is drawn once, as one channel,
     * unless RGB is asked for; a colour scene asked to be grey is drawn from
     * its luminance, stored as a grey scene's file stores its one channel. */
    s->channels_name = "rgb";
    frame->channels = 3;
    if (mode == RENDER_CHANNELS_GREY || (mode == RENDER_CHANNELS_AUTO && rf->channel_count == 1)) {
        frame->channels = 1;
        s->channels_name = "grey";
        if (rf->channel_count != 1) {
            s->luminance = frame->luminance = 1; /* render_frame_draw draws the corners' luminance */
            s->channels_name = "luminance";
        }
    }
    const char *drawing = frame->channels == 3 ? "R, G, B"
                          : s->luminance       ? "one channel, Rec. 709 luminance (--channels grey)"
                                               : "one grey channel";
    rad_info("%s: %s scene; drawing %s", s->input, rf->channel_count == 1 ? "grey (solved once)" : "colour",
             drawing);

    s->pixels = (size_t)frame->width * (size_t)frame->height;
    s->rgb = malloc((size_t)frame->channels * s->pixels * sizeof *s->rgb);
    if (!s->rgb) {
        rad_error("out of memory for a %dx%d image", frame->width, frame->height);
        return RAD_ERR_NOMEM;
    }
    double t_draw = rad_clock_seconds();
    rad_status status = render_frame_draw(&rf->mesh, rf->radiosity, &s->camera, frame, s->rgb);
    if (status != RAD_OK) return status;
    s->draw_seconds = rad_clock_seconds() - t_draw;
    warn_if_black(s->input, &rf->mesh, rf->radiosity, rf->channel_count, s->rgb,
                  (size_t)frame->channels * s->pixels, s->camera_text, s->framed_automatically);
    return RAD_OK;
}

/* The quantity asked for and the display scale: radiance of a diffuse
 * surface is L = B / pi. The automatic exposure is measured on B and
 * divided by the same factor, so the PNG does not change with the quantity
 * (to float rounding). A PNG's values are tone-mapped here. Returns the
 * scale. */
static double expose(stage_state *s)
{
    const render_options *options = s->options;
    const rad_radiosity *rf = &s->rf;
    const size_t values = (size_t)s->frame.channels * s->pixels;
    const double unit = s->radiance ? 1 / RAD_PI : 1;
    if (unit != 1)
        for (size_t k = 0; k < values; k++) s->rgb[k] = (float)(s->rgb[k] * unit);
    double scale = pow(2.0, options->exposure);
    if (options->auto_exposure) {
        /* A luminance picture is exposed by the patches' luminance. */
        double *exposed =
            s->luminance ? malloc(3 * (rf->mesh.patch_count ? rf->mesh.patch_count : 1) * sizeof *exposed) : NULL;
        if (exposed) render_luminance_radiosity(rf->radiosity, rf->mesh.patch_count, exposed);
        scale *= render_tonemap_auto_scale(&rf->mesh, exposed ? exposed : rf->radiosity) / unit;
        free(exposed);
    }
    if (s->format == RENDER_IMAGE_PNG) render_tonemap_apply(s->rgb, s->pixels, s->frame.channels, scale);
    return scale;
}

/* The write step: exposed, then written with attributes that say what
 * its values are. */
static rad_status stage_write(stage_state *s)
{
    const render_frame_options *frame = &s->frame;
    const double scale = expose(s);
    char fingerprint[32], scale_text[32], spp_text[16], values_text[160];
    const char *q = s->radiance ? "L" : "B";
    const char *q_name = s->radiance ? "radiance L = B / pi" : "radiosity B";
    if (s->format == RENDER_IMAGE_PNG && s->luminance)
        snprintf(values_text, sizeof values_text,
                 "sRGB(clamp(Y * rad:display_scale)), Y = 0.2126 %s_r + 0.7152 %s_g + 0.0722 %s_b", q, q, q);
    else if (s->format == RENDER_IMAGE_PNG)
        snprintf(values_text, sizeof values_text, "sRGB(clamp(%s * rad:display_scale))", q);
    else if (s->luminance)
        snprintf(values_text, sizeof values_text, "Y = 0.2126 %s_r + 0.7152 %s_g + 0.0722 %s_b, linear, unscaled", q,
                 q, q);
    else
        snprintf(values_text, sizeof values_text, "%s per channel, linear, unscaled", q_name);
    snprintf(fingerprint, sizeof fingerprint, "%016" PRIx64, s->rf.scene_fingerprint);
    snprintf(scale_text, sizeof scale_text, "%.9g", scale);
    snprintf(spp_text, sizeof spp_text, "%d", frame->spp);
    const render_image_attr attrs[] = {
        {"ImageDescription", "radiosity solution rendered by render (radiosity project)"},
        {"rad:camera", s->camera_text},
        {"rad:scene_fingerprint", fingerprint},
        {"rad:shading", render_shading_name(frame->shading)},
        {"rad:spp", spp_text},
        {"rad:display_scale", scale_text},
        {"rad:channels", s->channels_name},
        {"rad:quantity", s->radiance ? "radiance L = B / pi (per steradian)" : "radiosity B (exitance)"},
        {"rad:values", values_text},
        /* last, and only with --ke radiance: older files' images keep their bytes */
        {"rad:emission", "Ke read as emitted radiance L (formfactor --ke radiance): E = pi Ke, so L is in Ke's units"},
    };
    const size_t attr_count = sizeof attrs / sizeof attrs[0] - ((s->rf.flags & RAD_RF_FLAG_KE_RADIANCE) ? 0 : 1);
    rad_status status =
        render_image_write(s->output, s->rgb, frame->width, frame->height, frame->channels, attrs, attr_count);
    if (status != RAD_OK) return status;
    rad_info("wrote %s: %dx%d, %s, %d spp, %s shading, scale %.4g; draw %.3f s, total %.3f s", s->output,
             frame->width, frame->height, s->channels_name, frame->spp, render_shading_name(frame->shading), scale,
             s->draw_seconds, rad_clock_seconds() - s->t0);
    return RAD_OK;
}

rad_status render_stage_run(const render_options *options)
{
    stage_state s;
    memset(&s, 0, sizeof s);
    s.options = options;
    s.input = options->input ? options->input : RENDER_DEFAULT_INPUT;
    rad_status status = stage_check_names(&s);
    if (status == RAD_OK) status = stage_load(&s);
    if (status == RAD_OK) status = stage_draw(&s);
    if (status == RAD_OK) status = stage_write(&s);
    free(s.rgb);
    free(s.smooth_groups);
    rad_radiosity_free(&s.rf);
    return status;
}
