// Sphere, plane and quadric intersection: hits with hand-computed distances, misses, grazing
// rays, rays from inside, primitives behind the origin, and the self-intersection offset.
#include <gtest/gtest.h>

#include <cmath>

#include "kernels/intersect.h"

namespace cierzo {
namespace {

constexpr float kFar = kRayFar;

Ray<float> ray(Vec3f o, Vec3f d) { return {o, normalize(d)}; }

TEST(Sphere, HitFromOutsideGivesNearRoot) {
    float t = 0;
    ASSERT_TRUE(intersect_sphere(ray({0, 0, -5}, {0, 0, 1}), Vec3f{0, 0, 0}, 1.0f, kFar, t));
    EXPECT_FLOAT_EQ(t, 4.0f);
}

TEST(Sphere, HitFromInsideGivesFarRoot) {
    float t = 0;
    ASSERT_TRUE(intersect_sphere(ray({0, 0.5f, 0}, {0, 1, 0}), Vec3f{0, 0, 0}, 2.0f, kFar, t));
    EXPECT_FLOAT_EQ(t, 1.5f);
}

TEST(Sphere, MissBehindAndBeyondTmax) {
    float t = 0;
    EXPECT_FALSE(intersect_sphere(ray({0, 0, 5}, {0, 0, 1}), Vec3f{0, 0, 0}, 1.0f, kFar, t));
    EXPECT_FALSE(intersect_sphere(ray({0, 2, -5}, {0, 0, 1}), Vec3f{0, 0, 0}, 1.0f, kFar, t));
    EXPECT_FALSE(intersect_sphere(ray({0, 0, -5}, {0, 0, 1}), Vec3f{0, 0, 0}, 1.0f, 3.9f, t));
}

TEST(Sphere, GrazingRayTouchesAtTangent) {
    float t = 0;
    // Tangent at (0, 1, 0): just inside hits near t = 5, just outside misses
    EXPECT_TRUE(intersect_sphere(ray({0, 0.9999f, -5}, {0, 0, 1}), Vec3f{0}, 1.0f, kFar, t));
    EXPECT_NEAR(t, 5.0f, 0.02f);
    EXPECT_FALSE(intersect_sphere(ray({0, 1.0001f, -5}, {0, 0, 1}), Vec3f{0}, 1.0f, kFar, t));
}

TEST(Sphere, SmallFarSphereStaysAccurate) {
    // A 1e-3 sphere 1e4 away: the naive discriminant loses all digits here
    float t = 0;
    const Vec3f c{0, 0, 1e4f};
    ASSERT_TRUE(intersect_sphere(ray({0, 5e-4f, 0}, {0, 0, 1}), c, 1e-3f, kFar, t));
    const float expected = 1e4f - std::sqrt(1e-6f - 25e-8f);
    EXPECT_NEAR(t, expected, 1e-3f);
}

TEST(Plane, ReportConventionNormalAndDistance) {
    // n = (1,0,0), d = 1 is the plane x = -1
    float t = 0;
    ASSERT_TRUE(intersect_plane(ray({0, 0, 0}, {-1, 0, 0}), Vec3f{1, 0, 0}, 1.0f, kFar, t));
    EXPECT_FLOAT_EQ(t, 1.0f);
    EXPECT_FALSE(intersect_plane(ray({0, 0, 0}, {1, 0, 0}), Vec3f{1, 0, 0}, 1.0f, kFar, t));
}

TEST(Plane, ParallelRayMissesWithoutNaNHit) {
    float t = 0;
    EXPECT_FALSE(intersect_plane(ray({0, 0, 0}, {0, 1, 0}), Vec3f{1, 0, 0}, 1.0f, kFar, t));
    // Parallel and lying in the plane: 0/0
    EXPECT_FALSE(intersect_plane(ray({-1, 0, 0}, {0, 1, 0}), Vec3f{1, 0, 0}, 1.0f, kFar, t));
}

TEST(Plane, GrazingRayHitsFarAway) {
    float t = 0;
    ASSERT_TRUE(intersect_plane(ray({0, 1, 0}, {1, -1e-4f, 0}), Vec3f{0, 1, 0}, 0.0f, kFar, t));
    EXPECT_NEAR(t, 1e4f, 1.0f);
}

QuadricCoefficients<float> unit_sphere_quadric() { return {1, 1, 1, 0, 0, 0, 0, 0, 0, -1}; }

TEST(Quadric, SphereAsQuadricMatchesSphere) {
    const Vec3f lo(-kFar), hi(kFar);
    for (Vec3f o : {Vec3f{0.1f, 0.2f, -4}, Vec3f{0.3f, -0.1f, 0}, Vec3f{-3, 0.5f, 0.2f}}) {
        const Ray<float> r = ray(o, Vec3f{0, 0, 0} - o + Vec3f{0.05f, 0.02f, 0.0f});
        float tq = 0, ts = 0;
        ASSERT_TRUE(intersect_quadric(r, unit_sphere_quadric(), lo, hi, kFar, tq));
        ASSERT_TRUE(intersect_sphere(r, Vec3f{0}, 1.0f, kFar, ts));
        EXPECT_NEAR(tq, ts, 1e-5f * std::max(1.0f, ts));
    }
}

TEST(Quadric, CylinderClippedByBounds) {
    // x² + z² = 1, kept for y in [0, 1]
    const QuadricCoefficients<float> cyl{1, 0, 1, 0, 0, 0, 0, 0, 0, -1};
    const Vec3f lo{-2, 0, -2}, hi{2, 1, 2};
    float t = 0;
    ASSERT_TRUE(intersect_quadric(ray({0, 0.5f, -5}, {0, 0, 1}), cyl, lo, hi, kFar, t));
    EXPECT_NEAR(t, 4.0f, 1e-5f);
    EXPECT_FALSE(intersect_quadric(ray({0, 1.5f, -5}, {0, 0, 1}), cyl, lo, hi, kFar, t));
    // A ray along the axis is parallel to the surface (a = 0, linear case): no hit, no NaN
    EXPECT_FALSE(intersect_quadric(ray({0, -5, 0}, {0, 1, 0}), cyl, lo, hi, kFar, t));
    // From inside the clipped part, the far wall
    ASSERT_TRUE(intersect_quadric(ray({0, 0.5f, 0}, {1, 0, 0}), cyl, lo, hi, kFar, t));
    EXPECT_NEAR(t, 1.0f, 1e-5f);
}

TEST(Quadric, NearRootOutsideBoundsFallsToFarRoot) {
    // Sphere clipped to z >= 0: a ray along +z from z=-5 enters at z=-1 (clipped away)
    // and must hit the far side at z=+1
    const Vec3f lo{-2, -2, 0}, hi{2, 2, 2};
    float t = 0;
    ASSERT_TRUE(
        intersect_quadric(ray({0, 0, -5}, {0, 0, 1}), unit_sphere_quadric(), lo, hi, kFar, t));
    EXPECT_NEAR(t, 6.0f, 1e-5f);
}

TEST(Quadric, PlaneAsLinearQuadric) {
    // y - 1 = 0: a = b_quadratic = 0, the linear branch
    const QuadricCoefficients<float> q{0, 0, 0, 0, 0, 0, 0, 1, 0, -1};
    float t = 0;
    ASSERT_TRUE(
        intersect_quadric(ray({0, -1, 0}, {0, 1, 0}), q, Vec3f(-kFar), Vec3f(kFar), kFar, t));
    EXPECT_NEAR(t, 2.0f, 1e-6f);
    const Vec3f g = quadric_gradient(q, Vec3f{0, 1, 0});
    EXPECT_FLOAT_EQ(g.y, 1.0f);
}

TEST(Quadric, GradientIsOutwardNormal) {
    const Vec3f g = quadric_gradient(unit_sphere_quadric(), Vec3f{0.6f, 0.0f, 0.8f});
    const Vec3f n = normalize(g);
    EXPECT_NEAR(n.x, 0.6f, 1e-6f);
    EXPECT_NEAR(n.z, 0.8f, 1e-6f);
}

TEST(Offset, LeavesTheSurfaceOnTheRequestedSideAtEveryScale) {
    // Spheres from 1e-6 to 1e6 in size, placed near and far from the origin; rays come from
    // a camera 3 radii away, as in a scaled scene
    for (float scale : {1e-6f, 1e-4f, 1.0f, 1e3f, 1e6f}) {
        for (float place : {0.0f, 5.0f}) {
            const float r = scale;
            const Vec3f c = Vec3f{3.0f, -2.0f, 5.0f} * (scale * place);
            const Vec3f camera = c + Vec3f{0.0f, 0.0f, -3.0f * r};
            for (int i = 0; i < 64; ++i) {
                const float a = 0.1f * float(i), b = 0.37f * float(i);
                const Vec3f n{std::cos(a) * std::sin(b), std::sin(a) * std::sin(b), std::cos(b)};
                const Vec3f p = c + n * r;
                const float magnitude = std::max(max_abs(p), max_abs(camera));
                const Vec3f out = offset_ray_origin(p, n, magnitude);
                const Vec3f in = offset_ray_origin(p, -n, magnitude);
                // Outward origin: a ray along n must not hit the sphere again
                float t = 0;
                EXPECT_FALSE(intersect_sphere(Ray<float>{out, n}, c, r, kFar, t))
                    << "scale " << scale << " place " << place << " i " << i;
                // Inward origin: strictly inside, and a ray along -n hits the far side
                EXPECT_LT(length(in - c), r) << "scale " << scale << " i " << i;
                ASSERT_TRUE(intersect_sphere(Ray<float>{in, -n}, c, r, kFar, t));
                EXPECT_NEAR(t, 2.0f * r, 1e-3f * r);
                // The offset is small relative to the object
                EXPECT_LT(length(out - p), 1e-3f * r * std::max(1.0f, 8.0f * place));
            }
        }
    }
}

}  // namespace
}  // namespace cierzo
