// The scene's acceleration structure: one 8-wide BVH over every bounded primitive — the
// triangles of every mesh (in world space), spheres, bounded quadrics and mesh instances —
// whose leaves hold SoA blocks of one primitive kind, tested together. An instance is a
// mesh's own BVH (built once, however many objects use the mesh) reached through the
// object's transform. Built here (bvh_build.cpp: binned SAH, TBB-parallel for big inputs,
// collapsed to 8-wide nodes); traversed by kernels/traverse.h, the one traversal both
// integrators call. The layout below is plain data, so the per-ISA kernels include it too.
// Design and measurements: docs/acceleration.md.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "kernels/vec3.h"

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
//   bounds[0..2][i]  min x, y, z of child i; bounds[3..5][i] its max x, y, z
//   child[i]         inner child: its node index; leaf: where its primitives start (kind[i])
//   count[i]         leaf: its primitives (1-16); inner child: 0
//   kind[i]          leaf: a BvhLeafKind
//   slots            children in use, in slots [0, slots); unused slots have an empty box
//                    (min +inf, max -inf) and are also masked off by the traversal
//   leaves           bit i set: slot i is a leaf
struct alignas(64) WideBvhNode {
    float bounds[6][kWideBvhWidth];
    uint32_t child[kWideBvhWidth];
    uint16_t count[kWideBvhWidth];
    uint8_t kind[kWideBvhWidth];
    uint32_t slots;
    uint32_t leaves;
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
    const uint32_t* sphere_index = nullptr;    // block lane -> Scene sphere index
    const uint32_t* items = nullptr;           // quadric or instance indices of leaves
    const float* quadrics = nullptr;           // 16 floats per scene quadric: A..J, box min, max
    const BvhInstance* instances = nullptr;
    int32_t instance_count = 0;
    float bounds[6] = {0, 0, 0, -1, -1, -1};   // min xyz, max xyz of everything (empty: min > max)
};

// ---- Building ------------------------------------------------------------------------------

// Triangles of one mesh, 3 indices per triangle into positions.
struct BvhTriangles {
    std::span<const Vec3f> positions;
    std::span<const uint32_t> indices;
    uint32_t mesh = 0;  // reported with each hit
};

// A quadric clipped to a finite box.
struct BvhQuadric {
    uint32_t index;       // into `quadric_table`
    Vec3f box_min, box_max;
};

class Bvh;
struct BvhObjectInstance {
    std::shared_ptr<const Bvh> geometry;  // triangles only; shared by every copy
    float to_object[12];
    float normal_to_world[9];
    float to_world[12];              // for the instance's world box
    uint32_t mesh;
};

struct BvhInput {
    std::vector<BvhTriangles> triangles;
    std::span<const float> sphere_x, sphere_y, sphere_z, sphere_r;
    std::vector<BvhQuadric> quadrics;
    std::span<const float> quadric_table;  // 16 floats per quadric (BvhView::quadrics)
    std::vector<BvhObjectInstance> instances;
};

// Build statistics, for --stats and the benchmarks.
struct BvhStats {
    size_t primitives = 0;  // in the tree (degenerate triangles are left out)
    size_t nodes = 0, triangle_blocks = 0, sphere_blocks = 0, items = 0;
    size_t bytes = 0;       // everything the traversal reads (not the shared geometry)
    int depth = 0;          // of the binary build tree
};

// The closest hit of a ray on a single mesh's BVH (the convenience queries below).
struct TriangleHit {
    float t;
    float b1, b2;       // barycentrics of the 2nd and 3rd vertex
    uint32_t triangle;  // the triangle's index in the mesh
};

class Bvh {
public:
    Bvh() = default;
    // (copies and moves point their view at their own arrays; instances' meshes are shared)
    Bvh(const Bvh& other) { *this = other; }
    Bvh& operator=(const Bvh& other);
    Bvh(Bvh&& other) noexcept { *this = std::move(other); }
    Bvh& operator=(Bvh&& other) noexcept;

    // Builds over everything in `in`. Degenerate triangles (zero area, non-finite vertex)
    // and primitives with a non-finite box are left out: no ray can hit them. Throws
    // InputError when a triangle index is out of range or the count is not a multiple of 3.
    // Inputs of more than a few thousand primitives are built in parallel (TBB).
    void build(const BvhInput& in);
    // One mesh's triangles (mesh id 0).
    void build(std::span<const Vec3f> positions, std::span<const uint32_t> indices);

    const BvhView& view() const { return view_; }
    bool empty() const { return nodes_.empty(); }
    const BvhStats& stats() const { return stats_; }
    Vec3f bounds_min() const { return {view_.bounds[0], view_.bounds[1], view_.bounds[2]}; }
    Vec3f bounds_max() const { return {view_.bounds[3], view_.bounds[4], view_.bounds[5]}; }

    // One ray through the tree with the scalar traversal (kernels/traverse.h): the closest
    // triangle hit with t in (0, tmax), and any hit. For single-mesh BVHs (tests, benchmarks).
    bool intersect(const Ray<float>& ray, float tmax, TriangleHit& hit) const;
    bool occluded(const Ray<float>& ray, float tmax) const;

private:
    struct Builder;
    void update_view();

    std::vector<WideBvhNode> nodes_;
    std::vector<TriangleBlock> triangles_;
    std::vector<uint32_t> triangle_mesh_, triangle_index_;
    std::vector<SphereBlock> spheres_;
    std::vector<uint32_t> sphere_index_;
    std::vector<uint32_t> items_;
    std::vector<float> quadrics_;
    std::vector<BvhInstance> instances_;
    std::vector<std::shared_ptr<const Bvh>> geometries_;  // what instances_ point into
    BvhView view_;
    BvhStats stats_;
};

}  // namespace cierzo
