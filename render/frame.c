#include "frame.h"

#include <math.h>
#include <stdlib.h>

#include "rad_color.h"
#include "rad_log.h"
#include "raster.h"

/* The near clipping plane sits at this fraction of the depth of the
 * farthest vertex: close enough never to cut visible geometry in a scene
 * viewed from outside, far enough that 1/w stays well conditioned. */
#define RENDER_NEAR_FRACTION 1e-6

render_frame_options render_frame_options_resolve(const render_frame_options *options)
{
    render_frame_options r = *options;
    if (r.width == 0) r.width = RENDER_DEFAULT_WIDTH;
    if (r.height == 0) r.height = RENDER_DEFAULT_HEIGHT;
    if (r.spp == 0) r.spp = RENDER_DEFAULT_SPP;
    if (r.channels == 0) r.channels = 3;
    return r;
}

/* World position -> clip space (x, y scaled by the lens, w = depth). */
static render_vertex to_clip(const render_view *view, const double *p, const double *corner, int channels)
{
    rad_vec3 d = rad_v3_sub(rad_v3(p[0], p[1], p[2]), view->eye);
    render_vertex v;
    v.x = rad_v3_dot(d, view->right) / view->tan_half_x;
    v.y = rad_v3_dot(d, view->up) / view->tan_half_y;
    v.w = rad_v3_dot(d, view->forward);
    for (int c = 0; c < 3; c++) v.color[c] = c < channels ? (float)corner[c] : 0.0f;
    return v;
}

rad_status render_frame_draw(const rad_mesh *mesh, const double *radiosity, const render_camera *camera,
                             const render_frame_options *options, float *out_rgb)
{
    rad_status status = RAD_OK;
    double *corners = NULL;
    render_vertex *verts = NULL;
    render_frame_options opt = render_frame_options_resolve(options);
    render_view view;
    status = render_view_init(camera, (double)opt.width / (double)opt.height, &view);
    if (status != RAD_OK) goto done;
    if (opt.channels != 1 && opt.channels != 3) {
        rad_error("%d channels per pixel (expected 1 or 3)", opt.channels);
        status = RAD_ERR_INVALID;
        goto done;
    }

    size_t n = mesh->patch_count, nc = (size_t)opt.channels;
    /* Corners are shaded in RGB; one channel is channel 0 of them, or
     * their luminance (opt.luminance), so that a grey picture of a colour
     * scene is exactly the luminance of its colour picture (shading is not
     * linear where the limiter acts). */
    corners = malloc((n ? n : 1) * 4 * 3 * sizeof *corners);
    verts = malloc((n ? n : 1) * 6 * sizeof *verts); /* at most two triangles per patch */
    if (!corners || !verts) {
        rad_error("out of memory for %zu patches", n);
        status = RAD_ERR_NOMEM;
        goto done;
    }
    status = render_shade_corners_smoothed(mesh, radiosity, 3, opt.shading, opt.smoothing, corners);
    if (status != RAD_OK) goto done;
    if (nc == 1)
        for (size_t k = 0; k < 4 * n; k++) corners[k] = opt.luminance ? rad_luminance(&corners[3 * k]) : corners[3 * k];

    size_t tri_count = 0;
    double far_w = 0.0;
    for (size_t p = 0; p < n; p++) {
        const rad_patch *patch = &mesh->patches[p];
        render_vertex c[4];
        if (patch->vertex_count < 3 || patch->vertex_count > 4) { /* render_shade_corners refused those */
            status = RAD_ERR_INVALID;
            goto done;
        }
        for (uint32_t k = 0; k < patch->vertex_count; k++) {
            c[k] = to_clip(&view, &mesh->positions[3 * (size_t)patch->v[k]], &corners[(4 * p + k) * nc],
                           opt.channels);
            far_w = fmax(far_w, c[k].w);
        }
        verts[3 * tri_count + 0] = c[0];
        verts[3 * tri_count + 1] = c[1];
        verts[3 * tri_count + 2] = c[2];
        tri_count++;
        if (patch->vertex_count == 4) {
            verts[3 * tri_count + 0] = c[0];
            verts[3 * tri_count + 1] = c[2];
            verts[3 * tri_count + 2] = c[3];
            tri_count++;
        }
    }
    render_raster_options ropt = {opt.width, opt.height, opt.spp, 1,
                                  far_w > 0.0 ? RENDER_NEAR_FRACTION * far_w : 1.0, opt.channels};
    status = render_raster_draw(&ropt, verts, tri_count, out_rgb);
done:
    free(corners);
    free(verts);
    return status;
}
