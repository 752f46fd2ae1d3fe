// Instantiates the wavefront kernels for AVX-512 (F, CD, DQ, BW, VL) with FMA; CMake builds
// this file alone with that instruction set's flags and its own namespaces (kernels/isa.h).
#include "integrators/wavefront/isa_entries.h"
#include "integrators/wavefront/wavefront_tile.h"

namespace cierzo {

void render_tile_avx512(const FlatScene& scene, PathPool& pool, const TileJob& job,
                        WavefrontCounters& counters) {
    render_tile_isa<xsimd::avx512bw>(scene, pool, job, counters);
}

void trace_rays_avx512(const FlatScene& scene, const float* rays, size_t count,
                       const TraceOptions& options, TraceTotals& totals) {
    trace_rays_isa<xsimd::avx512bw>(scene, rays, count, options, totals);
}

}  // namespace cierzo
