// libFuzzer entry point for the image-texture reader (probe_texture_image and
// read_texture_image: stb_image's formats and OpenEXR); the body is fuzz_one_image in
// fuzz_targets.cpp. Build with -DCIERZO_BUILD_FUZZERS=ON (clang); see docs/fuzzing.md.
#include <cstddef>
#include <cstdint>

#include "fuzz_targets.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    cierzo::fuzz_one_image(data, size);
    return 0;
}
