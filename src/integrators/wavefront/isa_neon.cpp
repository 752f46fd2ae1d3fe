// Instantiates the wavefront kernels for aarch64's Advanced SIMD (NEON, 4 lanes); CMake
// builds this file alone with its own namespaces (see kernels/isa.h).
#include "integrators/wavefront/isa_entries.h"
#include "integrators/wavefront/wavefront_tile.h"

namespace cierzo {

void render_tile_neon(const FlatScene& scene, PathPool& pool, const TileJob& job,
                      WavefrontCounters& counters) {
    render_tile_isa<xsimd::neon64>(scene, pool, job, counters);
}

void trace_rays_neon(const FlatScene& scene, const float* rays, size_t count,
                     const TraceOptions& options, TraceTotals& totals) {
    trace_rays_isa<xsimd::neon64>(scene, rays, count, options, totals);
}

}  // namespace cierzo
