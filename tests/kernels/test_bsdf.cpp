// The report's material as a scattering interface (kernels/estimator.h): each lobe's
// sample() against bsdf_eval()'s density and value, and the interface's own identities.
//   - chi-square of the diffuse (uniform and cosine) and Phong specular samplers (s = 0, 1,
//     20, 1000, 10⁴) against the densities bsdf_eval gives, integrated numerically over
//     bins of equal probability in the lobe's own variable;
//   - every sampled weight equals f·cos θ / (P(lobe)·pdf_lobe) from bsdf_eval;
//   - the reverse density equals the forward density with the directions swapped;
//   - the roulette's lobe probabilities sum to the continuation probability, choose_lobe
//     draws each lobe with them (chi-square);
//   - a white furnace per lobe: a white diffuse lobe reflects everything; a white Phong lobe
//     (s = 0 … 10⁴) everything at normal incidence and never more than everything; a white
//     mirror and a clear refraction exactly their colour.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "kernels/estimator.h"
#include "support/emitter_tests.h"
#include "support/statistics.h"

namespace cierzo {
namespace {

using test::Uniforms;

Bsdf<float> material(Vec3f kd, Vec3f ks, float s) {
    Bsdf<float> m{};
    m.kd = kd, m.ks = ks, m.shininess = s, m.ior = 1.0f;
    return m;
}

Vec3f random_direction(Uniforms& u) {
    for (;;) {
        const Vec3f v{2 * u() - 1, 2 * u() - 1, 2 * u() - 1};
        const float l = length(v);
        if (l > 1e-2f && l <= 1.0f) return v * (1.0f / l);
    }
}

// Chi-square of `count` directions from `sample` about `axis` in bins of the lobe's
// variable x(cos α) (increasing, x(-1) = 0 ... x(1) = 1 over the support) × 8 sectors of φ,
// against the density `pdf(dir)` integrated numerically over each bin.
template <class Sample, class Pdf, class X>
void expect_matches(const Vec3f& axis, const Sample& sample, const Pdf& pdf, const X& x_of_cos,
                    double cos_min) {
    constexpr int kBands = 16, kSectors = 8, kCount = 200000;
    // The band edges in cos α: x_of_cos inverted by bisection
    std::vector<double> edges(kBands + 1);
    for (int b = 0; b <= kBands; ++b) {
        double lo = cos_min, hi = 1.0;
        for (int k = 0; k < 60; ++k) {
            const double mid = 0.5 * (lo + hi);
            (x_of_cos(mid) < double(b) / kBands ? lo : hi) = mid;
        }
        edges[size_t(b)] = b == 0 ? cos_min : (b == kBands ? 1.0 : 0.5 * (lo + hi));
    }
    const Vec3f t = normalize(std::abs(axis.x) < 0.9f ? cross(axis, Vec3f(1, 0, 0))
                                                      : cross(axis, Vec3f(0, 1, 0)));
    const Vec3f b2 = cross(axis, t);
    const auto bin_of = [&](const Vec3f& d) {
        const double c = std::clamp(double(dot(d, axis)), -1.0, 1.0);
        int band = int(std::upper_bound(edges.begin(), edges.end(), c) - edges.begin()) - 1;
        band = std::clamp(band, 0, kBands - 1);
        double phi = std::atan2(double(dot(d, b2)), double(dot(d, t)));
        if (phi < 0) phi += 2 * M_PI;
        const int sector = std::min(int(phi / (2 * M_PI) * kSectors), kSectors - 1);
        return band * kSectors + sector;
    };
    std::vector<double> observed(kBands * kSectors, 0.0), expected(kBands * kSectors, 0.0);
    for (int k = 0; k < kCount; ++k) {
        const Vec3f d = sample();
        if (dot(d, axis) < cos_min - 1e-6f) {
            ADD_FAILURE() << "sample outside the lobe's support";
            return;
        }
        observed[size_t(bin_of(d))] += 1;
    }
    // ∫ pdf dω over each bin: 256 × 16 midpoints in (v, φ), v = log(1 - cos α) (a narrow
    // lobe's density lies close to cos α = 1: the points crowd there, dcos = (1 - cos) dv)
    for (int band = 0; band < kBands; ++band)
        for (int sector = 0; sector < kSectors; ++sector) {
            double sum = 0;
            const double v0 = std::log(1 - edges[size_t(band)]);
            const double v1 = std::log(std::max(1 - edges[size_t(band) + 1], 1e-14));
            constexpr int kSteps = 256;
            for (int i = 0; i < kSteps; ++i) {
                const double v = v0 + (v1 - v0) * (i + 0.5) / kSteps;
                const double c = 1 - std::exp(v);
                for (int j = 0; j < 16; ++j) {
                    const double phi = 2 * M_PI * (sector + (j + 0.5) / 16) / kSectors;
                    const double s = std::sqrt(std::max(0.0, 1 - c * c));
                    const Vec3f d = normalize(t * float(s * std::cos(phi)) +
                                              b2 * float(s * std::sin(phi)) + axis * float(c));
                    sum += double(pdf(d)) * std::exp(v);
                }
            }
            expected[size_t(band * kSectors + sector)] =
                kCount * sum * (v0 - v1) * (2 * M_PI / kSectors) / (kSteps * 16);
        }
    const auto [stat, dof] = test::chi_square(observed, expected);
    EXPECT_LT(stat, test::chi_square_critical(dof)) << "dof " << dof;
    if (stat > test::chi_square_critical(dof))
        for (size_t i = 0; i < observed.size(); i += kSectors)
            std::printf("band %zu [%.9f, %.9f]: observed %.0f expected %.1f\n", i / kSectors,
                        edges[i / kSectors], edges[i / kSectors + 1], observed[i], expected[i]);
}

TEST(Bsdf, DiffuseSamplingMatchesItsDensity) {
    Uniforms u;
    const Vec3f n = normalize(Vec3f{0.3f, 1.0f, -0.2f});
    const Vec3f wo = normalize(Vec3f{0.5f, 0.6f, 0.1f});
    for (bool cosine : {false, true}) {
        SCOPED_TRACE(cosine ? "cosine" : "uniform");
        const Bsdf<float> m = material(Vec3f(0.6f), Vec3f(0.0f), 0.0f);
        // The diffuse lobe alone: P(lobe) = 0.6, the density over it is pdf / 0.6
        expect_matches(
            n, [&] { return sample_diffuse(m, n, u(), u(), 1.0f, cosine).dir; },
            [&](const Vec3f& wi) { return bsdf_eval(m, wo, n, wi, 0.9f, cosine).pdf / 0.6f; },
            [&](double c) { return cosine ? c * c : c; }, 0.0);
    }
}

TEST(Bsdf, PhongSamplingMatchesItsDensity) {
    Uniforms u;
    const Vec3f n{0, 0, 1};
    const Vec3f wo = normalize(Vec3f{0.4f, -0.1f, 0.8f});
    const Vec3f r = normalize(reflect(-wo, n));
    for (float s : {0.0f, 1.0f, 20.0f, 1000.0f, 1e4f}) {
        SCOPED_TRACE(s);
        const Bsdf<float> m = material(Vec3f(0.0f), Vec3f(0.5f), s);
        expect_matches(
            r, [&] { return sample_specular(m, -wo, n, u(), u(), 1.0f).dir; },
            [&](const Vec3f& wi) { return bsdf_eval(m, wo, n, wi, 0.9f, false).pdf / 0.5f; },
            [&](double c) { return std::pow(c, double(s) + 1.0); }, 0.0);
    }
}

// sample() and eval() agree: weight = f·cos θ / (P(lobe)·pdf_lobe) for directions above the
// surface (0 below), for random materials, directions and exponents.
TEST(Bsdf, SampledWeightsAreFCosOverPdf) {
    Uniforms u;
    for (int k = 0; k < 5000; ++k) {
        const Vec3f n = random_direction(u);
        Vec3f wo = random_direction(u);
        if (dot(wo, n) < 0) wo = -wo;
        const float s = std::pow(10.0f, 4 * u());
        const Bsdf<float> m = material(Vec3f(u(), u(), u()), Vec3f(u(), u(), u()), s);
        const bool cosine = k % 2 == 0;
        const LobeProbabilities<float> lp = lobe_probabilities(m, 0.9f);
        for (int lobe : {kLobeDiffuse, kLobeSpecular}) {
            const float p = lp.lobe[lobe];
            const Scatter<float> sc = lobe == kLobeDiffuse
                                          ? sample_diffuse(m, n, u(), u(), p, cosine)
                                          : sample_specular(m, -wo, n, u(), u(), p);
            // The lobe's own value and density: eval of the material with that lobe alone
            Bsdf<float> alone = m;
            (lobe == kLobeDiffuse ? alone.ks : alone.kd) = Vec3f(0.0f);
            const BsdfEval<float> e = bsdf_eval(alone, wo, n, sc.dir, 0.9f, cosine);
            const float p_alone = lobe_probabilities(alone, 0.9f).lobe[lobe];
            if (!(e.pdf > 1e-6f) || dot(sc.dir, n) <= 1e-4f) {
                if (dot(sc.dir, n) <= 0.0f) {
                    EXPECT_EQ(max_component(sc.weight), 0.0f);
                }
                continue;
            }
            const float pdf_lobe = e.pdf / p_alone;
            for (int c = 0; c < 3; ++c) {
                const float expected = e.f[c] * e.cos_i / (p * pdf_lobe);
                // (cos^s magnifies the rounding of cos α s times)
                ASSERT_NEAR(sc.weight[c], expected, (1e-4f + 5e-7f * s) * expected + 1e-6f)
                    << "lobe " << lobe << " s " << s << " cos " << e.cos_i;
            }
        }
    }
}

TEST(Bsdf, ReverseDensityIsTheForwardOneSwapped) {
    Uniforms u;
    for (int k = 0; k < 20000; ++k) {
        const Vec3f n = random_direction(u);
        const Vec3f a = random_direction(u), b = random_direction(u);
        const float s = std::pow(10.0f, 4 * u()) - 1.0f;
        const Bsdf<float> m = material(Vec3f(u(), 0.2f, u()), Vec3f(0.1f, u(), u()), s);
        const bool cosine = k % 2 == 1;
        const BsdfEval<float> ab = bsdf_eval(m, a, n, b, 0.9f, cosine);
        const BsdfEval<float> ba = bsdf_eval(m, b, n, a, 0.9f, cosine);
        // (to the rounding of cos α, which cos^s magnifies s times)
        const float tol = 1e-5f + 5e-7f * s;
        ASSERT_NEAR(ab.pdf_reverse, ba.pdf, tol * ba.pdf + 1e-7f);
        ASSERT_NEAR(ab.pdf, ba.pdf_reverse, tol * ab.pdf + 1e-7f);
        // and the Phong lobes are symmetric: f(a, b) = f(b, a)
        ASSERT_NEAR(ab.f.y, ba.f.y, tol * ab.f.y + 1e-7f);
    }
}

TEST(Bsdf, RouletteProbabilitiesAreTheContinuationAndTheChoice) {
    Uniforms u;
    Bsdf<float> m{};
    m.kd = Vec3f(0.5f, 0.2f, 0.1f), m.ks = Vec3f(0.3f), m.kr = Vec3f(0.2f), m.kt = Vec3f(0.4f);
    const LobeProbabilities<float> lp = lobe_probabilities(m, 0.9f);
    EXPECT_NEAR(lp.survival, 0.9f, 1e-6f);  // Σ max RGB = 1.4 > 0.9: capped
    EXPECT_NEAR(lp.lobe[0] / lp.survival, 0.5f / 1.4f, 1e-6f);
    std::vector<double> observed(5, 0.0), expected(5, 0.0);
    const int n = 100000;
    for (int k = 0; k < n; ++k) {
        float p;
        const int32_t lobe = choose_lobe(m, u(), 0.9f, p);
        observed[size_t(lobe)] += 1;
        if (lobe < 4) {
            ASSERT_NEAR(p, lp.lobe[lobe], 1e-6f);  // (a difference of cumulative sums)
        }
    }
    for (int l = 0; l < 4; ++l) expected[size_t(l)] = n * double(lp.lobe[l]);
    expected[4] = n * (1.0 - double(lp.survival));
    const auto [stat, dof] = test::chi_square(observed, expected);
    EXPECT_LT(stat, test::chi_square_critical(dof));
}

TEST(Bsdf, WhiteFurnacePerLobe) {
    Uniforms u;
    const Vec3f n{0, 0, 1};
    const int count = 200000;
    // Diffuse: E[weight] = 1 at every incidence, both samplers
    for (bool cosine : {false, true}) {
        test::MeanEstimate albedo;
        const Bsdf<float> m = material(Vec3f(1.0f), Vec3f(0.0f), 0.0f);
        for (int k = 0; k < count; ++k)
            albedo.add(sample_diffuse(m, n, u(), u(), 1.0f, cosine).weight.x);
        EXPECT_NEAR(albedo.mean(), 1.0, 4 * albedo.standard_error() + 1e-6);
    }
    // Phong: ∫ f cos dω = 1 at normal incidence, ≤ 1 elsewhere (what falls below the
    // surface is lost), by sampling and by eval (the same at every incidence)
    for (float s : {0.0f, 1.0f, 10.0f, 100.0f, 1e4f}) {
        SCOPED_TRACE(s);
        const Bsdf<float> m = material(Vec3f(0.0f), Vec3f(1.0f), s);
        for (float incidence : {0.0f, 0.5f, 1.2f}) {
            const Vec3f wo{std::sin(incidence), 0.0f, std::cos(incidence)};
            test::MeanEstimate sampled, evaluated;
            for (int k = 0; k < count; ++k) {
                sampled.add(sample_specular(m, -wo, n, u(), u(), 1.0f).weight.x);
                // uniform over the hemisphere: f·cos·2π
                const Vec3f wi = sample_uniform_hemisphere(u(), u());
                const BsdfEval<float> e = bsdf_eval(m, wo, n, wi, 0.9f, false);
                evaluated.add(double(e.f.x) * double(e.cos_i) * 2 * M_PI);
            }
            if (incidence == 0.0f) {
                EXPECT_NEAR(sampled.mean(), 1.0, 4 * sampled.standard_error() + 1e-5);
                if (s <= 100.0f) {
                    EXPECT_NEAR(evaluated.mean(), 1.0, 4 * evaluated.standard_error() + 1e-5);
                }
            }
            EXPECT_LE(sampled.mean(), 1.0 + 4 * sampled.standard_error() + 1e-5);
            EXPECT_NEAR(sampled.mean(), evaluated.mean(),
                        4 * std::hypot(sampled.standard_error(), evaluated.standard_error()) + 1e-5)
                << "incidence " << incidence;
        }
    }
    // Mirror and refraction: exactly their colour over the probability
    Bsdf<float> m{};
    m.kr = Vec3f(1.0f), m.kt = Vec3f(1.0f), m.ior = 1.5f;
    const Vec3f d = normalize(Vec3f{0.3f, 0.1f, -1.0f});
    EXPECT_EQ(sample_mirror(m, d, n, 1.0f).weight.x, 1.0f);
    EXPECT_EQ(sample_refraction(m, d, n, n, 1.0f, 1.0f).weight.x, 1.0f);
}

}  // namespace
}  // namespace cierzo
