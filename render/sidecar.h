/* sidecar.h - which camera sidecar a radiosity file's scene has.
 *
 * Usage:
 *     char camera[RENDER_SIDECAR_PATH_MAX];
 *     render_sidecar_query q = {rf.scene_path, "out/room.rad", rf.scene_fingerprint};
 *     if (render_sidecar_find(&q, camera, sizeof camera)) ... render_camera_load(camera, ...);
 *
 * The radiosity file records the OBJ path formfactor was given, as given:
 * a relative one is relative to the folder formfactor ran in, which render
 * cannot know. The rule:
 *  1. An absolute path is the scene.
 *  2. A relative path is tried from the current folder and from the
 *     radiosity file's folder (where solve wrote it: formfactor and solve
 *     usually run in one folder). Of the OBJ files found there, the scene
 *     is the one whose fingerprint is the radiosity file's (it loads to
 *     the geometry and materials that were solved, with or without
 *     --flip-normals); the first found (current folder first) when none
 *     has it, with a warning that its camera may belong to another scene
 *     (or the scene was edited since).
 *  3. The sidecar is that OBJ's name with ".camera" for its extension.
 *     A sidecar whose OBJ is not found is not used (nothing says whose it
 *     is): a warning names it and --camera FILE.
 *  4. A sidecar that resolves outside the scene's folder (a symlink) gets
 *     a warning, and is used.
 * Every outcome is logged: which file is used and how it was found (info),
 * or why there is none (info; a warning where the cause is the radiosity
 * file's scene path having been dropped: 88 bytes or more, see
 * core/rad_rfile.h).
 */
#ifndef RENDER_SIDECAR_H
#define RENDER_SIDECAR_H

#include <stddef.h>
#include <stdint.h>

#define RENDER_SIDECAR_PATH_MAX 4096 /* PATH_MAX on Linux */

typedef struct render_sidecar_query {
    const char *scene_path;      /* as the radiosity file records it; "" = none */
    const char *radiosity_path;  /* the radiosity file, as render was given it */
    uint64_t scene_fingerprint;  /* the radiosity file's */
} render_sidecar_query;

/* Returns 1 with the sidecar to load in out_path (size bytes), 0 when
 * there is none to use (out_path ""). Logs as described above. */
int render_sidecar_find(const render_sidecar_query *query, char *out_path, size_t size);

/* The smoothing groups (OBJ `s`) of the scene solved, by face: found as
 * above, but only an OBJ that loads to the radiosity file's fingerprint
 * counts. Returns 1 with *out_groups (*out_count entries, 0 = flat; free
 * it) when the scene is found and some face is in a group, else 0 with
 * *out_groups NULL. Quiet but for lack of memory. */
int render_scene_smoothing(const render_sidecar_query *query, uint32_t **out_groups, size_t *out_count);

#endif
