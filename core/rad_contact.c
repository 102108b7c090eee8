/* rad_contact.c - faces cut along their contacts (contract in rad_contact.h).
 *
 * Per face F: collect the cut segments (other faces meeting F's plane,
 * clipped to F), split F's pieces by them one at a time, tidy the pieces
 * (collinear corners, zero areas), drop the hidden ones and fan the rest
 * into 3-4-gons. Pieces live as runs of vertex indices in one pool; a
 * split appends its two halves and retires the piece it split.
 *
 * Cut vertices are deduplicated by exact position (a linear search over
 * the cut vertices made so far: contacts add tens to hundreds). A split
 * point on an edge is computed from the edge's lower vertex index to its
 * higher one, so the two pieces that share the edge get the same bits and
 * so the same vertex; a point within the tolerance of a cut segment's
 * end is that end (a footprint's corner stays the scene's vertex).
 * The faces near a face come from a uniform grid over the faces' boxes
 * (rad_face_grid.h), looked at in face order as if every face were; the
 * inside test's rays walk the same grid cell by cell and stop at the
 * first cell that holds their nearest hit.
 */
#include "rad_contact.h"

#include <assert.h>
#include <math.h>
#include <stddef.h>
#include <stdlib.h>
#include <string.h>

#include "rad_box.h"
#include "rad_face_grid.h"
#include "rad_log.h"
#include "rad_math.h"
#include "rad_polygon.h"

#define AREA_TOL 1e-12           /* x face diameter^2: a zero-area piece (as the loader's) */
#define INSIDE_RAY_ANGLE 0.8726646259971648 /* 50 degrees off the normal, radians */
#define TWO_PI 6.283185307179586
#define CUT_VERTEX_LIMIT ((size_t)UINT32_MAX - 2)
/* Corners of a piece that split_pieces still splits. A grid cell has 3 or
 * 4 and each cut line through it adds at most one to either half, so
 * pieces of real scenes stay far below 64 (60 lines through one cell); a
 * larger piece is left whole rather than growing the stack arrays. */
#define PIECE_SPLIT_MAX 64
/* Corners a piece can have: the halves of a piece of PIECE_SPLIT_MAX
 * corners get at most the two split points more. */
#define PIECE_CORNER_MAX (PIECE_SPLIT_MAX + 2)

typedef struct segment {
    rad_vec3 a, b;
    uint32_t ia, ib; /* scene vertex at a / b, or RAD_NO_VERTEX */
} segment;

typedef struct piece {
    size_t start; /* into cutter.pool */
    uint32_t n;
    int live;
} piece;

/* A face in the index of parallel faces (near_index_build): its normal's
 * bin and its first corner's offset along the bin's direction. */
typedef struct near_entry {
    uint64_t bin;
    double offset;
    uint32_t face;
} near_entry;

/* A piece emitted as out[out_begin, out_end) whose inside test
 * (inside_solid, rays through the grid: most of the cutting's time at
 * 10^6 faces) is left to resolve_solid_checks, on the threads, after every
 * face is cut: what it reads (the scene's faces, their normals, the grid)
 * no longer changes then. */
typedef struct solid_check {
    rad_vec3 centroid, normal;
    uint32_t face;
    uint8_t pressed; /* pressed(centroid), at the time: it reads the face's survey */
    uint8_t hidden;
    size_t out_begin, out_end;
} solid_check;

typedef struct cutter {
    const rad_scene *scene;
    double tol, min_length, offset; /* absolute, scene units */
    double gap;                     /* RAD_CONTACT_GAP, scene units */
    double near;                    /* RAD_CONTACT_NEAR, scene units */
    size_t near_count;              /* rad_contact_cut's near misses */
    uint32_t near_face, near_cover;
    double near_distance;
    rad_vec3 *normal;               /* per face, unit */
    rad_box *box;                   /* per face */
    double *pos;
    size_t vertex_count, vertex_cap;
    uint32_t *pool;  /* corners of the pieces */
    uint64_t *line;  /* per corner: the line its edge to the next corner lies on (line_of) */
    size_t pool_count, pool_cap, line_cap;
    piece *pieces;
    size_t piece_count, piece_cap;
    segment *segs;
    size_t seg_count, seg_cap;
    uint32_t *opposite; /* this face's coplanar faces of opposite facing */
    size_t opposite_count, opposite_cap;
    uint32_t *covering; /* its coplanar faces of the same facing that win where they overlap it */
    size_t covering_count, covering_cap;
    uint32_t *hash;  /* cut vertices by position: index or RAD_NO_VERTEX */
    size_t hash_mask;
    rad_contact_piece *out;
    size_t out_count, out_cap;
    size_t faces_cut, hidden;
    const int *face_level; /* NULL = 0 */
    rad_face_grid grid;    /* the faces' boxes grown by the gap (and the tolerance) */
    near_entry *near_index; /* the faces by normal bin, then by offset along it (near_index_build) */
    size_t near_index_count;
    double near_slack;      /* how far the index's offsets may stray from a face's own (near_band) */
    rad_vec3 centre;        /* of the scene's box: the offsets' origin */
    uint32_t *stamp;       /* per face: the cut_face call that last listed it */
    uint32_t stamp_now;
    uint32_t *cand;        /* the faces near the face being cut, ascending */
    size_t cand_count, cand_cap;
    uint8_t *cut;          /* per face: survey_face found something that cuts it */
    solid_check *checks;   /* the pieces emitted before their solid test (finish_piece) */
    size_t check_count, check_cap;
    int failed;
} cutter;

/* Room for `need` elements in *p (capacity *cap, doubling); on failure
 * *failed is set and p kept. */
static void *grow(void *p, size_t *cap, size_t need, size_t elem, int *failed)
{
    if (*failed || need <= *cap) return p;
    size_t n = *cap ? *cap : 16;
    while (n < need) n *= 2;
    void *q = realloc(p, n * elem);
    if (!q) {
        *failed = 1;
        return p;
    }
    *cap = n;
    return q;
}
#define GROW(C, arr, cap, need) ((C)->arr = grow((C)->arr, &(C)->cap, (need), sizeof *(C)->arr, &(C)->failed), !(C)->failed)

static rad_vec3 vertex(const cutter *C, uint32_t i)
{
    const double *p = C->pos + 3 * (size_t)i;
    return rad_v3(p[0], p[1], p[2]);
}

static rad_vec3 face_corner(const cutter *C, uint32_t f, uint32_t k) { return vertex(C, C->scene->faces[f].v[k]); }

/* Face f's area and centroid (rad_polygon_geometry). */
static double face_area(const cutter *C, uint32_t f, rad_vec3 *out_centroid)
{
    const rad_face *F = &C->scene->faces[f];
    rad_vec3 c[4], normal;
    double area;
    for (uint32_t k = 0; k < F->vertex_count; k++) c[k] = face_corner(C, f, k);
    rad_polygon_geometry(c, (int)F->vertex_count, &area, &normal, out_centroid);
    return area;
}

/* Lines that piece edges lie on: a cut segment (its index, tagged), or
 * the grid edge between two vertices (their indices, lower first). */
#define SEGMENT_LINE(i) (UINT64_C(0xFFFFFFFF00000000) | (uint64_t)(i))
static uint64_t edge_line(uint32_t a, uint32_t b) { return a < b ? (uint64_t)a << 32 | b : (uint64_t)b << 32 | a; }

static size_t position_hash(rad_vec3 p, size_t mask)
{
    uint64_t h = UINT64_C(1469598103934665603), w[3];
    memcpy(&w[0], &p.x, 8), memcpy(&w[1], &p.y, 8), memcpy(&w[2], &p.z, 8);
    for (int i = 0; i < 3; i++) h = (h ^ w[i]) * UINT64_C(0x9E3779B97F4A7C15);
    return (size_t)(h >> 20) & mask;
}

/* The cut vertex at p: an existing cut vertex at exactly p, else a new one
 * (kept in an open-addressing table at most half full). */
static uint32_t cut_vertex(cutter *C, rad_vec3 p)
{
    if (C->failed) return 0;
    size_t made = C->vertex_count - C->scene->vertex_count;
    if (2 * (made + 1) > C->hash_mask + 1 || !C->hash) {
        size_t size = C->hash ? 2 * (C->hash_mask + 1) : 1024;
        uint32_t *table = malloc(size * sizeof *table);
        if (!table) {
            C->failed = 1;
            return 0;
        }
        for (size_t i = 0; i < size; i++) table[i] = RAD_NO_VERTEX;
        free(C->hash);
        C->hash = table;
        C->hash_mask = size - 1;
        for (size_t v = C->scene->vertex_count; v < C->vertex_count; v++) {
            size_t i = position_hash(vertex(C, (uint32_t)v), C->hash_mask);
            while (table[i] != RAD_NO_VERTEX) i = (i + 1) & C->hash_mask;
            table[i] = (uint32_t)v;
        }
    }
    size_t i = position_hash(p, C->hash_mask);
    for (; C->hash[i] != RAD_NO_VERTEX; i = (i + 1) & C->hash_mask) {
        const double *q = C->pos + 3 * (size_t)C->hash[i];
        if (q[0] == p.x && q[1] == p.y && q[2] == p.z) return C->hash[i];
    }
    if (C->vertex_count >= CUT_VERTEX_LIMIT) C->failed = 1;
    if (!GROW(C, pos, vertex_cap, 3 * (C->vertex_count + 1))) return 0;
    double *q = C->pos + 3 * C->vertex_count;
    q[0] = p.x, q[1] = p.y, q[2] = p.z;
    C->hash[i] = (uint32_t)C->vertex_count;
    return (uint32_t)C->vertex_count++;
}

/* Signed distance of p inside the edge a->b of a convex polygon of unit
 * normal n (counter-clockwise about n): positive inside. */
static double inside_edge(rad_vec3 n, rad_vec3 a, rad_vec3 b, rad_vec3 p)
{
    rad_vec3 m = rad_v3_normalize(rad_v3_cross(n, rad_v3_sub(b, a)));
    return rad_v3_dot(m, rad_v3_sub(p, a));
}

/* Clips a + t (b - a), t in [*t0, *t1], to the convex polygon c[0..n-1]
 * (unit normal nrm); 0 when nothing is left. */
static int clip_to_polygon(rad_vec3 nrm, const rad_vec3 *c, uint32_t n, rad_vec3 a, rad_vec3 b, double tol, double *t0,
                           double *t1)
{
    for (uint32_t k = 0; k < n; k++) {
        double ha = inside_edge(nrm, c[k], c[(k + 1) % n], a), hb = inside_edge(nrm, c[k], c[(k + 1) % n], b);
        if (fabs(ha) <= tol) ha = 0;
        if (fabs(hb) <= tol) hb = 0;
        if (ha < 0 && hb < 0) return 0;
        if (ha < 0 && hb >= 0) *t0 = fmax(*t0, ha / (ha - hb));
        if (hb < 0 && ha >= 0) *t1 = fmin(*t1, ha / (ha - hb));
    }
    return *t1 > *t0;
}

static int boxes_meet(const rad_box *p, const rad_box *q, double tol)
{
    for (int a = 0; a < 3; a++)
        if (p->lo[a] > q->hi[a] + tol || q->lo[a] > p->hi[a] + tol) return 0;
    return 1;
}

/* Adds segment s (in F's plane) clipped to face f, unless it is short or
 * runs along f's boundary. */
static void add_segment(cutter *C, uint32_t f, segment s)
{
    const rad_face *F = &C->scene->faces[f];
    rad_vec3 c[4];
    for (uint32_t k = 0; k < F->vertex_count; k++) c[k] = face_corner(C, f, k);
    double t0 = 0, t1 = 1;
    if (!clip_to_polygon(C->normal[f], c, F->vertex_count, s.a, s.b, C->tol, &t0, &t1)) return;
    segment r = {rad_v3_lerp(s.a, s.b, t0), rad_v3_lerp(s.a, s.b, t1), t0 == 0 ? s.ia : RAD_NO_VERTEX,
                 t1 == 1 ? s.ib : RAD_NO_VERTEX};
    if (t0 == 0) r.a = s.a;
    if (t1 == 1) r.b = s.b;
    if (rad_v3_length(rad_v3_sub(r.b, r.a)) < C->min_length) return;
    for (uint32_t k = 0; k < F->vertex_count; k++) {
        rad_vec3 p = c[k], q = c[(k + 1) % F->vertex_count];
        if (fabs(inside_edge(C->normal[f], p, q, r.a)) <= C->tol && fabs(inside_edge(C->normal[f], p, q, r.b)) <= C->tol)
            return; /* along F's boundary */
    }
    if (!GROW(C, segs, seg_cap, C->seg_count + 1)) return;
    C->segs[C->seg_count++] = r;
}

/* Does p (in their plane) lie inside one of the faces list[0..count)? */
static int inside_any(const cutter *C, const uint32_t *list, size_t count, rad_vec3 p)
{
    for (size_t i = 0; i < count; i++) {
        uint32_t g = list[i];
        const rad_face *G = &C->scene->faces[g];
        int in = 1;
        for (uint32_t k = 0; k < G->vertex_count && in; k++)
            in = inside_edge(C->normal[g], face_corner(C, g, k), face_corner(C, g, (k + 1) % G->vertex_count), p) > C->tol;
        if (in) return 1;
    }
    return 0;
}

/* Where face g meets face f's plane: the segment it cuts there (added),
 * or, for a coplanar g facing the other way, its edges (and g noted as
 * opposite). */
static void meet(cutter *C, uint32_t f, uint32_t g)
{
    const rad_face *G = &C->scene->faces[g];
    rad_vec3 n = C->normal[f], p0 = face_corner(C, f, 0), q[4];
    double d[4];
    int pos = 0, neg = 0;
    for (uint32_t k = 0; k < G->vertex_count; k++) {
        q[k] = face_corner(C, g, k);
        d[k] = rad_v3_dot(n, rad_v3_sub(q[k], p0));
        if (fabs(d[k]) <= C->tol) d[k] = 0;
        pos += d[k] > 0, neg += d[k] < 0;
    }
    if (pos == 0 && neg == 0) {
        if (rad_v3_dot(n, C->normal[g]) >= 0) {
            /* Coplanar, same facing: side by side (a floor of two
             * triangles), or overlapping - one surface given twice, a
             * decal or a light panel snapped onto a wall. Where they
             * overlap, one wins: the smaller (the panel), the later on a
             * tie; f is cut along its outline and its pieces under it go
             * (otherwise the overlap is seen twice: rows of 1.13 in a
             * model with overlapping coplanar faces). Side by side, the
             * outline lies outside f or on its boundary and cuts nothing. */
            rad_vec3 centre_f, unused;
            double area_f = face_area(C, f, &centre_f), area_g = face_area(C, g, &unused);
            if (area_g > area_f || (area_g == area_f && g < f)) return;
            size_t segments_before = C->seg_count;
            for (uint32_t k = 0; k < G->vertex_count; k++) {
                uint32_t k1 = (k + 1) % G->vertex_count;
                add_segment(C, f, (segment){q[k], q[k1], G->v[k], G->v[k1]});
            }
            /* Overlapping: g's outline cuts f's inside, or f lies within g
             * (a face given twice). Side by side it does neither, and f is
             * left as it is (its grid vertices shared with its neighbours). */
            if (C->seg_count == segments_before && !inside_any(C, &g, 1, centre_f)) return;
            if (!GROW(C, covering, covering_cap, C->covering_count + 1)) return;
            C->covering[C->covering_count++] = g;
            return;
        }
        if (!GROW(C, opposite, opposite_cap, C->opposite_count + 1)) return;
        C->opposite[C->opposite_count++] = g;
        for (uint32_t k = 0; k < G->vertex_count; k++) {
            uint32_t k1 = (k + 1) % G->vertex_count;
            add_segment(C, f, (segment){q[k], q[k1], G->v[k], G->v[k1]});
        }
        return;
    }
    /* g parallel to f, facing the same way, a gap in front of f no wider
     * than RAD_CONTACT_GAP: f's region behind g (a light panel hung 1 cm
     * under a ceiling) is shut in. g's outline, moved onto f's plane, cuts
     * f; the inside test then finds the pieces behind g's back. */
    if (neg == 0 && pos == (int)G->vertex_count && rad_v3_dot(n, C->normal[g]) > 1.0 - 1e-9) {
        for (uint32_t k = 0; k < G->vertex_count; k++)
            if (d[k] > C->gap) return;
        for (uint32_t k = 0; k < G->vertex_count; k++) {
            uint32_t k1 = (k + 1) % G->vertex_count;
            add_segment(C, f, (segment){rad_v3_sub(q[k], rad_v3_scale(n, d[k])),
                                        rad_v3_sub(q[k1], rad_v3_scale(n, d[k1])), RAD_NO_VERTEX, RAD_NO_VERTEX});
        }
        return;
    }
    /* The points of g on the plane: its corners there and its edges' crossings. */
    rad_vec3 pt[8];
    uint32_t id[8];
    int m = 0;
    for (uint32_t k = 0; k < G->vertex_count; k++) {
        uint32_t k1 = (k + 1) % G->vertex_count;
        if (d[k] == 0) pt[m] = q[k], id[m++] = G->v[k];
        if ((d[k] < 0 && d[k1] > 0) || (d[k] > 0 && d[k1] < 0))
            pt[m] = rad_v3_lerp(q[k], q[k1], d[k] / (d[k] - d[k1])), id[m++] = RAD_NO_VERTEX;
    }
    int best_i = -1, best_j = -1;
    double best = 0;
    for (int i = 0; i < m; i++)
        for (int j = i + 1; j < m; j++) {
            double len = rad_v3_length(rad_v3_sub(pt[j], pt[i]));
            if (len > best) best = len, best_i = i, best_j = j;
        }
    if (best_i < 0) return;
    add_segment(C, f, (segment){pt[best_i], pt[best_j], id[best_i], id[best_j]});
}

static int new_piece(cutter *C, const uint32_t *v, const uint64_t *line, uint32_t n)
{
    if (!GROW(C, pool, pool_cap, C->pool_count + n) || !GROW(C, line, line_cap, C->pool_count + n) ||
        !GROW(C, pieces, piece_cap, C->piece_count + 1))
        return 0;
    memcpy(C->pool + C->pool_count, v, n * sizeof *v);
    memcpy(C->line + C->pool_count, line, n * sizeof *line);
    C->pieces[C->piece_count++] = (piece){C->pool_count, n, 1};
    C->pool_count += n;
    return 1;
}

/* The two points that define line l (line_of). */
static void line_points(const cutter *C, uint64_t l, rad_vec3 *p, rad_vec3 *q)
{
    if (l >> 32 == 0xFFFFFFFF) {
        *p = C->segs[l & 0xFFFFFFFF].a, *q = C->segs[l & 0xFFFFFFFF].b;
        return;
    }
    *p = vertex(C, (uint32_t)(l >> 32)), *q = vertex(C, (uint32_t)l);
}

/* Splits every live piece of face f that segment si passes through along
 * the segment's line. Each piece edge knows the line it lies on, and the
 * split point on it is where that line meets the segment's line, computed
 * from the two lines only: pieces that share the line (not necessarily
 * the edge) get the same point, bit for bit. */
static void split_pieces(cutter *C, uint32_t f, uint32_t si)
{
    const segment *s = &C->segs[si];
    rad_vec3 n = C->normal[f];
    rad_vec3 m = rad_v3_normalize(rad_v3_cross(n, rad_v3_sub(s->b, s->a)));
    size_t count = C->piece_count;
    for (size_t p = 0; p < count && !C->failed; p++) {
        if (!C->pieces[p].live) continue;
        uint32_t k, cn = C->pieces[p].n, v[PIECE_SPLIT_MAX];
        uint64_t e[PIECE_SPLIT_MAX], cut_line = SEGMENT_LINE(si);
        if (cn > PIECE_SPLIT_MAX) continue; /* far more than contacts make; left whole */
        memcpy(v, C->pool + C->pieces[p].start, cn * sizeof *v);
        memcpy(e, C->line + C->pieces[p].start, cn * sizeof *e);
        double side[PIECE_SPLIT_MAX];
        rad_vec3 c[PIECE_SPLIT_MAX];
        int pos = 0, neg = 0;
        for (k = 0; k < cn; k++) {
            c[k] = vertex(C, v[k]);
            side[k] = rad_v3_dot(m, rad_v3_sub(c[k], s->a));
            if (fabs(side[k]) <= C->tol) side[k] = 0;
            pos += side[k] > 0, neg += side[k] < 0;
        }
        if (!pos || !neg) continue;
        /* A convex piece changes side at most twice along its boundary; more
         * changes are rounding (sides within a hair of tol) and would put up
         * to 2 cn vertices into left and right: leave such a piece whole. */
        int changes = 0;
        for (k = 0; k < cn; k++) {
            double here = side[k], next = side[(k + 1) % cn];
            changes += (here > 0 && next < 0) || (here < 0 && next > 0);
        }
        if (changes > 2) continue;
        double t0 = 0, t1 = 1;
        if (!clip_to_polygon(n, c, cn, s->a, s->b, 0, &t0, &t1) ||
            (t1 - t0) * rad_v3_length(rad_v3_sub(s->b, s->a)) <= C->tol)
            continue; /* the line crosses the piece, the segment does not */
        uint32_t left[PIECE_CORNER_MAX], right[PIECE_CORNER_MAX], nl = 0, nr = 0;
        uint64_t left_line[PIECE_CORNER_MAX], right_line[PIECE_CORNER_MAX];
        for (k = 0; k < cn && !C->failed; k++) {
            uint32_t k1 = (k + 1) % cn;
            if (side[k] >= 0) left[nl] = v[k], left_line[nl++] = side[k] == 0 && side[k1] < 0 ? cut_line : e[k];
            if (side[k] <= 0) right[nr] = v[k], right_line[nr++] = side[k] == 0 && side[k1] > 0 ? cut_line : e[k];
            if ((side[k] > 0 && side[k1] < 0) || (side[k] < 0 && side[k1] > 0)) {
                rad_vec3 P, Q;
                line_points(C, e[k], &P, &Q);
                double den = rad_v3_dot(m, rad_v3_sub(Q, P));
                rad_vec3 x = den != 0 ? rad_v3_lerp(P, Q, rad_v3_dot(m, rad_v3_sub(s->a, P)) / den)
                                      : rad_v3_lerp(c[k], c[k1], side[k] / (side[k] - side[k1]));
                uint32_t id;
                if (rad_v3_length(rad_v3_sub(x, s->a)) <= C->tol)
                    id = s->ia != RAD_NO_VERTEX ? s->ia : cut_vertex(C, s->a);
                else if (rad_v3_length(rad_v3_sub(x, s->b)) <= C->tol)
                    id = s->ib != RAD_NO_VERTEX ? s->ib : cut_vertex(C, s->b);
                else
                    id = cut_vertex(C, x);
                left[nl] = id, left_line[nl++] = side[k] > 0 ? cut_line : e[k];
                right[nr] = id, right_line[nr++] = side[k] > 0 ? e[k] : cut_line;
            }
        }
        if (C->failed) return;
        C->pieces[p].live = 0;
        if (nl >= 3 && !new_piece(C, left, left_line, nl)) return;
        if (nr >= 3 && !new_piece(C, right, right_line, nr)) return;
    }
}

/* Area and area centroid of the convex polygon v[0..n-1] (unit normal nrm). */
static double polygon_area(const cutter *C, const uint32_t *v, uint32_t n, rad_vec3 nrm, rad_vec3 *out_centroid)
{
    rad_vec3 o = vertex(C, v[0]), sum = rad_v3(0, 0, 0);
    double area = 0;
    for (uint32_t k = 1; k + 1 < n; k++) {
        rad_vec3 b = vertex(C, v[k]), c = vertex(C, v[k + 1]);
        double a = 0.5 * rad_v3_dot(rad_v3_cross(rad_v3_sub(b, o), rad_v3_sub(c, o)), nrm);
        sum = rad_v3_add(sum, rad_v3_scale(rad_v3_add(rad_v3_add(o, b), c), a / 3));
        area += a;
    }
    *out_centroid = area > 0 ? rad_v3_scale(sum, 1 / area) : o;
    return area;
}

/* A ray of inside_solid on its walk through the grid. */
typedef struct solid_ray {
    const cutter *C;
    uint32_t f;
    rad_vec3 p, dir;
    double nearest;
    int nearest_back;
} solid_ray;

/* The faces of one cell: the nearest hit so far; done once it lies in a
 * cell already walked. */
static int solid_ray_cell(void *user, const uint32_t *faces, uint32_t count, double t_exit)
{
    solid_ray *r = user;
    const cutter *C = r->C;
    for (uint32_t i = 0; i < count; i++) {
        const uint32_t g = faces[i];
        if (g == r->f) continue;
        const rad_face *G = &C->scene->faces[g];
        rad_vec3 ng = C->normal[g], q0 = face_corner(C, g, 0);
        double den = rad_v3_dot(ng, r->dir);
        if (fabs(den) < 1e-12) continue;
        double t = rad_v3_dot(ng, rad_v3_sub(q0, r->p)) / den;
        if (!(t > 0) || t >= r->nearest) continue;
        rad_vec3 h = rad_v3_add(r->p, rad_v3_scale(r->dir, t));
        int in = 1;
        for (uint32_t k = 0; k < G->vertex_count && in; k++)
            in = inside_edge(ng, face_corner(C, g, k), face_corner(C, g, (k + 1) % G->vertex_count), h) >= -C->tol;
        if (in) r->nearest = t, r->nearest_back = den > 0;
    }
    return r->nearest <= t_exit;
}

/* Is p, a point just off face f, inside a solid: do most rays into the
 * hemisphere about n first hit a back face? */
static int inside_solid(const cutter *C, uint32_t f, rad_vec3 p, rad_vec3 n)
{
    rad_vec3 t1 = rad_v3_normalize(rad_v3_cross(n, fabs(n.x) < 0.6 ? rad_v3(1, 0, 0) : rad_v3(0, 1, 0)));
    rad_vec3 t2 = rad_v3_cross(n, t1);
    int back = 0;
    for (int r = 0; r < RAD_CONTACT_RAYS; r++) {
        rad_vec3 dir = n;
        if (r > 0) {
            double phi = TWO_PI * (r - 1) / (RAD_CONTACT_RAYS - 1) + 0.3; /* off the axes */
            rad_vec3 t = rad_v3_add(rad_v3_scale(t1, cos(phi)), rad_v3_scale(t2, sin(phi)));
            dir = rad_v3_add(rad_v3_scale(n, cos(INSIDE_RAY_ANGLE)), rad_v3_scale(t, sin(INSIDE_RAY_ANGLE)));
        }
        solid_ray ray = {.C = C, .f = f, .p = p, .dir = dir, .nearest = INFINITY, .nearest_back = 0};
        const double o[3] = {p.x, p.y, p.z}, d[3] = {dir.x, dir.y, dir.z};
        rad_face_grid_ray(&C->grid, o, d, solid_ray_cell, &ray);
        back += ray.nearest < INFINITY && ray.nearest_back;
    }
    return 2 * back > RAD_CONTACT_RAYS;
}

static int pressed(const cutter *C, rad_vec3 p)
{
    return inside_any(C, C->opposite, C->opposite_count, p);
}

static void emit(cutter *C, uint32_t f, const uint32_t *v, uint32_t n)
{
    if (!GROW(C, out, out_cap, C->out_count + 1)) return;
    rad_contact_piece *o = &C->out[C->out_count++];
    o->vertex_count = n;
    o->source_face = f;
    rad_polygon_corners_store(v, n, o->v);
}

/* Tidies piece v[0..n-1] of face f, drops it when empty or hidden, and
 * emits it as 3-4-gons. */
static void finish_piece(cutter *C, uint32_t f, double diameter, int has_contact, uint32_t *v, uint32_t n)
{
    rad_vec3 nrm = C->normal[f];
    for (int changed = 1; changed && n >= 3;) {
        changed = 0;
        for (uint32_t k = 0; k < n && n >= 3; k++) {
            rad_vec3 a = vertex(C, v[(k + n - 1) % n]), b = vertex(C, v[k]), c = vertex(C, v[(k + 1) % n]);
            rad_vec3 ac = rad_v3_sub(c, a);
            double len = rad_v3_length(ac);
            int drop = v[k] == v[(k + n - 1) % n] ||
                       (len > 0 && fabs(rad_v3_dot(rad_v3_cross(nrm, ac), rad_v3_sub(b, a))) / len <= C->tol);
            if (drop) {
                memmove(v + k, v + k + 1, (n - k - 1) * sizeof *v);
                n--, changed = 1;
            }
        }
    }
    if (n < 3) return;
    rad_vec3 centroid;
    if (polygon_area(C, v, n, nrm, &centroid) <= AREA_TOL * diameter * diameter) return;
    if (has_contact && inside_any(C, C->covering, C->covering_count, centroid)) {
        C->hidden++;
        return;
    }
    const size_t out_begin = C->out_count;
    for (uint32_t i = 1; i + 1 < n;) {
        if (i + 2 < n) {
            uint32_t q[4] = {v[0], v[i], v[i + 1], v[i + 2]};
            emit(C, f, q, 4);
            i += 2;
        } else {
            uint32_t t[3] = {v[0], v[i], v[i + 1]};
            emit(C, f, t, 3);
            i += 1;
        }
    }
    if (has_contact && !C->failed) { /* hidden if inside a solid: decided by resolve_solid_checks */
        if (!GROW(C, checks, check_cap, C->check_count + 1)) return;
        C->checks[C->check_count++] = (solid_check){.centroid = centroid, .normal = nrm, .face = f,
                                                    .pressed = (uint8_t)pressed(C, centroid),
                                                    .out_begin = out_begin, .out_end = C->out_count};
    }
}

/* The inside tests finish_piece left, on the threads; the pieces found
 * inside a solid taken out of C->out, the rest kept in order: the pieces
 * and the count of hidden ones as the tests made in turn gave them. */
static void resolve_solid_checks(cutter *C)
{
    const ptrdiff_t count = (ptrdiff_t)C->check_count;
#pragma omp parallel for schedule(dynamic, 16)
    for (ptrdiff_t k = 0; k < count; k++) {
        solid_check *s = &C->checks[k];
        const rad_vec3 c = s->centroid, n = s->normal, d = rad_v3_scale(n, C->offset);
        s->hidden = (uint8_t)((s->pressed && inside_solid(C, s->face, rad_v3_sub(c, d), rad_v3_scale(n, -1))) ||
                              inside_solid(C, s->face, rad_v3_add(c, d), n));
    }
    size_t to = 0, k = 0;
    for (size_t i = 0; i < C->out_count; i++) {
        while (k < C->check_count && C->checks[k].out_end <= i) k++;
        if (k < C->check_count && C->checks[k].out_begin <= i && C->checks[k].hidden) continue;
        C->out[to++] = C->out[i];
    }
    for (size_t j = 0; j < C->check_count; j++) C->hidden += C->checks[j].hidden;
    C->out_count = to;
}

/* rad_polygon_vertex_fn of the grid: a new vertex is the cut vertex at its
 * position (one per position, so the same as rad_mesh's one per edge). */
static uint32_t grid_vertex(void *context, uint32_t a, uint32_t b, rad_vec3 at)
{
    (void)a, (void)b;
    return cut_vertex(context, at);
}

/* The face's grid: polygon v split `level` more times as rad_mesh splits
 * faces (rad_polygon_split: the same midpoints and centres, bit for bit),
 * as live pieces. */
static void grid(cutter *C, const uint32_t *v, uint32_t n, int level)
{
    if (C->failed) return;
    if (level == 0) {
        uint64_t line[4];
        for (uint32_t k = 0; k < n; k++) line[k] = edge_line(v[k], v[(k + 1) % n]);
        new_piece(C, v, line, n);
        return;
    }
    rad_vec3 corner[4];
    uint32_t child[4][4];
    for (uint32_t k = 0; k < n; k++) corner[k] = vertex(C, v[k]);
    rad_polygon_split(v, corner, (int)n, grid_vertex, C, child);
    for (int i = 0; i < 4; i++) grid(C, child[i], n, level - 1);
}

/* Counts g as a near miss of f (rad_contact_cut.near_count). */
static void near_miss(cutter *C, uint32_t f, uint32_t g)
{
    const rad_face *G = &C->scene->faces[g];
    rad_vec3 n = C->normal[f], p0 = face_corner(C, f, 0), centre = rad_v3(0, 0, 0);
    if (!(rad_v3_dot(n, C->normal[g]) > 1.0 - 1e-9)) return;
    double far = 0;
    for (uint32_t k = 0; k < G->vertex_count; k++) {
        rad_vec3 q = face_corner(C, g, k);
        double d = rad_v3_dot(n, rad_v3_sub(q, p0));
        if (!(d > C->gap) || d > C->near) return;
        far = fmax(far, d);
        centre = rad_v3_add(centre, rad_v3_scale(q, 1.0 / G->vertex_count));
    }
    if (!inside_any(C, &f, 1, centre)) return;
    if (C->near_count++ == 0) C->near_face = f, C->near_cover = g, C->near_distance = far;
}

/* near_miss's first tests (parallel, same facing; g's first corner
 * between the gap and `near` in front of f), which it returns on. */
static int may_near_miss(const cutter *C, uint32_t f, uint32_t g)
{
    if (!(rad_v3_dot(C->normal[f], C->normal[g]) > 1.0 - 1e-9)) return 0;
    const double d = rad_v3_dot(C->normal[f], rad_v3_sub(face_corner(C, g, 0), face_corner(C, f, 0)));
    return d > C->gap && d <= C->near && boxes_meet(&C->box[f], &C->box[g], C->near);
}

/* Near misses come only from parallel faces (normals within 4.5e-5 of
 * each other: |n - m|^2 = 2 - 2 n.m < 2e-9) whose planes lie between the gap
 * and `near` apart. Those are found in an index, not in the grid: the grid
 * would have to list every face in every cell within `near` of it (a
 * hundred times the cells at 10^6 faces, and every face of a dense object
 * in each). Normals fall in bins of NEAR_BIN per component, so two parallel
 * faces' bins differ by at most one in each; within a bin the faces go by
 * their first corner's offset along the bin's direction, which strays from
 * the offset along a face's own normal by at most near_slack. */
#define NEAR_BIN 1e-4
#define NEAR_BIN_BIAS ((int64_t)1 << 20) /* bin numbers (|n| <= 2: within 20 001) made positive, 21 bits each */

static int near_bin_of(rad_vec3 n, int64_t out[3])
{
    const double c[3] = {n.x, n.y, n.z};
    for (int a = 0; a < 3; a++) {
        if (!(fabs(c[a]) <= 2.0)) return 0; /* not a normal: no near miss can be found for it */
        out[a] = (int64_t)floor(c[a] / NEAR_BIN);
    }
    return 1;
}

static uint64_t near_bin_key(const int64_t b[3])
{
    return (uint64_t)(b[0] + NEAR_BIN_BIAS) << 42 | (uint64_t)(b[1] + NEAR_BIN_BIAS) << 21 | (uint64_t)(b[2] + NEAR_BIN_BIAS);
}

/* The bin's direction: its centre. */
static rad_vec3 near_bin_direction(const int64_t b[3])
{
    return rad_v3((b[0] + 0.5) * NEAR_BIN, (b[1] + 0.5) * NEAR_BIN, (b[2] + 0.5) * NEAR_BIN);
}

static double near_offset(const cutter *C, rad_vec3 direction, uint32_t f)
{
    return rad_v3_dot(direction, rad_v3_sub(face_corner(C, f, 0), C->centre));
}

static int near_entry_order(const void *a, const void *b)
{
    const near_entry *x = a, *y = b;
    if (x->bin != y->bin) return x->bin < y->bin ? -1 : 1;
    if (x->offset != y->offset) return x->offset < y->offset ? -1 : 1;
    return (x->face > y->face) - (x->face < y->face);
}

static rad_status near_index_build(cutter *C, uint32_t face_count, double diameter)
{
    C->near_index = malloc((face_count ? face_count : 1) * sizeof *C->near_index);
    if (!C->near_index) return RAD_ERR_NOMEM;
    size_t m = 0;
    for (uint32_t f = 0; f < face_count; f++) {
        int64_t b[3];
        if (!near_bin_of(C->normal[f], b)) continue;
        C->near_index[m++] = (near_entry){.bin = near_bin_key(b), .offset = near_offset(C, near_bin_direction(b), f),
                                          .face = f};
    }
    C->near_index_count = m;
    qsort(C->near_index, m, sizeof *C->near_index, near_entry_order);
    /* A face's normal and a neighbouring bin's direction differ by at most
     * 1.5 NEAR_BIN per component (2.6 NEAR_BIN in all); two first corners
     * lie within the diameter of each other. */
    C->near_slack = 3.0 * NEAR_BIN * diameter + 1e-9 * diameter;
    return RAD_OK;
}

/* The first entry of bin `key` with offset >= at (the bin's end if none). */
static size_t near_lower(const cutter *C, uint64_t key, double at)
{
    size_t lo = 0, hi = C->near_index_count;
    while (lo < hi) {
        const size_t mid = lo + (hi - lo) / 2;
        const near_entry *e = &C->near_index[mid];
        if (e->bin < key || (e->bin == key && e->offset < at)) lo = mid + 1;
        else hi = mid;
    }
    return lo;
}

/* Adds to C->cand the faces not stamped yet that may be near misses of f
 * (may_near_miss), stamping them. */
static void near_candidates(cutter *C, uint32_t f)
{
    int64_t b[3];
    if (!near_bin_of(C->normal[f], b)) return;
    for (int dz = -1; dz <= 1; dz++)
        for (int dy = -1; dy <= 1; dy++)
            for (int dx = -1; dx <= 1; dx++) {
                const int64_t nb[3] = {b[0] + dx, b[1] + dy, b[2] + dz};
                const uint64_t key = near_bin_key(nb);
                const double at = near_offset(C, near_bin_direction(nb), f);
                const double from = at + C->gap - C->near_slack, to = at + C->near + C->near_slack;
                for (size_t i = near_lower(C, key, from); i < C->near_index_count; i++) {
                    const near_entry *e = &C->near_index[i];
                    if (e->bin != key || e->offset > to) break;
                    const uint32_t g = e->face;
                    if (C->stamp[g] == C->stamp_now || !may_near_miss(C, f, g)) continue;
                    C->stamp[g] = C->stamp_now;
                    if (!GROW(C, cand, cand_cap, C->cand_count + 1)) return;
                    C->cand[C->cand_count++] = g;
                }
            }
}

static int ascending(const void *a, const void *b)
{
    const uint32_t x = *(const uint32_t *)a, y = *(const uint32_t *)b;
    return (x > y) - (x < y);
}

/* C->cand: the faces cut_face's loops act on - boxes within the gap of
 * f's (from the grid), or parallel and within `near` (from the grid, and
 * the rest from the index of parallel faces) - once each, ascending (what
 * a loop over every face would reach, in its order). */
static void near_faces(cutter *C, uint32_t f)
{
    uint32_t lo[3], hi[3];
    rad_face_grid_cells(&C->grid, &C->box[f], lo, hi);
    C->cand_count = 0;
    C->stamp_now++;
    for (uint32_t z = lo[2]; z <= hi[2]; z++)
        for (uint32_t y = lo[1]; y <= hi[1]; y++)
            for (uint32_t x = lo[0]; x <= hi[0]; x++) {
                uint32_t count;
                const uint32_t *faces = rad_face_grid_cell(&C->grid, x, y, z, &count);
                for (uint32_t i = 0; i < count; i++) {
                    const uint32_t g = faces[i];
                    if (C->stamp[g] == C->stamp_now) continue;
                    C->stamp[g] = C->stamp_now;
                    /* what cut_face's two loops act on: a face within the gap (meet),
                     * or a parallel one within `near` (near_miss looks at no other) */
                    if (!boxes_meet(&C->box[f], &C->box[g], C->gap) && !may_near_miss(C, f, g)) continue;
                    if (!GROW(C, cand, cand_cap, C->cand_count + 1)) return;
                    C->cand[C->cand_count++] = g;
                }
            }
    near_candidates(C, f);
    qsort(C->cand, C->cand_count, sizeof *C->cand, ascending);
}

/* What cuts face f: the segments, opposite and covering faces its
 * neighbours make (meet), and its near misses counted. Reads the scene
 * and writes only C's scratch and near counters: rad_contact_cut_build
 * runs it on the threads, each with a cutter of its own. */
static void survey_face(cutter *C, uint32_t f)
{
    C->seg_count = C->opposite_count = C->covering_count = 0;
    near_faces(C, f);
    for (size_t i = 0; i < C->cand_count && !C->failed; i++) {
        const uint32_t g = C->cand[i];
        if (g != f && boxes_meet(&C->box[f], &C->box[g], C->gap)) meet(C, f, g);
    }
    for (size_t i = 0; i < C->cand_count && !C->failed; i++) {
        const uint32_t g = C->cand[i];
        if (g != f && boxes_meet(&C->box[f], &C->box[g], C->near)) near_miss(C, f, g);
    }
}

static int surveyed_cut(const cutter *C) { return C->seg_count || C->opposite_count || C->covering_count; }

/* Face f surveyed again (its near misses counted already) and cut. */
static void cut_face(cutter *C, uint32_t f)
{
    const rad_face *F = &C->scene->faces[f];
    const size_t near_count = C->near_count;
    const uint32_t near_face = C->near_face, near_cover = C->near_cover;
    const double near_distance = C->near_distance;
    survey_face(C, f);
    C->near_count = near_count, C->near_face = near_face, C->near_cover = near_cover;
    C->near_distance = near_distance;
    C->pool_count = C->piece_count = 0;
    if (C->failed) return;
    double diameter = rad_box_diagonal(&C->box[f]);
    if (!surveyed_cut(C)) {
        emit(C, f, F->v, F->vertex_count);
        return;
    }
    C->faces_cut += C->seg_count > 0;
    int level = C->face_level ? C->face_level[f] : 0;
    grid(C, F->v, F->vertex_count, level < RAD_CONTACT_GRID_MAX ? level : RAD_CONTACT_GRID_MAX);
    if (C->failed) return;
    for (size_t s = 0; s < C->seg_count && !C->failed; s++) split_pieces(C, f, (uint32_t)s);
    for (size_t p = 0; p < C->piece_count && !C->failed; p++) {
        if (!C->pieces[p].live) continue;
        uint32_t v[PIECE_CORNER_MAX], n = C->pieces[p].n;
        if (n > PIECE_CORNER_MAX) {
            emit(C, f, F->v, F->vertex_count); /* cannot happen: split_pieces leaves such pieces whole */
            continue;
        }
        memcpy(v, C->pool + C->pieces[p].start, n * sizeof *v);
        finish_piece(C, f, diameter, 1, v, n);
    }
}

/* survey_face's scratch (near_faces' and meet's), freed. */
static void survey_scratch_free(cutter *C)
{
    free(C->stamp);
    free(C->cand);
    free(C->segs);
    free(C->opposite);
    free(C->covering);
}

/* Every face surveyed on the threads (the work of all but the few faces
 * that are cut), each thread with a cutter of its own sharing the scene's
 * read-only tables: C->cut per face, and C's near misses as the faces in
 * order would have counted them (the count, and the first one's faces and
 * distance). The cut faces are then cut in order on one thread, as
 * before: the same pieces and vertex numbers for any thread count. */
static rad_status survey_faces(cutter *C, uint32_t nf)
{
    C->cut = calloc(nf ? nf : 1, 1);
    uint32_t *near_count = calloc(nf ? nf : 1, sizeof *near_count);
    uint32_t *near_cover = malloc((nf ? nf : 1) * sizeof *near_cover);
    double *near_distance = malloc((nf ? nf : 1) * sizeof *near_distance);
    int failed = !C->cut || !near_count || !near_cover || !near_distance;
    if (!failed) {
#pragma omp parallel reduction(| : failed)
        {
            cutter T = *C; /* the shared tables; survey_face's scratch of its own (none of C's made yet) */
            T.stamp = calloc(nf ? nf : 1, sizeof *T.stamp);
            T.failed = !T.stamp;
#pragma omp for schedule(dynamic, 1024)
            for (uint32_t f = 0; f < nf; f++) {
                if (T.failed) continue;
                T.near_count = 0;
                survey_face(&T, f);
                C->cut[f] = (uint8_t)surveyed_cut(&T);
                near_count[f] = (uint32_t)T.near_count;
                if (T.near_count) near_cover[f] = T.near_cover, near_distance[f] = T.near_distance;
            }
            failed |= T.failed;
            survey_scratch_free(&T);
        }
    }
    if (!failed) {
        for (uint32_t f = 0; f < nf; f++) {
            if (!near_count[f]) continue;
            if (C->near_count == 0)
                C->near_face = f, C->near_cover = near_cover[f], C->near_distance = near_distance[f];
            C->near_count += near_count[f];
        }
    }
    free(near_count);
    free(near_cover);
    free(near_distance);
    return failed ? RAD_ERR_NOMEM : RAD_OK;
}

rad_status rad_contact_cut_build(const rad_scene *scene, const int *face_level, rad_contact_cut *out_cut)
{
    cutter C;
    memset(&C, 0, sizeof C);
    C.scene = scene;
    C.face_level = face_level;
    rad_status status = RAD_ERR_NOMEM;
    size_t nf = scene->face_count;
    C.normal = malloc((nf ? nf : 1) * sizeof *C.normal);
    C.box = malloc((nf ? nf : 1) * sizeof *C.box);
    C.vertex_cap = 3 * (scene->vertex_count + 16);
    C.pos = malloc(C.vertex_cap * sizeof *C.pos);
    if (!C.normal || !C.box || !C.pos) goto done;
    memcpy(C.pos, scene->positions, 3 * scene->vertex_count * sizeof *C.pos);
    C.vertex_count = scene->vertex_count;
#pragma omp parallel for schedule(static)
    for (uint32_t f = 0; f < nf; f++) {
        const rad_face *F = &scene->faces[f];
        rad_vec3 c[4], centroid;
        double area;
        for (uint32_t k = 0; k < F->vertex_count; k++) c[k] = face_corner(&C, f, k);
        rad_polygon_geometry(c, (int)F->vertex_count, &area, &C.normal[f], &centroid);
        C.box[f] = rad_box_of_corners(C.pos, F->v, F->vertex_count);
    }
    rad_box scene_box = rad_box_empty(); /* of the faces' vertices (unused ones left out): their boxes' corners */
    for (uint32_t f = 0; f < nf; f++) {
        rad_box_add(&scene_box, C.box[f].lo);
        rad_box_add(&scene_box, C.box[f].hi);
    }
    double scene_diameter = rad_box_diagonal(&scene_box);
    C.tol = RAD_CONTACT_TOL * scene_diameter;
    C.gap = RAD_CONTACT_GAP * scene_diameter;
    C.near = RAD_CONTACT_NEAR * scene_diameter;
    C.min_length = RAD_CONTACT_MIN_LENGTH * scene_diameter;
    C.offset = RAD_CONTACT_OFFSET * scene_diameter;
    C.centre = rad_v3(0.5 * (scene_box.lo[0] + scene_box.hi[0]), 0.5 * (scene_box.lo[1] + scene_box.hi[1]),
                      0.5 * (scene_box.lo[2] + scene_box.hi[2]));
    C.stamp = calloc(nf ? nf : 1, sizeof *C.stamp);
    /* the grid's margin a tolerance over the gap: boxes_meet(gap) rounds
     * differently from the grid's placement, by an ulp */
    if (!C.stamp || rad_face_grid_build(C.box, (uint32_t)nf, C.gap + C.tol, &C.grid) != RAD_OK ||
        near_index_build(&C, (uint32_t)nf, scene_diameter) != RAD_OK)
        goto done;
    if (survey_faces(&C, (uint32_t)nf) != RAD_OK) goto done;
    for (uint32_t f = 0; f < nf && !C.failed; f++) {
        if (C.cut[f]) {
            cut_face(&C, f);
        } else {
            const rad_face *F = &scene->faces[f];
            emit(&C, f, F->v, F->vertex_count);
        }
    }
    if (C.failed) goto done;
    resolve_solid_checks(&C);
    double *shrunk = realloc(C.pos, (C.vertex_count ? C.vertex_count : 1) * 3 * sizeof *shrunk);
    if (shrunk) C.pos = shrunk;
    *out_cut = (rad_contact_cut){.positions = C.pos, .vertex_count = C.vertex_count, .pieces = C.out,
                                 .piece_count = C.out_count, .faces_cut = C.faces_cut, .pieces_hidden = C.hidden,
                                 .near_count = C.near_count, .near_face = C.near_face, .near_cover = C.near_cover,
                                 .near_distance = C.near_distance, .gap = C.gap};
    C.pos = NULL;
    C.out = NULL;
    status = RAD_OK;
done:
    if (status != RAD_OK)
        rad_error("contacts: out of memory cutting %zu faces (%zu cut vertices, %zu pieces so far)", nf,
                  C.vertex_count, C.out_count);
    free(C.normal);
    free(C.box);
    survey_scratch_free(&C);
    rad_face_grid_free(&C.grid);
    free(C.near_index);
    free(C.cut);
    free(C.pos);
    free(C.pool);
    free(C.line);
    free(C.hash);
    free(C.pieces);
    free(C.checks);
    free(C.out);
    return status;
}

void rad_contact_cut_free(rad_contact_cut *cut)
{
    if (!cut) return;
    free(cut->positions);
    free(cut->pieces);
    memset(cut, 0, sizeof *cut);
}
