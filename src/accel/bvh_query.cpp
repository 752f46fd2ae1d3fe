// A single mesh's BVH queried one ray at a time with the scalar traversal (T = float).
#include "accel/bvh.h"

#include "kernels/bvh/traverse.h"

namespace cierzo {

bool Bvh::intersect(const Ray<float>& ray, float tmax, TriangleHit& hit) const {
    BvhHit h;
    float t = tmax;
    if (!traverse<false, float>(view_, make_traversal_ray(ray.o, ray.d), t, h)) return false;
    // The barycentrics from the same kernel, on the triangle as stored
    const float(*v)[kWideBvhWidth] = view_.triangles[h.lane / kWideBvhWidth].v;
    const uint32_t j = h.lane % kWideBvhWidth;
    float t2 = 0.0f, b1 = 0.0f, b2 = 0.0f;
    intersect_triangle(ray, make_ray_shear(ray.d), Vec3f(v[0][j], v[1][j], v[2][j]),
                       Vec3f(v[3][j], v[4][j], v[5][j]), Vec3f(v[6][j], v[7][j], v[8][j]), kRayFar,
                       t2, b1, b2);
    hit = {t, b1, b2, hit_triangle(view_, h)};
    return true;
}

bool Bvh::occluded(const Ray<float>& ray, float tmax) const {
    BvhHit h;
    float t = tmax;
    return traverse<true, float>(view_, make_traversal_ray(ray.o, ray.d), t, h);
}

}  // namespace cierzo
