// Wavefront stage 2, closest hit: K rays at a time against the unbounded primitives (planes,
// unbounded quadrics: one broadcast to all lanes), then each ray whose interval meets the
// scene BVH's box through the tree on its own (kernels/bvh/traverse.h: all children of a node
// and all primitives of a leaf block tested at once). Records t and the primitive id; the
// shadow stage's any-hit test is here too.
#pragma once

#include <type_traits>
#include <vector>

#include "integrators/wavefront/wave.h"
#include "kernels/bvh/traverse.h"
#include "kernels/bvh/traverse_group.h"
#include "kernels/bvh/traverse_stream.h"

namespace cierzo {
inline namespace CIERZO_ISA_NAMESPACE {

// Plane j from its lane table (FlatScene::plane_lanes): the normal and distance.
template <class F>
struct PlaneTable {
    const float* table;
    PlaneLanes<F> operator()(int32_t j) const {
        const float* v = table + 64 * j;
        return {{F::load_aligned(v), F::load_aligned(v + 16), F::load_aligned(v + 32)},
                F::load_aligned(v + 48)};
    }
};

// The j-th unbounded quadric's coefficients and clipping box from the lane table
// (FlatScene::quadric_lanes).
template <class F>
struct QuadricTable {
    const float* table;
    const int32_t* list;
    QuadricOfLanes<F> operator()(int32_t j) const {
        const int32_t index = list[j];
        const float* v = table + 256 * index;
        auto at = [&](int k) { return F::load_aligned(v + 16 * k); };
        return {{at(0), at(1), at(2), at(3), at(4), at(5), at(6), at(7), at(8), at(9)},
                {at(10), at(11), at(12)},
                {at(13), at(14), at(15)},
                index};
    }
};

// The lanes one ray tests a node's 8 children or a leaf's 8 triangles in: one AVX register
// where the ISA has one (the AVX-512 objects use 256-bit operations: 8 fill them), else two
// SSE registers.
template <class A>
using WideArch =
    std::conditional_t<(xsimd::batch<float, A>::size >= 8), xsimd::fma3<xsimd::avx2>, A>;

// K rays set up for the traversal, in SIMD: origins, directions, reciprocal directions
// (zero components give +-inf) and the watertight kernel's shear (kernels/triangle.h: the
// axes kx, ky, kz and sx, sy, sz), each ray then traversed on its own; and what the node
// and leaf tests derive from them (make_node_ray, make_leaf_ray), for all K rays at once:
// the far planes' scaled reciprocals, where each axis' near and far rows start in a node,
// the origin in the shear's axis order and where those axes' rows start in a triangle
// block. A ray taken from here (LaneRay) costs its traversal only broadcasts.
template <class A>
struct WideRays {
    static constexpr int K = Wave<A>::K;
    alignas(64) float o[3][K], d[3][K], inv[3][K], shear[3][K];
    alignas(64) int32_t axis[3][K];
    alignas(64) float inv_far[3][K], o_sheared[3][K];
    alignas(64) int32_t near_at[3][K], far_at[3][K], row_at[3][K];

    explicit WideRays(const Ray<typename Wave<A>::F>& ray) {
        using F = typename Wave<A>::F;
        using I = typename Wave<A>::I;
        const RayShear<F> s = make_ray_shear(ray.d);
        store3(ray.o, o[0], o[1], o[2], 0);
        store3(ray.d, d[0], d[1], d[2], 0);
        const Vec3<F> r(F(1.0f) / ray.d.x, F(1.0f) / ray.d.y, F(1.0f) / ray.d.z);
        store3(r, inv[0], inv[1], inv[2], 0);
        store3(r * F(kBvhFarScale), inv_far[0], inv_far[1], inv_far[2], 0);
        store3(Vec3<F>(s.sx, s.sy, s.sz), shear[0], shear[1], shear[2], 0);
        s.kx.store_aligned(axis[0]), s.ky.store_aligned(axis[1]), s.kz.store_aligned(axis[2]);
        store3(Vec3<F>(pick(ray.o, s.px), pick(ray.o, s.py), pick(ray.o, s.pz)), o_sheared[0],
               o_sheared[1], o_sheared[2], 0);
        const F rk[3] = {r.x, r.y, r.z};
        const I ks[3] = {s.kx, s.ky, s.kz};
        for (int k = 0; k < 3; ++k) {
            near_row(rk[k], k).store_aligned(near_at[k]);
            far_row(rk[k], k).store_aligned(far_at[k]);
            (ks[k] * I(int32_t(sizeof(TriangleBlock::v[0])))).store_aligned(row_at[k]);
        }
    }

    // Ray l as the traversal takes it.
    TraversalRay lane(int l) const {
        TraversalRay r;
        for (int k = 0; k < 3; ++k) {
            r.o[k] = o[k][l], r.d[k] = d[k][l], r.inv[k] = inv[k][l];
            r.axis[k] = axis[k][l], r.shear[k] = shear[k][l];
        }
        return r;
    }
};

// Ray l of a WideRays, for traverse_in: its node and leaf lanes broadcast from the batch's
// set-up (the overloads below, which traverse_in finds by argument-dependent lookup), the
// whole TraversalRay made only where a leaf needs it.
template <class A>
struct LaneRay {
    const WideRays<A>* rays;
    int l;
};
template <class N, class A>
inline NodeRay<N> make_node_ray(const LaneRay<A>& lr) {
    const WideRays<A>& w = *lr.rays;
    const int l = lr.l;
    NodeRay<N> n;
    for (int k = 0; k < 3; ++k) {
        n.org[k] = N(w.o[k][l]), n.inv[k] = N(w.inv[k][l]), n.inv_far[k] = N(w.inv_far[k][l]);
        n.near_at[k] = size_t(w.near_at[k][l]), n.far_at[k] = size_t(w.far_at[k][l]);
    }
    return n;
}
template <class N, class A>
inline LeafRay<N> make_leaf_ray(const LaneRay<A>& lr) {
    const WideRays<A>& w = *lr.rays;
    const int l = lr.l;
    LeafRay<N> r;
    r.tri = {{N(w.o_sheared[0][l]), N(w.o_sheared[1][l]), N(w.o_sheared[2][l])}, Vec3<N>(N(0.0f))};
    r.sx = N(w.shear[0][l]), r.sy = N(w.shear[1][l]), r.sz = N(w.shear[2][l]);
    for (int k = 0; k < 3; ++k) r.row_at[k] = size_t(w.row_at[k][l]);
    return r;
}
template <class A>
inline TraversalRay traversal_ray(const LaneRay<A>& lr) {
    return lr.rays->lane(lr.l);
}

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

// The node lanes of the traversal: 8 floats (one AVX register, or two SSE or NEON ones).
template <class A>
using NodeLanes = xsimd::batch<float, WideArch<A>>;

// Path q's hit record from a tree hit: the primitive id, and for a triangle its mesh, index
// and normal.
inline void record_tree_hit(PathPool& p, const BvhView& bvh, int32_t q, const BvhHit& hit) {
    if (hit.kind == kLeafSpheres) {
        p.prim[q] = (kPrimSphere << kPrimShift) | int32_t(hit_sphere(bvh, hit));
    } else if (hit.kind == kLeafQuadrics) {
        p.prim[q] = (kPrimQuadric << kPrimShift) | int32_t(hit.lane);
    } else {
        const Vec3f n = hit_triangle_normal(bvh, hit);
        p.prim[q] = kPrimMesh << kPrimShift;
        p.mesh_nx[q] = n.x, p.mesh_ny[q] = n.y, p.mesh_nz[q] = n.z;
        p.mesh_id[q] = int32_t(hit_mesh(bvh, hit));
        p.mesh_tri[q] = hit_triangle(bvh, hit);
    }
}

// The closest hits of the lanes `enter` of K rays set up in `rays` in the scene BVH below
// their t (K floats at `t`, updated): the lanes hit, their hits in `hits`. One ray after
// another, the traversal inlined into this loop (flatten), so that a frame, its registers
// and the traversal's memory are set up once a batch, not once a ray. (Not inlined itself:
// the traversal of a deep tree costs far more than the call, and a copy of it in every
// stage loop that intersects would only grow the per-ISA objects.)
template <class A>
[[gnu::noinline, gnu::flatten]] uint32_t closest_lanes(const BvhView& bvh, const AlphaTable* alpha,
                                                       const WideRays<A>& rays, uint32_t enter,
                                                       float* t, BvhHit* hits) {
    TraversalScratch scratch;
    uint32_t found = 0;
    for (; enter; enter &= enter - 1) {
        const int l = std::countr_zero(enter);
        if (traverse_in<false, NodeLanes<A>>(bvh, LaneRay<A>{&rays, l}, t[l], hits[l], scratch,
                                             alpha))
            found |= 1u << l;
    }
    return found;
}

// The closest hits of the `live` lanes of K rays in the scene BVH below their t (K floats at
// `t`, updated), the rays whose interval [0, t] meets the tree's box one by one
// (closest_lanes); on_hit(l, hit) for each lane hit. (A one-node tree's packet test, cheap,
// stays inlined in closest_in_tree.)
template <class A, class OnHit>
void closest_in_tree_by_ray(const BvhView& bvh, const AlphaTable* alpha,
                            const Ray<typename Wave<A>::F>& ray, typename Wave<A>::M live, float* t,
                            const OnHit& on_hit) {
    using F = typename Wave<A>::F;
    const WideRays<A> rays(ray);
    const uint32_t enter = mask_bits(live & slab_hits<A>(bvh.bounds, rays, F::load_aligned(t)));
    if (enter == 0) return;
    BvhHit hits[Wave<A>::K];
    for (uint32_t found = closest_lanes<A>(bvh, alpha, rays, enter, t, hits); found;
         found &= found - 1) {
        const int l = std::countr_zero(found);
        on_hit(l, hits[l]);
    }
}

// The closest hits of K rays in the scene BVH below their t (K floats at `t`, updated),
// for the `live` lanes: a one-node tree, or K rays from one point (a pinhole camera's), are
// traced all at once (packet_traverse); otherwise the rays whose interval [0, t] meets the
// tree's box go through it one by one.
// on_hit(l, hit) is called for each lane hit.
template <class A, class OnHit>
void closest_in_tree(const BvhView& bvh, const AlphaTable* alpha, bool packet,
                     const Ray<typename Wave<A>::F>& ray, typename Wave<A>::M live, float* t,
                     const OnHit& on_hit) {
    using F = typename Wave<A>::F;
    using I = typename Wave<A>::I;
    if (packet || coherent(ray)) {
        F tt = F::load_aligned(t);
        I kind(0), lane(0), instance(-1);
        const Vec3<F> inv(F(1.0f) / ray.d.x, F(1.0f) / ray.d.y, F(1.0f) / ray.d.z);
        uint32_t hits = mask_bits(packet_traverse<false>(bvh, ray, inv, make_ray_shear(ray.d), live,
                                                         tt, kind, lane, instance, alpha));
        if (!hits) return;
        tt.store_aligned(t);
        alignas(64) int32_t kinds[Wave<A>::K], lanes[Wave<A>::K], instances[Wave<A>::K];
        kind.store_aligned(kinds), lane.store_aligned(lanes), instance.store_aligned(instances);
        for (; hits; hits &= hits - 1) {
            const int l = std::countr_zero(hits);
            on_hit(l, BvhHit{uint32_t(kinds[l]), uint32_t(lanes[l]), instances[l]});
        }
        return;
    }
    closest_in_tree_by_ray<A>(bvh, alpha, ray, live, t, on_hit);
}

// ---- Many rays in flight -----------------------------------------------------------------
// With --ray-group above 1, a stage whose rays go through the tree gathers them all first,
// then traverses them `FlatScene::ray_group` at a time (kernels/bvh/traverse_group.h), so
// that their cache misses may overlap; the same hits as one ray at a time.

// Whether the scene's tree is traversed with many rays in flight (a one-node tree is tested
// K rays at a time instead: packet_traverse).
inline bool grouped(const FlatScene& s) {
    return s.features.bvh && !s.features.packet && s.ray_group > 1;
}

// The pool's arrays for it (PathPool::group_rays...).
struct GroupArrays {
    TraversalRay* rays;
    int32_t* ids;
    float* t;
    BvhHit* hits;
    uint8_t* found;
    TraversalGroupScratch* scratch;
};
inline GroupArrays group_arrays(const PathPool& p) {
    static_assert(sizeof(TraversalRay) <= 16 * sizeof(float) && sizeof(BvhHit) == 12 &&
                  sizeof(TraversalGroupScratch) <= kTraversalGroupBytes);
    return {reinterpret_cast<TraversalRay*>(p.group_rays),
            p.group_ids,
            p.group_t,
            reinterpret_cast<BvhHit*>(p.group_hits),
            p.group_found,
            static_cast<TraversalGroupScratch*>(p.group_scratch)};
}

// Appends the rays of lanes `bits` (their ids: base + lane, their intervals' ends: t) to the
// gathered rays, of which there are `n`.
template <class A>
void gather_group_rays(const GroupArrays& g, int32_t& n, const WideRays<A>& rays, uint32_t bits,
                       int32_t base, const float* t) {
    for (; bits; bits &= bits - 1) {
        const int l = std::countr_zero(bits);
        g.rays[n] = rays.lane(l), g.ids[n] = base + l, g.t[n] = t[l];
        ++n;
    }
}

// The closest hits of every live path's ray, as closest_hit gives them batch by batch, left
// in p.t and p.prim (and a triangle's mesh, index and normal): the unbounded primitives and
// packets K rays at a time, then the rays that enter the tree, all of them, in groups.
template <class A>
CIERZO_STAGE void closest_hits_grouped(Wave<A>& w) {
    using F = typename Wave<A>::F;
    using I = typename Wave<A>::I;
    PathPool& p = w.pool;
    const FlatScene& s = w.scene;
    const BvhView& bvh = *s.bvh;
    const GroupArrays g = group_arrays(p);
    int32_t n = 0;
    const int32_t end = w.rounded_up(w.live);
    for (int32_t i = 0; i < end; i += Wave<A>::K) {
        const Ray<F> ray{load3<F>(p.ox, p.oy, p.oz, i), load3<F>(p.dx, p.dy, p.dz, i)};
        F t(kRayFar);
        I prim(-1);
        closest_unbounded(ray, t, prim, s.plane_count, PlaneTable<F>{s.plane_lanes},
                          kPrimPlane << kPrimShift, s.unbounded_quadric_count,
                          QuadricTable<F>{s.quadric_lanes, s.unbounded_quadrics},
                          kPrimQuadric << kPrimShift);
        t.store_aligned(p.t + i);
        prim.store_aligned(p.prim + i);
        w.counters.isect_active += uint64_t(std::min(Wave<A>::K, w.live - i));
        w.counters.isect_total += uint64_t(Wave<A>::K);
        if (coherent(ray)) {
            intersect_tree(w, i, ray);
            continue;
        }
        const WideRays<A> rays(ray);
        const uint32_t enter = mask_bits(w.live_mask(i) & slab_hits<A>(bvh.bounds, rays, t));
        gather_group_rays<A>(g, n, rays, enter, i, p.t + i);
    }
    traverse_group<false, NodeLanes<A>>(bvh, g.rays, n, g.t, g.hits, g.found, s.ray_group,
                                        *g.scratch, s.alpha);
    for (int32_t j = 0; j < n; ++j) {
        if (!g.found[j]) continue;
        const int32_t q = g.ids[j];
        p.t[q] = g.t[j];
        record_tree_hit(p, bvh, q, g.hits[j]);
    }
}

// The closest hits of batch `i` in the scene BVH, after its unbounded ones (in p.t and
// p.prim): a hit writes t and the primitive to the path.
template <class A>
void intersect_tree(Wave<A>& w, int32_t i, const Ray<typename Wave<A>::F>& ray) {
    PathPool& p = w.pool;
    const BvhView& bvh = *w.scene.bvh;
    closest_in_tree<A>(bvh, w.scene.alpha, w.scene.features.packet, ray, w.live_mask(i), p.t + i,
                       [&](int l, const BvhHit& hit) { record_tree_hit(p, bvh, i + l, hit); });
}

// Rays i .. i + K - 1 of the columns `rays` (trace_stride(count) floats each: job.h) as K
// rays, their tmax, and their closest hits among the unbounded primitives: t and prim (-1:
// none) updated.
template <class A>
Ray<typename Wave<A>::F> record_batch(const FlatScene& s, const float* rays, size_t count, size_t i,
                                      typename Wave<A>::F& t, typename Wave<A>::I& prim) {
    using F = typename Wave<A>::F;
    const size_t stride = trace_stride(count);
    const auto at = [&](int k) { return F::load_aligned(rays + size_t(k) * stride + i); };
    const Ray<F> ray{{at(0), at(1), at(2)}, {at(3), at(4), at(5)}};
    t = at(6);
    prim = typename Wave<A>::I(-1);
    closest_unbounded(ray, t, prim, s.plane_count, PlaneTable<F>{s.plane_lanes},
                      kPrimPlane << kPrimShift, s.unbounded_quadric_count,
                      QuadricTable<F>{s.quadric_lanes, s.unbounded_quadrics},
                      kPrimQuadric << kPrimShift);
    return ray;
}

// A vector whose type is this ISA's own, by xsimd's allocator (which kernels/isa.h renames
// per ISA): a std::vector<uint8_t> would share its inline code with other objects.
template <class T>
using IsaVector = std::vector<T, xsimd::aligned_allocator<T, 64>>;

// trace_rays_isa's streams: the unbounded primitives K rays at a time, then the tree in
// streams of options.stream_rays.
template <class A>
void trace_ray_streams(const FlatScene& s, const float* rays, size_t count,
                       const TraceOptions& options, TraceTotals& out) {
    using F = typename Wave<A>::F;
    using I = typename Wave<A>::I;
    constexpr int K = Wave<A>::K;
    const int chunk = std::max(K, std::min(options.stream_rays, kMaxStreamRays) / K * K);
    const size_t m = size_t(chunk);
    IsaVector<TraversalRay> setup(m);
    IsaVector<float> t(m);
    IsaVector<BvhHit> hit(m);
    IsaVector<uint8_t> found(m), masks(m);
    IsaVector<uint16_t> order(m), ids(stream_scratch_ids(chunk));
    const auto octant = [](const TraversalRay& r) {
        return int(std::signbit(r.d[0])) | int(std::signbit(r.d[1])) << 1 |
               int(std::signbit(r.d[2])) << 2;
    };
    for (size_t c0 = 0; c0 < count; c0 += size_t(chunk)) {
        const int n = int(std::min<size_t>(size_t(chunk), count - c0));
        for (int i = 0; i < n; i += K) {
            F tt;
            I prim;
            const Ray<F> ray = record_batch<A>(s, rays, count, c0 + size_t(i), tt, prim);
            tt.store_aligned(t.data() + i);
            alignas(64) int32_t p[K];
            prim.store_aligned(p);
            const WideRays<A> wide(ray);
            for (int l = 0; l < K; ++l) {
                found[size_t(i + l)] = p[l] >= 0;
                setup[size_t(i + l)] = wide.lane(l);
            }
        }
        // One stream per octant of directions: its rays order the children alike
        int first[9] = {};
        for (int r = 0; r < n; ++r) ++first[octant(setup[size_t(r)]) + 1];
        for (int o = 0; o < 8; ++o) first[o + 1] += first[o];
        int next[8];
        for (int o = 0; o < 8; ++o) next[o] = first[o];
        for (int r = 0; r < n; ++r) order[size_t(next[octant(setup[size_t(r)])]++)] = uint16_t(r);
        for (int o = 0; o < 8; ++o) {
            const int rays_in = first[o + 1] - first[o];
            if (rays_in == 0) continue;
            for (int j = first[o]; j < first[o + 1]; ++j)
                ids[size_t(j - first[o])] = order[size_t(j)];
            stream_closest<NodeLanes<A>>(*s.bvh, setup.data(), rays_in, t.data(), hit.data(),
                                         found.data(), ids.data(), masks.data(),
                                         options.single_below);
        }
        for (int r = 0; r < n; ++r) {
            if (!found[size_t(r)]) continue;
            ++out.hits;
            out.sum_t += double(t[size_t(r)]);
        }
        out.rays += uint64_t(n);
        out.streamed += uint64_t(n);
    }
}

// trace_rays_isa with many rays in flight: the unbounded primitives K rays at a time, then
// the tree in chunks of rays, FlatScene::ray_group of them at a time.
template <class A>
void trace_rays_grouped(const FlatScene& s, const float* rays, size_t count, TraceTotals& out) {
    using F = typename Wave<A>::F;
    using I = typename Wave<A>::I;
    constexpr int K = Wave<A>::K;
    constexpr size_t kChunk = 4096;
    IsaVector<TraversalRay> setup(kChunk);
    IsaVector<float> t(kChunk), tg(kChunk);
    IsaVector<int32_t> ids(kChunk);
    IsaVector<BvhHit> hit(kChunk);
    IsaVector<uint8_t> found(kChunk), hits(kChunk);
    IsaVector<TraversalGroupScratch> scratch(1);
    const GroupArrays g{setup.data(), ids.data(),   tg.data(),
                        hit.data(),   found.data(), scratch.data()};
    for (size_t c0 = 0; c0 < count; c0 += kChunk) {
        const int m = int(std::min(kChunk, count - c0));
        int32_t n = 0;
        for (int i = 0; i < m; i += K) {
            const int lanes = std::min(K, m - i);
            F tt;
            I prim;
            const Ray<F> ray = record_batch<A>(s, rays, count, c0 + size_t(i), tt, prim);
            tt.store_aligned(t.data() + i);
            alignas(64) int32_t pr[K];
            prim.store_aligned(pr);
            for (int l = 0; l < lanes; ++l) hits[size_t(i + l)] = pr[l] >= 0;
            const auto live = Wave<A>::lane_index() < F(float(lanes));
            if (s.features.packet || coherent(ray)) {
                closest_in_tree<A>(*s.bvh, s.alpha, s.features.packet, ray, live, t.data() + i,
                                   [&](int l, const BvhHit&) { hits[size_t(i + l)] = 1; });
                continue;
            }
            const WideRays<A> wide(ray);
            const uint32_t enter = mask_bits(live & slab_hits<A>(s.bvh->bounds, wide, tt));
            gather_group_rays<A>(g, n, wide, enter, i, t.data() + i);
        }
        traverse_group<false, NodeLanes<A>>(*s.bvh, g.rays, n, g.t, g.hits, g.found, s.ray_group,
                                            *g.scratch, s.alpha);
        for (int32_t j = 0; j < n; ++j)
            if (g.found[j]) t[size_t(ids[size_t(j)])] = g.t[j], hits[size_t(ids[size_t(j)])] = 1;
        for (int r = 0; r < m; ++r) {
            if (!hits[size_t(r)]) continue;
            ++out.hits;
            out.sum_t += double(t[size_t(r)]);
        }
        out.rays += uint64_t(m);
    }
}

// Closest hits of `count` rays (columns: trace_stride, job.h) through the whole
// scene: the traversal alone, for measuring it (`cierzo trace`). K at a time as the
// extension stage traces them, or in ordered streams (options). Adds the rays, hits and
// the sum of hit distances.
template <class A>
void trace_rays_isa(const FlatScene& s, const float* rays, size_t count,
                    const TraceOptions& options, TraceTotals& out) {
    using F = typename Wave<A>::F;
    using I = typename Wave<A>::I;
    constexpr int K = Wave<A>::K;
    if (options.stream_rays > 0 && s.features.bvh && stream_tree(*s.bvh, s.alpha != nullptr)) {
        trace_ray_streams<A>(s, rays, count, options, out);
        return;
    }
    if (grouped(s)) {
        trace_rays_grouped<A>(s, rays, count, out);
        return;
    }
    for (size_t i = 0; i < count; i += K) {
        const int lanes = int(std::min<size_t>(K, count - i));
        F t;
        I prim;
        const Ray<F> ray = record_batch<A>(s, rays, count, i, t, prim);
        alignas(64) float tt[K];
        t.store_aligned(tt);
        uint32_t hit = mask_bits(mask_f32(prim >= I(0)));
        const auto live = Wave<A>::lane_index() < F(float(lanes));
        if (s.features.bvh)
            closest_in_tree<A>(*s.bvh, s.alpha, s.features.packet, ray, live, tt,
                               [&](int l, const BvhHit&) { hit |= 1u << l; });
        hit &= (1u << lanes) - 1u;
        out.hits += uint64_t(std::popcount(hit));
        for (; hit; hit &= hit - 1) out.sum_t += double(tt[std::countr_zero(hit)]);
        out.rays += uint64_t(lanes);
    }
}

// The closest hit of batch `i` (rays `ray`): t and the primitive id (-1: nothing) in
// registers, and in p.t and p.prim when the scene has a BVH (its traversal goes through the
// pool one ray at a time).
template <class A>
void closest_hit(Wave<A>& w, int32_t i, const Ray<typename Wave<A>::F>& ray, typename Wave<A>::F& t,
                 typename Wave<A>::I& prim) {
    using F = typename Wave<A>::F;
    using I = typename Wave<A>::I;
    PathPool& p = w.pool;
    const FlatScene& s = w.scene;
    t = F(kRayFar);
    prim = I(-1);
    closest_unbounded(ray, t, prim, s.plane_count, PlaneTable<F>{s.plane_lanes},
                      kPrimPlane << kPrimShift, s.unbounded_quadric_count,
                      QuadricTable<F>{s.quadric_lanes, s.unbounded_quadrics},
                      kPrimQuadric << kPrimShift);
    if (s.features.bvh) {
        t.store_aligned(p.t + i);
        prim.store_aligned(p.prim + i);
        intersect_tree(w, i, ray);
        t = F::load_aligned(p.t + i);
        prim = I::load_aligned(p.prim + i);
    }
    w.counters.isect_active += uint64_t(std::min(Wave<A>::K, w.live - i));
    w.counters.isect_total += uint64_t(Wave<A>::K);
}

// The closest hit of batch `i` in registers, as closest_hit gives it: traced now, or, where a
// stage traced every live path's first (`group`: closest_hits_grouped), from the pool.
template <class A>
void batch_closest_hit(Wave<A>& w, int32_t i, const Ray<typename Wave<A>::F>& ray,
                       typename Wave<A>::F& t, typename Wave<A>::I& prim, bool group) {
    if (group) {
        t = Wave<A>::F::load_aligned(w.pool.t + i);
        prim = Wave<A>::I::load_aligned(w.pool.prim + i);
        return;
    }
    closest_hit(w, i, ray, t, prim);
}

// Whether the scene BVH blocks K shadow rays within tmax, ray by ray, for the lanes `live`
// that nothing unbounded has `blocked`. (Not inlined, and the traversal inlined into it, as
// closest_lanes.)
template <class A>
[[gnu::noinline, gnu::flatten]] typename Wave<A>::M occluded_by_ray(
    const FlatScene& s, const Ray<typename Wave<A>::F>& ray, const typename Wave<A>::F& tmax,
    typename Wave<A>::M live, typename Wave<A>::M blocked) {
    using I = typename Wave<A>::I;
    // The open rays that enter the tree's box through it, one by one
    const WideRays<A> rays(ray);
    alignas(64) float tm[Wave<A>::K];
    alignas(64) int32_t hit[Wave<A>::K] = {};
    tmax.store_aligned(tm);
    uint32_t open = mask_bits(live & !blocked & slab_hits<A>(s.bvh->bounds, rays, tmax));
    TraversalScratch scratch;
    for (; open; open &= open - 1) {
        const int l = std::countr_zero(open);
        BvhHit unused;
        if (traverse_in<true, NodeLanes<A>>(*s.bvh, LaneRay<A>{&rays, l}, tm[l], unused, scratch,
                                            s.alpha))
            hit[l] = 1;
    }
    return blocked | mask_f32(I::load_aligned(hit) != I(0));
}

// Whether anything blocks K shadow rays within tmax (for the `live` lanes); lanes already
// blocked skip nothing (SIMD), but the loops stop once every lane is blocked.
template <class A>
typename Wave<A>::M occluded(const FlatScene& s, const Ray<typename Wave<A>::F>& ray,
                             const typename Wave<A>::F& tmax, typename Wave<A>::M live) {
    using F = typename Wave<A>::F;
    using I = typename Wave<A>::I;
    typename Wave<A>::M blocked = occluded_unbounded(
        ray, tmax, typename Wave<A>::M(false), s.plane_count, PlaneTable<F>{s.plane_lanes},
        s.unbounded_quadric_count, QuadricTable<F>{s.quadric_lanes, s.unbounded_quadrics});
    if (s.features.packet && !all(blocked)) {
        F t = tmax;
        I kind(0), lane(0), instance(-1);
        const Vec3<F> inv(F(1.0f) / ray.d.x, F(1.0f) / ray.d.y, F(1.0f) / ray.d.z);
        return blocked | packet_traverse<true>(*s.bvh, ray, inv, make_ray_shear(ray.d),
                                               live & !blocked, t, kind, lane, instance, s.alpha);
    }
    if (s.features.bvh && !all(blocked)) blocked = occluded_by_ray<A>(s, ray, tmax, live, blocked);
    return blocked;
}

}  // namespace CIERZO_ISA_NAMESPACE
}  // namespace cierzo
