// Every kernel with T = xsimd::batch<float> (the ISA this file is built for; it is built
// once per ISA) against T = float on the same inputs: hit masks equal, results within a
// few ulps, lane by lane, including dead lanes (misses, absorbed paths) and inputs whose
// count is not a multiple of the width (the tail is padded with inert lanes).
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "kernels/camera.h"
#include "kernels/estimator.h"
#include "kernels/intersect.h"
#include "kernels/rng.h"
#include "integrators/wavefront/compact_stage.h"

namespace cierzo {
namespace {

using B = xsimd::batch<float>;
using BI = xsimd::batch<int32_t>;
constexpr size_t K = B::size;
// 1003 inputs: not a multiple of any width
constexpr size_t kInputs = 1003;

bool cpu_has_isa() {
#if defined(__AVX512F__)
    return __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512bw");
#elif defined(__AVX2__)
    return __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
#else
    return true;
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
        for (int c = 0; c < 3; ++c) o[c].resize(kInputs + K), d[c].resize(kInputs + K), u[c].resize(kInputs + K);
        for (size_t i = 0; i < kInputs + K; ++i) {
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
    Ray<float> ray(size_t i) const { return {{o[0][i], o[1][i], o[2][i]}, {d[0][i], d[1][i], d[2][i]}}; }
    Ray<B> ray_b(size_t i) const {
        return {{B::load_unaligned(&o[0][i]), B::load_unaligned(&o[1][i]), B::load_unaligned(&o[2][i])},
                {B::load_unaligned(&d[0][i]), B::load_unaligned(&d[1][i]), B::load_unaligned(&d[2][i])}};
    }
    B ub(int c, size_t i) const { return B::load_unaligned(&u[c][i]); }
};

// Runs a batch kernel and its scalar twin over all inputs (tail included) and compares.
template <class Simd, class Scalar>
void compare_all(Simd simd, Scalar scalar, int outputs, float ulps, float floor,
                 const char* what) {
    for (size_t i = 0; i < kInputs; i += K) {
        alignas(64) float got[8][K];
        simd(i, got);
        for (size_t l = 0; l < K && i + l < kInputs; ++l) {
            float want[8];
            scalar(i + l, want);
            for (int k = 0; k < outputs; ++k)
                expect_close(got[k][l], want[k], ulps, floor, what, i + l);
        }
    }
}

class SimdKernels : public testing::Test {
protected:
    void SetUp() override {
        if (!cpu_has_isa()) GTEST_SKIP() << "this CPU lacks the ISA this test was built for";
    }
    Inputs in;
};

TEST_F(SimdKernels, Intersections) {
    const QuadricCoefficients<float> qf{1, 0.5f, 1, 0.1f, 0, 0, 0, -0.2f, 0, -1};
    const QuadricCoefficients<B> qb{B(1.0f), B(0.5f), B(1.0f), B(0.1f), B(0.0f),
                                    B(0.0f), B(0.0f), B(-0.2f), B(0.0f), B(-1.0f)};
    compare_all(
        [&](size_t i, float out[][K]) {
            B t[3];
            const Ray<B> r = in.ray_b(i);
            const auto m0 = intersect_sphere(r, Vec3<B>(B(0.3f)), B(1.1f), B(kRayFar), t[0]);
            const auto m1 = intersect_plane(r, Vec3<B>(B(0.0f), B(1.0f), B(0.0f)), B(0.5f), B(kRayFar), t[1]);
            const auto m2 = intersect_quadric(r, qb, Vec3<B>(B(-1.5f)), Vec3<B>(B(1.5f)), B(kRayFar), t[2]);
            select(m0, t[0], B(-1.0f)).store_aligned(out[0]);
            select(m1, t[1], B(-1.0f)).store_aligned(out[1]);
            select(m2, t[2], B(-1.0f)).store_aligned(out[2]);
        },
        [&](size_t i, float* out) {
            float t[3];
            const Ray<float> r = in.ray(i);
            out[0] = intersect_sphere(r, Vec3f(0.3f), 1.1f, kRayFar, t[0]) ? t[0] : -1.0f;
            out[1] = intersect_plane(r, Vec3f{0, 1, 0}, 0.5f, kRayFar, t[1]) ? t[1] : -1.0f;
            out[2] = intersect_quadric(r, qf, Vec3f(-1.5f), Vec3f(1.5f), kRayFar, t[2]) ? t[2] : -1.0f;
        },
        3, 64.0f, 1e-6f, "intersection t");
}

TEST_F(SimdKernels, RouletteAndLobes) {
    const Bsdf<float> mf{{0.3f, 0.2f, 0.1f}, {0.2f, 0.25f, 0.1f}, {0.1f, 0.1f, 0.2f},
                         {0.15f, 0.1f, 0.1f}, 30.0f, 1.4f};
    const Bsdf<B> mb{Vec3<B>(mf.kd), Vec3<B>(mf.ks), Vec3<B>(mf.kr), Vec3<B>(mf.kt), B(30.0f), B(1.4f)};
    const Vec3f n = normalize(Vec3f{0.2f, 1.0f, -0.3f});
    for (int lobe = 0; lobe < 4; ++lobe) {
        SCOPED_TRACE(lobe);
        compare_all(
            [&](size_t i, float out[][K]) {
                const Ray<B> r = in.ray_b(i);
                B p;
                const BI chosen = choose_lobe(mb, in.ub(0, i), 0.9f, p);
                const Vec3<B> nb(n), nf = facing_normal(nb, r.d);
                Scatter<B> s;
                if (lobe == 0) s = sample_diffuse(mb, nf, in.ub(1, i), in.ub(2, i), B(0.3f), false);
                if (lobe == 1) s = sample_specular(mb, r.d, nf, in.ub(1, i), in.ub(2, i), B(0.25f));
                if (lobe == 2) s = sample_mirror(mb, r.d, nf, B(0.2f));
                if (lobe == 3) s = sample_refraction(mb, r.d, nb, B(1.0f), B(0.15f));
                xsimd::batch_cast<float>(chosen).store_aligned(out[0]);
                p.store_aligned(out[1]);
                s.dir.x.store_aligned(out[2]), s.dir.y.store_aligned(out[3]), s.dir.z.store_aligned(out[4]);
                s.weight.x.store_aligned(out[5]), s.weight.z.store_aligned(out[6]);
            },
            [&](size_t i, float* out) {
                const Ray<float> r = in.ray(i);
                float p;
                out[0] = float(choose_lobe(mf, in.u[0][i], 0.9f, p));
                out[1] = p;
                const Vec3f nf = facing_normal(n, r.d);
                Scatter<float> s;
                if (lobe == 0) s = sample_diffuse(mf, nf, in.u[1][i], in.u[2][i], 0.3f, false);
                if (lobe == 1) s = sample_specular(mf, r.d, nf, in.u[1][i], in.u[2][i], 0.25f);
                if (lobe == 2) s = sample_mirror(mf, r.d, nf, 0.2f);
                if (lobe == 3) s = sample_refraction(mf, r.d, n, 1.0f, 0.15f);
                out[2] = s.dir.x, out[3] = s.dir.y, out[4] = s.dir.z;
                out[5] = s.weight.x, out[6] = s.weight.z;
            },
            7, 64.0f, 1.0f, "lobe");
    }
}

TEST_F(SimdKernels, PhongEvaluationRandomNumbersAndCamera) {
    const Bsdf<float> mf{{0.5f, 0.4f, 0.3f}, {0.3f, 0.3f, 0.3f}, Vec3f(0), Vec3f(0), 12.0f, 1.0f};
    const Bsdf<B> mb{Vec3<B>(mf.kd), Vec3<B>(mf.ks), Vec3<B>(0.0f), Vec3<B>(0.0f), B(12.0f), B(1.0f)};
    const Vec3f n{0, 0, 1};
    const Vec3f o{0, 0, -3}, f{0, 0, 2}, l{-1, 0, 0}, up{0, 1, 0};
    compare_all(
        [&](size_t i, float out[][K]) {
            const Ray<B> r = in.ray_b(i);
            const Vec3<B> wi = normalize(Vec3<B>(in.ub(0, i), in.ub(1, i), in.ub(2, i) - B(0.3f)));
            const Vec3<B> fc = phong_f_cos(mb, r.d, Vec3<B>(n), wi);
            fc.x.store_aligned(out[0]), fc.z.store_aligned(out[1]);
            alignas(64) uint32_t idx[K];
            for (size_t k = 0; k < K; ++k) idx[k] = uint32_t(i + k);
            const auto key = path_key(5u, xsimd::batch<uint32_t>::load_aligned(idx), xsimd::batch<uint32_t>(3u));
            uniform<B>(key, xsimd::batch<uint32_t>(2u), Purpose::kLobe).store_aligned(out[2]);
            const Ray<B> c = pinhole_ray(o, f, l, up, in.ub(0, i) * B(64.0f), in.ub(1, i) * B(48.0f),
                                         1.0f / 64.0f, 1.0f / 48.0f);
            c.d.x.store_aligned(out[3]), c.d.y.store_aligned(out[4]);
        },
        [&](size_t i, float* out) {
            const Ray<float> r = in.ray(i);
            const Vec3f wi = normalize(Vec3f{in.u[0][i], in.u[1][i], in.u[2][i] - 0.3f});
            const Vec3f fc = phong_f_cos(mf, r.d, n, wi);
            out[0] = fc.x, out[1] = fc.z;
            out[2] = uniform<float>(path_key(5u, uint32_t(i), 3u), 2u, Purpose::kLobe);
            const Ray<float> c = pinhole_ray(o, f, l, up, in.u[0][i] * 64.0f, in.u[1][i] * 48.0f,
                                             1.0f / 64.0f, 1.0f / 48.0f);
            out[3] = c.d.x, out[4] = c.d.y;
        },
        5, 64.0f, 1.0f, "phong/rng/camera");
}

TEST_F(SimdKernels, AllDeadBatchStaysDead) {
    // Every lane absorbed (black material) and every lane missing: masks all false, no NaN
    const Bsdf<B> black{Vec3<B>(0.0f), Vec3<B>(0.0f), Vec3<B>(0.0f), Vec3<B>(0.0f), B(0.0f), B(1.0f)};
    B p;
    const BI lobe = choose_lobe(black, in.ub(0, 0), 0.9f, p);
    EXPECT_TRUE(xsimd::all(lobe == BI(kLobeAbsorbed)));
    B t;
    const Ray<B> away{Vec3<B>(B(0.0f), B(5.0f), B(0.0f)), Vec3<B>(B(0.0f), B(1.0f), B(0.0f))};
    EXPECT_FALSE(xsimd::any(intersect_sphere(away, Vec3<B>(B(0.0f)), B(1.0f), B(kRayFar), t)));
    // Zero-direction padding lanes never hit
    const Ray<B> zero{Vec3<B>(B(0.0f)), Vec3<B>(B(0.0f))};
    EXPECT_FALSE(xsimd::any(intersect_plane(zero, Vec3<B>(B(0.0f), B(1.0f), B(0.0f)), B(1.0f), B(kRayFar), t)));
}

TEST_F(SimdKernels, CompressKeepsTheChosenLanesInOrder) {
    // Every mask of the K lanes (65,536 for 16)
    using A = xsimd::default_arch;
    using BU = xsimd::batch<uint32_t, A>;
    alignas(64) float f[K], fout[K];
    alignas(64) uint32_t u[K], uout[K];
    for (size_t l = 0; l < K; ++l) f[l] = 0.5f + float(l), u[l] = 1000u + uint32_t(l);
    for (uint32_t m = 0; m < (1u << K); ++m) {
        compress<A>(B::load_aligned(f), m).store_aligned(fout);
        compress<A>(BU::load_aligned(u), m).store_aligned(uout);
        size_t at = 0;
        for (size_t l = 0; l < K; ++l) {
            if (!(m >> l & 1u)) continue;
            ASSERT_EQ(fout[at], f[l]) << "mask " << m << ", lane " << l;
            ASSERT_EQ(uout[at], u[l]) << "mask " << m << ", lane " << l;
            ++at;
        }
    }
}

}  // namespace
}  // namespace cierzo
