// The light samplers of paths that start at the emitters (kernels/light_sampling.h), against
// their stated densities: chi-square of points on a sphere and on a triangle (uniform by
// area), of emitted directions (cosine-weighted, either side) and of point-light directions
// (uniform); the densities integrate to 1; the density functions give the samplers' own
// densities at the sampled points; and nothing is NaN or infinite for degenerate triangles,
// tiny and huge emitters and the extreme uniform numbers. (The choice of an emitter by power
// is checked with next-event estimation's, in test_emitters.)
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "kernels/light_sampling.h"
#include "support/emitter_tests.h"
#include "support/statistics.h"

namespace cierzo {
namespace {

using test::Uniforms;

constexpr int kBins = 256;
constexpr int kSamples = kBins * 400;

void expect_uniform_over_bins(const std::vector<double>& observed) {
    const std::vector<double> expected(observed.size(), double(kSamples) / observed.size());
    const auto [stat, dof] = test::chi_square(observed, expected);
    EXPECT_LT(stat, test::chi_square_critical(dof)) << "dof " << dof;
}

bool finite(const Vec3f& v) {
    return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z);
}

// A uniform direction drawn here (normalised Gaussian), not by the samplers under test.
Vec3f gaussian_direction(std::mt19937& rng) {
    std::normal_distribution<float> g;
    for (;;) {
        const Vec3f v{g(rng), g(rng), g(rng)};
        if (length(v) > 1e-3f) return normalize(v);
    }
}

TEST(LightSampling, SpherePointsAreUniformByArea) {
    // Bins of equal area: 16 bands of cos θ about an oblique axis × 16 sectors of φ
    const Vec3f c{0.3f, -0.2f, 0.5f};
    const Scene scene = test::emitter_scene(
        R"({"type": "sphere", "center": [0.3, -0.2, 0.5], "radius": 0.5, "material": "L"})");
    const EmitterTable e = scene.emitters.table();
    ASSERT_EQ(e.count, 1);
    const Vec3f axis = normalize(Vec3f{1.0f, 2.0f, -0.5f});
    std::vector<double> observed(kBins, 0.0);
    Uniforms u;
    for (int k = 0; k < kSamples; ++k) {
        const EmitterPosition<float> s = sample_emitter_position(e, u(), u(), u(), u());
        ASSERT_TRUE(s.ok);
        ASSERT_EQ(s.id, 0);
        // pdf_A = 1 / (4πr²), the density function's; the point on the sphere, n outward
        ASSERT_NEAR(double(s.pdf) * 4.0 * M_PI * 0.25, 1.0, 1e-5);
        ASSERT_EQ(emitter_position_pdf<float>(e, s.id), s.pdf);
        ASSERT_NEAR(length(s.p - c), 0.5f, 1e-6f);
        ASSERT_NEAR(length(s.n), 1.0f, 1e-6f);
        ASSERT_NEAR(dot(s.n, normalize(s.p - c)), 1.0f, 1e-6f);
        ASSERT_EQ(s.le.x, 2.0f);
        observed[size_t(test::cone_bin(normalize(s.p - c), axis, 2.0))] += 1.0;
    }
    expect_uniform_over_bins(observed);
}

TEST(LightSampling, TrianglePointsAreUniformByArea) {
    // Bins of equal area: 64 congruent sub-triangles, from barycentrics solved here
    test::TriangleHistogram h;
    const Scene scene = test::emitter_scene(test::TriangleHistogram::object("M"));
    const EmitterTable e = scene.emitters.table();
    ASSERT_EQ(e.count, 1);
    Uniforms u;
    for (int i = 0; i < h.k * h.k * 1600; ++i) {
        const EmitterPosition<float> s = sample_emitter_position(e, u(), u(), u(), u());
        ASSERT_TRUE(s.ok);
        ASSERT_NEAR(double(s.pdf) * h.area(), 1.0, 1e-5);
        ASSERT_EQ(emitter_position_pdf<float>(e, s.id), s.pdf);
        ASSERT_NEAR(dot(s.n, h.normal()), 1.0f, 1e-6f);
        ASSERT_NEAR(dot(s.p - h.v0, s.n), 0.0f, 1e-5f);  // in the triangle's plane
        ASSERT_EQ(s.le.x, 7.0f);
        ASSERT_TRUE(h.add(s.p)) << "off the triangle";
    }
    const auto [stat, critical] = h.chi_square_test();
    EXPECT_LT(stat, critical);
}

TEST(LightSampling, EmittedDirectionsAreCosineWeightedOnEitherSide) {
    // pdf |cos θ|/(2π): each side half the time, and on each cos²θ and φ uniform. Bins:
    // 2 sides × 16 bands of cos²θ × 8 sectors of φ about the normal
    for (const Vec3f n : {Vec3f(0, 0, 1), Vec3f(0, 0, -1), normalize(Vec3f{0.3f, -0.8f, 0.2f})}) {
        SCOPED_TRACE(testing::Message() << n.x << " " << n.y << " " << n.z);
        std::vector<double> observed(kBins, 0.0);
        Uniforms u;
        for (int k = 0; k < kSamples; ++k) {
            const EmittedDirection<float> d = sample_emitted_direction(n, u(), u());
            ASSERT_NEAR(length(d.dir), 1.0f, 1e-6f);
            const test::Polar a = test::polar_about(d.dir, n);
            ASSERT_NEAR(d.cos_theta, std::abs(a.cos_theta), 1e-6);
            ASSERT_NEAR(d.pdf, std::abs(a.cos_theta) / (2.0 * M_PI), 2e-7);
            ASSERT_NEAR(emitted_direction_pdf(n, d.dir), d.pdf, 2e-7f);
            const int side = a.cos_theta >= 0.0 ? 0 : 1;
            const int band = test::part_of(a.cos_theta * a.cos_theta, 16);
            observed[size_t((side * 16 + band) * 8 + test::part_of(a.phi / (2.0 * M_PI), 8))] +=
                1.0;
        }
        expect_uniform_over_bins(observed);
    }
}

TEST(LightSampling, PointLightDirectionsAreUniform) {
    const Vec3f axis = normalize(Vec3f{-0.4f, 0.1f, 0.9f});
    std::vector<double> observed(kBins, 0.0);
    Uniforms u;
    for (int k = 0; k < kSamples; ++k) {
        const PointLightDirection<float> d = sample_point_light_direction(u(), u());
        ASSERT_NEAR(length(d.dir), 1.0f, 1e-6f);
        ASSERT_NEAR(double(d.pdf) * 4.0 * M_PI, 1.0, 1e-6);
        ASSERT_EQ(point_light_direction_pdf(d.dir), d.pdf);
        observed[size_t(test::cone_bin(d.dir, axis, 2.0))] += 1.0;
    }
    expect_uniform_over_bins(observed);
}

// Two spheres and two triangles of different powers, for the tests that need a table of
// several emitters (gathered, not broadcast).
Scene mixed_emitters() {
    return test::emitter_scene(
        R"({"type": "sphere", "center": [0, 0, 3], "radius": 0.2, "material": "L"},
           {"type": "sphere", "center": [1, 0, 3], "radius": 0.05, "material": "M"},
           {"type": "triangle", "vertices": [[0, 0, 0], [1, 0, 0], [0, 1, 0]], "material": "M"},
           {"type": "triangle", "vertices": [[0, 0, 1], [3, 0, 1], [0, 0.1, 1]],
            "material": "L"})");
}

TEST(LightSampling, DensitiesIntegrateToOne) {
    // Positions: ∫ pdf_A dA over every emitter's surface, by points uniform on the union of
    // the surfaces: an emitter j chosen uniformly (the density is constant over it, so where
    // on it does not matter), weighted N · area_j, the areas computed here from the records.
    const Scene scene = mixed_emitters();
    const EmitterTable e = scene.emitters.table();
    ASSERT_EQ(e.count, 4);
    std::mt19937 rng(2024);
    std::uniform_real_distribution<float> v(0.0f, 1.0f);
    test::MeanEstimate positions, directions, point_light;
    for (int k = 0; k < 400000; ++k) {
        const int32_t j = std::min(3, int32_t(v(rng) * 4.0f));
        const float* r = e.data + j * kEmitterStride;
        const double area =
            e.kind[j] == kEmitterSphere
                ? 4.0 * M_PI * double(r[3]) * r[3]
                : 0.5 * double(length(cross(Vec3f{r[4], r[5], r[6]}, Vec3f{r[7], r[8], r[9]})));
        positions.add(4.0 * area * double(emitter_position_pdf<float>(e, j)));
        // Directions: ∫ pdf_ω dω over the whole sphere, by uniform directions drawn here
        const Vec3f w = gaussian_direction(rng);
        const Vec3f n = normalize(Vec3f{0.3f, -0.8f, 0.2f});
        directions.add(4.0 * M_PI * double(emitted_direction_pdf(n, w)));
        point_light.add(4.0 * M_PI * double(point_light_direction_pdf(w)));
    }
    for (const test::MeanEstimate* m : {&positions, &directions, &point_light}) {
        EXPECT_NEAR(m->mean(), 1.0, 4.0 * m->standard_error() + 1e-6);
        EXPECT_LT(m->standard_error(), 0.004);
    }
}

TEST(LightSampling, DensityFunctionsGiveTheSamplersDensities) {
    // At each sampled point and direction, over a table of several emitters
    const Scene scene = mixed_emitters();
    const EmitterTable e = scene.emitters.table();
    Uniforms u;
    for (int k = 0; k < 100000; ++k) {
        const EmitterPosition<float> s = sample_emitter_position(e, u(), u(), u(), u());
        ASSERT_TRUE(s.ok);
        ASSERT_EQ(emitter_position_pdf<float>(e, s.id), s.pdf);
        const EmittedDirection<float> d = sample_emitted_direction(s.n, u(), u());
        ASSERT_NEAR(emitted_direction_pdf(s.n, d.dir), d.pdf, 2e-7f);
        ASSERT_GT(d.pdf, 0.0f);
    }
}

// A table of one emitter record, built by hand (the scene refuses what these test).
struct OneEmitter {
    float q = 1.0f, pmf = 1.0f;
    int32_t alias = 0, kind;
    float data[kEmitterStride];
    EmitterTable table() const { return {1, &q, &alias, &pmf, &kind, data, {}}; }
};

TEST(LightSampling, DegenerateTrianglesAreRefusedWithoutNaN) {
    // A triangle of zero area (collinear vertices) as the scene records it: area 0, normal z
    OneEmitter one{};
    one.kind = kEmitterTriangle;
    const float record[kEmitterStride] = {1, 1, 1, 0, 1, 0, 0, 2, 0, 0, 0, 0, 1, 3, 3, 3};
    std::copy(record, record + kEmitterStride, one.data);
    const EmitterTable e = one.table();
    for (const float a : {0.0f, 0.5f, 1.0f - 0x1.0p-24f})
        for (const float b : {0.0f, 0.5f, 1.0f - 0x1.0p-24f}) {
            const EmitterPosition<float> s = sample_emitter_position(e, a, b, a, b);
            EXPECT_FALSE(s.ok);
            EXPECT_EQ(s.pdf, 0.0f);
            EXPECT_TRUE(finite(s.p) && finite(s.n));
        }
    EXPECT_EQ(emitter_position_pdf<float>(e, 0), 0.0f);
    // In a scene it keeps its slot with power 0, and is never chosen
    const Scene scene = test::emitter_scene(
        R"({"type": "triangle", "vertices": [[0, 0, 0], [1, 0, 0], [2, 0, 0]], "material": "L"},
           {"type": "triangle", "vertices": [[0, 0, 1], [1, 0, 1], [0, 1, 1]], "material": "L"})");
    const EmitterTable t = scene.emitters.table();
    ASSERT_EQ(t.count, 2);
    const int32_t flat = t.data[3] == 0.0f ? 0 : 1;
    EXPECT_EQ(t.pmf[flat], 0.0f);
    Uniforms u;
    for (int k = 0; k < 100000; ++k) {
        const EmitterPosition<float> s = sample_emitter_position(t, u(), u(), u(), u());
        ASSERT_NE(s.id, flat);
        ASSERT_TRUE(s.ok);
    }
}

TEST(LightSampling, TinyAndHugeEmittersAndExtremeNumbersStayFinite) {
    // Spheres of radius 1e-4 and 1e4 and triangles of sides 1e-4 and 1e4, every sampler
    // at u = 0, 2^-24, 1/2 and 1 - 2^-24 in every argument
    const Scene scene = test::emitter_scene(
        R"({"type": "sphere", "center": [1, 2, 3], "radius": 1e-4, "material": "L"},
           {"type": "sphere", "center": [-5, 0, 0], "radius": 1e4, "material": "M"},
           {"type": "triangle", "vertices": [[0, 0, 0], [1e-4, 0, 0], [0, 1e-4, 0]],
            "material": "L"},
           {"type": "triangle", "vertices": [[0, 0, 5], [1e4, 0, 5], [0, 0, 1e4]],
            "material": "M"})");
    const EmitterTable e = scene.emitters.table();
    ASSERT_EQ(e.count, 4);
    const float extremes[4] = {0.0f, 0x1.0p-24f, 0.5f, 1.0f - 0x1.0p-24f};
    // Each emitter through a table of its own record (so each is sampled at every u)
    for (int32_t j = 0; j < 4; ++j) {
        SCOPED_TRACE(j);
        OneEmitter one{};
        one.kind = e.kind[j];
        std::copy(e.data + j * kEmitterStride, e.data + (j + 1) * kEmitterStride, one.data);
        const EmitterTable single = one.table();
        const float size = one.data[3];
        for (const float a : extremes)
            for (const float b : extremes) {
                const EmitterPosition<float> s = sample_emitter_position(single, a, b, a, b);
                ASSERT_TRUE(s.ok);
                ASSERT_TRUE(finite(s.p) && finite(s.n));
                ASSERT_TRUE(s.pdf > 0.0f && std::isfinite(s.pdf));
                ASSERT_NEAR(length(s.n), 1.0f, 1e-6f);
                // (on the sphere to the rounding of its centre's coordinates)
                const Vec3f c{one.data[0], one.data[1], one.data[2]};
                if (one.kind == kEmitterSphere) {
                    ASSERT_NEAR(length(s.p - c), size, 1e-6f * (size + length(c)));
                }
                for (const float c : extremes) {
                    const EmittedDirection<float> d = sample_emitted_direction(s.n, a, c);
                    ASSERT_TRUE(finite(d.dir));
                    ASSERT_NEAR(length(d.dir), 1.0f, 1e-6f);
                    ASSERT_TRUE(d.pdf > 0.0f && std::isfinite(d.pdf) && d.cos_theta > 0.0f);
                    const float back = emitted_direction_pdf(s.n, d.dir);
                    ASSERT_TRUE(back > 0.0f && std::isfinite(back));
                }
            }
        // and chosen from the whole table at the extreme numbers
        for (const float a : extremes)
            for (const float b : extremes) {
                const EmitterPosition<float> s = sample_emitter_position(e, a, b, b, a);
                ASSERT_TRUE(s.ok && finite(s.p) && finite(s.n) && std::isfinite(s.pdf));
            }
    }
    for (const float a : extremes)
        for (const float b : extremes) {
            const PointLightDirection<float> d = sample_point_light_direction(a, b);
            ASSERT_TRUE(finite(d.dir));
            ASSERT_NEAR(length(d.dir), 1.0f, 1e-6f);
        }
}

}  // namespace
}  // namespace cierzo
