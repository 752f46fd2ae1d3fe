// Wavefront stage 7, compaction: paths that ended hand their radiance to the film; the
// survivors move to the front of the pool, in order, so every stage works on full batches
// and the free slots at the back are refilled with new camera paths.
#pragma once

#include "integrators/wavefront/camera_stage.h"

namespace cierzo {
inline namespace CIERZO_ISA_NAMESPACE {

// Ended paths go to the film's queue; survivors move down to `kept`, bounce + 1.
template <class A>
void compact_paths(Wave<A>& w, const TileJob& job) {
    PathPool& p = w.pool;
    float* const fa[12] = {p.ox,     p.oy,     p.oz,     p.dx,    p.dy,    p.dz,
                           p.beta_r, p.beta_g, p.beta_b, p.rad_r, p.rad_g, p.rad_b};
    int32_t kept = 0, done = 0;

    // Finished paths to the film's queue and survivors to the front, both in pool order:
    // compressed in registers where the ISA can, else one by one. Writing at kept <= i
    // never overtakes the batch being read.
#if defined(__AVX512F__)
    if constexpr (std::is_base_of_v<xsimd::avx512f, A>) {
        constexpr int32_t K = Wave<A>::K;
        for (int32_t i = 0; i < w.live; i += K) {
            const int32_t lanes = std::min(K, w.live - i);
            const __mmask16 valid = __mmask16((1u << lanes) - 1u);
            const __mmask16 m = _mm512_cmpneq_epi32_mask(_mm512_load_si512(p.alive + i),
                                                         _mm512_setzero_si512()) & valid;
            const __mmask16 ended = __mmask16(~m) & valid;
            _mm512_storeu_si512(p.done_pixel + done,
                                _mm512_maskz_compress_epi32(ended, _mm512_load_si512(p.pixel + i)));
            float* const rad[3] = {p.rad_r, p.rad_g, p.rad_b};
            float* const out[3] = {p.done_r, p.done_g, p.done_b};
            for (int c = 0; c < 3; ++c)
                _mm512_storeu_ps(out[c] + done,
                                 _mm512_maskz_compress_ps(ended, _mm512_load_ps(rad[c] + i)));
            done += std::popcount(uint32_t(ended));
            for (float* a : fa)
                _mm512_storeu_ps(a + kept, _mm512_maskz_compress_ps(m, _mm512_load_ps(a + i)));
            for (uint32_t* a : {p.key, p.pixel})
                _mm512_storeu_si512(a + kept,
                                    _mm512_maskz_compress_epi32(m, _mm512_load_si512(a + i)));
            const __m512i next = _mm512_add_epi32(_mm512_load_si512(p.bounce + i),
                                                  _mm512_set1_epi32(1));
            _mm512_storeu_si512(p.bounce + kept, _mm512_maskz_compress_epi32(m, next));
            kept += std::popcount(uint32_t(m));
        }
    } else
#endif
    {
        for (int32_t i = 0; i < w.live; ++i) {
            if (!p.alive[i]) {
                p.done_pixel[done] = p.pixel[i];
                p.done_r[done] = p.rad_r[i], p.done_g[done] = p.rad_g[i];
                p.done_b[done] = p.rad_b[i];
                ++done;
                continue;
            }
            for (float* a : fa) a[kept] = a[i];
            p.key[kept] = p.key[i];
            p.pixel[kept] = p.pixel[i];
            p.bounce[kept] = p.bounce[i] + 1;
            ++kept;
        }
    }
    if (done) job.finish(job.film, done, p.done_pixel, p.done_r, p.done_g, p.done_b);
    w.live = kept;
}

}  // namespace CIERZO_ISA_NAMESPACE
}  // namespace cierzo
