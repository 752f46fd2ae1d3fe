// Emitter sampling for next-event estimation: the emitter chosen by power from the alias
// table (kernels/emitter_table.h), a point or direction on it (by area, or by the solid
// angle of a sphere's cone, a spherical triangle or rectangle), and the density of that choice.
#pragma once

#include "emitter_table.h"
#include "environment.h"
#include "intersect.h"
#include "sampling.h"

namespace cierzo {
inline namespace CIERZO_ISA_NAMESPACE {

// One emitter sample seen from x: the direction and distance to the sampled point, the
// solid-angle density of that direction (the emitter's pmf included), the emitter's Le, and
// whether the sample is usable (a degenerate one is dropped).
template <class T>
struct EmitterSample {
    Vec3<T> wi;
    T t, pdf;
    Vec3<T> le;
    Mask<T> ok;
    Mask<T> sphere;
    I32<T> id;            // the emitter chosen
    Mask<T> environment;  // it is the environment
};

// 1 - cos θmax of the cone a sphere of squared radius r2 subtends at squared distance dc2,
// from sin²θmax/(1 + cos θmax) (no cancellation when the sphere is small or far).
template <class T>
T cone_one_minus_cos(const T& r2, const T& dc2) {
    const T sin2 = min(r2 / dc2, T(1.0f));
    return sin2 / (T(1.0f) + sqrt(max(T(1.0f) - sin2, T(0.0f))));
}

// Field k of emitter id's record; a scene with one emitter broadcasts it (no gather).
template <class T>
T emitter_field(const EmitterTable& e, const I32<T>& id, int k) {
    if (e.count == 1) return T(e.data[k]);
    return gather_table(e.data, id * I32<T>(kEmitterStride) + I32<T>(k));
}
template <class T, class E>
auto emitter_entry(const EmitterTable& e, const E* table, const I32<T>& id) {
    using Lanes = std::conditional_t<std::is_same_v<E, float>, T, I32<T>>;
    if (e.count == 1) return Lanes(table[0]);
    return Lanes(gather_table(table, id));
}

// Whether emitter id is a sphere (else a triangle or a rectangle), and a rectangle.
template <class T>
Mask<T> emitter_is_sphere(const EmitterTable& e, const I32<T>& id) {
    return mask_f32(emitter_entry<T>(e, e.kind, id) == I32<T>(kEmitterSphere));
}
template <class T>
Mask<T> emitter_is_rectangle(const EmitterTable& e, const I32<T>& id) {
    return mask_f32(emitter_entry<T>(e, e.kind, id) == I32<T>(kEmitterRectangle));
}

// A point uniform by area on the triangle v0, v0 + e1, v0 + e2 (below), or on the
// rectangle v0 + [0, 1]·e1 + [0, 1]·e2 where `rectangle`.
template <class T>
Vec3<T> sample_triangle_area(const Vec3<T>& v0, const Vec3<T>& e1, const Vec3<T>& e2, const T& u1,
                             const T& u2);
template <class T>
Vec3<T> sample_planar_area(const Vec3<T>& v0, const Vec3<T>& e1, const Vec3<T>& e2, const T& u1,
                           const T& u2, const Mask<T>& rectangle) {
    const Vec3<T> on_triangle = sample_triangle_area(v0, e1, e2, u1, u2);
    if (!any(rectangle)) return on_triangle;
    return select(rectangle, fma(e2, u2, fma(e1, u1, v0)), on_triangle);
}

// A point uniform by area on the triangle v0, v0 + e1, v0 + e2: barycentrics
// (√u1(1 - u2), √u1·u2) of e1 and e2.
template <class T>
Vec3<T> sample_triangle_area(const Vec3<T>& v0, const Vec3<T>& e1, const Vec3<T>& e2, const T& u1,
                             const T& u2) {
    const T su = sqrt(u1);
    return fma(e2, su * u2, fma(e1, su - su * u2, v0));
}

// v scaled to unit length, or 0 where it has none.
template <class T>
Vec3<T> unit_or_zero(const Vec3<T>& v) {
    const T len = length(v);
    return v * select(len > T(0.0f), T(1.0f) / len, T(0.0f));
}

// The solid angle of the spherical triangle with corners at the unit directions a, b, c
// (Van Oosterom and Strackee 1983): Ω = 2·atan2(|a·(b × c)|, 1 + a·b + b·c + c·a).
template <class T>
T spherical_triangle_area(const Vec3<T>& a, const Vec3<T>& b, const Vec3<T>& c) {
    const T triple = abs(dot(a, cross(b, c)));
    const T den = T(1.0f) + dot(a, b) + dot(b, c) + dot(c, a);
    return T(2.0f) * atan2(triple, den);
}

// A direction uniform by solid angle over the spherical triangle a, b, c (unit directions)
// of area Ω (Arvo 1995, "Stratified Sampling of Spherical Triangles"): u1 chooses the area
// Â = u1·Ω of the sub-triangle a, b, ĉ, whose third corner ĉ on the arc from a to c follows
// from the spherical law of cosines; u2 chooses the point on the arc from b to ĉ so that
// the area is uniform along it.
template <class T>
Vec3<T> sample_spherical_triangle(const Vec3<T>& a, const Vec3<T>& b, const Vec3<T>& c,
                                  const T& area, const T& u1, const T& u2) {
    // The angle α at a, between the great arcs to b and to c
    const T cos_alpha =
        max(min(dot(unit_or_zero(cross(a, b)), unit_or_zero(cross(a, c))), T(1.0f)), T(-1.0f));
    const T sin_alpha = sqrt(max(T(1.0f) - cos_alpha * cos_alpha, T(0.0f)));
    T sin_area, cos_area;
    sincos_2pi(u1 * area * T(0.5f * kInvPi), sin_area, cos_area);
    const T s = sin_area * cos_alpha - cos_area * sin_alpha;  // sin(Â - α)
    const T t = cos_area * cos_alpha + sin_area * sin_alpha;  // cos(Â - α)
    const T u = t - cos_alpha;
    const T v = s + sin_alpha * dot(a, b);  // (cos of the arc from a to b)
    const T den = (v * s + u * t) * sin_alpha;
    const T q =
        max(min(select(den != T(0.0f), ((v * t - u * s) * cos_alpha - v) / den, T(1.0f)), T(1.0f)),
            T(-1.0f));
    const Vec3<T> c_hat =
        fma(unit_or_zero(c - a * dot(c, a)), sqrt(max(T(1.0f) - q * q, T(0.0f))), a * q);
    const T z = T(1.0f) - u2 * (T(1.0f) - dot(c_hat, b));
    // (unit again: where the corners are nearly coplanar with the apex, rounding leaves the
    // construction a little off the sphere)
    return unit_or_zero(
        fma(unit_or_zero(c_hat - b * dot(c_hat, b)), sqrt(max(T(1.0f) - z * z, T(0.0f))), b * z));
}

// The triangle v0, v0 + e1, v0 + e2 as seen from x: the unit directions to its corners and
// its solid angle; `spherical` where triangle_solid_angle samples it by solid angle (at
// least kMinTriangleSolidAngle, and x off the triangle's plane: in it, the formula's 2π is
// the limit from one side of a triangle seen edge-on).
template <class T>
struct TriangleView {
    Vec3<T> a, b, c;
    T omega;
    Mask<T> spherical;
};
template <class T>
TriangleView<T> triangle_view(const Vec3<T>& x, const Vec3<T>& v0, const Vec3<T>& e1,
                              const Vec3<T>& e2) {
    TriangleView<T> v;
    const Vec3<T> to0 = v0 - x;
    v.a = unit_or_zero(to0);
    v.b = unit_or_zero(to0 + e1);
    v.c = unit_or_zero(to0 + e2);
    v.omega = spherical_triangle_area(v.a, v.b, v.c);
    v.spherical = (v.omega >= T(kMinTriangleSolidAngle)) & (v.omega <= T(2.0f * kPi)) &
                  (dot(v.a, cross(v.b, v.c)) != T(0.0f));
    return v;
}

// The rectangle corner + [0, 1]·e1 + [0, 1]·e2 (e1 ⊥ e2) as seen from x, in the frame of
// Ureña, Fajardo and King ("An Area-Preserving Parametrization for Spherical Rectangles",
// 2013): x at the origin, the rectangle in the plane z = z0 < 0 spanning [x0, x1] × [y0, y1];
// its solid angle Ω and what sampling it needs; `spherical` where it is sampled by solid
// angle (Ω at least kMinTriangleSolidAngle, x off its plane).
template <class T>
struct RectangleView {
    Vec3<T> ex, ey, ez;
    T x0, x1, y0, y1, z0;
    T b0, b1, k, omega;
    Mask<T> spherical;
};
template <class T>
RectangleView<T> rectangle_view(const Vec3<T>& x, const Vec3<T>& corner, const Vec3<T>& e1,
                                const Vec3<T>& e2) {
    RectangleView<T> r;
    const T l1 = length(e1), l2 = length(e2);
    r.ex = e1 * (T(1.0f) / l1);
    r.ey = e2 * (T(1.0f) / l2);
    r.ez = cross(r.ex, r.ey);
    const Vec3<T> d = corner - x;
    r.x0 = dot(d, r.ex), r.y0 = dot(d, r.ey);
    const T z = dot(d, r.ez);
    r.ez = select(z > T(0.0f), -r.ez, r.ez);
    r.z0 = -abs(z);
    r.x1 = r.x0 + l1, r.y1 = r.y0 + l2;
    // The unit normals of the planes through x and each side, and the angles between them
    const T z2 = r.z0 * r.z0;
    const T i0 = T(1.0f) / sqrt(z2 + r.y0 * r.y0), i1 = T(1.0f) / sqrt(z2 + r.x1 * r.x1);
    const T i2 = T(1.0f) / sqrt(z2 + r.y1 * r.y1), i3 = T(1.0f) / sqrt(z2 + r.x0 * r.x0);
    const auto angle = [](const T& c) { return acos(max(min(c, T(1.0f)), T(-1.0f))); };
    // n0 = (0, z0, -y0)·i0, n1 = (-z0, 0, x1)·i1, n2 = (0, -z0, y1)·i2, n3 = (z0, 0, -x0)·i3
    const T g0 = angle(r.y0 * r.x1 * i0 * i1);
    const T g1 = angle(-r.x1 * r.y1 * i1 * i2);
    const T g2 = angle(r.y1 * r.x0 * i2 * i3);
    const T g3 = angle(-r.x0 * r.y0 * i3 * i0);
    r.b0 = -r.y0 * i0;
    r.b1 = r.y1 * i2;
    r.k = T(2.0f * kPi) - g2 - g3;
    r.omega = g0 + g1 - r.k;  // g0 + g1 + g2 + g3 - 2π
    r.spherical =
        (r.omega >= T(kMinTriangleSolidAngle)) & (r.omega <= T(2.0f * kPi)) & (r.z0 < T(0.0f));
    return r;
}

// A point of the rectangle whose direction from x is uniform by solid angle over it (Ureña
// et al.): u1 chooses the x of the point through the area of the spherical rectangle left of
// it, u2 the y uniformly in the solid angle's measure along that column.
template <class T>
Vec3<T> sample_spherical_rectangle(const RectangleView<T>& r, const Vec3<T>& x, const T& u1,
                                   const T& u2) {
    const T au = fma(u1, r.omega, r.k);
    T s, c;
    sincos_2pi(au * T(0.5f * kInvPi), s, c);
    const T fu = (c * r.b0 - r.b1) / s;
    const T cu =
        max(min(select(fu >= T(0.0f), T(1.0f), T(-1.0f)) / sqrt(fma(fu, fu, r.b0 * r.b0)), T(1.0f)),
            T(-1.0f));
    const T xu = max(min(-(cu * r.z0) / sqrt(max(T(1.0f) - cu * cu, T(1e-12f))), r.x1), r.x0);
    const T d2 = fma(xu, xu, r.z0 * r.z0);
    const T h0 = r.y0 / sqrt(d2 + r.y0 * r.y0), h1 = r.y1 / sqrt(d2 + r.y1 * r.y1);
    const T hv = fma(u2, h1 - h0, h0);
    const T hv2 = hv * hv;
    const T yv =
        select(hv2 < T(1.0f - 1e-6f), hv * sqrt(d2) / sqrt(max(T(1.0f) - hv2, T(1e-12f))), r.y1);
    return fma(r.ez, r.z0, fma(r.ey, min(max(yv, r.y0), r.y1), fma(r.ex, xu, x)));
}

// The emitter chosen by power through the alias table (kernels/emitter_table.h): slot
// ⌊u_pick·count⌋, kept if u_alias < its q, else its alias. Its pmf and kind with it.
// The one choice rule of every emitter sampler (here and kernels/light_sampling.h).
template <class T>
struct EmitterChoice {
    I32<T> id;
    T pmf;
    Mask<T> sphere, rectangle, environment;
};
template <class T>
EmitterChoice<T> choose_emitter(const EmitterTable& e, const T& u_pick, const T& u_alias) {
    using I = I32<T>;
    const I slot = min(to_int(u_pick * T(float(e.count))), I(e.count - 1));
    const I id = e.count == 1 ? I(0)
                              : select(mask_i32(u_alias < gather_table(e.alias_q, slot)), slot,
                                       gather_table(e.alias, slot));
    const I32<T> kind = emitter_entry<T>(e, e.kind, id);
    return {id, emitter_entry<T>(e, e.pmf, id), mask_f32(kind == I32<T>(kEmitterSphere)),
            mask_f32(kind == I32<T>(kEmitterRectangle)),
            mask_f32(kind == I32<T>(kEmitterEnvironment))};
}

// Chooses an emitter by power (alias table) and samples it from x:
//   - a sphere seen from outside by the solid angle of its cone, uniformly
//     (pdf 1 / (2π(1 - cos θmax))); from inside, every direction (pdf 1/4π);
//   - a triangle or a rectangle by area (pdf d² / (A·|cos θl|) in solid angle), or with
//     `solid_angle` uniformly over the spherical triangle or rectangle it subtends (pdf 1/Ω)
//     where Ω is at least kMinTriangleSolidAngle;
//   - the environment by its own distribution (kernels/environment.h), at distance kRayFar.
// A sphere's sampled distance is the ray's own intersection with it, so a shadow ray that
// stops just short of t sees the same surface the sample lies on.
template <class T>
EmitterSample<T> sample_emitter(const EmitterTable& e, const Vec3<T>& x, const T& u_pick,
                                const T& u_alias, const T& u1, const T& u2,
                                bool solid_angle = false) {
    const EmitterChoice<T> choice = choose_emitter(e, u_pick, u_alias);
    const I32<T>& id = choice.id;
    const T& pmf = choice.pmf;
    const Mask<T>& sphere = choice.sphere;
    const auto at = [&](int k) { return emitter_field<T>(e, id, k); };
    const Vec3<T> p0{at(0), at(1), at(2)};
    const T size = at(3);
    EmitterSample<T> out;
    out.le = {at(13), at(14), at(15)};
    out.sphere = sphere;
    out.id = id;
    out.environment = choice.environment;
    T s, c;
    sincos_2pi(u2, s, c);
    out.wi = Vec3<T>(T(0.0f));
    out.t = T(0.0f);
    out.pdf = T(1.0f);
    out.ok = T(0.0f) > T(1.0f);
    if (any(sphere)) {
        const Vec3<T> to_c = p0 - x;
        const T dc2 = dot(to_c, to_c);
        const T r2 = size * size;
        const auto inside = dc2 <= r2;
        const T one_minus = cone_one_minus_cos(r2, dc2);
        // Inside: uniform on the unit sphere; outside: uniform in the cone around x → c
        const T a = select(inside, T(2.0f) * u1, u1 * one_minus);  // 1 - cos θ
        const T sin_t = sqrt(max(a * (T(2.0f) - a), T(0.0f)));
        const Vec3<T> local{sin_t * c, sin_t * s, T(1.0f) - a};
        const Vec3<T> axis =
            select(inside, Vec3<T>(T(0.0f), T(0.0f), T(1.0f)), to_c * (T(1.0f) / sqrt(dc2)));
        const Vec3<T> dir = to_world(local, axis);
        T t(0.0f);
        const auto hit = intersect_sphere(Ray<T>{x, dir}, p0, size, T(kRayFar), t);
        // A direction inside the cone that rounding makes miss (at the silhouette of a
        // small, far sphere) stops at its closest approach: it touches the sphere there
        t = select(hit, t, max(dot(to_c, dir), T(0.0f)));
        const T pdf = pmf * select(inside, T(0.25f * kInvPi), T(0.5f * kInvPi) / one_minus);
        out.wi = select(sphere, dir, out.wi);
        out.t = select(sphere, t, out.t);
        out.pdf = select(sphere, pdf, out.pdf);
        out.ok = sphere & (inside | ((one_minus > T(0.0f)) & (t > T(0.0f))));
    }
    const bool environment = e.environment.emitter >= 0;
    const auto triangle =
        environment ? !(sphere | choice.environment) : !sphere;  // (or a rectangle)
    if (environment && any(choice.environment)) {
        const auto env = choice.environment;
        const EnvironmentSample<T> es = sample_environment(e.environment, u1, u2);
        out.wi = select(env, es.wi, out.wi);
        out.t = select(env, T(kRayFar), out.t);
        out.pdf = select(env, pmf * es.pdf, out.pdf);
        out.le = select(env, es.le, out.le);
        out.ok = out.ok | (env & es.ok);
    }
    if (any(triangle)) {
        const Mask<T>& rectangle = choice.rectangle;
        const Vec3<T> e1{at(4), at(5), at(6)}, e2{at(7), at(8), at(9)}, nl{at(10), at(11), at(12)};
        const Vec3<T> p = sample_planar_area(p0, e1, e2, u1, u2, rectangle);
        const Vec3<T> to = p - x;
        const T d2 = dot(to, to);
        const T dist = sqrt(d2);
        Vec3<T> wi = to * (T(1.0f) / dist);
        T cos_l = abs(dot(nl, wi));
        T pdf = pmf * d2 / (size * cos_l);
        T t = dist;
        if (solid_angle && any(rectangle)) {
            const RectangleView<T> r = rectangle_view(x, p0, e1, e2);
            const auto spherical = rectangle & r.spherical;
            if (any(spherical)) {
                const Vec3<T> to_s = sample_spherical_rectangle(r, x, u1, u2) - x;
                const T ts = length(to_s);
                const Vec3<T> ws = to_s * (T(1.0f) / ts);
                wi = select(spherical, ws, wi);
                t = select(spherical, ts, t);
                cos_l = select(spherical, abs(dot(nl, ws)), cos_l);
                pdf = select(spherical, pmf / r.omega, pdf);
            }
        }
        if (solid_angle && !all(rectangle)) {
            const TriangleView<T> v = triangle_view(x, p0, e1, e2);
            const auto spherical = triangle & !rectangle & v.spherical;
            if (any(spherical)) {
                // The direction, and the distance to the triangle's plane along it
                const Vec3<T> ws = sample_spherical_triangle(v.a, v.b, v.c, v.omega, u1, u2);
                const T cos_s = dot(nl, ws);
                wi = select(spherical, ws, wi);
                t = select(spherical, dot(p0 - x, nl) / cos_s, t);
                cos_l = select(spherical, abs(cos_s), cos_l);
                pdf = select(spherical, pmf / v.omega, pdf);
            }
        }
        out.wi = select(triangle, wi, out.wi);
        out.t = select(triangle, t, out.t);
        out.pdf = select(triangle, pdf, out.pdf);
        out.ok = out.ok | (triangle & (cos_l > T(1e-7f)) & (t > T(0.0f)) & (t < T(kRayFar)) &
                           (pdf < T(kRayFar)));
    }
    return out;
}

// The solid-angle density with which sample_emitter would choose direction d from x towards
// the point at distance t on emitter id (which the ray x + t·d has hit): the hit side of MIS.
template <class T>
T emitter_pdf(const EmitterTable& e, const I32<T>& id, const Vec3<T>& x, const Vec3<T>& d,
              const T& t, bool solid_angle = false) {
    const auto at = [&](int k) { return emitter_field<T>(e, id, k); };
    const T pmf = emitter_entry<T>(e, e.pmf, id);
    const T size = at(3);
    const auto sphere = emitter_is_sphere<T>(e, id);
    T pdf = T(0.0f);
    if (any(sphere)) {
        const Vec3<T> to_c = Vec3<T>{at(0), at(1), at(2)} - x;
        const T dc2 = dot(to_c, to_c);
        const T r2 = size * size;
        const T one_minus = cone_one_minus_cos(r2, dc2);
        pdf = select(dc2 <= r2, T(0.25f * kInvPi), T(0.5f * kInvPi) / one_minus);
    }
    if (any(!sphere)) {
        const Vec3<T> nl{at(10), at(11), at(12)};
        T area_pdf = t * t / (size * abs(dot(nl, d)));
        if (solid_angle) {
            const Vec3<T> p0{at(0), at(1), at(2)}, e1{at(4), at(5), at(6)}, e2{at(7), at(8), at(9)};
            const auto rectangle = emitter_is_rectangle<T>(e, id);
            if (any(rectangle)) {
                const RectangleView<T> r = rectangle_view(x, p0, e1, e2);
                area_pdf = select(rectangle & r.spherical, T(1.0f) / r.omega, area_pdf);
            }
            if (!all(rectangle)) {
                const TriangleView<T> v = triangle_view(x, p0, e1, e2);
                area_pdf = select((!rectangle) & v.spherical, T(1.0f) / v.omega, area_pdf);
            }
        }
        pdf = select(sphere, pdf, area_pdf);
    }
    return pmf * pdf;
}

}  // namespace CIERZO_ISA_NAMESPACE
}  // namespace cierzo
