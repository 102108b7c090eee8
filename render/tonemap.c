#include "tonemap.h"

#include <math.h>
#include <stdlib.h>

#include "rad_color.h"

typedef struct lum_area {
    double lum, area; /* lum: the brightest channel */
} lum_area;

static int compare_lum(const void *a, const void *b)
{
    double x = ((const lum_area *)a)->lum, y = ((const lum_area *)b)->lum;
    return (x > y) - (x < y);
}

void render_luminance_radiosity(const double *radiosity, size_t patch_count, double *out)
{
    for (size_t p = 0; p < patch_count; p++) {
        double y = rad_luminance(&radiosity[3 * p]);
        out[3 * p] = out[3 * p + 1] = out[3 * p + 2] = y;
    }
}

double render_tonemap_auto_scale(const rad_mesh *mesh, const double *radiosity)
{
    double scale = 1.0;
    size_t count = 0;
    double total = 0.0;
    lum_area *items = malloc((mesh->patch_count ? mesh->patch_count : 1) * sizeof *items);
    if (!items) goto done; /* exposure is cosmetic: fall back to scale 1 */
    for (size_t p = 0; p < mesh->patch_count; p++) {
        const rad_patch *patch = &mesh->patches[p];
        if (patch->emission[0] > 0.0 || patch->emission[1] > 0.0 || patch->emission[2] > 0.0) continue;
        const double *b = &radiosity[3 * p];
        items[count].lum = fmax(b[0], fmax(b[1], b[2]));
        items[count].area = patch->area;
        total += patch->area;
        count++;
    }
    if (count == 0 || !(total > 0.0)) goto done;
    qsort(items, count, sizeof *items, compare_lum);
    double want = RENDER_AUTO_PERCENTILE * total, acc = 0.0, lum = items[count - 1].lum;
    for (size_t i = 0; i < count; i++) {
        acc += items[i].area;
        if (acc >= want) {
            lum = items[i].lum;
            break;
        }
    }
    if (lum > 0.0 && isfinite(lum)) scale = RENDER_AUTO_TARGET / lum;
done:
    free(items);
    return scale;
}

double render_srgb_encode(double linear)
{
    double x = linear > 0.0 ? (linear < 1.0 ? linear : 1.0) : 0.0; /* also maps NaN to 0 */
    return x <= 0.0031308 ? 12.92 * x : 1.055 * pow(x, 1.0 / 2.4) - 0.055;
}

void render_tonemap_apply(float *values, size_t pixel_count, int channels, double scale)
{
    size_t count = (size_t)(channels == 1 ? 1 : 3) * pixel_count;
    for (size_t i = 0; i < count; i++) values[i] = (float)render_srgb_encode(values[i] * scale);
}
