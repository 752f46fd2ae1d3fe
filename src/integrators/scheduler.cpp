// Units, their memory and their one owner (see scheduler.h).
#include "integrators/scheduler.h"

#include <algorithm>
#include <cstdint>
#include <mutex>
#include <vector>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif
#include <stdexcept>

#include "integrators/scalar.h"

namespace cierzo {

void add(LaneStats& a, const LaneStats& b) {
    a.shade_active += b.shade_active, a.shade_total += b.shade_total;
    a.isect_active += b.isect_active, a.isect_total += b.isect_total;
    a.shadow_active += b.shadow_active, a.shadow_total += b.shadow_total;
}

// ---- Tiles' memory and rendering -----------------------------------------------------------

namespace {

// The slabs of finished renders, kept for the next render of this process (a converge
// sweep, a Python session): fresh memory costs a page fault and the kernel's zeroing of
// every page, and an estimator that splats holds a whole pass's tiles (64 bytes a pixel,
// 16 MB at 500x500; clearing them was 6.5% of a 4-path bdpt render of that size). At most
// kKeptSlabs are kept; a slab is zeroed tile by tile as it is handed out (FilmTile).
class SlabCache {
public:
    static constexpr size_t kKeptSlabs = 32;  // 64 MB

    ~SlabCache() {
        for (void* p : slabs_) free_large(p, kSlabBytes);
    }
    void* take() {
        std::lock_guard lock(mutex_);
        if (slabs_.empty()) return nullptr;
        void* p = slabs_.back();
        slabs_.pop_back();
        return p;
    }
    void give(void* p) {
        {
            std::lock_guard lock(mutex_);
            if (slabs_.size() < kKeptSlabs) {
                slabs_.push_back(p);
                return;
            }
        }
        free_large(p, kSlabBytes);
    }
    static constexpr size_t kSlabBytes = size_t(2) << 20;

private:
    std::mutex mutex_;
    std::vector<void*> slabs_;
};

SlabCache& slab_cache() {
    static SlabCache cache;
    return cache;
}

}  // namespace

void TilePool::SlabFree::operator()(PixelSums* p) const { slab_cache().give(p); }

PixelSums* TilePool::take_slab() {
    static_assert(SlabCache::kSlabBytes == kSlabBytes);
    void* p = slab_cache().take();
    return static_cast<PixelSums*>(p ? p : allocate_large(kSlabBytes));
}

FilmTile TilePool::make(const Tile& g, int image_width) {
    if (g.light) return FilmTile(g.x0, g.y0, g.x0, g.y0, image_width);  // (owns no pixels)
    if (size_t(g.x1 - g.x0) * size_t(g.y1 - g.y0) > kChunk)
        return FilmTile(g.x0, g.y0, g.x1, g.y1, image_width);  // (larger than a tile: its own)
    PixelSums* memory;
    {
        std::lock_guard lock(mutex_);
        if (!free_.empty()) {
            memory = free_.back();
            free_.pop_back();
        } else {
            if (carved_ == kChunksPerSlab) {
                slabs_.emplace_back(take_slab());
                carved_ = 0;
            }
            memory = slabs_.back().get() + kChunk * carved_++;
        }
    }
    return FilmTile(g.x0, g.y0, g.x1, g.y1, image_width, memory);
}

void TilePool::give(FilmTile&& tile) {
    PixelSums* memory = tile.release();
    if (!memory) return;
    std::lock_guard lock(mutex_);
    free_.push_back(memory);
}

UnitResult UnitRenderer::render(const Unit& u) const {
    Tile t = tiles_[size_t(u.tile)];
    t.s0 = u.s0, t.s1 = u.s1;
    UnitResult r{u, pool_.make(t, scene_.settings.width), {}, {}};
    if (t.light)
        r.sums.splats.reserve(size_t(t.x1 - t.x0) * size_t(t.y1 - t.y0) * size_t(t.s1 - t.s0));
    if (wavefront_) {
        wavefront_->render_tile(t, r.sums, r.rays, r.lanes, guide_, u.pass);
    } else if (bidirectional(scene_.settings.estimator.kind)) {
        if (strategies_)
            r.sums.strategies =
                std::make_shared<StrategyTile>(strategies_->layout(), t.x0, t.y0, t.x1, t.y1);
        render_tile_bdpt_scalar(scene_, t, r.sums, r.rays, light_store_limit_);
    } else {
        render_tile_scalar(scene_, t, r.sums, r.rays, guide_, u.pass);
    }
    return r;
}

// ---- The coordinator -----------------------------------------------------------------------

void Coordinator::PassWork::reset(size_t tiles, size_t splat_pixels) {
    sums.assign(tiles, std::nullopt);
    done.assign(tiles, 0);
    done_count = 0, cursor = 0, rays = {};
    if (splat_pixels) splats.reset(splat_pixels);
}

Coordinator::Coordinator(const Scene& scene, const RenderOptions& options,
                         const std::vector<Tile>& tiles, std::vector<int64_t> bounds, Film& film,
                         Clock::time_point start, Progress& progress, TilePool& pool,
                         PathGuide* guide)
    : options_(options),
      tiles_(tiles),
      bounds_(std::move(bounds)),
      film_(film),
      start_(start),
      progress_(progress),
      pool_(pool),
      guide_(guide),
      width_(scene.settings.width),
      splat_pixels_(splats(scene.settings.estimator.kind)
                        ? size_t(scene.settings.width) * size_t(scene.settings.height)
                        : 0),
      from_zero_(bounds_.empty() || bounds_[0] == 0),
      early_(!splat_pixels_ && !options.strategies) {
    passes_ = int32_t(bounds_.size()) - 1;
    // (nothing to render: a resumed render that had reached its paths per pixel)
    if (passes_ <= 0) stopping_ = true;
    for (PassWork& w : work_) w.reset(tiles_.size(), splat_pixels_);
    if (early_ && (passes_ > 1 || !from_zero_)) {
        next_.resize(size_t(film.width()) * size_t(film.height()));
    }
}

void Coordinator::restore_pending(const RenderState& state) {
    std::lock_guard lock(mutex_);
    if (passes_ <= 0 || state.pending_end != bounds_[1] || state.pending_tiles.empty() ||
        splat_pixels_)
        return;
    if (!early_) throw std::logic_error("tiles of a pass restored where units wait aside");
    PassWork& w = work_[0];
    for (size_t t = 0; t < tiles_.size() && t < state.pending_tiles.size(); ++t) {
        if (!state.pending_tiles[t]) continue;
        // (the state holds the film's tile with the pass added)
        const Tile& g = tiles_[t];
        for (int y = g.y0; y < g.y1; ++y)
            for (int x = g.x0; x < g.x1; ++x) added(x, y) = state.pending.at(x, y);
        w.done[t] = 1;
        ++w.done_count;
    }
    progress_.units_done(w.done_count, 0);
    if (w.done_count == tiles_.size()) commit_passes();
}

std::vector<Unit> Coordinator::grant(size_t n) {
    std::lock_guard lock(mutex_);
    std::vector<Unit> out;
    while (out.size() < n && !stopping_) {
        // The pass in progress first, then the next one
        std::optional<Unit> u = take(0);
        if (!u && frontier_ + 1 < passes_) u = take(1);
        if (!u) break;
        out.push_back(*u);
    }
    return out;
}

void Coordinator::complete(UnitResult&& r) {
    std::unique_lock lock(mutex_);
    add(lane_stats_, r.lanes);
    if (stopping_) return;  // a pass after the last one kept
    const int32_t ahead = r.unit.pass - frontier_;
    if (ahead < 0 || ahead > 1) throw std::logic_error("unit outside the passes in flight");
    PassWork& w = work_[(first_ + ahead) & 1];
    const size_t t = size_t(r.unit.tile);
    if (w.done[t]) throw std::logic_error("a unit was rendered twice");
    w.rays += r.rays;
    if (splat_pixels_) {
        w.splats.add(r.sums.splats);
        r.sums.splats = {};
    }
    if (ahead == 0 && early_) {
        // Into the film, outside the lock: nothing else writes this tile's pixels, and the
        // pass in progress cannot end before this unit is marked done
        ++adding_;
        const bool next = into_next();
        lock.unlock();
        add_to_film(t, std::move(r.sums), next);
        lock.lock();
        if (--adding_ == 0) added_.notify_all();
    } else {
        w.sums[t] = std::move(r.sums);
    }
    w.done[t] = 1;
    ++w.done_count;
    progress_.units_done(1, r.rays.total());
    if (ahead == 0 && w.done_count == tiles_.size()) commit_passes();
}

void Coordinator::fail(std::exception_ptr e) {
    std::lock_guard lock(mutex_);
    if (!failure_) failure_ = e;
    stop_locked();
}

void Coordinator::rethrow_failure() const {
    std::lock_guard lock(mutex_);
    if (failure_) std::rethrow_exception(failure_);
}

void Coordinator::poll_interrupt() {
    std::lock_guard lock(mutex_);
    if (!stopping_ && frontier_ > 0 && options_.cancel && options_.cancel->load()) {
        stopped_by_ = "interrupted";
        stop_locked();
    }
}

bool Coordinator::stopping() const {
    std::lock_guard lock(mutex_);
    return stopping_;
}

void Coordinator::wait(std::chrono::microseconds timeout) {
    std::unique_lock lock(mutex_);
    cv_.wait_for(lock, timeout);
}

RenderState Coordinator::snapshot(const RenderState* resumed) const {
    std::unique_lock lock(mutex_);
    added_.wait(lock, [&] { return adding_ == 0; });
    RenderState s;
    s.film = film_;
    s.spp_done = bounds_[size_t(frontier_)];
    s.rays = rays_;
    if (resumed) s.rays += resumed->rays;
    s.seconds = seconds_since(start_) + (resumed ? resumed->seconds : 0.0);
    const PassWork& w = work_[first_];
    if (frontier_ < passes_ && w.done_count > 0 && !splat_pixels_) {
        s.pending_end = bounds_[size_t(frontier_) + 1];
        s.pending_tiles = w.done;
        s.pending = Film(film_.width(), film_.height());
    }
    // The done tiles of the pass in progress: the film's tile before it, and with it added
    for (size_t t = 0; t < tiles_.size() && frontier_ < passes_; ++t) {
        if (!w.done[t] || tiles_[t].light) continue;
        const Tile& g = tiles_[t];
        for (int y = g.y0; y < g.y1; ++y)
            for (int x = g.x0; x < g.x1; ++x) {
                if (in_film(t)) {
                    if (!splat_pixels_) s.pending.at(x, y) = added(x, y);
                    s.film.at(x, y) = before(x, y);
                } else if (!splat_pixels_) {
                    PixelSums p = film_.at(x, y);
                    p.merge(w.sums[t]->at(x, y));
                    s.pending.at(x, y) = p;
                }
            }
    }
    if (guide_) {
        // (the pass in progress is left out: its tiles' deposits are mixed in its slot
        // with those of its tiles not done; a resumed render renders it again)
        s.pending_end = 0, s.pending_tiles.clear(), s.pending = Film(0, 0);
        s.guide = guide_->save();
    }
    return s;
}

std::string Coordinator::stopped_by() const {
    std::lock_guard lock(mutex_);
    return stopped_by_;
}

RayCounts Coordinator::rays() const {
    std::lock_guard lock(mutex_);
    return rays_;
}

LaneStats Coordinator::lanes() const {
    std::lock_guard lock(mutex_);
    return lane_stats_;
}

std::optional<Unit> Coordinator::take(int32_t ahead) {
    if (frontier_ + ahead >= passes_) return std::nullopt;
    PassWork& w = work_[(first_ + ahead) & 1];
    while (w.cursor < tiles_.size() && w.done[w.cursor]) ++w.cursor;  // (restored tiles)
    if (w.cursor >= tiles_.size()) return std::nullopt;
    const int32_t pass = frontier_ + ahead;
    // (a pass after a training of the guide waits for it)
    if (ahead > 0 && guide_ && PathGuide::trains_before(bounds_[size_t(pass)])) return std::nullopt;
    return Unit{int32_t(w.cursor++), pass, bounds_[size_t(pass)], bounds_[size_t(pass) + 1]};
}

namespace {

// A pixel's sums written around the caches where the CPU can (x86-64: SSE2's streaming
// stores, weakly ordered, so store_fence() follows them before the memory is handed on).
inline void store_streaming(PixelSums& out, const PixelSums& p) {
    static_assert(sizeof(PixelSums) == 64 && alignof(PixelSums) >= 8);
#if defined(__SSE2__)
    if ((reinterpret_cast<uintptr_t>(&out) & 15) == 0) {
        const double* src = reinterpret_cast<const double*>(&p);
        double* dst = reinterpret_cast<double*>(&out);
        for (int k = 0; k < 8; k += 2) _mm_stream_pd(dst + k, _mm_loadu_pd(src + k));
        return;
    }
#endif
    out = p;
}

inline void store_fence() {
#if defined(__SSE2__)
    _mm_sfence();
#endif
}

}  // namespace

bool Coordinator::into_next() const { return frontier_ > 0 || !from_zero_; }

void Coordinator::add_to_film(size_t t, FilmTile&& sums, bool next) {
    const Tile& g = tiles_[t];
    const size_t n = size_t(g.x1 - g.x0);
    for (int y = g.y0; y < g.y1; ++y) {
        PixelSums* film = &film_.at(g.x0, y);
        const PixelSums* add = &sums.at(g.x0, y);
        if (next) {
            // (as Film::merge adds: the film's sums plus the pass's). The second film is
            // written past the caches: it is read again only a pass later, and an ordinary
            // store would first read each line in (a third of this copy's memory traffic).
            PixelSums* out = next_.data() + size_t(y) * size_t(width_) + size_t(g.x0);
            for (size_t i = 0; i < n; ++i) {
                PixelSums p = film[i];
                p.merge(add[i]);
                store_streaming(out[i], p);
            }
        } else {
            for (size_t i = 0; i < n; ++i) film[i].merge(add[i]);
        }
    }
    if (next) store_fence();
    sums.strategies.reset();
    pool_.give(std::move(sums));
}

PixelSums Coordinator::before(int x, int y) const {
    return into_next() ? film_.at(x, y) : PixelSums{};
}

PixelSums& Coordinator::added(int x, int y) {
    return into_next() ? next_[size_t(y) * size_t(width_) + size_t(x)] : film_.at(x, y);
}

const PixelSums& Coordinator::added(int x, int y) const {
    return const_cast<Coordinator&>(*this).added(x, y);
}

bool Coordinator::in_film(size_t t) const {
    const PassWork& w = work_[first_];
    return w.done[t] && !w.sums[t] && !tiles_[t].light;
}

void Coordinator::commit_passes() {
    while (!stopping_ && work_[first_].done_count == tiles_.size()) {
        PassWork& w = work_[first_];
        for (size_t t = 0; t < tiles_.size(); ++t) {
            if (!w.sums[t]) continue;  // (already in the film)
            FilmTile& f = *w.sums[t];
            if (tiles_[t].light) continue;  // (its splats are in w.splats)
            if (splat_pixels_)
                film_.merge_batch(f, w.splats);
            else
                film_.merge(f);
            if (options_.strategies && f.strategies) options_.strategies->merge(*f.strategies);
            f.strategies.reset();
            pool_.give(std::move(f));
        }
        if (splat_pixels_) film_.end_batch(w.splats.nonfinite());
        // (units added into the second film: it is the film now)
        if (early_ && into_next()) std::swap(film_.pixels(), next_);
        rays_ += w.rays;
        w.reset(tiles_.size(), splat_pixels_);
        if (guide_) guide_->commit_pass(frontier_);
        first_ ^= 1;
        ++frontier_;
        if (frontier_ == passes_) {
            stopping_ = true;
            break;
        }
        stopped_by_ = stop_at_pass_end(options_, start_, bounds_[size_t(frontier_)],
                                       [&] { return film_.mean_relative_error(); });
        if (!stopped_by_.empty()) {
            stopping_ = true;
            break;
        }
        // The guide learns from the whole passes before the one now in progress
        if (guide_ && PathGuide::trains_before(bounds_[size_t(frontier_)]))
            guide_->train(bounds_[size_t(frontier_)]);
        // The next pass is now the one in progress: its units done early join the film
        if (early_) {
            PassWork& next = work_[first_];
            for (size_t t = 0; t < tiles_.size(); ++t)
                if (next.sums[t]) {
                    add_to_film(t, std::move(*next.sums[t]), into_next());
                    next.sums[t].reset();
                }
        }
    }
    // (a new pass can be handed out, or the render stops)
    cv_.notify_all();
}

void Coordinator::stop_locked() {
    stopping_ = true;
    cv_.notify_all();
}

}  // namespace cierzo
