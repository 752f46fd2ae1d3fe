// The entry points of the wavefront kernels for NEON (aarch64's Advanced SIMD); CMake builds this
// file and the parts (parts.h) with that instruction set's flags and their own namespaces (see
// kernels/isa.h).
#include "integrators/wavefront/isa/parts.h"
#include "integrators/wavefront/isa_entries.h"

namespace cierzo {

static_assert(std::is_same_v<IsaArch, xsimd::neon64>, "neon.cpp built without its flags");

void render_tile_neon(const FlatScene& scene, PathPool& pool, const TileJob& job,
                      WavefrontCounters& counters) {
    render_tile_isa<IsaArch>(scene, pool, job, counters);
}

void trace_rays_neon(const FlatScene& scene, const float* rays, size_t count,
                     const TraceOptions& options, TraceTotals& totals) {
    trace_rays_isa<IsaArch>(scene, rays, count, options, totals);
}

}  // namespace cierzo
