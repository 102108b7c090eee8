#include "rad_hash.h"

#include <string.h>

#define FNV_PRIME UINT64_C(0x100000001b3)

uint64_t rad_hash64(uint64_t h, const void *data, size_t size)
{
    const unsigned char *p = data;
    size_t words = size / 8;
    for (size_t i = 0; i < words; i++) {
        uint64_t w;
        memcpy(&w, p + 8 * i, 8);
        h = (h ^ w) * FNV_PRIME;
        h ^= h >> 29; /* fold high bits down so each word affects all bits */
    }
    for (size_t i = 8 * words; i < size; i++) h = (h ^ p[i]) * FNV_PRIME;
    return h;
}
