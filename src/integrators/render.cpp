// The render driver: tiles handed to TBB worker threads, a progress line on stderr, and
// the statistics of the run. Integrators only fill tiles; they know nothing of threads.
#include "integrators/render.h"

#include <chrono>
#include <limits>
#include <condition_variable>
#include <cstdio>
#include <mutex>
#include <optional>
#include <thread>

#include <oneapi/tbb/enumerable_thread_specific.h>
#include <oneapi/tbb/global_control.h>
#include <oneapi/tbb/info.h>
#include <oneapi/tbb/parallel_for.h>
#include <oneapi/tbb/task_arena.h>
#include <unistd.h>

#include "core/error.h"
#include "integrators/scalar.h"
#include "integrators/wavefront/wavefront.h"

namespace cierzo {

namespace {

using Clock = std::chrono::steady_clock;

std::vector<Tile> make_tiles(int width, int height) {
    std::vector<Tile> tiles;
    for (int y = 0; y < height; y += kTileSize)
        for (int x = 0; x < width; x += kTileSize)
            tiles.push_back({x, y, std::min(x + kTileSize, width), std::min(y + kTileSize, height)});
    return tiles;
}

// Prints "percent, ETA, Mrays/s" every half second until stopped.
class Progress {
public:
    Progress(bool enabled, size_t total) : enabled_(enabled), total_(total) {
        if (enabled_) thread_ = std::thread([this] { run(); });
    }
    ~Progress() { stop(); }
    void tile_done(uint64_t rays) {
        rays_.fetch_add(rays, std::memory_order_relaxed);
        done_.fetch_add(1, std::memory_order_relaxed);
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
        const double s = std::chrono::duration<double>(Clock::now() - start_).count();
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

}  // namespace

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
    std::unique_ptr<WavefrontRenderer> wavefront;
    if (options.integrator == "wavefront")
        wavefront = std::make_unique<WavefrontRenderer>(scene, parse_isa(options.isa),
                                                        options.pool_size, options.specialise);
    const int threads =
        options.threads > 0 ? options.threads : oneapi::tbb::info::default_concurrency();
    const RenderSettings& rs = scene.settings;
    RenderResult result{Film(rs.width, rs.height), {}};
    std::vector<Tile> tiles = make_tiles(rs.width, rs.height);
    // Passes of 1, 2, 4, 8 and then 16 paths per pixel: a fixed schedule (so the image does
    // not depend on timing), fine enough to stop soon after a request
    std::vector<int64_t> pass_end;
    for (int64_t done = 0, size = 1; done < rs.spp; size = std::min<int64_t>(size * 2, 16)) {
        done = std::min(rs.spp, done + size);
        pass_end.push_back(done);
    }
    const int64_t passes = int64_t(pass_end.size());

    // Pass by pass, tiles in parallel; per-thread ray counters summed at the end
    oneapi::tbb::enumerable_thread_specific<RayCounts> counts;
    oneapi::tbb::enumerable_thread_specific<LaneStats> lane_stats;
    std::string stopped_by;
    const auto start = Clock::now();
    {
        Progress progress(options.progress && isatty(STDERR_FILENO),
                          tiles.size() * size_t(passes));
        // More threads than the hardware has (to measure oversubscription) needs the
        // scheduler's limit raised; otherwise it would quietly run fewer
        std::optional<oneapi::tbb::global_control> limit;
        if (threads > oneapi::tbb::info::default_concurrency())
            limit.emplace(oneapi::tbb::global_control::max_allowed_parallelism, size_t(threads));
        oneapi::tbb::task_arena arena(threads);
        for (int64_t pass = 0; pass < passes; ++pass) {
            for (Tile& t : tiles) {
                t.s0 = pass == 0 ? 0 : pass_end[size_t(pass) - 1];
                t.s1 = pass_end[size_t(pass)];
            }
            arena.execute([&] {
                oneapi::tbb::parallel_for(size_t(0), tiles.size(), [&](size_t i) {
                    RayCounts local;
                    if (wavefront) {
                        wavefront->render_tile(tiles[i], result.film, local, lane_stats.local());
                    } else {
                        render_tile_scalar(scene, tiles[i], result.film, local);
                    }
                    counts.local() += local;
                    progress.tile_done(local.total());
                });
            });
            // Stopping rules, checked between passes
            if (pass + 1 == passes) break;
            const double elapsed = std::chrono::duration<double>(Clock::now() - start).count();
            if (options.cancel && options.cancel->load()) {
                stopped_by = "interrupted";
            } else if (options.time_budget > 0.0 && elapsed >= options.time_budget) {
                stopped_by = "time budget";
            } else if (options.target_error > 0.0 && pass_end[size_t(pass)] >= 16 &&
                       result.film.mean_relative_error().value_or(std::numeric_limits<double>::infinity()) <=
                           options.target_error) {
                // (from 16 paths per pixel on: fewer give no trustworthy variance)
                stopped_by = "target error";
            }
            if (!stopped_by.empty()) break;
        }
    }
    const double seconds = std::chrono::duration<double>(Clock::now() - start).count();

    // Statistics of the run
    RenderStats& st = result.stats;
    st.seconds = seconds;
    st.threads = threads;
    st.integrator = options.integrator;
    for (const RayCounts& c : counts) st.rays += c;
    st.paths = st.rays.camera;
    st.nonfinite_samples = result.film.nonfinite_samples();
    st.mean_relative_error = result.film.mean_relative_error();
    st.spp_reached = int64_t(result.film.min_samples());
    st.stopped_by = stopped_by;
    if (wavefront) {
        LaneStats lanes;
        for (const LaneStats& l : lane_stats) {
            lanes.shade_active += l.shade_active, lanes.shade_total += l.shade_total;
            lanes.isect_active += l.isect_active, lanes.isect_total += l.isect_total;
            lanes.shadow_active += l.shadow_active, lanes.shadow_total += l.shadow_total;
        }
        st.isa = isa_name(wavefront->isa());
        st.shade_lane_utilisation = double(lanes.shade_active) / double(std::max<uint64_t>(lanes.shade_total, 1));
        st.isect_lane_utilisation = double(lanes.isect_active) / double(std::max<uint64_t>(lanes.isect_total, 1));
        st.shadow_lane_utilisation = double(lanes.shadow_active) / double(std::max<uint64_t>(lanes.shadow_total, 1));
        st.pool_size = wavefront->pool_size();
        st.pool_bytes = wavefront->pool_bytes();
    }
    return result;
}

}  // namespace cierzo
