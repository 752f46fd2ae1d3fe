// The wavefront integrator: paths advance in SoA batches through one stage at a time
// (see wavefront_tile.h), with SIMD kernels chosen for this CPU at run time. Its public
// face is this one class, which renders tiles into a film like the scalar reference.
#pragma once

#include <memory>

#include "integrators/render_types.h"
#include "integrators/wavefront/isa_entries.h"

namespace cierzo {

class PathGuide;

// Lane utilisation of a render: live lanes over lanes computed.
struct LaneStats {
    uint64_t shade_active = 0, shade_total = 0;
    uint64_t isect_active = 0, isect_total = 0;
    uint64_t shadow_active = 0, shadow_total = 0;
};

class WavefrontRenderer {
public:
    // pool_size: paths in flight per thread (0 picks the default, kDefaultPoolSize).
    // specialise = false runs every stage and lobe kernel whatever the scene uses (for
    // measuring what specialisation to the scene's features saves; same image).
    // light_store_limit: bdpt and vcm, the bytes a thread's light-vertex store may take
    // (RenderOptions::light_store_limit). ray_group: rays a thread keeps in flight through
    // the tree, 1 (one at a time) to kMaxTraversalGroup (kernels/bvh/traverse_group.h; the same
    // hits whatever it is).
    WavefrontRenderer(const Scene& scene, Isa isa, int32_t pool_size = 0, bool specialise = true,
                      size_t light_store_limit = kLightStoreLimit, int32_t ray_group = 1);
    ~WavefrontRenderer();
    static constexpr int32_t kDefaultPoolSize = 512;

    Isa isa() const { return isa_; }
    int32_t pool_size() const { return pool_size_; }
    int32_t ray_group() const;
    size_t pool_bytes() const;
    // bdpt: the largest of the threads' light-vertex stores (bytes; 0 for other estimators)
    size_t light_store_bytes() const;
    // A guided render's records awaiting their paths' ends: the largest thread's table
    size_t guide_record_bytes() const;
    // Thread-safe: each calling thread uses its own path pool. A guided render's camera
    // tiles (nee, mis) sample `guide` and record for it as paths of pass `pass`.
    void render_tile(const Tile& tile, FilmTile& film, RayCounts& rays, LaneStats& lanes,
                     PathGuide* guide = nullptr, int32_t pass = 0) const;
    // Closest hits of `count` rays (seven columns: origin, direction, tmax, laid out as
    // job.h's trace_stride says) through the scene, with this ISA's traversal alone; adds
    // to `totals`.
    void trace(const float* rays, size_t count, const TraceOptions& options,
               TraceTotals& totals) const;

private:
    struct Data;
    std::unique_ptr<Data> data_;
    Isa isa_;
    int32_t pool_size_;
};

}  // namespace cierzo
