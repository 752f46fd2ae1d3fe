// Bidirectional path tracing in the wavefront (--estimator bdpt, and vcm, bpm, ppm), with
// the rules of kernels/bidirectional.h. A job (a tile's pixels × a pass's samples) runs in
// two waves through the same pool, intersection, surface and material stages as the camera's:
//   1. light subpaths, one per camera sample of the job (the sample's key, as lt's), the
//      walk light tracing shares (light_subpath_stage.h): each Phong vertex appended to the
//      thread's light-vertex store and its connection to the pinhole (t = 1) splatted;
//   2. the store is grouped by path (a counting sort of indices), vcm's grid built over it
//      (merge_stage.h), then camera subpaths (connection_stage.h): s = 0 at each hit, the
//      light samples (s = 1) and connections (s, t ≥ 2) queued as shadow rays, vcm's merges;
//      then the roulette, the lobes, and compaction, where ended paths hand their radiance
//      to the film.
#pragma once

#include "integrators/wavefront/compact_stage.h"
#include "integrators/wavefront/connection_stage.h"
#include "integrators/wavefront/isa/parts.h"
#include "integrators/wavefront/light_subpath_stage.h"
#include "integrators/wavefront/merge_stage.h"
#include "integrators/wavefront/shadow_stage.h"

namespace cierzo {
inline namespace CIERZO_ISA_NAMESPACE {

// The whole job: its light subpaths, then its camera subpaths.
template <class A>
CIERZO_STAGE_LOOP void render_bdpt_tile(Wave<A>& w, const TileJob& job) {
    using F = typename Wave<A>::F;
    constexpr int32_t K = Wave<A>::K;
    PathPool& p = w.pool;
    const FlatScene& s = w.scene;
    const bool merging = merges(s.path.estimator.kind);
    const bool has_lights =
        s.light_starts.emitter_probability > 0.0f || s.light_starts.point_count > 0;
    LightVertexStore& st = *p.light_store;
    st.count = 0;
    st.paths_per_sample = (job.x1 - job.x0) * (job.y1 - job.y0);
    st.samples = int32_t(job.sample_end - job.sample_begin);
    if (merging) merging_table(*st.merging, s.path, job, has_lights);
    // 1. The light subpaths
    TileCursor cursor = tile_cursor(job);
    if (has_lights) trace_light_subpaths<LightUse::kBidirectional>(w, job, cursor);
    group_light_vertices(st, int32_t(cursor.total));
    if (merging) build_merge_grid(st);

    // 2. The camera subpaths
    cursor = tile_cursor(job);
    w.live = 0;
    for (;;) {
        const int32_t first = w.live;
        const uint32_t seq0 = uint32_t(cursor.next);
        generate_camera_paths<true>(w, cursor);
        if (w.live == 0) break;
        number_paths(w, first, seq0);
        for (int32_t i = first / K * K; i < w.live; i += K) {
            const F lane = Wave<A>::lane_index();
            const auto fresh = (lane >= F(float(first - i))) & (lane < F(float(w.live - i)));
            const SubpathMis<F> mis =
                camera_start_mis(s.path, s.pinhole, load3<F>(p.dx, p.dy, p.dz, i));
            select(fresh, mis.vcm, F::load_aligned(p.mis_vcm + i)).store_aligned(p.mis_vcm + i);
            select(fresh, mis.vc, F::load_aligned(p.mis_vc + i)).store_aligned(p.mis_vc + i);
            select(fresh, mis.vm, F::load_aligned(p.mis_vm + i)).store_aligned(p.mis_vm + i);
        }
        int32_t queued = 0;
        each_vertex(w, [&](int32_t i, const Ray<F>& ray, const Surfaces<A>& sf, const auto& read) {
            camera_subpath_batch(w, i, ray, sf, read, queued);
        });
        p.shadow_count = queued;
        trace_shadow_rays(w);
        w.counters.shadow += uint64_t(queued);
        compact_paths(w, job,
                      path_fields(s) | kRadianceFields | kMisFields | field_bit(kFieldPixel) |
                          field_bit(kFieldPathId));
    }
}

template <class A>
void render_bdpt_job(const FlatScene& scene, PathPool& pool, const TileJob& job,
                     WavefrontCounters& counters) {
    Wave<A> w{scene, pool, counters};
    render_bdpt_tile(w, job);
}

}  // namespace CIERZO_ISA_NAMESPACE
}  // namespace cierzo
