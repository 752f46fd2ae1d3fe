// Per-kernel throughput, scalar (T = float) against SIMD (T = xsimd::batch<float>, the ISA
// this file is built for: it is built once per ISA): intersection per primitive kind, each
// lobe's sampling, the roulette, and the random numbers, in lanes (rays) per second; and the
// wavefront stages that have no kernel of their own (camera rays, material sort, compaction)
// on a path pool, in paths (rays) per second.
#include <benchmark/benchmark.h>

#include <cstdlib>
#include <cstring>
#include <random>
#include <vector>

#include "kernels/estimator.h"
#include "kernels/intersect.h"
#include "kernels/rng.h"
#include "integrators/wavefront/compact_stage.h"
#include "integrators/wavefront/material_stage.h"

namespace cierzo {
namespace {

constexpr size_t kN = 4096;  // rays per iteration, SoA, L1-resident

struct Rays {
    std::vector<float> ox, oy, oz, dx, dy, dz, u1, u2, u3;
    Rays() {
        std::mt19937 rng(1);
        std::uniform_real_distribution<float> u(-1.0f, 1.0f), v(0.0f, 1.0f);
        for (auto* a : {&ox, &oy, &oz, &dx, &dy, &dz, &u1, &u2, &u3}) a->resize(kN);
        for (size_t i = 0; i < kN; ++i) {
            ox[i] = u(rng), oy[i] = u(rng), oz[i] = u(rng) - 4.0f;
            const Vec3f d = normalize(Vec3f{u(rng) * 0.3f, u(rng) * 0.3f, 1.0f});
            dx[i] = d.x, dy[i] = d.y, dz[i] = d.z;
            u1[i] = v(rng), u2[i] = v(rng), u3[i] = v(rng);
        }
    }
};
const Rays& rays() {
    static const Rays r;
    return r;
}

template <class T>
T load(const std::vector<float>& a, size_t i) {
    if constexpr (std::is_same_v<T, float>) {
        return a[i];
    } else {
        return T::load_unaligned(a.data() + i);
    }
}
template <class T>
Ray<T> ray_at(size_t i) {
    const Rays& r = rays();
    return {{load<T>(r.ox, i), load<T>(r.oy, i), load<T>(r.oz, i)},
            {load<T>(r.dx, i), load<T>(r.dy, i), load<T>(r.dz, i)}};
}

// Runs f(i) over all rays K lanes at a time and reports lanes per second.
template <class T, class Fn>
void lanes(benchmark::State& state, Fn f) {
    constexpr size_t K = size_t(kWidth<T>);
    for (auto _ : state)
        for (size_t i = 0; i < kN; i += K) f(i);
    state.counters["rays_per_s"] =
        benchmark::Counter(double(state.iterations()) * kN, benchmark::Counter::kIsRate);
}

template <class T>
void BM_Plane(benchmark::State& state) {
    lanes<T>(state, [](size_t i) {
        T t(0.0f);  // (a miss leaves it unwritten)
        benchmark::DoNotOptimize(intersect_plane(ray_at<T>(i), Vec3<T>(T(0.0f), T(0.0f), T(-1.0f)),
                                                 T(1.0f), T(kRayFar), t));
        benchmark::DoNotOptimize(t);
    });
}
template <class T>
void BM_Sphere(benchmark::State& state) {
    lanes<T>(state, [](size_t i) {
        T t(0.0f);  // (a miss leaves it unwritten)
        benchmark::DoNotOptimize(
            intersect_sphere(ray_at<T>(i), Vec3<T>(T(0.0f)), T(0.7f), T(kRayFar), t));
        benchmark::DoNotOptimize(t);
    });
}
template <class T>
void BM_Quadric(benchmark::State& state) {
    const QuadricCoefficients<T> q{T(1.0f), T(0.0f), T(1.0f), T(0.0f), T(0.0f),
                                   T(0.0f), T(0.0f), T(0.0f), T(0.0f), T(-0.25f)};
    lanes<T>(state, [&](size_t i) {
        T t(0.0f);  // (a miss leaves it unwritten)
        benchmark::DoNotOptimize(
            intersect_quadric(ray_at<T>(i), q, Vec3<T>(T(-1.0f)), Vec3<T>(T(1.0f)), T(kRayFar), t));
        benchmark::DoNotOptimize(t);
    });
}

template <class T>
Bsdf<T> bsdf() {
    return {Vec3<T>(T(0.3f)), Vec3<T>(T(0.2f)), Vec3<T>(T(0.2f)),
            Vec3<T>(T(0.2f)), T(20.0f),         T(1.5f)};
}

template <class T, int kLobe>
void BM_Lobe(benchmark::State& state) {
    const Bsdf<T> m = bsdf<T>();
    const Vec3<T> n(T(0.0f), T(0.0f), T(-1.0f));
    const Rays& r = rays();
    lanes<T>(state, [&](size_t i) {
        const Vec3<T> d = ray_at<T>(i).d;
        const T u1 = load<T>(r.u1, i), u2 = load<T>(r.u2, i), p(0.25f);
        Scatter<T> s;
        if constexpr (kLobe == kLobeDiffuse) s = sample_diffuse(m, n, u1, u2, p, false);
        if constexpr (kLobe == kLobeSpecular) s = sample_specular(m, d, n, u1, u2, p);
        if constexpr (kLobe == kLobeMirror) s = sample_mirror(m, d, n, p);
        if constexpr (kLobe == kLobeRefract) s = sample_refraction(m, d, n, n, T(1.0f), p);
        benchmark::DoNotOptimize(s);
    });
}

template <class T>
void BM_Roulette(benchmark::State& state) {
    const Bsdf<T> m = bsdf<T>();
    const Rays& r = rays();
    lanes<T>(state, [&](size_t i) {
        T p;
        benchmark::DoNotOptimize(choose_lobe(m, load<T>(r.u3, i), 0.9f, p));
        benchmark::DoNotOptimize(p);
    });
}

template <class T>
void BM_Random(benchmark::State& state) {
    using U = U32<T>;
    lanes<T>(state, [&](size_t i) {
        const U key = path_key(1u, U(uint32_t(i)), U(7u));
        benchmark::DoNotOptimize(uniform<T>(key, U(3u), Purpose::kDirection1));
    });
}

// ---- Wavefront stages --------------------------------------------------------------------------
// A pool of the default 512 paths as the renderer carves it (path_pool.cpp), zeroed.
constexpr int32_t kPool = 512;

struct StagePool {
    void* memory = nullptr;
    PathPool pool;

    StagePool() {
        const int32_t lights = 0, materials = 16;
        const size_t bytes = (path_pool_bytes(kPool, lights, materials) + 63) / 64 * 64;
        memory = std::aligned_alloc(64, bytes);
        std::memset(memory, 0, bytes);
        pool = carve_path_pool(memory, kPool, lights, materials);
    }
    StagePool(const StagePool&) = delete;
    StagePool& operator=(const StagePool&) = delete;
    ~StagePool() { std::free(memory); }
};

// The scene as the stages see it: cornell.json's camera, 128 x 128, `materials` materials.
FlatScene stage_scene(int32_t materials) {
    FlatScene s{};
    const float origin[3] = {0, 0, -3.5f}, forward[3] = {0, 0, 3}, left[3] = {-1, 0, 0},
                up[3] = {0, 1, 0};
    for (int k = 0; k < 3; ++k) {
        s.cam_origin[k] = origin[k], s.cam_forward[k] = forward[k];
        s.cam_left[k] = left[k], s.cam_up[k] = up[k];
    }
    s.width = s.height = 128;
    s.seed = 1;
    s.material_count = materials;
    // Every material textures kd, so the sort orders every hit
    static const std::vector<int32_t> textured(64, 1 << kColKd);
    s.textured = textured.data();
    return s;
}

void report_paths(benchmark::State& state, double paths) {
    state.counters["rays_per_s"] = benchmark::Counter(paths, benchmark::Counter::kIsRate);
}

// Regeneration: the whole pool refilled with camera paths of a 16 x 16 tile at 8 samples.
void BM_CameraRays(benchmark::State& state) {
    using A = xsimd::default_arch;
    StagePool mem;
    const FlatScene scene = stage_scene(1);
    WavefrontCounters counters;
    Wave<A> w{scene, mem.pool, counters};
    TileCursor start;
    start.job = {32, 48, 48, 64, 0, 8, false, nullptr, nullptr, nullptr};
    start.tile_width = 16, start.tile_pixels = 256, start.total = 256 * 8;
    double paths = 0;
    for (auto _ : state) {
        TileCursor c = start;
        w.live = 0;
        generate_camera_paths<true>(w, c);
        paths += w.live;
    }
    benchmark::DoNotOptimize(mem.pool.dx[kPool - 1]);
    report_paths(state, paths);
}

// The material sort of a full pool of hits on `range(0)` materials, in random order.
void BM_SortByMaterial(benchmark::State& state) {
    using A = xsimd::default_arch;
    const int32_t materials = int32_t(state.range(0));
    StagePool mem;
    const FlatScene scene = stage_scene(materials);
    WavefrontCounters counters;
    Wave<A> w{scene, mem.pool, counters};
    std::mt19937 rng(2);
    std::uniform_int_distribution<int32_t> pick(0, materials - 1);
    for (int32_t i = 0; i < kPool; ++i) mem.pool.material[i] = pick(rng), mem.pool.alive[i] = 1;
    std::vector<int32_t> starts(size_t(materials) + 1);
    w.live = kPool;
    double paths = 0;
    for (auto _ : state) {
        sort_by_material(w, starts.data());
        paths += w.live;
    }
    benchmark::DoNotOptimize(mem.pool.order[kPool - 1]);
    report_paths(state, paths);
}

// Compaction of a full pool where a fifth of the paths ended (about what the roulette ends
// per bounce in diffuse scenes), at random: the same pattern every time (alive[] is not
// moved), the finished paths handed to a film that only counts them.
void BM_Compaction(benchmark::State& state) {
    using A = xsimd::default_arch;
    StagePool mem;
    const FlatScene scene = stage_scene(1);
    WavefrontCounters counters;
    Wave<A> w{scene, mem.pool, counters};
    std::mt19937 rng(3);
    std::bernoulli_distribution survives(0.8);
    for (int32_t i = 0; i < kPool; ++i) mem.pool.alive[i] = survives(rng) ? 1 : 0;
    int64_t finished = 0;
    const TileJob job{0,
                      0,
                      16,
                      16,
                      0,
                      1,
                      false,
                      &finished,
                      [](void* film, int32_t count, const uint32_t*, const float*, const float*,
                         const float*) { *static_cast<int64_t*>(film) += count; },
                      nullptr};
    double paths = 0;
    for (auto _ : state) {
        w.live = kPool;
        compact_paths(w, job);
        paths += kPool;
    }
    benchmark::DoNotOptimize(finished);
    report_paths(state, paths);
}

BENCHMARK(BM_CameraRays)->Name("BM_StageCameraRays/" CIERZO_BENCH_ISA);
BENCHMARK(BM_SortByMaterial)->Name("BM_StageSortByMaterial/" CIERZO_BENCH_ISA)->Arg(4)->Arg(16);
BENCHMARK(BM_Compaction)->Name("BM_StageCompaction/" CIERZO_BENCH_ISA);

using B = xsimd::batch<float>;
#define CIERZO_BENCH_BOTH(fn)                  \
    BENCHMARK(fn<float>)->Name(#fn "/scalar"); \
    BENCHMARK(fn<B>)->Name(#fn "/" CIERZO_BENCH_ISA)
CIERZO_BENCH_BOTH(BM_Plane);
CIERZO_BENCH_BOTH(BM_Sphere);
CIERZO_BENCH_BOTH(BM_Quadric);
CIERZO_BENCH_BOTH(BM_Roulette);
CIERZO_BENCH_BOTH(BM_Random);
BENCHMARK(BM_Lobe<float, kLobeDiffuse>)->Name("BM_LobeDiffuse/scalar");
BENCHMARK(BM_Lobe<B, kLobeDiffuse>)->Name("BM_LobeDiffuse/" CIERZO_BENCH_ISA);
BENCHMARK(BM_Lobe<float, kLobeSpecular>)->Name("BM_LobeSpecular/scalar");
BENCHMARK(BM_Lobe<B, kLobeSpecular>)->Name("BM_LobeSpecular/" CIERZO_BENCH_ISA);
BENCHMARK(BM_Lobe<float, kLobeMirror>)->Name("BM_LobeMirror/scalar");
BENCHMARK(BM_Lobe<B, kLobeMirror>)->Name("BM_LobeMirror/" CIERZO_BENCH_ISA);
BENCHMARK(BM_Lobe<float, kLobeRefract>)->Name("BM_LobeRefract/scalar");
BENCHMARK(BM_Lobe<B, kLobeRefract>)->Name("BM_LobeRefract/" CIERZO_BENCH_ISA);

}  // namespace
}  // namespace cierzo

BENCHMARK_MAIN();
