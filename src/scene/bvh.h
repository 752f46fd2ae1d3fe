// A bounding-volume hierarchy over triangles: binned-SAH build, flattened 32-byte nodes and
// scalar closest-hit / any-hit traversal with the watertight triangle test (kernels/triangle.h);
// and the same tree collapsed to 8 children per node for the wavefront's SIMD traversal.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "kernels/vec3.h"
#include "scene/wide_bvh.h"

namespace cierzo {

// The closest hit of a ray: distance, barycentrics of the 2nd and 3rd vertex, and the index of
// the triangle in the input triangle list.
struct TriangleHit {
    float t;
    float b1, b2;
    uint32_t triangle;
};

class Bvh {
public:
    // 3 indices per triangle into positions. Degenerate (zero-area) triangles are kept but can
    // never be hit. Throws InputError when an index is out of range or the count is not a
    // multiple of 3.
    void build(std::span<const Vec3f> positions, std::span<const uint32_t> indices);

    // The closest hit with t in (0, tmax); hit is written only when this returns true.
    bool intersect(const Ray<float>& ray, float tmax, TriangleHit& hit) const;
    // Whether anything is hit with t in (0, tmax); stops at the first hit found.
    bool occluded(const Ray<float>& ray, float tmax) const;

    // Bounds of all non-degenerate triangles (an empty box, min > max, when there are none).
    Vec3f bounds_min() const;
    Vec3f bounds_max() const;
    size_t node_count() const { return nodes_.size(); }
    size_t triangle_count() const { return triangle_count_; }
    int depth() const { return depth_; }

    // The 8-wide collapse of the tree, for the wavefront's SIMD traversal (layout in
    // scene/wide_bvh.h): nodes with the root first (none when no triangle can be hit), the
    // triangles in blocks of 8, and the input index of each block lane (8 * block + lane).
    const WideBvhNode* wide_nodes() const { return wide_nodes_.data(); }
    size_t wide_node_count() const { return wide_nodes_.size(); }
    const TriangleBlock* triangle_blocks() const { return blocks_.data(); }
    const uint32_t* block_triangle_ids() const { return block_ids_.data(); }

    // The traversal stack holds at most one entry per level, so the build keeps the depth
    // below this.
    static constexpr int kMaxDepth = kBvhMaxDepth;
    // Never a leaf above this many triangles, whatever the SAH says (the wide tree's leaves
    // are the binary ones: at most two blocks of 8)
    static constexpr uint32_t kMaxLeafSize = 2 * kWideBvhWidth;

private:
    // A flattened node: its box, and either a leaf's triangle range or, for an inner node, the
    // index of the second child (the first child follows the node) and the split axis.
    struct alignas(32) Node {
        float bounds[6];     // min x, y, z, max x, y, z
        uint32_t offset;     // leaf: first triangle in leaf order; inner: second child
        uint16_t count;      // leaf: number of triangles (> 0); inner: 0
        uint16_t axis;       // inner: the split axis, for near-child-first traversal
    };
    static_assert(sizeof(Node) == 32);

    // A triangle's vertices, stored in leaf order.
    struct Triangle {
        Vec3f v0, v1, v2;
    };

    struct Builder;
    struct Collapser;
    void collapse();  // the 8-wide tree from the binary one (wide_bvh.cpp)
    template <bool kAnyHit>
    bool traverse(const Ray<float>& ray, float tmax, TriangleHit& hit) const;

    std::vector<Node> nodes_;
    std::vector<Triangle> triangles_;   // leaf order
    std::vector<uint32_t> triangle_ids_; // leaf order -> input triangle index
    std::vector<WideBvhNode> wide_nodes_;
    std::vector<TriangleBlock> blocks_;  // leaf order, each leaf starting a new block
    std::vector<uint32_t> block_ids_;    // 8 * block + lane -> input triangle index
    size_t triangle_count_ = 0;
    int depth_ = 0;
};

}  // namespace cierzo
