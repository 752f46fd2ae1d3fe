// Merging in the wavefront (vcm, bpm, ppm; kernels/bidirectional.h): each sample's merging
// quantities, the job's grid over its stored light vertices, and the camera vertices of a
// batch gathering the vertices near them through it, lane by lane (merge_vertex.h).
#pragma once

#include "integrators/merge_vertex.h"
#include "integrators/wavefront/wave.h"
#include "kernels/bidirectional.h"

namespace cierzo {
inline namespace CIERZO_ISA_NAMESPACE {

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
[[gnu::noinline]] void merge_lanes(Wave<A>& w, int32_t i,
                                   const CameraVertex<typename Wave<A>::F>& cv,
                                   const Vec3<typename Wave<A>::F>& beta,
                                   const MergeWeights<typename Wave<A>::F>& mw,
                                   const typename Wave<A>::M& want) {
    using F = typename Wave<A>::F;
    constexpr int32_t K = Wave<A>::K;
    PathPool& p = w.pool;
    const FlatScene& s = w.scene;
    const LightVertexStore& st = *p.light_store;
    uint32_t bits = mask_bits(want);
    if (!bits) return;
    constexpr int kFields = 31;
    // clang-format off
    const F* src[kFields] = {&cv.p.x,      &cv.p.y,      &cv.p.z,      &cv.nf.x,     &cv.nf.y,
                             &cv.nf.z,     &cv.nsf.x,    &cv.nsf.y,    &cv.nsf.z,    &cv.wo.x,
                             &cv.wo.y,     &cv.wo.z,     &cv.phong.kd.x, &cv.phong.kd.y,
                             &cv.phong.kd.z, &cv.phong.ks.x, &cv.phong.ks.y, &cv.phong.ks.z,
                             &cv.phong.shininess, &cv.phong.p_diffuse, &cv.phong.p_specular,
                             &cv.mis.vcm,  &cv.mis.vc,   &cv.mis.vm,   &beta.x,      &beta.y,
                             &beta.z,      &mw.vm_weight, &mw.vc_weight, &mw.normalization,
                             &mw.radius2};
    // clang-format on
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
CIERZO_STAGE inline void build_merge_grid(LightVertexStore& st) {
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
                          job.sample_begin + int64_t(j), has_lights ? pixels : 0, kMergeTilePaths,
                          connects(c.estimator.kind), c.connection_count);
        t.vm_weight[j] = m.vm_weight, t.vc_weight[j] = m.vc_weight;
        t.normalization[j] = m.normalization, t.radius2[j] = m.radius2;
        t.radius[j] = std::sqrt(m.radius2);
    }
}

}  // namespace CIERZO_ISA_NAMESPACE
}  // namespace cierzo
