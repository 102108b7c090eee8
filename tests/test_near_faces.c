/* test_near_faces.c - faces that nearly touch, at every scene size
 * (issue 29, item 2).
 *
 * Two facing squares of a tenth of the room's size, `gap` apart in the
 * middle of a closed cubic room of size S, for gaps 1e-2 ... 1e-9 of S and
 * S = 1e-3 ... 1e6, through the CPU backend and the default (quadrature)
 * estimator: every row sums to at most 1 + 3 sigma + 1e-9 (sigma: the root
 * sum of the row's reported standard errors), and the two squares' rows -
 * each sees only the other square and, through the slit between them,
 * the room - to 1 within 1e-3 + 3 sigma. Before shadow segments counted
 * hits by height (ff_segment), a segment ignored everything within 1e-4
 * of its length of either end: at gap 1e-4 of the room the squares' rows
 * summed to 1.9998. Where a GPU is visible, the CUDA backend is held to
 * the same bounds.
 */
#include <stdio.h>

#include "ff_cuda.h"
#include "ff_fixture.h"
#include "rad_test.h"

/* A quad with corners a, b, c, d (in order around it), wound so that its
 * normal points along `facing`, appended to the OBJ text. */
static void put_quad(char *obj, size_t cap, int *vertices, const double p[4][3], const double facing[3])
{
    double u[3], v[3];
    for (int a = 0; a < 3; a++) u[a] = p[1][a] - p[0][a], v[a] = p[2][a] - p[0][a];
    double n[3] = {u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]};
    int flip = n[0] * facing[0] + n[1] * facing[1] + n[2] * facing[2] < 0;
    size_t at = strlen(obj);
    for (int k = 0; k < 4; k++)
        at += (size_t)snprintf(obj + at, cap - at, "v %.17g %.17g %.17g\n", p[k][0], p[k][1], p[k][2]);
    int b = *vertices;
    if (flip)
        at += (size_t)snprintf(obj + at, cap - at, "f %d %d %d %d\n", b + 4, b + 3, b + 2, b + 1);
    else
        at += (size_t)snprintf(obj + at, cap - at, "f %d %d %d %d\n", b + 1, b + 2, b + 3, b + 4);
    *vertices += 4;
}

static void make_scene(char *obj, size_t cap, double size, double gap)
{
    int vertices = 0;
    double h = 0.5 * size, s = 0.05 * size;
    snprintf(obj, cap, "mtllib s.mtl\nusemtl grey\n");
    for (int axis = 0; axis < 3; axis++)
        for (int side = -1; side <= 1; side += 2) {
            double p[4][3], facing[3] = {0, 0, 0};
            int a1 = (axis + 1) % 3, a2 = (axis + 2) % 3;
            const double corner[4][2] = {{-h, -h}, {h, -h}, {h, h}, {-h, h}};
            for (int k = 0; k < 4; k++) {
                p[k][axis] = side * h;
                p[k][a1] = corner[k][0];
                p[k][a2] = corner[k][1];
            }
            facing[axis] = -side; /* inwards */
            put_quad(obj, cap, &vertices, p, facing);
        }
    double a[4][3] = {{-s, -s, 0}, {s, -s, 0}, {s, s, 0}, {-s, s, 0}};
    double b[4][3] = {{-s, -s, gap}, {s, -s, gap}, {s, s, gap}, {-s, s, gap}};
    put_quad(obj, cap, &vertices, a, (double[3]){0, 0, 1});
    put_quad(obj, cap, &vertices, b, (double[3]){0, 0, -1});
}

static void check(const ff_backend *backend, double size, double gap_rel)
{
    static char obj[4096];
    make_scene(obj, sizeof obj, size, gap_rel * size);
    fixture fx;
    int ok = fixture_load(&fx, obj, "s.obj", 0);
    RAD_CHECK(ok);
    if (!ok) return;
    uint32_t n = (uint32_t)fx.mesh.patch_count;
    double *errors = NULL;
    compute_extra extra = {.errors = &errors};
    double *f = compute_full(backend, &fx, 512, 32, 1, RAD_ESTIMATOR_QUADRATURE, &extra, NULL);
    RAD_CHECK(f && errors);
    if (!f || !errors) return;
    double worst_excess = -1, worst_square = 0, square_off = 0, square_sigma = 0;
    for (uint32_t i = 0; i < n; i++) {
        double row = 0, var = 0;
        for (uint32_t j = 0; j < n; j++) row += f[i * n + j], var += errors[i * n + j] * errors[i * n + j];
        double sigma = sqrt(var);
        worst_excess = fmax(worst_excess, row - 1.0 - 3.0 * sigma);
        RAD_CHECK(row <= 1.0 + 3.0 * sigma + 1e-9);
        uint32_t face = fx.mesh.patches[i].source_face;
        if (face >= 6) { /* the squares */
            worst_square = fmax(worst_square, fabs(row - 1.0) - 3.0 * sigma);
            if (fabs(row - 1.0) >= square_off) square_off = fabs(row - 1.0), square_sigma = sigma;
            RAD_CHECK(fabs(row - 1.0) <= 1e-3 + 3.0 * sigma);
        }
        if (row > 1.0 + 3.0 * sigma + 1e-9 || (face >= 6 && fabs(row - 1.0) > 1e-3 + 3.0 * sigma))
            fprintf(stderr, "%s: size %g gap %g: row %u (face %u) sums to %.9f, sigma %.2e\n", backend->name, size, gap_rel, i, face, row,
                    sigma);
    }
    printf("%s: size %-6g gap %-6g: %u patches, worst row - 1 - 3 sigma %+.2e; squares: |row - 1| %.2e, sigma %.2e\n",
           backend->name, size, gap_rel, n, worst_excess, square_off, square_sigma);
    free(f);
    free(errors);
    fixture_free(&fx);
}

int main(void)
{
    const double sizes[] = {1e-3, 1.0, 1e3, 1e6}, gaps[] = {1e-2, 1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9};
    for (int s = 0; s < 4; s++)
        for (int g = 0; g < 8; g++) {
            check(&ff_backend_cpu, sizes[s], gaps[g]);
            if (ff_cuda_device_count() > 0) check(&ff_backend_cuda, sizes[s], gaps[g]);
        }
    return rad_test_finish();
}
