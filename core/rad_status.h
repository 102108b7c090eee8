/* rad_status.h - the one status type of the project.
 *
 * Every fallible function returns a rad_status; RAD_OK is 0. The message
 * that explains a failure ("file:line: what is wrong") goes through the
 * logger (rad_log.h) at the point where the failure is detected, so callers
 * only propagate the code. Only main() turns a status into an exit code.
 */
#ifndef RAD_STATUS_H
#define RAD_STATUS_H

typedef enum rad_status {
    RAD_OK = 0,
    RAD_ERR_IO,            /* a file cannot be opened, read, written or renamed */
    RAD_ERR_PARSE,         /* malformed text input (OBJ, MTL, camera, options) */
    RAD_ERR_FORMAT,        /* binary file foreign, truncated, corrupt or of a future version */
    RAD_ERR_INVALID,       /* well-formed input whose values are not allowed */
    RAD_ERR_NOMEM,         /* an allocation failed or would exceed a stated limit */
    RAD_ERR_USAGE,         /* bad command line */
    RAD_ERR_BACKEND,       /* Embree, CUDA or MPI reported a failure */
    RAD_ERR_UNSUPPORTED,   /* asked for something this build cannot do */
    RAD_ERR_NOT_CONVERGED, /* an iteration stopped at its limit */
    RAD_STATUS_COUNT
} rad_status;

/* A short constant description ("I/O error", ...); never NULL. */
const char *rad_status_str(rad_status status);

/* The process exit code for a status: 0 for RAD_OK, 2 for usage errors,
 * 3 for not-converged, 1 for everything else. */
int rad_status_exit_code(rad_status status);

#endif
