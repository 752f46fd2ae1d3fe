// How a test starts one of cierzo's programs: directly in a native build, through the
// emulator in a cross build (CIERZO_TEST_EMULATOR, e.g. "qemu-aarch64 -L /", set by
// tests/CMakeLists.txt; the host cannot execute the target's programs itself).
#pragma once

#include <cstdlib>
#include <sstream>
#include <string>
#include <vector>

namespace cierzo::test {

// The emulator's command line, one word per entry; empty in a native build.
inline std::vector<std::string> emulator_words() {
    std::vector<std::string> words;
    std::istringstream in(CIERZO_TEST_EMULATOR);
    for (std::string w; in >> w;) words.push_back(w);
    return words;
}

// `program` (already quoted for the shell) prefixed by the emulator, for std::system.
inline std::string emulated(const std::string& program) {
    const std::string emulator = CIERZO_TEST_EMULATOR;
    return emulator.empty() ? program : emulator + " " + program;
}

// Whether the suite runs with its lighter settings (CIERZO_TEST_EMULATED=1, set by the qemu
// and sanitizer jobs, whose code runs tens of times slower than natively): tests that say
// so use fewer paths, rays or pixels, and still fail as they would on what they check.
inline bool lighter_settings() {
    const char* e = std::getenv("CIERZO_TEST_EMULATED");
    return e != nullptr && *e != '\0' && *e != '0';
}

}  // namespace cierzo::test
