/* rad_enclosure.h - a room modelled from a closed mesh whose faces point
 * outward: the group (`o`/`g`) that encloses every other face of a scene
 * with its faces turned away from them.
 *
 * Usage:
 *     rad_enclosure e;
 *     if (rad_enclosure_find_outward(&scene, &e)) ... scene.groups[e.group] ...
 *
 * Light inside such a shell meets its back faces: they neither receive nor
 * reflect, so the light escapes and the walls stay black (Blender's cube
 * used as a room, unflipped, with objects in it; issue 30). A group counts
 * as that shell when
 *  - other groups have faces, and the group's faces reach all six sides
 *    of the scene's bounding box (to 1e-6 of its diagonal; so every other
 *    face lies inside the group's box), which has volume;
 *  - its faces cover at least RAD_ENCLOSURE_MIN_COVER of that box's surface
 *    (a shell, not a floor);
 *  - at least RAD_ENCLOSURE_MIN_OUTWARD of its area faces away from the
 *    box's centre.
 * A room whose faces point inward, an object beside others and a lone
 * closed object (nothing inside it) are not. Pure: no messages. */
#ifndef RAD_ENCLOSURE_H
#define RAD_ENCLOSURE_H

#include <stddef.h>
#include <stdint.h>

#include "rad_scene.h"

#define RAD_ENCLOSURE_MIN_COVER 0.5
#define RAD_ENCLOSURE_MIN_OUTWARD 0.9

typedef struct rad_enclosure {
    uint32_t group;          /* index into rad_scene.groups */
    uint32_t line;           /* OBJ line of its first face */
    size_t face_count;       /* its faces */
    double outward_fraction; /* of its area, facing away from the box's centre */
} rad_enclosure;

/* 1 and *out set when the scene has such a group (the first found), else 0. */
int rad_enclosure_find_outward(const rad_scene *scene, rad_enclosure *out);

#endif
