/* rad_enclosure.c - the outward-facing shell around a scene (rad_enclosure.h). */
#include "rad_enclosure.h"

#include <math.h>
#include <stdlib.h>

#include "rad_math.h"

static rad_vec3 vertex(const rad_scene *s, uint32_t i)
{
    return rad_v3(s->positions[3 * (size_t)i], s->positions[3 * (size_t)i + 1], s->positions[3 * (size_t)i + 2]);
}

/* Twice the face's vector area (Newell). */
static rad_vec3 face_normal(const rad_scene *s, const rad_face *f)
{
    rad_vec3 n = rad_v3(0, 0, 0);
    for (uint32_t k = 0; k < f->vertex_count; k++) {
        rad_vec3 a = vertex(s, f->v[k]), b = vertex(s, f->v[(k + 1) % f->vertex_count]);
        n = rad_v3_add(n, rad_v3_cross(a, b));
    }
    return n;
}

static rad_vec3 face_centre(const rad_scene *s, const rad_face *f)
{
    rad_vec3 c = rad_v3(0, 0, 0);
    for (uint32_t k = 0; k < f->vertex_count; k++) c = rad_v3_add(c, vertex(s, f->v[k]));
    return rad_v3_scale(c, 1.0 / f->vertex_count);
}

/* The bounding box of group g's faces (g = UINT32_MAX: of every face). */
static size_t group_box(const rad_scene *s, uint32_t g, double lo[3], double hi[3], uint32_t *out_line)
{
    size_t faces = 0;
    for (int a = 0; a < 3; a++) lo[a] = INFINITY, hi[a] = -INFINITY;
    for (size_t f = 0; f < s->face_count; f++) {
        const rad_face *face = &s->faces[f];
        if (g != UINT32_MAX && face->group != g) continue;
        if (faces++ == 0) *out_line = face->line;
        for (uint32_t k = 0; k < face->vertex_count; k++)
            for (int a = 0; a < 3; a++) {
                double x = s->positions[3 * (size_t)face->v[k] + a];
                lo[a] = fmin(lo[a], x);
                hi[a] = fmax(hi[a], x);
            }
    }
    return faces;
}

int rad_enclosure_find_outward(const rad_scene *s, rad_enclosure *out)
{
    double slo[3], shi[3];
    uint32_t line = 0;
    group_box(s, UINT32_MAX, slo, shi, &line);
    double ext[3] = {shi[0] - slo[0], shi[1] - slo[1], shi[2] - slo[2]};
    double diag = sqrt(ext[0] * ext[0] + ext[1] * ext[1] + ext[2] * ext[2]), tol = 1e-6 * diag;
    for (int a = 0; a < 3; a++)
        if (!(ext[a] > 1e-3 * diag)) return 0; /* a flat scene has no inside */
    /* A group enclosing every other face has the scene's box: find the
     * groups whose corners reach all six sides, in one pass. */
    uint8_t *touches = calloc(s->group_count ? s->group_count : 1, 1);
    size_t *faces = calloc(s->group_count ? s->group_count : 1, sizeof *faces);
    int found = 0;
    if (!touches || !faces) goto done; /* no finding is no harm: a message less */
    for (size_t f = 0; f < s->face_count; f++) {
        const rad_face *face = &s->faces[f];
        faces[face->group]++;
        for (uint32_t k = 0; k < face->vertex_count; k++)
            for (int a = 0; a < 3; a++) {
                double x = s->positions[3 * (size_t)face->v[k] + a];
                if (x <= slo[a] + tol) touches[face->group] |= (uint8_t)(1u << (2 * a));
                if (x >= shi[a] - tol) touches[face->group] |= (uint8_t)(1u << (2 * a + 1));
            }
    }
    for (uint32_t g = 0; g < s->group_count && !found; g++) {
        if (touches[g] != 0x3f || faces[g] == s->face_count) continue; /* not the box, or nothing inside */
        rad_vec3 centre = rad_v3(0.5 * (slo[0] + shi[0]), 0.5 * (slo[1] + shi[1]), 0.5 * (slo[2] + shi[2]));
        double area = 0, outward = 0;
        uint32_t first = 0;
        for (size_t f = 0; f < s->face_count; f++) {
            const rad_face *face = &s->faces[f];
            if (face->group != g) continue;
            if (area == 0) first = face->line;
            rad_vec3 n = face_normal(s, face);
            double a = 0.5 * rad_v3_length(n);
            area += a;
            if (rad_v3_dot(n, rad_v3_sub(face_centre(s, face), centre)) > 0) outward += a;
        }
        double box_area = 2 * (ext[0] * ext[1] + ext[1] * ext[2] + ext[2] * ext[0]);
        if (area >= RAD_ENCLOSURE_MIN_COVER * box_area && outward >= RAD_ENCLOSURE_MIN_OUTWARD * area) {
            *out = (rad_enclosure){.group = g, .line = first, .face_count = faces[g],
                                   .outward_fraction = outward / area};
            found = 1;
        }
    }
done:
    free(touches);
    free(faces);
    return found;
}
