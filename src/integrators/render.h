// Rendering a scene: the integrator choice, threads, progress, statistics. The image is
// split into tiles that threads take in any order; each pixel's samples are summed in a
// fixed order, so the image is bit-identical for every thread count.
#pragma once

#include <atomic>
#include <cstdint>
#include <string>

#include "integrators/film.h"
#include "scene/scene.h"

namespace cierzo {

inline constexpr int kTileSize = 16;

// Rays traced, by kind.
struct RayCounts {
    uint64_t camera = 0;
    uint64_t extension = 0;
    uint64_t shadow = 0;
    uint64_t total() const { return camera + extension + shadow; }
    RayCounts& operator+=(const RayCounts& o) {
        camera += o.camera, extension += o.extension, shadow += o.shadow;
        return *this;
    }
};

struct RenderOptions {
    int threads = 0;  // 0: every CPU this process may run on (TBB's default concurrency)
    std::string integrator = "wavefront";  // or "scalar", the reference
    std::string isa = "auto";              // wavefront: auto, avx512, avx2, sse4.2, neon
    int pool_size = 0;                     // wavefront: paths in flight per thread, 0 = default
    bool specialise = true;                // wavefront: skip what the scene does not use
    bool progress = true;                  // progress line on stderr
    // Stopping early (the image then holds fewer paths per pixel, the same in every pixel):
    double time_budget = 0.0;    // seconds; 0 = none
    double target_error = 0.0;   // mean relative standard error to reach; 0 = none
    const std::atomic<bool>* cancel = nullptr;  // set (e.g. by SIGINT) to stop after a pass
};

struct RenderStats {
    double seconds = 0.0;
    int threads = 1;
    std::string integrator;
    std::string isa = "scalar";
    uint64_t paths = 0;
    RayCounts rays;
    uint64_t nonfinite_samples = 0;
    std::optional<double> mean_relative_error;  // none at 1 path per pixel
    int64_t spp_reached = 0;
    std::string stopped_by;  // empty, or "time budget", "target error", "interrupted"
    // Wavefront only: lane utilisation (live lanes / lanes computed) and the pool
    double shade_lane_utilisation = 0.0, isect_lane_utilisation = 0.0;
    double shadow_lane_utilisation = 0.0;  // of the batches of shadow rays traced
    int pool_size = 0;
    size_t pool_bytes = 0;
    double rays_per_second() const { return seconds > 0 ? double(rays.total()) / seconds : 0.0; }
};

struct RenderResult {
    Film film;
    RenderStats stats;
};

// A rectangle of pixels [x0, x1) × [y0, y1), and the samples [s0, s1) of each of its pixels
// that one pass renders.
struct Tile {
    int x0, y0, x1, y1;
    int64_t s0 = 0, s1 = 0;
};

// Renders the scene with its settings (resolution, spp, seed) and the options, in passes of
// a few paths per pixel over the whole image, so it can stop between passes with the same
// number of paths in every pixel. Samples are keyed by index: passes change nothing else.
RenderResult render(const Scene& scene, const RenderOptions& options);

}  // namespace cierzo
