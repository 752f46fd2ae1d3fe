// libFuzzer entry point for the decoders of the messages between MPI ranks
// (integrators/rank_messages.h); the body is fuzz_one_rank_message in fuzz_render_targets.cpp.
// Build with -DCIERZO_BUILD_FUZZERS=ON (clang); see docs/fuzzing.md.
#include <cstddef>
#include <cstdint>

#include "fuzz_targets.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    cierzo::fuzz_one_rank_message(data, size);
    return 0;
}
