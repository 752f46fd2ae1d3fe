// The report's pinhole camera ray, for one pixel position or K of them: the direction goes
// from the origin through forward + u·left + v·up, with u, v in [-1, 1] (+1 at the left
// and top edges of the image).
#pragma once

#include "vec3.h"

namespace cierzo {
inline namespace CIERZO_ISA_NAMESPACE {

// (sx, sy): the position on the image in pixels, (0, 0) the top-left corner.
template <class T>
Ray<T> pinhole_ray(const Vec3f& origin, const Vec3f& forward, const Vec3f& left,
                   const Vec3f& up, const T& sx, const T& sy, float inv_width,
                   float inv_height) {
    const T u = T(1.0f) - T(2.0f * inv_width) * sx;
    const T v = T(1.0f) - T(2.0f * inv_height) * sy;
    const Vec3<T> d = fma(Vec3<T>(left), u, fma(Vec3<T>(up), v, Vec3<T>(forward)));
    return {Vec3<T>(origin), normalize(d)};
}

}  // namespace CIERZO_ISA_NAMESPACE
}  // namespace cierzo
