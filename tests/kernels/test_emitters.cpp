// Emitter sampling for next-event estimation (kernels/estimator.h), checked against its
// stated densities: chi-square of the directions a sphere's cone sampler and an inside
// sampler produce, of the points a triangle's area sampler produces, and of the emitters
// the alias table chooses (against powers computed here, and the same emitter chosen by
// the position sampler of kernels/light_sampling.h); a triangle sampled by solid angle
// (against the solid angle of each of 64 cells, computed in double here), its fallback to
// area sampling and its extremes; a rectangle of two triangles sampled as one by solid angle
// (against 64 cells' solid angles), its fallback and extremes; the hit-side density equals the
// sampling side's and integrates to 1 over the emitter; and the two MIS weights of one
// direction sum to 1 for random vertices, materials and emitters.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "kernels/estimator.h"
#include "kernels/light_sampling.h"
#include "support/emitter_tests.h"
#include "support/statistics.h"

namespace cierzo {
namespace {

using test::cone_bin;
using test::Uniforms;

TEST(EmitterSampling, SphereConeIsUniformInSolidAngleAndHitsTheSphere) {
    // Near (the cone is wide), far (narrow) and very far (1 - cos θmax ≈ 5e-9 would cancel
    // in 1 - cos)
    for (const float distance : {1.5f, 6.0f, 5000.0f}) {
        SCOPED_TRACE(distance);
        const Scene scene = test::emitter_scene(R"({"type": "sphere", "center": [0.3, -0.2, 0.5],
                                         "radius": 0.5, "material": "L"})");
        const EmitterTable e = scene.emitters.table();
        ASSERT_EQ(e.count, 1);
        const Vec3f c{0.3f, -0.2f, 0.5f};
        const Vec3f x = c + normalize(Vec3f{1.0f, 2.0f, -0.5f}) * distance;
        const double d = double(distance), sin2 = 0.25 / (d * d);
        const double one_minus = sin2 / (1.0 + std::sqrt(1.0 - sin2));
        const Vec3f axis = normalize(c - x);
        Uniforms u;
        std::vector<double> observed(256, 0.0);
        const int n = 256 * 400;
        for (int k = 0; k < n; ++k) {
            const EmitterSample<float> s = sample_emitter(e, x, u(), u(), u(), u());
            ASSERT_TRUE(s.ok);
            // Its density: 1 / (2π(1 - cos θmax)); the hit side computes the same
            ASSERT_NEAR(s.pdf * 2.0 * M_PI * one_minus, 1.0, 1e-3);
            ASSERT_NEAR(emitter_pdf<float>(e, 0, x, s.wi, s.t) / s.pdf, 1.0, 1e-5);
            // The point lies on the sphere (to float resolution at that distance)
            const Vec3f p = x + s.wi * s.t;
            ASSERT_NEAR(length(p - c), 0.5f, 4e-6f * std::max(1.0f, distance));
            observed[size_t(cone_bin(s.wi, axis, one_minus))] += 1.0;
        }
        const std::vector<double> expected(256, double(n) / 256.0);
        const auto [stat, dof] = test::chi_square(observed, expected);
        EXPECT_LT(stat, test::chi_square_critical(dof));
    }
}

TEST(EmitterSampling, FromInsideASphereEveryDirectionIsEquallyLikely) {
    const Scene scene = test::emitter_scene(R"({"type": "sphere", "center": [0, 0, 0], "radius": 10,
                                "material": "L"})");
    const EmitterTable e = scene.emitters.table();
    const Vec3f x{2.0f, -3.0f, 1.0f};
    Uniforms u;
    std::vector<double> observed(256, 0.0);
    const int n = 256 * 400;
    for (int k = 0; k < n; ++k) {
        const EmitterSample<float> s = sample_emitter(e, x, u(), u(), u(), u());
        ASSERT_TRUE(s.ok);
        ASSERT_NEAR(s.pdf * 4.0 * M_PI, 1.0, 1e-5);
        ASSERT_NEAR(emitter_pdf<float>(e, 0, x, s.wi, s.t) / s.pdf, 1.0, 1e-5);
        ASSERT_NEAR(length(x + s.wi * s.t), 10.0f, 1e-4f);
        // (the whole sphere of directions is a cone with 1 - cos θmax = 2)
        observed[size_t(cone_bin(s.wi, Vec3f(0, 0, 1), 2.0))] += 1.0;
    }
    const std::vector<double> expected(256, double(n) / 256.0);
    const auto [stat, dof] = test::chi_square(observed, expected);
    EXPECT_LT(stat, test::chi_square_critical(dof));
}

TEST(EmitterSampling, TriangleIsUniformInAreaWithTheSolidAngleDensity) {
    // Bins: the triangle cut into 8 × 8 = 64 congruent sub-triangles of equal area, found
    // from the barycentric coordinates of each point (solved here, not the sampler's)
    test::TriangleHistogram h;
    const Scene scene = test::emitter_scene(test::TriangleHistogram::object("L"));
    const EmitterTable e = scene.emitters.table();
    ASSERT_EQ(e.count, 1);
    const Vec3f x{0.2f, -0.5f, -1.0f};
    const Vec3f n = h.normal();
    Uniforms u;
    for (int s_i = 0; s_i < 64 * 800; ++s_i) {
        const EmitterSample<float> s = sample_emitter(e, x, u(), u(), u(), u());
        ASSERT_TRUE(s.ok);
        // Density d² / (A |cos θl|), and the hit side's
        const double cos_l = std::abs(double(dot(n, s.wi)));
        ASSERT_NEAR(double(s.pdf) * h.area() * cos_l / (double(s.t) * s.t), 1.0, 1e-4);
        ASSERT_NEAR(emitter_pdf<float>(e, 0, x, s.wi, s.t) / s.pdf, 1.0, 1e-5);
        ASSERT_TRUE(h.add(x + s.wi * s.t)) << "off the triangle";
    }
    const auto [stat, critical] = h.chi_square_test();
    EXPECT_LT(stat, critical);
}

TEST(EmitterSampling, TriangleBySolidAngleIsUniformInSolidAngle) {
    // Bins: the 64 sub-triangles, each expected in proportion to the solid angle it
    // subtends (computed in double here); from far, near, close to the plane and near a
    // corner. The density is 1/Ω, the hit side's the same, and every point on the triangle.
    const Scene scene = test::emitter_scene(test::TriangleHistogram::object("L"));
    const EmitterTable e = scene.emitters.table();
    for (const Vec3f x : {Vec3f{0.2f, -0.5f, -1.0f}, Vec3f{0.3f, 1.1f, 1.5f},
                          Vec3f{2.5f, 0.0f, 2.4f}, Vec3f{-0.9f, 0.55f, 1.9f}}) {
        SCOPED_TRACE(::testing::Message() << x.x << " " << x.y << " " << x.z);
        test::TriangleHistogram h;
        std::vector<double> p = h.cell_solid_angles(x);
        double omega = 0.0;
        for (double w : p) omega += w;
        ASSERT_GT(omega, double(kMinTriangleSolidAngle));
        for (double& w : p) w /= omega;
        Uniforms u;
        for (int s_i = 0; s_i < 64 * 800; ++s_i) {
            const EmitterSample<float> s = sample_emitter(e, x, u(), u(), u(), u(), true);
            ASSERT_TRUE(s.ok);
            ASSERT_NEAR(double(s.pdf) * omega, 1.0, 2e-4);
            ASSERT_NEAR(emitter_pdf<float>(e, 0, x, s.wi, s.t, true) / s.pdf, 1.0, 1e-5);
            ASSERT_TRUE(h.add(x + s.wi * s.t)) << "off the triangle";
        }
        const auto [stat, critical] = h.chi_square_test(p);
        EXPECT_LT(stat, critical);
        // Near the triangle, points sampled by area fail the same test: it tells the two
        // densities apart
        if (omega > 0.5) {
            test::TriangleHistogram by_area;
            for (int s_i = 0; s_i < 64 * 800; ++s_i) {
                const EmitterSample<float> s = sample_emitter(e, x, u(), u(), u(), u(), false);
                if (s.ok) by_area.add(x + s.wi * s.t);
            }
            EXPECT_GT(by_area.chi_square_test(p).first, critical);
        }
    }
}

TEST(EmitterSampling, TriangleBySolidAngleFallsBackToAreaAndStaysFinite) {
    const Scene scene = test::emitter_scene(test::TriangleHistogram::object("L"));
    const EmitterTable e = scene.emitters.table();
    test::TriangleHistogram h;
    const Vec3f centroid = (h.v0 + h.v1 + h.v2) * (1.0f / 3.0f);
    Uniforms u;
    // Far (Ω ≈ 1e-7 sr): sampled by area, with the area density on both sides
    const Vec3f far = centroid + h.normal() * 3000.0f;
    for (int k = 0; k < 1000; ++k) {
        const EmitterSample<float> s = sample_emitter(e, far, 0.3f, 0.5f, u(), u(), true);
        ASSERT_TRUE(s.ok);
        const double cos_l = std::abs(double(dot(h.normal(), s.wi)));
        ASSERT_NEAR(double(s.pdf) * h.area() * cos_l / (double(s.t) * s.t), 1.0, 1e-3);
        ASSERT_NEAR(emitter_pdf<float>(e, 0, far, s.wi, s.t, true) / s.pdf, 1.0, 1e-4);
    }
    // In the triangle's plane, at a corner, on the triangle, at 1e6 and 1e-6 scales: no NaN
    // or Inf in a usable sample
    const Vec3f in_plane = h.v0 + (h.v1 - h.v0) * 2.0f;
    for (const Vec3f x : {in_plane, h.v0, centroid, centroid + h.normal() * 1e-6f,
                          centroid + h.normal() * 1e6f, centroid - h.normal() * 0.01f}) {
        SCOPED_TRACE(::testing::Message() << x.x << " " << x.y << " " << x.z);
        for (int k = 0; k < 2000; ++k) {
            const EmitterSample<float> s = sample_emitter(e, x, u(), u(), u(), u(), true);
            if (!s.ok) continue;
            ASSERT_TRUE(std::isfinite(s.pdf) && s.pdf > 0.0f);
            ASSERT_TRUE(std::isfinite(s.t) && s.t > 0.0f);
            ASSERT_TRUE(std::isfinite(s.wi.x) && std::isfinite(s.wi.y) && std::isfinite(s.wi.z));
            ASSERT_NEAR(length(s.wi), 1.0f, 1e-4f);
        }
    }
}

// A tilted rectangle light of two triangles, and the solid angle of cell (i, j) of its
// n × n grid from x, in double (each cell two spherical triangles, Van Oosterom–Strackee).
struct TiltedRectangle {
    Vec3f p{-0.5f, -0.3f, 1.2f}, e1{1.2f, 0.3f, 0.4f}, e2;
    TiltedRectangle() {
        const Vec3f n0{0.1f, -0.2f, 1.0f};
        e2 = normalize(cross(n0, e1)) * 0.9f;
    }
    Vec3f corner(int k) const {
        return k == 0 ? p : k == 1 ? p + e1 : k == 2 ? p + e1 + e2 : p + e2;
    }
    std::string objects() const {
        const auto v = [&](int k) {
            const Vec3f c = corner(k);
            return "[" + std::to_string(c.x) + ", " + std::to_string(c.y) + ", " +
                   std::to_string(c.z) + "]";
        };
        return R"({"type": "triangle", "material": "L", "vertices": [)" + v(0) + ", " + v(1) +
               ", " + v(2) + R"(]}, {"type": "triangle", "material": "L", "vertices": [)" + v(0) +
               ", " + v(2) + ", " + v(3) + "]}";
    }
    static double triangle_omega(const double a[3], const double b[3], const double c[3]) {
        const auto unit = [](const double v[3], double o[3]) {
            const double l = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
            for (int k = 0; k < 3; ++k) o[k] = v[k] / l;
        };
        double u[3], w[3], z[3];
        unit(a, u), unit(b, w), unit(c, z);
        const double triple = u[0] * (w[1] * z[2] - w[2] * z[1]) -
                              u[1] * (w[0] * z[2] - w[2] * z[0]) +
                              u[2] * (w[0] * z[1] - w[1] * z[0]);
        const auto d = [](const double* x, const double* y) {
            return x[0] * y[0] + x[1] * y[1] + x[2] * y[2];
        };
        return 2.0 * std::atan2(std::abs(triple), 1.0 + d(u, w) + d(w, z) + d(z, u));
    }
    std::vector<double> cell_solid_angles(const Vec3f& x, int n) const {
        std::vector<double> out;
        const auto at = [&](double s, double t, double o[3]) {
            o[0] = double(p.x) + s * e1.x + t * e2.x - x.x;
            o[1] = double(p.y) + s * e1.y + t * e2.y - x.y;
            o[2] = double(p.z) + s * e1.z + t * e2.z - x.z;
        };
        for (int j = 0; j < n; ++j)
            for (int i = 0; i < n; ++i) {
                double a[3], b[3], c[3], d[3];
                at(double(i) / n, double(j) / n, a), at(double(i + 1) / n, double(j) / n, b);
                at(double(i + 1) / n, double(j + 1) / n, c),
                    at(double(i) / n, double(j + 1) / n, d);
                out.push_back(triangle_omega(a, b, c) + triangle_omega(a, c, d));
            }
        return out;
    }
    // The cell of a point on the rectangle, or -1 off it (by more than tol)
    int cell(const Vec3f& q, int n, float tol = 1e-4f) const {
        const Vec3f d = q - p;
        const float s = dot(d, e1) / dot(e1, e1), t = dot(d, e2) / dot(e2, e2);
        const float off = std::abs(dot(d, normalize(cross(e1, e2))));
        if (s < -tol || s > 1.0f + tol || t < -tol || t > 1.0f + tol || off > tol) return -1;
        const int i = std::min(std::max(int(s * n), 0), n - 1);
        const int j = std::min(std::max(int(t * n), 0), n - 1);
        return j * n + i;
    }
};

TEST(EmitterSampling, RectangleOfTwoTrianglesIsOneEmitterUniformInSolidAngle) {
    const TiltedRectangle r;
    const Scene scene = test::emitter_scene(r.objects());
    const EmitterTable e = scene.emitters.table();
    ASSERT_EQ(e.count, 2);
    EXPECT_EQ(e.kind[0], kEmitterRectangle);
    EXPECT_EQ(e.kind[1], kEmitterRectangle);
    EXPECT_EQ(e.pmf[0], e.pmf[1]);  // a hit on either half has the rectangle's density
    EXPECT_NEAR(double(e.data[3]), double(length(cross(r.e1, r.e2))), 1e-5);
    constexpr int n = 8;
    for (const Vec3f x :
         {Vec3f{0.1f, 0.0f, -1.0f}, Vec3f{0.3f, 0.2f, 0.9f}, Vec3f{-0.45f, -0.25f, 1.1f},
          Vec3f{2.5f, 0.4f, 1.3f}, Vec3f{0.1f, 0.1f, 4.0f}}) {
        SCOPED_TRACE(::testing::Message() << x.x << " " << x.y << " " << x.z);
        std::vector<double> p = r.cell_solid_angles(x, n);
        double omega = 0.0;
        for (double w : p) omega += w;
        ASSERT_GT(omega, double(kMinTriangleSolidAngle));
        std::vector<double> observed(n * n, 0.0), expected(n * n);
        Uniforms u;
        const int samples = n * n * 600;
        for (int k = 0; k < samples; ++k) {
            const EmitterSample<float> s = sample_emitter(e, x, u(), u(), u(), u(), true);
            ASSERT_TRUE(s.ok);
            ASSERT_NEAR(double(s.pdf) * omega, 1.0, 5e-4);
            for (int32_t id : {0, 1})
                ASSERT_NEAR(emitter_pdf<float>(e, id, x, s.wi, s.t, true) / s.pdf, 1.0, 1e-5);
            const int c = r.cell(x + s.wi * s.t, n);
            ASSERT_GE(c, 0) << "off the rectangle";
            observed[size_t(c)] += 1.0;
        }
        for (int c = 0; c < n * n; ++c) expected[size_t(c)] = p[size_t(c)] / omega * samples;
        const auto [stat, dof] = test::chi_square(observed, expected);
        EXPECT_LT(stat, test::chi_square_critical(dof));
        // Near the rectangle, points sampled by area fail the same test
        if (omega > 0.5) {
            std::vector<double> by_area(n * n, 0.0);
            for (int k = 0; k < samples; ++k) {
                const EmitterSample<float> s = sample_emitter(e, x, u(), u(), u(), u(), false);
                const int c = s.ok ? r.cell(x + s.wi * s.t, n) : -1;
                if (c >= 0) by_area[size_t(c)] += 1.0;
            }
            EXPECT_GT(test::chi_square(by_area, expected).first, test::chi_square_critical(dof));
        }
    }
    // Far (sampled by area: the area density on both sides), and extremes that give nothing
    // NaN or infinite: in the plane, at a corner, on it, 1e-6 and 1e6 away
    const Vec3f normal = normalize(cross(r.e1, r.e2));
    const Vec3f centre = r.p + (r.e1 + r.e2) * 0.5f;
    Uniforms u;
    const Vec3f far = centre + normal * 3000.0f;
    for (int k = 0; k < 1000; ++k) {
        const EmitterSample<float> s = sample_emitter(e, far, 0.3f, 0.5f, u(), u(), true);
        ASSERT_TRUE(s.ok);
        const double cos_l = std::abs(double(dot(normal, s.wi)));
        ASSERT_NEAR(double(s.pdf) * double(e.data[3]) * cos_l / (double(s.t) * s.t), 1.0, 1e-3);
        ASSERT_GE(r.cell(far + s.wi * s.t, n, 3e-3f), 0);  // (3000 away: float's 1e-7 × 3000)
    }
    for (const Vec3f x :
         {r.p + r.e1 * 2.0f, r.p, centre, centre + normal * 1e-6f, centre + normal * 1e6f,
          centre - normal * 0.01f, r.p - normal * 1e-3f + r.e1 * 0.001f}) {
        SCOPED_TRACE(::testing::Message() << x.x << " " << x.y << " " << x.z);
        for (int k = 0; k < 2000; ++k) {
            const EmitterSample<float> s = sample_emitter(e, x, u(), u(), u(), u(), true);
            if (!s.ok) continue;
            ASSERT_TRUE(std::isfinite(s.pdf) && s.pdf > 0.0f);
            ASSERT_TRUE(std::isfinite(s.t) && s.t > 0.0f);
            ASSERT_NEAR(length(s.wi), 1.0f, 1e-4f);
        }
    }
    // Two triangles that share an edge but make no rectangle stay two triangles
    const Scene kite = test::emitter_scene(
        R"({"type": "triangle", "material": "L", "vertices": [[0, 0, 1], [1, 0, 1], [1, 1, 1]]},
           {"type": "triangle", "material": "L", "vertices": [[0, 0, 1], [1, 1, 1], [0, 1.3, 1]]})");
    EXPECT_EQ(kite.emitters.table().kind[0], kEmitterTriangle);
    EXPECT_EQ(kite.emitters.table().kind[1], kEmitterTriangle);
}

TEST(EmitterSampling, DensityIntegratesToOneOverTheEmitter) {
    // ∫ pdf(ω) dω over the directions that reach the emitter, by uniform directions from x:
    // 1 for a sampling density that is normalised (a wrong d² or cos would not be)
    const Scene scene = test::emitter_scene(
        R"({"type": "triangle", "vertices": [[-1, -1, 2], [1.5, -0.5, 2.5], [0, 1.5, 1.5]],
            "material": "L"},
           {"type": "sphere", "center": [-1, 0.5, 1.2], "radius": 0.6, "material": "M"})");
    const EmitterTable e = scene.emitters.table();
    ASSERT_EQ(e.count, 2);
    const Vec3f x{0.0f, 0.0f, -0.5f};
    std::vector<test::MeanEstimate> integral(2);
    Uniforms u;
    for (int k = 0; k < 400000; ++k) {
        const float z = 1.0f - 2.0f * u(), phi = 2.0f * float(M_PI) * u();
        const float r = std::sqrt(std::max(0.0f, 1.0f - z * z));
        const Vec3f d{r * std::cos(phi), r * std::sin(phi), z};
        Hit hit;
        const bool found = scene.intersect({x, d}, kRayFar, hit);
        const int32_t id = found ? scene.emitter_id(hit) : -1;
        for (int32_t j = 0; j < 2; ++j) {
            const double pdf = id == j ? emitter_pdf<float>(e, j, x, d, hit.t) / e.pmf[j] : 0.0;
            integral[size_t(j)].add(pdf * 4.0 * M_PI);
        }
    }
    for (int j = 0; j < 2; ++j) {
        SCOPED_TRACE(j);
        EXPECT_NEAR(integral[size_t(j)].mean(), 1.0, 4.0 * integral[size_t(j)].standard_error());
        EXPECT_LT(integral[size_t(j)].standard_error(), 0.012);
    }
}

TEST(EmitterSampling, AliasTableChoosesEmittersInProportionToPower) {
    // Powers area × max Le computed here: spheres 4πr²·Le, triangles ½|e1 × e2|·Le
    const Scene scene = test::emitter_scene(
        R"({"type": "sphere", "center": [0, 0, 3], "radius": 0.2, "material": "L"},
           {"type": "sphere", "center": [1, 0, 3], "radius": 0.05, "material": "M"},
           {"type": "triangle", "vertices": [[0, 0, 0], [1, 0, 0], [0, 1, 0]], "material": "M"},
           {"type": "sphere", "center": [2, 0, 3], "radius": 0.3, "material": "w"},
           {"type": "triangle", "vertices": [[0, 0, 1], [3, 0, 1], [0, 0.1, 1]], "material": "L"},
           {"type": "sphere", "center": [-1, 0, 3], "radius": 0.01, "material": "L"})");
    const EmitterTable e = scene.emitters.table();
    ASSERT_EQ(e.count, 5);  // the diffuse sphere is not an emitter
    struct Known {
        int32_t kind;
        float le, size;  // max Le; radius or area
        double power;
    };
    const double pi = M_PI;
    const Known known[5] = {{kEmitterSphere, 2, 0.2f, 4 * pi * 0.04 * 2},
                            {kEmitterSphere, 7, 0.05f, 4 * pi * 0.0025 * 7},
                            {kEmitterSphere, 2, 0.01f, 4 * pi * 1e-4 * 2},
                            {kEmitterTriangle, 7, 0.5f, 0.5 * 7},
                            {kEmitterTriangle, 2, 0.15f, 0.15 * 2}};
    double total = 0;
    for (const Known& k : known) total += k.power;
    // Which known emitter each table entry is
    int of[5];
    for (int j = 0; j < 5; ++j) {
        of[j] = -1;
        for (int k = 0; k < 5; ++k)
            if (e.kind[j] == known[k].kind && e.data[j * kEmitterStride + 13] == known[k].le &&
                std::abs(e.data[j * kEmitterStride + 3] - known[k].size) < 1e-6f)
                of[j] = k;
        ASSERT_GE(of[j], 0) << j;
        EXPECT_NEAR(e.pmf[j], known[of[j]].power / total, 1e-6) << j;
    }
    // Samples from a point that sees every emitter; the chosen one is told by its Le, its
    // kind and its density (the hit-side density of the right emitter equals it). The
    // position sampler of light paths (kernels/light_sampling.h) chooses the same emitter
    // from the same numbers, and says which.
    std::vector<double> observed(5, 0.0), expected(5);
    Uniforms u;
    const int n = 400000;
    const Vec3f x{0.3f, 0.2f, -20.0f};
    for (int k = 0; k < n; ++k) {
        const float u_pick = u(), u_alias = u(), u1 = u(), u2 = u();
        const EmitterSample<float> s = sample_emitter(e, x, u_pick, u_alias, u1, u2);
        int which = -1, chosen = -1;
        for (int j = 0; j < 5; ++j)
            if (bool(s.sphere) == (e.kind[j] == kEmitterSphere) &&
                s.le.x == e.data[j * kEmitterStride + 13] &&
                std::abs(s.pdf / emitter_pdf<float>(e, j, x, s.wi, s.t) - 1.0f) < 1e-3f)
                which = of[j], chosen = j;
        ASSERT_GE(which, 0);
        ASSERT_EQ(sample_emitter_position(e, u_pick, u_alias, u1, u2).id, chosen);
        observed[size_t(which)] += 1.0;
    }
    for (int k = 0; k < 5; ++k) expected[size_t(k)] = known[k].power / total * n;
    const auto [stat, dof] = test::chi_square(observed, expected);
    EXPECT_LT(stat, test::chi_square_critical(dof));
}

TEST(Mis, TheTwoWeightsOfADirectionSumToOne) {
    // For random vertices, Phong materials and emitters: a direction's light-side weight
    // (computed as an emitter sample would) plus its BSDF-side weight (as a path that
    // sampled it and hit the emitter would) is 1, for the diffuse and the specular lobe
    const Scene scene = test::emitter_scene(
        R"({"type": "sphere", "center": [0.5, 1, 2], "radius": 0.7, "material": "L"},
           {"type": "triangle", "vertices": [[-2, -1, 3], [2, -1, 3.5], [0, 2, 4]],
            "material": "M"},
           {"type": "sphere", "center": [0, 0, 0], "radius": 30, "material": "M"})");
    const EmitterTable e = scene.emitters.table();
    std::mt19937 rng(7);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    int checked = 0;
    for (int k = 0; k < 20000; ++k) {
        const Vec3f x{4 * u(rng) - 2, 4 * u(rng) - 2, 3 * u(rng) - 2};
        const Vec3f nf = normalize(Vec3f{u(rng) - 0.5f, u(rng) - 0.5f, u(rng) - 0.5f});
        const Vec3f d = normalize(Vec3f{u(rng) - 0.5f, u(rng) - 0.5f, u(rng) - 0.5f});
        if (dot(d, nf) >= 0) continue;
        const float shininess = std::array<float, 4>{0.0f, 1.0f, 20.0f, 1e4f}[k % 4];
        const Bsdf<float> m{Vec3f(0.6f * u(rng)),
                            Vec3f(0.4f * u(rng)),
                            Vec3f(0.1f * u(rng)),
                            Vec3f(0.0f),
                            shininess,
                            1.0f};
        const bool cosine = k % 2 == 0;
        const EmitterSample<float> s = sample_emitter(e, x, u(rng), u(rng), u(rng), u(rng));
        // (a direction below the surface is one no lobe samples: its light weight is 1)
        if (!s.ok || dot(s.wi, nf) <= 0.0f) continue;
        const PhongLobes<float> f = phong_lobes(m, d, nf, s.wi, cosine);
        float pd, ps;
        phong_lobe_probabilities(m, 0.9f, pd, ps);
        // The emitter the sample landed on, found by tracing the direction
        Hit hit;
        ASSERT_TRUE(scene.intersect({x, s.wi}, kRayFar, hit));
        const int32_t id = scene.emitter_id(hit);
        ASSERT_GE(id, 0);
        if (std::abs(hit.t - s.t) > 1e-3f * s.t) continue;  // something else in front
        const float lobe_pdf[2] = {sampled_lobe_pdf<kLobeDiffuse>(m, d, nf, s.wi, pd, cosine),
                                   sampled_lobe_pdf<kLobeSpecular>(m, d, nf, s.wi, ps, false)};
        const float light_side[2] = {power_heuristic(s.pdf, pd * f.pdf_diffuse),
                                     power_heuristic(s.pdf, ps * f.pdf_specular)};
        for (int lobe = 0; lobe < 2; ++lobe) {
            if (!(lobe_pdf[lobe] > 0.0f)) continue;
            const float hit_side =
                emitter_hit_weight<float>(e, Estimator::kMis, id, lobe_pdf[lobe], x, s.wi, hit.t);
            ASSERT_NEAR(light_side[lobe] + hit_side, 1.0f, 2e-4f)
                << "lobe " << lobe << " s " << shininess << " pdfs " << s.pdf << " "
                << lobe_pdf[lobe];
            ASSERT_TRUE(hit_side >= 0.0f && hit_side <= 1.0f);
            ++checked;
        }
        // nee counts the hit side not at all after a Phong lobe, the camera's in full
        EXPECT_EQ(emitter_hit_weight<float>(e, Estimator::kNee, id, 0.5f, x, s.wi, hit.t), 0.0f);
        EXPECT_EQ(emitter_hit_weight<float>(e, Estimator::kMis, id, 0.0f, x, s.wi, hit.t), 1.0f);
        EXPECT_EQ(emitter_hit_weight<float>(e, Estimator::kMis, -1, 0.5f, x, s.wi, hit.t), 1.0f);
    }
    EXPECT_GT(checked, 5000);
}

TEST(Mis, PowerHeuristicAtTheExtremesIsFinite) {
    for (float a : {0.0f, 1e-30f, 1.0f, 1e30f, std::numeric_limits<float>::max()})
        for (float b : {0.0f, 1e-30f, 1.0f, 1e30f, std::numeric_limits<float>::max()}) {
            const float w = power_heuristic(a, b);
            EXPECT_TRUE(w >= 0.0f && w <= 1.0f) << a << " " << b << " " << w;
        }
    EXPECT_EQ(power_heuristic(1.0f, 0.0f), 1.0f);
    EXPECT_NEAR(power_heuristic(1.0f, 1.0f), 0.5f, 1e-7f);
    EXPECT_NEAR(power_heuristic(3.0f, 1.0f), 0.9f, 1e-6f);
}

}  // namespace
}  // namespace cierzo
