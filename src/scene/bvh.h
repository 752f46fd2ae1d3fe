// A bounding-volume hierarchy over triangles: binned-SAH build, flattened 32-byte nodes and
// scalar closest-hit / any-hit traversal with the watertight triangle test (kernels/triangle.h).
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "kernels/vec3.h"

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
    // Raw views for the wavefront's SIMD traversal (FlatBvhNode in flat_scene.h has the same
    // layout): nodes, triangles in leaf order (9 floats each), and their input indices.
    const void* node_data() const { return nodes_.data(); }
    const float* triangle_data() const {
        static_assert(sizeof(Triangle) == 9 * sizeof(float));
        return reinterpret_cast<const float*>(triangles_.data());
    }
    const uint32_t* triangle_id_data() const { return triangle_ids_.data(); }
    size_t triangle_count() const { return triangle_count_; }
    int depth() const { return depth_; }

    // The traversal stack holds at most one entry per level, so the build keeps the depth
    // below this.
    static constexpr int kMaxDepth = 96;

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
    template <bool kAnyHit>
    bool traverse(const Ray<float>& ray, float tmax, TriangleHit& hit) const;

    std::vector<Node> nodes_;
    std::vector<Triangle> triangles_;   // leaf order
    std::vector<uint32_t> triangle_ids_; // leaf order -> input triangle index
    size_t triangle_count_ = 0;
    int depth_ = 0;
};

}  // namespace cierzo
