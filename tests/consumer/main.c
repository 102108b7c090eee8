/* main.c - a program outside the project that uses the installed core
 * library (tests/install_consumer.sh builds it through find_package and
 * through pkg-config). It meshes the built-in Cornell box and checks what
 * it knows about it: 20 faces, 91 patches at --subdiv 1 (4 per face, the
 * floor cut along the blocks by default: rad_mesh.h, "Contacts"), and the
 * light, 130 x 105 mm, the only emitter. */
#include <math.h>
#include <stdio.h>

#include <radiosity/rad_mesh.h>
#include <radiosity/rad_scene.h>
#include <radiosity/rad_status.h>

int main(void)
{
    rad_scene scene;
    rad_status st = rad_scene_load_default(&scene);
    if (st != RAD_OK) {
        fprintf(stderr, "consumer: the built-in scene: %s\n", rad_status_str(st));
        return 1;
    }
    rad_mesh mesh;
    rad_mesh_options opt = {.subdiv = 1};
    st = rad_mesh_build(&scene, &opt, &mesh);
    if (st != RAD_OK) {
        fprintf(stderr, "consumer: the mesh: %s\n", rad_status_str(st));
        rad_scene_free(&scene);
        return 1;
    }
    double light_area = 0.0;
    for (size_t i = 0; i < mesh.patch_count; i++)
        if (mesh.patches[i].emission[0] > 0.0)
            light_area += mesh.patches[i].area;
    printf("%s: %zu faces, %zu patches, light area %.6g\n", scene.path, scene.face_count, mesh.patch_count,
           light_area);
    int ok = scene.face_count == 20 && mesh.patch_count == 91 && fabs(light_area - 130.0 * 105.0) < 1e-6;
    rad_mesh_free(&mesh);
    rad_scene_free(&scene);
    if (!ok) {
        fprintf(stderr, "consumer: expected 20 faces, 91 patches, light area 13650\n");
        return 1;
    }
    return 0;
}
