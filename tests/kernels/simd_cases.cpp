// One ISA's side of test_simd_kernels: the cases of simd_cases.h with T = xsimd::batch for
// the ISA this object is built for (CMake builds it once per ISA, with that ISA's flags and
// namespaces, as an object of its own: CIERZO_SIMD_CASES is its entry's name).
#include "kernels/simd_cases.h"

#include "integrators/wavefront/compact_stage.h"

namespace cierzo {
namespace {

using B = xsimd::batch<float>;
using BI = xsimd::batch<int32_t>;
using BU = xsimd::batch<uint32_t>;
constexpr size_t K = B::size;

void run(KernelCase c, const CaseInputs& in, float* const* out) {
    for (size_t i = 0; i < in.count; i += K) run_kernel_case<B>(c, in, i, out);
}

uint32_t dead_batch(const CaseInputs& in) {
    uint32_t holds = 0;
    const Bsdf<B> black{Vec3<B>(B(0.0f)), Vec3<B>(B(0.0f)), Vec3<B>(B(0.0f)),
                        Vec3<B>(B(0.0f)), B(0.0f),          B(1.0f)};
    B p;
    const BI lobe = choose_lobe(black, B::load_unaligned(in.u[0]), 0.9f, p);
    if (xsimd::all(lobe == BI(kLobeAbsorbed))) holds |= kDeadAbsorbed;
    B t;
    const Ray<B> away{Vec3<B>(B(0.0f), B(5.0f), B(0.0f)), Vec3<B>(B(0.0f), B(1.0f), B(0.0f))};
    if (!xsimd::any(intersect_sphere(away, Vec3<B>(B(0.0f)), B(1.0f), B(kRayFar), t)))
        holds |= kDeadMissSphere;
    const Ray<B> zero{Vec3<B>(B(0.0f)), Vec3<B>(B(0.0f))};
    if (!xsimd::any(
            intersect_plane(zero, Vec3<B>(B(0.0f), B(1.0f), B(0.0f)), B(1.0f), B(kRayFar), t)))
        holds |= kDeadZeroRays;
    return holds;
}

void compress_every_mask(float* f_out, uint32_t* u_out) {
    using A = xsimd::default_arch;
    alignas(64) float f[K];
    alignas(64) uint32_t u[K];
    for (size_t l = 0; l < K; ++l) f[l] = 0.5f + float(l), u[l] = 1000u + uint32_t(l);
    for (uint32_t m = 0; m < (1u << K); ++m) {
        compress<A>(B::load_aligned(f), m).store_unaligned(f_out + size_t(m) * K);
        compress<A>(BU::load_aligned(u), m).store_unaligned(u_out + size_t(m) * K);
    }
}

void arithmetic(const float* a, const float* b, size_t count, float* const* out) {
    for (size_t i = 0; i < count; i += K) {
        const B x = B::load_unaligned(a + i), y = B::load_unaligned(b + i);
        (x / y).store_unaligned(out[0] + i);
        xsimd::sqrt(x).store_unaligned(out[1] + i);
        xsimd::max(x, y).store_unaligned(out[2] + i);
        xsimd::min(x, y).store_unaligned(out[3] + i);
    }
}

}  // namespace

SimdCases CIERZO_SIMD_CASES() {
    return {int32_t(K), run, dead_batch, compress_every_mask, arithmetic};
}

}  // namespace cierzo
