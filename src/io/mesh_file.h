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

// The next token of `rest` (runs of spaces and tabs separate tokens), removed from it; empty
// at the end.
inline std::string_view next_token(std::string_view& rest) {
    size_t a = 0;
    while (a < rest.size() && (rest[a] == ' ' || rest[a] == '\t')) ++a;
    size_t b = a;
    while (b < rest.size() && rest[b] != ' ' && rest[b] != '\t') ++b;
    const std::string_view token = rest.substr(a, b - a);
    rest.remove_prefix(b);
    return token;
}

// The lines of a text file's bytes (OBJ, MTL): ended by LF or CRLF (the CR dropped),
// numbered from 1, a NUL byte refused as `format` is a text format.
struct TextLines {
    std::string_view bytes;
    const MeshSource& src;
    const char* format;
    size_t pos = 0, number = 0;  // number: the line `next` gave last
    bool next(std::string_view& line) {
        if (pos >= bytes.size()) return false;
        size_t end = bytes.find('\n', pos);
        if (end == std::string_view::npos) end = bytes.size();
        line = bytes.substr(pos, end - pos);
        pos = end + 1;
        ++number;
        if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
        if (line.find('\0') != std::string_view::npos)
            src.fail_at(number, fmt::format("has a NUL byte (not a text {} file)", format));
        return true;
    }
};

// The whole file (a mesh, an MTL library, an image texture); throws InputError naming it when
// it is missing, not a regular file (input_file_exists) or unreadable.
std::string read_mesh_bytes(const std::filesystem::path& path);

}  // namespace cierzo
