// Wavefront stage 6, shadow rays: the queued rays towards point lights and emitter samples
// (nee, mis), K at a time, any-hit against the analytic primitives and the meshes (one ray
// at a time through their 8-wide BVHs); an unblocked ray adds its contribution to its
// path's radiance.
#pragma once

#include "integrators/wavefront/intersect_stage.h"

namespace cierzo {
inline namespace CIERZO_ISA_NAMESPACE {

template <class A>
CIERZO_STAGE_LOOP void trace_shadow_rays(Wave<A>& w) {
    using F = typename Wave<A>::F;
    constexpr int32_t K = Wave<A>::K;
    PathPool& p = w.pool;
    const FlatScene& s = w.scene;
    const int32_t count = p.shadow_count;
    for (int32_t i = 0; i < count; i += K) {
        const Ray<F> ray{load3<F>(p.sox, p.soy, p.soz, i), load3<F>(p.sdx, p.sdy, p.sdz, i)};
        const F tmax = F::load_aligned(p.stmax + i);
        // Lanes of this chunk that hold a queued ray and are not blocked
        const int32_t lanes = std::min(K, count - i);
        w.counters.shadow_active += uint64_t(lanes);
        w.counters.shadow_total += uint64_t(K);
        const auto queued = Wave<A>::lane_index() < F(float(lanes));
        uint32_t open = ~mask_bits(occluded<A>(s, ray, tmax, queued)) & ((1u << lanes) - 1u);
        // The radiance update, per unblocked ray (one path may own several rays)
        while (open) {
            const int32_t q = i + std::countr_zero(open);
            open &= open - 1;
            const int32_t owner = p.sowner[q];
            p.rad_r[owner] += p.sc_r[q];
            p.rad_g[owner] += p.sc_g[q];
            p.rad_b[owner] += p.sc_b[q];
        }
    }
}

}  // namespace CIERZO_ISA_NAMESPACE
}  // namespace cierzo
