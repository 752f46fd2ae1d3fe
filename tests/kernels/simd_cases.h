// The kernel cases that test_simd_kernels compares lane by lane: each is written once as a
// template on the lane type, like the estimator. The driver (built without -m flags) runs it
// with T = float, one input at a time; each ISA's object (simd_cases.cpp, built once per ISA
// with that ISA's flags and namespaces) runs it with T = xsimd::batch and exports the results
// through a table of plain functions. Only the driver uses GoogleTest, and it calls an ISA's
// table only after asking the CPU, so no instruction the CPU lacks runs before the test
// decides to skip.
#pragma once

#include <cstddef>
#include <cstdint>
#include <type_traits>

#include "kernels/camera.h"
#include "kernels/estimator.h"
#include "kernels/intersect.h"
#include "kernels/light_sampling.h"
#include "kernels/rng.h"

namespace cierzo {

// Rays and uniform numbers as SoA arrays of `count` entries, readable up to count + 16
// (the padding holds inert zero rays).
struct CaseInputs {
    const float* o[3];
    const float* d[3];
    const float* u[3];
    size_t count;
};

enum class KernelCase : int32_t {
    kIntersections,  // t of a sphere, a plane and a bounded quadric (-1 on a miss)
    kLobeDiffuse,    // roulette lobe and probability; sampled direction and weight
    kLobeSpecular,
    kLobeMirror,
    kLobeRefraction,
    kPhongRngCamera,   // Phong f·cos, a uniform number, a camera ray's direction
    kLightPosition,    // a point on an emitter: id, point, normal, pdf_A, its density function
    kLightDirections,  // an emitted direction, its pdf and density function; a point light's
};
inline constexpr int kCaseCount = 8;
inline constexpr int kMaxCaseOutputs = 8;
inline constexpr int kCaseOutputs[kCaseCount] = {3, 7, 7, 7, 7, 5, 8, 8};

// The all-dead checks, a bit each when it holds: every lane of a black material absorbed;
// no lane hits a sphere behind the rays; zero-direction padding lanes hit no plane.
inline constexpr uint32_t kDeadAbsorbed = 1, kDeadMissSphere = 2, kDeadZeroRays = 4;

// One ISA's cases, as plain functions (no GoogleTest or standard-library code crosses over).
struct SimdCases {
    int32_t width;
    // out[k][i] for output k of the case and every i < count rounded up to `width`
    void (*run)(KernelCase c, const CaseInputs& in, float* const* out);
    uint32_t (*dead_batch)(const CaseInputs& in);
    // compress<A> of lanes f[l] = 0.5 + l, u[l] = 1000 + l under every mask m < 2^width:
    // the result's lanes at f_out[m * width + l], u_out[m * width + l]
    void (*compress_every_mask)(float* f_out, uint32_t* u_out);
    // a / b, sqrt(a), max(a, b) and min(a, b) of `count` lanes (a multiple of `width`) into
    // out[0..3]: the kernels assume IEEE division and square root, and SSE's maxps and minps
    // (a > b ? a : b, a < b ? a : b), on every ISA
    void (*arithmetic)(const float* a, const float* b, size_t count, float* const* out);
};

#if defined(__x86_64__) || defined(__i386__)
SimdCases simd_cases_avx512();
SimdCases simd_cases_avx2();
SimdCases simd_cases_sse42();
#elif defined(__aarch64__)
SimdCases simd_cases_neon();
#endif

inline namespace CIERZO_ISA_NAMESPACE {

template <class T>
T load_lanes(const float* p) {
    if constexpr (std::is_same_v<T, float>)
        return *p;
    else
        return T::load_unaligned(p);
}
template <class T>
void store_lanes(const T& v, float* p) {
    if constexpr (std::is_same_v<T, float>)
        *p = v;
    else
        v.store_unaligned(p);
}
// i, i + 1, ... as 32-bit unsigned lanes
template <class T>
U32<T> index_lanes(size_t i) {
    if constexpr (std::is_same_v<T, float>) {
        return uint32_t(i);
    } else {
        alignas(64) uint32_t idx[T::size];
        for (size_t k = 0; k < T::size; ++k) idx[k] = uint32_t(i + k);
        return U32<T>::load_aligned(idx);
    }
}

// The light sampling cases' emitters: spheres of radius 0.7 and 1e-4 and two triangles,
// with pmf 0.1, 0.2, 0.3, 0.4 and their alias table (records as kEmitterStride describes)
inline constexpr float kCaseEmitterQ[4] = {0.4f, 0.8f, 1.0f, 0.8f};
inline constexpr int32_t kCaseEmitterAlias[4] = {3, 3, 2, 2};
inline constexpr float kCaseEmitterPmf[4] = {0.1f, 0.2f, 0.3f, 0.4f};
inline constexpr int32_t kCaseEmitterKind[4] = {kEmitterSphere, kEmitterSphere, kEmitterTriangle,
                                                kEmitterTriangle};
inline constexpr float kCaseEmitterData[4 * kEmitterStride] = {
    0.5f,        -0.3f, 1.0f,       0.7f, 0,    0, 0, 0,     0,     0, 0,
    0,           0,     2,          1,    0.5f, 1, 2, 3,     1e-4f, 0, 0,
    0,           0,     0,          0,    0,    0, 0, 7,     7,     7, -1,
    0.5f,        2,     2.1213203f, 2,    0,    0, 0, 1.5f,  1.5f,  0, -0.70710677f,
    0.70710677f, 1,     2,          3,    0,    0, 1, 0.15f, 3,     0, 0,
    0,           0.1f,  0,          0,    0,    1, 2, 2,     2};

// u, with the lanes below 0.03 and above 0.97 moved to the ends 0 and 1 - 2^-24.
template <class T>
T with_extremes(const T& u) {
    return select(u < T(0.03f), T(0.0f), select(u > T(0.97f), T(1.0f - 0x1.0p-24f), u));
}

// Case c on inputs i, i + 1, … (as many as T has lanes); output k goes to out[k] + i.
template <class T>
void run_kernel_case(KernelCase c, const CaseInputs& in, size_t i, float* const* out) {
    const Ray<T> r{
        {load_lanes<T>(in.o[0] + i), load_lanes<T>(in.o[1] + i), load_lanes<T>(in.o[2] + i)},
        {load_lanes<T>(in.d[0] + i), load_lanes<T>(in.d[1] + i), load_lanes<T>(in.d[2] + i)}};
    const T u0 = load_lanes<T>(in.u[0] + i), u1 = load_lanes<T>(in.u[1] + i),
            u2 = load_lanes<T>(in.u[2] + i);
    switch (c) {
        case KernelCase::kIntersections: {
            const QuadricCoefficients<T> q{T(1.0f), T(0.5f), T(1.0f),  T(0.1f), T(0.0f),
                                           T(0.0f), T(0.0f), T(-0.2f), T(0.0f), T(-1.0f)};
            T t[3];
            const auto m0 = intersect_sphere(r, Vec3<T>(T(0.3f)), T(1.1f), T(kRayFar), t[0]);
            const auto m1 =
                intersect_plane(r, Vec3<T>(T(0.0f), T(1.0f), T(0.0f)), T(0.5f), T(kRayFar), t[1]);
            const auto m2 =
                intersect_quadric(r, q, Vec3<T>(T(-1.5f)), Vec3<T>(T(1.5f)), T(kRayFar), t[2]);
            store_lanes(select(m0, t[0], T(-1.0f)), out[0] + i);
            store_lanes(select(m1, t[1], T(-1.0f)), out[1] + i);
            store_lanes(select(m2, t[2], T(-1.0f)), out[2] + i);
            return;
        }
        case KernelCase::kLobeDiffuse:
        case KernelCase::kLobeSpecular:
        case KernelCase::kLobeMirror:
        case KernelCase::kLobeRefraction: {
            const Bsdf<T> m{Vec3<T>(T(0.3f), T(0.2f), T(0.1f)),
                            Vec3<T>(T(0.2f), T(0.25f), T(0.1f)),
                            Vec3<T>(T(0.1f), T(0.1f), T(0.2f)),
                            Vec3<T>(T(0.15f), T(0.1f), T(0.1f)),
                            T(30.0f),
                            T(1.4f)};
            const Vec3f n = normalize(Vec3f{0.2f, 1.0f, -0.3f});
            const Vec3<T> nb(T(n.x), T(n.y), T(n.z)), nf = facing_normal(nb, r.d);
            T p;
            const I32<T> chosen = choose_lobe(m, u0, 0.9f, p);
            Scatter<T> s;
            if (c == KernelCase::kLobeDiffuse) s = sample_diffuse(m, nf, u1, u2, T(0.3f), false);
            if (c == KernelCase::kLobeSpecular) s = sample_specular(m, r.d, nf, u1, u2, T(0.25f));
            if (c == KernelCase::kLobeMirror) s = sample_mirror(m, r.d, nf, T(0.2f));
            if (c == KernelCase::kLobeRefraction)
                s = sample_refraction(m, r.d, nb, nb, T(1.0f), T(0.15f));
            store_lanes(to_float(chosen), out[0] + i);
            store_lanes(p, out[1] + i);
            store_lanes(s.dir.x, out[2] + i), store_lanes(s.dir.y, out[3] + i);
            store_lanes(s.dir.z, out[4] + i);
            store_lanes(s.weight.x, out[5] + i), store_lanes(s.weight.z, out[6] + i);
            return;
        }
        case KernelCase::kPhongRngCamera: {
            const Bsdf<T> m{Vec3<T>(T(0.5f), T(0.4f), T(0.3f)),
                            Vec3<T>(T(0.3f)),
                            Vec3<T>(T(0.0f)),
                            Vec3<T>(T(0.0f)),
                            T(12.0f),
                            T(1.0f)};
            const Vec3<T> wi = normalize(Vec3<T>(u0, u1, u2 - T(0.3f)));
            const Vec3<T> fc = phong_f_cos(m, r.d, Vec3<T>(T(0.0f), T(0.0f), T(1.0f)), wi);
            store_lanes(fc.x, out[0] + i), store_lanes(fc.z, out[1] + i);
            const U32<T> key = path_key(5u, index_lanes<T>(i), U32<T>(3u));
            store_lanes(uniform<T>(key, U32<T>(2u), Purpose::kLobe), out[2] + i);
            const Ray<T> cam =
                pinhole_ray<T>(Vec3f{0, 0, -3}, Vec3f{0, 0, 2}, Vec3f{-1, 0, 0}, Vec3f{0, 1, 0},
                               u0 * T(64.0f), u1 * T(48.0f), 1.0f / 64.0f, 1.0f / 48.0f);
            store_lanes(cam.d.x, out[3] + i), store_lanes(cam.d.y, out[4] + i);
            return;
        }
        case KernelCase::kLightPosition: {
            const EmitterTable e{4,
                                 kCaseEmitterQ,
                                 kCaseEmitterAlias,
                                 kCaseEmitterPmf,
                                 kCaseEmitterKind,
                                 kCaseEmitterData,
                                 {}};
            // (a fourth number from the ray's origin, in [0, 1))
            const T u3 = min(abs(r.o.x) * T(0.25f), T(1.0f - 0x1.0p-24f));
            const EmitterPosition<T> s =
                sample_emitter_position(e, u0, u1, with_extremes(u2), with_extremes(u3));
            store_lanes(to_float(s.id), out[0] + i);
            store_lanes(s.p.x, out[1] + i), store_lanes(s.p.y, out[2] + i);
            store_lanes(s.p.z, out[3] + i);
            store_lanes(s.n.x, out[4] + i), store_lanes(s.n.z, out[5] + i);
            store_lanes(select(s.ok, s.pdf, T(-1.0f)), out[6] + i);
            store_lanes(emitter_position_pdf<T>(e, s.id), out[7] + i);
            return;
        }
        case KernelCase::kLightDirections: {
            // about the ray's direction as the normal
            const EmittedDirection<T> d =
                sample_emitted_direction(r.d, with_extremes(u0), with_extremes(u1));
            store_lanes(d.dir.x, out[0] + i), store_lanes(d.dir.y, out[1] + i);
            store_lanes(d.dir.z, out[2] + i), store_lanes(d.pdf, out[3] + i);
            store_lanes(emitted_direction_pdf(r.d, d.dir), out[4] + i);
            const PointLightDirection<T> l =
                sample_point_light_direction(with_extremes(u1), with_extremes(u2));
            store_lanes(l.dir.x, out[5] + i), store_lanes(l.dir.y, out[6] + i);
            store_lanes(l.dir.z, out[7] + i);
            return;
        }
    }
}

}  // namespace CIERZO_ISA_NAMESPACE
}  // namespace cierzo
