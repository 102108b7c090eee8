/* shaped_gpu_none.c - builds without nvcc: the shaped solve's cuda
 * backend (shaped_gpu.h) that says there is no GPU. solve refuses
 * --backend cuda in such a build before this is reached (stage.c), and
 * auto never picks it (solve_gpu_built). */
#include "rad_log.h"
#include "shaped_gpu.h"

static rad_status none_create(const solve_shaped_device_plan *plan, int device, void **out_state)
{
    (void)plan, (void)device, (void)out_state;
    rad_error("--backend cuda: this build of solve has no CUDA (nvcc was not found when it was configured, or "
              "-DRAD_WITH_CUDA=OFF): the shaped solve runs on the CPU with --backend cpu or auto");
    return RAD_ERR_UNSUPPORTED;
}

static rad_status none_factors(void *state, double *inv_mean)
{
    return (void)state, (void)inv_mean, RAD_ERR_UNSUPPORTED;
}

static rad_status none_drop(void *state, const uint64_t *dropped, uint64_t count, double *row_sum)
{
    return (void)state, (void)dropped, (void)count, (void)row_sum, RAD_ERR_UNSUPPORTED;
}

static rad_status none_materials(void *state, const double *rho, const double *E)
{
    return (void)state, (void)rho, (void)E, RAD_ERR_UNSUPPORTED;
}

static rad_status none_load(void *state, const double *B, const double *Q)
{
    return (void)state, (void)B, (void)Q, RAD_ERR_UNSUPPORTED;
}

static rad_status none_sweep(void *state, double change[3]) { return (void)state, (void)change, RAD_ERR_UNSUPPORTED; }
static rad_status none_accept(void *state) { return (void)state, RAD_ERR_UNSUPPORTED; }

static rad_status none_store(void *state, double *B, double *H)
{
    return (void)state, (void)B, (void)H, RAD_ERR_UNSUPPORTED;
}

static const char *none_device_name(void *state) { return (void)state, "none"; }
static void none_destroy(void *state) { (void)state; }

const solve_shaped_jacobi solve_shaped_jacobi_cuda = {"cuda",     none_create, none_factors,     none_drop,
                                                      none_materials, none_load,  none_sweep,  none_accept,      none_store,
                                                      none_device_name, none_destroy};
