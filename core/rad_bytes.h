/* rad_bytes.h - little-endian field encoding for the binary file headers.
 * Explicit byte order keeps the formats independent of struct padding. */
#ifndef RAD_BYTES_H
#define RAD_BYTES_H

#include <stdint.h>
#include <string.h>

static inline void rad_put_u32(unsigned char *p, uint32_t v)
{
    for (int i = 0; i < 4; i++) p[i] = (unsigned char)(v >> (8 * i));
}
static inline void rad_put_u64(unsigned char *p, uint64_t v)
{
    for (int i = 0; i < 8; i++) p[i] = (unsigned char)(v >> (8 * i));
}
static inline void rad_put_f64(unsigned char *p, double v)
{
    uint64_t bits;
    memcpy(&bits, &v, 8);
    rad_put_u64(p, bits);
}
static inline uint32_t rad_get_u32(const unsigned char *p)
{
    uint32_t v = 0;
    for (int i = 0; i < 4; i++) v |= (uint32_t)p[i] << (8 * i);
    return v;
}
static inline uint64_t rad_get_u64(const unsigned char *p)
{
    uint64_t v = 0;
    for (int i = 0; i < 8; i++) v |= (uint64_t)p[i] << (8 * i);
    return v;
}
static inline double rad_get_f64(const unsigned char *p)
{
    uint64_t bits = rad_get_u64(p);
    double v;
    memcpy(&v, &bits, 8);
    return v;
}
static inline uint64_t rad_align_up(uint64_t x, uint64_t a) { return (x + a - 1) / a * a; }

/* The formats store tables (vertices, patch records, matrix rows) as raw
 * host arrays, which is little-endian on every machine we build for. */
#if defined(__BYTE_ORDER__) && __BYTE_ORDER__ != __ORDER_LITTLE_ENDIAN__
#error "radiosity file formats assume a little-endian host"
#endif

#endif
