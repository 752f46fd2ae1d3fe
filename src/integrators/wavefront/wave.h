// The context every wavefront stage works on: the flat scene, this thread's path pool, the
// live path count and the counters, with lane types for one instruction set `A`. Included
// only by the per-ISA objects; everything here lives in the per-ISA namespace.
#pragma once

#include <algorithm>
#include <array>
#include <bit>
#include <limits>

#include "integrators/wavefront/job.h"
#include "integrators/wavefront/path_pool.h"
#include "kernels/estimator.h"
#include "kernels/intersect.h"
#include "kernels/rng.h"
#include "kernels/sampler.h"

// A stage: one pass over the whole wave (camera paths, shadow rays, compaction, a lobe's
// bucket...). Its call costs nothing beside the loop, so it is never inlined: a flattened
// caller would otherwise copy it whole into every loop that runs it, and the per-ISA objects'
// compile time grows with the largest function, not with the code.
#define CIERZO_STAGE [[gnu::noinline]]

// A stage loop: a stage that inlines every kernel it calls, so a batch's values stay in
// registers instead of going through memory around calls that pass Bsdf and Vec3 lanes; but
// not the stages it runs nor a deep tree's traversal ray by ray (intersect_stage.h). Sanitizer
// builds skip the flattening: there it would only multiply the per-ISA objects' compile time.
#if defined(__SANITIZE_ADDRESS__)
#define CIERZO_STAGE_LOOP CIERZO_STAGE
#else
#define CIERZO_STAGE_LOOP [[gnu::flatten, gnu::noinline]]
#endif

namespace cierzo {
inline namespace CIERZO_ISA_NAMESPACE {

template <class A>
struct Wave {
    using F = xsimd::batch<float, A>;
    using U = xsimd::batch<uint32_t, A>;
    using I = xsimd::batch<int32_t, A>;
    using M = xsimd::batch_bool<float, A>;
    static constexpr int32_t K = int32_t(F::size);

    const FlatScene& scene;
    PathPool& pool;
    WavefrontCounters& counters;
    int32_t live = 0;                       // paths in [0, live) are in flight
    const WavefrontGuide* guide = nullptr;  // a guided render's camera paths (job.h)

    int32_t rounded_up(int32_t n) const { return (n + K - 1) / K * K; }

    // Lane i of batch starting at `base` is a live path
    M live_mask(int32_t base) const { return lane_index() < F(float(live - base)); }

    // 0, 1, ..., K-1 as floats (one load of a constant, not an array built per call)
    static F lane_index() { return F::load_aligned(kLaneIndex); }
    // base, base+1, ..., base+K-1
    static I lane_ids(int32_t base) { return I::load_aligned(kLaneIds) + I(base); }

private:
    alignas(64) static constexpr float kLaneIndex[16] = {0, 1, 2,  3,  4,  5,  6,  7,
                                                         8, 9, 10, 11, 12, 13, 14, 15};
    alignas(64) static constexpr int32_t kLaneIds[16] = {0, 1, 2,  3,  4,  5,  6,  7,
                                                         8, 9, 10, 11, 12, 13, 14, 15};
};

// ---- Loads, stores, gathers of vectors of lanes -----------------------------------------
// The random-number stream of batch i's paths (the index is read only by the samplers that
// use it).
template <class A>
SampleStream<xsimd::batch<float, A>> stream_at(const FlatScene& s, const PathPool& p, int32_t i) {
    using U = xsimd::batch<uint32_t, A>;
    return {U::load_aligned(p.key + i),
            s.path.sampler.kind == Sampler::kIndependent ? U(0u) : U::load_aligned(p.index + i),
            s.path.sampler};
}

template <class F>
Vec3<F> load3(const float* x, const float* y, const float* z, int32_t i) {
    return {F::load_aligned(x + i), F::load_aligned(y + i), F::load_aligned(z + i)};
}
template <class F>
void store3(const Vec3<F>& v, float* x, float* y, float* z, int32_t i) {
    v.x.store_aligned(x + i), v.y.store_aligned(y + i), v.z.store_aligned(z + i);
}
template <class F, class I>
void scatter3(const Vec3<F>& v, float* x, float* y, float* z, const I& idx) {
    v.x.scatter(x, idx), v.y.scatter(y, idx), v.z.scatter(z, idx);
}

// ---- Table look-ups ---------------------------------------------------------------------
// A table of at most K entries (materials, planes) sits in one register and is indexed by a
// permute; a larger one is read with gather_table (kernels/lanes.h: the hardware gather,
// where there is one). Tables are padded to a multiple of 16.
template <class A, class T>
xsimd::batch<T, A> lookup(const T* table, int32_t count, const xsimd::batch<int32_t, A>& idx) {
    using B = xsimd::batch<T, A>;
    constexpr int32_t K = int32_t(B::size);
#if defined(__AVX512F__)
    if constexpr (std::is_base_of_v<xsimd::avx512f, A>) {
        if (count <= K) {
            if constexpr (std::is_same_v<T, float>)
                return B(_mm512_permutexvar_ps(idx.data, _mm512_loadu_ps(table)));
            else
                return B(_mm512_permutexvar_epi32(idx.data, _mm512_loadu_si512(table)));
        }
    }
#endif
#if defined(__AVX2__)
    if constexpr (std::is_base_of_v<xsimd::avx2, A> && !std::is_base_of_v<xsimd::avx512f, A>) {
        if (count <= K) {
            if constexpr (std::is_same_v<T, float>)
                return B(_mm256_permutevar8x32_ps(_mm256_loadu_ps(table), idx.data));
            else
                return B(_mm256_permutevar8x32_epi32(
                    _mm256_loadu_si256(reinterpret_cast<const __m256i*>(table)), idx.data));
        }
    }
#endif
    (void)count;
    (void)K;
    return gather_table(table, idx);
}
// A gather from a per-path array (any size).
template <class A, class T>
xsimd::batch<T, A> gather_lanes(const T* array, const xsimd::batch<int32_t, A>& idx) {
    return gather_table(array, idx);
}

// ---- Mesh vertices ------------------------------------------------------------------------
// Points `pos` of lanes on mesh m in the space of its vertices: as they are, or for an
// instance (whose vertices stay in the file's space) through its to_object map.
template <class F>
Vec3<F> mesh_space_point(const FlatMesh& m, const Vec3<F>& pos) {
    const float* m4 = m.to_object;
    if (!m4) return pos;
    return {fma(F(m4[0]), pos.x, fma(F(m4[1]), pos.y, fma(F(m4[2]), pos.z, F(m4[3])))),
            fma(F(m4[4]), pos.x, fma(F(m4[5]), pos.y, fma(F(m4[6]), pos.z, F(m4[7])))),
            fma(F(m4[8]), pos.x, fma(F(m4[9]), pos.y, fma(F(m4[10]), pos.z, F(m4[11]))))};
}

// A per-vertex attribute (x, y, z per vertex: positions, colours, normals) of corner k of
// each lane's triangle, whose first corner is at `corner` (3 × the triangle index).
template <class A>
Vec3<xsimd::batch<float, A>> gather_corner(const FlatMesh& m, const float* attribute,
                                           const xsimd::batch<int32_t, A>& corner, int k) {
    using I = xsimd::batch<int32_t, A>;
    const I at = gather_lanes<A>(m.indices, corner + I(k)) * I(3);
    return {gather_lanes<A>(attribute, at), gather_lanes<A>(attribute, at + I(1)),
            gather_lanes<A>(attribute, at + I(2))};
}

// ---- Compression ------------------------------------------------------------------------
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
        const __m256i idx =
            _mm256_and_si256(_mm256_srlv_epi32(_mm256_set1_epi32(int(kCompressNibbles[bits])),
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

// The paths of batch `i` set in `ended` whose radiance `rad` is not zero (or not finite), to
// the film's queue at p.done_*[done...]: the film has counted every path of the tile, so
// those that bring nothing need not be handed over. Returns the new queue length.
template <class A>
int32_t queue_radiant(PathPool& p, int32_t i, uint32_t ended,
                      const Vec3<xsimd::batch<float, A>>& rad, int32_t done) {
    using F = xsimd::batch<float, A>;
    using U = xsimd::batch<uint32_t, A>;
    const uint32_t bits =
        ended & ~mask_bits((rad.x == F(0.0f)) & (rad.y == F(0.0f)) & (rad.z == F(0.0f)));
    if (!bits) return done;
    compress<A>(U::load_aligned(p.pixel + i), bits).store_unaligned(p.done_pixel + done);
    compress<A>(rad.x, bits).store_unaligned(p.done_r + done);
    compress<A>(rad.y, bits).store_unaligned(p.done_g + done);
    compress<A>(rad.z, bits).store_unaligned(p.done_b + done);
    return done + std::popcount(bits);
}

// Appends the indices base + l of the lanes set in `bits` to list[size...].
inline void append_lanes(uint32_t bits, int32_t base, int32_t* list, int32_t& size) {
    while (bits) {
        list[size++] = base + std::countr_zero(bits);
        bits &= bits - 1;
    }
}

}  // namespace CIERZO_ISA_NAMESPACE
}  // namespace cierzo
