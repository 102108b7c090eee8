/* rad_clock.h - the one clock for durations: the monotonic clock, which
 * no change of the wall-clock time moves. Times from it mean something
 * only as differences (stage times, progress rates, per-pair ticks).
 */
#ifndef RAD_CLOCK_H
#define RAD_CLOCK_H

/* Seconds since an unspecified start. */
double rad_clock_seconds(void);

/* Nanoseconds since the same start: the per-pair timers' ticks
 * (rad_ff_pair.h's RAD_FF_TICKS on the CPU). */
long long rad_clock_ns(void);

#endif
