// Wavefront stage 3, surface: for K hits at a time, the hit point, the outward geometric
// normal of whichever primitive kind each lane hit (gathered by index), and the material id.
// Lanes that missed everything, and padding lanes, are dead. It runs on the closest hits in
// registers, straight after the intersection of the same batch.
#pragma once

#include "integrators/wavefront/wave.h"
#include "kernels/shading.h"

namespace cierzo {
inline namespace CIERZO_ISA_NAMESPACE {

// The surfaces of one batch: hit point, outward geometric normal, material, which lanes
// hit something, and the magnitude max(max_abs(pos), max_abs(ray origin)) that sets the
// offset of rays leaving the point (kept instead of the origin: two vectors fewer to hold
// through shading).
template <class A>
struct Surfaces {
    Vec3<typename Wave<A>::F> pos, n;
    Vec3<typename Wave<A>::F> ns;  // the shading normal: n, or a smooth mesh's (shading.h)
    typename Wave<A>::I material;
    typename Wave<A>::M hit;
    typename Wave<A>::F magnitude;
    typename Wave<A>::I emitter;  // nee/mis: the sampled emitter hit, or -1
};

// The shading normals of the lanes in `on_mesh` (hits on meshes, at pos, with geometric
// normal n), a mesh at a time: smooth meshes gather their triangles' vertices and normals.
template <class A>
Vec3<typename Wave<A>::F> smooth_normals(const Wave<A>& w, int32_t i,
                                         const typename Wave<A>::I& on_mesh_id,
                                         typename Wave<A>::M on_mesh,
                                         const Vec3<typename Wave<A>::F>& pos,
                                         const Vec3<typename Wave<A>::F>& n) {
    using F = typename Wave<A>::F;
    using I = typename Wave<A>::I;
    const PathPool& p = w.pool;
    const I triangle =
        xsimd::bitwise_cast<I>(xsimd::batch<uint32_t, A>::load_aligned(p.mesh_tri + i));
    alignas(64) int32_t ids[Wave<A>::K];
    on_mesh_id.store_aligned(ids);
    Vec3<F> out = n;
    for (uint32_t todo = mask_bits(on_mesh); todo;) {
        const int32_t id = ids[std::countr_zero(todo)];
        const auto lanes = on_mesh & mask_f32(on_mesh_id == I(id));
        todo &= ~mask_bits(lanes);
        const FlatMesh& m = w.scene.meshes[id];
        if (!m.normals) continue;
        const I corner = select(mask_i32(lanes), triangle, I(0)) * I(3);
        // (an instance's vertices and normals are in the file's space: so is the point)
        const Vec3<F> at = mesh_space_point(m, pos);
        Vec3<F> v[3], vn[3];
        for (int k = 0; k < 3; ++k) {
            v[k] = gather_corner<A>(m, m.positions, corner, k);
            vn[k] = gather_corner<A>(m, m.normals, corner, k);
        }
        Vec3<F> ns = interpolate_normal(v, vn, at, Vec3<F>(F(0.0f)));
        auto found = (ns.x != F(0.0f)) | (ns.y != F(0.0f)) | (ns.z != F(0.0f));
        if (const float* a = m.normal_to_world) {
            const Vec3<F> wn{fma(F(a[0]), ns.x, fma(F(a[1]), ns.y, F(a[2]) * ns.z)),
                             fma(F(a[3]), ns.x, fma(F(a[4]), ns.y, F(a[5]) * ns.z)),
                             fma(F(a[6]), ns.x, fma(F(a[7]), ns.y, F(a[8]) * ns.z))};
            const F len = sqrt(dot(wn, wn));
            found = found & (len > F(0.0f)) & (len < F(kRayFar));
            ns = wn * (F(1.0f) / select(found, len, F(1.0f)));
        }
        out = select(lanes & found, ns, out);
    }
    return out;
}

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
    Vec3<F> ns;  // set after the kinds: n, or on smooth meshes theirs
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
        if (weighs_emitter_hits(s.path))
            emitter = select(m, lookup<A>(s.sphere_emitter, count, j), emitter);
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
        // (mesh is the last kind: n is final here, and smooth_normals keeps it for the
        // lanes that are not on a smooth mesh)
        if (s.path.smooth) ns = smooth_normals(w, i, mesh, mask_f32(m) & w.live_mask(i), pos, n);
        if (weighs_emitter_hits(s.path)) {
            const I first = lookup<A>(s.mesh_emitter, s.mesh_count, mesh);
            const I tri =
                xsimd::bitwise_cast<I>(xsimd::batch<uint32_t, A>::load_aligned(p.mesh_tri + i));
            emitter = select(m & (first >= I(0)), first + tri, emitter);
        }
    }
    const auto hit = w.live_mask(i) & (to_float(prim) >= F(0.0f));
    if (!(s.path.smooth && f.meshes)) ns = n;
    return {pos,    n,
            ns,     select(mask_i32(hit), material, I(0)),
            hit,    max(max_abs(pos), max_abs(ray.o)),
            emitter};
}

// The surfaces store_surfaces kept of batch `i` (rays `ray`), read back.
template <class A>
Surfaces<A> load_surfaces(const Wave<A>& w, int32_t i, const Ray<typename Wave<A>::F>& ray) {
    using F = typename Wave<A>::F;
    using I = typename Wave<A>::I;
    const PathPool& p = w.pool;
    const PathContext& c = w.scene.path;
    const Vec3<F> pos = load3<F>(p.px, p.py, p.pz, i);
    const Vec3<F> n = load3<F>(p.nx, p.ny, p.nz, i);
    return {pos,
            n,
            c.smooth ? load3<F>(p.snx, p.sny, p.snz, i) : n,
            I::load_aligned(p.material + i),
            mask_f32(I::load_aligned(p.alive + i) != I(0)),
            max(max_abs(pos), max_abs(ray.o)),
            weighs_emitter_hits(c) ? I::load_aligned(p.emitter + i) : I(-1)};
}

// Stores a batch's surfaces for the stages that run after the material sort.
template <class A>
void store_surfaces(Wave<A>& w, int32_t i, const Surfaces<A>& sf) {
    using I = typename Wave<A>::I;
    PathPool& p = w.pool;
    store3(sf.pos, p.px, p.py, p.pz, i);
    store3(sf.n, p.nx, p.ny, p.nz, i);
    if (w.scene.path.smooth) store3(sf.ns, p.snx, p.sny, p.snz, i);
    sf.material.store_aligned(p.material + i);
    if (weighs_emitter_hits(w.scene.path)) sf.emitter.store_aligned(p.emitter + i);
    select(mask_i32(sf.hit), I(1), I(0)).store_aligned(p.alive + i);
}

}  // namespace CIERZO_ISA_NAMESPACE
}  // namespace cierzo
