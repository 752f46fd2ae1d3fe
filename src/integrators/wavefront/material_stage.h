// Wavefront stage 4, materials. Solid colours, shininess and index are read from the material
// tables where shading needs them (hit_bsdf). Scenes with textures first sort the hits on
// textured materials by material (a counting sort), so each material's textured channels are
// evaluated on coherent lanes with its parameters broadcast, vertex colours included.
#pragma once

#include "integrators/wavefront/wave.h"

namespace cierzo {
inline namespace CIERZO_ISA_NAMESPACE {

inline ColorSource color_source(const FlatColor& c) {
    ColorSource s;
    s.kind = TextureKind(c.kind);
    s.a = {c.a[0], c.a[1], c.a[2]};
    s.b = {c.b[0], c.b[1], c.b[2]};
    s.frequency = c.frequency;
    s.axis = {c.axis[0], c.axis[1], c.axis[2]};
    s.axis2 = {c.axis2[0], c.axis2[1], c.axis2[2]};
    s.image = c.image;
    s.uv_scale[0] = c.uv_scale[0], s.uv_scale[1] = c.uv_scale[1];
    s.uv_offset[0] = c.uv_offset[0], s.uv_offset[1] = c.uv_offset[1];
    s.clamp = c.clamp != 0;
    return s;
}

inline ImageView image_view(const FlatImage& f) {
    ImageView v;
    v.bytes = f.bytes, v.floats = f.floats, v.decode = f.decode;
    v.width = f.width, v.height = f.height;
    return v;
}

// Solid colours straight from the material tables, for the lobes the scene has (the
// others stay 0 and cost nothing).
template <class A>
Vec3<xsimd::batch<float, A>> table_color(const FlatScene& s, int c,
                                         const xsimd::batch<int32_t, A>& mat) {
    const float* row = s.color + c * 3 * s.material_stride;
    const int32_t mc = s.material_count;
    return {lookup<A>(row, mc, mat), lookup<A>(row + s.material_stride, mc, mat),
            lookup<A>(row + 2 * s.material_stride, mc, mat)};
}

// Colour channel c of K hits on materials `mat`: the table's solid colour, except where the
// hit's material textures the channel; there, what the material stage evaluated for the
// hit, which `read(c)` loads. Scenes without textures never call it.
template <class A, class Read>
Vec3<xsimd::batch<float, A>> hit_color(const FlatScene& s, int c,
                                       const xsimd::batch<int32_t, A>& mat, const Read& read) {
    using I = xsimd::batch<int32_t, A>;
    Vec3<xsimd::batch<float, A>> col = table_color<A>(s, c, mat);
    if (s.features.texture_channels >> c & 1u) {
        const I bits = lookup<A>(s.textured, s.material_count, mat);
        const auto own = mask_f32((bits & I(1 << c)) != I(0));
        if (any(own)) col = select(own, read(c), col);
    }
    return col;
}

// The material of K hits. kLobe is the one lobe kind whose parameters are wanted (the
// scene's only one, or the one a lobe bucket samples): the other lobes are then zero at
// compile time, so the roulette and the lobe kernels fold them away instead of carrying 12
// zero lanes through registers. kLobeCount: every lobe the scene has.
template <int kLobe, class A, class Read>
Bsdf<xsimd::batch<float, A>> hit_bsdf(const FlatScene& s, const xsimd::batch<int32_t, A>& mat,
                                      const Read& read) {
    using F = xsimd::batch<float, A>;
    const FlatFeatures& f = s.features;
    constexpr bool every = kLobe == kLobeCount;
    const bool diffuse = every ? f.diffuse : kLobe == kLobeDiffuse;
    const bool specular = every ? f.specular : kLobe == kLobeSpecular;
    const bool mirror = every ? f.mirror : kLobe == kLobeMirror;
    const bool refraction = every ? f.refraction : kLobe == kLobeRefract;
    // Member by member, each from its own expression: an aggregate built from copies of one
    // zero vector is one GCC leaves in memory
    Bsdf<F> m;
    m.kd = diffuse ? hit_color<A>(s, kColKd, mat, read) : Vec3<F>(F(0.0f));
    m.ks = specular ? hit_color<A>(s, kColKs, mat, read) : Vec3<F>(F(0.0f));
    m.kr = mirror ? hit_color<A>(s, kColKr, mat, read) : Vec3<F>(F(0.0f));
    m.kt = refraction ? hit_color<A>(s, kColKt, mat, read) : Vec3<F>(F(0.0f));
    m.shininess = specular ? lookup<A>(s.shininess, s.material_count, mat) : F(0.0f);
    m.ior = refraction ? lookup<A>(s.ior, s.material_count, mat) : F(1.0f);
    return m;
}

// The material sort: p.order lists the live hits on textured materials grouped by material,
// starts[m] where material m's group begins (starts has material_count + 1 entries). Hits
// on solid materials are left out: their colours come from the tables.
template <class A>
CIERZO_STAGE void sort_by_material(Wave<A>& w, int32_t* starts) {
    PathPool& p = w.pool;
    const int32_t* textured = w.scene.textured;
    const int32_t mc = w.scene.material_count;
    const auto sorted = [&](int32_t i) { return p.alive[i] != 0 && textured[p.material[i]] != 0; };
    std::fill(starts, starts + mc + 1, 0);
    for (int32_t i = 0; i < w.live; ++i) starts[p.material[i] + 1] += sorted(i);
    for (int32_t m = 0; m < mc; ++m) starts[m + 1] += starts[m];
    for (int32_t i = 0; i < w.live; ++i)
        if (sorted(i)) p.order[starts[p.material[i]]++] = i;
    for (int32_t m = mc; m > 0; --m) starts[m] = starts[m - 1];
    starts[0] = 0;
}

// Vertex colours of K hits (pool indices j) at their points: each mesh's lanes in turn (a
// material's hits are usually on one mesh) gather their triangle's vertices and colours.
// Hits on anything else, or on a mesh without colours, take the source's scale, as in the
// scalar reference (Scene::color_at).
template <class A>
Vec3<typename Wave<A>::F> vertex_colors(const Wave<A>& w, const ColorSource& cs,
                                        const typename Wave<A>::I& j,
                                        const Vec3<typename Wave<A>::F>& pos) {
    using F = typename Wave<A>::F;
    using I = typename Wave<A>::I;
    const PathPool& p = w.pool;
    const I mesh = gather_lanes<A>(p.mesh_id, j);
    const I triangle = gather_lanes<A>(reinterpret_cast<const int32_t*>(p.mesh_tri), j);
    const auto on_mesh = gather_lanes<A>(p.prim, j) >> kPrimShift == I(kPrimMesh);
    alignas(64) int32_t ids[Wave<A>::K];
    mesh.store_aligned(ids);
    Vec3<F> out{F(cs.a.x), F(cs.a.y), F(cs.a.z)};
    for (uint32_t todo = mask_bits(mask_f32(on_mesh)); todo;) {
        const int32_t id = ids[std::countr_zero(todo)];
        const auto lanes = on_mesh & (mesh == I(id));
        todo &= ~mask_bits(mask_f32(lanes));
        const FlatMesh& m = w.scene.meshes[id];
        if (!m.colors) continue;
        const I corner = select(lanes, triangle, I(0)) * I(3);
        const Vec3<F> at = mesh_space_point(m, pos);
        Vec3<F> v[3], col[3];
        for (int k = 0; k < 3; ++k) {
            v[k] = gather_corner<A>(m, m.positions, corner, k);
            col[k] = gather_corner<A>(m, m.colors, corner, k);
        }
        out = select(mask_f32(lanes), eval_vertex_color(cs, at, v, col), out);
    }
    return out;
}

// Texture coordinates of K hits (pool indices j) at their points, as Scene::hit_uv gives
// them: spheres and planes from their normals, each mesh's lanes in turn from its vertices'
// (u, v) (0 on a mesh without them and on quadrics).
template <class A>
void hit_uvs(const Wave<A>& w, const typename Wave<A>::I& j, const Vec3<typename Wave<A>::F>& pos,
             typename Wave<A>::F& u, typename Wave<A>::F& v) {
    using F = typename Wave<A>::F;
    using I = typename Wave<A>::I;
    const PathPool& p = w.pool;
    const FlatFeatures& f = w.scene.features;
    const I kind = gather_lanes<A>(p.prim, j) >> kPrimShift;
    u = v = F(0.0f);
    if (f.spheres || f.planes) {
        const Vec3<F> n{gather_lanes<A>(p.nx, j), gather_lanes<A>(p.ny, j),
                        gather_lanes<A>(p.nz, j)};
        if (f.spheres) {
            const auto m = mask_f32(kind == I(kPrimSphere));
            if (any(m)) {
                F su, sv;
                sphere_uv(n, su, sv);
                u = select(m, su, u), v = select(m, sv, v);
            }
        }
        if (f.planes) {
            const auto m = mask_f32(kind == I(kPrimPlane));
            if (any(m)) {
                F pu, pv;
                plane_uv(n, pos, pu, pv);
                u = select(m, pu, u), v = select(m, pv, v);
            }
        }
    }
    if (!f.meshes) return;
    const I mesh = gather_lanes<A>(p.mesh_id, j);
    const I triangle = gather_lanes<A>(reinterpret_cast<const int32_t*>(p.mesh_tri), j);
    const auto on_mesh = kind == I(kPrimMesh);
    alignas(64) int32_t ids[Wave<A>::K];
    mesh.store_aligned(ids);
    for (uint32_t todo = mask_bits(mask_f32(on_mesh)); todo;) {
        const int32_t id = ids[std::countr_zero(todo)];
        const auto lanes = on_mesh & (mesh == I(id));
        todo &= ~mask_bits(mask_f32(lanes));
        const FlatMesh& m = w.scene.meshes[id];
        if (!m.uvs) continue;
        const I corner = select(lanes, triangle, I(0)) * I(3);
        const Vec3<F> at = mesh_space_point(m, pos);
        Vec3<F> vtx[3];
        for (int k = 0; k < 3; ++k) vtx[k] = gather_corner<A>(m, m.positions, corner, k);
        F b[3];
        barycentrics(vtx, at, b[0], b[1], b[2]);
        F mu(0.0f), mv(0.0f);
        for (int k = 0; k < 3; ++k) {
            const I at2 = gather_lanes<A>(m.indices, corner + I(k)) * I(2);
            mu = fma(gather_lanes<A>(m.uvs, at2), b[k], mu);
            mv = fma(gather_lanes<A>(m.uvs, at2 + I(1)), b[k], mv);
        }
        const auto lf = mask_f32(lanes);
        u = select(lf, mu, u), v = select(lf, mv, v);
    }
}

// The textured channels of every live hit on a textured material, a material at a time (its
// texture's parameters broadcast), into p.col.
template <class A>
CIERZO_STAGE_LOOP void evaluate_sorted_materials(Wave<A>& w, int32_t* starts) {
    using F = typename Wave<A>::F;
    using I = typename Wave<A>::I;
    constexpr int32_t K = Wave<A>::K;
    PathPool& p = w.pool;
    const FlatScene& s = w.scene;
    sort_by_material(w, starts);
    for (int32_t m = 0; m < s.material_count; ++m) {
        const int32_t first = starts[m], last = starts[m + 1];
        if (first == last) continue;
        ColorSource sources[kColCount];
        for (int c = 0; c < kColCount; ++c) sources[c] = color_source(s.sources[m * kColCount + c]);
        for (int32_t i = first; i < last; i += K) {
            // Indices of this chunk; the tail repeats the last one (same result, same slot)
            alignas(64) int32_t idx[K];
            for (int32_t l = 0; l < K; ++l) idx[l] = p.order[std::min(i + l, last - 1)];
            const I j = I::load_aligned(idx);
            const Vec3<F> pos{gather_lanes<A>(p.px, j), gather_lanes<A>(p.py, j),
                              gather_lanes<A>(p.pz, j)};
            F u, v;
            bool have_uv = false;
            for (int c = 0; c < kColCount; ++c) {
                if (!(s.textured[m] >> c & 1)) continue;
                const ColorSource& cs = sources[c];
                Vec3<F> col;
                if (cs.kind == TextureKind::kImage) {
                    if (!have_uv) hit_uvs(w, j, pos, u, v), have_uv = true;
                    col =
                        sample_image(image_view(s.images[cs.image]), cs, u, v).rgb * Vec3<F>(cs.a);
                } else {
                    col = cs.is_vertex() ? vertex_colors(w, cs, j, pos) : eval_pattern(cs, pos);
                }
                scatter3(col, p.col[c][0], p.col[c][1], p.col[c][2], j);
            }
        }
    }
}

}  // namespace CIERZO_ISA_NAMESPACE
}  // namespace cierzo
