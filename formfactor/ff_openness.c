/* ff_openness.c - how open each face is (ff_openness.h). */
#include "ff_openness.h"

#include "rad_box.h"

double ff_openness_reach(const rad_ff_patch *patches, uint32_t count)
{
    rad_box box = rad_box_empty();
    for (uint32_t f = 0; f < count; f++)
        for (uint32_t k = 0; k < patches[f].vertex_count; k++)
            rad_box_add(&box, (const double[3]){patches[f].p[k].x, patches[f].p[k].y, patches[f].p[k].z});
    return FF_OPEN_REACH * rad_box_diagonal(&box);
}

void ff_openness_bvh(const rad_ff_patch *patches, uint32_t count, double reach, double delta, const ff_bvh *bvh,
                     float *open)
{
#pragma omp parallel for schedule(dynamic, 256)
    for (int64_t f = 0; f < (int64_t)count; f++)
        open[f] = ff_face_openness(&patches[f], (uint32_t)f, reach, delta, bvh->nodes, bvh->tris, bvh->root,
                                   bvh->root_count);
}

rad_status ff_openness(const rad_ff_patch *patches, uint32_t count, const double *triangles,
                       const uint32_t *triangle_face, uint32_t triangle_count, double delta, float *open)
{
    if (count == 0) return RAD_OK;
    ff_bvh bvh;
    rad_status st = ff_bvh_build(triangles, triangle_face, triangle_count, &bvh);
    if (st != RAD_OK) return st;
    ff_openness_bvh(patches, count, ff_openness_reach(patches, count), delta, &bvh, open);
    ff_bvh_free(&bvh);
    return RAD_OK;
}
