// The scene BVH's leaves as every traverser tests them (kernels/bvh/traverse.h): the ray set
// up for traversal and its lanes, the alpha cut-outs' filter, and the one leaf test (triangle
// and sphere blocks, quadrics one at a time, an instance through its own tree).
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
    uint32_t kind;     // BvhLeafKind
    uint32_t lane;     // triangles, spheres: block lane (8 * block + lane); quadric: its index
    int32_t instance;  // the instance a triangle was hit through, or -1
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
[[gnu::noinline]] inline float alpha_at(const AlphaTable& table, uint32_t mesh, uint32_t triangle,
                                        float b1, float b2) {
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
        if (!alpha_keeps(table, mesh, triangle, u[h], v[h], world.o, world.d)) hits &= ~(1u << h);
    }
    return hits;
}

// ---- Leaves --------------------------------------------------------------------------------
// A ray in every lane, as the triangle leaves read it: the origin with its axes already
// permuted (kx, ky, kz), the shear's factors, and where in a block the rows of the permuted axes
// start (`row_at[j]`: axis[j] rows in, as a byte offset, so a block's vertex k, axis j is one load
// at block + row_at[j] + 3k rows: the permutation costs no address arithmetic per block). (Sphere
// leaves broadcast the plain ray when they are entered.)
template <class N>
struct LeafRay {
    Ray<N> tri;
    N sx, sy, sz;
    size_t row_at[3];
};

template <class N>
inline LeafRay<N> make_leaf_ray(const TraversalRay& r) {
    const int32_t* axis = r.axis;
    constexpr size_t kRow = sizeof(TriangleBlock::v[0]);
    return {{{N(r.o[axis[0]]), N(r.o[axis[1]]), N(r.o[axis[2]])}, Vec3<N>(N(0.0f))},
            N(r.shear[0]),
            N(r.shear[1]),
            N(r.shear[2]),
            {size_t(axis[0]) * kRow, size_t(axis[1]) * kRow, size_t(axis[2]) * kRow}};
}

// The ray a traversal was given, whole (for the leaves that read it: spheres, quadrics,
// instances, alpha masks); a batch's lane view has its own overload beside it.
inline const TraversalRay& traversal_ray(const TraversalRay& r) { return r; }

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
    // (the vertices are handed to the kernel with their axes permuted as the origin is, so
    // its per-lane picks are the identity, built here as constants that fold away)
    const Mask<N> yes(true), no(false);
    const RayShear<N> shear{I32<N>(0), I32<N>(1), I32<N>(2), {yes, no}, {no, yes},
                            {no, no},  lr.sx,     lr.sy,     lr.sz};
    bool any = false;
    const uint32_t blocks = (count + kWideBvhWidth - 1) / kWideBvhWidth;
    for (uint32_t j = start; j < start + blocks; ++j) {
        const char* block = reinterpret_cast<const char*>(bvh.triangles + j);
        const float* x = reinterpret_cast<const float*>(block + lr.row_at[0]);
        const float* y = reinterpret_cast<const float*>(block + lr.row_at[1]);
        const float* z = reinterpret_cast<const float*>(block + lr.row_at[2]);
        for (int at = 0; at < kWideBvhWidth; at += kLanes) {
            const auto vertex = [&](int k) {
                const int r = 3 * k * kWideBvhWidth + at;
                return Vec3<N>(load_lanes<N>(x + r), load_lanes<N>(y + r), load_lanes<N>(z + r));
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
inline bool hit_sphere_leaf(const BvhView& bvh, const TraversalRay& r, uint32_t start,
                            uint32_t count, float& t, uint32_t& lane) {
    constexpr int kLanes = kNodeLanes<N>;
    const Ray<N> ray{{N(r.o[0]), N(r.o[1]), N(r.o[2])}, {N(r.d[0]), N(r.d[1]), N(r.d[2])}};
    bool any = false;
    const uint32_t blocks = (count + kWideBvhWidth - 1) / kWideBvhWidth;
    for (uint32_t j = start; j < start + blocks; ++j) {
        const float(*c)[kWideBvhWidth] = bvh.spheres[j].c;
        for (int at = 0; at < kWideBvhWidth; at += kLanes) {
            const Vec3<N> centre(row<N>(c, 0, at), row<N>(c, 1, at), row<N>(c, 2, at));
            N th(0.0f);
            const uint32_t hits =
                mask_bits(intersect_sphere(ray, centre, row<N>(c, 3, at), N(t), th));
            if (hits == 0) continue;
            if constexpr (kAnyHit) return true;
            any = true;
            nearest_lane(hits, th, j * kWideBvhWidth + uint32_t(at), t, lane);
        }
    }
    return any;
}

// An entry of a traversal stack: an inner node and where the ray enters its box.
struct TraversalEntry {
    uint32_t node;
    float t;
};

// A single-ray traversal's memory, sized once and kept by its caller (a thread's batch of
// rays, a group of rays in flight), so that tracing a ray sets up no stack frame of its own:
// the node test's entry distances and the stack, of the tree [0] and of an instance's tree
// entered from it [1].
struct alignas(64) TraversalScratch {
    float entry[2][kWideBvhWidth];
    TraversalEntry stack[2][kWideBvhStackSize];
};

template <bool kAnyHit, class N, bool kTop = true, class R = TraversalRay>
[[gnu::flatten]] bool traverse_in(const BvhView& bvh, const R& ray, float& tmax, BvhHit& hit,
                                  TraversalScratch& scratch, const AlphaTable* alpha = nullptr,
                                  int32_t object = -1, const TraversalRay* world = nullptr,
                                  uint32_t root = 0);

// One leaf of any kind (kind, start, count: a node's slot) for ray r (lr: in every lane):
// whether it is hit below t; closest hit: t and `best` updated to the nearest, the first on a
// tie. The one leaf test of every traverser: triangle and sphere blocks as above, quadrics
// one at a time, an instance by mapping the ray into its space (t is unchanged there) and
// traversing its mesh's tree (kTop = false: a mesh's tree holds triangles only) in
// `scratch`'s second half.
template <bool kAnyHit, class N, bool kTop>
inline bool hit_leaf(const BvhView& bvh, const TraversalRay& r, const LeafRay<N>& lr, uint32_t kind,
                     uint32_t start, uint32_t count, float& t, BvhHit& best,
                     const AlphaTable* alpha, int32_t object, const TraversalRay* world,
                     TraversalScratch& scratch) {
    uint32_t lane = best.lane;
    if (kind == kLeafTriangles) {
        if (!hit_triangle_leaf<kAnyHit>(bvh, r, lr, start, count, t, lane, alpha, object, world))
            return false;
        if constexpr (!kAnyHit) best = {kLeafTriangles, lane, -1};
        return true;
    }
    if constexpr (kTop) {
        if (kind == kLeafSpheres) {
            if (!hit_sphere_leaf<kAnyHit, N>(bvh, r, start, count, t, lane)) return false;
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
                if (!traverse_in<kAnyHit, N, false>(*inst.geometry, local, t, h, scratch, alpha,
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

}  // namespace CIERZO_ISA_NAMESPACE
}  // namespace cierzo
