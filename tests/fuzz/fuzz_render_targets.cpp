// The fuzz targets of what a render reads besides its scene: checkpoints (read_checkpoint)
// and the messages of other MPI ranks (integrators/rank_messages.h). Each treats its reader's
// own refusal (InputError, MessageError) as correct and checks the invariants of whatever was
// accepted; every other outcome aborts. See docs/fuzzing.md.
#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <string>
#include <vector>

#include "core/error.h"
#include "fuzz_targets.h"
#include "integrators/checkpoint.h"
#include "integrators/path_guide.h"
#include "integrators/rank_messages.h"
#include "integrators/scheduler.h"
#include "integrators/tile_owner.h"

namespace cierzo {
namespace {

namespace fs = std::filesystem;

void require(bool ok, const char* what) { fuzz_require(ok, what); }

bool same_bits(const PixelSums& a, const PixelSums& b) {
    return std::memcmp(&a, &b, sizeof(PixelSums)) == 0;
}

// ---- Checkpoints ----------------------------------------------------------------------------

// Radiance sums finite and >= 0, and exactly `paths` paths (finite ones and not).
bool pixel_holds(const PixelSums& p, uint64_t paths) {
    for (int c = 0; c < 3; ++c)
        if (!(std::isfinite(p.sum[c]) && p.sum[c] >= 0.0 && std::isfinite(p.sum_sq[c]) &&
              p.sum_sq[c] >= 0.0))
            return false;
    return p.count <= paths && p.nonfinite == paths - p.count;
}

// What an accepted checkpoint holds: a film of its size whose every pixel holds the paths it
// claims, and the tiles of the pass in progress each whole (every pixel at pending_end) or
// empty; a guide exactly where the estimator is guided, that a PathGuide takes.
void check_checkpoint(const Checkpoint& c) {
    const CheckpointIdentity& id = c.id;
    const RenderState& s = c.state;
    require(id.width >= 1 && id.height >= 1 &&
                int64_t(id.width) * int64_t(id.height) <= kMaxImagePixels,
            "checkpoint size within limits");
    require(s.film.width() == id.width && s.film.height() == id.height,
            "a film of the checkpoint's size");
    require(s.spp_done >= 0 && s.spp_done <= id.spp, "paths done within the paths asked for");
    require(s.film.batches() >= 0 && s.film.batches() <= s.spp_done,
            "batches within the paths done");
    for (const PixelSums& p : s.film.pixels())
        require(pixel_holds(p, uint64_t(s.spp_done)),
                "every pixel of the film holds its paths, with sums finite and >= 0");
    require(std::isfinite(s.seconds) && s.seconds >= 0.0, "render time finite and >= 0");
    if (!s.pending_tiles.empty()) {
        const std::vector<Tile> tiles = image_tiles(id.width, id.height);
        require(s.pending_tiles.size() == tiles.size(),
                "one flag per tile of the pass in progress");
        require(s.pending.width() == id.width && s.pending.height() == id.height,
                "the pass in progress of the film's size");
        require(s.pending_end > s.spp_done, "the pass in progress ends after the paths done");
        for (size_t t = 0; t < tiles.size(); ++t) {
            const Tile& g = tiles[t];
            for (int y = g.y0; y < g.y1; ++y)
                for (int x = g.x0; x < g.x1; ++x) {
                    const PixelSums& p = s.pending.at(x, y);
                    require(s.pending_tiles[t] ? pixel_holds(p, uint64_t(s.pending_end))
                                               : same_bits(p, PixelSums{}),
                            "a tile of the pass in progress whole, or empty");
                }
        }
    }
    require(s.guide.empty() == (id.estimator.find(" guided ") == std::string::npos),
            "a path guide exactly where the estimator is guided");
    if (!s.guide.empty()) {
        require(s.pending_tiles.empty(), "a guided checkpoint keeps whole passes");
        try {
            PathGuide guide;
            guide.restore(s.guide);
            require(guide.trained_through() <= s.spp_done,
                    "the guide trained within the paths done");
        } catch (const GuideStateError&) {
            require(false, "the guide of an accepted checkpoint is one a PathGuide takes");
        }
    }
}

// Reads the fuzzer's bytes as numbers, zeros once they run out.
class Bytes {
public:
    Bytes(const uint8_t* data, size_t size) : data_(data), size_(size) {}
    template <typename T>
    T take() {
        T v{};
        const size_t n = std::min(sizeof(T), size_ - at_);
        std::memcpy(&v, data_ + at_, n);
        at_ += n;
        return v;
    }
    std::vector<char> rest() {
        std::vector<char> r(data_ + at_, data_ + size_);
        at_ = size_;
        return r;
    }

private:
    const uint8_t* data_;
    size_t size_, at_ = 0;
};

// A render state described by the bytes (docs/fuzzing.md gives their layout): a valid state
// of a small image built from a few numbers, then edits of single pixel fields, then the
// guide's bytes. Writing it and reading it back reaches every check behind the checksum.
Checkpoint described_checkpoint(const uint8_t* data, size_t size) {
    Bytes in(data, size);
    Checkpoint c;
    CheckpointIdentity& id = c.id;
    RenderState& s = c.state;
    id.width = 1 + in.take<uint8_t>() % 40;
    id.height = 1 + in.take<uint8_t>() % 24;
    const uint8_t flags = in.take<uint8_t>();  // 1: a pass in progress, 2: guided, 4: a guide
    const uint8_t done = in.take<uint8_t>();   // bit t: tile t of the pass in progress done
    id.spp = in.take<uint32_t>();
    s.spp_done = in.take<uint32_t>();
    s.pending_end = in.take<uint32_t>();
    id.seed = in.take<uint32_t>();
    s.rays.camera = in.take<uint64_t>(), s.rays.extension = in.take<uint64_t>();
    s.rays.shadow = in.take<uint64_t>(), s.rays.light = in.take<uint64_t>();
    const uint32_t batches = in.take<uint32_t>(), nonfinite_splats = in.take<uint32_t>();
    s.seconds = in.take<double>();
    id.scene = "fuzz.json";
    id.fingerprint = "0123456789abcdef";
    id.estimator = flags & 2 ? "mis guided sdtree vertices 1" : "mis";
    id.survival_cap = "0x1.e666666666666p-1";
    id.roulette = "throughput from 3";
    id.sampler = "sobol";
    id.lengths = "1..";
    id.triangle_sampling = "solid-angle";
    id.diffuse_sampling = "cosine";
    id.integrator = "wavefront";
    id.isa = "avx2";
    id.pool = 1024;

    // Each pixel's sums: a mean of 0, 1/4, 1/2 or 3/4 over its paths
    const auto fill = [](PixelSums& p, int x, int y, uint64_t paths) {
        for (int c = 0; c < 3; ++c) {
            const double mean = 0.25 * double((x + 2 * y + c) % 4);
            p.sum[c] = mean * double(paths), p.sum_sq[c] = mean * mean * double(paths);
        }
        p.count = paths, p.nonfinite = 0;
    };
    s.film = Film(id.width, id.height);
    for (int y = 0; y < id.height; ++y)
        for (int x = 0; x < id.width; ++x) fill(s.film.at(x, y), x, y, uint64_t(s.spp_done));
    s.film.set_batches(batches, nonfinite_splats);
    if (flags & 1) {
        const std::vector<Tile> tiles = image_tiles(id.width, id.height);
        s.pending = Film(id.width, id.height);
        s.pending_tiles.assign(tiles.size(), 0);
        for (size_t t = 0; t < tiles.size() && t < 8; ++t) {
            if (!(done >> t & 1)) continue;
            s.pending_tiles[t] = 1;
            for (int y = tiles[t].y0; y < tiles[t].y1; ++y)
                for (int x = tiles[t].x0; x < tiles[t].x1; ++x)
                    fill(s.pending.at(x, y), x, y, uint64_t(s.pending_end));
        }
    }
    // Edits: a pixel, a field (0-7 of the film's, 8-15 of the pass in progress's: sum R G B,
    // sum of squares R G B, count, non-finite count) and its 64 bits
    const int edits = in.take<uint8_t>() % 32;
    for (int e = 0; e < edits; ++e) {
        const size_t pixel = in.take<uint16_t>() % (size_t(id.width) * size_t(id.height));
        const uint8_t field = in.take<uint8_t>() % 16;
        const uint64_t bits = in.take<uint64_t>();
        if (field >= 8 && s.pending_tiles.empty()) continue;
        PixelSums& p = (field < 8 ? s.film : s.pending).pixels()[pixel];
        const int f = field % 8;
        if (f < 3)
            p.sum[f] = std::bit_cast<double>(bits);
        else if (f < 6)
            p.sum_sq[f - 3] = std::bit_cast<double>(bits);
        else if (f == 6)
            p.count = bits;
        else
            p.nonfinite = bits;
    }
    if (flags & 4) s.guide = in.rest();
    return c;
}

// ---- Rank messages --------------------------------------------------------------------------

// The render the messages belong to: a 24 x 20 image in four bands of one tile each (whole,
// and cut at the image's right and bottom edges); its units are a batch of light paths, then
// the four tiles.
constexpr int kWidth = 24, kHeight = 20, kRanks = 4, kSender = 1;
const TileBands& bands() {
    static const TileBands b(kWidth, kHeight, kRanks);
    return b;
}
const std::vector<Tile>& units() {
    static const std::vector<Tile> u = work_units(kWidth, kHeight, true);
    return u;
}

// A decoder's result encodes to bytes that decode and encode again to themselves, of the
// message's size (the message's own bytes but for a padding word, which is not read).
template <typename Decode>
void check_round_trip(const std::vector<char>& m, const std::vector<char>& again,
                      const Decode& decode) {
    require(again.size() == m.size(), "an accepted message re-encodes to its size");
    require(wire::encode(decode(again)) == again, "an accepted message re-encodes stably");
}

// A band's state (from rank kSender) gathered into rank 0's film as at a checkpoint, the
// other bands fresh: the sender's tile holds the message's pixels, every other pixel none.
void check_gathered(const wire::StateView& v) {
    const TileBands& b = bands();
    Gathering g;
    const std::vector<int64_t> bounds = {0, 4, 8};
    g.start(b, bounds, 1, Film(0, 0));
    bool all = false;
    for (int r = 0; r < kRanks; ++r) all = g.place(b, r, r == kSender ? v : wire::StateView{});
    require(all, "every band in once each is placed");
    require(g.state.spp_done == 4 &&
                g.state.pending_end == (v.pending_tiles && v.pending_tiles[0] ? 8 : 0),
            "a gathered state at the pass gathered");
    const Tile& mine = b.tile(b.first(kSender));
    for (int y = 0; y < kHeight; ++y)
        for (int x = 0; x < kWidth; ++x) {
            const bool in = x >= mine.x0 && x < mine.x1 && y >= mine.y0 && y < mine.y1;
            PixelSums want{};
            if (in && v.film)
                std::memcpy(&want,
                            v.film + size_t((y - mine.y0) * (mine.x1 - mine.x0) + (x - mine.x0)) *
                                         sizeof(PixelSums),
                            sizeof(PixelSums));
            require(same_bits(g.state.film.at(x, y), want), "a band's pixels gathered in place");
        }
    if (g.state.pending_tiles.empty()) return;
    const size_t mine_k = b.first(kSender);
    for (size_t k = 0; k < b.tiles(); ++k)
        require(g.state.pending_tiles[k] == (k == mine_k),
                "the sender's tile of the pass in progress");
    for (int y = mine.y0; y < mine.y1; ++y)
        for (int x = mine.x0; x < mine.x1; ++x) {
            PixelSums want{};
            std::memcpy(&want,
                        v.pending + size_t((y - mine.y0) * (mine.x1 - mine.x0) + (x - mine.x0)) *
                                        sizeof(PixelSums),
                        sizeof(PixelSums));
            require(same_bits(g.state.pending.at(x, y), want),
                    "a band's pass in progress gathered in place");
        }
}

}  // namespace

bool fuzz_one_checkpoint(const uint8_t* data, size_t size) {
    const bool file = size >= 4 && std::memcmp(data, "\x76\x2f\x31\x01", 4) == 0;
    fs::path path;
    Checkpoint written;
    if (file) {
        path = fuzz_scratch_file("checkpoint.exr", {reinterpret_cast<const char*>(data), size});
    } else {
        written = described_checkpoint(data, size);
        path = fuzz_scratch_file("checkpoint.exr", {});
        try {
            write_checkpoint(path, written.id, written.state);
        } catch (const InputError&) {
            return false;  // (a state the writer refuses: not the reader's to judge)
        }
    }
    Checkpoint c;
    try {
        c = read_checkpoint(path);
    } catch (const InputError& e) {
        fuzz_refused(e);
        return false;
    }
    check_checkpoint(c);
    if (!file) {
        // A file read is the state written, bit for bit
        const CheckpointIdentity &a = c.id, &b = written.id;
        require(a.scene == b.scene && a.fingerprint == b.fingerprint && a.width == b.width &&
                    a.height == b.height && a.seed == b.seed && a.estimator == b.estimator &&
                    a.survival_cap == b.survival_cap && a.roulette == b.roulette &&
                    a.sampler == b.sampler && a.lengths == b.lengths &&
                    a.triangle_sampling == b.triangle_sampling &&
                    a.diffuse_sampling == b.diffuse_sampling && a.integrator == b.integrator &&
                    a.isa == b.isa && a.pool == b.pool && a.spp == b.spp,
                "a checkpoint read is the identity written");
        const RenderState &s = c.state, &w = written.state;
        require(s.spp_done == w.spp_done && s.rays.camera == w.rays.camera &&
                    s.rays.extension == w.rays.extension && s.rays.shadow == w.rays.shadow &&
                    s.rays.light == w.rays.light && s.film.batches() == w.film.batches() &&
                    s.film.nonfinite_splats() == w.film.nonfinite_splats() && s.guide == w.guide,
                "a checkpoint read is the progress written");
        for (size_t i = 0; i < w.film.pixels().size(); ++i)
            require(same_bits(s.film.pixels()[i], w.film.pixels()[i]),
                    "a checkpoint read is the film written, bit for bit");
        require(s.pending_tiles == w.pending_tiles, "a checkpoint read has the tiles written");
        if (!w.pending_tiles.empty()) {
            require(s.pending_end == w.pending_end, "a checkpoint read is the pass written");
            for (size_t i = 0; i < w.pending.pixels().size(); ++i)
                require(same_bits(s.pending.pixels()[i], w.pending.pixels()[i]),
                        "a checkpoint read is the pass in progress written, bit for bit");
        }
    }
    return true;
}

bool fuzz_one_rank_message(const uint8_t* data, size_t size) {
    const std::vector<char> m(data, data + size);
    const std::string from = "rank " + std::to_string(kSender);
    const size_t slots = bands().count(kSender) * TileBands::kSlots;
    int accepted = 0;
    const auto decode = [&](const auto& body) {
        try {
            body();
            ++accepted;
        } catch (const MessageError& e) {
            fuzz_refused(e);
        }
    };
    decode([&] {
        const wire::Request q = wire::decode_request(m, from);
        require(q.want >= 0 && q.holding >= 0, "a request of counts >= 0");
        require(wire::is_request(m), "a request is known as one");
        require(wire::encode(q) == m, "a request re-encodes to its bytes");
    });
    decode([&] {
        const wire::Control c = wire::decode_control(m, from);
        require((c.answer == 0 || c.answer == 1) && (c.over == 0 || c.over == 1) &&
                    c.frontier >= 0 && c.granted_through >= -1,
                "control fields in range");
        for (const Unit& u : c.units)
            require(u.tile >= 0 && u.pass >= 0 && u.s0 >= 0 && u.s1 > u.s0, "units in range");
        require(wire::encode(c) == m, "a control message re-encodes to its bytes");
    });
    decode([&] {
        const PassReport p = wire::decode_report(m, from);
        require(p.pass >= 0 && p.error.total >= 0 && p.error.used <= p.error.estimated,
                "report fields in range");
        check_round_trip(m, wire::encode(p),
                         [&](const std::vector<char>& b) { return wire::decode_report(b, from); });
    });
    decode([&] {
        const wire::Splats s = wire::decode_splats(m, from);
        require(s.pass >= 0, "splats of a pass >= 0");
        check_round_trip(m, wire::encode(s),
                         [&](const std::vector<char>& b) { return wire::decode_splats(b, from); });
    });
    decode([&] {
        const wire::State s = wire::decode_state(m, slots, from);
        const BandState& b = s.band;
        require(s.id >= 0 || s.id == wire::kInitState || s.id == wire::kFinalState,
                "a state's id in range");
        require(b.batches >= 0, "a state's batches >= 0");
        require(b.film.empty() || b.film.size() == slots, "a state's film of its band's size");
        require(b.pending_tiles.empty()
                    ? b.pending.empty()
                    : b.pending_tiles.size() == bands().count(kSender) && b.pending.size() == slots,
                "a state's pass in progress of its band's size");
        require(wire::encode(s) == m, "a state re-encodes to its bytes");
        check_gathered(wire::view_state(m, slots, from));
    });
    decode([&] {
        static TilePool pool;
        std::vector<UnitResult> results = wire::decode_results(m, units(), pool, from);
        require(!results.empty(), "a results message of one unit or more");
        for (const UnitResult& r : results) {
            require(r.unit.tile >= 0 && size_t(r.unit.tile) < units().size() && r.unit.pass >= 0,
                    "a result's unit in range");
            const Tile& g = units()[size_t(r.unit.tile)];
            require(!g.light && r.sums.x0() == g.x0 && r.sums.y0() == g.y0 && r.sums.x1() == g.x1 &&
                        r.sums.y1() == g.y1,
                    "a result's sums are its tile's");
        }
        const std::vector<char> again = wire::encode(results);
        for (UnitResult& r : results) pool.give(std::move(r.sums));
        require(again == m, "results re-encode to their bytes");
    });
    require(accepted <= 1, "a message is of one kind");
    return accepted == 1;
}

}  // namespace cierzo
