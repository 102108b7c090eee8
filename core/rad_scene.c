/* rad_scene.c - the strict OBJ/MTL loader (contract in rad_scene.h).
 *
 * One pass per file: each line is split into tokens and handled as it comes
 * (an `f` needs only the vertices read so far; `usemtl` only the MTLs that
 * `mtllib` loaded before it). Faces are checked and, where needed,
 * triangulated as they are added, so every message can name file:line.
 */
#include "rad_scene.h"

#include <errno.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "rad_box.h"
#include "rad_hash.h"
#include "rad_log.h"
#include "rad_math.h"

/* A face is planar when every vertex lies within PLANAR_TOL * diameter of
 * its plane, and has zero area (or a zero-length turn, for convexity) below
 * AREA_TOL * diameter^2. The diameter is the bounding-box diagonal. */
#define PLANAR_TOL 1e-6
#define AREA_TOL 1e-12
/* ...or, where the file's coordinates are written with few decimals
 * (Blender's exporter: 6), within what their rounding can move a vertex
 * off a plane: PLANAR_QUANTUM_FACTOR x the rounding step (half a unit of
 * the last decimal: each coordinate moves by at most that, a vertex by
 * sqrt(3) of it, and the fitted plane with them), at most PLANAR_TOL_MAX
 * of the face's diameter. A quad that far off its plane makes the same
 * form factors as a flat one to far below the Monte Carlo noise. */
#define PLANAR_QUANTUM_FACTOR 4.0
#define PLANAR_TOL_MAX 1e-4
/* A planar polygon whose triangles' areas differ from its own area by more
 * than this relative amount crosses itself. */
#define SELF_INTERSECT_TOL 1e-9
#define WARNED_KEYS_MAX 64
/* Limits a hostile or broken file meets (docs/reliability.md, "Threat
 * model: scene files"): warnings shown per scene (the rest are counted and
 * summarised), the longest line, the largest coordinate and emission. */
#define SCENE_WARNINGS_SHOWN 20
#define SCENE_LINE_MAX ((size_t)1 << 20)
/* |x| <= 1e12: the ray tracers (Embree, the GPU BVH) work in float, where
 * Moller-Trumbore forms products of three lengths - (2e12)^3 = 8e36 stays
 * below FLT_MAX = 3.4e38 with room; 1e39 is not even a float. */
#define SCENE_COORD_MAX 1e12
/* Ke <= 1e30: B = E / (1 - rho) and the energy sums (area x B, areas up to
 * 1e24 at the largest coordinates) stay far inside double range. */
#define SCENE_EMISSION_MAX 1e30
#define PATH_MAX_LEN 1024

/* Generated from scenes/cornell_box.{obj,mtl} by scenes/embed.cmake. */
struct rad_embedded_file {
    const char *name;
    const unsigned char *data;
    size_t size;
};
extern const struct rad_embedded_file rad_embedded_files[];

const char *const rad_default_scene_name = "cornell_box.obj (built-in)";

typedef struct source {
    const char *path;
    unsigned line;
} source;

typedef struct loader {
    rad_scene *scene;
    rad_read_file_fn read_file;
    void *read_file_user;
    size_t position_cap, face_cap, material_cap, group_cap;
    size_t texcoord_count, normal_count; /* `vt`, `vn` seen: to check indices */
    double *normals;                     /* the `vn` vectors, xyz each */
    size_t normal_cap;
    uint32_t *poly_normal;               /* scratch for one face: its corners' vn (UINT32_MAX: none) */
    size_t poly_normal_cap;
    uint32_t smooth;                     /* the last `s`: the faces' smoothing group (0 = off) */
    double clamp_rho;                    /* rad_scene_options */
    int flip_normals;
    const char *flip_groups;             /* rad_scene_options: names, comma-separated, or NULL */
    int ke_radiance;
    size_t vn_faces, vn_against;         /* faces whose corners all have vn; of those, wound against them */
    double coord_quantum;                /* largest rounding step of a `v` coordinate so far (0: none) */
    size_t nonplanar, nonplanar_faces;   /* non-planar polygons triangulated; the faces they became */
    unsigned nonplanar_first;            /* OBJ line of the first */
    double nonplanar_worst;              /* largest distance off its plane / diameter */
    char nonplanar_path[512];            /* the file of the first */
    char vn_first[600];                  /* file:line of the first one against */
    uint32_t material, group;            /* current `usemtl`, `g`/`o` */
    int have_usemtl, warned_default;
    size_t mtl_current;                  /* material being defined (0 = none) */
    int mtl_has_kd;
    unsigned mtl_line;
    uint64_t *mtl_loaded; /* hashes of the MTL paths read, to read each once */
    size_t mtl_loaded_count, mtl_loaded_cap;
    char warned[WARNED_KEYS_MAX][32]; /* unknown keys warned about */
    int warned_count;
    size_t warnings, warnings_hidden; /* shown so far; past SCENE_WARNINGS_SHOWN, counted only */
    struct flat_triangle *flat; /* scratch for one face: its triangles (faces_overlap) */
    size_t flat_cap;
    struct poly_edge *edges; /* scratch for one face: its edges (count_bridges) */
    size_t edge_cap;
    uint32_t *poly; /* scratch for one face: vertex indices */
    size_t poly_cap;
    double *uv; /* scratch: projected 2D points */
    size_t uv_cap;
} loader;

static rad_status fail(const source *src, rad_status status, const char *format, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 3, 4)))
#endif
    ;
static rad_status fail(const source *src, rad_status status, const char *format, ...)
{
    char message[1024];
    va_list args;
    va_start(args, format);
    vsnprintf(message, sizeof message, format, args);
    va_end(args);
    rad_error("%s:%u: %s", src->path, src->line, message);
    return status;
}

static rad_status out_of_memory(const source *src) { return fail(src, RAD_ERR_NOMEM, "out of memory"); }

/* Returns `array` grown (possibly moved) to hold `need` elements, or NULL,
 * leaving `array` valid, when memory runs out. */
static void *reserve(void *array, size_t *cap, size_t need, size_t elem)
{
    if (need <= *cap) return array;
    size_t n = *cap ? *cap : 16;
    while (n < need) {
        if (n > SIZE_MAX / 2) return NULL;
        n *= 2;
    }
    if (n > SIZE_MAX / elem) return NULL;
    void *p = realloc(array, n * elem);
    if (p) *cap = n;
    return p;
}

/* ---- reading files ---- */

static rad_status read_file_system(const char *path, char **out_data, size_t *out_size, void *user)
{
    (void)user;
    rad_status status = RAD_ERR_IO;
    char *data = NULL;
    size_t size = 0, cap = 0;
    *out_data = NULL;
    *out_size = 0;
    FILE *f = fopen(path, "rb");
    if (!f) goto done;
    for (;;) {
        char *p = reserve(data, &cap, size + 65536, 1);
        if (!p) {
            status = RAD_ERR_NOMEM;
            goto done;
        }
        data = p;
        size_t got = fread(data + size, 1, cap - size, f);
        size += got;
        if (got == 0) break;
    }
    if (ferror(f)) goto done;
    *out_data = data;
    *out_size = size;
    data = NULL;
    status = RAD_OK;
done:
    if (f) fclose(f);
    free(data);
    return status;
}

static rad_status read_embedded(const char *path, char **out_data, size_t *out_size, void *user)
{
    (void)user;
    *out_data = NULL;
    *out_size = 0;
    for (const struct rad_embedded_file *f = rad_embedded_files; f->name; f++) {
        if (strcmp(f->name, path) != 0) continue;
        char *data = malloc(f->size + 1);
        if (!data) return RAD_ERR_NOMEM;
        memcpy(data, f->data, f->size);
        *out_data = data;
        *out_size = f->size;
        return RAD_OK;
    }
    return RAD_ERR_IO;
}

/* Warnings go through here: the first SCENE_WARNINGS_SHOWN of a scene are
 * shown, the rest counted (rad_scene_load_file summarises them), so a
 * file of a million odd lines cannot flood a log. */
static void scene_warn(loader *L, const char *format, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 2, 3)))
#endif
    ;
static void scene_warn(loader *L, const char *format, ...)
{
    if (L->warnings >= SCENE_WARNINGS_SHOWN) {
        L->warnings_hidden++;
        return;
    }
    L->warnings++;
    va_list args;
    va_start(args, format);
    rad_logv(RAD_LOG_WARN, format, args);
    va_end(args);
}

/* ---- tokens and numbers ---- */

static int is_space(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\v' || c == '\f'; }

/* Keys whose argument is a name that runs to the end of the line (blanks
 * inside kept: `o Wall left` is the object "Wall left", not "Wall"). The
 * OBJ standard reads `g a b` as the face belonging to two groups; a face
 * here has one group, so the whole line is one name, as Blender's exporter
 * means it when it writes an object's name with blanks in it. */
static int takes_whole_line(const char *key)
{
    return !strcmp(key, "g") || !strcmp(key, "o") || !strcmp(key, "usemtl") || !strcmp(key, "newmtl");
}

/* Splits `line` in place into whitespace-separated tokens; a token starting
 * with '#' ends the line (comment). After a takes_whole_line key the rest
 * of the line (up to such a comment) is one token, trimmed of blanks at
 * both ends. */
static rad_status tokenize(char *line, char ***tokens, size_t *cap, size_t *out_count)
{
    size_t n = 0;
    char *p = line;
    for (;;) {
        while (is_space(*p)) p++;
        if (!*p || *p == '#') break;
        char **t = reserve(*tokens, cap, n + 1, sizeof **tokens);
        if (!t) return RAD_ERR_NOMEM;
        *tokens = t;
        t[n++] = p;
        if (n == 2 && takes_whole_line(t[0])) {
            char *end = p;
            while (*p && !(*p == '#' && is_space(p[-1]))) {
                if (!is_space(*p)) end = p + 1;
                p++;
            }
            *end = 0;
            break;
        }
        while (*p && !is_space(*p)) p++;
        if (*p) *p++ = 0;
    }
    *out_count = n;
    return RAD_OK;
}

static rad_status parse_number(const source *src, const char *text, double *out)
{
    char *end;
    errno = 0;
    double x = strtod(text, &end);
    if (end == text || *end) return fail(src, RAD_ERR_PARSE, "bad number '%s'", text);
    *out = x;
    return RAD_OK;
}

/* The rounding step of a coordinate written with d decimals and no
 * exponent ("0.123457": 5e-7), kept in L->coord_quantum (the largest).
 * Integers and exponent forms are taken as exact. */
static void note_precision(loader *L, const char *text)
{
    const char *dot = strchr(text, '.');
    if (!dot || strpbrk(text, "eE")) return;
    int decimals = 0;
    while (dot[1 + decimals] >= '0' && dot[1 + decimals] <= '9') decimals++;
    double quantum = 0.5 * pow(10.0, -decimals);
    if (quantum > L->coord_quantum) L->coord_quantum = quantum;
}

/* Parses `count` numbers from tok[1..]; n = tokens on the line. */
static rad_status parse_numbers(const source *src, char **tok, size_t n, size_t count, double *out)
{
    if (n - 1 != count)
        return fail(src, RAD_ERR_PARSE, "'%s' needs %zu numbers, got %zu", tok[0], count, n - 1);
    for (size_t i = 0; i < count; i++) {
        rad_status status = parse_number(src, tok[1 + i], &out[i]);
        if (status) return status;
    }
    return RAD_OK;
}

/* Copies a `g`/`o`/`usemtl`/`newmtl` name (the whole rest of the line,
 * tokenize), which must fit RAD_NAME_MAX: the form-factor file's group
 * table stores 64-byte names, so a longer one is an error, not cut short
 * (two names alike in their first 63 bytes would merge). */
static rad_status parse_name(const source *src, char **tok, size_t n, char *out)
{
    if (n < 2) return fail(src, RAD_ERR_PARSE, "'%s' needs a name", tok[0]);
    if (strlen(tok[1]) >= RAD_NAME_MAX)
        return fail(src, RAD_ERR_INVALID, "name '%.20s...' too long (at most %d bytes)", tok[1], RAD_NAME_MAX - 1);
    strcpy(out, tok[1]);
    return RAD_OK;
}

/* `s off`, `s 0`: the faces that follow are flat; `s N`: they belong to
 * smoothing group N (Blender writes `s 1` for Shade Smooth). */
static rad_status parse_smoothing(loader *L, const source *src, char **tok, size_t n)
{
    if (n != 2) return fail(src, RAD_ERR_PARSE, "'s' needs one smoothing group: a number, or off");
    if (strcmp(tok[1], "off") == 0) {
        L->smooth = 0;
        return RAD_OK;
    }
    char *end = NULL;
    unsigned long group = strtoul(tok[1], &end, 10);
    if (end == tok[1] || *end != '\0' || tok[1][0] == '-' || group > UINT32_MAX)
        return fail(src, RAD_ERR_PARSE, "'s %.20s': a smoothing group is a number from 0 to %u, or off", tok[1],
                    UINT32_MAX);
    L->smooth = (uint32_t)group;
    return RAD_OK;
}

/* A key is named in a message only if it looks like an OBJ/MTL keyword (a
 * letter or '_', then up to 15 letters, digits or '_'): a file that is not
 * a scene (mtllib ../../etc/shadow) gets its lines counted, not echoed. */
static int keyword_like(const char *key)
{
    size_t n = 0;
    for (; key[n]; n++) {
        char c = key[n];
        int alpha = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || c == '_';
        if (!(alpha || (n > 0 && c >= '0' && c <= '9')) || n >= 16) return 0;
    }
    return n > 0;
}

static void warn_unknown(loader *L, const source *src, const char *key)
{
    if (!keyword_like(key)) {
        scene_warn(L, "%s:%u: not an OBJ/MTL statement (its text is not shown); ignored", src->path, src->line);
        return;
    }
    for (int i = 0; i < L->warned_count; i++)
        if (strcmp(L->warned[i], key) == 0) return;
    if (L->warned_count < WARNED_KEYS_MAX && strlen(key) < sizeof L->warned[0])
        strcpy(L->warned[L->warned_count++], key);
    scene_warn(L, "%s:%u: unknown key '%s' ignored (warned once per key)", src->path, src->line, key);
}

/* ---- polygon geometry (n-gons, in the OBJ's vertex positions) ---- */

static rad_vec3 position(const rad_scene *s, uint32_t i)
{
    const double *p = s->positions + 3 * (size_t)i;
    return rad_v3(p[0], p[1], p[2]);
}

static rad_vec3 newell(const rad_scene *s, const uint32_t *v, size_t n)
{
    rad_vec3 sum = rad_v3(0, 0, 0);
    for (size_t i = 0; i < n; i++)
        sum = rad_v3_add(sum, rad_v3_cross(position(s, v[i]), position(s, v[(i + 1) % n])));
    return sum;
}

static double diameter(const rad_scene *s, const uint32_t *v, size_t n)
{
    rad_box box = rad_box_of_corners(s->positions, v, n);
    return rad_box_diagonal(&box);
}

static double triangle_area(const rad_scene *s, uint32_t a, uint32_t b, uint32_t c)
{
    rad_vec3 pa = position(s, a);
    return 0.5 * rad_v3_length(rad_v3_cross(rad_v3_sub(position(s, b), pa), rad_v3_sub(position(s, c), pa)));
}

/* ---- adding faces ---- */

static rad_status push_face(loader *L, const source *src, const uint32_t *v, uint32_t count)
{
    rad_scene *s = L->scene;
    if (s->face_count >= UINT32_MAX - 1) return fail(src, RAD_ERR_INVALID, "too many faces");
    rad_face *f = reserve(s->faces, &L->face_cap, s->face_count + 1, sizeof *f);
    if (!f) return out_of_memory(src);
    s->faces = f;
    f += s->face_count++;
    memset(f, 0, sizeof *f);
    f->vertex_count = count;
    memcpy(f->v, v, count * sizeof *v);
    f->material = L->material;
    f->group = L->group;
    f->smooth = L->smooth;
    f->line = src->line;
    return RAD_OK;
}

/* Vertex v projected on the plane perpendicular to the dominant axis of
 * `normal`, turned so that the polygon runs counter-clockwise there. */
static void project(const rad_scene *s, rad_vec3 normal, uint32_t v, double out[2])
{
    double nv[3] = {normal.x, normal.y, normal.z};
    int axis = fabs(nv[0]) > fabs(nv[1]) ? (fabs(nv[0]) > fabs(nv[2]) ? 0 : 2) : (fabs(nv[1]) > fabs(nv[2]) ? 1 : 2);
    const double *p = s->positions + 3 * (size_t)v;
    out[0] = p[(axis + 1) % 3];
    out[1] = p[(axis + 2) % 3] * (nv[axis] < 0 ? -1 : 1);
}

/* Signed doubled area of the projected triangle (a, b, c), positive when it
 * turns the same way as the polygon. */
static double turn(const double *uv, uint32_t a, uint32_t b, uint32_t c)
{
    return (uv[2 * b] - uv[2 * a]) * (uv[2 * c + 1] - uv[2 * a + 1]) -
           (uv[2 * b + 1] - uv[2 * a + 1]) * (uv[2 * c] - uv[2 * a]);
}

/* Do corners a and b of the projection lie on one point? A polygon with a
 * hole passes its bridge's ends twice; a copy of an ear's corner is on the
 * ear's boundary, not inside it, and must not block it. */
static int same_point(const double *uv, uint32_t a, uint32_t b)
{
    return uv[2 * a] == uv[2 * b] && uv[2 * a + 1] == uv[2 * b + 1];
}

/* Ear clipping of poly[0..n) (positions in L->uv, indexed by position in
 * poly) on the plane perpendicular to the dominant axis of `normal`. Emits
 * each ear whose area exceeds `min_area`; drops collinear vertices. Returns
 * RAD_ERR_INVALID (unlogged) when no ear can be found. */
static rad_status ear_clip(loader *L, const source *src, size_t n, rad_vec3 normal, double min_area)
{
    rad_scene *s = L->scene;
    double *uv = reserve(L->uv, &L->uv_cap, 2 * n, sizeof *uv);
    if (!uv) return out_of_memory(src);
    L->uv = uv;
    uint32_t *idx = L->poly + n; /* idx[k] = position in poly of remaining vertex k */
    for (size_t i = 0; i < n; i++) {
        project(s, normal, L->poly[i], uv + 2 * i);
        idx[i] = (uint32_t)i;
    }
    size_t left = n;
    while (left >= 3) {
        size_t pick = left;
        int is_ear = 0;
        for (size_t k = 0; k < left && pick == left; k++) {
            uint32_t a = idx[(k + left - 1) % left], b = idx[k], c = idx[(k + 1) % left];
            double t = turn(uv, a, b, c);
            if (left == 3 || fabs(t) <= 2 * min_area) {
                pick = k; /* last triangle, or a collinear vertex: just remove */
                is_ear = left == 3 && t > 2 * min_area;
                break;
            }
            if (t < 0) continue; /* reflex */
            int empty = 1;
            for (size_t m = 0; m < left && empty; m++) {
                uint32_t p = idx[m];
                if (same_point(uv, p, a) || same_point(uv, p, b) || same_point(uv, p, c)) continue;
                empty = !(turn(uv, a, b, p) >= 0 && turn(uv, b, c, p) >= 0 && turn(uv, c, a, p) >= 0);
            }
            if (empty) {
                pick = k;
                is_ear = 1;
            }
        }
        if (pick == left) return RAD_ERR_INVALID;
        if (is_ear) {
            uint32_t tri[3] = {L->poly[idx[(pick + left - 1) % left]], L->poly[idx[pick]], L->poly[idx[(pick + 1) % left]]};
            rad_status status = push_face(L, src, tri, 3);
            if (status) return status;
        }
        memmove(idx + pick, idx + pick + 1, (left - pick - 1) * sizeof *idx);
        left--;
    }
    return RAD_OK;
}

/* A triangle ear_clip emitted, projected as it was clipped (project). */
typedef struct flat_triangle {
    double p[3][2];
    double x_lo, x_hi;
} flat_triangle;

static int flat_triangle_compare(const void *pa, const void *pb)
{
    const flat_triangle *a = pa, *b = pb;
    return a->x_lo < b->x_lo ? -1 : a->x_lo > b->x_lo;
}

/* Does an edge of counter-clockwise triangle a have all of b on its outer
 * side (within `tol`, a doubled area)? Then their interiors are apart. */
static int separated_by_edge_of(const flat_triangle *a, const flat_triangle *b, double tol)
{
    for (int e = 0; e < 3; e++) {
        const double *p = a->p[e], *q = a->p[(e + 1) % 3];
        int outside = 1;
        for (int k = 0; k < 3 && outside; k++)
            outside = (q[0] - p[0]) * (b->p[k][1] - p[1]) - (q[1] - p[1]) * (b->p[k][0] - p[0]) <= tol;
        if (outside) return 1;
    }
    return 0;
}

/* Do two of the faces [first, face_count) overlap in the projection by
 * more than `tol` (touching along edges and corners is fine)? Ear clipping
 * covers each point as often as the polygon winds around it, so this is
 * how a polygon that winds twice round some region (an inner ring wound
 * the same way as the outer one, a spiral) shows; its triangles' areas
 * add up to the polygon's all the same. Sweep over x, then separating
 * edges. */
static rad_status faces_overlap(loader *L, const source *src, size_t first, rad_vec3 normal, double tol, int *out_overlap)
{
    rad_scene *s = L->scene;
    size_t count = s->face_count - first;
    flat_triangle *t = reserve(L->flat, &L->flat_cap, count, sizeof *t);
    if (!t) return out_of_memory(src);
    L->flat = t;
    for (size_t i = 0; i < count; i++) {
        for (int k = 0; k < 3; k++) project(s, normal, s->faces[first + i].v[k], t[i].p[k]);
        t[i].x_lo = fmin(t[i].p[0][0], fmin(t[i].p[1][0], t[i].p[2][0]));
        t[i].x_hi = fmax(t[i].p[0][0], fmax(t[i].p[1][0], t[i].p[2][0]));
    }
    qsort(t, count, sizeof *t, flat_triangle_compare);
    *out_overlap = 0;
    for (size_t i = 0; i < count && !*out_overlap; i++)
        for (size_t j = i + 1; j < count && t[j].x_lo < t[i].x_hi && !*out_overlap; j++)
            *out_overlap = !separated_by_edge_of(&t[i], &t[j], tol) && !separated_by_edge_of(&t[j], &t[i], tol);
    return RAD_OK;
}

typedef struct poly_edge {
    uint32_t lo, hi; /* its two vertex indices, lo < hi */
    uint32_t forward; /* walked lo -> hi */
} poly_edge;

static int poly_edge_compare(const void *pa, const void *pb)
{
    const poly_edge *a = pa, *b = pb;
    if (a->lo != b->lo) return a->lo < b->lo ? -1 : 1;
    return a->hi < b->hi ? -1 : a->hi > b->hi;
}

/* Counts the bridges of L->poly[0..n): edges walked both ways (a -> b and
 * b -> a). Exporters (LightWave, the assimp test corpus) write a polygon
 * with holes as one ring: the outer ring, a bridge to an inner ring, the
 * inner ring the other way round, back along the bridge. Vertices are
 * compared by index; copies of a vertex under another index are not seen
 * here (ear_clip copes with them all the same). */
static rad_status count_bridges(loader *L, const source *src, size_t n, size_t *out_count)
{
    poly_edge *edge = reserve(L->edges, &L->edge_cap, n, sizeof *edge);
    if (!edge) return out_of_memory(src);
    L->edges = edge;
    for (size_t i = 0; i < n; i++) {
        uint32_t a = L->poly[i], b = L->poly[(i + 1) % n];
        edge[i] = (poly_edge){a < b ? a : b, a < b ? b : a, a < b};
    }
    qsort(edge, n, sizeof *edge, poly_edge_compare);
    size_t bridges = 0;
    for (size_t i = 0, j; i < n; i = j) {
        size_t forward = 0;
        for (j = i; j < n && edge[j].lo == edge[i].lo && edge[j].hi == edge[i].hi; j++) forward += edge[j].forward;
        size_t backward = (j - i) - forward;
        bridges += forward < backward ? forward : backward;
    }
    *out_count = bridges;
    return RAD_OK;
}

/* Adds the polygon L->poly[0..n): drops it if it has zero area, keeps it if
 * it is a planar convex triangle or quad, triangulates it otherwise (a
 * polygon with holes, written with bridges, included: see count_bridges). */
static rad_status add_polygon(loader *L, const source *src, size_t n)
{
    rad_scene *s = L->scene;
    uint32_t *v = L->poly;
    /* A repeated corner (e.g. a triangle written as a quad) adds nothing. */
    size_t kept = 0;
    for (size_t i = 0; i < n; i++) {
        rad_vec3 d = rad_v3_sub(position(s, v[i]), position(s, kept ? v[kept - 1] : v[n - 1]));
        if (rad_v3_dot(d, d) > 0 || (kept == 0 && i == n - 1)) v[kept++] = v[i];
    }
    if (kept < n) scene_warn(L, "%s:%u: face repeats a corner; repeat removed", src->path, src->line);
    n = kept;
    double diam = diameter(s, v, n);
    rad_vec3 N = newell(s, v, n);
    double area = 0.5 * rad_v3_length(N), min_area = AREA_TOL * diam * diam;
    if (n < 3 || !(area > min_area)) {
        scene_warn(L, "%s:%u: face has zero area; dropped", src->path, src->line);
        return RAD_OK;
    }
    rad_vec3 unit = rad_v3_scale(N, 1.0 / (2 * area)), centre = rad_v3(0, 0, 0);
    for (size_t i = 0; i < n; i++) centre = rad_v3_add(centre, rad_v3_scale(position(s, v[i]), 1.0 / (double)n));
    double off_plane = 0;
    int convex = 1;
    for (size_t i = 0; i < n; i++) {
        rad_vec3 p = position(s, v[i]);
        off_plane = fmax(off_plane, fabs(rad_v3_dot(unit, rad_v3_sub(p, centre))));
        rad_vec3 e0 = rad_v3_sub(p, position(s, v[(i + n - 1) % n]));
        rad_vec3 e1 = rad_v3_sub(position(s, v[(i + 1) % n]), p);
        if (!(rad_v3_dot(rad_v3_cross(e0, e1), unit) > 2 * min_area)) convex = 0;
    }
    double tolerance = fmax(PLANAR_TOL * diam, fmin(PLANAR_QUANTUM_FACTOR * L->coord_quantum, PLANAR_TOL_MAX * diam));
    int planar = off_plane <= tolerance;
    if (n <= 4 && planar && convex) return push_face(L, src, v, (uint32_t)n);

    /* Triangulate: ear clipping on the projection (it needs 2n indices). */
    uint32_t *p = reserve(L->poly, &L->poly_cap, 2 * n, sizeof *p);
    if (!p) return out_of_memory(src);
    L->poly = p;
    size_t bridges = 0;
    rad_status status = count_bridges(L, src, n, &bridges);
    if (status) return status;
    size_t first = s->face_count;
    status = ear_clip(L, src, n, N, min_area);
    if (status == RAD_ERR_INVALID && !planar && bridges) /* a fan would cover the hole */
        return fail(src, RAD_ERR_INVALID,
                    "face with a hole is off its plane by more than 1e-6 of its size; cannot triangulate");
    if (status == RAD_ERR_INVALID && !planar) {
        s->face_count = first; /* a badly warped polygon: fan instead */
        status = RAD_OK;
        for (size_t i = 1; i + 1 < n && !status; i++) {
            uint32_t tri[3] = {L->poly[0], L->poly[i], L->poly[i + 1]};
            if (triangle_area(s, tri[0], tri[1], tri[2]) > min_area) status = push_face(L, src, tri, 3);
        }
    }
    if (status && status != RAD_ERR_INVALID) return status;
    double sum = 0; /* a simple planar polygon is covered exactly once */
    for (size_t f = first; f < s->face_count; f++)
        sum += triangle_area(s, s->faces[f].v[0], s->faces[f].v[1], s->faces[f].v[2]);
    int overlap = 0;
    if (!status && planar) {
        rad_status checked = faces_overlap(L, src, first, N, 2 * min_area, &overlap);
        if (checked) return checked;
    }
    if (status || overlap || (planar && fabs(sum - area) > SELF_INTERSECT_TOL * area))
        return fail(src, RAD_ERR_INVALID, "face crosses itself; cannot triangulate%s",
                    bridges ? " (it has an edge walked both ways, a bridge to a hole: the hole's ring must "
                              "wind the other way round from the outer one and lie inside it)"
                            : "");
    size_t emitted = s->face_count - first;
    if (!planar && !bridges) { /* counted, and said once for the scene (nonplanar_report) */
        if (L->nonplanar++ == 0) {
            L->nonplanar_first = src->line;
            snprintf(L->nonplanar_path, sizeof L->nonplanar_path, "%s", src->path);
        }
        L->nonplanar_faces += emitted;
        L->nonplanar_worst = fmax(L->nonplanar_worst, off_plane / diam);
        return RAD_OK;
    }
    char why[80];
    if (bridges)
        snprintf(why, sizeof why, "%s%zu hole%s joined by bridge edges", planar ? "" : "non-planar, ", bridges,
                 bridges > 1 ? "s" : "");
    else
        snprintf(why, sizeof why, "%s", !planar ? "non-planar" : !convex ? "non-convex" : "more than 4 vertices");
    scene_warn(L, "%s:%u: %zu-vertex face triangulated into %zu triangles (%s%s)", src->path, src->line, n, emitted, why,
               planar ? "" : "; off its plane by more than 1e-6 of its size");
    return RAD_OK;
}

/* Parses one index ("7", "-1"), 1-based or negative-relative, into 0-based.
 * `what` names the index in messages, `things` what it counts. */
static rad_status parse_index(const source *src, const char *text, size_t count, const char *what, const char *things, uint32_t *out)
{
    char *end;
    errno = 0;
    long long i = strtoll(text, &end, 10);
    if (end == text || *end) return fail(src, RAD_ERR_PARSE, "bad index '%s'", text);
    if (i == 0)
        return fail(src, RAD_ERR_INVALID, "%s index 0 is invalid (indices are 1-based)", strcmp(what, "vertex") ? what : "face");
    long long resolved = i > 0 ? i - 1 : (long long)count + i;
    if (errno == ERANGE || resolved < 0 || (unsigned long long)resolved >= count)
        return fail(src, RAD_ERR_INVALID, "%s index %s out of range (%zu %s so far)", what, text, count, things);
    *out = (uint32_t)resolved;
    return RAD_OK;
}

/* 1 when `name` is one of the comma-separated `list`'s names (NULL: none). */
static int name_listed(const char *list, const char *name)
{
    size_t len = strlen(name);
    for (const char *p = list; p && *p;) {
        const char *comma = strchr(p, ',');
        size_t n = comma ? (size_t)(comma - p) : strlen(p);
        if (n == len && strncmp(p, name, n) == 0) return 1;
        p = comma ? comma + 1 : NULL;
    }
    return 0;
}

/* rad_scene_options.flip_groups: every name must be a group of the scene
 * (else RAD_ERR_INVALID naming the scene's groups); each group's faces
 * are wound the other way round. */
static rad_status flip_groups(rad_scene *s, const char *list)
{
    for (const char *p = list; p && *p;) {
        const char *comma = strchr(p, ',');
        size_t n = comma ? (size_t)(comma - p) : strlen(p);
        size_t g = 1;
        while (g < s->group_count && !(strlen(s->groups[g]) == n && strncmp(s->groups[g], p, n) == 0)) g++;
        if (g == s->group_count) {
            char names[512] = "";
            for (size_t k = 1; k < s->group_count && strlen(names) + RAD_NAME_MAX + 8 < sizeof names; k++)
                snprintf(names + strlen(names), sizeof names - strlen(names), "%s'%s'", k > 1 ? ", " : "",
                         s->groups[k]);
            rad_error("%s: --flip-group '%.*s': no object or group (`o` or `g`) of that name; the scene's: %s",
                      s->path, (int)n, p, s->group_count > 1 ? names : "none (every face is in 'default')");
            return RAD_ERR_INVALID;
        }
        p = comma ? comma + 1 : NULL;
    }
    for (size_t f = 0; f < s->face_count; f++) {
        rad_face *face = &s->faces[f];
        if (!name_listed(list, s->groups[face->group])) continue;
        for (uint32_t a = 0, b = face->vertex_count - 1; a < b; a++, b--) {
            uint32_t t = face->v[a];
            face->v[a] = face->v[b];
            face->v[b] = t;
        }
    }
    return RAD_OK;
}

/* Does the face's winding (its Newell normal; reversed under
 * flip_normals) agree with its corners' vn normals? Counted, and the
 * first disagreement's place kept, for one warning per scene (vn_report):
 * the patch faces the way the winding says, as OBJ defines it, so a
 * contradiction usually means an exporter or modeller flipped one of them. */
static void check_vn(loader *L, const source *src, size_t n)
{
    rad_vec3 sum = rad_v3(0, 0, 0);
    for (size_t i = 0; i < n; i++) {
        if (L->poly_normal[i] == UINT32_MAX) return;
        const double *nv = L->normals + 3 * L->poly_normal[i];
        sum = rad_v3_add(sum, rad_v3(nv[0], nv[1], nv[2]));
    }
    rad_vec3 winding = newell(L->scene, L->poly, n);
    /* A group flipped by name contradicts its vn by design: not judged. */
    if (name_listed(L->flip_groups, L->scene->groups[L->group])) return;
    double along = rad_v3_dot(sum, winding) * (L->flip_normals ? -1.0 : 1.0);
    if (!(rad_v3_length(sum) > 0) || !(rad_v3_length(winding) > 0)) return;
    L->vn_faces++;
    if (along < 0 && L->vn_against++ == 0) snprintf(L->vn_first, sizeof L->vn_first, "%s:%u", src->path, src->line);
}

static void vn_report(const loader *L)
{
    if (L->vn_against == 0) return;
    if (L->vn_against == L->vn_faces)
        rad_warn("%s: every face is wound against its vn normals (%zu faces): patches face the way the winding "
                 "says (counter-clockwise seen from the front, as OBJ defines it), so they face away from where "
                 "the normals point; if the normals are right, run formfactor %s",
                 L->vn_first, L->vn_faces, L->flip_normals ? "without --flip-normals" : "with --flip-normals");
    else
        rad_warn("%s: %zu of %zu faces with vn normals are wound against them (this is the first): patches "
                 "face the way the winding says; fix the winding in the modeller (Blender: Mesh > Normals > "
                 "Recalculate Outside, or Flip) and export again",
                 L->vn_first, L->vn_against, L->vn_faces);
}

/* Non-planar polygons split into triangles, said once: how many, and how
 * much larger that makes the scene (a subdivided mesh's quads are mostly
 * not planar: every one becomes two faces, and N about doubles). */
static void nonplanar_report(const loader *L)
{
    if (L->nonplanar == 0) return;
    const rad_scene *s = L->scene;
    size_t without = s->face_count - L->nonplanar_faces + L->nonplanar;
    rad_warn("%s:%u: %zu non-planar polygons (this is the first; the farthest off its plane by %.2g of its size, "
             "beyond rounding) were split into %zu triangles: %zu faces where the file has %zu polygons, %.0f%% "
             "more patches to compute; a subdivided or sculpted mesh's quads are rarely planar (export it "
             "triangulated, or with fewer subdivisions, to choose the split yourself)",
             L->nonplanar_path, L->nonplanar_first, L->nonplanar, L->nonplanar_worst, L->nonplanar_faces,
             s->face_count, without, 100.0 * (double)(s->face_count - without) / (double)(without ? without : 1));
}

static rad_status parse_face(loader *L, const source *src, char **tok, size_t n)
{
    rad_scene *s = L->scene;
    if (n - 1 < 3) return fail(src, RAD_ERR_PARSE, "face has %zu vertices, needs at least 3", n - 1);
    uint32_t *poly = reserve(L->poly, &L->poly_cap, n - 1, sizeof *poly);
    if (!poly) return out_of_memory(src);
    L->poly = poly;
    uint32_t *poly_normal = reserve(L->poly_normal, &L->poly_normal_cap, n - 1, sizeof *poly_normal);
    if (!poly_normal) return out_of_memory(src);
    L->poly_normal = poly_normal;
    for (size_t i = 1; i < n; i++) {
        /* v, v/vt, v//vn or v/vt/vn: split at the slashes in place. */
        char *part[3] = {tok[i], NULL, NULL};
        char *slash = strchr(tok[i], '/');
        if (slash) {
            *slash = 0;
            part[1] = slash + 1;
            slash = strchr(part[1], '/');
            if (slash) {
                *slash = 0;
                part[2] = slash + 1;
            }
        }
        uint32_t unused;
        poly_normal[i - 1] = UINT32_MAX;
        rad_status status = parse_index(src, part[0], s->vertex_count, "vertex", "vertices", &poly[i - 1]);
        if (!status && part[1] && (*part[1] || !part[2]))
            status = parse_index(src, part[1], L->texcoord_count, "texture", "texture coordinates", &unused);
        if (!status && part[2])
            status = parse_index(src, part[2], L->normal_count, "normal", "normals", &poly_normal[i - 1]);
        if (status) return status;
    }
    check_vn(L, src, n - 1);
    if (!L->have_usemtl && !L->warned_default) {
        L->warned_default = 1;
        scene_warn(L, "%s:%u: face before any usemtl uses material 'default' (grey 0.5)", src->path, src->line);
    }
    return add_polygon(L, src, n - 1);
}

/* ---- OBJ and MTL statements ---- */

static rad_status parse_text(loader *L, const char *path, char *text, int is_mtl);

/* Names the encoding of a file of UTF-16 or UTF-32 text, which has NUL
 * bytes between its characters and would only be called "not a text
 * file": by its byte-order mark, or, without one, by NULs in every other
 * byte of its first characters. NULL for anything else (a UTF-8 BOM is
 * skipped by parse_text). */
static const char *wide_encoding(const unsigned char *data, size_t size)
{
    if (size >= 4 && !memcmp(data, "\xFF\xFE\0\0", 4)) return "UTF-32 text (byte-order mark FF FE 00 00)";
    if (size >= 4 && !memcmp(data, "\0\0\xFE\xFF", 4)) return "UTF-32 text (byte-order mark 00 00 FE FF)";
    if (size >= 2 && data[0] == 0xFF && data[1] == 0xFE) return "UTF-16 text (byte-order mark FF FE)";
    if (size >= 2 && data[0] == 0xFE && data[1] == 0xFF) return "UTF-16 text (byte-order mark FE FF)";
    /* No mark: mostly ASCII characters as 16-bit units, the NUL high byte
     * second (little-endian) or first (big-endian), in at least 3/4 of the
     * first 64 pairs (a binary file of small integers has NUL pairs too). */
    size_t pairs = size / 2 < 64 ? size / 2 : 64, low_nul = 0, high_nul = 0;
    for (size_t i = 0; i < pairs; i++) {
        low_nul += data[2 * i] != 0 && data[2 * i + 1] == 0;
        high_nul += data[2 * i] == 0 && data[2 * i + 1] != 0;
    }
    if (pairs >= 2 && 4 * low_nul >= 3 * pairs) return "UTF-16 text (little-endian, no byte-order mark)";
    if (pairs >= 2 && 4 * high_nul >= 3 * pairs) return "UTF-16 text (big-endian, no byte-order mark)";
    return NULL;
}

/* Reads and parses `path`; `from` is the mtllib statement that named it as
 * `name` (NULL for the OBJ itself). */
static rad_status load(loader *L, const char *path, const source *from, const char *name, int is_mtl)
{
    char *data = NULL;
    size_t size = 0;
    source here = {path, 0};
    rad_status status = L->read_file(path, &data, &size, L->read_file_user);
    if (status || !data) {
        const char *what = status == RAD_ERR_NOMEM ? "out of memory" : "cannot open";
        if (from)
            fail(from, RAD_ERR_IO, "mtllib '%s': %s", name, what);
        else
            rad_error("%s: %s", path, what);
        status = status == RAD_ERR_NOMEM ? RAD_ERR_NOMEM : RAD_ERR_IO;
        goto done;
    }
    char *text = realloc(data, size + 1); /* the reader need not terminate it */
    if (!text) {
        status = out_of_memory(&here);
        goto done;
    }
    data = text;
    data[size] = 0;
    const char *encoding = wide_encoding((const unsigned char *)data, size);
    if (encoding) {
        rad_error("%s: is %s; save it as UTF-8 or ASCII", path, encoding);
        status = RAD_ERR_PARSE;
        goto done;
    }
    const char *nul = memchr(data, 0, size);
    if (nul) {
        here.line = 1;
        for (const char *c = data; c < nul; c++) here.line += *c == '\n' || (*c == '\r' && c[1] != '\n');
        status = fail(&here, RAD_ERR_PARSE, "contains a NUL byte (not a text file)");
        goto done;
    }
    status = parse_text(L, path, data, is_mtl);
done:
    free(data);
    return status;
}

static rad_status load_mtllibs(loader *L, const source *src, char **tok, size_t n)
{
    if (n < 2) return fail(src, RAD_ERR_PARSE, "mtllib needs a file name");
    const char *slash = strrchr(src->path, '/');
    int dir_len = slash ? (int)(slash - src->path + 1) : 0;
    for (size_t i = 1; i < n; i++) {
        char path[PATH_MAX_LEN];
        int len = tok[i][0] == '/' ? snprintf(path, sizeof path, "%s", tok[i])
                                   : snprintf(path, sizeof path, "%.*s%s", dir_len, src->path, tok[i]);
        if (len < 0 || (size_t)len >= sizeof path) return fail(src, RAD_ERR_INVALID, "mtllib '%s': path too long", tok[i]);
        /* Read, but said: a scene that reaches outside its folder. */
        if (tok[i][0] == '/' || !strncmp(tok[i], "../", 3) || strstr(tok[i], "/../") || !strcmp(tok[i], ".."))
            scene_warn(L, "%s:%u: mtllib '%s' lies outside the scene's folder", src->path, src->line, tok[i]);
        uint64_t h = rad_hash64(RAD_HASH_SEED, path, (size_t)len);
        int seen = 0;
        for (size_t k = 0; k < L->mtl_loaded_count; k++) seen |= L->mtl_loaded[k] == h;
        if (seen) continue;
        uint64_t *loaded = reserve(L->mtl_loaded, &L->mtl_loaded_cap, L->mtl_loaded_count + 1, sizeof *loaded);
        if (!loaded) return out_of_memory(src);
        L->mtl_loaded = loaded;
        loaded[L->mtl_loaded_count++] = h;
        rad_status status = load(L, path, src, tok[i], 1);
        if (status) return status;
    }
    return RAD_OK;
}

static size_t find_material(const rad_scene *s, const char *name)
{
    for (size_t i = s->material_count; i-- > 1;)
        if (strcmp(s->materials[i].name, name) == 0) return i;
    return strcmp(s->materials[0].name, name) == 0 ? 0 : SIZE_MAX;
}

static rad_status obj_statement(loader *L, const source *src, char **tok, size_t n)
{
    rad_scene *s = L->scene;
    const char *key = tok[0];
    if (strcmp(key, "v") == 0) {
        double p[3];
        /* x y z, optionally w or an r g b colour: the extras are checked and ignored. */
        size_t count = n == 5 || n == 7 ? n - 1 : 3;
        double extra[6];
        rad_status status = parse_numbers(src, tok, n, count, extra);
        if (status) return status;
        memcpy(p, extra, sizeof p);
        for (int a = 0; a < 3; a++) note_precision(L, tok[1 + a]);
        if (!isfinite(p[0]) || !isfinite(p[1]) || !isfinite(p[2]))
            return fail(src, RAD_ERR_INVALID, "coordinate is NaN or infinite");
        for (int a = 0; a < 3; a++)
            if (fabs(p[a]) > SCENE_COORD_MAX)
                return fail(src, RAD_ERR_INVALID,
                            "coordinate %s beyond the supported range |x| <= %g (the ray tracers work in float; "
                            "scale the scene down)",
                            tok[1 + a], SCENE_COORD_MAX);
        if (s->vertex_count >= UINT32_MAX - 1) return fail(src, RAD_ERR_INVALID, "too many vertices");
        double *pos = reserve(s->positions, &L->position_cap, 3 * (s->vertex_count + 1), sizeof *pos);
        if (!pos) return out_of_memory(src);
        s->positions = pos;
        memcpy(pos + 3 * s->vertex_count++, p, sizeof p);
        return RAD_OK;
    }
    if (strcmp(key, "f") == 0) return parse_face(L, src, tok, n);
    if (strcmp(key, "vt") == 0) return L->texcoord_count++, RAD_OK;
    if (strcmp(key, "vn") == 0) {
        double nv[3];
        rad_status status = parse_numbers(src, tok, n, 3, nv);
        if (status) return status;
        double *normals = reserve(L->normals, &L->normal_cap, 3 * (L->normal_count + 1), sizeof *normals);
        if (!normals) return out_of_memory(src);
        L->normals = normals;
        memcpy(normals + 3 * L->normal_count++, nv, sizeof nv);
        return RAD_OK;
    }
    if (strcmp(key, "s") == 0) return parse_smoothing(L, src, tok, n);
    if (strcmp(key, "mtllib") == 0) return load_mtllibs(L, src, tok, n);
    if (strcmp(key, "usemtl") == 0) {
        char name[RAD_NAME_MAX];
        rad_status status = parse_name(src, tok, n, name);
        if (status) return status;
        size_t m = find_material(s, name);
        if (m == SIZE_MAX) return fail(src, RAD_ERR_INVALID, "usemtl '%s': no such material", name);
        L->material = (uint32_t)m;
        L->have_usemtl = 1;
        return RAD_OK;
    }
    if (strcmp(key, "g") == 0 || strcmp(key, "o") == 0) {
        char name[RAD_NAME_MAX] = "default";
        rad_status status = n < 2 ? RAD_OK : parse_name(src, tok, n, name);
        if (status) return status;
        size_t g = 0;
        while (g < s->group_count && strcmp(s->groups[g], name) != 0) g++;
        if (g == s->group_count) {
            char(*groups)[RAD_NAME_MAX] = reserve(s->groups, &L->group_cap, g + 1, sizeof *groups);
            if (!groups) return out_of_memory(src);
            s->groups = groups;
            strcpy(groups[s->group_count++], name);
        }
        L->group = (uint32_t)g;
        return RAD_OK;
    }
    warn_unknown(L, src, key);
    return RAD_OK;
}

static void finish_material(loader *L, const char *path)
{
    if (L->mtl_current && !L->mtl_has_kd)
        scene_warn(L, "%s:%u: material '%s' has no Kd; using grey 0.5", path, L->mtl_line,
                 L->scene->materials[L->mtl_current].name);
    L->mtl_current = 0;
}

static rad_status mtl_statement(loader *L, const source *src, char **tok, size_t n)
{
    rad_scene *s = L->scene;
    const char *key = tok[0];
    static const char *const ignored[] = {"Ka", "Ks", "Ns", "Ni", "d", "Tr", "illum", "Tf"};
    for (size_t i = 0; i < sizeof ignored / sizeof ignored[0]; i++)
        if (strcmp(key, ignored[i]) == 0) return RAD_OK;
    if (strncmp(key, "map_", 4) == 0) return RAD_OK;
    if (strcmp(key, "newmtl") == 0) {
        finish_material(L, src->path);
        char name[RAD_NAME_MAX];
        rad_status status = parse_name(src, tok, n, name);
        if (status) return status;
        size_t m = find_material(s, name);
        if (m != SIZE_MAX && m != 0) return fail(src, RAD_ERR_INVALID, "material '%s' defined twice", name);
        rad_material *mat = reserve(s->materials, &L->material_cap, s->material_count + 1, sizeof *mat);
        if (!mat) return out_of_memory(src);
        s->materials = mat;
        mat += s->material_count;
        *mat = s->materials[0]; /* defaults */
        strcpy(mat->name, name);
        L->mtl_current = s->material_count++;
        L->mtl_has_kd = 0;
        L->mtl_line = src->line;
        return RAD_OK;
    }
    int is_kd = strcmp(key, "Kd") == 0;
    if (is_kd || strcmp(key, "Ke") == 0) {
        if (!L->mtl_current) return fail(src, RAD_ERR_PARSE, "%s before any newmtl", key);
        double rgb[3];
        rad_status status = parse_numbers(src, tok, n, n == 2 ? 1 : 3, rgb); /* "Kd r" means grey */
        if (status) return status;
        if (n == 2) rgb[1] = rgb[2] = rgb[0];
        double given[3] = {rgb[0], rgb[1], rgb[2]};
        int clamped = 0;
        for (int c = 0; c < 3; c++) {
            const char *text = tok[n == 2 ? 1 : 1 + c];
            if (!isfinite(rgb[c])) return fail(src, RAD_ERR_INVALID, "%s %s is NaN or infinite", key, text);
            if (is_kd && L->clamp_rho > 0 && rgb[c] > L->clamp_rho) {
                rgb[c] = L->clamp_rho;
                clamped = 1;
            }
            if (is_kd && !(rgb[c] >= 0 && rgb[c] < 1))
                return fail(src, RAD_ERR_INVALID, "Kd %s out of range [0,1)%s", text,
                            rgb[c] >= 1 ? " (reflectance 1 makes the system singular; formfactor --clamp-rho "
                                          "0.99 clamps it)"
                                        : "");
            if (!is_kd && !(rgb[c] >= 0 && rgb[c] <= SCENE_EMISSION_MAX))
                return fail(src, RAD_ERR_INVALID, "Ke %s out of range [0, %g]", text, SCENE_EMISSION_MAX);
        }
        if (clamped)
            scene_warn(L, "%s:%u: material '%s': Kd %g %g %g clamped to %g %g %g (--clamp-rho %g)", src->path,
                       src->line, s->materials[L->mtl_current].name, given[0], given[1], given[2], rgb[0], rgb[1],
                       rgb[2], L->clamp_rho);
        memcpy(is_kd ? s->materials[L->mtl_current].rho : s->materials[L->mtl_current].emission, rgb, sizeof rgb);
        L->mtl_has_kd |= is_kd;
        return RAD_OK;
    }
    warn_unknown(L, src, key);
    return RAD_OK;
}

static rad_status parse_text(loader *L, const char *path, char *text, int is_mtl)
{
    rad_status status = RAD_OK;
    char **tok = NULL;
    size_t tok_cap = 0, n;
    source src = {path, 0};
    if ((unsigned char)text[0] == 0xEF && (unsigned char)text[1] == 0xBB && (unsigned char)text[2] == 0xBF) text += 3;
    while (*text) {
        /* A line ends at LF, CRLF or a lone CR (classic Mac OS). */
        char *line = text, *end = strpbrk(text, "\r\n");
        if (end) {
            text = end + (end[0] == '\r' && end[1] == '\n' ? 2 : 1);
            *end = 0;
        } else {
            text += strlen(text);
        }
        src.line++;
        if ((size_t)(end ? end - line : text - line) > SCENE_LINE_MAX) {
            status = fail(&src, RAD_ERR_PARSE, "line longer than %zu bytes", (size_t)SCENE_LINE_MAX);
            goto done;
        }
        status = tokenize(line, &tok, &tok_cap, &n);
        if (status) {
            out_of_memory(&src);
            goto done;
        }
        if (n == 0) continue;
        status = is_mtl ? mtl_statement(L, &src, tok, n) : obj_statement(L, &src, tok, n);
        if (status) goto done;
    }
    if (is_mtl) finish_material(L, path);
done:
    free(tok);
    return status;
}

/* ---- the public functions ---- */

static uint64_t fingerprint(const rad_scene *s)
{
    uint64_t counts[3] = {s->vertex_count, s->face_count, s->material_count};
    uint64_t h = rad_hash64(RAD_HASH_SEED, counts, sizeof counts);
    h = rad_hash64(h, s->positions, 3 * s->vertex_count * sizeof *s->positions);
    for (size_t i = 0; i < s->face_count; i++) {
        const rad_face *f = &s->faces[i];
        uint32_t words[6] = {f->vertex_count, f->v[0], f->v[1], f->v[2], f->vertex_count == 4 ? f->v[3] : 0, f->material};
        h = rad_hash64(h, words, sizeof words);
    }
    for (size_t i = 0; i < s->material_count; i++) {
        h = rad_hash64(h, s->materials[i].rho, sizeof s->materials[i].rho);
        h = rad_hash64(h, s->materials[i].emission, sizeof s->materials[i].emission);
    }
    return h;
}

rad_status rad_scene_load_file(const char *path, const rad_scene_options *options, rad_scene *out_scene)
{
    rad_status status = RAD_ERR_NOMEM;
    rad_scene scene;
    loader L;
    memset(&scene, 0, sizeof scene);
    memset(&L, 0, sizeof L);
    L.scene = &scene;
    L.read_file = options && options->read_file ? options->read_file : read_file_system;
    L.read_file_user = options ? options->read_file_user : NULL;
    L.clamp_rho = options ? options->clamp_rho : 0;
    L.flip_normals = options ? options->flip_normals : 0;
    L.flip_groups = options ? options->flip_groups : NULL;
    L.ke_radiance = options ? options->ke_radiance : 0;
    snprintf(scene.path, sizeof scene.path, "%s", path);
    scene.materials = reserve(NULL, &L.material_cap, 8, sizeof *scene.materials);
    scene.groups = reserve(NULL, &L.group_cap, 8, sizeof *scene.groups);
    if (!scene.materials || !scene.groups) {
        rad_error("%s: out of memory", path);
        goto done;
    }
    scene.materials[0] = (rad_material){.name = "default", .rho = {0.5, 0.5, 0.5}};
    scene.material_count = 1;
    strcpy(scene.groups[0], "default");
    scene.group_count = 1;
    status = load(&L, path, NULL, path, 0);
    if (!status) vn_report(&L);
    if (!status) nonplanar_report(&L);
    if (L.warnings_hidden)
        rad_warn("%s: %zu more warnings not shown (the first %d are)", path, L.warnings_hidden, SCENE_WARNINGS_SHOWN);
    if (status) goto done;
    if (scene.face_count == 0) {
        rad_error("%s: no faces", path);
        status = RAD_ERR_INVALID;
        goto done;
    }
    if (L.flip_normals) /* every face wound the other way round */
        for (size_t f = 0; f < scene.face_count; f++) {
            rad_face *face = &scene.faces[f];
            for (uint32_t a = 0, b = face->vertex_count - 1; a < b; a++, b--) {
                uint32_t t = face->v[a];
                face->v[a] = face->v[b];
                face->v[b] = t;
            }
        }
    if (L.flip_groups && (status = flip_groups(&scene, L.flip_groups)) != RAD_OK) goto done;
    if (L.ke_radiance) /* Ke was radiance: a diffuse emitter leaves E = pi L_e */
        for (size_t m = 1; m < scene.material_count; m++)
            for (int c = 0; c < 3; c++) scene.materials[m].emission[c] *= RAD_PI;
    scene.fingerprint = fingerprint(&scene);
    scene.vn_face_count = L.vn_faces;
    scene.vn_against_count = L.vn_against;
    *out_scene = scene;
    memset(&scene, 0, sizeof scene);
done:
    rad_scene_free(&scene);
    free(L.poly);
    free(L.poly_normal);
    free(L.normals);
    free(L.uv);
    free(L.edges);
    free(L.flat);
    free(L.mtl_loaded);
    return status;
}

rad_status rad_scene_load_default(rad_scene *out_scene)
{
    rad_scene_options options = {.read_file = read_embedded};
    return rad_scene_load_file("cornell_box.obj", &options, out_scene);
}

void rad_scene_free(rad_scene *scene)
{
    if (!scene) return;
    free(scene->positions);
    free(scene->faces);
    free(scene->materials);
    free(scene->groups);
    memset(scene, 0, sizeof *scene);
}
