// `cierzo trace SCENE.json --rays FILE`: closest hits of every ray of a ray file through the
// scene, one thread, after one warm-up pass; prints rays/s and what was hit (hits, sum of
// hit distances) so another program tracing the same file can be checked against it.
#include "apps/trace_command.h"

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <optional>
#include <string>
#include <vector>

#include "apps/app_common.h"
#include "apps/render_job.h"
#include "core/error.h"
#include "integrators/light_pilot.h"
#include "integrators/registry.h"
#include "integrators/wavefront/wavefront.h"
#include "io/input_file.h"
#include "scene/scene_json.h"

namespace cierzo {

namespace {

namespace fs = std::filesystem;

struct TraceArgs {
    fs::path scene, rays;
    InputOptions inputs;
    std::string integrator = "wavefront";
    std::string isa = "auto";
    int repeat = 1;
    int stream_rays = 0;
    int single_below = TraceOptions{}.single_below;
    int ray_group = 1;
    std::optional<float> spatial_splits;
};
TraceArgs g_args;

// The ray file: magic "CZRAYS1\0", uint64 count, then count records of 7 float32 (origin,
// direction, tmax), little-endian.
std::vector<float> read_rays(const fs::path& path) {
    std::ifstream in;
    if (input_file_exists(path)) in.open(path, std::ios::binary);
    if (!in.is_open()) throw InputError(path.string() + ": cannot open the ray file");
    char magic[8];
    uint64_t count = 0;
    if (!in.read(magic, 8) || std::memcmp(magic, "CZRAYS1\0", 8) != 0)
        throw InputError(path.string() + ": not a ray file (it must start with CZRAYS1)");
    if (!in.read(reinterpret_cast<char*>(&count), 8))
        throw InputError(path.string() + ": truncated: no ray count after the magic");
    const uintmax_t size = fs::file_size(path);
    if (count > (size - 16) / 28 || size != 16 + 28 * count)
        throw InputError(path.string() + ": the header says " + std::to_string(count) + " rays (" +
                         std::to_string(16 + 28 * count) + " bytes) but the file has " +
                         std::to_string(size) + " bytes");
    std::vector<float> rays(size_t(count) * 7);
    in.read(reinterpret_cast<char*>(rays.data()), std::streamsize(rays.size() * sizeof(float)));
    for (size_t i = 0; i < rays.size(); ++i)
        if (!std::isfinite(rays[i]) && i % 7 != 6)
            throw InputError(path.string() + ": ray " + std::to_string(i / 7) +
                             " has a non-finite origin or direction");
    return rays;
}

// The rays as the wavefront's trace entry reads them (job.h, trace_stride): seven columns,
// the last ray repeated to fill them, 64-byte aligned (in `memory`, from `data`). Made
// before the clock starts, as a renderer's rays are already laid out when they are traced.
struct RayColumns {
    std::vector<float> memory;
    const float* data = nullptr;
};
RayColumns ray_columns(const std::vector<float>& rays) {
    const size_t count = rays.size() / 7, stride = trace_stride(count);
    RayColumns c;
    c.memory.resize(7 * stride + 16);
    float* out = c.memory.data();
    while (reinterpret_cast<uintptr_t>(out) % 64 != 0) ++out;
    c.data = out;
    for (size_t i = 0; i < stride; ++i)
        for (size_t k = 0; k < 7; ++k)
            out[k * stride + i] = count ? rays[7 * std::min(i, count - 1) + k] : 0.0f;
    return c;
}

}  // namespace

CLI::App* add_trace_command(CLI::App& app) {
    CLI::App* t = app.add_subcommand(
        "trace",
        "Trace the closest hit of every ray of a ray file through a scene, one thread, "
        "and print rays/s, hits and the sum of hit distances (the traversal alone)");
    t->add_option("scene", g_args.scene, "Scene file (JSON; see docs/scene-format.md)")
        ->required()
        ->check(CLI::ExistingFile);
    g_args.inputs.add_to(t);
    t->add_option("--rays", g_args.rays,
                  "Ray file: 'CZRAYS1\\0', uint64 count, count x 7 float32 (ox oy oz dx dy dz "
                  "tmax), little-endian; e.g. written by bench/peers' embree_pt --dump-rays")
        ->required()
        ->check(CLI::ExistingFile);
    t->add_option("--integrator", g_args.integrator,
                  "wavefront (its SIMD traversal, K rays set up at a time) or scalar (the "
                  "reference's, one ray at a time)")
        ->check(CLI::IsMember(integrator_names()))
        ->capture_default_str();
    t->add_option("--isa", g_args.isa,
                  "Wavefront instruction set; valid on this CPU: " + usable_isa_names())
        ->check(CLI::IsMember({"auto", "avx512", "avx2", "sse4.2", "neon"}))
        ->capture_default_str();
    t->add_option("--stream", g_args.stream_rays,
                  "Wavefront: trace the rays as ordered streams of this many rays (node by node; "
                  "kernels/bvh/traverse_stream.h) where the tree allows it (triangles and spheres, "
                  "no instances, no alpha masks), instead of K rays at a time each on its own; "
                  "0: no streams")
        ->check(CLI::Range(0, 65536))
        ->capture_default_str();
    t->add_option("--single-below", g_args.single_below,
                  "With --stream: a stream of fewer rays than this finishes its subtree one ray "
                  "at a time")
        ->check(CLI::Range(1, 65536))
        ->capture_default_str();
    t->add_option("--ray-group", g_args.ray_group,
                  "Wavefront: rays in flight through the BVH, 1-64 (as render's --ray-group)")
        ->check(CLI::Range(1, 64))
        ->capture_default_str();
    t->add_option("--spatial-splits", g_args.spatial_splits,
                  "The BVH's spatial splits, 0 to 4 (overrides render.spatial_splits; the BVH is "
                  "built again)");
    t->add_option("--repeat", g_args.repeat, "Timed passes over the rays (after one warm-up pass)")
        ->check(CLI::Range(1, 100000))
        ->capture_default_str();
    return t;
}

int run_trace_command() {
    const TraceArgs& a = g_args;
    const Isa isa = parse_isa(a.isa);
    const bool simd = integrator_of(a.integrator) == Integrator::kWavefront;
    if (simd) require_isa(isa, "--isa");
    if (!simd && a.stream_rays > 0)
        throw InputError(
            "--stream: the scalar integrator traces one ray at a time; streams are "
            "the wavefront's (--integrator wavefront)");
    const Scene scene = [&] {
        LoadOptions load = a.inputs.load_options();
        load.output_named = true;  // (trace writes no image)
        Scene s = load_scene(a.scene, load);
        apply_spatial_splits(s, a.spatial_splits);
        return s;
    }();
    const std::vector<float> rays = read_rays(a.rays);
    const size_t count = rays.size() / 7;
    std::unique_ptr<WavefrontRenderer> wavefront;
    if (simd) {
        prepare_path_context(scene);  // (the wavefront's flat scene holds the path context)
        wavefront =
            std::make_unique<WavefrontRenderer>(scene, isa, 0, true, kLightStoreLimit, a.ray_group);
    }
    const auto columns = ray_columns(rays);
    const auto pass = [&](TraceTotals& totals) {
        if (wavefront)
            return wavefront->trace(columns.data, count, {a.stream_rays, a.single_below}, totals);
        for (size_t i = 0; i < count; ++i) {
            const float* r = &rays[7 * i];
            Hit hit;
            ++totals.rays;
            if (scene.intersect({{r[0], r[1], r[2]}, {r[3], r[4], r[5]}}, r[6], hit))
                ++totals.hits, totals.sum_t += double(hit.t);
        }
    };
    TraceTotals warm, timed;
    pass(warm);
    const auto t0 = std::chrono::steady_clock::now();
    for (int k = 0; k < a.repeat; ++k) {
        TraceTotals t;
        pass(t);
        timed.rays += t.rays;
    }
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    std::printf(
        "integrator: %s\nisa: %s\nray_group: %d\nstream: %d\nstreamed_rays: %llu\nrays: "
        "%zu\nrepeat: %d\ntrace_seconds: %.6f\n"
        "rays_per_second: %.0f\nhits: %llu\nsum_t: %.9g\n",
        a.integrator.c_str(), wavefront ? isa_name(wavefront->isa()).c_str() : "none",
        wavefront ? wavefront->ray_group() : 1, a.stream_rays,
        static_cast<unsigned long long>(warm.streamed), count, a.repeat, seconds,
        double(timed.rays) / seconds, static_cast<unsigned long long>(warm.hits), warm.sum_t);
    return 0;
}

}  // namespace cierzo
