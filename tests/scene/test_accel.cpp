// The scene BVH (src/accel/, kernels/bvh/traverse.h) against brute force: closest and any hit on
// random rays through mixtures of every primitive kind, with instances that rotate, scale
// non-uniformly and mirror; the wavefront's SIMD traversal and its K-ray packets against the
// scalar one; watertightness through instances; degenerate and extreme inputs.
#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include <unistd.h>

#include "integrators/registry.h"
#include "integrators/render.h"
#include "integrators/wavefront/isa.h"
#include "integrators/wavefront/intersect_stage.h"
#include "kernels/bvh/traverse.h"
#include "kernels/bvh/traverse_group.h"
#include "kernels/bvh/traverse_stream.h"
#include "scene/scene_json.h"
#include "support/emulator.h"
#include "support/uv_sphere.h"

namespace cierzo {
namespace {

namespace fs = std::filesystem;

// A folder of its own under the system's temporary folder, removed at the end.
struct TempDir {
    fs::path path;
    TempDir() {
        static int counter = 0;
        path = fs::temp_directory_path() /
               ("cierzo_accel_" + std::to_string(::getpid()) + "_" + std::to_string(counter++));
        fs::create_directories(path);
    }
    ~TempDir() { fs::remove_all(path); }
    fs::path write(const std::string& name, const std::string& text) const {
        std::ofstream(path / name) << text;
        return path / name;
    }
};

// A closed UV sphere of radius 1 as an ASCII PLY file.
std::string sphere_ply(int rings, int segments) {
    const test::TriangleMesh m = test::uv_sphere(rings, segments);
    std::string s = "ply\nformat ascii 1.0\nelement vertex " + std::to_string(m.positions.size()) +
                    "\nproperty float x\nproperty float y\nproperty float z\nelement face " +
                    std::to_string(m.indices.size() / 3) +
                    "\nproperty list uchar int vertex_indices\nend_header\n";
    char line[128];
    for (const Vec3f& p : m.positions) {
        std::snprintf(line, sizeof line, "%.9g %.9g %.9g\n", p.x, p.y, p.z);
        s += line;
    }
    for (size_t i = 0; i < m.indices.size(); i += 3)
        s += "3 " + std::to_string(m.indices[i]) + " " + std::to_string(m.indices[i + 1]) + " " +
             std::to_string(m.indices[i + 2]) + "\n";
    return s;
}

Vec3f to_world(const Mesh& m, const Vec3f& p) {
    const float* a = m.to_world;
    return {a[0] * p.x + a[1] * p.y + a[2] * p.z + a[3],
            a[4] * p.x + a[5] * p.y + a[6] * p.z + a[7],
            a[8] * p.x + a[9] * p.y + a[10] * p.z + a[11]};
}

// Every primitive of the scene with the kernels, one after the other: the nearest hit's t,
// material and normal, and how many primitives are hit within `tie` of it.
struct Brute {
    bool hit = false;
    float t = kRayFar;
    int32_t material = -1;
    Vec3f n{0.0f};
    int near_ties = 0;
};

Brute brute_force(const Scene& s, const Ray<float>& ray, float tmax, float tie) {
    struct Candidate {
        float t;
        int32_t material;
        Vec3f n;
    };
    std::vector<Candidate> hits;
    float t;
    for (size_t i = 0; i < s.spheres.size(); ++i) {
        const Vec3f c{s.spheres.cx[i], s.spheres.cy[i], s.spheres.cz[i]};
        if (intersect_sphere(ray, c, s.spheres.radius[i], tmax, t))
            hits.push_back({t, s.spheres.material[i], normalize(fma(ray.d, t, ray.o) - c)});
    }
    for (size_t i = 0; i < s.planes.size(); ++i) {
        const Vec3f n{s.planes.nx[i], s.planes.ny[i], s.planes.nz[i]};
        if (intersect_plane(ray, n, s.planes.distance[i], tmax, t))
            hits.push_back({t, s.planes.material[i], n});
    }
    for (const Quadric& q : s.quadrics)
        if (intersect_quadric(ray, q.q, q.box_min, q.box_max, tmax, t))
            hits.push_back({t, q.material, normalize(quadric_gradient(q.q, fma(ray.d, t, ray.o)))});
    const RayShear<float> shear = make_ray_shear(ray.d);
    for (const Mesh& m : s.meshes) {
        const Mesh& g = s.geometry_of(m);
        for (size_t i = 0; i < g.indices.size(); i += 3) {
            Vec3f v[3];
            for (int k = 0; k < 3; ++k) {
                const Vec3f p = g.positions[g.indices[i + size_t(k)]];
                v[k] = m.instanced() ? to_world(m, p) : p;
            }
            float b1, b2;
            // (a mirroring transform reverses the winding; the normal stays the file's
            // normal through the inverse transpose)
            const float side = m.instanced() && m.mirrored ? -1.0f : 1.0f;
            if (intersect_triangle(ray, shear, v[0], v[1], v[2], tmax, t, b1, b2))
                hits.push_back({t, m.material, normalize(cross(v[1] - v[0], v[2] - v[0])) * side});
        }
    }
    Brute b;
    for (const Candidate& c : hits)
        if (c.t < b.t) b = {true, c.t, c.material, c.n, 0};
    for (const Candidate& c : hits) b.near_ties += std::abs(c.t - b.t) <= tie * b.t;
    return b;
}

Vec3f random_direction(std::mt19937& rng) {
    std::normal_distribution<float> normal;
    return normalize(Vec3f(normal(rng), normal(rng), normal(rng)));
}

// The scene's closest hit and any hit against brute force for random rays from inside the
// box [-extent, extent]^3: the same hit or miss, t within `tolerance` (relative; 0: equal),
// the same material and normal unless two primitives tie; any hit on random segments.
// `allowed` hit/miss disagreements (rays grazing an instance's edge, rounded differently
// in its space). Returns the number of hits.
int expect_matches_brute_force(const Scene& s, float extent, float tolerance, int allowed,
                               uint32_t seed, int rays) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> unit(-1.0f, 1.0f), frac(0.0f, 1.0f);
    const float tie = std::max(tolerance, 1e-6f) * 4.0f;
    int hits = 0, disagreements = 0;
    for (int r = 0; r < rays; ++r) {
        const Ray<float> ray{Vec3f(unit(rng), unit(rng), unit(rng)) * extent,
                             random_direction(rng)};
        const float tmax = r % 4 == 0 ? frac(rng) * extent : kRayFar;
        const Brute want = brute_force(s, ray, tmax, tie);
        Hit got;
        const bool hit = s.intersect(ray, tmax, got);
        if (hit != want.hit) {
            ++disagreements;
            continue;
        }
        // Any hit on the segment to tmax: whatever the closest hit says
        if (s.occluded(ray, tmax) != want.hit) ++disagreements;
        if (!hit) continue;
        ++hits;
        if (tolerance == 0.0f) {
            EXPECT_EQ(got.t, want.t) << "ray " << r;
        } else {
            // (relative to the coordinates' size, which sets the rounding error)
            EXPECT_NEAR(got.t, want.t, tolerance * (want.t + extent)) << "ray " << r;
        }
        if (want.near_ties > 1) continue;
        EXPECT_EQ(got.material, want.material) << "ray " << r;
        EXPECT_NEAR(dot(got.n, want.n), 1.0f, 1e-3f) << "ray " << r;
    }
    EXPECT_LE(disagreements, allowed);
    return hits;
}

float frac_of(std::mt19937& rng) { return std::uniform_real_distribution<float>(0.0f, 1.0f)(rng); }

// A mixture in [-10, 10]^3: random spheres (radii 0.05-2), loose triangles, bounded quadrics
// (ellipsoids in their boxes), an unbounded cylinder and two planes, each with its own
// material so a wrong primitive shows.
std::string mixture_objects(uint32_t seed, int spheres, int triangles, int quadrics = 6) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> unit(-1.0f, 1.0f), size(0.05f, 2.0f);
    std::string o;
    int material = 0;
    const auto mat = [&] { return "{\"kd\": " + std::to_string(0.01 * (++material % 97)) + "}"; };
    const auto v3 = [](const Vec3f& v) {
        return "[" + std::to_string(v.x) + ", " + std::to_string(v.y) + ", " + std::to_string(v.z) +
               "]";
    };
    for (int i = 0; i < spheres; ++i)
        o += "{\"type\": \"sphere\", \"center\": " +
             v3(Vec3f(unit(rng), unit(rng), unit(rng)) * 10.0f) +
             ", \"radius\": " + std::to_string(size(rng)) + ", \"material\": " + mat() + "},\n";
    for (int i = 0; i < triangles; ++i) {
        const Vec3f c = Vec3f(unit(rng), unit(rng), unit(rng)) * 10.0f;
        const float s = size(rng);
        o += "{\"type\": \"triangle\", \"vertices\": [" +
             v3(c + Vec3f(unit(rng), unit(rng), unit(rng)) * s) + ", " +
             v3(c + Vec3f(unit(rng), unit(rng), unit(rng)) * s) + ", " +
             v3(c + Vec3f(unit(rng), unit(rng), unit(rng)) * s) + "], \"material\": " + mat() +
             "},\n";
    }
    for (int i = 0; i < quadrics; ++i) {
        // (x - c)²/a² + ... = 1, clipped to its box (half of it for the odd ones)
        const Vec3f c = Vec3f(unit(rng), unit(rng), unit(rng)) * 8.0f;
        const Vec3f a(1.0f + frac_of(rng), 0.5f + frac_of(rng), 1.0f + frac_of(rng));
        const float A = 1 / (a.x * a.x), B = 1 / (a.y * a.y), C = 1 / (a.z * a.z);
        const std::string k =
            "[" + std::to_string(A) + ", " + std::to_string(B) + ", " + std::to_string(C) +
            ", 0, 0, 0, " + std::to_string(-2 * A * c.x) + ", " + std::to_string(-2 * B * c.y) +
            ", " + std::to_string(-2 * C * c.z) + ", " +
            std::to_string(A * c.x * c.x + B * c.y * c.y + C * c.z * c.z - 1) + "]";
        const Vec3f hi = c + a * (i % 2 ? 1.01f : 0.0f) + Vec3f(i % 2 ? 0.0f : 1e-3f);
        o += "{\"type\": \"quadric\", \"coefficients\": " + k +
             ", \"bounds\": {\"min\": " + v3(c - a * 1.01f) +
             ", \"max\": " + v3(vmax(hi, c + Vec3f(1e-3f))) + "}, \"material\": " + mat() + "},\n";
    }
    // An unbounded cylinder x² + z² = 0.25 and two planes
    o += "{\"type\": \"quadric\", \"coefficients\": [1, 0, 1, 0, 0, 0, 0, 0, 0, -0.25], "
         "\"material\": " +
         mat() + "},\n";
    o += "{\"type\": \"plane\", \"normal\": [0, 1, 0], \"distance\": 9.5, \"material\": " + mat() +
         "},\n";
    o += "{\"type\": \"plane\", \"normal\": [1, 1, 0], \"distance\": -13, \"material\": " + mat() +
         "}";
    return o;
}

Scene scene_of(const std::string& objects, const fs::path& file) {
    return parse_scene(
        "{\"camera\": {\"position\": [0, 0, -3], \"look_at\": [0, 0, 0]},\n"
        "\"objects\": [" +
            objects + "]}",
        file);
}

TEST(Accel, ClosestAndAnyHitMatchBruteForceOnAMixtureOfEveryKind) {
    const TempDir dir;
    const Scene s = scene_of(mixture_objects(1, 800, 800), dir.path / "mixture.json");
    EXPECT_EQ(s.unbounded_quadrics.size(), 1u);
    EXPECT_EQ(s.bvh.stats().primitives, 800u + 800u + 6u);
    EXPECT_GT(s.bvh.stats().nodes, 10u);
    // Every primitive outside an instance is tested with the same kernel as brute force, on
    // the same ray: the same t exactly, the same hits and misses
    EXPECT_GT(expect_matches_brute_force(s, 14.0f, 0.0f, 0, 2, 10000), 6000);
}

TEST(Accel, InstancesThatRotateScaleAndMirrorMatchBruteForce) {
    const TempDir dir;
    dir.write("ball.ply", sphere_ply(12, 20));
    std::string objects = mixture_objects(3, 150, 150) + ",\n";
    std::mt19937 rng(4);
    std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
    const char* scales[] = {"0.7", "[1, 0.4, 2]", "[-1, 1, 1]", "[-0.5, -1.5, 0.8]",
                            "[2, 2, -0.3]"};
    for (int i = 0; i < 40; ++i) {
        const Vec3f t = Vec3f(unit(rng), unit(rng), unit(rng)) * 9.0f;
        const Vec3f r = Vec3f(unit(rng), unit(rng), unit(rng)) * 180.0f;
        objects += "{\"type\": \"mesh\", \"file\": \"ball.ply\", \"instance\": true, \"scale\": " +
                   std::string(scales[i % 5]) + ", \"rotate\": [" + std::to_string(r.x) + ", " +
                   std::to_string(r.y) + ", " + std::to_string(r.z) + "], \"translate\": [" +
                   std::to_string(t.x) + ", " + std::to_string(t.y) + ", " + std::to_string(t.z) +
                   "], \"material\": {\"kd\": " + std::to_string(0.3 + 0.01 * i) + "}}" +
                   (i < 39 ? ",\n" : "\n");
    }
    const Scene s = scene_of(objects, dir.path / "instances.json");
    // One file, 40 objects: one set of vertices, one BVH
    size_t with_vertices = 0;
    for (const Mesh& m : s.meshes) with_vertices += m.instanced() && !m.positions.empty();
    EXPECT_EQ(with_vertices, 1u);
    // (an instance maps the ray, brute force maps the vertices: t agrees to rounding, and a
    // ray through an edge may be rounded onto different sides; a third of the rays with the
    // suite's lighter settings, where brute force was the qemu suite's longest test)
    const int rays = test::lighter_settings() ? 2000 : 6000;
    EXPECT_GT(expect_matches_brute_force(s, 14.0f, 2e-4f, rays / 1000, 5, rays), rays / 2);
}

// Rays from points inside a closed mesh towards its vertices and edges: none may escape.
TEST(Accel, NoRayLeaksOutOfAClosedInstancedMeshThroughItsVerticesAndEdges) {
    const TempDir dir;
    dir.write("ball.ply", sphere_ply(16, 24));
    const Scene s = scene_of(
        R"({"type": "mesh", "file": "ball.ply", "instance": true, "scale": [1, 0.5, 2], "rotate": [30, 40, 50],
            "translate": [1, 2, 3], "material": {"kd": 0.5}},
           {"type": "mesh", "file": "ball.ply", "instance": true, "scale": [-2, 1, 1], "rotate": [10, 0, 70],
            "translate": [-5, 0, 0], "material": {"kd": 0.5}})",
        dir.path / "closed.json");
    std::mt19937 rng(6);
    std::uniform_real_distribution<float> unit(-1.0f, 1.0f), frac(0.0f, 1.0f);
    const Mesh& g = s.geometry_of(s.meshes[0]);
    std::uniform_int_distribution<size_t> pick(0, g.triangle_count() - 1);
    for (int r = 0; r < 20000; ++r) {
        const Mesh& m = s.meshes[size_t(r % 2)];
        const size_t tri = pick(rng);
        const Vec3f a = to_world(m, g.positions[g.indices[3 * tri + size_t(r % 3)]]);
        const Vec3f b = to_world(m, g.positions[g.indices[3 * tri + size_t((r + 1) % 3)]]);
        const Vec3f o = to_world(m, Vec3f(unit(rng), unit(rng), unit(rng)) * 0.4f);
        const Vec3f target = r % 2 ? a : fma(b - a, r % 4 == 1 ? 0.5f : frac(rng), a);
        const Ray<float> ray{o, normalize(target - o)};
        Hit hit;
        ASSERT_TRUE(s.intersect(ray, kRayFar, hit)) << "ray " << r << " leaks";
        ASSERT_TRUE(s.occluded(ray, kRayFar)) << "ray " << r << " leaks";
    }
}

// ---- The wavefront's traversal ------------------------------------------------------------
using TestArch = xsimd::default_arch;
using F = Wave<TestArch>::F;
constexpr int K = Wave<TestArch>::K;

// K rays at a time from SoA lanes, as the wavefront sets them up.
Ray<F> batch_of(const std::vector<Ray<float>>& rays, size_t i) {
    alignas(64) float c[6][K];
    for (int l = 0; l < K; ++l) {
        const Ray<float>& r = rays[std::min(i + size_t(l), rays.size() - 1)];
        const float v[6] = {r.o.x, r.o.y, r.o.z, r.d.x, r.d.y, r.d.z};
        for (int k = 0; k < 6; ++k) c[k][l] = v[k];
    }
    const auto at = [&](int k) { return F::load_aligned(c[k]); };
    return {{at(0), at(1), at(2)}, {at(3), at(4), at(5)}};
}

std::vector<Ray<float>> random_rays(size_t n, float extent, uint32_t seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
    std::vector<Ray<float>> rays;
    for (size_t r = 0; r < n; ++r)
        rays.push_back({Vec3f(unit(rng), unit(rng), unit(rng)) * extent, random_direction(rng)});
    return rays;
}

// The wavefront's batch traversal (closest_in_tree: a batch's rays one after another, the
// traversal inlined, its stack and an instance's in one TraversalScratch) lets no ray out of
// closed meshes, one instanced and one not, through their shared vertices and edges.
TEST(Accel, NoRayLeaksOutOfClosedMeshesThroughTheWavefrontBatchTraversal) {
    const TempDir dir;
    dir.write("ball.ply", sphere_ply(16, 24));
    const Scene s = scene_of(
        R"({"type": "mesh", "file": "ball.ply", "instance": true, "scale": [1, 0.5, 2], "rotate": [30, 40, 50],
            "translate": [1, 2, 3], "material": {"kd": 0.5}},
           {"type": "mesh", "file": "ball.ply", "translate": [-5, 0, 0], "material": {"kd": 0.5}})",
        dir.path / "closed.json");
    std::mt19937 rng(11);
    std::uniform_real_distribution<float> unit(-1.0f, 1.0f), frac(0.0f, 1.0f);
    std::vector<Ray<float>> rays;
    for (int r = 0; r < 8000; ++r) {
        // (an instance's geometry is in its own space; the other mesh's is in the world's,
        // centred on the translation)
        const Mesh& m = s.meshes[size_t(r % 2)];
        const Mesh& g = s.geometry_of(m);
        ASSERT_EQ(m.instanced(), r % 2 == 0);
        const auto world = [&](const Vec3f& p) {
            return m.instanced() ? to_world(m, p) : p + Vec3f(-5.0f, 0.0f, 0.0f);
        };
        std::uniform_int_distribution<size_t> pick(0, g.triangle_count() - 1);
        const size_t tri = pick(rng);
        const auto vertex = [&](size_t k) {
            const Vec3f p = g.positions[g.indices[3 * tri + k]];
            return m.instanced() ? to_world(m, p) : p;
        };
        const Vec3f a = vertex(size_t(r % 3)), b = vertex(size_t((r + 1) % 3));
        const Vec3f o = world(Vec3f(unit(rng), unit(rng), unit(rng)) * 0.4f);
        const Vec3f target = r % 3 == 0 ? a : fma(b - a, r % 3 == 1 ? 0.5f : frac(rng), a);
        rays.push_back({o, normalize(target - o)});
    }
    const BvhView bvh = s.bvh.view();
    ASSERT_GT(bvh.instance_count, 0);
    for (size_t i = 0; i < rays.size(); i += K) {
        alignas(64) float t[K];
        std::fill(t, t + K, kRayFar);
        uint32_t hit = 0;
        closest_in_tree<TestArch>(bvh, nullptr, false, batch_of(rays, i), F(0.0f) == F(0.0f), t,
                                  [&](int l, const BvhHit&) { hit |= 1u << l; });
        ASSERT_EQ(hit, (1u << K) - 1u) << "a ray of batch " << i / K << " leaks";
    }
}

// The SIMD node lanes, ray by ray, find exactly what the float lanes find.
TEST(Accel, SimdNodeLanesMatchTheScalarTraversal) {
    const TempDir dir;
    dir.write("ball.ply", sphere_ply(12, 20));
    const Scene s = scene_of(mixture_objects(7, 500, 500) + R"(,
        {"type": "mesh", "file": "ball.ply", "instance": true, "scale": [-1, 2, 1], "translate": [3, 0, 0],
         "material": {"kd": 0.5}},
        {"type": "mesh", "file": "ball.ply", "instance": true, "rotate": [0, 45, 0], "material": {"kd": 0.6}})",
                             dir.path / "simd.json");
    const std::vector<Ray<float>> rays = random_rays(8000, 14.0f, 8);
    int hits = 0;
    for (size_t i = 0; i < rays.size(); i += K) {
        const WideRays<TestArch> wide(batch_of(rays, i));
        for (int l = 0; l < K && i + size_t(l) < rays.size(); ++l) {
            const TraversalRay r = make_traversal_ray(rays[i + size_t(l)].o, rays[i + size_t(l)].d);
            float t_scalar = kRayFar, t_simd = kRayFar;
            BvhHit a{}, b{};
            const bool ha = traverse<false, float>(s.bvh.view(), r, t_scalar, a);
            const bool hb =
                traverse<false, NodeLanes<TestArch>>(s.bvh.view(), wide.lane(l), t_simd, b);
            ASSERT_EQ(ha, hb) << "ray " << i + size_t(l);
            float any_a = kRayFar, any_b = kRayFar;
            const bool any_scalar = traverse<true, float>(s.bvh.view(), r, any_a, a);
            using N = NodeLanes<TestArch>;
            EXPECT_EQ(any_scalar, (traverse<true, N>(s.bvh.view(), wide.lane(l), any_b, b)));
            if (!ha) continue;
            ++hits;
            // The same primitive; a triangle at exactly the same t (its kernel never fuses),
            // a sphere or quadric to rounding (their dot products fuse where the ISA has
            // FMA, as std::fma always does)
            EXPECT_EQ(a.kind, b.kind) << "ray " << i + size_t(l);
            if (a.kind == kLeafTriangles) {
                EXPECT_EQ(t_scalar, t_simd) << "ray " << i + size_t(l);
            } else {
                EXPECT_NEAR(t_scalar, t_simd, 4e-6f * (t_scalar + 14.0f))
                    << "ray " << i + size_t(l);
            }
        }
    }
    EXPECT_GT(hits, 3000);
}

// A one-node tree tested K rays at a time finds what single rays find.
TEST(Accel, PacketsOverAOneNodeTreeMatchSingleRays) {
    const TempDir dir;
    for (uint32_t seed = 10; seed < 16; ++seed) {
        const int spheres = int(seed % 3) * 3, triangles = 6 - spheres;
        const Scene s =
            scene_of(mixture_objects(seed, spheres, triangles, 2), dir.path / "small.json");
        ASSERT_TRUE(packet_tree(s.bvh.view())) << "seed " << seed;
        const std::vector<Ray<float>> rays = random_rays(4000, 14.0f, seed);
        for (size_t i = 0; i < rays.size(); i += K) {
            const Ray<F> ray = batch_of(rays, i);
            const Vec3<F> inv(F(1.0f) / ray.d.x, F(1.0f) / ray.d.y, F(1.0f) / ray.d.z);
            F t(kRayFar);
            Wave<TestArch>::I kind(0), lane(0), instance(-1);
            const uint32_t hits =
                mask_bits(packet_traverse<false>(s.bvh.view(), ray, inv, make_ray_shear(ray.d),
                                                 F(0.0f) == F(0.0f), t, kind, lane, instance));
            F t_any(kRayFar);
            const uint32_t any =
                mask_bits(packet_traverse<true>(s.bvh.view(), ray, inv, make_ray_shear(ray.d),
                                                F(0.0f) == F(0.0f), t_any, kind, lane, instance));
            alignas(64) float ts[K];
            t.store_aligned(ts);
            for (int l = 0; l < K && i + size_t(l) < rays.size(); ++l) {
                // A triangle at exactly the same t (its kernel never fuses); a sphere or
                // quadric to rounding (the compiler may fuse their products differently where
                // the two paths inline them, as it does on aarch64, and a quadric's root near
                // a tangent magnifies that)
                float want = kRayFar;
                BvhHit h;
                const bool single = traverse<false, NodeLanes<TestArch>>(
                    s.bvh.view(), WideRays<TestArch>(ray).lane(l), want, h);
                EXPECT_EQ(bool((hits >> l) & 1u), single)
                    << "seed " << seed << " ray " << i + size_t(l);
                EXPECT_EQ(bool((any >> l) & 1u), single)
                    << "seed " << seed << " ray " << i + size_t(l);
                if (single && h.kind == kLeafTriangles) {
                    EXPECT_EQ(ts[l], want);
                } else if (single) {
                    EXPECT_NEAR(ts[l], want, 5e-5f * (want + 14.0f));
                }
            }
        }
    }
}

// Camera rays (one origin) as packets through a deep tree with instances find what single
// rays find: the same primitive and instance, t to rounding (an instance maps the packet
// with vector arithmetic, a single ray with scalar), a ray through an edge excepted.
TEST(Accel, PacketsOfCameraRaysMatchSingleRaysThroughInstances) {
    const TempDir dir;
    dir.write("ball.ply", sphere_ply(12, 20));
    const Scene s = scene_of(mixture_objects(40, 400, 400) + R"(,
        {"type": "mesh", "file": "ball.ply", "instance": true, "scale": [-1, 2, 1], "translate": [3, 0, 0],
         "material": {"kd": 0.5}},
        {"type": "mesh", "file": "ball.ply", "instance": true, "scale": 3, "rotate": [0, 45, 10],
         "material": {"kd": 0.6}})",
                             dir.path / "camera.json");
    ASSERT_GT(s.bvh.stats().nodes, 8u);
    std::mt19937 rng(41);
    std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
    int hits = 0, disagreements = 0, through_instances = 0;
    for (int b = 0; b < 600; ++b) {
        // A pinhole at a random place, looking through K neighbouring pixels
        const Vec3f eye = Vec3f(unit(rng), unit(rng), unit(rng)) * 12.0f;
        const Vec3f look = random_direction(rng);
        std::vector<Ray<float>> rays;
        for (int l = 0; l < K; ++l)
            rays.push_back(
                {eye, normalize(look + Vec3f(0.002f * float(l), 0.001f * float(l % 3), 0.0f))});
        const Ray<F> ray = batch_of(rays, 0);
        ASSERT_TRUE(coherent(ray));
        const Vec3<F> inv(F(1.0f) / ray.d.x, F(1.0f) / ray.d.y, F(1.0f) / ray.d.z);
        F t(kRayFar);
        Wave<TestArch>::I kind(0), lane(0), instance(-1);
        const uint32_t got =
            mask_bits(packet_traverse<false>(s.bvh.view(), ray, inv, make_ray_shear(ray.d),
                                             F(0.0f) == F(0.0f), t, kind, lane, instance));
        alignas(64) float ts[K];
        alignas(64) int32_t kinds[K], lanes[K], instances[K];
        t.store_aligned(ts), kind.store_aligned(kinds), lane.store_aligned(lanes);
        instance.store_aligned(instances);
        const WideRays<TestArch> wide(ray);
        for (int l = 0; l < K; ++l) {
            float want = kRayFar;
            BvhHit h;
            const bool single =
                traverse<false, NodeLanes<TestArch>>(s.bvh.view(), wide.lane(l), want, h);
            if (bool((got >> l) & 1u) != single) {
                ++disagreements;
                continue;
            }
            if (!single) continue;
            ++hits;
            through_instances += h.instance >= 0;
            EXPECT_NEAR(ts[l], want, 1e-5f * (want + 12.0f));
            if (std::abs(ts[l] - want) > 1e-6f * want) continue;  // (a near tie: either may win)
            EXPECT_EQ(uint32_t(kinds[l]), h.kind);
            EXPECT_EQ(instances[l], h.instance);
            if (h.kind != kLeafQuadrics) {
                const BvhHit p{uint32_t(kinds[l]), uint32_t(lanes[l]), instances[l]};
                if (h.kind == kLeafTriangles) {
                    EXPECT_EQ(hit_triangle(s.bvh.view(), p), hit_triangle(s.bvh.view(), h));
                }
            }
        }
    }
    EXPECT_GT(hits, 1000);
    EXPECT_GT(through_instances, 20);
    EXPECT_LE(disagreements, 3);
}

// Ray streams (kernels/bvh/traverse_stream.h) find what single rays find: whether a ray hits,
// the same t bit for bit (the same kernels), and the same primitive but on an exact tie of
// two primitives' distances, where either may be named; with every stream cut-off, from
// streams traced node by node to the leaves (1) to streams that go one ray at a time from
// the root (more rays than the stream). Trees with quadrics or instances are not streamed.
TEST(Accel, RayStreamsFindWhatSingleRaysFind) {
    const TempDir dir;
    dir.write("ball.ply", sphere_ply(40, 60));
    const Scene s = scene_of(mixture_objects(21, 400, 1500, 0) + R"(,
        {"type": "mesh", "file": "ball.ply", "scale": [3, 3, 3], "translate": [2, 1, 0], "material": {"kd": 0.5}})",
                             dir.path / "stream.json");
    const BvhView bvh = s.bvh.view();
    ASSERT_TRUE(stream_tree(bvh, false));
    EXPECT_FALSE(stream_tree(bvh, true)) << "alpha masks are not streamed";
    const Scene quadrics = scene_of(mixture_objects(22, 40, 150, 6), dir.path / "quadrics.json");
    EXPECT_FALSE(stream_tree(quadrics.bvh.view(), false)) << "quadric leaves are not streamed";

    using N = NodeLanes<TestArch>;
    const std::vector<Ray<float>> rays = random_rays(3000, 14.0f, 23);
    const int n = int(rays.size());
    std::vector<TraversalRay> setup;
    for (const Ray<float>& r : rays) setup.push_back(make_traversal_ray(r.o, r.d));
    // What single rays find
    std::vector<float> want_t(rays.size(), kRayFar);
    std::vector<BvhHit> want(rays.size());
    std::vector<uint8_t> want_found(rays.size());
    int hits = 0;
    for (int r = 0; r < n; ++r) {
        want_found[size_t(r)] =
            traverse<false, N>(bvh, setup[size_t(r)], want_t[size_t(r)], want[size_t(r)]);
        hits += want_found[size_t(r)];
    }
    ASSERT_GT(hits, 1000);
    for (const int single_below : {1, 2, 4, 16, 100000}) {
        std::vector<float> t(rays.size(), kRayFar);
        std::vector<BvhHit> got(rays.size());
        std::vector<uint8_t> found(rays.size()), masks(rays.size());
        std::vector<uint16_t> ids(stream_scratch_ids(n));
        for (int r = 0; r < n; ++r) ids[size_t(r)] = uint16_t(r);
        stream_closest<N>(bvh, setup.data(), n, t.data(), got.data(), found.data(), ids.data(),
                          masks.data(), single_below);
        int ties = 0;
        for (size_t r = 0; r < rays.size(); ++r) {
            ASSERT_EQ(found[r], want_found[r]) << "ray " << r << ", streams below " << single_below;
            ASSERT_EQ(t[r], want_t[r]) << "ray " << r << ", streams below " << single_below;
            if (!found[r] || (got[r].kind == want[r].kind && got[r].lane == want[r].lane)) continue;
            // Another primitive: it must be hit at exactly the same distance
            ++ties;
            ASSERT_EQ(got[r].kind, uint32_t(kLeafTriangles)) << "ray " << r;
            const float(*v)[kWideBvhWidth] = bvh.triangles[got[r].lane / kWideBvhWidth].v;
            const uint32_t l = got[r].lane % kWideBvhWidth;
            const Vec3f v0{v[0][l], v[1][l], v[2][l]}, v1{v[3][l], v[4][l], v[5][l]},
                v2{v[6][l], v[7][l], v[8][l]};
            float th, b1, b2;
            ASSERT_TRUE(intersect_triangle(rays[r], make_ray_shear(rays[r].d), v0, v1, v2, kRayFar,
                                           th, b1, b2))
                << "ray " << r;
            EXPECT_EQ(th, t[r]) << "ray " << r;
        }
        EXPECT_LE(ties, 3) << "streams below " << single_below;
    }
}

// ---- Many rays in flight (kernels/bvh/traverse_group.h) ---------------------------------------
// What one ray at a time finds through `bvh`: closest hit and any hit.
struct SingleRayHits {
    std::vector<float> t;
    std::vector<BvhHit> hit;
    std::vector<uint8_t> found, blocked;
};
template <class N>
SingleRayHits single_ray_hits(const BvhView& bvh, const std::vector<TraversalRay>& rays,
                              const std::vector<float>& tmax, const AlphaTable* alpha) {
    SingleRayHits s{tmax, std::vector<BvhHit>(rays.size()), std::vector<uint8_t>(rays.size()),
                    std::vector<uint8_t>(rays.size())};
    for (size_t r = 0; r < rays.size(); ++r) {
        s.found[r] = traverse<false, N>(bvh, rays[r], s.t[r], s.hit[r], alpha);
        float t = tmax[r];
        BvhHit unused;
        s.blocked[r] = traverse<true, N>(bvh, rays[r], t, unused, alpha);
    }
    return s;
}

// Groups of every size find exactly what single rays find, for closest and any hit: the
// same rays hit, at the same t bit for bit, the same primitive of the same kind through the
// same instance. `hits`: how many rays hit.
template <class N>
void expect_groups_match_single_rays(const BvhView& bvh, const std::vector<Ray<float>>& rays,
                                     uint32_t seed, int& hits, const AlphaTable* alpha = nullptr) {
    std::mt19937 rng(seed);
    std::vector<TraversalRay> setup;
    std::vector<float> tmax;
    for (size_t r = 0; r < rays.size(); ++r) {
        setup.push_back(make_traversal_ray(rays[r].o, rays[r].d));
        // (a quarter of the rays end early: shadow rays' segments)
        tmax.push_back(r % 4 == 3 ? 0.5f + 10.0f * frac_of(rng) : kRayFar);
    }
    const SingleRayHits want = single_ray_hits<N>(bvh, setup, tmax, alpha);
    hits = int(std::count(want.found.begin(), want.found.end(), 1));
    auto scratch = std::make_unique<TraversalGroupScratch>();
    const int n = int(rays.size());
    for (const int group : {1, 2, 3, 7, 16, kMaxTraversalGroup}) {
        SCOPED_TRACE("group of " + std::to_string(group));
        std::vector<float> t = tmax, any_t = tmax;
        std::vector<BvhHit> hit(rays.size(), BvhHit{7, 7, 7}),
            any_hit(rays.size(), BvhHit{7, 7, 7});
        std::vector<uint8_t> found(rays.size(), 9), blocked(rays.size(), 9);
        traverse_group<false, N>(bvh, setup.data(), n, t.data(), hit.data(), found.data(), group,
                                 *scratch, alpha);
        traverse_group<true, N>(bvh, setup.data(), n, any_t.data(), any_hit.data(), blocked.data(),
                                group, *scratch, alpha);
        for (size_t r = 0; r < rays.size(); ++r) {
            ASSERT_EQ(found[r], want.found[r]) << "ray " << r;
            ASSERT_EQ(std::bit_cast<uint32_t>(t[r]), std::bit_cast<uint32_t>(want.t[r]))
                << "ray " << r;
            ASSERT_EQ(blocked[r], want.blocked[r]) << "ray " << r;
            // (any hit leaves t and the hit as they were)
            ASSERT_EQ(any_t[r], tmax[r]) << "ray " << r;
            ASSERT_EQ(any_hit[r].kind, 7u) << "ray " << r;
            if (!found[r]) {
                ASSERT_EQ(hit[r].kind, 7u) << "ray " << r << ": a miss writes no hit";
                continue;
            }
            ASSERT_EQ(hit[r].kind, want.hit[r].kind) << "ray " << r;
            ASSERT_EQ(hit[r].lane, want.hit[r].lane) << "ray " << r;
            ASSERT_EQ(hit[r].instance, want.hit[r].instance) << "ray " << r;
        }
    }
}

// Every primitive kind the tree holds (spheres, loose triangles, bounded quadrics, a mesh),
// instances that rotate, scale and mirror, and a masked mesh with a constant alpha of 0.5
// (half of its hits pass, by the ray's hash): deep enough that many rays are in flight at
// once, with the scalar and the SIMD node lanes.
TEST(Accel, GroupsOfRaysInFlightFindWhatSingleRaysFind) {
    const TempDir dir;
    dir.write("ball.ply", sphere_ply(30, 40));
    std::string objects = mixture_objects(31, 600, 1500, 8) + R"(,
        {"type": "mesh", "file": "ball.ply", "scale": 2.5, "translate": [-3, 2, 1], "material": {"kd": 0.5}},
        {"type": "mesh", "file": "ball.ply", "scale": [1, 3, 0.5], "translate": [4, -2, 3],
         "material": {"kd": 0.4, "alpha": 0.5}})";
    std::mt19937 rng(32);
    std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
    const char* scales[] = {"0.7", "[1, 0.4, 2]", "[-1, 1, 1]", "[-0.5, -1.5, 0.8]"};
    for (int i = 0; i < 12; ++i) {
        const Vec3f t = Vec3f(unit(rng), unit(rng), unit(rng)) * 8.0f;
        objects +=
            ",\n{\"type\": \"mesh\", \"file\": \"ball.ply\", \"instance\": true, \"scale\": " +
            std::string(scales[i % 4]) + ", \"rotate\": [" + std::to_string(30 * i) +
            ", 20, 10], \"translate\": [" + std::to_string(t.x) + ", " + std::to_string(t.y) +
            ", " + std::to_string(t.z) + "], \"material\": {\"kd\": 0.3}}";
    }
    const Scene s = scene_of(objects, dir.path / "group.json");
    const BvhView bvh = s.bvh.view();
    ASSERT_TRUE(s.alpha());
    ASSERT_GT(bvh.node_count, 200);
    ASSERT_EQ(bvh.instance_count, 12);
    const int n = test::lighter_settings() ? 1500 : 5000;
    const std::vector<Ray<float>> rays = random_rays(size_t(n), 12.0f, 33);
    int hits = 0;
    expect_groups_match_single_rays<NodeLanes<TestArch>>(bvh, rays, 34, hits, s.alpha());
    EXPECT_GT(hits, n / 2);
    expect_groups_match_single_rays<float>(bvh, rays, 35, hits, s.alpha());
    EXPECT_GT(hits, n / 2);
}

// Degenerate trees: one primitive (a single leaf under the root), slivers of 1e-6 among
// ordinary triangles, a triangle spanning the whole scene, and an empty tree.
TEST(Accel, GroupsOfRaysInFlightOnDegenerateTrees) {
    const TempDir dir;
    using N = NodeLanes<TestArch>;
    const std::vector<Ray<float>> rays = random_rays(800, 6.0f, 41);
    const Scene one =
        scene_of(R"({"type": "sphere", "center": [0, 0, 0], "radius": 2, "material": {"kd": 0.5}})",
                 dir.path / "one.json");
    ASSERT_EQ(one.bvh.view().node_count, 1);
    int hits = 0;
    expect_groups_match_single_rays<N>(one.bvh.view(), rays, 42, hits);
    EXPECT_GT(hits, 30);
    std::string slivers = mixture_objects(43, 0, 400, 0);
    std::mt19937 rng(44);
    std::uniform_real_distribution<float> unit(-5.0f, 5.0f);
    for (int i = 0; i < 300; ++i) {
        const float x = unit(rng), y = unit(rng), z = unit(rng);
        slivers += ",\n{\"type\": \"triangle\", \"vertices\": [[" + std::to_string(x) + ", " +
                   std::to_string(y) + ", " + std::to_string(z) + "], [" + std::to_string(x + 3) +
                   ", " + std::to_string(y) + ", " + std::to_string(z) + "], [" +
                   std::to_string(x + 3) + ", " + std::to_string(y + 1e-6f) + ", " +
                   std::to_string(z) + "]], \"material\": {\"kd\": 0.2}}";
    }
    slivers += R"(,
        {"type": "triangle", "vertices": [[-50, -40, 0.3], [50, -40, 0.2], [0, 60, -0.1]], "material": {"kd": 0.9}})";
    const Scene thin = scene_of(slivers, dir.path / "slivers.json");
    ASSERT_GT(thin.bvh.view().node_count, 8);
    expect_groups_match_single_rays<N>(thin.bvh.view(), rays, 45, hits);
    EXPECT_GT(hits, 300);
    // Nothing in the tree: every ray misses
    const BvhView empty;
    std::vector<TraversalRay> setup(10, make_traversal_ray(Vec3f(0.0f), Vec3f(0, 0, 1)));
    std::vector<float> t(10, kRayFar);
    std::vector<BvhHit> hit(10);
    std::vector<uint8_t> found(10, 1);
    auto scratch = std::make_unique<TraversalGroupScratch>();
    traverse_group<false, N>(empty, setup.data(), 10, t.data(), hit.data(), found.data(), 4,
                             *scratch);
    EXPECT_EQ(std::count(found.begin(), found.end(), 0), 10);
}

// The wavefront with many rays in flight (a tree over kPrefetchAbove nodes) renders the same
// image, bit for bit, as with one ray at a time, with groups of 16 and 5, on every ISA: closest
// hits of every path (report), queued shadow rays (point lights and emitter samples, with a second
// lobe kind; and a scene of one lobe kind, whose emitter samples one ray at a time trace during
// shading), light paths and bdpt.
TEST(Accel, GroupedWavefrontStagesRenderTheSameImage) {
    const TempDir dir;
    dir.write("ball.ply", sphere_ply(80, 120));
    const auto scene_with = [&](bool lights) {
        return parse_scene(
            R"({
            "camera": {"position": [0, 1, -6], "look_at": [0, 0, 0], "vfov": 60},
            "render": {"width": 20, "height": 16, "spp": 4, "seed": 3},
            "materials": {"floor": {"kd": 0.6}, "lamp": {"emission": 4},
                          "shiny": )" +
                std::string(lights ? R"({"kd": 0.3, "ks": 0.4, "shininess": 30})"
                                   : R"({"kd": 0.3})") +
                R"(},
            "objects": [)" +
                mixture_objects(51, 300, 600, 4) + R"(,
                {"type": "mesh", "file": "ball.ply", "scale": 1.5, "material": "shiny"},
                {"type": "mesh", "file": "ball.ply", "instance": true, "scale": 0.8,
                 "translate": [2.5, 0, 1], "material": "floor"},
                {"type": "sphere", "center": [0, 6, 0], "radius": 1, "material": "lamp"}],
            "lights": )" +
                std::string(lights ? R"([{"position": [-2, 5, -3], "intensity": 30}])" : "[]") + R"(
        })",
            dir.path / "grouped.json");
    };
    const Scene with_lights = scene_with(true), plain = scene_with(false);
    ASSERT_GT(plain.bvh.view().node_count, int32_t(kPrefetchAbove)) << "a tree that is prefetched";
    const std::pair<const Scene*, const char*> cases[] = {
        {&with_lights, "report"}, {&with_lights, "nee"},  {&with_lights, "mis"},
        {&with_lights, "lt"},     {&with_lights, "bdpt"}, {&plain, "mis"}};
    for (const auto& [s, estimator] : cases) {
        Scene scene = *s;
        use_estimator(scene.settings.estimator, *parse_estimator(estimator));
        for (Isa isa : compiled_isas()) {
            if (!isa_supported(isa)) continue;
            SCOPED_TRACE(std::string(estimator) + (s == &plain ? " (one lobe kind) " : " ") +
                         isa_name(isa));
            std::vector<std::vector<float>> images;
            for (const int group : {1, 16, 5}) {
                RenderOptions o;
                o.isa = isa_name(isa);
                o.threads = 1;
                o.progress = false;
                o.ray_group = group;
                const RenderResult r = render(scene, o);
                EXPECT_EQ(r.stats.ray_group, group);
                images.push_back(r.film.mean().rgb);
            }
            EXPECT_EQ(images[0], images[1]);
            EXPECT_EQ(images[0], images[2]);
        }
    }
}

// ---- Degenerate and extreme inputs --------------------------------------------------------
// Builds and traces without a NaN or a crash; what can be hit is hit.
void expect_sane(const Scene& s, float extent, uint32_t seed) {
    for (const Ray<float>& ray : random_rays(4000, extent, seed)) {
        Hit hit;
        if (!s.intersect(ray, kRayFar, hit)) continue;
        ASSERT_TRUE(std::isfinite(hit.t) && hit.t > 0.0f);
        ASSERT_TRUE(std::isfinite(hit.n.x) && std::isfinite(hit.n.y) && std::isfinite(hit.n.z));
        s.occluded(ray, hit.t);
    }
}

TEST(Accel, EveryPrimitiveAtOnePoint) {
    const TempDir dir;
    std::string o;
    for (int i = 0; i < 600; ++i)
        o += "{\"type\": \"sphere\", \"center\": [1, 2, 3], \"radius\": " +
             std::to_string(0.5 + 0.001 * i) + ", \"material\": {\"kd\": 0.5}},\n";
    for (int i = 0; i < 600; ++i)
        o += "{\"type\": \"triangle\", \"vertices\": [[1, 2, 3], [1, 2, 3], [1, 2, 3]], "
             "\"material\": {\"kd\": 0.5}},\n";
    o += "{\"type\": \"triangle\", \"vertices\": [[0, 0, 3], [2, 0, 3], [0, 4, 3]], "
         "\"material\": {\"kd\": 0.5}}";
    const Scene s = scene_of(o, dir.path / "point.json");
    EXPECT_EQ(s.bvh.stats().primitives, 601u);  // the 600 zero-area triangles are left out
    EXPECT_LE(s.bvh.stats().depth, kBvhMaxDepth);
    // From outside, the largest sphere is hit first
    Hit hit;
    ASSERT_TRUE(s.intersect({{1, 2, -10}, {0, 0, 1}}, kRayFar, hit));
    EXPECT_NEAR(hit.t, 13.0f - 1.099f, 1e-4f);
    expect_sane(s, 5.0f, 20);
}

TEST(Accel, TinyAndHugeSpheresTogether) {
    const TempDir dir;
    std::string o;
    std::mt19937 rng(21);
    std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
    for (int i = 0; i < 500; ++i)
        o += "{\"type\": \"sphere\", \"center\": [" + std::to_string(unit(rng)) + ", " +
             std::to_string(unit(rng)) + ", " + std::to_string(unit(rng)) +
             "], \"radius\": 1e-6, \"material\": {\"kd\": 0.5}},\n";
    o += "{\"type\": \"sphere\", \"center\": [0, 0, 0], \"radius\": 1e6, \"material\": {\"kd\": "
         "0.5}},\n";
    o += "{\"type\": \"sphere\", \"center\": [3e6, 0, 0], \"radius\": 1e6, \"material\": {\"kd\": "
         "0.5}}";
    const Scene s = scene_of(o, dir.path / "scales.json");
    expect_sane(s, 2.0f, 22);
    // A ray aimed at a tiny sphere hits it, not the huge one around it
    const Vec3f c{s.spheres.cx[7], s.spheres.cy[7], s.spheres.cz[7]};
    const Vec3f from = c + Vec3f(0.3f, -0.2f, 0.1f);
    Hit hit;
    ASSERT_TRUE(s.intersect({from, normalize(c - from)}, kRayFar, hit));
    EXPECT_NEAR(hit.t, length(c - from) - 1e-6f, 1e-6f);
    // From inside the huge sphere, every ray hits something within its radius
    for (const Ray<float>& ray : random_rays(1000, 1.0f, 23)) {
        ASSERT_TRUE(s.intersect(ray, kRayFar, hit));
        EXPECT_LT(hit.t, 1.0001e6f);
    }
}

TEST(Accel, ARayWithANaNDirectionHitsNothing) {
    // (a NaN slab distance leaves a box's interval as it was, so such a ray enters every
    // box: the traversal must still end, and report nothing it cannot hit)
    const TempDir dir;
    dir.write("ball.ply", sphere_ply(8, 12));
    const Scene s = scene_of(mixture_objects(30, 300, 300) + R"(,
        {"type": "mesh", "file": "ball.ply", "instance": true, "material": {"kd": 0.5}},
        {"type": "mesh", "file": "ball.ply", "instance": true, "translate": [3, 0, 0], "material": {"kd": 0.5}})",
                             dir.path / "nan.json");
    const float nan = std::numeric_limits<float>::quiet_NaN();
    for (const Vec3f d : {Vec3f(nan, 0, 0), Vec3f(nan, nan, nan), Vec3f(0, nan, 1)}) {
        Hit hit;
        EXPECT_FALSE(s.intersect({{0.1f, 0.2f, 0.3f}, d}, kRayFar, hit));
        EXPECT_FALSE(s.occluded({{0.1f, 0.2f, 0.3f}, d}, kRayFar));
        const TraversalRay r = make_traversal_ray({0.1f, 0.2f, 0.3f}, d);
        float t = kRayFar;
        BvhHit h;
        EXPECT_FALSE((traverse<false, NodeLanes<TestArch>>(s.bvh.view(), r, t, h)));
        t = kRayFar;
        EXPECT_FALSE((traverse<true, NodeLanes<TestArch>>(s.bvh.view(), r, t, h)));
    }
}

TEST(Accel, AMillionTrianglesInOnePlane) {
    // 708 x 708 unit squares, two triangles each, all in z = 0: every box is flat
    constexpr int n = 708;
    std::vector<Vec3f> positions;
    std::vector<uint32_t> indices;
    for (int j = 0; j <= n; ++j)
        for (int i = 0; i <= n; ++i) positions.push_back({float(i), float(j), 0.0f});
    for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) {
            const uint32_t p = uint32_t(j * (n + 1) + i), q = p + uint32_t(n + 1);
            indices.insert(indices.end(), {p, p + 1, q + 1, p, q + 1, q});
        }
    Bvh bvh;
    bvh.build(positions, indices);
    EXPECT_EQ(bvh.stats().primitives, indices.size() / 3);
    EXPECT_GE(bvh.stats().primitives, 1000000u);
    std::mt19937 rng(24);
    std::uniform_real_distribution<float> at(0.0f, float(n));
    for (int r = 0; r < 2000; ++r) {
        const Vec3f target{at(rng), at(rng), 0.0f};
        const Vec3f o = target + Vec3f(0.3f, -0.2f, r % 2 ? 5.0f : -5.0f);
        TriangleHit hit;
        ASSERT_TRUE(bvh.intersect({o, normalize(target - o)}, kRayFar, hit)) << "ray " << r;
        EXPECT_NEAR(hit.t, length(target - o), 1e-3f);
        // In the plane and parallel to it: nothing
        EXPECT_FALSE(bvh.occluded({target + Vec3f(0, 0, 1e-3f), {1, 0, 0}}, kRayFar));
    }
}

}  // namespace
}  // namespace cierzo
