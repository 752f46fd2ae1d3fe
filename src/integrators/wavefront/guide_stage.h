// A guided render's camera paths in the wavefront (kernels/guiding.h): the guide that serves
// each Phong vertex, found for whole lanes; the records the served vertices make; and their
// hand-over to the guide when their paths end. The rules are the scalar loop's
// (integrators/scalar.cpp): the guide serves the first render.guided_vertices Phong vertices
// of each path, which draw part of their diffuse directions from it, weigh the emitter
// sample and what the next segment hits with its density, and record what comes back along
// the direction they left in. A record's light is what the path gathers after the vertex's
// own shadow rays have landed: the record keeps the path's radiance then (at the compaction
// that follows the shadow stage, or as it is made in the compacting pass, which traces the
// vertex's shadow ray as it shades), and takes it from the path's radiance at its end.
#pragma once

#include "integrators/wavefront/wave.h"
#include "kernels/guiding.h"
#include "kernels/path_vertex.h"

namespace cierzo {
inline namespace CIERZO_ISA_NAMESPACE {

// A path keeps at most this many records (the scalar loop's bound).
inline constexpr int32_t kMaxPathRecords = 64;

// The guide at a batch's Phong vertices: where it serves them (`served`), and its quadtree
// and share α there (`at`: no lane active before the first training).
template <class A>
struct GuideLanes {
    GuideAt<typename Wave<A>::F> at;
    typename Wave<A>::M served = typename Wave<A>::M(false);
};

// The guide of batch i's Phong vertices `phong` (at points pos): each path counts its Phong
// vertices, and the first `served` of them are served. The pool keeps what the lobe buckets
// read back (guide_root, guide_fraction), and no record made yet (made = -1).
template <class A>
GuideLanes<A> serve_vertices(Wave<A>& w, int32_t i, const Vec3<typename Wave<A>::F>& pos,
                             const typename Wave<A>::M& phong) {
    using U = typename Wave<A>::U;
    using I = typename Wave<A>::I;
    PathPool& p = w.pool;
    const WavefrontGuide& g = *w.guide;
    const U before = U::load_aligned(p.phong + i);
    GuideLanes<A> out;
    out.served = phong & mask_f32(xsimd::bitwise_cast<I>(before) < I(g.served));
    (before + select(mask_u32(phong), U(1u), U(0u))).store_aligned(p.phong + i);
    out.at = guide_at(g.view, pos, out.served);
    select(mask_i32(out.served), out.at.root, I(-1)).store_aligned(p.guide_root + i);
    out.at.fraction.store_aligned(p.guide_fraction + i);
    I(-1).store_aligned(p.made + i);
    return out;
}

// The guide the lobe buckets' lanes j were served by (serve_vertices kept it).
template <class A>
GuideLanes<A> served_vertices(const Wave<A>& w, const typename Wave<A>::I& j) {
    using I = typename Wave<A>::I;
    const PathPool& p = w.pool;
    GuideLanes<A> out;
    const I root = gather_lanes<A>(p.guide_root, j);
    out.served = mask_f32(root >= I(0));
    out.at.view = w.guide->view;
    out.at.root = max(root, I(0));
    out.at.fraction = gather_lanes<A>(p.guide_fraction, j);
    return out;
}

// The records of the lanes in `bits` (pool indices j, at points pos, leaving in dir; m their
// material, nsf the shading normal on the arriving side): each appended to the thread's table
// and linked to its path's last one, unless the path holds kMaxPathRecords. A diffuse
// vertex with a guide to sample (kDiffuse and a guide) also records what the cell's share α
// learns from. `beta` and `rad`, where the vertex's shadow rays have landed (the compacting
// pass, which traces them as it shades): the throughput after the vertex and the radiance so
// far; otherwise settle_records writes them after the shadow stage.
template <bool kDiffuse, class A>
void make_records(Wave<A>& w, const typename Wave<A>::I& j, uint32_t bits,
                  const Vec3<typename Wave<A>::F>& pos, const Vec3<typename Wave<A>::F>& dir,
                  const Bsdf<typename Wave<A>::F>& m, const Vec3<typename Wave<A>::F>& nsf,
                  const GuideLanes<A>& guide, const RecordDensities<typename Wave<A>::F>& r,
                  const Vec3<typename Wave<A>::F>* beta = nullptr,
                  const Vec3<typename Wave<A>::F>* rad = nullptr) {
    using F = typename Wave<A>::F;
    constexpr int32_t K = Wave<A>::K;
    if (!bits) return;
    PathPool& p = w.pool;
    GuideRecordTable& table = *p.guide_records;
    const bool selection = kDiffuse && guide.at.exists();
    alignas(64) float lane[19][K];
    alignas(64) int32_t index[K];
    j.store_aligned(index);
    const F* values[] = {&pos.x, &pos.y, &pos.z, &dir.x, &dir.y, &dir.z, &r.density};
    for (int k = 0; k < 7; ++k) values[k]->store_aligned(lane[k]);
    if (selection) {
        const Vec3<F> f_cos = diffuse_f_cos(m, dir, nsf);
        const F* more[] = {&f_cos.x,     &f_cos.y,    &f_cos.z,
                           &r.guide_pdf, &r.lobe_pdf, &guide.at.fraction};
        for (int k = 0; k < 6; ++k) more[k]->store_aligned(lane[7 + k]);
    }
    if (beta) {
        const F* known[] = {&beta->x, &beta->y, &beta->z, &rad->x, &rad->y, &rad->z};
        for (int k = 0; k < 6; ++k) known[k]->store_aligned(lane[13 + k]);
    }
    for (; bits; bits &= bits - 1) {
        const int32_t l = std::countr_zero(bits);
        const int32_t path = index[l];
        const int32_t previous = p.record[path];
        const int32_t ordinal = previous >= 0 ? table.records[previous].ordinal + 1 : 0;
        if (ordinal >= kMaxPathRecords) continue;
        if (table.count == table.capacity) table.grow(table, table.count + 1);
        GuideRecord& rec = table.records[table.count];
        rec = {{lane[0][l], lane[1][l], lane[2][l]},
               {lane[3][l], lane[4][l], lane[5][l]},
               lane[6][l],
               {0.0f, 0.0f, 0.0f},
               {0.0f, 0.0f, 0.0f},
               {0.0f, 0.0f, 0.0f},
               0.0f,
               0.0f,
               0.0f,
               0,
               previous,
               ordinal};
        if (selection) {
            rec.f_cos[0] = lane[7][l], rec.f_cos[1] = lane[8][l], rec.f_cos[2] = lane[9][l];
            rec.guide_pdf = lane[10][l], rec.lobe_pdf = lane[11][l], rec.fraction = lane[12][l];
            rec.selection = 1;
        }
        if (beta)
            for (int c = 0; c < 3; ++c)
                rec.throughput[c] = lane[13 + c][l], rec.gathered[c] = lane[16 + c][l];
        p.record[path] = table.count++;
        if (!beta) p.made[path] = p.record[path];
    }
}

// A path that ended with radiance `final` hands its records, from its last (`last`) back,
// to the guide: the light each gathered is the path's radiance now less what it had then.
inline void hand_over_path(const WavefrontGuide& g, GuideRecordTable& table, int32_t last,
                           const float final[3]) {
    for (int32_t k = last; k >= 0;) {
        GuideRecord& r = table.records[k];
        for (int c = 0; c < 3; ++c) r.gathered[c] = final[c] - r.gathered[c];
        g.deposit(g.learner, g.pass, r);
        k = r.previous;
    }
}

// The paths of batch i in `ended` (radiance rad) hand their records over.
template <class A>
void hand_over_records(Wave<A>& w, int32_t i, uint32_t ended,
                       const Vec3<typename Wave<A>::F>& rad) {
    constexpr int32_t K = Wave<A>::K;
    PathPool& p = w.pool;
    alignas(64) float lane[3][K];
    rad.x.store_aligned(lane[0]), rad.y.store_aligned(lane[1]), rad.z.store_aligned(lane[2]);
    for (; ended; ended &= ended - 1) {
        const int32_t l = std::countr_zero(ended);
        const float final[3] = {lane[0][l], lane[1][l], lane[2][l]};
        hand_over_path(*w.guide, *p.guide_records, p.record[i + l], final);
    }
}

// After the shadow stage: each record made this bounce takes its path's throughput and the
// radiance it has gathered so far; each path that ended hands its records over.
template <class A>
CIERZO_STAGE void settle_records(Wave<A>& w) {
    PathPool& p = w.pool;
    GuideRecordTable& table = *p.guide_records;
    for (int32_t l = 0; l < w.live; ++l) {
        if (p.made[l] >= 0) {
            GuideRecord& r = table.records[p.made[l]];
            r.throughput[0] = p.beta_r[l], r.throughput[1] = p.beta_g[l];
            r.throughput[2] = p.beta_b[l];
            r.gathered[0] = p.rad_r[l], r.gathered[1] = p.rad_g[l], r.gathered[2] = p.rad_b[l];
        }
        if (p.alive[l]) continue;
        const float final[3] = {p.rad_r[l], p.rad_g[l], p.rad_b[l]};
        hand_over_path(*w.guide, table, p.record[l], final);
    }
}

}  // namespace CIERZO_ISA_NAMESPACE
}  // namespace cierzo
