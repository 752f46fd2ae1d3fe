// The lane architecture of the per-ISA object being compiled, read from the compiler's own
// instruction-set macros, which CMake's per-ISA flags set (CIERZO_ISA_<isa> in
// CMakeLists.txt): so the flags are the one place an object's ISA is named.
#pragma once

#include "kernels/lanes.h"  // (xsimd through it, never directly: xsimd_neon_ieee.h says why)

namespace cierzo {
inline namespace CIERZO_ISA_NAMESPACE {

#if defined(__AVX512BW__)
using IsaArch = xsimd::avx512bw;
#elif defined(__AVX2__) && defined(__FMA__)
using IsaArch = xsimd::fma3<xsimd::avx2>;
#elif defined(__SSE4_2__)
using IsaArch = xsimd::sse4_2;
#elif defined(__aarch64__)
using IsaArch = xsimd::neon64;
#else
#error "a per-ISA wavefront object built without its instruction set's flags"
#endif

}  // namespace CIERZO_ISA_NAMESPACE
}  // namespace cierzo
