// What the scalar reference's path loops share (scalar.cpp, scalar_bdpt.cpp): the inlining
// of every kernel they call, a shadow ray traced as soon as a vertex asks for it, and the one
// walk of a light subpath that light tracing and the bidirectional estimators both take.
#pragma once

#include "integrators/render_types.h"
#include "kernels/bidirectional.h"
#include "kernels/path_vertex.h"
#include "scene/scene.h"

// The path loops inline every kernel they call, as the wavefront's stage loops do (and as
// the compiler chose to when the vertex rules were written inside them). Sanitizer builds
// skip it, for their compile time.
#if defined(__SANITIZE_ADDRESS__)
#define CIERZO_PATH_LOOP
#else
#define CIERZO_PATH_LOOP [[gnu::flatten]]
#endif

namespace cierzo {

// A shadow ray the vertex asked for, traced at once: what it adds if clear.
inline Vec3f trace_request(const Scene& scene, const ShadowRequest<float>& r, RayCounts& rays) {
    if (!r.want) return Vec3f(0.0f);
    ++rays.shadow;
    return scene.occluded({r.origin, r.dir}, r.tmax) ? Vec3f(0.0f) : r.value;
}

// One light subpath, with the numbers of the camera sample whose stream it takes
// (light_stream): light tracing's path (scalar.cpp) and the bidirectional estimators' light
// subpath (scalar_bdpt.cpp) are this walk, told apart by their use `at`: at.start(start) once
// the start is sampled, at.vertex(lv, m) at every Phong vertex (lv and its Bsdf m), then the
// roulette and the chosen lobe in importance mode. With At::kMis the subpath carries its MIS
// quantities (mw: its sample's merging quantities) and lv its Phong lobes; light tracing
// weighs nothing, and skips them.
template <class At>
inline void walk_light_subpath(const Scene& scene, const PathContext& c,
                               const LightStartTable& lights, const SampleStream<float>& camera_rng,
                               const MergeWeights<float>& mw, At& at, RayCounts& rays) {
    const SampleStream<float> rng = light_stream(camera_rng);
    const LightStart<float> start = sample_light_start<float>(c.emitters, lights, rng);
    if (!start.ok) return;
    at.start(start);
    ++rays.light;
    if (!may_extend<float>(c.estimator, 0u)) return;
    SubpathMis<float> mis{};
    if constexpr (At::kMis) mis = light_start_mis(c, start, mw);
    Ray<float> ray{
        start.on_surface
            ? offset_ray_origin(start.p, dot(start.dir, start.n) > 0.0f ? start.n : -start.n,
                                max_abs(start.p))
            : start.p,
        start.dir};
    Vec3f beta = start.beta;
    const float cap = c.estimator.survival_cap;
    for (uint32_t bounce = 1;; ++bounce) {
        Hit hit;
        if (!scene.intersect(ray, kRayFar, hit)) break;
        const Material& material = scene.materials[size_t(hit.material)];
        if (material.is_emitter()) break;  // emitters absorb what reaches them
        const Bsdf<float> m = scene.bsdf_at(hit);
        const float magnitude = max(max_abs(hit.p), max_abs(ray.o));
        const VertexFrame<float> v = vertex_frame(c.smooth, ray.d, hit.n, hit.ns);
        PhongVertex<float> pv{};
        if constexpr (At::kMis) {
            const float direct =
                bounce == 1 ? start_direct_pdf_area<float>(c, start, hit.p, ray.d, hit.t) : 1.0f;
            mis_at_hit(mis, hit.t, std::abs(dot(ray.d, v.nf)), direct);
            pv = phong_vertex(m, cap);
        }
        if (material.has_phong())
            at.vertex(
                LightVertex<float>{hit.p, v.nf, v.nsf, -ray.d, beta, pv, mis, magnitude, bounce},
                m);

        // The roulette and the chosen lobe, in importance mode
        float p = 0.0f;
        const int32_t lobe = choose_lobe(m, uniform<float>(rng, bounce, Purpose::kLobe), cap, p);
        if (lobe == kLobeAbsorbed || !may_extend<float>(c.estimator, bounce)) break;
        const ScalarContinuation next = continue_path<Transport::kImportance>(
            lobe, c, m, ray.d, v, hit.p, hit.n, hit.ns, magnitude, p, rng, bounce);
        beta *= next.weight;
        if (!(max_component(beta) > 0.0f)) break;
        if constexpr (At::kMis) mis_after_lobe<float>(c, mis, lobe, pv, v, ray.d, next.d, mw);
        ray = {next.o, next.d};
        ++rays.extension;
    }
}

}  // namespace cierzo
