// The emitters that next-event estimation samples, as plain arrays both integrators read
// (built once per scene by Scene::finalize; see kernels/estimator.h for how they are used).
// No kernel types here: the per-ISA objects and the scalar side share this layout only.
#pragma once

#include <cstdint>

#include "settings.h"

namespace cierzo {

// The kinds of emitter that can be sampled.
enum EmitterKind : int32_t { kEmitterSphere = 0, kEmitterTriangle = 1 };

// Floats per emitter record in EmitterTable::data:
//   [0, 3)   sphere centre, or the triangle's first vertex v0 (world space)
//   3        sphere radius, or the triangle's area
//   [4, 7)   triangle edge v1 - v0     [7, 10) edge v2 - v0     [10, 13) unit normal
//   [13, 16) emitted radiance Le (RGB)
inline constexpr int32_t kEmitterStride = 16;

// Emitters chosen in proportion to their power (area × max Le) through Vose's alias table:
// slot i of `count` is kept with probability alias_q[i], else alias[i] is taken.
struct EmitterTable {
    int32_t count = 0;
    const float* alias_q = nullptr;    // count (padded)
    const int32_t* alias = nullptr;    // count
    const float* pmf = nullptr;        // count: the probability of choosing each emitter
    const int32_t* kind = nullptr;     // count: EmitterKind
    const float* data = nullptr;       // count * kEmitterStride
};

}  // namespace cierzo
