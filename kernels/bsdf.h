// The report's material at a hit as the estimators sample and evaluate it: the lobes the
// roulette chooses from (diffuse, Phong specular, mirror, refraction), each lobe's sampler
// and weight, and f with its densities for the strategies MIS weighs (kernels/mis_weights.h).
#pragma once

#include "sampling.h"

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

// ---- Beyond the report: the Phong lobes apart, and the material as a BSDF -------------

// The roulette's probabilities of the diffuse and the Phong specular lobe at a vertex (the
// same scaling as choose_lobe), which the emitter sample's MIS weights need.
template <class T>
void phong_lobe_probabilities(const Bsdf<T>& m, float survival_cap, T& p_diffuse, T& p_specular,
                              bool normalised = false) {
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
PhongLobes<T> phong_lobes(const Bsdf<T>& m, const Vec3<T>& d, const Vec3<T>& nf, const Vec3<T>& wi,
                          bool cosine) {
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
        return cosine ? max(c, T(0.0f)) * T(kInvPi)
                      : select(c > T(0.0f), T(0.5f * kInvPi), T(0.0f));
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

}  // namespace CIERZO_ISA_NAMESPACE
}  // namespace cierzo
