/* test_solve_fixtures.h - scenes with exact form factors for test_solve.
 *
 *  - solve_fx_box: the unit cube [0,1]^3 seen from inside, each face cut
 *    into cells x cells rectangles on a graded grid (finer towards the
 *    edges, so areas differ). Form factors are exact: Stokes' theorem turns
 *    the area integral into a contour integral of ln r over the two
 *    rectangles' edges, which has a closed form for parallel axis-aligned
 *    edges (solve_fx_rect_form_factor). Closed: every row sums to 1 (to
 *    rounding); reciprocal by construction. One face may be left out (an
 *    open box), and the central patches of one face may be a light.
 *  - solve_fx_sphere: flat patches of a UV sphere seen from inside, with the
 *    sphere's exact F_ij = A_j / A_total (including i = j).
 *  - solve_fx_two_squares: unit squares facing each other at distance 1.
 *  - solve_fx_join: two scenes as one (two rooms; F block diagonal), and
 *    solve_fx_couple to let two of their patches exchange a little light.
 *  - solve_fx_direct: the reference answer, a dense direct solve.
 */
#ifndef TEST_SOLVE_FIXTURES_H
#define TEST_SOLVE_FIXTURES_H

#include "rad_ffile.h"
#include "rad_mesh.h"

typedef struct solve_fx_scene {
    rad_mesh mesh;  /* owned */
    double *F;      /* N * N, owned */
    double *row_sum;
    double *area;
} solve_fx_scene;

/* Faces of the box: 0: x = 0, 1: x = 1, 2: y = 0, 3: y = 1, 4: z = 0, 5: z = 1. */
typedef struct solve_fx_box_spec {
    int cells;                 /* per face edge, >= 1 */
    double rho[6][3];
    double emission[6][3];
    int light_face;            /* -1: none; else the patches of that face whose
                                  centroid lies in [0.3, 0.7]^2 get light_* */
    double light_rho[3], light_emission[3];
    int open_face;             /* -1: closed; else that face is missing */
} solve_fx_box_spec;

/* A_i F_ij for two non-coplanar axis-aligned rectangles given as 4 corners
 * each, ordered counter-clockwise about their normals. */
double solve_fx_rect_form_factor_area(const rad_vec3 a[4], const rad_vec3 b[4]);

int solve_fx_box(const solve_fx_box_spec *spec, solve_fx_scene *out);

/* The test's working folder into dir: argv[1] (created if missing), else a
 * fresh /tmp/NAME.XXXXXX. Returns 0 (and says why) when it cannot. */
int solve_fx_work_dir(int argc, char **argv, const char *name, char *dir, size_t size);
/* DIR/NAME in one of 8 rotating static buffers (valid until 8 more calls). */
const char *solve_fx_path(const char *dir, const char *name);
/* Uniform rho and E on every patch. */
int solve_fx_sphere(int bands, int segments, double rho, double emission, solve_fx_scene *out);
int solve_fx_two_squares(double rho, double emission, solve_fx_scene *out);
void solve_fx_free(solve_fx_scene *scene);

/* Scene a followed by scene b (b's geometry moved by shift_x along x, so
 * the rooms do not overlap): patches of a, then of b; F block diagonal.
 * Returns 0 when out of memory. */
int solve_fx_join(const solve_fx_scene *a, const solve_fx_scene *b, double shift_x, solve_fx_scene *out);

/* Lets patches i and j exchange light: A_i F_ij = A_j F_ji = area_coupling
 * (reciprocal), added to whatever they had; row sums are updated. */
void solve_fx_couple(solve_fx_scene *scene, size_t i, size_t j, double area_coupling);

/* The reference solve: x with (I - diag(rho)·F)·x = rhs, by Gaussian
 * elimination with partial pivoting, every operation in long double (64-bit
 * mantissa on x86-64, ~11 bits more than double). Returns 0 if a pivot is
 * zero or memory runs out. Deliberately simple and separate from solve/. */
int solve_fx_direct(size_t n, const double *F, const double *rho, const double *rhs, double *out_x);

/* Uniform rho and E (all channels) on every patch of a scene. */
void solve_fx_set_uniform(solve_fx_scene *scene, double rho, double emission);

/* Writes the scene's form-factor file (element type F32 or F64). */
rad_status solve_fx_write(const char *path, const solve_fx_scene *scene, rad_element_type type);
/* The same in the sparse layout (docs/formats.md, version 3) when `sparse`. */
rad_status solve_fx_write_layout(const char *path, const solve_fx_scene *scene, rad_element_type type, int sparse);

#endif
