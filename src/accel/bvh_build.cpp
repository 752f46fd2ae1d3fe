// Building the scene BVH (layout in accel/bvh.h):
//  1. a binary tree by binned SAH (16 bins on the centroid bounds, best of the three axes,
//     primitives weighted by their test cost), leaves of one primitive kind; subtrees of
//     more than kParallelBelow primitives are built as parallel TBB tasks;
//  2. collapsed to 8 children per node with the surface-area cost minimised by dynamic
//     programming (Ylitie, Karras, Laine, "Efficient Incoherent Ray Traversal on GPUs
//     Through Compressed Wide BVHs", HPG 2017, section 3.1): each binary subtree becomes a
//     leaf, a wide node, or is spread over several slots of its parent, whichever costs least;
//  3. leaves written as SoA blocks of 8 (triangles, spheres) or index lists (quadrics,
//     instances).
// Spatial splits (SBVH, Stich et al. 2009): where the best object split's children overlap
// (by more than kSplitOverlap of the root's area), triangles' references may instead be cut
// at a plane, each side keeping the box of its part of the triangle; a node's refs then take
// more room than it had, so every node owns an extended range of `order` (its refs, then
// free slots) whose free slots its children share in proportion to their refs.
#include "accel/bvh.h"

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

#include "core/error.h"
#include "core/huge_pages.h"

namespace cierzo {

namespace {

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
    void grow(const Vec3f& p) { lo = vmin(lo, p); hi = vmax(hi, p); }
    void grow(const Box& b) { lo = vmin(lo, b.lo); hi = vmax(hi, b.hi); }
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

float largest_abs(const Vec3f& v) {
    return std::max(std::fabs(v.x), std::max(std::fabs(v.y), std::fabs(v.z)));
}

float component(const Vec3f& v, int axis) { return axis == 0 ? v.x : (axis == 1 ? v.y : v.z); }

// Zero area (collinear or coincident vertices, evaluated in double) or a non-finite vertex.
bool is_degenerate(const Vec3f& a, const Vec3f& b, const Vec3f& c) {
    for (const Vec3f& p : {a, b, c})
        if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) return true;
    const double e1[3] = {double(b.x) - a.x, double(b.y) - a.y, double(b.z) - a.z};
    const double e2[3] = {double(c.x) - a.x, double(c.y) - a.y, double(c.z) - a.z};
    const double n[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2],
                         e1[0] * e2[1] - e1[1] * e2[0]};
    return n[0] == 0.0 && n[1] == 0.0 && n[2] == 0.0;
}

Vec3f affine(const float m[12], const Vec3f& p) {
    return {m[0] * p.x + m[1] * p.y + m[2] * p.z + m[3], m[4] * p.x + m[5] * p.y + m[6] * p.z + m[7],
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

}  // namespace

Bvh& Bvh::operator=(const Bvh& o) {
    if (this == &o) return *this;
    nodes_ = o.nodes_;
    triangles_ = o.triangles_;
    triangle_mesh_ = o.triangle_mesh_;
    triangle_index_ = o.triangle_index_;
    spheres_ = o.spheres_;
    sphere_index_ = o.sphere_index_;
    items_ = o.items_;
    quadrics_ = o.quadrics_;
    instances_ = o.instances_;
    geometries_ = o.geometries_;
    stats_ = o.stats_;
    std::copy(o.view_.bounds, o.view_.bounds + 6, view_.bounds);
    update_view();
    return *this;
}

Bvh& Bvh::operator=(Bvh&& o) noexcept {
    nodes_ = std::move(o.nodes_);
    triangles_ = std::move(o.triangles_);
    triangle_mesh_ = std::move(o.triangle_mesh_);
    triangle_index_ = std::move(o.triangle_index_);
    spheres_ = std::move(o.spheres_);
    sphere_index_ = std::move(o.sphere_index_);
    items_ = std::move(o.items_);
    quadrics_ = std::move(o.quadrics_);
    instances_ = std::move(o.instances_);
    geometries_ = std::move(o.geometries_);
    stats_ = o.stats_;
    std::copy(o.view_.bounds, o.view_.bounds + 6, view_.bounds);
    update_view();
    o.update_view();
    return *this;
}

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
    Box clipped(const Ref& r, int axis, float a, float b) const {
        Vec3f v[3];
        vertices(r, v);
        Box out = slab_box(v, axis, a, b);
        if (!(out.lo.x <= out.hi.x)) return Box{};
        const Vec3f pad(std::max(largest_abs(out.lo), largest_abs(out.hi)) * 0x1p-21f);
        out.lo = vmax(out.lo - pad, r.box.lo), out.hi = vmin(out.hi + pad, r.box.hi);
        float& lo = axis == 0 ? out.lo.x : (axis == 1 ? out.lo.y : out.lo.z);
        float& hi = axis == 0 ? out.hi.x : (axis == 1 ? out.hi.y : out.hi.z);
        lo = std::max(lo, a), hi = std::min(hi, b);
        if (!(out.lo.x <= out.hi.x && out.lo.y <= out.hi.y && out.lo.z <= out.hi.z)) return Box{};
        return out;
    }

    void vertices(const Ref& r, Vec3f v[3]) const {
        const BvhTriangles& set = in.triangles[r.a];
        const uint32_t* tri = &set.indices[3 * size_t(r.b)];
        v[0] = set.positions[tri[0]], v[1] = set.positions[tri[1]], v[2] = set.positions[tri[2]];
    }

    // Where edge i of triangle v (from vertex i to the next) crosses the plane at `plane`
    // along `axis`, if its ends are strictly on either side (the point's axis coordinate
    // set to the plane exactly).
    static bool edge_crossing(const Vec3f v[3], int i, int axis, float plane, Vec3f& x) {
        const Vec3f& p = v[i];
        const Vec3f& q = v[i == 2 ? 0 : i + 1];
        const float pa = component(p, axis), qa = component(q, axis);
        if (!((pa < plane && qa > plane) || (pa > plane && qa < plane))) return false;
        x = p + (q - p) * ((plane - pa) / (qa - pa));
        (axis == 0 ? x.x : (axis == 1 ? x.y : x.z)) = plane;
        return true;
    }

    // The box of triangle v's part in the slab [a, b] along `axis` (unpadded).
    static Box slab_box(const Vec3f v[3], int axis, float a, float b) {
        Box out;
        for (int i = 0; i < 3; ++i) {
            const float pa = component(v[i], axis);
            if (pa >= a && pa <= b) out.grow(v[i]);
            Vec3f x;
            for (const float plane : {a, b})
                if (edge_crossing(v, i, axis, plane, x)) out.grow(x);
        }
        return out;
    }

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

    SpatialSplit find_spatial_split(uint32_t begin, uint32_t end, const Box& bounds) const {
        SpatialSplit best[3];
        auto axis_split = [&](int axis) {
            best[axis] = find_spatial_split(begin, end, bounds, axis);
        };
        if (end - begin > kParallelBelow)  // (the axes in parallel where the tree is not yet)
            oneapi::tbb::parallel_invoke([&] { axis_split(0); }, [&] { axis_split(1); },
                                         [&] { axis_split(2); });
        else
            for (int axis = 0; axis < 3; ++axis) axis_split(axis);
        const int first = best[1].cost < best[0].cost ? 1 : 0;
        return best[2].cost < best[first].cost ? best[2] : best[first];
    }

    // The cheapest spatial split along one axis (cost infinite when there is none).
    SpatialSplit find_spatial_split(uint32_t begin, uint32_t end, const Box& bounds,
                                    int axis) const {
        SpatialSplit best, s;
        s.axis = axis, s.lo = component(bounds.lo, axis);
        const float extent = component(bounds.hi, axis) - s.lo;
        if (!(extent > 0.0f) || !std::isfinite(extent)) return best;
        s.scale = kSpatialBins / extent, s.width = extent / kSpatialBins;
        Box slabs[kSpatialBins];
        uint32_t enter[kSpatialBins] = {}, leave[kSpatialBins] = {};
        for (uint32_t i = begin; i < end; ++i) {
            const Ref& r = refs[order[i]];
            const int b0 = s.slab(component(r.box.lo, axis));
            const int b1 = s.slab(component(r.box.hi, axis));
            ++enter[b0], ++leave[b1];
            if (b0 == b1) {
                slabs[b0].grow(r.box);
                continue;
            }
            // (the SAH's estimate, each part's box unpadded, within the ref's: a slab's part
            // is its vertices and the crossings of its two planes, each plane's crossings
            // found once for the slabs on both sides)
            Vec3f v[3];
            vertices(r, v);
            Box parts[kSpatialBins];
            for (const Vec3f& p : v) parts[std::clamp(s.slab(component(p, axis)), b0, b1)].grow(p);
            for (int k = b0 + 1; k <= b1; ++k) {
                const float plane = s.lo + float(k) * s.width;
                Vec3f x;
                for (int i = 0; i < 3; ++i)
                    if (edge_crossing(v, i, axis, plane, x)) parts[k - 1].grow(x), parts[k].grow(x);
            }
            for (int b = b0; b <= b1; ++b) {
                Box& part = parts[b];
                part.lo = vmax(part.lo, r.box.lo), part.hi = vmin(part.hi, r.box.hi);
                if (part.lo.x <= part.hi.x && part.lo.y <= part.hi.y && part.lo.z <= part.hi.z)
                    slabs[b].grow(part);
            }
        }
        float right_area[kSpatialBins];
        uint32_t right_count[kSpatialBins];
        Box right;
        uint32_t count = 0;
        for (int b = kSpatialBins - 1; b > 0; --b) {
            right.grow(slabs[b]);
            count += leave[b];
            right_area[b] = right.half_area(), right_count[b] = count;
        }
        Box left;
        count = 0;
        for (int b = 1; b < kSpatialBins; ++b) {
            left.grow(slabs[b - 1]);
            count += enter[b - 1];
            if (count == 0 || right_count[b] == 0) continue;
            const float c = float(count) * left.half_area() + float(right_count[b]) * right_area[b];
            if (c < best.cost) {
                best = s;
                best.cost = c, best.plane = b, best.left = count, best.right = right_count[b];
            }
        }
        return best;
    }

    // order[begin, end) split by `sp` into order[begin, begin + nl) and
    // order[second, second + nr), each side's extent measured; a ref the plane cuts
    // becomes two (the new one at the end of refs). Returns where the second side starts:
    // after the first side and its share of the free slots up to ext_end.
    uint32_t spatial_partition(uint32_t begin, uint32_t end, uint32_t ext_end,
                               const SpatialSplit& sp, Extent& a, Extent& b, uint32_t& nl,
                               uint32_t& nr) {
        std::vector<uint32_t> left, right;
        left.reserve(sp.left), right.reserve(sp.right);
        const float plane = sp.position();
        auto set_box = [](Ref& r, const Box& box) {
            r.box = box;
            r.centroid = (box.lo + box.hi) * 0.5f;
        };
        for (uint32_t i = begin; i < end; ++i) {
            const uint32_t id = order[i];
            Ref& r = refs[id];
            const int b0 = sp.slab(component(r.box.lo, sp.axis));
            const int b1 = sp.slab(component(r.box.hi, sp.axis));
            if (b1 < sp.plane || b0 >= sp.plane) {
                (b1 < sp.plane ? left : right).push_back(id);
                (b1 < sp.plane ? a : b).add(r);
                continue;
            }
            const Box l = clipped(r, sp.axis, -kInf, plane), h = clipped(r, sp.axis, plane, kInf);
            const bool has_l = l.lo.x <= l.hi.x, has_h = h.lo.x <= h.hi.x;
            if (has_l && has_h) {
                const uint32_t copy = ref_count.fetch_add(1, std::memory_order_relaxed);
                refs[copy] = r;
                set_box(r, l), set_box(refs[copy], h);
                left.push_back(id), right.push_back(copy);
                a.add(r), b.add(refs[copy]);
            } else if (has_h) {
                set_box(r, h);
                right.push_back(id), b.add(r);
            } else {
                if (has_l) set_box(r, l);
                left.push_back(id), a.add(r);
            }
        }
        nl = uint32_t(left.size()), nr = uint32_t(right.size());
        const uint32_t free = ext_end - begin - nl - nr;
        const uint32_t second = begin + nl + uint32_t(uint64_t(free) * nl / (nl + nr));
        std::copy(left.begin(), left.end(), order.data() + begin);
        std::copy(right.begin(), right.end(), order.data() + second);
        return second;
    }

    // Builds the subtree over order[begin, end), whose extent is `e`, into node `node`;
    // order[end, ext_end) is free for the spatial splits' new refs.
    void build(uint32_t node, uint32_t begin, uint32_t end, uint32_t ext_end, int level,
               const Extent& e) {
        int d = depth.load(std::memory_order_relaxed);
        while (level > d && !depth.compare_exchange_weak(d, level)) {}
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
            best = find_sah_split(begin, end, centroid_bounds, axis, bin, object_left,
                                  object_right);
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
                if (!(sp.cost < best) || sp.left + sp.right - n > ext_end - end) sp.cost = kInf;
                else best = sp.cost, evaluated = true;
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
                mid = partition(begin, end, [&](const Ref& r) {
                    return bin_of(component(r.centroid, axis), lo, scale, kBins) < bin;
                }, left_extent, right_extent);
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
            const int axis = extent.x >= extent.y && extent.x >= extent.z ? 0
                                                                           : (extent.y >= extent.z ? 1 : 2);
            mid = begin + n / 2;
            std::nth_element(order.data() + begin, order.data() + mid, order.data() + end,
                             [&](uint32_t a, uint32_t b) {
                return component(refs[a].centroid, axis) < component(refs[b].centroid, axis);
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

namespace {

// The collapse of the binary tree into wide nodes and leaf blocks.
struct Collapser {
    const NodeArray& nodes;
    // Per binary node: the cost of its subtree as at most i roots (cost[i], i = 1..8; as one
    // root it is a leaf or a wide node, whichever is cheaper: leaf); for i >= 2, whether
    // spreading over i slots beats one root (spread[i]) and how many go to the first child
    struct Plan {
        bool leaf = false;
        std::array<float, kWideBvhWidth + 1> cost{};
        std::array<bool, kWideBvhWidth + 1> spread{};
        std::array<int8_t, kWideBvhWidth + 1> split{};
    };
    std::vector<Plan> plan;

    static uint32_t blocks(uint32_t n) { return (n + kWideBvhWidth - 1) / kWideBvhWidth; }

    static float leaf_cost(const Node& node) {
        const float area = node.box.half_area();
        if (node.kind == kLeafTriangles || node.kind == kLeafSpheres)
            return area * kBlockCost * float(blocks(node.count));
        return area * kBlockCost * kKindCost[node.kind] * float(node.count);
    }

    Collapser(const NodeArray& n, uint32_t used) : nodes(n), plan(used) {
        if (used > 0) plan_subtree(0);
    }

    void plan_subtree(uint32_t n) {
        const Node& node = nodes[n];
        Plan& p = plan[n];
        if (!node.inner) {
            p.leaf = true;
            p.cost.fill(leaf_cost(node));
            return;
        }
        plan_subtree(node.left);
        plan_subtree(node.right);
        const Plan &a = plan[node.left], &b = plan[node.right];
        std::array<float, kWideBvhWidth + 1> spread_cost{};
        for (int j = 2; j <= kWideBvhWidth; ++j) {
            spread_cost[j] = a.cost[1] + b.cost[j - 1];
            p.split[j] = 1;
            for (int k = 2; k < j; ++k) {
                const float c = a.cost[k] + b.cost[j - k];
                if (c < spread_cost[j]) spread_cost[j] = c, p.split[j] = int8_t(k);
            }
        }
        // One root: a leaf (if small enough and of one kind) or a wide node over 8 slots
        const float wide = node.box.half_area() * kNodeCost + spread_cost[kWideBvhWidth];
        p.leaf = node.kind != kMixed && node.count <= kBvhMaxLeafSize && leaf_cost(node) <= wide;
        p.cost[1] = p.leaf ? leaf_cost(node) : wide;
        for (int i = 2; i <= kWideBvhWidth; ++i) {
            p.spread[i] = spread_cost[i] < p.cost[1];
            p.cost[i] = p.spread[i] ? spread_cost[i] : p.cost[1];
        }
    }

    // The roots of binary node n's subtree as at most i slots, in order.
    void roots(uint32_t n, int i, std::vector<uint32_t>& out) const {
        if (i == 1 || !nodes[n].inner || !plan[n].spread[i]) {
            out.push_back(n);
            return;
        }
        roots(nodes[n].left, plan[n].split[i], out);
        roots(nodes[n].right, i - plan[n].split[i], out);
    }
};

}  // namespace

void Bvh::update_view() {
    BvhView v;
    v.nodes = nodes_.data();
    v.node_count = int32_t(nodes_.size());
    v.triangles = triangles_.data();
    v.triangle_mesh = triangle_mesh_.data();
    v.triangle_index = triangle_index_.data();
    v.spheres = spheres_.data();
    v.sphere_index = sphere_index_.data();
    v.items = items_.data();
    v.quadrics = quadrics_.data();
    v.instances = instances_.data();
    v.instance_count = int32_t(instances_.size());
    std::copy(view_.bounds, view_.bounds + 6, v.bounds);
    view_ = v;
}

void Bvh::build(std::span<const Vec3f> positions, std::span<const uint32_t> indices,
                float split_budget) {
    BvhInput in;
    in.triangles.push_back({positions, indices, 0});
    in.split_budget = split_budget;
    build(in);
}

void Bvh::build(const BvhInput& in) {
    *this = Bvh();
    Builder b(in);
    // References: every primitive with a finite, hittable box
    for (size_t s = 0; s < in.triangles.size(); ++s) {
        const BvhTriangles& set = in.triangles[s];
        if (set.indices.size() % 3 != 0)
            throw InputError("BVH: the triangle index count (" + std::to_string(set.indices.size()) +
                             ") is not a multiple of 3");
        const size_t count = set.indices.size() / 3;
        const size_t first = b.refs.size();
        b.refs.resize(first + count);
        std::vector<uint8_t, Uninitialised<uint8_t>> keep(count);
        // (a triangle with a vertex past the end is reported, the first one if several)
        std::atomic<size_t> bad{count};
        oneapi::tbb::parallel_for(
            oneapi::tbb::blocked_range<size_t>(0, count, 4096),
            [&](const oneapi::tbb::blocked_range<size_t>& range) {
                for (size_t i = range.begin(); i < range.end(); ++i) {
                    const uint32_t* tri = &set.indices[3 * i];
                    Ref& r = b.refs[first + i];
                    if (tri[0] >= set.positions.size() || tri[1] >= set.positions.size() ||
                        tri[2] >= set.positions.size()) {
                        size_t seen = bad.load(std::memory_order_relaxed);
                        while (i < seen && !bad.compare_exchange_weak(seen, i)) {}
                        keep[i] = 0;
                        continue;
                    }
                    const Vec3f &p0 = set.positions[tri[0]], &p1 = set.positions[tri[1]],
                                &p2 = set.positions[tri[2]];
                    keep[i] = !is_degenerate(p0, p1, p2);
                    r.box = Box{};
                    r.box.grow(p0), r.box.grow(p1), r.box.grow(p2);
                    r.centroid = (r.box.lo + r.box.hi) * 0.5f;
                    r.kind = kLeafTriangles, r.a = uint32_t(s), r.b = uint32_t(i);
                }
            });
        if (const size_t i = bad.load(); i < count) {
            const uint32_t* tri = &set.indices[3 * i];
            const uint32_t v = tri[0] >= set.positions.size()   ? tri[0]
                               : tri[1] >= set.positions.size() ? tri[1]
                                                                : tri[2];
            throw InputError("BVH: triangle " + std::to_string(i) + " uses vertex " +
                             std::to_string(v) + " but there are only " +
                             std::to_string(set.positions.size()) + " vertices");
        }
        size_t out = first;
        for (size_t i = 0; i < count; ++i)
            if (keep[i]) b.refs[out++] = b.refs[first + i];
        b.refs.resize(out);
    }
    const size_t sphere_count = in.sphere_r.size();
    for (size_t i = 0; i < sphere_count; ++i) {
        const Vec3f c{in.sphere_x[i], in.sphere_y[i], in.sphere_z[i]};
        const float r = in.sphere_r[i];
        // Padded by a relative 2^-20 of the largest magnitude, so rounding in the sphere
        // test never finds a hit outside the box
        const float pad = r * 0x1p-20f + largest_abs(c) * 0x1p-20f;
        Ref ref;
        ref.box.lo = c - Vec3f(r + pad), ref.box.hi = c + Vec3f(r + pad);
        if (!(r > 0.0f) || !ref.box.finite()) continue;
        ref.centroid = c, ref.kind = kLeafSpheres, ref.a = uint32_t(i), ref.b = 0;
        b.refs.push_back(ref);
    }
    for (size_t i = 0; i < in.quadrics.size(); ++i) {
        Ref ref;
        ref.box.lo = in.quadrics[i].box_min, ref.box.hi = in.quadrics[i].box_max;
        if (!ref.box.finite()) continue;
        ref.centroid = (ref.box.lo + ref.box.hi) * 0.5f;
        ref.kind = kLeafQuadrics, ref.a = uint32_t(i), ref.b = 0;
        b.refs.push_back(ref);
    }
    for (size_t i = 0; i < in.instances.size(); ++i) {
        const BvhObjectInstance& inst = in.instances[i];
        if (inst.geometry->empty()) continue;
        const Vec3f lo = inst.geometry->bounds_min(), hi = inst.geometry->bounds_max();
        Ref ref;
        for (int corner = 0; corner < 8; ++corner)
            ref.box.grow(affine(inst.to_world, {corner & 1 ? hi.x : lo.x, corner & 2 ? hi.y : lo.y,
                                                corner & 4 ? hi.z : lo.z}));
        // (the corners are rounded: pad by a relative 2^-20)
        const float pad = std::max(largest_abs(ref.box.lo), largest_abs(ref.box.hi)) * 0x1p-20f;
        ref.box.lo = ref.box.lo - Vec3f(pad), ref.box.hi = ref.box.hi + Vec3f(pad);
        if (!ref.box.finite()) continue;
        ref.centroid = (ref.box.lo + ref.box.hi) * 0.5f;
        ref.kind = kLeafInstances, ref.a = uint32_t(i), ref.b = 0;
        b.refs.push_back(ref);
    }
    quadrics_.assign(in.quadric_table.begin(), in.quadric_table.end());
    for (const BvhObjectInstance& inst : in.instances) {
        BvhInstance out;
        out.geometry = &inst.geometry->view();
        geometries_.push_back(inst.geometry);
        std::copy(inst.to_object, inst.to_object + 12, out.to_object);
        std::copy(inst.normal_to_world, inst.normal_to_world + 9, out.normal_to_world);
        out.mesh = inst.mesh;
        instances_.push_back(out);
    }
    stats_ = {};
    stats_.primitives = b.refs.size();
    if (b.refs.empty()) {
        update_view();
        return;
    }

    // The binary tree, with room for the spatial splits' new refs
    const uint32_t n = uint32_t(b.refs.size());
    const float budget = in.split_budget > 0.0f ? std::min(in.split_budget, kBvhMaxSplitBudget)
                                                : 0.0f;  // (NaN: none)
    const bool triangles = std::any_of(b.refs.begin(), b.refs.end(),
                                       [](const Ref& r) { return r.kind == kLeafTriangles; });
    const uint32_t capacity = uint32_t(std::min<double>(
        triangles ? double(n) + std::floor(double(n) * double(budget)) : double(n),
        double(std::numeric_limits<uint32_t>::max() / 2)));
    b.spatial = capacity > n;
    b.refs.resize(capacity);
    b.ref_count = n;
    b.order.resize(capacity);
    oneapi::tbb::parallel_for(uint32_t(0), n, [&](uint32_t i) { b.order[i] = i; });
    b.nodes.resize(2 * size_t(capacity));  // (at most 2 refs - 1; pages untouched cost nothing)
    b.next = 1;
    const Builder::Extent all = b.extent_of(0, n);
    b.root_area = all.bounds.half_area();
    b.build(0, 0, n, capacity, 1, all);
    stats_.depth = b.depth;
    stats_.references = b.ref_count.load();
    const Box root = b.nodes[0].box;
    view_.bounds[0] = root.lo.x, view_.bounds[1] = root.lo.y, view_.bounds[2] = root.lo.z;
    view_.bounds[3] = root.hi.x, view_.bounds[4] = root.hi.y, view_.bounds[5] = root.hi.z;

    // The wide tree: breadth of each node's slots from the plan, leaves written as blocks
    // (into arrays reserved for the most the leaves can take: a block per 8 triangles and one
    // partial block per binary leaf, so they never move while they grow)
    const Collapser c(b.nodes, b.next.load());
    {
        size_t leaves = 0;
        for (uint32_t i = 0; i < b.next.load(); ++i) leaves += !b.nodes[i].inner;
        const size_t blocks = b.ref_count.load() / kWideBvhWidth + leaves;
        triangles_.reserve(blocks);
        triangle_mesh_.reserve(blocks * kWideBvhWidth);
        triangle_index_.reserve(blocks * kWideBvhWidth);
        advise_huge_pages(triangles_.data(), triangles_.capacity() * sizeof(TriangleBlock));
        advise_huge_pages(triangle_mesh_.data(), triangle_mesh_.capacity() * sizeof(uint32_t));
        advise_huge_pages(triangle_index_.data(), triangle_index_.capacity() * sizeof(uint32_t));
    }
    std::vector<uint32_t> kids;
    struct Todo {
        uint32_t wide, binary;
    };
    std::vector<Todo> todo{{0, 0}};
    nodes_.emplace_back();
    while (!todo.empty()) {
        const Todo t = todo.back();
        todo.pop_back();
        kids.clear();
        const Node& bn = b.nodes[t.binary];
        if (c.plan[t.binary].leaf) {
            kids.push_back(t.binary);
        } else {
            const int s = c.plan[t.binary].split[kWideBvhWidth];
            c.roots(bn.left, s, kids);
            c.roots(bn.right, kWideBvhWidth - s, kids);
        }
        WideBvhNode node{};
        for (int k = 0; k < 3; ++k) {
            std::fill(node.bounds[k], node.bounds[k] + kWideBvhWidth, kInf);
            std::fill(node.bounds[k + 3], node.bounds[k + 3] + kWideBvhWidth, -kInf);
        }
        node.slots = uint32_t(kids.size());
        for (size_t i = 0; i < kids.size(); ++i) {
            const Node& kid = b.nodes[kids[i]];
            const float box[6] = {kid.box.lo.x, kid.box.lo.y, kid.box.lo.z,
                                  kid.box.hi.x, kid.box.hi.y, kid.box.hi.z};
            for (int k = 0; k < 6; ++k) node.bounds[k][i] = box[k];
            if (c.plan[kids[i]].leaf) {
                uint32_t count = 0;
                node.child[i] = b.add_leaf(*this, in, kids[i], count);
                node.count[i] = uint16_t(count);
                node.kind[i] = kid.kind;
                node.leaves |= 1u << i;
            } else {
                node.child[i] = uint32_t(nodes_.size());
                nodes_.emplace_back();
                todo.push_back({node.child[i], kids[i]});
            }
        }
        nodes_[t.wide] = node;
    }
    stats_.nodes = nodes_.size();
    stats_.triangle_blocks = triangles_.size();
    stats_.sphere_blocks = spheres_.size();
    stats_.items = items_.size();
    stats_.bytes = nodes_.size() * sizeof(WideBvhNode) +
                   triangles_.size() * (sizeof(TriangleBlock) + 2 * kWideBvhWidth * sizeof(uint32_t)) +
                   spheres_.size() * (sizeof(SphereBlock) + kWideBvhWidth * sizeof(uint32_t)) +
                   items_.size() * sizeof(uint32_t) + quadrics_.size() * sizeof(float) +
                   instances_.size() * sizeof(BvhInstance);
    update_view();
}

// Writes the primitives of binary node `binary` (a leaf, or a subtree the collapse made one)
// as blocks or items; returns where they start and sets their count.
uint32_t Bvh::Builder::add_leaf(Bvh& bvh, const BvhInput& in, uint32_t binary,
                                uint32_t& count) const {
    const Node& leaf = nodes[binary];
    const uint32_t* order = this->order.data() + leaf.first;
    uint32_t n = leaf.count;
    std::vector<uint32_t> gathered;
    if (leaf.inner) {  // (a subtree the collapse made one leaf)
        gather(binary, gathered);
        order = gathered.data(), n = uint32_t(gathered.size());
    }
    count = n;
    const uint32_t block_count = (n + kWideBvhWidth - 1) / kWideBvhWidth;
    switch (leaf.kind) {
        case kLeafTriangles: {
            const uint32_t first = uint32_t(bvh.triangles_.size());
            bvh.triangles_.resize(first + block_count);  // zeros: unused lanes stay degenerate
            bvh.triangle_mesh_.resize(bvh.triangles_.size() * kWideBvhWidth, 0);
            bvh.triangle_index_.resize(bvh.triangles_.size() * kWideBvhWidth, 0);
            for (uint32_t j = 0; j < n; ++j) {
                const Ref& r = refs[order[j]];
                const BvhTriangles& set = in.triangles[r.a];
                float(*rows)[kWideBvhWidth] = bvh.triangles_[first + j / kWideBvhWidth].v;
                for (int k = 0; k < 3; ++k) {
                    const Vec3f& p = set.positions[set.indices[3 * size_t(r.b) + size_t(k)]];
                    rows[3 * k][j % kWideBvhWidth] = p.x;
                    rows[3 * k + 1][j % kWideBvhWidth] = p.y;
                    rows[3 * k + 2][j % kWideBvhWidth] = p.z;
                }
                const size_t lane = size_t(first) * kWideBvhWidth + j;
                bvh.triangle_mesh_[lane] = set.mesh;
                bvh.triangle_index_[lane] = r.b;
            }
            return first;
        }
        case kLeafSpheres: {
            const uint32_t first = uint32_t(bvh.spheres_.size());
            SphereBlock empty;
            for (int k = 0; k < 3; ++k)
                std::fill_n(empty.c[k], kWideBvhWidth, std::numeric_limits<float>::quiet_NaN());
            std::fill_n(empty.c[3], kWideBvhWidth, 0.0f);
            bvh.spheres_.resize(first + block_count, empty);
            bvh.sphere_index_.resize(bvh.spheres_.size() * kWideBvhWidth, 0);
            for (uint32_t j = 0; j < n; ++j) {
                const uint32_t s = refs[order[j]].a;
                float(*rows)[kWideBvhWidth] = bvh.spheres_[first + j / kWideBvhWidth].c;
                rows[0][j % kWideBvhWidth] = in.sphere_x[s];
                rows[1][j % kWideBvhWidth] = in.sphere_y[s];
                rows[2][j % kWideBvhWidth] = in.sphere_z[s];
                rows[3][j % kWideBvhWidth] = in.sphere_r[s];
                bvh.sphere_index_[size_t(first) * kWideBvhWidth + j] = s;
            }
            return first;
        }
        default: {
            const uint32_t first = uint32_t(bvh.items_.size());
            for (uint32_t j = 0; j < n; ++j) {
                const Ref& r = refs[order[j]];
                bvh.items_.push_back(leaf.kind == kLeafQuadrics ? in.quadrics[r.a].index : r.a);
            }
            return first;
        }
    }
}

}  // namespace cierzo
