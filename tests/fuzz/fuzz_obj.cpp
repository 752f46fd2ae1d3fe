// libFuzzer entry point for the OBJ reader (parse_obj); the body is fuzz_one_obj in
// fuzz_targets.cpp. Build with -DCIERZO_BUILD_FUZZERS=ON (clang); see docs/fuzzing.md.
#include <cstddef>
#include <cstdint>

#include "fuzz_targets.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    cierzo::fuzz_one_obj(data, size);
    return 0;
}
