// Tests of the triangle BVH (src/scene/bvh.h): closest hits against brute force on a random
// soup, a sphere mesh and an axis-aligned grid, any-hit against closest-hit, degenerate
// triangles, closed-mesh watertightness through the tree, and build edge cases.
#include "scene/bvh.h"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <random>
#include <vector>

#include "core/error.h"
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

Bvh build(const Mesh& mesh) {
    Bvh bvh;
    bvh.build(mesh.positions, mesh.indices);
    return bvh;
}

// The closest hit over all triangles, with the same kernel.
bool brute_force(const Mesh& mesh, const Ray<float>& ray, float tmax, TriangleHit& hit) {
    const RayShear<float> shear = make_ray_shear(ray.d);
    bool found = false;
    for (size_t i = 0; i < mesh.size(); ++i) {
        float t, b1, b2;
        if (intersect_triangle(ray, shear, mesh.vertex(i, 0), mesh.vertex(i, 1),
                               mesh.vertex(i, 2), tmax, t, b1, b2)) {
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
    EXPECT_EQ(bvh.triangle_count(), 3000u);
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
        const Vec3f o = inside ? Vec3f(unit(rng), unit(rng), unit(rng)) * 0.5f
                               : random_direction(rng) * 3.0f;
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
    mesh.indices.insert(mesh.indices.end(), {base, base, base + 1, base + 1, base + 1, base + 1,
                                             base, base + 1, base + 2, base + 3, base + 4, base + 5,
                                             base + 5, base + 3, base + 4});
    const Bvh bvh = build(mesh);
    EXPECT_EQ(bvh.triangle_count(), good + 5);
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
    EXPECT_EQ(bvh.triangle_count(), mesh.size());
    EXPECT_GT(bvh.node_count(), mesh.size() / 4);
    EXPECT_LT(bvh.node_count(), 2 * mesh.size());
    EXPECT_GT(bvh.depth(), 5);
    EXPECT_LT(bvh.depth(), 40);
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
    EXPECT_EQ(empty.triangle_count(), 0u);
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
    EXPECT_EQ(one.node_count(), 1u);
    EXPECT_EQ(one.depth(), 1);
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
    EXPECT_LE(bvh.depth(), 16);
    EXPECT_EQ(bvh.node_count(), 511u);
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
}

}  // namespace
}  // namespace cierzo
