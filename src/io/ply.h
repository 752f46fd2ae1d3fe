// PLY mesh reader: ASCII, binary little-endian and binary big-endian; vertex positions,
// optional vertex colours and normals (nx, ny, nz), faces of any size (fan-triangulated).
#pragma once

#include <cstdint>
#include <filesystem>
#include <string_view>
#include <vector>

#include "io/mesh_data.h"

namespace cierzo {

// Throws InputError naming the file and what is wrong (truncated, lying counts, bad
// indices, unsupported property types, absurd sizes) before any large allocation: the header's
// counts are checked against the bytes after it and against the machine's physical memory
// before anything is allocated for them. Bytes after the elements the header declares are
// ignored and never read.
MeshData read_ply(const std::filesystem::path& path);

// The same from the bytes of a PLY file held in memory; `name` is only used in messages.
// read_ply maps the file into memory (MappedFile) and calls this, so both make the same checks.
MeshData parse_ply(std::string_view bytes, const std::filesystem::path& name);

}  // namespace cierzo
