// The bodies of the fuzz targets, shared by the libFuzzer programs (fuzz_scene.cpp,
// fuzz_ply.cpp, fuzz_obj.cpp, fuzz_image.cpp, fuzz_hdr_image.cpp, fuzz_checkpoint.cpp,
// fuzz_rank_messages.cpp) and the fuzz_regressions test, which replays every corpus and
// regression file through them. See docs/fuzzing.md.
#pragma once

#include <cstddef>
#include <cstdint>
#include <exception>
#include <filesystem>
#include <string_view>

namespace cierzo {

// The memory the scenes the scene fuzzer parses may give their decoded images
// (LoadOptions::image_memory): a fuzzed scene is refused, from its images' headers, before it
// can make the fuzzer decode more.
inline constexpr uint64_t kFuzzImageMemory = uint64_t(64) << 20;

// Parses the bytes as a scene file whose folder is tests/fuzz/scene_root, so the files a scene
// names (meshes, MTL libraries, images) resolve inside that fixed folder, with the image
// budget above. Returns true if the scene was accepted, false if it was refused with an
// InputError. Anything else, including a parsed scene that breaks the Scene invariants
// (non-finite geometry, out-of-range indices, a file read from outside scene_root), aborts.
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

// Writes the bytes to a scratch file named by their signature (fuzz.png, .jpg, .bmp, .ppm,
// .hdr, .exr; fuzz.tga for bytes without one), probes it (probe_texture_image) and reads it
// as an image texture (read_texture_image), with the same contract; an image read must have
// the shape its probe gave.
bool fuzz_one_image(const uint8_t* data, size_t size);

// Writes the bytes to a scratch file named fuzz.exr (OpenEXR's signature) or fuzz.pfm (any
// other) and reads it as cierzo-tonemap does (read_hdr; an EXR also with its metadata and
// layers, and its shape), then tone-maps what was accepted with every operator.
bool fuzz_one_hdr_image(const uint8_t* data, size_t size);

// Reads the bytes as a checkpoint (read_checkpoint). Bytes that start with OpenEXR's
// signature are the file itself; any others describe a render state that write_checkpoint
// writes and read_checkpoint reads back (so the checks behind the file's checksum are
// reached). An accepted checkpoint must hold a valid state, and the state written.
bool fuzz_one_checkpoint(const uint8_t* data, size_t size);

// Decodes the bytes as a message from another MPI rank, by every decoder of
// integrators/rank_messages.h (at most the one of the message's kind may accept it; a refusal
// is a MessageError); what was accepted must be in range and encode to the same bytes, and a
// band's state is gathered into a film as rank 0 does.
bool fuzz_one_rank_message(const uint8_t* data, size_t size);

// ---- Shared by the bodies ------------------------------------------------------------------

// Aborts, saying which invariant an accepted input broke, unless `ok`.
void fuzz_require(bool ok, const char* what);

// A reader's refusal, printed when CIERZO_FUZZ_VERBOSE is set (to see why a seed is refused).
void fuzz_refused(const std::exception& e);

// A scratch file of this process holding `bytes`, in a folder of its own under the temporary
// folder (TMPDIR), removed at exit.
std::filesystem::path fuzz_scratch_file(const std::string_view name, std::string_view bytes);

}  // namespace cierzo
