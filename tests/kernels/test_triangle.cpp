// Tests of the watertight ray/triangle kernel (kernels/triangle.h): known answers, faces, t
// range, degenerate triangles, rays through shared edges and vertices of closed meshes, and
// the batch (SIMD across rays) variant against the scalar one.
#include "kernels/triangle.h"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstring>
#include <random>
#include <vector>

namespace cierzo {
namespace {

using Batch = xsimd::batch<float>;
constexpr int kLanes = int(Batch::size);

struct Hit {
    bool hit;
    float t, b1, b2;
};

Hit shoot(const Vec3f& o, const Vec3f& d, const Vec3f& v0, const Vec3f& v1, const Vec3f& v2,
          float tmax = 1e30f) {
    const Ray<float> ray{o, d};
    Hit h{};
    h.hit = intersect_triangle(ray, make_ray_shear(d), v0, v1, v2, tmax, h.t, h.b1, h.b2);
    return h;
}

// Rotates the coordinates (x, y, z) -> (y, z, x) `times` times, to move the dominant axis.
Vec3f cycle(const Vec3f& v, int times) {
    Vec3f r = v;
    for (int i = 0; i < times; ++i) {
        r = {r.y, r.z, r.x};
    }
    return r;
}

// ---- A closed mesh: the surface of a lattice cube, optionally pushed onto a sphere ----------
struct Mesh {
    std::vector<Vec3f> positions;
    std::vector<std::array<uint32_t, 3>> triangles;
    std::vector<std::array<uint32_t, 2>> edges;  // every triangle edge (shared ones twice)
};

// The six faces of an n x n x n lattice cube, two triangles per cell with alternating
// diagonals. Every vertex is computed once from its lattice coordinates, so neighbouring
// triangles share bit-identical positions. `spherical` moves the vertices onto the unit
// sphere, making no two triangles coplanar.
Mesh lattice_cube(int n, bool spherical) {
    Mesh mesh;
    std::vector<int> id((n + 1) * (n + 1) * (n + 1), -1);
    const auto vertex = [&](int i, int j, int k) {
        int& slot = id[(i * (n + 1) + j) * (n + 1) + k];
        if (slot < 0) {
            Vec3f p(-1.0f + 2.0f * float(i) / float(n), -1.0f + 2.0f * float(j) / float(n),
                    -1.0f + 2.0f * float(k) / float(n));
            if (spherical) {
                p = normalize(p);
            }
            slot = int(mesh.positions.size());
            mesh.positions.push_back(p);
        }
        return uint32_t(slot);
    };
    // For each face: a lattice point from two in-face coordinates
    for (int axis = 0; axis < 3; ++axis) {
        for (int side = 0; side <= n; side += n) {
            const auto at = [&](int a, int b) {
                int c[3];
                c[axis] = side;
                c[(axis + 1) % 3] = a;
                c[(axis + 2) % 3] = b;
                return vertex(c[0], c[1], c[2]);
            };
            for (int a = 0; a < n; ++a) {
                for (int b = 0; b < n; ++b) {
                    const uint32_t p00 = at(a, b), p10 = at(a + 1, b), p01 = at(a, b + 1),
                                   p11 = at(a + 1, b + 1);
                    if ((a + b) % 2 == 0) {
                        mesh.triangles.push_back({p00, p10, p11});
                        mesh.triangles.push_back({p00, p11, p01});
                    } else {
                        mesh.triangles.push_back({p00, p10, p01});
                        mesh.triangles.push_back({p10, p11, p01});
                    }
                }
            }
        }
    }
    for (const auto& t : mesh.triangles) {
        mesh.edges.push_back({t[0], t[1]});
        mesh.edges.push_back({t[1], t[2]});
        mesh.edges.push_back({t[2], t[0]});
    }
    return mesh;
}

// The regular octahedron: 8 faces meeting at 6 vertices on the axes.
Mesh octahedron() {
    Mesh mesh;
    mesh.positions = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
    for (uint32_t x : {0u, 1u}) {
        for (uint32_t y : {2u, 3u}) {
            for (uint32_t z : {4u, 5u}) {
                mesh.triangles.push_back({x, y, z});
            }
        }
    }
    for (const auto& t : mesh.triangles) {
        mesh.edges.push_back({t[0], t[1]});
        mesh.edges.push_back({t[1], t[2]});
        mesh.edges.push_back({t[2], t[0]});
    }
    return mesh;
}

// How many triangles of the mesh a ray hits (scalar kernel).
int count_hits(const Mesh& mesh, const Vec3f& o, const Vec3f& d) {
    int hits = 0;
    for (const auto& t : mesh.triangles) {
        hits += shoot(o, d, mesh.positions[t[0]], mesh.positions[t[1]], mesh.positions[t[2]]).hit;
    }
    return hits;
}

// The same count with the scalar kernel inlined into code compiled for FMA, where GCC fuses
// a*b - c*d into fma(a, b, -c*d) unless the kernel prevents it (that would open gaps along
// shared edges), so this build checks the FMA-enabled code too. x86-64 needs a target
// attribute (and a CPU with FMA) for that; on aarch64 FMA is in the base ISA, so every build
// is one, and the inlined copy is what GCC fuses.
#if defined(__GNUC__) && defined(__x86_64__)
#define CIERZO_TEST_FMA 1
#define CIERZO_FMA_TARGET gnu::target("avx2,fma"),
bool cpu_has_fma() { return __builtin_cpu_supports("fma"); }
#elif defined(__GNUC__) && defined(__aarch64__)
#define CIERZO_TEST_FMA 1
#define CIERZO_FMA_TARGET
bool cpu_has_fma() { return true; }
#endif
#if CIERZO_TEST_FMA
[[CIERZO_FMA_TARGET gnu::flatten]] int count_hits_fma(const Mesh& mesh, const Vec3f& o,
                                                      const Vec3f& d) {
    const Ray<float> ray{o, d};
    const RayShear<float> shear = make_ray_shear(d);
    int hits = 0;
    for (const auto& t : mesh.triangles) {
        float th, b1, b2;
        hits += intersect_triangle(ray, shear, mesh.positions[t[0]], mesh.positions[t[1]],
                                   mesh.positions[t[2]], 1e30f, th, b1, b2);
    }
    return hits;
}
#endif

// How many triangles every lane of a batch of rays hits (batch kernel, one triangle for all).
std::array<int, kLanes> count_hits_batch(const Mesh& mesh, const Ray<Batch>& ray) {
    std::array<int, kLanes> hits{};
    const RayShear<Batch> shear = make_ray_shear(ray.d);
    for (const auto& t : mesh.triangles) {
        Batch th, b1, b2;
        const auto m = intersect_triangle(
            ray, shear, Vec3<Batch>(mesh.positions[t[0]]), Vec3<Batch>(mesh.positions[t[1]]),
            Vec3<Batch>(mesh.positions[t[2]]), Batch(1e30f), th, b1, b2);
        alignas(64) float lane[kLanes];
        select(m, Batch(1.0f), Batch(0.0f)).store_aligned(lane);
        for (int i = 0; i < kLanes; ++i) {
            hits[i] += lane[i] != 0.0f;
        }
    }
    return hits;
}

Ray<Batch> gather_rays(const std::vector<Vec3f>& o, const std::vector<Vec3f>& d, size_t first) {
    alignas(64) float c[6][kLanes];
    for (int i = 0; i < kLanes; ++i) {
        const Vec3f& oi = o[first + i];
        const Vec3f& di = d[first + i];
        c[0][i] = oi.x, c[1][i] = oi.y, c[2][i] = oi.z;
        c[3][i] = di.x, c[4][i] = di.y, c[5][i] = di.z;
    }
    const auto load = [&](int k) { return Batch::load_aligned(c[k]); };
    return {{load(0), load(1), load(2)}, {load(3), load(4), load(5)}};
}

// Rays from random points inside the mesh towards its vertices, points on its edges (their
// midpoints and random fractions, rounded) and random points just around them: none may pass
// between the triangles, with either kernel.
void expect_no_leaks(const Mesh& mesh, float inner_radius, int rays, uint32_t seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> unit(-1.0f, 1.0f), frac(0.0f, 1.0f);
    std::uniform_int_distribution<size_t> pick_vertex(0, mesh.positions.size() - 1);
    std::uniform_int_distribution<size_t> pick_edge(0, mesh.edges.size() - 1);
    std::vector<Vec3f> origins, directions;
    for (int r = 0; r < rays; ++r) {
        // An origin inside: the centre, a lattice-aligned point or a random point
        Vec3f o(0.0f);
        if (r % 3 == 1) {
            o = Vec3f(unit(rng), unit(rng), unit(rng)) * inner_radius;
        } else if (r % 3 == 2) {
            o = Vec3f(0.5f * inner_radius, 0.0f, 0.0f);
        }
        // A target on a vertex or an edge
        Vec3f target;
        switch (r % 4) {
            case 0: target = mesh.positions[pick_vertex(rng)]; break;
            case 1: {
                const auto& e = mesh.edges[pick_edge(rng)];
                target = (mesh.positions[e[0]] + mesh.positions[e[1]]) * 0.5f;
                break;
            }
            case 2: {
                const auto& e = mesh.edges[pick_edge(rng)];
                const Vec3f a = mesh.positions[e[0]], b = mesh.positions[e[1]];
                target = fma(b - a, frac(rng), a);
                break;
            }
            default: {
                const Vec3f p = mesh.positions[pick_vertex(rng)];
                target = p + Vec3f(unit(rng), unit(rng), unit(rng)) * 1e-6f;
                break;
            }
        }
        origins.push_back(o);
        directions.push_back(target - o);
    }
    for (size_t r = 0; r < origins.size(); ++r) {
        ASSERT_GE(count_hits(mesh, origins[r], directions[r]), 1)
            << "ray " << r << " leaks: o = (" << origins[r].x << ", " << origins[r].y << ", "
            << origins[r].z << "), d = (" << directions[r].x << ", " << directions[r].y << ", "
            << directions[r].z << ")";
    }
#if CIERZO_TEST_FMA
    if (cpu_has_fma()) {
        for (size_t r = 0; r < origins.size(); ++r) {
            ASSERT_GE(count_hits_fma(mesh, origins[r], directions[r]), 1)
                << "ray " << r << " leaks with FMA";
        }
    }
#endif
    for (size_t first = 0; first + kLanes <= origins.size(); first += kLanes) {
        const auto hits = count_hits_batch(mesh, gather_rays(origins, directions, first));
        for (int i = 0; i < kLanes; ++i) {
            ASSERT_GE(hits[i], 1) << "batch ray " << first + i << " leaks";
        }
    }
}

// ---- Known answers ------------------------------------------------------------------------
TEST(Triangle, HitWithHandComputedDistanceAndBarycentrics) {
    const Vec3f v0(-1, -1, 2), v1(3, -1, 2), v2(-1, 3, 2);
    // Along +z through (0, 0, 2) = v0 + 1/4 (v1 - v0) + 1/4 (v2 - v0)
    Hit h = shoot({0, 0, 0}, {0, 0, 1}, v0, v1, v2);
    ASSERT_TRUE(h.hit);
    EXPECT_FLOAT_EQ(h.t, 2.0f);
    EXPECT_FLOAT_EQ(h.b1, 0.25f);
    EXPECT_FLOAT_EQ(h.b2, 0.25f);
    // An oblique, unnormalised direction: (0.5, 1, 2) at t = 2, b1 = 1.5/4, b2 = 2/4
    h = shoot({0, 0, 0}, {0.25f, 0.5f, 1.0f}, v0, v1, v2);
    ASSERT_TRUE(h.hit);
    EXPECT_FLOAT_EQ(h.t, 2.0f);
    EXPECT_FLOAT_EQ(h.b1, 0.375f);
    EXPECT_FLOAT_EQ(h.b2, 0.5f);
}

TEST(Triangle, SameAnswerForEveryDominantAxisAndSign) {
    const Vec3f v0(-1, -1, 2), v1(3, -1, 2), v2(-1, 3, 2);
    for (int axes = 0; axes < 3; ++axes) {
        for (float sign : {1.0f, -1.0f}) {
            // Mirror along the ray axis and rotate the whole configuration
            const auto place = [&](Vec3f p) { return cycle(Vec3f(p.x, p.y, sign * p.z), axes); };
            const Hit h = shoot(place({0, 0, 0}), place({0.25f, 0.5f, 1.0f}), place(v0), place(v1),
                                place(v2));
            ASSERT_TRUE(h.hit) << "axes " << axes << " sign " << sign;
            EXPECT_FLOAT_EQ(h.t, 2.0f);
            EXPECT_FLOAT_EQ(h.b1, 0.375f);
            EXPECT_FLOAT_EQ(h.b2, 0.5f);
        }
    }
}

TEST(Triangle, BothFacesAreHit) {
    const Vec3f v0(-1, -1, 2), v1(3, -1, 2), v2(-1, 3, 2);
    const Hit front = shoot({0, 0, 0}, {0, 0, 1}, v0, v1, v2);
    const Hit back = shoot({0, 0, 0}, {0, 0, 1}, v0, v2, v1);
    ASSERT_TRUE(front.hit);
    ASSERT_TRUE(back.hit);
    EXPECT_FLOAT_EQ(back.t, 2.0f);
    EXPECT_FLOAT_EQ(back.b1, front.b2);
    EXPECT_FLOAT_EQ(back.b2, front.b1);
    const Hit from_behind = shoot({0, 0, 4}, {0, 0, -1}, v0, v1, v2);
    ASSERT_TRUE(from_behind.hit);
    EXPECT_FLOAT_EQ(from_behind.t, 2.0f);
}

TEST(Triangle, Misses) {
    const Vec3f v0(-1, -1, 2), v1(3, -1, 2), v2(-1, 3, 2);
    EXPECT_FALSE(shoot({5, 5, 0}, {0, 0, 1}, v0, v1, v2).hit);            // beside it
    EXPECT_FALSE(shoot({1.5f, 1.5f, 0}, {0, 0, 1}, v0, v1, v2).hit);      // past the hypotenuse
    EXPECT_FALSE(shoot({0, 0, 3}, {0, 0, 1}, v0, v1, v2).hit);            // behind the origin
    EXPECT_FALSE(shoot({0, 0, 0}, {0, 0, -1}, v0, v1, v2).hit);           // pointing away
    EXPECT_FALSE(shoot({0, 0, 2}, {0, 0, 1}, v0, v1, v2).hit);            // t = 0
    EXPECT_FALSE(shoot({0, 0, 0}, {0, 0, 1}, v0, v1, v2, 2.0f).hit);      // t = tmax
    EXPECT_FALSE(shoot({0, 0, 0}, {0, 0, 1}, v0, v1, v2, 1.5f).hit);      // t > tmax
    EXPECT_TRUE(shoot({0, 0, 0}, {0, 0, 1}, v0, v1, v2, 2.000001f).hit);  // just inside
    EXPECT_FALSE(shoot({-5, 0, 2}, {1, 0, 0}, v0, v1, v2).hit);           // in its plane
}

// ---- Degenerate triangles ----------------------------------------------------------------
// Coincident vertices give exactly zero edge functions or opposite ones, so no hit. (Distinct
// but collinear vertices may not stay collinear through the rounded shear; the BVH drops
// those at build time, see test_bvh.)
TEST(Triangle, TrianglesWithCoincidentVerticesAreNeverHit) {
    std::mt19937 rng(7);
    std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
    const Vec3f p(0.3f, -0.2f, 2.0f), q(-0.7f, 0.9f, 2.5f);
    const std::array<std::array<Vec3f, 3>, 4> degenerate = {{
        {p, p, q},
        {p, q, q},
        {q, p, q},
        {p, p, p},
    }};
    for (const auto& tri : degenerate) {
        const Vec3f targets[] = {tri[0], tri[1], tri[2], (tri[0] + tri[1]) * 0.5f,
                                 (tri[1] + tri[2]) * 0.5f};
        for (int r = 0; r < 2000; ++r) {
            const Vec3f o(unit(rng), unit(rng), unit(rng) - 2.0f);
            const Vec3f target =
                targets[r % 5] + Vec3f(unit(rng), unit(rng), unit(rng)) * (r % 2 ? 1e-3f : 0.0f);
            ASSERT_FALSE(shoot(o, target - o, tri[0], tri[1], tri[2]).hit)
                << "triangle " << (&tri - degenerate.data()) << " ray " << r;
        }
    }
}

// ---- Watertightness -----------------------------------------------------------------------
TEST(Triangle, RayAlongTheEdgePlaneHitsAtLeastOneNeighbour) {
    // Two triangles share the edge x = 0 of the plane z = 1; every ray below lies in the
    // plane x = 0 through that edge, so the shared edge function is exactly zero.
    const Vec3f a(0, -1, 1), b(0, 1, 1), left(-1, 0, 1), right(1, 0, 1);
    const Vec3f origins[] = {{0, 0, 0}, {0, -0.7f, -2}, {0, 3, 0.5f}, {0, 0.1f, 4}};
    const Vec3f directions[] = {{0, 0.3f, 1}, {0, 0.1f, 1}, {0, -2, 0.25f}, {0, -0.2f, -1}};
    for (int r = 0; r < 4; ++r) {
        const Hit h1 = shoot(origins[r], directions[r], a, b, left);
        const Hit h2 = shoot(origins[r], directions[r], b, a, right);
        EXPECT_TRUE(h1.hit || h2.hit) << "ray " << r;
        const Hit h = h1.hit ? h1 : h2;
        const Vec3f at = fma(directions[r], h.t, origins[r]);
        EXPECT_NEAR(at.z, 1.0f, 1e-6f);
        EXPECT_NEAR(at.x, 0.0f, 1e-6f);
    }
}

TEST(Triangle, NoLeaksThroughEdgesAndVerticesOfAnOctahedron) {
    expect_no_leaks(octahedron(), 0.3f, 3000, 1);
}

TEST(Triangle, NoLeaksThroughEdgesAndVerticesOfASubdividedCube) {
    expect_no_leaks(lattice_cube(6, false), 0.9f, 3000, 2);
}

TEST(Triangle, NoLeaksThroughEdgesAndVerticesOfACubeSphere) {
    expect_no_leaks(lattice_cube(6, true), 0.5f, 3000, 3);
}

// ---- Batch variant -------------------------------------------------------------------------
TEST(TriangleBatch, MatchesScalarWithMixedDominantAxes) {
    std::mt19937 rng(11);
    std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
    int hits = 0, axes_seen[3] = {};
    long mixed_batches = 0;
    for (int round = 0; round < 4000; ++round) {
        // K rays, each against its own random triangle around a random point ahead of it
        Vec3f o[kLanes], d[kLanes], v[3][kLanes];
        for (int i = 0; i < kLanes; ++i) {
            o[i] = Vec3f(unit(rng), unit(rng), unit(rng)) * 4.0f;
            d[i] = Vec3f(unit(rng), unit(rng), unit(rng));
            const Vec3f centre = o[i] + d[i] * (1.0f + 2.0f * (unit(rng) + 1.0f));
            for (int k = 0; k < 3; ++k) {
                v[k][i] = centre + Vec3f(unit(rng), unit(rng), unit(rng)) * 0.8f;
            }
        }
        // Scalar answers, lane by lane
        alignas(64) float c[15][kLanes], tmax[kLanes];
        bool scalar_hit[kLanes];
        float scalar_t[kLanes], scalar_b1[kLanes], scalar_b2[kLanes];
        int kz[kLanes];
        for (int i = 0; i < kLanes; ++i) {
            tmax[i] = round % 2 ? 1e30f : 3.0f;
            const Ray<float> ray{o[i], d[i]};
            const RayShear<float> shear = make_ray_shear(d[i]);
            kz[i] = shear.kz;
            ++axes_seen[kz[i]];
            scalar_hit[i] = intersect_triangle(ray, shear, v[0][i], v[1][i], v[2][i], tmax[i],
                                               scalar_t[i], scalar_b1[i], scalar_b2[i]);
            const Vec3f all[5] = {o[i], d[i], v[0][i], v[1][i], v[2][i]};
            for (int k = 0; k < 5; ++k) {
                c[3 * k][i] = all[k].x, c[3 * k + 1][i] = all[k].y, c[3 * k + 2][i] = all[k].z;
            }
        }
        // Batch answer
        const auto load = [&](int k) {
            return Vec3<Batch>(Batch::load_aligned(c[3 * k]), Batch::load_aligned(c[3 * k + 1]),
                               Batch::load_aligned(c[3 * k + 2]));
        };
        const Ray<Batch> ray{load(0), load(1)};
        const RayShear<Batch> shear = make_ray_shear(ray.d);
        Batch t, b1, b2;
        const auto mask = intersect_triangle(ray, shear, load(2), load(3), load(4),
                                             Batch::load_aligned(tmax), t, b1, b2);
        alignas(64) float m[kLanes], tl[kLanes], b1l[kLanes], b2l[kLanes];
        alignas(64) int32_t kzl[kLanes];
        select(mask, Batch(1.0f), Batch(0.0f)).store_aligned(m);
        t.store_aligned(tl);
        b1.store_aligned(b1l);
        b2.store_aligned(b2l);
        shear.kz.store_aligned(kzl);
        bool mixed = false;
        for (int i = 0; i < kLanes; ++i) {
            ASSERT_EQ(kzl[i], kz[i]);
            mixed |= kz[i] != kz[0];
            ASSERT_EQ(m[i] != 0.0f, scalar_hit[i]) << "round " << round << " lane " << i;
            if (scalar_hit[i]) {
                ++hits;
                // The same operations in the same order, none fused: bit-identical (the
                // scalar double-precision fallback for a zero edge function aside)
                EXPECT_EQ(tl[i], scalar_t[i]);
                EXPECT_EQ(b1l[i], scalar_b1[i]);
                EXPECT_EQ(b2l[i], scalar_b2[i]);
            }
        }
        mixed_batches += mixed;
    }
    EXPECT_GT(hits, 1000);
    EXPECT_GT(mixed_batches, 1000);
    for (int axis = 0; axis < 3; ++axis) {
        EXPECT_GT(axes_seen[axis], 1000) << "axis " << axis;
    }
}

TEST(TriangleBatch, ZeroDirectionComponentsAndTiesOfTheDominantAxis) {
    // Lanes whose directions have zero components or equal largest components, mixed
    const Vec3f v0(-1, -1, 2), v1(3, -1, 2), v2(-1, 3, 2);
    std::vector<Vec3f> o, d;
    const Vec3f dirs[] = {{0, 0, 1}, {1, 1, 1}, {0.25f, 0.5f, 1}, {-1, 1, 1},
                          {1, 0, 0}, {0, 1, 0}, {0, -1, -1},      {0.5f, -0.5f, 1}};
    for (int r = 0; r < 64; ++r) {
        const Vec3f dir = cycle(dirs[r % 8], (r / 8) % 3);
        o.push_back(Vec3f(0.5f, 0.25f, 2.0f) - dir * 1.5f);
        d.push_back(dir);
    }
    for (size_t first = 0; first + kLanes <= o.size(); first += kLanes) {
        const Ray<Batch> ray = gather_rays(o, d, first);
        Batch t, b1, b2;
        const auto mask =
            intersect_triangle(ray, make_ray_shear(ray.d), Vec3<Batch>(v0), Vec3<Batch>(v1),
                               Vec3<Batch>(v2), Batch(1e30f), t, b1, b2);
        alignas(64) float m[kLanes], tl[kLanes];
        select(mask, Batch(1.0f), Batch(0.0f)).store_aligned(m);
        t.store_aligned(tl);
        for (int i = 0; i < kLanes; ++i) {
            const Hit h = shoot(o[first + i], d[first + i], v0, v1, v2);
            ASSERT_EQ(m[i] != 0.0f, h.hit) << "ray " << first + i;
            if (h.hit) {
                EXPECT_FLOAT_EQ(tl[i], h.t);
            }
        }
    }
}

}  // namespace
}  // namespace cierzo
