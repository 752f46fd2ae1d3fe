// Shading normals of smooth meshes, for both integrators (T = float or an xsimd batch).
//
// A smooth mesh shades with its vertex normals interpolated across each triangle (ns) while
// the geometric normal n keeps deciding everything about the surface itself: which side a ray
// arrives from and leaves to, the offset of the rays leaving it, and whether a refraction
// enters or leaves. The lobes are sampled and evaluated about ns turned to the arriving side;
// a direction they produce, or a light they are lit by, counts only on the geometric side it
// should be on (Veach 1997, §5.3: otherwise light leaks through the surface and a reflection
// goes into the object). These vertices lose what would have gone to the other side, mostly at
// grazing angles near silhouettes; they never gain energy.
#pragma once

#include "intersect.h"
#include "lanes.h"
#include "vec3.h"

namespace cierzo {
inline namespace CIERZO_ISA_NAMESPACE {

// The shading normal at p (on or next to the triangle v[0..2]) from the vertex normals
// vn[0..2]: interpolated with p's barycentric coordinates, clamped to the triangle, and
// normalised; `fallback` (the geometric normal) where the interpolation vanishes (opposite
// vertex normals, zero normals) or the triangle is degenerate. The coordinates are computed on
// edges rescaled to unit size, so huge and tiny triangles give the same answer.
template <class T>
Vec3<T> interpolate_normal(const Vec3<T> v[3], const Vec3<T> vn[3], const Vec3<T>& p,
                           const Vec3<T>& fallback) {
    const Vec3<T> e1 = v[1] - v[0], e2 = v[2] - v[0];
    const T scale = T(1.0f) / max(max_abs(e1), max_abs(e2));
    const Vec3<T> a = e1 * scale, b = e2 * scale, q = (p - v[0]) * scale;
    const Vec3<T> c = cross(a, b);
    const T inv = T(1.0f) / dot(c, c);
    T b1 = max(dot(cross(q, b), c) * inv, T(0.0f));
    T b2 = max(dot(cross(a, q), c) * inv, T(0.0f));
    const T sum = b1 + b2;
    const T over = select(sum > T(1.0f), T(1.0f) / sum, T(1.0f));
    b1 = b1 * over, b2 = b2 * over;
    const T b0 = max(T(1.0f) - b1 - b2, T(0.0f));
    const Vec3<T> n = fma(vn[2], b2, fma(vn[1], b1, vn[0] * b0));
    const T len2 = dot(n, n);
    // (NaN from a degenerate triangle fails the test too)
    const Mask<T> usable = (len2 > T(1e-20f)) & (len2 < T(1e30f));
    return select(usable, n * (T(1.0f) / sqrt(select(usable, len2, T(1.0f)))), fallback);
}

// The shading normal turned to the side of nf (the geometric normal facing the arriving ray).
template <class T>
Vec3<T> facing_shading_normal(const Vec3<T>& ns, const Vec3<T>& nf) {
    return select(dot(ns, nf) < T(0.0f), -ns, ns);
}

// A direction leaves on the arriving side of the geometric surface (nf faces the ray).
template <class T>
Mask<T> on_arriving_side(const Vec3<T>& dir, const Vec3<T>& nf) {
    return dot(dir, nf) > T(0.0f);
}

}  // namespace CIERZO_ISA_NAMESPACE
}  // namespace cierzo
