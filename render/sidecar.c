/* sidecar.c - finding the scene's camera sidecar (rule in sidecar.h). */
#define _XOPEN_SOURCE 700 /* realpath */
#include "sidecar.h"

#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <sys/stat.h>

#include "rad_enclosure.h"
#include "rad_log.h"
#include "rad_scene.h"

/* Where a relative scene path was resolved from, for messages. */
typedef struct candidate {
    char obj[RENDER_SIDECAR_PATH_MAX];
    const char *from;   /* "as recorded (absolute)", "from the current folder", ... */
    struct stat st;     /* of the OBJ */
    int exists;         /* the OBJ is a regular file */
    int match;          /* 1: loads to the fingerprint; 0: to another; -1: does not load */
} candidate;

static int is_regular(const char *path, struct stat *st)
{
    return stat(path, st) == 0 && S_ISREG(st->st_mode);
}

/* `path` with its extension (the last '.' of its file name, unless that
 * starts the name) replaced by ".camera". 0 when it does not fit. */
static int sidecar_name(const char *path, char *out, size_t size)
{
    const char *slash = strrchr(path, '/');
    const char *name = slash ? slash + 1 : path;
    const char *dot = strrchr(name, '.');
    size_t stem = dot && dot != name ? (size_t)(dot - path) : strlen(path);
    int n = snprintf(out, size, "%.*s.camera", (int)stem, path);
    return n > 0 && (size_t)n < size;
}

/* 1 when the OBJ at `path` loads (default options, --flip-normals, then
 * --flip-group of its outward-facing enclosing object (rad_enclosure.h),
 * each with --ke radiosity and radiance) to the fingerprint `want`,
 * 0 when it loads to another, -1 when it does not load (a --clamp-rho
 * scene, a broken file). Quiet: the loader's messages are about a file
 * render only identifies. */
static int scene_load_matching(const char *path, uint64_t want, rad_scene *out_scene)
{
    rad_log_level level = rad_log_get_level();
    rad_log_set_level(RAD_LOG_NONE);
    int result = -1;
    char shell[RAD_NAME_MAX] = "";
    for (int k = 0; k < 6 && result != 1; k++) {
        rad_scene scene;
        rad_scene_options options = {0};
        options.flip_normals = k % 3 == 1;
        options.ke_radiance = k / 3;
        if (k % 3 == 2 && !shell[0]) continue; /* no such object */
        if (k % 3 == 2) options.flip_groups = shell;
        if (rad_scene_load_file(path, &options, &scene) == RAD_OK) {
            rad_enclosure e;
            if (k == 0 && rad_enclosure_find_outward(&scene, &e)) snprintf(shell, sizeof shell, "%s", scene.groups[e.group]);
            result = scene.fingerprint == want;
            if (result == 1 && out_scene)
                *out_scene = scene; /* the caller's to free */
            else
                rad_scene_free(&scene);
        }
    }
    rad_log_set_level(level);
    return result;
}

static int scene_matches(const char *path, uint64_t want) { return scene_load_matching(path, want, NULL); }

/* The built-in Cornell box's fingerprint (its radiosity files record no
 * scene path), or 0 if it cannot be loaded. */
static uint64_t builtin_fingerprint(void)
{
    rad_scene scene;
    uint64_t fp = 0;
    rad_log_level level = rad_log_get_level();
    rad_log_set_level(RAD_LOG_NONE);
    if (rad_scene_load_default(&scene) == RAD_OK) {
        fp = scene.fingerprint;
        rad_scene_free(&scene);
    }
    rad_log_set_level(level);
    return fp;
}

/* Warns when the sidecar resolves (symlinks, "..") into another folder
 * than the scene's OBJ's folder as named. */
static void warn_if_outside(const char *sidecar, const char *obj)
{
    char dir[RENDER_SIDECAR_PATH_MAX];
    const char *slash = strrchr(obj, '/');
    if (!slash)
        snprintf(dir, sizeof dir, ".");
    else
        snprintf(dir, sizeof dir, "%.*s", slash == obj ? 1 : (int)(slash - obj), obj);
    char *real_dir = realpath(dir, NULL), *real_sidecar = realpath(sidecar, NULL);
    if (real_dir && real_sidecar) {
        char *cut = strrchr(real_sidecar, '/');
        size_t len = cut == real_sidecar ? 1 : (size_t)(cut - real_sidecar);
        if (strlen(real_dir) != len || strncmp(real_dir, real_sidecar, len) != 0)
            rad_warn("%s: the camera sidecar lies outside the scene's folder %s (it is %s, through a symbolic "
                     "link); using it: give --camera auto to ignore it",
                     sidecar, real_dir, real_sidecar);
    }
    free(real_dir);
    free(real_sidecar);
}

/* The candidates for the scene's OBJ: the path itself; a relative one
 * also from the radiosity file's folder. Returns their count (1 or 2),
 * *found how many exist (a file reached twice counts once). */
static int scene_candidates(const char *scene, const char *rad, candidate cand[2], int *found)
{
    int count = 0;
    memset(cand, 0, 2 * sizeof *cand);
    const char *rad_slash = strrchr(rad, '/');
    snprintf(cand[count].obj, sizeof cand[count].obj, "%s", scene);
    cand[count++].from = scene[0] == '/' ? "as recorded" : "from the current folder";
    if (scene[0] != '/' && rad_slash) {
        int n = snprintf(cand[count].obj, sizeof cand[count].obj, "%.*s/%s", (int)(rad_slash - rad), rad, scene);
        if (n > 0 && (size_t)n < sizeof cand[count].obj) cand[count++].from = "from the radiosity file's folder";
    }
    *found = 0;
    for (int k = 0; k < count; k++) {
        cand[k].exists = is_regular(cand[k].obj, &cand[k].st);
        if (k > 0 && cand[k].exists && cand[0].exists && cand[k].st.st_dev == cand[0].st.st_dev &&
            cand[k].st.st_ino == cand[0].st.st_ino)
            cand[k].exists = 0; /* the same file, reached twice */
        *found += cand[k].exists;
    }
    return count;
}

int render_scene_smoothing(const render_sidecar_query *query, uint32_t **out_groups, size_t *out_count)
{
    *out_groups = NULL;
    *out_count = 0;
    const char *scene_path = query->scene_path ? query->scene_path : "";
    if (!scene_path[0]) return 0;
    candidate cand[2];
    int found = 0, count = scene_candidates(scene_path, query->radiosity_path, cand, &found);
    for (int k = 0; k < count; k++) {
        rad_scene scene;
        if (!cand[k].exists || scene_load_matching(cand[k].obj, query->scene_fingerprint, &scene) != 1) continue;
        size_t smooth = 0;
        for (size_t f = 0; f < scene.face_count; f++) smooth += scene.faces[f].smooth != 0;
        uint32_t *groups = smooth ? malloc(scene.face_count * sizeof *groups) : NULL;
        if (groups) {
            for (size_t f = 0; f < scene.face_count; f++) groups[f] = scene.faces[f].smooth;
            *out_groups = groups;
            *out_count = scene.face_count;
        } else if (smooth) {
            rad_warn("%s: out of memory for the smoothing groups of %zu faces; drawn without them", cand[k].obj,
                     scene.face_count);
        }
        rad_scene_free(&scene);
        return groups != NULL;
    }
    return 0;
}

int render_sidecar_find(const render_sidecar_query *query, char *out_path, size_t size)
{
    const char *scene = query->scene_path ? query->scene_path : "";
    const char *rad = query->radiosity_path;
    out_path[0] = '\0';
    if (!scene[0]) {
        if (query->scene_fingerprint == builtin_fingerprint())
            rad_info("camera: the built-in Cornell box has no camera sidecar");
        else
            rad_warn("%s: the radiosity file names no scene (a scene path of 88 bytes or more does not fit it: "
                     "solve leaves it out; or a file from before 2026-11-24), so no camera sidecar is looked for: "
                     "give --camera FILE",
                     rad);
        return 0;
    }

    candidate cand[2];
    int found = 0, count = scene_candidates(scene, rad, cand, &found);

    if (!found) {
        /* No OBJ, so nothing says whose a sidecar there would be. */
        for (int k = 0; k < count; k++) {
            char side[RENDER_SIDECAR_PATH_MAX];
            struct stat st;
            if (sidecar_name(cand[k].obj, side, sizeof side) && stat(side, &st) == 0) {
                rad_warn("%s: not used as the camera: its scene %s is not there, so nothing says it belongs to the "
                         "scene of %s; give --camera %s to use it",
                         side, cand[k].obj, rad, side);
                return 0;
            }
        }
        rad_info("camera: no camera sidecar: the scene %s is not found %s%s (formfactor ran in another folder?); "
                 "give --camera FILE to choose one",
                 scene, scene[0] == '/' ? "" : "from the current folder",
                 count > 1 ? " or from the radiosity file's folder" : "");
        return 0;
    }

    int chosen = -1;
    for (int k = 0; k < count && chosen < 0; k++) {
        if (!cand[k].exists) continue;
        cand[k].match = scene_matches(cand[k].obj, query->scene_fingerprint);
        if (cand[k].match == 1) chosen = k;
    }
    int mismatch = chosen < 0;
    if (mismatch)
        for (int k = count - 1; k >= 0; k--)
            if (cand[k].exists) chosen = k;
    const candidate *c = &cand[chosen];
    if (found > 1)
        rad_info("camera: the scene path %s names two files, %s (from the current folder) and %s (from the "
                 "radiosity file's folder); %s is %s",
                 scene, cand[0].obj, cand[1].obj, c->obj,
                 mismatch ? "taken first, though neither is the scene solved" : "the scene solved");

    char side[RENDER_SIDECAR_PATH_MAX];
    struct stat st;
    if (!sidecar_name(c->obj, side, sizeof side) || stat(side, &st) != 0) {
        rad_info("camera: the scene %s (%s) has no camera sidecar %s", c->obj, c->from, side);
        return 0;
    }
    if (mismatch)
        rad_warn("%s: the camera sidecar of %s, which is not the scene %s was solved for (%s; or it changed "
                 "since formfactor read it): the camera may not fit; give --camera FILE or --camera auto",
                 side, c->obj, rad,
                 c->match == 0 ? "it loads to another geometry or materials" : "it does not load as it was");
    else
        rad_info("camera: the scene %s, %s, is the one solved; its sidecar is %s", c->obj, c->from, side);
    warn_if_outside(side, c->obj);
    if (strlen(side) >= size) return 0;
    memcpy(out_path, side, strlen(side) + 1);
    return 1;
}
