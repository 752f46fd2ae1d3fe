// Messages between ranks and the worker rank's loop (see rank_protocol.h).
#include "integrators/rank_protocol.h"

#include <algorithm>
#include <atomic>
#include <condition_variable>
#include <cstring>
#include <deque>
#include <mutex>
#include <optional>
#include <stdexcept>
#include <thread>
#include <utility>

#include <time.h>

#include "integrators/distributed.h"

namespace cierzo {

namespace {

// CPU time of the calling thread.
double thread_seconds() {
    timespec t{};
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
    return double(t.tv_sec) + 1e-9 * double(t.tv_nsec);
}

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
    uint64_t rays[4];
    LaneStats lanes;
    uint64_t splats;  // after the tile's PixelSums
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

// ---- The one codec of a unit's result ----------------------------------------------------
// A header (the unit, its rays by kind, its lane counts) and the tile's PixelSums as they are
// in memory: ranks run the same build, so the bits go across unchanged.

size_t encoded_size(const UnitResult& r) {
    return sizeof(ResultHeader) + r.sums.pixels().size() * sizeof(PixelSums) +
           r.sums.splats.size() * sizeof(Splat);
}

void encode_result(std::vector<char>& msg, const UnitResult& r) {
    append(msg, ResultHeader{r.unit.tile,
                             r.unit.pass,
                             r.unit.s0,
                             r.unit.s1,
                             {r.rays.camera, r.rays.extension, r.rays.shadow, r.rays.light},
                             r.lanes,
                             r.sums.splats.size()});
    const std::span<const PixelSums> px = std::as_const(r.sums).pixels();
    const char* p = reinterpret_cast<const char*>(px.data());
    msg.insert(msg.end(), p, p + px.size() * sizeof(PixelSums));
    if (!r.sums.splats.empty()) {
        const char* s = reinterpret_cast<const char*>(r.sums.splats.data());
        msg.insert(msg.end(), s, s + r.sums.splats.size() * sizeof(Splat));
    }
}

UnitResult decode_result(const std::vector<char>& msg, size_t& at, const std::vector<Tile>& tiles,
                         TilePool& pool) {
    const ResultHeader rh = read<ResultHeader>(msg, at);
    if (rh.tile < 0 || size_t(rh.tile) >= tiles.size())
        throw std::runtime_error("a rank sent a unit of an unknown tile");
    UnitResult r{Unit{rh.tile, rh.pass, rh.s0, rh.s1}, pool.make(tiles[size_t(rh.tile)], 0),
                 RayCounts{rh.rays[0], rh.rays[1], rh.rays[2], rh.rays[3]}, rh.lanes};
    const std::span<PixelSums> px = r.sums.pixels();
    const size_t bytes = px.size() * sizeof(PixelSums);
    if (at + bytes > msg.size()) throw std::runtime_error("truncated unit from a rank");
    // (a batch of light paths has no pixels: memcpy may not be given an empty vector's null data)
    if (bytes > 0) std::memcpy(px.data(), msg.data() + at, bytes);
    at += bytes;
    if (rh.splats > (msg.size() - at) / sizeof(Splat))
        throw std::runtime_error("truncated unit from a rank");
    if (rh.splats > 0) {  // (memcpy may not be given the null data of an empty vector)
        r.sums.splats.resize(rh.splats);
        std::memcpy(r.sums.splats.data(), msg.data() + at, rh.splats * sizeof(Splat));
        at += rh.splats * sizeof(Splat);
    }
    return r;
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

}  // namespace

// A worker rank keeps enough units queued for its threads to work through a round trip to rank 0:
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
                    busy_ns += uint64_t(
                        std::chrono::duration_cast<std::chrono::nanoseconds>(t1 - t0).count());
                    last_ns =
                        std::chrono::duration_cast<std::chrono::nanoseconds>(t1 - start).count();
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
                4096, std::max<size_t>(
                          2 * size_t(threads),
                          unit_seconds > 0 ? size_t(kQueuedSeconds * threads / unit_seconds) : 0));
            const size_t low = std::max<size_t>(size_t(threads), high / 2);
            if (!waiting) {
                const size_t pending = queue.pending();
                if (pending == 0 || (pending < low && (last_had_units || queue.has_results()))) {
                    std::vector<UnitResult> results = queue.take_results();
                    size_t bytes = sizeof(RequestHeader);
                    for (const UnitResult& r : results) bytes += encoded_size(r);
                    std::vector<char> msg;
                    msg.reserve(bytes);
                    append(msg, RequestHeader{int32_t(pending < high ? high - pending : 0),
                                              int32_t(results.size()), int32_t(pending)});
                    for (const UnitResult& r : results) encode_result(msg, r);
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

RankService::RankService(Coordinator& coord, const std::vector<Tile>& tiles, int ranks,
                         TilePool& pool)
    : coord_(coord),
      tiles_(tiles),
      pool_(pool),
      waiting_(size_t(ranks)),
      told_over_(size_t(ranks), false) {
    told_over_[0] = true;
}

bool RankService::poll() {
    bool acted = false;
    const double cpu_start = thread_seconds();
    while (std::optional<mpi::Message> m = mpi::try_receive(kTagRequest)) {
        acted = true;
        bytes_ += m->bytes.size();
        size_t at = 0;
        const RequestHeader h = read<RequestHeader>(m->bytes, at);
        for (int32_t i = 0; i < h.results; ++i) {
            coord_.complete(decode_result(m->bytes, at, tiles_, pool_));
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

bool RankService::all_told() const {
    return std::all_of(told_over_.begin(), told_over_.end(), [](bool b) { return b; });
}

void gather_rank_stats(const RankStats& mine, const std::string& isa, RenderStats& st) {
    while (!mpi::progress()) std::this_thread::sleep_for(std::chrono::microseconds(100));
    RankRecord rec{mine.seconds, mine.rays, mine.units, mine.threads, {}, {}};
    std::strncpy(rec.host, mine.host.c_str(), sizeof(rec.host) - 1);
    std::strncpy(rec.isa, isa.c_str(), sizeof(rec.isa) - 1);
    const std::vector<std::vector<char>> all = mpi::gather(&rec, sizeof(rec));
    for (size_t r = 0; r < all.size(); ++r) {
        RankRecord x;
        std::memcpy(&x, all[r].data(), sizeof(x));
        st.ranks.push_back({int(r), x.host, x.threads, x.rays, x.units, x.seconds});
        if (std::string(x.isa) != isa)
            st.warnings.push_back("rank " + std::to_string(r) + " rendered with " + x.isa +
                                  " kernels, rank 0 with " + isa +
                                  ": the image is right but not bit-identical to a "
                                  "one-process render (pass --isa to make them equal)");
    }
}

}  // namespace cierzo
