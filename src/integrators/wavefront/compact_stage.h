// Wavefront stage 7, compaction: paths that ended hand their radiance to the film; the
// survivors move to the front of the pool, in order, so every stage works on full batches
// and the free slots at the back are refilled with new camera paths.
#pragma once

#include "integrators/wavefront/camera_stage.h"

namespace cierzo {
inline namespace CIERZO_ISA_NAMESPACE {

// Ended paths with radiance go to the film's queue; survivors move down to `kept`, bounce + 1. Both keep
// pool order. A batch is compressed in registers and stored whole at the write position:
// writing at kept <= i never overtakes the batch being read, and the lanes stored past the
// last kept one are overwritten by the next batch or lie beyond the live paths.
template <class A>
void compact_paths(Wave<A>& w, const TileJob& job) {
    using F = typename Wave<A>::F;
    using U = typename Wave<A>::U;
    using I = typename Wave<A>::I;
    constexpr int32_t K = Wave<A>::K;
    PathPool& p = w.pool;
    float* const fa[12] = {p.ox,     p.oy,     p.oz,     p.dx,    p.dy,    p.dz,
                           p.beta_r, p.beta_g, p.beta_b, p.rad_r, p.rad_g, p.rad_b};
    int32_t kept = 0, done = 0;
    for (int32_t i = 0; i < w.live; i += K) {
        const int32_t lanes = std::min(K, w.live - i);
        const uint32_t valid = (1u << lanes) - 1u;
        const uint32_t m = mask_bits(mask_f32(I::load_aligned(p.alive + i) != I(0))) & valid;
        const uint32_t ended = ~m & valid;
        if (ended)
            done = queue_radiant<A>(p, i, ended, load3<F>(p.rad_r, p.rad_g, p.rad_b, i), done);
        for (float* a : fa) compress<A>(F::load_aligned(a + i), m).store_unaligned(a + kept);
        if (w.scene.path.nee)
            compress<A>(F::load_aligned(p.lobe_pdf + i), m).store_unaligned(p.lobe_pdf + kept);
        for (uint32_t* a : {p.key, p.pixel})
            compress<A>(U::load_aligned(a + i), m).store_unaligned(a + kept);
        if (w.scene.path.sampler.kind != Sampler::kIndependent)
            compress<A>(U::load_aligned(p.index + i), m).store_unaligned(p.index + kept);
        compress<A>(U::load_aligned(p.bounce + i) + U(1u), m).store_unaligned(p.bounce + kept);
        kept += std::popcount(m);
    }
    if (done) job.finish(job.film, done, p.done_pixel, p.done_r, p.done_g, p.done_b);
    w.live = kept;
}

}  // namespace CIERZO_ISA_NAMESPACE
}  // namespace cierzo
