/* test_solve_fixtures.c - exact synthetic form-factor matrices (see the
 * header). */
#define _POSIX_C_SOURCE 200809L /* mkdtemp */
#include "test_solve_fixtures.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

static double coord(rad_vec3 p, int axis) { return axis == 0 ? p.x : axis == 1 ? p.y : p.z; }

/* Phi'' = (1/2) ln(d2 + u^2), the double antiderivative used by the
 * contour integral of ln r between two parallel lines at distance
 * sqrt(d2); finite at u = d = 0 (u^2 ln u^2 -> 0). */
static double phi(double u, double d2)
{
    double s = d2 + u * u;
    double lg = s > 0 ? log(s) : 0;
    double d = sqrt(d2);
    double at = d > 0 ? d * u * atan(u / d) : 0;
    return 0.25 * s * lg - 0.75 * u * u - 0.25 * d2 + at - 0.5 * d2 * lg;
}

/* Axis along which p and q differ (edges are axis-aligned). */
static int edge_axis(rad_vec3 p, rad_vec3 q)
{
    return p.x != q.x ? 0 : p.y != q.y ? 1 : 2;
}

double solve_fx_rect_form_factor_area(const rad_vec3 a[4], const rad_vec3 b[4])
{
    /* A_a F_ab = (1/2 pi) sum over edge pairs of the integral of ln r dr_a·dr_b;
     * only parallel edges contribute. */
    double sum = 0;
    for (int e = 0; e < 4; e++) {
        rad_vec3 p0 = a[e], p1 = a[(e + 1) % 4];
        int axis = edge_axis(p0, p1);
        for (int f = 0; f < 4; f++) {
            rad_vec3 q0 = b[f], q1 = b[(f + 1) % 4];
            if (edge_axis(q0, q1) != axis) continue;
            double d2 = 0;
            for (int k = 0; k < 3; k++)
                if (k != axis) d2 += (coord(p0, k) - coord(q0, k)) * (coord(p0, k) - coord(q0, k));
            double ta = coord(p0, axis), tb = coord(p1, axis), sa = coord(q0, axis), sb = coord(q1, axis);
            sum += phi(tb - sa, d2) - phi(tb - sb, d2) - phi(ta - sa, d2) + phi(ta - sb, d2);
        }
    }
    return sum / (2 * RAD_PI);
}

/* Allocates a scene of n patches with 4 vertex slots each. */
static int scene_alloc(solve_fx_scene *s, size_t n)
{
    memset(s, 0, sizeof *s);
    s->mesh.patch_count = n;
    s->mesh.vertex_count = 4 * n;
    s->mesh.patches = calloc(n, sizeof(rad_patch));
    s->mesh.positions = calloc(12 * n, sizeof(double));
    s->F = calloc(n * n, sizeof(double));
    s->row_sum = calloc(n, sizeof(double));
    s->area = calloc(n, sizeof(double));
    return s->mesh.patches && s->mesh.positions && s->F && s->row_sum && s->area;
}

/* Stores polygon `v` (3 or 4 corners) as patch i with its own vertices. */
static void set_patch(solve_fx_scene *s, size_t i, const rad_vec3 *v, int count, uint32_t face)
{
    rad_patch *p = &s->mesh.patches[i];
    p->vertex_count = (uint32_t)count;
    for (int k = 0; k < 4; k++) {
        p->v[k] = k < count ? (uint32_t)(4 * i + (size_t)k) : RAD_NO_VERTEX;
        if (k < count) {
            double *pos = s->mesh.positions + 3 * (4 * i + (size_t)k);
            pos[0] = v[k].x;
            pos[1] = v[k].y;
            pos[2] = v[k].z;
        }
    }
    p->source_face = face;
    rad_polygon_geometry(v, count, &p->area, &p->normal, &p->centroid);
    s->area[i] = p->area;
}

static void finish_row_sums(solve_fx_scene *s)
{
    size_t n = s->mesh.patch_count;
    for (size_t i = 0; i < n; i++) {
        double sum = 0;
        for (size_t j = 0; j < n; j++) sum += s->F[i * n + j];
        s->row_sum[i] = sum;
    }
}

/* Corner k (counter-clockwise about the inward normal) of cell (cu, cv)
 * of box face f on grid g. */
static rad_vec3 box_corner(int f, const double *g, int cu, int cv, int k)
{
    int axis = f / 2, side = f % 2;
    int u = (axis + 1) % 3, v = (axis + 2) % 3;
    static const int du[4] = {0, 1, 1, 0}, dv[4] = {0, 0, 1, 1};
    int kk = side == 0 ? k : (4 - k) % 4; /* reversed winding for normal -axis */
    double c[3];
    c[axis] = side;
    c[u] = g[cu + du[kk]];
    c[v] = g[cv + dv[kk]];
    return rad_v3(c[0], c[1], c[2]);
}

int solve_fx_box(const solve_fx_box_spec *spec, solve_fx_scene *out)
{
    const int cells = spec->cells;
    int faces = spec->open_face >= 0 ? 5 : 6;
    size_t n = (size_t)faces * (size_t)cells * (size_t)cells;
    double *g = malloc((size_t)(cells + 1) * sizeof(double));
    if (!g || !scene_alloc(out, n)) {
        free(g);
        solve_fx_free(out);
        return 0;
    }
    for (int k = 0; k <= cells; k++) g[k] = 0.5 - 0.5 * cos(RAD_PI * k / cells);
    g[0] = 0;
    g[cells] = 1;
    size_t i = 0;
    for (int f = 0; f < 6; f++) {
        if (f == spec->open_face) continue;
        for (int cu = 0; cu < cells; cu++)
            for (int cv = 0; cv < cells; cv++, i++) {
                rad_vec3 v[4];
                for (int k = 0; k < 4; k++) v[k] = box_corner(f, g, cu, cv, k);
                set_patch(out, i, v, 4, (uint32_t)f);
                rad_patch *p = &out->mesh.patches[i];
                double cu_mid = 0.5 * (g[cu] + g[cu + 1]), cv_mid = 0.5 * (g[cv] + g[cv + 1]);
                int light = f == spec->light_face && cu_mid > 0.3 && cu_mid < 0.7 && cv_mid > 0.3 && cv_mid < 0.7;
                for (int c = 0; c < 3; c++) {
                    p->rho[c] = light ? spec->light_rho[c] : spec->rho[f][c];
                    p->emission[c] = light ? spec->light_emission[c] : spec->emission[f][c];
                }
            }
    }
    for (size_t a = 0; a < n; a++)
        for (size_t b = a + 1; b < n; b++) {
            if (out->mesh.patches[a].source_face == out->mesh.patches[b].source_face) continue; /* coplanar */
            rad_vec3 va[4], vb[4];
            for (int k = 0; k < 4; k++) {
                const double *pa = out->mesh.positions + 3 * out->mesh.patches[a].v[k];
                const double *pb = out->mesh.positions + 3 * out->mesh.patches[b].v[k];
                va[k] = rad_v3(pa[0], pa[1], pa[2]);
                vb[k] = rad_v3(pb[0], pb[1], pb[2]);
            }
            double af = solve_fx_rect_form_factor_area(va, vb);
            out->F[a * n + b] = af / out->area[a];
            out->F[b * n + a] = af / out->area[b];
        }
    finish_row_sums(out);
    free(g);
    return 1;
}

int solve_fx_sphere(int bands, int segments, double rho, double emission, solve_fx_scene *out)
{
    size_t n = (size_t)bands * (size_t)segments;
    if (!scene_alloc(out, n)) {
        solve_fx_free(out);
        return 0;
    }
    size_t i = 0;
    double total = 0;
    for (int b = 0; b < bands; b++)
        for (int s = 0; s < segments; s++, i++) {
            double t0 = RAD_PI * b / bands, t1 = RAD_PI * (b + 1) / bands;
            double p0 = 2 * RAD_PI * s / segments, p1 = 2 * RAD_PI * (s + 1) / segments;
            rad_vec3 q[4] = {
                rad_v3(sin(t0) * cos(p0), sin(t0) * sin(p0), cos(t0)),
                rad_v3(sin(t1) * cos(p0), sin(t1) * sin(p0), cos(t1)),
                rad_v3(sin(t1) * cos(p1), sin(t1) * sin(p1), cos(t1)),
                rad_v3(sin(t0) * cos(p1), sin(t0) * sin(p1), cos(t0)),
            };
            rad_vec3 v[4];
            int count = 0;
            /* drop the repeated pole corner of the first and last band */
            for (int k = 0; k < 4; k++)
                if (!((b == 0 && k == 3) || (b == bands - 1 && k == 2))) v[count++] = q[k];
            set_patch(out, i, v, count, 0);
            rad_patch *p = &out->mesh.patches[i];
            if (rad_v3_dot(p->normal, p->centroid) > 0) { /* make it face the centre */
                rad_vec3 r[4];
                for (int k = 0; k < count; k++) r[k] = v[count - 1 - k];
                set_patch(out, i, r, count, 0);
            }
            total += p->area;
        }
    for (size_t a = 0; a < n; a++)
        for (size_t b = 0; b < n; b++) out->F[a * n + b] = out->area[b] / total;
    solve_fx_set_uniform(out, rho, emission);
    finish_row_sums(out);
    return 1;
}

int solve_fx_two_squares(double rho, double emission, solve_fx_scene *out)
{
    if (!scene_alloc(out, 2)) {
        solve_fx_free(out);
        return 0;
    }
    rad_vec3 lower[4] = {rad_v3(0, 0, 0), rad_v3(1, 0, 0), rad_v3(1, 1, 0), rad_v3(0, 1, 0)};
    rad_vec3 upper[4] = {rad_v3(0, 0, 1), rad_v3(0, 1, 1), rad_v3(1, 1, 1), rad_v3(1, 0, 1)};
    set_patch(out, 0, lower, 4, 0);
    set_patch(out, 1, upper, 4, 1);
    double f = solve_fx_rect_form_factor_area(lower, upper); /* unit areas */
    out->F[1] = out->F[2] = f;
    solve_fx_set_uniform(out, rho, 0);
    for (int c = 0; c < 3; c++) out->mesh.patches[0].emission[c] = emission;
    finish_row_sums(out);
    return 1;
}

int solve_fx_join(const solve_fx_scene *a, const solve_fx_scene *b, double shift_x, solve_fx_scene *out)
{
    const size_t na = a->mesh.patch_count, nb = b->mesh.patch_count, n = na + nb;
    const size_t va = a->mesh.vertex_count, vb = b->mesh.vertex_count;
    if (!scene_alloc(out, n)) {
        solve_fx_free(out);
        return 0;
    }
    double *positions = realloc(out->mesh.positions, 3 * (va + vb) * sizeof(double));
    if (!positions) {
        solve_fx_free(out);
        return 0;
    }
    out->mesh.positions = positions;
    out->mesh.vertex_count = va + vb;
    memcpy(positions, a->mesh.positions, 3 * va * sizeof(double));
    memcpy(positions + 3 * va, b->mesh.positions, 3 * vb * sizeof(double));
    for (size_t v = va; v < va + vb; v++) positions[3 * v] += shift_x;
    memcpy(out->mesh.patches, a->mesh.patches, na * sizeof(rad_patch));
    memcpy(out->mesh.patches + na, b->mesh.patches, nb * sizeof(rad_patch));
    for (size_t i = na; i < n; i++) {
        rad_patch *p = &out->mesh.patches[i];
        for (int k = 0; k < 4; k++)
            if (p->v[k] != RAD_NO_VERTEX) p->v[k] += (uint32_t)va;
        p->centroid.x += shift_x;
    }
    for (size_t i = 0; i < na; i++) memcpy(out->F + i * n, a->F + i * na, na * sizeof(double));
    for (size_t i = 0; i < nb; i++) memcpy(out->F + (na + i) * n + na, b->F + i * nb, nb * sizeof(double));
    memcpy(out->area, a->area, na * sizeof(double));
    memcpy(out->area + na, b->area, nb * sizeof(double));
    finish_row_sums(out);
    return 1;
}

void solve_fx_couple(solve_fx_scene *scene, size_t i, size_t j, double area_coupling)
{
    size_t n = scene->mesh.patch_count;
    scene->F[i * n + j] += area_coupling / scene->area[i];
    scene->F[j * n + i] += area_coupling / scene->area[j];
    finish_row_sums(scene);
}

/* Row index of the largest |a[r][col]|, r >= col. */
static size_t pivot_row(const long double *a, size_t n, size_t col)
{
    size_t best = col;
    for (size_t r = col + 1; r < n; r++)
        if (fabsl(a[r * n + col]) > fabsl(a[best * n + col])) best = r;
    return best;
}

static void swap_rows(long double *a, long double *b, size_t n, size_t r, size_t s)
{
    for (size_t k = 0; k < n; k++) {
        long double t = a[r * n + k];
        a[r * n + k] = a[s * n + k];
        a[s * n + k] = t;
    }
    long double t = b[r];
    b[r] = b[s];
    b[s] = t;
}

int solve_fx_direct(size_t n, const double *F, const double *rho, const double *rhs, double *out_x)
{
    long double *a = malloc(n * n * sizeof(long double)), *b = malloc(n * sizeof(long double));
    int ok = a && b;
    for (size_t i = 0; ok && i < n; i++) {
        for (size_t j = 0; j < n; j++) a[i * n + j] = -(long double)rho[i] * F[i * n + j];
        a[i * n + i] += 1;
        b[i] = rhs[i];
    }
    for (size_t col = 0; ok && col < n; col++) { /* forward elimination */
        swap_rows(a, b, n, col, pivot_row(a, n, col));
        long double pivot = a[col * n + col];
        if (pivot == 0) {
            ok = 0;
            break;
        }
        for (size_t r = col + 1; r < n; r++) {
            long double factor = a[r * n + col] / pivot;
            if (factor == 0) continue;
            for (size_t k = col; k < n; k++) a[r * n + k] -= factor * a[col * n + k];
            b[r] -= factor * b[col];
        }
    }
    for (size_t i = n; ok && i-- > 0;) { /* back substitution */
        long double sum = b[i];
        for (size_t k = i + 1; k < n; k++) sum -= a[i * n + k] * b[k];
        b[i] = sum / a[i * n + i];
    }
    for (size_t i = 0; ok && i < n; i++) out_x[i] = (double)b[i];
    free(a);
    free(b);
    return ok;
}

void solve_fx_set_uniform(solve_fx_scene *scene, double rho, double emission)
{
    for (size_t i = 0; i < scene->mesh.patch_count; i++)
        for (int c = 0; c < 3; c++) {
            scene->mesh.patches[i].rho[c] = rho;
            scene->mesh.patches[i].emission[c] = emission;
        }
}

void solve_fx_free(solve_fx_scene *scene)
{
    free(scene->mesh.patches);
    free(scene->mesh.positions);
    free(scene->F);
    free(scene->row_sum);
    free(scene->area);
    memset(scene, 0, sizeof *scene);
}

rad_status solve_fx_write(const char *path, const solve_fx_scene *scene, rad_element_type type)
{
    return solve_fx_write_layout(path, scene, type, 0);
}

rad_status solve_fx_write_layout(const char *path, const solve_fx_scene *scene, rad_element_type type, int sparse)
{
    rad_ff_info info;
    memset(&info, 0, sizeof info);
    info.patch_count = scene->mesh.patch_count;
    info.vertex_count = scene->mesh.vertex_count;
    info.element_type = (uint32_t)type;
    info.estimator = RAD_ESTIMATOR_MC;
    info.scene_fingerprint = 0x5eed;
    info.layout = sparse ? RAD_FF_LAYOUT_SPARSE : RAD_FF_LAYOUT_DENSE;
    strcpy(info.scene_name, "test_solve fixture");
    return rad_ff_write_serial(path, &info, &scene->mesh, scene->F);
}

const char *solve_fx_path(const char *dir, const char *name)
{
    static char buf[8][1200];
    static int next;
    char *p = buf[next++ % 8];
    snprintf(p, sizeof buf[0], "%s/%s", dir, name);
    return p;
}

int solve_fx_work_dir(int argc, char **argv, const char *name, char *dir, size_t size)
{
    if (argc > 1) {
        snprintf(dir, size, "%s", argv[1]);
        if (mkdir(dir, 0777) != 0 && errno != EEXIST) {
            perror(dir);
            return 0;
        }
    } else {
        snprintf(dir, size, "/tmp/%s.XXXXXX", name);
        if (!mkdtemp(dir)) {
            perror("mkdtemp");
            return 0;
        }
    }
    return 1;
}
