// The one traversal of the scene BVH (layout in kernels/bvh/bvh_layout.h), for both integrators:
// one ray at a time through 8-wide nodes, templated on the lane type N that tests a node's
// children and a leaf block's primitives — `float` (one child at a time: the scalar
// reference) or an xsimd batch of 8 floats (or 4, twice: the wavefront). Every primitive
// kernel is the one of kernels/intersect.h and kernels/triangle.h, so the two integrators
// find the same hits. Also here: the short list of unbounded primitives (planes, unbounded
// quadrics) tested beside the tree, for one ray or K rays at once.
#pragma once

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <type_traits>
#include <utility>

#include "bvh_layout.h"
#include "../intersect.h"
#include "../texture.h"
#include "../triangle.h"

namespace cierzo {
inline namespace CIERZO_ISA_NAMESPACE {

// ---- Rays ----------------------------------------------------------------------------------
// A ray set up for traversal: origin, direction (for spheres and quadrics), reciprocal
// direction (zero components give ±inf) and the watertight kernel's shear (axes kx, ky, kz
// and sx, sy, sz; kernels/triangle.h).
struct TraversalRay {
    float o[3], d[3], inv[3];
    int32_t axis[3];
    float shear[3];
};

inline TraversalRay make_traversal_ray(const Vec3f& o, const Vec3f& d) {
    const RayShear<float> s = make_ray_shear(d);
    return {{o.x, o.y, o.z},
            {d.x, d.y, d.z},
            {1.0f / d.x, 1.0f / d.y, 1.0f / d.z},
            {s.kx, s.ky, s.kz},
            {s.sx, s.sy, s.sz}};
}

// What a ray hit in the tree.
struct BvhHit {
    uint32_t kind;      // BvhLeafKind
    uint32_t lane;      // triangles, spheres: block lane (8 * block + lane); quadric: its index
    int32_t instance;   // the instance a triangle was hit through, or -1
};

// ---- Lanes ---------------------------------------------------------------------------------
template <class N>
inline N load_lanes(const float* p) {
    if constexpr (std::is_same_v<N, float>) {
        return *p;
    } else {
        return N::load_aligned(p);
    }
}
template <class N>
inline void store_lanes(const N& v, float* p) {
    if constexpr (std::is_same_v<N, float>) {
        *p = v;
    } else {
        v.store_aligned(p);
    }
}
template <class N>
inline constexpr int kNodeLanes = kWidth<N>;

// a > b ? a : b and a < b ? a : b, so a NaN distance a leaves the interval as it was: maxps
// and minps for batches (kernels/xsimd_neon_ieee.h gives NEON the same), the conditional
// for a float (std::max(NaN, b) would be NaN).
template <class N>
inline N slab_max(const N& a, const N& b) {
    if constexpr (std::is_same_v<N, float>) {
        return a > b ? a : b;
    } else {
        return max(a, b);
    }
}
template <class N>
inline N slab_min(const N& a, const N& b) {
    if constexpr (std::is_same_v<N, float>) {
        return a < b ? a : b;
    } else {
        return min(a, b);
    }
}

// The 8 lanes of block row `row` starting at `at`, in N.
template <class N>
inline N row(const float (*rows)[kWideBvhWidth], int r, int at) {
    return load_lanes<N>(rows[r] + at);
}

inline Vec3f affine_point(const float m[12], const float p[3]) {
    return {m[0] * p[0] + m[1] * p[1] + m[2] * p[2] + m[3],
            m[4] * p[0] + m[5] * p[1] + m[6] * p[2] + m[7],
            m[8] * p[0] + m[9] * p[1] + m[10] * p[2] + m[11]};
}
inline Vec3f linear_map(const float m[], int stride, const float v[3]) {
    return {m[0] * v[0] + m[1] * v[1] + m[2] * v[2],
            m[stride] * v[0] + m[stride + 1] * v[1] + m[stride + 2] * v[2],
            m[2 * stride] * v[0] + m[2 * stride + 1] * v[1] + m[2 * stride + 2] * v[2]};
}

// ---- Alpha cut-outs ------------------------------------------------------------------------
// The alpha of a hit on triangle `triangle` of scene mesh `mesh` at barycentrics (b1, b2)
// (kernels/bvh/bvh_layout.h, AlphaMask): 1 where the mesh is not masked. One hit at a time, out
// of line: only masked scenes come here.
[[gnu::noinline]] inline float alpha_at(const AlphaTable& table, uint32_t mesh,
                                        uint32_t triangle, float b1, float b2) {
    const MeshAlpha& m = table.meshes[mesh];
    if (m.mask < 0) return 1.0f;
    const AlphaMask& a = table.masks[m.mask];
    if (a.width == 0) return a.constant;
    const uint32_t* idx = m.indices + 3 * size_t(triangle);
    const float b0 = std::max(1.0f - b1 - b2, 0.0f);
    const float* uv0 = m.uvs + 2 * size_t(idx[0]);
    const float* uv1 = m.uvs + 2 * size_t(idx[1]);
    const float* uv2 = m.uvs + 2 * size_t(idx[2]);
    const float u = std::fma(uv2[0], b2, std::fma(uv1[0], b1, uv0[0] * b0));
    const float v = std::fma(uv2[1], b2, std::fma(uv1[1], b1, uv0[1] * b0));
    ImageView view;
    view.bytes = a.bytes, view.floats = a.floats, view.decode = a.decode;
    view.width = a.width, view.height = a.height;
    ColorSource c;
    c.uv_scale[0] = a.uv_scale[0], c.uv_scale[1] = a.uv_scale[1];
    c.uv_offset[0] = a.uv_offset[0], c.uv_offset[1] = a.uv_offset[1];
    c.clamp = a.clamp != 0;
    const Texel<float> t = sample_image(view, c, u, v);
    const float channel[4] = {t.rgb.x, t.rgb.y, t.rgb.z, t.alpha};
    return a.constant * channel[a.channel];
}

// Whether a hit of alpha `a` counts for the world-space ray (o, d): always where a >= 1,
// never where a <= 0, and in between where a hash of the ray and the triangle, uniform in
// [0, 1), falls below a (stochastic transparency: the expected visibility through the
// surface is 1 - a, and the same ray always makes the same decision, in every integrator).
inline bool alpha_passes(float a, const float o[3], const float d[3], uint32_t mesh,
                         uint32_t triangle) {
    if (a >= 1.0f) return true;
    if (!(a > 0.0f)) return false;
    const auto mix = [](uint32_t h) {  // (a 32-bit finaliser with full avalanche)
        h ^= h >> 16, h *= 0x7feb352du;
        h ^= h >> 15, h *= 0x846ca68bu;
        return h ^ (h >> 16);
    };
    uint32_t h = mix(mesh * 0x9e3779b9u + triangle);
    for (int k = 0; k < 3; ++k) h = mix(h ^ std::bit_cast<uint32_t>(o[k]));
    for (int k = 0; k < 3; ++k) h = mix(h ^ std::bit_cast<uint32_t>(d[k]));
    return float(h >> 8) * 0x1p-24f < a;
}

// Whether the masks keep a hit at barycentrics (b1, b2) of `triangle` of scene mesh `mesh`,
// for the world-space ray (o, d).
inline bool alpha_keeps(const AlphaTable& table, uint32_t mesh, uint32_t triangle, float b1,
                        float b2, const float o[3], const float d[3]) {
    return alpha_passes(alpha_at(table, mesh, triangle, b1, b2), o, d, mesh, triangle);
}

// The hits of a block (bits of `hits`, lanes from lane0 on) that the alpha masks keep, for
// the world-space ray `world`. `object`: the scene mesh of an instance's triangles (-1: the
// tree's own, triangle_mesh).
template <class N>
uint32_t alpha_filter(const BvhView& bvh, const AlphaTable& table, int32_t object,
                      const TraversalRay& world, uint32_t hits, uint32_t lane0, const N& b1,
                      const N& b2) {
    constexpr int kLanes = kNodeLanes<N>;
    alignas(32) float u[kLanes], v[kLanes];
    store_lanes(b1, u);
    store_lanes(b2, v);
    for (uint32_t bits = hits; bits; bits &= bits - 1) {
        const uint32_t h = uint32_t(std::countr_zero(bits));
        const uint32_t lane = lane0 + h;
        const uint32_t mesh = object >= 0 ? uint32_t(object) : bvh.triangle_mesh[lane];
        const uint32_t triangle = bvh.triangle_index[lane];
        if (!alpha_keeps(table, mesh, triangle, u[h], v[h], world.o, world.d))
            hits &= ~(1u << h);
    }
    return hits;
}

// ---- Leaves --------------------------------------------------------------------------------
// A ray in every lane, as the leaf kernels read it: for triangles the origin with its axes
// already permuted (kx, ky, kz) and the shear's factors, and the plain ray for spheres.
template <class N>
struct LeafRay {
    Ray<N> tri;
    N sx, sy, sz;
    Ray<N> ray;
};

template <class N>
inline LeafRay<N> make_leaf_ray(const TraversalRay& r) {
    const int32_t* axis = r.axis;
    return {{{N(r.o[axis[0]]), N(r.o[axis[1]]), N(r.o[axis[2]])}, Vec3<N>(N(0.0f))},
            N(r.shear[0]),
            N(r.shear[1]),
            N(r.shear[2]),
            {{N(r.o[0]), N(r.o[1]), N(r.o[2])}, {N(r.d[0]), N(r.d[1]), N(r.d[2])}}};
}

// Lanes `hits` of a block tested at distances th: the nearest below t (t and lane updated;
// the first on a tie).
template <class N>
inline void nearest_lane(uint32_t hits, const N& th, uint32_t lane0, float& t, uint32_t& lane) {
    alignas(32) float ts[kNodeLanes<N>];
    store_lanes(th, ts);
    for (; hits; hits &= hits - 1) {
        const uint32_t h = uint32_t(std::countr_zero(hits));
        if (ts[h] < t) t = ts[h], lane = lane0 + h;
    }
}

// A leaf of triangle blocks (`count` triangles from block `start`) for ray r (lr: in every
// lane): whether one is hit below t; closest hit: t and lane (block lane) updated to the
// nearest. alpha: the masks (alpha_filter; object and world as there), or null.
template <bool kAnyHit, class N>
inline bool hit_triangle_leaf(const BvhView& bvh, const TraversalRay& r, const LeafRay<N>& lr,
                              uint32_t start, uint32_t count, float& t, uint32_t& lane,
                              const AlphaTable* alpha = nullptr, int32_t object = -1,
                              const TraversalRay* world = nullptr) {
    constexpr int kLanes = kNodeLanes<N>;
    const int32_t* axis = r.axis;
    // The vertices are handed to the kernel with their axes permuted as the origin is, so
    // its per-lane picks are the identity, built here as constants that fold away (it
    // computes exactly what it would unpermuted: it reads no direction)
    const Mask<N> yes(true), no(false);
    const RayShear<N> shear{I32<N>(0), I32<N>(1), I32<N>(2), {yes, no}, {no, yes}, {no, no},
                            lr.sx, lr.sy, lr.sz};
    bool any = false;
    const uint32_t blocks = (count + kWideBvhWidth - 1) / kWideBvhWidth;
    for (uint32_t j = start; j < start + blocks; ++j) {
        const float(*v)[kWideBvhWidth] = bvh.triangles[j].v;
        for (int at = 0; at < kWideBvhWidth; at += kLanes) {
            const auto vertex = [&](int k) {
                return Vec3<N>(row<N>(v, 3 * k + axis[0], at), row<N>(v, 3 * k + axis[1], at),
                               row<N>(v, 3 * k + axis[2], at));
            };
            N th(0.0f), b1(0.0f), b2(0.0f);
            uint32_t hits = mask_bits(intersect_triangle(lr.tri, shear, vertex(0), vertex(1),
                                                         vertex(2), N(t), th, b1, b2));
            if (hits == 0) continue;
            if (alpha) {
                hits = alpha_filter(bvh, *alpha, object, world ? *world : r, hits,
                                    j * kWideBvhWidth + uint32_t(at), b1, b2);
                if (hits == 0) continue;
            }
            if constexpr (kAnyHit) return true;
            any = true;
            nearest_lane(hits, th, j * kWideBvhWidth + uint32_t(at), t, lane);
        }
    }
    return any;
}

// A leaf of sphere blocks, likewise.
template <bool kAnyHit, class N>
inline bool hit_sphere_leaf(const BvhView& bvh, const LeafRay<N>& lr, uint32_t start,
                            uint32_t count, float& t, uint32_t& lane) {
    constexpr int kLanes = kNodeLanes<N>;
    bool any = false;
    const uint32_t blocks = (count + kWideBvhWidth - 1) / kWideBvhWidth;
    for (uint32_t j = start; j < start + blocks; ++j) {
        const float(*c)[kWideBvhWidth] = bvh.spheres[j].c;
        for (int at = 0; at < kWideBvhWidth; at += kLanes) {
            const Vec3<N> centre(row<N>(c, 0, at), row<N>(c, 1, at), row<N>(c, 2, at));
            N th(0.0f);
            const uint32_t hits =
                mask_bits(intersect_sphere(lr.ray, centre, row<N>(c, 3, at), N(t), th));
            if (hits == 0) continue;
            if constexpr (kAnyHit) return true;
            any = true;
            nearest_lane(hits, th, j * kWideBvhWidth + uint32_t(at), t, lane);
        }
    }
    return any;
}

template <bool kAnyHit, class N, bool kTop = true>
[[gnu::flatten]] bool traverse(const BvhView& bvh, const TraversalRay& r, float& tmax, BvhHit& hit,
                               const AlphaTable* alpha = nullptr, int32_t object = -1,
                               const TraversalRay* world = nullptr, uint32_t root = 0);

// One leaf of any kind (kind, start, count: a node's slot) for ray r (lr: in every lane):
// whether it is hit below t; closest hit: t and `best` updated to the nearest, the first on a
// tie. The one leaf test of every traverser: triangle and sphere blocks as above, quadrics
// one at a time, an instance by mapping the ray into its space (t is unchanged there) and
// traversing its mesh's tree (kTop = false: a mesh's tree holds triangles only).
template <bool kAnyHit, class N, bool kTop>
inline bool hit_leaf(const BvhView& bvh, const TraversalRay& r, const LeafRay<N>& lr, uint32_t kind,
                     uint32_t start, uint32_t count, float& t, BvhHit& best,
                     const AlphaTable* alpha, int32_t object, const TraversalRay* world) {
    uint32_t lane = best.lane;
    if (kind == kLeafTriangles) {
        if (!hit_triangle_leaf<kAnyHit>(bvh, r, lr, start, count, t, lane, alpha, object, world))
            return false;
        if constexpr (!kAnyHit) best = {kLeafTriangles, lane, -1};
        return true;
    }
    if constexpr (kTop) {
        if (kind == kLeafSpheres) {
            if (!hit_sphere_leaf<kAnyHit>(bvh, lr, start, count, t, lane)) return false;
            if constexpr (!kAnyHit) best = {kLeafSpheres, lane, -1};
            return true;
        }
        bool any = false;
        const Ray<float> ray1{{r.o[0], r.o[1], r.o[2]}, {r.d[0], r.d[1], r.d[2]}};
        for (uint32_t j = start; j < start + count; ++j) {
            const uint32_t item = bvh.items[j];
            if (kind == kLeafQuadrics) {
                const float* q = bvh.quadrics + 16 * size_t(item);
                const QuadricCoefficients<float> c{q[0], q[1], q[2], q[3], q[4],
                                                   q[5], q[6], q[7], q[8], q[9]};
                float th;
                if (!intersect_quadric(ray1, c, Vec3f(q[10], q[11], q[12]),
                                       Vec3f(q[13], q[14], q[15]), t, th))
                    continue;
                if constexpr (kAnyHit) return true;
                any = true;
                t = th, best = {kLeafQuadrics, item, -1};
            } else {
                const BvhInstance& inst = bvh.instances[item];
                const Vec3f o = affine_point(inst.to_object, r.o);
                const Vec3f d = linear_map(inst.to_object, 4, r.d);
                const TraversalRay local = make_traversal_ray(o, d);
                BvhHit h;
                if (!traverse<kAnyHit, N, false>(*inst.geometry, local, t, h, alpha,
                                                 int32_t(inst.mesh), &r))
                    continue;
                if constexpr (kAnyHit) return true;
                any = true;
                best = {kLeafTriangles, h.lane, int32_t(item)};
            }
        }
        return any;
    }
    return false;
}

// ---- Nodes ---------------------------------------------------------------------------------
// A ray in every lane, as the node test reads it: origin, reciprocal direction, the far
// planes' reciprocal scaled by kBvhFarScale once (Ize's robust far distances), and where
// each axis' near and far plane's row starts in a node's bounds (as float offsets, which the
// loads take as they are: row numbers cost a scaling per row and node, 3% of the traversal's
// instructions).
template <class N>
struct NodeRay {
    N org[3], inv[3], inv_far[3];
    size_t near_at[3], far_at[3];
};

template <class N>
inline NodeRay<N> make_node_ray(const TraversalRay& r) {
    NodeRay<N> n;
    for (int k = 0; k < 3; ++k) {
        n.org[k] = N(r.o[k]), n.inv[k] = N(r.inv[k]), n.inv_far[k] = N(r.inv[k] * kBvhFarScale);
        n.near_at[k] = size_t(std::signbit(r.inv[k]) ? k + 3 : k) * kWideBvhWidth;
        n.far_at[k] = size_t(std::signbit(r.inv[k]) ? k : k + 3) * kWideBvhWidth;
    }
    return n;
}

// The node test, the one of every single-ray traverser: the robust slab test of a node's
// children over [0, t] (a NaN distance leaves the interval as it was; far distances scaled
// by kBvhFarScale). Returns the slots entered (bit i: child i) and writes each child's entry
// distance. Unused slots have empty boxes (min +inf, max -inf), which no ray enters, but a
// NaN direction leaves every interval as it was: they are masked off too.
template <class N>
inline uint32_t enter_children(const NodeRay<N>& n, const WideBvhNode& node, float t,
                               float entry[kWideBvhWidth]) {
    constexpr int kLanes = kNodeLanes<N>;
    uint32_t enter = 0;
    for (int at = 0; at < kWideBvhWidth; at += kLanes) {
        N t0(0.0f), t1(t);
        for (int k = 0; k < 3; ++k) {
            const N near = load_lanes<N>(node.bounds[0] + n.near_at[k] + at);
            const N far = load_lanes<N>(node.bounds[0] + n.far_at[k] + at);
            t0 = slab_max((near - n.org[k]) * n.inv[k], t0);
            t1 = slab_min((far - n.org[k]) * n.inv_far[k], t1);
        }
        enter |= mask_bits(t0 <= t1) << at;
        store_lanes(t0, entry + at);
    }
    return enter & ((1u << node.slots) - 1u);
}

// Every cache line of `bytes` from p, into the caches.
inline void prefetch_lines(const void* p, size_t bytes) {
    const char* c = static_cast<const char*>(p);
    const char* end = c + bytes;
    for (c = reinterpret_cast<const char*>(reinterpret_cast<uintptr_t>(c) & ~uintptr_t(63));
         c < end; c += 64)
        __builtin_prefetch(c);
}

// What a ray goes on to read after entering the slots `enter` of `node`: the inner
// children's nodes (4 lines each) and the blocks of the leaves entered, their first 4 lines,
// or with `whole` every line of them. (Four fixed prefetches, not a loop over the lines, for
// the single-ray traversal: a loop cost it a tenth more instructions. A quadric or instance
// leaf's address is no block's, and prefetching it is harmless.)
inline void prefetch_children(const BvhView& bvh, const WideBvhNode& node, uint32_t enter,
                              bool whole) {
    for (uint32_t bits = enter; bits; bits &= bits - 1) {
        const int i = std::countr_zero(bits);
        const bool leaf = (node.leaves >> i) & 1u;
        const bool triangles = node.kind[i] == kLeafTriangles;
        const char* p =
            !leaf ? reinterpret_cast<const char*>(bvh.nodes + node.child[i])
            : triangles ? reinterpret_cast<const char*>(bvh.triangles + node.child[i])
                        : reinterpret_cast<const char*>(bvh.spheres + node.child[i]);
        if (whole && leaf) {
            const uint32_t blocks = (node.count[i] + kWideBvhWidth - 1) / kWideBvhWidth;
            prefetch_lines(p, blocks * (triangles ? sizeof(TriangleBlock) : sizeof(SphereBlock)));
            continue;
        }
        __builtin_prefetch(p);
        __builtin_prefetch(p + 64);
        __builtin_prefetch(p + 128);
        __builtin_prefetch(p + 192);
    }
}

// The inner children of `enter` after a node test: the nearest into `next` (the first in
// slot order, for any hit), the others pushed onto `stack` (size updated), for closest hit
// sorted by entry distance with the nearest on top. Whether there was one.
template <bool kAnyHit, class Entry>
inline bool push_children(const WideBvhNode& node, uint32_t enter, const float entry[kWideBvhWidth],
                          Entry& next, Entry* stack, int& size) {
    if (enter == 0) return false;
    int i = std::countr_zero(enter);
    next = {node.child[i], entry[i]};
    const int base = size;
    for (enter &= enter - 1; enter; enter &= enter - 1) {
        i = std::countr_zero(enter);
        Entry other{node.child[i], entry[i]};
        if constexpr (!kAnyHit)
            if (other.t < next.t) std::swap(other, next);
        int j = size++;
        if constexpr (!kAnyHit)
            for (; j > base && stack[j - 1].t < other.t; --j) stack[j] = stack[j - 1];
        stack[j] = other;
    }
    return true;
}

// An entry of a traversal stack: an inner node and where the ray enters its box.
struct TraversalEntry {
    uint32_t node;
    float t;
};

// ---- Traversal -----------------------------------------------------------------------------
// (kPrefetchAbove, kernels/bvh/bvh_layout.h: skipping the prefetch in small trees made renders of
// a 36-node tree up to 7% faster on a Xeon, AVX-512, a 22-node one unchanged, and of a
// 401-node mesh tree, 820 kB, instanced 100 times, 3%; on the 6,609-node tree of a
// 200k-triangle mesh, 13.6 MB, the prefetch made traversal 14% faster on a Zen 3, AVX2, and
// was neutral on that Xeon.)

// A ray through the tree. A node's children are tested at once (enter_children). The leaves
// entered are tested there and then, in slot order, each unless a hit so far is nearer than
// its box: that spares them the stack, and their hits shorten the interval before any inner
// child is visited. The inner children entered go on the stack with their entry distance,
// the nearest on top for closest hit (push_children), and one popped beyond the closest hit
// so far is dropped. Leaves are tested by hit_leaf.
// Closest hit: whether anything is hit in (0, tmax), then tmax and `hit`: the nearest, and
// on a tie the first found. Any hit (kAnyHit): whether anything is, stopping at the first.
// `root`: the node to start from (a ray stream's subtree, kernels/bvh/traverse_stream.h).
// The interleaved traversal of many rays (kernels/bvh/traverse_group.h) takes each ray through
// exactly these steps, and so finds the same hits.
// (flatten: the kernels are inlined, so the identity picks below fold away.)
template <bool kAnyHit, class N, bool kTop>
[[gnu::flatten]] bool traverse(const BvhView& bvh, const TraversalRay& r, float& tmax,
                               BvhHit& hit, const AlphaTable* alpha, int32_t object,
                               const TraversalRay* world, uint32_t root) {
    if (bvh.node_count == 0) return false;
    const NodeRay<N> nr = make_node_ray<N>(r);
    const LeafRay<N> lr = make_leaf_ray<N>(r);
    float t = tmax;  // the closest hit so far (a local: the stack cannot alias it)
    BvhHit best{0, 0, -1};
    bool found = false;

    TraversalEntry stack[kWideBvhStackSize];
    int size = 0;
    TraversalEntry e{root, 0.0f};
    const bool prefetch = uint32_t(bvh.node_count) > kPrefetchAbove;
    for (;;) {
        const WideBvhNode& node = bvh.nodes[e.node];
        alignas(32) float entry[kWideBvhWidth];
        uint32_t enter = enter_children(nr, node, t, entry);
        // What the ray goes on to read is fetched now (a traversal of a big tree waits
        // mostly on memory; a small one stays in the caches, where the prefetches only cost)
        if (prefetch) prefetch_children(bvh, node, enter, false);
        // The leaves entered, in slot order
        for (uint32_t leaves = enter & node.leaves; leaves; leaves &= leaves - 1) {
            const int i = std::countr_zero(leaves);
            if constexpr (!kAnyHit)
                if (entry[i] > t) continue;
            if (hit_leaf<kAnyHit, N, kTop>(bvh, r, lr, node.kind[i], node.child[i],
                                           node.count[i], t, best, alpha, object, world)) {
                if constexpr (kAnyHit) return true;
                found = true;
            }
        }
        // Into the nearest inner child entered, unless the leaves hit nearer than its box;
        // else the top of the stack, dropping boxes entered beyond the closest hit
        if (push_children<kAnyHit>(node, enter & ~node.leaves, entry, e, stack, size) &&
            e.t <= t)
            continue;
        do {
            if (size == 0) {
                if (found) tmax = t, hit = best;
                return found;
            }
            e = stack[--size];
        } while (e.t > t);
    }
}

// ---- Unbounded primitives ------------------------------------------------------------------
// Planes and quadrics without a finite box, the short list tested beside the tree, for one
// ray (T = float) or K rays (a batch). plane(j) gives plane j's normal and distance,
// quadric(j) the j-th unbounded quadric (coefficients, box, scene index) in lanes of T.
template <class T>
struct PlaneLanes {
    Vec3<T> n;
    T d;
};
template <class T>
struct QuadricOfLanes {
    QuadricCoefficients<T> q;
    Vec3<T> lo, hi;
    int32_t index;
};

// Closest hit below t: t and id updated where one is nearer (id = plane_id + j for plane j,
// quadric_id + index for a quadric).
template <class T, class Planes, class Quadrics>
void closest_unbounded(const Ray<T>& ray, T& t, I32<T>& id, int32_t plane_count,
                       const Planes& plane, int32_t plane_id, int32_t quadric_count,
                       const Quadrics& quadric, int32_t quadric_id) {
    using I = I32<T>;
    T th;
    I next(plane_id);  // counted up with j rather than broadcast
    for (int32_t j = 0; j < plane_count; ++j) {
        const PlaneLanes<T> p = plane(j);
        const auto hit = intersect_plane(ray, p.n, p.d, t, th);
        t = select(hit, th, t);
        id = select(mask_i32(hit), next, id);
        next += I(1);
    }
    for (int32_t j = 0; j < quadric_count; ++j) {
        const QuadricOfLanes<T> q = quadric(j);
        const auto hit = intersect_quadric(ray, q.q, q.lo, q.hi, t, th);
        t = select(hit, th, t);
        id = select(mask_i32(hit), I(quadric_id + q.index), id);
    }
}

// Whether an unbounded primitive blocks each ray within tmax; stops once all are blocked.
template <class T, class Planes, class Quadrics>
Mask<T> occluded_unbounded(const Ray<T>& ray, const T& tmax, Mask<T> blocked,
                           int32_t plane_count, const Planes& plane, int32_t quadric_count,
                           const Quadrics& quadric) {
    T th;
    for (int32_t j = 0; j < plane_count && !all(blocked); ++j) {
        const PlaneLanes<T> p = plane(j);
        blocked = blocked | intersect_plane(ray, p.n, p.d, tmax, th);
    }
    for (int32_t j = 0; j < quadric_count && !all(blocked); ++j) {
        const QuadricOfLanes<T> q = quadric(j);
        blocked = blocked | intersect_quadric(ray, q.q, q.lo, q.hi, tmax, th);
    }
    return blocked;
}

// ---- Packets -------------------------------------------------------------------------------
// K rays at a time through the tree, each node's children tested by all rays at once (one
// child box broadcast), the primitives of a leaf that any ray enters broadcast to all rays.
// It pays where the rays go the same way: a one-node tree (a scene of a few dozen
// primitives at most, which every ray enters: the report's linear loop over the
// primitives, with boxes), and camera rays of neighbouring pixels. Whether a tree is one
// node without instances (then every batch takes this path; rays that scatter into an
// instance's deeper tree go one by one):
inline bool packet_tree(const BvhView& bvh) {
    return bvh.node_count == 1 && bvh.instance_count == 0;
}

// The smallest lane of v.
template <class T>
float lane_min(const T& v) {
    if constexpr (std::is_same_v<T, float>) {
        return v;
    } else {
        alignas(64) float a[T::size];
        v.store_aligned(a);
        float m = a[0];
        for (size_t i = 1; i < T::size; ++i) m = a[i] < m ? a[i] : m;
        return m;
    }
}

// Whether K rays are coherent enough for a packet: one origin (a pinhole camera's rays).
template <class T>
bool coherent(const Ray<T>& ray) {
    if constexpr (std::is_same_v<T, float>) {
        return true;
    } else {
        const auto same = [](const T& v) { return all(v == T(v.get(0))); };
        return same(ray.o.x) && same(ray.o.y) && same(ray.o.z);
    }
}

// K rays (T lanes; inv: reciprocal directions, shear: the watertight kernel's per-ray
// shear) through the tree; an instance maps them all into its space and takes them through
// its mesh's tree (kTop = false there). Closest hit: the lanes hit below t, with t, kind (a
// BvhLeafKind), lane (block lane, or quadric index) and instance (-1: none) updated where
// nearer; inner children are visited nearest first (by the
// nearest entry of any ray) and skipped once every ray has a hit before their box. Any hit
// (kAnyHit): the lanes hit below t, stopping once every active lane is.
template <bool kAnyHit, class T, bool kTop = true>
Mask<T> packet_traverse(const BvhView& bvh, const Ray<T>& ray, const Vec3<T>& inv,
                        const RayShear<T>& shear, Mask<T> active, T& t, I32<T>& kind,
                        I32<T>& lane, I32<T>& instance, const AlphaTable* alpha = nullptr,
                        int32_t object = -1, const Ray<T>* world = nullptr) {
    using I = I32<T>;
    Mask<T> hit(false);
    if (bvh.node_count == 0 || none(active)) return hit;
    const T o[3] = {ray.o.x, ray.o.y, ray.o.z}, r[3] = {inv.x, inv.y, inv.z};
    T r_far[3];
    Mask<T> forward[3];
    for (int k = 0; k < 3; ++k) r_far[k] = r[k] * T(kBvhFarScale), forward[k] = r[k] >= T(0.0f);

    // One leaf for the rays `enter`
    const auto test_leaf = [&](const WideBvhNode& node, uint32_t i, const Mask<T>& enter) {
        const uint32_t start = node.child[i], count = node.count[i];
        for (uint32_t j = 0; j < count; ++j) {
            T th(0.0f);
            Mask<T> h(false);
            uint32_t id = 0;
            if (node.kind[i] == kLeafTriangles) {
                id = start * kWideBvhWidth + j;
                const float(*v)[kWideBvhWidth] = bvh.triangles[id / kWideBvhWidth].v;
                const uint32_t l = id % kWideBvhWidth;
                const auto vertex = [&](int k) {
                    return Vec3<T>(T(v[3 * k][l]), T(v[3 * k + 1][l]), T(v[3 * k + 2][l]));
                };
                T b1(0.0f), b2(0.0f);
                h = intersect_triangle(ray, shear, vertex(0), vertex(1), vertex(2), t, th, b1, b2);
                if (alpha && any(h & enter)) {
                    // (each ray's hit on the one triangle, lane by lane)
                    const uint32_t mesh = object >= 0 ? uint32_t(object) : bvh.triangle_mesh[id];
                    const uint32_t triangle = bvh.triangle_index[id];
                    const Ray<T>& w = world ? *world : ray;
                    alignas(64) float u[kWidth<T>], v[kWidth<T>], wo[3][kWidth<T>], wd[3][kWidth<T>];
                    store_lanes(b1, u), store_lanes(b2, v);
                    store_lanes(w.o.x, wo[0]), store_lanes(w.o.y, wo[1]), store_lanes(w.o.z, wo[2]);
                    store_lanes(w.d.x, wd[0]), store_lanes(w.d.y, wd[1]), store_lanes(w.d.z, wd[2]);
                    uint32_t keep = mask_bits(h & enter);
                    for (uint32_t bits = keep; bits; bits &= bits - 1) {
                        const int k = std::countr_zero(bits);
                        const float o1[3] = {wo[0][k], wo[1][k], wo[2][k]};
                        const float d1[3] = {wd[0][k], wd[1][k], wd[2][k]};
                        if (!alpha_keeps(*alpha, mesh, triangle, u[k], v[k], o1, d1))
                            keep &= ~(1u << k);
                    }
                    h = h & lanes_of_bits<T>(keep);
                }
            } else if (node.kind[i] == kLeafSpheres) {
                id = start * kWideBvhWidth + j;
                const float(*c)[kWideBvhWidth] = bvh.spheres[id / kWideBvhWidth].c;
                const uint32_t l = id % kWideBvhWidth;
                h = intersect_sphere(ray, Vec3<T>(T(c[0][l]), T(c[1][l]), T(c[2][l])), T(c[3][l]),
                                     t, th);
            } else if (kTop && node.kind[i] == kLeafInstances) {
                // The rays mapped into the instance's space (t is the same there), through
                // its mesh's tree
                id = bvh.items[start + j];
                const BvhInstance& in = bvh.instances[id];
                const float* m = in.to_object;
                const auto row = [&](int r, const Vec3<T>& v, bool point) {
                    const T x = fma(T(m[4 * r]), v.x, fma(T(m[4 * r + 1]), v.y, T(m[4 * r + 2]) * v.z));
                    return point ? x + T(m[4 * r + 3]) : x;
                };
                const Ray<T> local{{row(0, ray.o, true), row(1, ray.o, true), row(2, ray.o, true)},
                                   {row(0, ray.d, false), row(1, ray.d, false), row(2, ray.d, false)}};
                const Vec3<T> local_inv(T(1.0f) / local.d.x, T(1.0f) / local.d.y,
                                        T(1.0f) / local.d.z);
                I unused(0);
                if constexpr (kTop) {
                    h = packet_traverse<kAnyHit, T, false>(*in.geometry, local, local_inv,
                                                           make_ray_shear(local.d), enter, t,
                                                           kind, lane, unused, alpha,
                                                           int32_t(in.mesh), &ray);
                }
                hit = hit | h;
                if constexpr (kAnyHit) {
                    if (all(hit | !active)) return true;
                } else {
                    instance = select(mask_i32(h), I(int32_t(id)), instance);
                }
                continue;
            } else {
                id = bvh.items[start + j];
                const float* q = bvh.quadrics + 16 * size_t(id);
                const QuadricCoefficients<T> c{T(q[0]), T(q[1]), T(q[2]), T(q[3]), T(q[4]),
                                               T(q[5]), T(q[6]), T(q[7]), T(q[8]), T(q[9])};
                h = intersect_quadric(ray, c, Vec3<T>(T(q[10]), T(q[11]), T(q[12])),
                                      Vec3<T>(T(q[13]), T(q[14]), T(q[15])), t, th);
            }
            h = h & enter;
            hit = hit | h;
            if constexpr (kAnyHit) {
                if (all(hit | !active)) return true;
            } else {
                t = select(h, th, t);
                kind = select(mask_i32(h), I(int32_t(node.kind[i])), kind);
                lane = select(mask_i32(h), I(int32_t(id)), lane);
                instance = select(mask_i32(h), I(-1), instance);
            }
        }
        return false;
    };

    struct Entry {
        uint32_t node;
        float t;  // the nearest entry of any ray into its box
    };
    Entry stack[kWideBvhStackSize];
    int size = 0;
    Entry e{0, 0.0f};
    for (;;) {
        const WideBvhNode& node = bvh.nodes[e.node];
        const int base = size;
        for (uint32_t i = 0; i < node.slots; ++i) {
            // The child's box over [0, t] for every ray, the robust slab test
            T t0(0.0f), t1 = t;
            for (int k = 0; k < 3; ++k) {
                const T a = T(node.bounds[k][i]) - o[k], b = T(node.bounds[k + 3][i]) - o[k];
                const T near = select(forward[k], a, b) * r[k];
                const T far = select(forward[k], b, a) * r_far[k];
                t0 = select(near > t0, near, t0);
                t1 = select(far < t1, far, t1);
            }
            const Mask<T> enter = active & !(kAnyHit ? hit : Mask<T>(false)) & (t0 <= t1);
            if (none(enter)) continue;
            if ((node.leaves >> i) & 1u) {
                if (test_leaf(node, i, enter)) return hit;
                continue;
            }
            // An inner child: onto the stack, the nearest on top
            const float near = lane_min(select(enter, t0, T(kRayFar)));
            Entry other{node.child[i], near};
            int j = size++;
            if constexpr (!kAnyHit)
                for (; j > base && stack[j - 1].t < other.t; --j) stack[j] = stack[j - 1];
            stack[j] = other;
        }
        // Next: the top of the stack, dropping boxes that every ray has a hit before
        do {
            if (size == 0) return hit;
            e = stack[--size];
        } while (!kAnyHit && all((t < T(e.t)) | !active));
    }
}

// ---- What was hit --------------------------------------------------------------------------
// The tree (the scene's, or an instance's mesh) whose block a triangle hit is in.
inline const BvhView& hit_tree(const BvhView& bvh, const BvhHit& h) {
    return h.instance < 0 ? bvh : *bvh.instances[h.instance].geometry;
}

// The Scene::meshes entry and the triangle index of a triangle hit.
inline uint32_t hit_mesh(const BvhView& bvh, const BvhHit& h) {
    return h.instance < 0 ? bvh.triangle_mesh[h.lane] : bvh.instances[h.instance].mesh;
}
inline uint32_t hit_triangle(const BvhView& bvh, const BvhHit& h) {
    return hit_tree(bvh, h).triangle_index[h.lane];
}

// The unit geometric normal of a triangle hit, in world space: the cross product of its
// edges (v1 - v0) × (v2 - v0), through an instance's inverse transpose.
inline Vec3f hit_triangle_normal(const BvhView& bvh, const BvhHit& h) {
    const float(*v)[kWideBvhWidth] = hit_tree(bvh, h).triangles[h.lane / kWideBvhWidth].v;
    const uint32_t j = h.lane % kWideBvhWidth;
    const Vec3f v0{v[0][j], v[1][j], v[2][j]}, v1{v[3][j], v[4][j], v[5][j]},
        v2{v[6][j], v[7][j], v[8][j]};
    Vec3f n = cross(v1 - v0, v2 - v0);
    if (h.instance >= 0) {
        const float c[3] = {n.x, n.y, n.z};
        n = linear_map(bvh.instances[h.instance].normal_to_world, 3, c);
    }
    return normalize(n);
}

// The scene sphere of a sphere hit.
inline uint32_t hit_sphere(const BvhView& bvh, const BvhHit& h) { return bvh.sphere_index[h.lane]; }

}  // namespace CIERZO_ISA_NAMESPACE
}  // namespace cierzo
