/* rad_estimator.h - the form-factor estimators by id and name: what the
 * form-factor file records (rad_ff_info.estimator) and the command line
 * and the stats spell. The estimators themselves are formfactor's
 * (core/ff/rad_ff_kernel.h, rad_ff_pair.h); readers of the file need
 * only their ids, so this header holds no math.
 */
#ifndef RAD_ESTIMATOR_H
#define RAD_ESTIMATOR_H

#include <stdint.h>

typedef enum rad_estimator_id {
    RAD_ESTIMATOR_MC = 1,  /* uniform area-sampled point pairs, kernel-weighted visibility */
    RAD_ESTIMATOR_AUTO = 2, /* MC for far pairs, the near-field contour estimator for near ones
                               (rad_ff_kernel.h) */
    RAD_ESTIMATOR_QMC = 3,  /* point pairs from a randomly shifted Halton sequence, everywhere */
    RAD_ESTIMATOR_ANALYTIC = 4, /* the near-field contour estimator for every pair */
    RAD_ESTIMATOR_QUADRATURE = 5 /* unoccluded factor by adaptive quadrature, visible fraction by
                                    bounded-weight shadow rays (rad_ff_pair.h) */
} rad_estimator_id;

/* Estimator names as the command line and the stats spell them. */
static inline const char *rad_estimator_name(uint32_t id)
{
    switch (id) {
    case RAD_ESTIMATOR_MC: return "mc";
    case RAD_ESTIMATOR_AUTO: return "auto";
    case RAD_ESTIMATOR_QMC: return "qmc";
    case RAD_ESTIMATOR_ANALYTIC: return "analytic";
    case RAD_ESTIMATOR_QUADRATURE: return "quadrature";
    default: return "unknown";
    }
}

/* Parses a name of rad_estimator_name; 0 if it is none. (Host only.) */
static inline int rad_estimator_parse(const char *name, rad_estimator_id *out)
{
    for (uint32_t id = RAD_ESTIMATOR_MC; id <= RAD_ESTIMATOR_QUADRATURE; id++) {
        const char *n = rad_estimator_name(id);
        uint32_t k = 0;
        while (n[k] && n[k] == name[k]) k++;
        if (n[k] == 0 && name[k] == 0) {
            *out = (rad_estimator_id)id;
            return 1;
        }
    }
    return 0;
}

#endif
