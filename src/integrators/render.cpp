// The render driver: tile × pass units handed to worker threads (and, under MPI, to the
// other ranks), the passes added to the film in order, stopping rules, checkpoints, a
// progress line on stderr, and the statistics of the run. Integrators only fill tiles; they
// know nothing of threads or processes.
//
// How the image stays bit-identical for any number of threads and processes: a unit is one
// tile's samples [s0, s1) of one pass, rendered from zero into its own sums. The coordinator
// (the only one, on rank 0) keeps the units of the pass in progress aside and adds them to
// the film only once every tile of that pass is in, so each pixel's sums are always
// film + pass 0 + pass 1 + ..., in that order, whoever rendered each pass. The film thus
// always holds whole passes: a stop or a checkpoint at any moment has the same paths in
// every pixel.
#include "integrators/render.h"

#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <cstring>
#include <deque>
#include <exception>
#include <limits>
#include <mutex>
#include <optional>
#include <thread>

#include <time.h>

#include <oneapi/tbb/info.h>
#include <unistd.h>

#include "core/error.h"
#include "integrators/distributed.h"
#include "integrators/scalar.h"
#include "integrators/wavefront/wavefront.h"

namespace cierzo {

namespace {

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point t) {
    return std::chrono::duration<double>(Clock::now() - t).count();
}

// CPU time of the calling thread.
double thread_seconds() {
    timespec t{};
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
    return double(t.tv_sec) + 1e-9 * double(t.tv_nsec);
}

// One tile's samples [s0, s1): pass `pass` of tile `tile`.
struct Unit {
    int32_t tile = 0;
    int32_t pass = 0;
    int64_t s0 = 0, s1 = 0;
};

struct UnitResult {
    Unit unit;
    FilmTile sums;
    RayCounts rays;
    LaneStats lanes;
};

void add(LaneStats& a, const LaneStats& b) {
    a.shade_active += b.shade_active, a.shade_total += b.shade_total;
    a.isect_active += b.isect_active, a.isect_total += b.isect_total;
    a.shadow_active += b.shadow_active, a.shadow_total += b.shadow_total;
}

// Prints "percent, ETA, Mrays/s" every half second until stopped.
class Progress {
public:
    Progress(bool enabled, size_t total) : enabled_(enabled), total_(total) {
        if (enabled_) thread_ = std::thread([this] { run(); });
    }
    ~Progress() { stop(); }
    void units_done(size_t units, uint64_t rays) {
        rays_.fetch_add(rays, std::memory_order_relaxed);
        done_.fetch_add(units, std::memory_order_relaxed);
    }
    void stop() {
        if (!thread_.joinable()) return;
        {
            std::lock_guard lock(mutex_);
            stopping_ = true;
        }
        cv_.notify_all();
        thread_.join();
        print(true);
    }

private:
    void run() {
        std::unique_lock lock(mutex_);
        while (!cv_.wait_for(lock, std::chrono::milliseconds(500), [&] { return stopping_; }))
            print(false);
    }
    void print(bool last) {
        const double s = seconds_since(start_);
        const double f = double(done_.load()) / double(std::max<size_t>(total_, 1));
        const double eta = f > 0 ? s * (1.0 - f) / f : 0.0;
        const double mrays = s > 0 ? double(rays_.load()) / s * 1e-6 : 0.0;
        std::fprintf(stderr, "\r%5.1f%%  %6.1f s  ETA %6.1f s  %8.2f Mrays/s%s", 100.0 * f, s,
                     eta, mrays, last ? "\n" : "");
        std::fflush(stderr);
    }

    bool enabled_;
    size_t total_;
    std::atomic<uint64_t> rays_{0};
    std::atomic<size_t> done_{0};
    Clock::time_point start_ = Clock::now();
    std::mutex mutex_;
    std::condition_variable cv_;
    bool stopping_ = false;
    std::thread thread_;
};

// Tiles' memory, handed back after use: a pass's tiles are freed together when the pass is
// added to the film, and fresh ones would be new pages, faulted in one by one (that showed
// in rank 0's profile).
class TilePool {
public:
    explicit TilePool(size_t keep) : keep_(keep) {}
    FilmTile make(const Tile& g, int image_width) {
        std::vector<PixelSums> memory;
        {
            std::lock_guard lock(mutex_);
            if (!free_.empty()) {
                memory = std::move(free_.back());
                free_.pop_back();
            }
        }
        return FilmTile(g.x0, g.y0, g.x1, g.y1, image_width, std::move(memory));
    }
    void give(FilmTile&& tile) {
        std::vector<PixelSums> memory = tile.release();
        std::lock_guard lock(mutex_);
        if (free_.size() < keep_) free_.push_back(std::move(memory));
    }

private:
    size_t keep_;
    std::mutex mutex_;
    std::vector<std::vector<PixelSums>> free_;
};

// Renders units with this process's integrator.
class UnitRenderer {
public:
    UnitRenderer(const Scene& scene, const WavefrontRenderer* wavefront,
                 const std::vector<Tile>& tiles, TilePool& pool)
        : scene_(scene), wavefront_(wavefront), tiles_(tiles), pool_(pool) {}

    UnitResult render(const Unit& u) const {
        Tile t = tiles_[size_t(u.tile)];
        t.s0 = u.s0, t.s1 = u.s1;
        UnitResult r{u, pool_.make(t, scene_.settings.width), {}, {}};
        if (wavefront_) {
            wavefront_->render_tile(t, r.sums, r.rays, r.lanes);
        } else {
            render_tile_scalar(scene_, t, r.sums, r.rays);
        }
        return r;
    }

private:
    const Scene& scene_;
    const WavefrontRenderer* wavefront_;
    const std::vector<Tile>& tiles_;
    TilePool& pool_;
};

// The one owner of the film (rank 0): hands out units in pass order, keeps the units of the
// pass in progress (and of the next one, which idle workers may start early) aside, adds a
// pass to the film once it is whole, and applies the stopping rules at pass ends.
// Thread-safe: every method takes the lock.
class Coordinator {
public:
    Coordinator(const Scene& scene, const RenderOptions& options, const std::vector<Tile>& tiles,
                std::vector<int64_t> bounds, Film& film, Clock::time_point start,
                Progress& progress, TilePool& pool)
        : options_(options), tiles_(tiles), bounds_(std::move(bounds)), film_(film),
          start_(start), progress_(progress), pool_(pool), width_(scene.settings.width) {
        passes_ = int32_t(bounds_.size()) - 1;
        for (PassWork& w : work_) w.reset(tiles_.size());
        if (passes_ <= 0) stopping_ = true;
    }

    // Puts back the tiles of the first pass that a checkpoint had already done.
    void restore_pending(const RenderState& state) {
        std::lock_guard lock(mutex_);
        if (passes_ <= 0 || state.pending_end != bounds_[1] || state.pending_tiles.empty()) return;
        PassWork& w = work_[0];
        for (size_t t = 0; t < tiles_.size() && t < state.pending_tiles.size(); ++t) {
            if (!state.pending_tiles[t]) continue;
            const Tile& g = tiles_[t];
            FilmTile sums(g.x0, g.y0, g.x1, g.y1, width_);
            for (int y = g.y0; y < g.y1; ++y)
                for (int x = g.x0; x < g.x1; ++x) sums.at(x, y) = state.pending.at(x, y);
            w.sums[t] = std::move(sums);
            w.done[t] = 1;
            ++w.done_count;
        }
        progress_.units_done(w.done_count, 0);
        if (w.done_count == tiles_.size()) commit_passes();
    }

    // Up to `n` units (fewer, or none, when none can be handed out now).
    std::vector<Unit> grant(size_t n) {
        std::lock_guard lock(mutex_);
        std::vector<Unit> out;
        while (out.size() < n && !stopping_) {
            // The pass in progress first, then the next one
            std::optional<Unit> u = take(0);
            if (!u && frontier_ + 1 < passes_) u = take(1);
            if (!u) break;
            out.push_back(*u);
        }
        return out;
    }

    void complete(UnitResult&& r) {
        std::lock_guard lock(mutex_);
        add(lane_stats_, r.lanes);
        if (stopping_) return;  // a pass after the last one kept
        const int32_t ahead = r.unit.pass - frontier_;
        if (ahead < 0 || ahead > 1) throw std::logic_error("unit outside the passes in flight");
        PassWork& w = work_[(first_ + ahead) & 1];
        const size_t t = size_t(r.unit.tile);
        if (w.done[t]) throw std::logic_error("a unit was rendered twice");
        w.rays += r.rays;
        w.sums[t] = std::move(r.sums);
        w.done[t] = 1;
        ++w.done_count;
        progress_.units_done(1, r.rays.total());
        if (ahead == 0 && w.done_count == tiles_.size()) commit_passes();
        cv_.notify_all();
    }

    // Stops now because a render thread failed; the error is rethrown by rethrow_failure.
    void fail(std::exception_ptr e) {
        std::lock_guard lock(mutex_);
        if (!failure_) failure_ = e;
        stopping_ = true;
        cv_.notify_all();
    }
    void rethrow_failure() const {
        std::lock_guard lock(mutex_);
        if (failure_) std::rethrow_exception(failure_);
    }

    // Stops now if interrupted (once a first pass is in the film).
    void poll_interrupt() {
        std::lock_guard lock(mutex_);
        if (!stopping_ && frontier_ > 0 && options_.cancel && options_.cancel->load()) {
            stopped_by_ = "interrupted";
            stopping_ = true;
            cv_.notify_all();
        }
    }

    bool stopping() const {
        std::lock_guard lock(mutex_);
        return stopping_;
    }

    // Blocks until units can be handed out, the render stops, or `timeout` passes.
    template <typename Rep, typename Period>
    void wait(const std::chrono::duration<Rep, Period>& timeout) {
        std::unique_lock lock(mutex_);
        cv_.wait_for(lock, timeout);
    }

    // The state for a checkpoint: the film and the done tiles of the pass in progress.
    RenderState snapshot(const RenderState* resumed) const {
        std::lock_guard lock(mutex_);
        RenderState s;
        s.film = film_;
        s.spp_done = bounds_[size_t(frontier_)];
        s.rays = rays_;
        if (resumed) s.rays += resumed->rays;
        s.seconds = seconds_since(start_) + (resumed ? resumed->seconds : 0.0);
        const PassWork& w = work_[first_];
        if (frontier_ < passes_ && w.done_count > 0) {
            s.pending_end = bounds_[size_t(frontier_) + 1];
            s.pending_tiles = w.done;
            s.pending = Film(film_.width(), film_.height());
            for (size_t t = 0; t < tiles_.size(); ++t) {
                if (!w.done[t]) continue;
                const FilmTile& f = *w.sums[t];
                for (int y = f.y0(); y < f.y1(); ++y)
                    for (int x = f.x0(); x < f.x1(); ++x)
                        s.pending.at(x, y) = f.at(x, y);
            }
        }
        return s;
    }

    std::string stopped_by() const {
        std::lock_guard lock(mutex_);
        return stopped_by_;
    }
    RayCounts rays() const {
        std::lock_guard lock(mutex_);
        return rays_;
    }
    LaneStats lanes() const {
        std::lock_guard lock(mutex_);
        return lane_stats_;
    }

private:
    struct PassWork {
        std::vector<std::optional<FilmTile>> sums;
        std::vector<uint8_t> done;
        size_t done_count = 0;
        size_t cursor = 0;  // next tile to hand out
        RayCounts rays;
        void reset(size_t tiles) {
            sums.assign(tiles, std::nullopt);
            done.assign(tiles, 0);
            done_count = 0, cursor = 0, rays = {};
        }
    };

    // The next unit of the pass in progress (ahead = 0) or of the next one (ahead = 1).
    std::optional<Unit> take(int32_t ahead) {
        PassWork& w = work_[(first_ + ahead) & 1];
        while (w.cursor < tiles_.size() && w.done[w.cursor]) ++w.cursor;  // (restored tiles)
        if (w.cursor >= tiles_.size()) return std::nullopt;
        const int32_t pass = frontier_ + ahead;
        return Unit{int32_t(w.cursor++), pass, bounds_[size_t(pass)], bounds_[size_t(pass) + 1]};
    }

    // Adds every whole pass at the front to the film, then applies the stopping rules.
    void commit_passes() {
        while (!stopping_ && work_[first_].done_count == tiles_.size()) {
            PassWork& w = work_[first_];
            for (std::optional<FilmTile>& f : w.sums) {
                film_.merge(*f);
                pool_.give(std::move(*f));
            }
            rays_ += w.rays;
            w.reset(tiles_.size());
            first_ ^= 1;
            ++frontier_;
            if (frontier_ == passes_) {
                stopping_ = true;
                break;
            }
            const double elapsed = seconds_since(start_);
            if (options_.cancel && options_.cancel->load()) {
                stopped_by_ = "interrupted";
            } else if (options_.time_budget > 0.0 && elapsed >= options_.time_budget) {
                stopped_by_ = "time budget";
            } else if (options_.target_error > 0.0 && bounds_[size_t(frontier_)] >= 16 &&
                       film_.mean_relative_error().value_or(
                           std::numeric_limits<double>::infinity()) <= options_.target_error) {
                // (from 16 paths per pixel on: fewer give no trustworthy variance)
                stopped_by_ = "target error";
            }
            if (!stopped_by_.empty()) stopping_ = true;
        }
        cv_.notify_all();
    }

    const RenderOptions& options_;
    const std::vector<Tile>& tiles_;
    const std::vector<int64_t> bounds_;
    Film& film_;
    Clock::time_point start_;
    Progress& progress_;
    TilePool& pool_;
    int width_;
    int32_t passes_ = 0;
    int32_t frontier_ = 0;  // the pass in progress; passes before it are in the film
    int first_ = 0;         // work_[first_] is the pass in progress, the other the next
    PassWork work_[2];
    bool stopping_ = false;
    std::exception_ptr failure_;
    std::string stopped_by_;
    RayCounts rays_;
    LaneStats lane_stats_;
    mutable std::mutex mutex_;
    std::condition_variable cv_;
};

// Messages between ranks: a worker rank sends its finished units, how many units it holds
// and how many more it wants (kTagRequest); rank 0 answers every request (kTagGrant) with
// units, with none, or with "over". One request is in flight per rank at a time, so the
// messages of a rank are strictly ordered and none is left unread at the end. Rank 0 waits
// before answering only a rank that holds no unit (so no result can be stuck behind it);
// a rank that holds some and got none asks again when it has results.
constexpr int kTagRequest = 17, kTagGrant = 18;

struct RequestHeader {
    int32_t want = 0;
    int32_t results = 0;
    int32_t holding = 0;  // units queued or being rendered at the rank
};
struct ResultHeader {
    int32_t tile, pass;
    int64_t s0, s1;
    uint64_t rays[3];
    LaneStats lanes;
};
struct GrantHeader {
    int32_t over = 0;
    int32_t units = 0;
};
// A rank's figures at the end, gathered on rank 0.
struct RankRecord {
    double seconds = 0.0;
    uint64_t rays = 0, units = 0;
    int32_t threads = 0;
    char host[64] = {};
    char isa[16] = {};
};

template <typename T>
void append(std::vector<char>& buf, const T& v) {
    const char* p = reinterpret_cast<const char*>(&v);
    buf.insert(buf.end(), p, p + sizeof(T));
}
template <typename T>
T read(const std::vector<char>& buf, size_t& at) {
    if (at + sizeof(T) > buf.size()) throw std::runtime_error("truncated message between ranks");
    T v;
    std::memcpy(&v, buf.data() + at, sizeof(T));
    at += sizeof(T);
    return v;
}

// The units a rank has been given, and the results its threads have finished.
class LocalQueue {
public:
    void push(const std::vector<Unit>& units) {
        std::lock_guard lock(mutex_);
        units_.insert(units_.end(), units.begin(), units.end());
        cv_.notify_all();
    }
    // The next unit, or nothing once over and empty.
    std::optional<Unit> pop() {
        std::unique_lock lock(mutex_);
        cv_.wait(lock, [&] { return !units_.empty() || over_; });
        if (over_) return std::nullopt;
        Unit u = units_.front();
        units_.pop_front();
        ++busy_;
        return u;
    }
    void finished(UnitResult&& r) {
        std::lock_guard lock(mutex_);
        --busy_;
        results_.push_back(std::move(r));
        if (units_.size() + busy_ < low_ || wake_on_result_) done_cv_.notify_all();
    }
    // Waits until fewer than `low` units are held, or (with `any_result`) until a unit is
    // finished, or `timeout` passes.
    void wait(size_t low, bool any_result, std::chrono::microseconds timeout) {
        std::unique_lock lock(mutex_);
        low_ = low, wake_on_result_ = any_result;
        done_cv_.wait_for(lock, timeout, [&] {
            return units_.size() + busy_ < low || (any_result && !results_.empty()) || over_;
        });
    }
    void set_over() {
        std::lock_guard lock(mutex_);
        over_ = true;
        units_.clear();
        cv_.notify_all();
    }
    // Units queued or being rendered, and the results to send (taken out).
    size_t pending() {
        std::lock_guard lock(mutex_);
        return units_.size() + busy_;
    }
    bool has_results() {
        std::lock_guard lock(mutex_);
        return !results_.empty();
    }
    std::vector<UnitResult> take_results() {
        std::lock_guard lock(mutex_);
        return std::exchange(results_, {});
    }

private:
    std::mutex mutex_;
    std::condition_variable cv_, done_cv_;
    std::deque<Unit> units_;
    std::vector<UnitResult> results_;
    size_t busy_ = 0;
    size_t low_ = 0;
    bool wake_on_result_ = false;
    bool over_ = false;
};

// A worker rank (not 0): asks rank 0 for units, renders them on its threads, sends them back.
// It keeps enough units queued for its threads to work through a round trip to rank 0:
// at least two per thread, and at least kQueuedSeconds of work at the units' measured speed.
// When it holds fewer than half of that it sends its finished units and asks for more; in
// between its main thread sleeps (it polls MPI only while it waits for an answer).
constexpr double kQueuedSeconds = 0.01;

void serve_as_worker(const UnitRenderer& renderer, TilePool& pool, int threads, RankStats& mine) {
    LocalQueue queue;
    std::atomic<uint64_t> rays{0}, units{0}, busy_ns{0};
    const auto start = Clock::now();
    std::atomic<int64_t> last_ns{0};
    std::vector<std::thread> workers;
    std::mutex failure_mutex;
    std::exception_ptr failure;
    std::atomic<bool> failed{false};
    for (int i = 0; i < threads; ++i)
        workers.emplace_back([&] {
            try {
                while (std::optional<Unit> u = queue.pop()) {
                    const auto t0 = Clock::now();
                    UnitResult r = renderer.render(*u);
                    const auto t1 = Clock::now();
                    rays += r.rays.total(), ++units;
                    busy_ns += uint64_t(std::chrono::duration_cast<std::chrono::nanoseconds>(t1 - t0).count());
                    last_ns = std::chrono::duration_cast<std::chrono::nanoseconds>(t1 - start).count();
                    queue.finished(std::move(r));
                }
            } catch (...) {
                std::lock_guard lock(failure_mutex);
                if (!failure) failure = std::current_exception();
                failed = true;
            }
        });
    bool waiting = false, over = false, last_had_units = true;
    try {
        while (!over) {
            if (failed) {
                // (main() ends every rank: rank 0 would wait for this one's units forever)
                std::rethrow_exception(failure);
            }
            bool acted = false;
            // How many units to hold: two per thread, or kQueuedSeconds of work if more
            const uint64_t done = units.load();
            const double unit_seconds = done ? double(busy_ns.load()) * 1e-9 / double(done) : 0.0;
            const size_t high = std::min<size_t>(
                4096, std::max<size_t>(2 * size_t(threads),
                                       unit_seconds > 0 ? size_t(kQueuedSeconds * threads / unit_seconds) : 0));
            const size_t low = std::max<size_t>(size_t(threads), high / 2);
            if (!waiting) {
                const size_t pending = queue.pending();
                if (pending == 0 || (pending < low && (last_had_units || queue.has_results()))) {
                    std::vector<UnitResult> results = queue.take_results();
                    size_t bytes = sizeof(RequestHeader);
                    for (const UnitResult& r : results)
                        bytes += sizeof(ResultHeader) + r.sums.pixels().size() * sizeof(PixelSums);
                    std::vector<char> msg;
                    msg.reserve(bytes);
                    append(msg, RequestHeader{int32_t(pending < high ? high - pending : 0),
                                              int32_t(results.size()), int32_t(pending)});
                    for (const UnitResult& r : results) {
                        append(msg, ResultHeader{r.unit.tile, r.unit.pass, r.unit.s0, r.unit.s1,
                                                 {r.rays.camera, r.rays.extension, r.rays.shadow},
                                                 r.lanes});
                        const auto& px = r.sums.pixels();
                        const char* p = reinterpret_cast<const char*>(px.data());
                        msg.insert(msg.end(), p, p + px.size() * sizeof(PixelSums));
                    }
                    mpi::send(0, kTagRequest, std::move(msg));
                    for (UnitResult& r : results) pool.give(std::move(r.sums));
                    waiting = acted = true;
                }
            } else if (std::optional<mpi::Message> m = mpi::try_receive(kTagGrant, 0)) {
                size_t at = 0;
                const GrantHeader h = read<GrantHeader>(m->bytes, at);
                std::vector<Unit> granted;
                for (int32_t i = 0; i < h.units; ++i) granted.push_back(read<Unit>(m->bytes, at));
                if (h.over) {
                    queue.set_over();
                    over = true;
                }
                queue.push(granted);
                last_had_units = !granted.empty();
                waiting = false, acted = true;
            }
            if (waiting) {
                if (!acted) std::this_thread::sleep_for(std::chrono::microseconds(100));
            } else if (!acted) {
                queue.wait(low, !last_had_units, std::chrono::microseconds(20000));
            }
        }
    } catch (...) {
        // (the render threads are stopped before the error is passed on)
        queue.set_over();
        for (std::thread& t : workers)
            if (t.joinable()) t.join();
        throw;
    }
    for (std::thread& t : workers) t.join();
    while (!mpi::progress()) std::this_thread::sleep_for(std::chrono::microseconds(100));
    mine.rays = rays, mine.units = units;
    mine.seconds = double(last_ns.load()) * 1e-9;
}

// Rank 0's side of a distributed render: answers the other ranks' requests until each has
// been told the render is over. Returns when that is done and `local_done` is true.
class RankService {
public:
    RankService(Coordinator& coord, const std::vector<Tile>& tiles, int ranks, TilePool& pool)
        : coord_(coord), tiles_(tiles), pool_(pool), waiting_(size_t(ranks)),
          told_over_(size_t(ranks), false) {
        told_over_[0] = true;
    }

    // Handles what has arrived; returns whether anything happened.
    bool poll() {
        bool acted = false;
        const double cpu_start = thread_seconds();
        while (std::optional<mpi::Message> m = mpi::try_receive(kTagRequest)) {
            acted = true;
            bytes_ += m->bytes.size();
            size_t at = 0;
            const RequestHeader h = read<RequestHeader>(m->bytes, at);
            for (int32_t i = 0; i < h.results; ++i) {
                const ResultHeader rh = read<ResultHeader>(m->bytes, at);
                if (rh.tile < 0 || size_t(rh.tile) >= tiles_.size())
                    throw std::runtime_error("a rank sent a unit of an unknown tile");
                const Tile& g = tiles_[size_t(rh.tile)];
                UnitResult r{Unit{rh.tile, rh.pass, rh.s0, rh.s1},
                             pool_.make(g, 0),
                             RayCounts{rh.rays[0], rh.rays[1], rh.rays[2]}, rh.lanes};
                auto& px = r.sums.pixels();
                const size_t bytes = px.size() * sizeof(PixelSums);
                if (at + bytes > m->bytes.size()) throw std::runtime_error("truncated unit from a rank");
                std::memcpy(px.data(), m->bytes.data() + at, bytes);
                at += bytes;
                coord_.complete(std::move(r));
                ++units_;
            }
            mpi::recycle(std::move(m->bytes));
            waiting_[size_t(m->source)] = {true, h.want, h.holding};
        }
        // Answer the ranks that wait: with units, with none (a rank that holds units), or
        // with "over"; a rank that holds nothing waits for work
        for (size_t r = 1; r < waiting_.size(); ++r) {
            Waiting& w = waiting_[r];
            if (!w.asked) continue;
            const std::vector<Unit> units =
                w.want > 0 ? coord_.grant(size_t(w.want)) : std::vector<Unit>{};
            const bool over = coord_.stopping();
            if (units.empty() && !over && w.holding == 0) continue;  // later
            std::vector<char> msg;
            append(msg, GrantHeader{over ? 1 : 0, int32_t(units.size())});
            for (const Unit& u : units) append(msg, u);
            mpi::send(int(r), kTagGrant, std::move(msg));
            w = {};
            if (over) told_over_[r] = true;
            acted = true;
        }
        if (acted) seconds_ += thread_seconds() - cpu_start;
        return acted;
    }

    double seconds() const { return seconds_; }
    uint64_t units() const { return units_; }
    uint64_t bytes() const { return bytes_; }

    bool all_told() const {
        return std::all_of(told_over_.begin(), told_over_.end(), [](bool b) { return b; });
    }

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

void copy_name(char (&dst)[64], const std::string& s) {
    std::strncpy(dst, s.c_str(), sizeof(dst) - 1);
}

}  // namespace

std::vector<int64_t> pass_bounds(int64_t start, int64_t spp) {
    // Boundaries 1, 2, 4, 8, 16 and then every 16: so a finished render of a power of two or a
    // multiple of 16 paths per pixel ends on a boundary, and can be continued to more
    // paths with the very bits of an uninterrupted render of more
    std::vector<int64_t> bounds{start};
    for (int64_t b = 1; b < spp + 16; b = b < 16 ? 2 * b : b + 16) {
        const int64_t end = std::min(b, spp);
        if (end > bounds.back()) bounds.push_back(end);
        if (end == spp) break;
    }
    return bounds;
}

std::vector<Tile> image_tiles(int width, int height) {
    std::vector<Tile> tiles;
    for (int y = 0; y < height; y += kTileSize)
        for (int x = 0; x < width; x += kTileSize)
            tiles.push_back({x, y, std::min(x + kTileSize, width), std::min(y + kTileSize, height)});
    return tiles;
}

RenderResult render(const Scene& scene, const RenderOptions& options) {
    if (options.integrator != "scalar" && options.integrator != "wavefront")
        throw InputError("unknown integrator '" + options.integrator +
                         "' (valid: wavefront, scalar)");
    // (an emitter is chosen from 24 random bits)
    if (scene.settings.estimator.kind != Estimator::kReport &&
        scene.emitters.count() > (size_t(1) << 24))
        throw InputError(scene.source.string() + ": " + std::to_string(scene.emitters.count()) +
                         " emitting spheres and triangles; the nee and mis estimators sample "
                         "at most 2^24 (16,777,216)");
    const mpi::World& world = mpi::world();
    const bool root = world.rank == 0;
    std::unique_ptr<WavefrontRenderer> wavefront;
    if (options.integrator == "wavefront")
        wavefront = std::make_unique<WavefrontRenderer>(scene, parse_isa(options.isa),
                                                        options.pool_size, options.specialise);
    const int threads =
        options.threads > 0 ? options.threads : oneapi::tbb::info::default_concurrency();
    const RenderSettings& rs = scene.settings;
    const std::vector<Tile> tiles = image_tiles(rs.width, rs.height);
    // (enough for two passes in flight and every thread's unit)
    TilePool pool(2 * tiles.size() + 8 * size_t(threads));
    const UnitRenderer renderer(scene, wavefront.get(), tiles, pool);
    RenderResult result{root ? Film(rs.width, rs.height) : Film(0, 0), {}};
    RenderStats& st = result.stats;
    st.threads = threads;
    st.integrator = options.integrator;
    st.isa = wavefront ? isa_name(wavefront->isa()) : "scalar";
    if (wavefront) st.pool_size = wavefront->pool_size(), st.pool_bytes = wavefront->pool_bytes();
    RankStats mine{world.rank, mpi::host_name(), threads};
    const auto start = Clock::now();

    if (!root) {
        serve_as_worker(renderer, pool, threads, mine);
    } else {
        const RenderState* resume = options.resume;
        if (resume) {
            if (resume->film.width() != rs.width || resume->film.height() != rs.height)
                throw std::logic_error("resumed state of another resolution");
            result.film = resume->film;
            st.spp_resumed = resume->spp_done;
        }
        std::vector<int64_t> bounds = pass_bounds(resume ? resume->spp_done : 0, rs.spp);
        Progress progress(options.progress && isatty(STDERR_FILENO),
                          tiles.size() * (bounds.size() - 1));
        Coordinator coord(scene, options, tiles, bounds, result.film, start, progress, pool);
        if (resume) coord.restore_pending(*resume);

        // Checkpoints are written by a thread of their own (the main thread keeps serving
        // the other ranks meanwhile), one at a time
        std::thread writer;
        std::atomic<bool> writing{false};
        std::mutex warnings_mutex;
        auto write_state = [&](const RenderState& state) -> bool {
            bool written = false;
            try {
                const auto t = Clock::now();
                options.checkpoint(state);
                std::lock_guard lock(warnings_mutex);
                ++st.checkpoint_writes;
                st.checkpoint_last_seconds = seconds_since(t);
                st.checkpoint_seconds += st.checkpoint_last_seconds;
                written = true;
            } catch (const std::exception& e) {  // (InputError: the file's name and why)
                const std::string w = std::string(e.what()) + "; the previous checkpoint is kept";
                std::fprintf(stderr, "\ncierzo: %s\n", w.c_str());
                std::lock_guard lock(warnings_mutex);
                st.warnings.push_back(w);
                ++st.checkpoint_failures;
            }
            writing = false;
            return written;
        };
        auto start_checkpoint = [&] {
            if (writing) return;  // (the previous one is still being written)
            if (writer.joinable()) writer.join();
            writing = true;
            writer = std::thread(write_state, coord.snapshot(resume));
        };

        // This process's threads take units straight from the coordinator
        std::atomic<uint64_t> rays{0}, units{0};
        std::atomic<int64_t> last_ns{0};
        std::vector<std::thread> workers;
        for (int i = 0; i < threads; ++i)
            workers.emplace_back([&] {
                try {
                    for (;;) {
                        std::vector<Unit> u = coord.grant(1);
                        if (u.empty()) {
                            if (coord.stopping()) break;
                            coord.wait(std::chrono::milliseconds(5));
                            continue;
                        }
                        UnitResult r = renderer.render(u[0]);
                        rays += r.rays.total(), ++units;
                        last_ns = std::chrono::duration_cast<std::chrono::nanoseconds>(
                                      Clock::now() - start).count();
                        coord.complete(std::move(r));
                    }
                } catch (...) {
                    coord.fail(std::current_exception());
                }
            });
        std::optional<RankService> service;
        if (world.size > 1) service.emplace(coord, tiles, world.size, pool);
        auto next_checkpoint = start + std::chrono::duration_cast<Clock::duration>(
                                           std::chrono::duration<double>(options.checkpoint_every));
        // The main thread: interruption, checkpoints, and the other ranks (an error here,
        // e.g. a malformed message, stops the render threads before it is passed on)
        try {
            while (!coord.stopping() || (service && !service->all_told())) {
                coord.poll_interrupt();
                if (options.checkpoint && options.checkpoint_every > 0.0 &&
                    Clock::now() >= next_checkpoint && !coord.stopping()) {
                    start_checkpoint();
                    next_checkpoint = Clock::now() + std::chrono::duration_cast<Clock::duration>(
                                                         std::chrono::duration<double>(options.checkpoint_every));
                }
                if (service) {
                    // (the other ranks hold kQueuedSeconds of work: a poll every half
                    // millisecond keeps them fed)
                    if (!service->poll()) coord.wait(std::chrono::microseconds(500));
                } else {
                    coord.wait(std::chrono::milliseconds(20));
                }
            }
        } catch (...) {
            coord.fail(std::current_exception());
        }
        for (std::thread& t : workers) t.join();
        progress.stop();
        if (writer.joinable()) writer.join();
        coord.rethrow_failure();  // (a render thread's error, e.g. out of memory)
        // The final state (with the tiles done of the pass in progress, after a stop)
        if (options.checkpoint) st.checkpoint_final_failed = !write_state(coord.snapshot(resume));
        mine.rays = rays, mine.units = units;
        mine.seconds = double(last_ns.load()) * 1e-9;
        if (service) {
            st.service_seconds = service->seconds();
            st.units_received = service->units();
            st.bytes_received = service->bytes();
        }
        st.stopped_by = coord.stopped_by();
        st.rays = coord.rays();
        const LaneStats lanes = coord.lanes();
        st.shade_lane_utilisation = double(lanes.shade_active) / double(std::max<uint64_t>(lanes.shade_total, 1));
        st.isect_lane_utilisation = double(lanes.isect_active) / double(std::max<uint64_t>(lanes.isect_total, 1));
        st.shadow_lane_utilisation = double(lanes.shadow_active) / double(std::max<uint64_t>(lanes.shadow_total, 1));
    }
    st.seconds = seconds_since(start);

    // Every rank's figures, on rank 0
    if (world.size > 1) {
        while (!mpi::progress()) std::this_thread::sleep_for(std::chrono::microseconds(100));
        RankRecord rec{mine.seconds, mine.rays, mine.units, threads, {}, {}};
        copy_name(rec.host, mine.host);
        std::strncpy(rec.isa, st.isa.c_str(), sizeof(rec.isa) - 1);
        const std::vector<std::vector<char>> all = mpi::gather(&rec, sizeof(rec));
        for (size_t r = 0; r < all.size(); ++r) {
            RankRecord x;
            std::memcpy(&x, all[r].data(), sizeof(x));
            st.ranks.push_back({int(r), x.host, x.threads, x.rays, x.units, x.seconds});
            if (std::string(x.isa) != st.isa)
                st.warnings.push_back("rank " + std::to_string(r) + " rendered with " + x.isa +
                                      " kernels, rank 0 with " + st.isa +
                                      ": the image is right but not bit-identical to a "
                                      "one-process render (pass --isa to make them equal)");
        }
    }
    if (!root) return result;
    st.paths = st.rays.camera;
    st.nonfinite_samples = result.film.nonfinite_samples();
    st.mean_relative_error = result.film.mean_relative_error();
    st.spp_reached = int64_t(result.film.min_samples());
    return result;
}

}  // namespace cierzo
