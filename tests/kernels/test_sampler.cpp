// The samplers' sequences (kernels/sampler.h, src/scene/pmj02.cpp):
//   - Sobol's dimension 1 as its generator matrix gives it (the superset-sum form is exact);
//   - stratification: every 2D projection used (each slot of each bounce) of the first 2^k
//     samples of a pixel puts one point in each elementary interval of area 2^-k, for sobol,
//     zsobol and pmj02, before scrambling (the plain Sobol points in prefixes and aligned
//     blocks, the pmj02 tables in prefixes) and after; a planted off-by-one in the index is caught;
//   - the scrambles differ across pixels, seeds and pairs, and no two decisions share a
//     dimension: E[u_a·u_b] = 1/4 for every two decisions of a path (1/3 for a planted reuse);
//   - each uniform is uniform (a chi-square over 64 bins), and the lanes' values are the
//     scalar code's, bit for bit.
#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <set>
#include <vector>

#include "kernels/sampler.h"
#include "scene/pmj02.h"
#include "support/statistics.h"

namespace cierzo {
namespace {

SamplerSetup setup_of(Sampler kind, uint32_t log2_spp = 8) {
    SamplerSetup s;
    s.kind = kind;
    s.log2_spp = log2_spp;
    if (kind == Sampler::kPmj02) s.pmj02 = pmj02_tables();
    return s;
}

// Whether the n = 2^k points (32-bit fixed point) occupy every elementary interval of area
// 1/n once: for every split of k bits into a column bits and k - a row bits.
bool stratified(const std::vector<uint32_t>& x, const std::vector<uint32_t>& y) {
    const size_t n = x.size();
    const int k = std::countr_zero(n);
    for (int a = 0; a <= k; ++a) {
        std::vector<uint8_t> seen(n, 0);
        for (size_t i = 0; i < n; ++i) {
            const uint32_t col = a == 0 ? 0u : x[i] >> (32 - a);
            const uint32_t row = a == k ? 0u : y[i] >> (32 - (k - a));
            const size_t cell = (size_t(row) << a) | col;
            if (seen[cell]++) return false;
        }
    }
    return true;
}

TEST(Sobol, DimensionOneIsItsGeneratorMatrix) {
    // Direction numbers of dimension 1 (primitive polynomial x + 1): v_1 = 1/2,
    // v_k = v_{k-1} xor v_{k-1}/2
    uint32_t v[32];
    v[0] = 0x80000000u;
    for (int k = 1; k < 32; ++k) v[k] = v[k - 1] ^ (v[k - 1] >> 1);
    for (uint32_t i : {0u, 1u, 2u, 3u, 5u, 77u, 1023u, 65535u, 0x12345678u, 0xffffffffu}) {
        uint32_t expected = 0;
        for (int b = 0; b < 32; ++b)
            if (i >> b & 1u) expected ^= v[b];
        EXPECT_EQ(sobol1(i), expected) << "index " << i;
    }
    EXPECT_EQ(reverse_bits(1u), 0x80000000u);
    EXPECT_EQ(reverse_bits(0x0000f00du), 0xb00f0000u);
}

TEST(Sobol, PlainPointsAreStratifiedInEveryPrefixAndBlock) {
    for (int k = 0; k <= 12; ++k) {
        const uint32_t n = 1u << k;
        for (uint32_t block : {0u, 1u, 5u}) {
            std::vector<uint32_t> x, y;
            for (uint32_t i = block * n; i < (block + 1) * n; ++i)
                x.push_back(reverse_bits(i)), y.push_back(sobol1(i));
            EXPECT_TRUE(stratified(x, y)) << "2^" << k << " points, block " << block;
        }
    }
}

TEST(Pmj02, TablesAreProgressiveAndStratifiedInEveryPrefixAndBlock) {
    const uint32_t* tables = pmj02_tables();
    for (uint32_t t = 0; t < kPmj02Tables; ++t) {
        const uint32_t* table = tables + size_t(t) * kPmj02Points;
        // (every prefix; aligned blocks past the first are not nets in general, so the
        // sampler shuffles indices only inside each octave)
        for (uint32_t n = 1; n <= kPmj02Points; n *= 2) {
            std::vector<uint32_t> x, y;
            for (uint32_t i = 0; i < n; ++i)
                x.push_back(table[i] << 16), y.push_back(table[i] & 0xffff0000u);
            ASSERT_TRUE(stratified(x, y)) << "table " << t << ", first " << n << " points";
        }
        // Multi-jittered: the first 4^k points fall one in each cell of a 2^k grid
        for (int k = 1; k <= 6; ++k) {
            std::set<uint32_t> cells;
            for (uint32_t i = 0; i < (1u << (2 * k)); ++i)
                cells.insert(((table[i] & 0xffffu) >> (16 - k)) << k | (table[i] >> (32 - k)));
            EXPECT_EQ(cells.size(), size_t(1) << (2 * k)) << "table " << t;
        }
    }
    // Made from the seed alone
    EXPECT_EQ(make_pmj02_table(256, 7), make_pmj02_table(256, 7));
    EXPECT_NE(make_pmj02_table(256, 7), make_pmj02_table(256, 8));
}

// The first 2^k samples of pixel (px, py) in slot `slot` of `bounce`.
void pixel_points(Sampler kind, uint32_t seed, uint32_t px, uint32_t py, uint32_t bounce,
                  uint32_t slot, uint32_t n, std::vector<uint32_t>& x, std::vector<uint32_t>& y,
                  uint32_t index_offset = 0) {
    const SamplerSetup setup = setup_of(kind, uint32_t(std::countr_zero(n)));
    x.clear(), y.clear();
    for (uint32_t s = 0; s < n; ++s) {
        const SampleStream<float> rng =
            camera_stream<float>(setup, seed, py * 640u + px, px, py, s + index_offset);
        uint32_t a, b;
        sample_point(rng, bounce, slot, a, b);
        x.push_back(a), y.push_back(b);
    }
}

TEST(Samplers, EveryDecisionPairOfAPixelIsStratified) {
    for (Sampler kind : {Sampler::kSobol, Sampler::kZSobol, Sampler::kPmj02}) {
        for (uint32_t n : {1u, 2u, 4u, 16u, 64u, 256u, 1024u}) {
            for (uint32_t bounce : {0u, 1u, 7u, 40u})
                for (uint32_t slot = 0; slot < kSlotsPerBounce; ++slot)
                    for (uint32_t pixel : {0u, 1u, 333u}) {
                        std::vector<uint32_t> x, y;
                        pixel_points(kind, 17u, pixel, pixel / 7, bounce, slot, n, x, y);
                        ASSERT_TRUE(stratified(x, y))
                            << "sampler " << int(kind) << ", " << n << " samples, bounce " << bounce
                            << ", slot " << slot << ", pixel " << pixel;
                    }
        }
        // A progressive render's prefix: the first 2^k of a pixel's 1024 are stratified too
        if (kind != Sampler::kZSobol) {
            std::vector<uint32_t> x, y;
            for (uint32_t n : {8u, 32u, 128u}) {
                pixel_points(kind, 3u, 5, 9, 2, 2, n, x, y);
                EXPECT_TRUE(stratified(x, y));
            }
        }
    }
}

TEST(Samplers, AnIndexOffByOneIsCaught) {
    // Samples 1..n of a pixel (a planted off-by-one) are not a net
    int caught = 0;
    for (uint32_t pixel = 0; pixel < 8; ++pixel) {
        std::vector<uint32_t> x, y;
        pixel_points(Sampler::kSobol, 17u, pixel, 0, 1, 2, 64, x, y, 1);
        caught += !stratified(x, y);
    }
    EXPECT_GE(caught, 6);
}

TEST(Samplers, ScramblesDifferAcrossPixelsSeedsAndPairs) {
    for (Sampler kind : {Sampler::kSobol, Sampler::kZSobol, Sampler::kPmj02}) {
        std::set<std::vector<uint32_t>> seen;
        std::vector<uint32_t> x, y;
        for (uint32_t seed : {1u, 2u})
            for (uint32_t pixel : {0u, 1u, 2u, 100u})
                for (uint32_t slot : {1u, 2u, 4u}) {
                    pixel_points(kind, seed, pixel, 3, 1, slot, 16, x, y);
                    EXPECT_TRUE(seen.insert(x).second) << "sampler " << int(kind);
                }
    }
}

// E[u_a · u_b] over many paths: 1/4 for independent decisions, 1/3 for one number used twice.
double product_mean(Sampler kind, Purpose a, uint32_t bounce_a, Purpose b, uint32_t bounce_b) {
    const SamplerSetup setup = setup_of(kind, 4);
    double sum = 0;
    int n = 0;
    for (uint32_t pixel = 0; pixel < 256; ++pixel)
        for (uint32_t s = 0; s < 16; ++s) {
            const SampleStream<float> rng =
                camera_stream<float>(setup, 4u, pixel, pixel % 16, pixel / 16, s);
            const float ua = uniform<float>(rng, bounce_a, a);
            const float ub = a == Purpose::kLobe && b == Purpose::kLobe && bounce_a == bounce_b
                                 ? second_uniform<float>(rng, bounce_b, b)
                                 : uniform<float>(rng, bounce_b, b);
            sum += double(ua) * double(ub);
            ++n;
        }
    return sum / n;
}

TEST(Samplers, NoTwoDecisionsShareADimension) {
    // Every two decisions of bounces 0..2 (the roulette's draw as "kLobe twice")
    const Purpose all[] = {Purpose::kPixelX,     Purpose::kPixelY,     Purpose::kLobe,
                           Purpose::kDirection1, Purpose::kDirection2, Purpose::kEmitterPick,
                           Purpose::kEmitter1,   Purpose::kEmitter2};
    // σ of the mean of 4096 products of independent uniforms: ≈ 0.0034
    for (Sampler kind : {Sampler::kIndependent, Sampler::kSobol, Sampler::kZSobol, Sampler::kPmj02})
        for (uint32_t ba = 0; ba < 3; ++ba)
            for (uint32_t bb = ba; bb < 3; ++bb)
                for (Purpose a : all)
                    for (Purpose b : all) {
                        if (ba == bb && uint32_t(b) < uint32_t(a)) continue;
                        if (ba == bb && a == b && a != Purpose::kLobe) continue;
                        EXPECT_NEAR(product_mean(kind, a, ba, b, bb), 0.25, 0.02)
                            << "sampler " << int(kind) << ": purposes " << int(a) << "@" << ba
                            << " and " << int(b) << "@" << bb;
                    }
    // A planted reuse (one number for two decisions) is caught
    EXPECT_NEAR(product_mean(Sampler::kSobol, Purpose::kDirection1, 1, Purpose::kDirection1, 1),
                1.0 / 3.0, 0.01);
}

TEST(Samplers, EveryUniformIsUniform) {
    for (Sampler kind : {Sampler::kSobol, Sampler::kZSobol, Sampler::kPmj02}) {
        const SamplerSetup setup = setup_of(kind, 2);
        std::vector<double> observed(64, 0.0), expected(64, 0.0);
        int n = 0;
        for (uint32_t pixel = 0; pixel < 4096; ++pixel)
            for (uint32_t s = 0; s < 4; ++s) {
                const SampleStream<float> rng =
                    camera_stream<float>(setup, 9u, pixel, pixel % 64, pixel / 64, s);
                const float u = uniform<float>(rng, 3u, Purpose::kEmitter2);
                ASSERT_GE(u, 0.0f);
                ASSERT_LT(u, 1.0f);
                observed[size_t(u * 64.0f)] += 1.0, ++n;
            }
        for (double& e : expected) e = n / 64.0;
        const auto [stat, dof] = test::chi_square(observed, expected);
        EXPECT_LT(stat, test::chi_square_critical(dof)) << "sampler " << int(kind);
    }
}

TEST(Samplers, TheLobesPairIsTheLobeChoiceAndTheRoulettesDraw) {
    // lobe_uniforms draws slot 1 once: the same two numbers as uniform(kLobe) and
    // second_uniform(kLobe), with every sampler, at every bounce
    for (Sampler kind :
         {Sampler::kIndependent, Sampler::kSobol, Sampler::kZSobol, Sampler::kPmj02}) {
        const SamplerSetup setup = setup_of(kind, 3);
        for (uint32_t pixel = 0; pixel < 64; ++pixel)
            for (uint32_t bounce : {0u, 1u, 9u}) {
                const SampleStream<float> rng =
                    camera_stream<float>(setup, 2u, pixel, pixel % 8, pixel / 8, pixel % 5);
                float u, v;
                lobe_uniforms<float>(rng, bounce, true, u, v);
                ASSERT_EQ(u, uniform<float>(rng, bounce, Purpose::kLobe));
                ASSERT_EQ(v, second_uniform<float>(rng, bounce, Purpose::kLobe));
            }
    }
}

TEST(Samplers, LanesDrawTheScalarNumbers) {
    using F = xsimd::batch<float>;
    using U = xsimd::batch<uint32_t>;
    constexpr size_t K = F::size;
    for (Sampler kind :
         {Sampler::kIndependent, Sampler::kSobol, Sampler::kZSobol, Sampler::kPmj02}) {
        const SamplerSetup setup = setup_of(kind, 5);
        alignas(64) uint32_t px[K], py[K], pixel[K], sample[K];
        for (size_t l = 0; l < K; ++l)
            px[l] = uint32_t(3 * l + 1), py[l] = uint32_t(l / 2), pixel[l] = py[l] * 50 + px[l],
            sample[l] = uint32_t(7 * l);
        const SampleStream<F> lanes =
            camera_stream<F>(setup, 11u, U::load_aligned(pixel), U::load_aligned(px),
                             U::load_aligned(py), U::load_aligned(sample));
        for (uint32_t bounce : {0u, 2u}) {
            for (Purpose p : {Purpose::kPixelX, Purpose::kLobe, Purpose::kDirection2,
                              Purpose::kEmitterPick, Purpose::kEmitter1}) {
                alignas(64) float got[K];
                uniform<F>(lanes, U(bounce), p).store_aligned(got);
                for (size_t l = 0; l < K; ++l) {
                    const SampleStream<float> one =
                        camera_stream<float>(setup, 11u, pixel[l], px[l], py[l], sample[l]);
                    EXPECT_EQ(got[l], uniform<float>(one, bounce, p))
                        << "sampler " << int(kind) << ", lane " << l;
                }
            }
            alignas(64) float got[K];
            second_uniform<F>(light_stream(lanes), U(bounce), Purpose::kLobe).store_aligned(got);
            for (size_t l = 0; l < K; ++l) {
                const SampleStream<float> one =
                    camera_stream<float>(setup, 11u, pixel[l], px[l], py[l], sample[l]);
                EXPECT_EQ(got[l], second_uniform<float>(light_stream(one), bounce, Purpose::kLobe));
            }
        }
    }
}

}  // namespace
}  // namespace cierzo
