#include "rad_parse.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>

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
