// One instruction set's wavefront kernels come in parts, each a translation unit of its own
// built with that ISA's flags and namespaces (CMakeLists.txt: the object library
// isa_wavefront_<isa>), so the cores of a build share them: the estimators' stage loops are
// the largest functions of the program, and one object holding them all was the build's
// critical path. Each part instantiates one of the templates declared here for IsaArch
// (arch.h); the dispatch below sees only their declarations.
#pragma once

#include <cstddef>
#include <type_traits>

#include "integrators/wavefront/isa/arch.h"
#include "integrators/wavefront/job.h"
#include "integrators/wavefront/path_pool.h"
#include "kernels/bsdf.h"

namespace cierzo {
inline namespace CIERZO_ISA_NAMESPACE {

// The camera paths of a tile whose scene has the one lobe kind kFused, or kLobeCount for
// several (wavefront_tile.h; parts tile_<lobe>.cpp).
template <int kFused, class A>
void render_tile_stages(const FlatScene& scene, PathPool& pool, const TileJob& job,
                        WavefrontCounters& counters);
// A batch of light paths (light_stage.h; part light.cpp).
template <class A>
void render_light_job(const FlatScene& scene, PathPool& pool, const TileJob& job,
                      WavefrontCounters& counters);
// A bidirectional job (bdpt_stage.h; part bdpt.cpp).
template <class A>
void render_bdpt_job(const FlatScene& scene, PathPool& pool, const TileJob& job,
                     WavefrontCounters& counters);
// The traversal alone (intersect_stage.h; part trace.cpp).
template <class A>
void trace_rays_isa(const FlatScene& scene, const float* rays, size_t count,
                    const TraceOptions& options, TraceTotals& totals);

// One unit of work: a batch of light paths, a bidirectional job, or a camera tile run by the
// loop of its scene's lobe kinds.
template <class A>
void render_tile_isa(const FlatScene& scene, PathPool& pool, const TileJob& job,
                     WavefrontCounters& counters) {
    const FlatFeatures& f = scene.features;
    auto run = [&](auto fused) {
        render_tile_stages<decltype(fused)::value, A>(scene, pool, job, counters);
    };
    // (with light tracing, a camera tile only where some emitter is not sampled: the
    // camera's paths bring nothing else)
    if (job.light) return render_light_job<A>(scene, pool, job, counters);
    if (scene.path.bdpt) return render_bdpt_job<A>(scene, pool, job, counters);
    if (!scene.camera_paths) return;
    if (f.lobe_kinds != 1)
        run(std::integral_constant<int, kLobeCount>{});
    else if (f.diffuse)
        run(std::integral_constant<int, kLobeDiffuse>{});
    else if (f.specular)
        run(std::integral_constant<int, kLobeSpecular>{});
    else if (f.mirror)
        run(std::integral_constant<int, kLobeMirror>{});
    else
        run(std::integral_constant<int, kLobeRefract>{});
}

}  // namespace CIERZO_ISA_NAMESPACE
}  // namespace cierzo
