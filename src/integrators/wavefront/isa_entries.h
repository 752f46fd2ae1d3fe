// The per-ISA entry points of the wavefront kernels (one object file each, built with that
// instruction set's flags) and the instruction sets this program can run.
#pragma once

#include <string>

#include "integrators/wavefront/flat_scene.h"
#include "integrators/wavefront/path_pool.h"

namespace cierzo {

enum class Isa { kAuto, kAvx512, kAvx2, kSse42 };

void render_tile_avx512(const FlatScene&, PathPool&, const TileJob&, WavefrontCounters&);
void render_tile_avx2(const FlatScene&, PathPool&, const TileJob&, WavefrontCounters&);
void render_tile_sse42(const FlatScene&, PathPool&, const TileJob&, WavefrontCounters&);

// Whether this CPU can run an instruction set; the best it can for kAuto.
bool isa_supported(Isa isa);
Isa best_isa();
// "avx512", "avx2", "sse4.2" (and "auto"); parse_isa throws InputError on anything else.
std::string isa_name(Isa isa);
Isa parse_isa(const std::string& name);
// SIMD lanes of 32-bit floats.
int isa_width(Isa isa);

}  // namespace cierzo
