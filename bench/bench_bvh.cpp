// BVH benchmarks: the binned-SAH build, and closest-hit / any-hit traversal of random
// incoherent rays on a procedurally displaced sphere of about 100k triangles, one ray at a
// time: the binary tree's scalar traversal against the 8-wide collapse's SIMD traversal.
#include <benchmark/benchmark.h>

#include <cmath>
#include <random>
#include <vector>

#include "integrators/wavefront/intersect_stage.h"
#include "accel/bvh.h"
#include "support/uv_sphere.h"

namespace {

using cierzo::Bvh;
using cierzo::Ray;
using cierzo::TriangleHit;
using cierzo::Vec3f;

struct Mesh {
    std::vector<Vec3f> positions;
    std::vector<uint32_t> indices;
};

// A latitude/longitude sphere with a bumpy radial displacement: 2 * segments * (rings - 1)
// triangles (rings = 226, segments = 224 gives 100,800).
Mesh displaced_sphere(int rings, int segments) {
    cierzo::test::TriangleMesh m = cierzo::test::uv_sphere(rings, segments, [](float t, float p) {
        return 1.0f + 0.08f * std::sin(9.0f * t) * std::sin(7.0f * p) +
               0.02f * std::sin(41.0f * t + 3.0f * p);
    });
    return {std::move(m.positions), std::move(m.indices)};
}

const Mesh& bench_mesh() {
    static const Mesh mesh = displaced_sphere(226, 224);
    return mesh;
}

const Bvh& bench_bvh() {
    static const Bvh bvh = [] {
        Bvh b;
        b.build(bench_mesh().positions, bench_mesh().indices);
        return b;
    }();
    return bvh;
}

// Incoherent rays: origins uniform in a cube around the mesh (inside and outside it),
// directions uniform on the sphere.
std::vector<Ray<float>> random_rays(size_t count) {
    std::mt19937 rng(1);
    std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
    std::normal_distribution<float> normal;
    std::vector<Ray<float>> rays(count);
    for (Ray<float>& ray : rays) {
        ray.o = Vec3f(unit(rng), unit(rng), unit(rng)) * 1.6f;
        ray.d = cierzo::normalize(Vec3f(normal(rng), normal(rng), normal(rng)));
    }
    return rays;
}

void BM_BvhBuild(benchmark::State& state) {
    const Mesh& mesh = bench_mesh();
    for (auto _ : state) {
        Bvh bvh;
        bvh.build(mesh.positions, mesh.indices);
        benchmark::DoNotOptimize(bvh.stats().nodes);
    }
    Bvh bvh;
    bvh.build(mesh.positions, mesh.indices);
    state.counters["triangles"] = double(bvh.stats().primitives);
    state.counters["nodes"] = double(bvh.stats().nodes);
    state.counters["depth"] = double(bvh.stats().depth);
    state.counters["bytes_per_triangle"] =
        double(bvh.stats().bytes) / double(bvh.stats().primitives);
}
BENCHMARK(BM_BvhBuild)->Unit(benchmark::kMillisecond);

void BM_BvhClosestHit(benchmark::State& state) {
    const Bvh& bvh = bench_bvh();
    const std::vector<Ray<float>> rays = random_rays(1 << 16);
    size_t traced = 0, hits = 0;
    for (auto _ : state) {
        for (const Ray<float>& ray : rays) {
            TriangleHit hit;
            hits += bvh.intersect(ray, 1e30f, hit);
        }
        traced += rays.size();
    }
    benchmark::DoNotOptimize(hits);
    state.counters["rays"] = benchmark::Counter(double(traced), benchmark::Counter::kIsRate);
    state.counters["hit_fraction"] = double(hits) / double(traced);
}
BENCHMARK(BM_BvhClosestHit)->Unit(benchmark::kMillisecond);

void BM_BvhOccluded(benchmark::State& state) {
    const Bvh& bvh = bench_bvh();
    const std::vector<Ray<float>> rays = random_rays(1 << 16);
    size_t traced = 0, hits = 0;
    for (auto _ : state) {
        for (const Ray<float>& ray : rays) {
            hits += bvh.occluded(ray, 1e30f);
        }
        traced += rays.size();
    }
    benchmark::DoNotOptimize(hits);
    state.counters["rays"] = benchmark::Counter(double(traced), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_BvhOccluded)->Unit(benchmark::kMillisecond);

// The same rays through the 8-wide BVH with the wavefront's traversal (traverse_wide in
// intersect_stage.h), set up K at a time as the wavefront does, on the SIMD lanes this
// program is built for (the label; SSE2 without -m flags: children and triangles 4 + 4).
template <bool kAnyHit>
void BM_WideBvh(benchmark::State& state) {
    using A = xsimd::default_arch;
    using F = cierzo::Wave<A>::F;
    constexpr size_t K = size_t(cierzo::Wave<A>::K);
    const Bvh& bvh = bench_bvh();
    // The rays in SoA, as the wavefront's path pool holds them
    const std::vector<Ray<float>> rays = random_rays(1 << 16);
    std::vector<float> soa[6];
    for (const Ray<float>& ray : rays)
        for (int k = 0; k < 3; ++k) soa[k].push_back(ray.o[k]), soa[k + 3].push_back(ray.d[k]);
    size_t traced = 0, hits = 0;
    for (auto _ : state) {
        for (size_t i = 0; i < rays.size(); i += K) {
            const auto at = [&](int k) { return F::load_unaligned(soa[k].data() + i); };
            const cierzo::WideRays<A> wide(Ray<F>{{at(0), at(1), at(2)}, {at(3), at(4), at(5)}});
            for (int l = 0; l < int(K); ++l) {
                float t = 1e30f;
                cierzo::BvhHit hit;
                hits += cierzo::traverse<kAnyHit, cierzo::NodeLanes<A>>(bvh.view(), wide.lane(l), t,
                                                                        hit);
            }
        }
        traced += rays.size();
    }
    benchmark::DoNotOptimize(hits);
    state.SetLabel(A::name());
    state.counters["rays"] = benchmark::Counter(double(traced), benchmark::Counter::kIsRate);
    state.counters["hit_fraction"] = double(hits) / double(traced);
    state.counters["wide_nodes"] = double(bvh.stats().nodes);
}
BENCHMARK(BM_WideBvh<false>)->Name("BM_WideBvhClosestHit")->Unit(benchmark::kMillisecond);
BENCHMARK(BM_WideBvh<true>)->Name("BM_WideBvhOccluded")->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
