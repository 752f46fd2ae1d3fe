// The per-ISA entry points of the wavefront kernels: one object file each, built with that
// instruction set's flags (isa/avx512.cpp, isa/avx2.cpp, isa/sse42.cpp on x86-64, isa/neon.cpp on
// aarch64, with the parts of isa/parts.h). Only the entry of an ISA that isa_supported() accepts
// may be called.
#pragma once

#include <cstddef>
#include <cstdint>

#include "integrators/wavefront/job.h"
#include "integrators/wavefront/isa.h"
#include "integrators/wavefront/path_pool.h"

namespace cierzo {

using RenderTileEntry = void (*)(const FlatScene&, PathPool&, const TileJob&, WavefrontCounters&);

// Closest hits of rays (seven columns: origin, direction, tmax; job.h, trace_stride) through
// the scene: the traversal alone (`cierzo trace`).
using TraceRaysEntry = void (*)(const FlatScene&, const float*, size_t, const TraceOptions&,
                                TraceTotals&);

#if defined(__x86_64__) || defined(__i386__)
void render_tile_avx512(const FlatScene&, PathPool&, const TileJob&, WavefrontCounters&);
void render_tile_avx2(const FlatScene&, PathPool&, const TileJob&, WavefrontCounters&);
void render_tile_sse42(const FlatScene&, PathPool&, const TileJob&, WavefrontCounters&);
void trace_rays_avx512(const FlatScene&, const float*, size_t, const TraceOptions&, TraceTotals&);
void trace_rays_avx2(const FlatScene&, const float*, size_t, const TraceOptions&, TraceTotals&);
void trace_rays_sse42(const FlatScene&, const float*, size_t, const TraceOptions&, TraceTotals&);
#elif defined(__aarch64__)
void render_tile_neon(const FlatScene&, PathPool&, const TileJob&, WavefrontCounters&);
void trace_rays_neon(const FlatScene&, const float*, size_t, const TraceOptions&, TraceTotals&);
#endif

}  // namespace cierzo
