// Whole-render throughput: every scene, scalar reference against the wavefront on each ISA,
// one thread, in rays per second (per core: one thread). Also the pool-size sweep that chose
// the default pool, feature specialisation on and off, and 1 against 2 threads.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <filesystem>
#include <map>

#include "integrators/registry.h"
#include "integrators/render.h"
#include "integrators/wavefront/isa.h"
#include "scene/scene_json.h"

namespace cierzo {
namespace {

namespace fs = std::filesystem;

Scene bench_scene(const std::string& name) {
    Scene s = load_scene(fs::path(CIERZO_SOURCE_DIR) / "scenes" / (name + ".json"));
    s.set_resolution(128, 128);
    s.settings.spp = 8;
    return s;
}

void run(benchmark::State& state, const Scene& scene, RenderOptions o) {
    o.progress = false;
    double rays = 0, util = 0, isect = 0;
    int runs = 0;
    for (auto _ : state) {
        const RenderResult r = render(scene, o);
        rays += double(r.stats.rays.total());
        util += r.stats.shade_lane_utilisation;
        isect += r.stats.isect_lane_utilisation;
        ++runs;
    }
    state.counters["rays_per_s"] = benchmark::Counter(rays, benchmark::Counter::kIsRate);
    state.counters["rays_per_s_per_thread"] =
        benchmark::Counter(rays / std::max(o.threads, 1), benchmark::Counter::kIsRate);
    if (o.integrator == Integrator::kWavefront) {
        state.counters["shade_lane_util"] = util / runs;
        state.counters["isect_lane_util"] = isect / runs;
    }
}

// The scenes of the per-scene benchmarks, by name
std::map<std::string, Scene>& scene_cache() {
    static std::map<std::string, Scene> cache;
    return cache;
}

// Scene × integrator/ISA, 1 thread, for every scene of scenes/
void register_scenes() {
    const fs::path root = fs::path(CIERZO_SOURCE_DIR) / "scenes";
    std::vector<std::string> names;
    for (const auto& e : fs::directory_iterator(root))
        if (e.path().extension() == ".json") names.push_back(e.path().stem().string());
    std::sort(names.begin(), names.end());
    for (const std::string& name : names) {
        scene_cache().emplace(name, bench_scene(name));  // loaded once, here
        std::vector<std::pair<std::string, std::string>> variants = {{"scalar", "scalar"}};
        for (Isa isa : compiled_isas())
            if (isa_supported(isa)) variants.push_back({"wavefront", isa_name(isa)});
        for (const auto& [integrator, isa] : variants) {
            const std::string label = std::string("render/") + name + "/" +
                                      (integrator == "scalar" ? "scalar" : "wavefront_" + isa);
            benchmark::RegisterBenchmark(label.c_str(), [=](benchmark::State& st) {
                RenderOptions o;
                o.threads = 1;
                o.integrator = integrator_of(integrator);
                o.isa = integrator == "scalar" ? "auto" : isa;
                run(st, scene_cache().at(name), o);
            })->Unit(benchmark::kMillisecond);
        }
    }
}

// The pool size: paths in flight per thread (the default was chosen from this sweep)
void BM_PoolSize(benchmark::State& state) {
    static const Scene scene = bench_scene("cornell");
    RenderOptions o;
    o.threads = 1;
    o.pool_size = int(state.range(0));
    run(state, scene, o);
}
BENCHMARK(BM_PoolSize)->RangeMultiplier(2)->Range(64, 4096)->Unit(benchmark::kMillisecond);

// Feature specialisation: the same scenes with every stage and lobe kernel forced on
void BM_Specialisation(benchmark::State& state, const char* name, bool specialise) {
    static std::map<std::string, Scene> cache;
    if (!cache.count(name)) cache.emplace(name, bench_scene(name));
    RenderOptions o;
    o.threads = 1;
    o.specialise = specialise;
    run(state, cache.at(name), o);
}
BENCHMARK_CAPTURE(BM_Specialisation, cornell_specialised, "cornell", true)
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_Specialisation, cornell_general, "cornell", false)
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_Specialisation, diffuse_spheres_specialised, "diffuse_spheres", true)
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_Specialisation, diffuse_spheres_general, "diffuse_spheres", false)
    ->Unit(benchmark::kMillisecond);

// Threads: 1 against 2 on the default scene (rays_per_s is the whole machine's)
void BM_Threads(benchmark::State& state) {
    static Scene scene = [] {
        Scene s = bench_scene("cornell");
        s.set_resolution(256, 256);
        return s;
    }();
    RenderOptions o;
    o.threads = int(state.range(0));
    run(state, scene, o);
}
BENCHMARK(BM_Threads)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace
}  // namespace cierzo

int main(int argc, char** argv) {
    cierzo::register_scenes();
    benchmark::Initialize(&argc, argv);
    benchmark::RunSpecifiedBenchmarks();
    benchmark::Shutdown();
    return 0;
}
