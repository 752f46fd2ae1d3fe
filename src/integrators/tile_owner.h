// A rank's own tiles under MPI. The image's tiles (row order) are cut into one contiguous
// band per rank (TileBands); each rank keeps the film of its band and adds every pass of its
// tiles itself, in pass order, whoever rendered them: its own threads (most units: rank 0
// hands a rank its own tiles first) or another rank that took some (their sums come in a
// message). So a pixel's sums are `0 + pass 0 + pass 1 + ...` as in one process, the image is
// the same bits, and no unit's sums pass through rank 0. The film crosses the network once,
// to rank 0, at a checkpoint and at the end.
//
// The owner follows the pass in progress as rank 0 announces it (advance), in the message
// order from rank 0, so at any message from rank 0 its band is at rank 0's pass: a
// checkpoint then gathers bands of one pass. As in the coordinator (scheduler.h), `film_`
// holds the passes before the pass in progress and `next_` the film with the pass in
// progress added, tile by tile; units of later passes wait aside. An estimator that splats
// adds a pass as one batch (Film::merge_batch) once its tiles and every rank's splats of
// that pass are in (each rank sends each owner its splats of a pass in one message, once it
// has rendered all it was given of that pass: `flushed`). When its band has the pass in
// progress added, the owner reports it to rank 0 with its pixels' exact error sum (ErrorSum),
// from which rank 0 applies the stopping rules as one process does.
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <mutex>
#include <optional>
#include <vector>

#include "integrators/film.h"
#include "integrators/render_types.h"
#include "integrators/scheduler.h"

namespace cierzo {

// Which rank owns which tile: the image's tiles (image_tiles: row order) cut into `ranks`
// contiguous bands of almost equal length; rank r owns [first(r), first(r + 1)). A rank's
// pixels are kept tile by tile, kSlots per tile (a tile's pixels row by row, as FilmTile).
class TileBands {
public:
    static constexpr size_t kSlots = size_t(kTileSize) * size_t(kTileSize);

    TileBands(int width, int height, int ranks);
    int width() const { return width_; }
    int height() const { return height_; }
    int ranks() const { return ranks_; }
    size_t tiles() const { return tiles_.size(); }
    const Tile& tile(size_t k) const { return tiles_[k]; }
    size_t first(int rank) const { return tiles_.size() * size_t(rank) / size_t(ranks_); }
    size_t count(int rank) const { return first(rank + 1) - first(rank); }
    int owner(size_t tile) const;
    // The tile of pixel `pixel` (y * width + x), and the pixel's slot in its owner's band.
    size_t tile_of(uint32_t pixel) const;
    size_t slot(uint32_t pixel) const;

private:
    int width_, height_, ranks_, tiles_x_;
    std::vector<Tile> tiles_;
};

// A band's state: its film, and the tiles done of the pass in progress with that pass added
// (`pending`, flagged per tile in `pending_tiles`, none for an estimator that splats), both
// kSlots pixels per tile; and for estimators that splat, the passes added as batches and the
// splats of this band left out as not finite.
struct BandState {
    std::vector<PixelSums> film;
    std::vector<uint8_t> pending_tiles;  // empty: none
    std::vector<PixelSums> pending;
    int64_t batches = 0;
    uint64_t nonfinite_splats = 0;
};

// A band whose pass in progress is all added: its rays, and its pixels' error sum.
struct PassReport {
    int32_t pass = 0;
    ErrorSum error;  // (when asked for: a target error)
    RayCounts rays;  // of its tiles' units (and at rank 0, of every batch of light paths)
};

class TileOwner {
public:
    // `light_units`: the batches of light paths before the tiles in the render's units
    // (work_units); `splats`: the estimator splats (a pass is added as one batch).
    // Tile memory of units added goes back to `pool`. `error`: the reports carry the band's
    // error sum (for a target error; it reads every pixel of the band).
    TileOwner(const TileBands& bands, int rank, size_t light_units, bool splats, TilePool& pool,
              bool error);

    // The band's state from a checkpoint (before anything else), at pass 0 of this run:
    // its pending tiles are the first pass's tiles already done.
    void restore(BandState&& state);
    // A unit of one of this band's tiles, from any thread (its splats already handed out);
    // After stop(), units are dropped.
    void complete(UnitResult&& r);
    // Splats of pass `pass` that land in this band (pixels by image index), from any thread.
    void add_splats(int32_t pass, const std::vector<Splat>& splats);
    // One rank has sent all its splats of `pass` (and the rays of the light batches it
    // rendered: counted by the owner of band 0).
    void flushed(int32_t pass, const RayCounts& light_rays);
    // Rank 0 announced that the pass in progress is `pass` (the band had every pass before
    // it added and reported). The band moves there (swaps its films, adds the units of
    // `pass` done early) on catch_up(), or at once on anything else that needs it:
    // announce() is the main thread's, catch_up() a render thread's (each band's work is
    // its own rank's render threads', so the main thread of rank 0 only deals).
    void announce(int32_t pass);
    void catch_up();
    // Both at once.
    void advance(int32_t pass) {
        announce(pass);
        catch_up();
    }
    // The render ended at pass `pass`: the band holds the passes before it.
    void stop(int32_t pass);
    // The report of the pass in progress, once, when the band has it all added; `ready` is
    // called (under the owner's lock) when there is one.
    std::optional<PassReport> take_report();
    void on_report(std::function<void()> ready) { ready_ = std::move(ready); }
    BandState snapshot();  // (at the pass announced)
    size_t tiles() const { return count_; }

private:
    void advance_locked(int32_t pass);
    void catch_up_locked();
    // Adds tile j's sums of the pass in progress into next_.
    void add_next(size_t j, const FilmTile& sums);
    void check_complete();
    // Hands the memory of the units waiting aside for `pass` back to the pool, and forgets them.
    void drop(int32_t pass);

    const TileBands& bands_;
    TilePool& pool_;
    const size_t first_, count_, light_units_;
    const bool splats_, error_;
    mutable std::mutex mutex_;
    std::vector<PixelSums> film_, next_;  // count_ × kSlots each
    std::vector<uint8_t> done_;           // tiles of the pass in progress in next_
    size_t done_count_ = 0;
    int32_t frontier_ = 0;
    int32_t announced_ = 0;  // the pass in progress as rank 0 announced it
    bool reported_ = false, stopped_ = false;
    std::optional<PassReport> report_;
    std::function<void()> ready_;
    int64_t batches_ = 0;
    uint64_t nonfinite_splats_ = 0;
    // Per pass not yet added: units waiting aside, splats, ranks flushed, rays
    struct Aside {
        std::vector<std::optional<FilmTile>> tiles;
        size_t tiles_in = 0;
        SplatSums splats;  // (by slot)
        bool splats_sized = false;
        int flushed = 0;
        RayCounts rays;
    };
    std::map<int32_t, Aside> aside_;
    Aside& aside(int32_t pass);
    std::vector<Splat> remapped_;  // (add_splats' scratch, under the lock)
};

}  // namespace cierzo
