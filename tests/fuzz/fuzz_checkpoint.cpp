// libFuzzer entry point for the checkpoint reader (read_checkpoint); the body is
// fuzz_one_checkpoint in fuzz_render_targets.cpp. Build with -DCIERZO_BUILD_FUZZERS=ON (clang);
// see docs/fuzzing.md.
#include <cstddef>
#include <cstdint>

#include "fuzz_targets.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    cierzo::fuzz_one_checkpoint(data, size);
    return 0;
}
