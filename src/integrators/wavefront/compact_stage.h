// Wavefront stage 7, compaction: paths that ended hand their radiance to the film; the
// survivors move to the front of the pool, in order, so every stage works on full batches
// and the free slots at the back are refilled with new camera paths. move_paths is the one
// move of a batch's survivors, which every stage that compacts calls.
#pragma once

#include "integrators/wavefront/camera_stage.h"
#include "integrators/wavefront/guide_stage.h"

namespace cierzo {
inline namespace CIERZO_ISA_NAMESPACE {

// The fields every path of a wave keeps: its ray, throughput, key and bounce, and its
// sample's index where the sampler has one.
inline uint32_t path_fields(const FlatScene& s) {
    return kRayFields | kBetaFields | field_bit(kFieldKey) | field_bit(kFieldBounce) |
           (s.path.sampler.kind != Sampler::kIndependent ? field_bit(kFieldIndex) : 0u);
}

// The part of a batch's new path state that a stage holds in registers (move_paths: the
// fields of its kHeld).
template <class A>
struct HeldState {
    using F = xsimd::batch<float, A>;
    const Vec3<F>* o = nullptr;
    const Vec3<F>* d = nullptr;
    const Vec3<F>* beta = nullptr;
    const Vec3<F>* rad = nullptr;
    const F* lobe_pdf = nullptr;
    const F* mis[3] = {};  // vcm, vc, vm
};

// The register `held` holds for field kField.
template <int32_t kField, class A>
const xsimd::batch<float, A>& held_field(const HeldState<A>& held) {
    using F = xsimd::batch<float, A>;
    const auto of = [](const Vec3<F>* v, int32_t c) -> const F& {
        return c == 0 ? v->x : c == 1 ? v->y : v->z;
    };
    if constexpr (kField <= kFieldOz)
        return of(held.o, kField - kFieldOx);
    else if constexpr (kField <= kFieldDz)
        return of(held.d, kField - kFieldDx);
    else if constexpr (kField <= kFieldBetaB)
        return of(held.beta, kField - kFieldBetaR);
    else if constexpr (kField <= kFieldRadB)
        return of(held.rad, kField - kFieldRadR);
    else if constexpr (kField == kFieldLobePdf)
        return *held.lobe_pdf;
    else
        return *held.mis[kField - kFieldMisVcm];
}

// Moves the lanes in `bits` of batch i to [kept, kept + popcount(bits)) of the pool, in
// order: each field of `fields` (a set of PathField bits), from `held` for the fields of
// kHeld (known when compiling, so that no lane work asks where a field is), else from the
// pool; the bounce becomes bounce + 1. A batch is compressed in registers and stored whole
// at the write position: writing at kept <= i never overtakes the batch being read, and the
// lanes stored past the last kept one are overwritten by the next batch or lie beyond the
// live paths.
template <class A, uint32_t kHeld = 0u>
void move_paths(const PathPool& p, uint32_t fields, int32_t i, uint32_t bits, int32_t kept,
                const HeldState<A>& held = {}) {
    using F = xsimd::batch<float, A>;
    using U = xsimd::batch<uint32_t, A>;
    p.for_each_state([&](auto field, auto* a) {
        constexpr int32_t k = decltype(field)::value;
        if (!(fields & field_bit(PathField(k)))) return;
        if constexpr (k == kFieldBounce) {
            compress<A>(U::load_aligned(a + i) + U(1u), bits).store_unaligned(a + kept);
        } else if constexpr (k >= kFieldKey) {
            using B = xsimd::batch<std::remove_pointer_t<decltype(a)>, A>;  // (uint32 or int32)
            compress<A>(B::load_aligned(a + i), bits).store_unaligned(a + kept);
        } else if constexpr ((kHeld >> k) & 1u) {
            compress<A>(held_field<k, A>(held), bits).store_unaligned(a + kept);
        } else {
            compress<A>(F::load_aligned(a + i), bits).store_unaligned(a + kept);
        }
    });
}

// Ended paths with radiance go to the film's queue; survivors move down to `kept` with the
// fields `fields` (move_paths), bounce + 1. Both keep pool order.
template <class A>
CIERZO_STAGE void compact_paths(Wave<A>& w, const TileJob& job, uint32_t fields) {
    using F = typename Wave<A>::F;
    using I = typename Wave<A>::I;
    constexpr int32_t K = Wave<A>::K;
    PathPool& p = w.pool;
    int32_t kept = 0, done = 0;
    for (int32_t i = 0; i < w.live; i += K) {
        const int32_t lanes = std::min(K, w.live - i);
        const uint32_t valid = (1u << lanes) - 1u;
        const uint32_t m = mask_bits(mask_f32(I::load_aligned(p.alive + i) != I(0))) & valid;
        const uint32_t ended = ~m & valid;
        if (ended)
            done = queue_radiant<A>(p, i, ended, load3<F>(p.rad_r, p.rad_g, p.rad_b, i), done);
        move_paths<A>(p, fields, i, m, kept);
        kept += std::popcount(m);
    }
    if (done) job.finish(job.film, done, p.done_pixel, p.done_r, p.done_g, p.done_b);
    w.live = kept;
}

// The camera paths' compaction (the report's estimators): their radiance, pixel, and with
// nee or mis the last lobe's density, as well; a guided render's paths first settle their
// records (guide_stage.h) and keep their Phong vertices' count and last record.
template <class A>
void compact_paths(Wave<A>& w, const TileJob& job) {
    const FlatScene& s = w.scene;
    if (w.guide && w.guide->learner) settle_records(w);
    compact_paths(w, job,
                  path_fields(s) | kRadianceFields | field_bit(kFieldPixel) |
                      (s.path.nee ? field_bit(kFieldLobePdf) : 0u) | (w.guide ? kGuideFields : 0u));
}

}  // namespace CIERZO_ISA_NAMESPACE
}  // namespace cierzo
