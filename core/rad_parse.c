#include "rad_parse.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "rad_log.h"

rad_status rad_parse_uint(const char *option, const char *text, uint64_t min, uint64_t max, uint64_t *out)
{
    char *end = NULL;
    unsigned long long v = 0;
    int ok = text && *text >= '0' && *text <= '9';
    if (ok) {
        errno = 0;
        v = strtoull(text, &end, 10);
        ok = errno == 0 && *end == 0 && v >= min && v <= max;
    }
    if (!ok) {
        rad_error("%s: '%s' is not an integer in [%llu, %llu]", option, text ? text : "", (unsigned long long)min,
                  (unsigned long long)max);
        return RAD_ERR_USAGE;
    }
    *out = v;
    return RAD_OK;
}

rad_status rad_parse_real(const char *option, const char *text, double lo, int lo_inclusive, double hi,
                          int hi_inclusive, double *out)
{
    char *end = NULL;
    double v = 0;
    int ok = text && *text && *text != ' ' && *text != '\t';
    if (ok) {
        errno = 0;
        v = strtod(text, &end);
        ok = *end == 0 && isfinite(v) && !(errno == ERANGE && fabs(v) > 1) && (lo_inclusive ? v >= lo : v > lo) &&
             (hi_inclusive ? v <= hi : v < hi);
    }
    if (!ok) {
        rad_error("%s: '%s' is not a number in %c%g, %g%c", option, text ? text : "", lo_inclusive ? '[' : '(', lo, hi,
                  hi_inclusive ? ']' : ')');
        return RAD_ERR_USAGE;
    }
    *out = v;
    return RAD_OK;
}

rad_status rad_parse_bytes(const char *option, const char *text, double *out)
{
    static const struct {
        const char *suffix;
        double scale;
    } units[] = {{"", 1},          {"B", 1},           {"k", 1e3},         {"kB", 1e3},          {"K", 1e3},
                 {"KB", 1e3},      {"M", 1e6},         {"MB", 1e6},        {"G", 1e9},           {"GB", 1e9},
                 {"T", 1e12},      {"TB", 1e12},       {"P", 1e15},        {"PB", 1e15},         {"Ki", 1024.0},
                 {"KiB", 1024.0},  {"Mi", 1048576.0},  {"MiB", 1048576.0}, {"Gi", 1073741824.0}, {"GiB", 1073741824.0},
                 {"Ti", 1099511627776.0}, {"TiB", 1099511627776.0}, {"Pi", 1125899906842624.0},
                 {"PiB", 1125899906842624.0}};
    char *end = NULL;
    double v = 0;
    int ok = text && *text >= '0' && *text <= '9';
    if (ok) {
        errno = 0;
        v = strtod(text, &end);
        ok = errno == 0 && isfinite(v);
        size_t u = 0, count = sizeof units / sizeof units[0];
        while (ok && u < count && strcmp(end, units[u].suffix) != 0) u++;
        ok = ok && u < count;
        if (ok) v *= units[u].scale;
        ok = ok && v >= 1 && v <= 9223372036854775808.0;
    }
    if (!ok) {
        rad_error("%s: '%s' is not a size in bytes (a number with an optional unit: k, M, G, T, P or Ki, Mi, Gi, "
                  "Ti, Pi; e.g. 50G)",
                  option, text ? text : "");
        return RAD_ERR_USAGE;
    }
    *out = v;
    return RAD_OK;
}
