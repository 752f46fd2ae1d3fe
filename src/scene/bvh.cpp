// The triangle BVH: a binned-SAH top-down build (16 bins on the centroid bounds, best of the
// three axes) into depth-first flattened nodes, and stack-based scalar traversal with a
// robust slab test (Williams et al. 2005; Ize, "Robust BVH Ray Traversal", JCGT 2013).
#include "scene/bvh.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "core/error.h"
#include "kernels/triangle.h"

namespace cierzo {

namespace {

constexpr int kBins = 16;
constexpr uint32_t kLeafSize = 4;       // always a leaf at or below this many triangles
constexpr int kMaxSahDepth = 64;        // below this, object-median splits bound the depth
constexpr float kTraversalCost = 1.0f;  // relative to one triangle test

constexpr float kInf = std::numeric_limits<float>::infinity();

// Ize's bound on the rounding error of a slab distance: 1 + 2 gamma(3), gamma(n) = n u/(1 - n u).
constexpr float kGamma3 = 3.0f * 0x1p-24f / (1.0f - 3.0f * 0x1p-24f);
constexpr float kFarScale = 1.0f + 2.0f * kGamma3;

struct Box {
    Vec3f lo{kInf}, hi{-kInf};

    void grow(const Vec3f& p) { lo = vmin(lo, p); hi = vmax(hi, p); }
    void grow(const Box& b) { lo = vmin(lo, b.lo); hi = vmax(hi, b.hi); }
    // Half the surface area; zero for an empty box.
    float half_area() const {
        if (!(lo.x <= hi.x)) {
            return 0.0f;
        }
        const Vec3f e = hi - lo;
        return e.x * e.y + e.y * e.z + e.z * e.x;
    }
};

float component(const Vec3f& v, int axis) { return axis == 0 ? v.x : (axis == 1 ? v.y : v.z); }

// Zero area (collinear or coincident vertices, evaluated in double) or a non-finite vertex.
bool is_degenerate(const Vec3f& a, const Vec3f& b, const Vec3f& c) {
    for (const Vec3f& p : {a, b, c}) {
        if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) {
            return true;
        }
    }
    const double e1[3] = {double(b.x) - a.x, double(b.y) - a.y, double(b.z) - a.z};
    const double e2[3] = {double(c.x) - a.x, double(c.y) - a.y, double(c.z) - a.z};
    const double n[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2],
                         e1[0] * e2[1] - e1[1] * e2[0]};
    return n[0] == 0.0 && n[1] == 0.0 && n[2] == 0.0;
}

}  // namespace

// ---- Build ---------------------------------------------------------------------------------
struct Bvh::Builder {
    std::vector<Box> boxes;         // per input triangle
    std::vector<Vec3f> centroids;   // per input triangle (of the box)
    std::vector<uint32_t> order;    // the triangles being partitioned, non-degenerate only
    std::vector<Node>& nodes;
    int depth = 0;

    explicit Builder(std::vector<Node>& nodes_) : nodes(nodes_) {}

    // The bin of a centroid along an axis; the same formula for binning and partitioning.
    // Clamped in float first: near ±3e38 the scale can be 0 and the position NaN or out of
    // int range, and converting such a float to int is undefined (NaN goes to bin 0).
    static int bin_of(float c, float lo, float scale) {
        const float x = (c - lo) * scale;
        return x > 0.0f ? int(std::min(x, float(kBins - 1))) : 0;
    }

    void make_leaf(uint32_t node, uint32_t begin, uint32_t end) {
        nodes[node].offset = begin;
        nodes[node].count = uint16_t(end - begin);
        nodes[node].axis = 0;
    }

    // Builds the subtree over order[begin, end) and returns the index of its root.
    uint32_t build(uint32_t begin, uint32_t end, int level) {
        const uint32_t node = uint32_t(nodes.size());
        nodes.emplace_back();
        depth = std::max(depth, level);
        // Bounds of the triangles and of their centroids
        Box bounds, centroid_bounds;
        for (uint32_t i = begin; i < end; ++i) {
            bounds.grow(boxes[order[i]]);
            centroid_bounds.grow(centroids[order[i]]);
        }
        nodes[node].bounds[0] = bounds.lo.x;
        nodes[node].bounds[1] = bounds.lo.y;
        nodes[node].bounds[2] = bounds.lo.z;
        nodes[node].bounds[3] = bounds.hi.x;
        nodes[node].bounds[4] = bounds.hi.y;
        nodes[node].bounds[5] = bounds.hi.z;
        const uint32_t n = end - begin;
        if (n <= kLeafSize) {
            make_leaf(node, begin, end);
            return node;
        }
        // Split: binned SAH, or an object median when the SAH is not usable
        uint32_t mid = begin;
        int axis = 0;
        const Vec3f extent = centroid_bounds.hi - centroid_bounds.lo;
        const float max_extent = max_component(extent);
        if (level < kMaxSahDepth && max_extent > 0.0f) {
            int bin = -1;
            const float best_cost = find_sah_split(begin, end, centroid_bounds, axis, bin);
            const float split_cost = kTraversalCost + best_cost / bounds.half_area();
            if (split_cost >= float(n) && n <= Bvh::kMaxLeafSize) {
                make_leaf(node, begin, end);
                return node;
            }
            const float lo = component(centroid_bounds.lo, axis);
            const float scale = kBins / component(extent, axis);
            auto* split = std::partition(order.data() + begin, order.data() + end,
                                         [&](uint32_t t) {
                return bin_of(component(centroids[t], axis), lo, scale) < bin;
            });
            mid = uint32_t(split - order.data());
        }
        if (mid == begin || mid == end) {
            axis = extent.x >= extent.y && extent.x >= extent.z ? 0
                                                                 : (extent.y >= extent.z ? 1 : 2);
            mid = begin + n / 2;
            std::nth_element(order.data() + begin, order.data() + mid, order.data() + end,
                             [&](uint32_t a, uint32_t b) {
                return component(centroids[a], axis) < component(centroids[b], axis);
            });
        }
        // Children: the first follows this node, the second's index is stored
        build(begin, mid, level + 1);
        const uint32_t second = build(mid, end, level + 1);
        nodes[node].offset = second;
        nodes[node].count = 0;
        nodes[node].axis = uint16_t(axis);
        return node;
    }

    // The cheapest binned split plane over the three axes: returns its SAH cost (the sum of
    // child half-areas times counts) and sets the axis and the first bin of the second child.
    float find_sah_split(uint32_t begin, uint32_t end, const Box& centroid_bounds, int& best_axis,
                         int& best_bin) const {
        float best = kInf;
        for (int axis = 0; axis < 3; ++axis) {
            const float lo = component(centroid_bounds.lo, axis);
            const float extent = component(centroid_bounds.hi, axis) - lo;
            if (!(extent > 0.0f)) {
                continue;
            }
            // Bin the triangles
            const float scale = kBins / extent;
            Box bin_boxes[kBins];
            uint32_t bin_counts[kBins] = {};
            for (uint32_t i = begin; i < end; ++i) {
                const uint32_t t = order[i];
                const int b = bin_of(component(centroids[t], axis), lo, scale);
                bin_boxes[b].grow(boxes[t]);
                ++bin_counts[b];
            }
            // Sweep from the right, then from the left evaluating the planes
            float right_cost[kBins];
            Box right;
            uint32_t right_count = 0;
            for (int b = kBins - 1; b > 0; --b) {
                right.grow(bin_boxes[b]);
                right_count += bin_counts[b];
                right_cost[b] = float(right_count) * right.half_area();
            }
            Box left;
            uint32_t left_count = 0;
            for (int b = 1; b < kBins; ++b) {
                left.grow(bin_boxes[b - 1]);
                left_count += bin_counts[b - 1];
                if (left_count == 0 || left_count == end - begin) {
                    continue;
                }
                const float cost = float(left_count) * left.half_area() + right_cost[b];
                if (cost < best) {
                    best = cost;
                    best_axis = axis;
                    best_bin = b;
                }
            }
        }
        return best;
    }
};

void Bvh::build(std::span<const Vec3f> positions, std::span<const uint32_t> indices) {
    if (indices.size() % 3 != 0) {
        throw InputError("BVH: the triangle index count (" + std::to_string(indices.size()) +
                         ") is not a multiple of 3");
    }
    nodes_.clear();
    triangles_.clear();
    triangle_ids_.clear();
    wide_nodes_.clear();
    blocks_.clear();
    block_ids_.clear();
    depth_ = 0;
    triangle_count_ = indices.size() / 3;
    // Per-triangle boxes and centroids; degenerate triangles are left out of the tree
    Builder builder(nodes_);
    builder.boxes.resize(triangle_count_);
    builder.centroids.resize(triangle_count_);
    builder.order.reserve(triangle_count_);
    for (size_t i = 0; i < triangle_count_; ++i) {
        const uint32_t* tri = &indices[3 * i];
        for (int k = 0; k < 3; ++k) {
            if (tri[k] >= positions.size()) {
                throw InputError("BVH: triangle " + std::to_string(i) + " uses vertex " +
                                 std::to_string(tri[k]) + " but there are only " +
                                 std::to_string(positions.size()) + " vertices");
            }
        }
        const Vec3f &a = positions[tri[0]], &b = positions[tri[1]], &c = positions[tri[2]];
        if (is_degenerate(a, b, c)) {
            continue;
        }
        Box box;
        box.grow(a);
        box.grow(b);
        box.grow(c);
        builder.boxes[i] = box;
        builder.centroids[i] = (box.lo + box.hi) * 0.5f;
        builder.order.push_back(uint32_t(i));
    }
    if (builder.order.empty()) {
        return;
    }
    // The tree, the triangles copied in leaf order, then the 8-wide tree
    nodes_.reserve(2 * builder.order.size() / kLeafSize + 1);
    builder.build(0, uint32_t(builder.order.size()), 1);
    depth_ = builder.depth;
    triangles_.resize(builder.order.size());
    triangle_ids_ = builder.order;
    for (size_t i = 0; i < builder.order.size(); ++i) {
        const uint32_t* tri = &indices[3 * size_t(builder.order[i])];
        triangles_[i] = {positions[tri[0]], positions[tri[1]], positions[tri[2]]};
    }
    collapse();
}

Vec3f Bvh::bounds_min() const {
    return nodes_.empty() ? Vec3f(kInf)
                          : Vec3f(nodes_[0].bounds[0], nodes_[0].bounds[1], nodes_[0].bounds[2]);
}

Vec3f Bvh::bounds_max() const {
    return nodes_.empty() ? Vec3f(-kInf)
                          : Vec3f(nodes_[0].bounds[3], nodes_[0].bounds[4], nodes_[0].bounds[5]);
}

// ---- Traversal -----------------------------------------------------------------------------
template <bool kAnyHit>
bool Bvh::traverse(const Ray<float>& ray, float tmax, TriangleHit& hit) const {
    if (nodes_.empty() || !(tmax > 0.0f)) {
        return false;
    }
    // Per-ray constants: the triangle shear, reciprocal direction (zero components give
    // +-inf), and for each axis the bounds slot of the near and far plane
    const RayShear<float> shear = make_ray_shear(ray.d);
    const float org[3] = {ray.o.x, ray.o.y, ray.o.z};
    const float inv[3] = {1.0f / ray.d.x, 1.0f / ray.d.y, 1.0f / ray.d.z};
    int near_slot[3], far_slot[3];
    for (int k = 0; k < 3; ++k) {
        near_slot[k] = std::signbit(inv[k]) ? k + 3 : k;
        far_slot[k] = std::signbit(inv[k]) ? k : k + 3;
    }
    uint32_t stack[kMaxDepth];
    int stack_size = 0;
    uint32_t index = 0;
    float closest = tmax;
    bool found = false;
    for (;;) {
        // Slab test against [0, closest]; a NaN distance (origin on a plane the ray is
        // parallel to) leaves the interval unchanged, and the far distances are scaled by
        // 1 + 2 gamma(3) so rounding never culls a box the ray touches
        const Node& node = nodes_[index];
        float t0 = 0.0f, t1 = closest;
        for (int k = 0; k < 3; ++k) {
            const float t_near = (node.bounds[near_slot[k]] - org[k]) * inv[k];
            const float t_far = (node.bounds[far_slot[k]] - org[k]) * inv[k] * kFarScale;
            t0 = t_near > t0 ? t_near : t0;
            t1 = t_far < t1 ? t_far : t1;
        }
        if (t0 <= t1) {
            if (node.count == 0) {
                // Inner node: the child on the near side of the split first
                const bool second_first = std::signbit(inv[node.axis]);
                stack[stack_size++] = second_first ? index + 1 : node.offset;
                index = second_first ? node.offset : index + 1;
                continue;
            }
            // Leaf: test its triangles
            const uint32_t end = node.offset + node.count;
            for (uint32_t i = node.offset; i < end; ++i) {
                const Triangle& tri = triangles_[i];
                float t, b1, b2;
                if (intersect_triangle(ray, shear, tri.v0, tri.v1, tri.v2, closest, t, b1, b2)) {
                    if constexpr (kAnyHit) {
                        return true;
                    }
                    closest = t;
                    hit = {t, b1, b2, triangle_ids_[i]};
                    found = true;
                }
            }
        }
        if (stack_size == 0) {
            return found;
        }
        index = stack[--stack_size];
    }
}

bool Bvh::intersect(const Ray<float>& ray, float tmax, TriangleHit& hit) const {
    return traverse<false>(ray, tmax, hit);
}

bool Bvh::occluded(const Ray<float>& ray, float tmax) const {
    TriangleHit unused;
    return traverse<true>(ray, tmax, unused);
}

}  // namespace cierzo
