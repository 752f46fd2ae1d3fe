// Closest hits of a stream of rays through the scene BVH, node by node (an ordered ray
// stream: Fuetterling et al., "Efficient Ray Tracing Kernels for Modern CPU
// Architectures", JCGT 2015; Barringer and Akenine-Möller, "Dynamic Ray Stream Traversal",
// 2014). Every ray of a node's stream tests the node's eight boxes while the node is in the
// first-level cache, tests the leaves it enters there and then, and joins the stream of
// each inner child it enters; the children's streams go on one stack, the nearest (by the
// mean entry distance of its rays) on top. A stream of fewer than `single_below` rays
// finishes its subtree one ray at a time (kernels/bvh/traverse.h, from that node): streams thin
// out with depth, and there one ray's traversal costs less per node.
//
// The same node test and leaf kernels as the single-ray traversal, so a ray finds the same
// nearest distance t, bit for bit, and the same primitive, except on an exact tie of two
// primitives' distances (a ray through a shared edge), where either may be named: the two
// visit the leaves in another order. For trees of triangles and spheres without alpha
// masks (stream_tree()).
#pragma once

#include <algorithm>
#include <bit>
#include <cstddef>
#include <cstdint>

#include "traverse.h"

namespace cierzo {
inline namespace CIERZO_ISA_NAMESPACE {

// Whether a tree can be traversed as ray streams: inner nodes, and leaves of triangles and
// spheres alone (no quadrics, no instances); `alpha` masks none of it.
inline bool stream_tree(const BvhView& bvh, bool alpha) {
    if (alpha || bvh.node_count <= 1 || bvh.instance_count != 0) return false;
    for (int32_t n = 0; n < bvh.node_count; ++n) {
        const WideBvhNode& node = bvh.nodes[n];
        for (uint32_t i = 0; i < node.slots; ++i)
            if (((node.leaves >> i) & 1u) && node.kind[i] != kLeafTriangles &&
                node.kind[i] != kLeafSpheres)
                return false;
    }
    return true;
}

// The most rays of one stream (its ray ids are 16-bit).
inline constexpr int kMaxStreamRays = 1 << 16;

// The ray ids a stream of `count` rays may hold at once: at each level of the path from the
// root, the streams of up to eight children (seven waiting on the stack, and the one whose
// subtree is being traversed), each of at most `count` rays; and the root's. Few of them
// are ever touched: memory that is never written costs nothing (core/huge_pages.h).
inline size_t stream_scratch_ids(int count) {
    return size_t(count) * (size_t(kWideBvhWidth) * kBvhMaxDepth + 1);
}

// Closest hits of the stream of `count` rays whose indices (into rays, t, hit, found and
// masks; each below kMaxStreamRays) are ids[0, count), below t[r] (updated), in the tree
// (stream_tree()): found[r] = 1 and hit[r] where ray r hits, found untouched where it does
// not. ids: stream_scratch_ids(count) entries.
template <class N>
[[gnu::flatten]] void stream_closest(const BvhView& bvh, const TraversalRay* rays, int count,
                                     float* t, BvhHit* hit, uint8_t* found, uint16_t* ids,
                                     uint8_t* masks, int single_below) {
    constexpr int kLanes = kNodeLanes<N>;
    if (bvh.node_count == 0 || count <= 0) return;
    struct Entry {
        uint32_t node;
        uint32_t begin, end;  // its rays: ids[begin, end)
    };
    Entry stack[kWideBvhStackSize];
    int size = 0;
    stack[size++] = {0, 0, uint32_t(count)};

    while (size > 0) {
        const Entry e = stack[--size];
        const uint32_t n = e.end - e.begin;
        if (n < uint32_t(single_below)) {
            for (uint32_t j = e.begin; j < e.end; ++j) {
                const int r = ids[j];
                BvhHit h;
                if (traverse<false, N>(bvh, rays[r], t[r], h, nullptr, -1, nullptr, e.node))
                    hit[r] = h, found[r] = 1;
            }
            continue;
        }
        const WideBvhNode& node = bvh.nodes[e.node];
        const uint32_t used = (1u << node.slots) - 1u;
        float key[kWideBvhWidth] = {};  // the sum of the entry distances of a child's rays
        uint32_t members[kWideBvhWidth] = {};
        // Every ray of the stream: its boxes entered, its leaves tested now, its inner
        // children noted
        for (uint32_t j = e.begin; j < e.end; ++j) {
            const int r = ids[j];
            const TraversalRay& ray = rays[r];
            alignas(32) float entry[kWideBvhWidth];
            uint32_t enter = 0;
            for (int at = 0; at < kWideBvhWidth; at += kLanes) {
                N t0(0.0f), t1(t[r]);
                for (int k = 0; k < 3; ++k) {
                    const bool back = std::signbit(ray.inv[k]);
                    const float* near_row = node.bounds + (back ? k + 3 : k) * kWideBvhWidth;
                    const float* far_row = node.bounds + (back ? k : k + 3) * kWideBvhWidth;
                    const N near = load_lanes<N>(near_row + at);
                    const N far = load_lanes<N>(far_row + at);
                    const N o(ray.o[k]);
                    t0 = slab_max((near - o) * N(ray.inv[k]), t0);
                    t1 = slab_min((far - o) * N(ray.inv[k] * kBvhFarScale), t1);
                }
                enter |= mask_bits(t0 <= t1) << at;
                store_lanes(t0, entry + at);
            }
            enter &= used;
            if (uint32_t leaves = enter & node.leaves) {
                const LeafRay<N> lr = make_leaf_ray<N>(ray);
                for (; leaves; leaves &= leaves - 1) {
                    const int i = std::countr_zero(leaves);
                    if (entry[i] > t[r]) continue;
                    uint32_t lane = 0;
                    const bool h = node.kind[i] == kLeafTriangles
                                       ? hit_triangle_leaf<false>(bvh, ray, lr, node.child[i],
                                                                  node.count[i], t[r], lane)
                                       : hit_sphere_leaf<false, N>(bvh, ray, node.child[i],
                                                                   node.count[i], t[r], lane);
                    if (h) hit[r] = {node.kind[i], lane, -1}, found[r] = 1;
                }
            }
            uint32_t inner = enter & ~node.leaves;
            masks[r] = uint8_t(inner);
            for (; inner; inner &= inner - 1) {
                const int i = std::countr_zero(inner);
                key[i] += entry[i];
                ++members[i];
            }
        }
        // The inner children entered, farthest first (so the nearest is on top)
        int order[kWideBvhWidth], children = 0;
        for (int i = 0; i < int(node.slots); ++i) {
            if (members[i] == 0) continue;
            key[i] /= float(members[i]);
            int k = children++;
            for (; k > 0 && key[order[k - 1]] < key[i]; --k) order[k] = order[k - 1];
            order[k] = i;
        }
        if (children == 0) continue;
        // Their streams, above this one's ids (which are read while they are written: the
        // first child's stream starts past them)
        uint32_t start[kWideBvhWidth], at = e.end;
        for (int k = 0; k < children; ++k) {
            const int i = order[k];
            start[i] = at;
            stack[size++] = {node.child[i], at, at + members[i]};
            at += members[i];
        }
        for (uint32_t j = e.begin; j < e.end; ++j) {
            const uint16_t r = ids[j];
            for (uint32_t inner = masks[r]; inner; inner &= inner - 1)
                ids[start[std::countr_zero(inner)]++] = r;
        }
    }
}

}  // namespace CIERZO_ISA_NAMESPACE
}  // namespace cierzo
