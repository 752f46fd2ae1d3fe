// libFuzzer entry point for cierzo-tonemap's HDR reader (read_hdr: OpenEXR and PFM); the body
// is fuzz_one_hdr_image in fuzz_targets.cpp. Build with -DCIERZO_BUILD_FUZZERS=ON (clang); see
// docs/fuzzing.md.
#include <cstddef>
#include <cstdint>

#include "fuzz_targets.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    cierzo::fuzz_one_hdr_image(data, size);
    return 0;
}
