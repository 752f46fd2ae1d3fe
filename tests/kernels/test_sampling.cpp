// Direction samplers against their densities (chi-square over bins of cos θ and φ), the
// orthonormal frame, and the counter-based random numbers (uniformity and independence).
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <random>

#include "kernels/rng.h"
#include "kernels/sampling.h"
#include "support/statistics.h"

namespace cierzo {
namespace {

constexpr int kCosBins = 16, kPhiBins = 8;
constexpr int kSamples = 200000;

// Histogram of local directions over (cos θ, φ) bins against the expected mass of each bin,
// given the CDF of cos θ (the samplers are all symmetric in φ).
void expect_matches_density(const std::function<Vec3f(float, float)>& sample,
                            const std::function<double(double)>& cos_cdf) {
    std::mt19937 rng(12345);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    std::vector<double> observed(kCosBins * kPhiBins, 0.0), expected(kCosBins * kPhiBins);
    for (int i = 0; i < kSamples; ++i) {
        const Vec3f d = sample(u(rng), u(rng));
        ASSERT_NEAR(length(d), 1.0f, 1e-5f);
        ASSERT_GE(d.z, 0.0f);
        const double phi = std::atan2(double(d.y), double(d.x)) + kPi;
        const int ci = std::min(int(double(d.z) * kCosBins), kCosBins - 1);
        const int pi = std::min(int(phi / (2.0 * kPi) * kPhiBins), kPhiBins - 1);
        observed[size_t(ci * kPhiBins + pi)] += 1.0;
    }
    for (int ci = 0; ci < kCosBins; ++ci) {
        const double mass = cos_cdf(double(ci + 1) / kCosBins) - cos_cdf(double(ci) / kCosBins);
        for (int pi = 0; pi < kPhiBins; ++pi)
            expected[size_t(ci * kPhiBins + pi)] = mass / kPhiBins * kSamples;
    }
    const auto [stat, dof] = test::chi_square(observed, expected);
    EXPECT_LT(stat, test::chi_square_critical(dof)) << "dof " << dof;
}

TEST(Sampling, UniformHemisphereMatchesItsDensity) {
    // pdf 1/(2π): cos θ is uniform on [0, 1]
    expect_matches_density([](float a, float b) { return sample_uniform_hemisphere(a, b); },
                           [](double c) { return c; });
}

TEST(Sampling, CosineHemisphereMatchesItsDensity) {
    // pdf cos θ/π: P(cos θ ≤ c) = c²
    expect_matches_density([](float a, float b) { return sample_cosine_hemisphere(a, b); },
                           [](double c) { return c * c; });
}

TEST(Sampling, PhongLobeMatchesItsDensityForManyExponents) {
    // pdf (s+1)/(2π)·cos^s α: P(cos α ≤ c) = c^(s+1)
    for (float s : {0.0f, 1.0f, 10.0f, 100.0f}) {
        SCOPED_TRACE(s);
        expect_matches_density([s](float a, float b) { return sample_phong_lobe(a, b, s); },
                               [s](double c) { return std::pow(c, double(s) + 1.0); });
    }
}

TEST(Sampling, UniformSamplerFailsTheCosineDensity) {
    // The test has power: the uniform sampler is rejected against the cosine density
    std::mt19937 rng(7);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    std::vector<double> observed(kCosBins, 0.0), expected(kCosBins);
    for (int i = 0; i < kSamples; ++i)
        observed[size_t(std::min(int(sample_uniform_hemisphere(u(rng), u(rng)).z * kCosBins),
                                 kCosBins - 1))] += 1;
    for (int i = 0; i < kCosBins; ++i)
        expected[size_t(i)] =
            (std::pow((i + 1.0) / kCosBins, 2) - std::pow(double(i) / kCosBins, 2)) * kSamples;
    const auto [stat, dof] = test::chi_square(observed, expected);
    EXPECT_GT(stat, test::chi_square_critical(dof));
}

TEST(Sampling, ExtremeExponentsStayFiniteAndInTheLobe) {
    for (float s : {0.0f, 1e4f, 1e6f}) {
        for (float a : {0.0f, 1e-7f, 0.5f, 0.9999999f}) {
            const Vec3f d = sample_phong_lobe(a, 0.3f, s);
            EXPECT_TRUE(std::isfinite(d.x) && std::isfinite(d.y) && std::isfinite(d.z));
            EXPECT_NEAR(length(d), 1.0f, 1e-5f);
            EXPECT_GE(d.z, 0.0f);
        }
    }
    // s = 1e4 concentrates the lobe: 99% of the mass within cos α > 0.9995
    EXPECT_GT(sample_phong_lobe(0.99f, 0.0f, 1e4f).z, 0.9995f);
}

TEST(Sampling, SinCos2PiMatchesTheLibraryEverywhere) {
    // Every quadrant boundary, both ends, and a dense sweep of [0, 1)
    std::vector<float> us = {0.0f,  0.125f, 0.25f,       0.375f, 0.5f,       0.625f,
                             0.75f, 0.875f, 0.99999994f, 1e-8f,  0.2499999f, 0.2500001f};
    for (int i = 0; i < 100000; ++i) us.push_back(float(i) / 100000.0f);
    for (float u : us) {
        float s, c;
        sincos_2pi(u, s, c);
        const double a = 2.0 * M_PI * double(u);
        EXPECT_NEAR(s, std::sin(a), 2e-7) << u;
        EXPECT_NEAR(c, std::cos(a), 2e-7) << u;
    }
}

TEST(Frame, OrthonormalForEveryNormalIncludingPoles) {
    std::mt19937 rng(3);
    std::normal_distribution<float> g;
    std::vector<Vec3f> normals = {
        {0, 0, 1}, {0, 0, -1}, {1, 0, 0}, {0, -1, 0}, normalize(Vec3f{0, 1e-7f, -1})};
    for (int i = 0; i < 1000; ++i) normals.push_back(normalize(Vec3f{g(rng), g(rng), g(rng)}));
    for (const Vec3f& n : normals) {
        Vec3f t, b;
        orthonormal_basis(n, t, b);
        EXPECT_NEAR(dot(t, n), 0.0f, 1e-5f);
        EXPECT_NEAR(dot(b, n), 0.0f, 1e-5f);
        EXPECT_NEAR(dot(t, b), 0.0f, 1e-5f);
        EXPECT_NEAR(length(t), 1.0f, 1e-5f);
        EXPECT_NEAR(length(b), 1.0f, 1e-5f);
        // to_world keeps the local z as the cosine to n
        const Vec3f w = to_world(Vec3f{0.6f, 0.0f, 0.8f}, n);
        EXPECT_NEAR(dot(w, n), 0.8f, 1e-5f);
    }
}

TEST(Rng, UniformOverPixelsSamplesAndPurposes) {
    std::vector<double> observed(64, 0.0);
    int n = 0;
    for (uint32_t pixel = 0; pixel < 256; ++pixel)
        for (uint32_t s = 0; s < 64; ++s)
            for (uint32_t bounce = 0; bounce < 4; ++bounce) {
                const uint32_t key = path_key(7u, pixel, s);
                const float u = uniform<float>(key, bounce, Purpose::kLobe);
                ASSERT_GE(u, 0.0f);
                ASSERT_LT(u, 1.0f);
                observed[size_t(u * 64.0f)] += 1.0, ++n;
            }
    const std::vector<double> expected(64, double(n) / 64.0);
    const auto [stat, dof] = test::chi_square(observed, expected);
    EXPECT_LT(stat, test::chi_square_critical(dof));
}

TEST(Rng, PurposesAndNeighboursAreUncorrelated) {
    // Correlation between the two direction numbers, between neighbouring pixels, between
    // consecutive samples and between seeds: all ~0 (|r| < 4.5/sqrt(n))
    const int n = 100000;
    auto corr = [&](const std::function<std::pair<float, float>(int)>& pair) {
        double sx = 0, sy = 0, sxx = 0, syy = 0, sxy = 0;
        for (int i = 0; i < n; ++i) {
            auto [x, y] = pair(i);
            sx += x, sy += y, sxx += x * x, syy += y * y, sxy += x * y;
        }
        const double cov = sxy / n - sx / n * sy / n;
        return cov / std::sqrt((sxx / n - sx * sx / n / n) * (syy / n - sy * sy / n / n));
    };
    const double bound = 4.5 / std::sqrt(double(n));
    EXPECT_LT(std::abs(corr([](int i) {
                  const uint32_t k = path_key(1u, uint32_t(i), 0u);
                  return std::pair{uniform<float>(k, 0u, Purpose::kDirection1),
                                   uniform<float>(k, 0u, Purpose::kDirection2)};
              })),
              bound);
    EXPECT_LT(std::abs(corr([](int i) {
                  return std::pair{
                      uniform<float>(path_key(1u, uint32_t(i), 0u), 0u, Purpose::kLobe),
                      uniform<float>(path_key(1u, uint32_t(i) + 1, 0u), 0u, Purpose::kLobe)};
              })),
              bound);
    EXPECT_LT(std::abs(corr([](int i) {
                  return std::pair{
                      uniform<float>(path_key(1u, 5u, uint32_t(i)), 1u, Purpose::kLobe),
                      uniform<float>(path_key(1u, 5u, uint32_t(i) + 1), 1u, Purpose::kLobe)};
              })),
              bound);
    EXPECT_LT(std::abs(corr([](int i) {
                  return std::pair{
                      uniform<float>(path_key(1u, uint32_t(i), 0u), 2u, Purpose::kLobe),
                      uniform<float>(path_key(2u, uint32_t(i), 0u), 2u, Purpose::kLobe)};
              })),
              bound);
}

TEST(Rng, SimdLanesDrawTheSameNumbersAsScalar) {
    using B = xsimd::batch<float>;
    using U = xsimd::batch<uint32_t>;
    alignas(64) uint32_t pixels[U::size], samples[U::size];
    for (size_t i = 0; i < U::size; ++i)
        pixels[i] = 1000u + 37u * uint32_t(i), samples[i] = uint32_t(i) * 3u;
    const U key = path_key(9u, U::load_aligned(pixels), U::load_aligned(samples));
    const B u = uniform<B>(key, U(3u), Purpose::kDirection2);
    alignas(64) float out[B::size];
    u.store_aligned(out);
    for (size_t i = 0; i < B::size; ++i) {
        const uint32_t k = path_key(9u, pixels[i], samples[i]);
        EXPECT_EQ(out[i], uniform<float>(k, 3u, Purpose::kDirection2));
    }
}

}  // namespace
}  // namespace cierzo
