// Instantiates the wavefront kernels for SSE4.2; CMake builds this file alone with that
// instruction set's flags and its own namespaces (see kernels/isa.h).
#include "integrators/wavefront/isa_entries.h"
#include "integrators/wavefront/wavefront_tile.h"

namespace cierzo {

void render_tile_sse42(const FlatScene& scene, PathPool& pool, const TileJob& job,
                       WavefrontCounters& counters) {
    render_tile_isa<xsimd::sse4_2>(scene, pool, job, counters);
}

void trace_rays_sse42(const FlatScene& scene, const float* rays, size_t count,
                      const TraceOptions& options, TraceTotals& totals) {
    trace_rays_isa<xsimd::sse4_2>(scene, rays, count, options, totals);
}

}  // namespace cierzo
