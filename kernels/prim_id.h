// The one encoding of a primitive in a hit record, for both integrators: its kind in the top
// byte, its index below. So a scene holds at most 2^24 - 1 spheres, planes and quadrics
// each (Scene::finalize refuses more); triangles are found through their mesh.
#pragma once

#include <cstdint>

namespace cierzo {

enum PrimKind : int32_t { kPrimSphere = 1, kPrimPlane = 2, kPrimQuadric = 3, kPrimMesh = 4 };
inline constexpr int32_t kPrimShift = 24;
inline constexpr int32_t kPrimIndexMask = (1 << kPrimShift) - 1;

}  // namespace cierzo
