// The `cierzo` program: renders a scene file to an HDR image (OpenEXR or PFM) and prints
// time and throughput. A thin main over the render library; every option is in --help.
#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <algorithm>
#include <filesystem>
#include <thread>

#include <CLI/CLI.hpp>
#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "apps/app_common.h"
#include "apps/converge_command.h"
#include "apps/trace_command.h"
#include "core/error.h"
#include "integrators/checkpoint.h"
#include "integrators/distributed.h"
#include "integrators/render.h"
#include "integrators/wavefront/isa.h"
#include "integrators/wavefront/wavefront.h"
#include "io/atomic_file.h"
#include "io/image.h"
#include "scene/scene_json.h"

namespace {

namespace fs = std::filesystem;
using namespace cierzo;

// Set by SIGINT or SIGTERM: the render stops at once with the passes it finished and writes them.
// A second signal ends the program at once (the handler restores the default).
std::atomic<bool> g_interrupted{false};
extern "C" void on_signal(int sig) {
    g_interrupted.store(true);
    std::signal(sig, SIG_DFL);
}

struct RenderArgs {
    fs::path scene;
    std::optional<int64_t> spp;
    std::optional<uint32_t> seed;
    std::optional<int> width, height;
    std::optional<float> survival_cap;
    std::optional<std::string> diffuse_sampling;
    std::optional<std::string> estimator;
    int threads = 0;
    std::string integrator = "wavefront";
    std::string isa = "auto";
    int pool = 0;
    fs::path out;
    fs::path stats;
    bool variance = false;
    bool quiet = false;
    double time_budget = 0.0;
    double target_error = 0.0;
    fs::path checkpoint;
    double checkpoint_every = 300.0;
    bool checkpoint_every_given = false;
    fs::path resume;
};

// Threads of the whole run: this process's, or under MPI every rank's.
int total_threads(const RenderStats& st) {
    if (st.ranks.empty()) return st.threads;
    int n = 0;
    for (const RankStats& r : st.ranks) n += r.threads;
    return n;
}

void write_stats(const fs::path& path, const Scene& scene, const RenderStats& st,
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
        {"emitters", {{"sampled", scene.emitters.count()},
                      {"sampled_objects", scene.emitters.sampled_objects},
                      {"unsampled_objects", scene.emitters.unsampled_objects}}},
        {"seconds", st.seconds},
        {"paths", st.paths},
        {"rays", {{"camera", st.rays.camera}, {"extension", st.rays.extension},
                  {"shadow", st.rays.shadow}, {"total", st.rays.total()}}},
        {"rays_per_second", st.rays_per_second()},
        {"rays_per_second_per_thread", st.rays_per_second() / total_threads(st)},
        {"nonfinite_samples", st.nonfinite_samples},
        {"lane_utilisation", {{"shading", st.shade_lane_utilisation},
                              {"intersection", st.isect_lane_utilisation},
                              {"shadow", st.shadow_lane_utilisation}}},
        {"pool", {{"paths", st.pool_size}, {"bytes", st.pool_bytes}}},
        {"mean_relative_error", st.mean_relative_error ? nlohmann::json(*st.mean_relative_error)
                                                       : nlohmann::json(nullptr)},
        {"stopped_by", st.stopped_by},
        {"spp_resumed", st.spp_resumed},
        {"warnings", st.warnings},
    };
    if (!checkpoint.empty()) {
        std::error_code ec;
        const auto bytes = fs::file_size(checkpoint, ec);
        j["checkpoint"] = {{"file", checkpoint.string()},
                           {"writes", st.checkpoint_writes},
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
            ranks.push_back({{"rank", r.rank}, {"host", r.host}, {"threads", r.threads},
                             {"units", r.units}, {"rays", r.rays}, {"seconds", r.seconds},
                             {"rays_per_second", r.rays_per_second()}});
            rays += r.rays, threads += r.threads;
        }
        j["mpi"] = {{"ranks", st.ranks.size()},
                    {"service_seconds", st.service_seconds},
                    {"units_received", st.units_received},
                    {"bytes_received", st.bytes_received},
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
    j["bvh"] = {{"primitives", b.primitives}, {"nodes", b.nodes}, {"bytes", b.bytes},
                {"instances", instances}, {"instanced_mesh_bytes", mesh_bytes},
                {"unbounded", scene.planes.size() + scene.unbounded_quadrics.size()},
                {"build_seconds", scene.bvh_seconds}};
    write_stream_atomically(path, [&](std::ostream& out) { out << j.dump(2) << "\n"; });
}

// Whether `spp` ends a pass of an uninterrupted render (pass_bounds from zero).
bool on_pass_schedule(int64_t spp) {
    for (int64_t b : pass_bounds(0, spp)) if (b == spp) return true;
    return false;
}

int run_render(const RenderArgs& a) {
    const mpi::World& world = mpi::world();
    const bool root = world.rank == 0;
    // An instruction set this CPU lacks is refused before the scene is read
    if (a.integrator == "wavefront") require_isa(parse_isa(a.isa), "--isa");
    Scene scene = load_scene(a.scene);
    // Command-line values override the scene file
    RenderSettings& s = scene.settings;
    if (a.spp) s.spp = *a.spp;
    if (a.seed) s.seed = *a.seed;
    if (a.width || a.height)
        scene.set_resolution(a.width.value_or(s.width), a.height.value_or(s.height));
    if (a.survival_cap) s.estimator.survival_cap = *a.survival_cap;
    if (a.diffuse_sampling) s.estimator.cosine_diffuse = *a.diffuse_sampling == "cosine";
    if (a.estimator) s.estimator.kind = *parse_estimator(*a.estimator);
    if (!a.out.empty()) s.output = a.out;
    check_render_size(scene, a.scene);
    const std::string ext = s.output.extension().string();
    if (ext != ".exr" && ext != ".pfm")
        throw InputError(s.output.string() + ": output must end in .exr or .pfm");
    if (root) {
        check_writable_folder(s.output, "the image");
        if (!a.stats.empty()) check_writable_folder(a.stats, "the statistics");
    }

    RenderOptions options;
    options.threads = a.threads;
    options.integrator = a.integrator;
    options.isa = a.isa;
    options.pool_size = a.pool;
    options.time_budget = a.time_budget;
    options.target_error = a.target_error;
    options.cancel = &g_interrupted;
    std::signal(SIGINT, on_signal);
    std::signal(SIGTERM, on_signal);
    options.progress = !a.quiet && root;

    // Checkpoints: what the pixels depend on, the state to continue from, where to write
    const int pool = a.integrator == "wavefront"
                         ? (a.pool > 0 ? a.pool : WavefrontRenderer::kDefaultPoolSize)
                         : 0;
    const Isa chosen = parse_isa(a.isa) == Isa::kAuto ? best_isa() : parse_isa(a.isa);
    const std::string isa = a.integrator == "wavefront" ? isa_name(chosen) : "scalar";
    const fs::path checkpoint = !a.checkpoint.empty() ? a.checkpoint : a.resume;
    // (the fingerprint reads every mesh: only rank 0, and only with checkpoints)
    const CheckpointIdentity identity = root && !checkpoint.empty()
                                            ? checkpoint_identity(scene, a.integrator, isa, pool)
                                            : CheckpointIdentity{};
    std::optional<Checkpoint> resumed;
    std::vector<std::string> resume_warnings;
    if (root && !a.resume.empty()) {
        resumed = read_checkpoint(a.resume);
        resume_warnings = check_resume(a.resume, *resumed, identity);
        const int64_t done = resumed->state.spp_done;
        if (done > s.spp)
            throw InputError(fmt::format("{}: the checkpoint already has {} paths per pixel, "
                                         "more than the {} asked for", a.resume.string(), done, s.spp));
        if (!on_pass_schedule(done) && done < s.spp)
            resume_warnings.push_back(fmt::format(
                "{}: the checkpoint is a finished render of {} paths per pixel; continued to {}, "
                "the image is right but not bit-identical to an uninterrupted render of {}",
                a.resume.string(), done, s.spp, s.spp));
        for (const std::string& w : resume_warnings) std::fprintf(stderr, "cierzo: warning: %s\n", w.c_str());
        options.resume = &resumed->state;
    }
    if (a.checkpoint_every_given && checkpoint.empty())
        throw InputError("--checkpoint-every needs --checkpoint FILE.exr (or --resume FILE.exr)");
    if (root && !checkpoint.empty()) {
        if (checkpoint.extension() != ".exr")
            throw InputError(checkpoint.string() + ": a checkpoint must end in .exr");
        if (fs::weakly_canonical(checkpoint) == fs::weakly_canonical(s.output))
            throw InputError(checkpoint.string() + ": the checkpoint and the image (--out) must "
                             "be different files");
        check_writable_folder(checkpoint, "the checkpoint");
        options.checkpoint_every = a.checkpoint_every;
        options.checkpoint = [&](const RenderState& state) {
            write_checkpoint(checkpoint, identity, state);
        };
    }
    RenderResult result = render(scene, options);
    if (!root) return 0;
    RenderStats& st = result.stats;
    st.warnings.insert(st.warnings.begin(), resume_warnings.begin(), resume_warnings.end());
    for (const std::string& w : st.warnings)
        if (std::find(resume_warnings.begin(), resume_warnings.end(), w) == resume_warnings.end() &&
            w.find("the previous checkpoint is kept") == std::string::npos)
            std::fprintf(stderr, "cierzo: warning: %s\n", w.c_str());

    // The image, its metadata, and optionally the variance of each pixel's mean
    ImageMetadata meta = {{"cierzo:scene", scene.source.string()},
                          {"cierzo:integrator", st.integrator},
                          {"cierzo:isa", st.isa},
                          {"cierzo:spp", std::to_string(s.spp)},
                          {"cierzo:spp_reached", std::to_string(st.spp_reached)},
                          {"cierzo:stopped_by", st.stopped_by.empty() ? "done" : st.stopped_by},
                          {"cierzo:seed", std::to_string(s.seed)},
                          {"cierzo:estimator", estimator_name(s.estimator.kind)}};
    ImageLayers layers;
    if (a.variance && ext == ".exr") layers = variance_layers(result.film.variance_of_mean());
    write_hdr(s.output, result.film.mean(), meta, layers);
    if (!a.stats.empty()) write_stats(a.stats, scene, st, checkpoint);

    // The summary line; an early stop says why and how far it got
    std::string summary = fmt::format(
        "{}: {}x{}, {} spp, {} ({}), {} threads: {:.3f} s, {:.2f} Mrays/s ({:.2f} per thread), "
        "{}",
        s.output.string(), s.width, s.height, s.spp, st.integrator, st.isa,
        st.ranks.empty() ? std::to_string(st.threads)
                         : fmt::format("{} ranks, {}", st.ranks.size(), total_threads(st)),
        st.seconds, st.rays_per_second() * 1e-6, st.rays_per_second() * 1e-6 / total_threads(st),
        st.mean_relative_error
            ? fmt::format("relative error {:.4f}", *st.mean_relative_error)
            : std::string("relative error not available (one path per pixel gives no variance)"));
    if (st.nonfinite_samples)
        summary += fmt::format(", {} non-finite samples excluded", st.nonfinite_samples);
    if (!st.stopped_by.empty())
        summary += fmt::format("; stopped ({}) at {} of {} paths per pixel", st.stopped_by,
                               st.spp_reached, s.spp);
    std::fprintf(stderr, "%s\n", summary.c_str());
    return st.stopped_by == "interrupted" ? 130 : 0;
}

// `cierzo isas`: the instruction sets of this build, one per line, tab-separated: name,
// lanes, whether this CPU runs it ("yes", "yes, auto" for the one auto picks, or "no") and
// why not.
int run_isas() {
    const Isa best = best_isa();
    for (Isa isa : compiled_isas()) {
        const bool ok = isa_supported(isa);
        std::printf("%s\t%d lanes\t%s\t%s\n", isa_name(isa).c_str(), isa_width(isa),
                    ok ? (isa == best ? "yes, auto" : "yes") : "no",
                    isa_unsupported_reason(isa).c_str());
    }
    return 0;
}

int run_main(int argc, char** argv) {
    CLI::App app{"cierzo: a data-oriented SIMD research path tracer"};
    app.require_subcommand(1);
    RenderArgs a;
    CLI::App* r = app.add_subcommand("render", "Render a scene file to an HDR image");
    r->add_option("scene", a.scene, "Scene file (JSON; see docs/scene-format.md)")
        ->required()
        ->check(CLI::ExistingFile);
    r->add_option("--spp", a.spp, "Paths per pixel (overrides render.spp)")
        ->check(CLI::Range(int64_t(1), int64_t(UINT32_MAX)));
    r->add_option("--threads", a.threads, "Worker threads; 0 = every CPU this process may run on")
        ->check(CLI::Range(0, 4096))
        ->capture_default_str();
    r->add_option("--seed", a.seed, "Random seed (overrides render.seed)");
    r->add_option("--width", a.width, "Image width in pixels (overrides render.width)")
        ->check(CLI::Range(1, 1 << 16));
    r->add_option("--height", a.height, "Image height in pixels (overrides render.height)")
        ->check(CLI::Range(1, 1 << 16));
    r->add_option("--survival-cap", a.survival_cap,
                  "Largest total survival probability of the lobe roulette, in (0, 1) "
                  "(overrides render.survival_cap; default 0.9)")
        ->check(CLI::Range(1e-6f, 0.999999f));
    r->add_option("--diffuse-sampling", a.diffuse_sampling,
                  "Diffuse directions: uniform (the report's) or cosine (overrides "
                  "render.diffuse_sampling)")
        ->check(CLI::IsMember({"uniform", "cosine"}));
    r->add_option("--estimator", a.estimator,
                  "report (the report's: emitters found by chance), nee (plus one emitter "
                  "sample per Phong vertex) or mis (both, power-heuristic weights); overrides "
                  "render.estimator, default report. Sampled emitters: spheres and triangles "
                  "of solid emission")
        ->check(CLI::IsMember({"report", "nee", "mis"}));
    r->add_option("--integrator", a.integrator,
                  "wavefront (SoA batches, SIMD kernels) or scalar (the reference: one path at "
                  "a time)")
        ->check(CLI::IsMember({"wavefront", "scalar"}))
        ->capture_default_str();
    r->add_option("--isa", a.isa,
                  "Wavefront instruction set: auto (the best this CPU has), avx512, avx2, sse4.2 "
                  "(x86-64), neon (aarch64); valid on this CPU: " + usable_isa_names())
        ->check(CLI::IsMember({"auto", "avx512", "avx2", "sse4.2", "neon"}))
        ->capture_default_str();
    r->add_option("--pool", a.pool,
                  "Wavefront paths in flight per thread, a multiple of 16; 0 = default (512)")
        ->check(CLI::Range(0, 1 << 22))
        ->capture_default_str();
    r->add_option("--out", a.out, "Output image, .exr (float32) or .pfm (overrides render.output)");
    r->add_option("--stats", a.stats,
                  "Write run statistics as JSON: time, paths, rays by kind, rays/s, error");
    r->add_flag("--variance", a.variance,
                "Add the per-pixel variance of the mean as layers variance.R/G/B to the EXR");
    r->add_option("--time-budget", a.time_budget,
                  "Stop after this many seconds (at the end of a pass: every pixel then has the "
                  "same number of paths, recorded in the EXR and --stats)")
        ->check(CLI::NonNegativeNumber);
    r->add_option("--target-error", a.target_error,
                  "Stop once the mean relative standard error of the pixels is at most this "
                  "(checked after each pass from 16 paths per pixel on), e.g. 0.01")
        ->check(CLI::NonNegativeNumber);
    r->add_option("--checkpoint", a.checkpoint,
                  "Write the render's exact state to this .exr file every --checkpoint-every "
                  "seconds, when stopped and at the end (atomically: a failed write keeps the "
                  "previous one); continue it with --resume")
        ->check(CLI::NonexistentPath | CLI::ExistingFile);
    r->add_option("--checkpoint-every", a.checkpoint_every,
                  "Seconds between checkpoints (a crash loses at most this much work)")
        ->check(CLI::Range(0.01, 1e9))
        ->capture_default_str();
    r->add_option("--resume", a.resume,
                  "Continue the render in this checkpoint to --spp paths per pixel (the same "
                  "image, bit for bit, as an uninterrupted render); refused for another scene, "
                  "resolution, seed, estimator or integrator. Checkpoints then go on into the "
                  "same file unless --checkpoint names another")
        ->check(CLI::ExistingFile);
    r->add_flag("--quiet", a.quiet, "No progress line");
    r->footer(
        "Ctrl-C (SIGINT) or SIGTERM stops the render at once (after its first pass at the "
        "earliest), writes the image of the\npasses finished (with the paths per pixel reached "
        "in its metadata; a checkpoint also keeps the tiles done of the\npass in progress) and "
        "exits with status 130; a second one ends it at once.\n\n"
        "Under MPI (mpirun -np N cierzo render ..., or srun) every rank renders with its "
        "threads, rank 0 hands out the\nwork and writes the outputs; the image is "
        "bit-identical to a one-process render. See docs/distributed.md.");
    CLI::App* converge = add_converge_command(app);
    CLI::App* trace = add_trace_command(app);
    CLI::App* isas = app.add_subcommand(
        "isas", "List the wavefront's instruction sets: lanes, whether this CPU runs each (and "
                "which auto picks), and why not");
    CLI11_PARSE(app, argc, argv);
    const mpi::World& world = mpi::world();
    // Messages of a rank other than 0 say which rank they come from
    const std::string who =
        world.rank == 0 ? "cierzo" : fmt::format("cierzo (rank {} of {})", world.rank, world.size);
    try {
        if (world.size > 1 && !r->parsed())
            throw InputError("only `cierzo render` runs across MPI ranks; run this command in "
                             "one process");
        a.checkpoint_every_given = r->count("--checkpoint-every") > 0;
        if (r->parsed()) return run_render(a);
        if (converge->parsed()) return run_converge_command();
        if (trace->parsed()) return run_trace_command();
        if (isas->parsed()) return run_isas();
    } catch (const InputError& e) {
        std::fprintf(stderr, "%s: %s\n", who.c_str(), e.what());
        return 1;
    } catch (const std::exception& e) {
        std::fprintf(stderr, "%s: internal error: %s\n", who.c_str(), e.what());
        return 2;
    }
    return 0;
}

}  // namespace

int main(int argc, char** argv) {
    // A write past `ulimit -f` fails with EFBIG (and is reported) instead of killing cierzo
    std::signal(SIGXFSZ, SIG_IGN);
    mpi::init(&argc, &argv);
    const int code = run_main(argc, argv);
    // A failure on any rank ends them all (the others would wait for it forever)
    if (mpi::world().size > 1 && code != 0 && code != 130) mpi::abort(code);
    mpi::finalize();
    return code;
}
