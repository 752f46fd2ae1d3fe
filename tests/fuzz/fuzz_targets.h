// The bodies of the fuzz targets, shared by the libFuzzer programs (fuzz_scene.cpp,
// fuzz_ply.cpp, fuzz_obj.cpp, fuzz_image.cpp) and the fuzz_regressions test, which replays every
// corpus and regression file through them. See docs/fuzzing.md.
#pragma once

#include <cstddef>
#include <cstdint>

namespace cierzo {

// Parses the bytes as a scene file whose folder is tests/fuzz/scene_root, so the PLY files a
// scene names resolve inside that fixed folder. Returns true if the scene was accepted, false
// if it was refused with an InputError (or names a mesh file outside that folder, which is
// skipped). Anything else, including a parsed scene that breaks the Scene invariants
// (non-finite geometry, out-of-range indices), aborts.
bool fuzz_one_scene(const uint8_t* data, size_t size);

// Parses the bytes as a PLY file (parse_ply). Returns true if accepted, false on InputError;
// anything else, including a mesh that breaks the MeshData invariants, aborts.
bool fuzz_one_ply(const uint8_t* data, size_t size);

// Parses the bytes as an OBJ file (parse_obj), with the same contract as fuzz_one_ply. Where
// a line "#%mtl" divides the bytes, what follows it is also parsed as the OBJ's MTL library
// (parse_mtl); the result is whether both were accepted.
bool fuzz_one_obj(const uint8_t* data, size_t size);

// Parses the bytes as an MTL library (parse_mtl), with the same contract.
bool fuzz_one_mtl(const uint8_t* data, size_t size);

// Decodes the bytes as an image texture (decode_texture_image: an EXR where they start with
// its magic number, else whatever stb_image recognises), with the same contract.
bool fuzz_one_image(const uint8_t* data, size_t size);

}  // namespace cierzo
