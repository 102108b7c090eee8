/* rad_edge_map.h - vertex pair -> vertex (an edge's midpoint), an
 * open-addressing table: how rad_mesh_build and rad_refine_split share
 * midpoints between patches that share an edge.
 *
 *     rad_edge_map map;
 *     if (rad_edge_map_init(&map, expected_edges) != RAD_OK) ...;
 *     uint32_t *slot;
 *     if (!rad_edge_map_find(&map, a, b, &slot)) *slot = new_midpoint_vertex(a, b);
 *     ... *slot ...
 *     rad_edge_map_free(&map);
 *
 * The key is the unordered pair, so (a, b) and (b, a) meet. The table
 * holds at least twice the expected edges; more edges than that fill it
 * (callers size it from a bound).
 */
#ifndef RAD_EDGE_MAP_H
#define RAD_EDGE_MAP_H

#include <stdint.h>
#include <stdlib.h>

#include "rad_status.h"

#define RAD_EDGE_MAP_EMPTY UINT64_MAX

typedef struct rad_edge_map {
    uint64_t *keys;   /* (lo << 32) | hi, or RAD_EDGE_MAP_EMPTY */
    uint32_t *vertex; /* the value of each key */
    size_t mask;      /* table size - 1 (a power of two) */
} rad_edge_map;

/* RAD_ERR_NOMEM (not logged: the caller says what it was building). */
static inline rad_status rad_edge_map_init(rad_edge_map *map, size_t edges)
{
    size_t table = 16;
    while (table < 2 * edges && table < SIZE_MAX / 4) table *= 2;
    map->keys = malloc(table * sizeof *map->keys);
    map->vertex = malloc(table * sizeof *map->vertex);
    map->mask = table - 1;
    if (!map->keys || !map->vertex) return RAD_ERR_NOMEM;
    for (size_t i = 0; i < table; i++) map->keys[i] = RAD_EDGE_MAP_EMPTY;
    return RAD_OK;
}

static inline void rad_edge_map_free(rad_edge_map *map)
{
    free(map->keys);
    free(map->vertex);
    map->keys = NULL;
    map->vertex = NULL;
}

/* 1 and *slot at edge (a, b)'s vertex when it is in the map; else 0 and
 * *slot where the caller stores the new vertex (the key is set). */
static inline int rad_edge_map_find(rad_edge_map *map, uint32_t a, uint32_t b, uint32_t **slot)
{
    uint64_t key = a < b ? (uint64_t)a << 32 | b : (uint64_t)b << 32 | a;
    size_t i = (size_t)((key * UINT64_C(0x9E3779B97F4A7C15)) >> 17) & map->mask;
    while (map->keys[i] != RAD_EDGE_MAP_EMPTY) {
        if (map->keys[i] == key) {
            *slot = &map->vertex[i];
            return 1;
        }
        i = (i + 1) & map->mask;
    }
    map->keys[i] = key;
    *slot = &map->vertex[i];
    return 0;
}

#endif
