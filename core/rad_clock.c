/* rad_clock.c - the monotonic clock (rad_clock.h). */
#define _POSIX_C_SOURCE 200809L /* clock_gettime */
#include "rad_clock.h"

#include <time.h>

double rad_clock_seconds(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

long long rad_clock_ns(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (long long)t.tv_sec * 1000000000ll + t.tv_nsec;
}
