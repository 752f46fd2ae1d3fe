// Wavefront stage 7, compaction: paths that ended hand their radiance to the film; the
// survivors move to the front of the pool, in order, so every stage works on full batches
// and the free slots at the back are refilled with new camera paths.
#pragma once

#include "integrators/wavefront/camera_stage.h"

namespace cierzo {
inline namespace CIERZO_ISA_NAMESPACE {

template <class A>
void compact_paths(Wave<A>& w, const TileJob& job) {
    PathPool& p = w.pool;
    float* fa[] = {p.ox, p.oy, p.oz, p.dx, p.dy, p.dz, p.beta_r, p.beta_g, p.beta_b,
                   p.rad_r, p.rad_g, p.rad_b};
    uint32_t* ua[] = {p.key, p.pixel};
    int32_t kept = 0, done = 0;
    for (int32_t i = 0; i < w.live; ++i) {
        if (!p.alive[i]) {
            p.done_pixel[done] = p.pixel[i];
            p.done_r[done] = p.rad_r[i], p.done_g[done] = p.rad_g[i], p.done_b[done] = p.rad_b[i];
            ++done;
            continue;
        }
        if (kept != i) {
            for (float* a : fa) a[kept] = a[i];
            for (uint32_t* a : ua) a[kept] = a[i];
        }
        p.bounce[kept] = p.bounce[i] + 1;
        ++kept;
    }
    if (done) job.finish(job.film, done, p.done_pixel, p.done_r, p.done_g, p.done_b);
    w.live = kept;
}

}  // namespace CIERZO_ISA_NAMESPACE
}  // namespace cierzo
