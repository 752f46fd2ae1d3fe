// A rank's own tiles under MPI (see tile_owner.h).
#include "integrators/tile_owner.h"

#include <algorithm>
#include <stdexcept>
#include <string>

namespace cierzo {

TileBands::TileBands(int width, int height, int ranks)
    : width_(width),
      height_(height),
      ranks_(std::max(ranks, 1)),
      tiles_x_((width + kTileSize - 1) / kTileSize),
      tiles_(image_tiles(width, height)) {}

int TileBands::owner(size_t tile) const {
    // (the r with first(r) <= tile < first(r + 1), near tile × ranks / tiles)
    int r = int(std::min<size_t>(tile * size_t(ranks_) / std::max<size_t>(tiles_.size(), 1),
                                 size_t(ranks_ - 1)));
    while (r > 0 && first(r) > tile) --r;
    while (r + 1 < ranks_ && first(r + 1) <= tile) ++r;
    return r;
}

size_t TileBands::tile_of(uint32_t pixel) const {
    const int x = int(pixel % uint32_t(width_)), y = int(pixel / uint32_t(width_));
    return size_t(y / kTileSize) * size_t(tiles_x_) + size_t(x / kTileSize);
}

size_t TileBands::slot(uint32_t pixel) const {
    const int x = int(pixel % uint32_t(width_)), y = int(pixel / uint32_t(width_));
    const size_t k = tile_of(pixel);
    const Tile& t = tiles_[k];
    return (k - first(owner(k))) * kSlots + size_t(y - t.y0) * size_t(t.x1 - t.x0) +
           size_t(x - t.x0);
}

TileOwner::TileOwner(const TileBands& bands, int rank, size_t light_units, bool splats,
                     TilePool& pool, bool error)
    : bands_(bands),
      pool_(pool),
      first_(bands.first(rank)),
      count_(bands.count(rank)),
      light_units_(light_units),
      splats_(splats),
      error_(error),
      film_(count_ * TileBands::kSlots),
      next_(count_ * TileBands::kSlots),
      done_(count_, 0) {
    check_complete();  // (a band of no tiles has every pass at once)
}

TileOwner::Aside& TileOwner::aside(int32_t pass) {
    Aside& a = aside_[pass];
    if (a.tiles.empty()) a.tiles.resize(count_);
    if (splats_ && !a.splats_sized) {
        a.splats.reset(count_ * TileBands::kSlots);
        a.splats_sized = true;
    }
    return a;
}

void TileOwner::restore(BandState&& s) {
    std::lock_guard lock(mutex_);
    if (s.film.size() != film_.size()) throw std::logic_error("a band restored of another size");
    film_ = std::move(s.film);
    batches_ = s.batches, nonfinite_splats_ = s.nonfinite_splats;
    if (!s.pending_tiles.empty() && !splats_) {
        for (size_t j = 0; j < count_; ++j) {
            if (!s.pending_tiles[j]) continue;
            std::copy_n(s.pending.begin() + ptrdiff_t(j * TileBands::kSlots), TileBands::kSlots,
                        next_.begin() + ptrdiff_t(j * TileBands::kSlots));
            done_[j] = 1;
            ++done_count_;
        }
    }
    check_complete();
}

void TileOwner::add_next(size_t j, const FilmTile& sums) {
    const std::span<const PixelSums> px = sums.pixels();
    const PixelSums* film = film_.data() + j * TileBands::kSlots;
    PixelSums* next = next_.data() + j * TileBands::kSlots;
    for (size_t i = 0; i < px.size(); ++i) {
        PixelSums p = film[i];  // (as Film::merge adds: the film's sums plus the pass's)
        p.merge(px[i]);
        next[i] = p;
    }
}

void TileOwner::drop(int32_t pass) {
    auto it = aside_.find(pass);
    if (it == aside_.end()) return;
    for (std::optional<FilmTile>& t : it->second.tiles)
        if (t) pool_.give(std::move(*t));
    aside_.erase(it);
}

void TileOwner::complete(UnitResult&& r) {
    std::lock_guard lock(mutex_);
    if (stopped_) {
        pool_.give(std::move(r.sums));
        return;
    }
    const size_t k = size_t(r.unit.tile) - light_units_;
    if (size_t(r.unit.tile) < light_units_ || k < first_ || k >= first_ + count_)
        throw std::runtime_error("a unit of tile " + std::to_string(r.unit.tile) +
                                 " came to a rank that does not own it");
    if (r.unit.pass < frontier_)
        throw std::runtime_error("a unit of pass " + std::to_string(r.unit.pass) +
                                 " came after that pass was added");
    const size_t j = k - first_;
    catch_up_locked();
    Aside& a = aside(r.unit.pass);
    a.rays += r.rays;
    const bool twice =
        r.unit.pass == frontier_ && !splats_ ? done_[j] != 0 : a.tiles[j].has_value();
    if (twice) throw std::runtime_error("a unit was rendered twice");
    if (!splats_ && r.unit.pass == frontier_) {
        add_next(j, r.sums);
        pool_.give(std::move(r.sums));
        done_[j] = 1;
        ++done_count_;
    } else {
        a.tiles[j] = std::move(r.sums);
        ++a.tiles_in;
    }
    check_complete();
}

void TileOwner::add_splats(int32_t pass, const std::vector<Splat>& splats) {
    std::lock_guard lock(mutex_);
    if (stopped_) return;
    if (pass < frontier_)
        throw std::runtime_error("splats of pass " + std::to_string(pass) +
                                 " came after that pass was added");
    remapped_.resize(splats.size());
    const size_t pixels = size_t(bands_.width()) * size_t(bands_.height());
    for (size_t i = 0; i < splats.size(); ++i) {
        const Splat& s = splats[i];
        if (s.pixel >= pixels) throw std::runtime_error("a splat outside the image");
        const size_t k = bands_.tile_of(s.pixel);
        if (k < first_ || k >= first_ + count_)
            throw std::runtime_error("a splat came to a rank that does not own its pixel");
        remapped_[i] = {uint32_t(bands_.slot(s.pixel)), s.value};
    }
    aside(pass).splats.add(remapped_);
}

void TileOwner::flushed(int32_t pass, const RayCounts& light_rays) {
    std::lock_guard lock(mutex_);
    if (stopped_) return;
    if (pass < frontier_)
        throw std::runtime_error("a rank's splats of pass " + std::to_string(pass) +
                                 " came after that pass was added");
    Aside& a = aside(pass);
    if (++a.flushed > bands_.ranks())
        throw std::runtime_error("more ranks sent their splats of a pass than there are");
    a.rays += light_rays;
    check_complete();
}

void TileOwner::check_complete() {
    if (reported_ || stopped_) return;
    Aside& a = aside(frontier_);
    const int64_t batches = batches_ + (splats_ ? 1 : 0);
    if (splats_) {
        if (a.tiles_in < count_ || a.flushed < bands_.ranks()) return;
        // The whole pass as one batch per pixel: the film plus the tile's camera sums and
        // its splats, into next_
        for (size_t j = 0; j < count_; ++j) {
            const Tile& g = bands_.tile(first_ + j);
            const size_t n = size_t(g.x1 - g.x0) * size_t(g.y1 - g.y0);
            const std::span<const PixelSums> camera = std::as_const(*a.tiles[j]).pixels();
            for (size_t i = 0; i < n; ++i) {
                const size_t s = j * TileBands::kSlots + i;
                const double splat[3] = {a.splats.at(s, 0), a.splats.at(s, 1), a.splats.at(s, 2)};
                PixelSums p = film_[s];
                add_batch(p, camera[i], splat);
                next_[s] = p;
            }
        }
    } else if (done_count_ < count_) {
        return;
    }
    PassReport rep;
    rep.pass = frontier_;
    rep.rays = a.rays;
    if (error_) rep.error.add({next_.data(), next_.size()}, batches);
    report_ = rep;
    reported_ = true;
    if (ready_) ready_();
}

void TileOwner::announce(int32_t pass) {
    std::lock_guard lock(mutex_);
    announced_ = std::max(announced_, pass);
}

void TileOwner::catch_up() {
    std::lock_guard lock(mutex_);
    catch_up_locked();
}

void TileOwner::catch_up_locked() {
    while (!stopped_ && frontier_ < announced_) advance_locked(frontier_ + 1);
}

void TileOwner::advance_locked(int32_t pass) {
    if (!reported_ || pass != frontier_ + 1)
        throw std::runtime_error("rank 0 announced pass " + std::to_string(pass) +
                                 " before this rank had pass " + std::to_string(frontier_));
    std::swap(film_, next_);
    if (splats_) {
        ++batches_;
        nonfinite_splats_ += aside_[frontier_].splats.nonfinite();
    }
    drop(frontier_);
    frontier_ = pass;
    std::fill(done_.begin(), done_.end(), 0);
    done_count_ = 0;
    reported_ = false;
    report_.reset();
    if (!splats_) {
        // Units of the new pass in progress done early join next_
        auto it = aside_.find(frontier_);
        if (it != aside_.end()) {
            for (size_t j = 0; j < count_; ++j) {
                if (!it->second.tiles[j]) continue;
                add_next(j, *it->second.tiles[j]);
                pool_.give(std::move(*it->second.tiles[j]));
                it->second.tiles[j].reset();
                done_[j] = 1;
                ++done_count_;
            }
            it->second.tiles_in = 0;
        }
    }
    check_complete();
}

void TileOwner::stop(int32_t pass) {
    std::lock_guard lock(mutex_);
    if (stopped_) return;
    announced_ = std::max(announced_, pass);
    catch_up_locked();
    stopped_ = true;
    while (!aside_.empty()) drop(aside_.begin()->first);
}

std::optional<PassReport> TileOwner::take_report() {
    std::lock_guard lock(mutex_);
    return std::exchange(report_, std::nullopt);
}

BandState TileOwner::snapshot() {
    std::lock_guard lock(mutex_);
    catch_up_locked();
    BandState s;
    s.film = film_;
    s.batches = batches_;
    s.nonfinite_splats = nonfinite_splats_;
    if (!splats_ && done_count_ > 0) {
        s.pending_tiles = done_;
        s.pending = next_;
    }
    return s;
}

}  // namespace cierzo
