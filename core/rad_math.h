/* rad_math.h - 3-vectors in double precision, for host and device.
 *
 * Everything here is `static inline` and marked RAD_HD so that the same
 * code compiles as C11 on the host and as CUDA device code (see
 * rad_ff_kernel.h). Keep it free of libc calls other than <math.h>.
 */
#ifndef RAD_MATH_H
#define RAD_MATH_H

#include <math.h>

#if defined(__CUDACC__)
#define RAD_HD __host__ __device__
#else
#define RAD_HD
#endif

#define RAD_PI 3.14159265358979323846

typedef struct rad_vec3 {
    double x, y, z;
} rad_vec3;

static inline RAD_HD rad_vec3 rad_v3(double x, double y, double z)
{
    rad_vec3 r = {x, y, z};
    return r;
}
static inline RAD_HD rad_vec3 rad_v3_add(rad_vec3 a, rad_vec3 b) { return rad_v3(a.x + b.x, a.y + b.y, a.z + b.z); }
static inline RAD_HD rad_vec3 rad_v3_sub(rad_vec3 a, rad_vec3 b) { return rad_v3(a.x - b.x, a.y - b.y, a.z - b.z); }
static inline RAD_HD rad_vec3 rad_v3_scale(rad_vec3 a, double s) { return rad_v3(a.x * s, a.y * s, a.z * s); }
static inline RAD_HD double rad_v3_dot(rad_vec3 a, rad_vec3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
static inline RAD_HD rad_vec3 rad_v3_cross(rad_vec3 a, rad_vec3 b)
{
    return rad_v3(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x);
}
static inline RAD_HD double rad_v3_length(rad_vec3 a) { return sqrt(rad_v3_dot(a, a)); }
/* a + (b - a) * t */
static inline RAD_HD rad_vec3 rad_v3_lerp(rad_vec3 a, rad_vec3 b, double t)
{
    return rad_v3(a.x + (b.x - a.x) * t, a.y + (b.y - a.y) * t, a.z + (b.z - a.z) * t);
}
/* Unit vector along a; the zero vector stays zero. */
static inline RAD_HD rad_vec3 rad_v3_normalize(rad_vec3 a)
{
    double len = rad_v3_length(a);
    return len > 0 ? rad_v3_scale(a, 1.0 / len) : a;
}

#endif
