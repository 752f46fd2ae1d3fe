// Light tracing in the wavefront (--estimator lt): a batch's paths from the lights, one per
// key of its pixels and samples, each the light-subpath walk of light_subpath_stage.h with
// its light tracing use: the emitter's point and every Phong vertex seen from the pinhole,
// splatted unweighted where nothing blocks the connection.
#pragma once

#include "integrators/wavefront/isa/parts.h"
#include "integrators/wavefront/light_subpath_stage.h"

namespace cierzo {
inline namespace CIERZO_ISA_NAMESPACE {

// The light paths of one batch, to the end.
template <class A>
CIERZO_STAGE_LOOP void render_light_paths(Wave<A>& w, const TileJob& job) {
    TileCursor cursor = tile_cursor(job);
    trace_light_subpaths<LightUse::kLightTracing>(w, job, cursor);
}

template <class A>
void render_light_job(const FlatScene& scene, PathPool& pool, const TileJob& job,
                      WavefrontCounters& counters) {
    Wave<A> w{scene, pool, counters};
    render_light_paths(w, job);
}

}  // namespace CIERZO_ISA_NAMESPACE
}  // namespace cierzo
