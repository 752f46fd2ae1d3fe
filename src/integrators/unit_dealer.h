// Rank 0's part of a render under MPI: it hands out units and counts passes, and nothing of a
// unit's sums comes to it (the owners of the tiles add them: tile_owner.h). It hands out only
// the pass in progress and the next one, in this order to a rank that asks: its own tiles
// of the pass in progress, its own tiles of the next pass, then tiles of the pass in
// progress taken from the end of the band with the most left (then of the next pass). So a
// rank renders its own band while the others keep up, and the tiles of a rank slowed by
// another job go to the others (their sums then travel to the owner). The light batches of
// light tracing, which have no owner, go first to whoever asks. A pass is over when every
// rank has reported its band's part of it; the stopping rules are then applied to the sum
// of their exact error sums, as one process applies them to its film.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "integrators/progress.h"
#include "integrators/render_types.h"
#include "integrators/scheduler.h"
#include "integrators/tile_owner.h"

namespace cierzo {

class UnitDealer {
public:
    // `bounds`: the passes (pass_bounds); `pending`: the first pass's tiles a checkpoint
    // already holds (by image tile; empty: none).
    // `guided`: no unit of a pass after a training of the path guide is handed out before
    // the pass before it is whole (every rank trains then: rank_protocol.h).
    UnitDealer(const TileBands& bands, size_t light_units, std::vector<int64_t> bounds,
               const RenderOptions& options, Clock::time_point start, Progress& progress,
               const std::vector<uint8_t>& pending, bool guided = false);

    // Up to `n` units for rank `rank`.
    std::vector<Unit> grant(int rank, size_t n);
    // Rank `rank`'s report of its band's part of the pass in progress.
    void report(int rank, const PassReport& r);
    // Ctrl-C: stops now (once a first pass is whole), in the middle of the pass in progress.
    void interrupt();

    int32_t frontier() const { return frontier_; }
    int32_t passes() const { return passes_; }
    int64_t bound(int32_t pass) const { return bounds_[size_t(pass)]; }
    // The last pass all of whose units (and all earlier passes') have been handed out; -1: none
    int32_t granted_through() const;
    bool stopping() const { return stopping_; }
    const std::string& stopped_by() const { return stopped_by_; }
    RayCounts rays() const { return rays_; }  // of the passes added
    uint64_t units_granted() const { return granted_; }
    int reports_in() const { return reports_; }  // of the pass in progress

private:
    struct Deal {
        int32_t pass = -1;
        std::vector<size_t> lo, hi;  // per rank: the tiles of its band not yet handed out
        size_t light = 0;            // light batches handed out
        size_t left = 0;             // units not yet handed out
        size_t victim = 0;           // where the search for a band to take from starts
    };
    void open(Deal& d, int32_t pass);
    Deal* deal(int32_t pass);
    std::optional<Unit> take_light(Deal& d);
    std::optional<Unit> take_own(Deal& d, int rank);
    std::optional<Unit> take_other(Deal& d);
    Unit unit(const Deal& d, size_t image_tile) const;
    void end_pass();

    const TileBands& bands_;
    const size_t light_units_;
    const std::vector<int64_t> bounds_;
    const RenderOptions& options_;
    Clock::time_point start_;
    Progress& progress_;
    std::vector<uint8_t> pending_;  // (the first pass's)
    const bool guided_;
    int32_t passes_ = 0;
    int32_t frontier_ = 0;
    Deal deals_[2];
    std::vector<uint8_t> reported_;
    int reports_ = 0;
    ErrorSum error_;
    RayCounts pass_rays_, rays_;
    bool stopping_ = false;
    std::string stopped_by_;
    uint64_t granted_ = 0;
};

}  // namespace cierzo
