// The work of a render and its one owner in one process. The image is split into tiles and
// the paths per pixel into passes; a unit is one tile's samples [s0, s1) of one pass,
// rendered from zero into its own sums by any thread. The coordinator adds each pixel's
// passes to the film in pass order, film + pass 0 + pass 1 + ..., whoever rendered each pass:
// the image is bit-identical for any number of threads. (Under MPI each rank owns a band of
// tiles and adds its passes the same way, and rank 0 only deals: tile_owner.h, unit_dealer.h.)
// A unit of the pass in progress is added as soon as it comes (its tile memory is then used
// again at once, while in cache), into a second film (`next_`: the film with the pass in
// progress added, tile by tile), which becomes the film when the pass is whole (a swap). A
// unit of the next pass, which idle workers may start early, waits aside until its pass is
// the one in progress. So the film always holds whole passes, for the stopping rules at
// pass ends, a stop in the middle of a pass (an interruption) and a checkpoint (which keeps
// the done tiles of `next_` beside it). A first pass from zero needs no second film: its
// units go straight into the (empty) film, 0 + x being x; a checkpoint then reads them back
// out, and nothing but a failure stops a render in its first pass. An
// estimator that splats (light tracing) has units of a second kind, batches of light paths
// (Tile::light, work_units): their splats land anywhere in the image, are added up exactly
// as units come in (SplatSums: integer sums, the same bits in any order), and all its units
// wait aside until the pass is whole; a checkpoint then keeps whole passes only.
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <exception>
#include <limits>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "core/huge_pages.h"
#include "integrators/film.h"
#include "integrators/path_guide.h"
#include "integrators/progress.h"
#include "integrators/render_types.h"
#include "integrators/wavefront/wavefront.h"

namespace cierzo {

using Clock = std::chrono::steady_clock;

inline double seconds_since(Clock::time_point t) {
    return std::chrono::duration<double>(Clock::now() - t).count();
}

// The stopping rules at a pass's end, the same for one process and for ranks: why the render
// stops with `spp_done` paths per pixel in every pixel ("interrupted", "time budget",
// "target error"), or nothing to go on. `error()` gives the film's mean relative error; it is
// called only for a target error, from 16 paths per pixel on (fewer give no trustworthy
// variance).
template <class Error>
std::string stop_at_pass_end(const RenderOptions& options, Clock::time_point start,
                             int64_t spp_done, const Error& error) {
    if (options.cancel && options.cancel->load()) return "interrupted";
    if (options.time_budget > 0.0 && seconds_since(start) >= options.time_budget)
        return "time budget";
    if (options.target_error > 0.0 && spp_done >= 16 &&
        error().value_or(std::numeric_limits<double>::infinity()) <= options.target_error)
        return "target error";
    return {};
}

// One unit's samples [s0, s1): pass `pass` of unit `tile` (a camera tile or a batch of light
// paths, by its index in the render's work_units).
struct Unit {
    int32_t tile = 0;
    int32_t pass = 0;
    int64_t s0 = 0, s1 = 0;
};

struct UnitResult {
    Unit unit;
    FilmTile sums;
    RayCounts rays;
    LaneStats lanes;
};

void add(LaneStats& a, const LaneStats& b);

// Tiles' memory, handed back after use and used again. It comes in chunks of a full tile's
// pixels (16 KiB) carved out of 2 MiB slabs in huge pages (core/huge_pages.h), all freed
// with the pool: fresh tile memory from the heap faulted in 4 KiB pages at some 10 µs each
// here (a 160x160 bdpt render spent a sixth of its time on it).
class TilePool {
public:
    TilePool() = default;
    TilePool(const TilePool&) = delete;
    TilePool& operator=(const TilePool&) = delete;
    // A zeroed tile of g's pixels (none for a batch of light paths).
    FilmTile make(const Tile& g, int image_width);
    // Takes the tile's memory back (a tile that owns its memory just lets it go).
    void give(FilmTile&& tile);

private:
    static constexpr size_t kChunk = size_t(kTileSize) * size_t(kTileSize);  // pixels
    static constexpr size_t kSlabBytes = size_t(2) << 20;
    static constexpr size_t kChunksPerSlab = kSlabBytes / (kChunk * sizeof(PixelSums));
    // (a finished render's slabs go to a cache the next render of the process takes
    // them from: scheduler.cpp)
    struct SlabFree {
        void operator()(PixelSums* p) const;
    };
    static PixelSums* take_slab();
    std::mutex mutex_;
    std::vector<std::unique_ptr<PixelSums, SlabFree>> slabs_;
    size_t carved_ = kChunksPerSlab;  // chunks taken from the last slab
    std::vector<PixelSums*> free_;
};

// Renders units with this process's integrator.
class UnitRenderer {
public:
    UnitRenderer(const Scene& scene, const WavefrontRenderer* wavefront,
                 const std::vector<Tile>& tiles, TilePool& pool, size_t light_store_limit,
                 const StrategyFilm* strategies = nullptr, PathGuide* guide = nullptr)
        : scene_(scene),
          wavefront_(wavefront),
          tiles_(tiles),
          pool_(pool),
          light_store_limit_(light_store_limit),
          strategies_(strategies),
          guide_(guide) {}
    UnitResult render(const Unit& u) const;

private:
    const Scene& scene_;
    const WavefrontRenderer* wavefront_;
    const std::vector<Tile>& tiles_;
    TilePool& pool_;
    size_t light_store_limit_;        // the scalar bidirectional estimators' (RenderOptions)
    const StrategyFilm* strategies_;  // the strategy images recorded, if any
    PathGuide* guide_;                // a guided render's path guide (path_guide.h)
};

// The one owner of the film of a render in one process: hands out units in pass order, keeps
// the units of the pass in progress (and of the next one, which idle threads may start early)
// aside, adds a pass to the film once it is whole, and applies the stopping rules at pass
// ends. A guided render's path guide (path_guide.h) is trained when a pass is whole and the
// next starts at a training point (PathGuide::trains_before); no unit of that next pass is
// handed out before, so every unit of a pass samples the same guide and the training sees
// whole passes.
// Thread-safe: every method takes the lock. Waiters (wait()) are woken only when something
// they wait for happens: a pass is added (units of a new pass can be handed out) or the
// render stops; a finished unit alone wakes nobody.
class Coordinator {
public:
    Coordinator(const Scene& scene, const RenderOptions& options, const std::vector<Tile>& tiles,
                std::vector<int64_t> bounds, Film& film, Clock::time_point start,
                Progress& progress, TilePool& pool, PathGuide* guide = nullptr);

    // Puts back the tiles of the first pass that a checkpoint had already done.
    void restore_pending(const RenderState& state);
    // Up to `n` units (fewer, or none, when none can be handed out now).
    std::vector<Unit> grant(size_t n);
    void complete(UnitResult&& r);
    // Stops now because a render thread failed; the error is rethrown by rethrow_failure.
    void fail(std::exception_ptr e);
    void rethrow_failure() const;
    // Stops now if interrupted (once a first pass is in the film).
    void poll_interrupt();
    bool stopping() const;
    // Blocks until units can be handed out, the render stops, or `timeout` passes.
    void wait(std::chrono::microseconds timeout);
    // The state for a checkpoint: the film and the done tiles of the pass in progress.
    RenderState snapshot(const RenderState* resumed) const;

    std::string stopped_by() const;
    RayCounts rays() const;
    LaneStats lanes() const;

private:
    struct PassWork {
        std::vector<std::optional<FilmTile>> sums;
        std::vector<uint8_t> done;
        size_t done_count = 0;
        size_t cursor = 0;  // next tile to hand out
        RayCounts rays;
        SplatSums splats;  // estimators that splat: the pass's splats, added up as they come
        void reset(size_t tiles, size_t splat_pixels);
    };

    // The next unit of the pass in progress (ahead = 0) or of the next one (ahead = 1).
    std::optional<Unit> take(int32_t ahead);
    // True if the pass in progress is added into `next_` (not straight into the film: a
    // first pass from zero).
    bool into_next() const;
    // Adds unit `t` of the pass in progress (into `next_` if `next`, else into the film).
    // Called without the lock: it touches the tile's pixels alone.
    void add_to_film(size_t t, FilmTile&& sums, bool next);
    // Pixel (x, y) of a done tile of the pass in progress: the film's before the pass, and
    // with the pass added.
    PixelSums before(int x, int y) const;
    PixelSums& added(int x, int y);
    const PixelSums& added(int x, int y) const;
    // True if tile `t` of the pass in progress is done and added (not waiting aside).
    bool in_film(size_t t) const;
    // Adds every whole pass at the front to the film, then applies the stopping rules.
    void commit_passes();
    void stop_locked();

    const RenderOptions& options_;
    const std::vector<Tile>& tiles_;
    const std::vector<int64_t> bounds_;
    Film& film_;
    Clock::time_point start_;
    Progress& progress_;
    TilePool& pool_;
    PathGuide* guide_;
    int width_;
    size_t splat_pixels_;  // the image's pixels for an estimator that splats, else 0
    bool from_zero_;       // the film starts empty (not a resumed render's)
    // Units are added to the film as they come (not for estimators that splat, whose
    // tiles join the pass's splats at its end, nor when strategy images are recorded)
    bool early_;
    // The film with the pass in progress added, for its done tiles (see above); allocated
    // when a pass needs it
    PixelArray next_;  // (not zeroed: a tile is written before it is read)
    // Units of the pass in progress being added to the film now, outside the lock (each
    // into its own tile); a snapshot waits until none is
    int adding_ = 0;
    mutable std::condition_variable added_;
    int32_t passes_ = 0;
    int32_t frontier_ = 0;  // the pass in progress; passes before it are in the film
    int first_ = 0;         // work_[first_] is the pass in progress, the other the next
    PassWork work_[2];
    bool stopping_ = false;
    std::exception_ptr failure_;
    std::string stopped_by_;
    RayCounts rays_;
    LaneStats lane_stats_;
    mutable std::mutex mutex_;
    std::condition_variable cv_;
};

}  // namespace cierzo
