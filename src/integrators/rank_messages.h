// The messages between MPI ranks (rank_protocol.h says who sends which) and their one codec.
// Each message starts with its kind; one that is truncated, longer than its contents, of
// another kind, or that does not fit the render is refused (MessageError, naming the sender).
// Ranks run the same build: PixelSums and splats go across as they are in memory.
#pragma once

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <stdexcept>
#include <string>
#include <vector>

#include "integrators/scheduler.h"
#include "integrators/tile_owner.h"

namespace cierzo {

struct MessageError : std::runtime_error {
    using std::runtime_error::runtime_error;
};

namespace wire {

struct Request {
    int32_t want = 0, holding = 0;
};
struct Control {
    int32_t answer = 0;  // 1: the answer to the rank's request (0: news alone)
    int32_t frontier = 0;
    int32_t granted_through = -1;
    int32_t over = 0;        // the render ends at pass `frontier`
    int64_t checkpoint = 0;  // > 0: send your band for checkpoint number `checkpoint`
    std::vector<Unit> units;
};
struct Splats {
    int32_t pass = 0;
    RayCounts light_rays;
    std::vector<Splat> splats;
};
inline constexpr int64_t kInitState = -1, kFinalState = -2;
struct State {
    int64_t id = 0;  // kInitState, kFinalState or a checkpoint's number
    BandState band;
};

std::vector<char> encode(const Request& m);
std::vector<char> encode(const Control& m);
std::vector<char> encode(const PassReport& m);
std::vector<char> encode(const Splats& m);
std::vector<char> encode(const State& m);
// Units' results (their sums and rays; not their splats): a message of them, or one more
// appended to a message (empty: a new one).
std::vector<char> encode(const std::vector<UnitResult>& results);
void append_result(std::vector<char>& message, const UnitResult& r);

// Whether a message to rank 0 is a Request (else a Report).
bool is_request(const std::vector<char>& m);
// A state message read in place: its pixels (kSlots a tile, as BandState) stay in the message.
struct StateView {
    int64_t id = 0, batches = 0;
    uint64_t nonfinite_splats = 0;
    const char* film = nullptr;              // none: a fresh band
    const uint8_t* pending_tiles = nullptr;  // none: no tile of the pass in progress
    const char* pending = nullptr;
};
StateView view_state(const std::vector<char>& m, size_t slots, const std::string& from);

// Each throws MessageError naming `from` (e.g. "rank 2") and what is wrong.
Request decode_request(const std::vector<char>& m, const std::string& from);
Control decode_control(const std::vector<char>& m, const std::string& from);
PassReport decode_report(const std::vector<char>& m, const std::string& from);
Splats decode_splats(const std::vector<char>& m, const std::string& from);
// `slots`: the band's pixels the state must hold.
State decode_state(const std::vector<char>& m, size_t slots, const std::string& from);
// Units of image tiles (indices into `units`), with tile memory from `pool`.
std::vector<UnitResult> decode_results(const std::vector<char>& m, const std::vector<Tile>& units,
                                       TilePool& pool, const std::string& from);

}  // namespace wire

// Rank 0's side of the State messages: a render state gathered from every rank's band at pass
// `frontier` (the film, and the tiles done of the pass in progress), each band written
// straight from its message into the film.
struct Gathering {
    RenderState state;
    std::vector<uint8_t> in;  // per rank: its band is in
    int count = 0;
    int64_t batches = 0;
    uint64_t nonfinite = 0;

    // `film`: the film to fill (every pixel is written), or none to make one
    void start(const TileBands& bands, const std::vector<int64_t>& bounds, int32_t frontier,
               Film&& film) {
        state = RenderState{};
        state.film = film.width() ? std::move(film) : Film(bands.width(), bands.height());
        state.spp_done = bounds[size_t(frontier)];
        if (frontier + 1 < int32_t(bounds.size())) state.pending_end = bounds[size_t(frontier) + 1];
        in.assign(size_t(bands.ranks()), 0);
        count = 0, batches = 0, nonfinite = 0;
    }
    // Rank r's band; returns whether every band is in.
    bool place(const TileBands& bands, int r, const wire::StateView& v) {
        if (in[size_t(r)]) throw MessageError("rank " + std::to_string(r) + " sent its band twice");
        in[size_t(r)] = 1;
        batches = v.batches, nonfinite += v.nonfinite_splats;
        for (size_t j = 0; j < bands.count(r); ++j) {
            const Tile& g = bands.tile(bands.first(r) + j);
            const size_t w = size_t(g.x1 - g.x0);
            const bool done = v.pending_tiles && v.pending_tiles[j] && state.pending_end;
            if (done && state.pending_tiles.empty()) {
                state.pending_tiles.assign(bands.tiles(), 0);
                state.pending = Film(bands.width(), bands.height());
            }
            if (done) state.pending_tiles[bands.first(r) + j] = 1;
            for (int y = g.y0; y < g.y1; ++y) {
                const size_t at =
                    (j * TileBands::kSlots + size_t(y - g.y0) * w) * sizeof(PixelSums);
                PixelSums* row = &state.film.at(g.x0, y);
                if (v.film)
                    std::memcpy(row, v.film + at, w * sizeof(PixelSums));
                else
                    std::fill(row, row + w, PixelSums{});
                if (done)
                    std::memcpy(&state.pending.at(g.x0, y), v.pending + at, w * sizeof(PixelSums));
            }
        }
        if (++count < bands.ranks()) return false;
        if (state.pending_tiles.empty()) state.pending_end = 0;
        state.film.set_batches(batches, nonfinite);
        return true;
    }
};

// A resumed render's band of rank r (the State rank 0 sends it first): its tiles of the
// checkpoint's film, and of the first pass's tiles done when `with_pending`.
BandState band_of(const TileBands& bands, int r, const RenderState& state, bool with_pending);

}  // namespace cierzo
