// PLY's header as the reader sees it: the format, the elements and their typed properties,
// where the mesh's vertex and face data sit in them, and the scalar types' sizes and ranges.
// Shared by the header's parser (ply_header.cpp) and the body's readers (ply.cpp).
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "io/mesh_file.h"

namespace cierzo::ply {

enum class Format { Ascii, BinaryLittleEndian, BinaryBigEndian };

enum class ScalarType { Int8, UInt8, Int16, UInt16, Int32, UInt32, Float32, Float64 };

struct Property {
    std::string name;
    ScalarType type = ScalarType::Float32;  // the item type for a list
    bool is_list = false;
    ScalarType count_type = ScalarType::UInt8;
};

struct Element {
    std::string name;
    uint64_t count = 0;
    std::vector<Property> properties;
    size_t line = 0;  // of its 'element' line in the header
};

struct Header {
    Format format = Format::Ascii;
    std::vector<Element> elements;
    size_t body_offset = 0;  // first byte after the end_header line
    size_t body_line = 0;    // line number of that byte, counting from 1
    std::vector<std::string> warnings;
};

// Where each interesting property sits in its element; -1 when absent.
struct VertexLayout {
    int x = -1, y = -1, z = -1;
    int red = -1, green = -1, blue = -1;
    int nx = -1, ny = -1, nz = -1;
    bool has_colors() const { return red >= 0 && green >= 0 && blue >= 0; }
    bool has_normals() const { return nx >= 0 && ny >= 0 && nz >= 0; }

    // For each property of the vertex element: 0-2 for x/y/z, 3-5 for r/g/b, 6-8 for
    // nx/ny/nz, -1 to skip.
    std::vector<int> targets(size_t property_count) const {
        std::vector<int> result(property_count, -1);
        const int slots[9] = {x, y, z, red, green, blue, nx, ny, nz};
        for (int k = 0; k < 9; ++k) {
            const bool used = k < 3 || (k < 6 ? has_colors() : has_normals());
            if (used) result[size_t(slots[k])] = k;
        }
        return result;
    }
};

using Source = MeshSource;  // the file being read, for error messages

inline std::optional<ScalarType> parse_type(std::string_view name) {
    if (name == "char" || name == "int8") return ScalarType::Int8;
    if (name == "uchar" || name == "uint8") return ScalarType::UInt8;
    if (name == "short" || name == "int16") return ScalarType::Int16;
    if (name == "ushort" || name == "uint16") return ScalarType::UInt16;
    if (name == "int" || name == "int32") return ScalarType::Int32;
    if (name == "uint" || name == "uint32") return ScalarType::UInt32;
    if (name == "float" || name == "float32") return ScalarType::Float32;
    if (name == "double" || name == "float64") return ScalarType::Float64;
    return std::nullopt;
}

inline const char* type_name(ScalarType type) {
    switch (type) {
        case ScalarType::Int8: return "char";
        case ScalarType::UInt8: return "uchar";
        case ScalarType::Int16: return "short";
        case ScalarType::UInt16: return "ushort";
        case ScalarType::Int32: return "int";
        case ScalarType::UInt32: return "uint";
        case ScalarType::Float32: return "float";
        case ScalarType::Float64: return "double";
    }
    return "?";
}

inline size_t type_size(ScalarType type) {
    switch (type) {
        case ScalarType::Int8:
        case ScalarType::UInt8: return 1;
        case ScalarType::Int16:
        case ScalarType::UInt16: return 2;
        case ScalarType::Int32:
        case ScalarType::UInt32:
        case ScalarType::Float32: return 4;
        case ScalarType::Float64: return 8;
    }
    return 0;
}

inline bool is_integer(ScalarType type) {
    return type != ScalarType::Float32 && type != ScalarType::Float64;
}

// The value that maps to full intensity for a colour channel of this type.
inline double color_scale(ScalarType type) {
    switch (type) {
        case ScalarType::Int8: return 127.0;
        case ScalarType::UInt8: return 255.0;
        case ScalarType::Int16: return 32767.0;
        case ScalarType::UInt16: return 65535.0;
        case ScalarType::Int32: return 2147483647.0;
        case ScalarType::UInt32: return 4294967295.0;
        case ScalarType::Float32:
        case ScalarType::Float64: return 1.0;
    }
    return 1.0;
}

// Inclusive range of an integer type, as int64.
inline std::pair<int64_t, int64_t> integer_range(ScalarType type) {
    switch (type) {
        case ScalarType::Int8: return {-128, 127};
        case ScalarType::UInt8: return {0, 255};
        case ScalarType::Int16: return {-32768, 32767};
        case ScalarType::UInt16: return {0, 65535};
        case ScalarType::Int32: return {-2147483648LL, 2147483647LL};
        case ScalarType::UInt32: return {0, 4294967295LL};
        default: return {0, 0};
    }
}

inline std::string plural(std::string_view element_name) {
    if (element_name == "vertex") return "vertices";
    return std::string(element_name) + "s";
}

inline bool is_space(char c) {
    return c == ' ' || c == '\t' || c == '\n' || c == '\r' || c == '\v' || c == '\f';
}

// Splits off the next whitespace-separated token of `rest`; empty when none is left.
inline std::string_view next_token(std::string_view& rest) {
    size_t begin = 0;
    while (begin < rest.size() && is_space(rest[begin])) ++begin;
    size_t end = begin;
    while (end < rest.size() && !is_space(rest[end])) ++end;
    std::string_view token = rest.substr(begin, end - begin);
    rest.remove_prefix(end);
    return token;
}

// ---- The header and its claims ---------------------------------------------------

struct MeshLayout {
    size_t vertex_element = 0;
    size_t face_element = 0;
    VertexLayout vertex;
    int face_indices = -1;  // the list property with the vertex indices
};

// The header of `file` up to end_header, every line checked (a NUL byte refused: the header
// is text, and nothing after a NUL is looked at). An element without properties is refused
// unless its count is 0: its instances would take no bytes (binary) or no line (ascii, where
// blank lines are skipped), so nothing in the file could bound its count.
Header parse_header(std::string_view file, const Source& src);
// The vertex and face elements and where their properties sit; refuses a file without them.
MeshLayout find_mesh_layout(const Header& header, const Source& src);
// The bytes the vertex arrays take for the header's vertex count: positions, and the
// colours and normals when the layout has them.
uint64_t vertex_memory(const Header& header, const MeshLayout& layout);
// Refuses counts the file cannot hold (`body_bytes` after the header), and counts whose arrays
// (vertex_memory and one triangle per face) need more than `memory` bytes, before anything
// is allocated for them.
void check_claimed_sizes(const Header& header, const MeshLayout& layout, uint64_t body_bytes,
                         uint64_t memory, const Source& src);

}  // namespace cierzo::ply
