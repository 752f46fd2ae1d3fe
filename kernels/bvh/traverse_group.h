// Many independent rays in flight per thread: the interleaved traversal of a group of rays
// through the scene BVH (group prefetching with refill, as in Chen, Ailamaki, Gibbons and
// Mowry, "Improving Hash Join Performance through Prefetching", ICDE 2004, and Kocberber,
// Falsafi and Grot, "Asynchronous Memory Access Chaining", VLDB 2016). A ray's traversal of
// a big tree waits on memory, one miss after another (the node it enters next, the leaf
// blocks it tests), and one ray at a time overlaps few of them. Here each of up to `group`
// rays keeps its own state and stack, and the rays take turns: a ray does one step (the
// leaves it entered at its last node, then the next node's test), issues prefetches for
// every line that its next step reads, and yields to the next ray, so that those lines can
// arrive before its turn comes again. A ray that finishes hands its slot to the next ray of
// the input. (Measured slower than one ray at a time on an AMD Zen 4 at every group size:
// docs/acceleration.md says why.)
//
// Each ray goes through exactly the steps of the single-ray traversal (kernels/bvh/traverse.h:
// the same node test, leaf test and stack order; only the order in which different rays'
// steps interleave differs), so it finds the same hit, bit for bit: the same t, the same
// primitive, the same instance. Instances are traversed one ray at a time inside the step
// that enters them.
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>

#include "traverse.h"

namespace cierzo {
inline namespace CIERZO_ISA_NAMESPACE {

// One ray's state between its steps (3 cache lines).
struct alignas(64) GroupRay {
    alignas(32) float entry[kWideBvhWidth];  // where the ray enters leaf_node's children
    TraversalRay r;
    float t;              // the closest hit so far
    uint32_t ray;         // its index in the input
    BvhHit best;          // closest hit: the nearest so far
    TraversalEntry next;  // the node its next step tests, if `ready`
    uint32_t leaf_node;   // the node whose leaves `leaves` are still to be tested
    uint32_t leaves;      // slots of leaf_node, in slot order
    int32_t size;         // entries on its stack
    uint8_t found, ready;
    TraversalEntry* stack;  // kWideBvhStackSize entries
};

// Memory for a group of up to kMaxTraversalGroup rays: their states and stacks (5.4 kB of
// stack a ray, of which a traversal touches a few lines).
struct TraversalGroupScratch {
    GroupRay rays[kMaxTraversalGroup];
    TraversalEntry stacks[kMaxTraversalGroup][kWideBvhStackSize];
    TraversalScratch instance;  // an instance's traversal, inside one step
};

// One step of ray g (its stack at g.stack): the leaves entered at its last node, then its next
// node's test, or a pop from its stack and a prefetch of that node (tested at its next turn).
// Whether the ray is done (then g.found, and for closest hit g.t and g.best, are its result).
// (The state is worked on in locals and written back once: through `g`, every store to the
// stack would be taken to change it.)
template <bool kAnyHit, class N>
inline bool group_step(const BvhView& bvh, GroupRay& g, const AlphaTable* alpha,
                       TraversalScratch& instance) {
    float t = g.t;
    TraversalEntry next = g.next;
    TraversalEntry* const stack = g.stack;
    int size = g.size;
    bool ready = g.ready;
    // The leaves entered at the last node, in slot order (their blocks were prefetched then)
    if (g.leaves) {
        const WideBvhNode& node = bvh.nodes[g.leaf_node];
        const LeafRay<N> lr = make_leaf_ray<N>(g.r);
        BvhHit best = g.best;
        bool found = false;
        for (uint32_t leaves = g.leaves; leaves; leaves &= leaves - 1) {
            const int i = std::countr_zero(leaves);
            if constexpr (!kAnyHit)
                if (g.entry[i] > t) continue;
            if (hit_leaf<kAnyHit, N, true>(bvh, g.r, lr, node.kind[i], node.child[i], node.count[i],
                                           t, best, alpha, -1, nullptr, instance)) {
                found = true;
                if constexpr (kAnyHit) break;
            }
        }
        g.leaves = 0;
        if (found) {
            g.found = 1;
            if constexpr (kAnyHit) return true;
            g.t = t, g.best = best;
        }
    }
    // The next node: the nearest child entered at the last node (prefetched then) unless the
    // leaves hit nearer than its box; else the top of the stack, dropping boxes entered
    // beyond the closest hit, prefetched now and tested at the ray's next turn
    if (!ready || next.t > t) {
        do {
            if (size == 0) return true;
            next = stack[--size];
        } while (next.t > t);
        g.next = next, g.size = size, g.ready = 1;
        prefetch_lines(bvh.nodes + next.node, sizeof(WideBvhNode));
        return false;
    }
    const WideBvhNode& node = bvh.nodes[next.node];
    const NodeRay<N> nr = make_node_ray<N>(g.r);
    alignas(32) float entry[kWideBvhWidth];
    const uint32_t enter = enter_children(nr, node, t, entry);
    prefetch_children(bvh, node, enter, true);
    const uint32_t leaves = enter & node.leaves;
    if (leaves) {
        g.leaves = leaves, g.leaf_node = next.node;
        std::copy_n(entry, kWideBvhWidth, g.entry);
    }
    g.ready = push_children<kAnyHit>(node, enter & ~node.leaves, entry, next, stack, size);
    g.next = next, g.size = size;
    return false;
}

// The hits of `count` rays (rays[i], with their intervals (0, tmax[i])) in the tree, `group`
// of them in flight at once (1 to kMaxTraversalGroup). found[i] = 1 where ray i hits, else
// 0; closest hit: there tmax[i] and hit[i] become the nearest (the first on a tie); any hit
// (kAnyHit): hit is not written. The same hits as traverse() for each ray.
template <bool kAnyHit, class N>
[[gnu::flatten]] void traverse_group(const BvhView& bvh, const TraversalRay* rays, int count,
                                     float* tmax, BvhHit* hit, uint8_t* found, int group,
                                     TraversalGroupScratch& scratch,
                                     const AlphaTable* alpha = nullptr) {
    if (count <= 0) return;
    if (bvh.node_count == 0) {
        std::fill(found, found + count, uint8_t(0));
        return;
    }
    group = std::clamp(group, 1, int(kMaxTraversalGroup));  // (a copy: no symbol of the constant)
    GroupRay* slots = scratch.rays;
    int next = 0;
    // Ray `next` of the input into slot g, its stack `stack`
    const auto start = [&](GroupRay& g, TraversalEntry* stack) {
        g.r = rays[next];
        g.t = tmax[next];
        g.ray = uint32_t(next);
        g.best = {0, 0, -1};
        g.next = {0, 0.0f};
        g.leaves = 0;
        g.size = 0;
        g.found = 0;
        g.ready = 1;
        g.stack = stack;
        ++next;
    };
    int active = std::min(group, count);
    for (int s = 0; s < active; ++s) start(slots[s], scratch.stacks[s]);
    while (active > 0) {
        for (int s = 0; s < active;) {
            GroupRay& g = slots[s];
            if (!group_step<kAnyHit, N>(bvh, g, alpha, scratch.instance)) {
                ++s;
                continue;
            }
            found[g.ray] = g.found;
            if constexpr (!kAnyHit)
                if (g.found) tmax[g.ray] = g.t, hit[g.ray] = g.best;
            if (next < count) {
                start(g, g.stack);
                ++s;
            } else if (s != --active) {
                // The last slot's ray (with its stack) takes this slot; its step comes now
                slots[s] = slots[active];
            }
        }
    }
}

}  // namespace CIERZO_ISA_NAMESPACE
}  // namespace cierzo
