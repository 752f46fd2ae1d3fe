// Every kernel with T = xsimd::batch<float> of each ISA this build has, against T = float
// on the same inputs: hit masks equal, results within a few ulps, lane by lane, including
// dead lanes (misses, absorbed paths) and inputs whose count is not a multiple of the width
// (the tail is padded with inert lanes). The batch side runs in each ISA's own object
// (simd_cases.h says why); an ISA this CPU lacks is skipped, with what it lacks.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <random>
#include <vector>

#include "kernels/simd_cases.h"
#include "support/isa.h"

namespace cierzo {
namespace {

// 1003 inputs: not a multiple of any width
constexpr size_t kInputs = 1003;
constexpr size_t kPadded = (kInputs + 15) / 16 * 16 + 16;

struct IsaCases {
    Isa isa;
    SimdCases (*cases)();
};
void PrintTo(const IsaCases& c, std::ostream* os) { *os << isa_name(c.isa); }
std::vector<IsaCases> isa_cases() {
// (an ISA left out of the build by CIERZO_ISAS has no cases; its tests skip, saying so)
#if CIERZO_BUILT_AVX512
#define CIERZO_CASES_AVX512 simd_cases_avx512
#else
#define CIERZO_CASES_AVX512 nullptr
#endif
#if CIERZO_BUILT_AVX2
#define CIERZO_CASES_AVX2 simd_cases_avx2
#else
#define CIERZO_CASES_AVX2 nullptr
#endif
#if CIERZO_BUILT_SSE42
#define CIERZO_CASES_SSE42 simd_cases_sse42
#else
#define CIERZO_CASES_SSE42 nullptr
#endif
#if CIERZO_BUILT_NEON
#define CIERZO_CASES_NEON simd_cases_neon
#else
#define CIERZO_CASES_NEON nullptr
#endif
#if defined(__x86_64__) || defined(__i386__)
    return {{Isa::kAvx512, CIERZO_CASES_AVX512},
            {Isa::kAvx2, CIERZO_CASES_AVX2},
            {Isa::kSse42, CIERZO_CASES_SSE42}};
#else
    return {{Isa::kNeon, CIERZO_CASES_NEON}};
#endif
}

// Within `ulps` units in the last place of max(|a|, |b|, floor): floor 1 for components of
// unit vectors and weights of order 1, whose error is set by the vector, not the component.
void expect_close(float simd, float scalar, float ulps, float floor, const char* what, size_t i) {
    if (std::isnan(scalar)) {
        EXPECT_TRUE(std::isnan(simd)) << what << " lane " << i;
        return;
    }
    const float scale = std::max({std::abs(simd), std::abs(scalar), floor});
    EXPECT_LE(std::abs(simd - scalar), ulps * scale * 0x1.0p-23f)
        << what << " lane " << i << ": " << simd << " vs " << scalar;
}

struct Inputs {
    std::vector<float> o[3], d[3], u[3];
    Inputs() {
        std::mt19937 rng(99);
        std::uniform_real_distribution<float> s(-2.0f, 2.0f), v(0.0f, 1.0f);
        for (int c = 0; c < 3; ++c)
            o[c].resize(kPadded), d[c].resize(kPadded), u[c].resize(kPadded);
        for (size_t i = 0; i < kPadded; ++i) {
            // Padding lanes past kInputs: inert zero rays (d = 0) that must not disturb anything
            const bool pad = i >= kInputs;
            Vec3f dir = normalize(Vec3f{s(rng), s(rng), s(rng)});
            for (int c = 0; c < 3; ++c) {
                o[c][i] = pad ? 0.0f : s(rng) * 2.0f;
                d[c][i] = pad ? 0.0f : dir[c];
                u[c][i] = pad ? 0.0f : v(rng);
            }
        }
    }
    CaseInputs view() const {
        return {{o[0].data(), o[1].data(), o[2].data()},
                {d[0].data(), d[1].data(), d[2].data()},
                {u[0].data(), u[1].data(), u[2].data()},
                kInputs};
    }
};

class SimdKernels : public testing::TestWithParam<IsaCases> {
protected:
    void SetUp() override {
        CIERZO_REQUIRE_ISA(GetParam().isa);
        cases = GetParam().cases();
    }
    // Runs a case on every input through the ISA's batches and through the scalar kernels,
    // and compares every output of every input.
    void compare(KernelCase c, float ulps, float floor, const char* what) {
        const CaseInputs view = in.view();
        std::vector<float> simd[kMaxCaseOutputs], scalar[kMaxCaseOutputs];
        float* simd_out[kMaxCaseOutputs];
        float* scalar_out[kMaxCaseOutputs];
        for (int k = 0; k < kMaxCaseOutputs; ++k) {
            simd[k].assign(kPadded, NAN), scalar[k].assign(kPadded, NAN);
            simd_out[k] = simd[k].data(), scalar_out[k] = scalar[k].data();
        }
        cases.run(c, view, simd_out);
        for (size_t i = 0; i < kInputs; ++i) run_kernel_case<float>(c, view, i, scalar_out);
        for (int k = 0; k < kCaseOutputs[int(c)]; ++k)
            for (size_t i = 0; i < kInputs; ++i)
                expect_close(simd[k][i], scalar[k][i], ulps, floor, what, i);
    }
    Inputs in;
    SimdCases cases{};
};

TEST_P(SimdKernels, Intersections) {
    compare(KernelCase::kIntersections, 64.0f, 1e-6f, "intersection t");
}

TEST_P(SimdKernels, RouletteAndLobes) {
    compare(KernelCase::kLobeDiffuse, 64.0f, 1.0f, "diffuse lobe");
    compare(KernelCase::kLobeSpecular, 64.0f, 1.0f, "specular lobe");
    compare(KernelCase::kLobeMirror, 64.0f, 1.0f, "mirror lobe");
    compare(KernelCase::kLobeRefraction, 64.0f, 1.0f, "refraction lobe");
}

TEST_P(SimdKernels, PhongEvaluationRandomNumbersAndCamera) {
    compare(KernelCase::kPhongRngCamera, 64.0f, 1.0f, "phong/rng/camera");
}

TEST_P(SimdKernels, LightSampling) {
    compare(KernelCase::kLightPosition, 64.0f, 1.0f, "emitter position");
    compare(KernelCase::kLightDirections, 64.0f, 1.0f, "emitted/point-light direction");
}

TEST_P(SimdKernels, AllDeadBatchStaysDead) {
    // Every lane absorbed (black material) and every lane missing: masks all false, no NaN
    const uint32_t holds = cases.dead_batch(in.view());
    EXPECT_TRUE(holds & kDeadAbsorbed) << "a black material's lanes were not all absorbed";
    EXPECT_TRUE(holds & kDeadMissSphere) << "a ray hit a sphere behind it";
    EXPECT_TRUE(holds & kDeadZeroRays) << "a zero-direction padding lane hit a plane";
}

TEST_P(SimdKernels, CompressKeepsTheChosenLanesInOrder) {
    // Every mask of the K lanes (65,536 for 16)
    const size_t K = size_t(cases.width), masks = size_t(1) << K;
    std::vector<float> f(masks * K + 16);
    std::vector<uint32_t> u(masks * K + 16);
    cases.compress_every_mask(f.data(), u.data());
    for (size_t m = 0; m < masks; ++m) {
        size_t at = 0;
        for (size_t l = 0; l < K; ++l) {
            if (!(m >> l & 1u)) continue;
            ASSERT_EQ(f[m * K + at], 0.5f + float(l)) << "mask " << m << ", lane " << l;
            ASSERT_EQ(u[m * K + at], 1000u + uint32_t(l)) << "mask " << m << ", lane " << l;
            ++at;
        }
    }
}

TEST_P(SimdKernels, DivisionSquareRootMinAndMaxAreTheScalarOnes) {
    // Random operands of every magnitude, then the special values, each against each
    std::mt19937 rng(7);
    std::uniform_real_distribution<float> mantissa(1.0f, 2.0f);
    std::uniform_int_distribution<int> exponent(-40, 40);
    std::vector<float> a, b;
    for (int i = 0; i < 4096; ++i) {
        a.push_back(std::ldexp(mantissa(rng), exponent(rng)));
        b.push_back(std::ldexp(mantissa(rng), exponent(rng)) * (i % 3 == 0 ? -1.0f : 1.0f));
    }
    const float inf = std::numeric_limits<float>::infinity(), nan = std::nanf("");
    const float special[] = {0.0f, -0.0f, 1.0f, inf, -inf, nan, 0x1.0p-140f, 3.0f};
    for (float x : special)
        for (float y : special) a.push_back(x), b.push_back(y);
    while (a.size() % 16) a.push_back(1.0f), b.push_back(1.0f);
    std::vector<float> out[4];
    for (auto& o : out) o.resize(a.size());
    float* const outs[4] = {out[0].data(), out[1].data(), out[2].data(), out[3].data()};
    cases.arithmetic(a.data(), b.data(), a.size(), outs);
    const auto same = [](float x, float y) {
        return std::isnan(x) ? std::isnan(y) : std::memcmp(&x, &y, sizeof x) == 0;
    };
    for (size_t i = 0; i < a.size(); ++i) {
        const float x = a[i], y = b[i];
        EXPECT_PRED2(same, out[0][i], x / y) << x << " / " << y;
        // (sqrt of a negative number is NaN either way; of -0, -0)
        EXPECT_PRED2(same, out[1][i], std::sqrt(x)) << "sqrt " << x;
        EXPECT_PRED2(same, out[2][i], x > y ? x : y) << "max " << x << ", " << y;
        EXPECT_PRED2(same, out[3][i], x < y ? x : y) << "min " << x << ", " << y;
    }
}

INSTANTIATE_TEST_SUITE_P(EveryIsa, SimdKernels, testing::ValuesIn(isa_cases()),
                         [](const testing::TestParamInfo<IsaCases>& info) {
                             std::string name = isa_name(info.param.isa);
                             std::erase(name, '.');
                             return name;
                         });

}  // namespace
}  // namespace cierzo
