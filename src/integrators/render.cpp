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
#include <memory>
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

// The estimator's limits a render checks first: an emitter is chosen from 24 random bits,
// and the roulette's settings.
void check_estimator(const Scene& scene) {
    if (traits(scene.settings.estimator.kind).draws_emitters &&
        scene.emitters.count() > (size_t(1) << 24))
        throw InputError(scene.source.string() + ": " + std::to_string(scene.emitters.count()) +
                         " emitting spheres and triangles; the nee and mis estimators sample "
                         "at most 2^24 (16,777,216)");
    check_roulette(scene.settings.estimator, scene.source.string());
}

// A guided render's path guide (none unguided), checked against the options; rank 0's goes
// on from a resumed checkpoint's.
std::unique_ptr<PathGuide> make_guide(const Scene& scene, const RenderOptions& options, bool root) {
    if (scene.settings.estimator.guiding == Guiding::kNone) return nullptr;
    check_guiding(scene.settings.estimator, scene.source.string());
    // (the wavefront's guided paths end where the film's lengths end; the scalar loop's go on
    // past render.max_length while their records gather light)
    if (options.integrator != Integrator::kScalar && limits_length(scene.settings.estimator))
        throw InputError(scene.source.string() + ": --guiding " +
                         guiding_name(scene.settings.estimator.guiding) +
                         " with render.min_length or render.max_length runs with "
                         "--integrator scalar only (docs/guiding.md)");
    if (options.strategies)
        throw InputError(scene.source.string() + ": --guiding " +
                         guiding_name(scene.settings.estimator.guiding) +
                         " is not supported with --strategies");
    auto guide =
        std::make_unique<PathGuide>(options.guide_merges_threads, true,
                                    options.guide_first_fraction.value_or(kGuideFirstFraction),
                                    options.guide_learn_records.value_or(kGuideLearnRecords));
    if (root && options.resume) {
        if (options.resume->guide.empty())
            throw InputError(scene.source.string() +
                             ": the checkpoint to resume holds no path guide");
        guide->restore(options.resume->guide);
    }
    return guide;
}

// Light tracing needs lights to start from; emitters it cannot sample (planes, quadrics,
// textured emission) are left to the camera's paths, with a warning where nothing else
// shines.
std::vector<std::string> check_light_tracing(const Scene& scene) {
    std::vector<std::string> warnings;
    if (!traits(scene.settings.estimator.kind).light_batches) return warnings;
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
    return warnings;
}

// What a render's two ways (this process's threads, or MPI's ranks) share: the guide, the
// wavefront's kernels, the units and the renderer of one, the result, this process's
// figures, the state resumed and the passes from there.
struct RenderRun {
    const Scene& scene;
    const RenderOptions& options;
    const bool root;
    std::unique_ptr<PathGuide> guide;
    std::unique_ptr<WavefrontRenderer> wavefront;
    const int threads;
    const std::vector<Tile> tiles;
    TilePool pool;
    const UnitRenderer renderer;
    RenderResult result;
    RankStats mine;
    const Clock::time_point start;
    const RenderState* resume;
    std::vector<int64_t> bounds;

    RenderRun(const Scene& s, const RenderOptions& o, bool is_root, std::unique_ptr<PathGuide> g,
              std::vector<std::string> warnings)
        : scene(s),
          options(o),
          root(is_root),
          guide(std::move(g)),
          wavefront(o.integrator == Integrator::kWavefront
                        ? std::make_unique<WavefrontRenderer>(s, parse_isa(o.isa), o.pool_size,
                                                              o.specialise, o.light_store_limit,
                                                              o.ray_group)
                        : nullptr),
          threads(o.threads > 0 ? o.threads : oneapi::tbb::info::default_concurrency()),
          tiles(work_units(s.settings.width, s.settings.height,
                           traits(s.settings.estimator.kind).light_batches)),
          renderer(s, wavefront.get(), tiles, pool, o.light_store_limit, o.strategies, guide.get()),
          result{root ? Film(s.settings.width, s.settings.height) : Film(0, 0), {}},
          mine{mpi::world().rank, mpi::host_name(), threads},
          start(Clock::now()),
          resume(root ? o.resume : nullptr) {
        RenderStats& st = result.stats;
        st.warnings = std::move(warnings);  // (the program prints them at the end)
        st.threads = threads;
        st.integrator = integrator_name(o.integrator);
        st.isa = wavefront ? isa_name(wavefront->isa()) : "scalar";
        if (wavefront) {
            st.pool_size = wavefront->pool_size(), st.pool_bytes = wavefront->pool_bytes();
            st.ray_group = wavefront->ray_group();
        }
        if (resume) {
            if (resume->film.width() != s.settings.width ||
                resume->film.height() != s.settings.height)
                throw std::logic_error("resumed state of another resolution");
            st.spp_resumed = resume->spp_done;
        }
        bounds = pass_bounds(resume ? resume->spp_done : 0, s.settings.spp, pass_pixels(s));
    }

    void on_ranks();
    void in_this_process();
    void finish_stats();
};

// Under MPI every rank owns a band of the image and adds its passes; rank 0 also hands out
// the units (rank_protocol.h) and gathers every rank's figures.
void RenderRun::on_ranks() {
    RenderStats& st = result.stats;
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
        if (options.checkpoint) st.checkpoint_final_failed = !checkpoints.write(out.final_state);
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
    if (root) set_lane_utilisation(st, lanes);
}

// One process: its threads take units from the coordinator; the main thread is one of them,
// and also polls for an interruption and starts the checkpoints when they are due.
void RenderRun::in_this_process() {
    RenderStats& st = result.stats;
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
    const std::function<void()> duties = [&] {
        if (options.cancel && options.cancel->load()) coord.poll_interrupt();
        if (options.checkpoint && options.checkpoint_every > 0.0 &&
            Clock::now() >= next_checkpoint && !coord.stopping()) {
            checkpoints.start([&] { return coord.snapshot(resume); });
            next_checkpoint = Clock::now() + every;
        }
    };
    std::vector<std::thread> workers;
    for (int i = 1; i < threads; ++i)
        workers.emplace_back([&] { work(coord, renderer, start, totals, nullptr); });
    work(coord, renderer, start, totals, &duties);
    for (std::thread& t : workers) t.join();
    progress.stop();
    checkpoints.join();
    coord.rethrow_failure();  // (a render thread's error, e.g. out of memory)
    // The final state (with the tiles done of the pass in progress, after a stop)
    if (options.checkpoint) st.checkpoint_final_failed = !checkpoints.write(coord.snapshot(resume));
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

// The figures of the image (rank 0's): paths, non-finite samples, error, paths reached.
void RenderRun::finish_stats() {
    RenderStats& st = result.stats;
    if (guide) {
        st.guiding = guide->stats();
        if (wavefront) st.guiding->record_table_bytes = wavefront->guide_record_bytes();
    }
    st.paths = st.rays.camera + st.rays.light;
    st.nonfinite_samples = result.film.nonfinite_samples();
    st.mean_relative_error = result.film.mean_relative_error();
    st.spp_reached = int64_t(result.film.min_samples());
}

}  // namespace

RenderResult render(const Scene& scene, const RenderOptions& options) {
    check_estimator(scene);
    const mpi::World& world = mpi::world();
    const bool root = world.rank == 0;
    std::unique_ptr<PathGuide> guide = make_guide(scene, options, root);
    std::vector<std::string> warnings = check_light_tracing(scene);
    if (options.strategies && (options.integrator != Integrator::kScalar ||
                               !traits(scene.settings.estimator.kind).strategy_images ||
                               world.size > 1 || options.resume || options.checkpoint ||
                               options.strategies->width() != scene.settings.width ||
                               options.strategies->height() != scene.settings.height))
        throw std::logic_error("strategy images are scalar bdpt's, in one process, from zero");
    // (the light vertex cache's estimate of the light subpaths' vertices, once per scene and
    // settings, here before the clock for both integrators, as the trees' build is)
    prepare_path_context(scene);
    RenderRun run(scene, options, root, std::move(guide), std::move(warnings));
    // (a render stopped at a training point, before the training: it trains now; ranks train
    // together, rank_protocol.h)
    if (run.guide && run.resume && world.size == 1 && PathGuide::trains_before(run.bounds[0]) &&
        run.guide->trained_through() < run.bounds[0])
        run.guide->train(run.bounds[0]);
    if (world.size > 1) {
        run.on_ranks();
        if (!root) return std::move(run.result);
    } else {
        run.in_this_process();
    }
    run.finish_stats();
    return std::move(run.result);
}

}  // namespace cierzo
