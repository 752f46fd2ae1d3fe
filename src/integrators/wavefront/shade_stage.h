// Wavefront stage 5, shading, with the estimator of kernels/estimator.h: emitters end their
// paths; Phong vertices queue one shadow ray per point light and, with nee or mis, one
// emitter sample; the roulette picks each path's lobe. A scene with one lobe kind runs that lobe on
// the same batch in registers; otherwise hits are bucketed by lobe and each lobe's kernel runs on
// full batches of its own lanes (gathered by index).
#pragma once

#include "integrators/wavefront/compact_stage.h"
#include "integrators/wavefront/guide_stage.h"
#include "integrators/wavefront/intersect_stage.h"
#include "integrators/wavefront/material_stage.h"
#include "integrators/wavefront/surface_stage.h"
#include "kernels/path_vertex.h"

namespace cierzo {
inline namespace CIERZO_ISA_NAMESPACE {

template <class A>
Vec3<xsimd::batch<float, A>> gather3(const float* x, const float* y, const float* z,
                                     const xsimd::batch<int32_t, A>& j) {
    return {gather_lanes<A>(x, j), gather_lanes<A>(y, j), gather_lanes<A>(z, j)};
}

// One lobe's continuation for K paths: new direction, throughput and origin.
template <int kLobe, class A>
struct LobeStep {
    using F = typename Wave<A>::F;
    using U = typename Wave<A>::U;
    Vec3<F> o, d, beta;
    F pdf = F(
        0.0f);  // nee/mis: the density the lobe sampled d with, P(lobe) included (0: a delta lobe)
    typename Wave<A>::M alive;
    // A guided render's vertices that record (guide_stage.h): what their records need
    RecordDensities<F> record;
    Vec3<F> nsf;

    // magnitude: max(max_abs(pos), max_abs(ray origin)), for the origin's offset; n the
    // geometric normal, ns the shading normal (= n without smooth meshes)
    // c: the scene's path context, or a copy whose switches the caller knows at compile time
    // guide: a guided render's (guide_stage.h): the diffuse lobe draws from it where it is
    // active, and the served vertices' records are measured (`learn`)
    LobeStep(const PathContext& c, const Bsdf<F>& m, const F& magnitude, const Vec3<F>& d0,
             const Vec3<F>& pos, const Vec3<F>& n, const Vec3<F>& ns, const Vec3<F>& beta0,
             const F& probability, const SampleStream<F>& rng, const F& u_roulette, const U& bounce,
             const GuideLanes<A>* guide = nullptr, bool learn = false) {
        const VertexFrame<F> v = vertex_frame(c.smooth, d0, n, ns);
        Scatter<F> sc = continue_path<kLobe>(c, m, d0, v, n, ns, probability, rng, bounce);
        continuation_pdf<kLobe>(c, m, d0, v, sc.dir, probability, pdf);
        nsf = v.nsf;
        if constexpr (kLobe == kLobeDiffuse || kLobe == kLobeSpecular)
            if (guide) guided(c, m, d0, v, probability, rng, bounce, *guide, learn, sc);
        beta = throughput_roulette(c.estimator, beta0 * sc.weight, u_roulette, bounce);
        alive = max_component(beta) > F(0.0f);
        o = leaving_origin(pos, n, sc.dir, magnitude);
        d = sc.dir;
    }

    // The guide's part (the scalar loop's rules, integrators/scalar.cpp), for the diffuse and
    // specular lobes: the diffuse lobe's lanes where the guide is active take the guided
    // continuation instead (the Phong specular lobe is not guided); the served vertices'
    // records take their densities (record_densities).
    void guided(const PathContext& c, const Bsdf<F>& m, const Vec3<F>& d0, const VertexFrame<F>& v,
                const F& probability, const SampleStream<F>& rng, const U& bounce,
                const GuideLanes<A>& guide, bool learn, Scatter<F>& sc) {
        static_assert(kLobe == kLobeDiffuse || kLobe == kLobeSpecular);
        GuidedScatter<F> g{};
        Mask<F> on(false);
        if constexpr (kLobe == kLobeDiffuse) {
            on = guide.at.active();
            if (any(on)) {
                g = continue_guided_diffuse<F>(c, m, v, probability, guide.at, rng, bounce);
                sc.dir = select(on, g.sc.dir, sc.dir);
                sc.weight = select(on, g.sc.weight, sc.weight);
                if (c.nee) pdf = select(on, g.pdf, pdf);
            }
        }
        if (learn)
            record = record_densities<kLobe>(c, m, d0, v.nsf, sc.dir, guide.at, guide.served, on, g,
                                             probability);
        (void)rng, (void)bounce;
    }
};

// Where a shaded batch goes when it is compacted at once (see shade_batch): survivors to
// [0, kept) of the pool, ended paths with radiance to [0, done) of the film's queue.
struct Compaction {
    int32_t kept = 0, done = 0;
};

// Emission, shadow rays and the roulette for batch `i` (rays `ray`, their surfaces `sf`).
// kFused is the scene's only lobe, whose continuation then runs here on the same registers;
// or kLobeCount: the roulette's choice is stored for the lobe buckets (sample_lobes).
// kCompact (one lobe, no point lights, no textures: no later stage reads the batch, and a
// path's radiance is only the emission that ends it) retires and compacts the batch here:
// emitter hits go to the film's queue, survivors move down to `compaction->kept` with
// bounce + 1, and no radiance is carried in the pool.
// kInlineNee (with kCompact; nee or mis): the emitter sample's shadow ray is traced here, on
// the batch's registers, so a one-lobe scene without point lights keeps this single pass;
// radiance is then carried, and every path that ends goes to the film's queue.
template <int kFused, bool kCompact = false, bool kInlineNee = false, class A>
void shade_batch(Wave<A>& w, int32_t i, const Ray<typename Wave<A>::F>& ray, const Surfaces<A>& sf,
                 int32_t& queued, Compaction* compaction = nullptr) {
    static_assert(!kCompact || kFused != kLobeCount, "compaction in shading needs one lobe");
    static_assert(!kInlineNee || kCompact, "inline shadow rays are for the compacting pass");
    constexpr bool kCarried = !kCompact || kInlineNee;  // radiance is kept in the pool
    using F = typename Wave<A>::F;
    using U = typename Wave<A>::U;
    using I = typename Wave<A>::I;
    constexpr int32_t K = Wave<A>::K;
    PathPool& p = w.pool;
    const FlatScene& s = w.scene;
    const FlatFeatures& f = s.features;
    // The path context, with the switches this instantiation knows at compile time (the
    // compacting kernels are chosen for scenes without point lights: without emitter samples,
    // or with them traced inline)
    PathContext c = s.path;
    if constexpr (kCompact) c.light_count = 0;
    if constexpr (kCompact && !kInlineNee) c.nee = false;
    if constexpr (kInlineNee) c.nee = true;
    auto alive = sf.hit;
    const I mat = sf.material;
    // Textured channels as the material stage left them
    const auto evaluated = [&](int c) {
        return load3<F>(p.col[c][0], p.col[c][1], p.col[c][2], i);
    };
    const Vec3<F> beta = load3<F>(p.beta_r, p.beta_g, p.beta_b, i);
    Vec3<F> rad = kCarried ? load3<F>(p.rad_r, p.rad_g, p.rad_b, i) : Vec3<F>(F(0.0f));

    const SampleStream<F> rng = stream_at<A>(s, p, i);
    const U bounce = U::load_aligned(p.bounce + i);
    const Vec3<F>& d = ray.d;
    const Vec3<F>& n = sf.n;
    const Vec3<F>& pos = sf.pos;

    // An emitter ends the path (after a Phong bounce, a sampled one is weighted: nee, mis)
    if (f.emitters) {
        const auto em = mask_f32(lookup<A>(s.emitter, s.material_count, mat) != I(0)) & alive;
        Vec3<F> le = hit_color<A>(s, kColEmission, mat, evaluated);
        if (c.nee && any(em)) {
            const F lobe_pdf = F::load_aligned(p.lobe_pdf + i);
            le = le * emitter_hit_weight<F>(c.emitters, c.estimator.kind,
                                            select(mask_i32(em), sf.emitter, I(-1)), lobe_pdf,
                                            ray.o, d, length(pos - ray.o),
                                            c.estimator.triangle_solid_angle);
        } else if (c.lt && any(em)) {
            le = le * emitter_hit_weight<F>(c.emitters, c.estimator.kind,
                                            select(mask_i32(em), sf.emitter, I(-1)), F(0.0f), ray.o,
                                            d, length(pos - ray.o));
        }
        rad = select(length_counts<F>(c.estimator, bounce + U(1u), em), rad + beta * le, rad);
        alive = alive & !em;
        if constexpr (kCompact && !kInlineNee)
            compaction->done = queue_radiant<A>(p, i, mask_bits(em), rad, compaction->done);
    }
    // A path that escapes gathers the environment (never in the compacting kernels: they
    // are not chosen for scenes with one)
    if (!kCompact && has_environment(c)) {
        const auto missed = w.live_mask(i) & !sf.hit;
        if (any(missed)) {
            const F lobe_pdf = c.nee ? F::load_aligned(p.lobe_pdf + i) : F(0.0f);
            const Vec3<F> le = escaped_radiance<F>(c, d, lobe_pdf);
            rad =
                select(length_counts<F>(c.estimator, bounce + U(1u), missed), rad + beta * le, rad);
        }
    }
    // (a scene with one lobe kind has that lobe's parameters only: kFused)
    const Bsdf<F> m = hit_bsdf<kFused, A>(s, mat, evaluated);

    // Queues the shadow rays of the lanes in `bits`: origin, direction, tmax, contribution
    // and owner, each compressed in its register and stored whole at the queue's end (the
    // queue has K entries of slack; the lanes past the new end are overwritten next)
    const auto queue = [&](uint32_t bits, const Vec3<F>& origin, const Vec3<F>& wi, const F& tmax,
                           const Vec3<F>& value) {
        const F* src[10] = {&origin.x, &origin.y, &origin.z, &wi.x,    &wi.y,
                            &wi.z,     &tmax,     &value.x,  &value.y, &value.z};
        float* dst[10] = {p.sox, p.soy,   p.soz,  p.sdx,  p.sdy,
                          p.sdz, p.stmax, p.sc_r, p.sc_g, p.sc_b};
        for (int k = 0; k < 10; ++k) compress<A>(*src[k], bits).store_unaligned(dst[k] + queued);
        compress<A>(Wave<A>::lane_ids(i), bits).store_unaligned(p.sowner + queued);
        queued += std::popcount(bits);
    };

    // Direct light at Phong vertices (kernels/path_vertex.h): each shadow ray queued, or
    // (kInlineNee: the emitter sample alone) traced here on the batch's registers
    // (kInlineNee is chosen only with emitter samples and no point lights: known at compile
    // time there)
    const bool nee = c.nee;
    const auto phong_hits = mask_f32(lookup<A>(s.phong, s.material_count, mat) != I(0)) & alive;
    // A guided render: the guide that serves the batch's Phong vertices (guide_stage.h)
    GuideLanes<A> guided;
    if (w.guide) guided = serve_vertices(w, i, pos, phong_hits);
    const GuideAt<F>* guide = w.guide && w.guide->view ? &guided.at : nullptr;
    if (f.lights || nee) {
        const auto phong = length_counts<F>(c.estimator, bounce + U(2u), phong_hits);
        if (any(phong)) {
            const VertexFrame<F> v = vertex_frame(c.smooth, d, n, sf.ns);
            const Vec3<F> origin = shadow_origin(v, pos, sf.magnitude);
            if (nee) {
                const ShadowRequest<F> r =
                    emitter_request(s.path, m, d, v, origin, beta, phong, rng, bounce, guide);
                const uint32_t bits = mask_bits(r.want);
                if constexpr (kInlineNee) {
                    if (bits) {
                        const auto blocked = occluded<A>(s, Ray<F>{origin, r.dir}, r.tmax, r.want);
                        rad = select(r.want & !blocked, rad + r.value, rad);
                        w.counters.shadow += uint64_t(std::popcount(bits));
                        w.counters.shadow_active += uint64_t(std::popcount(bits));
                        w.counters.shadow_total += uint64_t(K);
                    }
                } else if (bits) {
                    queue(bits, origin, r.dir, r.tmax, r.value);
                }
            }
            for (int32_t j = 0; j < c.light_count; ++j) {
                const ShadowRequest<F> r =
                    point_light_request(s.path, j, m, d, v, origin, beta, phong);
                const uint32_t bits = mask_bits(r.want);
                if (bits) queue(bits, origin, r.dir, r.tmax, r.value);
            }
        }
    }

    // Russian roulette over the lobes
    F probability;
    // (the roulette's draw with the lobe's: one 2D point, kept for the lobe buckets)
    F u_lobe, u_roulette;
    lobe_uniforms<F>(rng, bounce, normalised_lobes(c.estimator), u_lobe, u_roulette);
    I lobe = choose_lobe<kFused>(m, u_lobe, c.estimator.survival_cap, probability,
                                 normalised_lobes(c.estimator));
    alive = may_extend<F>(c.estimator, bounce, alive);
    lobe = select(mask_i32(alive), lobe, I(kLobeAbsorbed));
    alive = alive & mask_f32(lobe != I(kLobeAbsorbed));
    if constexpr (kFused == kLobeCount) {
        lobe.store_aligned(p.lobe + i);
        probability.store_aligned(p.probability + i);
        if (normalised_lobes(c.estimator)) u_roulette.store_aligned(p.roulette_draw + i);
    } else {
        // The scene's one lobe: every surviving lane chose it. Lanes that did not survive
        // are written too; their rays are never read again.
        const bool learn = w.guide && w.guide->learner;
        const LobeStep<kFused, A> step(c, m, sf.magnitude, d, pos, n, sf.ns, beta, probability, rng,
                                       u_roulette, bounce, w.guide ? &guided : nullptr, learn);
        // (a guided render's served vertices record; in the compacting pass, whose vertex's
        // shadow ray has landed, with the throughput and radiance their records keep)
        if constexpr (kCarried && (kFused == kLobeDiffuse || kFused == kLobeSpecular))
            if (learn)
                make_records<kFused == kLobeDiffuse>(
                    w, Wave<A>::lane_ids(i), mask_bits(alive & guided.served), pos, step.d, m,
                    step.nsf, guided, step.record, kCompact ? &step.beta : nullptr, &rad);
        alive = alive & step.alive;
        w.counters.extension += uint64_t(std::popcount(mask_bits(alive)));
        if constexpr (kCompact) {
            // Survivors straight to the front of the pool, in order: writing at kept <= i
            // never overtakes the batches not yet read (compact_paths says more)
            const uint32_t bits = mask_bits(alive);
            const int32_t at = compaction->kept;
            // Every path that ended here hands over what it gathered (before the survivors'
            // stores below overwrite this batch's pixels)
            if constexpr (kInlineNee) {
                const uint32_t ended = mask_bits(w.live_mask(i)) & ~bits;
                compaction->done = queue_radiant<A>(p, i, ended, rad, compaction->done);
                if (learn) hand_over_records(w, i, ended, rad);
            }
            // (with kInlineNee, survivors keep their radiance and their lobe's density; a
            // guided render's, their Phong vertices' count and last record)
            constexpr uint32_t kCarriedFields =
                kInlineNee ? kRadianceFields | field_bit(kFieldLobePdf) : 0u;
            move_paths<A, kRayFields | kBetaFields | kCarriedFields>(
                p,
                path_fields(s) | field_bit(kFieldPixel) | kCarriedFields |
                    (w.guide ? kGuideFields : 0u),
                i, bits, at, {&step.o, &step.d, &step.beta, &rad, &step.pdf});
            compaction->kept = at + std::popcount(bits);
        } else {
            store3(step.o, p.ox, p.oy, p.oz, i);
            store3(step.d, p.dx, p.dy, p.dz, i);
            store3(step.beta, p.beta_r, p.beta_g, p.beta_b, i);
            if (c.nee) step.pdf.store_aligned(p.lobe_pdf + i);
        }
    }
    if constexpr (!kCompact) {
        select(mask_i32(alive), I(1), I(0)).store_aligned(p.alive + i);
        store3(rad, p.rad_r, p.rad_g, p.rad_b, i);
    }
    w.counters.lanes_active += uint64_t(std::min(K, w.live - i));
    w.counters.lanes_total += uint64_t(K);
}

// Shading of the surfaces stored before the material stage, K at a time.
template <int kFused, class A>
CIERZO_STAGE_LOOP void shade_stored(Wave<A>& w) {
    using F = typename Wave<A>::F;
    PathPool& p = w.pool;
    int32_t queued = 0;
    const int32_t end = w.rounded_up(w.live);
    for (int32_t i = 0; i < end; i += Wave<A>::K) {
        const Ray<F> ray{load3<F>(p.ox, p.oy, p.oz, i), load3<F>(p.dx, p.dy, p.dz, i)};
        shade_batch<kFused>(w, i, ray, load_surfaces(w, i, ray), queued);
    }
    p.shadow_count = queued;
    w.counters.shadow += uint64_t(queued);
}

// A lobe's kernel over its bucket: full batches of gathered lanes.
template <int kLobe, class A>
CIERZO_STAGE_LOOP void run_lobe_bucket(Wave<A>& w, const int32_t* list, int32_t size) {
    using F = typename Wave<A>::F;
    using I = typename Wave<A>::I;
    constexpr int32_t K = Wave<A>::K;
    PathPool& p = w.pool;
    for (int32_t i = 0; i < size; i += K) {
        alignas(64) int32_t idx[K];
        for (int32_t l = 0; l < K; ++l) idx[l] = list[std::min(i + l, size - 1)];
        const I j = I::load_aligned(idx);
        // (only this bucket's lobe is sampled, so only its parameters are read)
        const auto m = hit_bsdf<kLobe, A>(w.scene, gather_lanes<A>(p.material, j), [&](int c) {
            return gather3<A>(p.col[c][0], p.col[c][1], p.col[c][2], j);
        });
        const Vec3<F> pos = gather3<A>(p.px, p.py, p.pz, j);
        const F magnitude = max(max_abs(pos), max_abs(gather3<A>(p.ox, p.oy, p.oz, j)));
        const Vec3<F> n = gather3<A>(p.nx, p.ny, p.nz, j);
        const typename Wave<A>::U bounce = gather_lanes<A>(p.bounce, j);
        const SampleStream<F> rng{gather_lanes<A>(p.key, j),
                                  w.scene.path.sampler.kind == Sampler::kIndependent
                                      ? typename Wave<A>::U(0u)
                                      : gather_lanes<A>(p.index, j),
                                  w.scene.path.sampler};
        // (the roulette's draw, where the throughput roulette needs it: drawn with the lobe's)
        const F u_roulette = normalised_lobes(w.scene.path.estimator)
                                 ? gather_lanes<A>(p.roulette_draw, j)
                                 : F(0.0f);
        // (a guided render: the guide that served these vertices, and their records)
        GuideLanes<A> guided;
        if (w.guide) guided = served_vertices(w, j);
        const bool learn = w.guide && w.guide->learner;
        const LobeStep<kLobe, A> step(
            w.scene.path, m, magnitude, gather3<A>(p.dx, p.dy, p.dz, j), pos, n,
            w.scene.path.smooth ? gather3<A>(p.snx, p.sny, p.snz, j) : n,
            gather3<A>(p.beta_r, p.beta_g, p.beta_b, j), gather_lanes<A>(p.probability, j), rng,
            u_roulette, bounce, w.guide ? &guided : nullptr, learn);
        const int32_t lanes = std::min(K, size - i);
        if constexpr (kLobe == kLobeDiffuse || kLobe == kLobeSpecular)
            if (learn)
                make_records<kLobe == kLobeDiffuse>(w, j,
                                                    mask_bits(guided.served) & ((1u << lanes) - 1u),
                                                    pos, step.d, m, step.nsf, guided, step.record);
        scatter3(step.o, p.ox, p.oy, p.oz, j);
        scatter3(step.d, p.dx, p.dy, p.dz, j);
        scatter3(step.beta, p.beta_r, p.beta_g, p.beta_b, j);
        select(mask_i32(step.alive), I(1), I(0)).scatter(p.alive, j);
        if (w.scene.path.nee) step.pdf.scatter(p.lobe_pdf, j);
        w.counters.extension +=
            uint64_t(std::popcount(mask_bits(step.alive) & ((1u << lanes) - 1u)));
        w.counters.lanes_active += uint64_t(lanes);
        w.counters.lanes_total += uint64_t(K);
    }
}

// The lobes of scenes with more than one: the paths bucketed by the lobe the roulette
// picked, then each lobe's kernel over its bucket.
template <class A>
CIERZO_STAGE void sample_lobes(Wave<A>& w) {
    using I = typename Wave<A>::I;
    PathPool& p = w.pool;
    const FlatFeatures& f = w.scene.features;
    for (int b = 0; b < kLobeCount; ++b) p.bucket_size[b] = 0;
    const int32_t end = w.rounded_up(w.live);
    for (int32_t i = 0; i < end; i += Wave<A>::K) {
        const I lobe = I::load_aligned(p.lobe + i);
        for (int b = 0; b < kLobeCount; ++b)
            append_lanes(mask_bits(mask_f32(lobe == I(b))), i, p.bucket[b], p.bucket_size[b]);
    }
    if (f.diffuse) run_lobe_bucket<kLobeDiffuse>(w, p.bucket[0], p.bucket_size[0]);
    if (f.specular) run_lobe_bucket<kLobeSpecular>(w, p.bucket[1], p.bucket_size[1]);
    if (f.mirror) run_lobe_bucket<kLobeMirror>(w, p.bucket[2], p.bucket_size[2]);
    if (f.refraction) run_lobe_bucket<kLobeRefract>(w, p.bucket[3], p.bucket_size[3]);
}

}  // namespace CIERZO_ISA_NAMESPACE
}  // namespace cierzo
