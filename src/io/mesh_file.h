// What the mesh readers share (not part of the readers' interface).
#pragma once

#include <cstddef>
#include <filesystem>
#include <string>
#include <string_view>

#include <fmt/format.h>

#include "core/error.h"

namespace cierzo {

// The file being read, for error messages: "PATH: what" or "PATH: line N: what".
struct MeshSource {
    std::string path;
    [[noreturn]] void fail(std::string_view what) const {
        throw InputError(fmt::format("{}: {}", path, what));
    }
    [[noreturn]] void fail_at(size_t line, std::string_view what) const {
        throw InputError(fmt::format("{}: line {}: {}", path, line, what));
    }
};

// The whole file; throws InputError naming it when it is missing, a directory (`format` says
// what it should have been, e.g. "PLY") or unreadable.
std::string read_mesh_bytes(const std::filesystem::path& path, const char* format);

}  // namespace cierzo
