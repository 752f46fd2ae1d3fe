// The one traversal of the scene BVH (layout in kernels/bvh/bvh_layout.h), for both integrators:
// one ray at a time through 8-wide nodes, templated on the lane type N that tests a node's
// children and a leaf block's primitives — `float` (one child at a time: the scalar
// reference) or an xsimd batch of 8 floats (or 4, twice: the wavefront). Every primitive
// kernel is the one of kernels/intersect.h and kernels/triangle.h, so the two integrators
// find the same hits. Also here: the short list of unbounded primitives (planes, unbounded
// quadrics) tested beside the tree, for one ray or K rays at once.
// The rays, lanes and leaf tests it builds on are in kernels/bvh/bvh_leaves.h.
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
#include "bvh_leaves.h"

namespace cierzo {
inline namespace CIERZO_ISA_NAMESPACE {

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

// Where axis k's near and far planes' row starts in a node's bounds (float offsets), for
// one ray (T = float) or K rays (a batch, the wavefront's WideRays) of reciprocal direction
// `inv`: the min row, or the max row where inv's sign bit is set.
template <class T>
inline I32<T> near_row(const T& inv, int k) {
    return select(as_int(inv) < I32<T>(0), I32<T>((k + 3) * kWideBvhWidth),
                  I32<T>(k * kWideBvhWidth));
}
template <class T>
inline I32<T> far_row(const T& inv, int k) {
    return select(as_int(inv) < I32<T>(0), I32<T>(k * kWideBvhWidth),
                  I32<T>((k + 3) * kWideBvhWidth));
}

template <class N>
inline NodeRay<N> make_node_ray(const TraversalRay& r) {
    NodeRay<N> n;
    for (int k = 0; k < 3; ++k) {
        n.org[k] = N(r.o[k]), n.inv[k] = N(r.inv[k]), n.inv_far[k] = N(r.inv[k] * kBvhFarScale);
        n.near_at[k] = size_t(near_row(r.inv[k], k)), n.far_at[k] = size_t(far_row(r.inv[k], k));
    }
    return n;
}

// The node test, the one of every single-ray traverser: the robust slab test of a node's
// children over [0, t] (a NaN distance leaves the interval as it was; far distances scaled
// by kBvhFarScale). Returns the slots entered (bit i: child i) and writes each child's entry
// distance. Unused slots have empty boxes (min +inf, max -inf), which no ray with a finite
// origin and direction enters; a NaN one enters them, and finds empty leaves there
// (kernels/bvh/bvh_layout.h), so no per-visit mask of the slots in use is needed.
template <class N>
inline uint32_t enter_children(const NodeRay<N>& n, const WideBvhNode& node, float t,
                               float entry[kWideBvhWidth]) {
    constexpr int kLanes = kNodeLanes<N>;
    uint32_t enter = 0;
    for (int at = 0; at < kWideBvhWidth; at += kLanes) {
        N t0(0.0f), t1(t);
        for (int k = 0; k < 3; ++k) {
            const N near = load_lanes<N>(node.bounds + n.near_at[k] + at);
            const N far = load_lanes<N>(node.bounds + n.far_at[k] + at);
            t0 = slab_max((near - n.org[k]) * n.inv[k], t0);
            t1 = slab_min((far - n.org[k]) * n.inv_far[k], t1);
        }
        enter |= mask_bits(t0 <= t1) << at;
        store_lanes(t0, entry + at);
    }
    return enter;
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
        const char* p = !leaf       ? reinterpret_cast<const char*>(bvh.nodes + node.child[i])
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
// The stack and entry distances live in `scratch` (the tree's half; an instance's tree, with
// kTop = false, the other).
// (flatten: the kernels are inlined, so the identity picks below fold away.)
// `ray`: a TraversalRay, or a view of one set up with others in a batch (the wavefront's
// LaneRay), which gives its node and leaf lanes (make_node_ray, make_leaf_ray) and the whole
// ray (traversal_ray) by overloads of its own.
template <bool kAnyHit, class N, bool kTop, class R>
[[gnu::flatten]] bool traverse_in(const BvhView& bvh, const R& ray, float& tmax, BvhHit& hit,
                                  TraversalScratch& scratch, const AlphaTable* alpha,
                                  int32_t object, const TraversalRay* world, uint32_t root) {
    if (bvh.node_count == 0) return false;
    const NodeRay<N> nr = make_node_ray<N>(ray);
    const LeafRay<N> lr = make_leaf_ray<N>(ray);
    const auto& r = traversal_ray(ray);
    float t = tmax;  // the closest hit so far (a local: the stack cannot alias it)
    BvhHit best{0, 0, -1};
    bool found = false;

    TraversalEntry* const stack = scratch.stack[kTop ? 0 : 1];
    float* const entry = scratch.entry[kTop ? 0 : 1];
    int size = 0;
    TraversalEntry e{root, 0.0f};
    const bool prefetch = uint32_t(bvh.node_count) > kPrefetchAbove;
    for (;;) {
        const WideBvhNode& node = bvh.nodes[e.node];
        uint32_t enter = enter_children(nr, node, t, entry);
        // What the ray goes on to read is fetched now (a traversal of a big tree waits
        // mostly on memory; a small one stays in the caches, where the prefetches only cost)
        if (prefetch) prefetch_children(bvh, node, enter, false);
        // The leaves entered, in slot order
        for (uint32_t leaves = enter & node.leaves; leaves; leaves &= leaves - 1) {
            const int i = std::countr_zero(leaves);
            if constexpr (!kAnyHit)
                if (entry[i] > t) continue;
            if (hit_leaf<kAnyHit, N, kTop>(bvh, r, lr, node.kind[i], node.child[i], node.count[i],
                                           t, best, alpha, object, world, scratch)) {
                if constexpr (kAnyHit) return true;
                found = true;
            }
        }
        // Into the nearest inner child entered, unless the leaves hit nearer than its box;
        // else the top of the stack, dropping boxes entered beyond the closest hit
        if (push_children<kAnyHit>(node, enter & ~node.leaves, entry, e, stack, size) && e.t <= t)
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

// traverse_in with its memory on the stack, for callers that trace a ray now and then (the
// scalar reference, tests); a thread that traces many keeps one TraversalScratch.
template <bool kAnyHit, class N, bool kTop = true>
bool traverse(const BvhView& bvh, const TraversalRay& r, float& tmax, BvhHit& hit,
              const AlphaTable* alpha = nullptr, int32_t object = -1,
              const TraversalRay* world = nullptr, uint32_t root = 0) {
    TraversalScratch scratch;
    return traverse_in<kAnyHit, N, kTop>(bvh, r, tmax, hit, scratch, alpha, object, world, root);
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
Mask<T> occluded_unbounded(const Ray<T>& ray, const T& tmax, Mask<T> blocked, int32_t plane_count,
                           const Planes& plane, int32_t quadric_count, const Quadrics& quadric) {
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
                        const RayShear<T>& shear, Mask<T> active, T& t, I32<T>& kind, I32<T>& lane,
                        I32<T>& instance, const AlphaTable* alpha = nullptr, int32_t object = -1,
                        const Ray<T>* world = nullptr) {
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
                    alignas(64) float u[kWidth<T>], v[kWidth<T>], wo[3][kWidth<T>],
                        wd[3][kWidth<T>];
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
                    const T x =
                        fma(T(m[4 * r]), v.x, fma(T(m[4 * r + 1]), v.y, T(m[4 * r + 2]) * v.z));
                    return point ? x + T(m[4 * r + 3]) : x;
                };
                const Ray<T> local{
                    {row(0, ray.o, true), row(1, ray.o, true), row(2, ray.o, true)},
                    {row(0, ray.d, false), row(1, ray.d, false), row(2, ray.d, false)}};
                const Vec3<T> local_inv(T(1.0f) / local.d.x, T(1.0f) / local.d.y,
                                        T(1.0f) / local.d.z);
                I unused(0);
                if constexpr (kTop) {
                    h = packet_traverse<kAnyHit, T, false>(
                        *in.geometry, local, local_inv, make_ray_shear(local.d), enter, t, kind,
                        lane, unused, alpha, int32_t(in.mesh), &ray);
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
                const T a = T(node.bounds[k * kWideBvhWidth + i]) - o[k];
                const T b = T(node.bounds[(k + 3) * kWideBvhWidth + i]) - o[k];
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
