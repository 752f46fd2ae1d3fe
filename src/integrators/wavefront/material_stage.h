// Wavefront stage 4, materials: every live hit gets its material's colours (emission, kd,
// ks, kr, kt), shininess and index. Scenes with textures sort the hits by material (a
// counting sort), so each material's texture is evaluated on coherent lanes with its
// parameters broadcast; scenes with only solid colours skip the stage and the shading
// kernels read the material tables directly (table_bsdf).
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
    return s;
}

// Solid colours straight from the material tables, for the lobes the scene has (the
// others stay 0 and cost nothing): no material stage at all for such scenes.
template <class A>
Vec3<xsimd::batch<float, A>> table_color(const FlatScene& s, int c,
                                         const xsimd::batch<int32_t, A>& mat) {
    const float* row = s.color + c * 3 * s.material_stride;
    const int32_t mc = s.material_count;
    return {lookup<A>(row, mc, mat), lookup<A>(row + s.material_stride, mc, mat),
            lookup<A>(row + 2 * s.material_stride, mc, mat)};
}

template <class A>
Bsdf<xsimd::batch<float, A>> table_bsdf(const FlatScene& s, const xsimd::batch<int32_t, A>& mat) {
    using F = xsimd::batch<float, A>;
    const FlatFeatures& f = s.features;
    const Vec3<F> zero(F(0.0f));
    return {f.diffuse ? table_color<A>(s, kColKd, mat) : zero,
            f.specular ? table_color<A>(s, kColKs, mat) : zero,
            f.mirror ? table_color<A>(s, kColKr, mat) : zero,
            f.refraction ? table_color<A>(s, kColKt, mat) : zero,
            f.specular ? lookup<A>(s.shininess, s.material_count, mat) : F(0.0f),
            f.refraction ? lookup<A>(s.ior, s.material_count, mat) : F(1.0f)};
}

// The material sort: p.order lists the live hits grouped by material, starts[m] where
// material m's group begins (starts has material_count + 1 entries).
template <class A>
void sort_by_material(Wave<A>& w, int32_t* starts) {
    PathPool& p = w.pool;
    const int32_t mc = w.scene.material_count;
    std::fill(starts, starts + mc + 1, 0);
    for (int32_t i = 0; i < w.live; ++i) ++starts[p.material[i] + 1];
    for (int32_t m = 0; m < mc; ++m) starts[m + 1] += starts[m];
    for (int32_t i = 0; i < w.live; ++i) p.order[starts[p.material[i]]++] = i;
    for (int32_t m = mc; m > 0; --m) starts[m] = starts[m - 1];
    starts[0] = 0;
}

template <class A>
void evaluate_sorted_materials(Wave<A>& w, int32_t* starts) {
    using F = typename Wave<A>::F;
    using I = typename Wave<A>::I;
    constexpr int32_t K = Wave<A>::K;
    PathPool& p = w.pool;
    const FlatScene& s = w.scene;
    sort_by_material(w, starts);
    for (int32_t m = 0; m < s.material_count; ++m) {
        const int32_t first = starts[m], last = starts[m + 1];
        const FlatColor* src = s.sources + m * kColCount;
        for (int32_t i = first; i < last; i += K) {
            // Indices of this chunk; the tail repeats the last one (same result, same slot)
            alignas(64) int32_t idx[K];
            for (int32_t l = 0; l < K; ++l) idx[l] = p.order[std::min(i + l, last - 1)];
            const I j = I::load_aligned(idx);
            const Vec3<F> pos{gather_lanes<A>(p.px, j), gather_lanes<A>(p.py, j),
                              gather_lanes<A>(p.pz, j)};
            for (int c = 0; c < kColCount; ++c) {
                const ColorSource cs = color_source(src[c]);
                Vec3<F> col = eval_pattern(cs, pos);
                if (cs.is_vertex()) {
                    // Vertex colours come from the mesh, one hit at a time
                    alignas(64) float r[K], g[K], b[K];
                    for (int32_t l = 0; l < K; ++l) {
                        const int32_t q = idx[l];
                        const float at[3] = {p.px[q], p.py[q], p.pz[q]};
                        float out[3] = {cs.a.x, cs.a.y, cs.a.z};
                        if (p.prim[q] >> kPrimShift == kPrimMesh)
                            s.vertex_color(s.scene, p.mesh_id[q], p.mesh_tri[q], at, &src[c], out);
                        r[l] = out[0], g[l] = out[1], b[l] = out[2];
                    }
                    col = {F::load_aligned(r), F::load_aligned(g), F::load_aligned(b)};
                }
                scatter3(col, p.col[c][0], p.col[c][1], p.col[c][2], j);
            }
            F(s.shininess[m]).scatter(p.shininess, j);
            F(s.ior[m]).scatter(p.ior, j);
        }
    }
}

}  // namespace CIERZO_ISA_NAMESPACE
}  // namespace cierzo
