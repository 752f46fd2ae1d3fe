// The messages between ranks and their codec (see rank_messages.h).
#include "integrators/rank_messages.h"

#include <cstring>
#include <type_traits>

namespace cierzo {

namespace {

template <typename T>
void append_array(std::vector<char>& buf, const T* data, size_t n) {
    static_assert(std::is_trivially_copyable_v<T>);
    if (n == 0) return;  // (memcpy may not be given a null pointer)
    const size_t at = buf.size();
    buf.resize(at + n * sizeof(T));
    std::memcpy(buf.data() + at, data, n * sizeof(T));
}

template <typename T>
void append(std::vector<char>& buf, const T& v) {
    append_array(buf, &v, 1);
}

// Reads a message's fields in order; any read past its end is a MessageError naming the
// sender and the message.
class Reader {
public:
    Reader(const std::vector<char>& m, const std::string& from, const char* what)
        : m_(m), from_(from), what_(what) {}
    template <typename T>
    T get() {
        T v;
        need(sizeof(T));
        std::memcpy(&v, m_.data() + at_, sizeof(T));
        at_ += sizeof(T);
        return v;
    }
    template <typename T>
    void get_array(T* out, size_t n) {
        if (n > (m_.size() - at_) / sizeof(T)) fail("truncated");
        if (n == 0) return;
        std::memcpy(out, m_.data() + at_, n * sizeof(T));
        at_ += n * sizeof(T);
    }
    void end() const {
        if (at_ != m_.size()) fail("longer than its contents");
    }
    bool at_end() const { return at_ == m_.size(); }
    // The next `n` bytes, in place.
    const char* skip(size_t n) {
        need(n);
        const char* p = m_.data() + at_;
        at_ += n;
        return p;
    }
    [[noreturn]] void fail(const std::string& why) const {
        throw MessageError(from_ + " sent a malformed " + what_ + " message (" +
                           std::to_string(m_.size()) + " bytes): " + why);
    }

private:
    void need(size_t n) const {
        if (n > m_.size() - at_) fail("truncated");
    }
    const std::vector<char>& m_;
    const std::string& from_;
    const char* what_;
    size_t at_ = 0;
};

// (each message starts with its kind, so one sent under the wrong tag is refused too)
enum class Kind : uint32_t {
    kRequest = 0x52455131,
    kControl,
    kReport,
    kSplats,
    kState,
    kResults,
};

void expect(Reader& r, Kind k) {
    if (r.get<Kind>() != k) r.fail("not a message of this kind");
}

struct RaysWire {
    uint64_t v[4];
};
RaysWire to_wire(const RayCounts& r) { return {{r.camera, r.extension, r.shadow, r.light}}; }
RayCounts from_wire(const RaysWire& w) { return {w.v[0], w.v[1], w.v[2], w.v[3]}; }

}  // namespace

// ---- The messages ------------------------------------------------------------------------

namespace wire {

std::vector<char> encode(const Request& m) {
    std::vector<char> b;
    append(b, Kind::kRequest), append(b, m);
    return b;
}

bool is_request(const std::vector<char>& m) {
    Kind k{};
    if (m.size() >= sizeof(k)) std::memcpy(&k, m.data(), sizeof(k));
    return k == Kind::kRequest;
}

Request decode_request(const std::vector<char>& m, const std::string& from) {
    Reader r(m, from, "request");
    expect(r, Kind::kRequest);
    const Request q = r.get<Request>();
    r.end();
    if (q.want < 0 || q.holding < 0) r.fail("a negative count");
    return q;
}

namespace {
struct ControlHead {
    int32_t answer, frontier, granted_through, over;
    int64_t checkpoint;
    uint64_t units;
};
}  // namespace

std::vector<char> encode(const Control& m) {
    std::vector<char> b;
    append(b, Kind::kControl);
    append(b, ControlHead{m.answer, m.frontier, m.granted_through, m.over, m.checkpoint,
                          m.units.size()});
    append_array(b, m.units.data(), m.units.size());
    return b;
}

Control decode_control(const std::vector<char>& m, const std::string& from) {
    Reader r(m, from, "control");
    expect(r, Kind::kControl);
    const ControlHead h = r.get<ControlHead>();
    if (h.units > m.size() / sizeof(Unit)) r.fail("more units than bytes");
    Control c{h.answer, h.frontier, h.granted_through, h.over, h.checkpoint, {}};
    c.units.resize(size_t(h.units));
    r.get_array(c.units.data(), c.units.size());
    r.end();
    if (c.frontier < 0 || c.granted_through < -1 || (c.answer | c.over) & ~1)
        r.fail("fields out of range");
    for (const Unit& u : c.units)
        if (u.tile < 0 || u.pass < 0 || u.s0 < 0 || u.s1 <= u.s0) r.fail("a unit out of range");
    return c;
}

namespace {
struct ReportHead {
    int32_t pass, pad;
    uint64_t error_total[2];
    uint64_t used, estimated;
    RaysWire rays;
};
}  // namespace

std::vector<char> encode(const PassReport& m) {
    std::vector<char> b;
    append(b, Kind::kReport);
    ReportHead h{m.pass, 0, {}, m.error.used, m.error.estimated, to_wire(m.rays)};
    std::memcpy(h.error_total, &m.error.total, sizeof(h.error_total));
    append(b, h);
    return b;
}

PassReport decode_report(const std::vector<char>& m, const std::string& from) {
    Reader r(m, from, "report");
    expect(r, Kind::kReport);
    const ReportHead h = r.get<ReportHead>();
    r.end();
    if (h.pass < 0 || h.used > h.estimated) r.fail("fields out of range");
    PassReport p;
    p.pass = h.pass;
    std::memcpy(&p.error.total, h.error_total, sizeof(h.error_total));
    if (p.error.total < 0) r.fail("a negative error sum");
    p.error.used = h.used, p.error.estimated = h.estimated;
    p.rays = from_wire(h.rays);
    return p;
}

namespace {
struct SplatsHead {
    int32_t pass, pad;
    RaysWire light_rays;
    uint64_t count;
};
}  // namespace

std::vector<char> encode(const Splats& m) {
    std::vector<char> b;
    b.reserve(sizeof(Kind) + sizeof(SplatsHead) + m.splats.size() * sizeof(Splat));
    append(b, Kind::kSplats);
    append(b, SplatsHead{m.pass, 0, to_wire(m.light_rays), m.splats.size()});
    append_array(b, m.splats.data(), m.splats.size());
    return b;
}

Splats decode_splats(const std::vector<char>& m, const std::string& from) {
    Reader r(m, from, "splats");
    expect(r, Kind::kSplats);
    const SplatsHead h = r.get<SplatsHead>();
    if (h.pass < 0) r.fail("a negative pass");
    if (h.count > m.size() / sizeof(Splat)) r.fail("more splats than bytes");
    Splats s{h.pass, from_wire(h.light_rays), {}};
    s.splats.resize(size_t(h.count));
    r.get_array(s.splats.data(), s.splats.size());
    r.end();
    return s;
}

namespace {
struct StateHead {
    int64_t id;
    int64_t batches;
    uint64_t nonfinite_splats;
    uint64_t slots;    // film pixels (0: a fresh band)
    uint64_t pending;  // tiles flagged (0: none)
};
}  // namespace

std::vector<char> encode(const State& m) {
    const BandState& s = m.band;
    std::vector<char> b;
    b.reserve(sizeof(Kind) + sizeof(StateHead) + (s.film.size() + s.pending.size()) * 64 +
              s.pending_tiles.size());
    append(b, Kind::kState);
    append(b,
           StateHead{m.id, s.batches, s.nonfinite_splats, s.film.size(), s.pending_tiles.size()});
    append_array(b, s.film.data(), s.film.size());
    if (!s.pending_tiles.empty()) {
        append_array(b, s.pending_tiles.data(), s.pending_tiles.size());
        append_array(b, s.pending.data(), s.pending.size());
    }
    return b;
}

StateView view_state(const std::vector<char>& m, size_t slots, const std::string& from) {
    Reader r(m, from, "state");
    expect(r, Kind::kState);
    const StateHead h = r.get<StateHead>();
    if (h.slots != 0 && h.slots != slots) r.fail("a band of another size");
    if (h.pending != 0 && h.pending * TileBands::kSlots != slots)
        r.fail("pending tiles of another band");
    if (h.batches < 0 || (h.id < 0 && h.id != kInitState && h.id != kFinalState))
        r.fail("fields out of range");
    StateView v{h.id, h.batches, h.nonfinite_splats, nullptr, nullptr, nullptr};
    if (h.slots) v.film = r.skip(size_t(h.slots) * sizeof(PixelSums));
    if (h.pending) {
        v.pending_tiles = reinterpret_cast<const uint8_t*>(r.skip(size_t(h.pending)));
        v.pending = r.skip(slots * sizeof(PixelSums));
    }
    r.end();
    return v;
}

State decode_state(const std::vector<char>& m, size_t slots, const std::string& from) {
    const StateView v = view_state(m, slots, from);
    State s{v.id, {}};
    s.band.batches = v.batches, s.band.nonfinite_splats = v.nonfinite_splats;
    if (v.film) {
        s.band.film.resize(slots);
        std::memcpy(s.band.film.data(), v.film, slots * sizeof(PixelSums));
    }
    if (v.pending_tiles) {
        const size_t tiles = slots / TileBands::kSlots;
        s.band.pending_tiles.assign(v.pending_tiles, v.pending_tiles + tiles);
        s.band.pending.resize(slots);
        std::memcpy(s.band.pending.data(), v.pending, slots * sizeof(PixelSums));
    }
    return s;
}

namespace {
struct ResultHead {
    Unit unit;
    RaysWire rays;
    uint64_t pixels;
};
}  // namespace

void append_result(std::vector<char>& msg, const UnitResult& r) {
    if (msg.empty()) append(msg, Kind::kResults);
    const std::span<const PixelSums> px = r.sums.pixels();
    append(msg, ResultHead{r.unit, to_wire(r.rays), px.size()});
    append_array(msg, px.data(), px.size());
}

std::vector<char> encode(const std::vector<UnitResult>& results) {
    std::vector<char> b;
    for (const UnitResult& r : results) append_result(b, r);
    return b;
}

std::vector<UnitResult> decode_results(const std::vector<char>& m, const std::vector<Tile>& units,
                                       TilePool& pool, const std::string& from) {
    Reader r(m, from, "results");
    expect(r, Kind::kResults);
    if (r.at_end()) r.fail("no units");
    std::vector<UnitResult> out;
    try {
        while (!r.at_end()) {
            const ResultHead h = r.get<ResultHead>();
            if (h.unit.tile < 0 || size_t(h.unit.tile) >= units.size() ||
                units[size_t(h.unit.tile)].light || h.unit.pass < 0)
                r.fail("a unit of no tile");
            const Tile& g = units[size_t(h.unit.tile)];
            if (h.pixels != size_t(g.x1 - g.x0) * size_t(g.y1 - g.y0))
                r.fail("a unit of another size than its tile");
            UnitResult u{h.unit, pool.make(g, 0), from_wire(h.rays), {}};
            r.get_array(u.sums.pixels().data(), u.sums.pixels().size());
            out.push_back(std::move(u));
        }
    } catch (...) {
        for (UnitResult& u : out) pool.give(std::move(u.sums));
        throw;
    }
    return out;
}

}  // namespace wire

BandState band_of(const TileBands& bands, int r, const RenderState& st, bool with_pending) {
    BandState b;
    b.film.resize(bands.count(r) * TileBands::kSlots);
    b.batches = st.film.batches();
    b.nonfinite_splats = r == 0 ? st.film.nonfinite_splats() : 0;
    if (with_pending) {
        b.pending_tiles.assign(bands.count(r), 0);
        b.pending.resize(b.film.size());
    }
    for (size_t j = 0; j < bands.count(r); ++j) {
        const size_t k = bands.first(r) + j;
        const Tile& g = bands.tile(k);
        const bool done = with_pending && k < st.pending_tiles.size() && st.pending_tiles[k];
        if (done) b.pending_tiles[j] = 1;
        size_t i = j * TileBands::kSlots;
        for (int y = g.y0; y < g.y1; ++y)
            for (int x = g.x0; x < g.x1; ++x, ++i) {
                b.film[i] = st.film.at(x, y);
                if (done) b.pending[i] = st.pending.at(x, y);
            }
    }
    return b;
}

}  // namespace cierzo
