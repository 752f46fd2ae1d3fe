// Wavefront stage 2, closest hit: K rays at a time against every sphere, plane and quadric
// of the scene (one primitive broadcast to all lanes, in the scalar reference's order), then
// each ray that enters a mesh's box through the mesh's 8-wide BVH on its own (all children
// of a node tested at once). Records t and the primitive id; the shadow stage's any-hit
// test is here too.
#pragma once

#include <type_traits>

#include "integrators/wavefront/wave.h"
#include "kernels/triangle.h"

namespace cierzo {
inline namespace CIERZO_ISA_NAMESPACE {

// Sphere or plane j from its lane table (FlatScene::sphere_lanes, plane_lanes): the centre
// and radius, or the normal and distance.
template <class F>
struct PrimitiveLanes {
    Vec3<F> xyz;
    F w;
    PrimitiveLanes(const float* table, int32_t j) {
        const float* v = table + 64 * j;
        xyz = {F::load_aligned(v), F::load_aligned(v + 16), F::load_aligned(v + 32)};
        w = F::load_aligned(v + 48);
    }
};

// Quadric j's coefficients and clipping box from the lane table (FlatScene::quadric_lanes).
template <class F>
struct QuadricLanes {
    QuadricCoefficients<F> q;
    Vec3<F> lo, hi;
    QuadricLanes(const float* table, int32_t j) {
        const float* v = table + 256 * j;
        auto at = [&](int k) { return F::load_aligned(v + 16 * k); };
        q = {at(0), at(1), at(2), at(3), at(4), at(5), at(6), at(7), at(8), at(9)};
        lo = {at(10), at(11), at(12)};
        hi = {at(13), at(14), at(15)};
    }
};

// Closest analytic hit of K rays; `prim` is left as it was where nothing is hit.
template <class A>
void closest_analytic(const FlatScene& s, const Ray<typename Wave<A>::F>& ray,
                      typename Wave<A>::F& t, typename Wave<A>::I& prim) {
    using F = typename Wave<A>::F;
    using I = typename Wave<A>::I;
    // id: (kind << kPrimShift) | j in every lane, counted up with j rather than broadcast
    auto record = [&](const auto& hit, const F& th, I& id) {
        t = select(hit, th, t);
        prim = select(mask_i32(hit), id, prim);
        id += I(1);
    };
    F th;
    I id(kPrimSphere << kPrimShift);
    for (int32_t j = 0; j < s.sphere_count; ++j) {
        const PrimitiveLanes<F> q(s.sphere_lanes, j);
        record(intersect_sphere(ray, q.xyz, q.w, t, th), th, id);
    }
    id = I(kPrimPlane << kPrimShift);
    for (int32_t j = 0; j < s.plane_count; ++j) {
        const PrimitiveLanes<F> q(s.plane_lanes, j);
        record(intersect_plane(ray, q.xyz, q.w, t, th), th, id);
    }
    id = I(kPrimQuadric << kPrimShift);
    for (int32_t j = 0; j < s.quadric_count; ++j) {
        const QuadricLanes<F> ql(s.quadric_lanes, j);
        record(intersect_quadric(ray, ql.q, ql.lo, ql.hi, t, th), th, id);
    }
}

// The lanes one ray tests a node's 8 children or a leaf's 8 triangles in: one AVX register
// where the ISA has one (the AVX-512 objects use 256-bit operations: 8 fill them), else two
// SSE registers.
template <class A>
using WideArch =
    std::conditional_t<(xsimd::batch<float, A>::size >= 8), xsimd::fma3<xsimd::avx2>, A>;

// K rays set up for the wide traversal, in SIMD: origins, reciprocal directions (zero
// components give +-inf) and the watertight kernel's shear (kernels/triangle.h: the axes
// kx, ky, kz and sx, sy, sz), each ray then traversed on its own.
template <class A>
struct WideRays {
    alignas(64) float o[3][Wave<A>::K], inv[3][Wave<A>::K], shear[3][Wave<A>::K];
    alignas(64) int32_t axis[3][Wave<A>::K];

    explicit WideRays(const Ray<typename Wave<A>::F>& ray) {
        using F = typename Wave<A>::F;
        const RayShear<F> s = make_ray_shear(ray.d);
        store3(ray.o, o[0], o[1], o[2], 0);
        store3(Vec3<F>(F(1.0f) / ray.d.x, F(1.0f) / ray.d.y, F(1.0f) / ray.d.z), inv[0], inv[1],
               inv[2], 0);
        store3(Vec3<F>(s.sx, s.sy, s.sz), shear[0], shear[1], shear[2], 0);
        s.kx.store_aligned(axis[0]), s.ky.store_aligned(axis[1]), s.kz.store_aligned(axis[2]);
    }
};

// The robust slab test of the K rays against a box (min x, y, z, max x, y, z) over [0, t], as
// in the BVH traversals: a NaN distance leaves the interval as it was; far distances are
// scaled by kBvhFarScale. Returns the lanes whose interval meets the box.
template <class A>
typename Wave<A>::M slab_hits(const float box[6], const WideRays<A>& rays,
                              const typename Wave<A>::F& t) {
    using F = typename Wave<A>::F;
    F t0(0.0f), t1 = t;
    for (int k = 0; k < 3; ++k) {
        const F org = F::load_aligned(rays.o[k]), inv = F::load_aligned(rays.inv[k]);
        const F a = (F(box[k]) - org) * inv;
        const F b = (F(box[k + 3]) - org) * inv;
        const auto forward = inv >= F(0.0f);
        const F near = select(forward, a, b), far = select(forward, b, a) * F(kBvhFarScale);
        t0 = select(near > t0, near, t0);
        t1 = select(far < t1, far, t1);
    }
    return t0 <= t1;
}

// Ray `l` of `rays` through a mesh's 8-wide BVH (scene/wide_bvh.h). A node's children are
// tested at once with the slab test of the binary traversal (src/scene/bvh.cpp). The leaves
// entered are tested there and then, in slot order, each unless a hit so far is nearer than
// its box: that spares them the stack, and their hits shorten the interval before any inner
// child is visited. The inner children entered go on the stack with their entry distance,
// the nearest on top for closest hit, and one popped beyond the closest hit so far is
// dropped (as re-testing its box would). A leaf's triangles are tested 8 at a time with the
// watertight kernel, the ray broadcast and one triangle per lane.
// Closest hit: whether a triangle is hit in (0, tmax), then tmax and the hit's block lane
// (8 * block + lane): the nearest hit, and on a tie the first found; any hit (kAnyHit):
// whether anything is, stopping at the first.
// (flatten: the triangle kernel is inlined, so the identity picks below fold away.)
template <bool kAnyHit, class A>
[[gnu::flatten]] bool traverse_wide(const FlatMesh& mesh, const WideRays<A>& rays, int l,
                                    float& tmax, uint32_t& lane) {
    using N = xsimd::batch<float, WideArch<A>>;
    using B = xsimd::batch_bool<float, WideArch<A>>;
    using I = xsimd::batch<int32_t, WideArch<A>>;
    constexpr int kLanes = int(N::size);
    if (mesh.node_count == 0) return false;
    // The ray in every lane, and the bounds row of each axis' near and far plane
    N org[3], inv[3];
    int near_row[3], far_row[3];
    for (int k = 0; k < 3; ++k) {
        org[k] = N(rays.o[k][l]), inv[k] = N(rays.inv[k][l]);
        near_row[k] = std::signbit(rays.inv[k][l]) ? k + 3 : k;
        far_row[k] = std::signbit(rays.inv[k][l]) ? k : k + 3;
    }
    // The kernel's shear is the same in every lane, so the origin and the vertices are handed
    // to it with their axes already permuted (kx, ky, kz): its per-lane picks are then the
    // identity, and it computes exactly what it would unpermuted (it reads no direction)
    const int axis[3] = {rays.axis[0][l], rays.axis[1][l], rays.axis[2][l]};
    const Ray<N> ray{{N(rays.o[axis[0]][l]), N(rays.o[axis[1]][l]), N(rays.o[axis[2]][l])},
                     Vec3<N>(N(0.0f))};
    const B yes(true), no(false);
    const RayShear<N> shear{I(0), I(1), I(2), {yes, no}, {no, yes}, {no, no},
                            N(rays.shear[0][l]), N(rays.shear[1][l]), N(rays.shear[2][l])};
    float t = tmax;  // the closest hit so far (a local: the stack cannot alias it)
    uint32_t hit_lane = 0;
    bool found = false;

    // The triangles of blocks list[0, n) (from[j]: where the ray enters block j's leaf), a
    // register at a time; for closest hit, t and hit_lane updated (the nearest hit, the first
    // lane on a tie), and a block skipped when both it and the next are entered beyond the
    // closest hit so far (a hit there could not be nearer). Whether anything is hit.
    const auto test_blocks = [&](const uint32_t* list, const float* from, int n) {
        bool any = false;
        for (int j = 0; j < n; ++j) {
            if constexpr (!kAnyHit)
                if (from[j] > t && from[std::min(j + 1, n - 1)] > t) continue;
            const float(*v)[kWideBvhWidth] = mesh.blocks[list[j]].v;
            for (int at = 0; at < kWideBvhWidth; at += kLanes) {
                const auto vertex = [&](int k) {
                    return Vec3<N>(N::load_aligned(v[3 * k + axis[0]] + at),
                                   N::load_aligned(v[3 * k + axis[1]] + at),
                                   N::load_aligned(v[3 * k + axis[2]] + at));
                };
                N th(0.0f), b1(0.0f), b2(0.0f);
                uint32_t hits = mask_bits<WideArch<A>>(intersect_triangle(
                    ray, shear, vertex(0), vertex(1), vertex(2), N(t), th, b1, b2));
                if (hits == 0) continue;
                if constexpr (kAnyHit) return true;
                any = true;
                alignas(32) float ts[kLanes];
                th.store_aligned(ts);
                for (; hits; hits &= hits - 1) {
                    const uint32_t h = uint32_t(std::countr_zero(hits));
                    if (ts[h] < t) t = ts[h], hit_lane = list[j] * kWideBvhWidth + at + h;
                }
            }
        }
        return any;
    };

    struct Entry {
        uint32_t node;  // an inner node
        float t;        // where the ray enters its box
    };
    Entry stack[kWideBvhStackSize];
    int size = 0;
    Entry e{0, 0.0f};  // the root
    for (;;) {
        // The slab test of every child over [0, t]
        const WideBvhNode& node = mesh.nodes[e.node];
        alignas(32) float entry[kWideBvhWidth];
        uint32_t enter = 0;
        for (int at = 0; at < kWideBvhWidth; at += kLanes) {
            // (max(a, b) and min(a, b) are maxps and minps, a > b ? a : b and a < b ? a : b:
            // a NaN distance a leaves the interval as it was)
            N t0(0.0f), t1(t);
            for (int k = 0; k < 3; ++k) {
                const N near = N::load_aligned(node.bounds[near_row[k]] + at);
                const N far = N::load_aligned(node.bounds[far_row[k]] + at);
                t0 = max((near - org[k]) * inv[k], t0);
                t1 = min((far - org[k]) * inv[k] * N(kBvhFarScale), t1);
            }
            enter |= mask_bits<WideArch<A>>(t0 <= t1) << at;
            t0.store_aligned(entry + at);
        }
        enter &= (1u << node.slots) - 1u;
        // The leaves entered: their blocks, in slot order (a leaf has at most 2)
        if (uint32_t leaves = enter & node.leaves) {
            uint32_t list[kWideBvhWidth * 2];
            float from[kWideBvhWidth * 2];
            int n = 0;
            for (; leaves; leaves &= leaves - 1) {
                const int i = std::countr_zero(leaves);
                list[n] = node.child[i], from[n++] = entry[i];
                if (node.count[i] > kWideBvhWidth)
                    list[n] = node.child[i] + 1, from[n++] = entry[i];
            }
            if (test_blocks(list, from, n)) {
                if constexpr (kAnyHit) return true;
                found = true;
            }
            enter &= ~node.leaves;
        }
        if (enter != 0) {
            // Into the nearest inner child entered (the first, for any hit); the others onto
            // the stack, for closest hit sorted by entry distance with the nearest on top
            int i = std::countr_zero(enter);
            e = {node.child[i], entry[i]};
            const int base = size;
            for (enter &= enter - 1; enter; enter &= enter - 1) {
                i = std::countr_zero(enter);
                Entry other{node.child[i], entry[i]};
                if constexpr (!kAnyHit)
                    if (other.t < e.t) std::swap(other, e);
                int j = size++;
                if constexpr (!kAnyHit)
                    for (; j > base && stack[j - 1].t < other.t; --j) stack[j] = stack[j - 1];
                stack[j] = other;
            }
            // (the leaves may have hit nearer than every child entered: then the pops below
            // drop them all)
            if (e.t <= t) continue;
        }
        // Next: the top of the stack, dropping boxes entered beyond the closest hit
        do {
            if (size == 0) {
                if (found) tmax = t, lane = hit_lane;
                return found;
            }
            e = stack[--size];
        } while (e.t > t);
    }
}

// The closest mesh hits of batch `i`, after its analytic ones (in p.t and p.prim): for each
// mesh, the rays whose interval [0, t] meets the mesh's box go through its BVH one by one,
// and a hit writes t, primitive, mesh, triangle and the triangle's normal to the path.
template <class A>
void intersect_meshes(Wave<A>& w, int32_t i, const Ray<typename Wave<A>::F>& ray) {
    using F = typename Wave<A>::F;
    PathPool& p = w.pool;
    const FlatScene& s = w.scene;
    const WideRays<A> rays(ray);
    for (int32_t m = 0; m < s.mesh_count; ++m) {
        const FlatMesh& mesh = s.meshes[m];
        const F t = F::load_aligned(p.t + i);
        uint32_t enter = mask_bits(w.live_mask(i) & slab_hits<A>(mesh.bounds, rays, t));
        for (; enter; enter &= enter - 1) {
            const int l = std::countr_zero(enter);
            const int32_t q = i + l;
            uint32_t lane = 0;
            if (!traverse_wide<false, A>(mesh, rays, l, p.t[q], lane)) continue;
            // The hit triangle's normal from its vertices
            const float(*v)[kWideBvhWidth] = mesh.blocks[lane / kWideBvhWidth].v;
            const uint32_t j = lane % kWideBvhWidth;
            const Vec3f v0{v[0][j], v[1][j], v[2][j]}, v1{v[3][j], v[4][j], v[5][j]},
                v2{v[6][j], v[7][j], v[8][j]};
            const Vec3f n = normalize(cross(v1 - v0, v2 - v0));
            p.prim[q] = kPrimMesh << kPrimShift;
            p.mesh_nx[q] = n.x, p.mesh_ny[q] = n.y, p.mesh_nz[q] = n.z;
            p.mesh_id[q] = m;
            p.mesh_tri[q] = mesh.triangle_ids[lane];
        }
    }
}

// The closest hit of batch `i` (rays `ray`): t and the primitive id (-1: nothing) in
// registers, and in p.t and p.prim when the scene has meshes (their traversal goes through
// the pool one ray at a time).
template <class A>
void closest_hit(Wave<A>& w, int32_t i, const Ray<typename Wave<A>::F>& ray,
                 typename Wave<A>::F& t, typename Wave<A>::I& prim) {
    using F = typename Wave<A>::F;
    using I = typename Wave<A>::I;
    PathPool& p = w.pool;
    t = F(kRayFar);
    prim = I(-1);
    closest_analytic<A>(w.scene, ray, t, prim);
    if (w.scene.features.meshes) {
        t.store_aligned(p.t + i);
        prim.store_aligned(p.prim + i);
        intersect_meshes(w, i, ray);
        t = F::load_aligned(p.t + i);
        prim = I::load_aligned(p.prim + i);
    }
    w.counters.isect_active += uint64_t(std::min(Wave<A>::K, w.live - i));
    w.counters.isect_total += uint64_t(Wave<A>::K);
}

// Whether anything blocks K shadow rays within tmax (for the `live` lanes); lanes already
// blocked skip nothing (SIMD), but the loops stop once every lane is blocked.
template <class A>
typename Wave<A>::M occluded(const FlatScene& s, const Ray<typename Wave<A>::F>& ray,
                             const typename Wave<A>::F& tmax, typename Wave<A>::M live) {
    using F = typename Wave<A>::F;
    typename Wave<A>::M blocked(false);
    F th;
    for (int32_t j = 0; j < s.plane_count && !all(blocked); ++j) {
        const PrimitiveLanes<F> q(s.plane_lanes, j);
        blocked = blocked | intersect_plane(ray, q.xyz, q.w, tmax, th);
    }
    for (int32_t j = 0; j < s.sphere_count && !all(blocked); ++j) {
        const PrimitiveLanes<F> q(s.sphere_lanes, j);
        blocked = blocked | intersect_sphere(ray, q.xyz, q.w, tmax, th);
    }
    for (int32_t j = 0; j < s.quadric_count && !all(blocked); ++j) {
        const QuadricLanes<F> ql(s.quadric_lanes, j);
        blocked = blocked | intersect_quadric(ray, ql.q, ql.lo, ql.hi, tmax, th);
    }
    if (s.features.meshes && !all(blocked)) {
        // Meshes: each open ray that enters a mesh's box through its BVH, one by one
        using I = typename Wave<A>::I;
        const WideRays<A> rays(ray);
        alignas(64) float tm[Wave<A>::K];
        alignas(64) int32_t hit[Wave<A>::K] = {};
        tmax.store_aligned(tm);
        for (int32_t m = 0; m < s.mesh_count && !all(blocked); ++m) {
            const FlatMesh& mesh = s.meshes[m];
            uint32_t open = mask_bits(live & !blocked & slab_hits<A>(mesh.bounds, rays, tmax));
            for (; open; open &= open - 1) {
                const int l = std::countr_zero(open);
                uint32_t unused;
                if (traverse_wide<true, A>(mesh, rays, l, tm[l], unused)) hit[l] = 1;
            }
            blocked = blocked | mask_f32(I::load_aligned(hit) != I(0));
        }
    }
    return blocked;
}

}  // namespace CIERZO_ISA_NAMESPACE
}  // namespace cierzo
