// The weights that combine the strategies of nee and mis: the power heuristic, the emitter
// sample's shadow ray at a Phong vertex with its lobes' weights, and the weight of an emitter
// or the environment that the BSDF strategy reaches (Veach 1997, §9.2).
#pragma once

#include "bsdf.h"
#include "emitter_sampling.h"
#include "guiding.h"
#include "sampler.h"
#include "settings.h"

namespace cierzo {
inline namespace CIERZO_ISA_NAMESPACE {

// The power heuristic weight of strategy a against b, pa²/(pa² + pb²), written so that huge
// or zero densities give 0 or 1 and never NaN: 1 where pb = 0.
template <class T>
T power_heuristic(const T& pa, const T& pb) {
    const T r = pb / pa;
    return select(pb > T(0.0f), T(1.0f) / fma(r, r, T(1.0f)), T(1.0f));
}

// The shadow ray of one emitter sample at a Phong vertex and what it brings if unblocked
// (before the path's throughput): Le·Σ_lobe f_lobe·cos θ·w_lobe / pdf, w = 1 for nee, the
// power heuristic against P(lobe)·pdf_lobe for mis. Where the path guide is active at the
// vertex (`guide`, on its active lanes), the diffuse lobe's density is the guided mixture's
// (kernels/guiding.h), as the direction the path goes on in was drawn from it.
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
                                const U32<T>& bounce, const GuideAt<T>* guide = nullptr) {
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
        T pdf_diffuse = f.pdf_diffuse;
        if (guide && est.guide_in_mis) pdf_diffuse = guide->mix(ls.wi, pdf_diffuse);
        fcos = f.diffuse * power_heuristic(pdf, pd * pdf_diffuse) +
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
    const T light = emitter_pdf(e, select(mask_i32(sampled), id, I32<T>(0)), x, d, t, solid_angle);
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
