// The report's pinhole camera ray, for one pixel position or K of them: the direction goes
// from the origin through forward + u·left + v·up, with u, v in [-1, 1] (+1 at the left
// and top edges of the image). And the way back, for paths that start at the lights: where a
// point projects on the image, and the pinhole's importance for a direction.
#pragma once

#include "vec3.h"

namespace cierzo {
inline namespace CIERZO_ISA_NAMESPACE {

// (sx, sy): the position on the image in pixels, (0, 0) the top-left corner.
template <class T>
Ray<T> pinhole_ray(const Vec3f& origin, const Vec3f& forward, const Vec3f& left, const Vec3f& up,
                   const T& sx, const T& sy, float inv_width, float inv_height) {
    const T u = T(1.0f) - T(2.0f * inv_width) * sx;
    const T v = T(1.0f) - T(2.0f * inv_height) * sy;
    const Vec3<T> d = fma(Vec3<T>(left), u, fma(Vec3<T>(up), v, Vec3<T>(forward)));
    return {Vec3<T>(origin), normalize(d)};
}

// Where a point lands on the image: (sx, sy) in pixels as pinhole_ray takes them, and whether
// it lands at all (in front of the camera and inside the film).
template <class T>
struct FilmPoint {
    T sx, sy;
    Mask<T> on_film;
};

// The inverse of pinhole_ray: the point's direction from the origin written as
// a·(forward + u·left + v·up), solved by Cramer's rule (the frame need not be orthogonal: the
// report's explicit form takes any three vectors), then u, v turned into pixels. A point
// behind the camera (a ≤ 0), beside the film, or not finite is off the film.
template <class T>
FilmPoint<T> pinhole_project(const Vec3f& origin, const Vec3f& forward, const Vec3f& left,
                             const Vec3f& up, const Vec3<T>& p, float width, float height) {
    const Vec3<T> d = p - Vec3<T>(origin);
    const Vec3f lu = cross(left, up);
    const float det = dot(forward, lu);
    const T a = dot(d, Vec3<T>(lu)) * T(1.0f / det);
    const T b = dot(Vec3<T>(forward), cross(d, Vec3<T>(up))) * T(1.0f / det);
    const T c = dot(Vec3<T>(forward), cross(Vec3<T>(left), d)) * T(1.0f / det);
    const T inv_a = T(1.0f) / a;
    FilmPoint<T> out;
    out.sx = (T(1.0f) - b * inv_a) * T(0.5f * width);
    out.sy = (T(1.0f) - c * inv_a) * T(0.5f * height);
    out.on_film = (a > T(0.0f)) & (out.sx >= T(0.0f)) & (out.sx < T(width)) & (out.sy >= T(0.0f)) &
                  (out.sy < T(height));
    return out;
}

// The unit normal of the image plane (the plane through origin + forward spanned by left
// and up), on the side forward points to.
inline Vec3f pinhole_film_normal(const Vec3f& forward, const Vec3f& left, const Vec3f& up) {
    const Vec3f n = normalize(cross(left, up));
    return dot(forward, n) < 0.0f ? -n : n;
}

// The area of the image on its plane moved to distance 1 from the origin: the
// parallelogram 2·left × 2·up, over the squared distance of its plane.
inline float pinhole_film_area(const Vec3f& forward, const Vec3f& left, const Vec3f& up) {
    const float h = dot(forward, pinhole_film_normal(forward, left, up));
    return 4.0f * length(cross(left, up)) / (h * h);
}

// The pinhole's importance for a direction on the film whose cosine with the film normal is
// cos_theta: We = 1 / (A·cos⁴θ), A = pinhole_film_area, so that ∫_film We·cos θ dω = 1 (a
// solid angle dω is cos³θ·dA of the plane at distance 1). A pixel's share is its fraction
// of the film.
template <class T>
T pinhole_importance(const T& cos_theta, float film_area) {
    const T c2 = cos_theta * cos_theta;
    return T(1.0f / film_area) / (c2 * c2);
}

}  // namespace CIERZO_ISA_NAMESPACE
}  // namespace cierzo
