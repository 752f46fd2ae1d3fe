// Wavefront stage 3, surface: for K hits at a time, the hit point, the outward geometric
// normal of whichever primitive kind each lane hit (gathered by index), and the material id.
// Lanes that missed everything, and padding lanes, are dead. It runs on the closest hits in
// registers, straight after the intersection of the same batch.
#pragma once

#include "integrators/wavefront/wave.h"

namespace cierzo {
inline namespace CIERZO_ISA_NAMESPACE {

// The surfaces of one batch: hit point, outward geometric normal, material, which lanes
// hit something, and the magnitude max(max_abs(pos), max_abs(ray origin)) that sets the
// offset of rays leaving the point (kept instead of the origin: two vectors fewer to hold
// through shading).
template <class A>
struct Surfaces {
    Vec3<typename Wave<A>::F> pos, n;
    typename Wave<A>::I material;
    typename Wave<A>::M hit;
    typename Wave<A>::F magnitude;
    typename Wave<A>::I emitter;  // nee/mis: the sampled emitter hit, or -1
};

template <class A>
Surfaces<A> resolve_surfaces(const Wave<A>& w, int32_t i, const Ray<typename Wave<A>::F>& ray,
                             const typename Wave<A>::F& t, const typename Wave<A>::I& prim) {
    using F = typename Wave<A>::F;
    using I = typename Wave<A>::I;
    const PathPool& p = w.pool;
    const FlatScene& s = w.scene;
    const FlatFeatures& f = s.features;
    const I kind = prim >> kPrimShift;
    const I index = prim & I(kPrimIndexMask);
    const Vec3<F> pos = fma(ray.d, t, ray.o);
    Vec3<F> n(F(0.0f), F(0.0f), F(1.0f));
    I material(0);
    I emitter(-1);

    // Each primitive kind the scene has: gather its data where lanes hit that kind
    if (f.spheres) {
        const auto m = kind == I(kPrimSphere);
        const I j = select(m, index, I(0));
        const int32_t count = s.sphere_count;
        const Vec3<F> c{lookup<A>(s.sphere_cx, count, j), lookup<A>(s.sphere_cy, count, j),
                        lookup<A>(s.sphere_cz, count, j)};
        n = select(mask_f32(m), normalize(pos - c), n);
        material = select(m, lookup<A>(s.sphere_material, count, j), material);
        if (f.nee) emitter = select(m, lookup<A>(s.sphere_emitter, count, j), emitter);
    }
    if (f.planes) {
        const auto m = kind == I(kPrimPlane);
        const I j = select(m, index, I(0));
        const int32_t count = s.plane_count;
        const Vec3<F> pn{lookup<A>(s.plane_nx, count, j), lookup<A>(s.plane_ny, count, j),
                         lookup<A>(s.plane_nz, count, j)};
        n = select(mask_f32(m), pn, n);
        material = select(m, lookup<A>(s.plane_material, count, j), material);
    }
    if (f.quadrics) {
        const auto m = kind == I(kPrimQuadric);
        const auto mf = mask_f32(m);
        if (any(mf)) {
            const I j = select(m, index, I(0));
            const I base = j * I(16);
            QuadricCoefficients<F> q;
            F* c[10] = {&q.a, &q.b, &q.c, &q.d, &q.e, &q.f, &q.g, &q.h, &q.i, &q.j};
            for (int k = 0; k < 10; ++k) *c[k] = gather_lanes<A>(s.quadric, base + I(k));
            n = select(mf, normalize(quadric_gradient(q, pos)), n);
            material = select(m, lookup<A>(s.quadric_material, s.quadric_count, j), material);
        }
    }
    if (f.meshes) {
        const auto m = kind == I(kPrimMesh);
        const I mesh = select(m, I::load_aligned(p.mesh_id + i), I(0));
        n = select(mask_f32(m), load3<F>(p.mesh_nx, p.mesh_ny, p.mesh_nz, i), n);
        material = select(m, lookup<A>(s.mesh_material, s.mesh_count, mesh), material);
        if (f.nee) {
            const I first = lookup<A>(s.mesh_emitter, s.mesh_count, mesh);
            const I tri = xsimd::bitwise_cast<I>(xsimd::batch<uint32_t, A>::load_aligned(p.mesh_tri + i));
            emitter = select(m & (first >= I(0)), first + tri, emitter);
        }
    }
    const auto hit = w.live_mask(i) & (to_float(prim) >= F(0.0f));
    return {pos, n, select(mask_i32(hit), material, I(0)), hit,
            max(max_abs(pos), max_abs(ray.o)), emitter};
}

// Stores a batch's surfaces for the stages that run after the material sort.
template <class A>
void store_surfaces(Wave<A>& w, int32_t i, const Surfaces<A>& sf) {
    using I = typename Wave<A>::I;
    PathPool& p = w.pool;
    store3(sf.pos, p.px, p.py, p.pz, i);
    store3(sf.n, p.nx, p.ny, p.nz, i);
    sf.material.store_aligned(p.material + i);
    if (w.scene.features.nee) sf.emitter.store_aligned(p.emitter + i);
    select(mask_i32(sf.hit), I(1), I(0)).store_aligned(p.alive + i);
}

}  // namespace CIERZO_ISA_NAMESPACE
}  // namespace cierzo
