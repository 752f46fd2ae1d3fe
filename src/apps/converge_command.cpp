// `cierzo converge SCENE`: renders (or reads) a reference image, then renders the scene at
// increasing paths per pixel for every combination of the knobs given, and records for each
// render its wall time and its error against the reference (RMSE and relative MSE, with the
// reference's own noise removed) in a CSV file that papers/scripts/plot_converge.py plots.
#include "apps/converge_command.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <optional>

#include <unistd.h>

#include <CLI/CLI.hpp>
#include <fmt/format.h>

#include "apps/app_common.h"
#include "core/error.h"
#include "integrators/convergence.h"
#include "integrators/wavefront/isa.h"
#include "io/output_file.h"
#include "io/image.h"
#include "integrators/registry.h"
#include "integrators/render.h"
#include "scene/scene_json.h"

namespace cierzo {

namespace fs = std::filesystem;

namespace {

ConvergeArgs g_args;

// Every combination of the knobs; those that do not apply to the scalar reference (ISA,
// pool) are not repeated for it.
std::vector<ConvergeConfig> configs_of(const ConvergeArgs& a) {
    const std::vector<float> caps =
        a.survival_caps.empty() ? std::vector<float>{-1.0f} : a.survival_caps;
    std::vector<int> diffuse;
    for (const std::string& d : a.diffuse_sampling) diffuse.push_back(d == "cosine");
    if (diffuse.empty()) diffuse.push_back(-1);
    std::vector<int> estimators;
    for (const std::string& e : a.estimators) estimators.push_back(int(*parse_estimator(e)));
    if (estimators.empty()) estimators.push_back(-1);
    std::vector<int> roulettes;
    for (const std::string& r : a.roulettes) roulettes.push_back(int(*parse_roulette(r)));
    if (roulettes.empty()) roulettes.push_back(-1);
    std::vector<int> triangles;
    for (const std::string& t : a.triangle_sampling) triangles.push_back(t == "solid-angle");
    if (triangles.empty()) triangles.push_back(-1);
    std::vector<int> samplers;
    for (const std::string& s : a.samplers) samplers.push_back(int(*parse_sampler(s)));
    if (samplers.empty()) samplers.push_back(-1);
    // (the merging radius and exponent: swept for vcm, bpm and ppm alone)
    const std::vector<float> radii =
        a.merge_radii.empty() ? std::vector<float>{-1.0f} : a.merge_radii;
    const std::vector<float> alphas =
        a.merge_alphas.empty() ? std::vector<float>{-1.0f} : a.merge_alphas;
    // (guiding for the estimators that take it alone)
    std::vector<int> guidings;
    for (const std::string& g : a.guidings) guidings.push_back(int(*parse_guiding(g)));
    if (guidings.empty()) guidings.push_back(-1);
    // (and the connections' draws for bdpt and vcm alone)
    const std::vector<int> draws =
        a.light_connections.empty() ? std::vector<int>{-1} : a.light_connections;
    std::vector<ConvergeConfig> out;
    for (const std::string& integrator : a.integrators) {
        const bool scalar = integrator_of(integrator) == Integrator::kScalar;
        const std::vector<std::string> isas = scalar ? std::vector<std::string>{"-"} : a.isas;
        const std::vector<int> pools = scalar ? std::vector<int>{0} : a.pools;
        for (const std::string& isa : isas)
            for (int pool : pools)
                for (float cap : caps)
                    for (int d : diffuse)
                        for (int e : estimators)
                            for (int r : roulettes)
                                for (int t : triangles)
                                    for (int smp : samplers) {
                                        const bool vcm = merges(Estimator(e));
                                        const bool connecting = connects(Estimator(e));
                                        // (the scene's estimator, e = -1, may take guiding:
                                        // the render refuses it if not)
                                        const bool guided =
                                            e < 0 || traits(Estimator(e)).samples_emitters;
                                        for (float radius : vcm ? radii : std::vector<float>{-1.0f})
                                            for (float alpha :
                                                 vcm ? alphas : std::vector<float>{-1.0f})
                                                for (int n :
                                                     connecting ? draws : std::vector<int>{-1})
                                                    for (int g :
                                                         guided ? guidings : std::vector<int>{-1})
                                                        out.push_back(
                                                            {.integrator = integrator,
                                                             .isa = scalar ? "auto" : isa,
                                                             .pool_size = pool,
                                                             .survival_cap = cap,
                                                             .cosine_diffuse = d,
                                                             .estimator = e,
                                                             .roulette = r,
                                                             .triangle_solid_angle = t,
                                                             .roulette_depth =
                                                                 a.roulette_depth.value_or(-1),
                                                             .sampler = smp,
                                                             .merge_radius = radius,
                                                             .merge_alpha = alpha,
                                                             .light_connections = n,
                                                             .guiding = g,
                                                             .guided_vertices =
                                                                 a.guided_vertices.value_or(-1)});
                                    }
    }
    return out;
}

}  // namespace

std::string converge_csv_header() {
    return "scene,integrator,isa,pool,survival_cap,diffuse_sampling,roulette,triangle_sampling,"
           "sampler,estimator,merge_radius,merge_alpha,light_connections,guiding,threads,width,"
           "height,spp,"
           "repeats,seconds,rays,rays_per_second,mse,rmse,rel_mse,reference_mse,"
           "reference_rel_mse,mse_corrected,rmse_corrected,rel_mse_corrected,"
           "estimated_relative_error,efficiency";
}

namespace {

const char* diffuse_name(const EstimatorSettings& e) {
    return e.cosine_diffuse ? "cosine" : "uniform";
}

// "none", or "sdtree1" (the guide serving the first Phong vertex; "sdtree0": every one)
std::string guiding_label(const EstimatorSettings& e) {
    return e.guiding == Guiding::kNone
               ? std::string(guiding_name(e.guiding))
               : fmt::format("{}{}", guiding_name(e.guiding), e.guided_vertices);
}

// "lobe", or "throughput3" (the throughput roulette from vertex 3)
std::string roulette_label(const EstimatorSettings& e) {
    return e.roulette == Roulette::kLobe
               ? std::string(roulette_name(e.roulette))
               : fmt::format("{}{}", roulette_name(e.roulette), e.roulette_depth);
}

std::string csv_row(const Scene& scene, const ConvergePoint& p) {
    const ImageError& e = p.error;
    // Efficiency: 1 / (error × time), the figure of merit of Monte Carlo estimators
    const double efficiency = e.rel_mse_corrected() > 0 && p.seconds > 0
                                  ? 1.0 / (e.rel_mse_corrected() * p.seconds)
                                  : 0.0;
    return fmt::format(
        "{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{:.6g},{},{:.6g},{:.6g},{:.6g},{:"
        "."
        "6g},{:.6g},"
        "{:.6g},{:.6g},{:.6g},{:.6g},{:.6g},{:.6g}",
        scene.source.stem().string(), p.config.integrator, p.stats.isa, p.stats.pool_size,
        p.estimator.survival_cap, diffuse_name(p.estimator), roulette_label(p.estimator),
        triangle_sampling_name(p.estimator), sampler_name(p.estimator.sampler),
        estimator_name(p.estimator.kind),
        // (the merging radius as rendered, the scene's rule resolved; empty for the others)
        merges(p.estimator.kind) ? fmt::format("{:.6g}", p.merge_radius) : std::string(),
        merges(p.estimator.kind) ? fmt::format("{:.6g}", p.estimator.merge_alpha) : std::string(),
        // (the connections' draws as rendered, bdpt's and vcm's; empty for the others)
        connects(p.estimator.kind) ? std::to_string(p.estimator.light_connections) : std::string(),
        guiding_label(p.estimator), p.stats.threads, scene.settings.width, scene.settings.height,
        p.spp, p.repeats, p.seconds, p.rays, p.seconds > 0 ? double(p.rays) / p.seconds : 0.0,
        e.mse, std::sqrt(e.mse), e.rel_mse, e.reference_mse, e.reference_rel_mse, e.mse_corrected(),
        std::sqrt(e.mse_corrected()), e.rel_mse_corrected(), p.estimated_relative_error,
        efficiency);
}

}  // namespace

CLI::App* add_converge_command(CLI::App& app) {
    ConvergeArgs& a = g_args;
    CLI::App* c = app.add_subcommand(
        "converge",
        "Measure error against time: render a scene at increasing paths per pixel for each "
        "combination of the knobs given, against a reference");
    c->add_option("scene", a.scene,
                  "Scene file (JSON; see docs/scene-format.md), or an OBJ or PLY model")
        ->required()
        ->check(CLI::ExistingFile);
    a.inputs.add_to(c);
    CLI::Option* reference =
        c->add_option("--reference", a.reference,
                      "Reference image (.exr or .pfm) of the scene at the same resolution, e.g. "
                      "an analytic answer or an earlier --save-reference; if it is an EXR with "
                      "variance.R/G/B layers (render --variance), its noise is removed from the "
                      "errors. Default: render one")
            ->check(CLI::ExistingFile);
    CLI::Option* reference_spp =
        c->add_option("--reference-spp", a.reference_spp,
                      "Paths per pixel of the rendered reference (its seed is the scene's; the "
                      "sweep uses others)")
            ->check(CLI::Range(int64_t(1), int64_t(UINT32_MAX)))
            ->capture_default_str();
    CLI::Option* reference_integrator =
        c->add_option("--reference-integrator", a.reference_integrator,
                      "Integrator of the rendered reference: " + describe_integrators())
            ->check(CLI::IsMember(integrator_names()))
            ->capture_default_str();
    CLI::Option* save_reference =
        c->add_option("--save-reference", a.save_reference,
                      "Write the rendered reference here (.exr, with its variance layers) for "
                      "reuse");
    // (the options of a rendered reference mean nothing beside a given one)
    reference->excludes(reference_spp)->excludes(reference_integrator)->excludes(save_reference);
    c->add_option("--spp", a.spp, "Paths per pixel to sweep, comma-separated")
        ->delimiter(',')
        ->check(CLI::Range(int64_t(1), int64_t(UINT32_MAX)))
        ->capture_default_str();
    c->add_option("--integrator", a.integrators,
                  "Integrators to sweep, comma-separated: " + describe_integrators())
        ->delimiter(',')
        ->check(CLI::IsMember(integrator_names()))
        ->capture_default_str();
    c->add_option("--isa", a.isas,
                  "Wavefront instruction sets to sweep: auto, avx512, avx2, sse4.2 (x86-64), "
                  "neon (aarch64); valid on this CPU: " +
                      usable_isa_names())
        ->delimiter(',')
        ->check(CLI::IsMember({"auto", "avx512", "avx2", "sse4.2", "neon"}))
        ->capture_default_str();
    c->add_option("--pool", a.pools,
                  "Wavefront pool sizes to sweep (multiples of 16; 0 = the default 512)")
        ->delimiter(',')
        ->check(CLI::Range(0, 1 << 22))
        ->capture_default_str();
    c->add_option("--survival-cap", a.survival_caps,
                  "Roulette survival caps to sweep, each in (0, 1); default: the scene's")
        ->delimiter(',')
        ->check(CLI::Range(1e-6f, 0.999999f));
    c->add_option("--diffuse-sampling", a.diffuse_sampling,
                  "Diffuse sampling to sweep: uniform, cosine; default: the scene's")
        ->delimiter(',')
        ->check(CLI::IsMember({"uniform", "cosine"}));
    c->add_option("--triangle-sampling", a.triangle_sampling,
                  "Triangle sampling of nee and mis to sweep: area, solid-angle; default: the "
                  "scene's")
        ->delimiter(',')
        ->check(CLI::IsMember({"area", "solid-angle"}));
    c->add_option(
         "--sampler", a.samplers,
         "Samplers to sweep, comma-separated: " + describe_samplers() + "; default: the scene's")
        ->delimiter(',')
        ->check(CLI::IsMember(sampler_names()));
    const auto positive = CLI::Validator(
        [](std::string& v) {
            const double x = std::strtod(v.c_str(), nullptr);
            return x > 0.0 && std::isfinite(x) ? std::string() : "must be a positive length";
        },
        "POSITIVE");
    const auto open_unit = CLI::Validator(
        [](std::string& v) {
            const double x = std::strtod(v.c_str(), nullptr);
            return x > 0.0 && x < 1.0 ? std::string() : "must be in (0, 1), exclusive";
        },
        "(0, 1)");
    c->add_option(
         "--merge-radius", a.merge_radii,
         "The first merging radii r0 of vcm, bpm and ppm to sweep (scene units, each > 0; render's "
         "--merge-radius); default: the scene's")
        ->delimiter(',')
        ->check(positive);
    c->add_option(
         "--merge-alpha", a.merge_alphas,
         "The merging radius exponents alpha of vcm, bpm and ppm to sweep, each in (0, 1); "
         "default: the scene's")
        ->delimiter(',')
        ->check(open_unit);
    c->add_option("--light-connections", a.light_connections,
                  "The light vertex cache's draws of bdpt and vcm to sweep, each in 0..64 (0: "
                  "every vertex of the sample's own light subpath; render's --light-connections); "
                  "default: the scene's")
        ->delimiter(',')
        ->check(CLI::Range(0, int(kMaxLightConnections)));
    c->add_option("--guiding", a.guidings,
                  "Path guiding to sweep for nee and mis, comma-separated: " + describe_guidings() +
                      "; default: the scene's")
        ->delimiter(',')
        ->check(CLI::IsMember(guiding_names()));
    c->add_option("--guided-vertices", a.guided_vertices,
                  "The Phong vertices a guide serves from the camera (0: every one; render's "
                  "--guided-vertices); the CSV's guiding column appends it (sdtree1); default: "
                  "the scene's")
        ->check(CLI::Range(0, kMaxLengthLimit));
    c->add_option(
         "--roulette", a.roulettes,
         "Roulettes to sweep, comma-separated: " + describe_roulettes() + "; default: the scene's")
        ->delimiter(',')
        ->check(CLI::IsMember(roulette_names()));
    c->add_option("--roulette-depth", a.roulette_depth,
                  "The vertex the throughput roulette starts at (the camera's first hit: 0); "
                  "default: the scene's")
        ->check(CLI::Range(0, kMaxRouletteDepth));
    c->add_option("--estimator", a.estimators,
                  "Estimators to sweep, comma-separated: " + describe_estimators() +
                      "; default: the scene's")
        ->delimiter(',')
        ->check(CLI::IsMember(estimator_names()));
    c->add_option("--reference-estimator", a.reference_estimator,
                  "Estimator of the rendered reference (every one is unbiased; mis converges "
                  "fastest where emitters can be sampled); default: the scene's")
        ->check(CLI::IsMember(estimator_names()));
    c->add_option("--width", a.width, "Image width (overrides render.width)")
        ->check(CLI::Range(1, 1 << 16));
    c->add_option("--height", a.height, "Image height (overrides render.height)")
        ->check(CLI::Range(1, 1 << 16));
    c->add_option("--threads", a.threads, "Worker threads; 0 = every CPU this process may run on")
        ->check(CLI::Range(0, 4096))
        ->capture_default_str();
    c->add_option("--repeats", a.repeats,
                  "Renders per point with different seeds: the time is their median, the "
                  "error their mean")
        ->check(CLI::Range(1, 1000))
        ->capture_default_str();
    c->add_option("--out", a.out,
                  "Write the measurements as CSV (one row per render point; rewritten after "
                  "each point, so a sweep that stops early keeps what it measured; - for "
                  "standard output, where the rows then go as they are measured and the table "
                  "goes to standard error)");
    c->add_flag("--quiet", a.quiet, "Print only the summary");
    c->footer(
        "Errors are averaged over pixels and channels: RMSE, and relative MSE (x-r)^2/(r^2+0.01).\n"
        "A rendered reference's own variance is subtracted (the *_corrected columns), so the\n"
        "error is that against the true image; efficiency = 1 / (rel_mse_corrected x "
        "seconds).\n\n" +
        std::string(kOutputPolicy));
    return c;
}

int run_converge_command() {
    LoadOptions load = g_args.inputs.load_options();
    load.output_named = true;  // (converge writes no image where the scene says)
    run_converge_job(load_scene(g_args.scene, load), g_args);
    return 0;
}

std::vector<std::string> run_converge_job(Scene scene, const ConvergeArgs& a) {
    if (a.width || a.height)
        scene.set_resolution(a.width.value_or(scene.settings.width),
                             a.height.value_or(scene.settings.height));
    for (int64_t spp : a.spp) {
        scene.settings.spp = spp;
        check_render_size(scene, scene.source);
    }
    for (int pool : a.pools)
        if (pool % 16 != 0)
            throw InputError(fmt::format("--pool: {} is not a multiple of 16", pool));
    for (const std::string& isa : a.isas) require_isa(parse_isa(isa), "--isa");
    if (!a.light_connections.empty() &&
        std::none_of(a.estimators.begin(), a.estimators.end(), [](const std::string& e) {
            const std::optional<Estimator> kind = parse_estimator(e);
            return kind && connects(*kind);
        }))
        throw InputError(
            "--light-connections: connections are bdpt's and vcm's; sweep them with "
            "--estimator bdpt (or vcm)");
    if (!a.merge_radii.empty() || !a.merge_alphas.empty()) {
        // (the radii are swept for the configurations of --estimator vcm, bpm or ppm alone: a
        // scene's own vcm without --estimator would ignore them)
        if (std::none_of(a.estimators.begin(), a.estimators.end(), [](const std::string& e) {
                const std::optional<Estimator> kind = parse_estimator(e);
                return kind && merges(*kind);
            }))
            throw InputError(
                std::string(a.merge_radii.empty() ? "--merge-alpha" : "--merge-radius") +
                ": merging is vcm's, bpm's and ppm's; sweep it with --estimator vcm "
                "(or bpm, ppm)");
    }
    if (!a.save_reference.empty() && a.save_reference.extension() != ".exr")
        throw InputError(a.save_reference.string() + ": --save-reference must end in .exr");
    std::vector<InputPath> inputs = scene_inputs(scene);
    inputs.push_back({a.reference, "--reference"});
    check_outputs({{a.out, "--out", "the measurements"},
                   {a.save_reference, "--save-reference", "the reference"}},
                  inputs);
    // The CSV to a stream (standard output, a FIFO, a device) goes row by row, as measured;
    // when it goes to standard output, the table goes to standard error
    std::optional<StreamOutput> csv_stream;
    bool csv_on_stdout = false;
    if (!a.out.empty()) {
        const OutputTarget target = resolve_output(a.out, "the measurements");
        if (target.kind == OutputTarget::Kind::kStream) csv_stream.emplace(a.out, target);
        csv_on_stdout = target.descriptor == STDOUT_FILENO;
    }
    FILE* const table = csv_on_stdout ? stderr : stdout;
    if (csv_stream) csv_stream->write(converge_csv_header() + "\n");

    // The reference: read, or rendered with the scene's own seed
    Image reference, variance;
    bool have_variance = false;
    if (!a.reference.empty()) {
        ImageLayers layers;
        if (a.reference.extension() == ".exr") {
            reference = read_exr(a.reference, nullptr, &layers);
            if (layers.count("variance.R")) {
                variance =
                    variance_from_layers(layers, reference.width, reference.height, a.reference);
                have_variance = true;
            }
        } else {
            reference = read_hdr(a.reference);
        }
        if (reference.width != scene.settings.width || reference.height != scene.settings.height)
            throw InputError(fmt::format("{}: the reference is {}x{} but the scene renders {}x{}",
                                         a.reference.string(), reference.width, reference.height,
                                         scene.settings.width, scene.settings.height));
    } else {
        Scene s = scene;
        s.settings.spp = a.reference_spp;
        if (a.reference_estimator)
            use_estimator(s.settings.estimator, *parse_estimator(*a.reference_estimator));
        // (the scene's throughput roulette, where the reference's estimator cannot take it,
        // gives way to the lobe roulette: either is unbiased)
        EstimatorSettings& e = s.settings.estimator;
        if (!traits(e.kind).samples_emitters) e.roulette = Roulette::kLobe;
        check_render_size(s, scene.source);
        RenderOptions options;
        options.threads = a.threads;
        options.integrator = integrator_of(a.reference_integrator, "--reference-integrator");
        options.progress = !a.quiet;
        options.cancel = a.cancel;
        const RenderResult r = render(s, options);
        if (r.stats.stopped_by == "interrupted") return {};
        reference = r.film.mean();
        variance = r.film.variance_of_mean();
        have_variance = true;
        if (a.summary)
            std::fprintf(stderr, "reference: %lld paths per pixel, %s, %.2f s\n",
                         static_cast<long long>(a.reference_spp), r.stats.isa.c_str(),
                         r.stats.seconds);
        if (!a.save_reference.empty())
            write_hdr(a.save_reference, reference,
                      {{"cierzo:scene", scene.source.string()},
                       {"cierzo:spp", std::to_string(a.reference_spp)},
                       {"cierzo:seed", std::to_string(scene.settings.seed)},
                       {"cierzo:estimator", estimator_name(s.settings.estimator.kind)}},
                      variance_layers(variance));
    }

    ConvergeSweep sweep;
    sweep.configs = configs_of(a);
    sweep.spp = a.spp;
    sweep.repeats = a.repeats;
    sweep.threads = a.threads;
    sweep.cancel = a.cancel;
    // The CSV is rewritten after every point, so a sweep that stops early keeps its points
    std::vector<std::string> rows;
    const auto write_csv = [&] {
        if (a.out.empty()) return;
        if (csv_stream) {
            csv_stream->write(rows.back() + "\n");
            return;
        }
        write_output_stream(a.out, [&](std::ostream& out) {
            out << converge_csv_header() << "\n";
            for (const std::string& r : rows) out << r << "\n";
        });
    };
    if (!a.quiet)
        std::fprintf(table,
                     "%-9s %-7s %5s %5s %-7s %-11s %-11s %-6s %-6s %7s %10s %12s %12s %12s\n",
                     "integr.", "isa", "pool", "cap", "diffuse", "roulette", "sampler", "est.",
                     "guide", "spp", "seconds", "Mrays/s", "RMSE", "relMSE");
    const std::vector<ConvergePoint> points = run_converge(
        scene, reference, have_variance ? &variance : nullptr, sweep, [&](const ConvergePoint& p) {
            rows.push_back(csv_row(scene, p));
            write_csv();
            if (a.quiet) return;
            std::fprintf(table,
                         "%-9s %-7s %5d %5.2f %-7s %-11s %-11s %-6s %-6s %7lld %10.4f %12.2f "
                         "%12.4g %12.4g\n",
                         p.config.integrator.c_str(), p.stats.isa.c_str(), p.stats.pool_size,
                         p.estimator.survival_cap, diffuse_name(p.estimator),
                         roulette_label(p.estimator).c_str(), sampler_name(p.estimator.sampler),
                         estimator_name(p.estimator.kind), guiding_label(p.estimator).c_str(),
                         static_cast<long long>(p.spp), p.seconds,
                         p.seconds > 0 ? double(p.rays) / p.seconds * 1e-6 : 0.0,
                         std::sqrt(p.error.mse_corrected()), p.error.rel_mse_corrected());
            std::fflush(table);
        });

    // Per config: the slope of the error against paths per pixel (-1 for MSE when unbiased)
    // and the time per path per pixel, from the largest point
    const size_t n = a.spp.size();
    for (size_t first = 0; a.summary && first + n <= points.size(); first += n) {
        std::vector<double> x, y;
        for (size_t i = first; i < first + n; ++i) {
            x.push_back(double(points[i].spp));
            y.push_back(points[i].error.mse_corrected());
        }
        const ConvergePoint* last = &points[first + n - 1];
        std::fprintf(stderr,
                     "%s %s pool %d cap %.2f %s %s %s %s guiding %s: MSE ~ spp^%.2f, %.3g s per "
                     "path per pixel\n",
                     last->config.integrator.c_str(), last->stats.isa.c_str(),
                     last->stats.pool_size, last->estimator.survival_cap,
                     diffuse_name(last->estimator), roulette_label(last->estimator).c_str(),
                     sampler_name(last->estimator.sampler), estimator_name(last->estimator.kind),
                     guiding_label(last->estimator).c_str(), log_log_slope(x, y),
                     last->seconds / double(last->spp));
    }
    if (csv_stream) csv_stream->close();
    return rows;
}

}  // namespace cierzo
