// The messages between ranks and every rank's loop (see rank_protocol.h).
#include "integrators/rank_protocol.h"

#include <algorithm>
#include <atomic>
#include <condition_variable>
#include <cstring>
#include <deque>
#include <map>
#include <mutex>
#include <optional>
#include <thread>
#include <utility>

#include <time.h>

#include "integrators/distributed.h"
#include "integrators/unit_dealer.h"

namespace cierzo {

namespace {

// CPU time of the calling thread.
double thread_seconds() {
    timespec t{};
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
    return double(t.tv_sec) + 1e-9 * double(t.tv_nsec);
}

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
    append(b, StateHead{m.id, s.batches, s.nonfinite_splats, s.film.size(),
                        s.pending_tiles.size()});
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

// ---- A rank's loop ----------------------------------------------------------------------

namespace {

constexpr int kTagToRoot = 21, kTagControl = 22, kTagState = 23, kTagResults = 24,
              kTagSplats = 25;

std::string rank_name(int r) { return "rank " + std::to_string(r); }

// Messages to another rank go through MPI; to itself (rank 0 is its own dealer) through a
// queue here, in order. Arrived messages are taken in once per turn of a loop (pump: one
// probe for any tag, however many kinds the loop then reads) into queues by tag.
class Link {
public:
    explicit Link(int me) : me_(me) {}
    void send(int dest, int tag, std::vector<char> bytes) {
        if (dest == me_)
            inbox_[tag].push_back({me_, std::move(bytes), tag});
        else
            mpi::send(dest, tag, std::move(bytes));
    }
    void pump() {
        while (std::optional<mpi::Message> m = mpi::try_receive(-1)) {
            const int tag = m->tag;
            inbox_[tag].push_back(std::move(*m));
        }
    }
    // The next message of this tag taken in (from `source`, if not -1; in arrival order).
    bool has(int tag) const {
        auto it = inbox_.find(tag);
        return it != inbox_.end() && !it->second.empty();
    }
    std::optional<mpi::Message> receive(int tag, int source = -1) {
        auto it = inbox_.find(tag);
        if (it == inbox_.end()) return std::nullopt;
        std::deque<mpi::Message>& q = it->second;
        for (auto m = q.begin(); m != q.end(); ++m) {
            if (source >= 0 && m->source != source) continue;
            mpi::Message out = std::move(*m);
            q.erase(m);
            return out;
        }
        return std::nullopt;
    }

private:
    int me_;
    std::map<int, std::deque<mpi::Message>> inbox_;
};

// The units this rank was given and not yet finished, by pass.
class LocalQueue {
public:
    void push(const std::vector<Unit>& units) {
        std::lock_guard lock(mutex_);
        for (const Unit& u : units) {
            units_.push_back(u);
            ++held_[u.pass];
        }
        cv_.notify_all();
    }
    // Work for the next free render thread, before any unit: a band's work (a pass
    // announced, units' sums from another rank), so that the main thread only deals with
    // messages. pop() gives it as a unit of tile kTask, and task() then hands it over.
    static constexpr int32_t kTask = -1;
    void push_task(std::function<void()> task) {
        std::lock_guard lock(mutex_);
        tasks_.push_back(std::move(task));
        cv_.notify_one();
    }
    std::optional<Unit> pop(std::function<void()>& task) {
        std::unique_lock lock(mutex_);
        cv_.wait(lock, [&] { return !units_.empty() || !tasks_.empty() || over_; });
        if (over_) return std::nullopt;
        if (!tasks_.empty()) {
            task = std::move(tasks_.front());
            tasks_.pop_front();
            return Unit{kTask, 0, 0, 0};
        }
        Unit u = units_.front();
        units_.pop_front();
        return u;
    }
    void finished(int32_t pass) {
        std::lock_guard lock(mutex_);
        if (--held_[pass] == 0) held_.erase(pass);
        ++finished_;
        if (size() < low_) done_cv_.notify_all();
    }
    // Waits until fewer than `low` units are held, wake() is called or `timeout` passes.
    void wait(size_t low, std::chrono::microseconds timeout) {
        std::unique_lock lock(mutex_);
        low_ = low;
        done_cv_.wait_for(lock, timeout, [&] { return size() < low || over_ || woken_; });
        woken_ = false;
    }
    // Wakes the main thread's wait (something to send: a band's report, units' sums).
    void wake() {
        std::lock_guard lock(mutex_);
        woken_ = true;
        done_cv_.notify_all();
    }
    void set_over() {
        std::lock_guard lock(mutex_);
        over_ = true;
        units_.clear();
        cv_.notify_all();
        done_cv_.notify_all();
    }
    size_t pending() {
        std::lock_guard lock(mutex_);
        return size();
    }
    bool holds(int32_t pass) {
        std::lock_guard lock(mutex_);
        return held_.count(pass) != 0;
    }

private:
    size_t size() const {
        size_t n = 0;
        for (const auto& [pass, count] : held_) n += size_t(count);
        return n;
    }
    std::mutex mutex_;
    std::condition_variable cv_, done_cv_;
    std::deque<Unit> units_;
    std::deque<std::function<void()>> tasks_;
    std::map<int32_t, int64_t> held_;  // queued or being rendered
    uint64_t finished_ = 0;
    size_t low_ = 0;
    bool over_ = false, woken_ = false;
};

// What the render threads leave for the main thread to send: units of other ranks' tiles,
// and splats by pass and owner (with the rays of light batches, by pass).
struct Outbox {
    std::mutex mutex;
    std::map<int, std::vector<char>> results;  // by owner: a Results message
    std::map<int32_t, std::vector<std::vector<Splat>>> splats;
    std::map<int32_t, RayCounts> light_rays;
};

// A rank keeps enough units queued for its threads to work through a round trip to rank 0:
// at least four per thread, and at least kQueuedSeconds of work at the units' measured speed;
// it asks for more when it holds half of that. (Each request costs rank 0 some microseconds
// however many units it carries: more units a request, less of rank 0 per unit; more held,
// more work dropped at a stop.)
constexpr double kQueuedSeconds = 0.02;
constexpr size_t kQueuedPerThread = 4;

// A render state gathered from every rank's band, at pass `frontier`: the film (and the tiles
// done of the pass in progress), each band written straight from its message.
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
                const size_t at = (j * TileBands::kSlots + size_t(y - g.y0) * w) * sizeof(PixelSums);
                PixelSums* row = &state.film.at(g.x0, y);
                if (v.film)
                    std::memcpy(row, v.film + at, w * sizeof(PixelSums));
                else
                    std::fill(row, row + w, PixelSums{});
                if (done) std::memcpy(&state.pending.at(g.x0, y), v.pending + at, w * sizeof(PixelSums));
            }
        }
        if (++count < bands.ranks()) return false;
        if (state.pending_tiles.empty()) state.pending_end = 0;
        state.film.set_batches(batches, nonfinite);
        return true;
    }
};

// Rank 0's side: requests waiting for units, what each rank was last told, checkpoints and
// the final bands as they come in.
struct Dealing {
    struct Told {
        int32_t frontier = 0, granted_through = -1, over = 0;
    };
    struct Waiting {
        bool asked = false;
        int32_t want = 0, holding = 0;
    };
    std::vector<Waiting> waiting;
    bool any_waiting = false;  // a request not yet answered
    std::vector<Told> told;
    // The checkpoint being gathered (0: none): its pass, rays, bands in
    int64_t checkpoint = 0, asked_checkpoint = 0;
    RayCounts checkpoint_rays;
    Gathering bands;   // the checkpoint's
    Gathering finals;  // the end's (into a film made at the start: no pages faulted in then)
    bool finals_done = false;
};

// A resumed render's band of rank r: its tiles of the film, and of the first pass's tiles
// done (when the checkpoint holds that pass's tiles).
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

}  // namespace

DistributedOutcome render_as_rank(const RankRun& run, RankStats& mine, LaneStats& lanes) {
    const mpi::World& world = mpi::world();
    const int me = world.rank, ranks = world.size;
    const bool root = me == 0;
    const RenderSettings& rs = run.scene.settings;
    const bool splatting = splats(rs.estimator.kind);
    const TileBands bands(rs.width, rs.height, ranks);
    TileOwner owner(bands, me, run.light_units, splatting, run.pool,
                    run.options.target_error > 0.0);
    LocalQueue queue;
    owner.on_report([&queue] { queue.wake(); });
    const size_t slots = bands.count(me) * TileBands::kSlots;
    Link link(me);
    std::vector<std::string> names;  // (for messages' errors, made once)
    for (int r = 0; r < ranks; ++r) names.push_back(rank_name(r));
    DistributedOutcome outcome;
    const double cpu_start = thread_seconds();

    // ---- Start: rank 0 hands every rank its band of a resumed checkpoint (or a fresh one)
    std::optional<UnitDealer> dealer;
    std::optional<Progress> progress;
    Dealing dealing;
    if (root) {
        const RenderState* resume = run.resume;
        const bool with_pending = resume && !splatting && run.bounds.size() > 1 &&
                                  resume->pending_end == run.bounds[1] &&
                                  !resume->pending_tiles.empty();
        for (int r = 0; r < ranks; ++r) {
            wire::State init{wire::kInitState, {}};
            if (resume) init.band = band_of(bands, r, *resume, with_pending);
            link.send(r, kTagState, wire::encode(init));
        }
        progress.emplace(run.options.progress && isatty(STDERR_FILENO),
                         run.units.size() * (run.bounds.size() - 1));
        dealer.emplace(bands, run.light_units, run.bounds, run.options, run.start, *progress,
                       with_pending ? resume->pending_tiles : std::vector<uint8_t>{});
        dealing.waiting.resize(size_t(ranks));
        dealing.told.resize(size_t(ranks));
        // (the film of the end made now, before the render: its pages are in by then)
        dealing.finals.start(bands, run.bounds, 0, Film(rs.width, rs.height));
    }
    for (;;) {
        link.pump();
        if (std::optional<mpi::Message> m = link.receive(kTagState, 0)) {
            wire::State s = wire::decode_state(m->bytes, slots, rank_name(0));
            if (s.id != wire::kInitState) throw MessageError("rank 0 sent a state before the start");
            if (!s.band.film.empty()) owner.restore(std::move(s.band));
            break;
        }
        std::this_thread::sleep_for(std::chrono::microseconds(200));
    }

    // ---- The render threads
    Outbox outbox;
    std::atomic<uint64_t> rays{0}, units{0}, busy_ns{0}, idle_ns{0};
    std::atomic<int64_t> last_ns{0};
    std::mutex failure_mutex;
    std::exception_ptr failure;
    std::atomic<bool> failed{false};
    std::mutex lanes_mutex;
    const auto render_units = [&] {
        std::vector<std::vector<Splat>> by_owner{size_t(ranks)};
        try {
            for (;;) {
                const auto w0 = Clock::now();
                std::function<void()> task;
                std::optional<Unit> u = queue.pop(task);
                idle_ns += uint64_t(std::chrono::duration_cast<std::chrono::nanoseconds>(
                                        Clock::now() - w0)
                                        .count());
                if (!u) break;
                if (u->tile == LocalQueue::kTask) {
                    task();
                    continue;
                }
                const auto t0 = Clock::now();
                UnitResult r = run.renderer.render(*u);
                const auto t1 = Clock::now();
                rays += r.rays.total(), ++units;
                busy_ns += uint64_t(
                    std::chrono::duration_cast<std::chrono::nanoseconds>(t1 - t0).count());
                last_ns = std::chrono::duration_cast<std::chrono::nanoseconds>(t1 - run.start)
                              .count();
                {
                    std::lock_guard lock(lanes_mutex);
                    add(lanes, r.lanes);
                }
                const int32_t pass = u->pass;
                if (!r.sums.splats.empty()) {
                    // Splats to the owners of their pixels: this band's now, the others'
                    // with the pass's flush
                    for (auto& v : by_owner) v.clear();
                    for (const Splat& s : r.sums.splats)
                        by_owner[size_t(bands.owner(bands.tile_of(s.pixel)))].push_back(s);
                    r.sums.splats = {};
                    if (!by_owner[size_t(me)].empty()) owner.add_splats(pass, by_owner[size_t(me)]);
                    std::lock_guard lock(outbox.mutex);
                    auto& out = outbox.splats[pass];
                    out.resize(size_t(ranks));
                    for (int o = 0; o < ranks; ++o)
                        if (o != me)
                            out[size_t(o)].insert(out[size_t(o)].end(), by_owner[size_t(o)].begin(),
                                                  by_owner[size_t(o)].end());
                }
                const Tile& g = run.units[size_t(u->tile)];
                if (g.light) {
                    {
                        std::lock_guard lock(outbox.mutex);
                        outbox.light_rays[pass] += r.rays;
                    }
                    run.pool.give(std::move(r.sums));
                } else if (bands.owner(size_t(u->tile) - run.light_units) == me) {
                    owner.complete(std::move(r));
                } else {
                    // (encoded here, on a render thread: the main thread only sends)
                    const int o = bands.owner(size_t(u->tile) - run.light_units);
                    {
                        std::lock_guard lock(outbox.mutex);
                        wire::append_result(outbox.results[o], r);
                    }
                    run.pool.give(std::move(r.sums));
                    queue.wake();
                }
                queue.finished(pass);
            }
        } catch (...) {
            std::lock_guard lock(failure_mutex);
            if (!failure) failure = std::current_exception();
            failed = true;
        }
    };
    std::vector<std::thread> workers;
    for (int i = 0; i < run.threads; ++i) workers.emplace_back(render_units);
    const auto stop_threads = [&] {
        queue.set_over();
        for (std::thread& t : workers)
            if (t.joinable()) t.join();
    };

    // ---- The main thread's loop
    bool waiting = false, over = false, final_sent = false, news = true, last_had_units = true;
    int32_t granted_through = -1, flushed_through = -1, announced = 0, reported = -1;
    uint64_t splat_bytes = 0;  // sent
    const auto every = std::chrono::duration_cast<Clock::duration>(
        std::chrono::duration<double>(run.options.checkpoint_every));
    auto next_checkpoint = run.start + every;
    const auto send_news = [&](int r, bool answer, std::vector<Unit> granted, int64_t ckpt) {
        wire::Control c{answer ? 1 : 0, dealer->frontier(), dealer->granted_through(),
                        dealer->stopping() ? 1 : 0, ckpt, std::move(granted)};
        dealing.told[size_t(r)] = {c.frontier, c.granted_through, c.over};
        link.send(r, kTagControl, wire::encode(c));
    };
    try {
        for (;;) {
            if (failed) std::rethrow_exception(failure);
            bool acted = false;
            link.pump();
            // -- Rank 0: requests, reports, checkpoints, news, bands
            if (root) {
                if (run.options.cancel && run.options.cancel->load()) dealer->interrupt();
                // (the dealing's own CPU, apart from the loop's polls: --stats)
                const bool dealing_now = link.has(kTagToRoot) || dealing.any_waiting;
                const double deal_start = dealing_now ? thread_seconds() : 0.0;
                while (std::optional<mpi::Message> m = link.receive(kTagToRoot)) {
                    acted = true;
                    outcome.bytes_received += m->bytes.size();
                    const std::string from = names[size_t(m->source)];
                    if (wire::is_request(m->bytes)) {
                        const wire::Request q = wire::decode_request(m->bytes, from);
                        dealing.waiting[size_t(m->source)] = {true, q.want, q.holding};
                    } else {
                        dealer->report(m->source, wire::decode_report(m->bytes, from));
                        ++outcome.reports;
                    }
                }
                int64_t ask = 0;
                if (run.options.checkpoint && run.options.checkpoint_every > 0.0 &&
                    Clock::now() >= next_checkpoint && !dealer->stopping() &&
                    dealing.checkpoint == 0) {
                    ask = dealing.checkpoint = ++dealing.asked_checkpoint;
                    dealing.checkpoint_rays = dealer->rays();
                    dealing.bands.start(bands, run.bounds, dealer->frontier(), Film(0, 0));
                    next_checkpoint = Clock::now() + every;
                }
                for (int r = 0; r < ranks; ++r) {
                    Dealing::Waiting& w = dealing.waiting[size_t(r)];
                    if (w.asked) {
                        std::vector<Unit> granted =
                            w.want > 0 ? dealer->grant(r, size_t(w.want)) : std::vector<Unit>{};
                        if (!granted.empty() || dealer->stopping() || w.holding > 0) {
                            ++outcome.requests;
                            send_news(r, true, std::move(granted), ask);
                            w = {};
                            acted = true;
                            continue;
                        }
                    }
                    const Dealing::Told& t = dealing.told[size_t(r)];
                    if (ask || t.frontier != dealer->frontier() ||
                        t.over != int32_t(dealer->stopping()) ||
                        (splatting && t.granted_through != dealer->granted_through())) {
                        send_news(r, false, {}, ask);
                        acted = true;
                    }
                }
                dealing.any_waiting = false;
                for (const Dealing::Waiting& w : dealing.waiting) dealing.any_waiting |= w.asked;
                if (dealing_now) outcome.deal_seconds += thread_seconds() - deal_start;
                while (std::optional<mpi::Message> m = link.receive(kTagState)) {
                    const double gather_start = thread_seconds();
                    acted = true;
                    outcome.bytes_received += m->bytes.size();
                    const int r = m->source;
                    const wire::StateView v = wire::view_state(
                        m->bytes, bands.count(r) * TileBands::kSlots, names[size_t(r)]);
                    if (v.id == wire::kFinalState) {
                        dealing.finals_done = dealing.finals.place(bands, r, v);
                    } else if (v.id == dealing.checkpoint && dealing.bands.place(bands, r, v)) {
                        RenderState st = std::move(dealing.bands.state);
                        st.rays = dealing.checkpoint_rays;
                        if (run.resume) st.rays += run.resume->rays;
                        st.seconds = seconds_since(run.start) +
                                     (run.resume ? run.resume->seconds : 0.0);
                        dealing.checkpoint = 0;
                        run.checkpoint(std::move(st));
                    }
                    mpi::recycle(std::move(m->bytes));
                    outcome.gather_seconds += thread_seconds() - gather_start;
                }
                if (dealing.finals_done) break;
            }
            // -- Every rank: what rank 0 says, in order
            if (!over) {
                while (std::optional<mpi::Message> m = link.receive(kTagControl, 0)) {
                    acted = true;
                    const wire::Control c = wire::decode_control(m->bytes, names[0]);
                    for (const Unit& u : c.units)
                        if (size_t(u.tile) >= run.units.size())
                            throw MessageError("rank 0 granted a unit of no tile");
                    if (c.over) {
                        over = true;
                        if (root) {  // (the end's pass, before any band of the end comes)
                            RenderState& f = dealing.finals.state;
                            f.spp_done = run.bounds[size_t(c.frontier)];
                            f.pending_end = size_t(c.frontier) + 1 < run.bounds.size()
                                                ? run.bounds[size_t(c.frontier) + 1]
                                                : 0;
                        }
                        stop_threads();
                        owner.stop(c.frontier);
                        break;
                    }
                    owner.announce(c.frontier);
                    if (c.frontier > announced) {
                        announced = c.frontier;
                        queue.push_task([&owner] { owner.catch_up(); });
                    }
                    granted_through = std::max(granted_through, c.granted_through);
                    if (c.checkpoint > 0)
                        link.send(0, kTagState, wire::encode(wire::State{c.checkpoint,
                                                                         owner.snapshot()}));
                    queue.push(c.units);
                    // (news alone may mean units to ask for; an answer is not news: a rank
                    // answered with none asks again only when it runs dry or hears news)
                    if (c.answer) {
                        waiting = false;
                        last_had_units = !c.units.empty();
                    } else {
                        news = true;
                    }
                }
            }
            // -- Units and splats of this band from other ranks
            while (std::optional<mpi::Message> m = link.receive(kTagResults)) {
                acted = true;
                // (read and added on a render thread)
                auto bytes = std::make_shared<std::vector<char>>(std::move(m->bytes));
                queue.push_task([&, bytes, from = m->source] {
                    for (UnitResult& r :
                         wire::decode_results(*bytes, run.units, run.pool, names[size_t(from)]))
                        owner.complete(std::move(r));
                });
            }
            while (std::optional<mpi::Message> m = link.receive(kTagSplats)) {
                acted = true;
                const wire::Splats s = wire::decode_splats(m->bytes, names[size_t(m->source)]);
                owner.add_splats(s.pass, s.splats);
                owner.flushed(s.pass, s.light_rays);
                mpi::recycle(std::move(m->bytes));
            }
            if (over) {
                if (!final_sent) {
                    BandState band = owner.snapshot();
                    link.send(0, kTagState, wire::encode(wire::State{wire::kFinalState,
                                                                     std::move(band)}));
                    final_sent = acted = true;
                }
                if (!root) break;
                if (!acted) std::this_thread::sleep_for(std::chrono::microseconds(200));
                continue;
            }
            // -- Units of other bands to their owners
            std::map<int, std::vector<char>> results;
            {
                std::lock_guard lock(outbox.mutex);
                results.swap(outbox.results);
            }
            for (auto& [o, msg] : results) {
                link.send(o, kTagResults, std::move(msg));
                acted = true;
            }
            // -- Splats of a pass handed out whole and rendered here, to every owner
            while (splatting && flushed_through < granted_through &&
                   !queue.holds(flushed_through + 1)) {
                acted = true;
                const int32_t pass = ++flushed_through;
                std::vector<std::vector<Splat>> out;
                RayCounts light;
                {
                    std::lock_guard lock(outbox.mutex);
                    if (auto it = outbox.splats.find(pass); it != outbox.splats.end()) {
                        out = std::move(it->second);
                        outbox.splats.erase(it);
                    }
                    if (auto it = outbox.light_rays.find(pass); it != outbox.light_rays.end()) {
                        light = it->second;
                        outbox.light_rays.erase(it);
                    }
                }
                out.resize(size_t(ranks));
                for (int o = 0; o < ranks; ++o) {
                    const RayCounts to = o == 0 ? light : RayCounts{};
                    if (o == me) {
                        owner.flushed(pass, to);
                    } else {
                        std::vector<char> msg =
                            wire::encode(wire::Splats{pass, to, std::move(out[size_t(o)])});
                        splat_bytes += msg.size();
                        link.send(o, kTagSplats, std::move(msg));
                    }
                }
            }
            // -- This band's part of the pass in progress, to rank 0
            if (std::optional<PassReport> rep = owner.take_report()) {
                link.send(0, kTagToRoot, wire::encode(*rep));
                reported = rep->pass;
                acted = true;
            }
            // -- More units
            const uint64_t done = units.load();
            const double unit_seconds = done ? double(busy_ns.load()) * 1e-9 / double(done) : 0.0;
            // (and at most the rank's share of a pass, so that with many ranks those that ask
            // first do not hold the units the others wait for at a pass's end)
            const size_t high = std::min<size_t>(
                std::max<size_t>(size_t(run.threads), run.units.size() / size_t(ranks)),
                std::max<size_t>(kQueuedPerThread * size_t(run.threads),
                                 unit_seconds > 0
                                     ? size_t(kQueuedSeconds * run.threads / unit_seconds)
                                     : 0));
            // (asks while its threads still render: with as many units as threads left)
            const size_t ask_at = std::max<size_t>(size_t(run.threads), high / 2);
            if (!waiting) {
                const size_t pending = queue.pending();
                if (pending == 0 || (pending <= ask_at && (last_had_units || news))) {
                    link.send(0, kTagToRoot,
                              wire::encode(wire::Request{int32_t(pending < high ? high - pending : 0),
                                                         int32_t(pending)}));
                    waiting = acted = true;
                    news = false;
                }
            }
            if (!acted) {
                // Polls: rank 0 every 3 ms and a rank every millisecond while the ranks hold
                // work (a rank asks with at least half of kQueuedSeconds of work left; a poll
                // is some microseconds of the main thread's CPU, which on rank 0 is a cost per
                // second, however long a unit), and every 250 us at a pass's end (rank 0: the
                // pass all handed out and some bands' reports in; a rank: its band's part
                // reported, the next pass not yet heard of), as the next pass waits on them; a
                // render thread's report or units' sums to send end the wait at once
                const bool near_end =
                    root ? dealer->reports_in() > 0 &&
                               dealer->granted_through() >= dealer->frontier()
                         : reported >= announced;
                if (waiting && !root)
                    std::this_thread::sleep_for(std::chrono::microseconds(100));
                else
                    queue.wait(ask_at + 1,
                               std::chrono::microseconds(near_end ? 250 : root ? 3000 : 1000));
            }
        }
    } catch (...) {
        stop_threads();
        throw;
    }
    // (rank 0's CPU in the loop: what follows is waiting for the render threads and, in the
    // drain, for the other ranks)
    const double loop_seconds = thread_seconds() - cpu_start - outcome.gather_seconds;
    stop_threads();
    if (progress) progress->stop();
    while (!mpi::progress()) std::this_thread::sleep_for(std::chrono::microseconds(100));
    if (root) {
        outcome.final_state = std::move(dealing.finals.state);
        outcome.final_state.rays = dealer->rays();
        if (run.resume) outcome.final_state.rays += run.resume->rays;
        outcome.final_state.seconds =
            seconds_since(run.start) + (run.resume ? run.resume->seconds : 0.0);
        outcome.stopped_by = dealer->stopped_by();
        outcome.rays = dealer->rays();
        outcome.units = dealer->units_granted();
        outcome.service_seconds = loop_seconds;
    }
    mpi::drain();
    mine.bytes_sent = mpi::bytes_sent();
    mine.idle_seconds = double(idle_ns.load()) * 1e-9;
    mine.splat_bytes_sent = splat_bytes;
    mine.rays = rays, mine.units = units;
    mine.seconds = double(last_ns.load()) * 1e-9;
    return outcome;
}

// ---- Figures of every rank ----------------------------------------------------------------

namespace {
// A rank's figures at the end, gathered on rank 0.
struct RankRecord {
    double seconds = 0.0;
    uint64_t rays = 0, units = 0, bytes_sent = 0, splat_bytes_sent = 0;
    double idle_seconds = 0.0;
    int32_t threads = 0;
    char host[64] = {};
    char isa[16] = {};
    LaneStats lanes;
};
}  // namespace

void gather_rank_stats(const RankStats& mine, const std::string& isa, RenderStats& st,
                       LaneStats& lanes) {
    while (!mpi::progress()) std::this_thread::sleep_for(std::chrono::microseconds(100));
    RankRecord rec{mine.seconds,      mine.rays,    mine.units, mine.bytes_sent,
                   mine.splat_bytes_sent, mine.idle_seconds, mine.threads, {}, {}, lanes};
    std::strncpy(rec.host, mine.host.c_str(), sizeof(rec.host) - 1);
    std::strncpy(rec.isa, isa.c_str(), sizeof(rec.isa) - 1);
    const std::vector<std::vector<char>> all = mpi::gather(&rec, sizeof(rec));
    if (!all.empty()) lanes = {};
    for (size_t r = 0; r < all.size(); ++r) {
        RankRecord x;
        std::memcpy(&x, all[r].data(), sizeof(x));
        x.host[sizeof(x.host) - 1] = 0, x.isa[sizeof(x.isa) - 1] = 0;
        add(lanes, x.lanes);
        st.ranks.push_back({int(r), x.host, x.threads, x.rays, x.units, x.bytes_sent,
                            x.seconds, x.idle_seconds, x.splat_bytes_sent});
        if (std::string(x.isa) != isa)
            st.warnings.push_back("rank " + std::to_string(r) + " rendered with " + x.isa +
                                  " kernels, rank 0 with " + isa +
                                  ": the image is right but not bit-identical to a "
                                  "one-process render (pass --isa to make them equal)");
    }
}

}  // namespace cierzo
