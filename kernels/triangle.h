// Watertight ray/triangle intersection: Woop, Benthin and Wald, "Watertight Ray/Triangle
// Intersection", JCGT 2(1), 2013. One template serves one ray (T = float) and K rays against
// K triangles (T = xsimd::batch<float, Arch>), with a per-lane choice of the dominant axis.
#pragma once

#include <type_traits>

#include "lanes.h"
#include "vec3.h"

namespace cierzo {
inline namespace CIERZO_ISA_NAMESPACE {

// ---- Per-lane component selection ---------------------------------------------------
// Which component of a Vec3 an axis index names, as masks, so a batch can pick a different
// component in every lane with two selects (and a float picks with two conditionals).
template <class T>
struct AxisPick {
    Mask<T> is_x, is_y;  // neither: z
};

template <class T>
T pick(const Vec3<T>& v, const AxisPick<T>& a) {
    return select(a.is_x, v.x, select(a.is_y, v.y, v.z));
}

// A product rounded to float and kept that way: the empty asm hides the value from the
// optimiser, so it cannot fuse the multiplication into a following addition. With FMA enabled
// GCC (-ffp-contract=fast, its C++ default) and clang (=on) turn a*b - c*d into
// fma(a, b, -c*d), which breaks the antisymmetry of the edge functions: rays then leak
// between neighbouring triangles (test_triangle checks this with an FMA-compiled copy).
// aarch64 always has FMA, so there every build needs the barrier. The constraint names the
// register file floats and vectors live in: "v" (SSE/AVX) on x86-64, "w" (FP/SIMD) on aarch64.
#if defined(__aarch64__)
#define CIERZO_FP_REGISTER "+w"
#else
#define CIERZO_FP_REGISTER "+v"
#endif
inline float rounded(float x) {
#if defined(__GNUC__)
    __asm__("" : CIERZO_FP_REGISTER(x));
#endif
    return x;
}
template <class A>
inline xsimd::batch<float, A> rounded(const xsimd::batch<float, A>& x) {
    auto r = x.data;
#if defined(__GNUC__)
    __asm__("" : CIERZO_FP_REGISTER(r));
#endif
    return xsimd::batch<float, A>(r);
}

// ---- Per-ray precomputation --------------------------------------------------------
// The shear that maps the ray to the +z axis through the origin (section 3 of the paper):
// kz is the dominant axis of d, kx = kz + 1, ky = kx + 1 (mod 3), with kx and ky swapped
// when d[kz] < 0 so the winding of every triangle is preserved.
template <class T>
struct RayShear {
    I32<T> kx, ky, kz;       // the axis indices (int32_t for float lanes)
    AxisPick<T> px, py, pz;  // the same axes as masks, used for the permutation
    T sx, sy, sz;            // d[kx] / d[kz], d[ky] / d[kz], 1 / d[kz]
};

template <class T>
RayShear<T> make_ray_shear(const Vec3<T>& d) {
    using I = I32<T>;
    RayShear<T> s;
    // Dominant axis; ties go to x, then y
    const T ax = abs(d.x), ay = abs(d.y), az = abs(d.z);
    const Mask<T> z_is_x = (ax >= ay) && (ax >= az);
    const Mask<T> z_is_y = (ay >= az) && !z_is_x;
    const Mask<T> z_is_z = !(z_is_x || z_is_y);
    s.pz = {z_is_x, z_is_y};
    const T dz = pick(d, s.pz);
    const Mask<T> neg = dz < T(0.0f);
    const Mask<T> pos = !neg;
    // kx, ky: the cyclic successors of kz, swapped for a negative d[kz]
    s.px = {(z_is_y && neg) || (z_is_z && pos), (z_is_x && pos) || (z_is_z && neg)};
    s.py = {(z_is_y && pos) || (z_is_z && neg), (z_is_x && neg) || (z_is_z && pos)};
    const auto index = [](const AxisPick<T>& p) {
        return select(mask_i32(p.is_x), I(0), select(mask_i32(p.is_y), I(1), I(2)));
    };
    s.kx = index(s.px);
    s.ky = index(s.py);
    s.kz = index(s.pz);
    // Shear constants
    s.sx = pick(d, s.px) / dz;
    s.sy = pick(d, s.py) / dz;
    s.sz = T(1.0f) / dz;
    return s;
}

// ---- The intersection test ---------------------------------------------------------
// Returns the lanes whose ray hits the triangle (v0, v1, v2) at a distance t in (0, tmax),
// from either side. t, b1 and b2 (the barycentric weights of v1 and v2) are written for every
// lane and meaningful only in the hit lanes. A triangle with two coincident vertices is never
// hit; one with distinct collinear vertices may be, as the rounded shear need not keep them
// collinear (the BVH leaves zero-area triangles out at build time).
//
// Edge functions that are exactly zero (the ray passes through an edge or a vertex in the
// sheared projection): the scalar version recomputes all three in double precision, where
// the products of floats are exact and the sign of each edge function is exact, as in the
// paper. The batch version keeps the float values, which are safe too: rounding is monotone,
// so a nonzero round(a*b) - round(c*d) has the sign of a*b - c*d, and the triangles on both
// sides of an edge compute exactly opposite values (the products are rounded, never fused).
// A zero only lets both neighbours report a hit; it never opens a gap.
template <class T>
Mask<T> intersect_triangle(const Ray<T>& ray, const RayShear<T>& s, const Vec3<T>& v0,
                           const Vec3<T>& v1, const Vec3<T>& v2, T tmax, T& t, T& b1, T& b2) {
    // Vertices relative to the ray origin
    const Vec3<T> a = v0 - ray.o;
    const Vec3<T> b = v1 - ray.o;
    const Vec3<T> c = v2 - ray.o;
    // Shear and scale into ray space (z is scaled later, only for hits)
    const T a_z = pick(a, s.pz), b_z = pick(b, s.pz), c_z = pick(c, s.pz);
    const T a_x = pick(a, s.px) - rounded(s.sx * a_z);
    const T a_y = pick(a, s.py) - rounded(s.sy * a_z);
    const T b_x = pick(b, s.px) - rounded(s.sx * b_z);
    const T b_y = pick(b, s.py) - rounded(s.sy * b_z);
    const T c_x = pick(c, s.px) - rounded(s.sx * c_z);
    const T c_y = pick(c, s.py) - rounded(s.sy * c_z);
    // Scaled barycentric coordinates: 2D edge functions about the ray
    T u = rounded(c_x * b_y) - rounded(c_y * b_x);
    T v = rounded(a_x * c_y) - rounded(a_y * c_x);
    T w = rounded(b_x * a_y) - rounded(b_y * a_x);
    if constexpr (std::is_same_v<T, float>) {
        if (u == 0.0f || v == 0.0f || w == 0.0f) {
            u = float(double(c_x) * double(b_y) - double(c_y) * double(b_x));
            v = float(double(a_x) * double(c_y) - double(a_y) * double(c_x));
            w = float(double(b_x) * double(a_y) - double(b_y) * double(a_x));
        }
    }
    // Inside when no edge function has a sign opposite to another
    const T zero(0.0f);
    const Mask<T> has_neg = (u < zero) | (v < zero) | (w < zero);
    const Mask<T> has_pos = (u > zero) | (v > zero) | (w > zero);
    const Mask<T> one_sign = mask_not(has_neg & has_pos);
    const T det = u + v + w;
    const Mask<T> inside = one_sign & (det != zero);
    if (none(inside)) {
        return inside;
    }
    // Distance and barycentrics (unfused here too, so one ray and K rays agree bit for bit)
    const T t_scaled =
        rounded(u * (s.sz * a_z)) + rounded(v * (s.sz * b_z)) + rounded(w * (s.sz * c_z));
    const T rcp_det = T(1.0f) / det;
    t = t_scaled * rcp_det;
    b1 = v * rcp_det;
    b2 = w * rcp_det;
    return inside & (t > zero) & (t < tmax);
}

}  // namespace CIERZO_ISA_NAMESPACE
}  // namespace cierzo
