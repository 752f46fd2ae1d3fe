// A render across MPI ranks (integrators/distributed.h). Every rank renders units on its
// threads and owns a band of tiles (tile_owner.h), whose passes it adds itself; rank 0 also
// hands out units and counts passes (unit_dealer.h). The messages:
//   a rank to rank 0:   Request (how many units it wants and holds), Report (its band has
//                       the pass in progress added: rays and exact error sum), State (its
//                       band for a checkpoint, or at the end);
//   rank 0 to a rank:   Control (units granted, the pass in progress, the last pass handed
//                       out whole, a checkpoint to take, the end), State (its band of a
//                       resumed checkpoint, first);
//   a rank to an owner: Results (the sums of units of the owner's tiles it rendered),
//                       Splats (estimators that splat: its splats of one pass in the owner's
//                       band, once it has rendered all it was given of the pass);
// and in a guided render (path_guide.h):
//   rank 0 to a rank:   GuideStart (the passes' start, and the guide of a resumed
//                       checkpoint, without its sums), first;
//   a rank to a rank:   GuideSums (before a training: its exact sums of the iteration's
//                       passes, to every other rank; each adds them all and trains the same
//                       trees);
//   a rank to rank 0:   GuideState (for a checkpoint or at the end: its guide with its sums,
//                       which rank 0 adds up into the checkpoint's guide).
// The dealer hands out no unit of a pass after a training before the pass before it is
// whole; so at a training every rank's sums hold whole passes, all of them.
// Rank 0 sends to itself through a local queue, so every rank runs the same loop. The
// messages and their codec: rank_messages.h.
#pragma once

#include <cstdint>
#include <functional>
#include <stdexcept>
#include <string>
#include <vector>

#include "integrators/scheduler.h"
#include "integrators/rank_messages.h"
#include "integrators/tile_owner.h"

namespace cierzo {

// What a render under MPI gives rank 0.
struct DistributedOutcome {
    RenderState final_state;  // the film, and the tiles done of the pass in progress
    std::string stopped_by;
    RayCounts rays;      // of the passes in the film
    uint64_t units = 0;  // units handed out
    // Rank 0's main thread's CPU time: handing out units and all else, and apart from it
    // gathering the bands (checkpoints and the end)
    double service_seconds = 0.0, gather_seconds = 0.0;
    // Of service_seconds: the turns that dealt (requests, reports, answers, news), without
    // the polls of the turns that found nothing
    double deal_seconds = 0.0;
    uint64_t bytes_received = 0;         // by rank 0
    uint64_t requests = 0, reports = 0;  // answered and received by rank 0
};

struct RankRun {
    const Scene& scene;
    const RenderOptions& options;
    const std::vector<Tile>& units;  // work_units
    size_t light_units;              // batches of light paths at the front of `units`
    const UnitRenderer& renderer;
    TilePool& pool;
    int threads;
    Clock::time_point start;
    // Rank 0: the passes, the checkpoint resumed (or null), and where checkpoints go (a
    // state to write in the background)
    std::vector<int64_t> bounds;
    const RenderState* resume = nullptr;
    std::function<void(RenderState&&)> checkpoint;
    // A guided render's path guide (every rank's own; rank 0's restored from `resume`)
    PathGuide* guide = nullptr;
};

// Runs this rank's part of a render under MPI until it ends; rank 0 gets the outcome.
// Fills this rank's rays, units, seconds and lane counts.
DistributedOutcome render_as_rank(const RankRun& run, RankStats& mine, LaneStats& lanes);

// Every rank's figures, gathered on rank 0 (a collective call: every rank makes it) into
// `stats.ranks`, with a warning for a rank whose kernels differ from rank 0's; the lane
// counts of every rank are added into `lanes` on rank 0.
void gather_rank_stats(const RankStats& mine, const std::string& isa, RenderStats& stats,
                       LaneStats& lanes);

}  // namespace cierzo
