// The camera subpaths of the bidirectional estimators in the wavefront (bdpt_stage.h's
// second wave): at each hit s = 0 (emitter or environment) weighed at once; a Phong vertex
// queues its light samples (s = 1) and its connections to stored light vertices (s, t ≥ 2:
// one per vertex of its own light subpath, lane k of the batch gathering its path's k-th,
// or draws from the light vertex cache) as shadow rays, traced whenever the queue fills and
// after the pass; vcm: it merges with the stored vertices near it (merge_stage.h).
#pragma once

#include "integrators/wavefront/light_subpath_stage.h"
#include "integrators/wavefront/merge_stage.h"
#include "integrators/wavefront/shadow_stage.h"
#include "kernels/bidirectional.h"

namespace cierzo {
inline namespace CIERZO_ISA_NAMESPACE {

// A light-store vertex for each lane (indices idx; lanes not in `m` read vertex 0).
// (the shading normal only in scenes with smooth meshes, the specular lobe only in scenes
// with one: the fields that are not stored)
template <class A>
LightVertex<typename Wave<A>::F> gather_light_vertex(const FlatScene& s, const LightVertexStore& st,
                                                     const typename Wave<A>::I& idx) {
    using F = typename Wave<A>::F;
    const typename Wave<A>::I at = idx * typename Wave<A>::I(kLightVertexStride);
    const auto g = [&](int k) { return gather_lanes<A>(st.records + k, at); };
    LightVertex<F> l;
    l.p = {g(kLvPx), g(kLvPy), g(kLvPz)};
    l.nf = {g(kLvNx), g(kLvNy), g(kLvNz)};
    l.nsf = s.path.smooth ? Vec3<F>{g(kLvSx), g(kLvSy), g(kLvSz)} : l.nf;
    l.wl = {g(kLvWx), g(kLvWy), g(kLvWz)};
    l.beta = {g(kLvBr), g(kLvBg), g(kLvBb)};
    l.phong.kd = {g(kLvKdR), g(kLvKdG), g(kLvKdB)};
    l.phong.p_diffuse = g(kLvPd);
    if (s.features.specular) {
        l.phong.ks = {g(kLvKsR), g(kLvKsG), g(kLvKsB)};
        l.phong.shininess = g(kLvShininess);
        l.phong.p_specular = g(kLvPs);
    } else {
        l.phong.ks = Vec3<F>(F(0.0f));
        l.phong.shininess = l.phong.p_specular = F(0.0f);
    }
    l.mis = {g(kLvVcm), g(kLvVc), g(kLvVm)};
    l.magnitude = g(kLvMagnitude);
    l.length = gather_lanes<A>(st.length, idx);
    return l;
}

// Queues shadow rays of the lanes in `want` (owner: the lane's path), tracing the queue
// first when it could not take a whole batch more. The owners' radiance must be in the pool.
template <class A>
void queue_owned(Wave<A>& w, int32_t i, const ShadowRequest<typename Wave<A>::F>& r,
                 const Vec3<typename Wave<A>::F>& value, int32_t& queued) {
    constexpr int32_t K = Wave<A>::K;
    PathPool& p = w.pool;
    const uint32_t bits = mask_bits(r.want);
    if (!bits) return;
    if (queued + K > p.shadow_capacity) {
        p.shadow_count = queued;
        trace_shadow_rays(w);
        w.counters.shadow += uint64_t(queued);
        queued = 0;
    }
    const typename Wave<A>::F* src[10] = {&r.origin.x, &r.origin.y, &r.origin.z, &r.dir.x,
                                          &r.dir.y,    &r.dir.z,    &r.tmax,     &value.x,
                                          &value.y,    &value.z};
    float* dst[10] = {p.sox, p.soy, p.soz, p.sdx, p.sdy, p.sdz, p.stmax, p.sc_r, p.sc_g, p.sc_b};
    for (int k = 0; k < 10; ++k) compress<A>(*src[k], bits).store_unaligned(dst[k] + queued);
    compress<A>(Wave<A>::lane_ids(i), bits).store_unaligned(p.sowner + queued);
    queued += std::popcount(bits);
}

// The light vertex cache (light_connections n ≥ 1): each lane in `phong` connects its camera
// vertex cv to n vertices drawn from its sample's set (kernels/bidirectional.h), queued as
// shadow rays owned by the lane.
template <class A>
[[gnu::noinline]] void draw_connections(Wave<A>& w, int32_t i,
                                        const CameraVertex<typename Wave<A>::F>& cv,
                                        const Vec3<typename Wave<A>::F>& beta,
                                        const MergeWeights<typename Wave<A>::F>& mw,
                                        const typename Wave<A>::M& phong,
                                        const typename Wave<A>::U& bounce, int32_t& queued) {
    using F = typename Wave<A>::F;
    using U = typename Wave<A>::U;
    using I = typename Wave<A>::I;
    constexpr int32_t K = Wave<A>::K;
    PathPool& p = w.pool;
    const FlatScene& s = w.scene;
    const EstimatorSettings& est = s.path.estimator;
    const LightVertexStore& st = *p.light_store;
    // (a job whose light subpaths stored nothing: no lights to start from, or every light
    // path lost at once; the sets' bounds below take a division per lane)
    if (st.count == 0) return;
    // Each lane's set: its first vertex in `order` and its count
    alignas(64) int32_t first[K], count[K];
    const uint32_t per = uint32_t(st.paths_per_sample), last = uint32_t(st.samples) - 1u;
    for (int32_t l = 0; l < K; ++l) {
        const uint32_t set = std::min(p.path_id[i + l] / per, last);
        first[l] = int32_t(st.begin[set * per]);
        count[l] = int32_t(st.begin[(set + 1u) * per]) - first[l];
    }
    const I lo = I::load_aligned(first);
    const I n = I::load_aligned(count);
    const auto some = phong & mask_f32(n > I(0));
    if (!any(some)) return;
    const I vertices = max(n, I(1));
    const F weight = cache_draw_weight<F>(vertices, st.paths_per_sample, est.light_connections);
    const SampleStream<F> rng = stream_at<A>(s, p, i);
    for (int32_t j = 0; j < est.light_connections; ++j) {
        const I k = cache_vertex<F>(connection_uniform<F>(rng, bounce, uint32_t(j)), vertices);
        const I idx = gather_lanes<A>(st.order, select(mask_i32(some), lo + k, I(0)));
        const LightVertex<F> lv = gather_light_vertex<A>(s, st, idx);
        auto has = some;
        has = length_counts<F>(est, lv.length + bounce + U(2u), has);
        const ShadowRequest<F> r = connect_drawn_vertex(s.path, cv, lv, mw, weight, has);
        queue_owned(w, i, r, beta * r.value, queued);
    }
}

// One batch of camera-subpath vertices: s = 0 at once; s = 1 and s, t ≥ 2 queued as shadow
// rays; the roulette and the lobe, the new state stored in place (compact_paths follows).
template <class A, class Read>
void camera_subpath_batch(Wave<A>& w, int32_t i, const Ray<typename Wave<A>::F>& ray,
                          const Surfaces<A>& sf, const Read& evaluated, int32_t& queued) {
    using F = typename Wave<A>::F;
    using U = typename Wave<A>::U;
    using I = typename Wave<A>::I;
    constexpr int32_t K = Wave<A>::K;
    PathPool& p = w.pool;
    const FlatScene& s = w.scene;
    const PathContext& c = s.path;
    const EstimatorSettings& est = c.estimator;
    const LightStartTable& lights = s.light_starts;
    const I mat = sf.material;
    const MergeWeights<F> mw = lane_merge_weights(w, i);
    auto alive = sf.hit;
    const Vec3<F> beta = load3<F>(p.beta_r, p.beta_g, p.beta_b, i);
    Vec3<F> rad = load3<F>(p.rad_r, p.rad_g, p.rad_b, i);
    const SampleStream<F> rng = stream_at<A>(s, p, i);
    const U bounce = U::load_aligned(p.bounce + i);
    const Vec3<F>& d = ray.d;
    SubpathMis<F> mis = load_mis<A>(p, i);
    const F t = length(sf.pos - ray.o);
    const F cos_in = abs(dot(d, sf.n));
    mis_at_hit(mis, t, cos_in);

    // s = 0: an emitter ends the path; a path that escapes gathers the environment
    if (s.features.emitters) {
        const auto em = mask_f32(lookup<A>(s.emitter, s.material_count, mat) != I(0)) & alive;
        if (any(em)) {
            const Vec3<F> le =
                hit_color<A>(s, kColEmission, mat, evaluated) *
                emitter_hit_mis<F>(c, lights, mis, select(mask_i32(em), sf.emitter, I(-1)), ray.o,
                                   d, t, cos_in, bounce + U(2u));
            rad = select(length_counts<F>(est, bounce + U(1u), em), rad + beta * le, rad);
            alive = alive & !em;
        }
    }
    if (has_environment(c)) {
        const auto missed = w.live_mask(i) & !sf.hit;
        if (any(missed)) {
            const Vec3<F> le = environment_radiance(c.emitters.environment, d) *
                               environment_mis<F>(c, mis, d, bounce + U(2u));
            rad = select(length_counts<F>(est, bounce + U(1u), missed), rad + beta * le, rad);
        }
    }
    store3(rad, p.rad_r, p.rad_g, p.rad_b, i);  // (before any shadow ray adds to it)

    const Bsdf<F> m = hit_bsdf<kLobeCount, A>(s, mat, evaluated);
    const VertexFrame<F> v = vertex_frame(c.smooth, d, sf.n, sf.ns);
    const PhongVertex<F> pv = phong_vertex(m, est.survival_cap);
    const auto phong = mask_f32(lookup<A>(s.phong, s.material_count, mat) != I(0)) & alive;
    if (any(phong)) {
        const CameraVertex<F> cv{
            sf.pos, v.nf, v.nsf,         -d, shadow_origin(v, sf.pos, sf.magnitude),
            pv,     mis,  bounce + U(2u)};
        // s = 1: the lights sampled from here
        const bool connecting = connects(est.kind);
        const auto direct = length_counts<F>(est, bounce + U(2u), phong);
        if (connecting && any(direct)) {
            if (c.emitters.count > 0) {
                const ShadowRequest<F> r = nee_emitter(c, lights, cv, mw, rng, bounce, direct);
                queue_owned(w, i, r, beta * r.value, queued);
            }
            for (int32_t j = 0; j < lights.point_count; ++j) {
                const ShadowRequest<F> r = nee_point_light(c, lights, j, cv, mw, direct);
                queue_owned(w, i, r, beta * r.value, queued);
            }
        }
        // s, t ≥ 2: draws from the light vertex cache, or (the pairing) the k-th vertex of
        // each lane's light subpath, for every k some lane has
        if (connecting && est.light_connections > 0) {
            draw_connections(w, i, cv, beta, mw, phong, bounce, queued);
        } else if (connecting) {
            const LightVertexStore& st = *p.light_store;
            const I id = select(mask_i32(phong),
                                xsimd::bitwise_cast<I>(U::load_aligned(p.path_id + i)), I(0));
            const I lo = xsimd::bitwise_cast<I>(gather_lanes<A>(st.begin, id));
            const I hi = xsimd::bitwise_cast<I>(gather_lanes<A>(st.begin, id + I(1)));
            const I n = select(mask_i32(phong), hi - lo, I(0));
            alignas(64) int32_t lane_n[K];
            n.store_aligned(lane_n);
            int32_t most = 0;
            for (int32_t l = 0; l < K; ++l) most = std::max(most, lane_n[l]);
            for (int32_t k = 0; k < most; ++k) {
                auto has = mask_f32(I(k) < n);
                const I idx = gather_lanes<A>(st.order, select(mask_i32(has), lo + I(k), I(0)));
                const LightVertex<F> lv = gather_light_vertex<A>(s, st, idx);
                has = length_counts<F>(est, lv.length + bounce + U(2u), has);
                const ShadowRequest<F> r = connect_vertices(c, cv, lv, mw, has);
                queue_owned(w, i, r, beta * r.value, queued);
            }
        }
        // vcm, bpm, ppm: the stored vertices near it
        if (merges(est.kind))
            merge_lanes<A>(w, i, cv, beta, mw, phong & camera_vertex_merges<F>(est, cv));
    }

    Vec3<F> dir, weight;
    bdpt_scatter<Transport::kRadiance, A>(s, m, pv, v, sf, d, rng, bounce, mw, alive, mis, dir,
                                          weight);
    const Vec3<F> beta1 = beta * weight;
    alive = alive & (max_component(beta1) > F(0.0f));
    store3(leaving_origin(sf.pos, sf.n, dir, sf.magnitude), p.ox, p.oy, p.oz, i);
    store3(dir, p.dx, p.dy, p.dz, i);
    store3(beta1, p.beta_r, p.beta_g, p.beta_b, i);
    mis.vcm.store_aligned(p.mis_vcm + i);
    mis.vc.store_aligned(p.mis_vc + i);
    mis.vm.store_aligned(p.mis_vm + i);
    select(mask_i32(alive), I(1), I(0)).store_aligned(p.alive + i);
    w.counters.extension += uint64_t(std::popcount(mask_bits(alive)));
    w.counters.lanes_active += uint64_t(std::min(K, w.live - i));
    w.counters.lanes_total += uint64_t(K);
}

}  // namespace CIERZO_ISA_NAMESPACE
}  // namespace cierzo
