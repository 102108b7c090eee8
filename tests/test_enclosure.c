/* test_enclosure.c - core/rad_enclosure: the outward-facing shell around a
 * scene is found (a room from Blender's cube, unflipped, with a light
 * inside); an inward room, a lone cube, a floor under a box and an open
 * box beside another are not. */
#include "rad_enclosure.h"
#include "rad_test.h"

#include <stdio.h>
#include <string.h>

/* A scene with a 4 x 3 x 4 box (outward or inward) as object 'Room' and,
 * unless `alone`, a 1 x 1 panel facing down inside it. */
static int load_room(int inward, int alone, rad_scene *out)
{
    char obj[2048];
    const char *faces_out = "f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 2 3 7 6\nf 3 4 8 7\nf 4 1 5 8\n";
    const char *faces_in = "f 2 3 4 1\nf 8 7 6 5\nf 5 6 2 1\nf 6 7 3 2\nf 7 8 4 3\nf 8 5 1 4\n";
    snprintf(obj, sizeof obj,
             "o Room\nv 0 0 0\nv 4 0 0\nv 4 3 0\nv 0 3 0\nv 0 0 4\nv 4 0 4\nv 4 3 4\nv 0 3 4\n%s%s",
             inward ? faces_in : faces_out,
             alone ? "" : "o Light\nv 1.5 2.5 1.5\nv 2.5 2.5 1.5\nv 2.5 2.5 2.5\nv 1.5 2.5 2.5\nf 9 10 11 12\n");
    FILE *file = fopen("enclosure.obj", "w");
    if (!file) return 0;
    fputs(obj, file);
    fclose(file);
    return rad_scene_load_file("enclosure.obj", NULL, out) == RAD_OK;
}

int main(void)
{
    rad_scene scene;
    rad_enclosure e;
    RAD_CHECK(load_room(0, 0, &scene));
    RAD_CHECK(rad_enclosure_find_outward(&scene, &e) == 1);
    RAD_CHECK(strcmp(scene.groups[e.group], "Room") == 0 && e.face_count == 6 && e.line == 10);
    RAD_CHECK_NEAR(e.outward_fraction, 1.0, 1e-12);
    rad_scene_free(&scene);

    RAD_CHECK(load_room(1, 0, &scene)); /* faces inward: right */
    RAD_CHECK(rad_enclosure_find_outward(&scene, &e) == 0);
    rad_scene_free(&scene);
    RAD_CHECK(load_room(0, 1, &scene)); /* a lone cube: an object, nothing inside */
    RAD_CHECK(rad_enclosure_find_outward(&scene, &e) == 0);
    rad_scene_free(&scene);

    /* --flip-group Room turns it the right way */
    RAD_CHECK(load_room(0, 0, &scene));
    rad_scene_free(&scene);
    rad_scene_options flip = {.flip_groups = "Room"};
    RAD_CHECK(rad_scene_load_file("enclosure.obj", &flip, &scene) == RAD_OK);
    RAD_CHECK(rad_enclosure_find_outward(&scene, &e) == 0);
    rad_scene_free(&scene);

    /* A floor under a box: the floor reaches the scene's sides but is flat. */
    FILE *f = fopen("floor.obj", "w");
    RAD_CHECK(f != NULL);
    if (f) {
        fputs("o Floor\nv -5 0 -5\nv 5 0 -5\nv 5 0 5\nv -5 0 5\nf 1 4 3 2\n"
              "o Box\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n"
              "f 5 8 7 6\nf 9 10 11 12\nf 5 6 10 9\nf 6 7 11 10\nf 7 8 12 11\nf 8 5 9 12\n", f);
        fclose(f);
        RAD_CHECK(rad_scene_load_file("floor.obj", NULL, &scene) == RAD_OK);
        RAD_CHECK(rad_enclosure_find_outward(&scene, &e) == 0);
        rad_scene_free(&scene);
    }
    return rad_test_finish();
}
