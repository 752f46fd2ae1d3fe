// Ray intersection with the report's analytic primitives (sphere, plane, bounded quadric),
// one function per primitive templated on the lane type, plus the ray-origin offset that
// keeps secondary rays from hitting the surface they leave (after Wächter and Binder, "A
// Fast and Robust Method for Avoiding Self-Intersection", Ray Tracing Gems, ch. 6, 2019).
#pragma once

#include <limits>

#include "vec3.h"

namespace cierzo {
inline namespace CIERZO_ISA_NAMESPACE {

// The farthest distance a ray looks: finite, so that t = inf (a ray parallel to a plane)
// fails `t < tmax` and never reads as a hit.
inline constexpr float kRayFar = std::numeric_limits<float>::max();

// Sphere: |p - c| = r. Discriminant in the form r² - |oc - (oc·d)d|², which stays
// accurate when the sphere is small and far away (Haines et al., Ray Tracing Gems ch. 7).
// `d` must be unit length. Returns the mask of lanes with a hit in (0, tmax) and its t.
template <class T>
Mask<T> intersect_sphere(const Ray<T>& ray, const Vec3<T>& center, const T& radius, const T& tmax,
                         T& t) {
    const Vec3<T> oc = ray.o - center;
    const T b = dot(oc, ray.d);
    const Vec3<T> v = oc - ray.d * b;
    const T r2 = radius * radius;
    const T disc = r2 - dot(v, v);
    const Mask<T> touches = disc >= T(0.0f);
    // (most rays that reach a sphere's lanes pass them all by: they skip the root and the
    // division; t is then left as it was, as on every lane missed)
    if (none(touches)) return touches;
    const T root = sqrt(max(disc, T(0.0f)));
    // Stable pair of roots: q = -b - sign(b)·root, t0 = c/q, t1 = q.
    const T q = select(b >= T(0.0f), -b - root, -b + root);
    const T c = dot(oc, oc) - r2;
    const T t0 = c / q;
    const T near = min(t0, q);
    const T far = max(t0, q);
    t = select(near > T(0.0f), near, far);
    return touches & (t > T(0.0f)) & (t < tmax);
}

// Plane n·p + d = 0 (the report's normal-and-distance form): with n = (1,0,0) and d = 1
// it is the plane x = -1. Rays parallel to it give t = ±inf or NaN and miss.
template <class T>
Mask<T> intersect_plane(const Ray<T>& ray, const Vec3<T>& normal, const T& distance, const T& tmax,
                        T& t) {
    t = -(dot(normal, ray.o) + distance) / dot(normal, ray.d);
    return (t > T(0.0f)) & (t < tmax);
}

// The ten coefficients of Ax² + By² + Cz² + Dxy + Eyz + Fxz + Gx + Hy + Iz + J = 0.
template <class T>
struct QuadricCoefficients {
    T a, b, c, d, e, f, g, h, i, j;
};

template <class T>
T quadric_value(const QuadricCoefficients<T>& q, const Vec3<T>& p) {
    return p.x * (q.a * p.x + q.d * p.y + q.f * p.z + q.g) + p.y * (q.b * p.y + q.e * p.z + q.h) +
           p.z * (q.c * p.z + q.i) + q.j;
}

// The gradient of the quadric: its unnormalised outward normal (towards f > 0).
template <class T>
Vec3<T> quadric_gradient(const QuadricCoefficients<T>& q, const Vec3<T>& p) {
    return {T(2.0f) * q.a * p.x + q.d * p.y + q.f * p.z + q.g,
            T(2.0f) * q.b * p.y + q.d * p.x + q.e * p.z + q.h,
            T(2.0f) * q.c * p.z + q.e * p.y + q.f * p.x + q.i};
}

// Quadric clipped to an axis-aligned box (infinite bounds for an unbounded quadric).
// Solves a·t² + b·t + c = 0 (the linear case when a vanishes) and keeps the nearest root
// in (0, tmax) whose point lies inside the box.
template <class T>
Mask<T> intersect_quadric(const Ray<T>& ray, const QuadricCoefficients<T>& q,
                          const Vec3<T>& box_min, const Vec3<T>& box_max, const T& tmax, T& t) {
    const Vec3<T>& o = ray.o;
    const Vec3<T>& d = ray.d;
    // Coefficients of the polynomial in t
    const T a =
        d.x * (q.a * d.x + q.d * d.y + q.f * d.z) + d.y * (q.b * d.y + q.e * d.z) + q.c * d.z * d.z;
    const T b = T(2.0f) * (q.a * o.x * d.x + q.b * o.y * d.y + q.c * o.z * d.z) +
                q.d * (o.x * d.y + o.y * d.x) + q.e * (o.y * d.z + o.z * d.y) +
                q.f * (o.x * d.z + o.z * d.x) + q.g * d.x + q.h * d.y + q.i * d.z;
    const T c = quadric_value(q, o);
    // Roots: stable quadratic form, or the single root of the linear case
    const auto linear = abs(a) <= T(1e-12f) * (abs(b) + T(1e-30f));
    const T disc = b * b - T(4.0f) * a * c;
    const T root = sqrt(max(disc, T(0.0f)));
    const T qq = T(-0.5f) * select(b >= T(0.0f), b + root, b - root);
    const T t_lin = -c / b;
    const T r0 = select(linear, t_lin, qq / a);
    const T r1 = select(linear, t_lin, c / qq);
    const auto real = linear | (disc >= T(0.0f));
    const T t_near = min(r0, r1);
    const T t_far = max(r0, r1);
    // A root counts when it is ahead, closer than tmax and inside the clipping box
    auto accept = [&](const T& tr) {
        const Vec3<T> p = fma(d, tr, o);
        return real & (tr > T(0.0f)) & (tr < tmax) & (p.x >= box_min.x) & (p.x <= box_max.x) &
               (p.y >= box_min.y) & (p.y <= box_max.y) & (p.z >= box_min.z) & (p.z <= box_max.z);
    };
    const auto hit_near = accept(t_near);
    const auto hit_far = accept(t_far);
    t = select(hit_near, t_near, t_far);
    return hit_near | hit_far;
}

// Largest absolute coordinate: the magnitude that sets a point's floating-point error.
template <class T>
T max_abs(const Vec3<T>& v) {
    return max(abs(v.x), max(abs(v.y), abs(v.z)));
}

// Moves a surface point p off the surface along n (the side the new ray leaves from).
// The error of a computed hit point is a few ulps of the largest coordinate that produced
// it, the point's own or the ray origin's, so `magnitude` = max(max_abs(p),
// max_abs(origin)) and the offset is 2^-17 of it (about 64 ulps): right at every scale,
// unlike a fixed epsilon. This is the idea of Wächter and Binder (Ray Tracing Gems ch. 6),
// made relative to the whole vector rather than per component, so a scene scaled by 1e-4
// near the origin is treated like one of unit size.
inline constexpr float kOffsetScale = 0x1.0p-17f;
template <class T>
Vec3<T> offset_ray_origin(const Vec3<T>& p, const Vec3<T>& n, const T& magnitude) {
    return fma(n, fma(magnitude, T(kOffsetScale), T(1e-30f)), p);
}

}  // namespace CIERZO_ISA_NAMESPACE
}  // namespace cierzo
