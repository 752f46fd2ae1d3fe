// One path vertex, written once for both integrators (T = float: the scalar loops, which
// trace what it asks for at once; T = xsimd::batch: the wavefront stages, which queue it or
// trace it on the batch's registers). A vertex is, in this order:
//   1. its frame: the geometric normal facing the arriving ray and the shading normal turned
//      to it (vertex_frame); rays that leave on that side start just off the surface;
//   2. what an emitter hit adds is weighed by emitter_hit_weight (kernels/estimator.h) where
//      the estimator weighs it (weighs_emitter_hits);
//   3. the direct light of a Phong vertex: the shadow-ray requests of one emitter sample
//      (nee, mis; emitter_request) and of every point light (point_light_request), each with
//      what it adds if clear;
//   4. the roulette (choose_lobe), and the chosen lobe's continuation: direction, weight,
//      the origin of the next ray, and the density the estimator's MIS needs (continue_path),
//      in radiance mode for camera paths and importance mode for paths from the lights.
// The scalar reference and the wavefront both call exactly these, so no rule of the
// estimator stands in two places; the wavefront's specialisations (one lobe fused in
// registers, compaction in shading, inline shadow rays) only decide where the results go.
#pragma once

#include "estimator.h"
#include "shading.h"
#include "transport.h"

namespace cierzo {
inline namespace CIERZO_ISA_NAMESPACE {

// Whether paths that escape the scene gather an environment.
inline bool has_environment(const PathContext& c) { return c.emitters.environment.width > 0; }

// What a path that escapes in direction d gathers (before its throughput): the
// environment's radiance, weighed as the estimator weighs it (environment_weight; lobe_pdf
// as for emitter hits).
template <class T>
Vec3<T> escaped_radiance(const PathContext& c, const Vec3<T>& d, const T& lobe_pdf) {
    const Vec3<T> le = environment_radiance(c.emitters.environment, d);
    return le * environment_weight(c.emitters, c.estimator.kind, c.nee, lobe_pdf, d);
}

template <class T>
struct VertexFrame {
    Vec3<T> nf;   // the geometric normal on the arriving side
    Vec3<T> nsf;  // the shading normal turned to that side (nf without smooth meshes)
};

// (`smooth`: PathContext::smooth, which the caller reads once)
template <class T>
VertexFrame<T> vertex_frame(bool smooth, const Vec3<T>& d, const Vec3<T>& n, const Vec3<T>& ns) {
    VertexFrame<T> v;
    v.nf = facing_normal(n, d);
    v.nsf = smooth ? facing_shading_normal(ns, v.nf) : v.nf;
    return v;
}

// A shadow ray a vertex asks for: from `origin` (just off the surface on the arriving side)
// along `dir` up to `tmax`; if
// nothing blocks it, the path gains `value` (the throughput passed to direct_light
// included). Lanes not in `want` ask for nothing.
template <class T>
struct ShadowRequest {
    Vec3<T> origin;
    Vec3<T> dir;
    T tmax;
    Vec3<T> value;
    Mask<T> want;
};

// The direct light of the Phong vertices in `phong` (the material m, the ray's direction d,
// the path's throughput beta), as shadow-ray requests from `origin` (shadow_origin): one
// emitter sample where the estimator samples emitters (emitter_request, when c.nee), then
// each point light j < c.light_count (point_light_request). The loops ask for them in that
// order. f·cos θ·I/d² for a point light (kernels/estimator.h, phong_f_cos), emitter_shadow's
// value for the sample; a light on the wrong geometric side of a smooth mesh's vertex is not
// asked for. The wavefront passes the throughput (each ray is queued with its own
// contribution); the scalar loop passes 1 and multiplies the sum of what its clear rays
// bring by the throughput, as the report writes it (the two differ only in the rounding of
// that product).
template <class T>
Vec3<T> shadow_origin(const VertexFrame<T>& v, const Vec3<T>& pos, const T& magnitude) {
    return offset_ray_origin(pos, v.nf, magnitude);
}

template <class T>
ShadowRequest<T> emitter_request(const PathContext& c, const Bsdf<T>& m, const Vec3<T>& d,
                                 const VertexFrame<T>& v, const Vec3<T>& origin,
                                 const Vec3<T>& beta, const Mask<T>& phong,
                                 const SampleStream<T>& rng, const U32<T>& bounce,
                                 const GuideAt<T>* guide = nullptr) {
    const EmitterShadow<T> es =
        emitter_shadow(c.emitters, c.estimator, m, d, v.nsf, origin, rng, bounce, guide);
    const Vec3<T> value = beta * es.value;
    Mask<T> want = phong & es.ok & (max_component(value) > T(0.0f));
    if (c.smooth) want = want & on_arriving_side(es.wi, v.nf);
    return {origin, es.wi, es.tmax, value, want};
}

template <class T>
ShadowRequest<T> point_light_request(const PathContext& c, int32_t j, const Bsdf<T>& m,
                                     const Vec3<T>& d, const VertexFrame<T>& v,
                                     const Vec3<T>& origin, const Vec3<T>& beta,
                                     const Mask<T>& phong) {
    const float* l = c.lights + 6 * j;
    const Vec3<T> to = Vec3<T>(T(l[0]), T(l[1]), T(l[2])) - origin;
    const T d2 = dot(to, to);
    const T dist = sqrt(d2);
    const Vec3<T> wi = to * (T(1.0f) / dist);
    const Vec3<T> value =
        beta * phong_f_cos(m, d, v.nsf, wi) * Vec3<T>(T(l[3]), T(l[4]), T(l[5])) * (T(1.0f) / d2);
    Mask<T> want = phong & (max_component(value) > T(0.0f));
    if (c.smooth) want = want & on_arriving_side(wi, v.nf);
    return {origin, wi, dist * T(1.0f - 1e-5f), value, want};
}

// The continuation of a path through lobe kLobe (chosen by the roulette with `probability`),
// in three parts that the loops compose (kept apart so that a stage loop holds no more in
// registers than it needs at each point):
//   - continue_path: the new direction and the factor of the throughput (0 where the path
//     ends here); kMode radiance (camera paths) or importance (paths from the lights: the
//     refraction's (η_i/η_t)², and the shading normals' correction);
//   - continuation_pdf: where the estimator samples emitters (MIS needs it), the density the
//     lobe sampled the direction with (P(lobe) included; 0 for a delta lobe);
//   - leaving_origin: the next ray's origin, just off the surface on the side it leaves to.
template <int kLobe, Transport kMode = Transport::kRadiance, class T>
Scatter<T> continue_path(const PathContext& c, const Bsdf<T>& m, const Vec3<T>& d,
                         const VertexFrame<T>& v, const Vec3<T>& n, const Vec3<T>& ns,
                         const T& probability, const SampleStream<T>& rng, const U32<T>& bounce) {
    const bool smooth = c.smooth;
    T u1, u2;
    uniform2<T>(rng, bounce, Purpose::kDirection1, u1, u2);
    Scatter<T> sc;
    if constexpr (kLobe == kLobeDiffuse) {
        sc = sample_diffuse(m, v.nsf, u1, u2, probability, c.estimator.cosine_diffuse);
    } else if constexpr (kLobe == kLobeSpecular) {
        sc = sample_specular(m, d, v.nsf, u1, u2, probability);
    } else if constexpr (kLobe == kLobeMirror) {
        sc = sample_mirror(m, d, v.nsf, probability);
    } else {
        sc = sample_refraction<kMode>(m, d, n, ns, T(c.scene_ior), probability, smooth);
    }
    // A reflection about the shading normal must leave on the geometric surface's side
    if constexpr (kLobe != kLobeRefract)
        if (smooth) sc.weight = select(on_arriving_side(sc.dir, v.nf), sc.weight, Vec3<T>(T(0.0f)));
    if constexpr (kMode == Transport::kImportance)
        if (smooth) sc.weight = sc.weight * shading_correction(-d, sc.dir, n, v.nsf);
    return sc;
}

// (it sets `pdf` only where the estimator samples emitters, and leaves it as it is, 0, where
// it does not: a branch, so the density is never computed for nothing)
template <int kLobe, class T>
void continuation_pdf(const PathContext& c, const Bsdf<T>& m, const Vec3<T>& d,
                      const VertexFrame<T>& v, const Vec3<T>& dir, const T& probability, T& pdf) {
    if (c.nee)
        pdf = sampled_lobe_pdf<kLobe>(m, d, v.nsf, dir, probability, c.estimator.cosine_diffuse);
}

// The throughput roulette (EstimatorSettings::roulette, kThroughput), applied to a camera
// path's throughput `beta` after the lobe at vertex `bounce` (the camera's first hit is 0):
// from vertex roulette_depth on, the path goes on with probability
// q = min(max RGB of beta, survival cap), its throughput divided by q; else it ends
// (throughput 0). The cap makes every path end, mirrors and glass included. Under the
// report's roulette it returns beta unchanged. u_roulette: the roulette's draw (slot 1's
// second number, lobe_uniforms in kernels/sampler.h).
template <class T>
Vec3<T> throughput_roulette(const EstimatorSettings& est, const Vec3<T>& beta, const T& u_roulette,
                            const U32<T>& bounce) {
    if (!normalised_lobes(est)) return beta;
    const auto due = to_float(bounce) >= T(float(est.roulette_depth));
    if (!any(due)) return beta;
    const T q = min(max_component(beta), T(est.survival_cap));
    const auto survives = u_roulette < q;
    const Vec3<T> kept = select(survives, beta * (T(1.0f) / q), Vec3<T>(T(0.0f)));
    return select(due, kept, beta);
}

// The path-length rule (render.min_length, render.max_length), stated once for every
// estimator and both integrators: whether light that reaches the camera along `length`
// segments counts, and whether a path whose last vertex is `bounce` (the camera's first hit
// is 0) may go on (its next vertex's light would be at least bounce + 2 segments long), on
// the lanes of `lanes`. Without limits (limits_length) both are `lanes`.
template <class T>
Mask<T> length_counts(const EstimatorSettings& est, const U32<T>& length,
                      const Mask<T>& lanes = Mask<T>(true)) {
    if (!limits_length(est)) return lanes;
    const T l = to_float(length);
    return lanes & (l >= T(float(est.min_length))) & (l <= T(float(est.max_length)));
}
template <class T>
Mask<T> may_extend(const EstimatorSettings& est, const U32<T>& bounce,
                   const Mask<T>& lanes = Mask<T>(true)) {
    if (!limits_length(est)) return lanes;
    return lanes & (to_float(bounce) + T(2.0f) <= T(float(est.max_length)));
}

template <class T>
Vec3<T> leaving_origin(const Vec3<T>& pos, const Vec3<T>& n, const Vec3<T>& dir,
                       const T& magnitude) {
    return offset_ray_origin(pos, select(dot(dir, n) > T(0.0f), n, -n), magnitude);
}

// The three for a lobe known only at run time (one path: the scalar loops).
struct ScalarContinuation {
    Vec3f o, d, weight;
    float pdf;
};
template <Transport kMode = Transport::kRadiance>
ScalarContinuation continue_path(int32_t lobe, const PathContext& c, const Bsdf<float>& m,
                                 const Vec3f& d, const VertexFrame<float>& v, const Vec3f& pos,
                                 const Vec3f& n, const Vec3f& ns, float magnitude,
                                 float probability, const SampleStream<float>& rng,
                                 uint32_t bounce) {
    const auto run = [&](auto kind) {
        constexpr int kLobe = decltype(kind)::value;
        const Scatter<float> sc =
            continue_path<kLobe, kMode>(c, m, d, v, n, ns, probability, rng, bounce);
        ScalarContinuation out{leaving_origin(pos, n, sc.dir, magnitude), sc.dir, sc.weight, 0.0f};
        continuation_pdf<kLobe>(c, m, d, v, sc.dir, probability, out.pdf);
        return out;
    };
    switch (lobe) {
        case kLobeDiffuse: return run(std::integral_constant<int, kLobeDiffuse>{});
        case kLobeSpecular: return run(std::integral_constant<int, kLobeSpecular>{});
        case kLobeMirror: return run(std::integral_constant<int, kLobeMirror>{});
        default: return run(std::integral_constant<int, kLobeRefract>{});
    }
}

// The diffuse lobe's continuation where the path guide is active (`guide` from guide_at,
// `probability` P_d): a direction from the guide or the lobe (sample_guided_diffuse,
// kernels/guiding.h), its weight, and `pdf` P_d·p, p the mixture's density (which the
// guide's records divide by), with guide_pdf and lobe_pdf its two parts. On lanes where the
// guide is not active the caller takes continue_path's instead.
template <class T>
struct GuidedScatter {
    Scatter<T> sc;
    T pdf, guide_pdf, lobe_pdf;
};
template <class T>
GuidedScatter<T> continue_guided_diffuse(const PathContext& c, const Bsdf<T>& m,
                                         const VertexFrame<T>& v, const T& probability,
                                         const GuideAt<T>& guide, const SampleStream<T>& rng,
                                         const U32<T>& bounce) {
    T u1, u2;
    uniform2<T>(rng, bounce, Purpose::kDirection1, u1, u2);
    GuidedScatter<T> g;
    g.sc = sample_guided_diffuse(m, v.nsf, guide, u1, u2, probability, c.estimator.cosine_diffuse,
                                 g.pdf, g.guide_pdf, g.lobe_pdf);
    // A reflection about the shading normal must leave on the geometric surface's side
    if (c.smooth)
        g.sc.weight = select(on_arriving_side(g.sc.dir, v.nf), g.sc.weight, Vec3<T>(T(0.0f)));
    return g;
}

// What the record of a vertex the guide serves divides by (integrators/guide_record.h), where
// lobe kLobe (diffuse or specular) continued the path in `dir`: `density`, the density `dir`
// was drawn with, P(lobe) left out (the mixture's on the `guided` lanes, which the guided
// continuation g drew; the lobe's own elsewhere); and for the diffuse lobe the mixture's two
// parts, the guide's density of `dir` (g's where it drew; looked up on the `served` lanes
// whose cell has a guide but drew from the lobe; 0 elsewhere) and the lobe's.
template <class T>
struct RecordDensities {
    T density = T(0.0f), guide_pdf = T(0.0f), lobe_pdf = T(0.0f);
};
template <int kLobe, class T>
RecordDensities<T> record_densities(const PathContext& c, const Bsdf<T>& m, const Vec3<T>& d0,
                                    const Vec3<T>& nsf, const Vec3<T>& dir, const GuideAt<T>& guide,
                                    const Mask<T>& served, const Mask<T>& guided,
                                    const GuidedScatter<T>& g, const T& probability) {
    RecordDensities<T> r;
    const bool cosine = c.estimator.cosine_diffuse;
    if constexpr (kLobe == kLobeDiffuse) {
        const T own = sampled_lobe_pdf<kLobeDiffuse>(m, d0, nsf, dir, T(1.0f), cosine);
        r.density = select(guided, g.pdf / probability, own);
        r.lobe_pdf = select(guided, g.lobe_pdf, own);
        r.guide_pdf = select(guided, g.guide_pdf, T(0.0f));
        const Mask<T> unguided = served & !guided;
        if (guide.exists() && any(unguided))
            r.guide_pdf =
                select(unguided, guide_pdf(*guide.view, guide.root, dir, unguided), r.guide_pdf);
    } else if constexpr (kLobe == kLobeSpecular) {
        r.density = sampled_lobe_pdf<kLobeSpecular>(m, d0, nsf, dir, T(1.0f), cosine);
    }
    return r;
}

// The same for one path (the scalar loop): the continuation, with `pdf` P_d·p where the
// estimator samples emitters (as continuation_pdf), and the guided draw itself (`g`).
struct GuidedContinuation {
    ScalarContinuation next;
    GuidedScatter<float> g;
};
inline GuidedContinuation continue_guided_diffuse(const PathContext& c, const Bsdf<float>& m,
                                                  const VertexFrame<float>& v, const Vec3f& pos,
                                                  const Vec3f& n, float magnitude,
                                                  float probability, const GuideAt<float>& guide,
                                                  const SampleStream<float>& rng, uint32_t bounce) {
    const GuidedScatter<float> g =
        continue_guided_diffuse<float>(c, m, v, probability, guide, rng, bounce);
    return {
        {leaving_origin(pos, n, g.sc.dir, magnitude), g.sc.dir, g.sc.weight, c.nee ? g.pdf : 0.0f},
        g};
}

}  // namespace CIERZO_ISA_NAMESPACE
}  // namespace cierzo
