// xsimd 8.1, with NEON float arithmetic that computes what the x86-64 ISAs compute. Its
// neon64 batches divide and take square roots by reciprocal estimates and Newton steps (not
// correctly rounded, and sqrt(inf) is NaN), and its min and max return NaN when either
// operand is one, where SSE's minps and maxps return the second operand. Here they are
// vdivq_f32 and vsqrtq_f32, correctly rounded like divps and sqrtps, and a < b ? a : b and
// a > b ? a : b, like minps and maxps. Include this, never <xsimd/xsimd.hpp>: xsimd's
// templates find these overloads only if they are declared before xsimd's headers are read.
#pragma once

// (read first, or a unit would mix the two: its code before this header would divide by
// estimates, and two units of one build could compute the same function differently)
#if defined(XSIMD_HPP) && defined(__aarch64__)
#error "xsimd/xsimd.hpp was read before kernels/xsimd_neon_ieee.h: include kernels/lanes.h"
#endif

#include <cstddef>

#include <xsimd/config/xsimd_config.hpp>

#if XSIMD_WITH_NEON64
#include <xsimd/types/xsimd_neon64_register.hpp>

namespace xsimd {
template <class T, class A>
class batch;
namespace kernel {
// For neon64 these match better than xsimd's own, which take requires_arch<neon>
template <class A>
inline batch<float, A> div(const batch<float, A>& lhs, const batch<float, A>& rhs,
                           requires_arch<neon64>) noexcept;
template <class A>
inline batch<float, A> sqrt(const batch<float, A>& x, requires_arch<neon64>) noexcept;
template <class A>
inline batch<float, A> min(const batch<float, A>& lhs, const batch<float, A>& rhs,
                           requires_arch<neon64>) noexcept;
template <class A>
inline batch<float, A> max(const batch<float, A>& lhs, const batch<float, A>& rhs,
                           requires_arch<neon64>) noexcept;
}  // namespace kernel
}  // namespace xsimd
#endif

#include <xsimd/xsimd.hpp>

#if XSIMD_WITH_NEON64
namespace xsimd::kernel {
template <class A>
inline batch<float, A> div(const batch<float, A>& lhs, const batch<float, A>& rhs,
                           requires_arch<neon64>) noexcept {
    return vdivq_f32(lhs, rhs);
}
template <class A>
inline batch<float, A> sqrt(const batch<float, A>& x, requires_arch<neon64>) noexcept {
    return vsqrtq_f32(x);
}
template <class A>
inline batch<float, A> min(const batch<float, A>& lhs, const batch<float, A>& rhs,
                           requires_arch<neon64>) noexcept {
    return vbslq_f32(vcltq_f32(lhs, rhs), lhs, rhs);
}
template <class A>
inline batch<float, A> max(const batch<float, A>& lhs, const batch<float, A>& rhs,
                           requires_arch<neon64>) noexcept {
    return vbslq_f32(vcgtq_f32(lhs, rhs), lhs, rhs);
}
}  // namespace xsimd::kernel
#endif
