// Per-ISA isolation: the kernels are compiled once per instruction set, and each copy lives in
// its own inline namespace (set by -DCIERZO_ISA_NAMESPACE=... on the per-ISA objects), so no
// inline function compiled for AVX-512 can be linked into the SSE or scalar code paths.
#pragma once

#ifndef CIERZO_ISA_NAMESPACE
#define CIERZO_ISA_NAMESPACE generic
#endif
