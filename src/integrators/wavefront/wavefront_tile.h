// The wavefront loop over one tile, for one instruction set: regenerate → intersect →
// surfaces → materials (textured scenes only) → shade → lobes → shadow rays → compact, until every path of the
// tile has ended. Included only by the per-ISA files, which instantiate it.
#pragma once

#include "integrators/wavefront/compact_stage.h"
#include "integrators/wavefront/material_stage.h"
#include "integrators/wavefront/shade_stage.h"
#include "integrators/wavefront/shadow_stage.h"
#include "integrators/wavefront/surface_stage.h"

namespace cierzo {
inline namespace CIERZO_ISA_NAMESPACE {

template <class A>
void render_tile_isa(const FlatScene& scene, PathPool& pool, const TileJob& job,
                     WavefrontCounters& counters) {
    Wave<A> w{scene, pool, counters};
    TileCursor cursor;
    cursor.job = job;
    cursor.tile_width = job.x1 - job.x0;
    cursor.tile_pixels = cursor.tile_width * (job.y1 - job.y0);
    cursor.total = int64_t(cursor.tile_pixels) * (job.sample_end - job.sample_begin);
    cursor.sample = uint32_t(job.sample_begin);
    for (;;) {
        generate_camera_paths(w, cursor);
        if (w.live == 0) break;
        intersect_closest(w);
        resolve_surfaces(w);
        if (scene.features.textures) evaluate_sorted_materials(w, pool.material_starts);
        shade_vertices(w);
        sample_lobes(w);
        trace_shadow_rays(w);
        compact_paths(w, job);
    }
}

}  // namespace CIERZO_ISA_NAMESPACE
}  // namespace cierzo
