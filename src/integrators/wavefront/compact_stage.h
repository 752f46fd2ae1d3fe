// Wavefront stage 7, compaction: paths that ended hand their radiance to the film; the
// survivors move to the front of the pool, in order, so every stage works on full batches
// and the free slots at the back are refilled with new camera paths.
#pragma once

#include <array>

#include "integrators/wavefront/camera_stage.h"

namespace cierzo {
inline namespace CIERZO_ISA_NAMESPACE {

// For the 8-lane mask m, the indices of its set lanes in order, packed 4 bits each (lane 0
// of the result in the low nibble): the permute that compresses an AVX register.
constexpr std::array<uint32_t, 256> compress_nibbles() {
    std::array<uint32_t, 256> table{};
    for (uint32_t m = 0; m < 256; ++m) {
        uint32_t packed = 0, at = 0;
        for (uint32_t l = 0; l < 8; ++l)
            if (m >> l & 1u) packed |= l << (4 * at++);
        table[m] = packed;
    }
    return table;
}
inline constexpr std::array<uint32_t, 256> kCompressNibbles = compress_nibbles();

// The same for 4 lanes as byte-shuffle controls (SSE's pshufb, NEON's tbl): lane l takes the
// 4 bytes of lane idx[l].
struct alignas(16) ShuffleControl {
    uint8_t byte[16];
};
constexpr std::array<ShuffleControl, 16> compress_shuffles() {
    std::array<ShuffleControl, 16> table{};
    for (uint32_t m = 0; m < 16; ++m)
        for (uint32_t l = 0; l < 4; ++l)
            for (uint32_t b = 0; b < 4; ++b)
                table[m].byte[4 * l + b] = uint8_t(4 * (kCompressNibbles[m] >> (4 * l) & 15u) + b);
    return table;
}
inline constexpr std::array<ShuffleControl, 16> kCompressShuffles = compress_shuffles();

// The 32-bit lanes of v whose bit is set in `bits` moved to the front, in order; the lanes
// after them hold anything. AVX-512 compresses in one instruction; AVX2 permutes by a table
// of 256 index lists, SSE and NEON shuffle bytes by the same table.
template <class A, class T>
xsimd::batch<T, A> compress(const xsimd::batch<T, A>& v, uint32_t bits) {
    using B = xsimd::batch<T, A>;
    static_assert(sizeof(T) == 4);
#if defined(__AVX512F__)
    if constexpr (std::is_base_of_v<xsimd::avx512f, A>) {
        if constexpr (std::is_same_v<T, float>)
            return B(_mm512_maskz_compress_ps(__mmask16(bits), v.data));
        else
            return B(_mm512_maskz_compress_epi32(__mmask16(bits), v.data));
    }
#endif
#if defined(__AVX2__)
    if constexpr (std::is_base_of_v<xsimd::avx2, A> && !std::is_base_of_v<xsimd::avx512f, A>) {
        const __m256i idx = _mm256_and_si256(
            _mm256_srlv_epi32(_mm256_set1_epi32(int(kCompressNibbles[bits])),
                              _mm256_setr_epi32(0, 4, 8, 12, 16, 20, 24, 28)),
            _mm256_set1_epi32(7));
        if constexpr (std::is_same_v<T, float>)
            return B(_mm256_permutevar8x32_ps(v.data, idx));
        else
            return B(_mm256_permutevar8x32_epi32(v.data, idx));
    }
#endif
#if defined(__SSE2__)
    if constexpr (!std::is_base_of_v<xsimd::avx2, A> && !std::is_base_of_v<xsimd::avx512f, A>) {
        const auto* control = reinterpret_cast<const __m128i*>(&kCompressShuffles[bits]);
        const __m128i c = _mm_load_si128(control);
        if constexpr (std::is_same_v<T, float>)
            return B(_mm_castsi128_ps(_mm_shuffle_epi8(_mm_castps_si128(v.data), c)));
        else
            return B(_mm_shuffle_epi8(v.data, c));
    }
#endif
#if defined(__aarch64__)
    if constexpr (std::is_base_of_v<xsimd::neon64, A>) {
        const uint8x16_t c = vld1q_u8(kCompressShuffles[bits].byte);
        if constexpr (std::is_same_v<T, float>)
            return B(vreinterpretq_f32_u8(vqtbl1q_u8(vreinterpretq_u8_f32(v.data), c)));
        else if constexpr (std::is_same_v<T, uint32_t>)
            return B(vreinterpretq_u32_u8(vqtbl1q_u8(vreinterpretq_u8_u32(v.data), c)));
        else
            return B(vreinterpretq_s32_u8(vqtbl1q_u8(vreinterpretq_u8_s32(v.data), c)));
    }
#endif
}

// Ended paths go to the film's queue; survivors move down to `kept`, bounce + 1. Both keep
// pool order. A batch is compressed in registers and stored whole at the write position:
// writing at kept <= i never overtakes the batch being read, and the lanes stored past the
// last kept one are overwritten by the next batch or lie beyond the live paths.
template <class A>
void compact_paths(Wave<A>& w, const TileJob& job) {
    using F = typename Wave<A>::F;
    using U = typename Wave<A>::U;
    using I = typename Wave<A>::I;
    constexpr int32_t K = Wave<A>::K;
    PathPool& p = w.pool;
    float* const fa[12] = {p.ox,     p.oy,     p.oz,     p.dx,    p.dy,    p.dz,
                           p.beta_r, p.beta_g, p.beta_b, p.rad_r, p.rad_g, p.rad_b};
    float* const rad[3] = {p.rad_r, p.rad_g, p.rad_b};
    float* const out[3] = {p.done_r, p.done_g, p.done_b};
    int32_t kept = 0, done = 0;
    for (int32_t i = 0; i < w.live; i += K) {
        const int32_t lanes = std::min(K, w.live - i);
        const uint32_t valid = (1u << lanes) - 1u;
        const uint32_t m = mask_bits(mask_f32(I::load_aligned(p.alive + i) != I(0))) & valid;
        const uint32_t ended = ~m & valid;
        if (ended) {
            compress<A>(U::load_aligned(p.pixel + i), ended).store_unaligned(p.done_pixel + done);
            for (int c = 0; c < 3; ++c)
                compress<A>(F::load_aligned(rad[c] + i), ended).store_unaligned(out[c] + done);
            done += std::popcount(ended);
        }
        for (float* a : fa) compress<A>(F::load_aligned(a + i), m).store_unaligned(a + kept);
        for (uint32_t* a : {p.key, p.pixel})
            compress<A>(U::load_aligned(a + i), m).store_unaligned(a + kept);
        compress<A>(U::load_aligned(p.bounce + i) + U(1u), m).store_unaligned(p.bounce + kept);
        kept += std::popcount(m);
    }
    if (done) job.finish(job.film, done, p.done_pixel, p.done_r, p.done_g, p.done_b);
    w.live = kept;
}

}  // namespace CIERZO_ISA_NAMESPACE
}  // namespace cierzo
