// The 8-wide BVH, collapsed from the binary SAH tree with the surface-area cost minimised by
// dynamic programming (Ylitie, Karras, Laine, "Efficient Incoherent Ray Traversal on GPUs
// Through Compressed Wide BVHs", HPG 2017, section 3.1): each binary subtree becomes a leaf,
// a wide node, or is spread over several slots of its parent, whichever costs least. Leaves
// keep their triangles in blocks of 8 (SoA), one SIMD test per block. Layout in
// scene/wide_bvh.h.
#include <algorithm>
#include <array>
#include <limits>

#include "scene/bvh.h"

namespace cierzo {

static_assert(kWideBvhStackSize >= (kWideBvhWidth - 1) * Bvh::kMaxDepth + 1);

namespace {

// Costs relative to one node visit (the slab test of 8 children and the stack work); one
// block of 8 triangles costs about 1.4 of them (instructions per visit, measured; the tree
// and its speed hardly change for any value from 1 to 3).
constexpr float kNodeCost = 1.0f;
constexpr float kBlockCost = 1.4f;
constexpr float kInf = std::numeric_limits<float>::infinity();
constexpr float kLargestArea = 1e30f;

}  // namespace

struct Bvh::Collapser {
    Bvh& bvh;
    // Per binary node: its triangles (first in leaf order, count); the cost of its subtree
    // as at most i roots (cost[i], i = 1..8; as one root it is a leaf or a wide node,
    // whichever is cheaper: leaf); for i >= 2, whether spreading over i slots beats one root
    // (spread[i]) and how many of them go to the first child (split[i])
    struct Plan {
        uint32_t first = 0, count = 0;
        bool leaf = false;
        std::array<float, kWideBvhWidth + 1> cost{};
        std::array<bool, kWideBvhWidth + 1> spread{};
        std::array<int8_t, kWideBvhWidth + 1> split{};
    };
    std::vector<Plan> plan;

    explicit Collapser(Bvh& b) : bvh(b), plan(b.nodes_.size()) {
        // Children follow their parent, so a reverse sweep sees them first
        for (size_t n = plan.size(); n-- > 0;) {
            const Node& node = bvh.nodes_[n];
            Plan& p = plan[n];
            const float area = half_area(node);
            if (node.count != 0) {
                // A binary leaf stays a leaf (the build keeps it within 16 triangles)
                p.first = node.offset, p.count = node.count, p.leaf = true;
                p.cost.fill(area * kBlockCost * float(blocks(p.count)));
                continue;
            }
            const Plan &a = plan[n + 1], &b = plan[node.offset];
            p.first = a.first, p.count = a.count + b.count;
            // The children spread over j slots, the best split of them for each j
            std::array<float, kWideBvhWidth + 1> spread_cost;
            for (int j = 2; j <= kWideBvhWidth; ++j) {
                spread_cost[j] = a.cost[1] + b.cost[j - 1];
                p.split[j] = 1;
                for (int k = 2; k < j; ++k) {
                    const float c = a.cost[k] + b.cost[j - k];
                    if (c < spread_cost[j]) spread_cost[j] = c, p.split[j] = int8_t(k);
                }
            }
            // One root: a leaf (if small enough) or a wide node over 8 slots
            const float wide = area * kNodeCost + spread_cost[kWideBvhWidth];
            const float leaf = area * kBlockCost * float(blocks(p.count));
            p.leaf = p.count <= Bvh::kMaxLeafSize && leaf <= wide;
            p.cost[1] = p.leaf ? leaf : wide;
            for (int i = 2; i <= kWideBvhWidth; ++i) {
                p.spread[i] = spread_cost[i] < p.cost[1];
                p.cost[i] = p.spread[i] ? spread_cost[i] : p.cost[1];
            }
        }
    }

    static uint32_t blocks(uint32_t triangles) {
        return (triangles + kWideBvhWidth - 1) / kWideBvhWidth;
    }

    // Half the surface area of a node's box, kept finite (boxes of huge coordinates overflow;
    // the plan's shape never depends on the costs being meaningful)
    static float half_area(const Node& node) {
        const float* b = node.bounds;
        const float ex = b[3] - b[0], ey = b[4] - b[1], ez = b[5] - b[2];
        const float area = ex * ey + ey * ez + ez * ex;
        return area <= kLargestArea ? area : kLargestArea;
    }

    // The roots of binary node n's subtree as at most i slots, in order.
    void roots(uint32_t n, int i, std::vector<uint32_t>& out) const {
        if (i == 1 || !plan[n].spread[i]) {
            out.push_back(n);
            return;
        }
        roots(n + 1, plan[n].split[i], out);
        roots(bvh.nodes_[n].offset, i - plan[n].split[i], out);
    }

    // Fills wide node `wide` with the children of binary node n (the root may be a leaf).
    void fill(uint32_t wide, uint32_t n) {
        std::vector<uint32_t> kids;
        if (plan[n].leaf) {
            kids.push_back(n);
        } else {
            roots(n + 1, plan[n].split[kWideBvhWidth], kids);
            roots(bvh.nodes_[n].offset, kWideBvhWidth - plan[n].split[kWideBvhWidth], kids);
        }
        // The slots: boxes, leaves as their blocks, inner children as new nodes (allocated
        // together, then filled); unused slots get an empty box
        WideBvhNode node{};
        for (int k = 0; k < 3; ++k) {
            std::fill(node.bounds[k], node.bounds[k] + kWideBvhWidth, kInf);
            std::fill(node.bounds[k + 3], node.bounds[k + 3] + kWideBvhWidth, -kInf);
        }
        node.slots = uint32_t(kids.size());
        for (size_t i = 0; i < kids.size(); ++i) {
            const Plan& p = plan[kids[i]];
            for (int k = 0; k < 6; ++k) node.bounds[k][i] = bvh.nodes_[kids[i]].bounds[k];
            if (p.leaf) {
                node.child[i] = add_leaf(p.first, p.count);
                node.count[i] = uint16_t(p.count);
                node.leaves |= 1u << i;
            } else {
                node.child[i] = uint32_t(bvh.wide_nodes_.size());
                bvh.wide_nodes_.emplace_back();
            }
        }
        bvh.wide_nodes_[wide] = node;
        for (size_t i = 0; i < kids.size(); ++i)
            if (!plan[kids[i]].leaf) fill(node.child[i], kids[i]);
    }

    // Copies triangles [begin, begin + n) of the leaf order into new blocks; returns the first.
    uint32_t add_leaf(uint32_t begin, uint32_t n) {
        const uint32_t first = uint32_t(bvh.blocks_.size());
        bvh.blocks_.resize(first + blocks(n));  // zeros: lanes past the last stay degenerate
        bvh.block_ids_.resize(bvh.blocks_.size() * kWideBvhWidth, 0);
        for (uint32_t j = 0; j < n; ++j) {
            const Triangle& tri = bvh.triangles_[begin + j];
            const Vec3f* v[3] = {&tri.v0, &tri.v1, &tri.v2};
            float(*rows)[kWideBvhWidth] = bvh.blocks_[first + j / kWideBvhWidth].v;
            for (int k = 0; k < 3; ++k) {
                rows[3 * k][j % kWideBvhWidth] = v[k]->x;
                rows[3 * k + 1][j % kWideBvhWidth] = v[k]->y;
                rows[3 * k + 2][j % kWideBvhWidth] = v[k]->z;
            }
            bvh.block_ids_[size_t(first) * kWideBvhWidth + j] = bvh.triangle_ids_[begin + j];
        }
        return first;
    }
};

void Bvh::collapse() {
    if (nodes_.empty()) return;
    wide_nodes_.emplace_back();
    Collapser(*this).fill(0, 0);
}

}  // namespace cierzo
