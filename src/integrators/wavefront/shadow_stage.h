// Wavefront stage 6, shadow rays: the queued rays towards point lights and emitter samples
// (nee, mis), K at a time, any-hit against the analytic primitives and the meshes (one ray
// at a time through their 8-wide BVHs); an unblocked ray adds its contribution to its
// path's radiance.
#pragma once

#include "integrators/wavefront/intersect_stage.h"

namespace cierzo {
inline namespace CIERZO_ISA_NAMESPACE {

// Chunk `i` of the shadow queue (K rays from entry i): the rays, where they end, the lanes
// that hold a queued ray and how many; counted in the shadow lanes' use.
template <class A>
struct ShadowChunk {
    Ray<typename Wave<A>::F> ray;
    typename Wave<A>::F tmax;
    typename Wave<A>::M queued;
    int32_t lanes;
};
template <class A>
ShadowChunk<A> shadow_chunk(Wave<A>& w, int32_t i) {
    using F = typename Wave<A>::F;
    constexpr int32_t K = Wave<A>::K;
    const PathPool& p = w.pool;
    const int32_t lanes = std::min(K, p.shadow_count - i);
    w.counters.shadow_active += uint64_t(lanes);
    w.counters.shadow_total += uint64_t(K);
    return {{load3<F>(p.sox, p.soy, p.soz, i), load3<F>(p.sdx, p.sdy, p.sdz, i)},
            F::load_aligned(p.stmax + i),
            Wave<A>::lane_index() < F(float(lanes)),
            lanes};
}

// The queued rays with many in flight (intersect_stage.h, grouped): which are blocked, all
// first (the unbounded primitives K rays at a time, then the tree), then the radiance
// updates in the order of the queue, as trace_shadow_rays makes them.
template <class A>
CIERZO_STAGE void trace_shadow_rays_grouped(Wave<A>& w) {
    using F = typename Wave<A>::F;
    constexpr int32_t K = Wave<A>::K;
    PathPool& p = w.pool;
    const FlatScene& s = w.scene;
    const int32_t count = p.shadow_count;
    const GroupArrays g = group_arrays(p);
    int32_t n = 0;
    for (int32_t i = 0; i < count; i += K) {
        const ShadowChunk<A> c = shadow_chunk(w, i);
        const auto blocked = occluded_unbounded(
            c.ray, c.tmax, typename Wave<A>::M(false), s.plane_count, PlaneTable<F>{s.plane_lanes},
            s.unbounded_quadric_count, QuadricTable<F>{s.quadric_lanes, s.unbounded_quadrics});
        const uint32_t b = mask_bits(blocked);
        for (int32_t l = 0; l < c.lanes; ++l) p.group_blocked[i + l] = uint8_t((b >> l) & 1u);
        if (all(blocked)) continue;
        const WideRays<A> rays(c.ray);
        const auto enter = slab_hits<A>(s.bvh->bounds, rays, c.tmax);
        const uint32_t open = mask_bits(c.queued & !blocked & enter);
        gather_group_rays<A>(g, n, rays, open, i, p.stmax + i);
    }
    traverse_group<true, NodeLanes<A>>(*s.bvh, g.rays, n, g.t, g.hits, g.found, s.ray_group,
                                       *g.scratch, s.alpha);
    for (int32_t j = 0; j < n; ++j)
        if (g.found[j]) p.group_blocked[g.ids[j]] = 1;
    for (int32_t q = 0; q < count; ++q) {
        if (p.group_blocked[q]) continue;
        const int32_t owner = p.sowner[q];
        p.rad_r[owner] += p.sc_r[q];
        p.rad_g[owner] += p.sc_g[q];
        p.rad_b[owner] += p.sc_b[q];
    }
}

template <class A>
CIERZO_STAGE_LOOP void trace_shadow_rays(Wave<A>& w) {
    constexpr int32_t K = Wave<A>::K;
    PathPool& p = w.pool;
    const FlatScene& s = w.scene;
    if (grouped(s)) {
        trace_shadow_rays_grouped(w);
        return;
    }
    const int32_t count = p.shadow_count;
    for (int32_t i = 0; i < count; i += K) {
        // Lanes of this chunk that hold a queued ray and are not blocked
        const ShadowChunk<A> c = shadow_chunk(w, i);
        uint32_t open = ~mask_bits(occluded<A>(s, c.ray, c.tmax, c.queued));
        open &= (1u << c.lanes) - 1u;
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
