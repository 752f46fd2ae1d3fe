// The binary build of the scene BVH (the first step of bvh_build.cpp): the build's constants,
// boxes, refs and nodes, and Bvh::Builder, binned SAH with spatial splits (whose clipping
// and binning are in bvh_spatial_splits.cpp). For those two files only.
#pragma once

#include <algorithm>
#include <array>
#include <cstdlib>
#include <new>
#include <atomic>
#include <bit>
#include <cmath>
#include <limits>
#include <string>
#include <type_traits>
#include <utility>

#include <oneapi/tbb/blocked_range.h>
#include <oneapi/tbb/parallel_for.h>
#include <oneapi/tbb/parallel_invoke.h>

#include "accel/bvh.h"
#include "core/error.h"
#include "core/huge_pages.h"

namespace cierzo {

// (names of the build alone, seen unqualified by its two files)
namespace bvh_build {

constexpr int kBins = 16;
constexpr uint32_t kLeafSize = 8;       // always a leaf at or below this many (of one kind)
constexpr int kMaxSahDepth = 64;        // below this, object-median splits bound the depth
constexpr float kTraversalCost = 1.0f;  // relative to one triangle test
constexpr uint32_t kParallelBelow = 4096;
constexpr int kSpatialBins = 16;
// A spatial split is sought where the object split's children overlap by more than this
// fraction of the root's half area (Stich et al.'s alpha)
constexpr float kSplitOverlap = 1e-5f;

// Test cost of one primitive of each kind, in triangle tests (the SAH weights and the
// collapse's leaf costs): a sphere is about a triangle, a quadric a few, an instance a
// transform and a traversal of its own.
constexpr float kKindCost[4] = {1.0f, 1.0f, 3.0f, 8.0f};

// Collapse costs relative to one wide-node visit (the slab test of 8 children and the stack
// work); one block of 8 triangles costs about 1.4 of them (instructions per visit,
// measured; the tree and its speed hardly change for any value from 1 to 3).
constexpr float kNodeCost = 1.0f;
constexpr float kBlockCost = 1.4f;
constexpr float kLargestArea = 1e30f;

constexpr float kInf = std::numeric_limits<float>::infinity();

struct Box {
    Vec3f lo{kInf}, hi{-kInf};
    void grow(const Vec3f& p) {
        lo = vmin(lo, p);
        hi = vmax(hi, p);
    }
    void grow(const Box& b) {
        lo = vmin(lo, b.lo);
        hi = vmax(hi, b.hi);
    }
    // Half the surface area; zero for an empty box, finite for huge ones
    float half_area() const {
        if (!(lo.x <= hi.x)) return 0.0f;
        const Vec3f e = hi - lo;
        const float a = e.x * e.y + e.y * e.z + e.z * e.x;
        return a <= kLargestArea ? a : kLargestArea;
    }
    bool finite() const {
        return std::isfinite(lo.x) && std::isfinite(lo.y) && std::isfinite(lo.z) &&
               std::isfinite(hi.x) && std::isfinite(hi.y) && std::isfinite(hi.z);
    }
};

inline float largest_abs(const Vec3f& v) {
    return std::max(std::fabs(v.x), std::max(std::fabs(v.y), std::fabs(v.z)));
}

inline float component(const Vec3f& v, int axis) {
    return axis == 0 ? v.x : (axis == 1 ? v.y : v.z);
}

// Zero area (collinear or coincident vertices, evaluated in double) or a non-finite vertex.
inline bool is_degenerate(const Vec3f& a, const Vec3f& b, const Vec3f& c) {
    for (const Vec3f& p : {a, b, c})
        if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) return true;
    const double e1[3] = {double(b.x) - a.x, double(b.y) - a.y, double(b.z) - a.z};
    const double e2[3] = {double(c.x) - a.x, double(c.y) - a.y, double(c.z) - a.z};
    const double n[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2],
                         e1[0] * e2[1] - e1[1] * e2[0]};
    return n[0] == 0.0 && n[1] == 0.0 && n[2] == 0.0;
}

inline Vec3f affine(const float m[12], const Vec3f& p) {
    return {m[0] * p.x + m[1] * p.y + m[2] * p.z + m[3],
            m[4] * p.x + m[5] * p.y + m[6] * p.z + m[7],
            m[8] * p.x + m[9] * p.y + m[10] * p.z + m[11]};
}

// The build's large arrays of plain structs (Uninitialised, core/huge_pages.h): every
// element is written before it is read (by parallel loops). Value-initialising them first
// was a serial pass over 100+ MB that faulted in every page (a fifth of a 1M-triangle
// build), and small pages faulted 69,000 times.

// A primitive as the build sees it.
struct Ref {
    Box box;
    Vec3f centroid;
    uint8_t kind;
    uint32_t a, b;  // triangle: set, index; sphere: index; quadric, instance: input index
};

// A binary build node over refs order[first, first + count): a leaf, or an inner node with
// two children. kind: the kind of all its refs, or kMixed.
constexpr uint8_t kMixed = 255;
struct Node {
    Box box;
    uint32_t left = 0, right = 0;
    uint32_t first = 0, count = 0;
    uint8_t kind = 0;
    bool inner = false;
};
using NodeArray = std::vector<Node, Uninitialised<Node>>;

}  // namespace bvh_build
using namespace bvh_build;

struct Bvh::Builder {
    const BvhInput& in;
    std::vector<Ref, Uninitialised<Ref>> refs;
    std::vector<uint32_t, Uninitialised<uint32_t>> order;  // the refs being partitioned
    NodeArray nodes;  // allocated by `next`, each written whole
    std::atomic<uint32_t> next{0};
    std::atomic<int> depth{0};
    std::atomic<uint32_t> ref_count{0};  // refs in use (the spatial splits add some)
    float root_area = 0.0f;
    bool spatial = false;  // spatial splits allowed (a budget and triangles to cut)

    explicit Builder(const BvhInput& input) : in(input) {}

    // The bin of a centroid along an axis; the same formula for binning and partitioning.
    // Clamped in float first: near ±3e38 the scale can be 0 and the position NaN or out of
    // int range, and converting such a float to int is undefined (NaN goes to bin 0).
    static int bin_of(float c, float lo, float scale, int bins) {
        const float x = (c - lo) * scale;
        return x > 0.0f ? int(std::min(x, float(bins - 1))) : 0;
    }

    float cost(uint32_t begin, uint32_t end) const {
        float c = 0.0f;
        for (uint32_t i = begin; i < end; ++i) c += kKindCost[refs[order[i]].kind];
        return c;
    }

    uint32_t add_leaf(Bvh& bvh, const BvhInput& in, uint32_t binary, uint32_t& count) const;

    // The refs of binary subtree `node`'s leaves, left to right, each primitive once (a
    // triangle a spatial split cut is in more than one leaf). A subtree's refs are not
    // contiguous in `order` where its nodes had free slots.
    void gather(uint32_t node, std::vector<uint32_t>& ids) const {
        const Node& n = nodes[node];
        if (n.inner) {
            gather(n.left, ids);
            gather(n.right, ids);
            return;
        }
        for (uint32_t i = n.first; i < n.first + n.count; ++i) {
            const Ref& r = refs[order[i]];
            const bool seen = std::any_of(ids.begin(), ids.end(), [&](uint32_t id) {
                return refs[id].kind == r.kind && refs[id].a == r.a && refs[id].b == r.b;
            });
            if (!seen) ids.push_back(order[i]);
        }
    }

    // What a node's refs span: their boxes, their centroids, and the kinds among them (a bit
    // per kind). The partition that makes a node measures its children's, so each ref is read
    // once per level, by the binning pass.
    struct Extent {
        Box bounds, centroids;
        uint32_t kinds = 0;
        void add(const Ref& r) {
            bounds.grow(r.box);
            centroids.grow(r.centroid);
            kinds |= 1u << r.kind;
        }
    };

    Extent extent_of(uint32_t begin, uint32_t end) const {
        Extent e;
        for (uint32_t i = begin; i < end; ++i) e.add(refs[order[i]]);
        return e;
    }

    // order[begin, end) split in place so that the refs `left` says yes to come first (the
    // order std::partition leaves them in: swaps from both ends), with each side's extent;
    // returns where the second side starts.
    template <class Left>
    uint32_t partition(uint32_t begin, uint32_t end, const Left& left, Extent& a, Extent& b) {
        uint32_t* first = order.data() + begin;
        uint32_t* last = order.data() + end;
        while (true) {
            while (true) {
                if (first == last) return uint32_t(first - order.data());
                const Ref& r = refs[*first];
                if (!left(r)) break;
                a.add(r);
                ++first;
            }
            b.add(refs[*first]);
            --last;
            while (true) {
                if (first == last) return uint32_t(first - order.data());
                const Ref& r = refs[*last];
                if (left(r)) break;
                b.add(r);
                --last;
            }
            a.add(refs[*last]);
            std::iter_swap(first, last);
            ++first;
        }
    }

    // The box of the part of triangle ref `r` whose coordinate along `axis` lies in [a, b],
    // within the ref's box (empty when there is none): the triangle's vertices in the slab
    // and its edges' crossings of the slab's planes. The crossings are rounded, so the box is
    // padded by a relative 2^-21 across the axis; along it the planes are exact.
    Box clipped(const Ref& r, int axis, float a, float b) const;

    void vertices(const Ref& r, Vec3f v[3]) const;

    // Where edge i of triangle v (from vertex i to the next) crosses the plane at `plane`
    // along `axis`, if its ends are strictly on either side (the point's axis coordinate
    // set to the plane exactly).
    static bool edge_crossing(const Vec3f v[3], int i, int axis, float plane, Vec3f& x);

    // The box of triangle v's part in the slab [a, b] along `axis` (unpadded).
    static Box slab_box(const Vec3f v[3], int axis, float a, float b);

    // The cheapest spatial split of a node of triangles: kSpatialBins slabs over its bounds
    // along each axis, each ref's part in each slab it spans binned by its clipped box, a ref
    // counted on the left of every plane right of its first slab and on the right of every
    // plane left of its last (Stich et al. 2009, section 4.1).
    struct SpatialSplit {
        float cost = kInf;
        int axis = 0, plane = 0;  // the plane between slabs plane - 1 and plane
        float lo = 0.0f, scale = 0.0f, width = 0.0f;
        uint32_t left = 0, right = 0;  // refs on each side, the cut ones on both
        float position() const { return lo + float(plane) * width; }
        int slab(float x) const { return bin_of(x, lo, scale, kSpatialBins); }
    };

    SpatialSplit find_spatial_split(uint32_t begin, uint32_t end, const Box& bounds) const;

    // The cheapest spatial split along one axis (cost infinite when there is none).
    SpatialSplit find_spatial_split(uint32_t begin, uint32_t end, const Box& bounds,
                                    int axis) const;

    // order[begin, end) split by `sp` into order[begin, begin + nl) and
    // order[second, second + nr), each side's extent measured; a ref the plane cuts
    // becomes two (the new one at the end of refs). Returns where the second side starts:
    // after the first side and its share of the free slots up to ext_end.
    uint32_t spatial_partition(uint32_t begin, uint32_t end, uint32_t ext_end,
                               const SpatialSplit& sp, Extent& a, Extent& b, uint32_t& nl,
                               uint32_t& nr);

    // Builds the subtree over order[begin, end), whose extent is `e`, into node `node`;
    // order[end, ext_end) is free for the spatial splits' new refs.
    void build(uint32_t node, uint32_t begin, uint32_t end, uint32_t ext_end, int level,
               const Extent& e) {
        int d = depth.load(std::memory_order_relaxed);
        while (level > d && !depth.compare_exchange_weak(d, level)) {
        }
        const Box& bounds = e.bounds;
        const Box& centroid_bounds = e.centroids;
        Node& out = nodes[node];
        out.box = bounds;
        const uint32_t n = end - begin;
        const bool homogeneous = std::has_single_bit(e.kinds);
        out.first = begin, out.count = n,
        out.kind = homogeneous ? uint8_t(std::countr_zero(e.kinds)) : kMixed;
        out.left = out.right = 0;
        auto leaf = [&] { out.inner = false; };
        if (n <= kLeafSize && homogeneous) return leaf();
        // Split: binned SAH (over the centroids, or spatial), or by kind where a small mixed
        // node would otherwise be a leaf, or an object median when the SAH is not usable
        uint32_t mid = begin;
        Extent left_extent, right_extent;
        bool measured = false;  // (the children's extents, from the partition)
        const Vec3f extent = centroid_bounds.hi - centroid_bounds.lo;
        int axis = 0, bin = -1;
        float best = kInf;
        Box object_left, object_right;
        bool evaluated = false;
        if (level < kMaxSahDepth && max_component(extent) > 0.0f) {
            best =
                find_sah_split(begin, end, centroid_bounds, axis, bin, object_left, object_right);
            evaluated = true;
        }
        SpatialSplit sp;
        if (spatial && level < kMaxSahDepth && e.kinds == 1u << kLeafTriangles && ext_end > end) {
            Box overlap;
            overlap.lo = vmax(object_left.lo, object_right.lo);
            overlap.hi = vmin(object_left.hi, object_right.hi);
            const bool apart = overlap.lo.y > overlap.hi.y || overlap.lo.z > overlap.hi.z;
            if (bin < 0 || (!apart && overlap.half_area() > kSplitOverlap * root_area)) {
                sp = find_spatial_split(begin, end, bounds);
                if (!(sp.cost < best) || sp.left + sp.right - n > ext_end - end)
                    sp.cost = kInf;
                else
                    best = sp.cost, evaluated = true;
            }
        }
        if (evaluated) {
            const float split_cost = kTraversalCost + best / std::max(bounds.half_area(), 1e-30f);
            if (homogeneous && n <= kBvhMaxLeafSize && split_cost >= cost(begin, end))
                return leaf();
            if (sp.cost < kInf) {
                uint32_t left_count = 0, right_count = 0;
                const uint32_t second = spatial_partition(begin, end, ext_end, sp, left_extent,
                                                          right_extent, left_count, right_count);
                if (left_count > 0 && right_count > 0)
                    return split(out, level, {begin, begin + left_count, second},
                                 {second, second + right_count, ext_end}, left_extent,
                                 right_extent);
                // (every part on one side, by rounding: nothing was cut, the refs are in
                // order[begin, end) again, and the splits below take them)
                left_extent = right_extent = Extent{};
            } else if (bin >= 0) {
                const float lo = component(centroid_bounds.lo, axis);
                const float scale = kBins / component(extent, axis);
                mid = partition(
                    begin, end,
                    [&](const Ref& r) {
                        return bin_of(component(r.centroid, axis), lo, scale, kBins) < bin;
                    },
                    left_extent, right_extent);
                measured = true;
            }
        }
        if ((mid == begin || mid == end) && !homogeneous && n <= 4 * kBvhMaxLeafSize) {
            const uint8_t k = refs[order[begin]].kind;
            auto* other = std::stable_partition(order.data() + begin, order.data() + end,
                                                [&](uint32_t r) { return refs[r].kind == k; });
            mid = uint32_t(other - order.data());
            measured = false;
        }
        if (mid == begin || mid == end) {
            const int axis =
                extent.x >= extent.y && extent.x >= extent.z ? 0 : (extent.y >= extent.z ? 1 : 2);
            mid = begin + n / 2;
            std::nth_element(order.data() + begin, order.data() + mid, order.data() + end,
                             [&](uint32_t a, uint32_t b) {
                                 return component(refs[a].centroid, axis) <
                                        component(refs[b].centroid, axis);
                             });
            measured = false;
        }
        if (!measured) left_extent = extent_of(begin, mid), right_extent = extent_of(mid, end);
        // The free slots shared in proportion: the second child's refs move up by the first's
        // share
        uint32_t shift = 0;
        if (ext_end > end) {
            shift = uint32_t(uint64_t(ext_end - end) * (mid - begin) / n);
            if (shift > 0)
                std::memmove(order.data() + mid + shift, order.data() + mid,
                             (end - mid) * sizeof(uint32_t));
        }
        split(out, level, {begin, mid, mid + shift}, {mid + shift, end + shift, ext_end},
              left_extent, right_extent);
    }

    // A child's range of `order`: its refs [begin, end), free slots up to ext_end.
    struct Range {
        uint32_t begin, end, ext_end;
    };

    // Makes `out` an inner node over two new children, built in parallel when large.
    void split(Node& out, int level, const Range& a, const Range& b, const Extent& ea,
               const Extent& eb) {
        const uint32_t left = next.fetch_add(2, std::memory_order_relaxed);
        out.left = left, out.right = left + 1, out.inner = true;
        if ((a.end - a.begin) + (b.end - b.begin) > kParallelBelow) {
            oneapi::tbb::parallel_invoke(
                [&] { build(left, a.begin, a.end, a.ext_end, level + 1, ea); },
                [&] { build(left + 1, b.begin, b.end, b.ext_end, level + 1, eb); });
        } else {
            build(left, a.begin, a.end, a.ext_end, level + 1, ea);
            build(left + 1, b.begin, b.end, b.ext_end, level + 1, eb);
        }
    }

    // The cheapest binned split plane over the three axes, binned in one pass: returns its
    // SAH cost (the sum of child half-areas times test costs) and sets the axis and the first
    // bin of the second child (bin stays -1 when no plane separates anything), and the two
    // children's boxes.
    float find_sah_split(uint32_t begin, uint32_t end, const Box& centroid_bounds, int& best_axis,
                         int& best_bin, Box& best_left, Box& best_right) const {
        float lo[3], scale[3];
        bool usable[3];
        for (int axis = 0; axis < 3; ++axis) {
            lo[axis] = component(centroid_bounds.lo, axis);
            const float extent = component(centroid_bounds.hi, axis) - lo[axis];
            usable[axis] = extent > 0.0f;
            scale[axis] = usable[axis] ? kBins / extent : 0.0f;
        }
        Box bin_boxes[3][kBins];
        float bin_cost[3][kBins] = {};
        uint32_t bin_count[3][kBins] = {};
        for (uint32_t i = begin; i < end; ++i) {
            const Ref& r = refs[order[i]];
            const float c = kKindCost[r.kind];
            for (int axis = 0; axis < 3; ++axis) {
                const int b = bin_of(component(r.centroid, axis), lo[axis], scale[axis], kBins);
                bin_boxes[axis][b].grow(r.box);
                bin_cost[axis][b] += c;
                ++bin_count[axis][b];
            }
        }
        float best = kInf;
        for (int axis = 0; axis < 3; ++axis) {
            if (!usable[axis]) continue;
            float right_cost[kBins];
            Box right[kBins];
            float right_sum = 0.0f;
            for (int b = kBins - 1; b > 0; --b) {
                right[b] = right[b < kBins - 1 ? b + 1 : b];
                right[b].grow(bin_boxes[axis][b]);
                right_sum += bin_cost[axis][b];
                right_cost[b] = right_sum * right[b].half_area();
            }
            Box left;
            float left_sum = 0.0f;
            uint32_t left_count = 0;
            for (int b = 1; b < kBins; ++b) {
                left.grow(bin_boxes[axis][b - 1]);
                left_sum += bin_cost[axis][b - 1];
                left_count += bin_count[axis][b - 1];
                if (left_count == 0 || left_count == end - begin) continue;
                const float c = left_sum * left.half_area() + right_cost[b];
                if (c < best) {
                    best = c, best_axis = axis, best_bin = b;
                    best_left = left, best_right = right[b];
                }
            }
        }
        return best;
    }
};

}  // namespace cierzo
