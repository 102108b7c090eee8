/* gpu_none.c - builds without nvcc: no GPU, and a device matrix that
 * cannot be made (solve --backend cuda is refused before this is reached:
 * main.c). */
#include "gpu.h"
#include "rad_log.h"

int solve_gpu_built(void) { return 0; }
int solve_gpu_device_count(void) { return 0; }

rad_status solve_gpu_create(const solve_gpu_tiles *tiles, const double *area, solve_gpu **out_gpu)
{
    (void)tiles, (void)area, (void)out_gpu;
    rad_error("--backend cuda: this build of solve has no CUDA (nvcc was not found when it was configured)");
    return RAD_ERR_UNSUPPORTED;
}

rad_status solve_gpu_create_ranks(const solve_gpu_tiles *tiles, const double *area, const solve_gpu_ranks *ranks,
                                  solve_gpu **out_gpu)
{
    (void)ranks;
    return solve_gpu_create(tiles, area, out_gpu);
}

/* As gpu_cuda.cu's (256 rows a chunk, at most 512 chunks), so that a split
 * made in a build without CUDA would be the same. */
size_t solve_gpu_row_quantum(size_t n)
{
    size_t blocks = (n + 256 * 512 - 1) / (256 * 512);
    return 256 * (blocks ? blocks : 1);
}

void solve_gpu_destroy(solve_gpu *gpu) { (void)gpu; }
int solve_gpu_exact(const solve_gpu *gpu) { return (void)gpu, 0; }
void solve_gpu_set_exact(solve_gpu *gpu, int exact) { (void)gpu, (void)exact; }
const char *solve_gpu_device_name(const solve_gpu *gpu) { return (void)gpu, "none"; }
size_t solve_gpu_matrix_bytes(const solve_gpu *gpu) { return (void)gpu, 0; }

rad_status solve_gpu_multiply(solve_gpu *gpu, size_t count, const double *const *x, double *const *y)
{
    (void)gpu, (void)count, (void)x, (void)y;
    return RAD_ERR_UNSUPPORTED;
}

rad_status solve_gpu_lanes_load(solve_gpu *gpu, size_t count, const double *const *rho, const double *const *E,
                                const double *const *B, const double *e_norm)
{
    (void)gpu, (void)count, (void)rho, (void)E, (void)B, (void)e_norm;
    return RAD_ERR_UNSUPPORTED;
}

rad_status solve_gpu_lanes_store(solve_gpu *gpu, size_t lane, double *out_B)
{
    (void)gpu, (void)lane, (void)out_B;
    return RAD_ERR_UNSUPPORTED;
}

rad_status solve_gpu_lanes_iterate(solve_gpu *gpu, const solve_gpu_op *ops, double *out_omega)
{
    (void)gpu, (void)ops, (void)out_omega;
    return RAD_ERR_UNSUPPORTED;
}

rad_status solve_gpu_cg_restart(solve_gpu *gpu, const int *restart)
{
    (void)gpu, (void)restart;
    return RAD_ERR_UNSUPPORTED;
}

void solve_gpu_jacobi_accept(solve_gpu *gpu, size_t lane) { (void)gpu, (void)lane; }
void solve_gpu_prestart(int rank) { (void)rank; }
void solve_gpu_prestart_join(void) {}
