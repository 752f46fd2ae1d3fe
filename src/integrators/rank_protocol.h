// A render across MPI ranks (integrators/distributed.h): rank 0's coordinator hands units to
// the other ranks as they ask and receives their sums; each worker rank renders its units on
// its threads. The messages and the one codec of a unit's result are in rank_protocol.cpp.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "integrators/scheduler.h"

namespace cierzo {

// A worker rank (not 0): asks rank 0 for units, renders them on `threads` threads, sends them
// back, until rank 0 says the render is over. Fills this rank's rays, units and seconds.
void serve_as_worker(const UnitRenderer& renderer, TilePool& pool, int threads, RankStats& mine);

// Rank 0's side of a distributed render: answers the other ranks' requests until each has
// been told the render is over.
class RankService {
public:
    RankService(Coordinator& coord, const std::vector<Tile>& tiles, int ranks, TilePool& pool);

    // Handles what has arrived; returns whether anything happened.
    bool poll();
    bool all_told() const;

    double seconds() const { return seconds_; }  // CPU time of poll()
    uint64_t units() const { return units_; }
    uint64_t bytes() const { return bytes_; }

private:
    Coordinator& coord_;
    const std::vector<Tile>& tiles_;
    TilePool& pool_;
    struct Waiting {
        bool asked = false;
        int32_t want = 0, holding = 0;
    };
    std::vector<Waiting> waiting_;  // each rank's unanswered request
    std::vector<bool> told_over_;
    double seconds_ = 0.0;
    uint64_t units_ = 0, bytes_ = 0;
};

// Every rank's figures, gathered on rank 0 (a collective call: every rank makes it) into
// `stats.ranks`, with a warning for a rank whose kernels differ from rank 0's.
void gather_rank_stats(const RankStats& mine, const std::string& isa, RenderStats& stats);

}  // namespace cierzo
