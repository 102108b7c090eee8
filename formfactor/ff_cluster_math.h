/* ff_cluster_math.h - the math of a pair with a cluster at an end, written
 * once for the CPU and the GPU (RAD_HD): the bounds a link is weighed by
 * (ff_clusters.h tells what they mean), a root drawn by area, the drawing
 * of a pair's shadow segments (ff_cluster_draw) and its coupling and
 * errors once they are traced (ff_cluster_couple), which both backends'
 * cluster_draws run (ff_backend.h).
 *
 *     ff_cluster_view v = {clusters, roots, area_before, patches, counts, cone, delta};
 *     ff_cluster_drawn o;
 *     ff_cluster_pair(&v, bvh nodes, tris, root, root_count, a, b, &o);
 *     // = ff_cluster_draw (o.rays segments), ff_bvh_occluded_cached on each
 *     //   (o.blocked), ff_cluster_couple (o.coupling, o.error_ab, o.error_ba)
 */
#ifndef FF_CLUSTER_MATH_H
#define FF_CLUSTER_MATH_H

#include <math.h>
#include <stdint.h>

#include "ff_bvh.h"
#include "rad_ff_kernel.h"
#include "rad_links.h"
#include "rad_math.h"

/* The geometry a link between clusters or elements is bounded with. */
typedef struct ff_cluster_bound {
    rad_vec3 centre;
    double radius;     /* every point of every face lies within it of centre */
    double area;       /* S */
    rad_vec3 vector_area; /* V */
    rad_vec3 axis;     /* unit; every face normal within cone_angle of it */
    double cone_angle; /* radians, in [0, pi] */
    double moment[6];  /* M = sum A n n^T: xx, yy, zz, xy, xz, yz */
    float open_lo, open_hi; /* the least and largest openness of its faces (ff_openness.h); 1, 1 for an element */
} ff_cluster_bound;

typedef struct ff_cluster {
    rad_link_cluster link; /* parent, children, root range, area: what the file stores */
    ff_cluster_bound bound;
} ff_cluster;

/* The unoccluded coupling between two bounds r and s (clusters, or an
 * element and a cluster), and per direction the range that the factor from
 * any point of r's faces to s can take, visibility aside:
 *   coupling = P_r(w) P_s(-w) / (S_r S_s pi d^2), w the unit vector from r's
 *              centre to s's, d their distance (F_rs = coupling S_s);
 *   lo_rs, hi_rs: cos_x P_s / (pi d^2) at its least and largest over the
 *              faces' normals, the directions and the distances the two
 *              spheres allow (hi at most 1; infinite where the spheres meet).
 * facing 0: no face of r can face s, or none of s r (no link). */
typedef struct ff_cluster_pair_bound {
    double coupling;
    double lo_rs, hi_rs, lo_sr, hi_sr;
    int facing;
} ff_cluster_pair_bound;

/* Pair ids: elements are 0 .. 2^31 - 1, cluster c is FF_CLUSTER_ID(c). */
#define FF_CLUSTER_BIT 0x80000000u
#define FF_CLUSTER_ID(c) (FF_CLUSTER_BIT | (uint32_t)(c))
static inline RAD_HD int ff_is_cluster(uint32_t id) { return (id & FF_CLUSTER_BIT) != 0; }
static inline RAD_HD uint32_t ff_cluster_of(uint32_t id) { return id & ~FF_CLUSTER_BIT; }

/* Shadow segments per link with a cluster at an end. */
#define FF_CLUSTER_RAYS 8u

/* A cluster link is made only between ends whose bounding spheres' radii
 * sum to less than this fraction of their centres' distance: nearer, the
 * bounds say nothing (their distance goes to 0). Between, the oracle
 * weighs the bounds' error. */
#define FF_CLUSTER_ADMISSIBLE 0.9

/* One element's bound (a cluster of one face). */
static inline RAD_HD ff_cluster_bound ff_element_bound(const rad_ff_patch *p)
{
    ff_cluster_bound b;
    b.centre = p->centre;
    b.radius = p->radius;
    b.area = p->area;
    b.vector_area = rad_v3_scale(p->normal, p->area);
    b.axis = p->normal;
    b.cone_angle = 0;
    b.open_lo = b.open_hi = 1.0f;
    rad_vec3 n = p->normal;
    const double A = p->area;
    b.moment[0] = A * n.x * n.x, b.moment[1] = A * n.y * n.y, b.moment[2] = A * n.z * n.z;
    b.moment[3] = A * n.x * n.y, b.moment[4] = A * n.x * n.z, b.moment[5] = A * n.y * n.z;
    return b;
}

/* The area b shows towards directions within beta of the unit w: an
 * estimate and bounds (ff_clusters.h), and the range of cos between a
 * face's normal and those directions. */
typedef struct ff_shown_area {
    double est, lo, hi, cos_lo, cos_hi;
} ff_shown_area;

static inline RAD_HD ff_shown_area ff_cluster_shown_towards(const ff_cluster_bound *b, rad_vec3 w, double beta)
{
    ff_shown_area a;
    double theta = acos(fmax(-1.0, fmin(1.0, rad_v3_dot(b->axis, w))));
    double widest = theta + b->cone_angle + beta, narrowest = theta - b->cone_angle - beta;
    a.cos_hi = narrowest <= 0 ? 1.0 : cos(narrowest);
    a.cos_lo = widest >= RAD_PI ? -1.0 : cos(widest);
    double vw = rad_v3_dot(b->vector_area, w), S = b->area;
    /* Each point sees the faces from its own direction, within beta of w:
     * sum A n.w(y) lies within S beta of V.w (not |V| beta: the faces'
     * normals may disagree, and each face takes its own worst direction). */
    double slack = S * beta;
    a.hi = a.cos_hi <= 0 ? 0.0 : fmin(S * a.cos_hi, 0.5 * (vw + slack + S));
    a.lo = a.cos_lo >= 0 ? fmax(S * a.cos_lo, vw - slack) : fmax(0.0, vw - slack);
    if (a.lo > a.hi) a.lo = a.hi;
    /* The estimate at w itself: every face in front, P(w) = V.w exactly;
     * else (V.w + T) / 2, T between its moment bounds (ff_clusters.h). */
    const double *M = b->moment;
    double q = w.x * w.x * M[0] + w.y * w.y * M[1] + w.z * w.z * M[2] +
               2 * (w.x * w.y * M[3] + w.x * w.z * M[4] + w.y * w.z * M[5]);
    q = fmax(0.0, q);
    double t_hi = sqrt(S * q), t_lo = fmin(t_hi, fmax(q, fabs(vw)));
    int in_front = theta + b->cone_angle <= 0.5 * RAD_PI;
    double est = in_front ? vw : 0.5 * (vw + sqrt(t_hi * t_lo));
    a.est = fmin(a.hi, fmax(a.lo, est));
    return a;
}

static inline RAD_HD ff_cluster_pair_bound ff_cluster_pair_estimate(const ff_cluster_bound *r,
                                                                    const ff_cluster_bound *s)
{
    ff_cluster_pair_bound p = {0, 0, 0, 0, 0, 0};
    rad_vec3 d = rad_v3_sub(s->centre, r->centre);
    double dist = rad_v3_length(d), reach = r->radius + s->radius;
    if (!(dist > 0)) {
        p.facing = 1;
        p.hi_rs = p.hi_sr = INFINITY;
        return p;
    }
    rad_vec3 w = rad_v3_scale(d, 1.0 / dist);
    double beta = reach >= dist ? RAD_PI : asin(reach / dist);
    ff_shown_area ar = ff_cluster_shown_towards(r, w, beta), as = ff_cluster_shown_towards(s, rad_v3_scale(w, -1.0), beta);
    if (ar.hi <= 0 || as.hi <= 0) return p;
    p.facing = 1;
    p.coupling = ar.est * as.est / (r->area * s->area * RAD_PI * dist * dist);
    double near = dist - reach, far = dist + reach;
    if (near <= 0) {
        p.hi_rs = p.hi_sr = INFINITY;
    } else {
        p.hi_rs = fmin(1.0, ar.cos_hi * as.hi / (RAD_PI * near * near));
        p.hi_sr = fmin(1.0, as.cos_hi * ar.hi / (RAD_PI * near * near));
    }
    p.lo_rs = fmax(0.0, ar.cos_lo) * as.lo / (RAD_PI * far * far);
    p.lo_sr = fmax(0.0, as.cos_lo) * ar.lo / (RAD_PI * far * far);
    return p;
}

/* What the draws read: the cluster tree's arrays (ff_clusters.h), the
 * elements (roots first) in the backend's frame, the cone beyond which a
 * cluster links nothing (radians) and the segments' delta (ff_segment). */
typedef struct ff_cluster_view {
    const ff_cluster *clusters;
    const uint32_t *roots;      /* in cluster order */
    const double *area_before;  /* root_count + 1: the roots' areas summed in cluster order */
    const rad_ff_patch *patches; /* element_count, by element id (roots first) */
    uint32_t cluster_count, root_count;
    size_t element_count;
    double cone;
    double open_spread; /* --cluster-open: a cluster whose faces' openness spreads more links nothing */
    double delta;
} ff_cluster_view;

/* A cluster end that may not be linked: its faces face apart (normals
 * beyond cone of their axis), or some are hidden at close range and
 * others open (openness spread beyond open_spread): one irradiance for
 * all of them would move light between them (docs/hierarchy.md). */
static inline RAD_HD int ff_cluster_bound_mixed(const ff_cluster_bound *b, double cone, double open_spread)
{
    return b->cone_angle > cone || (double)(b->open_hi - b->open_lo) > open_spread;
}

/* The root of cluster c that holds the area fraction u in [0, 1) of it,
 * the roots taken in cluster order: a root drawn in proportion to its area. */
static inline RAD_HD uint32_t ff_cluster_pick_in(const ff_cluster *clusters, const uint32_t *roots,
                                                  const double *area_before, uint32_t c, double u)
{
    const rad_link_cluster *l = &clusters[c].link;
    double lo_area = area_before[l->root_begin], want = lo_area + u * (area_before[l->root_end] - lo_area);
    uint32_t lo = l->root_begin, hi = l->root_end - 1; /* the last k with area_before[k] <= want */
    while (lo < hi) {
        uint32_t mid = lo + (hi - lo + 1) / 2;
        if (area_before[mid] <= want)
            lo = mid;
        else
            hi = mid - 1;
    }
    return roots[lo];
}

static inline RAD_HD uint64_t ff_cluster_mix64(uint64_t x)
{
    x += 0x9E3779B97F4A7C15ull;
    x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
    x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
    return x ^ (x >> 31);
}

static inline RAD_HD double ff_cluster_unit(uint64_t h) { return (double)(h >> 11) * 0x1.0p-53; }

static inline RAD_HD ff_cluster_bound ff_cluster_view_bound(const ff_cluster_view *v, uint32_t id)
{
    return ff_is_cluster(id) ? v->clusters[ff_cluster_of(id)].bound : ff_element_bound(&v->patches[id]);
}

/* A point on side id for the draw h: on the element, or on a face of the
 * cluster drawn in proportion to its area. */
static inline RAD_HD const rad_ff_patch *ff_cluster_side_point(const ff_cluster_view *v, uint32_t id, uint64_t h,
                                                               rad_vec3 *x)
{
    uint64_t h1 = ff_cluster_mix64(h), h2 = ff_cluster_mix64(h1), h3 = ff_cluster_mix64(h2);
    const rad_ff_patch *p =
        ff_is_cluster(id)
            ? &v->patches[ff_cluster_pick_in(v->clusters, v->roots, v->area_before, ff_cluster_of(id), ff_cluster_unit(h1))]
            : &v->patches[id];
    *x = rad_ff_sample_point(p, ff_cluster_unit(h2), ff_cluster_unit(h3));
    return p;
}

/* What a pair came to: drawn (ff_cluster_draw), traced, coupled
 * (ff_cluster_couple). */
typedef struct ff_cluster_drawn {
    double coupling;          /* c_ab, visibility included */
    double error_ab, error_ba;
    uint32_t rays;            /* segments drawn (facing each other at both ends) */
    uint32_t blocked;         /* of them, blocked */
    uint8_t facing;           /* 0: no link */
    uint8_t must_split;       /* a self-link, a mixed end or ends too close for a cluster link */
} ff_cluster_drawn;

/* The pair (a, b), a cluster at one end at least: whether it faces and
 * may be linked, and if so FF_CLUSTER_RAYS segments between points drawn
 * on the two ends (o->rays of them; at most 4 FF_CLUSTER_RAYS draws) whose
 * ends face each other. A cluster whose normals spread beyond v->cone is
 * a mixed end. */
static inline RAD_HD void ff_cluster_draw(const ff_cluster_view *v, uint32_t a, uint32_t b, ff_cluster_drawn *o,
                                          ff_segment segs[FF_CLUSTER_RAYS])
{
    o->coupling = o->error_ab = o->error_ba = 0;
    o->rays = o->blocked = 0;
    o->facing = o->must_split = 0;
    if (a == b) {
        o->facing = o->must_split = 1;
        return;
    }
    ff_cluster_bound ba = ff_cluster_view_bound(v, a), bb = ff_cluster_view_bound(v, b);
    ff_cluster_pair_bound pb = ff_cluster_pair_estimate(&ba, &bb);
    if (!pb.facing) return;
    o->facing = 1;
    const int mixed = (ff_is_cluster(a) && ff_cluster_bound_mixed(&ba, v->cone, v->open_spread)) ||
                      (ff_is_cluster(b) && ff_cluster_bound_mixed(&bb, v->cone, v->open_spread));
    if (mixed || ba.radius + bb.radius >= FF_CLUSTER_ADMISSIBLE * rad_v3_length(rad_v3_sub(ba.centre, bb.centre))) {
        o->must_split = 1;
        return;
    }
    uint32_t valid = 0;
    const uint64_t seed = ff_cluster_mix64(((uint64_t)a << 32) | b);
    for (uint32_t k = 0; k < 4 * FF_CLUSTER_RAYS && valid < FF_CLUSTER_RAYS; k++) {
        rad_vec3 x, y;
        const rad_ff_patch *px = ff_cluster_side_point(v, a, seed + 2 * k, &x);
        const rad_ff_patch *py = ff_cluster_side_point(v, b, seed + 2 * k + 1, &y);
        rad_vec3 d = rad_v3_sub(y, x);
        if (rad_v3_dot(px->normal, d) <= 0 || rad_v3_dot(py->normal, d) >= 0) continue;
        segs[valid++] = ff_segment_make(x, px->normal, px->face, y, py->normal, py->face, v->delta);
    }
    o->rays = valid;
}

/* A cluster whose normals lie within this of their axis (radians) is flat
 * enough to be one part of a link's coupling. */
#define FF_CLUSTER_FLAT_ANGLE 0.2
/* Parts a link's end comes apart into at most (ff_cluster_end_parts). */
#define FF_CLUSTER_PARTS 16

/* P(w) of cluster c from its parts: exact where its cone lies wholly in
 * front of w or behind it, summed over its faces in a leaf cluster, summed
 * over its children down to three levels (2^3 parts at most) where their
 * normals disagree (a room's corner: each wall's part is exact), the
 * moment estimate below that. ff_cluster_shown_at decides c at `depth`
 * levels left (1, *p set) or says its children are to be summed (0); the
 * levels are functions of their own, not recursion, so that a GPU thread's
 * stack is known. */
static inline RAD_HD int ff_cluster_shown_at(const ff_cluster_view *v, uint32_t c, rad_vec3 w, int depth, double *p)
{
    const ff_cluster *cl = &v->clusters[c];
    const ff_cluster_bound *b = &cl->bound;
    double theta = acos(fmax(-1.0, fmin(1.0, rad_v3_dot(b->axis, w))));
    if (theta + b->cone_angle <= 0.5 * RAD_PI) { /* all in front */
        *p = fmax(0.0, rad_v3_dot(b->vector_area, w));
        return 1;
    }
    if (theta - b->cone_angle >= 0.5 * RAD_PI) { /* all behind */
        *p = 0.0;
        return 1;
    }
    if (cl->link.child_count == 0) {
        double sum = 0;
        for (uint32_t k = cl->link.root_begin; k < cl->link.root_end; k++) {
            const rad_ff_patch *f = &v->patches[v->roots[k]];
            sum += f->area * fmax(0.0, rad_v3_dot(f->normal, w));
        }
        *p = sum;
        return 1;
    }
    if (depth <= 0) {
        *p = ff_cluster_shown_towards(b, w, 0.0).est;
        return 1;
    }
    return 0;
}

#define FF_CLUSTER_SHOWN_LEVEL(name, depth, below)                                                   \
    static inline RAD_HD double name(const ff_cluster_view *v, uint32_t c, rad_vec3 w)               \
    {                                                                                                \
        double p;                                                                                    \
        if (ff_cluster_shown_at(v, c, w, depth, &p)) return p;                                       \
        p = 0;                                                                                       \
        const rad_link_cluster *l = &v->clusters[c].link;                                            \
        for (uint32_t i = 0; i < l->child_count; i++) p += below(v, l->first_child + i, w);          \
        return p;                                                                                    \
    }
static inline RAD_HD double ff_cluster_shown_0(const ff_cluster_view *v, uint32_t c, rad_vec3 w)
{
    double p = 0;
    ff_cluster_shown_at(v, c, w, 0, &p);
    return p;
}
FF_CLUSTER_SHOWN_LEVEL(ff_cluster_shown_1, 1, ff_cluster_shown_0)
FF_CLUSTER_SHOWN_LEVEL(ff_cluster_shown_2, 2, ff_cluster_shown_1)
FF_CLUSTER_SHOWN_LEVEL(ff_cluster_shown_3, 3, ff_cluster_shown_2)
#undef FF_CLUSTER_SHOWN_LEVEL

/* The area end id shows towards w: an element's A max(n.w, 0), a
 * cluster's from its parts (ff_cluster_shown_3). */
static inline RAD_HD double ff_cluster_shown(const ff_cluster_view *v, uint32_t id, rad_vec3 w)
{
    if (ff_is_cluster(id)) return ff_cluster_shown_3(v, ff_cluster_of(id), w);
    return v->patches[id].area * fmax(0.0, rad_v3_dot(v->patches[id].normal, w));
}

/* End id as the parts its coupling is summed over (FF_CLUSTER_PARTS at
 * most): a cluster whose normals spread beyond FF_CLUSTER_FLAT_ANGLE is
 * replaced by its child clusters, or a leaf cluster by its faces, twice
 * at most; anything else is one part. */
static inline RAD_HD int ff_cluster_end_parts(const ff_cluster_view *v, uint32_t id, uint32_t parts[FF_CLUSTER_PARTS])
{
    int m = 1;
    parts[0] = id;
    for (int level = 0; level < 2; level++) {
        uint32_t next[FF_CLUSTER_PARTS];
        int k = 0;
        for (int i = 0; i < m; i++) {
            const ff_cluster *c = ff_is_cluster(parts[i]) ? &v->clusters[ff_cluster_of(parts[i])] : 0;
            if (c && c->bound.cone_angle > FF_CLUSTER_FLAT_ANGLE && c->link.child_count == 2) {
                next[k++] = FF_CLUSTER_ID(c->link.first_child);
                next[k++] = FF_CLUSTER_ID(c->link.first_child + 1);
            } else if (c && c->bound.cone_angle > FF_CLUSTER_FLAT_ANGLE && c->link.child_count == 0) {
                for (uint32_t r = c->link.root_begin; r < c->link.root_end; r++) next[k++] = v->roots[r];
            } else {
                next[k++] = parts[i];
            }
        }
        for (int i = 0; i < k; i++) parts[i] = next[i];
        m = k;
    }
    return m;
}

/* The pair (a, b) once drawn and traced (o->rays, o->blocked): a linked
 * pair's coupling, summed over the two ends' parts (ff_cluster_end_parts,
 * ff_cluster_shown) times the visible fraction, and its errors: what the
 * bounds (ff_cluster_pair_estimate) allow a point of a's faces to see of b
 * beyond F_ab, the lower bound taken only where every segment was clear. */
static inline RAD_HD void ff_cluster_couple(const ff_cluster_view *v, uint32_t a, uint32_t b, ff_cluster_drawn *o)
{
    if (!o->facing || o->must_split) return;
    ff_cluster_bound ba = ff_cluster_view_bound(v, a), bb = ff_cluster_view_bound(v, b);
    ff_cluster_pair_bound pb = ff_cluster_pair_estimate(&ba, &bb);
    const uint32_t valid = o->rays, blocked = o->blocked;
    const double V = valid ? 1.0 - (double)blocked / valid : 1.0;
    const int clear = valid == FF_CLUSTER_RAYS && blocked == 0;
    /* The coupling part by part: an end whose normals spread comes apart
     * into its child clusters or faces (two levels), each with its own
     * centre and shown area (a room's corner is two walls, each exact;
     * from the corner's one centre, which lies off both walls, the
     * moments put it 7-10 % high). */
    uint32_t pa[FF_CLUSTER_PARTS], pb_[FF_CLUSTER_PARTS];
    int na = ff_cluster_end_parts(v, a, pa), nb = ff_cluster_end_parts(v, b, pb_);
    double sum = 0;
    for (int i = 0; i < na; i++)
        for (int j = 0; j < nb; j++) {
            ff_cluster_bound bi = ff_cluster_view_bound(v, pa[i]), bj = ff_cluster_view_bound(v, pb_[j]);
            rad_vec3 dv = rad_v3_sub(bj.centre, bi.centre);
            double dist2 = rad_v3_dot(dv, dv);
            if (!(dist2 > 0)) continue;
            rad_vec3 w = rad_v3_scale(dv, 1.0 / sqrt(dist2));
            sum += ff_cluster_shown(v, pa[i], w) * ff_cluster_shown(v, pb_[j], rad_v3_scale(w, -1.0)) / (RAD_PI * dist2);
        }
    o->coupling = V * sum / (ba.area * bb.area);
    double Fab = o->coupling * bb.area, Fba = o->coupling * ba.area;
    o->error_ab = fmax(pb.hi_rs - Fab, Fab - (clear ? pb.lo_rs : 0.0));
    o->error_ba = fmax(pb.hi_sr - Fba, Fba - (clear ? pb.lo_sr : 0.0));
}

/* The pair (a, b) whole: drawn, its segments traced through the BVH
 * (ff_bvh.h), coupled: what both backends' cluster_draws run per pair. */
static inline RAD_HD void ff_cluster_pair(const ff_cluster_view *v, const ff_bvh_node *nodes, const ff_bvh_tri *tris,
                                          int32_t root, uint32_t root_count, uint32_t a, uint32_t b,
                                          ff_cluster_drawn *o)
{
    ff_segment segs[FF_CLUSTER_RAYS];
    ff_cluster_draw(v, a, b, o, segs);
    uint32_t blocked = 0, last = FF_BVH_NO_HIT;
    for (uint32_t r = 0; r < o->rays; r++)
        blocked += (uint32_t)ff_bvh_occluded_cached(nodes, tris, root, root_count, &segs[r], &last);
    o->blocked = blocked;
    ff_cluster_couple(v, a, b, o);
}

#endif
