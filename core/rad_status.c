#include "rad_status.h"

const char *rad_status_str(rad_status status)
{
    switch (status) {
    case RAD_OK: return "ok";
    case RAD_ERR_IO: return "I/O error";
    case RAD_ERR_PARSE: return "parse error";
    case RAD_ERR_FORMAT: return "bad file format";
    case RAD_ERR_INVALID: return "invalid input";
    case RAD_ERR_NOMEM: return "out of memory";
    case RAD_ERR_USAGE: return "usage error";
    case RAD_ERR_BACKEND: return "backend failure";
    case RAD_ERR_UNSUPPORTED: return "unsupported";
    case RAD_ERR_NOT_CONVERGED: return "not converged";
    case RAD_STATUS_COUNT: break;
    }
    return "unknown status";
}

int rad_status_exit_code(rad_status status)
{
    switch (status) {
    case RAD_OK: return 0;
    case RAD_ERR_USAGE: return 2;
    case RAD_ERR_NOT_CONVERGED: return 3;
    default: return 1;
    }
}
