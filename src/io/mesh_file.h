// What the mesh readers share (not part of the readers' interface).
#pragma once

#include <cstddef>
#include <filesystem>
#include <new>
#include <string>
#include <string_view>

#include <fmt/format.h>

#include "core/error.h"
#include "io/mapped_file.h"

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

// Where the text line from `pos` ends: at its '\n', at the end of `text`, or at a NUL byte,
// whichever comes first. A text format has no NUL byte, so the caller refuses one there; the
// search never runs on past it (a sparse file's hole is NUL bytes: it is not read to its end).
inline size_t line_end(std::string_view text, size_t pos) {
    const char* p = text.data() + pos;
    const char* const end = text.data() + text.size();
    while (p < end && *p != '\n' && *p != '\0') ++p;
    return size_t(p - text.data());
}

// A token of the file as a message quotes it: whole, or its first 40 bytes and its length
// (a token of a mapped file can be as long as the file).
inline std::string shown(std::string_view token) {
    if (token.size() <= 40) return std::string(token);
    return fmt::format("{}... ({} bytes)", token.substr(0, 40), token.size());
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
        const size_t end = line_end(bytes, pos);
        ++number;
        if (end < bytes.size() && bytes[end] == '\0')
            src.fail_at(number, fmt::format("has a NUL byte (not a text {} file)", format));
        line = bytes.substr(pos, end - pos);
        pos = end + 1;
        if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
        return true;
    }
};

// `parse(bytes)` on the file at `path` mapped into memory (MappedFile: only what the parser
// looks at is read), for the mesh readers (PLY, OBJ, MTL). Throws InputError naming the file
// when it cannot be mapped or read, and when the parser runs out of memory (so no file ends
// in an internal error; the parsers bound their allocations by the file's size and
// reader_memory_bound() first).
template <class Parse>
auto read_mapped(const std::filesystem::path& path, Parse parse) {
    const MappedFile file(path);
    try {
        return parse(file.bytes());
    } catch (const std::bad_alloc&) {
        throw InputError(fmt::format("{}: out of memory reading it ({} bytes)", path.string(),
                                     file.bytes().size()));
    }
}

// The whole file read into memory (an image texture; the mesh readers use read_mapped);
// throws InputError naming it when it is missing, not a regular file (input_file_exists) or
// unreadable.
std::string read_mesh_bytes(const std::filesystem::path& path);

}  // namespace cierzo
