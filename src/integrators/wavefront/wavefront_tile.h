// The wavefront loop over one tile, for one instruction set: regenerate → intersect →
// surfaces → materials (textured scenes only) → shade → lobes → shadow rays → compact, until
// every path of the tile has ended. Stages with no reordering between them run on the same
// batch of K paths in registers, one pass over the pool: intersection and surfaces always;
// shading too when there are no textures to sort; the lobe too when the scene has one lobe
// kind. Included only by the per-ISA parts tile_<lobe>.cpp (isa/parts.h), which instantiate it.
#pragma once

#include <type_traits>

#include "integrators/wavefront/bdpt_stage.h"
#include "integrators/wavefront/compact_stage.h"
#include "integrators/wavefront/intersect_stage.h"
#include "integrators/wavefront/isa/parts.h"
#include "integrators/wavefront/light_stage.h"
#include "integrators/wavefront/material_stage.h"
#include "integrators/wavefront/shade_stage.h"
#include "integrators/wavefront/shadow_stage.h"
#include "integrators/wavefront/surface_stage.h"

namespace cierzo {
inline namespace CIERZO_ISA_NAMESPACE {

// Closest hit and surface of every live path, K at a time, then: untextured scenes shade the
// batch at once (no stage between needs the hits reordered), textured ones leave the
// surfaces in the pool for the material sort. (CIERZO_STAGE_LOOP: every kernel it calls is
// inlined; wave.h says why.)
//
// kCompact: shading also retires and compacts each batch (shade_batch says when it may), so
// the wavefront needs no compaction pass and no shadow stage.
template <int kFused, bool kCompact, bool kInlineNee = false, class A>
CIERZO_STAGE_LOOP void trace_paths(Wave<A>& w, const TileJob& job) {
    using F = typename Wave<A>::F;
    using I = typename Wave<A>::I;
    PathPool& p = w.pool;
    const bool textures = w.scene.features.textures;
    int32_t queued = 0;
    Compaction compaction;
    // (with many rays in flight, grouped(): every path's closest hit first)
    const bool group = grouped(w.scene);
    if (group) closest_hits_grouped(w);
    const int32_t end = w.rounded_up(w.live);
    for (int32_t i = 0; i < end; i += Wave<A>::K) {
        const Ray<F> ray{load3<F>(p.ox, p.oy, p.oz, i), load3<F>(p.dx, p.dy, p.dz, i)};
        F t;
        I prim;
        batch_closest_hit(w, i, ray, t, prim, group);
        const Surfaces<A> sf = resolve_surfaces(w, i, ray, t, prim);
        // The surfaces are stored for the stages that read them back: the material sort,
        // and the lobe buckets (which gather hit points, normals and materials)
        if (textures || kFused == kLobeCount) store_surfaces(w, i, sf);
        if (textures)
            prim.store_aligned(p.prim + i);
        else
            shade_batch<kFused, kCompact, kInlineNee>(w, i, ray, sf, queued, &compaction);
    }
    if constexpr (kCompact) {
        if (compaction.done)
            job.finish(job.film, compaction.done, p.done_pixel, p.done_r, p.done_g, p.done_b);
        w.live = compaction.kept;
    } else {
        p.shadow_count = queued;
        w.counters.shadow += uint64_t(queued);
    }
}

// The wavefront loop of one tile; kFused is the scene's only lobe kind, or kLobeCount.
template <int kFused, class A>
void render_tile_stages(const FlatScene& scene, PathPool& pool, const TileJob& job,
                        WavefrontCounters& counters) {
    Wave<A> w{scene, pool, counters};
    TileCursor cursor = tile_cursor(job);
    const FlatFeatures& f = scene.features;
    w.guide = job.guide;
    if (job.guide) pool.guide_records->count = 0;
    if constexpr (kFused != kLobeCount) {
        // One lobe, no point lights, no textures: shading compacts, no radiance is carried;
        // with nee or mis, shading also traces the emitter sample and carries radiance
        // (an environment is gathered by paths that miss: radiance is carried, shading does
        // not compact; a guided render's paths carry radiance for their records)
        const bool escapes = has_environment(scene.path);
        if (!f.lights && !f.textures && !scene.path.nee && !escapes && !job.guide) {
            for (;;) {
                generate_camera_paths<false>(w, cursor);
                if (w.live == 0) return;
                trace_paths<kFused, true>(w, job);
            }
        }
        // (with many rays in flight, the emitter samples' shadow rays go to the shadow stage,
        // which groups them: the loop below)
        if (!f.lights && !f.textures && scene.path.nee && !escapes && !grouped(scene)) {
            for (;;) {
                generate_camera_paths<true>(w, cursor);
                if (w.live == 0) return;
                trace_paths<kFused, true, true>(w, job);
            }
        }
    }
    for (;;) {
        generate_camera_paths<true>(w, cursor);
        if (w.live == 0) break;
        trace_paths<kFused, false>(w, job);
        if (f.textures) {
            evaluate_sorted_materials(w, pool.material_starts);
            shade_stored<kFused>(w);
        }
        if (kFused == kLobeCount && f.lobe_kinds > 1) sample_lobes(w);
        trace_shadow_rays(w);
        compact_paths(w, job);
    }
}

}  // namespace CIERZO_ISA_NAMESPACE
}  // namespace cierzo
