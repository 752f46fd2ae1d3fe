// The scene's acceleration structure: one 8-wide BVH over every bounded primitive — the
// triangles of every mesh (in world space), spheres, bounded quadrics and mesh instances —
// whose leaves hold SoA blocks of one primitive kind, tested together. An instance is a
// mesh's own BVH (built once, however many objects use the mesh) reached through the
// object's transform. Built here (bvh_build.cpp: binned SAH, spatial splits on request,
// TBB-parallel for big inputs, collapsed to 8-wide nodes); traversed by kernels/bvh/traverse.h,
// the one traversal both integrators call, over the plain layout of kernels/bvh/bvh_layout.h.
// Design and measurements: docs/acceleration.md.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "kernels/bvh/bvh_layout.h"
#include "kernels/vec3.h"

namespace cierzo {

// ---- Building ------------------------------------------------------------------------------

// Triangles of one mesh, 3 indices per triangle into positions.
struct BvhTriangles {
    std::span<const Vec3f> positions;
    std::span<const uint32_t> indices;
    uint32_t mesh = 0;  // reported with each hit
};

// A quadric clipped to a finite box.
struct BvhQuadric {
    uint32_t index;  // into `quadric_table`
    Vec3f box_min, box_max;
};

class Bvh;
struct BvhObjectInstance {
    std::shared_ptr<const Bvh> geometry;  // triangles only; shared by every copy
    float to_object[12];
    float normal_to_world[9];
    float to_world[12];  // for the instance's world box
    uint32_t mesh;
};

// Spatial splits (SBVH: Stich, Friedrich and Dietrich, "Spatial Splits in Bounding Volume
// Hierarchies", HPG 2009): a triangle's reference may be split at a plane, so that the two
// children's boxes overlap less, for up to this fraction of extra references (0: none).
// The default was measured (docs/acceleration.md, "Spatial splits").
constexpr float kBvhDefaultSplitBudget = 0.0f;
constexpr float kBvhMaxSplitBudget = 4.0f;

struct BvhInput {
    std::vector<BvhTriangles> triangles;
    float split_budget = kBvhDefaultSplitBudget;  // in [0, kBvhMaxSplitBudget]
    std::span<const float> sphere_x, sphere_y, sphere_z, sphere_r;
    std::vector<BvhQuadric> quadrics;
    std::span<const float> quadric_table;  // 16 floats per quadric (BvhView::quadrics)
    std::vector<BvhObjectInstance> instances;
};

// Build statistics, for --stats and the benchmarks.
struct BvhStats {
    size_t primitives = 0;  // in the tree (degenerate triangles are left out)
    size_t references = 0;  // in the leaves: primitives plus the spatial splits' copies
    size_t nodes = 0, triangle_blocks = 0, sphere_blocks = 0, items = 0;
    size_t bytes = 0;  // everything the traversal reads (not the shared geometry)
    int depth = 0;     // of the binary build tree
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
    void build(std::span<const Vec3f> positions, std::span<const uint32_t> indices,
               float split_budget = kBvhDefaultSplitBudget);

    const BvhView& view() const { return view_; }
    bool empty() const { return nodes_.empty(); }
    const BvhStats& stats() const { return stats_; }
    Vec3f bounds_min() const { return {view_.bounds[0], view_.bounds[1], view_.bounds[2]}; }
    Vec3f bounds_max() const { return {view_.bounds[3], view_.bounds[4], view_.bounds[5]}; }

    // One ray through the tree with the scalar traversal (kernels/bvh/traverse.h): the closest
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
