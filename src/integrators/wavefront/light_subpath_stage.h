// Paths from the lights in the wavefront, through the same pool, intersection, surface and
// material stages as the camera's: one walk that light tracing (light_stage.h) and the
// bidirectional estimators' light subpaths (bdpt_stage.h) share, told apart by LightUse.
//   regenerate: free slots take the job's next (pixel, sample) keys, each a light path's
//     start (a light chosen by power, a point, a direction); light tracing connects an
//     emitter's point to the pinhole at once, a light subpath takes its MIS quantities;
//   intersect → surfaces (→ materials, textured scenes) → vertex: at each Phong vertex a
//     light subpath is appended to the thread's light-vertex store, and its connection to
//     the pinhole (t = 1) is queued, weighed for a light subpath; the roulette picks a lobe,
//     the lobe is sampled in importance mode, and the survivors move to the front of the pool;
//   camera connections: the queued shadow rays to the pinhole, traced in full batches; the
//     clear ones are splatted (the film takes them in batches: TileJob);
// until every path of the job has ended.
#pragma once

#include "integrators/wavefront/camera_stage.h"
#include "integrators/wavefront/compact_stage.h"
#include "integrators/wavefront/intersect_stage.h"
#include "integrators/wavefront/material_stage.h"
#include "integrators/wavefront/merge_stage.h"
#include "integrators/wavefront/surface_stage.h"
#include "kernels/bidirectional.h"
#include "kernels/path_vertex.h"

namespace cierzo {
inline namespace CIERZO_ISA_NAMESPACE {

// The two uses of a path from the lights: light tracing's (its emitter's point and every
// Phong vertex seen from the pinhole, unweighted) and the bidirectional estimators' (every
// Phong vertex stored, the subpath's MIS quantities carried, the pinhole's view weighed).
enum class LightUse { kLightTracing, kBidirectional };

// Queues the splats of the lanes in `bits` (pixel, value) at the pool's splat queue
// (p.done_*: a light path hands no radiance over when it ends). At most one splat per lane
// processed so far is queued, so the queue never outruns the pool.
template <class A>
void queue_splats(PathPool& p, uint32_t bits, const xsimd::batch<int32_t, A>& pixel,
                  const Vec3<xsimd::batch<float, A>>& v, int32_t& queued) {
    using U = xsimd::batch<uint32_t, A>;
    if (!bits) return;
    compress<A>(xsimd::bitwise_cast<U>(pixel), bits).store_unaligned(p.done_pixel + queued);
    compress<A>(v.x, bits).store_unaligned(p.done_r + queued);
    compress<A>(v.y, bits).store_unaligned(p.done_g + queued);
    compress<A>(v.z, bits).store_unaligned(p.done_b + queued);
    queued += std::popcount(bits);
}

template <class A>
void flush_splats(const TileJob& job, PathPool& p, int32_t& queued) {
    if (queued) job.splat(job.film, queued, p.done_pixel, p.done_r, p.done_g, p.done_b);
    queued = 0;
}

// The connections of the lanes in `want` (from `origin`, offset to the pinhole's side) to
// the pinhole, queued: the camera connections are a shadow-ray queue of
// their own (the pool's shadow queue, which light paths use for nothing else: origin,
// direction, distance, the value to splat, and the pixel in place of an owner), traced in
// full batches by trace_camera_connections.
template <class A>
void queue_connections(Wave<A>& w, typename Wave<A>::M want,
                       const Vec3<typename Wave<A>::F>& origin,
                       const CameraConnection<typename Wave<A>::F>& c,
                       const Vec3<typename Wave<A>::F>& value, int32_t& connections) {
    using F = typename Wave<A>::F;
    using U = typename Wave<A>::U;
    PathPool& p = w.pool;
    want = want & c.ok & (max_component(value) > F(0.0f));
    const uint32_t bits = mask_bits(want);
    if (!bits) return;
    const int32_t at = connections;
    const auto put = [&](const F& v, float* a) { compress<A>(v, bits).store_unaligned(a + at); };
    put(origin.x, p.sox), put(origin.y, p.soy), put(origin.z, p.soz);
    put(c.wc.x, p.sdx), put(c.wc.y, p.sdy), put(c.wc.z, p.sdz);
    put(c.dist * F(1.0f - 1e-5f), p.stmax);
    put(value.x, p.sc_r), put(value.y, p.sc_g), put(value.z, p.sc_b);
    compress<A>(xsimd::bitwise_cast<U>(c.pixel), bits)
        .store_unaligned(reinterpret_cast<uint32_t*>(p.sowner) + at);
    connections += std::popcount(bits);
}

// The queued camera connections, K at a time (any hit); the clear ones are splatted, and the
// splats handed to the film.
template <class A>
CIERZO_STAGE_LOOP void trace_camera_connections(Wave<A>& w, const TileJob& job,
                                                int32_t& connections) {
    using F = typename Wave<A>::F;
    using I = typename Wave<A>::I;
    constexpr int32_t K = Wave<A>::K;
    PathPool& p = w.pool;
    const int32_t count = connections;
    int32_t queued = 0;
    for (int32_t i = 0; i < count; i += K) {
        const Ray<F> ray{load3<F>(p.sox, p.soy, p.soz, i), load3<F>(p.sdx, p.sdy, p.sdz, i)};
        const int32_t lanes = std::min(K, count - i);
        const auto live = Wave<A>::lane_index() < F(float(lanes));
        const auto blocked = occluded<A>(w.scene, ray, F::load_aligned(p.stmax + i), live);
        queue_splats<A>(p, mask_bits(live & !blocked), I::load_aligned(p.sowner + i),
                        load3<F>(p.sc_r, p.sc_g, p.sc_b, i), queued);
        w.counters.shadow_active += uint64_t(lanes);
        w.counters.shadow_total += uint64_t(K);
    }
    w.counters.shadow += uint64_t(count);
    connections = 0;
    flush_splats<A>(job, p, queued);
}

// Paths [first, w.live) are the job's paths seq0, seq0 + 1, ...
template <class A>
void number_paths(Wave<A>& w, int32_t first, uint32_t seq0) {
    for (int32_t k = first; k < w.live; ++k) w.pool.path_id[k] = seq0 + uint32_t(k - first);
}

template <class A>
SubpathMis<typename Wave<A>::F> load_mis(const PathPool& p, int32_t i) {
    using F = typename Wave<A>::F;
    return {F::load_aligned(p.mis_vcm + i), F::load_aligned(p.mis_vc + i),
            F::load_aligned(p.mis_vm + i)};
}

// Appends the lanes in `bits` of vertex l (of paths `path`) to the store.
template <class A>
void append_light_vertices(LightVertexStore& st, uint32_t bits,
                           const LightVertex<typename Wave<A>::F>& l,
                           const typename Wave<A>::U& path) {
    using F = typename Wave<A>::F;
    constexpr int32_t K = Wave<A>::K;
    if (!bits) return;
    if (st.count + K > st.capacity) st.grow(st, st.count + K);
    // clang-format off
    const F* v[kLightVertexFloats] = {
        &l.p.x,         &l.p.y,         &l.p.z,         &l.nf.x,           &l.nf.y,
        &l.nf.z,        &l.nsf.x,       &l.nsf.y,       &l.nsf.z,          &l.wl.x,
        &l.wl.y,        &l.wl.z,        &l.beta.x,      &l.beta.y,         &l.beta.z,
        &l.phong.kd.x,  &l.phong.kd.y,  &l.phong.kd.z,  &l.phong.ks.x,     &l.phong.ks.y,
        &l.phong.ks.z,  &l.phong.shininess, &l.phong.p_diffuse, &l.phong.p_specular,
        &l.mis.vcm,     &l.mis.vc,      &l.mis.vm,      &l.magnitude};
    // clang-format on
    // (the lanes' fields side by side, then each kept lane's column into its record)
    alignas(64) float lanes[kLightVertexFloats][K];
    for (int k = 0; k < kLightVertexFloats; ++k) v[k]->store_aligned(lanes[k]);
    float* out = st.record(st.count);
    for (uint32_t b = bits; b; b &= b - 1, out += kLightVertexStride) {
        const int lane = std::countr_zero(b);
        for (int k = 0; k < kLightVertexFloats; ++k) out[k] = lanes[k][lane];
    }
    compress<A>(l.length, bits).store_unaligned(st.length + st.count);
    compress<A>(path, bits).store_unaligned(st.path + st.count);
    st.count += std::popcount(bits);
}

// The light-store's vertices grouped by path: begin[k]..begin[k + 1] of `order` are path
// k's, in the order they were stored (a counting sort; a path's vertices were stored in
// the order of its bounces).
CIERZO_STAGE inline void group_light_vertices(LightVertexStore& st, int32_t paths) {
    for (int32_t k = 0; k <= paths; ++k) st.begin[k] = 0;
    for (int32_t v = 0; v < st.count; ++v) ++st.begin[st.path[v] + 1];
    for (int32_t k = 0; k < paths; ++k) st.begin[k + 1] += st.begin[k];
    // (begin[k] is advanced past each vertex placed, then restored)
    for (int32_t v = 0; v < st.count; ++v) st.order[st.begin[st.path[v]]++] = v;
    for (int32_t k = paths; k > 0; --k) st.begin[k] = st.begin[k - 1];
    st.begin[0] = 0;
}

// Regeneration: the paths [w.live, ...) take the job's next keys (as the camera's would)
// and become light paths: start sampled, ray and throughput set; for light tracing, the
// emitter's point connected; for a light subpath, its number in the job, MIS quantities and
// start. A start that cannot be sampled is dead at once (its throughput 0).
template <LightUse kUse, class A>
CIERZO_STAGE_LOOP void generate_light_subpaths(Wave<A>& w, TileCursor& cursor,
                                               int32_t& connections) {
    using F = typename Wave<A>::F;
    using U = typename Wave<A>::U;
    using I = typename Wave<A>::I;
    constexpr int32_t K = Wave<A>::K;
    constexpr bool kBidirectional = kUse == LightUse::kBidirectional;
    PathPool& p = w.pool;
    const FlatScene& s = w.scene;
    const int32_t first = w.live;
    const uint32_t seq0 = uint32_t(cursor.next);
    const uint64_t before = w.counters.camera;
    // (the camera's regeneration assigns pixels and keys; its rays are replaced below)
    generate_camera_paths<false>(w, cursor);
    w.counters.light += w.counters.camera - before;
    w.counters.camera = before;
    if constexpr (kBidirectional) number_paths(w, first, seq0);
    const int32_t end = w.live;
    const EstimatorSettings& est = s.path.estimator;
    // (a path that may not go on past its start: throughput 0, so its first hit ends it)
    const bool extends = may_extend<float>(est, 0u);
    for (int32_t i = first / K * K; i < end; i += K) {
        const F lane = Wave<A>::lane_index();
        const auto fresh = (lane >= F(float(first - i))) & (lane < F(float(end - i)));
        const SampleStream<F> rng = light_stream(stream_at<A>(s, p, i));
        const LightStart<F> ls = sample_light_start<F>(s.path.emitters, s.light_starts, rng);
        if constexpr (!kBidirectional) {
            // The emitter's point itself, seen by the pinhole
            const auto surface =
                !length_counts<float>(est, 1u) ? fresh & !fresh : fresh & ls.ok & ls.on_surface;
            if (any(surface)) {
                const CameraConnection<F> c = connect_camera(s.pinhole, ls.p);
                const F cos_l = dot(c.wc, ls.n);
                const Vec3<F> origin =
                    offset_ray_origin(ls.p, select(cos_l > F(0.0f), ls.n, -ls.n), max_abs(ls.p));
                queue_connections(w, surface, origin, c, ls.le * (abs(cos_l) * c.factor),
                                  connections);
            }
        }
        const Vec3<F> o =
            select(ls.on_surface,
                   offset_ray_origin(ls.p, select(dot(ls.dir, ls.n) > F(0.0f), ls.n, -ls.n),
                                     max_abs(ls.p)),
                   ls.p);
        const auto starts = extends ? ls.ok : (ls.ok & !ls.ok);
        const Vec3<F> beta = select(starts, ls.beta, Vec3<F>(F(0.0f)));
        const auto keep = [&](const F& v, float* a) {
            select(fresh, v, F::load_aligned(a + i)).store_aligned(a + i);
        };
        keep(o.x, p.ox), keep(o.y, p.oy), keep(o.z, p.oz);
        keep(ls.dir.x, p.dx), keep(ls.dir.y, p.dy), keep(ls.dir.z, p.dz);
        keep(beta.x, p.beta_r), keep(beta.y, p.beta_g), keep(beta.z, p.beta_b);
        if constexpr (kBidirectional) {
            const SubpathMis<F> mis = light_start_mis(s.path, ls, lane_merge_weights(w, i));
            keep(mis.vcm, p.mis_vcm), keep(mis.vc, p.mis_vc), keep(mis.vm, p.mis_vm);
            keep(ls.cos_light, p.start_cos);
            select(mask_i32(fresh), ls.emitter, I::load_aligned(p.start_emitter + i))
                .store_aligned(p.start_emitter + i);
        }
        select(mask_u32(fresh), rng.key, U::load_aligned(p.key + i)).store_aligned(p.key + i);
        select(mask_u32(fresh), U(1u), U::load_aligned(p.bounce + i)).store_aligned(p.bounce + i);
    }
}

// The roulette and the chosen lobe of each lane (kMode: radiance for camera subpaths,
// importance for light subpaths), and the subpath quantities after it (kMis; light tracing
// carries none): the new direction and throughput factor; `alive` loses the lanes whose
// path ends.
template <Transport kMode, class A, bool kMis = true>
void bdpt_scatter(const FlatScene& s, const Bsdf<typename Wave<A>::F>& m,
                  const PhongVertex<typename Wave<A>::F>& pv,
                  const VertexFrame<typename Wave<A>::F>& v, const Surfaces<A>& sf,
                  const Vec3<typename Wave<A>::F>& d, const SampleStream<typename Wave<A>::F>& rng,
                  const typename Wave<A>::U& bounce, const MergeWeights<typename Wave<A>::F>& mw,
                  typename Wave<A>::M& alive, SubpathMis<typename Wave<A>::F>& mis,
                  Vec3<typename Wave<A>::F>& dir, Vec3<typename Wave<A>::F>& weight) {
    using F = typename Wave<A>::F;
    using I = typename Wave<A>::I;
    const FlatFeatures& f = s.features;
    const EstimatorSettings& est = s.path.estimator;
    F probability;
    const I lobe =
        choose_lobe(m, uniform<F>(rng, bounce, Purpose::kLobe), est.survival_cap, probability);
    alive = alive & mask_f32(lobe != I(kLobeAbsorbed));
    if constexpr (kMode == Transport::kRadiance)
        alive = alive & !camera_lobe_ends_path<F>(s.path, lobe);
    alive = may_extend<F>(est, bounce, alive);
    dir = weight = Vec3<F>(F(0.0f));
    const auto run = [&](auto kind) {
        constexpr int kLobe = decltype(kind)::value;
        const auto chosen = alive & mask_f32(lobe == I(kLobe));
        if (!any(chosen)) return;
        const Scatter<F> sc =
            continue_path<kLobe, kMode>(s.path, m, d, v, sf.n, sf.ns, probability, rng, bounce);
        dir = select(chosen, sc.dir, dir);
        weight = select(chosen, sc.weight, weight);
    };
    if (f.diffuse) run(std::integral_constant<int, kLobeDiffuse>{});
    if (f.specular) run(std::integral_constant<int, kLobeSpecular>{});
    if (f.mirror) run(std::integral_constant<int, kLobeMirror>{});
    if (f.refraction) run(std::integral_constant<int, kLobeRefract>{});
    if constexpr (kMis)
        if (any(alive)) mis_after_lobe(s.path, mis, lobe, pv, v, d, dir, mw);
}

// One batch of light-path vertices (rays `ray`, surfaces `sf`): for a light subpath, the
// MIS quantities at the hit and its Phong vertices stored; every Phong vertex's connection
// to the pinhole queued (t = 1); the roulette and the lobe in importance mode; survivors
// compacted to `kept`.
template <LightUse kUse, class A, class Read>
void light_subpath_batch(Wave<A>& w, int32_t i, const Ray<typename Wave<A>::F>& ray,
                         const Surfaces<A>& sf, const Read& evaluated, int32_t& kept,
                         int32_t& connections) {
    using F = typename Wave<A>::F;
    using U = typename Wave<A>::U;
    using I = typename Wave<A>::I;
    constexpr int32_t K = Wave<A>::K;
    constexpr bool kBidirectional = kUse == LightUse::kBidirectional;
    PathPool& p = w.pool;
    const FlatScene& s = w.scene;
    const PathContext& c = s.path;
    const EstimatorSettings& est = c.estimator;
    const I mat = sf.material;
    MergeWeights<F> mw{};
    if constexpr (kBidirectional) mw = lane_merge_weights(w, i);
    auto alive = sf.hit;
    // Emitters absorb what reaches them
    if (s.features.emitters)
        alive = alive & !mask_f32(lookup<A>(s.emitter, s.material_count, mat) != I(0));
    const Bsdf<F> m = hit_bsdf<kLobeCount, A>(s, mat, evaluated);
    const Vec3<F> beta = load3<F>(p.beta_r, p.beta_g, p.beta_b, i);
    const SampleStream<F> rng = stream_at<A>(s, p, i);
    const U bounce = U::load_aligned(p.bounce + i);
    const Vec3<F>& d = ray.d;
    const VertexFrame<F> v = vertex_frame(c.smooth, d, sf.n, sf.ns);

    // The subpath quantities at the hit (the first hit completes the start's)
    SubpathMis<F> mis{};
    PhongVertex<F> pv{};
    if constexpr (kBidirectional) {
        mis = load_mis<A>(p, i);
        const F t = length(sf.pos - ray.o);
        F direct(1.0f);
        const auto first = mask_f32(xsimd::bitwise_cast<I>(bounce) == I(1)) & alive;
        if (any(first)) {
            LightStart<F> st;
            // (only the lanes at their first hit: the others' start is stale)
            st.emitter = select(mask_i32(first), I::load_aligned(p.start_emitter + i), I(-1));
            st.on_surface = mask_f32(st.emitter >= I(0));
            st.cos_light = F::load_aligned(p.start_cos + i);
            direct = select(first, start_direct_pdf_area<F>(c, st, sf.pos, d, t), direct);
        }
        mis_at_hit(mis, t, abs(dot(d, v.nf)), direct);
        pv = phong_vertex(m, est.survival_cap);
    }

    // Phong vertices: stored (light subpaths), and seen from the pinhole (t = 1)
    const auto phong = mask_f32(lookup<A>(s.phong, s.material_count, mat) != I(0)) & alive;
    if (any(phong)) {
        const LightVertex<F> lv{sf.pos, v.nf, v.nsf, -d, beta, pv, mis, sf.magnitude, bounce};
        auto seen = phong;
        if constexpr (kBidirectional) {
            append_light_vertices<A>(*p.light_store, mask_bits(phong), lv,
                                     U::load_aligned(p.path_id + i));
            if (!connects(est.kind)) seen = decltype(phong)(false);
        }
        seen = length_counts<F>(est, bounce + U(1u), seen);
        const CameraConnection<F> cc = connect_camera(s.pinhole, sf.pos);
        seen = seen & on_arriving_side(cc.wc, v.nf);
        if (any(seen)) {
            Vec3<F> value = camera_contribution(m, beta, d, v.nf, v.nsf, cc, c.smooth);
            if constexpr (kBidirectional) value = value * camera_connection_mis(c, lv, cc, mw);
            queue_connections(w, seen, offset_ray_origin(sf.pos, v.nf, sf.magnitude), cc, value,
                              connections);
        }
    }

    // The roulette and the chosen lobe, in importance mode; survivors to the front of the
    // pool, in order (kept <= i: nothing unread is overwritten)
    Vec3<F> dir, weight;
    bdpt_scatter<Transport::kImportance, A, kBidirectional>(s, m, pv, v, sf, d, rng, bounce, mw,
                                                            alive, mis, dir, weight);
    const Vec3<F> beta1 = beta * weight;
    alive = alive & (max_component(beta1) > F(0.0f));
    const uint32_t bits = mask_bits(alive);
    const Vec3<F> o = leaving_origin(sf.pos, sf.n, dir, sf.magnitude);
    if constexpr (kBidirectional)
        move_paths<A, kRayFields | kBetaFields | kMisFields>(
            p, path_fields(s) | kMisFields | field_bit(kFieldPathId), i, bits, kept,
            {&o, &dir, &beta1, nullptr, nullptr, {&mis.vcm, &mis.vc, &mis.vm}});
    else
        move_paths<A, kRayFields | kBetaFields>(p, path_fields(s), i, bits, kept,
                                                {&o, &dir, &beta1});
    kept += std::popcount(bits);
    w.counters.extension += uint64_t(std::popcount(bits));
    w.counters.lanes_active += uint64_t(std::min(K, w.live - i));
    w.counters.lanes_total += uint64_t(K);
}

// Runs `vertex(i, ray, surfaces, read)` on every live batch of the wave (read(c): colour c
// as the material stage evaluated it), its closest hits first (with many rays in flight,
// grouped(): every live path's), through the material stage in textured scenes.
template <class A, class Vertex>
void each_vertex(Wave<A>& w, const Vertex& vertex) {
    using F = typename Wave<A>::F;
    using I = typename Wave<A>::I;
    constexpr int32_t K = Wave<A>::K;
    PathPool& p = w.pool;
    const bool textures = w.scene.features.textures;
    const bool group = grouped(w.scene);
    // Batch i's rays, their closest hits and surfaces
    const auto trace = [&](int32_t i, Ray<F>& ray) {
        ray = {load3<F>(p.ox, p.oy, p.oz, i), load3<F>(p.dx, p.dy, p.dz, i)};
        F t;
        I prim;
        batch_closest_hit(w, i, ray, t, prim, group);
        if (textures) prim.store_aligned(p.prim + i);  // (for the vertex colours)
        return resolve_surfaces(w, i, ray, t, prim);
    };
    const int32_t end = w.rounded_up(w.live);
    if (group) closest_hits_grouped(w);
    if (!textures) {
        for (int32_t i = 0; i < end; i += K) {
            Ray<F> ray;
            const Surfaces<A> sf = trace(i, ray);
            vertex(i, ray, sf, [](int) { return Vec3<F>(F(0.0f)); });
        }
        return;
    }
    // Textured: every hit first, then the material stage, then the vertices
    for (int32_t i = 0; i < end; i += K) {
        Ray<F> ray;
        store_surfaces(w, i, trace(i, ray));
    }
    evaluate_sorted_materials(w, p.material_starts);
    for (int32_t i = 0; i < end; i += K) {
        const Ray<F> ray{load3<F>(p.ox, p.oy, p.oz, i), load3<F>(p.dx, p.dy, p.dz, i)};
        vertex(i, ray, load_surfaces(w, i, ray),
               [&p, i](int ch) { return load3<F>(p.col[ch][0], p.col[ch][1], p.col[ch][2], i); });
    }
}

// The job's paths from the lights (one per key of its pixels and samples, from `cursor`),
// as a wave, to the end.
template <LightUse kUse, class A>
CIERZO_STAGE_LOOP void trace_light_subpaths(Wave<A>& w, const TileJob& job, TileCursor& cursor) {
    using F = typename Wave<A>::F;
    w.live = 0;
    int32_t connections = 0;
    for (;;) {
        generate_light_subpaths<kUse>(w, cursor, connections);
        trace_camera_connections<A>(w, job, connections);
        if (w.live == 0) break;
        int32_t kept = 0;
        each_vertex(w, [&](int32_t i, const Ray<F>& ray, const Surfaces<A>& sf, const auto& read) {
            light_subpath_batch<kUse>(w, i, ray, sf, read, kept, connections);
        });
        trace_camera_connections<A>(w, job, connections);
        w.live = kept;
    }
}

}  // namespace CIERZO_ISA_NAMESPACE
}  // namespace cierzo
