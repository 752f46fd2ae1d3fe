// Colour sources of the report: a solid colour, procedural sin / sin² / sin·cos patterns of
// the hit position, and per-vertex colours of triangles (nearest vertex, or weighted by
// inverse distance to the three vertices).
#pragma once

#include <cstdint>

#include "vec3.h"

namespace cierzo {
inline namespace CIERZO_ISA_NAMESPACE {

enum class TextureKind : uint8_t {
    kSolid,           // a
    kSin,             // a + (b - a)·½(1 + sin(f·(p·axis)))
    kSin2,            // a + (b - a)·sin²(f·(p·axis))
    kSinCos,          // a + (b - a)·½(1 + sin(f·(p·axis))·cos(f·(p·axis2)))
    kVertexNearest,   // a · colour of the vertex nearest to p
    kVertexWeighted,  // a · Σ wᵢ·colourᵢ / Σ wᵢ, wᵢ = 1 / |p - vᵢ|
};

// One colour of a material (emission, kd, ks, kr or kt).
struct ColorSource {
    TextureKind kind = TextureKind::kSolid;
    Vec3f a{0.0f};  // the solid colour, the pattern's colour at 0, or the vertex-colour scale
    Vec3f b{0.0f};  // the pattern's colour at 1
    float frequency = 1.0f;
    Vec3f axis{1.0f, 0.0f, 0.0f};
    Vec3f axis2{0.0f, 1.0f, 0.0f};

    bool is_zero() const { return kind == TextureKind::kSolid && max_component(a) <= 0.0f; }
    bool is_procedural() const {
        return kind == TextureKind::kSin || kind == TextureKind::kSin2 ||
               kind == TextureKind::kSinCos;
    }
    bool is_vertex() const {
        return kind == TextureKind::kVertexNearest || kind == TextureKind::kVertexWeighted;
    }
    // The largest value any channel can take (for roulette bounds and validation).
    float max_value() const {
        if (kind == TextureKind::kSolid || is_vertex()) return max_component(a);
        return std::max(max_component(a), max_component(b));
    }
};

// The procedural and solid cases at p (vertex colours are resolved by the caller).
template <class T>
Vec3<T> eval_pattern(const ColorSource& c, const Vec3<T>& p) {
    const Vec3<T> a(c.a);
    if (c.kind == TextureKind::kSolid || c.is_vertex()) return a;
    const T f(c.frequency);
    const T s = f * dot(p, Vec3<T>(c.axis));
    T v;
    if (c.kind == TextureKind::kSin) {
        v = T(0.5f) + T(0.5f) * sin(s);
    } else if (c.kind == TextureKind::kSin2) {
        const T sn = sin(s);
        v = sn * sn;
    } else {
        v = T(0.5f) + T(0.5f) * sin(s) * cos(f * dot(p, Vec3<T>(c.axis2)));
    }
    return fma(Vec3<T>(c.b) - a, v, a);
}

// Vertex colour at p from the three vertices and their colours.
template <class T>
Vec3<T> eval_vertex_color(const ColorSource& c, const Vec3<T>& p, const Vec3<T> v[3],
                          const Vec3<T> color[3]) {
    const T d0 = length(p - v[0]), d1 = length(p - v[1]), d2 = length(p - v[2]);
    Vec3<T> out;
    if (c.kind == TextureKind::kVertexNearest) {
        const auto m01 = d0 <= d1;
        const T d01 = min(d0, d1);
        out = select(d2 < d01, color[2], select(m01, color[0], color[1]));
    } else {
        // Inverse-distance weights; a vertex at distance 0 takes all the weight.
        const T eps(1e-30f);
        const T w0 = T(1.0f) / max(d0, eps), w1 = T(1.0f) / max(d1, eps),
                w2 = T(1.0f) / max(d2, eps);
        out = (color[0] * w0 + color[1] * w1 + color[2] * w2) / (w0 + w1 + w2);
    }
    return out * Vec3<T>(c.a);
}

}  // namespace CIERZO_ISA_NAMESPACE
}  // namespace cierzo
