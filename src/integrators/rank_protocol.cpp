// Every rank's loop (see rank_protocol.h); the messages are in rank_messages.cpp.
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
#include "integrators/rank_mailboxes.h"
#include "integrators/unit_dealer.h"

namespace cierzo {

namespace {

// CPU time of the calling thread.
double thread_seconds() {
    timespec t{};
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
    return double(t.tv_sec) + 1e-9 * double(t.tv_nsec);
}

}  // namespace

// ---- A rank's loop ----------------------------------------------------------------------

namespace {

using rank::Link;
using rank::LocalQueue;
using rank::Outbox;

constexpr int kTagToRoot = 21, kTagControl = 22, kTagState = 23, kTagResults = 24, kTagSplats = 25;
constexpr int kTagGuideStart = 26, kTagGuideSums = 27, kTagGuideState = 28;

// A guided render's messages (rank_protocol.h): a number (the passes' start, a training's
// pass, a checkpoint's id), then a guide's bytes (PathGuide's state or sums).
std::vector<char> guide_message(int64_t number, const std::vector<char>& guide) {
    std::vector<char> m(sizeof(number) + guide.size());
    std::memcpy(m.data(), &number, sizeof(number));
    if (!guide.empty()) std::memcpy(m.data() + sizeof(number), guide.data(), guide.size());
    return m;
}
int64_t guide_number(const std::vector<char>& m, const std::string& from) {
    if (m.size() < sizeof(int64_t))
        throw MessageError(from + " sent a malformed path guide message (" +
                           std::to_string(m.size()) + " bytes)");
    int64_t n;
    std::memcpy(&n, m.data(), sizeof(n));
    return n;
}
std::vector<char> guide_bytes(const std::vector<char>& m) {
    return std::vector<char>(m.begin() + sizeof(int64_t), m.end());
}
// Every rank's guide (of the same trees) as one with all their sums.
std::vector<char> merged_guide(const std::vector<std::vector<char>>& guides) {
    try {
        return PathGuide::merge_states(guides);
    } catch (const GuideStateError& e) {
        throw MessageError(std::string("the ranks' path guides do not fit together: ") + e.what());
    }
}

std::string rank_name(int r) { return "rank " + std::to_string(r); }

// A rank keeps enough units queued for its threads to work through a round trip to rank 0:
// at least four per thread, and at least kQueuedSeconds of work at the units' measured speed;
// it asks for more when it holds half of that. (Each request costs rank 0 some microseconds
// however many units it carries: more units a request, less of rank 0 per unit; more held,
// more work dropped at a stop.)
constexpr double kQueuedSeconds = 0.02;
constexpr size_t kQueuedPerThread = 4;

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
    // A guided render: each rank's guide, per checkpoint (and kFinalState: the end's); a
    // checkpoint whose bands are all in waits in `ready` for the guides
    std::map<int64_t, std::vector<std::vector<char>>> guides;
    std::optional<RenderState> ready;
    bool guides_in(int64_t id, int ranks) const {
        auto it = guides.find(id);
        if (it == guides.end()) return false;
        for (const std::vector<char>& g : it->second)
            if (g.empty()) return false;
        return int(it->second.size()) == ranks;
    }
};

// One rank's part of a render: the state its steps share, from the start (every rank its
// band; a guided render's passes and guide) through the main thread's turns (rank 0's dealing
// and gathering, every rank's hearing of rank 0, trading units and splats, reporting, asking
// for units) to the end (the outcome on rank 0, this rank's figures).
struct RankRender {
    const RankRun& run;
    RankStats& mine;
    LaneStats& lanes;
    const int me, ranks;
    const bool root;
    const RenderSettings& rs;
    const bool splatting;
    const TileBands bands;
    TileOwner owner;
    LocalQueue queue;
    const size_t slots;
    Link link;
    std::vector<std::string> names;  // (for messages' errors, made once)
    DistributedOutcome outcome;
    const double cpu_start;
    // Rank 0's
    std::optional<UnitDealer> dealer;
    std::optional<Progress> progress;
    Dealing dealing;
    // The passes (a guided render's from rank 0's start)
    std::vector<int64_t> bounds;
    int32_t passes = 0;
    // The render threads and what they hand over
    Outbox outbox;
    std::atomic<uint64_t> rays{0}, units{0}, busy_ns{0}, idle_ns{0};
    std::atomic<int64_t> last_ns{0};
    std::mutex failure_mutex;
    std::exception_ptr failure;
    std::atomic<bool> failed{false};
    std::mutex lanes_mutex;
    std::vector<std::thread> workers;
    // A guided render's trainings
    int32_t committed = 0;  // passes whose deposits have joined the guide's sums
    std::map<int64_t, std::vector<mpi::Message>> early_sums;  // (of a later training)
    // The main thread's loop
    bool acted = false;  // (this turn)
    bool waiting = false, over = false, final_sent = false, news = true, last_had_units = true;
    int32_t granted_through = -1, flushed_through = -1, announced = 0, reported = -1;
    uint64_t splat_bytes = 0;  // sent
    size_t ask_at = 0;         // (units held at most when asking for more: ask_for_units)
    Clock::duration every;
    Clock::time_point next_checkpoint;

    RankRender(const RankRun& r, RankStats& m, LaneStats& l)
        : run(r),
          mine(m),
          lanes(l),
          me(mpi::world().rank),
          ranks(mpi::world().size),
          root(me == 0),
          rs(r.scene.settings),
          splatting(splats(rs.estimator.kind)),
          bands(rs.width, rs.height, ranks),
          owner(bands, me, r.light_units, splatting, r.pool, r.options.target_error > 0.0),
          slots(bands.count(me) * TileBands::kSlots),
          link(me),
          cpu_start(thread_seconds()),
          bounds(r.bounds),
          every(std::chrono::duration_cast<Clock::duration>(
              std::chrono::duration<double>(r.options.checkpoint_every))),
          next_checkpoint(r.start + every) {
        owner.on_report([this] { queue.wake(); });
        for (int i = 0; i < ranks; ++i) names.push_back(rank_name(i));
    }
    ~RankRender() { stop_threads(); }  // (after a failure, too)

    DistributedOutcome render();

    // ---- The start
    void start_bands();
    void start_guide();
    // ---- The render threads
    void render_units();
    void hand_on(const Unit& u, UnitResult&& r, std::vector<std::vector<Splat>>& by_owner);
    void stop_threads() {
        queue.set_over();
        for (std::thread& t : workers)
            if (t.joinable()) t.join();
    }
    // ---- A guided render's trainings
    void train_guide(int32_t pass);
    void take_guide_sums(int32_t pass, mpi::Message&& m, std::vector<std::vector<char>>& from,
                         int& in);
    // ---- The main thread's turns
    bool root_turn();
    int64_t ask_for_checkpoint();
    void answer_ranks(int64_t ask);
    void gather_states();
    void hear_rank0();
    void take_band_work();
    bool end_turn();
    void send_results();
    void flush_splats();
    void ask_for_units();
    void wait_for_news();
    void finish(double loop_seconds);
};

DistributedOutcome RankRender::render() {
    start_bands();
    start_guide();
    passes = int32_t(bounds.size()) - 1;
    for (int i = 0; i < run.threads; ++i) workers.emplace_back([this] { render_units(); });
    // (a resumed render stopped at a training point, before the training, trains first)
    if (run.guide && passes > 0 && PathGuide::trains_before(bounds[0]) &&
        run.guide->trained_through() < bounds[0])
        train_guide(0);
    for (;;) {
        if (failed) std::rethrow_exception(failure);
        acted = false;
        link.pump();
        if (root && root_turn()) break;
        if (!over) hear_rank0();
        take_band_work();
        if (over) {
            if (end_turn()) break;
            continue;
        }
        send_results();
        flush_splats();
        // -- This band's part of the pass in progress, to rank 0
        if (std::optional<PassReport> rep = owner.take_report()) {
            link.send(0, kTagToRoot, wire::encode(*rep));
            reported = rep->pass;
            acted = true;
        }
        ask_for_units();
        if (!acted) wait_for_news();
    }
    // (rank 0's CPU in the loop: what follows is waiting for the render threads and, in the
    // drain, for the other ranks)
    const double loop_seconds = thread_seconds() - cpu_start - outcome.gather_seconds;
    stop_threads();
    if (progress) progress->stop();
    finish(loop_seconds);
    return std::move(outcome);
}

// Rank 0 hands every rank its band of a resumed checkpoint (or a fresh one); every rank
// takes its own.
void RankRender::start_bands() {
    if (root) {
        const RenderState* resume = run.resume;
        // (a guided render's checkpoints keep whole passes only)
        const bool with_pending = resume && !splatting && !run.guide && run.bounds.size() > 1 &&
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
                       with_pending ? resume->pending_tiles : std::vector<uint8_t>{},
                       run.guide != nullptr);
        dealing.waiting.resize(size_t(ranks));
        dealing.told.resize(size_t(ranks));
        // (the film of the end made now, before the render: its pages are in by then)
        dealing.finals.start(bands, run.bounds, 0, Film(rs.width, rs.height));
    }
    for (;;) {
        link.pump();
        if (std::optional<mpi::Message> m = link.receive(kTagState, 0)) {
            wire::State s = wire::decode_state(m->bytes, slots, rank_name(0));
            if (s.id != wire::kInitState)
                throw MessageError("rank 0 sent a state before the start");
            if (!s.band.film.empty()) owner.restore(std::move(s.band));
            return;
        }
        std::this_thread::sleep_for(std::chrono::microseconds(200));
    }
}

// A guided render: the passes (rank 0's, from where a resumed render starts) and the guide
// of a resumed checkpoint, without its sums (rank 0 holds them).
void RankRender::start_guide() {
    if (!run.guide) return;
    if (root) {
        const std::vector<char> start =
            guide_message(bounds[0], run.resume ? run.guide->save() : std::vector<char>{});
        for (int r = 1; r < ranks; ++r) link.send(r, kTagGuideStart, start);
        return;
    }
    for (;;) {
        link.pump();
        if (std::optional<mpi::Message> m = link.receive(kTagGuideStart, 0)) {
            const int64_t spp_start = guide_number(m->bytes, names[0]);
            if (spp_start < 0 || spp_start > rs.spp)
                throw MessageError("rank 0 sent passes that start at " + std::to_string(spp_start) +
                                   " paths per pixel");
            bounds = pass_bounds(spp_start, rs.spp, pass_pixels(run.scene));
            if (m->bytes.size() > sizeof(int64_t)) {
                try {
                    run.guide->restore(guide_bytes(m->bytes), false);
                } catch (const GuideStateError& e) {
                    throw MessageError("rank 0 sent a path guide that cannot be read: " +
                                       std::string(e.what()));
                }
            }
            return;
        }
        std::this_thread::sleep_for(std::chrono::microseconds(200));
    }
}

// A render thread: units (and band work) from the queue until it is over; a failure stops
// the main thread's loop.
void RankRender::render_units() {
    std::vector<std::vector<Splat>> by_owner{size_t(ranks)};
    try {
        for (;;) {
            const auto w0 = Clock::now();
            std::function<void()> task;
            std::optional<Unit> u = queue.pop(task);
            idle_ns += uint64_t(
                std::chrono::duration_cast<std::chrono::nanoseconds>(Clock::now() - w0).count());
            if (!u) break;
            if (u->tile == LocalQueue::kTask) {
                task();
                continue;
            }
            const auto t0 = Clock::now();
            UnitResult r = run.renderer.render(*u);
            const auto t1 = Clock::now();
            rays += r.rays.total(), ++units;
            busy_ns +=
                uint64_t(std::chrono::duration_cast<std::chrono::nanoseconds>(t1 - t0).count());
            last_ns = std::chrono::duration_cast<std::chrono::nanoseconds>(t1 - run.start).count();
            {
                std::lock_guard lock(lanes_mutex);
                add(lanes, r.lanes);
            }
            hand_on(*u, std::move(r), by_owner);
            queue.finished(u->pass);
        }
    } catch (...) {
        std::lock_guard lock(failure_mutex);
        if (!failure) failure = std::current_exception();
        failed = true;
    }
}

// A unit's result to where it goes: its splats to the owners of their pixels (this band's
// now, the others' with the pass's flush), a batch of light paths' rays to the pass's flush,
// a tile of this band to its owner, another band's tile to the outbox.
void RankRender::hand_on(const Unit& u, UnitResult&& r, std::vector<std::vector<Splat>>& by_owner) {
    const int32_t pass = u.pass;
    if (!r.sums.splats.empty()) {
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
    const Tile& g = run.units[size_t(u.tile)];
    if (g.light) {
        {
            std::lock_guard lock(outbox.mutex);
            outbox.light_rays[pass] += r.rays;
        }
        run.pool.give(std::move(r.sums));
    } else if (bands.owner(size_t(u.tile) - run.light_units) == me) {
        owner.complete(std::move(r));
    } else {
        // (encoded here, on a render thread: the main thread only sends)
        const int o = bands.owner(size_t(u.tile) - run.light_units);
        {
            std::lock_guard lock(outbox.mutex);
            wire::append_result(outbox.results[o], r);
        }
        run.pool.give(std::move(r.sums));
        queue.wake();
    }
}

// A guided render's training before `pass`: every rank sends its exact sums of the
// iteration to every other, adds theirs (integers: in any order, the same) and trains the
// same trees.
void RankRender::train_guide(int32_t pass) {
    // (a guide that has stopped learning, on every rank alike, has no sums to share)
    if (!run.guide->learning()) {
        run.guide->train(bounds[size_t(pass)]);
        return;
    }
    const std::vector<char> sums = guide_message(pass, run.guide->sums());
    for (int r = 0; r < ranks; ++r)
        if (r != me) link.send(r, kTagGuideSums, sums);
    std::vector<std::vector<char>> from(static_cast<size_t>(ranks));
    int in = 0;
    if (auto it = early_sums.find(pass); it != early_sums.end()) {
        std::vector<mpi::Message> early = std::move(it->second);
        early_sums.erase(it);
        for (mpi::Message& m : early) take_guide_sums(pass, std::move(m), from, in);
    }
    while (in < ranks - 1) {
        if (failed) std::rethrow_exception(failure);
        link.pump();
        bool got = false;
        while (std::optional<mpi::Message> m = link.receive(kTagGuideSums)) {
            take_guide_sums(pass, std::move(*m), from, in);
            got = true;
        }
        if (!got && in < ranks - 1) std::this_thread::sleep_for(std::chrono::microseconds(100));
    }
    for (int r = 0; r < ranks; ++r) {
        if (r == me) continue;
        try {
            run.guide->add_sums(from[size_t(r)]);
        } catch (const GuideStateError& e) {
            throw MessageError(names[size_t(r)] +
                               " sent path guide sums that do not fit: " + e.what());
        }
    }
    run.guide->train(bounds[size_t(pass)]);
}

// A rank's sums for the training before `pass` (kept for later if they are for a later one).
void RankRender::take_guide_sums(int32_t pass, mpi::Message&& m,
                                 std::vector<std::vector<char>>& from, int& in) {
    const int64_t p = guide_number(m.bytes, names[size_t(m.source)]);
    if (p > pass) {
        early_sums[p].push_back(std::move(m));
        return;
    }
    if (p < pass || m.source == me || !from[size_t(m.source)].empty())
        throw MessageError(names[size_t(m.source)] + " sent its path guide's sums of pass " +
                           std::to_string(p) + " at the training before pass " +
                           std::to_string(pass));
    from[size_t(m.source)] = guide_bytes(m.bytes);
    ++in;
}

// Rank 0's turn: requests and reports, a checkpoint to ask for, answers and news to every
// rank, the bands and guides coming in. True when the end's bands (and guides) are all in.
bool RankRender::root_turn() {
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
    answer_ranks(ask_for_checkpoint());
    if (dealing_now) outcome.deal_seconds += thread_seconds() - deal_start;
    gather_states();
    return dealing.finals_done && (!run.guide || dealing.guides_in(wire::kFinalState, ranks));
}

// The id of a checkpoint to ask every rank for now (0: none).
int64_t RankRender::ask_for_checkpoint() {
    if (!run.options.checkpoint || run.options.checkpoint_every <= 0.0 ||
        Clock::now() < next_checkpoint || dealer->stopping() || dealing.checkpoint != 0)
        return 0;
    dealing.checkpoint = ++dealing.asked_checkpoint;
    dealing.checkpoint_rays = dealer->rays();
    dealing.bands.start(bands, run.bounds, dealer->frontier(), Film(0, 0));
    next_checkpoint = Clock::now() + every;
    return dealing.checkpoint;
}

// Rank 0's answers to the ranks waiting for units, and news to the ranks whose last word
// from rank 0 is out of date (or a checkpoint `ask` to take).
void RankRender::answer_ranks(int64_t ask) {
    const auto send_news = [&](int r, bool answer, std::vector<Unit> granted) {
        wire::Control c{answer ? 1 : 0,
                        dealer->frontier(),
                        dealer->granted_through(),
                        dealer->stopping() ? 1 : 0,
                        ask,
                        std::move(granted)};
        dealing.told[size_t(r)] = {c.frontier, c.granted_through, c.over};
        link.send(r, kTagControl, wire::encode(c));
    };
    for (int r = 0; r < ranks; ++r) {
        Dealing::Waiting& w = dealing.waiting[size_t(r)];
        if (w.asked) {
            std::vector<Unit> granted =
                w.want > 0 ? dealer->grant(r, size_t(w.want)) : std::vector<Unit>{};
            if (!granted.empty() || dealer->stopping() || w.holding > 0) {
                ++outcome.requests;
                send_news(r, true, std::move(granted));
                w = {};
                acted = true;
                continue;
            }
        }
        const Dealing::Told& t = dealing.told[size_t(r)];
        if (ask || t.frontier != dealer->frontier() || t.over != int32_t(dealer->stopping()) ||
            (splatting && t.granted_through != dealer->granted_through())) {
            send_news(r, false, {});
            acted = true;
        }
    }
    dealing.any_waiting = false;
    for (const Dealing::Waiting& w : dealing.waiting) dealing.any_waiting |= w.asked;
}

// Rank 0: the ranks' bands (of a checkpoint, or the end's) and a guided render's guides as
// they come in; a checkpoint whose bands and guides are all in, written.
void RankRender::gather_states() {
    while (std::optional<mpi::Message> m = link.receive(kTagState)) {
        const double gather_start = thread_seconds();
        acted = true;
        outcome.bytes_received += m->bytes.size();
        const int r = m->source;
        const wire::StateView v =
            wire::view_state(m->bytes, bands.count(r) * TileBands::kSlots, names[size_t(r)]);
        if (v.id == wire::kFinalState) {
            dealing.finals_done = dealing.finals.place(bands, r, v);
        } else if (v.id == dealing.checkpoint && dealing.bands.place(bands, r, v)) {
            RenderState st = std::move(dealing.bands.state);
            st.rays = dealing.checkpoint_rays;
            if (run.resume) st.rays += run.resume->rays;
            st.seconds = seconds_since(run.start) + (run.resume ? run.resume->seconds : 0.0);
            dealing.ready = std::move(st);
        }
        mpi::recycle(std::move(m->bytes));
        outcome.gather_seconds += thread_seconds() - gather_start;
    }
    // (a guided render's guides, each rank's with its sums)
    while (std::optional<mpi::Message> m = link.receive(kTagGuideState)) {
        acted = true;
        outcome.bytes_received += m->bytes.size();
        const int64_t id = guide_number(m->bytes, names[size_t(m->source)]);
        std::vector<std::vector<char>>& g = dealing.guides[id];
        g.resize(size_t(ranks));
        if (!g[size_t(m->source)].empty() || m->bytes.size() <= sizeof(int64_t))
            throw MessageError(names[size_t(m->source)] +
                               " sent a path guide for a checkpoint twice, or empty");
        g[size_t(m->source)] = guide_bytes(m->bytes);
    }
    // A checkpoint whose bands (and guides) are all in
    if (dealing.ready && (!run.guide || dealing.guides_in(dealing.checkpoint, ranks))) {
        RenderState st = std::move(*dealing.ready);
        dealing.ready.reset();
        if (run.guide) {
            st.guide = merged_guide(dealing.guides[dealing.checkpoint]);
            dealing.guides.erase(dealing.checkpoint);
            st.pending_end = 0, st.pending_tiles.clear(), st.pending = Film(0, 0);
        }
        dealing.checkpoint = 0;
        run.checkpoint(std::move(st));
    }
}

// Every rank: what rank 0 says, in order (units, the pass in progress, a training, a
// checkpoint to take, the end).
void RankRender::hear_rank0() {
    while (std::optional<mpi::Message> m = link.receive(kTagControl, 0)) {
        acted = true;
        const wire::Control c = wire::decode_control(m->bytes, names[0]);
        for (const Unit& u : c.units)
            if (size_t(u.tile) >= run.units.size())
                throw MessageError("rank 0 granted a unit of no tile");
        // (the passes before the one in progress are whole on every rank: their deposits
        // join the guide's sums)
        if (run.guide)
            while (committed < c.frontier) run.guide->commit_pass(committed++);
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
            return;
        }
        owner.announce(c.frontier);
        if (c.frontier > announced) {
            announced = c.frontier;
            queue.push_task([this] { owner.catch_up(); });
        }
        granted_through = std::max(granted_through, c.granted_through);
        // (a pass after a training: every rank trains before any renders it)
        if (run.guide && c.frontier < passes &&
            PathGuide::trains_before(bounds[size_t(c.frontier)]) &&
            run.guide->trained_through() < bounds[size_t(c.frontier)])
            train_guide(c.frontier);
        if (c.checkpoint > 0) {
            link.send(0, kTagState, wire::encode(wire::State{c.checkpoint, owner.snapshot()}));
            if (run.guide)
                link.send(0, kTagGuideState, guide_message(c.checkpoint, run.guide->save()));
        }
        queue.push(c.units);
        // (news alone may mean units to ask for; an answer is not news: a rank answered
        // with none asks again only when it runs dry or hears news)
        if (c.answer) {
            waiting = false;
            last_had_units = !c.units.empty();
        } else {
            news = true;
        }
    }
}

// Units and splats of this band from other ranks.
void RankRender::take_band_work() {
    while (std::optional<mpi::Message> m = link.receive(kTagResults)) {
        acted = true;
        // (read and added on a render thread)
        auto bytes = std::make_shared<std::vector<char>>(std::move(m->bytes));
        queue.push_task([this, bytes, from = m->source] {
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
}

// A turn after the end: this band (and guide) to rank 0, once. True when this rank's loop
// is over (rank 0's ends when every band is in: root_turn).
bool RankRender::end_turn() {
    if (!final_sent) {
        BandState band = owner.snapshot();
        link.send(0, kTagState, wire::encode(wire::State{wire::kFinalState, std::move(band)}));
        if (run.guide)
            link.send(0, kTagGuideState, guide_message(wire::kFinalState, run.guide->save()));
        final_sent = acted = true;
    }
    if (!root) return true;
    if (!acted) std::this_thread::sleep_for(std::chrono::microseconds(200));
    return false;
}

// Units of other bands, rendered here, to their owners.
void RankRender::send_results() {
    std::map<int, std::vector<char>> results;
    {
        std::lock_guard lock(outbox.mutex);
        results.swap(outbox.results);
    }
    for (auto& [o, msg] : results) {
        link.send(o, kTagResults, std::move(msg));
        acted = true;
    }
}

// Splats of each pass handed out whole and rendered here, to every owner (rank 0 also gets
// the pass's light rays).
void RankRender::flush_splats() {
    while (splatting && flushed_through < granted_through && !queue.holds(flushed_through + 1)) {
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
}

// More units from rank 0, asked for before the threads run dry: enough for a round trip
// (kQueuedSeconds, kQueuedPerThread), at most the rank's share of a pass.
void RankRender::ask_for_units() {
    const uint64_t done = units.load();
    const double unit_seconds = done ? double(busy_ns.load()) * 1e-9 / double(done) : 0.0;
    // (and at most the rank's share of a pass, so that with many ranks those that ask first
    // do not hold the units the others wait for at a pass's end)
    const size_t high = std::min<size_t>(
        std::max<size_t>(size_t(run.threads), run.units.size() / size_t(ranks)),
        std::max<size_t>(
            kQueuedPerThread * size_t(run.threads),
            unit_seconds > 0 ? size_t(kQueuedSeconds * run.threads / unit_seconds) : 0));
    // (asks while its threads still render: with as many units as threads left)
    ask_at = std::max<size_t>(size_t(run.threads), high / 2);
    if (waiting) return;
    const size_t pending = queue.pending();
    if (pending == 0 || (pending <= ask_at && (last_had_units || news))) {
        link.send(0, kTagToRoot,
                  wire::encode(wire::Request{int32_t(pending < high ? high - pending : 0),
                                             int32_t(pending)}));
        waiting = acted = true;
        news = false;
    }
}

// A turn that found nothing to do: a poll's wait. Rank 0 every 3 ms and a rank every
// millisecond while the ranks hold work (a rank asks with at least half of kQueuedSeconds of
// work left; a poll is some microseconds of the main thread's CPU, which on rank 0 is a cost
// per second, however long a unit), and every 250 us at a pass's end (rank 0: the pass all
// handed out and some bands' reports in; a rank: its band's part reported, the next pass not
// yet heard of), as the next pass waits on them; a render thread's report or units' sums to
// send end the wait at once.
void RankRender::wait_for_news() {
    const bool near_end =
        root ? dealer->reports_in() > 0 && dealer->granted_through() >= dealer->frontier()
             : reported >= announced;
    if (waiting && !root)
        std::this_thread::sleep_for(std::chrono::microseconds(100));
    else
        queue.wait(ask_at + 1, std::chrono::microseconds(near_end ? 250 : root ? 3000 : 1000));
}

// The end: rank 0's outcome (the end's state, with the merged guide; the dealing's figures),
// the messages drained, this rank's figures.
void RankRender::finish(double loop_seconds) {
    // (no waiting here for this rank's sends to finish: a large one finishes only once its
    // receiver takes it, and a rank that has left its loop takes nothing until the drain)
    if (root) {
        outcome.final_state = std::move(dealing.finals.state);
        if (run.guide) {
            RenderState& f = outcome.final_state;
            f.guide = merged_guide(dealing.guides[wire::kFinalState]);
            f.pending_end = 0, f.pending_tiles.clear(), f.pending = Film(0, 0);
        }
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
}

}  // namespace

DistributedOutcome render_as_rank(const RankRun& run, RankStats& mine, LaneStats& lanes) {
    RankRender rank(run, mine, lanes);
    return rank.render();
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
    RankRecord rec{mine.seconds,
                   mine.rays,
                   mine.units,
                   mine.bytes_sent,
                   mine.splat_bytes_sent,
                   mine.idle_seconds,
                   mine.threads,
                   {},
                   {},
                   lanes};
    std::strncpy(rec.host, mine.host.c_str(), sizeof(rec.host) - 1);
    std::strncpy(rec.isa, isa.c_str(), sizeof(rec.isa) - 1);
    const std::vector<std::vector<char>> all = mpi::gather(&rec, sizeof(rec));
    if (!all.empty()) lanes = {};
    for (size_t r = 0; r < all.size(); ++r) {
        RankRecord x;
        std::memcpy(&x, all[r].data(), sizeof(x));
        x.host[sizeof(x.host) - 1] = 0, x.isa[sizeof(x.isa) - 1] = 0;
        add(lanes, x.lanes);
        st.ranks.push_back({int(r), x.host, x.threads, x.rays, x.units, x.bytes_sent, x.seconds,
                            x.idle_seconds, x.splat_bytes_sent});
        if (std::string(x.isa) != isa)
            st.warnings.push_back("rank " + std::to_string(r) + " rendered with " + x.isa +
                                  " kernels, rank 0 with " + isa +
                                  ": the image is right but not bit-identical to a "
                                  "one-process render (pass --isa to make them equal)");
    }
}

}  // namespace cierzo
