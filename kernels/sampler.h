// The samplers: where the uniform numbers of a path come from (render.sampler, --sampler).
//
// Every number is still a pure function of (seed, pixel, sample, bounce, purpose), so an
// image does not depend on threads, ranks, stops or resumes, and both integrators draw the
// same numbers for the same path vertex.
//
// - independent: rng.h's hash of those five, as the report's renderer draws them.
// - sobol: the numbers of one bounce come in 2D pairs (the "slots" below). Each pair of each
//   bounce is the 2D Sobol (0,2) sequence (dimensions 0 and 1), its index shuffled and its
//   values Owen-scrambled with hash-based nested uniform scrambling (Burley, "Practical
//   Hash-based Owen Scrambling", JCGT 2020) seeded by (seed, pixel, pair). The pairs of a
//   pixel are thus independent of each other ("padding"), and the first 2^k samples of a
//   pixel in every pair are a (0,k,2)-net: stratified in every elementary interval.
// - zsobol: one Sobol sequence over the whole image (Ahmed and Wonka, "Screen-Space Blue-Noise
//   Diffusion of Monte Carlo Sampling Error via Hierarchical Ordering of Pixels", 2020): pixel
//   p's samples are the block of indices morton(p) · 2^L + [0, 2^L), L = log2 of the render's
//   paths per pixel rounded up, with the Morton digits permuted per pair by a nested scramble
//   (neighbouring pixels then hold neighbouring blocks, whose union is a finer net). The
//   points depend on the render's paths per pixel.
// - pmj02: progressive multi-jittered (0,2) points (Christensen, Kensler and Kilpatrick 2018)
//   from kPmj02Tables tables of kPmj02Points made once (src/scene/pmj02.cpp); the table, the
//   index's shuffle and the values' scramble chosen per (seed, pixel, pair) as for sobol.
//   Samples past a table's end continue in another table.
//
// The slots of one bounce (docs/estimators.md, "samplers"):
//   0: the pixel jitter (x, y)                      (bounce 0 only)
//   1: the lobe choice, the throughput roulette's draw
//   2: the direction in the chosen lobe (u1, u2)
//   3: which emitter, and its alias slot
//   4: the point or direction on it (u1, u2)
// A light path's numbers are those of its own key (light_stream), in the same slots.
#pragma once

#include "rng.h"
#include "settings.h"

namespace cierzo {
inline namespace CIERZO_ISA_NAMESPACE {

inline constexpr uint32_t kSlotsPerBounce = 5;

// The numbers of one path: for independent, `key` is rng.h's path key; for sobol and pmj02,
// the pixel's key and the sample's index; for zsobol, the seed's key and the image-wide
// index.
template <class T>
struct SampleStream {
    U32<T> key;
    U32<T> index;
    SamplerSetup sampler;
};

// The slot of a purpose and whether it is the pair's second number.
inline constexpr uint32_t slot_of(Purpose p) {
    constexpr uint32_t kSlot[kPurposesPerBounce] = {0, 0, 1, 2, 2, 3, 4, 4};
    return kSlot[uint32_t(p)];
}
inline constexpr bool second_of(Purpose p) {
    return p == Purpose::kPixelY || p == Purpose::kDirection2 || p == Purpose::kEmitter2;
}

// ---- bit manipulation (scalar and lanes alike) ----

// The bits of each 32-bit lane in reverse order. The lanes reverse each byte's bits with two
// nibble lookups and then the bytes (a byte shuffle; NEON has both as instructions); one
// value uses shifts.
inline uint32_t reverse_bits(uint32_t x) {
    x = ((x >> 1) & 0x55555555u) | ((x & 0x55555555u) << 1);
    x = ((x >> 2) & 0x33333333u) | ((x & 0x33333333u) << 2);
    x = ((x >> 4) & 0x0f0f0f0fu) | ((x & 0x0f0f0f0fu) << 4);
    return __builtin_bswap32(x);
}
template <class A>
inline xsimd::batch<uint32_t, A> reverse_bits_by_shifts(xsimd::batch<uint32_t, A> x) {
    using U = xsimd::batch<uint32_t, A>;
    x = ((x >> 1) & U(0x55555555u)) | ((x & U(0x55555555u)) << 1);
    x = ((x >> 2) & U(0x33333333u)) | ((x & U(0x33333333u)) << 2);
    x = ((x >> 4) & U(0x0f0f0f0fu)) | ((x & U(0x0f0f0f0fu)) << 4);
    x = ((x >> 8) & U(0x00ff00ffu)) | ((x & U(0x00ff00ffu)) << 8);
    return (x >> 16) | (x << 16);
}
template <class A>
inline xsimd::batch<uint32_t, A> reverse_bits(const xsimd::batch<uint32_t, A>& v) {
#if defined(__aarch64__)
    if constexpr (std::is_base_of_v<xsimd::neon64, A>)
        return xsimd::batch<uint32_t, A>(
            vreinterpretq_u32_u8(vrev32q_u8(vrbitq_u8(vreinterpretq_u8_u32(v.data)))));
    else
        return reverse_bits_by_shifts(v);
#elif defined(__SSSE3__)
    // Nibble n reversed, in the high and the low half of a byte; bytes 3,2,1,0 of each lane
    const __m128i high =
        _mm_setr_epi8(0x00, char(0x80), 0x40, char(0xc0), 0x20, char(0xa0), 0x60, char(0xe0), 0x10,
                      char(0x90), 0x50, char(0xd0), 0x30, char(0xb0), 0x70, char(0xf0));
    const __m128i low = _mm_setr_epi8(0x0, 0x8, 0x4, 0xc, 0x2, 0xa, 0x6, 0xe, 0x1, 0x9, 0x5, 0xd,
                                      0x3, 0xb, 0x7, 0xf);
    const __m128i swap = _mm_setr_epi8(3, 2, 1, 0, 7, 6, 5, 4, 11, 10, 9, 8, 15, 14, 13, 12);
#if defined(__AVX512BW__)
    if constexpr (std::is_base_of_v<xsimd::avx512bw, A>) {
        const __m512i nib = _mm512_set1_epi8(0x0f);
        const __m512i lo = _mm512_and_si512(v.data, nib);
        const __m512i hi = _mm512_and_si512(_mm512_srli_epi16(v.data, 4), nib);
        const __m512i r = _mm512_or_si512(_mm512_shuffle_epi8(_mm512_broadcast_i32x4(high), lo),
                                          _mm512_shuffle_epi8(_mm512_broadcast_i32x4(low), hi));
        return xsimd::batch<uint32_t, A>(_mm512_shuffle_epi8(r, _mm512_broadcast_i32x4(swap)));
    } else
#endif
#if defined(__AVX2__)
        if constexpr (std::is_base_of_v<xsimd::avx2, A> && !std::is_base_of_v<xsimd::avx512f, A>) {
        const __m256i nib = _mm256_set1_epi8(0x0f);
        const __m256i lo = _mm256_and_si256(v.data, nib);
        const __m256i hi = _mm256_and_si256(_mm256_srli_epi16(v.data, 4), nib);
        const __m256i r =
            _mm256_or_si256(_mm256_shuffle_epi8(_mm256_broadcastsi128_si256(high), lo),
                            _mm256_shuffle_epi8(_mm256_broadcastsi128_si256(low), hi));
        return xsimd::batch<uint32_t, A>(_mm256_shuffle_epi8(r, _mm256_broadcastsi128_si256(swap)));
    } else
#endif
        if constexpr (std::is_base_of_v<xsimd::sse2, A> && !std::is_base_of_v<xsimd::avx, A>) {
        const __m128i nib = _mm_set1_epi8(0x0f);
        const __m128i lo = _mm_and_si128(v.data, nib);
        const __m128i hi = _mm_and_si128(_mm_srli_epi16(v.data, 4), nib);
        const __m128i r = _mm_or_si128(_mm_shuffle_epi8(high, lo), _mm_shuffle_epi8(low, hi));
        return xsimd::batch<uint32_t, A>(_mm_shuffle_epi8(r, swap));
    } else {
        return reverse_bits_by_shifts(v);
    }
#else
    return reverse_bits_by_shifts(v);
#endif
}

// Laine and Karras's permutation as Burley gives it: output bit k depends only on input
// bits 0..k, so on reversed bits it is a nested uniform (Owen) scramble.
template <class U>
inline U laine_karras(U x, const U& seed) {
    x += seed;
    x ^= x * splat<U, 0x6c50b47cu>();
    x ^= x * splat<U, 0xb82f1e52u>();
    x ^= x * splat<U, 0xc7afe638u>();
    x ^= x * splat<U, 0x8d22f6e6u>();
    return x;
}

// Owen scrambling of a 32-bit fixed-point value in [0, 1): bit j (from the top) flipped by a
// hash of the bits above it.
template <class U>
inline U owen_scramble(const U& v, const U& seed) {
    return reverse_bits(laine_karras(reverse_bits(v), seed));
}

// The i-th point of Sobol's dimension 1 in 32-bit fixed point. Its generator matrix is
// Pascal's triangle mod 2: bit j of i contributes to output bit (31 - k) for every k whose
// bits are a subset of j's (Lucas), a superset sum over bit positions.
template <class U>
inline U sobol1(U i) {
    i ^= (i >> 1) & splat<U, 0x55555555u>();
    i ^= (i >> 2) & splat<U, 0x33333333u>();
    i ^= (i >> 4) & splat<U, 0x0f0f0f0fu>();
    i ^= (i >> 8) & splat<U, 0x00ff00ffu>();
    i ^= (i >> 16) & splat<U, 0x0000ffffu>();
    return reverse_bits(i);
}

// Bits 0..15 of x spread to the even bits (for Morton codes).
template <class U>
inline U spread_bits(U x) {
    x &= splat<U, 0x0000ffffu>();
    x = (x | (x << 8)) & splat<U, 0x00ff00ffu>();
    x = (x | (x << 4)) & splat<U, 0x0f0f0f0fu>();
    x = (x | (x << 2)) & splat<U, 0x33333333u>();
    x = (x | (x << 1)) & splat<U, 0x55555555u>();
    return x;
}

// table[at] in every lane.
template <class T>
inline U32<T> gather_u32(const uint32_t* table, const U32<T>& at) {
    if constexpr (std::is_same_v<T, float>)
        return table[at];
    else
        return gather_table(table, xsimd::bitwise_cast<I32<T>>(at));
}

// ---- the streams ----

// The key of a pixel for the samplers whose scramble is per pixel (sobol, pmj02).
template <class U>
inline U pixel_key(uint32_t seed, const U& pixel) {
    const U s(hash32(seed ^ 0xbb67ae85u));
    return hash32(hash32(pixel ^ s) ^ splat<U, 0x3c6ef372u>());
}

// The numbers of camera sample `sample` of pixel (x, y) (pixel = y · width + x).
template <class T>
inline SampleStream<T> camera_stream(const SamplerSetup& setup, uint32_t seed, const U32<T>& pixel,
                                     const U32<T>& x, const U32<T>& y, const U32<T>& sample) {
    using U = U32<T>;
    switch (setup.kind) {
        case Sampler::kIndependent: return {path_key(seed, pixel, sample), sample, setup};
        case Sampler::kSobol:
        case Sampler::kPmj02: return {pixel_key(seed, pixel), sample, setup};
        case Sampler::kZSobol: {
            // Morton code of (x, y); its bits that do not fit beside the sample's L bits pick the
            // scramble instead (images of more than 2^(32-L) pixels)
            // scramble instead (images of more than 2^(32-L) pixels), as do the samples past 2^L
            // (a render that goes on past the paths per pixel it was set up for)
            const U morton = spread_bits(x) | (spread_bits(y) << 1);
            const uint32_t l = setup.log2_spp;
            const U mask(l >= 32 ? 0xffffffffu : (1u << l) - 1u);
            const U high = l == 0 ? U(0u) : (morton >> (32u - l));
            const U over = l >= 32 ? U(0u) : (sample >> l);
            const U key = hash32(U(hash32(seed ^ 0xa54ff53au)) ^ hash32(high + U(1u)) ^
                                 hash32(over * splat<U, 0x6a09e667u>()));
            return {key, (l >= 32 ? U(0u) : (morton << l)) | (sample & mask), setup};
        }
    }
    return {path_key(seed, pixel, sample), sample, setup};
}

// The independent sampler's numbers for path key `key` (kernels/rng.h).
template <class T>
inline SampleStream<T> independent_stream(const U32<T>& key) {
    return {key, U32<T>(0u), SamplerSetup{}};
}

// The numbers of the path from the lights traced beside a camera sample (light tracing): the
// same index, its own key.
template <class T>
inline SampleStream<T> light_stream(const SampleStream<T>& camera) {
    return {light_path_key(camera.key), camera.index, camera.sampler};
}

// The 2D point of (stream, bounce, slot) in 32-bit fixed point, for the low-discrepancy
// samplers.
template <class T>
inline void sample_point(const SampleStream<T>& s, const U32<T>& bounce, uint32_t slot, U32<T>& x,
                         U32<T>& y) {
    using U = U32<T>;
    const U pair = bounce * U(kSlotsPerBounce) + U(slot);
    const U seed = hash32(s.key ^ (pair * splat<U, 0x9e3779b9u>() + splat<U, 0x7f4a7c15u>()));
    U index = s.index;
    if (s.sampler.kind == Sampler::kZSobol) {
        // The pixel's block moves with a nested scramble of its Morton digits; the samples
        // inside the block are shuffled as sobol's
        const uint32_t l = s.sampler.log2_spp;
        const U low_mask(l >= 32 ? 0xffffffffu : (1u << l) - 1u);
        const U block = l >= 32 ? U(0u) : (s.index >> l);
        const U sample = s.index & low_mask;
        // (a nested scramble keeps a value's bits from j up a function of its own bits from j
        // up: the first 2^k samples stay an aligned block, a quadtree node stays a node). The
        // shuffle inside the block is the pixel's own, so that two pairs' samples meet in a
        // random order in each pixel (with one order for all pixels, the pairs' values would
        // be correlated across the image).
        const U in_block =
            owen_scramble(sample, hash32(seed ^ (block * splat<U, 0x2545f491u>()))) & low_mask;
        const U moved = owen_scramble(block, hash32(seed ^ splat<U, 0x1f83d9abu>()));
        index = (l >= 32 ? U(0u) : (moved << l)) | in_block;
    } else if (s.sampler.kind == Sampler::kSobol) {
        // Burley's shuffle: a nested scramble of the index's reversed bits, so the first 2^k
        // samples are an aligned block of 2^k of the sequence
        index = owen_scramble(s.index, seed);
    }
    // (the values' scrambles: the pair's seed times two odd constants, distinct bijections of
    // it, rather than two more hashes)
    const U sx = seed * splat<U, 0x5be0cd19u>();
    const U sy = seed * splat<U, 0x9b05688du>();
    if (s.sampler.kind == Sampler::kPmj02) {
        constexpr uint32_t kBits = 12;  // log2(kPmj02Points)
        static_assert((1u << kBits) == kPmj02Points);
        // The tables are stratified in every prefix of 2^k points, not in every aligned
        // block, so the index is shuffled only inside each octave [2^h, 2^(h+1)) (the first
        // 2^k samples are then always the table's first 2^k points, in another order)
        const U j = s.index & U(kPmj02Points - 1u);
        U ones = j | (j >> 1);  // 2^(h+1) - 1 for j in [2^h, 2^(h+1))
        ones = ones | (ones >> 2);
        ones = ones | (ones >> 4);
        ones = ones | (ones >> 8);
        const U octave = (ones >> 1) + U(1u);
        const U below = octave - U(1u);
        const U in_octave = owen_scramble(j & below, hash32(seed ^ octave)) & below;
        const U table =
            hash32(seed ^ (s.index >> kBits) ^ splat<U, 0x510e527fu>()) & U(kPmj02Tables - 1u);
        const U at = (table << kBits) | select(j >= U(2u), octave | in_octave, j);
        const U p = gather_u32<T>(s.sampler.pmj02, at);
        // 16 bits from the table, the rest a jitter inside its finest cell
        const U jitter = hash32(seed ^ index);
        x = owen_scramble((p << 16) | (jitter & U(0xffffu)), sx);
        y = owen_scramble((p & splat<U, 0xffff0000u>()) | (jitter >> 16), sy);
        return;
    }
    x = owen_scramble(reverse_bits(index), sx);
    y = owen_scramble(sobol1(index), sy);
}

template <class T>
inline T unit_float(const U32<T>& bits) {
    return to_float(bits >> 8) * T(0x1.0p-24f);
}

// A uniform number in [0, 1) for (stream, bounce, purpose).
template <class T>
inline T uniform(const SampleStream<T>& s, const U32<T>& bounce, Purpose purpose) {
    if (s.sampler.kind == Sampler::kIndependent) return uniform<T>(s.key, bounce, purpose);
    U32<T> x, y;
    sample_point(s, bounce, slot_of(purpose), x, y);
    return unit_float<T>(second_of(purpose) ? y : x);
}

// The two numbers of a pair purpose (kPixelX, kDirection1, kEmitter1) and the one after it.
template <class T>
inline void uniform2(const SampleStream<T>& s, const U32<T>& bounce, Purpose first, T& u, T& v) {
    if (s.sampler.kind == Sampler::kIndependent) {
        u = uniform<T>(s.key, bounce, first);
        v = uniform<T>(s.key, bounce, Purpose(uint32_t(first) + 1u));
        return;
    }
    U32<T> x, y;
    sample_point(s, bounce, slot_of(first), x, y);
    u = unit_float<T>(x);
    v = unit_float<T>(y);
}

// Which emitter and its alias slot (rng.h's uniform_pair for independent).
template <class T>
inline void uniform_pair(const SampleStream<T>& s, const U32<T>& bounce, Purpose purpose, T& u,
                         T& v) {
    if (s.sampler.kind == Sampler::kIndependent)
        return uniform_pair<T>(s.key, bounce, purpose, u, v);
    U32<T> x, y;
    sample_point(s, bounce, slot_of(purpose), x, y);
    u = unit_float<T>(x);
    v = unit_float<T>(y);
}

// The lobe choice's number and, where `roulette` (the throughput roulette), the roulette's
// draw: slot 1's pair, drawn once.
template <class T>
inline void lobe_uniforms(const SampleStream<T>& s, const U32<T>& bounce, bool roulette, T& u_lobe,
                          T& u_roulette) {
    if (s.sampler.kind == Sampler::kIndependent) {
        u_lobe = uniform<T>(s.key, bounce, Purpose::kLobe);
        u_roulette = roulette ? second_uniform<T>(s.key, bounce, Purpose::kLobe) : T(0.0f);
        return;
    }
    U32<T> x, y;
    sample_point(s, bounce, slot_of(Purpose::kLobe), x, y);
    u_lobe = unit_float<T>(x);
    u_roulette = unit_float<T>(y);
}

// The light vertex cache's draw j (from 0, below kMaxLightConnections) at a camera vertex
// of `bounce`: a hash of the stream's key and index (a path's own numbers under every
// sampler), outside every sampler's dimensions, so that no other decision's numbers change.
template <class T>
inline T connection_uniform(const SampleStream<T>& s, const U32<T>& bounce, uint32_t j) {
    using U = U32<T>;
    const U counter = (bounce * U(kMaxLightConnections) + U(j)) * splat<U, 0x27d4eb2fu>() +
                      s.index * splat<U, 0x165667b1u>();
    return unit_float<T>(hash32(s.key ^ hash32(counter ^ splat<U, 0x5bd1e995u>())));
}

// The throughput roulette's draw alone: the lobe slot's second number.
template <class T>
inline T second_uniform(const SampleStream<T>& s, const U32<T>& bounce, Purpose purpose) {
    if (s.sampler.kind == Sampler::kIndependent) return second_uniform<T>(s.key, bounce, purpose);
    U32<T> x, y;
    sample_point(s, bounce, slot_of(purpose), x, y);
    return unit_float<T>(y);
}

}  // namespace CIERZO_ISA_NAMESPACE
}  // namespace cierzo
