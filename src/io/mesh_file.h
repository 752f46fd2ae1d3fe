// What the mesh readers share (not part of the readers' interface).
#pragma once

#include <filesystem>
#include <string>

namespace cierzo {

// The whole file; throws InputError naming it when it is missing, a directory (`format` says
// what it should have been, e.g. "PLY") or unreadable.
std::string read_mesh_bytes(const std::filesystem::path& path, const char* format);

}  // namespace cierzo
