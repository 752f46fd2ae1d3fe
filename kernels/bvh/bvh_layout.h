// The layout of the scene's acceleration structure as the traversal reads it
// (kernels/bvh/traverse.h): plain data, no standard containers and no functions, so that every
// per-ISA object includes it and shares nothing else. Built by src/accel (bvh.h), which
// says what the structure holds; design and measurements: docs/acceleration.md.
#pragma once

#include <cstdint>

namespace cierzo {

// Children per node, and primitives per leaf block: one AVX register of floats (SSE and
// NEON: 4 + 4).
inline constexpr int kWideBvhWidth = 8;
// The binary build tree's depth bound, and the traversal stack's: every wide level lowers
// the binary depth by at least one and leaves at most 7 entries on the stack.
inline constexpr int kBvhMaxDepth = 96;
inline constexpr int kWideBvhStackSize = (kWideBvhWidth - 1) * kBvhMaxDepth + 1;
// Never a leaf above this many primitives (at most two blocks of 8).
inline constexpr uint32_t kBvhMaxLeafSize = 2 * kWideBvhWidth;

// The most rays a thread keeps in flight through the tree at once (kernels/bvh/traverse_group.h;
// FlatScene::ray_group).
inline constexpr int kMaxTraversalGroup = 64;
// Trees of at most this many wide nodes (a triangle tree takes about 2 kB a node with its
// leaf blocks, some 1 MB in all) stay in a core's L2 cache during a traversal: what a ray
// goes on to read is not prefetched there (kernels/bvh/traverse.h).
inline constexpr uint32_t kPrefetchAbove = 512;

// Far slab distances are scaled by 1 + 2γ(3) so rounding never culls a box a ray touches
// (Ize, "Robust BVH Ray Traversal", JCGT 2013).
inline constexpr float kBvhFarScale = 1.0f + 2.0f * (3.0f * 0x1p-24f / (1.0f - 3.0f * 0x1p-24f));

// What a leaf holds: all its primitives are of one kind.
enum BvhLeafKind : uint8_t {
    kLeafTriangles = 0,  // child: first TriangleBlock
    kLeafSpheres = 1,    // child: first SphereBlock
    kLeafQuadrics = 2,   // child: first entry of `items` (quadric indices)
    kLeafInstances = 3,  // child: first entry of `items` (instance indices)
};

// A node holds its children's boxes in SoA, so one ray tests all of them with a few SIMD
// operations; 256 bytes, 4 cache lines (boxes in the first 3).
//   bounds           six rows of kWideBvhWidth floats, row(k)[i]: rows 0..2 the min x, y, z
//                    of child i, rows 3..5 its max x, y, z (one flat array, so an offset
//                    into any row, as the traversal computes them, stays inside it)
//   child[i]         inner child: its node index; leaf: where its primitives start (kind[i])
//   count[i]         leaf: its primitives (1-16); inner child: 0
//   kind[i]          leaf: a BvhLeafKind
//   slots            children in use, in slots [0, slots); unused slots have an empty box
//                    (min +inf, max -inf), which no ray with a finite origin and direction
//                    enters, and are empty leaves (count 0), so that one that does (a NaN
//                    direction keeps every interval) tests nothing
//   leaves           bit i set: slot i is a leaf (or unused)
struct alignas(64) WideBvhNode {
    float bounds[6 * kWideBvhWidth];
    uint32_t child[kWideBvhWidth];
    uint16_t count[kWideBvhWidth];
    uint8_t kind[kWideBvhWidth];
    uint32_t slots;
    uint32_t leaves;

    const float* row(int k) const { return bounds + k * kWideBvhWidth; }
    float* row(int k) { return bounds + k * kWideBvhWidth; }
};
static_assert(sizeof(WideBvhNode) == 256);

// Eight triangles in SoA (288 bytes): v[0..2] the x, y, z of vertex 0, v[3..5] vertex 1,
// v[6..8] vertex 2, lane l being triangle l. Lanes past a leaf's last triangle have all
// vertices at the origin, a degenerate triangle that the watertight test never hits.
struct alignas(32) TriangleBlock {
    float v[9][kWideBvhWidth];
};
static_assert(sizeof(TriangleBlock) == 288);

// Eight spheres in SoA (128 bytes): centre x, y, z and radius. Unused lanes have a NaN
// centre, which no ray hits.
struct alignas(32) SphereBlock {
    float c[4][kWideBvhWidth];
};
static_assert(sizeof(SphereBlock) == 128);

struct BvhView;

// An object that uses a shared mesh: the mesh's BVH in its own space, the world-to-object
// affine map for rays (x' = M x + m; t is the same in both spaces, as the direction is
// mapped without normalising), and the inverse transpose of the object-to-world linear part
// for normals. Row-major 3 × 4 and 3 × 3.
struct BvhInstance {
    const BvhView* geometry;
    float to_object[12];
    float normal_to_world[9];
    uint32_t mesh;  // the Scene::meshes entry of this object (its material, its colours)
};

// The structure as the traversal reads it: pointers into a Bvh's arrays.
struct BvhView {
    const WideBvhNode* nodes = nullptr;  // root first; none when nothing can be hit
    int32_t node_count = 0;
    const TriangleBlock* triangles = nullptr;
    const uint32_t* triangle_mesh = nullptr;   // block lane (8 * block + lane) -> mesh
    const uint32_t* triangle_index = nullptr;  // block lane -> the triangle in its mesh
    const SphereBlock* spheres = nullptr;
    const uint32_t* sphere_index = nullptr;  // block lane -> Scene sphere index
    const uint32_t* items = nullptr;         // quadric or instance indices of leaves
    const float* quadrics = nullptr;         // 16 floats per scene quadric: A..J, box min, max
    const BvhInstance* instances = nullptr;
    int32_t instance_count = 0;
    float bounds[6] = {0, 0, 0, -1, -1, -1};  // min xyz, max xyz of everything (empty: min > max)
};

// Alpha cut-outs (materials' "alpha", MTL d and map_d): a triangle of a masked mesh is hit
// only where its alpha is at least kAlphaCutoff, in closest-hit and any-hit traversal alike
// (kernels/bvh/traverse.h). The alpha is `constant`, times the mask image's `channel` looked up
// bilinearly at the hit's texture coordinates where there is an image (width > 0). A
// threshold, not a stochastic test: masks are cut-outs (leaves, fences), and every ray,
// integrator and ISA makes the same decision from the same barycentrics.
inline constexpr float kAlphaCutoff = 0.5f;
struct AlphaMask {
    float constant = 1.0f;
    const int32_t* bytes = nullptr;  // the image (RGBA8 or RGBA32F), as ImageView
    const float* floats = nullptr;
    const float* decode = nullptr;  // byte / 255 (masks are data, never sRGB)
    int32_t width = 0, height = 0;
    int32_t channel = 3;  // 0..2 red, green, blue; 3 alpha
    float uv_scale[2] = {1.0f, 1.0f}, uv_offset[2] = {0.0f, 0.0f};
    uint32_t clamp = 0;
};
// Per scene mesh entry: its mask (-1: opaque), and its geometry's texture coordinates and
// triangles (null without an image).
struct MeshAlpha {
    int32_t mask = -1;
    const float* uvs = nullptr;
    const uint32_t* indices = nullptr;
};
struct AlphaTable {
    const MeshAlpha* meshes = nullptr;  // one per Scene mesh entry; null: nothing is masked
    const AlphaMask* masks = nullptr;
};

}  // namespace cierzo
