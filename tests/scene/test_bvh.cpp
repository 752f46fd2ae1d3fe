// Tests of the triangle BVH (src/scene/bvh.h): closest hits against brute force on a random
// soup, a sphere mesh and an axis-aligned grid, any-hit against closest-hit, degenerate
// triangles, closed-mesh watertightness through the tree, and build edge cases; and the
// 8-wide collapse with the wavefront's single-ray traversal against the binary tree.
#include "accel/bvh.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <random>
#include <vector>

#include "core/error.h"
#include "integrators/wavefront/intersect_stage.h"
#include "kernels/triangle.h"
#include "support/uv_sphere.h"

namespace cierzo {
namespace {

struct Mesh {
    std::vector<Vec3f> positions;
    std::vector<uint32_t> indices;

    size_t size() const { return indices.size() / 3; }
    Vec3f vertex(size_t triangle, int k) const { return positions[indices[3 * triangle + k]]; }
};

// Random triangles of random sizes in [-10, 10]^3.
Mesh random_soup(size_t count, uint32_t seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> unit(-1.0f, 1.0f), size(0.05f, 2.0f);
    Mesh mesh;
    for (size_t i = 0; i < count; ++i) {
        const Vec3f centre = Vec3f(unit(rng), unit(rng), unit(rng)) * 10.0f;
        const float s = size(rng);
        for (int k = 0; k < 3; ++k) {
            mesh.indices.push_back(uint32_t(mesh.positions.size()));
            mesh.positions.push_back(centre + Vec3f(unit(rng), unit(rng), unit(rng)) * s);
        }
    }
    return mesh;
}

// A latitude/longitude sphere of radius 1 with shared vertices (poles fanned).
Mesh uv_sphere(int rings, int segments) {
    test::TriangleMesh m = test::uv_sphere(rings, segments);
    return {std::move(m.positions), std::move(m.indices)};
}

// An n x n grid of unit squares in the plane z = 0, two triangles each.
Mesh grid(int n) {
    Mesh mesh;
    for (int j = 0; j <= n; ++j) {
        for (int i = 0; i <= n; ++i) {
            mesh.positions.push_back({float(i), float(j), 0.0f});
        }
    }
    for (int j = 0; j < n; ++j) {
        for (int i = 0; i < n; ++i) {
            const uint32_t p = uint32_t(j * (n + 1) + i);
            const uint32_t q = p + uint32_t(n + 1);
            mesh.indices.insert(mesh.indices.end(), {p, p + 1, q + 1, p, q + 1, q});
        }
    }
    return mesh;
}

Bvh build(const Mesh& mesh, float split_budget = kBvhDefaultSplitBudget) {
    Bvh bvh;
    bvh.build(mesh.positions, mesh.indices, split_budget);
    return bvh;
}

// The closest hit over all triangles, with the same kernel.
bool brute_force(const Mesh& mesh, const Ray<float>& ray, float tmax, TriangleHit& hit) {
    const RayShear<float> shear = make_ray_shear(ray.d);
    bool found = false;
    for (size_t i = 0; i < mesh.size(); ++i) {
        float t, b1, b2;
        if (intersect_triangle(ray, shear, mesh.vertex(i, 0), mesh.vertex(i, 1), mesh.vertex(i, 2),
                               tmax, t, b1, b2)) {
            tmax = t;
            hit = {t, b1, b2, uint32_t(i)};
            found = true;
        }
    }
    return found;
}

// The BVH's closest hit must be brute force's: the same triangle and t, or, on a tie (a ray
// through a shared edge), another triangle that the kernel hits at the same t.
void expect_same_closest_hit(const Mesh& mesh, const Bvh& bvh, const Ray<float>& ray, float tmax,
                             int index) {
    TriangleHit expected{}, got{};
    const bool want = brute_force(mesh, ray, tmax, expected);
    ASSERT_EQ(bvh.intersect(ray, tmax, got), want) << "ray " << index;
    if (!want) {
        return;
    }
    ASSERT_NEAR(got.t, expected.t, 1e-6f * expected.t) << "ray " << index;
    if (got.triangle != expected.triangle) {
        float t, b1, b2;
        const size_t i = got.triangle;
        ASSERT_TRUE(intersect_triangle(ray, make_ray_shear(ray.d), mesh.vertex(i, 0),
                                       mesh.vertex(i, 1), mesh.vertex(i, 2), tmax, t, b1, b2));
        ASSERT_EQ(t, expected.t) << "ray " << index;
    } else {
        EXPECT_EQ(got.b1, expected.b1);
        EXPECT_EQ(got.b2, expected.b2);
    }
}

Vec3f random_direction(std::mt19937& rng) {
    std::normal_distribution<float> normal;
    return normalize(Vec3f(normal(rng), normal(rng), normal(rng)));
}

// ---- Closest hits against brute force --------------------------------------------------------
TEST(Bvh, ClosestHitMatchesBruteForceOnARandomSoup) {
    const Mesh mesh = random_soup(3000, 1);
    const Bvh bvh = build(mesh);
    EXPECT_EQ(bvh.stats().primitives, 3000u);
    std::mt19937 rng(2);
    std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
    int hits = 0;
    for (int r = 0; r < 4000; ++r) {
        const Ray<float> ray{Vec3f(unit(rng), unit(rng), unit(rng)) * 14.0f, random_direction(rng)};
        const float tmax = r % 4 == 0 ? 5.0f : 1e30f;
        expect_same_closest_hit(mesh, bvh, ray, tmax, r);
        TriangleHit hit;
        hits += bvh.intersect(ray, tmax, hit);
    }
    EXPECT_GT(hits, 1000);
}

TEST(Bvh, ClosestHitMatchesBruteForceOnASphere) {
    const Mesh mesh = uv_sphere(48, 96);
    const Bvh bvh = build(mesh);
    std::mt19937 rng(3);
    std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
    for (int r = 0; r < 3000; ++r) {
        // From inside (always a hit), then from outside towards a random point of the ball
        const bool inside = r % 2 == 0;
        const Vec3f o =
            inside ? Vec3f(unit(rng), unit(rng), unit(rng)) * 0.5f : random_direction(rng) * 3.0f;
        const Vec3f target = Vec3f(unit(rng), unit(rng), unit(rng)) * 1.1f;
        const Ray<float> ray{o, inside ? random_direction(rng) : normalize(target - o)};
        expect_same_closest_hit(mesh, bvh, ray, 1e30f, r);
        if (inside) {
            TriangleHit hit;
            ASSERT_TRUE(bvh.intersect(ray, 1e30f, hit)) << "ray " << r << " escapes the sphere";
        }
    }
}

TEST(Bvh, AxisParallelRaysThroughBoxPlanesAndSharedEdges) {
    // Rays with zero direction components whose origins lie on node box planes (integer
    // coordinates), many exactly through shared edges and vertices of the grid
    const Mesh mesh = grid(24);
    const Bvh bvh = build(mesh);
    std::mt19937 rng(4);
    std::uniform_int_distribution<int> cell(0, 23);
    const float offsets[] = {0.0f, 0.5f, 0.25f};
    int index = 0;
    for (int r = 0; r < 2000; ++r, ++index) {
        const Vec3f o(float(cell(rng)) + offsets[r % 3], float(cell(rng)) + offsets[(r / 3) % 3],
                      r % 2 ? 3.0f : -3.0f);
        const float zero = r % 4 < 2 ? 0.0f : -0.0f;  // -0 gives -inf reciprocals
        const Ray<float> ray{o, Vec3f(zero, zero, r % 2 ? -1.0f : 1.0f)};
        expect_same_closest_hit(mesh, bvh, ray, 1e30f, index);
        TriangleHit hit;
        ASSERT_TRUE(bvh.intersect(ray, 1e30f, hit)) << "ray " << index << " leaks";
        EXPECT_EQ(hit.t, 3.0f);
    }
    // Rays inside the plane z = 0 (parallel to every triangle) never hit, and rays along
    // the x axis just above it never hit either
    for (int r = 0; r < 200; ++r, ++index) {
        const Ray<float> ray{Vec3f(-1.0f, float(cell(rng)) + 0.5f, r % 2 ? 0.0f : 1e-3f),
                             Vec3f(1.0f, 0.0f, 0.0f)};
        TriangleHit hit;
        EXPECT_FALSE(bvh.intersect(ray, 1e30f, hit)) << "ray " << index;
    }
}

// ---- Any hit -----------------------------------------------------------------------------------
TEST(Bvh, OccludedAgreesWithIntersectOnRandomSegments) {
    const Mesh mesh = random_soup(2000, 5);
    const Bvh bvh = build(mesh);
    std::mt19937 rng(6);
    std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
    int blocked = 0;
    for (int r = 0; r < 5000; ++r) {
        const Vec3f a = Vec3f(unit(rng), unit(rng), unit(rng)) * 12.0f;
        const Vec3f b = Vec3f(unit(rng), unit(rng), unit(rng)) * 12.0f;
        const float length_ab = length(b - a);
        const Ray<float> ray{a, (b - a) / length_ab};
        TriangleHit hit;
        const bool any = bvh.occluded(ray, length_ab);
        ASSERT_EQ(any, bvh.intersect(ray, length_ab, hit)) << "segment " << r;
        blocked += any;
    }
    EXPECT_GT(blocked, 500);
    EXPECT_LT(blocked, 4500);
}

// ---- Degenerate triangles ----------------------------------------------------------------------
TEST(Bvh, DegenerateTrianglesAreKeptButNeverHit) {
    Mesh mesh = grid(4);
    const size_t good = mesh.size();
    // Coincident vertices, a point, and exactly collinear vertices, all across the grid
    const uint32_t base = uint32_t(mesh.positions.size());
    mesh.positions.insert(mesh.positions.end(), {{0.5f, 0.5f, 1.0f},
                                                 {3.5f, 3.5f, 1.0f},
                                                 {2.0f, 2.0f, 1.0f},
                                                 {0.0f, 0.0f, 2.0f},
                                                 {1.0f, 1.0f, 2.0f},
                                                 {2.0f, 2.0f, 2.0f}});
    mesh.indices.insert(mesh.indices.end(),
                        {base, base, base + 1, base + 1, base + 1, base + 1, base, base + 1,
                         base + 2, base + 3, base + 4, base + 5, base + 5, base + 3, base + 4});
    const Bvh bvh = build(mesh);
    EXPECT_EQ(bvh.stats().primitives, good);
    // Rays straight down through points of the degenerate triangles hit the grid below
    std::mt19937 rng(8);
    std::uniform_real_distribution<float> frac(0.0f, 1.0f);
    for (int r = 0; r < 1000; ++r) {
        const float s = 0.5f + 3.0f * frac(rng);
        const Vec3f on_line(r % 2 ? s : std::round(s * 4.0f) / 4.0f, 0.0f, 0.0f);
        const Ray<float> ray{Vec3f(on_line.x, on_line.x, 5.0f), Vec3f(0.0f, 0.0f, -1.0f)};
        TriangleHit hit;
        ASSERT_TRUE(bvh.intersect(ray, 1e30f, hit));
        EXPECT_LT(hit.triangle, good) << "ray " << r;
        EXPECT_EQ(hit.t, 5.0f);
    }
}

// ---- Watertightness through the tree ----------------------------------------------------------
TEST(Bvh, NoLeaksFromInsideAClosedMeshThroughVerticesAndEdges) {
    const Mesh mesh = uv_sphere(16, 24);
    const Bvh bvh = build(mesh);
    std::mt19937 rng(9);
    std::uniform_real_distribution<float> unit(-1.0f, 1.0f), frac(0.0f, 1.0f);
    std::uniform_int_distribution<size_t> pick(0, mesh.size() - 1);
    for (int r = 0; r < 20000; ++r) {
        const Vec3f o = r % 5 == 0 ? Vec3f(0.0f) : Vec3f(unit(rng), unit(rng), unit(rng)) * 0.5f;
        const size_t tri = pick(rng);
        const int k = r % 3;
        const Vec3f a = mesh.vertex(tri, k), b = mesh.vertex(tri, (k + 1) % 3);
        const Vec3f target = r % 2 ? a : fma(b - a, r % 4 == 1 ? 0.5f : frac(rng), a);
        const Ray<float> ray{o, target - o};
        TriangleHit hit;
        ASSERT_TRUE(bvh.intersect(ray, 1e30f, hit)) << "ray " << r << " leaks";
        ASSERT_TRUE(bvh.occluded(ray, 1e30f)) << "ray " << r << " leaks";
    }
}

// ---- Structure and edge cases ------------------------------------------------------------------
TEST(Bvh, StructureAndBounds) {
    const Mesh mesh = uv_sphere(32, 64);
    const Bvh bvh = build(mesh);
    EXPECT_EQ(bvh.stats().primitives, mesh.size());
    // (8-wide nodes over leaves of up to 16 triangles)
    EXPECT_GT(bvh.stats().nodes, mesh.size() / 128);
    EXPECT_LT(bvh.stats().nodes, mesh.size() / 8);
    EXPECT_GT(bvh.stats().depth, 5);
    EXPECT_LT(bvh.stats().depth, 40);
    EXPECT_FLOAT_EQ(bvh.bounds_min().z, -1.0f);
    EXPECT_FLOAT_EQ(bvh.bounds_max().z, 1.0f);
    EXPECT_NEAR(bvh.bounds_min().x, -1.0f, 1e-6f);
    EXPECT_NEAR(bvh.bounds_max().y, 1.0f, 1e-3f);
}

TEST(Bvh, EmptyAndSingleTriangle) {
    Bvh empty;
    empty.build({}, {});
    TriangleHit hit;
    const Ray<float> ray{Vec3f(0.2f, 0.2f, 1.0f), Vec3f(0.0f, 0.0f, -1.0f)};
    EXPECT_FALSE(empty.intersect(ray, 1e30f, hit));
    EXPECT_FALSE(empty.occluded(ray, 1e30f));
    EXPECT_EQ(empty.stats().primitives, 0u);
    EXPECT_GT(empty.bounds_min().x, empty.bounds_max().x);

    const std::vector<Vec3f> positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
    const std::vector<uint32_t> indices = {0, 1, 2};
    Bvh one;
    one.build(positions, indices);
    ASSERT_TRUE(one.intersect(ray, 1e30f, hit));
    EXPECT_EQ(hit.triangle, 0u);
    EXPECT_FLOAT_EQ(hit.t, 1.0f);
    EXPECT_FLOAT_EQ(hit.b1, 0.2f);
    EXPECT_FLOAT_EQ(hit.b2, 0.2f);
    EXPECT_FALSE(one.intersect(ray, 1.0f, hit));
    EXPECT_FALSE(one.occluded(ray, 1.0f));
    EXPECT_EQ(one.stats().nodes, 1u);
    EXPECT_EQ(one.stats().depth, 1);
}

TEST(Bvh, ManyTrianglesWithTheSameCentroidStillBuild) {
    // Every box is centred on the origin, which defeats the SAH binning: the build falls back
    // to median splits and still finds the closest hits
    Mesh mesh;
    for (int i = 0; i < 1000; ++i) {
        const float s = 1.0f + float(i) * 1e-3f, h = float(i) * 1e-3f;
        const uint32_t base = uint32_t(mesh.positions.size());
        mesh.positions.insert(mesh.positions.end(), {{-s, -s, -h}, {s, -s, h}, {0.0f, s, 0.0f}});
        mesh.indices.insert(mesh.indices.end(), {base, base + 1, base + 2});
    }
    const Bvh bvh = build(mesh);
    EXPECT_LE(bvh.stats().depth, 16);
    EXPECT_LE(bvh.stats().nodes, 1000u / 8);
    std::mt19937 rng(10);
    std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
    for (int r = 0; r < 500; ++r) {
        const Ray<float> ray{Vec3f(unit(rng), unit(rng), 5.0f) * 2.0f,
                             Vec3f(unit(rng) * 0.1f, unit(rng) * 0.1f, -1.0f)};
        expect_same_closest_hit(mesh, bvh, ray, 1e30f, r);
    }
}

TEST(Bvh, BadIndicesAreInputErrors) {
    const std::vector<Vec3f> positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
    const std::vector<uint32_t> out_of_range = {0, 1, 3};
    const std::vector<uint32_t> not_triangles = {0, 1};
    Bvh bvh;
    EXPECT_THROW(bvh.build(positions, out_of_range), InputError);
    EXPECT_THROW(bvh.build(positions, not_triangles), InputError);
    // Among many triangles (checked in parallel), the first bad one is named, with its vertex
    std::vector<Vec3f> grid;
    std::vector<uint32_t> tris;
    for (uint32_t i = 0; i < 20000; ++i) {
        grid.push_back({float(i), 0, 0}), grid.push_back({float(i), 1, 0}),
            grid.push_back({float(i), 0, 1});
        tris.insert(tris.end(), {3 * i, 3 * i + 1, 3 * i + 2});
    }
    tris[3 * 15000 + 1] = 70000, tris[3 * 17000] = 90000, tris[3 * 19000 + 2] = 60001;
    try {
        bvh.build(grid, tris);
        FAIL() << "a vertex past the end was accepted";
    } catch (const InputError& e) {
        EXPECT_NE(
            std::string(e.what()).find("triangle 15000 uses vertex 70000 but there are only 60000"),
            std::string::npos)
            << e.what();
    }
}

// ---- The 8-wide BVH ----------------------------------------------------------------------------
// traverse_wide (src/integrators/wavefront/intersect_stage.h) on the SIMD lanes this test is
// built for (SSE2: children and triangles tested 4 + 4; the renders run the same template on
// AVX2 and AVX-512 in test_agreement), against the binary tree's scalar traversal.
using TestArch = xsimd::default_arch;

struct WideHit {
    bool hit;
    float t;
    uint32_t triangle;  // input index (closest hit only)
};

// Each ray with its tmax through the wide BVH, set up K at a time as the wavefront does.
template <bool kAnyHit>
std::vector<WideHit> trace_wide(const Bvh& bvh, const std::vector<Ray<float>>& rays,
                                const std::vector<float>& tmax) {
    using F = Wave<TestArch>::F;
    constexpr int K = Wave<TestArch>::K;
    std::vector<WideHit> out(rays.size());
    for (size_t i = 0; i < rays.size(); i += K) {
        alignas(64) float c[6][K];
        for (int l = 0; l < K; ++l) {
            const Ray<float>& r = rays[std::min(i + size_t(l), rays.size() - 1)];
            const float v[6] = {r.o.x, r.o.y, r.o.z, r.d.x, r.d.y, r.d.z};
            for (int k = 0; k < 6; ++k) c[k][l] = v[k];
        }
        const auto load = [&](int k) { return F::load_aligned(c[k]); };
        const WideRays<TestArch> wide(
            Ray<F>{{load(0), load(1), load(2)}, {load(3), load(4), load(5)}});
        for (int l = 0; l < K && i + size_t(l) < rays.size(); ++l) {
            float t = tmax[i + size_t(l)];
            BvhHit h{};
            const bool hit = traverse<kAnyHit, NodeLanes<TestArch>>(bvh.view(), wide.lane(l), t, h);
            out[i + size_t(l)] = {hit, t, hit && !kAnyHit ? hit_triangle(bvh.view(), h) : 0u};
        }
    }
    return out;
}

// The wide traversal must find what the binary one finds: any hit exactly; the closest hit's
// t and triangle, or on a tie (a ray through a shared edge) another triangle that the kernel
// hits at the same t. Returns the number of hits.
int expect_wide_matches_binary(const Mesh& mesh, const Bvh& bvh,
                               const std::vector<Ray<float>>& rays,
                               const std::vector<float>& tmax) {
    const std::vector<WideHit> closest = trace_wide<false>(bvh, rays, tmax);
    const std::vector<WideHit> any = trace_wide<true>(bvh, rays, tmax);
    int hits = 0;
    for (size_t r = 0; r < rays.size(); ++r) {
        TriangleHit want{};
        const bool hit = bvh.intersect(rays[r], tmax[r], want);
        EXPECT_EQ(any[r].hit, bvh.occluded(rays[r], tmax[r])) << "ray " << r;
        EXPECT_EQ(closest[r].hit, hit) << "ray " << r;
        if (!hit || !closest[r].hit) continue;
        ++hits;
        EXPECT_NEAR(closest[r].t, want.t, 1e-6f * want.t) << "ray " << r;
        if (closest[r].triangle != want.triangle) {
            const size_t i = closest[r].triangle;
            float t, b1, b2;
            EXPECT_TRUE(intersect_triangle(rays[r], make_ray_shear(rays[r].d), mesh.vertex(i, 0),
                                           mesh.vertex(i, 1), mesh.vertex(i, 2), tmax[r], t, b1,
                                           b2))
                << "ray " << r;
            EXPECT_NEAR(t, want.t, 1e-6f * want.t) << "ray " << r;
        }
    }
    return hits;
}

TEST(WideBvh, MatchesTheBinaryTreeOnARandomSoup) {
    const Mesh mesh = random_soup(3000, 11);
    const Bvh bvh = build(mesh);
    std::mt19937 rng(12);
    std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
    std::vector<Ray<float>> rays;
    std::vector<float> tmax;
    for (int r = 0; r < 6000; ++r) {
        rays.push_back({Vec3f(unit(rng), unit(rng), unit(rng)) * 14.0f, random_direction(rng)});
        tmax.push_back(r % 3 == 0 ? 6.0f : 1e30f);
    }
    EXPECT_GT(expect_wide_matches_binary(mesh, bvh, rays, tmax), 1500);
}

TEST(WideBvh, MatchesTheBinaryTreeOnAClosedMesh) {
    // From inside (always a hit), from outside towards the ball, and segments that end
    // before, inside or beyond the surface (any hit)
    const Mesh mesh = uv_sphere(48, 96);
    const Bvh bvh = build(mesh);
    std::mt19937 rng(13);
    std::uniform_real_distribution<float> unit(-1.0f, 1.0f), frac(0.0f, 1.0f);
    std::vector<Ray<float>> rays;
    std::vector<float> tmax;
    for (int r = 0; r < 6000; ++r) {
        const bool inside = r % 2 == 0;
        const Vec3f o =
            inside ? Vec3f(unit(rng), unit(rng), unit(rng)) * 0.5f : random_direction(rng) * 3.0f;
        const Vec3f target = Vec3f(unit(rng), unit(rng), unit(rng)) * 1.1f;
        rays.push_back({o, inside ? random_direction(rng) : normalize(target - o)});
        tmax.push_back(r % 3 == 0 ? 3.0f * frac(rng) : 1e30f);
    }
    EXPECT_GT(expect_wide_matches_binary(mesh, bvh, rays, tmax), 2500);
}

TEST(WideBvh, NoLeaksFromInsideAClosedMeshThroughVerticesAndEdges) {
    const Mesh mesh = uv_sphere(16, 24);
    const Bvh bvh = build(mesh);
    std::mt19937 rng(14);
    std::uniform_real_distribution<float> unit(-1.0f, 1.0f), frac(0.0f, 1.0f);
    std::uniform_int_distribution<size_t> pick(0, mesh.size() - 1);
    std::vector<Ray<float>> rays;
    for (int r = 0; r < 20000; ++r) {
        const Vec3f o = r % 5 == 0 ? Vec3f(0.0f) : Vec3f(unit(rng), unit(rng), unit(rng)) * 0.5f;
        const size_t tri = pick(rng);
        const Vec3f a = mesh.vertex(tri, r % 3), b = mesh.vertex(tri, (r + 1) % 3);
        rays.push_back({o, (r % 2 ? a : fma(b - a, r % 4 == 1 ? 0.5f : frac(rng), a)) - o});
    }
    const std::vector<float> tmax(rays.size(), 1e30f);
    const std::vector<WideHit> closest = trace_wide<false>(bvh, rays, tmax);
    const std::vector<WideHit> any = trace_wide<true>(bvh, rays, tmax);
    for (size_t r = 0; r < rays.size(); ++r) {
        ASSERT_TRUE(closest[r].hit) << "ray " << r << " leaks";
        ASSERT_TRUE(any[r].hit) << "ray " << r << " leaks";
    }
}

TEST(WideBvh, AxisParallelRaysThroughBoxPlanesAndSharedEdges) {
    // Zero direction components (+-inf reciprocals) and origins on box planes: a NaN slab
    // distance must leave the interval as it was, as in the binary traversal, on whichever
    // axis it occurs (the grid and the rays turned to each axis in turn)
    const auto turn = [](const Vec3f& v, int axis) {
        return axis == 0 ? v : (axis == 1 ? Vec3f(v.z, v.x, v.y) : Vec3f(v.y, v.z, v.x));
    };
    for (int axis = 0; axis < 3; ++axis) {
        Mesh mesh = grid(24);
        for (Vec3f& p : mesh.positions) p = turn(p, axis);
        const Bvh bvh = build(mesh);
        std::mt19937 rng(15);
        std::uniform_int_distribution<int> cell(0, 23);
        const float offsets[] = {0.0f, 0.5f, 0.25f};
        std::vector<Ray<float>> rays;
        for (int r = 0; r < 2000; ++r) {
            const Vec3f o(float(cell(rng)) + offsets[r % 3],
                          float(cell(rng)) + offsets[(r / 3) % 3], r % 2 ? 3.0f : -3.0f);
            const float zero = r % 4 < 2 ? 0.0f : -0.0f;
            rays.push_back({turn(o, axis), turn(Vec3f(zero, zero, r % 2 ? -1.0f : 1.0f), axis)});
        }
        // In the grid's plane (parallel to every triangle) and just above it: no hits
        for (int r = 0; r < 200; ++r)
            rays.push_back({turn(Vec3f(-1.0f, float(cell(rng)) + 0.5f, r % 2 ? 0.0f : 1e-3f), axis),
                            turn(Vec3f(1.0f, 0.0f, 0.0f), axis)});
        const std::vector<float> tmax(rays.size(), 1e30f);
        EXPECT_EQ(expect_wide_matches_binary(mesh, bvh, rays, tmax), 2000) << "axis " << axis;
    }
}

// Each non-degenerate triangle of the mesh in exactly one leaf lane, inside its slot's box;
// padding lanes zero; the slots in use at the front, the others empty. Returns the mean
// number of slots in use.
// Checks the wide layout: node slots, the leaf mask, padding lanes, and that the leaves hold
// every triangle before `degenerate_from` and none after it. Without spatial splits
// (references == primitives) each triangle is in exactly one leaf whose box holds its
// vertices; with them, in one or more leaves whose boxes together cover the whole triangle
// (checked on a grid of points over it, vertices and edges included, to a relative 2^-22).
// Returns the mean slots per node.
double expect_valid_wide_layout(const Mesh& mesh, const Bvh& bvh, size_t degenerate_from) {
    constexpr uint32_t W = kWideBvhWidth;
    const bool splits = bvh.stats().references > bvh.stats().primitives;
    std::vector<int> seen(mesh.size(), 0);
    std::vector<std::vector<std::array<float, 6>>> boxes(mesh.size());
    size_t slots = 0;
    for (size_t n = 0; n < size_t(bvh.view().node_count); ++n) {
        const WideBvhNode& node = bvh.view().nodes[n];
        EXPECT_GE(node.slots, 1u);
        EXPECT_LE(node.slots, W);
        slots += node.slots;
        for (uint32_t i = node.slots; i < W; ++i) {
            EXPECT_GT(node.row(0)[i], node.row(3)[i]) << "an unused slot's box";
            EXPECT_EQ(node.count[i], 0u) << "an unused slot is an empty leaf";
        }
        // The leaf mask: exactly the used slots that hold triangles (the traversal tests
        // those at once and never descends into them) and the unused ones (empty leaves, so
        // that a NaN ray, which enters every box, tests nothing there and never loops back
        // to the root through child 0)
        for (uint32_t i = 0; i < 32; ++i) {
            const bool leaf = i < W && (i >= node.slots || node.count[i] != 0);
            EXPECT_EQ((node.leaves >> i) & 1u, uint32_t(leaf)) << "node " << n << " slot " << i;
        }
        for (uint32_t i = 0; i < std::min(node.slots, W); ++i) {
            if (node.count[i] == 0) {  // an inner child, after its parent
                EXPECT_GT(node.child[i], n);
                EXPECT_LT(node.child[i], uint32_t(bvh.view().node_count));
                continue;
            }
            EXPECT_LE(node.count[i], 2 * W);
            for (uint32_t j = 0; j < (node.count[i] + W - 1) / W * W; ++j) {
                const uint32_t lane = node.child[i] * W + j;
                const TriangleBlock& block = bvh.view().triangles[lane / W];
                for (int k = 0; k < 9; ++k) {
                    const float v = block.v[k][lane % W];
                    if (j >= node.count[i]) {
                        EXPECT_EQ(v, 0.0f);
                        continue;
                    }
                    if (splits) continue;
                    EXPECT_GE(v, node.row(k % 3)[i]);
                    EXPECT_LE(v, node.row(k % 3 + 3)[i]);
                }
                if (j >= node.count[i]) continue;
                const uint32_t t = bvh.view().triangle_index[lane];
                ++seen[t];
                boxes[t].push_back({node.row(0)[i], node.row(1)[i], node.row(2)[i], node.row(3)[i],
                                    node.row(4)[i], node.row(5)[i]});
            }
        }
    }
    size_t lanes = 0;
    for (size_t t = 0; t < mesh.size(); ++t) {
        lanes += size_t(seen[t]);
        if (t >= degenerate_from || !splits) {
            EXPECT_EQ(seen[t], t < degenerate_from ? 1 : 0) << "triangle " << t;
            continue;
        }
        EXPECT_GE(seen[t], 1) << "triangle " << t;
        constexpr int kSteps = 12;
        for (int u = 0; u <= kSteps; ++u) {
            for (int v = 0; u + v <= kSteps; ++v) {
                const float bu = float(u) / kSteps, bv = float(v) / kSteps;
                const Vec3f p = u == kSteps   ? mesh.vertex(t, 1)
                                : v == kSteps ? mesh.vertex(t, 2)
                                              : mesh.vertex(t, 0) * (1.0f - bu - bv) +
                                                    mesh.vertex(t, 1) * bu + mesh.vertex(t, 2) * bv;
                const float tol =
                    0x1p-22f * std::max({std::fabs(p.x), std::fabs(p.y), std::fabs(p.z)});
                const bool covered =
                    std::any_of(boxes[t].begin(), boxes[t].end(), [&](const auto& b) {
                        return p.x >= b[0] - tol && p.y >= b[1] - tol && p.z >= b[2] - tol &&
                               p.x <= b[3] + tol && p.y <= b[4] + tol && p.z <= b[5] + tol;
                    });
                EXPECT_TRUE(covered) << "triangle " << t << ", point " << u << "," << v
                                     << " in none of its " << boxes[t].size() << " leaves";
            }
        }
    }
    // (a leaf the collapse made of a subtree holds a cut triangle once)
    EXPECT_LE(lanes, bvh.stats().references);
    return double(slots) / double(std::max<size_t>(size_t(bvh.view().node_count), 1));
}

TEST(WideBvh, HoldsEveryTriangleOnceInMostlyFullNodes) {
    // A soup with two degenerate triangles, a sphere, and a tree of median splits (every
    // centroid the same)
    Mesh soup = random_soup(2000, 16);
    soup.indices.insert(soup.indices.end(), {0, 0, 1, 2, 2, 2});
    EXPECT_GT(expect_valid_wide_layout(soup, build(soup, 0.0f), 2000), 5.0);
    const Mesh sphere = uv_sphere(32, 64);
    EXPECT_GT(expect_valid_wide_layout(sphere, build(sphere, 0.0f), sphere.size()), 5.0);
    Mesh median;
    for (int i = 0; i < 1000; ++i) {
        const float s = 1.0f + float(i) * 1e-3f, h = float(i) * 1e-3f;
        const uint32_t base = uint32_t(median.positions.size());
        median.positions.insert(median.positions.end(),
                                {{-s, -s, -h}, {s, -s, h}, {0.0f, s, 0.0f}});
        median.indices.insert(median.indices.end(), {base, base + 1, base + 2});
    }
    EXPECT_GT(expect_valid_wide_layout(median, build(median, 0.0f), median.size()), 5.0);
}

TEST(WideBvh, BoxAreasThatOverflowStillGiveAValidTree) {
    // A soup of ordinary size plus eight triangles near the corners of a cube of side 2e36:
    // the upper boxes' surface areas are infinite, the collapse's costs there meaningless,
    // and the tree must still be valid and agree with the binary one. (Triangles out at 1e36
    // cannot be hit at all: the watertight kernel's edge products overflow, in both trees;
    // the rays hit the ordinary ones.)
    Mesh mesh = random_soup(1500, 17);
    for (int c = 0; c < 8; ++c) {
        const Vec3f corner{c & 1 ? 1e36f : -1e36f, c & 2 ? 1e36f : -1e36f, c & 4 ? 1e36f : -1e36f};
        const uint32_t base = uint32_t(mesh.positions.size());
        mesh.positions.insert(mesh.positions.end(),
                              {corner, corner * 0.9f, corner * Vec3f{0.9f, 1.0f, 0.8f}});
        mesh.indices.insert(mesh.indices.end(), {base, base + 1, base + 2});
    }
    const Bvh bvh = build(mesh);
    expect_valid_wide_layout(mesh, bvh, mesh.size());
    std::mt19937 rng(18);
    std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
    std::vector<Ray<float>> rays;
    for (int r = 0; r < 2000; ++r)
        rays.push_back({Vec3f(unit(rng), unit(rng), unit(rng)) * 14.0f, random_direction(rng)});
    const std::vector<float> tmax(rays.size(), 3e38f);
    // (and enough of the rays hit for the comparison to mean something)
    EXPECT_GT(expect_wide_matches_binary(mesh, bvh, rays, tmax), 200);
}

TEST(WideBvh, EmptyAndSingleTriangle) {
    Bvh empty;
    empty.build({}, {});
    EXPECT_EQ(empty.view().node_count, 0);
    const Ray<float> ray{Vec3f(0.2f, 0.2f, 1.0f), Vec3f(0.0f, 0.0f, -1.0f)};
    EXPECT_FALSE(trace_wide<false>(empty, {ray}, {1e30f})[0].hit);
    EXPECT_FALSE(trace_wide<true>(empty, {ray}, {1e30f})[0].hit);

    const std::vector<Vec3f> positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
    const std::vector<uint32_t> indices = {0, 1, 2};
    Bvh one;
    one.build(positions, indices);
    ASSERT_EQ(one.view().node_count, 1);
    EXPECT_EQ(one.view().nodes[0].slots, 1u);
    const WideHit hit = trace_wide<false>(one, {ray}, {1e30f})[0];
    ASSERT_TRUE(hit.hit);
    EXPECT_EQ(hit.triangle, 0u);
    EXPECT_EQ(hit.t, 1.0f);
    EXPECT_FALSE(trace_wide<false>(one, {ray}, {1.0f})[0].hit);
    EXPECT_FALSE(trace_wide<true>(one, {ray}, {1.0f})[0].hit);
}

// ---- Spatial splits -----------------------------------------------------------------------------
// Long thin triangles across a soup: the case spatial splits are for (a sliver's box overlaps
// everything it crosses).
Mesh slivers_in_a_soup(uint32_t seed) {
    Mesh mesh = random_soup(1500, seed);
    std::mt19937 rng(seed + 1);
    std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
    for (int i = 0; i < 300; ++i) {
        const Vec3f a = Vec3f(unit(rng), unit(rng), unit(rng)) * 10.0f;
        const Vec3f b = Vec3f(unit(rng), unit(rng), unit(rng)) * 10.0f;
        const Vec3f c = a + Vec3f(unit(rng), unit(rng), unit(rng)) * 0.05f;
        const uint32_t base = uint32_t(mesh.positions.size());
        mesh.positions.insert(mesh.positions.end(), {a, b, c});
        mesh.indices.insert(mesh.indices.end(), {base, base + 1, base + 2});
    }
    return mesh;
}

TEST(SpatialSplits, CutReferencesWithinTheBudgetAndNoneWithout) {
    const Mesh mesh = slivers_in_a_soup(30);
    const Bvh none = build(mesh, 0.0f);
    EXPECT_EQ(none.stats().references, none.stats().primitives);
    for (const float budget : {0.1f, 0.25f, 1.0f}) {
        const Bvh bvh = build(mesh, budget);
        EXPECT_EQ(bvh.stats().primitives, mesh.size());
        EXPECT_GT(bvh.stats().references, bvh.stats().primitives) << "budget " << budget;
        EXPECT_LE(double(bvh.stats().references), double(mesh.size()) * (1.0 + budget))
            << "budget " << budget;
    }
    // (a budget out of range is clamped: negative or NaN is none)
    EXPECT_EQ(build(mesh, -1.0f).stats().references, mesh.size());
    EXPECT_EQ(build(mesh, std::nanf("")).stats().references, mesh.size());
}

TEST(SpatialSplits, TreesMatchBruteForceAndCoverEveryTriangle) {
    const Mesh mesh = slivers_in_a_soup(31);
    const Bvh bvh = build(mesh, 1.0f);
    ASSERT_GT(bvh.stats().references, bvh.stats().primitives + 100);
    expect_valid_wide_layout(mesh, bvh, mesh.size());
    std::mt19937 rng(32);
    std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
    std::vector<Ray<float>> rays;
    std::vector<float> tmax;
    for (int r = 0; r < 4000; ++r) {
        const Ray<float> ray{Vec3f(unit(rng), unit(rng), unit(rng)) * 14.0f, random_direction(rng)};
        expect_same_closest_hit(mesh, bvh, ray, r % 4 == 0 ? 5.0f : 1e30f, r);
        rays.push_back(ray), tmax.push_back(r % 4 == 0 ? 5.0f : 1e30f);
    }
    EXPECT_GT(expect_wide_matches_binary(mesh, bvh, rays, tmax), 800);
}

TEST(SpatialSplits, WatertightAcrossCutReferences) {
    // A closed sphere of long thin quads (few segments around, many along) and a triangle
    // spanning the whole scene behind it: rays from inside must never escape, and rays aimed
    // at points of the big triangle (cut many times) must hit it or something in front
    Mesh mesh = uv_sphere(200, 6);
    const uint32_t base = uint32_t(mesh.positions.size());
    mesh.positions.insert(mesh.positions.end(),
                          {{-50.0f, -50.0f, -3.0f}, {50.0f, -50.0f, -3.0f}, {0.0f, 60.0f, -3.0f}});
    mesh.indices.insert(mesh.indices.end(), {base, base + 1, base + 2});
    const Bvh bvh = build(mesh, 1.0f);
    ASSERT_GT(bvh.stats().references, bvh.stats().primitives);
    expect_valid_wide_layout(mesh, bvh, mesh.size());
    std::mt19937 rng(33);
    std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
    for (int r = 0; r < 3000; ++r) {
        const Ray<float> ray{Vec3f(unit(rng), unit(rng), unit(rng)) * 0.5f, random_direction(rng)};
        TriangleHit hit;
        ASSERT_TRUE(bvh.intersect(ray, 1e30f, hit)) << "ray " << r << " escapes the sphere";
        ASSERT_TRUE(bvh.occluded(ray, 1e30f)) << "ray " << r;
    }
    for (int r = 0; r < 4000; ++r) {
        // (points inside the big triangle, from in front of it)
        const float u = std::fabs(unit(rng)), v = std::fabs(unit(rng)) * (1.0f - u);
        const Vec3f target = mesh.vertex(mesh.size() - 1, 0) * (1.0f - u - v) +
                             mesh.vertex(mesh.size() - 1, 1) * u +
                             mesh.vertex(mesh.size() - 1, 2) * v;
        const Vec3f o(unit(rng) * 40.0f, unit(rng) * 40.0f, 20.0f);
        const Ray<float> ray{o, normalize(target - o)};
        TriangleHit hit;
        ASSERT_TRUE(bvh.intersect(ray, 1e30f, hit)) << "ray " << r << " passes the big triangle";
        expect_same_closest_hit(mesh, bvh, ray, 1e30f, r);
    }
}

TEST(SpatialSplits, SurviveDegenerateInput) {
    // Every triangle in the plane z = 1 (boxes flat along z), many overlapping; slivers of
    // width 1e-6; and one triangle spanning everything
    Mesh mesh;
    std::mt19937 rng(34);
    std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
    for (int i = 0; i < 2000; ++i) {
        const uint32_t base = uint32_t(mesh.positions.size());
        const Vec3f a(unit(rng) * 10.0f, unit(rng) * 10.0f, 1.0f);
        const Vec3f b = i % 2 ? Vec3f(unit(rng) * 10.0f, unit(rng) * 10.0f, 1.0f)
                              : a + Vec3f(unit(rng), unit(rng), 0.0f);
        const Vec3f c = i % 3 == 0 ? a + Vec3f(1e-6f, 0.0f, 0.0f)
                                   : Vec3f(unit(rng) * 10.0f, unit(rng) * 10.0f, 1.0f);
        mesh.positions.insert(mesh.positions.end(), {a, b, c});
        mesh.indices.insert(mesh.indices.end(), {base, base + 1, base + 2});
    }
    const uint32_t base = uint32_t(mesh.positions.size());
    mesh.positions.insert(mesh.positions.end(),
                          {{-30.0f, -30.0f, -5.0f}, {30.0f, -30.0f, 5.0f}, {0.0f, 40.0f, 0.0f}});
    mesh.indices.insert(mesh.indices.end(), {base, base + 1, base + 2});
    for (const float budget : {0.25f, 4.0f}) {
        const Bvh bvh = build(mesh, budget);
        EXPECT_LE(bvh.stats().depth, kBvhMaxDepth);
        expect_valid_wide_layout(mesh, bvh, mesh.size());
        for (int r = 0; r < 3000; ++r) {
            const Ray<float> ray{
                Vec3f(unit(rng) * 12.0f, unit(rng) * 12.0f, r % 2 ? 6.0f : -6.0f),
                normalize(Vec3f(unit(rng) * 0.3f, unit(rng) * 0.3f, r % 2 ? -1.0f : 1.0f))};
            // (coplanar triangles overlap: on a tie the tree may name another one at the same
            // distance, to rounding)
            TriangleHit want{}, got{};
            const bool hit = brute_force(mesh, ray, 1e30f, want);
            ASSERT_EQ(bvh.intersect(ray, 1e30f, got), hit) << "ray " << r;
            if (!hit) continue;
            ASSERT_NEAR(got.t, want.t, 1e-6f * want.t) << "ray " << r;
            float t, b1, b2;
            const size_t i = got.triangle;
            ASSERT_TRUE(intersect_triangle(ray, make_ray_shear(ray.d), mesh.vertex(i, 0),
                                           mesh.vertex(i, 1), mesh.vertex(i, 2), 1e30f, t, b1, b2));
            ASSERT_EQ(t, got.t) << "ray " << r;
        }
    }
}

TEST(SpatialSplits, ParallelBuildsGiveTheSameTreeByteForByte) {
    // Cut references get their numbers from an atomic counter in parallel tasks; the tree
    // must not depend on which task came first
    Mesh mesh = slivers_in_a_soup(35);
    const Mesh more = random_soup(20000, 36);
    for (const uint32_t i : more.indices)
        mesh.indices.push_back(i + uint32_t(mesh.positions.size()));
    mesh.positions.insert(mesh.positions.end(), more.positions.begin(), more.positions.end());
    const Bvh a = build(mesh, 1.0f), b = build(mesh, 1.0f);
    ASSERT_GT(a.stats().references, a.stats().primitives);
    ASSERT_EQ(a.view().node_count, b.view().node_count);
    EXPECT_EQ(a.stats().references, b.stats().references);
    EXPECT_EQ(a.stats().triangle_blocks, b.stats().triangle_blocks);
    EXPECT_EQ(std::memcmp(a.view().nodes, b.view().nodes,
                          size_t(a.view().node_count) * sizeof(WideBvhNode)),
              0);
    EXPECT_EQ(std::memcmp(a.view().triangles, b.view().triangles,
                          a.stats().triangle_blocks * sizeof(TriangleBlock)),
              0);
    EXPECT_EQ(std::memcmp(a.view().triangle_index, b.view().triangle_index,
                          a.stats().triangle_blocks * kWideBvhWidth * sizeof(uint32_t)),
              0);
}

}  // namespace
}  // namespace cierzo
