// What a render shares with every part of it: its options, its state (as a checkpoint holds
// it), its statistics and outcome, the units of work and the passes. The image is split into
// tiles and the paths per pixel into passes; threads (and, under MPI, other processes) render
// tile × pass units in any order, each from zero, and the units of a pass are added to the
// film in pass order once the whole pass is done. So the image is bit-identical for every
// thread count, process count and interruption. The driver that runs a render is
// integrators/render.h; the schedulers, integrators and ranks below it include this.
#pragma once

#include <atomic>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "integrators/film.h"
#include "integrators/guide_stats.h"
#include "integrators/registry.h"
#include "integrators/strategies.h"
#include "scene/scene.h"

namespace cierzo {

inline constexpr int kTileSize = 16;
static_assert(kTileSize * kTileSize == kMergeTilePaths, "vcm's weights take a full tile's pixels");

// The bidirectional estimators keep a unit's light-subpath vertices (a tile × a pass's
// samples: at most 256 × 16 light paths; about 5 MB at a mean of 10 vertices a path). A unit
// whose light subpaths would take more than this many bytes per thread (RenderOptions::
// light_store_limit) is refused: paths that long come from a survival cap near 1.
inline constexpr size_t kLightStoreLimit = size_t(1) << 30;

// Throws InputError: the scene's unit needs more than `limit` bytes of light-vertex store
// (`vertices` vertices at least).
[[noreturn]] void refuse_light_store(const Scene& scene, size_t limit, size_t vertices);

// Rays traced, by kind.
struct RayCounts {
    uint64_t camera = 0;
    uint64_t extension = 0;
    uint64_t shadow = 0;  // towards point lights, emitter samples and (lt) the pinhole
    uint64_t light = 0;   // the first ray of each path from the lights (lt)
    uint64_t total() const { return camera + extension + shadow + light; }
    RayCounts& operator+=(const RayCounts& o) {
        camera += o.camera, extension += o.extension, shadow += o.shadow, light += o.light;
        return *this;
    }
};

// What a render has reached, as a checkpoint holds it: the film of the passes finished
// (every pixel has `spp_done` paths) and, for the pass in progress [spp_done, pending_end),
// the tiles already done (`pending_tiles`, by tile index of kTileSize tiles in row order):
// `pending` holds their pixels' sums with that pass added (`pending_end` paths; the film's
// pixel plus the pass, in that order), the rest zero.
struct RenderState {
    Film film{0, 0};
    int64_t spp_done = 0;
    int64_t pending_end = 0;
    std::vector<uint8_t> pending_tiles;
    Film pending{0, 0};
    RayCounts rays;        // rays of the passes in `film` (all runs)
    double seconds = 0.0;  // render time of all runs so far
    // A guided render's path guide after the passes in `film` (PathGuide::save; its
    // checkpoints then keep whole passes only: no pending tiles)
    std::vector<char> guide;
};

struct RenderOptions {
    int threads = 0;  // 0: every CPU this process may run on (TBB's default concurrency)
    Integrator integrator = Integrator::kWavefront;
    std::string isa = "auto";  // wavefront: auto, avx512, avx2, sse4.2, neon
    int pool_size = 0;         // wavefront: paths in flight per thread, 0 = default
    int ray_group = 1;         // wavefront: rays in flight per thread through the tree (1-64)
    bool specialise = true;    // wavefront: skip what the scene does not use
    bool progress = true;      // progress line on stderr
    // Stopping early (the image then holds fewer paths per pixel, the same in every pixel):
    double time_budget = 0.0;   // seconds; 0 = none
    double target_error = 0.0;  // mean relative standard error to reach; 0 = none
    // Set (e.g. by SIGINT) to stop: the image then holds the passes finished so far (at
    // least the first), and a checkpoint also keeps the tiles done of the pass in progress
    const std::atomic<bool>* cancel = nullptr;
    // Checkpoints: every `checkpoint_every` seconds, on interruption and at the end, the
    // state is handed to `checkpoint` (which writes it; see integrators/checkpoint.h)
    double checkpoint_every = 0.0;
    std::function<void(const RenderState&)> checkpoint;
    // Continue from this state (read from a checkpoint) instead of from zero
    const RenderState* resume = nullptr;
    // bdpt and vcm: the most bytes a thread's light-vertex store may hold (a unit's light
    // subpaths); a unit that needs more is refused (refuse_light_store)
    size_t light_store_limit = kLightStoreLimit;
    // bdpt with the scalar integrator in one process: also adds every pass's contributions
    // of each strategy to this film (integrators/strategies.h)
    StrategyFilm* strategies = nullptr;
    // A guided render (path_guide.h) trains on the sums of every render thread's records.
    // Always true; the tests clear it (training on one thread's records alone: an unmerged
    // pass) to show that it is caught.
    bool guide_merges_threads = true;
    // Every cell's share α of guided directions until its records choose one (unset: 0,
    // kGuideFirstFraction). The tests' small renders take ½, where no cell's records would
    // choose to sample the guide, to show that what they test changes the image.
    std::optional<float> guide_first_fraction;
    // The records the guide's trainings take before it stops learning (unset:
    // kGuideLearnRecords; the tests set fewer).
    std::optional<uint64_t> guide_learn_records;
};

// Per-process figures of a distributed render (one entry per MPI rank).
struct RankStats {
    int rank = 0;
    std::string host;
    int threads = 1;
    uint64_t rays = 0;              // traced by this rank (passes abandoned at a stop included)
    uint64_t units = 0;             // tile × pass units rendered
    uint64_t bytes_sent = 0;        // in messages to other ranks
    double seconds = 0.0;           // from the start of the render to its last unit
    double idle_seconds = 0.0;      // its render threads' time waiting for a unit, summed
    uint64_t splat_bytes_sent = 0;  // of bytes_sent: splats to the owners of their pixels
    double rays_per_second() const { return seconds > 0 ? double(rays) / seconds : 0.0; }
};

struct RenderStats {
    double seconds = 0.0;
    int threads = 1;
    std::string integrator;
    std::string isa = "scalar";
    uint64_t paths = 0;
    RayCounts rays;  // of the passes in the image, this run's (a resumed run: its own)
    uint64_t nonfinite_samples = 0;
    int64_t spp_resumed = 0;       // paths per pixel the resumed checkpoint already had
    std::vector<RankStats> ranks;  // under MPI: one per rank (empty for one process)
    // Under MPI: the CPU time of rank 0's main thread (handing out units, counting passes,
    // adding the units of its band that other ranks rendered; apart from it, gathering the
    // bands for checkpoints and the image), the units handed out, and the bytes rank 0
    // received
    double rank0_cpu_seconds = 0.0, rank0_gather_cpu_seconds = 0.0;
    double rank0_deal_cpu_seconds = 0.0;  // of rank0_cpu_seconds: the turns that dealt
    uint64_t units_handed_out = 0, bytes_received = 0;
    uint64_t requests = 0, reports = 0;  // requests for units answered, pass reports received
    // Checkpoints written, and the time of the last write (and of all)
    int checkpoint_writes = 0;
    double checkpoint_last_seconds = 0.0, checkpoint_seconds = 0.0;
    // This process's units and what handing them out cost: the render threads' time in the
    // coordinator (taking a unit, handing it in, adding whole passes to the film) and
    // waiting for a unit (at pass ends, when every unit of two passes is out)
    uint64_t units = 0;
    double scheduler_seconds = 0.0, idle_seconds = 0.0;
    int checkpoint_failures = 0;                // writes that failed (each a warning)
    bool checkpoint_final_failed = false;       // the last state could not be written
    std::vector<std::string> warnings;          // e.g. a checkpoint that could not be written
    std::optional<double> mean_relative_error;  // none at 1 path per pixel
    int64_t spp_reached = 0;
    std::string stopped_by;  // empty, or "time budget", "target error", "interrupted"
    // Wavefront only: lane utilisation (live lanes / lanes computed) and the pool
    double shade_lane_utilisation = 0.0, isect_lane_utilisation = 0.0;
    double shadow_lane_utilisation = 0.0;  // of the batches of shadow rays traced
    int pool_size = 0;
    int ray_group = 0;  // wavefront: rays in flight per thread through the tree (scalar: 0)
    size_t pool_bytes = 0;
    size_t light_store_bytes = 0;       // bdpt: the largest thread's light-vertex store
    std::optional<GuideStats> guiding;  // a guided render's path guide (path_guide.h)
    double rays_per_second() const { return seconds > 0 ? double(rays.total()) / seconds : 0.0; }
};

struct RenderResult {
    Film film;
    RenderStats stats;
};

// A unit of work's extent. A camera tile: a rectangle of pixels [x0, x1) × [y0, y1), and the
// samples [s0, s1) of each of its pixels that one pass renders (its camera paths, or for
// light tracing only the count of its samples where the camera traces none). A batch of light
// paths (`light`): the paths from the lights that take the keys of those pixels and samples
// (light path n of a pass has the key of camera sample n), whose splats land anywhere in the
// image; it owns no pixels.
struct Tile {
    int x0, y0, x1, y1;
    int64_t s0 = 0, s1 = 0;
    bool light = false;
};

// The passes: pass k renders samples [bounds[k], bounds[k + 1]) of every pixel. From zero,
// the boundaries are 1, 2, 4, 8, 16 and then every 16 paths per pixel, the last one cut at
// `spp`: a fixed schedule (so the image does not depend on timing), fine enough to stop
// soon after a request. Below 16, a boundary is kept only where the pass it ends has at
// least kMinPassPaths paths over the image's `pixels`: a pass costs every pixel the same
// handling whatever its paths (its sums zeroed, counted, added to the film), which in a
// small image's 1-, 2- and 4-path passes took a third of the render, and a small image's
// early passes are over in milliseconds anyway. From `start` (a resumed render), the same
// boundaries above `start`.
// An estimator that splats is the exception (pass_pixels): its error is estimated from the
// spread of the passes' means (Film::merge_batch), which fewer passes would make coarser.
inline constexpr int64_t kMinPassPaths = int64_t(1) << 20;
std::vector<int64_t> pass_bounds(int64_t start, int64_t spp, int64_t pixels);

// The `pixels` pass_bounds takes for a render of `scene`: its image's, or for an estimator
// that splats kMinPassPaths (no pass joined).
int64_t pass_pixels(const Scene& scene);

// The tiles of a width × height image, kTileSize square, in row order.
std::vector<Tile> image_tiles(int width, int height);

// Rows of the image per batch of light paths: about kLightBatchPixels pixels' keys (times
// the samples of a pass) per unit, whole rows.
inline constexpr int kLightBatchPixels = 1024;
int light_batch_rows(int width);

// The units of one pass: the image's tiles, and for an estimator that splats (`light`) the
// batches of light paths first (the larger work, started first), then the tiles.
std::vector<Tile> work_units(int width, int height, bool light);

}  // namespace cierzo
