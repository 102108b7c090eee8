/* ff_rank_rounds.c - a hierarchy's rounds shared by the ranks
 * (ff_rank_rounds.h). */
#include "ff_rank_rounds.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "rad_clock.h"
#include "rad_log.h"

enum { OP_ROUND = 1, OP_STOP = 2 };

/* The cyclic cut's chunk: pairs next to each other in a round's list are
 * often alike in cost (the children of one split: a near object's pairs
 * trace many rays), so a rank takes every size-th chunk of this many,
 * not one block of the list. */
#define RANK_CHUNK 2048u

/* The most pairs one exchange holds: a larger round goes in pieces, so
 * that the areas (96 bytes a pair: its job and outcome) stay near 400 MB
 * in all whatever the round (rounds reach 10^8 pairs at 10^6 faces). */
#define RANK_PIECE ((uint64_t)4 << 20)

/* What rank 0 says before each round. */
typedef struct round_header {
    uint32_t op;
    uint32_t with_tree; /* the cluster tree follows (the first round with cluster pairs) */
    uint64_t element_count;
    uint64_t pair_count, cluster_count;
    uint32_t tree_count, root_count; /* the tree's clusters and roots */
    double cone, open_spread, delta; /* the cluster view's */
} round_header;

/* What each rank says after its chunks. */
typedef struct round_report {
    int32_t status;
    int32_t pad;
    double cluster_seconds;
    double compute_seconds; /* its chunks' wall */
    ff_counters counters;
} round_report;

/* A rank's copy of what the rounds need: all of rank 0's on rank 0 (views),
 * the elements and the tree received so far elsewhere. */
typedef struct rank_state {
    ff_comm *comm;
    int rank, size;
    size_t elements;      /* sent (rank 0) or received so far */
    int tree_sent;
    rad_ff_patch *patches; /* the other ranks' copies */
    uint32_t *keys;
    size_t element_cap;
    ff_cluster *clusters;
    uint32_t *roots;
    double *area_before;
    round_report *reports; /* rank 0: size */
    ff_comm_area *area;   /* this rank's chunks of jobs and outcomes (ff_comm.h), `area_bytes` */
    size_t area_bytes;
    int said;             /* rank 0 has said how the rounds travel */
    uint64_t piece;       /* rank 0: RANK_PIECE, or RAD_MPI_PIECE's (tests) */
    size_t *at;           /* 4 x size, by part: every rank's offset in its area of its jobs (at[r]),
                             cluster jobs (at[size + r]), outcomes and cluster outcomes */
    ff_rank_times times; /* rank 0 */
} rank_state;

struct ff_rank_rounds {
    rank_state s;
};

/* Rank 0's reports; 0 where there is no memory for them. */
static int state_init(rank_state *s, ff_comm *comm)
{
    s->comm = comm;
    s->rank = ff_comm_rank(comm);
    s->size = ff_comm_size(comm);
    s->reports = s->rank == 0 ? calloc((size_t)s->size, sizeof *s->reports) : NULL;
    s->at = malloc(4 * (size_t)s->size * sizeof *s->at);
    return s->at && (s->rank != 0 || s->reports);
}

static void state_free(rank_state *s)
{
    free(s->reports);
    free(s->patches);
    free(s->keys);
    free(s->clusters);
    free(s->roots);
    free(s->area_before);
    free(s->at);
    ff_comm_area_close(s->area); /* collective where shared: every rank frees its state at the same point */
}

/* Rank r's area for a round: its jobs, cluster jobs, outcomes and cluster
 * outcomes, each 64-byte aligned, at s->at[k * size + r]; the bytes in all. */
static size_t layout(rank_state *s, int r, uint64_t pairs, uint64_t clusters)
{
    const size_t sizes[4] = {pairs * sizeof(ff_pair_job), clusters * sizeof(ff_pair_job),
                             pairs * sizeof(ff_pair_outcome), clusters * sizeof(ff_cluster_drawn)};
    size_t total = 0;
    for (int k = 0; k < 4; k++) {
        s->at[k * s->size + r] = total;
        total += (sizes[k] + 63) & ~(size_t)63;
    }
    return total;
}

/* Every rank's offset of part k (0 jobs, 1 cluster jobs, 2 outcomes, 3
 * cluster outcomes), rank by rank. */
static const size_t *at_of(const rank_state *s, int k) { return s->at + (size_t)k * s->size; }

static int grow(void **p, size_t *cap, size_t want, size_t item)
{
    if (want <= *cap) return 1;
    size_t n = want + want / 4 + 1024;
    void *q = realloc(*p, n * item);
    if (!q) return 0;
    *p = q;
    *cap = n;
    return 1;
}

/* A rank's room for a round's elements and tree (rank 0 has them);
 * RAD_ERR_NOMEM (logged). */
static rad_status reserve(rank_state *s, const round_header *h, uint64_t my_pairs, uint64_t my_clusters)
{
    int ok = s->at != NULL;
    if (s->rank > 0) { /* rank 0 has the elements and the tree */
        size_t cap = s->element_cap, cap_keys = s->element_cap;
        ok = grow((void **)&s->patches, &cap, h->element_count, sizeof *s->patches) &&
             grow((void **)&s->keys, &cap_keys, h->element_count, sizeof *s->keys);
        if (ok) s->element_cap = cap < cap_keys ? cap : cap_keys;
    }
    if (ok && s->rank > 0 && h->with_tree) {
        free(s->clusters);
        free(s->roots);
        free(s->area_before);
        s->clusters = malloc((h->tree_count ? h->tree_count : 1) * sizeof *s->clusters);
        s->roots = malloc((h->root_count ? h->root_count : 1) * sizeof *s->roots);
        s->area_before = malloc(((size_t)h->root_count + 1) * sizeof *s->area_before);
        ok = s->clusters && s->roots && s->area_before;
    }
    if (!ok) {
        rad_error("rank %d: out of memory for a round of %llu elements and %llu pairs", s->rank,
                  (unsigned long long)h->element_count, (unsigned long long)(my_pairs + my_clusters));
        return RAD_ERR_NOMEM;
    }
    return RAD_OK;
}

/* One round on every rank, rank 0's w (NULL elsewhere): the elements and
 * the tree out, the chunks out, computed, back. The other ranks compute
 * with (backend, state); their failures reach rank 0 in the reports. */
static rad_status round_everywhere(rank_state *s, const round_header *h, const ff_round_work *w,
                                   const ff_backend *backend, void *backend_state, ff_counters *counters,
                                   double *cluster_seconds)
{
    const uint64_t my_pairs = ff_comm_cyclic_count(h->pair_count, RANK_CHUNK, s->rank, s->size);
    const uint64_t my_clusters = ff_comm_cyclic_count(h->cluster_count, RANK_CHUNK, s->rank, s->size);
    const double t0 = rad_clock_seconds();
    rad_status st = ff_comm_agree(s->comm, reserve(s, h, my_pairs, my_clusters));
    if (st != RAD_OK) return st;
    /* every rank's offsets; the areas grown together where one is short */
    size_t need = 0;
    for (int r = 0; r < s->size; r++) {
        const size_t bytes = layout(s, r, ff_comm_cyclic_count(h->pair_count, RANK_CHUNK, r, s->size),
                                    ff_comm_cyclic_count(h->cluster_count, RANK_CHUNK, r, s->size));
        if (r == s->rank) need = bytes;
    }
    if (ff_comm_max_u64(s->comm, !s->area || need > s->area_bytes)) {
        ff_comm_area_close(s->area);
        s->area = NULL;
        s->area_bytes = need + need / 4 + ((size_t)1 << 20);
        st = ff_comm_agree(s->comm, ff_comm_area_open(s->comm, s->area_bytes, &s->area));
        if (st != RAD_OK) {
            if (s->area) ff_comm_area_close(s->area); /* collective too: each rank that has one */
            s->area = NULL;
            return st;
        }
        if (!s->said && s->rank == 0)
            rad_info("ranks: the rounds' pairs and outcomes %s", ff_comm_area_shared(s->area)
                                                                    ? "through memory the ranks share (one node)"
                                                                    : "as messages");
        s->said = 1;
    }
    unsigned char *area = ff_comm_area_data(s->area);
    size_t at[4];
    for (int k = 0; k < 4; k++) at[k] = at_of(s, k)[s->rank];
    /* the elements made since the last round, the tree once */
    const size_t from = s->elements, more = h->element_count - from;
    if (more) {
        ff_comm_broadcast(s->comm, s->rank ? (void *)(s->patches + from) : (void *)(w->patches + from),
                          more * sizeof *s->patches, 0);
        ff_comm_broadcast(s->comm, s->rank ? (void *)(s->keys + from) : (void *)(w->keys + from),
                          more * sizeof *s->keys, 0);
        s->elements = h->element_count;
    }
    if (h->with_tree) {
        const ff_cluster_view *v = w ? w->view : NULL;
        ff_comm_broadcast(s->comm, s->rank ? (void *)s->clusters : (void *)v->clusters,
                          h->tree_count * sizeof *s->clusters, 0);
        ff_comm_broadcast(s->comm, s->rank ? (void *)s->roots : (void *)v->roots, h->root_count * sizeof *s->roots,
                          0);
        ff_comm_broadcast(s->comm, s->rank ? (void *)s->area_before : (void *)v->area_before,
                          ((size_t)h->root_count + 1) * sizeof *s->area_before, 0);
        s->tree_sent = 1;
    }
    /* this rank's chunks */
    ff_cluster_view view = {0};
    ff_round_work mine;
    if (s->rank == 0) {
        mine = *w;
    } else {
        view = (ff_cluster_view){.clusters = s->clusters, .roots = s->roots, .area_before = s->area_before,
                                 .patches = s->patches, .cluster_count = h->tree_count, .root_count = h->root_count,
                                 .element_count = h->element_count, .cone = h->cone, .open_spread = h->open_spread,
                                 .delta = h->delta};
        mine = (ff_round_work){.backend = backend, .backend_state = backend_state, .patches = s->patches,
                               .keys = s->keys, .view = &view};
    }
    mine.pairs = (const ff_pair_job *)(area + at[0]), mine.pair_count = my_pairs;
    mine.cluster_pairs = (const ff_pair_job *)(area + at[1]), mine.cluster_count = my_clusters;
    mine.out = (ff_pair_outcome *)(area + at[2]), mine.cluster_out = (ff_cluster_drawn *)(area + at[3]);
    if (!mine.cluster_count) mine.view = NULL;
    if (h->pair_count)
        st = ff_comm_scatter_cyclic(s->comm, w ? w->pairs : NULL, h->pair_count, RANK_CHUNK, sizeof(ff_pair_job),
                                    s->area, at_of(s, 0));
    if (st == RAD_OK && h->cluster_count)
        st = ff_comm_scatter_cyclic(s->comm, w ? w->cluster_pairs : NULL, h->cluster_count, RANK_CHUNK,
                                    sizeof(ff_pair_job), s->area, at_of(s, 1));
    const double t1 = rad_clock_seconds();
    round_report report = {0};
    report.status = st == RAD_OK ? ff_round_compute(&mine, &report.counters, &report.cluster_seconds) : st;
    const double t2 = rad_clock_seconds();
    report.compute_seconds = t2 - t1;
    /* the reports first: the other ranks then wait for rank 0's copies
     * asleep (area fence), not spinning in a gather */
    round_report *all = s->reports;
    ff_comm_gather(s->comm, &report, sizeof report, all, 0);
    rad_status gst = RAD_OK;
    if (h->pair_count)
        gst = ff_comm_gather_cyclic(s->comm, s->area, at_of(s, 2), h->pair_count, RANK_CHUNK, sizeof(ff_pair_outcome),
                                    w ? w->out : NULL);
    if (gst == RAD_OK && h->cluster_count)
        gst = ff_comm_gather_cyclic(s->comm, s->area, at_of(s, 3), h->cluster_count, RANK_CHUNK,
                                    sizeof(ff_cluster_drawn), w ? w->cluster_out : NULL);
    if (s->rank != 0) return report.status != RAD_OK ? (rad_status)report.status : gst;
    st = gst;
    *cluster_seconds = 0;
    double slowest = 0, fastest = INFINITY;
    for (int r = 0; r < s->size; r++) {
        if (st == RAD_OK && all[r].status != RAD_OK) st = (rad_status)all[r].status;
        ff_counters_add(counters, &all[r].counters);
        if (all[r].cluster_seconds > *cluster_seconds) *cluster_seconds = all[r].cluster_seconds;
        slowest = fmax(slowest, all[r].compute_seconds);
        fastest = fmin(fastest, all[r].compute_seconds);
    }
    s->times.send += t1 - t0;
    s->times.own += t2 - t1;
    s->times.slowest += slowest;
    s->times.fastest += fastest;
    s->times.collect += rad_clock_seconds() - t2;
    s->times.rounds++;
    return st;
}

rad_status ff_rank_rounds_open(ff_comm *comm, ff_rank_rounds **out)
{
    ff_rank_rounds *R = calloc(1, sizeof *R);
    if (!R || !state_init(&R->s, comm)) {
        rad_error("out of memory for the ranks' rounds");
        if (R) state_free(&R->s);
        free(R);
        return RAD_ERR_NOMEM;
    }
    const char *piece = getenv("RAD_MPI_PIECE"); /* tests: pieces of small rounds */
    R->s.piece = piece && atoll(piece) > 0 ? (uint64_t)atoll(piece) : RANK_PIECE;
    *out = R;
    return RAD_OK;
}

rad_status ff_rank_rounds_compute(ff_rank_rounds *R, const ff_round_work *w, size_t element_count,
                                  ff_counters *counters, double *cluster_seconds)
{
    rank_state *s = &R->s;
    /* in pieces of at most RANK_PIECE pairs, each a round of its own to
     * the others: the areas hold a piece, not the whole round */
    const uint64_t all = (uint64_t)w->pair_count + w->cluster_count;
    const uint64_t pieces = all ? (all + s->piece - 1) / s->piece : 1;
    rad_status st = RAD_OK;
    *cluster_seconds = 0;
    for (uint64_t k = 0; k < pieces && st == RAD_OK; k++) {
        const size_t p0 = (size_t)(w->pair_count * k / pieces), p1 = (size_t)(w->pair_count * (k + 1) / pieces);
        const size_t c0 = (size_t)(w->cluster_count * k / pieces), c1 = (size_t)(w->cluster_count * (k + 1) / pieces);
        ff_round_work piece = *w;
        piece.pairs = w->pairs + p0, piece.out = w->out + p0, piece.pair_count = p1 - p0;
        piece.cluster_pairs = w->cluster_pairs + c0, piece.cluster_out = w->cluster_out + c0;
        piece.cluster_count = c1 - c0;
        round_header h = {.op = OP_ROUND, .element_count = element_count, .pair_count = piece.pair_count,
                          .cluster_count = piece.cluster_count};
        if (piece.cluster_count) {
            h.with_tree = !s->tree_sent;
            h.tree_count = w->view->cluster_count;
            h.root_count = w->view->root_count;
            h.cone = w->view->cone;
            h.open_spread = w->view->open_spread;
            h.delta = w->view->delta;
        }
        ff_comm_broadcast_idle(s->comm, &h, sizeof h);
        double seconds = 0;
        st = round_everywhere(s, &h, &piece, NULL, NULL, counters, &seconds);
        *cluster_seconds += seconds;
    }
    return st;
}

void ff_rank_rounds_times_get(const ff_rank_rounds *R, ff_rank_times *out)
{
    if (R) *out = R->s.times;
}

void ff_rank_rounds_close(ff_comm *comm, ff_rank_rounds *R)
{
    if (ff_comm_size(comm) > 1) {
        round_header h = {.op = OP_STOP};
        ff_comm_broadcast_idle(comm, &h, sizeof h);
    }
    if (R) state_free(&R->s);
    free(R);
}

rad_status ff_rank_rounds_serve(ff_comm *comm, const ff_backend *backend, void *backend_state)
{
    rank_state s = {0};
    state_init(&s, comm); /* without room for its offsets every round fails (reserve), the others told so */
    rad_status first = RAD_OK;
    for (;;) {
        round_header h;
        ff_comm_broadcast_idle(comm, &h, sizeof h); /* asleep while rank 0 decides */
        if (h.op != OP_ROUND) break;
        ff_counters unused = {0};
        double seconds = 0;
        rad_status st = round_everywhere(&s, &h, NULL, backend, backend_state, &unused, &seconds);
        if (first == RAD_OK) first = st;
    }
    state_free(&s);
    return first;
}
