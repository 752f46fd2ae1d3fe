// Wavefront stage 2, closest hit: K rays at a time against every sphere, plane and quadric
// of the scene (one primitive broadcast to all lanes, in the scalar reference's order), then meshes through the scalar BVH
// for each lane. Records t and the primitive id; the shadow stage's any-hit test is here too.
#pragma once

#include "integrators/wavefront/wave.h"

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
    w.counters.isect_active += uint64_t(w.live);
    w.counters.isect_total += uint64_t(end);

    // Meshes: one ray at a time through the BVH, bounded by the analytic hit
    if (!s.features.meshes) return;
    for (int32_t i = 0; i < w.live; ++i) {
        const float o[3] = {p.ox[i], p.oy[i], p.oz[i]}, d[3] = {p.dx[i], p.dy[i], p.dz[i]};
        MeshHit h;
        if (!s.intersect_meshes(s.scene, o, d, p.t[i], &h)) continue;
        p.t[i] = h.t;
        p.prim[i] = kPrimMesh << kPrimShift;
        p.mesh_nx[i] = h.n[0], p.mesh_ny[i] = h.n[1], p.mesh_nz[i] = h.n[2];
        p.mesh_id[i] = h.mesh;
        p.mesh_tri[i] = h.triangle;
    }
}

// Whether anything blocks K shadow rays within tmax; lanes already blocked skip nothing
// (SIMD), but the loop stops once every lane is blocked.
template <class A>
typename Wave<A>::M occluded(const FlatScene& s, const Ray<typename Wave<A>::F>& ray,
                             const typename Wave<A>::F& tmax) {
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
    return blocked;
}

}  // namespace CIERZO_ISA_NAMESPACE
}  // namespace cierzo
