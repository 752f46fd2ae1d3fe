// Paths from the lights in the wavefront (light tracing, --estimator lt), through the same
// pool, intersection, surface and material stages as the camera's, with the kernels of
// kernels/transport.h:
//   regenerate: free slots take the tile's next (pixel, sample) keys, each a light path's
//     start (a light chosen by power, a point, a direction); an emitter's point is connected
//     to the pinhole at once;
//   intersect → surfaces (→ materials, textured scenes) → vertex: every Phong vertex queues
//     its connection to the pinhole, the roulette picks a lobe, the lobe is sampled in
//     importance mode, and the survivors move to the front of the pool;
//   camera connections: the queued shadow rays to the pinhole, traced in full batches; the
//     clear ones are splatted;
// until every light path of the batch has ended. Splats go to the film in batches (TileJob).
#pragma once

#include "integrators/wavefront/camera_stage.h"
#include "integrators/wavefront/compact_stage.h"
#include "integrators/wavefront/intersect_stage.h"
#include "integrators/wavefront/material_stage.h"
#include "integrators/wavefront/surface_stage.h"
#include "kernels/path_vertex.h"

namespace cierzo {
inline namespace CIERZO_ISA_NAMESPACE {

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

// Regeneration: the paths [w.live, ...) take the tile's next keys (as the camera's would)
// and become light paths: start sampled, the emitter's point connected, ray and throughput
// set; a start that cannot be sampled is dead at once (its throughput 0).
template <class A>
CIERZO_STAGE_LOOP void generate_light_paths(Wave<A>& w, TileCursor& cursor,
                                            int32_t& connections) {
    using F = typename Wave<A>::F;
    using U = typename Wave<A>::U;
    constexpr int32_t K = Wave<A>::K;
    PathPool& p = w.pool;
    const FlatScene& s = w.scene;
    const int32_t first = w.live;
    const uint64_t before = w.counters.camera;
    // (the camera's regeneration assigns pixels and keys; its rays are replaced below)
    generate_camera_paths<false>(w, cursor);
    w.counters.light += w.counters.camera - before;
    w.counters.camera = before;
    const int32_t end = w.live;
    for (int32_t i = first / K * K; i < end; i += K) {
        const F lane = Wave<A>::lane_index();
        const auto fresh = (lane >= F(float(first - i))) & (lane < F(float(end - i)));
        const SampleStream<F> rng = light_stream(stream_at<A>(s, p, i));
        const U key = rng.key;
        const LightStart<F> ls = sample_light_start<F>(s.path.emitters, s.light_starts, rng);
        // The emitter's point itself, seen by the pinhole
        const EstimatorSettings& est = s.path.estimator;
        const auto surface = !length_counts<float>(est, 1u)
                                 ? fresh & !fresh
                                 : fresh & ls.ok & ls.on_surface;
        if (any(surface)) {
            const CameraConnection<F> c = connect_camera(s.pinhole, ls.p);
            const F cos_l = dot(c.wc, ls.n);
            const Vec3<F> origin =
                offset_ray_origin(ls.p, select(cos_l > F(0.0f), ls.n, -ls.n), max_abs(ls.p));
            queue_connections(w, surface, origin, c, ls.le * (abs(cos_l) * c.factor),
                              connections);
        }
        const Vec3<F> o = select(ls.on_surface,
                                 offset_ray_origin(ls.p, select(dot(ls.dir, ls.n) > F(0.0f), ls.n, -ls.n),
                                                   max_abs(ls.p)),
                                 ls.p);
        const auto keep = [&](const F& v, float* a) {
            select(fresh, v, F::load_aligned(a + i)).store_aligned(a + i);
        };
        // (a path that may not go on past its start: throughput 0, so its first hit ends it)
        const bool extends = may_extend<float>(est, 0u);
        const auto starts = extends ? ls.ok : (ls.ok & !ls.ok);
        const Vec3<F> beta = select(starts, ls.beta, Vec3<F>(F(0.0f)));
        keep(o.x, p.ox), keep(o.y, p.oy), keep(o.z, p.oz);
        keep(ls.dir.x, p.dx), keep(ls.dir.y, p.dy), keep(ls.dir.z, p.dz);
        keep(beta.x, p.beta_r), keep(beta.y, p.beta_g), keep(beta.z, p.beta_b);
        select(mask_u32(fresh), key, U::load_aligned(p.key + i)).store_aligned(p.key + i);
        select(mask_u32(fresh), U(1u), U::load_aligned(p.bounce + i)).store_aligned(p.bounce + i);
    }
}

// One batch's light-path vertices (rays `ray`, surfaces `sf`): connection, roulette, lobe in
// importance mode; the survivors are compacted to the front of the pool at `kept`.
template <class A, class Read>
void light_vertex_batch(Wave<A>& w, int32_t i, const Ray<typename Wave<A>::F>& ray,
                        const Surfaces<A>& sf, const Read& evaluated, int32_t& kept,
                        int32_t& connections) {
    using F = typename Wave<A>::F;
    using U = typename Wave<A>::U;
    using I = typename Wave<A>::I;
    constexpr int32_t K = Wave<A>::K;
    PathPool& p = w.pool;
    const FlatScene& s = w.scene;
    const FlatFeatures& f = s.features;
    const I mat = sf.material;
    auto alive = sf.hit;
    // Emitters absorb what reaches them
    if (f.emitters) alive = alive & !mask_f32(lookup<A>(s.emitter, s.material_count, mat) != I(0));
    const Bsdf<F> m = hit_bsdf<kLobeCount, A>(s, mat, evaluated);
    const Vec3<F> beta = load3<F>(p.beta_r, p.beta_g, p.beta_b, i);
    const SampleStream<F> rng = stream_at<A>(s, p, i);
    const U bounce = U::load_aligned(p.bounce + i);
    const Vec3<F>& d = ray.d;
    const VertexFrame<F> v = vertex_frame(s.path.smooth, d, sf.n, sf.ns);

    // Every Phong vertex is seen from the pinhole
    const EstimatorSettings& est = s.path.estimator;
    auto phong = mask_f32(lookup<A>(s.phong, s.material_count, mat) != I(0)) & alive;
    phong = length_counts<F>(est, bounce + U(1u), phong);
    if (any(phong)) {
        const CameraConnection<F> c = connect_camera(s.pinhole, sf.pos);
        queue_connections(w, phong & on_arriving_side(c.wc, v.nf),
                          offset_ray_origin(sf.pos, v.nf, sf.magnitude), c,
                          camera_contribution(m, beta, d, v.nf, v.nsf, c, s.path.smooth),
                          connections);
    }

    // The roulette and the chosen lobe, in importance mode (each lobe some lane chose)
    F probability;
    const I lobe = choose_lobe(m, uniform<F>(rng, bounce, Purpose::kLobe),
                               s.path.estimator.survival_cap, probability);
    alive = alive & mask_f32(lobe != I(kLobeAbsorbed));
    alive = may_extend<F>(est, bounce, alive);
    Vec3<F> dir(F(0.0f)), weight(F(0.0f));
    const auto run = [&](auto kind) {
        constexpr int kLobe = decltype(kind)::value;
        const auto chosen = alive & mask_f32(lobe == I(kLobe));
        if (!any(chosen)) return;
        const Scatter<F> sc = continue_path<kLobe, Transport::kImportance>(
            s.path, m, d, v, sf.n, sf.ns, probability, rng, bounce);
        dir = select(chosen, sc.dir, dir);
        weight = select(chosen, sc.weight, weight);
    };
    if (f.diffuse) run(std::integral_constant<int, kLobeDiffuse>{});
    if (f.specular) run(std::integral_constant<int, kLobeSpecular>{});
    if (f.mirror) run(std::integral_constant<int, kLobeMirror>{});
    if (f.refraction) run(std::integral_constant<int, kLobeRefract>{});
    const Vec3<F> beta1 = beta * weight;
    alive = alive & (max_component(beta1) > F(0.0f));
    const Vec3<F> o = leaving_origin(sf.pos, sf.n, dir, sf.magnitude);
    // Survivors to the front of the pool, in order (kept <= i: nothing unread is overwritten)
    const uint32_t bits = mask_bits(alive);
    move_paths<A>(p, path_fields(s), i, bits, kept, {&o, &dir, &beta1});
    kept += std::popcount(bits);
    w.counters.extension += uint64_t(std::popcount(bits));
    w.counters.lanes_active += uint64_t(std::min(K, w.live - i));
    w.counters.lanes_total += uint64_t(K);
}

// The light paths of one batch (one per key of the job's pixels and samples), to the end.
template <class A>
CIERZO_STAGE_LOOP void render_light_paths(Wave<A>& w, const TileJob& job) {
    using F = typename Wave<A>::F;
    using I = typename Wave<A>::I;
    constexpr int32_t K = Wave<A>::K;
    PathPool& p = w.pool;
    const bool textures = w.scene.features.textures;
    TileCursor cursor = tile_cursor(job);
    w.live = 0;
    // Batch i's rays, their closest hits (with many rays in flight, grouped(): every live
    // path's first) and surfaces
    const bool group = grouped(w.scene);
    const auto trace = [&](int32_t i, Ray<F>& ray) {
        ray = {load3<F>(p.ox, p.oy, p.oz, i), load3<F>(p.dx, p.dy, p.dz, i)};
        F t;
        I prim;
        batch_closest_hit(w, i, ray, t, prim, group);
        if (textures) prim.store_aligned(p.prim + i);  // (for the vertex colours)
        return resolve_surfaces(w, i, ray, t, prim);
    };
    int32_t connections = 0;
    for (;;) {
        generate_light_paths(w, cursor, connections);
        trace_camera_connections<A>(w, job, connections);
        if (w.live == 0) break;
        int32_t kept = 0;
        const int32_t end = w.rounded_up(w.live);
        if (group) closest_hits_grouped(w);
        if (!textures) {
            for (int32_t i = 0; i < end; i += K) {
                Ray<F> ray;
                const Surfaces<A> sf = trace(i, ray);
                light_vertex_batch(w, i, ray, sf, [](int) { return Vec3<F>(F(0.0f)); }, kept,
                                   connections);
            }
        } else {
            // Textured: every hit first, then the material stage, then the vertices
            for (int32_t i = 0; i < end; i += K) {
                Ray<F> ray;
                store_surfaces(w, i, trace(i, ray));
            }
            evaluate_sorted_materials(w, p.material_starts);
            for (int32_t i = 0; i < end; i += K) {
                const Ray<F> ray{load3<F>(p.ox, p.oy, p.oz, i), load3<F>(p.dx, p.dy, p.dz, i)};
                light_vertex_batch(
                    w, i, ray, load_surfaces(w, i, ray),
                    [&](int c) { return load3<F>(p.col[c][0], p.col[c][1], p.col[c][2], i); },
                    kept, connections);
            }
        }
        trace_camera_connections<A>(w, job, connections);
        w.live = kept;
    }
}

}  // namespace CIERZO_ISA_NAMESPACE
}  // namespace cierzo
