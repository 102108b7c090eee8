/* test_pairing.c - rad_links_pairing: every link's pair by the transpose,
 * against a binary search in the source's links.
 *
 *  - Symmetric links over nodes and clusters (self links too, a few
 *    receivers with thousands of links, some with none), sources
 *    ascending per receiver: for 1 to 64 threads the blocks cover the ids
 *    in order, at most RAD_LINKS_PAIR_BLOCKS of them, and each block's
 *    walk gives every link the very pair a search finds.
 *  - A walk that skips every link of some sources still pairs the rest.
 *  - One link taken away: some link of the walk reports no pair, and no
 *    link is given a wrong one. */
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "rad_links.h"
#include "rad_test.h"

#define NODES 2500u
#define CLUSTERS 500u
#define IDS (NODES + CLUSTERS)

/* the link back of k (at receiver r) by a search; UINT64_MAX if none */
static uint64_t searched(const rad_links *L, uint32_t r, uint64_t k)
{
    const uint32_t s = L->links[k].source;
    uint64_t lo = L->first_link[s], hi = L->first_link[s + 1];
    while (lo < hi) {
        const uint64_t mid = lo + (hi - lo) / 2;
        if (L->links[mid].source < r) lo = mid + 1;
        else hi = mid;
    }
    return lo < L->first_link[s + 1] && L->links[lo].source == r ? lo : UINT64_MAX;
}

/* Symmetric random links; `drop`: the link (drop_r <- drop_s) left out. */
static void make_links(rad_links *L, unsigned char *adj, int drop, uint32_t drop_r, uint32_t drop_s)
{
    memset(L, 0, sizeof *L);
    L->node_count = NODES;
    L->cluster_count = CLUSTERS;
    L->first_link = calloc(IDS + 1, sizeof *L->first_link);
    uint64_t n = 0;
    for (uint32_t r = 0; r < IDS; r++) {
        for (uint32_t s = 0; s < IDS; s++) n += adj[(size_t)r * IDS + s] && !(drop && r == drop_r && s == drop_s);
        L->first_link[r + 1] = n;
    }
    L->link_count = n;
    L->links = malloc((n ? n : 1) * sizeof *L->links);
    uint64_t k = 0;
    for (uint32_t r = 0; r < IDS; r++)
        for (uint32_t s = 0; s < IDS; s++)
            if (adj[(size_t)r * IDS + s] && !(drop && r == drop_r && s == drop_s))
                L->links[k++] = (rad_link){.source = s, .error = 0.5f, .factor = r + s * 1e-4};
}

static void free_links(rad_links *L)
{
    free(L->first_link);
    free(L->links);
}

/* Walks every block as the threads would (one after the other here):
 * the number of links whose pair differs from the search's, and of those
 * without one. `skip_odd`: the links of odd sources are not visited. */
static void walk(const rad_links *L, int threads, int skip_odd, uint64_t *wrong, uint64_t *unpaired)
{
    rad_links_pairing w;
    *wrong = *unpaired = 0;
    RAD_CHECK(rad_links_pairing_make(L, threads, &w) == RAD_OK);
    RAD_CHECK(w.blocks >= 1 && w.blocks <= RAD_LINKS_PAIR_BLOCKS);
    RAD_CHECK(w.begin[0] == 0 && w.begin[w.blocks] == IDS);
    for (uint32_t b = 0; b < w.blocks; b++) {
        RAD_CHECK(w.begin[b] <= w.begin[b + 1]);
        uint32_t *at = rad_links_pairing_cursors(&w, b);
        for (uint32_t r = w.begin[b]; r < w.begin[b + 1]; r++)
            for (uint64_t k = L->first_link[r]; k < L->first_link[r + 1]; k++) {
                if (skip_odd && (L->links[k].source & 1)) continue;
                const uint64_t j = rad_links_pair_next(L, at, r, k);
                if (j == UINT64_MAX) ++*unpaired;
                else if (j != searched(L, r, k)) ++*wrong;
            }
    }
    rad_links_pairing_free(&w);
}

/* xorshift64*: a uniform number in [0, 1) */
static double uniform(uint64_t *x)
{
    *x ^= *x >> 12, *x ^= *x << 25, *x ^= *x >> 27;
    return (double)((*x * 2685821657736338717ull) >> 11) / 9007199254740992.0;
}

int main(void)
{
    unsigned char *adj = calloc((size_t)IDS * IDS, 1);
    uint64_t rng = 0x9e3779b97f4a7c15ull;
    for (uint32_t r = 0; r < IDS; r++)
        for (uint32_t s = r; s < IDS; s++) {
            /* dense among the first ids (receivers of thousands), none at every 97th */
            const double p = r < 8 ? 0.9 : (r % 97 == 0 || s % 97 == 0) ? 0 : 0.03;
            if (uniform(&rng) < p) adj[(size_t)r * IDS + s] = adj[(size_t)s * IDS + r] = 1;
        }
    rad_links L;
    make_links(&L, adj, 0, 0, 0);
    RAD_CHECK(L.link_count > (uint64_t)RAD_LINKS_PAIR_BLOCKS * 4096); /* enough for every block count */
    const int threads[] = {1, 2, 3, 7, 16, 64};
    for (size_t t = 0; t < sizeof threads / sizeof *threads; t++) {
        uint64_t wrong, unpaired;
        walk(&L, threads[t], 0, &wrong, &unpaired);
        RAD_CHECK(wrong == 0 && unpaired == 0);
        walk(&L, threads[t], 1, &wrong, &unpaired);
        RAD_CHECK(wrong == 0 && unpaired == 0);
    }
    rad_links_pairing w;
    RAD_CHECK(rad_links_pairing_make(&L, 16, &w) == RAD_OK && w.blocks == 16);
    rad_links_pairing_free(&w);
    free_links(&L);

    /* one link without its pair: found, and no pair given wrongly */
    uint32_t r0 = 0, s0 = 0;
    for (uint32_t r = 1200; r < IDS && !s0; r++)
        for (uint32_t s = r + 1; s < IDS; s++)
            if (adj[(size_t)r * IDS + s]) {
                r0 = r, s0 = s;
                break;
            }
    RAD_CHECK(s0 != 0);
    make_links(&L, adj, 1, r0, s0);
    for (size_t t = 0; t < sizeof threads / sizeof *threads; t++) {
        uint64_t wrong, unpaired;
        walk(&L, threads[t], 0, &wrong, &unpaired);
        RAD_CHECK(wrong == 0 && unpaired >= 1);
    }
    free_links(&L);
    free(adj);
    return rad_test_finish();
}
