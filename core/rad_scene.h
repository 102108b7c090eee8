/* rad_scene.h - scenes loaded from Wavefront OBJ/MTL.
 *
 * Usage:
 *     rad_scene scene;
 *     rad_scene_options opt = {0};            // zero = defaults
 *     if (rad_scene_load_file("cornell_box.obj", &opt, &scene) != RAD_OK) ...;
 *     ... scene.faces[f] ...
 *     rad_scene_free(&scene);
 *
 * The loader is strict: every problem is logged as "file:line: what is
 * wrong" and returns RAD_ERR_PARSE (syntax), RAD_ERR_INVALID (values) or
 * RAD_ERR_IO (missing file). Supported: `v`; `f` with n >= 3 vertices in all
 * index forms (v, v/vt, v//vn, v/vt/vn; negative = relative); `g`, `o`, `s`,
 * `usemtl`, `mtllib` (several files, several names per line); in MTL:
 * `newmtl`, `Kd` (reflectance rho, RGB in [0,1)), `Ke` (emission E, RGB >= 0:
 * the emitted radiosity, or with rad_scene_options.ke_radiance the emitted
 * radiance L_e, stored as E = pi L_e).
 * The names of `g`, `o`, `usemtl` and `newmtl` are the rest of the line,
 * blanks inside kept (`o Wall left`; `g a b` is one group "a b", not two),
 * at most RAD_NAME_MAX - 1 bytes (longer: RAD_ERR_INVALID, never cut).
 * `vt` and other known-but-unused keys are accepted and ignored; `vn`
 * normals only check the winding: a patch faces the way its winding says
 * (counter-clockwise seen from the front), and faces wound against their
 * corners' vn get one warning per scene saying what to do;
 * unknown keys produce one warning each. CRLF, a UTF-8 BOM and a missing
 * final newline are tolerated; a UTF-16 or UTF-32 file (by its byte-order
 * mark, or NULs in every other byte) is refused as such (RAD_ERR_PARSE,
 * "file: is UTF-16 text (byte-order mark FF FE); save it as UTF-8 or ASCII").
 * Details (rad_scene.c): `v` may carry a w or an r g b after x y z (checked,
 * ignored); vt/vn indices are range-checked too; `Kd r` (one value) means
 * grey; a `newmtl` without Kd warns and gets grey 0.5; a material defined
 * twice, a NUL byte in a file and a scene without faces are errors
 * (RAD_ERR_INVALID / RAD_ERR_PARSE); each mtllib file is read once.
 *
 * After parsing, every face is planar and convex with 3 or 4 vertices:
 *  - zero-area faces are dropped with a warning naming file:line;
 *  - triangles and planar convex quads are kept as they are;
 *  - anything else (n > 4, non-planar, non-convex) is triangulated with a
 *    note (warning) naming file:line; each triangle becomes its own face.
 * Planarity tolerance: every vertex within 1e-6 * (face diameter) of the
 * best-fit plane through the face's Newell normal and centroid, or within
 * 4x the rounding of the file's coordinates (half a unit of their last
 * decimal; Blender writes 6), at most 1e-4 * diameter. Non-planar
 * polygons split into triangles are counted and said once per scene. The
 * diameter is the bounding-box diagonal; "zero" area (and a zero turn, for
 * convexity) means below 1e-12 * diameter^2. A corner repeated right after
 * itself is removed (warning). Triangulation is ear clipping on the plane
 * of the dominant normal axis; a planar polygon that crosses itself (its
 * triangles' areas do not add up to its own, or they overlap) is an
 * error, a warped one where clipping gets stuck is fanned.
 * Polygons with holes are read as exporters write them, one ring: the
 * outer ring, a bridge edge to a hole's ring wound the other way round,
 * back along the same edge (LightWave, the assimp corpus). The triangles
 * cover the polygon minus its holes; a hole's ring wound the same way as
 * the outer one, or reaching outside it, "crosses itself" (with a hint),
 * and a warped polygon with a hole is never fanned (that would fill it).
 */
#ifndef RAD_SCENE_H
#define RAD_SCENE_H

#include <stddef.h>
#include <stdint.h>

#include "rad_status.h"

#define RAD_NAME_MAX 64

typedef struct rad_material {
    char name[RAD_NAME_MAX];
    double rho[3];      /* diffuse reflectance (Kd), each in [0, 1) */
    double emission[3]; /* emitted radiosity E, W/m^2 in scene units, >= 0: Ke,
                           or pi Ke with rad_scene_options.ke_radiance */
} rad_material;

typedef struct rad_face {
    uint32_t vertex_count; /* 3 or 4 */
    uint32_t v[4];         /* indices into rad_scene.positions; v[3] unused for triangles */
    uint32_t material;     /* index into rad_scene.materials */
    uint32_t group;        /* index into rad_scene.groups (last `g` or `o` name) */
    uint32_t line;         /* line of the OBJ `f` statement it came from (1-based) */
    uint32_t smooth;       /* smoothing group (the last `s`: 0 = off): render interpolates
                              across edges of faces in one group; not in the fingerprint */
} rad_face;

typedef struct rad_scene {
    char path[512];           /* the OBJ file name, for messages ("cornell_box.obj" for the built-in one) */
    double *positions;        /* xyz per vertex */
    size_t vertex_count;
    rad_face *faces;
    size_t face_count;
    rad_material *materials;  /* What every stage says of a scene where nothing emits, after its own
 * words: the usual cause, lamps, and the remedy (issue 30). */
#define RAD_SCENE_NO_LIGHT_HINT                                                                                   \
    "Blender's lights (Light objects: point, sun, spot and area lamps, the default scene's 'Light') are not "    \
    "written to OBJ files, so only emissive surfaces light a radiosity scene: give a mesh (a plane for a "     \
    "panel) a material with Emission Strength > 0, which the exporter writes as Ke (read it with formfactor "  \
    "--ke radiance); exports before Blender 2.9 write no Ke at all"

/* materials[0] is "default" (see below) */
    size_t material_count;
    char (*groups)[RAD_NAME_MAX]; /* groups[0] is "default" */
    size_t group_count;
    uint64_t fingerprint;     /* hash of positions, faces and materials (rad_hash64) */
    size_t vn_face_count;     /* faces with vn on every corner; of those, wound against them */
    size_t vn_against_count;  /* (after flip_normals / flip_groups) */
} rad_scene;

/* Reads a whole file into memory. Returns RAD_ERR_IO if it cannot, with
 * *out_data = NULL. The loader calls it for the OBJ and every mtllib; a
 * custom one serves embedded scenes. *out_data is freed with free(). */
typedef rad_status (*rad_read_file_fn)(const char *path, char **out_data, size_t *out_size, void *user);

typedef struct rad_scene_options {
    rad_read_file_fn read_file; /* NULL = read from the file system */
    void *read_file_user;
    double clamp_rho;  /* > 0: a Kd value above it (1 included) is set to it, with a
                          warning per statement, instead of refused (formfactor
                          --clamp-rho); 0: values outside [0, 1) are errors */
    int flip_normals;  /* every face wound the other way round (formfactor
                          --flip-normals): for scenes whose faces all point away */
    const char *flip_groups; /* NULL, or comma-separated names of `o`/`g` groups whose
                          faces are wound the other way round (formfactor
                          --flip-group): a room modelled from an outward cube
                          among objects that are right; a name the scene lacks
                          is RAD_ERR_INVALID. With flip_normals both apply
                          (those groups end as written). Their faces are not
                          checked against their vn (flipping them by name
                          contradicts their exported normals by design). */
    int ke_radiance;   /* 1: `Ke` is the emitted radiance L_e (W/m^2/sr; what
                          Blender's emission strength is), so each material's
                          emission is E = RAD_PI * Ke, the radiosity a diffuse
                          emitter of radiance L_e leaves (formfactor --ke
                          radiance); 0: `Ke` is E itself. The fingerprint is
                          of the E stored. */
} rad_scene_options;

/* What every stage says of a scene where nothing emits, after its own
 * words: the usual cause, lamps, and the remedy (issue 30). */
#define RAD_SCENE_NO_LIGHT_HINT                                                                                   \
    "Blender's lights (Light objects: point, sun, spot and area lamps, the default scene's 'Light') are not "    \
    "written to OBJ files, so only emissive surfaces light a radiosity scene: give a mesh (a plane for a "     \
    "panel) a material with Emission Strength > 0, which the exporter writes as Ke (read it with formfactor "  \
    "--ke radiance); exports before Blender 2.9 write no Ke at all"

/* materials[0] is "default": rho 0.5 grey, no emission. Faces before any
 * `usemtl` use it (one warning per file); `usemtl` naming a material that no
 * loaded MTL defines is an error. */
rad_status rad_scene_load_file(const char *path, const rad_scene_options *options, rad_scene *out_scene);

/* The built-in Cornell box (scenes/cornell_box.obj embedded at build time). */
rad_status rad_scene_load_default(rad_scene *out_scene);
/* Name of the built-in scene, for messages and stats. */
extern const char *const rad_default_scene_name;

void rad_scene_free(rad_scene *scene); /* safe on a zeroed or freed scene */

#endif
