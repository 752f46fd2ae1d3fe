// The lane abstraction that lets one estimator serve both integrators: every kernel is a
// template on the lane type T, which is `float` for the scalar reference (one path) or
// `xsimd::batch<float, Arch>` for the wavefront kernels (K paths at once). Masks are
// `bool` or `xsimd::batch_bool<float, Arch>`; branches become `select` on a mask.
#pragma once

#include <bit>
#include <cmath>
#include <cstdint>
#include <type_traits>

#include "xsimd_neon_ieee.h"

#include "isa.h"

namespace cierzo {
inline namespace CIERZO_ISA_NAMESPACE {

// ---- Scalar lanes: the same vocabulary xsimd gives batches -------------------------
inline float select(bool m, float a, float b) { return m ? a : b; }
inline uint32_t select(bool m, uint32_t a, uint32_t b) { return m ? a : b; }
inline int32_t select(bool m, int32_t a, int32_t b) { return m ? a : b; }
inline bool any(bool m) { return m; }
inline bool all(bool m) { return m; }
inline bool none(bool m) { return !m; }
inline float fma(float a, float b, float c) { return std::fma(a, b, c); }

using std::abs;
using std::acos;
using std::atan2;
using std::cos;
using std::floor;
using std::max;
using std::min;
using std::sin;
using std::sqrt;
using xsimd::abs;
using xsimd::acos;
using xsimd::all;
using xsimd::any;
using xsimd::atan2;
using xsimd::cos;
using xsimd::floor;
using xsimd::fma;
using xsimd::max;
using xsimd::min;
using xsimd::nearbyint;
using xsimd::none;
using xsimd::select;
using xsimd::sin;
using xsimd::sqrt;

// Mask type of a lane type: bool for float, batch_bool for a batch.
template <class T>
using Mask = decltype(std::declval<T>() < std::declval<T>());

// Lane types of other element types with the same width: uint32 lanes for random-number
// hashing, int32 lanes for indices.
template <class T>
struct LaneOf {
    using u32 = uint32_t;
    using i32 = int32_t;
    static constexpr int width = 1;
};
template <class A>
struct LaneOf<xsimd::batch<float, A>> {
    using u32 = xsimd::batch<uint32_t, A>;
    using i32 = xsimd::batch<int32_t, A>;
    static constexpr int width = int(xsimd::batch<float, A>::size);
};
template <class T>
using U32 = typename LaneOf<T>::u32;
template <class T>
using I32 = typename LaneOf<T>::i32;
template <class T>
inline constexpr int kWidth = LaneOf<T>::width;

// The constant kValue in every lane of U (uint32_t, int32_t or a batch of them): for batches
// a load from a table, which the arithmetic takes as a memory operand, where GCC would
// otherwise build the vector from an immediate with two FP-pipe moves at every use (the
// hashes' multipliers). The table is deliberately not const: GCC folds a const one back
// into the immediate form. Nothing writes it.
template <class U, auto kValue>
inline U splat() {
    if constexpr (std::is_arithmetic_v<U>) {
        return U(kValue);
    } else {
        using E = typename U::value_type;
        alignas(64) static E kTable[16] = {
            E(kValue), E(kValue), E(kValue), E(kValue), E(kValue), E(kValue), E(kValue), E(kValue),
            E(kValue), E(kValue), E(kValue), E(kValue), E(kValue), E(kValue), E(kValue), E(kValue)};
        return U::load_aligned(kTable);
    }
}

// Reinterpret and convert between lanes of one width.
inline float to_float(uint32_t v) { return float(v); }
inline float to_float(int32_t v) { return float(v); }
template <class A>
inline xsimd::batch<float, A> to_float(const xsimd::batch<uint32_t, A>& v) {
    // Values used here stay below 2^31, so a signed conversion is exact enough.
    return xsimd::batch_cast<float>(xsimd::bitwise_cast<xsimd::batch<int32_t, A>>(v));
}
template <class A>
inline xsimd::batch<float, A> to_float(const xsimd::batch<int32_t, A>& v) {
    return xsimd::batch_cast<float>(v);
}

// A mask of float lanes as a mask of 32-bit integer lanes of the same width. Where both
// masks have one register type (AVX-512's k-register, NEON's uint32x4_t) it is taken as it
// is; on SSE/AVX the bits are reinterpreted, never recomputed.
template <class To, class From, class A>
inline xsimd::batch_bool<To, A> mask_cast_to(const xsimd::batch_bool<From, A>& m) {
    using TB = xsimd::batch_bool<To, A>;
    using FB = xsimd::batch_bool<From, A>;
    if constexpr (std::is_same_v<typename TB::register_type, typename FB::register_type>) {
        return TB(m.data);
    } else {
        return TB(xsimd::bitwise_cast<xsimd::batch<To, A>>(xsimd::batch<From, A>(m.data)).data);
    }
}
// Not of a mask. In a vector register (SSE, AVX, NEON) it is one xor with all ones (xsimd
// 8.1's own `!` on AVX compares the two halves as integers, six instructions); AVX-512's
// k-registers keep xsimd's `!`, as its `^` on them is wrong (it returns all ones for
// all-ones ^ all-ones).
inline bool mask_not(bool m) { return !m; }
template <class T, class A>
inline xsimd::batch_bool<T, A> mask_not(const xsimd::batch_bool<T, A>& m) {
    using M = xsimd::batch_bool<T, A>;
    if constexpr (std::is_integral_v<typename M::register_type>) {
        return !m;
    } else {
        return m ^ M(true);
    }
}
inline bool mask_u32(bool m) { return m; }
inline bool mask_i32(bool m) { return m; }
inline bool mask_f32(bool m) { return m; }
template <class A>
inline xsimd::batch_bool<float, A> mask_f32(const xsimd::batch_bool<int32_t, A>& m) {
    return mask_cast_to<float>(m);
}
template <class A>
inline xsimd::batch_bool<uint32_t, A> mask_u32(const xsimd::batch_bool<float, A>& m) {
    return mask_cast_to<uint32_t>(m);
}
template <class A>
inline xsimd::batch_bool<int32_t, A> mask_i32(const xsimd::batch_bool<float, A>& m) {
    return mask_cast_to<int32_t>(m);
}

// Bit reinterpretation between float and int32 lanes, and float -> int truncation.
inline int32_t as_int(float v) { return std::bit_cast<int32_t>(v); }
inline float as_float(int32_t v) { return std::bit_cast<float>(v); }
inline int32_t to_int(float v) { return int32_t(v); }
template <class A>
inline xsimd::batch<int32_t, A> as_int(const xsimd::batch<float, A>& v) {
    return xsimd::bitwise_cast<xsimd::batch<int32_t, A>>(v);
}
template <class A>
inline xsimd::batch<float, A> as_float(const xsimd::batch<int32_t, A>& v) {
    return xsimd::bitwise_cast<xsimd::batch<float, A>>(v);
}
template <class A>
inline xsimd::batch<int32_t, A> to_int(const xsimd::batch<float, A>& v) {
    return xsimd::batch_cast<int32_t>(v);
}

// Bits of a mask, lane 0 in bit 0 (a bool is one lane). NEON has no movemask: each all-ones lane
// keeps its own bit of {1, 2, 4, 8}, and the lanes are summed.
template <class A>
uint32_t mask_bits(const xsimd::batch_bool<float, A>& m) {
#if defined(__AVX512F__)
    if constexpr (std::is_base_of_v<xsimd::avx512f, A>) return uint32_t(m.data);
#endif
#if defined(__AVX__)
    if constexpr (std::is_base_of_v<xsimd::avx, A> && !std::is_base_of_v<xsimd::avx512f, A>)
        return uint32_t(_mm256_movemask_ps(m.data));
#endif
#if defined(__SSE2__)
    if constexpr (!std::is_base_of_v<xsimd::avx, A> && !std::is_base_of_v<xsimd::avx512f, A>)
        return uint32_t(_mm_movemask_ps(m.data));
#endif
#if defined(__aarch64__)
    if constexpr (std::is_base_of_v<xsimd::neon64, A>) {
        constexpr uint32x4_t kLaneBits = {1u, 2u, 4u, 8u};
        return vaddvq_u32(vandq_u32(m.data, kLaneBits));
    }
#endif
}
inline uint32_t mask_bits(bool m) { return m ? 1u : 0u; }

// The mask whose lane l is bit l of `bits` (mask_bits' inverse; rare paths only).
template <class T>
inline Mask<T> lanes_of_bits(uint32_t bits) {
    if constexpr (std::is_same_v<T, float>) {
        return (bits & 1u) != 0;
    } else {
        using I = xsimd::batch<int32_t, typename T::arch_type>;
        alignas(64) int32_t lane[T::size];
        for (size_t l = 0; l < T::size; ++l) lane[l] = int32_t((bits >> l) & 1u);
        return mask_f32(I::load_aligned(lane) != I(0));
    }
}

// table[idx] in every lane: a plain load for one lane, the hardware gather where there is
// one (xsimd 8.1 emulates gather lane by lane), four lane loads on SSE and NEON.
template <class E>
inline E gather_table(const E* table, int32_t idx) {
    return table[idx];
}
template <class E, class A>
inline xsimd::batch<E, A> gather_table(const E* table, const xsimd::batch<int32_t, A>& idx) {
    using B = xsimd::batch<E, A>;
    static_assert(sizeof(E) == 4);
#if defined(__AVX512F__)
    if constexpr (std::is_base_of_v<xsimd::avx512f, A>) {
        if constexpr (std::is_same_v<E, float>)
            return B(_mm512_i32gather_ps(idx.data, table, 4));
        else
            return B(_mm512_i32gather_epi32(idx.data, table, 4));
    }
#endif
#if defined(__AVX2__)
    if constexpr (std::is_base_of_v<xsimd::avx2, A> && !std::is_base_of_v<xsimd::avx512f, A>) {
        if constexpr (std::is_same_v<E, float>)
            return B(_mm256_i32gather_ps(table, idx.data, 4));
        else
            return B(_mm256_i32gather_epi32(reinterpret_cast<const int*>(table), idx.data, 4));
    }
#endif
    return B::gather(table, idx);
}

}  // namespace CIERZO_ISA_NAMESPACE
}  // namespace cierzo
