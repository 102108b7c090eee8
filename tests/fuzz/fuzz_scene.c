/* fuzz_scene.c - the OBJ/MTL loader (rad_scene_load_file), then the mesh.
 *
 * Input: the OBJ text, then for each MTL file a NUL byte and its text
 * ("OBJ\0MTL1\0MTL2..."). The loader reads files through a callback: the
 * OBJ is "fuzz.obj", and the k-th distinct file an `mtllib` asks for gets
 * the k-th MTL chunk (none left: "cannot open"). NUL separates because the
 * loader refuses NUL bytes inside a file anyway.
 *
 * Whatever the loader accepts must be a valid scene (indices in range,
 * finite positions, rho in [0,1), E >= 0), and its level-0 and level-1
 * meshes must pass the checks the file readers apply to patch records -
 * otherwise formfactor would write a file its own readers refuse.
 */
#include "fuzz_common.h" /* first: it defines _GNU_SOURCE */

#include <math.h>

#include "rad_ffile.h"
#include "rad_mesh.h"
#include "rad_rfile.h"
#include "rad_scene.h"

typedef struct chunks {
    const uint8_t *data;
    size_t size;
    size_t next_mtl; /* offset of the next MTL chunk, size + 1 when none */
} chunks;

static rad_status read_chunk(const char *path, char **out_data, size_t *out_size, void *user)
{
    chunks *c = user;
    const uint8_t *begin;
    size_t len;
    *out_data = NULL;
    *out_size = 0;
    if (strcmp(path, "fuzz.obj") == 0) {
        const uint8_t *nul = memchr(c->data, 0, c->size);
        begin = c->data;
        len = nul ? (size_t)(nul - c->data) : c->size;
    } else {
        if (c->next_mtl > c->size) return RAD_ERR_IO;
        begin = c->data + c->next_mtl;
        const uint8_t *nul = memchr(begin, 0, c->size - c->next_mtl);
        len = nul ? (size_t)(nul - begin) : c->size - c->next_mtl;
        c->next_mtl += len + 1;
    }
    /* An exact-size copy: the loader must not read past out_size. */
    char *copy = malloc(len ? len : 1);
    if (!copy) return RAD_ERR_NOMEM;
    if (len) memcpy(copy, begin, len);
    *out_data = copy;
    *out_size = len;
    return RAD_OK;
}

static void check_patches(const rad_mesh *mesh)
{
    for (size_t i = 0; i < mesh->patch_count; i++) {
        const rad_patch *p = &mesh->patches[i];
        FUZZ_REQUIRE(p->vertex_count == 3 || p->vertex_count == 4);
        for (uint32_t k = 0; k < p->vertex_count; k++) FUZZ_REQUIRE(p->v[k] < mesh->vertex_count);
        FUZZ_REQUIRE(p->area > 0 && isfinite(p->area));
        FUZZ_REQUIRE(fabs(rad_v3_length(p->normal) - 1) < 1e-6);
        FUZZ_REQUIRE(isfinite(p->centroid.x) && isfinite(p->centroid.y) && isfinite(p->centroid.z));
    }
    for (size_t i = 0; i < 3 * mesh->vertex_count; i++) FUZZ_REQUIRE(isfinite(mesh->positions[i]));
}

/* What formfactor and solve would write from this mesh, their readers must
 * accept (small meshes only: the matrix is N^2). */
#define FUZZ_ROUND_TRIP_PATCHES 64
static void check_round_trip(const rad_mesh *mesh)
{
    size_t n = mesh->patch_count;
    if (n > FUZZ_ROUND_TRIP_PATCHES) return;
    double *zeros = calloc(n * n > 3 * n ? n * n : 3 * n, sizeof *zeros);
    if (!zeros) return;
    rad_ff_info info = {.patch_count = n, .vertex_count = mesh->vertex_count, .element_type = RAD_ELEMENT_F32,
                        .estimator = RAD_ESTIMATOR_MC, .samples = 1, .group_count = (uint32_t)mesh->group_count};
    const char *ff_path = fuzz_scratch_path("scene.ff");
    FUZZ_REQUIRE(rad_ff_write_serial(ff_path, &info, mesh, zeros) == RAD_OK);
    rad_ff_file *ff = NULL;
    FUZZ_REQUIRE(rad_ff_open(ff_path, &ff) == RAD_OK);
    rad_ff_close(ff);
    rad_radiosity solved = {.mesh = *mesh, .radiosity = zeros, .channel_count = 3, .method = RAD_SOLVE_JACOBI,
                            .tolerance = 1e-10};
    const char *rad_path = fuzz_scratch_path("scene.rad");
    FUZZ_REQUIRE(rad_rf_write(rad_path, &solved) == RAD_OK);
    rad_radiosity back;
    FUZZ_REQUIRE(rad_rf_read(rad_path, &back) == RAD_OK);
    rad_radiosity_free(&back);
    free(zeros);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    static int ready;
    if (!ready) {
        fuzz_quiet_logger();
        ready = 1;
    }
    const uint8_t *nul = memchr(data, 0, size);
    chunks c = {data, size, nul ? (size_t)(nul - data) + 1 : size + 1};
    rad_scene_options options = {.read_file = read_chunk, .read_file_user = &c};
    rad_scene scene;
    if (rad_scene_load_file("fuzz.obj", &options, &scene) != RAD_OK) return 0;

    FUZZ_REQUIRE(scene.face_count > 0 && scene.material_count > 0 && scene.group_count > 0);
    for (size_t i = 0; i < 3 * scene.vertex_count; i++) FUZZ_REQUIRE(isfinite(scene.positions[i]));
    for (size_t f = 0; f < scene.face_count; f++) {
        const rad_face *face = &scene.faces[f];
        FUZZ_REQUIRE(face->vertex_count == 3 || face->vertex_count == 4);
        for (uint32_t k = 0; k < face->vertex_count; k++) FUZZ_REQUIRE(face->v[k] < scene.vertex_count);
        FUZZ_REQUIRE(face->material < scene.material_count && face->group < scene.group_count);
    }
    for (size_t m = 0; m < scene.material_count; m++)
        for (int k = 0; k < 3; k++) {
            FUZZ_REQUIRE(scene.materials[m].rho[k] >= 0 && scene.materials[m].rho[k] < 1);
            FUZZ_REQUIRE(scene.materials[m].emission[k] >= 0 && isfinite(scene.materials[m].emission[k]));
        }
    for (int subdiv = 0; subdiv <= 1; subdiv++) {
        rad_mesh mesh;
        rad_mesh_options mo = {.subdiv = subdiv};
        if (rad_mesh_build(&scene, &mo, &mesh) == RAD_OK) {
            FUZZ_REQUIRE(mesh.patch_count == rad_mesh_count_patches(&scene, &mo));
            check_patches(&mesh);
            check_round_trip(&mesh);
            rad_mesh_free(&mesh);
        }
    }
    rad_scene_free(&scene);
    return 0;
}
