// Wavefront stage 2, closest hit: K rays at a time against every sphere, plane and quadric
// of the scene (one primitive broadcast to all lanes, in the scalar reference's order), then
// each mesh's BVH traversed by packets of the rays that enter it. Records t and the primitive id; the
// shadow stage's any-hit test is here too.
#pragma once

#include "integrators/wavefront/wave.h"
#include "kernels/triangle.h"

namespace cierzo {
inline namespace CIERZO_ISA_NAMESPACE {

template <class F>
QuadricCoefficients<F> quadric_at(const float* q) {
    return {F(q[0]), F(q[1]), F(q[2]), F(q[3]), F(q[4]), F(q[5]), F(q[6]), F(q[7]), F(q[8]),
            F(q[9])};
}

// Closest analytic hit of K rays; `prim` is -1 where nothing is hit.
template <class A>
void closest_analytic(const FlatScene& s, const Ray<typename Wave<A>::F>& ray,
                      typename Wave<A>::F& t, typename Wave<A>::I& prim) {
    using F = typename Wave<A>::F;
    using I = typename Wave<A>::I;
    auto record = [&](const auto& hit, const F& th, int32_t kind, int32_t j) {
        t = select(hit, th, t);
        prim = select(mask_i32(hit), I((kind << kPrimShift) | j), prim);
    };
    F th;
    for (int32_t j = 0; j < s.sphere_count; ++j) {
        const Vec3<F> c{F(s.sphere_cx[j]), F(s.sphere_cy[j]), F(s.sphere_cz[j])};
        record(intersect_sphere(ray, c, F(s.sphere_r[j]), t, th), th, kPrimSphere, j);
    }
    for (int32_t j = 0; j < s.plane_count; ++j) {
        const Vec3<F> n{F(s.plane_nx[j]), F(s.plane_ny[j]), F(s.plane_nz[j])};
        record(intersect_plane(ray, n, F(s.plane_d[j]), t, th), th, kPrimPlane, j);
    }
    for (int32_t j = 0; j < s.quadric_count; ++j) {
        const float* q = s.quadric + 16 * j;
        const Vec3<F> lo{F(q[10]), F(q[11]), F(q[12])}, hi{F(q[13]), F(q[14]), F(q[15])};
        record(intersect_quadric(ray, quadric_at<F>(q), lo, hi, t, th), th, kPrimQuadric, j);
    }
}

// The robust slab test of K rays against a node's box over [0, t]: the same as the scalar
// traversal (a NaN distance leaves the interval as it was; far distances scaled by
// kBvhFarScale). Returns the lanes whose interval meets the box.
template <class A>
typename Wave<A>::M slab_hits(const FlatBvhNode& node, const typename Wave<A>::F org[3],
                              const typename Wave<A>::F inv[3], const typename Wave<A>::F& t) {
    using F = typename Wave<A>::F;
    F t0(0.0f), t1 = t;
    for (int k = 0; k < 3; ++k) {
        const F a = (F(node.bounds[k]) - org[k]) * inv[k];
        const F b = (F(node.bounds[k + 3]) - org[k]) * inv[k];
        const auto forward = inv[k] >= F(0.0f);
        const F near = select(forward, a, b), far = select(forward, b, a) * F(kBvhFarScale);
        t0 = select(near > t0, near, t0);
        t1 = select(far < t1, far, t1);
    }
    return t0 <= t1;
}

// K rays through one mesh's BVH together: a node is entered when any live lane's slab
// interval [0, t] meets its box (the same robust slab test as the scalar traversal), the
// children in the order most lanes prefer; leaves test their triangles on all K lanes with
// the watertight kernel. Closest hit: t, leaf-order triangle and hit mask are updated;
// any hit: `blocked` gathers the lanes that hit anything and the walk stops once all have.
template <bool kAnyHit, class A>
void traverse_packet(const FlatMesh& mesh, const Ray<typename Wave<A>::F>& ray,
                     const RayShear<typename Wave<A>::F>& shear, typename Wave<A>::M live,
                     typename Wave<A>::F& t, typename Wave<A>::I& triangle,
                     typename Wave<A>::M& hit) {
    using F = typename Wave<A>::F;
    using I = typename Wave<A>::I;
    if (mesh.node_count == 0) return;  // every triangle degenerate: nothing to hit
    const F inv[3] = {F(1.0f) / ray.d.x, F(1.0f) / ray.d.y, F(1.0f) / ray.d.z};
    const F org[3] = {ray.o.x, ray.o.y, ray.o.z};
    uint32_t stack[96];
    int size = 0;
    uint32_t index = 0;
    for (;;) {
        const FlatBvhNode& node = mesh.nodes[index];
        const auto enter = live & slab_hits<A>(node, org, inv, t);
        if (any(enter)) {
            if (node.count == 0) {
                // Inner node: the near child first, as most entering lanes see it
                const uint32_t lanes = mask_bits(enter);
                const uint32_t backwards = mask_bits(enter & (inv[node.axis] < F(0.0f)));
                const bool second_first = 2 * std::popcount(backwards) > std::popcount(lanes);
                stack[size++] = second_first ? index + 1 : node.offset;
                index = second_first ? node.offset : index + 1;
                continue;
            }
            // Leaf: every triangle against the entering lanes
            for (uint32_t j = node.offset; j < node.offset + node.count; ++j) {
                const float* v = mesh.triangles + 9 * size_t(j);
                F th(0.0f), b1(0.0f), b2(0.0f);
                const auto m = intersect_triangle(ray, shear, Vec3<F>(F(v[0]), F(v[1]), F(v[2])),
                                                  Vec3<F>(F(v[3]), F(v[4]), F(v[5])),
                                                  Vec3<F>(F(v[6]), F(v[7]), F(v[8])), t, th, b1,
                                                  b2) &
                               enter;
                hit = hit | m;
                if constexpr (kAnyHit) {
                    live = live & !m;
                } else {
                    t = select(m, th, t);
                    triangle = select(mask_i32(m), I(int32_t(j)), triangle);
                }
            }
            if constexpr (kAnyHit) {
                if (none(live)) return;
            }
        }
        if (size == 0) return;
        index = stack[--size];
    }
}

// The closest mesh hits, after the analytic ones: for each mesh, the rays whose interval
// [0, t] meets its root box are gathered into full packets (most rays of a scene never come
// near a given mesh, and a sparse packet walks the tree for its few live lanes), traversed,
// and their t, primitive, mesh, triangle and normal scattered back.
template <class A>
void intersect_meshes(Wave<A>& w) {
    using F = typename Wave<A>::F;
    using I = typename Wave<A>::I;
    constexpr int32_t K = Wave<A>::K;
    PathPool& p = w.pool;
    const FlatScene& s = w.scene;
    int32_t* list = p.bucket[kLobeCount];
    for (int32_t m = 0; m < s.mesh_count; ++m) {
        const FlatMesh& mesh = s.meshes[m];
        if (mesh.node_count == 0) continue;  // every triangle degenerate: nothing to hit
        // The rays that enter the root box
        int32_t size = 0;
        const FlatBvhNode& root = mesh.nodes[0];
        for (int32_t i = 0; i < w.live; i += K) {
            const Vec3<F> o = load3<F>(p.ox, p.oy, p.oz, i), d = load3<F>(p.dx, p.dy, p.dz, i);
            const F org[3] = {o.x, o.y, o.z};
            const F inv[3] = {F(1.0f) / d.x, F(1.0f) / d.y, F(1.0f) / d.z};
            const auto enter = slab_hits<A>(root, org, inv, F::load_aligned(p.t + i));
            append_lanes(mask_bits(w.live_mask(i) & enter), i, list, size);
        }
        // Full packets of those rays through the tree
        for (int32_t i = 0; i < size; i += K) {
            alignas(64) int32_t idx[K];
            for (int32_t l = 0; l < K; ++l) idx[l] = list[std::min(i + l, size - 1)];
            const I j = I::load_aligned(idx);
            const Ray<F> ray{{gather_lanes<A>(p.ox, j), gather_lanes<A>(p.oy, j), gather_lanes<A>(p.oz, j)},
                             {gather_lanes<A>(p.dx, j), gather_lanes<A>(p.dy, j), gather_lanes<A>(p.dz, j)}};
            F t = gather_lanes<A>(p.t, j);
            I triangle(0);
            typename Wave<A>::M hit(false);
            traverse_packet<false, A>(mesh, ray, make_ray_shear(ray.d), typename Wave<A>::M(true), t,
                                      triangle, hit);
            // Hits back to their paths, lane by lane (normal from the triangle's vertices)
            alignas(64) float ts[K];
            alignas(64) int32_t tris[K];
            t.store_aligned(ts);
            triangle.store_aligned(tris);
            uint32_t bits = mask_bits(hit) & ((size - i >= K) ? ~0u : (1u << (size - i)) - 1u);
            while (bits) {
                const int32_t l = std::countr_zero(bits);
                bits &= bits - 1;
                const int32_t q = idx[l];
                const float* v = mesh.triangles + 9 * size_t(tris[l]);
                const Vec3f n = normalize(cross(Vec3f{v[3] - v[0], v[4] - v[1], v[5] - v[2]},
                                                Vec3f{v[6] - v[0], v[7] - v[1], v[8] - v[2]}));
                p.t[q] = ts[l];
                p.prim[q] = kPrimMesh << kPrimShift;
                p.mesh_nx[q] = n.x, p.mesh_ny[q] = n.y, p.mesh_nz[q] = n.z;
                p.mesh_id[q] = m;
                p.mesh_tri[q] = mesh.triangle_ids[tris[l]];
            }
        }
    }
}

template <class A>
void intersect_closest(Wave<A>& w) {
    using F = typename Wave<A>::F;
    using I = typename Wave<A>::I;
    PathPool& p = w.pool;
    const FlatScene& s = w.scene;
    const int32_t end = w.rounded_up(w.live);
    for (int32_t i = 0; i < end; i += Wave<A>::K) {
        const Ray<F> ray{load3<F>(p.ox, p.oy, p.oz, i), load3<F>(p.dx, p.dy, p.dz, i)};
        F t(kRayFar);
        I prim(-1);
        closest_analytic<A>(s, ray, t, prim);
        t.store_aligned(p.t + i);
        prim.store_aligned(p.prim + i);
    }
    if (s.features.meshes) intersect_meshes(w);
    w.counters.isect_active += uint64_t(w.live);
    w.counters.isect_total += uint64_t(end);

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
        const Vec3<F> n{F(s.plane_nx[j]), F(s.plane_ny[j]), F(s.plane_nz[j])};
        blocked = blocked | intersect_plane(ray, n, F(s.plane_d[j]), tmax, th);
    }
    for (int32_t j = 0; j < s.sphere_count && !all(blocked); ++j) {
        const Vec3<F> c{F(s.sphere_cx[j]), F(s.sphere_cy[j]), F(s.sphere_cz[j])};
        blocked = blocked | intersect_sphere(ray, c, F(s.sphere_r[j]), tmax, th);
    }
    for (int32_t j = 0; j < s.quadric_count && !all(blocked); ++j) {
        const float* q = s.quadric + 16 * j;
        const Vec3<F> lo{F(q[10]), F(q[11]), F(q[12])}, hi{F(q[13]), F(q[14]), F(q[15])};
        blocked = blocked | intersect_quadric(ray, quadric_at<F>(q), lo, hi, tmax, th);
    }
    if (s.features.meshes && !all(blocked)) {
        const RayShear<F> shear = make_ray_shear(ray.d);
        for (int32_t m = 0; m < s.mesh_count && !all(blocked); ++m) {
            F t = tmax;
            typename Wave<A>::I unused(0);
            traverse_packet<true, A>(s.meshes[m], ray, shear, (!blocked) & live, t, unused,
                                     blocked);
        }
    }
    return blocked;
}

}  // namespace CIERZO_ISA_NAMESPACE
}  // namespace cierzo
