// Colour sources of the report: a solid colour, procedural sin / sin² / sin·cos patterns of
// the hit position, and per-vertex colours of triangles (nearest vertex, or weighted by
// inverse distance to the three vertices); and image textures, looked up bilinearly at the
// hit's texture coordinates (a mesh's per-vertex (u, v), a sphere's longitude and latitude, a
// plane's position in its own frame; hit_uv below).
#pragma once

#include <cstdint>

#include "intersect.h"
#include "lanes.h"
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
    kImage,           // a · image(uv · uv_scale + uv_offset), bilinear
};

// An image texture as the kernels read it: width × height texels, row 0 at the top of the
// picture (texture coordinate v = 1), four channels each (red, green, blue, alpha). 8-bit
// files are kept as bytes, their colour channels mapped to linear values through `decode`
// (256 entries: the sRGB curve or byte / 255) and alpha as byte / 255; HDR and EXR files as
// linear floats.
struct ImageView {
    const int32_t* bytes = nullptr;  // RGBA8 packed, red in the low byte; or null
    const float* floats = nullptr;   // RGBA32F; or null
    const float* decode = nullptr;   // the byte table, with `bytes`
    int32_t width = 0, height = 0;
};

// One colour of a material (emission, kd, ks, kr or kt).
struct ColorSource {
    TextureKind kind = TextureKind::kSolid;
    Vec3f a{0.0f};  // the solid colour, the pattern's colour at 0, or the vertex-colour scale
    Vec3f b{0.0f};  // the pattern's colour at 1
    float frequency = 1.0f;
    Vec3f axis{1.0f, 0.0f, 0.0f};
    Vec3f axis2{0.0f, 1.0f, 0.0f};
    // kImage: the scene's image, the map of texture coordinates, and wrap = repeat (the
    // image tiles the plane) or clamp (the border texels extend). b holds a · the image's
    // largest texel, per channel.
    int32_t image = -1;
    float uv_scale[2] = {1.0f, 1.0f}, uv_offset[2] = {0.0f, 0.0f};
    bool clamp = false;

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
        if (kind == TextureKind::kImage) return max_component(b);
        return std::max(max_component(a), max_component(b));
    }
};

// ---- Image textures --------------------------------------------------------------------

template <class T>
struct Texel {
    Vec3<T> rgb;
    T alpha;
};

// Texel index (x, y) of image `im` (both in range), four channels.
template <class T, class I>
Texel<T> fetch_texel(const ImageView& im, const I& x, const I& y) {
    const I index = y * I(im.width) + x;
    if (im.floats) {
        const I base = index * I(4);
        return {{gather_table(im.floats, base), gather_table(im.floats, base + I(1)),
                 gather_table(im.floats, base + I(2))},
                gather_table(im.floats, base + I(3))};
    }
    const I t = gather_table(im.bytes, index);
    const I m(255);
    return {{gather_table(im.decode, t & m), gather_table(im.decode, (t >> 8) & m),
             gather_table(im.decode, (t >> 16) & m)},
            to_float((t >> 24) & m) * T(1.0f / 255.0f)};
}

// The texel coordinates of a bilinear look-up along one axis of n texels: the two texels
// (i0, i1) and the weight of i1. Texel k covers [k, k + 1) / n, its centre at (k + ½) / n.
// Repeat wraps the coordinate to its fractional part first (exact in float), clamp bounds it;
// a coordinate that is NaN or beyond ±2^20 reads as 0.
template <class T, class I>
void texel_pair(T s, int32_t n, bool clamp, I& i0, I& i1, T& w) {
    s = select(abs(s) < T(1048576.0f), s, T(0.0f));
    s = clamp ? min(max(s, T(-1.0f)), T(2.0f)) : s - floor(s);
    const T nf = T(float(n));
    const T x = fma(s, nf, T(-0.5f));
    const T x0 = floor(x);
    w = x - x0;
    const T lo(0.0f), hi = nf - T(1.0f);
    T a, b;
    if (clamp) {
        a = min(max(x0, lo), hi);
        b = min(max(x0 + T(1.0f), lo), hi);
    } else {
        // x0 is in [-1, n - 1]: -1 is the last texel, n the first
        a = select(x0 < lo, hi, min(x0, hi));
        b = select(x0 + T(1.0f) > hi, lo, max(x0 + T(1.0f), lo));
    }
    i0 = to_int(a), i1 = to_int(b);
}

// The image at texture coordinates (u, v) (v = 0 at the bottom row), bilinear, with the
// source's scale, offset and wrap.
template <class T>
Texel<T> sample_image(const ImageView& im, const ColorSource& c, T u, T v) {
    using I = decltype(to_int(std::declval<T>()));
    u = fma(u, T(c.uv_scale[0]), T(c.uv_offset[0]));
    v = fma(v, T(c.uv_scale[1]), T(c.uv_offset[1]));
    I x0, x1, y0, y1;
    T wx, wy;
    texel_pair(u, im.width, c.clamp, x0, x1, wx);
    texel_pair(T(1.0f) - v, im.height, c.clamp, y0, y1, wy);
    const Texel<T> t00 = fetch_texel<T>(im, x0, y0), t10 = fetch_texel<T>(im, x1, y0);
    const Texel<T> t01 = fetch_texel<T>(im, x0, y1), t11 = fetch_texel<T>(im, x1, y1);
    const auto lerp = [](const T& a, const T& b, const T& t) { return fma(b - a, t, a); };
    const auto lerp3 = [&](const Vec3<T>& a, const Vec3<T>& b, const T& t) {
        return Vec3<T>{lerp(a.x, b.x, t), lerp(a.y, b.y, t), lerp(a.z, b.z, t)};
    };
    return {lerp3(lerp3(t00.rgb, t10.rgb, wx), lerp3(t01.rgb, t11.rgb, wx), wy),
            lerp(lerp(t00.alpha, t10.alpha, wx), lerp(t01.alpha, t11.alpha, wx), wy)};
}

// Texture coordinates of a hit, by what was hit (kernels/prim_id.h kinds are not needed:
// the callers pass the kind's own quantities).
//
// A sphere: its outward unit normal n as longitude and latitude about +y, u = ½ + atan2(n.x,
// n.z) / 2π (u = ½ faces +z), v = ½ + asin(n.y) / π (v = 1 at the top).
template <class T>
void sphere_uv(const Vec3<T>& n, T& u, T& v) {
    constexpr float kInvTwoPi = 0.15915494309189535f, kInvPi = 0.3183098861837907f;
    u = fma(atan2(n.x, n.z), T(kInvTwoPi), T(0.5f));
    const T y = min(max(n.y, T(-1.0f)), T(1.0f));
    v = fma(T(0.5f * 3.14159265358979f) - acos(y), T(kInvPi), T(0.5f));
}

// A plane of unit normal n: the point's coordinates along two unit tangents of the plane
// (Duff et al. 2017's frame of n), one texture unit per scene unit.
template <class T>
void plane_uv(const Vec3<T>& n, const Vec3<T>& p, T& u, T& v) {
    const T sign = select(n.z >= T(0.0f), T(1.0f), T(-1.0f));
    const T a = T(-1.0f) / (sign + n.z);
    const T b = n.x * n.y * a;
    const Vec3<T> t1{fma(sign * n.x * n.x, a, T(1.0f)), sign * b, -sign * n.x};
    const Vec3<T> t2{b, fma(n.y * n.y, a, sign), -n.y};
    u = dot(p, t1), v = dot(p, t2);
}

// A triangle's barycentric weights of the point p on or next to it (clamped to the
// triangle; computed on edges rescaled to unit size, as interpolate_normal does). A
// degenerate triangle gives the first vertex.
template <class T>
void barycentrics(const Vec3<T> v[3], const Vec3<T>& p, T& b0, T& b1, T& b2) {
    const Vec3<T> e1 = v[1] - v[0], e2 = v[2] - v[0];
    const T scale = T(1.0f) / max(max_abs(e1), max_abs(e2));
    const Vec3<T> a = e1 * scale, b = e2 * scale, q = (p - v[0]) * scale;
    const Vec3<T> c = cross(a, b);
    const T inv = T(1.0f) / dot(c, c);
    b1 = max(dot(cross(q, b), c) * inv, T(0.0f));
    b2 = max(dot(cross(a, q), c) * inv, T(0.0f));
    const T sum = b1 + b2;
    const T over = select(sum > T(1.0f), T(1.0f) / sum, T(1.0f));
    b1 = b1 * over, b2 = b2 * over;
    // (NaN from a degenerate triangle: the first vertex)
    const auto ok = (b1 == b1) & (b2 == b2);
    b1 = select(ok, b1, T(0.0f)), b2 = select(ok, b2, T(0.0f));
    b0 = max(T(1.0f) - b1 - b2, T(0.0f));
}

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
