// Reading a mesh file by its extension: PLY (ply.h) or OBJ (obj.h), into the MeshData of
// io/mesh_data.h.
#pragma once

#include <filesystem>

#include "io/mesh_data.h"

namespace cierzo {

// Reads a mesh file by its extension (case-insensitive): .ply (read_ply) or .obj (read_obj).
// Throws InputError naming the file and what is wrong, including an unknown extension.
MeshData read_mesh(const std::filesystem::path& path);

}  // namespace cierzo
