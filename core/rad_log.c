#include "rad_log.h"

#include <stdio.h>

/* The logger is the one deliberate piece of process-wide state: a sink, its
 * user pointer, a level and a program name, all set by main or a test. */
static rad_log_sink g_sink;
static void *g_user;
static rad_log_level g_level = RAD_LOG_INFO;
static const char *g_program;

void rad_log_set_sink(rad_log_sink sink, void *user)
{
    g_sink = sink;
    g_user = user;
}

void rad_log_set_level(rad_log_level max_level) { g_level = max_level; }
rad_log_level rad_log_get_level(void) { return g_level; }
void rad_log_set_program(const char *program_name) { g_program = program_name; }

void rad_logv(rad_log_level level, const char *format, va_list args)
{
    if (level > g_level) return;
    char message[2048];
    vsnprintf(message, sizeof message, format, args);
    if (g_sink) {
        g_sink(level, message, g_user);
        return;
    }
    const char *tag = level == RAD_LOG_ERROR ? "error: " : level == RAD_LOG_WARN ? "warning: " : "";
    if (g_program)
        fprintf(stderr, "%s: %s%s\n", g_program, tag, message);
    else
        fprintf(stderr, "%s%s\n", tag, message);
    fflush(stderr);
}

void rad_log(rad_log_level level, const char *format, ...)
{
    va_list args;
    va_start(args, format);
    rad_logv(level, format, args);
    va_end(args);
}
