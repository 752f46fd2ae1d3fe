// Bidirectional path tracing in the wavefront (--estimator bdpt), with the rules of
// kernels/bidirectional.h. A job (a tile's pixels × a pass's samples) runs in two waves
// through the same pool, intersection, surface and material stages as the camera's:
//   1. light subpaths, one per camera sample of the job (the sample's key, as lt's): at each
//      Phong vertex the vertex is appended to the thread's light-vertex store (SoA) and its
//      connection to the pinhole is queued (t = 1); the roulette and the lobes in importance
//      mode; survivors compacted. The camera connections are traced in full batches and the
//      clear ones splatted.
//   2. the store is grouped by path (a counting sort of indices), then camera subpaths: at
//      each hit s = 0 (emitter or environment) is weighed at once; a Phong vertex queues its
//      light samples (s = 1) and one connection per vertex of its own light subpath (s, t ≥ 2,
//      lane k of the batch gathering its path's k-th vertex), all as shadow rays whose queue
//      is traced whenever it fills and after the pass; vcm: each Phong vertex merges with
//      the stored vertices near it of its sample index (the job's grid, lane by lane); then
//      the roulette, the lobes, and compaction, where ended paths hand their radiance to the
//      film.
#pragma once

#include "integrators/merge_vertex.h"
#include "integrators/wavefront/light_stage.h"
#include "integrators/wavefront/shadow_stage.h"
#include "kernels/bidirectional.h"

namespace cierzo {
inline namespace CIERZO_ISA_NAMESPACE {

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

// Each lane's sample offset in the job (paths are numbered sample by sample: path k is
// sample k / paths_per_sample), clamped to the job's samples (lanes past the live ones hold
// any index).
template <class A>
typename Wave<A>::I sample_offsets(const PathPool& p, int32_t i, const MergeTable& t) {
    constexpr int32_t K = Wave<A>::K;
    alignas(64) int32_t j[K];
    const uint32_t last = uint32_t(t.samples) - 1u;
    for (int32_t l = 0; l < K; ++l)
        j[l] = int32_t(std::min(p.path_id[i + l] / uint32_t(t.paths_per_sample), last));
    return Wave<A>::I::load_aligned(j);
}

// The merging quantities of each lane's sample (vcm; bdpt: all 0).
template <class A>
MergeWeights<typename Wave<A>::F> lane_merge_weights(const Wave<A>& w, int32_t i) {
    if (!merges(w.scene.path.estimator.kind)) return {};
    const MergeTable& t = *w.pool.light_store->merging;
    const typename Wave<A>::I j = sample_offsets<A>(w.pool, i, t);
    return {gather_lanes<A>(t.vm_weight, j), gather_lanes<A>(t.vc_weight, j),
            gather_lanes<A>(t.normalization, j), gather_lanes<A>(t.radius2, j)};
}

// vcm: the lanes in `want` (Phong camera vertices cv of batch i, throughput beta, their
// samples' merging quantities mw) merged with the stored vertices of their sample within
// its radius, found through the job's grid lane by lane (merge_at); what they add goes to
// the lanes' radiance in the pool.
template <class A>
void merge_lanes(Wave<A>& w, int32_t i, const CameraVertex<typename Wave<A>::F>& cv,
                 const Vec3<typename Wave<A>::F>& beta,
                 const MergeWeights<typename Wave<A>::F>& mw, const typename Wave<A>::M& want) {
    using F = typename Wave<A>::F;
    constexpr int32_t K = Wave<A>::K;
    PathPool& p = w.pool;
    const FlatScene& s = w.scene;
    const LightVertexStore& st = *p.light_store;
    uint32_t bits = mask_bits(want);
    if (!bits) return;
    constexpr int kFields = 31;
    const F* src[kFields] = {&cv.p.x,      &cv.p.y,      &cv.p.z,      &cv.nf.x,     &cv.nf.y,
                             &cv.nf.z,     &cv.nsf.x,    &cv.nsf.y,    &cv.nsf.z,    &cv.wo.x,
                             &cv.wo.y,     &cv.wo.z,     &cv.phong.kd.x, &cv.phong.kd.y,
                             &cv.phong.kd.z, &cv.phong.ks.x, &cv.phong.ks.y, &cv.phong.ks.z,
                             &cv.phong.shininess, &cv.phong.p_diffuse, &cv.phong.p_specular,
                             &cv.mis.vcm,  &cv.mis.vc,   &cv.mis.vm,   &beta.x,      &beta.y,
                             &beta.z,      &mw.vm_weight, &mw.vc_weight, &mw.normalization,
                             &mw.radius2};
    alignas(64) float lanes[kFields][K];
    for (int k = 0; k < kFields; ++k) src[k]->store_aligned(lanes[k]);
    alignas(64) uint32_t vertices[K];
    cv.vertices.store_aligned(vertices);
    alignas(64) int32_t sample[K];
    sample_offsets<A>(p, i, *st.merging).store_aligned(sample);
    while (bits) {
        const int l = std::countr_zero(bits);
        bits &= bits - 1u;
        const auto at = [&](int k) { return lanes[k][l]; };
        CameraVertex<float> v;
        v.p = {at(0), at(1), at(2)};
        v.nf = {at(3), at(4), at(5)};
        v.nsf = {at(6), at(7), at(8)};
        v.wo = {at(9), at(10), at(11)};
        v.phong = {{at(12), at(13), at(14)}, {at(15), at(16), at(17)}, at(18), at(19), at(20)};
        v.mis = {at(21), at(22), at(23)};
        v.vertices = vertices[l];
        const Vec3f sum =
            merge_at(s.path, *st.grid, v, uint32_t(sample[l]), {at(27), at(28), at(29), at(30)});
        p.rad_r[i + l] += at(24) * sum.x;
        p.rad_g[i + l] += at(25) * sum.y;
        p.rad_b[i + l] += at(26) * sum.z;
    }
}

// The job's grid (vcm): its stored vertices as photons of their sample's set.
inline void build_merge_grid(LightVertexStore& st) {
    MergeTable& t = *st.merging;
    const uint32_t per = uint32_t(t.paths_per_sample);
    t.reserve_photons(size_t(st.count));
    const auto f = [&](int k, int32_t v) { return st.record(v)[k]; };
    for (int32_t v = 0; v < st.count; ++v) {
        Photon& p = t.photons[size_t(v)];
        p.p[0] = f(kLvPx, v), p.p[1] = f(kLvPy, v), p.p[2] = f(kLvPz, v);
        p.wl[0] = f(kLvWx, v), p.wl[1] = f(kLvWy, v), p.wl[2] = f(kLvWz, v);
        p.beta[0] = f(kLvBr, v), p.beta[1] = f(kLvBg, v), p.beta[2] = f(kLvBb, v);
        p.vcm = f(kLvVcm, v), p.vm = f(kLvVm, v);
        p.length = st.length[v], p.set = st.path[v] / per;
    }
    st.grid->build(t.photons, size_t(st.count), t.radius, size_t(t.samples));
}

// The job's merging quantities per sample (vcm), before its light subpaths.
inline void merging_table(MergeTable& t, const PathContext& c, const TileJob& job,
                          bool has_lights) {
    const int32_t pixels = (job.x1 - job.x0) * (job.y1 - job.y0);
    t.paths_per_sample = pixels;
    t.resize(size_t(job.sample_end - job.sample_begin));
    for (size_t j = 0; j < size_t(t.samples); ++j) {
        const MergeWeights<float> m =
            merge_weights(c.estimator.merge_radius, c.estimator.merge_alpha,
                          job.sample_begin + int64_t(j), has_lights ? pixels : 0,
                          kMergeTilePaths, connects(c.estimator.kind), c.connection_count);
        t.vm_weight[j] = m.vm_weight, t.vc_weight[j] = m.vc_weight;
        t.normalization[j] = m.normalization, t.radius2[j] = m.radius2;
        t.radius[j] = std::sqrt(m.radius2);
    }
}

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

// Appends the lanes in `bits` of vertex l (of paths `path`) to the store.
template <class A>
void append_light_vertices(LightVertexStore& st, uint32_t bits,
                           const LightVertex<typename Wave<A>::F>& l,
                           const typename Wave<A>::U& path) {
    using F = typename Wave<A>::F;
    constexpr int32_t K = Wave<A>::K;
    if (!bits) return;
    if (st.count + K > st.capacity) st.grow(st, st.count + K);
    const F* v[kLightVertexFloats] = {
        &l.p.x,         &l.p.y,         &l.p.z,         &l.nf.x,           &l.nf.y,
        &l.nf.z,        &l.nsf.x,       &l.nsf.y,       &l.nsf.z,          &l.wl.x,
        &l.wl.y,        &l.wl.z,        &l.beta.x,      &l.beta.y,         &l.beta.z,
        &l.phong.kd.x,  &l.phong.kd.y,  &l.phong.kd.z,  &l.phong.ks.x,     &l.phong.ks.y,
        &l.phong.ks.z,  &l.phong.shininess, &l.phong.p_diffuse, &l.phong.p_specular,
        &l.mis.vcm,     &l.mis.vc,      &l.mis.vm,      &l.magnitude};
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

// Regeneration of light subpaths: the paths [w.live, ...) take the job's next keys and
// become light paths (start, ray, throughput, MIS quantities).
template <class A>
CIERZO_STAGE_LOOP void generate_light_subpaths(Wave<A>& w, TileCursor& cursor) {
    using F = typename Wave<A>::F;
    using U = typename Wave<A>::U;
    using I = typename Wave<A>::I;
    constexpr int32_t K = Wave<A>::K;
    PathPool& p = w.pool;
    const FlatScene& s = w.scene;
    const int32_t first = w.live;
    const uint32_t seq0 = uint32_t(cursor.next);
    const uint64_t before = w.counters.camera;
    generate_camera_paths<false>(w, cursor);
    w.counters.light += w.counters.camera - before;
    w.counters.camera = before;
    number_paths(w, first, seq0);
    const int32_t end = w.live;
    const EstimatorSettings& est = s.path.estimator;
    const bool extends = may_extend<float>(est, 0u);
    for (int32_t i = first / K * K; i < end; i += K) {
        const F lane = Wave<A>::lane_index();
        const auto fresh = (lane >= F(float(first - i))) & (lane < F(float(end - i)));
        const SampleStream<F> rng = light_stream(stream_at<A>(s, p, i));
        const LightStart<F> ls = sample_light_start<F>(s.path.emitters, s.light_starts, rng);
        const Vec3<F> o = select(
            ls.on_surface,
            offset_ray_origin(ls.p, select(dot(ls.dir, ls.n) > F(0.0f), ls.n, -ls.n), max_abs(ls.p)),
            ls.p);
        const auto starts = extends ? ls.ok : (ls.ok & !ls.ok);
        const Vec3<F> beta = select(starts, ls.beta, Vec3<F>(F(0.0f)));
        const SubpathMis<F> mis = light_start_mis(s.path, ls, lane_merge_weights(w, i));
        const auto keep = [&](const F& v, float* a) {
            select(fresh, v, F::load_aligned(a + i)).store_aligned(a + i);
        };
        keep(o.x, p.ox), keep(o.y, p.oy), keep(o.z, p.oz);
        keep(ls.dir.x, p.dx), keep(ls.dir.y, p.dy), keep(ls.dir.z, p.dz);
        keep(beta.x, p.beta_r), keep(beta.y, p.beta_g), keep(beta.z, p.beta_b);
        keep(mis.vcm, p.mis_vcm), keep(mis.vc, p.mis_vc), keep(mis.vm, p.mis_vm);
        keep(ls.cos_light, p.start_cos);
        select(mask_i32(fresh), ls.emitter, I::load_aligned(p.start_emitter + i))
            .store_aligned(p.start_emitter + i);
        select(mask_u32(fresh), rng.key, U::load_aligned(p.key + i)).store_aligned(p.key + i);
        select(mask_u32(fresh), U(1u), U::load_aligned(p.bounce + i)).store_aligned(p.bounce + i);
    }
}

// The roulette and the chosen lobe of each lane (kMode: radiance for camera subpaths,
// importance for light subpaths), and the subpath quantities after it: the new direction
// and throughput factor; `alive` loses the lanes whose path ends.
template <Transport kMode, class A>
void bdpt_scatter(const FlatScene& s, const Bsdf<typename Wave<A>::F>& m,
                  const PhongVertex<typename Wave<A>::F>& pv,
                  const VertexFrame<typename Wave<A>::F>& v, const Surfaces<A>& sf,
                  const Vec3<typename Wave<A>::F>& d,
                  const SampleStream<typename Wave<A>::F>& rng, const typename Wave<A>::U& bounce,
                  const MergeWeights<typename Wave<A>::F>& mw, typename Wave<A>::M& alive,
                  SubpathMis<typename Wave<A>::F>& mis, Vec3<typename Wave<A>::F>& dir,
                  Vec3<typename Wave<A>::F>& weight) {
    using F = typename Wave<A>::F;
    using I = typename Wave<A>::I;
    const FlatFeatures& f = s.features;
    const EstimatorSettings& est = s.path.estimator;
    F probability;
    const I lobe = choose_lobe(m, uniform<F>(rng, bounce, Purpose::kLobe), est.survival_cap,
                               probability);
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
    if (any(alive)) mis_after_lobe(s.path, mis, lobe, pv, v, d, dir, mw);
}

// One batch of light-subpath vertices: MIS at the hit, the Phong vertices stored and
// connected to the pinhole, the roulette and lobe; survivors compacted to `kept`.
template <class A, class Read>
void light_subpath_batch(Wave<A>& w, int32_t i, const Ray<typename Wave<A>::F>& ray,
                         const Surfaces<A>& sf, const Read& evaluated, int32_t& kept,
                         int32_t& connections) {
    using F = typename Wave<A>::F;
    using U = typename Wave<A>::U;
    using I = typename Wave<A>::I;
    constexpr int32_t K = Wave<A>::K;
    PathPool& p = w.pool;
    const FlatScene& s = w.scene;
    const PathContext& c = s.path;
    const EstimatorSettings& est = c.estimator;
    const I mat = sf.material;
    const MergeWeights<F> mw = lane_merge_weights(w, i);
    auto alive = sf.hit;
    if (s.features.emitters)
        alive = alive & !mask_f32(lookup<A>(s.emitter, s.material_count, mat) != I(0));
    const Bsdf<F> m = hit_bsdf<kLobeCount, A>(s, mat, evaluated);
    const Vec3<F> beta = load3<F>(p.beta_r, p.beta_g, p.beta_b, i);
    const SampleStream<F> rng = stream_at<A>(s, p, i);
    const U bounce = U::load_aligned(p.bounce + i);
    const Vec3<F>& d = ray.d;
    const VertexFrame<F> v = vertex_frame(c.smooth, d, sf.n, sf.ns);

    // The subpath quantities at the hit (the first hit completes the start's)
    SubpathMis<F> mis = load_mis<A>(p, i);
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
    const PhongVertex<F> pv = phong_vertex(m, est.survival_cap);

    // Phong vertices: stored, and seen from the pinhole (t = 1)
    const auto phong = mask_f32(lookup<A>(s.phong, s.material_count, mat) != I(0)) & alive;
    if (any(phong)) {
        const LightVertex<F> lv{sf.pos, v.nf, v.nsf, -d, beta, pv, mis, sf.magnitude, bounce};
        append_light_vertices<A>(*p.light_store, mask_bits(phong), lv,
                                 U::load_aligned(p.path_id + i));
        auto seen = connects(est.kind) ? phong : decltype(phong)(false);
        seen = length_counts<F>(est, bounce + U(1u), seen);
        const CameraConnection<F> cc = connect_camera(s.pinhole, sf.pos);
        seen = seen & on_arriving_side(cc.wc, v.nf);
        if (any(seen)) {
            const Vec3<F> value = camera_contribution(m, beta, d, v.nf, v.nsf, cc, c.smooth) *
                                  camera_connection_mis(c, lv, cc, mw);
            queue_connections(w, seen, offset_ray_origin(sf.pos, v.nf, sf.magnitude), cc, value,
                              connections);
        }
    }

    Vec3<F> dir, weight;
    bdpt_scatter<Transport::kImportance, A>(s, m, pv, v, sf, d, rng, bounce, mw, alive, mis,
                                            dir, weight);
    const Vec3<F> beta1 = beta * weight;
    alive = alive & (max_component(beta1) > F(0.0f));
    const uint32_t bits = mask_bits(alive);
    const Vec3<F> o = leaving_origin(sf.pos, sf.n, dir, sf.magnitude);
    move_paths<A>(p, path_fields(s) | kMisFields | field_bit(kFieldPathId), i, bits, kept,
                  {&o, &dir, &beta1, nullptr, nullptr, {&mis.vcm, &mis.vc, &mis.vm}});
    kept += std::popcount(bits);
    w.counters.extension += uint64_t(std::popcount(bits));
    w.counters.lanes_active += uint64_t(std::min(K, w.live - i));
    w.counters.lanes_total += uint64_t(K);
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
void draw_connections(Wave<A>& w, int32_t i, const CameraVertex<typename Wave<A>::F>& cv,
                      const Vec3<typename Wave<A>::F>& beta,
                      const MergeWeights<typename Wave<A>::F>& mw, const typename Wave<A>::M& phong,
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
            const Vec3<F> le = hit_color<A>(s, kColEmission, mat, evaluated) *
                               emitter_hit_mis<F>(c, lights, mis, select(mask_i32(em), sf.emitter, I(-1)),
                                                  ray.o, d, t, cos_in, bounce + U(2u));
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
        const CameraVertex<F> cv{sf.pos, v.nf, v.nsf, -d, shadow_origin(v, sf.pos, sf.magnitude),
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
            const I id = select(mask_i32(phong), xsimd::bitwise_cast<I>(U::load_aligned(p.path_id + i)), I(0));
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
        if (merges(est.kind)) merge_lanes<A>(w, i, cv, beta, mw, phong & camera_vertex_merges<F>(est, cv));
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

// The light-store's vertices grouped by path: begin[k]..begin[k + 1] of `order` are path
// k's, in the order they were stored (a counting sort; a path's vertices were stored in
// the order of its bounces).
inline void group_light_vertices(LightVertexStore& st, int32_t paths) {
    for (int32_t k = 0; k <= paths; ++k) st.begin[k] = 0;
    for (int32_t v = 0; v < st.count; ++v) ++st.begin[st.path[v] + 1];
    for (int32_t k = 0; k < paths; ++k) st.begin[k + 1] += st.begin[k];
    // (begin[k] is advanced past each vertex placed, then restored)
    for (int32_t v = 0; v < st.count; ++v) st.order[st.begin[st.path[v]]++] = v;
    for (int32_t k = paths; k > 0; --k) st.begin[k] = st.begin[k - 1];
    st.begin[0] = 0;
}

// The whole job: its light subpaths, then its camera subpaths.
template <class A>
CIERZO_STAGE_LOOP void render_bdpt_tile(Wave<A>& w, const TileJob& job) {
    using F = typename Wave<A>::F;
    using I = typename Wave<A>::I;
    constexpr int32_t K = Wave<A>::K;
    PathPool& p = w.pool;
    const FlatScene& s = w.scene;
    const bool textures = s.features.textures;
    const bool merging = merges(s.path.estimator.kind);
    const bool has_lights =
        s.light_starts.emitter_probability > 0.0f || s.light_starts.point_count > 0;
    LightVertexStore& st = *p.light_store;
    st.count = 0;
    st.paths_per_sample = (job.x1 - job.x0) * (job.y1 - job.y0);
    st.samples = int32_t(job.sample_end - job.sample_begin);
    if (merging) merging_table(*st.merging, s.path, job, has_lights);
    // Batch i's rays, their closest hits (with many rays in flight, grouped(): every live
    // path's first) and surfaces
    const bool group = grouped(s);
    const auto trace = [&](int32_t i, Ray<F>& ray) {
        ray = {load3<F>(p.ox, p.oy, p.oz, i), load3<F>(p.dx, p.dy, p.dz, i)};
        F t;
        I prim;
        batch_closest_hit(w, i, ray, t, prim, group);
        if (textures) prim.store_aligned(p.prim + i);  // (for the vertex colours)
        return resolve_surfaces(w, i, ray, t, prim);
    };
    const auto colours = [&](int32_t i) {
        return [&p, i](int ch) { return load3<F>(p.col[ch][0], p.col[ch][1], p.col[ch][2], i); };
    };
    const auto solid = [](int) { return Vec3<F>(F(0.0f)); };
    // Runs `vertex(i, ray, surfaces, read)` on every live batch, through the material stage
    // in textured scenes
    const auto each_vertex = [&](const auto& vertex) {
        const int32_t end = w.rounded_up(w.live);
        if (group) closest_hits_grouped(w);
        if (!textures) {
            for (int32_t i = 0; i < end; i += K) {
                Ray<F> ray;
                const Surfaces<A> sf = trace(i, ray);
                vertex(i, ray, sf, solid);
            }
            return;
        }
        for (int32_t i = 0; i < end; i += K) {
            Ray<F> ray;
            store_surfaces(w, i, trace(i, ray));
        }
        evaluate_sorted_materials(w, p.material_starts);
        for (int32_t i = 0; i < end; i += K) {
            const Ray<F> ray{load3<F>(p.ox, p.oy, p.oz, i), load3<F>(p.dx, p.dy, p.dz, i)};
            vertex(i, ray, load_surfaces(w, i, ray), colours(i));
        }
    };

    // 1. The light subpaths
    TileCursor cursor = tile_cursor(job);
    if (has_lights) {
        w.live = 0;
        int32_t connections = 0;
        for (;;) {
            generate_light_subpaths(w, cursor);
            if (w.live == 0) break;
            int32_t kept = 0;
            each_vertex([&](int32_t i, const Ray<F>& ray, const Surfaces<A>& sf, const auto& read) {
                light_subpath_batch(w, i, ray, sf, read, kept, connections);
            });
            trace_camera_connections<A>(w, job, connections);
            w.live = kept;
        }
    }
    group_light_vertices(st, int32_t(cursor.total));
    if (merging) build_merge_grid(st);

    // 2. The camera subpaths
    cursor = tile_cursor(job);
    w.live = 0;
    for (;;) {
        const int32_t first = w.live;
        const uint32_t seq0 = uint32_t(cursor.next);
        generate_camera_paths<true>(w, cursor);
        if (w.live == 0) break;
        number_paths(w, first, seq0);
        for (int32_t i = first / K * K; i < w.live; i += K) {
            const F lane = Wave<A>::lane_index();
            const auto fresh = (lane >= F(float(first - i))) & (lane < F(float(w.live - i)));
            const SubpathMis<F> mis =
                camera_start_mis(s.path, s.pinhole, load3<F>(p.dx, p.dy, p.dz, i));
            select(fresh, mis.vcm, F::load_aligned(p.mis_vcm + i)).store_aligned(p.mis_vcm + i);
            select(fresh, mis.vc, F::load_aligned(p.mis_vc + i)).store_aligned(p.mis_vc + i);
            select(fresh, mis.vm, F::load_aligned(p.mis_vm + i)).store_aligned(p.mis_vm + i);
        }
        int32_t queued = 0;
        each_vertex([&](int32_t i, const Ray<F>& ray, const Surfaces<A>& sf, const auto& read) {
            camera_subpath_batch(w, i, ray, sf, read, queued);
        });
        p.shadow_count = queued;
        trace_shadow_rays(w);
        w.counters.shadow += uint64_t(queued);
        compact_paths(w, job,
                      path_fields(s) | kRadianceFields | kMisFields | field_bit(kFieldPixel) |
                          field_bit(kFieldPathId));
    }
}

}  // namespace CIERZO_ISA_NAMESPACE
}  // namespace cierzo
