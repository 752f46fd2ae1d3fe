// The `cierzo` program: renders a scene file to an HDR image (OpenEXR or PFM) and prints
// time and throughput. A thin main over the render library; every option is in --help.
#include <algorithm>
#include <atomic>
#include <csignal>
#include <cstdio>
#include <filesystem>

#include <CLI/CLI.hpp>
#include <fmt/format.h>

#include "apps/app_common.h"
#include "apps/converge_command.h"
#include "apps/render_job.h"
#include "apps/trace_command.h"
#include "core/error.h"
#include "integrators/distributed.h"
#include "integrators/registry.h"
#include "integrators/wavefront/isa.h"
#include "io/output_file.h"
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

// The command line of `cierzo render`: the scene file and the job (apps/render_job.h).
struct RenderArgs {
    fs::path scene;
    InputOptions inputs;
    bool quiet = false;
    RenderJob job;
};

int run_render(RenderArgs& args) {
    const bool root = mpi::world().rank == 0;
    RenderJob& a = args.job;
    // An instruction set this CPU lacks is refused before the scene is read
    check_render_isa(a);
    a.progress = !args.quiet;
    a.cancel = &g_interrupted;
    a.on_start = [] {
        std::signal(SIGINT, on_signal);
        std::signal(SIGTERM, on_signal);
    };
    LoadOptions load = args.inputs.load_options();
    load.output_named = !a.out.empty();
    Scene loaded = load_scene(args.scene, load);
    if (root)
        for (const std::string& w : loaded.warnings)
            std::fprintf(stderr, "cierzo: warning: %s\n", w.c_str());
    // A model names no estimator and no paths: say what it gets and how to ask for more
    if (root && is_model_file(args.scene) && (!a.estimator || !a.spp))
        std::fprintf(
            stderr, "%s\n",
            fmt::format("cierzo: {}: a model: {} at {} paths per pixel; --spp N for more "
                        "paths (the error falls as 1/sqrt(N)), --estimator NAME for "
                        "another",
                        args.scene.string(),
                        a.estimator ? *a.estimator
                                    : std::string(estimator_name(loaded.settings.estimator.kind)),
                        a.spp ? *a.spp : loaded.settings.spp)
                .c_str());
    const RenderJobResult done = run_render_job(std::move(loaded), a);
    if (!root) return 0;
    const Scene& scene = done.scene;
    const RenderSettings& s = scene.settings;
    const RenderStats& st = done.result.stats;
    for (const std::string& w : st.warnings)
        if (std::find(done.resume_warnings.begin(), done.resume_warnings.end(), w) ==
                done.resume_warnings.end() &&
            w.find("the previous checkpoint is kept") == std::string::npos)
            std::fprintf(stderr, "cierzo: warning: %s\n", w.c_str());

    // The image, its metadata, optionally the variance of each pixel's mean, the statistics
    write_render_outputs(a, done);

    // The summary line; an early stop says why and how far it got
    std::string summary = fmt::format(
        "{}: {}x{}, {} spp, {}, {} ({}), {} threads: {:.3f} s, {:.2f} Mrays/s ({:.2f} per "
        "thread), {}",
        s.output.string(), s.width, s.height, s.spp, estimator_name(s.estimator.kind),
        st.integrator, st.isa,
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
    if (st.checkpoint_final_failed) {
        std::fprintf(stderr,
                     "cierzo: %s: the render's last state could not be written (see "
                     "above); the image is written, the checkpoint is an earlier one or none\n",
                     done.checkpoint.string().c_str());
        return 1;
    }
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
    r->add_option(
         "scene", a.scene,
         "Scene file (JSON; see docs/scene-format.md), or an OBJ or PLY model to render "
         "with its own materials under a white sky, framed by a default camera, at 512x512 "
         "and 16 paths per pixel of mis, to STEM.exr in the current folder. A scene "
         "or model that names no estimator renders with mis; the scenes of scenes/ "
         "name theirs")
        ->required()
        ->check(CLI::ExistingFile);
    a.inputs.add_to(r);
    r->add_option("--spp", a.job.spp, "Paths per pixel (overrides render.spp)")
        ->check(CLI::Range(int64_t(1), int64_t(UINT32_MAX)));
    r->add_option("--threads", a.job.threads,
                  "Worker threads; 0 = every CPU this process may run on")
        ->check(CLI::Range(0, 4096))
        ->capture_default_str();
    r->add_option("--seed", a.job.seed, "Random seed (overrides render.seed)");
    r->add_option("--width", a.job.width, "Image width in pixels (overrides render.width)")
        ->check(CLI::Range(1, 1 << 16));
    r->add_option("--height", a.job.height, "Image height in pixels (overrides render.height)")
        ->check(CLI::Range(1, 1 << 16));
    r->add_option("--survival-cap", a.job.survival_cap,
                  "Largest total survival probability of the lobe roulette (and the largest q "
                  "of the throughput roulette), in (0, 1) "
                  "(overrides render.survival_cap; default 0.9)")
        ->check(CLI::Range(1e-6f, 0.999999f));
    r->add_option("--spatial-splits", a.job.spatial_splits,
                  "The BVH's spatial splits: triangles may be cut into up to this fraction of "
                  "extra references, 0 to 4 (overrides render.spatial_splits; default 0: none; "
                  "1 pays on long thin triangles such as grass, hair or wire; the BVH is built "
                  "again)");
    r->add_option("--diffuse-sampling", a.job.diffuse_sampling,
                  "Diffuse directions: uniform (the report's) or cosine (overrides "
                  "render.diffuse_sampling; default cosine for nee and mis, uniform for report "
                  "and lt)")
        ->check(CLI::IsMember({"uniform", "cosine"}));
    r->add_option("--triangle-sampling", a.job.triangle_sampling,
                  "How nee and mis sample emitting triangles: area (uniform on the triangle) or "
                  "solid-angle (uniform over the spherical triangle it subtends, where that is "
                  "at least 1e-3 sr; area below) (overrides render.triangle_sampling; default "
                  "solid-angle for nee and mis)")
        ->check(CLI::IsMember({"area", "solid-angle"}));
    r->add_option("--roulette", a.job.roulette,
                  describe_roulettes() + "; overrides render.roulette")
        ->check(CLI::IsMember(roulette_names()));
    r->add_option("--roulette-depth", a.job.roulette_depth,
                  "The vertex the throughput roulette starts at, the camera's first hit being 0 "
                  "(overrides render.roulette_depth; default 1)")
        ->check(CLI::Range(0, kMaxRouletteDepth));
    r->add_option(
         "--sampler", a.job.sampler,
         "Where the random numbers come from: " + describe_samplers() +
             "; every estimator (overrides render.sampler; docs/estimators.md, \"samplers\")")
        ->check(CLI::IsMember(sampler_names()));
    r->add_option(
         "--guiding", a.job.guiding,
         "Path guiding: " + describe_guidings() + " (overrides render.guiding; docs/guiding.md)")
        ->check(CLI::IsMember(guiding_names()));
    r->add_option("--guided-vertices", a.job.guided_vertices,
                  "A guided render's guide serves the first N Phong (diffuse or glossy) vertices "
                  "of each camera path: it draws part of their diffuse directions and learns "
                  "from their light alone; 0: every Phong vertex (overrides "
                  "render.guided_vertices; default 1)")
        ->check(CLI::Range(0, kMaxLengthLimit));
    r->add_option("--min-length", a.job.min_length,
                  "Count only light carried by paths of at least this many segments (the camera "
                  "seeing an emitter is 1, direct light 2, the first indirect bounce 3; "
                  "overrides render.min_length; default 1)")
        ->check(CLI::Range(1, kMaxLengthLimit));
    r->add_option("--max-length", a.job.max_length,
                  "Count only light carried by paths of at most this many segments, and end "
                  "paths there (a guided render's go on: its guide learns from the whole light, "
                  "so its bands add up to its image) (overrides render.max_length; default: no "
                  "limit)")
        ->check(CLI::Range(1, kMaxLengthLimit));
    r->add_option("--strategy", a.job.strategy,
                  "bdpt: count only the paths strategy S,T makes (S light vertices, T camera "
                  "vertices, the pinhole one of them; a path of S + T - 1 segments), with its "
                  "MIS weight: the strategies' images add up to the whole (docs/estimators.md)")
        ->delimiter(',')
        ->expected(2);
    r->add_option("--strategies", a.job.strategies_dir,
                  "bdpt: also write every strategy's image, MIS-weighted and unweighted, of "
                  "paths up to --max-length segments (default 5, at most 12) into folder DIR "
                  "(made if missing): lengthK_sS_tT.exr and lengthK_sS_tT_unweighted.exr. "
                  "One render, by the scalar integrator, in one process, without checkpoints "
                  "(docs/estimators.md, \"strategy images\")")
        ->type_name("DIR");
    r->add_option(
        "--merge-radius", a.job.merge_radius,
        "vcm, bpm, ppm: the first sample's merging radius r0, in scene units; sample n merges "
        "within r0 * (n + 1)^((alpha - 1) / 2) (overrides render.merge_radius; "
        "default: 0.05 of half the diagonal of the box around the scene's bounded "
        "objects and the camera)");
    r->add_option(
        "--merge-alpha", a.job.merge_alpha,
        "vcm, bpm, ppm: how fast the merging radius shrinks, alpha in (0, 1): the error's bias "
        "vanishes as the radius does (overrides render.merge_alpha; default 0.75)");
    r->add_option("--light-connections", a.job.light_connections,
                  "bdpt, vcm: what a Phong camera vertex connects to: 0, every stored vertex of "
                  "its own light subpath; N (1..64), N vertices drawn from the light vertex "
                  "cache, every stored vertex of the light subpaths of its sample in its tile "
                  "(overrides render.light_connections; default 1)")
        ->type_name("N");
    r->add_flag("--unweighted", a.job.unweighted,
                "With --strategy: without its MIS weight (each strategy alone is an unbiased "
                "image of the paths it can make)");
    r->add_option("--estimator", a.job.estimator,
                  describe_estimators() +
                      "; overrides render.estimator. Sampled emitters: "
                      "spheres and triangles of solid emission (two that make a rectangle as one). "
                      "nee and mis "
                      "default to cosine "
                      "diffuse sampling, the throughput roulette, triangles by solid angle and the "
                      "sobol sampler (chosen by measured efficiency; docs/estimators.md), bdpt, "
                      "vcm, bpm and ppm "
                      "to cosine diffuse sampling, triangles by solid angle and the sobol sampler "
                      "(with the lobe roulette), report and lt to the report's settings; an option "
                      "or scene key given keeps its value")
        ->check(CLI::IsMember(estimator_names()));
    r->add_option("--integrator", a.job.integrator, describe_integrators())
        ->check(CLI::IsMember(integrator_names()))
        ->capture_default_str();
    r->add_option("--isa", a.job.isa,
                  "Wavefront instruction set: auto (the best this CPU has), avx512, avx2, sse4.2 "
                  "(x86-64), neon (aarch64); valid on this CPU: " +
                      usable_isa_names())
        ->check(CLI::IsMember({"auto", "avx512", "avx2", "sse4.2", "neon"}))
        ->capture_default_str();
    r->add_option("--pool", a.job.pool,
                  "Wavefront paths in flight per thread, a multiple of 16; 0 = default (512)")
        ->check(CLI::Range(0, 1 << 22))
        ->capture_default_str();
    r->add_option("--ray-group", a.job.ray_group,
                  "Wavefront rays in flight per thread through the BVH, 1-64: above 1, each ray "
                  "takes a step in turn while the next node or leaf it reads is prefetched "
                  "(docs/acceleration.md; the same image whatever it is; 1, one ray at a time, "
                  "measured fastest)")
        ->check(CLI::Range(1, 64))
        ->capture_default_str();
    r->add_option("--out", a.job.out,
                  "Output image, .exr (float32) or .pfm (overrides render.output)");
    r->add_option("--stats", a.job.stats,
                  "Write run statistics as JSON: time, paths, rays by kind, rays/s, error "
                  "(- for standard output)");
    r->add_flag("--variance", a.job.variance,
                "Add the per-pixel variance of the mean as layers variance.R/G/B to the EXR");
    r->add_option("--time-budget", a.job.time_budget,
                  "Stop after this many seconds (at the end of a pass: every pixel then has the "
                  "same number of paths, recorded in the EXR and --stats)")
        ->check(CLI::NonNegativeNumber);
    r->add_option("--target-error", a.job.target_error,
                  "Stop once the mean relative standard error of the pixels is at most this "
                  "(checked after each pass from 16 paths per pixel on), e.g. 0.01")
        ->check(CLI::NonNegativeNumber);
    r->add_option("--checkpoint", a.job.checkpoint,
                  "Write the render's exact state to this .exr file every --checkpoint-every "
                  "seconds, when stopped and at the end (atomically: a failed write keeps the "
                  "previous one); continue it with --resume")
        ->check(CLI::NonexistentPath | CLI::ExistingFile);
    r->add_option("--checkpoint-every", a.job.checkpoint_every,
                  "Seconds between checkpoints (a crash loses at most this much work)")
        ->check(CLI::Range(0.01, 1e9))
        ->capture_default_str();
    r->add_option("--resume", a.job.resume,
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
        "threads and adds the passes of\nits own band of tiles; rank 0 hands out the work, "
        "gathers the film and writes the outputs; the image is\nbit-identical to a "
        "one-process render. See docs/distributed.md.\n\n" +
        std::string(kOutputPolicy));
    CLI::App* converge = add_converge_command(app);
    CLI::App* trace = add_trace_command(app);
    CLI::App* isas = app.add_subcommand(
        "isas",
        "List the wavefront's instruction sets: lanes, whether this CPU runs each (and "
        "which auto picks), and why not");
    CLI11_PARSE(app, argc, argv);
    const mpi::World& world = mpi::world();
    // Messages of a rank other than 0 say which rank they come from
    const std::string who =
        world.rank == 0 ? "cierzo" : fmt::format("cierzo (rank {} of {})", world.rank, world.size);
    try {
        if (world.size > 1 && !r->parsed())
            throw InputError(
                "only `cierzo render` runs across MPI ranks; run this command in "
                "one process");
        a.job.checkpoint_every_given = r->count("--checkpoint-every") > 0;
        a.job.integrator_given = r->count("--integrator") > 0;
        a.job.strategies = r->count("--strategies") > 0;
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
    // A write past `ulimit -f` fails with EFBIG, and a write into a closed pipe with EPIPE,
    // and each is reported naming the file, instead of killing cierzo
    std::signal(SIGXFSZ, SIG_IGN);
    std::signal(SIGPIPE, SIG_IGN);
    mpi::init(&argc, &argv);
    const int code = run_main(argc, argv);
    // A failure on any rank ends them all (the others would wait for it forever)
    if (mpi::world().size > 1 && code != 0 && code != 130) mpi::abort(code);
    mpi::finalize();
    return code;
}
