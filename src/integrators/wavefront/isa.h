// The instruction sets the wavefront kernels are built for, and which of them this CPU can
// run. Built without any -m flag, so nothing here executes an instruction the CPU may lack:
// the CPU is asked (cpuid on x86-64) before any per-ISA code is entered.
#pragma once

#include <span>
#include <string>

namespace cierzo {

enum class Isa { kAuto, kAvx512, kAvx2, kSse42, kNeon };

// Every ISA this build has kernels for, widest first: avx512, avx2, sse4.2 on x86-64; neon
// on aarch64.
std::span<const Isa> compiled_isas();
// Whether this build has kernels for the ISA and this CPU can run them (kAuto: always).
bool isa_supported(Isa isa);
// Why an ISA cannot run here, e.g. "this CPU lacks avx512f, avx512bw" or "avx512 is an
// x86-64 instruction set and this is an aarch64 build"; empty when it can.
std::string isa_unsupported_reason(Isa isa);
// The widest ISA this CPU can run.
Isa best_isa();
// "auto", "avx512", "avx2", "sse4.2", "neon".
std::string isa_name(Isa isa);
// The ISA of a name; InputError for a name that is none ("unknown ISA 'x' (valid here: …)").
Isa parse_isa(const std::string& name);
// The names this program accepts on this CPU, "auto" first: "auto, avx2, sse4.2".
std::string usable_isa_names();
// An InputError, naming `what` (e.g. "--isa"), unless the ISA can run here.
void require_isa(Isa isa, const std::string& what);
// SIMD lanes of 32-bit floats.
int isa_width(Isa isa);

}  // namespace cierzo
