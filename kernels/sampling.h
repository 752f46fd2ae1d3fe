// Direction sampling for the report's lobes, in a local frame whose z axis is the lobe's
// axis (the shading normal for diffuse, the mirror direction for Phong specular).
// Each sampler states its density; tests check the samples against it by chi-square.
#pragma once

#include <numbers>

#include "vec3.h"

namespace cierzo {
inline namespace CIERZO_ISA_NAMESPACE {

inline constexpr float kPi = std::numbers::pi_v<float>;
inline constexpr float kInvPi = std::numbers::inv_pi_v<float>;

// sin(2πu) and cos(2πu) for any u (the samplers' azimuth, u in [0, 1)): reduced to
// a = 2π(u - q/4) in [-π/4, π/4] with q = round(4u), Taylor polynomials of degree 9 and 10
// there (error below 1e-7), then rotated by the quadrant q. Cheaper than a general sin and
// cos, whose range reduction must handle any argument.
template <class T>
void sincos_2pi(const T& u, T& s, T& c) {
    const T x = u - nearbyint(u);
    const T q = nearbyint(T(4.0f) * x);
    const T a = T(2.0f * kPi) * (x - T(0.25f) * q);
    const T a2 = a * a;
    const T ps =
        a * fma(a2,
                fma(a2, fma(a2, fma(a2, T(1.0f / 362880.0f), T(-1.0f / 5040.0f)), T(1.0f / 120.0f)),
                    T(-1.0f / 6.0f)),
                T(1.0f));
    const T pc = fma(
        a2,
        fma(a2,
            fma(a2, fma(a2, fma(a2, T(-1.0f / 3628800.0f), T(1.0f / 40320.0f)), T(-1.0f / 720.0f)),
                T(1.0f / 24.0f)),
            T(-0.5f)),
        T(1.0f));
    // Quadrant q mod 4: 0 (s, c), 1 (c, -s), 2 (-s, -c), 3 (-c, s)
    const auto qi = to_int(q) & I32<T>(3);
    const auto swap = mask_f32(qi == I32<T>(1)) | mask_f32(qi == I32<T>(3));
    const auto neg_s = mask_f32(qi == I32<T>(2)) | mask_f32(qi == I32<T>(3));
    const auto neg_c = mask_f32(qi == I32<T>(1)) | mask_f32(qi == I32<T>(2));
    const T ss = select(swap, pc, ps), cc = select(swap, ps, pc);
    s = select(neg_s, -ss, ss);
    c = select(neg_c, -cc, cc);
}

// Uniform over the hemisphere z > 0: pdf = 1 / (2π).
template <class T>
Vec3<T> sample_uniform_hemisphere(const T& u1, const T& u2) {
    const T z = u1;
    const T r = sqrt(max(T(0.0f), T(1.0f) - z * z));
    T s, c;
    sincos_2pi(u2, s, c);
    return {r * c, r * s, z};
}

// Cosine-weighted over the hemisphere z > 0: pdf = cos θ / π.
template <class T>
Vec3<T> sample_cosine_hemisphere(const T& u1, const T& u2) {
    const T r = sqrt(u1);
    T s, c;
    sincos_2pi(u2, s, c);
    return {r * c, r * s, sqrt(max(T(0.0f), T(1.0f) - u1))};
}

// cos α = u^(1/(s+1)), computed as exp(log(u)/(s+1)) so it is defined for u = 0.
inline float pow_inv(float u, float e) { return u > 0.0f ? std::exp(std::log(u) / e) : 0.0f; }
template <class A>
xsimd::batch<float, A> pow_inv(const xsimd::batch<float, A>& u, const xsimd::batch<float, A>& e) {
    using B = xsimd::batch<float, A>;
    return select(u > B(0.0f), xsimd::exp(xsimd::log(u) / e), B(0.0f));
}

// Uniform over the whole sphere of directions: pdf = 1 / (4π). sin θ = 2√(u1(1 - u1)),
// which does not cancel near the poles as √(1 - z²) would.
template <class T>
Vec3<T> sample_uniform_sphere(const T& u1, const T& u2) {
    const T z = T(1.0f) - T(2.0f) * u1;
    const T r = T(2.0f) * sqrt(max(T(0.0f), u1 * (T(1.0f) - u1)));
    T s, c;
    sincos_2pi(u2, s, c);
    return {r * c, r * s, z};
}

// The Phong lobe around z: pdf = (s+1)/(2π) · cos^s α, α the angle to the axis.
template <class T>
Vec3<T> sample_phong_lobe(const T& u1, const T& u2, const T& shininess) {
    const T cos_a = pow_inv(T(1.0f) - u1, shininess + T(1.0f));
    const T sin_a = sqrt(max(T(0.0f), T(1.0f) - cos_a * cos_a));
    T s, c;
    sincos_2pi(u2, s, c);
    return {sin_a * c, sin_a * s, cos_a};
}

// cos^s for c in [0, 1]; 0^0 = 1 so s = 0 is a uniform lobe.
inline float pow_s(float c, float s) {
    return s == 0.0f ? 1.0f : (c > 0.0f ? std::pow(c, s) : 0.0f);
}
template <class A>
xsimd::batch<float, A> pow_s(const xsimd::batch<float, A>& c, const xsimd::batch<float, A>& s) {
    using B = xsimd::batch<float, A>;
    const B p = select(c > B(0.0f), xsimd::exp(s * xsimd::log(c)), B(0.0f));
    return select(s == B(0.0f), B(1.0f), p);
}

// A local direction (frame z = n) to world space.
template <class T>
Vec3<T> to_world(const Vec3<T>& local, const Vec3<T>& n) {
    Vec3<T> t, b;
    orthonormal_basis(n, t, b);
    return {fma(local.x, t.x, fma(local.y, b.x, local.z * n.x)),
            fma(local.x, t.y, fma(local.y, b.y, local.z * n.y)),
            fma(local.x, t.z, fma(local.y, b.z, local.z * n.z))};
}

// Mirror d about n (d points towards the surface).
template <class T>
Vec3<T> reflect(const Vec3<T>& d, const Vec3<T>& n) {
    return d - n * (T(2.0f) * dot(d, n));
}

}  // namespace CIERZO_ISA_NAMESPACE
}  // namespace cierzo
