// The render driver: the integrator chosen, this process's threads taking units from the
// coordinator (integrators/scheduler.h) or, under MPI, from rank 0 (rank_protocol.h),
// checkpoints written by a thread of their own, and the statistics of the run. Integrators
// only fill tiles; they know nothing of threads or processes.
#include "integrators/render.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <exception>
#include <functional>
#include <mutex>
#include <thread>

#include <fmt/format.h>
#include <oneapi/tbb/info.h>
#include <unistd.h>

#include "core/error.h"
#include "integrators/distributed.h"
#include "integrators/light_pilot.h"
#include "integrators/progress.h"
#include "integrators/rank_protocol.h"
#include "integrators/scheduler.h"
#include "integrators/wavefront/wavefront.h"

namespace cierzo {

void refuse_light_store(const Scene& scene, size_t limit, size_t vertices) {
    const std::string bound = limit >= (size_t(1) << 20)
                                  ? fmt::format("{:.0f} MiB", double(limit) / double(1 << 20))
                                  : fmt::format("{} bytes", limit);
    throw InputError(fmt::format(
        "{}: {}: a unit's light subpaths need more than {} of light-vertex store (over {} "
        "vertices): paths this long come from a survival cap near 1 (survival_cap {}); lower "
        "it (--survival-cap), or use an estimator without light subpaths",
        scene.source.string(), estimator_name(scene.settings.estimator.kind), bound, vertices,
        scene.settings.estimator.survival_cap));
}

namespace {

// Checkpoints, written by a thread of their own (the main thread renders or serves the other
// ranks meanwhile), one at a time. A failed write is a warning: the previous file is kept.
class CheckpointWriter {
public:
    CheckpointWriter(const RenderOptions& options, RenderStats& stats)
        : options_(options), stats_(stats) {}
    ~CheckpointWriter() { join(); }

    // Writes the state `snapshot()` returns in the background, unless a write is still
    // going on; then no snapshot is taken (it copies the whole film).
    template <class Snapshot>
    void start(const Snapshot& snapshot) {
        if (writing_) return;
        join();
        writing_ = true;
        thread_ = std::thread([this, s = snapshot()] { write(s); });
    }
    // Writes `state` now; returns whether it was written.
    bool write(const RenderState& state) {
        bool written = false;
        try {
            const auto t = Clock::now();
            options_.checkpoint(state);
            std::lock_guard lock(mutex_);
            ++stats_.checkpoint_writes;
            stats_.checkpoint_last_seconds = seconds_since(t);
            stats_.checkpoint_seconds += stats_.checkpoint_last_seconds;
            written = true;
        } catch (const std::exception& e) {  // (InputError: the file's name and why)
            const std::string w = std::string(e.what()) + "; the previous checkpoint is kept";
            std::fprintf(stderr, "\ncierzo: %s\n", w.c_str());
            std::lock_guard lock(mutex_);
            stats_.warnings.push_back(w);
            ++stats_.checkpoint_failures;
        }
        writing_ = false;
        return written;
    }
    void join() {
        if (thread_.joinable()) thread_.join();
    }

private:
    const RenderOptions& options_;
    RenderStats& stats_;
    std::mutex mutex_;
    std::atomic<bool> writing_{false};
    std::thread thread_;
};

// What this process's threads did, added up as they go.
struct WorkTotals {
    std::atomic<uint64_t> rays{0}, units{0};
    std::atomic<int64_t> last_ns{0};        // from the start to the last unit finished
    std::atomic<uint64_t> scheduler_ns{0};  // in grant and complete (the coordinator's lock,
                                            // adding whole passes to the film)
    std::atomic<uint64_t> idle_ns{0};       // waiting for a unit
};

int64_t nanoseconds(Clock::duration d) {
    return std::chrono::duration_cast<std::chrono::nanoseconds>(d).count();
}

// Renders units from the coordinator until the render stops. On the main thread `duties`
// runs before each unit and while it waits (interruption, checkpoints); a unit is
// finished and handed in on the thread that rendered it, so a render on one thread hands
// nothing between threads.
void work(Coordinator& coord, const UnitRenderer& renderer, Clock::time_point start,
          WorkTotals& totals, const std::function<void()>* duties) {
    try {
        for (;;) {
            if (duties) (*duties)();
            const auto t0 = Clock::now();
            std::vector<Unit> u = coord.grant(1);
            const auto t1 = Clock::now();
            if (u.empty()) {
                if (coord.stopping()) break;
                coord.wait(std::chrono::milliseconds(5));
                totals.idle_ns += uint64_t(nanoseconds(Clock::now() - t1));
                continue;
            }
            UnitResult r = renderer.render(u[0]);
            const auto t2 = Clock::now();
            totals.rays += r.rays.total(), ++totals.units;
            totals.last_ns = nanoseconds(t2 - start);
            coord.complete(std::move(r));
            totals.scheduler_ns += uint64_t(nanoseconds(t1 - t0) + nanoseconds(Clock::now() - t2));
        }
    } catch (...) {
        coord.fail(std::current_exception());
    }
}

void set_lane_utilisation(RenderStats& st, const LaneStats& lanes) {
    st.shade_lane_utilisation =
        double(lanes.shade_active) / double(std::max<uint64_t>(lanes.shade_total, 1));
    st.isect_lane_utilisation =
        double(lanes.isect_active) / double(std::max<uint64_t>(lanes.isect_total, 1));
    st.shadow_lane_utilisation =
        double(lanes.shadow_active) / double(std::max<uint64_t>(lanes.shadow_total, 1));
}

}  // namespace

std::vector<int64_t> pass_bounds(int64_t start, int64_t spp, int64_t pixels) {
    // Boundaries 1, 2, 4, 8, 16 (those of passes of kMinPassPaths paths or more) and then
    // every 16: so a finished render of a multiple of 16 paths per pixel (in a large image,
    // of a power of two too) ends on a boundary, and can be continued to more paths with the
    // very bits of an uninterrupted render of more
    std::vector<int64_t> bounds{start};
    int64_t kept = 0;  // the last boundary of the schedule from zero
    for (int64_t b = 1; b < spp + 16; b = b < 16 ? 2 * b : b + 16) {
        if (b < 16 && b < spp && (b - kept) * std::max<int64_t>(pixels, 1) < kMinPassPaths)
            continue;
        kept = b;
        const int64_t end = std::min(b, spp);
        if (end > bounds.back()) bounds.push_back(end);
        if (end == spp) break;
    }
    return bounds;
}

int64_t pass_pixels(const Scene& scene) {
    if (splats(scene.settings.estimator.kind)) return kMinPassPaths;
    return int64_t(scene.settings.width) * int64_t(scene.settings.height);
}

std::vector<Tile> image_tiles(int width, int height) {
    std::vector<Tile> tiles;
    for (int y = 0; y < height; y += kTileSize)
        for (int x = 0; x < width; x += kTileSize)
            tiles.push_back(
                {x, y, std::min(x + kTileSize, width), std::min(y + kTileSize, height)});
    return tiles;
}

int light_batch_rows(int width) {
    return std::max(1, (kLightBatchPixels + width / 2) / std::max(width, 1));
}

std::vector<Tile> work_units(int width, int height, bool light) {
    std::vector<Tile> units;
    if (light) {
        const int rows = light_batch_rows(width);
        for (int y = 0; y < height; y += rows) {
            Tile batch{0, y, width, std::min(y + rows, height)};
            batch.light = true;
            units.push_back(batch);
        }
    }
    const std::vector<Tile> tiles = image_tiles(width, height);
    units.insert(units.end(), tiles.begin(), tiles.end());
    return units;
}

RenderResult render(const Scene& scene, const RenderOptions& options) {
    // (an emitter is chosen from 24 random bits)
    if (traits(scene.settings.estimator.kind).draws_emitters &&
        scene.emitters.count() > (size_t(1) << 24))
        throw InputError(scene.source.string() + ": " + std::to_string(scene.emitters.count()) +
                         " emitting spheres and triangles; the nee and mis estimators sample "
                         "at most 2^24 (16,777,216)");
    check_roulette(scene.settings.estimator, scene.source.string());
    const mpi::World& world = mpi::world();
    std::unique_ptr<PathGuide> guide;
    if (scene.settings.estimator.guiding != Guiding::kNone) {
        check_guiding(scene.settings.estimator, scene.source.string());
        // (the wavefront's guided paths end where the film's lengths end; the scalar loop's go
        // on past render.max_length while their records gather light)
        if (options.integrator != Integrator::kScalar && limits_length(scene.settings.estimator))
            throw InputError(scene.source.string() + ": --guiding " +
                             guiding_name(scene.settings.estimator.guiding) +
                             " with render.min_length or render.max_length runs with "
                             "--integrator scalar only (docs/guiding.md)");
        if (options.strategies)
            throw InputError(scene.source.string() + ": --guiding " +
                             guiding_name(scene.settings.estimator.guiding) +
                             " is not supported with --strategies");
        guide =
            std::make_unique<PathGuide>(options.guide_merges_threads, true,
                                        options.guide_first_fraction.value_or(kGuideFirstFraction),
                                        options.guide_learn_records.value_or(kGuideLearnRecords));
        // (a resumed render's guide goes on from its checkpoint's)
        if (world.rank == 0 && options.resume) {
            if (options.resume->guide.empty())
                throw InputError(scene.source.string() +
                                 ": the checkpoint to resume holds no path guide");
            guide->restore(options.resume->guide);
        }
    }
    const bool root = world.rank == 0;
    std::vector<std::string> warnings;
    if (traits(scene.settings.estimator.kind).light_batches) {
        // Light tracing needs lights to start from; emitters it cannot sample (planes,
        // quadrics, textured emission) are left to the camera's paths
        if (scene.light_starts.total_power <= 0.0 && scene.emitters.unsampled_objects == 0)
            throw InputError(scene.source.string() +
                             ": the lt estimator needs a light: the scene has no point light "
                             "and no emitter");
        if (scene.light_starts.total_power <= 0.0)
            warnings.push_back(
                scene.source.string() +
                ": no light or emitter here can start a light path (planes, quadrics and "
                "textured emission are not sampled): light tracing adds nothing, the image is "
                "the camera paths' alone");
    }
    if (options.strategies && (options.integrator != Integrator::kScalar ||
                               !traits(scene.settings.estimator.kind).strategy_images ||
                               world.size > 1 || options.resume || options.checkpoint ||
                               options.strategies->width() != scene.settings.width ||
                               options.strategies->height() != scene.settings.height))
        throw std::logic_error("strategy images are scalar bdpt's, in one process, from zero");
    // (the light vertex cache's estimate of the light subpaths' vertices, once per scene and
    // settings, here before the clock for both integrators, as the trees' build is)
    prepare_path_context(scene);
    std::unique_ptr<WavefrontRenderer> wavefront;
    if (options.integrator == Integrator::kWavefront)
        wavefront = std::make_unique<WavefrontRenderer>(
            scene, parse_isa(options.isa), options.pool_size, options.specialise,
            options.light_store_limit, options.ray_group);
    const int threads =
        options.threads > 0 ? options.threads : oneapi::tbb::info::default_concurrency();
    const RenderSettings& rs = scene.settings;
    const std::vector<Tile> tiles =
        work_units(rs.width, rs.height, traits(scene.settings.estimator.kind).light_batches);
    TilePool pool;
    const UnitRenderer renderer(scene, wavefront.get(), tiles, pool, options.light_store_limit,
                                options.strategies, guide.get());
    RenderResult result{root ? Film(rs.width, rs.height) : Film(0, 0), {}};
    RenderStats& st = result.stats;
    st.warnings = warnings;  // (the program prints them at the end)
    st.threads = threads;
    st.integrator = integrator_name(options.integrator);
    st.isa = wavefront ? isa_name(wavefront->isa()) : "scalar";
    if (wavefront) {
        st.pool_size = wavefront->pool_size(), st.pool_bytes = wavefront->pool_bytes();
        st.ray_group = wavefront->ray_group();
    }
    RankStats mine{world.rank, mpi::host_name(), threads};
    const auto start = Clock::now();

    // The state resumed (rank 0 reads it) and the passes from there
    const RenderState* resume = root ? options.resume : nullptr;
    if (resume) {
        if (resume->film.width() != rs.width || resume->film.height() != rs.height)
            throw std::logic_error("resumed state of another resolution");
        st.spp_resumed = resume->spp_done;
    }
    const std::vector<int64_t> bounds =
        pass_bounds(resume ? resume->spp_done : 0, rs.spp, pass_pixels(scene));
    // (a render stopped at a training point, before the training: it trains now; ranks
    // train together, rank_protocol.h)
    if (guide && resume && world.size == 1 && PathGuide::trains_before(bounds[0]) &&
        guide->trained_through() < bounds[0])
        guide->train(bounds[0]);

    if (world.size > 1) {
        // Under MPI every rank owns a band of the image and adds its passes; rank 0 also
        // hands out the units (rank_protocol.h)
        CheckpointWriter checkpoints(options, st);
        LaneStats lanes;
        RankRun run{scene,
                    options,
                    tiles,
                    size_t(std::count_if(tiles.begin(), tiles.end(), [](const Tile& t) { return t.light; })),
                    renderer,
                    pool,
                    threads,
                    start,
                    {},
                    nullptr,
                    {}};
        run.guide = guide.get();
        if (root) {
            run.bounds = bounds;
            run.resume = resume;
            run.checkpoint = [&](RenderState&& state) {
                auto shared = std::make_shared<RenderState>(std::move(state));
                checkpoints.start([shared] { return std::move(*shared); });
            };
        }
        DistributedOutcome out = render_as_rank(run, mine, lanes);
        if (root) {
            checkpoints.join();
            if (options.checkpoint)
                st.checkpoint_final_failed = !checkpoints.write(out.final_state);
            result.film = std::move(out.final_state.film);
            st.units = mine.units;
            st.stopped_by = out.stopped_by;
            st.rays = out.rays;
            st.rank0_cpu_seconds = out.service_seconds;
            st.rank0_gather_cpu_seconds = out.gather_seconds;
            st.rank0_deal_cpu_seconds = out.deal_seconds;
            st.units_handed_out = out.units;
            st.requests = out.requests, st.reports = out.reports;
            st.bytes_received = out.bytes_received;
            if (wavefront) st.light_store_bytes = wavefront->light_store_bytes();
        }
        st.seconds = seconds_since(start);
        // Every rank's figures, on rank 0
        gather_rank_stats(mine, st.isa, st, lanes);
        if (!root) return result;
        set_lane_utilisation(st, lanes);
    } else {
        if (resume) result.film = resume->film;
        Progress progress(options.progress && isatty(STDERR_FILENO),
                          tiles.size() * (bounds.size() - 1));
        Coordinator coord(scene, options, tiles, bounds, result.film, start, progress, pool,
                          guide.get());
        if (resume && !guide) coord.restore_pending(*resume);  // (guided: none kept)

        CheckpointWriter checkpoints(options, st);
        WorkTotals totals;
        const auto every = std::chrono::duration_cast<Clock::duration>(
            std::chrono::duration<double>(options.checkpoint_every));
        auto next_checkpoint = start + every;
        // The main thread's duties: interruption, and checkpoints when they are due
        const std::function<void()> duties = [&] {
            if (options.cancel && options.cancel->load()) coord.poll_interrupt();
            if (options.checkpoint && options.checkpoint_every > 0.0 &&
                Clock::now() >= next_checkpoint && !coord.stopping()) {
                checkpoints.start([&] { return coord.snapshot(resume); });
                next_checkpoint = Clock::now() + every;
            }
        };
        // The main thread is one of the render threads
        std::vector<std::thread> workers;
        for (int i = 1; i < threads; ++i)
            workers.emplace_back([&] { work(coord, renderer, start, totals, nullptr); });
        work(coord, renderer, start, totals, &duties);
        for (std::thread& t : workers) t.join();
        progress.stop();
        checkpoints.join();
        coord.rethrow_failure();  // (a render thread's error, e.g. out of memory)
        // The final state (with the tiles done of the pass in progress, after a stop)
        if (options.checkpoint)
            st.checkpoint_final_failed = !checkpoints.write(coord.snapshot(resume));
        mine.rays = totals.rays, mine.units = totals.units;
        mine.seconds = double(totals.last_ns.load()) * 1e-9;
        st.units = totals.units;
        st.scheduler_seconds = double(totals.scheduler_ns.load()) * 1e-9;
        st.idle_seconds = double(totals.idle_ns.load()) * 1e-9;
        st.stopped_by = coord.stopped_by();
        st.rays = coord.rays();
        set_lane_utilisation(st, coord.lanes());
        if (wavefront) st.light_store_bytes = wavefront->light_store_bytes();
        st.seconds = seconds_since(start);
    }
    if (guide) {
        st.guiding = guide->stats();
        if (wavefront) st.guiding->record_table_bytes = wavefront->guide_record_bytes();
    }
    st.paths = st.rays.camera + st.rays.light;
    st.nonfinite_samples = result.film.nonfinite_samples();
    st.mean_relative_error = result.film.mean_relative_error();
    st.spp_reached = int64_t(result.film.min_samples());
    return result;
}

}  // namespace cierzo