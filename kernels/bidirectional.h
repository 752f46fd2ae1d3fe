// Bidirectional path tracing (--estimator bdpt) and vertex connection and merging (vcm): the
// vertex-level rules, written once for both integrators (T = float for the scalar
// reference, T = xsimd::batch for the wavefront kernels). bdpt is vcm without merging: its
// MergeWeights are 0, which leaves every rule below bdpt's. (Over 600 lines as one file:
// every strategy's weight below reads the same SubpathMis quantities, and they stay
// consistent by standing side by side.)
//
// A sample pairs one camera subpath with one light subpath (the light path of camera sample
// n takes the key of that sample, as lt's do). Every way of making a full path from them is a
// strategy (s light vertices, t camera vertices):
//   - s = 0: the camera subpath hits an emitter (emitter_hit_mis);
//   - s = 1: a Phong camera vertex samples a light (next-event estimation: nee_emitter,
//     nee_point_light);
//   - t = 1: a Phong light vertex is connected to the pinhole (camera_connection_mis);
//   - s, t ≥ 2: a Phong camera vertex is connected to each stored Phong vertex of its light
//     subpath (connect_vertices);
//   - vcm only: a Phong camera vertex merges with every stored Phong vertex, of any light
//     subpath of its sample in its tile, within the sample's radius (merge_vertices).
// They are combined by the power heuristic, with the recursive quantities of Georgiev's
// "Implementing Vertex Connection and Merging" (2012): each subpath carries three numbers
// (SubpathMis: dVCM, dVC, dVM), updated at each hit (mis_at_hit) and each scattering
// (mis_after_lobe), from which the weight of any strategy needs only its two end vertices.
// All densities are of the BSDF strategy as the report's roulette samples it: P(lobe), the
// survival included, times the lobe's own density (phong_eval), summed over the Phong lobes.
// Delta lobes (mirror, refraction) are never connected; a path through them keeps
// its weights exact because dVCM is 0 after them (their densities cancel). Cosines in the
// conversions between solid-angle and area densities are those of the geometric normal.
//
// Units of density. A light path's connection to the pinhole lands anywhere in the image
// (kernels/transport.h), so the camera strategy's density of a direction is that of the whole
// film: p = 1 / (A·cos³θ) per unit solid angle (A: the film's area at distance 1).
#pragma once

#include <algorithm>
#include <cmath>

#include "light_sampling.h"
#include "path_vertex.h"
#include "transport.h"

namespace cierzo {
inline namespace CIERZO_ISA_NAMESPACE {

// The power heuristic's exponent: every density enters squared.
template <class T>
T mis2(const T& x) {
    return x * x;
}

// c² for the light vertex cache's c = PathContext::connection_count (1 with the pairing):
// how many times more often than the other strategies a connection (s, t ≥ 2) is made.
// Every quantity a subpath carries is a sum of other strategies' densities over a
// connection's, each times the squared ratio of their counts; those of the strategies made
// once per path (s = 0, s = 1, t = 1) enter them divided by c² (camera_start_mis,
// light_start_mis), merging's with η/c for η (merge_weights). The weight of a strategy made
// once multiplies them back by c².
template <class T>
T connection_count2(const PathContext& c) {
    return T(c.connection_count * c.connection_count);
}

// The three quantities a subpath carries (already squared: the power heuristic's terms).
template <class T>
struct SubpathMis {
    T vcm, vc, vm;
};

// What the strategies of a sample share once vertices merge (vcm; all 0 for bdpt). A camera
// vertex of sample n merges with the light vertices of the N light subpaths of the same
// sample index in its tile, within radius r_n: η = π·r_n²·N is the ratio of merging's density
// of a path to the connection's that makes its last light vertex, and
//   vm_weight = η² (merging against a connection, squared: the power heuristic),
//   vc_weight = 1/η² (a connection against merging),
//   normalization = 1/(π r_n² N) (the merging estimate's kernel over the N light paths),
//   radius2 = r_n².
// The weights take N as a full tile's pixels in every tile: a light vertex's t = 1
// connection lands in any tile, and its weight must be the one the merging there gives
// the same path (a tile at the image's edge, with fewer paths, would otherwise lose the
// difference: measured −2% on a 24 × 24 image of 16 × 16 tiles). With the light vertex
// cache a connection is made c times (connection_count2), so merging against a connection
// counts η/c in the weights (not in the normalization, which is the estimate's own).
template <class T>
struct MergeWeights {
    T vm_weight = T(0.0f);
    T vc_weight = T(0.0f);
    T normalization = T(0.0f);
    T radius2 = T(0.0f);
};

// The merging quantities of sample n (from 0) of a tile whose light subpaths for that
// sample number `light_paths` (0: none, nothing merges), with merging radius r0 and exponent
// α (EstimatorSettings); the weights' N is `tile_paths`, a full tile's, and a connection counts
// `connection_count` times (PathContext::connection_count). Without connections (bpm, ppm:
// `connections` false) the connections' weight 1/η² is 0, so merging is weighed against
// merging alone.
inline MergeWeights<float> merge_weights(float r0, float alpha, int64_t n, int64_t light_paths,
                                         int64_t tile_paths, bool connections,
                                         float connection_count = 1.0f) {
    MergeWeights<float> m;
    const double r = double(r0) * std::pow(double(n + 1), 0.5 * (double(alpha) - 1.0));
    const double area = kPi * r * r;
    // (η kept within 10^±12, so that η² and 1/η² are finite floats whatever the radius:
    // every strategy's weight takes the same η, so the weights still sum to 1)
    const double eta =
        std::clamp(area * double(tile_paths) / double(connection_count), 1e-12, 1e12);
    if (light_paths <= 0 || !(area > 0.0) || !std::isfinite(area)) return m;
    m.vm_weight = float(eta * eta);
    m.vc_weight = connections ? float(1.0 / (eta * eta)) : 0.0f;
    m.normalization = float(1.0 / (area * double(light_paths)));
    m.radius2 = float(r * r);
    return m;
}

// ---- The Phong part of a vertex, as the strategies evaluate it ---------------------------

// The Phong lobes of a vertex and the roulette's probabilities of choosing them (the
// survival included), all that connections and merging need of its material.
template <class T>
struct PhongVertex {
    Vec3<T> kd, ks;
    T shininess;
    T p_diffuse, p_specular;
};
template <class T>
PhongVertex<T> phong_vertex(const Bsdf<T>& m, float survival_cap, bool normalised = false) {
    const LobeProbabilities<T> lp = lobe_probabilities(m, survival_cap, normalised);
    return {m.kd, m.ks, m.shininess, lp.lobe[0], lp.lobe[1]};
}

// f(wo, wi) of the Phong lobes, cos θi to nf, and the BSDF strategy's densities: `pdf` of
// sampling wi from wo and `pdf_reverse` of sampling wo from wi (see bsdf_eval, which is this
// for a whole material).
template <class T>
BsdfEval<T> phong_eval(const PhongVertex<T>& v, const Vec3<T>& wo, const Vec3<T>& nf,
                       const Vec3<T>& wi, bool cosine) {
    BsdfEval<T> out;
    const Vec3<T> d = -wo;
    const Bsdf<T> m{v.kd, v.ks, Vec3<T>(T(0.0f)), Vec3<T>(T(0.0f)), v.shininess, T(1.0f)};
    const Vec3<T> f = phong_f(m, d, nf, wi, out.cos_i);
    const T cos_o = dot(wo, nf);
    const auto reflects = (out.cos_i > T(0.0f)) & (cos_o > T(0.0f));
    out.f = select(reflects, f, Vec3<T>(T(0.0f)));
    const auto diffuse_pdf = [&](const T& c) {
        return cosine ? max(c, T(0.0f)) * T(kInvPi)
                      : select(c > T(0.0f), T(0.5f * kInvPi), T(0.0f));
    };
    out.pdf = v.p_diffuse * diffuse_pdf(out.cos_i);
    out.pdf_reverse = v.p_diffuse * diffuse_pdf(cos_o);
    // (the specular lobe's density only where some lane has one: it costs an exp and a log)
    if (any(v.p_specular > T(0.0f))) {
        const T cos_a = dot(wi, normalize(reflect(d, nf)));
        const T lobe = select(cos_a > T(0.0f), pow_s(max(cos_a, T(0.0f)), v.shininess), T(0.0f));
        const T specular = v.p_specular * (v.shininess + T(1.0f)) * T(0.5f * kInvPi) * lobe;
        out.pdf = out.pdf + specular;
        out.pdf_reverse = out.pdf_reverse + specular;
    }
    return out;
}

// The strategy filter (EstimatorSettings::strategy_s, strategy_t, unweighted): what strategy
// (s, t) of MIS weight w counts with: w, or 1 (unweighted) for the one strategy kept, 0 for
// the others. Unweighted with no strategy named, every strategy counts with 1: the scalar
// integrator's strategy images (integrators/strategies.h) take each contribution so too.
template <class T>
T strategy_weight(const EstimatorSettings& e, const U32<T>& s, const U32<T>& t, const T& w) {
    if (e.strategy_s < 0) return e.unweighted ? T(1.0f) : w;
    const auto kept =
        (to_float(s) == T(float(e.strategy_s))) & (to_float(t) == T(float(e.strategy_t)));
    return select(kept, e.unweighted ? T(1.0f) : w, T(0.0f));
}

// ---- Starts -------------------------------------------------------------------------------

// A camera subpath's quantities at the pinhole, for the direction d of its first ray:
// dVCM = 1/(c²p²), p = 1/(A·cos³θ) the film's density of d (the t = 1 strategy, made once:
// connection_count2); dVC = dVM = 0.
template <class T>
SubpathMis<T> camera_start_mis(const PathContext& c, const PinholeFrame& pinhole,
                               const Vec3<T>& d) {
    const Vec3<T> n(Vec3f{pinhole.film_normal[0], pinhole.film_normal[1], pinhole.film_normal[2]});
    const T cos_c = dot(d, n);
    return {mis2(T(pinhole.film_area) * cos_c * cos_c * cos_c) / connection_count2<T>(c), T(0.0f),
            T(0.0f)};
}

// A light subpath's quantities at its start, before its first hit. Its dVCM needs the
// density with which next-event estimation samples the start from the first hit, which
// (cone-sampled spheres, spherical triangles) depends on where that hit is: it is left as
// 1/p_e² (p_e the start's density: the light's choice, its point and its direction) and
// completed by start_direct_pdf_area. dVC = |cos θ|² / p_e² for an emitter, 0 for a point
// light (a delta position: no strategy hits it); dVM = dVC / η² (vcm: merging at the first
// hit against the connection that makes that segment; 0 for bdpt). dVCM and dVC stand for
// strategies made once (s = 1, s = 0): both divided by c² (connection_count2).
template <class T>
SubpathMis<T> light_start_mis(const PathContext& c, const LightStart<T>& s,
                              const MergeWeights<T>& mw) {
    const T inv = T(1.0f) / s.pdf_emit;
    const T once = T(1.0f) / connection_count2<T>(c);
    SubpathMis<T> m;
    m.vcm = mis2(inv) * once;
    m.vc = select(s.on_surface, mis2(s.cos_light * inv) * once, T(0.0f));
    m.vm = m.vc * mw.vc_weight;
    return m;
}

// At the light subpath's first hit x (reached from the start along d, at distance t): the
// density with which next-event estimation would sample the start from x, by area: for an
// emitter its solid-angle density from x (emitter_pdf) times |cos θ_l| / t²; for a point
// light 1 (every point light is sampled from every vertex). dVCM is multiplied by its square.
template <class T>
T start_direct_pdf_area(const PathContext& c, const LightStart<T>& s, const Vec3<T>& x,
                        const Vec3<T>& d, const T& t) {
    T pdf(1.0f);
    if (c.emitters.count > 0 && any(s.on_surface)) {
        const I32<T> id = select(mask_i32(s.on_surface), s.emitter, I32<T>(0));
        const T w = emitter_pdf(c.emitters, id, x, -d, t, c.estimator.triangle_solid_angle);
        pdf = select(s.on_surface, w * s.cos_light / (t * t), pdf);
    }
    return pdf;
}

// ---- Updates along a subpath --------------------------------------------------------------

// At a hit at distance t whose geometric cosine to the arriving direction is cos_in: the
// solid-angle density of the segment becomes one by area (× cos_in / t²), so dVCM is
// multiplied by (t² / cos_in)² and dVC, dVM by 1 / cos_in². `direct` (the light subpath's
// first hit only, start_direct_pdf_area; else 1) completes the start's dVCM.
template <class T>
void mis_at_hit(SubpathMis<T>& m, const T& t, const T& cos_in, const T& direct = T(1.0f)) {
    const T inv = T(1.0f) / mis2(cos_in);
    m.vcm = m.vcm * mis2(t * t * direct) * inv;
    m.vc = m.vc * inv;
    m.vm = m.vm * inv;
}

// After a Phong lobe sampled the new direction (geometric cosine cos_out) with density pdf
// (phong_eval's, of the whole Phong part) whose reverse is pdf_reverse.
template <class T>
void mis_after_phong(SubpathMis<T>& m, const T& cos_out, const T& pdf, const T& pdf_reverse,
                     const MergeWeights<T>& mw) {
    const T g = mis2(cos_out / pdf);
    const T vc = g * (m.vc * mis2(pdf_reverse) + m.vcm + mw.vm_weight);
    const T vm = g * (m.vm * mis2(pdf_reverse) + m.vcm * mw.vc_weight + T(1.0f));
    m.vcm = T(1.0f) / mis2(pdf);
    m.vc = vc, m.vm = vm;
}

// After a delta lobe (mirror, refraction: its discrete densities cancel both ways).
template <class T>
void mis_after_delta(SubpathMis<T>& m, const T& cos_out) {
    const T c2 = mis2(cos_out);
    m.vcm = T(0.0f);
    m.vc = m.vc * c2;
    m.vm = m.vm * c2;
}

// After the roulette chose `lobe` and it sampled `dir` at a vertex (frame v, arriving along
// d): the delta lobes' rule, or the Phong part's densities (phong_eval), lane by lane.
template <class T>
void mis_after_lobe(const PathContext& c, SubpathMis<T>& m, const I32<T>& lobe,
                    const PhongVertex<T>& pv, const VertexFrame<T>& v, const Vec3<T>& d,
                    const Vec3<T>& dir, const MergeWeights<T>& mw) {
    const T cos_out = abs(dot(dir, v.nf));
    const auto delta =
        mask_f32(lobe == I32<T>(kLobeMirror)) | mask_f32(lobe == I32<T>(kLobeRefract));
    SubpathMis<T> through_delta = m;
    if (any(delta)) mis_after_delta(through_delta, cos_out);
    if (!all(delta)) {
        const BsdfEval<T> b = phong_eval(pv, -d, v.nsf, dir, c.estimator.cosine_diffuse);
        mis_after_phong(m, cos_out, b.pdf, b.pdf_reverse, mw);
    }
    m.vcm = select(delta, through_delta.vcm, m.vcm);
    m.vc = select(delta, through_delta.vc, m.vc);
    m.vm = select(delta, through_delta.vm, m.vm);
}

// Whether camera subpaths that came this way (quantities m, `vertices` camera vertices with
// this one) came only through mirrors and glass from the pinhole: its first hit, or dVCM and
// dVC still 0 (a Phong vertex makes both positive, a delta lobe keeps them 0).
template <class T>
Mask<T> through_delta_only(const SubpathMis<T>& m, const U32<T>& vertices) {
    return (to_float(vertices) == T(2.0f)) | ((m.vcm == T(0.0f)) & (m.vc == T(0.0f)));
}

// ---- The strategies' weights and values ---------------------------------------------------

// s = 0: the weight of Le where the camera subpath (quantities `m`, already updated at this
// hit; `vertices` camera vertices with this one: the bounce + 2) hits sampled emitter `id` at
// x, from the previous vertex `prev` along d at distance t, cos_l the geometric cosine at
// the emitter. The camera's own first hit and an emitter that is not sampled (id < 0) count
// in full: no other strategy makes those paths. Without connections (bpm, ppm) merging makes
// every path of a sampled emitter through a Phong vertex, so the emitter counts in full where
// the camera subpath came only through mirrors and glass (its dVCM and dVC still 0) and not
// at all after a Phong vertex.
template <class T>
T emitter_hit_mis(const PathContext& c, const LightStartTable& lights, const SubpathMis<T>& m,
                  const I32<T>& id, const Vec3<T>& prev, const Vec3<T>& d, const T& t,
                  const T& cos_l, const U32<T>& vertices) {
    const auto first = to_float(vertices) == T(2.0f);
    const auto sampled = mask_f32(id >= I32<T>(0)) & !first;
    if (none(sampled)) return strategy_weight(c.estimator, U32<T>(0u), vertices, T(1.0f));
    if (!connects(c.estimator.kind))
        return strategy_weight(
            c.estimator, U32<T>(0u), vertices,
            select(sampled & !through_delta_only(m, vertices), T(0.0f), T(1.0f)));
    const I32<T> e = select(mask_i32(sampled), id, I32<T>(0));
    const T direct_w = emitter_pdf(c.emitters, e, prev, d, t, c.estimator.triangle_solid_angle);
    const T direct_a = direct_w * cos_l / (t * t);
    const T emit = T(lights.emitter_probability) * emitter_position_pdf<T>(c.emitters, e) * cos_l *
                   T(0.5f * kInvPi);
    // (dVCM: next-event estimation from the previous vertex, made once as this is; dVC: the
    // connections and the strategies before them, relative to a connection)
    const T w = mis2(direct_a) * m.vcm + mis2(emit) * m.vc * connection_count2<T>(c);
    return strategy_weight(c.estimator, U32<T>(0u), vertices,
                           select(sampled, T(1.0f) / (T(1.0f) + w), T(1.0f)));
}

// s = 0 for the environment, where a camera subpath escapes along d: its only other strategy
// is next-event estimation (light paths do not start at it; bpm and ppm have none). The
// camera's own ray counts in full. (`vertices`: as for emitter_hit_mis, the escape counting
// as one)
template <class T>
T environment_mis(const PathContext& c, const SubpathMis<T>& m, const Vec3<T>& d,
                  const U32<T>& vertices) {
    if (c.emitters.environment.emitter < 0 || !connects(c.estimator.kind))
        return strategy_weight(c.estimator, U32<T>(0u), vertices, T(1.0f));
    const T light = T(c.emitters.pmf[c.emitters.environment.emitter]) *
                    environment_pdf(c.emitters.environment, d);
    const auto first = to_float(vertices) == T(2.0f);
    return strategy_weight(c.estimator, U32<T>(0u), vertices,
                           select(first, T(1.0f), T(1.0f) / (T(1.0f) + mis2(light) * m.vcm)));
}

// A camera vertex as the strategies that end there see it.
template <class T>
struct CameraVertex {
    Vec3<T> p, nf, nsf;  // position, geometric and shading normals on the arriving side
    Vec3<T> wo;          // unit, towards the previous vertex
    Vec3<T> origin;      // where its shadow rays start (shadow_origin)
    PhongVertex<T> phong;
    SubpathMis<T> mis;
    U32<T> vertices;  // the camera subpath's vertices up to this one (bounce + 2)
};

// s = 1 from an emitter: the weight of a sample of sampled emitter `id` (or the
// environment) in direction wi from camera vertex v, which the emitter sampler chose with
// solid-angle density `light_pdf` (its pmf included) and v's Phong lobes would with b.pdf.
template <class T>
T emitter_sample_mis(const PathContext& c, const LightStartTable& lights, const CameraVertex<T>& v,
                     const MergeWeights<T>& mw, const BsdfEval<T>& b, const Vec3<T>& wi,
                     const T& light_pdf, const I32<T>& id, const Mask<T>& environment) {
    // The BSDF strategy hits the same point: its density against the sample's
    const T w_light = mis2(b.pdf / light_pdf);
    // A light subpath one vertex longer reaches this vertex: its density (its start's, by
    // area, times its direction's density towards here) against the sample's; |cos θ_l|
    // cancels. None for the environment, where no light path starts.
    T w_camera(0.0f);
    const auto finite = !environment;
    if (any(finite)) {
        const I32<T> e = select(mask_i32(finite), id, I32<T>(0));
        const T emit = T(lights.emitter_probability) * emitter_position_pdf<T>(c.emitters, e) *
                       dot(wi, v.nf) * T(0.5f * kInvPi) / light_pdf;
        const T rest = mw.vm_weight + v.mis.vcm +
                       v.mis.vc * mis2(b.pdf_reverse * T(c.estimator.reverse_pdf_scale));
        w_camera = select(finite, mis2(emit) * rest * connection_count2<T>(c), T(0.0f));
    }
    return T(1.0f) / (T(1.0f) + w_light + w_camera);
}

// s = 1 from an emitter: the shadow ray of one emitter sample (kernels/estimator.h's
// sampler, with its numbers) and what it adds if clear, Le·f·cos θ / p times its weight
// (before the camera subpath's throughput).
template <class T>
ShadowRequest<T> nee_emitter(const PathContext& c, const LightStartTable& lights,
                             const CameraVertex<T>& v, const MergeWeights<T>& mw,
                             const SampleStream<T>& rng, const U32<T>& bounce,
                             const Mask<T>& want) {
    const EmitterTable& e = c.emitters;
    const EstimatorSettings& est = c.estimator;
    T u_pick(0.0f), u_alias(0.0f), u1, u2;
    if (e.count > 1) uniform_pair<T>(rng, bounce, Purpose::kEmitterPick, u_pick, u_alias);
    uniform2<T>(rng, bounce, Purpose::kEmitter1, u1, u2);
    const EmitterSample<T> ls =
        sample_emitter(e, v.origin, u_pick, u_alias, u1, u2, est.triangle_solid_angle);
    const T pdf = ls.pdf * T(est.light_pdf_scale);
    const BsdfEval<T> b = phong_eval(v.phong, v.wo, v.nsf, ls.wi, est.cosine_diffuse);
    const T cos_g = dot(ls.wi, v.nf);
    const T weight =
        strategy_weight(c.estimator, U32<T>(1u), v.vertices,
                        emitter_sample_mis(c, lights, v, mw, b, ls.wi, pdf, ls.id, ls.environment));
    ShadowRequest<T> r;
    r.origin = v.origin;
    r.dir = ls.wi;
    r.tmax = ls.t * select(ls.sphere, T(1.0f - 1e-3f), T(1.0f - 1e-4f));
    r.value = ls.le * b.f * (max(b.cos_i, T(0.0f)) * weight / pdf);
    r.want = want & ls.ok & (cos_g > T(0.0f)) & (max_component(r.value) > T(0.0f)) &
             (r.value.x < T(kRayFar)) & (r.value.y < T(kRayFar)) & (r.value.z < T(kRayFar));
    return r;
}

// s = 1 from point light j: the weight of its shadow ray from camera vertex v, at distance²
// d2 along wi (b: v's Phong lobes for wi), against the light subpath that starts at it and
// reaches v.
template <class T>
T point_light_mis(const PathContext& c, const LightStartTable& lights, int32_t j,
                  const CameraVertex<T>& v, const MergeWeights<T>& mw, const BsdfEval<T>& b,
                  const Vec3<T>& wi, const T& d2) {
    const T emit = T(lights.point_source[4 * j + 3] * (0.25f * kInvPi)) * dot(wi, v.nf) / d2;
    const T rest = mw.vm_weight + v.mis.vcm +
                   v.mis.vc * mis2(b.pdf_reverse * T(c.estimator.reverse_pdf_scale));
    return T(1.0f) / (T(1.0f) + mis2(emit) * rest * connection_count2<T>(c));
}

// s = 1 from point light j (every one, from every Phong vertex): I·f·cos θ / d² times its
// weight.
template <class T>
ShadowRequest<T> nee_point_light(const PathContext& c, const LightStartTable& lights, int32_t j,
                                 const CameraVertex<T>& v, const MergeWeights<T>& mw,
                                 const Mask<T>& want) {
    const float* l = lights.point + 6 * j;
    const float* src = lights.point_source + 4 * j;  // its intensity, its start probability
    const Vec3<T> to = Vec3<T>(T(l[0]), T(l[1]), T(l[2])) - v.origin;
    const T d2 = dot(to, to);
    const T dist = sqrt(d2);
    const Vec3<T> wi = to * (T(1.0f) / dist);
    const BsdfEval<T> b = phong_eval(v.phong, v.wo, v.nsf, wi, c.estimator.cosine_diffuse);
    const T cos_g = dot(wi, v.nf);
    const T weight = strategy_weight(c.estimator, U32<T>(1u), v.vertices,
                                     point_light_mis(c, lights, j, v, mw, b, wi, d2));
    ShadowRequest<T> r;
    r.origin = v.origin;
    r.dir = wi;
    r.tmax = dist * T(1.0f - 1e-5f);
    r.value =
        Vec3<T>(T(src[0]), T(src[1]), T(src[2])) * b.f * (max(b.cos_i, T(0.0f)) * weight / d2);
    r.want = want & (cos_g > T(0.0f)) & (max_component(r.value) > T(0.0f)) &
             (r.value.x < T(kRayFar)) & (r.value.y < T(kRayFar)) & (r.value.z < T(kRayFar));
    return r;
}

// A stored vertex of a light subpath (Phong vertices only).
template <class T>
struct LightVertex {
    Vec3<T> p, nf, nsf;  // position, geometric and shading normals on the arriving side
    Vec3<T> wl;          // unit, towards the previous vertex (where the light came from)
    Vec3<T> beta;        // the subpath's throughput arriving here
    PhongVertex<T> phong;
    SubpathMis<T> mis;
    T magnitude;    // for its ray offsets
    U32<T> length;  // segments from the light to here
};

// What a light vertex's Phong lobes send along w (unit, away from it): f(wl, w)·|w·ns|, with
// the shading normals' correction of paths from the lights (transport.h); 0 below.
template <class T>
Vec3<T> light_vertex_f_cos(const LightVertex<T>& l, const BsdfEval<T>& b, const Vec3<T>& w,
                           bool smooth) {
    Vec3<T> v = b.f * max(b.cos_i, T(0.0f));
    if (smooth) v = v * shading_correction(l.wl, w, l.nf, l.nsf);
    return v;
}

// t = 1: the weight of light vertex l's connection to the pinhole (cc: connect_camera from
// l.p), against the camera subpaths that reach it.
template <class T>
T camera_connection_mis(const PathContext& c, const LightVertex<T>& l,
                        const CameraConnection<T>& cc, const MergeWeights<T>& mw) {
    const BsdfEval<T> b = phong_eval(l.phong, l.wl, l.nsf, cc.wc, c.estimator.cosine_diffuse);
    const T camera_area = cc.factor * dot(cc.wc, l.nf);
    const T rest = mw.vm_weight + l.mis.vcm +
                   l.mis.vc * mis2(b.pdf_reverse * T(c.estimator.reverse_pdf_scale));
    return strategy_weight(
        c.estimator, l.length + U32<T>(1u), U32<T>(1u),
        T(1.0f) / (T(1.0f) + mis2(camera_area) * rest * connection_count2<T>(c)));
}

// s, t ≥ 2: the weight of connecting camera vertex v to light vertex l along w (unit, from
// v to l, at distance² d2; bc and bl: each one's Phong lobes towards the other).
template <class T>
T connection_mis(const PathContext& c, const CameraVertex<T>& v, const LightVertex<T>& l,
                 const MergeWeights<T>& mw, const BsdfEval<T>& bc, const BsdfEval<T>& bl,
                 const Vec3<T>& w, const T& d2) {
    const T inv_d2 = T(1.0f) / d2;
    // Each side's density of sampling the other end, by area
    const T camera_area = bc.pdf * -dot(w, l.nf) * inv_d2;
    const T light_area = bl.pdf * dot(w, v.nf) * inv_d2;
    const T s = T(c.estimator.reverse_pdf_scale);
    const T w_light =
        mis2(camera_area) * (mw.vm_weight + l.mis.vcm + l.mis.vc * mis2(bl.pdf_reverse * s));
    const T w_camera =
        mis2(light_area) * (mw.vm_weight + v.mis.vcm + v.mis.vc * mis2(bc.pdf_reverse * s));
    return T(1.0f) / (T(1.0f) + w_light + w_camera);
}

// s, t ≥ 2: camera vertex v connected to light vertex l: the shadow ray between them (from
// v's shadow origin to l's, offset to the side the connection arrives on) and what it adds
// if clear, weighted, before the camera subpath's throughput (the light's is in).
template <class T>
ShadowRequest<T> connect_vertices(const PathContext& c, const CameraVertex<T>& v,
                                  const LightVertex<T>& l, const MergeWeights<T>& mw,
                                  const Mask<T>& want) {
    const EstimatorSettings& est = c.estimator;
    const Vec3<T> to = l.p - v.p;
    const T d2 = dot(to, to);
    const T dist = sqrt(d2);
    const Vec3<T> w = to * (T(1.0f) / dist);
    const BsdfEval<T> bc = phong_eval(v.phong, v.wo, v.nsf, w, est.cosine_diffuse);
    const BsdfEval<T> bl = phong_eval(l.phong, l.wl, l.nsf, -w, est.cosine_diffuse);
    const T cos_c = dot(w, v.nf), cos_l = -dot(w, l.nf);
    const T inv_d2 = T(1.0f) / d2;
    const T weight = strategy_weight(c.estimator, l.length + U32<T>(1u), v.vertices,
                                     connection_mis(c, v, l, mw, bc, bl, w, d2));
    const Vec3<T> target = offset_ray_origin(l.p, l.nf, l.magnitude);
    const Vec3<T> ray = target - v.origin;
    const T reach = length(ray);
    ShadowRequest<T> r;
    r.origin = v.origin;
    r.dir = ray * (T(1.0f) / reach);
    r.tmax = reach * T(1.0f - 1e-5f);
    r.value = l.beta * light_vertex_f_cos(l, bl, -w, c.smooth) * bc.f *
              (max(bc.cos_i, T(0.0f)) * weight * inv_d2);
    r.want = want & (cos_c > T(0.0f)) & (cos_l > T(0.0f)) & (d2 > T(0.0f)) &
             (max_component(r.value) > T(0.0f)) & (r.value.x < T(kRayFar)) &
             (r.value.y < T(kRayFar)) & (r.value.z < T(kRayFar));
    return r;
}

// ---- The light vertex cache (EstimatorSettings::light_connections n ≥ 1) -----------------
//
// Instead of every vertex of its own light subpath, a Phong camera vertex connects to n
// vertices drawn uniformly, with replacement, from the V stored vertices of the N light
// subpaths of its sample index in its tile (the set vcm merges with; Davidovič et al. 2014's
// light vertex cache). Draw j takes vertex ⌊u_j·V⌋ (connection_uniform) and counts V/(N·n)
// times: the n draws' sum then has the expectation of (1/N)·Σ over the N subpaths of the
// connections to all their vertices, which is the pairing's, as every subpath is an
// independent light subpath. In the MIS weights a connection to a light vertex of a given
// index is made c = n·N/V times per camera vertex on average (V/N: the mean number of
// vertices a light subpath stores, PathContext::connection_count, estimated before the
// render), where the pairing makes it once: the power heuristic takes each strategy's
// density times its count (Veach 1997, §9.2.2; connection_count2). Any c keeps every
// strategy's estimate unbiased and a path's weights summing to 1; the expected one weighs
// the strategies as often as they are made. What a draw costs is one connection where the
// pairing makes one per vertex of the light subpath.

// The vertex of draw u among a set of `vertices` (> 0), from 0.
template <class T>
I32<T> cache_vertex(const T& u, const I32<T>& vertices) {
    return min(to_int(u * to_float(vertices)), vertices - I32<T>(1));
}

// What each of n draws from a set of `vertices` stored by `paths` light subpaths counts.
template <class T>
T cache_draw_weight(const I32<T>& vertices, int32_t paths, int32_t n) {
    return to_float(vertices) * T(1.0f / (float(paths) * float(n)));
}

// A drawn connection: connect_vertices's request, its value counting `weight` times.
template <class T>
ShadowRequest<T> connect_drawn_vertex(const PathContext& c, const CameraVertex<T>& v,
                                      const LightVertex<T>& l, const MergeWeights<T>& mw,
                                      const T& weight, const Mask<T>& want) {
    ShadowRequest<T> r = connect_vertices(c, v, l, mw, want);
    r.value = r.value * weight;
    r.want =
        r.want & (r.value.x < T(kRayFar)) & (r.value.y < T(kRayFar)) & (r.value.z < T(kRayFar));
    return r;
}

// ---- Vertex merging (vcm, bpm, ppm) ------------------------------------------------------

// Whether camera vertex v merges: every Phong vertex under vcm and bpm; under ppm
// (progressive photon mapping) the first Phong vertex of the camera subpath, reached through
// mirrors and glass alone.
template <class T>
Mask<T> camera_vertex_merges(const EstimatorSettings& e, const CameraVertex<T>& v) {
    if (e.kind != Estimator::kPpm) return Mask<T>(true);
    return through_delta_only(v.mis, v.vertices);
}

// ppm: whether the lobe the roulette chose at a camera vertex ends its subpath. A Phong lobe
// does (the vertex merged, and no later vertex would), unless the scene has light that only
// camera paths find (PathContext::unstarted_light), which the subpath goes on to gather;
// mirrors and glass go on with their usual weight.
template <class T>
Mask<T> camera_lobe_ends_path(const PathContext& c, const I32<T>& lobe) {
    if (c.estimator.kind != Estimator::kPpm || c.unstarted_light) return Mask<T>(false);
    return mask_f32(lobe == I32<T>(kLobeDiffuse)) | mask_f32(lobe == I32<T>(kLobeSpecular));
}

// A camera vertex merged with a light vertex l of its sample's tile (a photon): the path
// the light subpath would make if it went on from l's previous vertex to v's point. Its
// weight against the connections that make the same path (bc: v's Phong lobes towards
// l.wl): the light side's quantities at l with v's density of sampling l.wl as the reverse,
// the camera side's with its density of sampling v.wo from l.wl. ppm weighs nothing: its
// camera subpaths merge only at their first Phong vertex (camera_vertex_merges), so each
// merge makes paths that no other strategy of it makes.
template <class T>
T merge_mis(const PathContext& c, const CameraVertex<T>& v, const LightVertex<T>& l,
            const MergeWeights<T>& mw, const BsdfEval<T>& bc) {
    if (c.estimator.kind == Estimator::kPpm) return T(1.0f);
    const T w_light = l.mis.vcm * mw.vc_weight + l.mis.vm * mis2(bc.pdf);
    const T w_camera = v.mis.vcm * mw.vc_weight +
                       v.mis.vm * mis2(bc.pdf_reverse * T(c.estimator.reverse_pdf_scale));
    return T(1.0f) / (T(1.0f) + w_light + w_camera);
}

// What merging camera vertex v with light vertex l adds, weighted, before the camera
// subpath's throughput: the density estimate f(v.wo, l.wl)·β_l / (π r² N), where l is
// within the sample's radius of v and arrived from v's side of its surface; else 0.
template <class T>
Vec3<T> merge_vertices(const PathContext& c, const CameraVertex<T>& v, const LightVertex<T>& l,
                       const MergeWeights<T>& mw, const Mask<T>& want) {
    const Vec3<T> to = l.p - v.p;
    const BsdfEval<T> bc = phong_eval(v.phong, v.wo, v.nsf, l.wl, c.estimator.cosine_diffuse);
    const Vec3<T> value = l.beta * bc.f * (merge_mis(c, v, l, mw, bc) * mw.normalization);
    const auto ok = want & (dot(to, to) <= mw.radius2) & (dot(l.wl, v.nf) > T(0.0f)) &
                    (value.x < T(kRayFar)) & (value.y < T(kRayFar)) & (value.z < T(kRayFar));
    return select(ok, value, Vec3<T>(T(0.0f)));
}

}  // namespace CIERZO_ISA_NAMESPACE
}  // namespace cierzo
