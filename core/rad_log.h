/* rad_log.h - the one logger.
 *
 * All diagnostics (errors, warnings, progress) go through rad_log(); nothing
 * else in the libraries writes to stdout or stderr. The default sink writes
 * "prog: message" lines to stderr. Tests replace the sink to capture
 * messages; MPI programs silence non-zero ranks with rad_log_set_level.
 *
 * Error messages about input follow "file:line: what is wrong".
 */
#ifndef RAD_LOG_H
#define RAD_LOG_H

#include <stdarg.h>

typedef enum rad_log_level {
    RAD_LOG_NONE = -1, /* as a level: drop everything */
    RAD_LOG_ERROR = 0,
    RAD_LOG_WARN = 1,
    RAD_LOG_INFO = 2,
    RAD_LOG_DEBUG = 3
} rad_log_level;

/* A sink receives one complete message (no trailing newline). */
typedef void (*rad_log_sink)(rad_log_level level, const char *message, void *user);

/* Replace the sink; NULL restores the default stderr sink. */
void rad_log_set_sink(rad_log_sink sink, void *user);
/* Messages above `max_level` are dropped (default RAD_LOG_INFO). */
void rad_log_set_level(rad_log_level max_level);
rad_log_level rad_log_get_level(void);
/* Name printed before each default-sink message (default none). */
void rad_log_set_program(const char *program_name);

void rad_log(rad_log_level level, const char *format, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 2, 3)))
#endif
    ;
void rad_logv(rad_log_level level, const char *format, va_list args);

#define rad_error(...) rad_log(RAD_LOG_ERROR, __VA_ARGS__)
#define rad_warn(...) rad_log(RAD_LOG_WARN, __VA_ARGS__)
#define rad_info(...) rad_log(RAD_LOG_INFO, __VA_ARGS__)
#define rad_debug(...) rad_log(RAD_LOG_DEBUG, __VA_ARGS__)

#endif
