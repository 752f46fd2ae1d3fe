// What the per-ISA wavefront kernels are handed besides the scene (scene/flat_scene.h): a
// unit of work and where its results go, and the counters they return.
#pragma once

#include <cstdint>

#include "scene/flat_scene.h"

namespace cierzo {

struct GuideView;
struct GuideRecord;

// A guided render's camera paths (kernels/guiding.h): the guide they sample from (null before
// the first training), the Phong vertices of each path it serves, and where the records go
// when a path ends: deposit(learner, pass, record) (learner null: the guide has stopped
// learning, and no path records).
struct WavefrontGuide {
    const GuideView* view = nullptr;
    int32_t served = 1;
    int32_t pass = 0;
    void* learner = nullptr;
    void (*deposit)(void* learner, int32_t pass, const GuideRecord& record) = nullptr;
};

// One unit of work and where its finished paths go: a camera tile, or a batch of light paths
// (`light`: one per key of the pixels and samples, splatted).
struct TileJob {
    int32_t x0, y0, x1, y1;
    int64_t sample_begin, sample_end;  // the samples of each pixel this job renders
    bool light;
    void* film;
    // Adds the radiance of `count` finished paths (pixel index, radiance) to the film, in
    // order. The film has counted every path of the job before it starts (so paths whose
    // radiance is zero need not be handed over at all), and takes a non-finite radiance
    // back out of that count.
    void (*finish)(void* film, int32_t count, const uint32_t* pixel, const float* r, const float* g,
                   const float* b);
    // Light tracing: adds `count` splats (pixel index anywhere in the image, value), in order.
    void (*splat)(void* film, int32_t count, const uint32_t* pixel, const float* r, const float* g,
                  const float* b);
    // A guided render's camera tile: its guide (null: not guided)
    const WavefrontGuide* guide = nullptr;
};

// How `cierzo trace` takes the rays through the tree: K at a time, each alone (the
// extension stage's way), or as ordered streams of `stream_rays` rays (kernels/
// traverse_stream.h) whose streams below `single_below` rays go on one ray at a time.
struct TraceOptions {
    int stream_rays = 0;  // 0: no streams
    int single_below = 4;
};

// The rays `cierzo trace` hands the kernels, laid out before anything is timed: seven
// columns (origin x, y, z, direction x, y, z, tmax) of trace_stride(count) floats each,
// 64-byte aligned, the last ray repeated to fill a column, so a batch of K rays is seven
// aligned loads.
inline size_t trace_stride(size_t count) { return (count + 15) / 16 * 16; }

// What `cierzo trace` counts: rays, hits and the sum of the hits' distances, and the rays
// traced as streams.
struct TraceTotals {
    uint64_t rays = 0, hits = 0, streamed = 0;
    double sum_t = 0.0;
};

// Counters a tile returns.
struct WavefrontCounters {
    uint64_t camera = 0, extension = 0, shadow = 0;
    uint64_t light = 0;                            // light paths started (lt)
    uint64_t lanes_active = 0, lanes_total = 0;    // shading lane utilisation
    uint64_t isect_active = 0, isect_total = 0;    // intersection lane utilisation
    uint64_t shadow_active = 0, shadow_total = 0;  // shadow-ray lane utilisation
};

}  // namespace cierzo
