// One render as `cierzo render` runs it (see render_job.h): overrides, checks, checkpoints,
// outputs and statistics, shared by the command line and the Python module.
#include "apps/render_job.h"

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>

#include <unistd.h>

#include <fmt/format.h>

#include "apps/app_common.h"
#include "core/error.h"
#include "integrators/checkpoint.h"
#include "integrators/distributed.h"
#include "integrators/light_pilot.h"
#include "integrators/render.h"
#include "integrators/wavefront/isa.h"
#include "integrators/wavefront/wavefront.h"
#include "io/output_file.h"
#include "integrators/registry.h"

namespace cierzo {

namespace fs = std::filesystem;

namespace {

// Whether `spp` ends a pass of an uninterrupted render of `target` paths per pixel
// (pass_bounds from zero) of an image of `pixels`.
bool on_pass_schedule(int64_t spp, int64_t target, int64_t pixels) {
    for (int64_t b : pass_bounds(0, target, pixels))
        if (b == spp) return true;
    return false;
}

// The strategy images recorded by a render of `scene` (with the job's overrides) that asks
// for them; throws InputError naming the option when it cannot record them.
StrategyLayout strategy_layout(const Scene& scene, const RenderJob& a, int ranks) {
    const EstimatorSettings& e = scene.settings.estimator;
    const char* option = a.strategies_dir.empty() ? "strategies" : "--strategies";
    const auto refuse = [&](const std::string& why) {
        throw InputError(std::string(option) + ": " + why);
    };
    if (!traits(e.kind).strategy_images)
        refuse(std::string("strategy images are bdpt's (this render's estimator is ") +
               estimator_name(e.kind) +
               (merges(e.kind) ? "; merging is no strategy (s, t))" : ")"));
    if (!a.strategy.empty())
        refuse("it records every strategy; --strategy keeps one (give one or the other)");
    if (a.integrator_given && integrator_of(a.integrator) != Integrator::kScalar)
        refuse(
            "the scalar integrator records the strategy images (--integrator scalar, or "
            "leave --integrator out)");
    if (ranks > 1)
        refuse("one process records the strategy images (this run has " + std::to_string(ranks) +
               " MPI ranks)");
    if (!a.checkpoint.empty() || !a.resume.empty())
        refuse("a render with strategy images takes no checkpoint and resumes none");
    StrategyLayout layout;
    if (e.max_length == kNoLengthLimit) {
        layout.max_length = StrategyLayout::kDefaultLength;
    } else if (e.max_length > StrategyLayout::kLengthLimit) {
        refuse(
            fmt::format("strategy images go up to paths of {} segments; the render's "
                        "--max-length (or render.max_length) is {}",
                        StrategyLayout::kLengthLimit, e.max_length));
    } else {
        layout.max_length = e.max_length;
    }
    const RenderSettings& s = scene.settings;
    const size_t bytes = StrategyFilm::bytes(s.width, s.height, layout);
    if (bytes > kStrategyMemoryLimit)
        refuse(
            fmt::format("{} strategies (paths up to {} segments) at {}x{} take {:.1f} GiB, "
                        "more than the {} GiB allowed: lower --max-length or the resolution",
                        layout.count(), layout.max_length, s.width, s.height,
                        double(bytes) / double(size_t(1) << 30), kStrategyMemoryLimit >> 30));
    return layout;
}

// Refuses, before any work, an output that cannot be written or that is the same file as an
// input (the scene, its meshes, the checkpoint resumed) or as another output.
void check_render_outputs(const Scene& scene, const RenderJob& a, const fs::path& checkpoint,
                          const StrategyLayout& strategies) {
    std::vector<OutputPath> outputs;
    if (a.write_outputs) {
        const fs::path& image = scene.settings.output;
        const std::string ext = image.extension().string();
        if (ext != ".exr" && ext != ".pfm")
            throw InputError(image.string() + ": output must end in .exr or .pfm");
        outputs.push_back(
            {image, a.out.empty() ? "the scene's render.output" : "--out", "the image"});
        outputs.push_back({a.stats, "--stats", "the statistics"});
        if (a.strategies && a.strategies_dir.empty())
            throw InputError("--strategies: empty folder name");
        if (a.strategies) {
            const fs::path& dir = a.strategies_dir;
            std::error_code ec;
            const fs::file_status st = fs::status(dir, ec);
            if (fs::exists(st) && !fs::is_directory(st))
                throw InputError(dir.string() + ": --strategies must name a folder (it is a file)");
            if (!fs::exists(st)) {
                // (a folder still to be made holds nothing its images could replace)
                const fs::path parent = dir.has_parent_path() ? dir.parent_path() : fs::path(".");
                if (!fs::is_directory(parent, ec))
                    throw InputError(dir.string() + ": --strategies: its folder " +
                                     parent.string() + " does not exist");
                if (::access(parent.c_str(), W_OK) != 0)
                    throw InputError(dir.string() + ": --strategies: cannot make it in " +
                                     parent.string() + ": " + std::strerror(errno));
            } else {
                for (int i = 0; i < strategies.count(); ++i)
                    for (bool weighted : {true, false})
                        outputs.push_back({strategy_image_path(dir, strategies, i, weighted),
                                           "--strategies", "a strategy image"});
            }
        }
    }
    if (!checkpoint.empty()) {
        const char* option = a.checkpoint.empty() ? "--resume" : "--checkpoint";
        if (checkpoint.extension() != ".exr")
            throw InputError(checkpoint.string() + ": a checkpoint must end in .exr");
        if (resolve_output(checkpoint, "the checkpoint").kind != OutputTarget::Kind::kFile)
            throw InputError(checkpoint.string() + ": " + option +
                             " must be a regular file "
                             "(a checkpoint is read back by --resume)");
        outputs.push_back({checkpoint, option, "the checkpoint"});
    }
    std::vector<InputPath> inputs = scene_inputs(scene);
    // (checkpoints go on into the file resumed unless --checkpoint names another)
    if (!a.resume.empty() && !writes_over(checkpoint, a.resume))
        inputs.push_back({a.resume, "--resume"});
    check_outputs(outputs, inputs);
}

}  // namespace

int total_threads(const RenderStats& st) {
    if (st.ranks.empty()) return st.threads;
    int n = 0;
    for (const RankStats& r : st.ranks) n += r.threads;
    return n;
}

void check_render_isa(const RenderJob& job) {
    if (integrator_of(job.integrator) == Integrator::kWavefront)
        require_isa(parse_isa(job.isa), "--isa");
}

void apply_spatial_splits(Scene& scene, std::optional<float> budget) {
    if (!budget) return;
    if (!(*budget >= 0.0f && *budget <= kBvhMaxSplitBudget))
        throw InputError(
            "--spatial-splits: must be in [0, 4], the fraction of extra triangle "
            "references the BVH may cut (got " +
            fmt::format("{}", *budget) + ")");
    if (*budget == scene.settings.spatial_splits) return;
    scene.settings.spatial_splits = *budget;
    scene.finalize();  // (the BVH again, with the scene's other tables)
}

void apply_render_overrides(Scene& scene, const RenderJob& a) {
    apply_spatial_splits(scene, a.spatial_splits);
    RenderSettings& s = scene.settings;
    if (a.spp) s.spp = *a.spp;
    if (a.seed) s.seed = *a.seed;
    if (a.width || a.height)
        scene.set_resolution(a.width.value_or(s.width), a.height.value_or(s.height));
    if (a.survival_cap) s.estimator.survival_cap = *a.survival_cap;
    EstimatorSettings& e = s.estimator;
    if (a.diffuse_sampling)
        e.cosine_diffuse = *a.diffuse_sampling == "cosine", e.chosen |= kChoseDiffuse;
    if (a.triangle_sampling)
        e.triangle_solid_angle = *a.triangle_sampling == "solid-angle", e.chosen |= kChoseTriangles;
    if (a.roulette) e.roulette = *parse_roulette(*a.roulette), e.chosen |= kChoseRoulette;
    if (a.roulette_depth) e.roulette_depth = *a.roulette_depth;
    if (a.sampler) e.sampler = *parse_sampler(*a.sampler), e.chosen |= kChoseSampler;
    if (a.guiding) e.guiding = *parse_guiding(*a.guiding);
    if (a.guided_vertices) e.guided_vertices = *a.guided_vertices;
    if (a.min_length) s.estimator.min_length = *a.min_length;
    if (a.max_length) s.estimator.max_length = *a.max_length;
    if (s.estimator.max_length < s.estimator.min_length)
        throw InputError("--max-length " + std::to_string(s.estimator.max_length) +
                         " is below --min-length " + std::to_string(s.estimator.min_length) +
                         " (with the scene's values): no path would count");
    use_estimator(e, a.estimator ? *parse_estimator(*a.estimator) : e.kind);
    if (a.merge_radius) {
        if (!(*a.merge_radius > 0.0f) || !std::isfinite(*a.merge_radius))
            throw InputError("--merge-radius: must be a positive length (got " +
                             fmt::format("{}", *a.merge_radius) + ")");
        e.merge_radius = *a.merge_radius;
    }
    if (a.merge_alpha) {
        if (!(*a.merge_alpha > 0.0f && *a.merge_alpha < 1.0f))
            throw InputError("--merge-alpha: must be in (0, 1), exclusive (got " +
                             fmt::format("{}", *a.merge_alpha) + ")");
        e.merge_alpha = *a.merge_alpha;
    }
    if (a.light_connections) {
        if (*a.light_connections < 0 || *a.light_connections > kMaxLightConnections)
            throw InputError(
                "--light-connections: must be 0 (every vertex of the sample's own "
                "light subpath) or 1.." +
                std::to_string(kMaxLightConnections) + " draws from the light vertex cache (got " +
                std::to_string(*a.light_connections) + ")");
        if (!connects(e.kind))
            throw InputError(std::string("--light-connections: connections are bdpt's and vcm's "
                                         "(this render's estimator is ") +
                             estimator_name(e.kind) + ")");
        e.light_connections = *a.light_connections;
    }
    if ((a.merge_radius || a.merge_alpha) && !merges(e.kind))
        throw InputError(std::string(a.merge_radius ? "--merge-radius" : "--merge-alpha") +
                         ": merging is vcm's, bpm's and ppm's (this render's estimator is " +
                         estimator_name(e.kind) + ")");
    if (!a.strategy.empty()) {
        if (!traits(e.kind).strategy_images)
            throw InputError("--strategy: strategies are bdpt's (this render's estimator is " +
                             std::string(estimator_name(e.kind)) +
                             (merges(e.kind) ? "; merging is no strategy (s, t)" : "") + ")");
        if (a.strategy.size() != 2 || a.strategy[0] < 0 || a.strategy[1] < 1 ||
            a.strategy[0] + a.strategy[1] < 2 || a.strategy[0] > kMaxLengthLimit ||
            a.strategy[1] > kMaxLengthLimit)
            throw InputError(
                "--strategy: expected S,T with S >= 0 light vertices and T >= 1 "
                "camera vertices (the pinhole counts as one), S + T >= 2");
        e.strategy_s = a.strategy[0], e.strategy_t = a.strategy[1];
    }
    if (a.unweighted && a.strategy.empty())
        throw InputError(
            "--unweighted: it shows one strategy without its weight; name it with "
            "--strategy S,T");
    e.unweighted = a.unweighted;
    if (!a.out.empty()) s.output = a.out;
    check_render_size(scene, scene.source);
}

RenderJobResult run_render_job(Scene scene_in, const RenderJob& a) {
    const mpi::World& world = mpi::world();
    const bool root = world.rank == 0;
    check_render_isa(a);
    RenderJobResult done{std::move(scene_in), RenderResult{Film(0, 0), {}}, {}, {}, {}};
    Scene& scene = done.scene;
    apply_render_overrides(scene, a);
    RenderSettings& s = scene.settings;
    RenderOptions options;
    options.threads = a.threads;
    options.integrator = integrator_of(a.integrator);
    if (a.strategies) options.integrator = Integrator::kScalar;  // (it records them)
    options.isa = a.isa;
    options.pool_size = a.pool;
    options.ray_group = a.ray_group;
    options.time_budget = a.time_budget;
    options.target_error = a.target_error;
    options.cancel = a.cancel;
    options.progress = a.progress && root;

    // Checkpoints: what the pixels depend on, the state to continue from, where to write
    const bool wavefront = options.integrator == Integrator::kWavefront;
    const int pool = wavefront ? (a.pool > 0 ? a.pool : WavefrontRenderer::kDefaultPoolSize) : 0;
    const Isa chosen = parse_isa(a.isa) == Isa::kAuto ? best_isa() : parse_isa(a.isa);
    const std::string isa = wavefront ? isa_name(chosen) : "scalar";
    const fs::path checkpoint = !a.checkpoint.empty() ? a.checkpoint : a.resume;
    done.checkpoint = checkpoint;
    if (a.checkpoint_every_given && checkpoint.empty())
        throw InputError("--checkpoint-every needs --checkpoint FILE.exr (or --resume FILE.exr)");
    StrategyLayout layout;
    if (a.strategies) layout = strategy_layout(scene, a, world.size);
    if (root) check_render_outputs(scene, a, checkpoint, layout);
    if (a.strategies) {
        // (the folder once everything else is known to be right)
        if (root && !a.strategies_dir.empty() && a.write_outputs) {
            std::error_code ec;
            fs::create_directory(a.strategies_dir, ec);
            if (ec)
                throw InputError(a.strategies_dir.string() +
                                 ": --strategies: cannot make the folder: " + ec.message());
        }
        done.strategies = std::make_shared<StrategyFilm>(s.width, s.height, layout);
        options.strategies = done.strategies.get();
    }
    // (the fingerprint reads every mesh: only rank 0, and only with checkpoints)
    const CheckpointIdentity identity = root && !checkpoint.empty()
                                            ? checkpoint_identity(scene, a.integrator, isa, pool)
                                            : CheckpointIdentity{};
    std::optional<Checkpoint> resumed;
    std::vector<std::string>& resume_warnings = done.resume_warnings;
    if (root && !a.resume.empty()) {
        resumed = read_checkpoint(a.resume);
        resume_warnings = check_resume(a.resume, *resumed, identity);
        const int64_t spp_done = resumed->state.spp_done;
        if (spp_done > s.spp)
            throw InputError(
                fmt::format("{}: the checkpoint already has {} paths per pixel, "
                            "more than the {} asked for",
                            a.resume.string(), spp_done, s.spp));
        if (spp_done < s.spp && !on_pass_schedule(spp_done, s.spp, pass_pixels(scene)))
            resume_warnings.push_back(fmt::format(
                "{}: the checkpoint is a finished render of {} paths per pixel; continued to {}, "
                "the image is right but not bit-identical to an uninterrupted render of {}",
                a.resume.string(), spp_done, s.spp, s.spp));
        for (const std::string& w : resume_warnings)
            std::fprintf(stderr, "cierzo: warning: %s\n", w.c_str());
        options.resume = &resumed->state;
    }
    if (root && !checkpoint.empty()) {
        options.checkpoint_every = a.checkpoint_every;
        options.checkpoint = [&](const RenderState& state) {
            write_checkpoint(checkpoint, identity, state);
        };
    }
    if (a.on_start) a.on_start();
    done.result = render(scene, options);
    RenderStats& st = done.result.stats;
    st.warnings.insert(st.warnings.begin(), resume_warnings.begin(), resume_warnings.end());
    return done;
}

fs::path strategy_image_path(const fs::path& dir, const StrategyLayout& layout, int i,
                             bool weighted) {
    int s = 0, t = 0;
    layout.strategy(i, s, t);
    return dir /
           fmt::format("length{}_s{}_t{}{}.exr", s + t - 1, s, t, weighted ? "" : "_unweighted");
}

ImageMetadata render_metadata(const Scene& scene, const RenderStats& st) {
    const RenderSettings& s = scene.settings;
    return {{"cierzo:scene", scene.source.string()},
            {"cierzo:integrator", st.integrator},
            {"cierzo:isa", st.isa},
            {"cierzo:spp", std::to_string(s.spp)},
            {"cierzo:spp_reached", std::to_string(st.spp_reached)},
            {"cierzo:stopped_by", st.stopped_by.empty() ? "done" : st.stopped_by},
            {"cierzo:seed", std::to_string(s.seed)},
            {"cierzo:estimator", estimator_name(s.estimator.kind)}};
}

nlohmann::json render_stats_json(const Scene& scene, const RenderStats& st,
                                 const fs::path& checkpoint) {
    nlohmann::json j = {
        {"scene", scene.source.string()},
        {"integrator", st.integrator},
        {"isa", st.isa},
        {"threads", st.threads},
        {"width", scene.settings.width},
        {"height", scene.settings.height},
        {"spp", scene.settings.spp},
        {"spp_reached", st.spp_reached},
        {"seed", scene.settings.seed},
        {"estimator", estimator_name(scene.settings.estimator.kind)},
        {"emitters",
         {{"sampled", scene.emitters.count()},
          {"sampled_objects", scene.emitters.sampled_objects},
          {"unsampled_objects", scene.emitters.unsampled_objects}}},
        {"seconds", st.seconds},
        {"paths", st.paths},
        {"rays",
         {{"camera", st.rays.camera},
          {"extension", st.rays.extension},
          {"shadow", st.rays.shadow},
          {"light", st.rays.light},
          {"total", st.rays.total()}}},
        {"rays_per_second", st.rays_per_second()},
        {"rays_per_second_per_thread", st.rays_per_second() / total_threads(st)},
        {"nonfinite_samples", st.nonfinite_samples},
        {"lane_utilisation",
         {{"shading", st.shade_lane_utilisation},
          {"intersection", st.isect_lane_utilisation},
          {"shadow", st.shadow_lane_utilisation}}},
        {"pool",
         {{"paths", st.pool_size},
          {"bytes", st.pool_bytes},
          {"light_store_bytes", st.light_store_bytes}}},
        {"ray_group", st.ray_group},
        {"scheduler",
         {{"units", st.units},
          {"seconds", st.scheduler_seconds},
          {"microseconds_per_unit", st.units ? st.scheduler_seconds * 1e6 / double(st.units) : 0.0},
          {"idle_seconds", st.idle_seconds}}},
        {"mean_relative_error", st.mean_relative_error ? nlohmann::json(*st.mean_relative_error)
                                                       : nlohmann::json(nullptr)},
        {"stopped_by", st.stopped_by},
        {"spp_resumed", st.spp_resumed},
        {"warnings", st.warnings},
    };
    const EstimatorSettings& est = scene.settings.estimator;
    if (connects(est.kind) && est.light_connections > 0) {
        // (the light vertex cache's MIS: its estimate of the light subpaths' stored vertices,
        // made once before the render and kept by the scene)
        const PathContext pc = scene.path_context();
        j["light_vertex_cache"] = {{"draws", est.light_connections},
                                   {"mean_light_vertices", light_pilot(scene)},
                                   {"connection_count", pc.connection_count}};
    }
    if (st.guiding) {
        // The path guide: its size now, what it learnt from, and each training's time
        const GuideStats& g = *st.guiding;
        double training = 0.0;
        for (double t : g.training_seconds) training += t;
        j["guiding"] = {{"method", guiding_name(est.guiding)},
                        {"guided_vertices", est.guided_vertices},
                        {"cells", g.cells},
                        {"nodes", g.nodes},
                        {"learning_nodes", g.learning_nodes},
                        {"bytes", g.bytes},
                        {"record_table_bytes", g.record_table_bytes},
                        {"records", g.records},
                        {"learning", g.learning},
                        {"guided_fractions", kGuideFractions},
                        {"cells_by_fraction", g.cells_by_fraction},
                        {"trainings", g.training_seconds.size()},
                        {"trained_at_spp", g.trained_at},
                        {"training_seconds", g.training_seconds},
                        {"training_seconds_total", training}};
    }
    if (!checkpoint.empty()) {
        std::error_code ec;
        const auto bytes = fs::file_size(checkpoint, ec);
        j["checkpoint"] = {{"file", checkpoint.string()},
                           {"writes", st.checkpoint_writes},
                           {"failed_writes", st.checkpoint_failures},
                           {"last_write_seconds", st.checkpoint_last_seconds},
                           {"write_seconds", st.checkpoint_seconds},
                           {"bytes", ec ? nlohmann::json(nullptr) : nlohmann::json(bytes)}};
    }
    // Under MPI: each rank's rays, time and rays/s, and the sum over ranks
    if (!st.ranks.empty()) {
        nlohmann::json ranks = nlohmann::json::array();
        uint64_t rays = 0;
        int threads = 0;
        for (const RankStats& r : st.ranks) {
            ranks.push_back({{"rank", r.rank},
                             {"host", r.host},
                             {"threads", r.threads},
                             {"units", r.units},
                             {"rays", r.rays},
                             {"bytes_sent", r.bytes_sent},
                             {"splat_bytes_sent", r.splat_bytes_sent},
                             {"seconds", r.seconds},
                             {"idle_seconds", r.idle_seconds},
                             {"rays_per_second", r.rays_per_second()}});
            rays += r.rays, threads += r.threads;
        }
        uint64_t sent = 0;
        for (const RankStats& r : st.ranks) sent += r.bytes_sent;
        const double units = double(std::max<uint64_t>(st.units_handed_out, 1));
        j["mpi"] = {{"ranks", st.ranks.size()},
                    {"units", st.units_handed_out},
                    {"requests", st.requests},
                    {"reports", st.reports},
                    {"rank0_cpu_seconds", st.rank0_cpu_seconds},
                    {"rank0_cpu_seconds_per_unit", st.rank0_cpu_seconds / units},
                    {"rank0_gather_cpu_seconds", st.rank0_gather_cpu_seconds},
                    {"rank0_deal_cpu_seconds", st.rank0_deal_cpu_seconds},
                    {"rank0_deal_cpu_seconds_per_request",
                     st.rank0_deal_cpu_seconds / double(std::max<uint64_t>(st.requests, 1))},
                    {"rank0_bytes_received", st.bytes_received},
                    {"bytes_sent", sent},
                    {"bytes_sent_per_unit", double(sent) / units},
                    {"threads", threads},
                    {"rays_traced", rays},
                    {"rays_traced_per_second", st.seconds > 0 ? double(rays) / st.seconds : 0.0},
                    {"per_rank", ranks}};
    }
    // The acceleration structure: what it holds, its size and how long it took to build
    const BvhStats& b = scene.bvh.stats();
    size_t instances = 0, mesh_bytes = 0;
    for (const Mesh& m : scene.meshes) {
        instances += m.instanced();
        if (m.bvh) mesh_bytes += m.bvh->stats().bytes;
    }
    j["bvh"] = {{"primitives", b.primitives},
                {"references", b.references},
                {"spatial_splits", scene.settings.spatial_splits},
                {"nodes", b.nodes},
                {"bytes", b.bytes},
                {"instances", instances},
                {"instanced_mesh_bytes", mesh_bytes},
                {"unbounded", scene.planes.size() + scene.unbounded_quadrics.size()},
                {"build_seconds", scene.bvh_seconds}};
    // Reading the scene: all of it, the images' decoding and the BVH's build within it
    size_t image_bytes = 0;
    for (const auto& image : scene.images) image_bytes += image->memory_bytes();
    j["load"] = {{"seconds", scene.load_seconds},
                 {"image_seconds", scene.image_seconds},
                 {"bvh_seconds", scene.bvh_seconds},
                 {"images", scene.images.size()},
                 {"image_bytes", image_bytes},
                 {"triangles", [&] {
                      size_t n = 0;
                      for (const Mesh& m : scene.meshes) n += scene.geometry_of(m).triangle_count();
                      return n;
                  }()}};
    return j;
}

void write_render_outputs(const RenderJob& a, const RenderJobResult& done) {
    const Scene& scene = done.scene;
    const RenderStats& st = done.result.stats;
    const fs::path& output = scene.settings.output;
    ImageLayers layers;
    if (a.variance && output.extension() == ".exr")
        layers = variance_layers(done.result.film.variance_of_mean());
    write_hdr(output, done.result.film.mean(), render_metadata(scene, st), layers);
    if (done.strategies && !a.strategies_dir.empty()) {
        const StrategyFilm& f = *done.strategies;
        for (int i = 0; i < f.layout().count(); ++i)
            for (bool weighted : {true, false}) {
                int s = 0, t = 0;
                f.layout().strategy(i, s, t);
                ImageMetadata m = render_metadata(scene, st);
                m["cierzo:strategy"] = fmt::format("s={} t={} length={}", s, t, s + t - 1);
                m["cierzo:weighted"] = weighted ? "MIS-weighted" : "unweighted";
                write_hdr(strategy_image_path(a.strategies_dir, f.layout(), i, weighted),
                          f.image(i, weighted, st.spp_reached), m);
            }
    }
    if (!a.stats.empty()) {
        const nlohmann::json j = render_stats_json(scene, st, done.checkpoint);
        write_output_stream(a.stats, [&](std::ostream& out) { out << j.dump(2) << "\n"; });
    }
}

}  // namespace cierzo
