// The report's path-vertex estimator, written once for both integrators (T = float for the
// scalar reference, T = xsimd::batch for the wavefront kernels). At each hit:
//   - an emitter ends the path and adds throughput · Le;
//   - a Phong vertex (kd or ks non-zero) sends a shadow ray to every point light, adding
//     throughput · f(ωi, ωo) · cos θi · I / d²;
//   - one lobe is chosen by Russian roulette with probability proportional to its max RGB,
//     scaled so that at least 1 - survival_cap of the time the path dies;
//   - the chosen lobe samples a direction and the throughput is multiplied by
//     f · cos θ / (pdf · P(lobe)).
#pragma once

#include "sampling.h"
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

// Settings of the estimator that a scene or the command line may change.
struct EstimatorSettings {
    // The roulette's total survival probability never exceeds this, so every path ends.
    float survival_cap = 0.9f;
    // Diffuse directions: uniform over the hemisphere as in the report, or cosine-weighted.
    bool cosine_diffuse = false;
};

// The report's material at one hit point, textures already evaluated.
template <class T>
struct Bsdf {
    Vec3<T> kd, ks, kr, kt;
    T shininess;  // Phong exponent s
    T ior;        // the object's refractive index
};

// Russian roulette over the lobes. p_i = max RGB of lobe i; if Σ p_i exceeds the survival
// cap, all are scaled down so they sum to it. Returns the chosen lobe and its probability.
// kOnly: the one lobe whose colour may be non-zero, where the caller knows it (a scene with
// one lobe kind); the others' thresholds are then exactly 0 and the same choice is made
// from that lobe alone, with bit-identical results.
template <int kOnly = kLobeCount, class T>
I32<T> choose_lobe(const Bsdf<T>& m, const T& u, float survival_cap, T& probability) {
    using I = I32<T>;
    if constexpr (kOnly != kLobeCount) {
        const Vec3<T>* colour[4] = {&m.kd, &m.ks, &m.kr, &m.kt};
        const T p = max_component(*colour[kOnly]);
        const T c = p * select(p > T(survival_cap), T(survival_cap) / p, T(1.0f));
        const auto chosen = u < c;
        // (an absorbed path gets what the general form gives it: the last lobe's share)
        probability = kOnly == kLobeRefract ? c : select(chosen, c, T(0.0f));
        return select(mask_i32(chosen), I(kOnly), I(kLobeAbsorbed));
    }
    const T pd = max_component(m.kd);
    const T ps = max_component(m.ks);
    const T pr = max_component(m.kr);
    const T pt = max_component(m.kt);
    const T sum = pd + ps + pr + pt;
    const T scale = select(sum > T(survival_cap), T(survival_cap) / sum, T(1.0f));
    // The lobe index is the number of cumulative thresholds that u has passed
    const T c1 = pd * scale, c2 = c1 + ps * scale, c3 = c2 + pr * scale, c4 = c3 + pt * scale;
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
// normal n) the index ratio is η = n_scene / n_object; leaving it is inverted. Total
// internal reflection sends the path along the mirror direction with the same weight.
template <class T>
Scatter<T> sample_refraction(const Bsdf<T>& m, const Vec3<T>& d, const Vec3<T>& n,
                             const T& scene_ior, const T& probability) {
    const T dn = dot(d, n);
    const auto entering = dn < T(0.0f);
    const Vec3<T> nf = select(entering, n, -n);
    const T eta = select(entering, scene_ior / m.ior, m.ior / scene_ior);
    const T cos_i = abs(dn);
    const T k = T(1.0f) - eta * eta * (T(1.0f) - cos_i * cos_i);
    const Vec3<T> refracted = fma(nf, eta * cos_i - sqrt(max(k, T(0.0f))), d * eta);
    const Vec3<T> dir = normalize(select(k < T(0.0f), reflect(d, nf), refracted));
    return {dir, m.kt * (T(1.0f) / probability)};
}

// f(ωi, ωo)·cos θi of the Phong lobes for a light direction wi (unit, towards the light):
// kd/π + ks·(s+2)/(2π)·cos^s α, α between wi and the mirror direction of d, restricted to
// the lobe's half-space cos α > 0 (the half the specular sampler covers). 0 when wi is
// below the surface seen from d.
template <class T>
Vec3<T> phong_f_cos(const Bsdf<T>& m, const Vec3<T>& d, const Vec3<T>& nf, const Vec3<T>& wi) {
    const T cos_i = dot(wi, nf);
    const T cos_a = max(dot(wi, reflect(d, nf)), T(0.0f));
    const T s = m.shininess;
    const T spec = (s + T(2.0f)) * T(0.5f * kInvPi) * pow_s(cos_a, s);
    const Vec3<T> f = fma(m.ks, spec, m.kd * T(kInvPi));
    return f * select(cos_i > T(0.0f), cos_i, T(0.0f));
}

}  // namespace CIERZO_ISA_NAMESPACE
}  // namespace cierzo
