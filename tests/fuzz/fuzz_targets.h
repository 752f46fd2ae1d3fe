// The bodies of the two fuzz targets, shared by the libFuzzer programs (fuzz_scene.cpp,
// fuzz_ply.cpp) and the fuzz_regressions test, which replays every corpus and regression file
// through them. See docs/fuzzing.md.
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

// Parses the bytes as an OBJ file (parse_obj), with the same contract as fuzz_one_ply.
bool fuzz_one_obj(const uint8_t* data, size_t size);

}  // namespace cierzo
