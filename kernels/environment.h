// The environment light (kernels/emitter_table.h, EnvironmentMap) for both integrators:
// its radiance in a direction, the density with which it samples a direction, and the
// sample itself. Paths that escape the scene gather it (path_vertex.h, escaped_radiance);
// nee and mis also sample it as one of the emitters (estimator.h, sample_emitter), chosen by
// its power π·R²·L̄ (R the radius of the scene's bounds, L̄ the mean max-RGB radiance over
// directions).
#pragma once

#include <bit>

#include "emitter_table.h"
#include "lanes.h"
#include "sampling.h"
#include "vec3.h"

namespace cierzo {
inline namespace CIERZO_ISA_NAMESPACE {

// The largest i in [0, n) with cdf[base + i] <= u (cdf non-decreasing, cdf[base] = 0 <= u):
// a branchless binary search, a gather per step.
template <class T>
I32<T> search_cdf(const float* cdf, const I32<T>& base, int32_t n, const T& u) {
    using I = I32<T>;
    I i(0);
    for (int32_t step = int32_t(std::bit_floor(uint32_t(n))); step > 0; step >>= 1) {
        const I next = i + I(step);
        const I at = min(next, I(n - 1));
        const auto below = mask_i32(gather_table(cdf, base + at) <= u);
        i = select(below & (next < I(n)), next, i);
    }
    return i;
}

template <class T>
Vec3<T> rotate3(const float* m, const Vec3<T>& v) {
    return {fma(T(m[0]), v.x, fma(T(m[1]), v.y, T(m[2]) * v.z)),
            fma(T(m[3]), v.x, fma(T(m[4]), v.y, T(m[5]) * v.z)),
            fma(T(m[6]), v.x, fma(T(m[7]), v.y, T(m[8]) * v.z))};
}

// The texel (flat index) a world direction falls in, and sin θ there.
template <class T>
I32<T> environment_texel(const EnvironmentMap& env, const Vec3<T>& d, T& sin_theta) {
    using I = I32<T>;
    constexpr float kInvPi = 0.3183098861837907f, kInvTwoPi = 0.15915494309189535f;
    const Vec3<T> w = rotate3(env.to_local, d);
    const T len = sqrt(dot(w, w));
    const T y = min(max(w.y / len, T(-1.0f)), T(1.0f));
    sin_theta = sqrt(max(T(1.0f) - y * y, T(0.0f)));
    const T row_f = acos(y) * T(kInvPi * float(env.height));
    const T u = fma(atan2(w.x, w.z), T(kInvTwoPi), T(0.5f));
    const T col_f = u * T(float(env.width));
    // (NaN, from a zero direction, becomes texel 0)
    const I row =
        to_int(min(max(select(row_f == row_f, row_f, T(0.0f)), T(0.0f)), T(float(env.height - 1))));
    const I col =
        to_int(min(max(select(col_f == col_f, col_f, T(0.0f)), T(0.0f)), T(float(env.width - 1))));
    return row * I(env.width) + col;
}

template <class T>
Vec3<T> environment_texel_radiance(const EnvironmentMap& env, const I32<T>& texel) {
    const I32<T> at = texel * I32<T>(3);
    return {gather_table(env.radiance, at), gather_table(env.radiance, at + I32<T>(1)),
            gather_table(env.radiance, at + I32<T>(2))};
}

// The radiance arriving along -d (seen looking in direction d).
template <class T>
Vec3<T> environment_radiance(const EnvironmentMap& env, const Vec3<T>& d) {
    T sin_theta;
    return environment_texel_radiance<T>(env, environment_texel(env, d, sin_theta));
}

// The solid-angle density with which sample_environment chooses direction d.
template <class T>
T environment_pdf(const EnvironmentMap& env, const Vec3<T>& d) {
    constexpr float kInvTwoPi2 = 0.05066059182116889f;  // 1 / (2π²)
    T sin_theta;
    const I32<T> texel = environment_texel(env, d, sin_theta);
    const T density = gather_table(env.density, texel);
    return select(sin_theta > T(0.0f), density * T(kInvTwoPi2) / sin_theta, T(0.0f));
}

// A direction from the environment's distribution: its world direction, radiance and
// solid-angle density (ok: the density is positive and finite).
template <class T>
struct EnvironmentSample {
    Vec3<T> wi, le;
    T pdf;
    Mask<T> ok;
};
template <class T>
EnvironmentSample<T> sample_environment(const EnvironmentMap& env, const T& u1, const T& u2) {
    using I = I32<T>;
    constexpr float kInvTwoPi2 = 0.05066059182116889f;
    const I row = search_cdf(env.row_cdf, I(0), env.height, u1);
    const T r0 = gather_table(env.row_cdf, row), r1 = gather_table(env.row_cdf, row + I(1));
    const T dv = min(max((u1 - r0) / (r1 - r0), T(0.0f)), T(0x1.fffffep-1f));
    const I base = row * I(env.width + 1);
    const I col = search_cdf(env.col_cdf, base, env.width, u2);
    const T c0 = gather_table(env.col_cdf, base + col),
            c1 = gather_table(env.col_cdf, base + col + I(1));
    const T du = min(max((u2 - c0) / (c1 - c0), T(0.0f)), T(0x1.fffffep-1f));
    const T theta = (to_float(row) + dv) * T(kPi / float(env.height));
    const T phi = fma(to_float(col) + du, T(2.0f * kPi / float(env.width)), T(-kPi));
    const T st = sin(theta), ct = cos(theta);
    const Vec3<T> local{st * sin(phi), ct, st * cos(phi)};
    const I texel = row * I(env.width) + col;
    EnvironmentSample<T> out;
    out.wi = rotate3(env.to_world, local);
    out.le = environment_texel_radiance<T>(env, texel);
    const T density = gather_table(env.density, texel);
    out.pdf = density * T(kInvTwoPi2) / st;
    out.ok = (st > T(0.0f)) & (density > T(0.0f)) & (out.pdf < T(3e38f));
    out.pdf = select(out.ok, out.pdf, T(1.0f));
    return out;
}

}  // namespace CIERZO_ISA_NAMESPACE
}  // namespace cierzo
