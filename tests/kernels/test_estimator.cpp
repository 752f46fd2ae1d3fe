// The estimator's lobe choice and weights: roulette frequencies against the stated
// probabilities (chi-square), and for every lobe, the mean of weight × [lobe chosen] against
// the lobe's directional albedo ∫ f cos θ dω computed independently by quadrature. Each
// check is tight enough (standard error < 0.5% of the value) to catch a 5% weight error.
#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <random>

#include "kernels/estimator.h"
#include "support/statistics.h"

namespace cierzo {
namespace {

Bsdf<float> make(Vec3f kd, Vec3f ks, float s, Vec3f kr, Vec3f kt, float ior = 1.5f) {
    return {kd, ks, kr, kt, s, ior};
}

TEST(Roulette, FrequenciesMatchMaxRgbProbabilities) {
    const Bsdf<float> m = make({0.1f, 0.3f, 0.2f}, {0.2f, 0.1f, 0.0f}, 10.0f, {0.05f, 0.0f, 0.1f},
                               {0.0f, 0.2f, 0.0f});
    // p = (0.3, 0.2, 0.1, 0.2), sum 0.8 < cap: unscaled, death 0.2
    const double p[5] = {0.3, 0.2, 0.1, 0.2, 0.2};
    std::vector<double> observed(5, 0.0), expected(5);
    std::mt19937 rng(1);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    const int n = 200000;
    for (int i = 0; i < n; ++i) {
        float prob = 0;
        const int lobe = choose_lobe(m, u(rng), 0.9f, prob);
        ASSERT_GE(lobe, 0);
        ASSERT_LE(lobe, 4);
        if (lobe < 4) {
            EXPECT_NEAR(prob, p[lobe], 1e-6);
        }
        observed[size_t(lobe)] += 1;
    }
    for (int i = 0; i < 5; ++i) expected[size_t(i)] = p[i] * n;
    const auto [stat, dof] = test::chi_square(observed, expected);
    EXPECT_LT(stat, test::chi_square_critical(dof));
}

TEST(Roulette, ScaledDownToTheSurvivalCap) {
    const Bsdf<float> m = make(Vec3f(0.9f), Vec3f(0.6f), 1.0f, Vec3f(0.0f), Vec3f(0.0f));
    float prob = 0;
    // Σ = 1.5 > 0.9: each scaled by 0.6
    EXPECT_EQ(choose_lobe(m, 0.1f, 0.9f, prob), kLobeDiffuse);
    EXPECT_NEAR(prob, 0.54f, 1e-6f);
    EXPECT_EQ(choose_lobe(m, 0.6f, 0.9f, prob), kLobeSpecular);
    EXPECT_NEAR(prob, 0.36f, 1e-6f);
    EXPECT_EQ(choose_lobe(m, 0.9f, 0.9f, prob), kLobeAbsorbed);
    // A black material always dies
    EXPECT_EQ(choose_lobe(make(Vec3f(0), Vec3f(0), 0, Vec3f(0), Vec3f(0)), 0.0f, 0.9f, prob),
              kLobeAbsorbed);
}

// The one-lobe roulette (what a scene with one lobe kind runs) makes exactly the general
// roulette's choice, with the same probability bit for bit, for materials with only that
// lobe: below and above the survival cap, black, and u right at the threshold.
TEST(Roulette, OneLobeFormMatchesTheGeneralOneExactly) {
    std::mt19937 rng(7);
    std::uniform_real_distribution<float> u(0.0f, 1.0f), c(0.0f, 1.2f);
    auto check = [&](auto only) {
        constexpr int kOnly = decltype(only)::value;
        SCOPED_TRACE(kOnly);
        for (int i = 0; i < 20000; ++i) {
            Bsdf<float> m = make(Vec3f(0), Vec3f(0), 20.0f, Vec3f(0), Vec3f(0));
            Vec3f* colour[4] = {&m.kd, &m.ks, &m.kr, &m.kt};
            *colour[kOnly] = i % 97 == 0 ? Vec3f(0) : Vec3f{c(rng), c(rng), c(rng)};
            float un = u(rng);
            if (i % 13 == 0) {  // exactly at the threshold
                const float p = max_component(*colour[kOnly]);
                un = p > 0.9f ? 0.9f : p;
            }
            float p_general = -1, p_one = -1;
            const int general = choose_lobe(m, un, 0.9f, p_general);
            const int one = choose_lobe<kOnly>(m, un, 0.9f, p_one);
            ASSERT_EQ(one, general) << "u " << un;
            ASSERT_EQ(std::bit_cast<uint32_t>(p_one), std::bit_cast<uint32_t>(p_general))
                << "u " << un << ": " << p_one << " vs " << p_general;
        }
    };
    check(std::integral_constant<int, kLobeDiffuse>{});
    check(std::integral_constant<int, kLobeSpecular>{});
    check(std::integral_constant<int, kLobeMirror>{});
    check(std::integral_constant<int, kLobeRefract>{});
}

// ∫ ks-free Phong lobe · cos θi dω for view direction d (unit, towards the surface) and
// normal +z: (s+2)/(2π)·∫ max(cos α,0)^s·max(cos θi,0) dω, by a fine midpoint rule over
// the sphere in coordinates around the mirror direction.
double phong_albedo(const Vec3f& d, float s) {
    const Vec3f n{0, 0, 1};
    const Vec3f r = reflect(d, n);
    Vec3f t, b;
    orthonormal_basis(r, t, b);
    const int na = 4000, nb = 256;
    double sum = 0.0;
    for (int i = 0; i < na; ++i) {
        // x = cos^(s+1) α uniform on [0,1] maps the lobe's mass evenly onto the grid:
        // ∫ cos^s α sin α dα = ∫ dx/(s+1)
        const double x = (i + 0.5) / na;
        const double ca = std::pow(x, 1.0 / (double(s) + 1.0));
        const double sa = std::sqrt(std::max(0.0, 1.0 - ca * ca));
        for (int j = 0; j < nb; ++j) {
            const double phi = 2.0 * M_PI * (j + 0.5) / nb;
            const double cz = ca * r.z + sa * (std::cos(phi) * t.z + std::sin(phi) * b.z);
            sum += std::max(cz, 0.0);
        }
    }
    // (s+2)/(2π) · (1/(s+1)) · 2π · mean
    return (double(s) + 2.0) / (double(s) + 1.0) * sum / (double(na) * nb);
}

struct LobeCase {
    const char* name;
    Bsdf<float> m;
    int lobe;
};

// Mean over many samples of the lobe's weight when it is chosen (0 otherwise).
Vec3f mean_lobe_weight(const Bsdf<float>& m, int lobe, const Vec3f& d, bool cosine,
                       test::MeanEstimate est[3]) {
    const Vec3f n{0, 0, 1};
    const Vec3f nf = facing_normal(n, d);
    std::mt19937 rng(2024);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    const int samples = 400000;
    for (int i = 0; i < samples; ++i) {
        float p = 0;
        const float ul = u(rng), u1 = u(rng), u2 = u(rng);
        const int chosen = choose_lobe(m, ul, 0.9f, p);
        Vec3f w(0.0f);
        if (chosen == lobe) {
            Scatter<float> s;
            if (lobe == kLobeDiffuse) s = sample_diffuse(m, nf, u1, u2, p, cosine);
            if (lobe == kLobeSpecular) s = sample_specular(m, d, nf, u1, u2, p);
            if (lobe == kLobeMirror) s = sample_mirror(m, d, nf, p);
            if (lobe == kLobeRefract) s = sample_refraction(m, d, n, n, 1.0f, p);
            w = s.weight;
            EXPECT_NEAR(length(s.dir), 1.0f, 1e-4f);
        }
        est[0].add(w.x), est[1].add(w.y), est[2].add(w.z);
    }
    return {float(est[0].mean()), float(est[1].mean()), float(est[2].mean())};
}

void expect_albedo(const Bsdf<float>& m, int lobe, const Vec3f& d, const Vec3f& expected,
                   bool cosine = false) {
    test::MeanEstimate est[3];
    mean_lobe_weight(m, lobe, d, cosine, est);
    for (int c = 0; c < 3; ++c) {
        if (expected[c] == 0.0f) {
            EXPECT_EQ(est[c].mean(), 0.0);
            continue;
        }
        // Power: a 5% error is more than 10 standard errors away
        EXPECT_LT(est[c].standard_error(), 0.005 * expected[c]) << "channel " << c;
        EXPECT_NEAR(est[c].mean(), expected[c], 4.0 * est[c].standard_error())
            << "channel " << c << " lobe " << lobe;
    }
}

const Vec3f kViews[] = {normalize(Vec3f{0, 0, -1}), normalize(Vec3f{0.5f, 0, -1}),
                        normalize(Vec3f{1, 0.3f, -0.2f})};

TEST(LobeWeights, DiffuseAlbedoIsKdForBothSamplers) {
    const Bsdf<float> m = make({0.2f, 0.5f, 0.7f}, Vec3f(0.1f), 5, Vec3f(0.1f), Vec3f(0.0f));
    for (const Vec3f& d : kViews) {
        expect_albedo(m, kLobeDiffuse, d, m.kd, false);
        expect_albedo(m, kLobeDiffuse, d, m.kd, true);
    }
}

TEST(LobeWeights, PhongSpecularAlbedoMatchesQuadrature) {
    for (float s : {0.0f, 3.0f, 40.0f, 1000.0f}) {
        const Bsdf<float> m = make(Vec3f(0.2f), {0.6f, 0.3f, 0.1f}, s, Vec3f(0), Vec3f(0));
        for (const Vec3f& d : kViews) {
            SCOPED_TRACE(testing::Message() << "s=" << s << " d.z=" << d.z);
            const float a = float(phong_albedo(d, s));
            expect_albedo(m, kLobeSpecular, d, m.ks * a);
        }
    }
}

TEST(LobeWeights, MirrorAndRefractionCarryTheirColour) {
    const Bsdf<float> m = make(Vec3f(0.1f), Vec3f(0), 0, {0.3f, 0.2f, 0.1f}, {0.2f, 0.4f, 0.3f});
    for (const Vec3f& d : kViews) {
        expect_albedo(m, kLobeMirror, d, m.kr);
        expect_albedo(m, kLobeRefract, d, m.kt);
    }
}

TEST(LobeWeights, PhongBrdfEvaluationMatchesTheFormula) {
    const Bsdf<float> m = make({0.5f, 0.4f, 0.3f}, {0.2f, 0.2f, 0.2f}, 8.0f, Vec3f(0), Vec3f(0));
    const Vec3f d = normalize(Vec3f{1, 0, -1});
    const Vec3f n{0, 0, 1};
    const Vec3f wi = normalize(Vec3f{1, 0.2f, 0.8f});
    const Vec3f r = normalize(Vec3f{1, 0, 1});
    const float cos_i = wi.z, cos_a = dot(wi, r);
    const float spec = 0.2f * 10.0f / (2.0f * kPi) * std::pow(cos_a, 8.0f);
    const Vec3f got = phong_f_cos(m, d, n, wi);
    EXPECT_NEAR(got.x, (0.5f / kPi + spec) * cos_i, 1e-5f);
    EXPECT_NEAR(got.z, (0.3f / kPi + spec) * cos_i, 1e-5f);
    // Below the surface: nothing
    EXPECT_EQ(max_component(phong_f_cos(m, d, n, Vec3f{0, 0, -1})), 0.0f);
}

TEST(Refraction, SnellAndTotalInternalReflection) {
    const Bsdf<float> m = make(Vec3f(0), Vec3f(0), 0, Vec3f(0), Vec3f(1), 1.5f);
    const Vec3f n{0, 0, 1};
    // Entering at 45°: sin θt = sin 45° / 1.5
    const Vec3f d_in = normalize(Vec3f{1, 0, -1});
    const Scatter<float> in = sample_refraction(m, d_in, n, n, 1.0f, 1.0f);
    EXPECT_NEAR(in.dir.x, std::sin(kPi / 4) / 1.5f, 1e-5f);
    EXPECT_LT(in.dir.z, 0.0f);
    // Leaving at 30° (below the critical 41.8°): sin θt = 1.5 sin 30°
    const Vec3f d_out = normalize(Vec3f{std::sin(kPi / 6), 0, std::cos(kPi / 6)});
    const Scatter<float> out = sample_refraction(m, d_out, n, n, 1.0f, 1.0f);
    EXPECT_NEAR(out.dir.x, 0.75f, 1e-5f);
    EXPECT_GT(out.dir.z, 0.0f);
    // Leaving at 60°: total internal reflection, stays inside (z < 0... reflected back)
    const Vec3f d_tir = normalize(Vec3f{std::sin(kPi / 3), 0, std::cos(kPi / 3)});
    const Scatter<float> tir = sample_refraction(m, d_tir, n, n, 1.0f, 1.0f);
    EXPECT_NEAR(tir.dir.x, d_tir.x, 1e-5f);
    EXPECT_NEAR(tir.dir.z, -d_tir.z, 1e-5f);
    EXPECT_FLOAT_EQ(tir.weight.x, 1.0f);
    // The scene's index counts: ior equal to the scene's bends nothing
    const Scatter<float> same = sample_refraction(m, d_in, n, n, 1.5f, 1.0f);
    EXPECT_NEAR(same.dir.x, d_in.x, 1e-6f);
    EXPECT_NEAR(same.dir.z, d_in.z, 1e-6f);
}

TEST(Textures, PatternsMatchTheirFormulas) {
    ColorSource c;
    c.kind = TextureKind::kSin;
    c.a = Vec3f(0.0f);
    c.b = Vec3f{1.0f, 0.5f, 0.0f};
    c.frequency = 2.0f;
    const Vec3f p{0.3f, 0.7f, -0.2f};
    const float v = 0.5f + 0.5f * std::sin(2.0f * 0.3f);
    EXPECT_NEAR(eval_pattern(c, p).x, v, 1e-6f);
    EXPECT_NEAR(eval_pattern(c, p).y, 0.5f * v, 1e-6f);
    c.kind = TextureKind::kSin2;
    EXPECT_NEAR(eval_pattern(c, p).x, std::pow(std::sin(0.6f), 2.0f), 1e-6f);
    c.kind = TextureKind::kSinCos;
    EXPECT_NEAR(eval_pattern(c, p).x, 0.5f + 0.5f * std::sin(0.6f) * std::cos(1.4f), 1e-6f);
    // Vertex colours: nearest and inverse-distance weighted
    const Vec3f v3[3] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
    const Vec3f col[3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
    ColorSource vc;
    vc.kind = TextureKind::kVertexNearest;
    vc.a = Vec3f(1.0f);
    const Vec3f near1 = eval_vertex_color(vc, Vec3f{0.7f, 0.1f, 0.0f}, v3, col);
    EXPECT_EQ(near1.y, 1.0f);
    vc.kind = TextureKind::kVertexWeighted;
    const Vec3f q{0.25f, 0.25f, 0.0f};
    const float w0 = 1 / length(q - v3[0]), w1 = 1 / length(q - v3[1]), w2 = 1 / length(q - v3[2]);
    const Vec3f wtd = eval_vertex_color(vc, q, v3, col);
    EXPECT_NEAR(wtd.x, w0 / (w0 + w1 + w2), 1e-6f);
    EXPECT_NEAR(wtd.z, w2 / (w0 + w1 + w2), 1e-6f);
}

}  // namespace
}  // namespace cierzo
