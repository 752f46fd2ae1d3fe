// Which instruction sets this build has and this CPU runs (see isa.h).
#include "integrators/wavefront/isa.h"

#include <array>
#include <span>
#include <vector>

#include "core/error.h"

namespace cierzo {

namespace {

// (CIERZO_BUILT_<ISA> and CIERZO_BUILT_ISAS come from CMake's CIERZO_ISAS)
#if !defined(CIERZO_BUILT_AVX512) || !defined(CIERZO_BUILT_AVX2) || \
    !defined(CIERZO_BUILT_SSE42) || !defined(CIERZO_BUILT_NEON) || !defined(CIERZO_BUILT_ISAS)
#error "CIERZO_BUILT_<ISA> and CIERZO_BUILT_ISAS must be defined (CMakeLists.txt sets them)"
#endif
#if defined(__x86_64__) || defined(__i386__)
constexpr Isa kTarget[] = {Isa::kAvx512, Isa::kAvx2, Isa::kSse42};
constexpr Isa kCompiled[] = {
#if CIERZO_BUILT_AVX512
    Isa::kAvx512,
#endif
#if CIERZO_BUILT_AVX2
    Isa::kAvx2,
#endif
#if CIERZO_BUILT_SSE42
    Isa::kSse42,
#endif
};
constexpr const char* kBuild = "an x86-64 build";
#elif defined(__aarch64__)
constexpr Isa kTarget[] = {Isa::kNeon};
constexpr Isa kCompiled[] = {
#if CIERZO_BUILT_NEON
    Isa::kNeon,
#endif
};
constexpr const char* kBuild = "an aarch64 build";
#else
#error "cierzo's wavefront kernels are built for x86-64 and aarch64 only"
#endif

bool in(std::span<const Isa> set, Isa isa) {
    for (Isa c : set)
        if (c == isa) return true;
    return false;
}
bool compiled(Isa isa) { return in(kCompiled, isa); }

// The CPU features an ISA's kernels are compiled for (the -m flags of its object)
std::vector<const char*> missing_features(Isa isa) {
    std::vector<const char*> missing;
#if defined(__x86_64__) || defined(__i386__)
    // Before any constructor has run (the per-ISA benchmark programs' guard) the CPU's
    // features must be read first; after that this does nothing
    __builtin_cpu_init();
    // __builtin_cpu_supports takes string literals only, hence one line per feature
#define CIERZO_NEED(name) \
    if (!__builtin_cpu_supports(name)) missing.push_back(name)
    switch (isa) {
        case Isa::kAvx512:
            CIERZO_NEED("avx512f");
            CIERZO_NEED("avx512bw");
            CIERZO_NEED("avx512dq");
            CIERZO_NEED("avx512vl");
            CIERZO_NEED("avx512cd");
            CIERZO_NEED("fma");
            break;
        case Isa::kAvx2:
            CIERZO_NEED("avx2");
            CIERZO_NEED("fma");
            break;
        case Isa::kSse42: CIERZO_NEED("sse4.2"); break;
        default: break;
    }
#undef CIERZO_NEED
#else
    (void)isa;  // Advanced SIMD (NEON) is part of every ARMv8-A CPU
#endif
    return missing;
}

}  // namespace

std::span<const Isa> compiled_isas() { return kCompiled; }

bool isa_supported(Isa isa) {
    if (isa == Isa::kAuto) return true;
    return compiled(isa) && missing_features(isa).empty();
}

std::string isa_unsupported_reason(Isa isa) {
    if (isa == Isa::kAuto) return "";
    if (!in(kTarget, isa)) {
        const bool x86 = isa == Isa::kAvx512 || isa == Isa::kAvx2 || isa == Isa::kSse42;
        return isa_name(isa) + " is " + (x86 ? "an x86-64" : "an aarch64") +
               " instruction set and this is " + kBuild;
    }
    if (!compiled(isa))
        return isa_name(isa) +
               " kernels are not in this build (it was configured with "
               "CIERZO_ISAS for " CIERZO_BUILT_ISAS " only)";
    const std::vector<const char*> missing = missing_features(isa);
    if (missing.empty()) return "";
    std::string why = "this CPU lacks";
    for (size_t i = 0; i < missing.size(); ++i) why += (i ? ", " : " ") + std::string(missing[i]);
    return why;
}

Isa best_isa() {
    for (Isa isa : kCompiled)
        if (isa_supported(isa)) return isa;
    // The last ISA is the build's baseline (SSE4.2 on x86-64; a CPU without it is refused
    // when a renderer is made, with the reason)
    return kCompiled[std::size(kCompiled) - 1];
}

std::string isa_name(Isa isa) {
    switch (isa) {
        case Isa::kAuto: return "auto";
        case Isa::kAvx512: return "avx512";
        case Isa::kAvx2: return "avx2";
        case Isa::kSse42: return "sse4.2";
        case Isa::kNeon: return "neon";
    }
    return "?";
}

std::string usable_isa_names() {
    std::string names = "auto";
    for (Isa isa : kCompiled)
        if (isa_supported(isa)) names += ", " + isa_name(isa);
    return names;
}

Isa parse_isa(const std::string& name) {
    for (Isa isa : {Isa::kAuto, Isa::kAvx512, Isa::kAvx2, Isa::kSse42, Isa::kNeon})
        if (name == isa_name(isa)) return isa;
    throw InputError("unknown ISA '" + name + "' (valid here: " + usable_isa_names() + ")");
}

void require_isa(Isa isa, const std::string& what) {
    const std::string why = isa_unsupported_reason(isa);
    if (!why.empty())
        throw InputError(what + " " + isa_name(isa) + ": " + why +
                         " (valid here: " + usable_isa_names() + ")");
}

int isa_width(Isa isa) {
    switch (isa) {
        case Isa::kAvx512: return 16;
        case Isa::kAvx2: return 8;
        case Isa::kAuto: return isa_width(best_isa());
        default: return 4;
    }
}

}  // namespace cierzo
