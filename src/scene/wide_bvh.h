// The memory layout of the 8-wide triangle BVH that the wavefront traces one ray at a time
// (traverse_wide in src/integrators/wavefront/intersect_stage.h), collapsed from the binary
// SAH tree by Bvh::build (src/scene/wide_bvh.cpp). Plain data only, so both the scene code
// and the per-ISA kernels include it.
#pragma once

#include <cstdint>

namespace cierzo {

// Children per node, and triangles per leaf block: one AVX register of floats (SSE: 4 + 4).
inline constexpr int kWideBvhWidth = 8;
// The binary tree's depth bound (Bvh::kMaxDepth), and the traversal stack's: every wide level
// lowers the binary depth by at least one and leaves at most 7 entries on the stack.
inline constexpr int kBvhMaxDepth = 96;
inline constexpr int kWideBvhStackSize = (kWideBvhWidth - 1) * kBvhMaxDepth + 1;

// A node holds its children's boxes in SoA, so one ray tests all of them with a few SIMD
// operations; 256 bytes, 4 cache lines (boxes in the first 3).
//   bounds[0..2][i]  min x, y, z of child i; bounds[3..5][i] its max x, y, z
//   child[i]         inner child: its node index; leaf: its first triangle block
//   count[i]         leaf: its triangles (1-16, in ceil(count / 8) blocks); inner child: 0
//   slots            children in use, in slots [0, slots); unused slots have an empty box
//                    (min +inf, max -inf) and are also masked off by the traversal
//   leaves           bit i set: slot i is a leaf (count[i] != 0), so the traversal splits the
//                    children it enters into leaves and inner nodes with one AND
struct alignas(64) WideBvhNode {
    float bounds[6][kWideBvhWidth];
    uint32_t child[kWideBvhWidth];
    uint16_t count[kWideBvhWidth];
    uint32_t slots;
    uint32_t leaves;
};
static_assert(sizeof(WideBvhNode) == 256);

// Eight triangles in SoA (288 bytes): v[0..2] the x, y, z of vertex 0, v[3..5] vertex 1,
// v[6..8] vertex 2, lane l being triangle l. A leaf's triangles fill consecutive blocks in
// the binary tree's leaf order; lanes past its last triangle have all vertices at the origin,
// a degenerate triangle that the watertight test never hits.
struct alignas(32) TriangleBlock {
    float v[9][kWideBvhWidth];
};
static_assert(sizeof(TriangleBlock) == 288);

}  // namespace cierzo
