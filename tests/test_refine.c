/* test_refine.c - error-driven refinement (core/rad_refine.h) and the
 * conforming shading of refined meshes (render/shade.h): what is split,
 * what the split mesh keeps (areas, faces, materials, groups), the patch
 * budget, and that render's corners agree across T-vertices and
 * reproduce linear radiosity exactly. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "rad_adjacency.h"
#include "rad_mesh.h"
#include "rad_refine.h"
#include "rad_scene.h"
#include "rad_test.h"
#include "shade.h"

/* The Cornell box's faces as they are (contacts kept: whole faces, 4^S
 * patches each) or cut where the blocks stand on the floor. */
static rad_mesh cornell_mesh(int subdiv, rad_mesh_contacts contacts)
{
    rad_scene scene;
    rad_mesh mesh;
    memset(&mesh, 0, sizeof mesh);
    if (rad_scene_load_default(&scene) != RAD_OK) return mesh;
    rad_mesh_options mo = {.subdiv = subdiv, .contacts = contacts};
    if (rad_mesh_build(&scene, &mo, &mesh) != RAD_OK) memset(&mesh, 0, sizeof mesh);
    rad_scene_free(&scene);
    return mesh;
}

static rad_mesh cornell(int subdiv) { return cornell_mesh(subdiv, RAD_MESH_CONTACTS_KEEP); }

/* B = 1 where the centroid's x is below 278 mm, else 0.1: a step down the
 * middle of the floor, ceiling and back wall. */
static double *step_field(const rad_mesh *mesh)
{
    double *b = malloc(mesh->patch_count * 3 * sizeof *b);
    for (size_t p = 0; p < mesh->patch_count; p++)
        for (int c = 0; c < 3; c++) b[3 * p + c] = mesh->patches[p].centroid.x < 278 ? 1.0 : 0.1;
    return b;
}

static double face_area(const rad_mesh *mesh, uint32_t face)
{
    double a = 0;
    for (size_t p = 0; p < mesh->patch_count; p++)
        if (mesh->patches[p].source_face == face) a += mesh->patches[p].area;
    return a;
}

static void test_split_keeps_the_surfaces(void)
{
    rad_mesh mesh = cornell(1);
    RAD_CHECK(mesh.patch_count == 80);
    double *b = step_field(&mesh);
    uint8_t *split = malloc(mesh.patch_count);
    rad_refine_options opt = rad_refine_defaults();
    opt.tolerance = 0.5;
    rad_refine_stats st;
    RAD_CHECK(rad_refine_mark(&mesh, b, &opt, split, &st) == RAD_OK);
    /* Floor, ceiling (4 faces) and back wall are cut by the step: their
     * patches on both sides of x = 278 jump by 0.9 (Ybar is near 0.55). */
    RAD_CHECK(st.split > 0 && st.split < mesh.patch_count);
    RAD_CHECK(st.patches_after == mesh.patch_count + 3 * st.split);
    RAD_CHECK(st.max_indicator > 1.0);
    size_t walls = 0;
    for (size_t p = 0; p < mesh.patch_count; p++) {
        /* The green and red walls (faces 7, 8 and 9) lie wholly on one
         * side of the step: uniform, not split. */
        if (mesh.patches[p].source_face < 7 || mesh.patches[p].source_face > 9) continue;
        RAD_CHECK(!split[p]);
        walls++;
    }
    RAD_CHECK(walls == 12); /* green 4, red 2 triangles x 4 */
    rad_mesh out;
    uint32_t *parent = NULL;
    RAD_CHECK(rad_refine_split(&mesh, split, &out, &parent) == RAD_OK);
    RAD_CHECK(out.patch_count == st.patches_after);
    RAD_CHECK(out.group_count == mesh.group_count);
    for (uint32_t f = 0; f < 20; f++) RAD_CHECK_REL(face_area(&out, f), face_area(&mesh, f), 1e-12);
    for (size_t i = 0; i < out.patch_count; i++) {
        const rad_patch *c = &out.patches[i], *p = &mesh.patches[parent[i]];
        RAD_CHECK(c->source_face == p->source_face);
        RAD_CHECK(out.patch_group[i] == mesh.patch_group[parent[i]]);
        RAD_CHECK(memcmp(c->rho, p->rho, sizeof c->rho) == 0 && memcmp(c->emission, p->emission, sizeof c->emission) == 0);
        RAD_CHECK(rad_v3_dot(c->normal, p->normal) > 1 - 1e-12);
        if (!split[parent[i]]) RAD_CHECK(c->area == p->area);
        RAD_CHECK(rad_patch_centroid_inside(c, out.positions));
    }
    free(parent);
    rad_mesh_free(&out);

    /* A budget: the largest errors first, at most max_patches before balance. */
    opt.max_patches = mesh.patch_count + 3 * 5;
    RAD_CHECK(rad_refine_mark(&mesh, b, &opt, split, &st) == RAD_OK);
    RAD_CHECK(st.over_budget > 0);
    RAD_CHECK(st.split - st.balanced == 5);
    /* Nothing to split: a uniform field, or patches all below min_size. */
    for (size_t k = 0; k < 3 * mesh.patch_count; k++) b[k] = 0.5;
    opt.max_patches = 0;
    RAD_CHECK(rad_refine_mark(&mesh, b, &opt, split, &st) == RAD_OK);
    RAD_CHECK(st.split == 0 && st.max_indicator == 0);
    free(b);
    b = step_field(&mesh);
    opt.min_size = 0.9;
    RAD_CHECK(rad_refine_mark(&mesh, b, &opt, split, &st) == RAD_OK);
    RAD_CHECK(st.split == 0 && st.too_small > 0);
    /* Bad options are refused. */
    opt.tolerance = 0;
    rad_test_capture_log();
    RAD_CHECK(rad_refine_mark(&mesh, b, &opt, split, &st) == RAD_ERR_INVALID);
    rad_log_set_sink(NULL, NULL);
    free(b);
    free(split);
    rad_mesh_free(&mesh);
}

/* Splitting every patch once is the next subdivision level: the same
 * patches, vertices shared the same way. */
static void test_split_all_is_the_next_level(void)
{
    rad_mesh s1 = cornell(1), s2 = cornell(2);
    uint8_t *all = malloc(s1.patch_count);
    memset(all, 1, s1.patch_count);
    rad_mesh out;
    RAD_CHECK(rad_refine_split(&s1, all, &out, NULL) == RAD_OK);
    RAD_CHECK(out.patch_count == s2.patch_count);
    RAD_CHECK(out.vertex_count == s2.vertex_count);
    for (size_t p = 0; p < out.patch_count && p < s2.patch_count; p++) {
        RAD_CHECK(out.patches[p].source_face == s2.patches[p].source_face);
        RAD_CHECK_REL(out.patches[p].area, s2.patches[p].area, 1e-12);
    }
    free(all);
    rad_mesh_free(&out);
    rad_mesh_free(&s1);
    rad_mesh_free(&s2);
}

static const double *pos(const rad_mesh *mesh, uint32_t v) { return mesh->positions + 3 * (size_t)v; }

/* Every vertex that lies inside an edge of a patch on its surface (a
 * T-vertex) has, in every patch of that surface around it, the value the
 * coarse patch's corners interpolate to: no seam. Returns how many
 * T-vertices were checked. */
static size_t check_conforming(const rad_mesh *mesh, const double *corners, int nc)
{
    size_t checked = 0;
    double crease = cos(RAD_CREASE_DEGREES * RAD_PI / 180.0);
    for (size_t p = 0; p < mesh->patch_count; p++) {
        const rad_patch *coarse = &mesh->patches[p];
        for (uint32_t k = 0; k < coarse->vertex_count; k++) {
            uint32_t kb = (k + 1) % coarse->vertex_count, a = coarse->v[k], b = coarse->v[kb];
            const double *pa = pos(mesh, a), *pb = pos(mesh, b);
            double d[3] = {pb[0] - pa[0], pb[1] - pa[1], pb[2] - pa[2]}, len2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
            for (size_t q = 0; q < mesh->patch_count; q++) {
                const rad_patch *fine = &mesh->patches[q];
                if (!rad_same_surface(coarse, fine, crease)) continue;
                for (uint32_t j = 0; j < fine->vertex_count; j++) {
                    uint32_t v = fine->v[j];
                    if (v == a || v == b) continue;
                    const double *pv = pos(mesh, v);
                    double w[3] = {pv[0] - pa[0], pv[1] - pa[1], pv[2] - pa[2]};
                    double t = (w[0] * d[0] + w[1] * d[1] + w[2] * d[2]) / len2, off = 0;
                    for (int i = 0; i < 3; i++) off += (w[i] - t * d[i]) * (w[i] - t * d[i]);
                    if (t <= 1e-6 || t >= 1 - 1e-6 || off > 1e-12 * len2) continue;
                    if (getenv("DBG")) fprintf(stderr, "T v%u (%.3f %.3f %.3f) in edge %u-%u of patch %zu (face %u) t=%.4f, fine patch %zu face %u\n", v, pv[0], pv[1], pv[2], a, b, p, coarse->source_face, t, q, fine->source_face);
                    for (int c = 0; c < nc; c++) {
                        double want = (1 - t) * corners[(4 * p + k) * nc + c] + t * corners[(4 * p + kb) * nc + c];
                        RAD_CHECK_NEAR(corners[(4 * q + j) * nc + c], want, 1e-12 * fmax(1, fabs(want)));
                    }
                    checked++;
                }
            }
        }
    }
    return checked;
}

static void test_shading_is_conforming(void)
{
    rad_mesh mesh = cornell(1);
    /* Split two neighbouring floor patches once, and one of their children
     * again: T-vertices one and two levels deep. */
    uint8_t *split = calloc(mesh.patch_count, 1);
    split[0] = split[1] = 1;
    rad_mesh once, twice;
    RAD_CHECK(rad_refine_split(&mesh, split, &once, NULL) == RAD_OK);
    uint8_t *again = calloc(once.patch_count, 1);
    again[0] = 1;
    RAD_CHECK(rad_refine_split(&once, again, &twice, NULL) == RAD_OK);
    /* Radiosity that is not linear, so that averaging the fine patches
     * alone would leave a seam. */
    double *b = malloc(twice.patch_count * 3 * sizeof *b);
    for (size_t p = 0; p < twice.patch_count; p++) {
        rad_vec3 c = twice.patches[p].centroid;
        b[3 * p] = 1e-5 * c.x * c.x + 1e-3 * c.z, b[3 * p + 1] = 1e-5 * c.z * c.z, b[3 * p + 2] = 0.3;
    }
    double *corners = malloc(twice.patch_count * 4 * 3 * sizeof *corners);
    render_shading modes[] = {RENDER_SHADING_SMOOTH, RENDER_SHADING_LINEAR};
    for (int m = 0; m < 2; m++) {
        RAD_CHECK(render_shade_corners(&twice, b, 3, modes[m], corners) == RAD_OK);
        size_t checked = check_conforming(&twice, corners, 3);
        /* Each split floor patch leaves T-vertices on its unsplit
         * neighbours' edges, the deeper split more inside its siblings'. */
        RAD_CHECK(checked >= 6);
    }
    free(b);
    free(corners);
    free(split);
    free(again);
    rad_mesh_free(&mesh);
    rad_mesh_free(&once);
    rad_mesh_free(&twice);
}

/* The mesh cut where the blocks stand (cut cells meet whole ones with
 * T-vertices along the cut face's grid), refined around the blocks: still
 * no seams. */
static void test_cut_mesh_is_conforming(void)
{
    rad_mesh mesh = cornell_mesh(2, RAD_MESH_CONTACTS_CUT);
    uint8_t *split = calloc(mesh.patch_count, 1);
    size_t floor_patches = 0;
    for (size_t p = 0; p < mesh.patch_count; p++) {
        if (mesh.patches[p].source_face != 0) continue;
        floor_patches++;
        rad_vec3 c = mesh.patches[p].centroid;
        split[p] = c.x > 100 && c.x < 450 && c.z > 50 && c.z < 450; /* around both blocks */
    }
    RAD_CHECK(floor_patches > 16); /* the floor's 16 cells, some cut into pieces, less the hidden ones */
    rad_mesh refined;
    RAD_CHECK(rad_refine_split(&mesh, split, &refined, NULL) == RAD_OK);
    double *b = malloc(refined.patch_count * 3 * sizeof *b);
    for (size_t p = 0; p < refined.patch_count; p++) {
        rad_vec3 c = refined.patches[p].centroid;
        b[3 * p] = 1e-5 * c.x * c.x + 1e-3 * c.z, b[3 * p + 1] = 1e-5 * c.z * c.z + 0.1, b[3 * p + 2] = 0.3;
    }
    double *corners = malloc(refined.patch_count * 4 * 3 * sizeof *corners);
    render_shading modes[] = {RENDER_SHADING_SMOOTH, RENDER_SHADING_LINEAR};
    for (int m = 0; m < 2; m++) {
        RAD_CHECK(render_shade_corners(&refined, b, 3, modes[m], corners) == RAD_OK);
        RAD_CHECK(check_conforming(&refined, corners, 3) >= 20);
    }
    free(b);
    free(corners);
    free(split);
    rad_mesh_free(&mesh);
    rad_mesh_free(&refined);
}

/* Linear shading reproduces radiosity that is linear across a surface at
 * every corner, the surface's edges included, where the area-weighted
 * mean (smooth) is off by half a patch's gradient. */
static void test_linear_shading_is_exact_for_linear_fields(void)
{
    rad_mesh mesh = cornell(3);
    double *b = malloc(mesh.patch_count * 3 * sizeof *b);
    double *corners = malloc(mesh.patch_count * 4 * sizeof *corners);
    /* The floor (face 0, y = 0): B = 0.2 + 1e-3 x + 5e-4 z, the centroid's value = the patch mean. */
    for (size_t p = 0; p < mesh.patch_count; p++) {
        rad_vec3 c = mesh.patches[p].centroid;
        b[3 * p] = b[3 * p + 1] = b[3 * p + 2] = 0.2 + 1e-3 * c.x + 5e-4 * c.z;
    }
    double worst_linear = 0, worst_smooth = 0;
    for (int m = 0; m < 2; m++) {
        render_shading mode = m ? RENDER_SHADING_LINEAR : RENDER_SHADING_SMOOTH;
        RAD_CHECK(render_shade_corners(&mesh, b, 1, mode, corners) == RAD_OK);
        for (size_t p = 0; p < mesh.patch_count; p++) {
            if (mesh.patches[p].source_face != 0) continue;
            for (uint32_t k = 0; k < 4; k++) {
                const double *x = pos(&mesh, mesh.patches[p].v[k]);
                double err = fabs(corners[4 * p + k] - (0.2 + 1e-3 * x[0] + 5e-4 * x[2]));
                if (m) worst_linear = fmax(worst_linear, err);
                else worst_smooth = fmax(worst_smooth, err);
            }
        }
    }
    RAD_CHECK(worst_linear < 1e-9);
    RAD_CHECK(worst_smooth > 1e-3); /* the floor's edges: patches are 69 mm wide */
    free(b);
    free(corners);
    rad_mesh_free(&mesh);
}

int main(void)
{
    test_split_keeps_the_surfaces();
    test_split_all_is_the_next_level();
    test_shading_is_conforming();
    test_cut_mesh_is_conforming();
    test_linear_shading_is_exact_for_linear_fields();
    return rad_test_finish();
}
