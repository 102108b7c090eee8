#include "camera.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <stdint.h>
#include <sys/stat.h>

#include "rad_box.h"
#include "rad_fs.h"
#include "rad_log.h"

/* Automatic framing stands back this much further than the distance at
 * which the bounding box's cross-section exactly fills the view; 1.04 is
 * what the measured Cornell camera does (800 mm where 768 mm would fit). */
#define RENDER_AUTO_MARGIN 1.04
/* Emitters decide "up" only when their centroid lies this far from the
 * bounding box's centre, as a fraction of the half-extent on that axis. */
#define RENDER_AUTO_UP_MIN_OFFSET 0.25
/* |sin| of the angle between up and the view direction below which the
 * two count as parallel. */
#define RENDER_PARALLEL_SIN 1e-6

#define CAMERA_LINE_MAX 1024
#define CAMERA_TOKENS_MAX 8

render_camera render_camera_cornell(void)
{
    render_camera c;
    c.eye = rad_v3(278.0, 273.0, -800.0);
    c.look_at = rad_v3(278.0, 273.0, 0.0);
    c.up = rad_v3(0.0, 1.0, 0.0);
    c.fov_y = RENDER_DEFAULT_FOV_Y;
    c.width = c.height = 0;
    return c;
}

/* Splits `line` in place at blanks; returns the token count (at most max,
 * *out_more set if there were more). */
static int split_tokens(char *line, char **tokens, int max, int *out_more)
{
    int count = 0;
    *out_more = 0;
    char *p = line;
    for (;;) {
        while (*p == ' ' || *p == '\t' || *p == '\r' || *p == '\v' || *p == '\f') p++;
        if (!*p) break;
        if (count == max) {
            *out_more = 1;
            break;
        }
        tokens[count++] = p;
        while (*p && *p != ' ' && *p != '\t' && *p != '\r' && *p != '\v' && *p != '\f') p++;
        if (*p) *p++ = 0;
    }
    return count;
}

static int parse_number(const char *token, double *out)
{
    char *end = NULL;
    double v = strtod(token, &end);
    if (end == token || *end || !isfinite(v)) return 0;
    *out = v;
    return 1;
}

enum { KEY_EYE, KEY_LOOK_AT, KEY_UP, KEY_FOV_Y, KEY_WIDTH, KEY_HEIGHT, KEY_COUNT };
static const char *const key_names[KEY_COUNT] = {"eye", "look_at", "up", "fov_y", "width", "height"};
static const int key_arity[KEY_COUNT] = {3, 3, 3, 1, 1, 1};

/* One non-blank, comment-free line: "key numbers...". */
static rad_status parse_statement(const char *name, int line_no, char *line, render_camera *cam,
                                  int seen[KEY_COUNT])
{
    char *tok[CAMERA_TOKENS_MAX];
    int more = 0;
    int n = split_tokens(line, tok, CAMERA_TOKENS_MAX, &more);
    if (n == 0) return RAD_OK;
    int key = -1;
    for (int k = 0; k < KEY_COUNT; k++)
        if (strcmp(tok[0], key_names[k]) == 0) key = k;
    if (key < 0) {
        rad_error("%s:%d: unknown key '%s' (expected eye, look_at, up, fov_y, width or height)", name, line_no,
                  tok[0]);
        return RAD_ERR_PARSE;
    }
    if (seen[key]) {
        rad_error("%s:%d: '%s' given twice (first on line %d)", name, line_no, tok[0], seen[key]);
        return RAD_ERR_PARSE;
    }
    if (more || n - 1 != key_arity[key]) {
        rad_error("%s:%d: '%s' takes %d number%s", name, line_no, tok[0], key_arity[key],
                  key_arity[key] == 1 ? "" : "s");
        return RAD_ERR_PARSE;
    }
    double v[3] = {0, 0, 0};
    for (int i = 0; i < key_arity[key]; i++) {
        if (!parse_number(tok[1 + i], &v[i])) {
            rad_error("%s:%d: '%s' is not a finite number", name, line_no, tok[1 + i]);
            return RAD_ERR_PARSE;
        }
    }
    if (key == KEY_FOV_Y && !(v[0] > 0.0 && v[0] < 180.0)) {
        rad_error("%s:%d: fov_y %g is outside (0, 180) degrees", name, line_no, v[0]);
        return RAD_ERR_INVALID;
    }
    if ((key == KEY_WIDTH || key == KEY_HEIGHT) && !(v[0] >= 1 && v[0] <= RENDER_CAMERA_SIZE_MAX && v[0] == floor(v[0]))) {
        rad_error("%s:%d: %s %s is not a whole number of pixels in [1, %d]", name, line_no, tok[0], tok[1],
                  RENDER_CAMERA_SIZE_MAX);
        return RAD_ERR_INVALID;
    }
    switch (key) {
    case KEY_EYE: cam->eye = rad_v3(v[0], v[1], v[2]); break;
    case KEY_LOOK_AT: cam->look_at = rad_v3(v[0], v[1], v[2]); break;
    case KEY_UP: cam->up = rad_v3(v[0], v[1], v[2]); break;
    case KEY_WIDTH: cam->width = (int)v[0]; break;
    case KEY_HEIGHT: cam->height = (int)v[0]; break;
    default: cam->fov_y = v[0]; break;
    }
    seen[key] = line_no;
    return RAD_OK;
}

rad_status render_camera_parse(const char *name, const char *text, render_camera *out_camera)
{
    rad_status status = RAD_OK;
    render_camera cam = {rad_v3(0, 0, 0), rad_v3(0, 0, 0), rad_v3(0, 1, 0), RENDER_DEFAULT_FOV_Y, 0, 0};
    int seen[KEY_COUNT] = {0};
    char line[CAMERA_LINE_MAX];
    int line_no = 0;
    const char *p = text;
    if ((unsigned char)p[0] == 0xEF && (unsigned char)p[1] == 0xBB && (unsigned char)p[2] == 0xBF) p += 3;
    while (*p) {
        line_no++;
        const char *end = strchr(p, '\n');
        size_t len = end ? (size_t)(end - p) : strlen(p);
        if (len >= sizeof line) {
            rad_error("%s:%d: line longer than %d characters", name, line_no, CAMERA_LINE_MAX - 1);
            status = RAD_ERR_PARSE;
            goto done;
        }
        memcpy(line, p, len);
        line[len] = 0;
        char *hash = strchr(line, '#');
        if (hash) *hash = 0;
        /* ';' also ends a statement, so the one-line form render writes
         * into the image (rad:camera, render_camera_format) is a camera
         * file too. */
        for (char *stmt = line, *semi; stmt; stmt = semi ? semi + 1 : NULL) {
            semi = strchr(stmt, ';');
            if (semi) *semi = 0;
            status = parse_statement(name, line_no, stmt, &cam, seen);
            if (status != RAD_OK) goto done;
        }
        p = end ? end + 1 : p + len;
    }
    for (int k = KEY_EYE; k <= KEY_LOOK_AT; k++) {
        if (!seen[k]) {
            rad_error("%s: missing '%s'", name, key_names[k]);
            status = RAD_ERR_INVALID;
            goto done;
        }
    }
    if (!seen[KEY_WIDTH] != !seen[KEY_HEIGHT]) {
        rad_error("%s:%d: '%s' without '%s' (give both, or neither)", name,
                  seen[KEY_WIDTH] ? seen[KEY_WIDTH] : seen[KEY_HEIGHT], seen[KEY_WIDTH] ? "width" : "height",
                  seen[KEY_WIDTH] ? "height" : "width");
        status = RAD_ERR_INVALID;
        goto done;
    }
    status = render_camera_validate(&cam, name);
    if (status != RAD_OK) goto done;
    *out_camera = cam;
done:
    return status;
}

rad_status render_camera_load(const char *path, render_camera *out_camera)
{
    rad_status status = RAD_ERR_IO;
    char *text = NULL;
    /* Read at most one byte past the cap, so a huge file (or one that grows
     * while read) costs RENDER_CAMERA_FILE_MAX bytes, not its size. */
    FILE *f = rad_fs_open_input(path); /* regular files only: no FIFO, no /dev/zero */
    if (!f) goto done;
    text = malloc(RENDER_CAMERA_FILE_MAX + 2);
    if (!text) {
        rad_error("%s: out of memory", path);
        status = RAD_ERR_NOMEM;
        goto done;
    }
    size_t size = fread(text, 1, RENDER_CAMERA_FILE_MAX + 1, f);
    if (ferror(f)) {
        rad_error("%s: read error", path);
        goto done;
    }
    if (size > RENDER_CAMERA_FILE_MAX) {
        struct stat st;
        if (fstat(fileno(f), &st) == 0 && (uint64_t)st.st_size > RENDER_CAMERA_FILE_MAX)
            rad_error("%s: %llu bytes; a camera file (four short lines) is at most %d bytes: not a camera file?",
                      path, (unsigned long long)st.st_size, RENDER_CAMERA_FILE_MAX);
        else
            rad_error("%s: more than %d bytes; a camera file (four short lines) is at most that: not a camera file?",
                      path, RENDER_CAMERA_FILE_MAX);
        status = RAD_ERR_INVALID;
        goto done;
    }
    text[size] = 0;
    if (strlen(text) != size) {
        rad_error("%s: contains a NUL byte; not a camera file", path);
        status = RAD_ERR_PARSE;
        goto done;
    }
    status = render_camera_parse(path, text, out_camera);
done:
    if (f) fclose(f);
    free(text);
    return status;
}

rad_status render_camera_validate(const render_camera *camera, const char *what)
{
    const render_camera *c = camera;
    double coords[10] = {c->eye.x, c->eye.y, c->eye.z, c->look_at.x, c->look_at.y,
                         c->look_at.z, c->up.x, c->up.y, c->up.z, c->fov_y};
    for (int i = 0; i < 10; i++) {
        if (!isfinite(coords[i])) {
            rad_error("%s: camera values must be finite", what);
            return RAD_ERR_INVALID;
        }
    }
    if (!(c->fov_y > 0.0 && c->fov_y < 180.0)) {
        rad_error("%s: fov_y %g is outside (0, 180) degrees", what, c->fov_y);
        return RAD_ERR_INVALID;
    }
    rad_vec3 dir = rad_v3_sub(c->look_at, c->eye);
    double dir_len = rad_v3_length(dir), up_len = rad_v3_length(c->up);
    if (!(dir_len > 0.0)) {
        rad_error("%s: eye and look_at are the same point", what);
        return RAD_ERR_INVALID;
    }
    if (!(up_len > 0.0) || rad_v3_length(rad_v3_cross(dir, c->up)) <= RENDER_PARALLEL_SIN * dir_len * up_len) {
        rad_error("%s: up (%g %g %g) is zero or parallel to the view direction", what, c->up.x, c->up.y, c->up.z);
        return RAD_ERR_INVALID;
    }
    return RAD_OK;
}

typedef struct bbox {
    rad_vec3 lo, hi;
} bbox;

static double axis_of(rad_vec3 v, int axis) { return axis == 0 ? v.x : axis == 1 ? v.y : v.z; }

static rad_vec3 unit_axis(int axis, double sign)
{
    return rad_v3(axis == 0 ? sign : 0.0, axis == 1 ? sign : 0.0, axis == 2 ? sign : 0.0);
}

/* Bounding box of the vertices that patches use (a file's mesh has at
 * least one patch). */
static bbox mesh_bbox(const rad_mesh *mesh)
{
    rad_box box = rad_box_empty();
    for (size_t p = 0; p < mesh->patch_count; p++) {
        const rad_patch *patch = &mesh->patches[p];
        for (uint32_t k = 0; k < patch->vertex_count; k++) rad_box_add(&box, &mesh->positions[3 * (size_t)patch->v[k]]);
    }
    return (bbox){rad_v3(box.lo[0], box.lo[1], box.lo[2]), rad_v3(box.hi[0], box.hi[1], box.hi[2])};
}

void render_camera_auto(const rad_mesh *mesh, double aspect, render_camera *out_camera)
{
    bbox b = mesh_bbox(mesh);
    rad_vec3 centre = rad_v3_scale(rad_v3_add(b.lo, b.hi), 0.5);
    rad_vec3 half = rad_v3_scale(rad_v3_sub(b.hi, b.lo), 0.5);

    /* "Up" points from the centre towards the emitters (the light hangs
     * from the ceiling), along the axis where their power-weighted
     * centroid is furthest out; +y when that is not clear. */
    double wsum = 0.0;
    rad_vec3 ecentre = rad_v3(0, 0, 0);
    for (size_t p = 0; p < mesh->patch_count; p++) {
        const rad_patch *patch = &mesh->patches[p];
        double w = patch->area * (patch->emission[0] + patch->emission[1] + patch->emission[2]);
        wsum += w;
        ecentre = rad_v3_add(ecentre, rad_v3_scale(patch->centroid, w));
    }
    int up_axis = 1;
    double up_sign = 1.0;
    if (wsum > 0.0) {
        ecentre = rad_v3_scale(ecentre, 1.0 / wsum);
        double best = RENDER_AUTO_UP_MIN_OFFSET;
        for (int a = 0; a < 3; a++) {
            double h = axis_of(half, a);
            if (!(h > 0.0)) continue;
            double off = (axis_of(ecentre, a) - axis_of(centre, a)) / h;
            if (fabs(off) > best) {
                best = fabs(off);
                up_axis = a;
                up_sign = off > 0 ? 1.0 : -1.0;
            }
        }
    }
    /* The camera looks along -z when up is y, from the scene's front: OBJ's
     * (and OpenGL's) convention, +x to the right, and a Blender scene's front
     * view once exported Y-up (Blender's -y, the front, becomes +z). Along
     * +y when up is z (Blender's own front view, +x to the right), along +z
     * when up is x. */
    int fwd_axis = up_axis == 2 ? 1 : 2;
    double fwd_sign = up_axis == 1 ? -1.0 : 1.0;
    int right_axis = 3 - up_axis - fwd_axis;

    double tan_y = tan(0.5 * RENDER_DEFAULT_FOV_Y * RAD_PI / 180.0);
    double tan_x = tan_y * aspect;
    double fit = fmax(axis_of(half, up_axis) / tan_y, axis_of(half, right_axis) / tan_x);
    double distance = axis_of(half, fwd_axis) + RENDER_AUTO_MARGIN * fit;
    if (!(distance > 0.0)) distance = 1.0; /* a single point: any distance frames it */

    rad_vec3 forward = unit_axis(fwd_axis, fwd_sign);
    out_camera->look_at = centre;
    out_camera->eye = rad_v3_sub(centre, rad_v3_scale(forward, distance));
    out_camera->up = unit_axis(up_axis, up_sign);
    out_camera->fov_y = RENDER_DEFAULT_FOV_Y;
    out_camera->width = out_camera->height = 0;
}

void render_camera_default(const rad_mesh *mesh, double aspect, render_camera *out_camera, int *out_is_cornell)
{
    bbox b = mesh_bbox(mesh);
    const double lo[3] = {0.0, 0.0, 0.0}, hi[3] = {556.0, 548.8, 559.2};
    int cornell = mesh->patch_count > 0;
    for (int a = 0; a < 3; a++) {
        if (!(fabs(axis_of(b.lo, a) - lo[a]) <= RENDER_CORNELL_BBOX_TOL &&
              fabs(axis_of(b.hi, a) - hi[a]) <= RENDER_CORNELL_BBOX_TOL))
            cornell = 0;
    }
    if (cornell)
        *out_camera = render_camera_cornell();
    else
        render_camera_auto(mesh, aspect, out_camera);
    if (out_is_cornell) *out_is_cornell = cornell;
}

void render_camera_format(const render_camera *c, char *out, size_t size)
{
    snprintf(out, size, "eye %.9g %.9g %.9g; look_at %.9g %.9g %.9g; up %.9g %.9g %.9g; fov_y %.9g", c->eye.x,
             c->eye.y, c->eye.z, c->look_at.x, c->look_at.y, c->look_at.z, c->up.x, c->up.y, c->up.z, c->fov_y);
}

rad_status render_view_init(const render_camera *camera, double aspect, render_view *out_view)
{
    rad_status status = render_camera_validate(camera, "camera");
    if (status != RAD_OK) return status;
    if (!(aspect > 0.0) || !isfinite(aspect)) {
        rad_error("camera: aspect ratio %g is not positive", aspect);
        return RAD_ERR_INVALID;
    }
    render_view v;
    v.eye = camera->eye;
    v.forward = rad_v3_normalize(rad_v3_sub(camera->look_at, camera->eye));
    v.right = rad_v3_normalize(rad_v3_cross(v.forward, camera->up));
    v.up = rad_v3_cross(v.right, v.forward);
    v.tan_half_y = tan(0.5 * camera->fov_y * RAD_PI / 180.0);
    v.tan_half_x = v.tan_half_y * aspect;
    *out_view = v;
    return RAD_OK;
}

int render_view_project(const render_view *view, int width, int height, rad_vec3 p, double *out_x, double *out_y)
{
    rad_vec3 d = rad_v3_sub(p, view->eye);
    double z = rad_v3_dot(d, view->forward);
    if (!(z > 0.0)) return 0;
    double ndc_x = rad_v3_dot(d, view->right) / (z * view->tan_half_x);
    double ndc_y = rad_v3_dot(d, view->up) / (z * view->tan_half_y);
    *out_x = 0.5 * (ndc_x + 1.0) * width;
    *out_y = 0.5 * (1.0 - ndc_y) * height;
    return 1;
}
