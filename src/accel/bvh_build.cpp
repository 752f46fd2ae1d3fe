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
// Step 1 is Bvh::Builder (bvh_builder.h; its spatial splits in bvh_spatial_splits.cpp); here
// the collapse, the leaves and the build that runs them.
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

#include "accel/bvh_builder.h"
#include "core/error.h"
#include "core/huge_pages.h"

namespace cierzo {

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
            throw InputError("BVH: the triangle index count (" +
                             std::to_string(set.indices.size()) + ") is not a multiple of 3");
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
                        while (i < seen && !bad.compare_exchange_weak(seen, i)) {
                        }
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
    const uint32_t capacity = uint32_t(
        std::min<double>(triangles ? double(n) + std::floor(double(n) * double(budget)) : double(n),
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
            std::fill(node.row(k), node.row(k) + kWideBvhWidth, kInf);
            std::fill(node.row(k + 3), node.row(k + 3) + kWideBvhWidth, -kInf);
        }
        node.slots = uint32_t(kids.size());
        for (size_t i = 0; i < kids.size(); ++i) {
            const Node& kid = b.nodes[kids[i]];
            const float box[6] = {kid.box.lo.x, kid.box.lo.y, kid.box.lo.z,
                                  kid.box.hi.x, kid.box.hi.y, kid.box.hi.z};
            for (int k = 0; k < 6; ++k) node.row(k)[i] = box[k];
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
        // Unused slots: empty boxes, and empty leaves, so a ray that enters one anyway (a NaN
        // direction keeps every interval) tests nothing there
        node.leaves |= (~0u << kids.size()) & ((1u << kWideBvhWidth) - 1u);
        nodes_[t.wide] = node;
    }
    stats_.nodes = nodes_.size();
    stats_.triangle_blocks = triangles_.size();
    stats_.sphere_blocks = spheres_.size();
    stats_.items = items_.size();
    stats_.bytes =
        nodes_.size() * sizeof(WideBvhNode) +
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
