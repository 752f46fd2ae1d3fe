// Sampling the lights as the start of a path (light tracing, bidirectional estimators): a
// point on an emitter chosen by power with its area density, a direction leaving it and a
// point light's direction with their solid-angle densities, and each density again for a
// given point or direction (the reverse densities a bidirectional estimator weighs with).
// Emission is two-sided, as a path's hit sees it (docs/scene-format.md, `emission`): a
// direction leaves either side of the surface, the side chosen with probability 1/2.
#pragma once

#include "estimator.h"

namespace cierzo {
inline namespace CIERZO_ISA_NAMESPACE {

// A point on an emitter: its id, position, unit outward normal (a sphere's (p - c)/r, a
// triangle's e1 × e2 direction), Le, and the area density of the point, the emitter's pmf
// included. Not ok (and pdf 0) where the emitter has no area, or a density beyond float.
template <class T>
struct EmitterPosition {
    I32<T> id;
    Vec3<T> p, n;
    Vec3<T> le;
    T pdf;
    Mask<T> ok;
};

// pmf / area, from the record's size (a sphere's radius, a triangle's area); 0 where that
// is not a finite positive density. The one formula of the sampler and the density.
template <class T>
T emitter_area_pdf(const T& pmf, const T& size, const Mask<T>& sphere) {
    const T area = select(sphere, T(4.0f * kPi) * (size * size), size);
    const T pdf = pmf / area;
    return select((area > T(0.0f)) & (pdf < T(kRayFar)), pdf, T(0.0f));
}

// Chooses an emitter by power (choose_emitter, as next-event estimation does) and a point
// uniform by area on it: on a sphere over its whole surface (4πr²), on a triangle by the √u1
// warp. pdf_A = pmf / area.
template <class T>
EmitterPosition<T> sample_emitter_position(const EmitterTable& e, const T& u_pick, const T& u_alias,
                                           const T& u1, const T& u2) {
    const EmitterChoice<T> choice = choose_emitter(e, u_pick, u_alias);
    const auto at = [&](int k) { return emitter_field<T>(e, choice.id, k); };
    const Vec3<T> p0{at(0), at(1), at(2)};
    const T size = at(3);
    EmitterPosition<T> out;
    out.id = choice.id;
    out.le = {at(13), at(14), at(15)};
    out.pdf = emitter_area_pdf(choice.pmf, size, choice.sphere);
    out.ok = out.pdf > T(0.0f);
    // (light paths do not start on the environment: its share of them is not traced, and
    // camera paths gather it in full under lt)
    if (e.environment.emitter >= 0) out.ok = out.ok & !choice.environment;
    out.p = out.n = Vec3<T>(T(0.0f));
    // A sphere: its centre plus r times a uniform direction, which is the normal
    if (any(choice.sphere)) {
        const Vec3<T> n = sample_uniform_sphere(u1, u2);
        out.p = select(choice.sphere, fma(n, size, p0), out.p);
        out.n = select(choice.sphere, n, out.n);
    }
    // A triangle or a rectangle: the same area warp as next-event estimation's
    const auto triangle = !choice.sphere;
    if (any(triangle)) {
        const Vec3<T> e1{at(4), at(5), at(6)}, e2{at(7), at(8), at(9)};
        out.p = select(triangle, sample_planar_area(p0, e1, e2, u1, u2, choice.rectangle), out.p);
        out.n = select(triangle, Vec3<T>{at(10), at(11), at(12)}, out.n);
    }
    return out;
}

// The area density with which sample_emitter_position returns any given point on emitter id
// (uniform by area: the point itself does not enter).
template <class T>
T emitter_position_pdf(const EmitterTable& e, const I32<T>& id) {
    return emitter_area_pdf(emitter_entry<T>(e, e.pmf, id), emitter_field<T>(e, id, 3),
                            emitter_is_sphere<T>(e, id));
}

// A direction leaving a surface point and its solid-angle density; cos_theta = |cos θ| to
// the normal.
template <class T>
struct EmittedDirection {
    Vec3<T> dir;
    T cos_theta, pdf;
};

// Cosine-weighted about the normal, on a side chosen by u2: its first half the side of n,
// its second half the side of -n, each stretched back over [0, 1) for the azimuth (2u2 and
// 2u2 - 1 are exact). pdf_ω = |cos θ|/π · 1/2.
template <class T>
EmittedDirection<T> sample_emitted_direction(const Vec3<T>& n, const T& u1, const T& u2) {
    const auto front = u2 < T(0.5f);
    const T azimuth = T(2.0f) * u2 - select(front, T(0.0f), T(1.0f));
    const Vec3<T> local = sample_cosine_hemisphere(u1, azimuth);
    return {to_world(local, select(front, n, -n)), local.z, local.z * T(0.5f * kInvPi)};
}

// The density with which sample_emitted_direction leaves a point of unit normal n along dir.
template <class T>
T emitted_direction_pdf(const Vec3<T>& n, const Vec3<T>& dir) {
    return abs(dot(n, dir)) * T(0.5f * kInvPi);
}

// A point light's direction: uniform over the sphere, pdf_ω = 1/(4π) (its position is
// fixed: no area density).
template <class T>
struct PointLightDirection {
    Vec3<T> dir;
    T pdf;
};
template <class T>
T point_light_direction_pdf(const Vec3<T>&) {
    return T(0.25f * kInvPi);
}
template <class T>
PointLightDirection<T> sample_point_light_direction(const T& u1, const T& u2) {
    const Vec3<T> dir = sample_uniform_sphere(u1, u2);
    return {dir, point_light_direction_pdf(dir)};
}

}  // namespace CIERZO_ISA_NAMESPACE
}  // namespace cierzo
