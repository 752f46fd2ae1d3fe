// The probe behind CIERZO_ISAS=host (CMakeLists.txt): built with isa.cpp and every ISA of
// the target, it prints the ones this machine runs as a CMake list of their build names,
// widest first (e.g. "avx2;sse42").
#include <cstdio>
#include <string>

#include "integrators/wavefront/isa.h"

int main() {
    const char* separator = "";
    for (cierzo::Isa isa : cierzo::compiled_isas()) {
        if (!cierzo::isa_supported(isa)) continue;
        const std::string name = isa == cierzo::Isa::kSse42 ? "sse42" : cierzo::isa_name(isa);
        std::printf("%s%s", separator, name.c_str());
        separator = ";";
    }
    return 0;
}
