// The report's path-vertex estimator, written once for both integrators (T = float for the
// scalar reference, T = xsimd::batch for the wavefront kernels). At each hit:
//   - an emitter ends the path and adds throughput · Le;
//   - a Phong vertex (kd or ks non-zero) sends a shadow ray to every point light, adding
//     throughput · f(ωi, ωo) · cos θi · I / d²;
//   - one lobe is chosen by Russian roulette with probability proportional to its max RGB,
//     scaled so that at least 1 - survival_cap of the time the path dies;
//   - the chosen lobe samples a direction and the throughput is multiplied by
//     f · cos θ / (pdf · P(lobe)).
// Beyond the report (EstimatorSettings::kind), the sampled emitters (spheres and triangles
// of solid emission, kernels/emitter_table.h) are also reached from every Phong vertex:
//   - nee: one emitter sample per Phong vertex, f·cos θ·Le / pdf through a shadow ray; a
//     path that then hits a sampled emitter straight after a Phong bounce adds nothing;
//   - mis: both, each lobe's share weighted by the power heuristic between the emitter
//     sample's pdf and that lobe's own pdf P(lobe)·pdf_lobe (Veach 1997, §9.2).
// After the camera, a mirror or a refraction, and for emitters that cannot be sampled, an
// emitter hit counts in full as in the report.
#pragma once

#include "emitter_table.h"
#include "environment.h"
#include "intersect.h"
#include "sampler.h"
#include "sampling.h"
#include "settings.h"
#include "texture.h"

namespace cierzo {
inline namespace CIERZO_ISA_NAMESPACE {

// The lobes the roulette chooses from, in this order; kAbsorbed is the path's death.
enum Lobe : int32_t {
    kLobeDiffuse = 0,
    kLobeSpecular = 1,  // Phong specular
    kLobeMirror = 2,    // perfect specular
    kLobeRefract = 3,   // perfect refraction
    kLobeAbsorbed = 4,
    kLobeCount = 4,
};

// The report's material at one hit point, textures already evaluated.
template <class T>
struct Bsdf {
    Vec3<T> kd, ks, kr, kt;
    T shininess;  // Phong exponent s
    T ior;        // the object's refractive index
};

// The roulette's probabilities, apart from its draw: P(lobe i) = p_i·scale, p_i the max RGB
// of lobe i, scale = cap/Σp where Σp exceeds the survival cap (else 1); the continuation
// probability q = Σ P(lobe) = min(Σp, cap) is the chance a path goes on from the vertex, and
// P(lobe)/q the choice of the lobe once it does. choose_lobe draws from exactly these.
// `normalised` (the throughput roulette, settings.h): scale = 1/Σp, so q = 1 wherever some
// lobe is not black (throughput_roulette then decides the path's death).
template <class T>
struct LobeProbabilities {
    T lobe[4];   // diffuse, Phong specular, mirror, refraction
    T survival;  // q
};
template <class T>
LobeProbabilities<T> lobe_probabilities(const Bsdf<T>& m, float survival_cap,
                                        bool normalised = false) {
    const T pd = max_component(m.kd);
    const T ps = max_component(m.ks);
    const T pr = max_component(m.kr);
    const T pt = max_component(m.kt);
    const T sum = pd + ps + pr + pt;
    const T scale = normalised ? select(sum > T(0.0f), T(1.0f) / sum, T(0.0f))
                               : select(sum > T(survival_cap), T(survival_cap) / sum, T(1.0f));
    LobeProbabilities<T> out;
    out.lobe[0] = pd * scale, out.lobe[1] = ps * scale;
    out.lobe[2] = pr * scale, out.lobe[3] = pt * scale;
    out.survival = ((out.lobe[0] + out.lobe[1]) + out.lobe[2]) + out.lobe[3];
    return out;
}

// Russian roulette over the lobes (lobe_probabilities). Returns the chosen lobe and its
// probability.
// kOnly: the one lobe whose colour may be non-zero, where the caller knows it (a scene with
// one lobe kind); the others' thresholds are then exactly 0 and the same choice is made
// from that lobe alone, with bit-identical results.
template <int kOnly = kLobeCount, class T>
I32<T> choose_lobe(const Bsdf<T>& m, const T& u, float survival_cap, T& probability,
                   bool normalised = false) {
    using I = I32<T>;
    if constexpr (kOnly != kLobeCount) {
        const Vec3<T>* colour[4] = {&m.kd, &m.ks, &m.kr, &m.kt};
        const T p = max_component(*colour[kOnly]);
        const T c = normalised ? select(p > T(0.0f), T(1.0f), T(0.0f))
                               : p * select(p > T(survival_cap), T(survival_cap) / p, T(1.0f));
        const auto chosen = u < c;
        // (an absorbed path gets what the general form gives it: the last lobe's share)
        probability = kOnly == kLobeRefract ? c : select(chosen, c, T(0.0f));
        return select(mask_i32(chosen), I(kOnly), I(kLobeAbsorbed));
    }
    const LobeProbabilities<T> lp = lobe_probabilities(m, survival_cap, normalised);
    // The lobe index is the number of cumulative thresholds that u has passed
    const T c1 = lp.lobe[0], c2 = c1 + lp.lobe[1], c3 = c2 + lp.lobe[2], c4 = c3 + lp.lobe[3];
    const I one(1), zero(0);
    const I lobe = select(mask_i32(u >= c1), one, zero) + select(mask_i32(u >= c2), one, zero) +
                   select(mask_i32(u >= c3), one, zero) + select(mask_i32(u >= c4), one, zero);
    probability = select(u < c1, c1, select(u < c2, c2 - c1, select(u < c3, c3 - c2, c4 - c3)));
    return lobe;
}

// The normal on the side the ray arrives from (surfaces are two-sided for reflection).
template <class T>
Vec3<T> facing_normal(const Vec3<T>& n, const Vec3<T>& d) {
    return select(dot(n, d) < T(0.0f), n, -n);
}

// A sampled continuation: new direction and the throughput factor; dead lanes have weight 0.
template <class T>
struct Scatter {
    Vec3<T> dir;
    Vec3<T> weight;
};

// Phong diffuse kd/π. Uniform hemisphere (pdf 1/2π): weight = kd · 2cos θ / P.
// Cosine-weighted (pdf cos θ/π): weight = kd / P.
template <class T>
Scatter<T> sample_diffuse(const Bsdf<T>& m, const Vec3<T>& nf, const T& u1, const T& u2,
                          const T& probability, bool cosine) {
    const Vec3<T> local =
        cosine ? sample_cosine_hemisphere(u1, u2) : sample_uniform_hemisphere(u1, u2);
    const T factor = cosine ? T(1.0f) / probability : T(2.0f) * local.z / probability;
    return {to_world(local, nf), m.kd * factor};
}

// Phong specular ks·(s+2)/(2π)·cos^s α, sampled from pdf (s+1)/(2π)·cos^s α around the
// mirror direction: weight = ks · (s+2)/(s+1) · cos θi / P; 0 below the surface.
template <class T>
Scatter<T> sample_specular(const Bsdf<T>& m, const Vec3<T>& d, const Vec3<T>& nf, const T& u1,
                           const T& u2, const T& probability) {
    const Vec3<T> r = normalize(reflect(d, nf));
    const Vec3<T> dir = to_world(sample_phong_lobe(u1, u2, m.shininess), r);
    const T cos_i = dot(dir, nf);
    const T s = m.shininess;
    const T factor = (s + T(2.0f)) / ((s + T(1.0f)) * probability) * cos_i;
    return {dir, m.ks * select(cos_i > T(0.0f), factor, T(0.0f))};
}

// Perfect specular: the mirror direction, weight = kr / P. Reflected directions are
// renormalised: reflect() keeps |d| = 1 only to rounding, and over hundreds of bounces
// (mirrors, total internal reflection) the error would grow until a ray left a closed sphere.
template <class T>
Scatter<T> sample_mirror(const Bsdf<T>& m, const Vec3<T>& d, const Vec3<T>& nf,
                         const T& probability) {
    return {normalize(reflect(d, nf)), m.kr * (T(1.0f) / probability)};
}

// Perfect refraction by Snell's law, weight = kt / P. Entering (d·n < 0 for the outward
// geometric normal n) the index ratio is η = n_scene / n_object; leaving it is inverted.
// Total internal reflection sends the path along the mirror direction with the same weight.
// The direction bends about the shading normal ns (= n but on smooth meshes; either
// orientation) turned to the arriving side. With `shading` (a scene with smooth meshes), a
// refracted direction that does not cross the geometric surface, or a reflected one that does,
// gets weight 0 (kernels/shading.h). With ns = n the result is the same, bit for bit.
//
// Transport modes. The report's refraction keeps radiance as it is (weight kt, no η²), so its
// refraction operator is not its own adjoint (Veach 1997, §5.2): a camera path (radiance
// mode) has weight kt, and a path from the lights (importance mode) that crosses from index
// η_i to η_t has weight kt·(η_i/η_t)², so that both estimate the same integral. Entering glass
// from the scene (η 1 → 1.5) a light path's weight is kt/2.25; leaving it, 2.25·kt. Total
// internal reflection has weight kt in both modes. (docs/estimators.md says more.)
enum class Transport : int32_t { kRadiance = 0, kImportance = 1 };

template <Transport kMode = Transport::kRadiance, class T>
Scatter<T> sample_refraction(const Bsdf<T>& m, const Vec3<T>& d, const Vec3<T>& n,
                             const Vec3<T>& ns, const T& scene_ior, const T& probability,
                             bool shading = false) {
    const T dn = dot(d, n);
    const auto entering = dn < T(0.0f);
    const Vec3<T> ns_out = select(dot(ns, n) < T(0.0f), -ns, ns);
    const Vec3<T> nf = select(entering, ns_out, -ns_out);
    const T eta = select(entering, scene_ior / m.ior, m.ior / scene_ior);
    const T cos_i = -dot(d, nf);
    const T k = T(1.0f) - eta * eta * (T(1.0f) - cos_i * cos_i);
    const Vec3<T> refracted = fma(nf, eta * cos_i - sqrt(max(k, T(0.0f))), d * eta);
    const auto reflected = k < T(0.0f);
    const Vec3<T> dir = normalize(select(reflected, reflect(d, nf), refracted));
    Vec3<T> weight = m.kt * (T(1.0f) / probability);
    if constexpr (kMode == Transport::kImportance)
        weight = weight * select(reflected, T(1.0f), eta * eta);
    if (shading) {
        // The side it should leave to: the arriving side when reflected, the other one when
        // refracted (d·n < 0 on the arriving side of n)
        const T side = dot(dir, n) * dn;
        const Mask<T> ok = (reflected & (side < T(0.0f))) | ((!reflected) & (side > T(0.0f)));
        weight = select(ok, weight, Vec3<T>(T(0.0f)));
    }
    return {dir, weight};
}

// f(ωi, ωo)·cos θi of the Phong lobes for a light direction wi (unit, towards the light):
// kd/π + ks·(s+2)/(2π)·cos^s α, α between wi and the mirror direction of d, restricted to
// the lobe's half-space cos α > 0 (the half the specular sampler covers). 0 when wi is
// below the surface seen from d.
// The Phong BRDF is symmetric (cos α = wi·reflect(d) = reflect(wi)·d), so radiance and
// importance evaluate it alike: f itself is phong_f, the same without the cosine (0 below).
template <class T>
Vec3<T> phong_f(const Bsdf<T>& m, const Vec3<T>& d, const Vec3<T>& nf, const Vec3<T>& wi,
                T& cos_i) {
    cos_i = dot(wi, nf);
    const T r = dot(wi, reflect(d, nf));
    const T s = m.shininess;
    // (0 outside the lobe's half-space, s = 0 included, where cos^0 would be 1)
    const T lobe = select(r > T(0.0f), pow_s(max(r, T(0.0f)), s), T(0.0f));
    const T spec = (s + T(2.0f)) * T(0.5f * kInvPi) * lobe;
    return fma(m.ks, spec, m.kd * T(kInvPi));
}
template <class T>
Vec3<T> phong_f_cos(const Bsdf<T>& m, const Vec3<T>& d, const Vec3<T>& nf, const Vec3<T>& wi) {
    T cos_i;
    const Vec3<T> f = phong_f(m, d, nf, wi, cos_i);
    return f * select(cos_i > T(0.0f), cos_i, T(0.0f));
}

// ---- Beyond the report: emitter sampling and multiple importance sampling ---------------

// The roulette's probabilities of the diffuse and the Phong specular lobe at a vertex (the
// same scaling as choose_lobe), which the emitter sample's MIS weights need.
template <class T>
void phong_lobe_probabilities(const Bsdf<T>& m, float survival_cap, T& p_diffuse,
                              T& p_specular, bool normalised = false) {
    const LobeProbabilities<T> lp = lobe_probabilities(m, survival_cap, normalised);
    p_diffuse = lp.lobe[0];
    p_specular = lp.lobe[1];
}

// The diffuse and specular terms of phong_f_cos apart, and each lobe's own sampling density
// of wi (uniform 1/2π or cos θ/π; (s+1)/(2π)·cos^s α), 0 where the lobe cannot sample wi.
template <class T>
struct PhongLobes {
    Vec3<T> diffuse, specular;  // f·cos θi of each lobe
    T pdf_diffuse, pdf_specular;
};
template <class T>
PhongLobes<T> phong_lobes(const Bsdf<T>& m, const Vec3<T>& d, const Vec3<T>& nf,
                          const Vec3<T>& wi, bool cosine) {
    const T cos_i = dot(wi, nf);
    const auto above = cos_i > T(0.0f);
    const T c = select(above, cos_i, T(0.0f));
    PhongLobes<T> out;
    out.diffuse = m.kd * (T(kInvPi) * c);
    out.pdf_diffuse = cosine ? c * T(kInvPi) : select(above, T(0.5f * kInvPi), T(0.0f));
    out.specular = Vec3<T>(T(0.0f));
    out.pdf_specular = T(0.0f);
    // (cos^s α only where some lane has a specular lobe: it costs an exp and a log)
    if (any(max_component(m.ks) > T(0.0f))) {
        const T cos_a = dot(wi, normalize(reflect(d, nf)));
        const T s = m.shininess;
        const T lobe = select(cos_a > T(0.0f), pow_s(max(cos_a, T(0.0f)), s), T(0.0f));
        out.specular = m.ks * ((s + T(2.0f)) * T(0.5f * kInvPi) * lobe * c);
        out.pdf_specular = (s + T(1.0f)) * T(0.5f * kInvPi) * lobe;
    }
    return out;
}

// The report's material evaluated as a BSDF, for estimators that weigh strategies from both
// ends of a path: for the directions wo (towards where the path came from) and wi (the
// other one), both unit, f(wo, wi) of the Phong lobes (delta lobes are never evaluated: 0),
// the cosine of wi to nf (the geometric or shading normal on wo's side), and the densities
// of the BSDF strategy, the roulette's P(lobe) times the lobe's own density: `pdf` of
// sampling wi from wo, `pdf_reverse` of sampling wo from wi. The Phong lobes are symmetric,
// so f and the specular density are the same both ways; the diffuse density is that of the
// sampled direction (uniform 1/2π, or cos θ/π), and 0 below the surface. f is 0 where wi is
// below the surface seen from wo (the material only reflects through these lobes).
template <class T>
struct BsdfEval {
    Vec3<T> f;
    T cos_i;
    T pdf, pdf_reverse;
};
template <class T>
BsdfEval<T> bsdf_eval(const Bsdf<T>& m, const Vec3<T>& wo, const Vec3<T>& nf, const Vec3<T>& wi,
                      float survival_cap, bool cosine, bool normalised = false) {
    BsdfEval<T> out;
    const Vec3<T> d = -wo;
    const Vec3<T> f = phong_f(m, d, nf, wi, out.cos_i);
    const T cos_o = dot(wo, nf);
    const auto reflects = (out.cos_i > T(0.0f)) & (cos_o > T(0.0f));
    out.f = select(reflects, f, Vec3<T>(T(0.0f)));
    const LobeProbabilities<T> lp = lobe_probabilities(m, survival_cap, normalised);
    const auto diffuse_pdf = [&](const T& c) {
        return cosine ? max(c, T(0.0f)) * T(kInvPi) : select(c > T(0.0f), T(0.5f * kInvPi), T(0.0f));
    };
    const T cos_a = dot(wi, normalize(reflect(d, nf)));
    const T lobe = select(cos_a > T(0.0f), pow_s(max(cos_a, T(0.0f)), m.shininess), T(0.0f));
    const T specular = (m.shininess + T(1.0f)) * T(0.5f * kInvPi) * lobe;
    out.pdf = lp.lobe[0] * diffuse_pdf(out.cos_i) + lp.lobe[1] * specular;
    out.pdf_reverse = lp.lobe[0] * diffuse_pdf(cos_o) + lp.lobe[1] * specular;
    return out;
}

// The density with which the BSDF strategy sampled `dir` at a vertex where the roulette chose
// `lobe` with `probability`: P(lobe)·pdf_lobe(dir) for the Phong lobes, 0 for a mirror or a
// refraction (a delta lobe: an emitter it reaches counts in full).
template <int kLobe, class T>
T sampled_lobe_pdf(const Bsdf<T>& m, const Vec3<T>& d, const Vec3<T>& nf, const Vec3<T>& dir,
                   const T& probability, bool cosine) {
    if constexpr (kLobe == kLobeDiffuse) {
        const T c = max(dot(dir, nf), T(0.0f));
        return probability * (cosine ? c * T(kInvPi) : T(0.5f * kInvPi));
    } else if constexpr (kLobe == kLobeSpecular) {
        const T cos_a = dot(dir, normalize(reflect(d, nf)));
        const T lobe = select(cos_a > T(0.0f), pow_s(max(cos_a, T(0.0f)), m.shininess), T(0.0f));
        return probability * (m.shininess + T(1.0f)) * T(0.5f * kInvPi) * lobe;
    } else {
        return T(0.0f);
    }
}

// The power heuristic weight of strategy a against b, pa²/(pa² + pb²), written so that huge
// or zero densities give 0 or 1 and never NaN: 1 where pb = 0.
template <class T>
T power_heuristic(const T& pa, const T& pb) {
    const T r = pb / pa;
    return select(pb > T(0.0f), T(1.0f) / fma(r, r, T(1.0f)), T(1.0f));
}

// One emitter sample seen from x: the direction and distance to the sampled point, the
// solid-angle density of that direction (the emitter's pmf included), the emitter's Le, and
// whether the sample is usable (a degenerate one is dropped).
template <class T>
struct EmitterSample {
    Vec3<T> wi;
    T t, pdf;
    Vec3<T> le;
    Mask<T> ok;
    Mask<T> sphere;
    I32<T> id;             // the emitter chosen
    Mask<T> environment;   // it is the environment
};

// 1 - cos θmax of the cone a sphere of squared radius r2 subtends at squared distance dc2,
// from sin²θmax/(1 + cos θmax) (no cancellation when the sphere is small or far).
template <class T>
T cone_one_minus_cos(const T& r2, const T& dc2) {
    const T sin2 = min(r2 / dc2, T(1.0f));
    return sin2 / (T(1.0f) + sqrt(max(T(1.0f) - sin2, T(0.0f))));
}

// Field k of emitter id's record; a scene with one emitter broadcasts it (no gather).
template <class T>
T emitter_field(const EmitterTable& e, const I32<T>& id, int k) {
    if (e.count == 1) return T(e.data[k]);
    return gather_table(e.data, id * I32<T>(kEmitterStride) + I32<T>(k));
}
template <class T, class E>
auto emitter_entry(const EmitterTable& e, const E* table, const I32<T>& id) {
    using Lanes = std::conditional_t<std::is_same_v<E, float>, T, I32<T>>;
    if (e.count == 1) return Lanes(table[0]);
    return Lanes(gather_table(table, id));
}

// Whether emitter id is a sphere (else a triangle or a rectangle), and a rectangle.
template <class T>
Mask<T> emitter_is_sphere(const EmitterTable& e, const I32<T>& id) {
    return mask_f32(emitter_entry<T>(e, e.kind, id) == I32<T>(kEmitterSphere));
}
template <class T>
Mask<T> emitter_is_rectangle(const EmitterTable& e, const I32<T>& id) {
    return mask_f32(emitter_entry<T>(e, e.kind, id) == I32<T>(kEmitterRectangle));
}

// A point uniform by area on the triangle v0, v0 + e1, v0 + e2 (below), or on the
// rectangle v0 + [0, 1]·e1 + [0, 1]·e2 where `rectangle`.
template <class T>
Vec3<T> sample_triangle_area(const Vec3<T>& v0, const Vec3<T>& e1, const Vec3<T>& e2,
                             const T& u1, const T& u2);
template <class T>
Vec3<T> sample_planar_area(const Vec3<T>& v0, const Vec3<T>& e1, const Vec3<T>& e2,
                           const T& u1, const T& u2, const Mask<T>& rectangle) {
    const Vec3<T> on_triangle = sample_triangle_area(v0, e1, e2, u1, u2);
    if (!any(rectangle)) return on_triangle;
    return select(rectangle, fma(e2, u2, fma(e1, u1, v0)), on_triangle);
}

// A point uniform by area on the triangle v0, v0 + e1, v0 + e2: barycentrics
// (√u1(1 - u2), √u1·u2) of e1 and e2.
template <class T>
Vec3<T> sample_triangle_area(const Vec3<T>& v0, const Vec3<T>& e1, const Vec3<T>& e2,
                             const T& u1, const T& u2) {
    const T su = sqrt(u1);
    return fma(e2, su * u2, fma(e1, su - su * u2, v0));
}

// v scaled to unit length, or 0 where it has none.
template <class T>
Vec3<T> unit_or_zero(const Vec3<T>& v) {
    const T len = length(v);
    return v * select(len > T(0.0f), T(1.0f) / len, T(0.0f));
}

// The solid angle of the spherical triangle with corners at the unit directions a, b, c
// (Van Oosterom and Strackee 1983): Ω = 2·atan2(|a·(b × c)|, 1 + a·b + b·c + c·a).
template <class T>
T spherical_triangle_area(const Vec3<T>& a, const Vec3<T>& b, const Vec3<T>& c) {
    const T triple = abs(dot(a, cross(b, c)));
    const T den = T(1.0f) + dot(a, b) + dot(b, c) + dot(c, a);
    return T(2.0f) * atan2(triple, den);
}

// A direction uniform by solid angle over the spherical triangle a, b, c (unit directions)
// of area Ω (Arvo 1995, "Stratified Sampling of Spherical Triangles"): u1 chooses the area
// Â = u1·Ω of the sub-triangle a, b, ĉ, whose third corner ĉ on the arc from a to c follows
// from the spherical law of cosines; u2 chooses the point on the arc from b to ĉ so that
// the area is uniform along it.
template <class T>
Vec3<T> sample_spherical_triangle(const Vec3<T>& a, const Vec3<T>& b, const Vec3<T>& c,
                                  const T& area, const T& u1, const T& u2) {
    // The angle α at a, between the great arcs to b and to c
    const T cos_alpha =
        max(min(dot(unit_or_zero(cross(a, b)), unit_or_zero(cross(a, c))), T(1.0f)), T(-1.0f));
    const T sin_alpha = sqrt(max(T(1.0f) - cos_alpha * cos_alpha, T(0.0f)));
    T sin_area, cos_area;
    sincos_2pi(u1 * area * T(0.5f * kInvPi), sin_area, cos_area);
    const T s = sin_area * cos_alpha - cos_area * sin_alpha;  // sin(Â - α)
    const T t = cos_area * cos_alpha + sin_area * sin_alpha;  // cos(Â - α)
    const T u = t - cos_alpha;
    const T v = s + sin_alpha * dot(a, b);  // (cos of the arc from a to b)
    const T den = (v * s + u * t) * sin_alpha;
    const T q = max(min(select(den != T(0.0f), ((v * t - u * s) * cos_alpha - v) / den, T(1.0f)),
                        T(1.0f)),
                    T(-1.0f));
    const Vec3<T> c_hat =
        fma(unit_or_zero(c - a * dot(c, a)), sqrt(max(T(1.0f) - q * q, T(0.0f))), a * q);
    const T z = T(1.0f) - u2 * (T(1.0f) - dot(c_hat, b));
    // (unit again: where the corners are nearly coplanar with the apex, rounding leaves the
    // construction a little off the sphere)
    return unit_or_zero(
        fma(unit_or_zero(c_hat - b * dot(c_hat, b)), sqrt(max(T(1.0f) - z * z, T(0.0f))), b * z));
}

// The triangle v0, v0 + e1, v0 + e2 as seen from x: the unit directions to its corners and
// its solid angle; `spherical` where triangle_solid_angle samples it by solid angle (at
// least kMinTriangleSolidAngle, and x off the triangle's plane: in it, the formula's 2π is
// the limit from one side of a triangle seen edge-on).
template <class T>
struct TriangleView {
    Vec3<T> a, b, c;
    T omega;
    Mask<T> spherical;
};
template <class T>
TriangleView<T> triangle_view(const Vec3<T>& x, const Vec3<T>& v0, const Vec3<T>& e1,
                              const Vec3<T>& e2) {
    TriangleView<T> v;
    const Vec3<T> to0 = v0 - x;
    v.a = unit_or_zero(to0);
    v.b = unit_or_zero(to0 + e1);
    v.c = unit_or_zero(to0 + e2);
    v.omega = spherical_triangle_area(v.a, v.b, v.c);
    v.spherical = (v.omega >= T(kMinTriangleSolidAngle)) & (v.omega <= T(2.0f * kPi)) &
                  (dot(v.a, cross(v.b, v.c)) != T(0.0f));
    return v;
}

// The rectangle corner + [0, 1]·e1 + [0, 1]·e2 (e1 ⊥ e2) as seen from x, in the frame of
// Ureña, Fajardo and King ("An Area-Preserving Parametrization for Spherical Rectangles",
// 2013): x at the origin, the rectangle in the plane z = z0 < 0 spanning [x0, x1] × [y0, y1];
// its solid angle Ω and what sampling it needs; `spherical` where it is sampled by solid
// angle (Ω at least kMinTriangleSolidAngle, x off its plane).
template <class T>
struct RectangleView {
    Vec3<T> ex, ey, ez;
    T x0, x1, y0, y1, z0;
    T b0, b1, k, omega;
    Mask<T> spherical;
};
template <class T>
RectangleView<T> rectangle_view(const Vec3<T>& x, const Vec3<T>& corner, const Vec3<T>& e1,
                                const Vec3<T>& e2) {
    RectangleView<T> r;
    const T l1 = length(e1), l2 = length(e2);
    r.ex = e1 * (T(1.0f) / l1);
    r.ey = e2 * (T(1.0f) / l2);
    r.ez = cross(r.ex, r.ey);
    const Vec3<T> d = corner - x;
    r.x0 = dot(d, r.ex), r.y0 = dot(d, r.ey);
    const T z = dot(d, r.ez);
    r.ez = select(z > T(0.0f), -r.ez, r.ez);
    r.z0 = -abs(z);
    r.x1 = r.x0 + l1, r.y1 = r.y0 + l2;
    // The unit normals of the planes through x and each side, and the angles between them
    const T z2 = r.z0 * r.z0;
    const T i0 = T(1.0f) / sqrt(z2 + r.y0 * r.y0), i1 = T(1.0f) / sqrt(z2 + r.x1 * r.x1);
    const T i2 = T(1.0f) / sqrt(z2 + r.y1 * r.y1), i3 = T(1.0f) / sqrt(z2 + r.x0 * r.x0);
    const auto angle = [](const T& c) { return acos(max(min(c, T(1.0f)), T(-1.0f))); };
    // n0 = (0, z0, -y0)·i0, n1 = (-z0, 0, x1)·i1, n2 = (0, -z0, y1)·i2, n3 = (z0, 0, -x0)·i3
    const T g0 = angle(r.y0 * r.x1 * i0 * i1);
    const T g1 = angle(-r.x1 * r.y1 * i1 * i2);
    const T g2 = angle(r.y1 * r.x0 * i2 * i3);
    const T g3 = angle(-r.x0 * r.y0 * i3 * i0);
    r.b0 = -r.y0 * i0;
    r.b1 = r.y1 * i2;
    r.k = T(2.0f * kPi) - g2 - g3;
    r.omega = g0 + g1 - r.k;  // g0 + g1 + g2 + g3 - 2π
    r.spherical = (r.omega >= T(kMinTriangleSolidAngle)) & (r.omega <= T(2.0f * kPi)) &
                  (r.z0 < T(0.0f));
    return r;
}

// A point of the rectangle whose direction from x is uniform by solid angle over it (Ureña
// et al.): u1 chooses the x of the point through the area of the spherical rectangle left of
// it, u2 the y uniformly in the solid angle's measure along that column.
template <class T>
Vec3<T> sample_spherical_rectangle(const RectangleView<T>& r, const Vec3<T>& x, const T& u1,
                                   const T& u2) {
    const T au = fma(u1, r.omega, r.k);
    T s, c;
    sincos_2pi(au * T(0.5f * kInvPi), s, c);
    const T fu = (c * r.b0 - r.b1) / s;
    const T cu = max(min(select(fu >= T(0.0f), T(1.0f), T(-1.0f)) /
                             sqrt(fma(fu, fu, r.b0 * r.b0)),
                         T(1.0f)),
                     T(-1.0f));
    const T xu = max(min(-(cu * r.z0) / sqrt(max(T(1.0f) - cu * cu, T(1e-12f))), r.x1), r.x0);
    const T d2 = fma(xu, xu, r.z0 * r.z0);
    const T h0 = r.y0 / sqrt(d2 + r.y0 * r.y0), h1 = r.y1 / sqrt(d2 + r.y1 * r.y1);
    const T hv = fma(u2, h1 - h0, h0);
    const T hv2 = hv * hv;
    const T yv = select(hv2 < T(1.0f - 1e-6f), hv * sqrt(d2) / sqrt(max(T(1.0f) - hv2, T(1e-12f))),
                        r.y1);
    return fma(r.ez, r.z0, fma(r.ey, min(max(yv, r.y0), r.y1), fma(r.ex, xu, x)));
}

// The emitter chosen by power through the alias table (kernels/emitter_table.h): slot
// ⌊u_pick·count⌋, kept if u_alias < its q, else its alias. Its pmf and kind with it.
// The one choice rule of every emitter sampler (here and kernels/light_sampling.h).
template <class T>
struct EmitterChoice {
    I32<T> id;
    T pmf;
    Mask<T> sphere, rectangle, environment;
};
template <class T>
EmitterChoice<T> choose_emitter(const EmitterTable& e, const T& u_pick, const T& u_alias) {
    using I = I32<T>;
    const I slot = min(to_int(u_pick * T(float(e.count))), I(e.count - 1));
    const I id = e.count == 1 ? I(0)
                              : select(mask_i32(u_alias < gather_table(e.alias_q, slot)), slot,
                                       gather_table(e.alias, slot));
    const I32<T> kind = emitter_entry<T>(e, e.kind, id);
    return {id, emitter_entry<T>(e, e.pmf, id), mask_f32(kind == I32<T>(kEmitterSphere)),
            mask_f32(kind == I32<T>(kEmitterRectangle)),
            mask_f32(kind == I32<T>(kEmitterEnvironment))};
}

// Chooses an emitter by power (alias table) and samples it from x:
//   - a sphere seen from outside by the solid angle of its cone, uniformly
//     (pdf 1 / (2π(1 - cos θmax))); from inside, every direction (pdf 1/4π);
//   - a triangle or a rectangle by area (pdf d² / (A·|cos θl|) in solid angle), or with
//     `solid_angle` uniformly over the spherical triangle or rectangle it subtends (pdf 1/Ω)
//     where Ω is at least kMinTriangleSolidAngle;
//   - the environment by its own distribution (kernels/environment.h), at distance kRayFar.
// A sphere's sampled distance is the ray's own intersection with it, so a shadow ray that
// stops just short of t sees the same surface the sample lies on.
template <class T>
EmitterSample<T> sample_emitter(const EmitterTable& e, const Vec3<T>& x, const T& u_pick,
                                const T& u_alias, const T& u1, const T& u2,
                                bool solid_angle = false) {
    const EmitterChoice<T> choice = choose_emitter(e, u_pick, u_alias);
    const I32<T>& id = choice.id;
    const T& pmf = choice.pmf;
    const Mask<T>& sphere = choice.sphere;
    const auto at = [&](int k) { return emitter_field<T>(e, id, k); };
    const Vec3<T> p0{at(0), at(1), at(2)};
    const T size = at(3);
    EmitterSample<T> out;
    out.le = {at(13), at(14), at(15)};
    out.sphere = sphere;
    out.id = id;
    out.environment = choice.environment;
    T s, c;
    sincos_2pi(u2, s, c);
    out.wi = Vec3<T>(T(0.0f));
    out.t = T(0.0f);
    out.pdf = T(1.0f);
    out.ok = T(0.0f) > T(1.0f);
    if (any(sphere)) {
        const Vec3<T> to_c = p0 - x;
        const T dc2 = dot(to_c, to_c);
        const T r2 = size * size;
        const auto inside = dc2 <= r2;
        const T one_minus = cone_one_minus_cos(r2, dc2);
        // Inside: uniform on the unit sphere; outside: uniform in the cone around x → c
        const T a = select(inside, T(2.0f) * u1, u1 * one_minus);  // 1 - cos θ
        const T sin_t = sqrt(max(a * (T(2.0f) - a), T(0.0f)));
        const Vec3<T> local{sin_t * c, sin_t * s, T(1.0f) - a};
        const Vec3<T> axis = select(inside, Vec3<T>(T(0.0f), T(0.0f), T(1.0f)),
                                    to_c * (T(1.0f) / sqrt(dc2)));
        const Vec3<T> dir = to_world(local, axis);
        T t(0.0f);
        const auto hit = intersect_sphere(Ray<T>{x, dir}, p0, size, T(kRayFar), t);
        // A direction inside the cone that rounding makes miss (at the silhouette of a
        // small, far sphere) stops at its closest approach: it touches the sphere there
        t = select(hit, t, max(dot(to_c, dir), T(0.0f)));
        const T pdf = pmf * select(inside, T(0.25f * kInvPi), T(0.5f * kInvPi) / one_minus);
        out.wi = select(sphere, dir, out.wi);
        out.t = select(sphere, t, out.t);
        out.pdf = select(sphere, pdf, out.pdf);
        out.ok = sphere & (inside | ((one_minus > T(0.0f)) & (t > T(0.0f))));
    }
    const bool environment = e.environment.emitter >= 0;
    const auto triangle = environment ? !(sphere | choice.environment) : !sphere;  // (or a rectangle)
    if (environment && any(choice.environment)) {
        const auto env = choice.environment;
        const EnvironmentSample<T> es = sample_environment(e.environment, u1, u2);
        out.wi = select(env, es.wi, out.wi);
        out.t = select(env, T(kRayFar), out.t);
        out.pdf = select(env, pmf * es.pdf, out.pdf);
        out.le = select(env, es.le, out.le);
        out.ok = out.ok | (env & es.ok);
    }
    if (any(triangle)) {
        const Mask<T>& rectangle = choice.rectangle;
        const Vec3<T> e1{at(4), at(5), at(6)}, e2{at(7), at(8), at(9)}, nl{at(10), at(11), at(12)};
        const Vec3<T> p = sample_planar_area(p0, e1, e2, u1, u2, rectangle);
        const Vec3<T> to = p - x;
        const T d2 = dot(to, to);
        const T dist = sqrt(d2);
        Vec3<T> wi = to * (T(1.0f) / dist);
        T cos_l = abs(dot(nl, wi));
        T pdf = pmf * d2 / (size * cos_l);
        T t = dist;
        if (solid_angle && any(rectangle)) {
            const RectangleView<T> r = rectangle_view(x, p0, e1, e2);
            const auto spherical = rectangle & r.spherical;
            if (any(spherical)) {
                const Vec3<T> to_s = sample_spherical_rectangle(r, x, u1, u2) - x;
                const T ts = length(to_s);
                const Vec3<T> ws = to_s * (T(1.0f) / ts);
                wi = select(spherical, ws, wi);
                t = select(spherical, ts, t);
                cos_l = select(spherical, abs(dot(nl, ws)), cos_l);
                pdf = select(spherical, pmf / r.omega, pdf);
            }
        }
        if (solid_angle && !all(rectangle)) {
            const TriangleView<T> v = triangle_view(x, p0, e1, e2);
            const auto spherical = triangle & !rectangle & v.spherical;
            if (any(spherical)) {
                // The direction, and the distance to the triangle's plane along it
                const Vec3<T> ws = sample_spherical_triangle(v.a, v.b, v.c, v.omega, u1, u2);
                const T cos_s = dot(nl, ws);
                wi = select(spherical, ws, wi);
                t = select(spherical, dot(p0 - x, nl) / cos_s, t);
                cos_l = select(spherical, abs(cos_s), cos_l);
                pdf = select(spherical, pmf / v.omega, pdf);
            }
        }
        out.wi = select(triangle, wi, out.wi);
        out.t = select(triangle, t, out.t);
        out.pdf = select(triangle, pdf, out.pdf);
        out.ok = out.ok | (triangle & (cos_l > T(1e-7f)) & (t > T(0.0f)) & (t < T(kRayFar)) &
                           (pdf < T(kRayFar)));
    }
    return out;
}

// The solid-angle density with which sample_emitter would choose direction d from x towards
// the point at distance t on emitter id (which the ray x + t·d has hit): the hit side of MIS.
template <class T>
T emitter_pdf(const EmitterTable& e, const I32<T>& id, const Vec3<T>& x, const Vec3<T>& d,
              const T& t, bool solid_angle = false) {
    const auto at = [&](int k) { return emitter_field<T>(e, id, k); };
    const T pmf = emitter_entry<T>(e, e.pmf, id);
    const T size = at(3);
    const auto sphere = emitter_is_sphere<T>(e, id);
    T pdf = T(0.0f);
    if (any(sphere)) {
        const Vec3<T> to_c = Vec3<T>{at(0), at(1), at(2)} - x;
        const T dc2 = dot(to_c, to_c);
        const T r2 = size * size;
        const T one_minus = cone_one_minus_cos(r2, dc2);
        pdf = select(dc2 <= r2, T(0.25f * kInvPi), T(0.5f * kInvPi) / one_minus);
    }
    if (any(!sphere)) {
        const Vec3<T> nl{at(10), at(11), at(12)};
        T area_pdf = t * t / (size * abs(dot(nl, d)));
        if (solid_angle) {
            const Vec3<T> p0{at(0), at(1), at(2)}, e1{at(4), at(5), at(6)}, e2{at(7), at(8), at(9)};
            const auto rectangle = emitter_is_rectangle<T>(e, id);
            if (any(rectangle)) {
                const RectangleView<T> r = rectangle_view(x, p0, e1, e2);
                area_pdf = select(rectangle & r.spherical, T(1.0f) / r.omega, area_pdf);
            }
            if (!all(rectangle)) {
                const TriangleView<T> v = triangle_view(x, p0, e1, e2);
                area_pdf = select((!rectangle) & v.spherical, T(1.0f) / v.omega, area_pdf);
            }
        }
        pdf = select(sphere, pdf, area_pdf);
    }
    return pmf * pdf;
}

// The shadow ray of one emitter sample at a Phong vertex and what it brings if unblocked
// (before the path's throughput): Le·Σ_lobe f_lobe·cos θ·w_lobe / pdf, w = 1 for nee, the
// power heuristic against P(lobe)·pdf_lobe for mis.
template <class T>
struct EmitterShadow {
    Vec3<T> wi;
    T tmax;
    Vec3<T> value;
    Mask<T> ok;
};
template <class T>
EmitterShadow<T> emitter_shadow(const EmitterTable& e, const EstimatorSettings& est,
                                const Bsdf<T>& m, const Vec3<T>& d, const Vec3<T>& nf,
                                const Vec3<T>& origin, const SampleStream<T>& rng,
                                const U32<T>& bounce) {
    // (one emitter: nothing to choose, and no numbers drawn for it)
    T u_pick(0.0f), u_alias(0.0f), u1, u2;
    if (e.count > 1) uniform_pair<T>(rng, bounce, Purpose::kEmitterPick, u_pick, u_alias);
    uniform2<T>(rng, bounce, Purpose::kEmitter1, u1, u2);
    const EmitterSample<T> ls =
        sample_emitter(e, origin, u_pick, u_alias, u1, u2, est.triangle_solid_angle);
    const T pdf = ls.pdf * T(est.light_pdf_scale);
    const PhongLobes<T> f = phong_lobes(m, d, nf, ls.wi, est.cosine_diffuse);
    Vec3<T> fcos;
    if (est.kind == Estimator::kMis) {
        T pd, ps;
        phong_lobe_probabilities(m, est.survival_cap, pd, ps, normalised_lobes(est));
        fcos = f.diffuse * power_heuristic(pdf, pd * f.pdf_diffuse) +
               f.specular * power_heuristic(pdf, ps * f.pdf_specular);
    } else {
        fcos = f.diffuse + f.specular;
    }
    EmitterShadow<T> out;
    out.wi = ls.wi;
    // (a sphere's t is its own intersection, rounded as the shadow ray's will be; a point on
    // a triangle is exact)
    out.tmax = ls.t * select(ls.sphere, T(1.0f - 1e-3f), T(1.0f - 1e-4f));
    out.value = ls.le * fcos * (T(1.0f) / pdf);
    out.ok = ls.ok & (max_component(out.value) > T(0.0f)) & (out.value.x < T(kRayFar)) &
             (out.value.y < T(kRayFar)) & (out.value.z < T(kRayFar));
    return out;
}

// The weight of a sampled emitter's Le when the BSDF strategy has hit it, coming from x in
// direction d at distance t after a vertex whose lobe sampled d with density lobe_pdf (0:
// the camera, a mirror or a refraction, where it counts in full). nee: 0 after a Phong
// lobe (its emitter samples counted this light already); mis: the power heuristic; lt: 0
// after any vertex, the camera included (the light paths bring it), 1 for an emitter that
// is not sampled.
template <class T>
T emitter_hit_weight(const EmitterTable& e, Estimator kind, const I32<T>& id, const T& lobe_pdf,
                     const Vec3<T>& x, const Vec3<T>& d, const T& t, bool solid_angle = false) {
    if (kind == Estimator::kLt)  // light paths bring every sampled emitter's light
        return select(mask_f32(id >= I32<T>(0)), T(0.0f), T(1.0f));
    const auto sampled = mask_f32(id >= I32<T>(0)) & (lobe_pdf > T(0.0f));
    if (kind == Estimator::kReport || none(sampled)) return T(1.0f);
    if (kind == Estimator::kNee) return select(sampled, T(0.0f), T(1.0f));
    const T light =
        emitter_pdf(e, select(mask_i32(sampled), id, I32<T>(0)), x, d, t, solid_angle);
    return select(sampled, power_heuristic(lobe_pdf, light), T(1.0f));
}

// The weight of the environment's radiance when a path escapes in direction d after a
// vertex whose lobe sampled d with density lobe_pdf (0: the camera, a mirror or a
// refraction, where it counts in full), as emitter_hit_weight weighs a sampled emitter: nee
// 0 after a Phong lobe, mis the power heuristic, where the estimator samples it (`nee`:
// PathContext::nee); report, and lt (whose light paths never start on it), 1.
template <class T>
T environment_weight(const EmitterTable& e, Estimator kind, bool nee, const T& lobe_pdf,
                     const Vec3<T>& d) {
    if (kind == Estimator::kReport || kind == Estimator::kLt || !nee || e.environment.emitter < 0)
        return T(1.0f);
    const auto sampled = lobe_pdf > T(0.0f);
    if (none(sampled)) return T(1.0f);
    if (kind == Estimator::kNee) return select(sampled, T(0.0f), T(1.0f));
    const T light = T(e.pmf[e.environment.emitter]) * environment_pdf(e.environment, d);
    return select(sampled, power_heuristic(lobe_pdf, light), T(1.0f));
}

}  // namespace CIERZO_ISA_NAMESPACE
}  // namespace cierzo
