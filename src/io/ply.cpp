// PLY mesh reader: parses the header, checks the claimed sizes against the file and the
// machine's memory, then reads ascii or binary (either byte order) vertices and faces into flat
// arrays, fanning polygons. The header's parser and checks are in ply_header.cpp; here the
// body's readers. The file is mapped (read_mapped): only the header and the elements it
// declares are read, never what follows them.
#include "io/ply.h"

#include <bit>
#include <charconv>
#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>
#include <optional>
#include <string>
#include <string_view>
#include <system_error>
#include <unordered_set>
#include <utility>
#include <vector>

#include <fmt/format.h>

#include "core/error.h"
#include "io/mapped_file.h"
#include "io/mesh_file.h"
#include "io/ply_header.h"

namespace cierzo {
namespace ply {
namespace {

// Whether a face of n corners can add its n - 2 triangles to the mesh's indices without
// passing `max_indices` (the memory left after the vertex arrays: reader_memory_bound).
bool fits_fan(const MeshData& mesh, int64_t n, uint64_t max_indices) {
    return uint64_t(n - 2) * 3 <= max_indices - mesh.indices.size();
}

std::string too_many_triangles(uint64_t face, const MeshData& mesh) {
    return fmt::format(
        "face {}: the faces' {}+ triangles need more than the memory a file may "
        "take (half this machine's)",
        face, mesh.indices.size() / 3);
}

// ---- Binary body -------------------------------------------------------------------

template <class UInt>
UInt load_swapped(const char* p, bool swap) {
    UInt bits;
    std::memcpy(&bits, p, sizeof bits);
    if (swap) {
        if constexpr (sizeof(UInt) == 2) bits = __builtin_bswap16(bits);
        if constexpr (sizeof(UInt) == 4) bits = __builtin_bswap32(bits);
        if constexpr (sizeof(UInt) == 8) bits = __builtin_bswap64(bits);
    }
    return bits;
}

int64_t load_integer(const char* p, ScalarType type, bool swap) {
    switch (type) {
        case ScalarType::Int8: return int8_t(*p);
        case ScalarType::UInt8: return uint8_t(*p);
        case ScalarType::Int16: return std::bit_cast<int16_t>(load_swapped<uint16_t>(p, swap));
        case ScalarType::UInt16: return load_swapped<uint16_t>(p, swap);
        case ScalarType::Int32: return std::bit_cast<int32_t>(load_swapped<uint32_t>(p, swap));
        case ScalarType::UInt32: return load_swapped<uint32_t>(p, swap);
        default: return 0;  // list counts and face indices are integer types (checked)
    }
}

// Reads one scalar of the given type at p (the caller has checked the bytes are there).
double load_number(const char* p, ScalarType type, bool swap) {
    switch (type) {
        case ScalarType::Float32:
            return double(std::bit_cast<float>(load_swapped<uint32_t>(p, swap)));
        case ScalarType::Float64: return std::bit_cast<double>(load_swapped<uint64_t>(p, swap));
        default: return double(load_integer(p, type, swap));
    }
}

// Checks and stores one vertex: values[0..2] are x, y, z, values[3..5] the raw colour and
// values[6..8] the normal.
void store_vertex(MeshData& mesh, uint64_t i, const double* values, const Element& element,
                  const VertexLayout& layout, const Source& src) {
    constexpr double float_max = std::numeric_limits<float>::max();
    for (int k = 0; k < 3; ++k) {
        if (!std::isfinite(values[k])) {
            src.fail(fmt::format("vertex {} has a non-finite coordinate ({})", i, values[k]));
        }
        if (std::fabs(values[k]) > float_max) {
            src.fail(fmt::format("vertex {} has coordinate {} beyond float range", i, values[k]));
        }
        mesh.positions[size_t(i) * 3 + size_t(k)] = float(values[k]);
    }
    if (layout.has_normals()) {
        for (int k = 0; k < 3; ++k) {
            const double c = values[6 + k];
            if (!std::isfinite(c) || std::fabs(c) > float_max)
                src.fail(fmt::format("vertex {} has an unusable normal component ({})", i, c));
            mesh.normals[size_t(i) * 3 + size_t(k)] = float(c);
        }
    }
    if (!layout.has_colors()) return;
    const int slots[3] = {layout.red, layout.green, layout.blue};
    for (int k = 0; k < 3; ++k) {
        double c = values[3 + k] / color_scale(element.properties[size_t(slots[k])].type);
        if (!std::isfinite(c) || std::fabs(c) > float_max) {
            src.fail(fmt::format("vertex {} has an unusable colour value ({})", i, values[3 + k]));
        }
        mesh.colors[size_t(i) * 3 + size_t(k)] = float(c);
    }
}

// Walks a binary body element by element, with bounds checks on every read.
struct BinaryReader {
    std::string_view body;
    size_t pos = 0;
    bool swap = false;
    const Source* src = nullptr;
    uint64_t max_indices = 0;  // what the triangles' indices may grow to (fits_fan)

    [[noreturn]] void truncated(uint64_t done, const Element& element) const {
        src->fail(fmt::format("binary data ends after {} of {} {} (file truncated?)", done,
                              element.count, plural(element.name)));
    }
    const char* take(uint64_t bytes, uint64_t done, const Element& element) {
        if (bytes > body.size() - pos) truncated(done, element);
        const char* p = body.data() + pos;
        pos += size_t(bytes);
        return p;
    }

    void skip_element(const Element& element) {
        // Fixed-size elements are skipped in one step, others one instance at a time.
        uint64_t stride = 0;
        bool fixed = true;
        for (const Property& property : element.properties) {
            if (property.is_list)
                fixed = false;
            else
                stride += type_size(property.type);
        }
        if (fixed) {
            uint64_t available = (body.size() - pos) / (stride ? stride : 1);
            if (stride && element.count > available) truncated(available, element);
            pos += size_t(element.count * stride);
            return;
        }
        for (uint64_t i = 0; i < element.count; ++i) {
            for (const Property& property : element.properties) {
                if (!property.is_list) {
                    take(type_size(property.type), i, element);
                    continue;
                }
                int64_t n = load_integer(take(type_size(property.count_type), i, element),
                                         property.count_type, swap);
                if (n < 0) {
                    src->fail(fmt::format("{} {} has a negative list length ({}) for '{}'",
                                          element.name, i, n, property.name));
                }
                take(uint64_t(n) * type_size(property.type), i, element);
            }
        }
    }

    void read_vertices(const Element& element, const VertexLayout& layout, MeshData& mesh) {
        const std::vector<int> targets = layout.targets(element.properties.size());
        double values[9] = {};
        for (uint64_t i = 0; i < element.count; ++i) {
            for (size_t p = 0; p < element.properties.size(); ++p) {
                const Property& property = element.properties[p];
                if (!property.is_list) {
                    const char* q = take(type_size(property.type), i, element);
                    if (targets[p] >= 0) values[targets[p]] = load_number(q, property.type, swap);
                    continue;
                }
                int64_t n = load_integer(take(type_size(property.count_type), i, element),
                                         property.count_type, swap);
                if (n < 0) {
                    src->fail(fmt::format("vertex {} has a negative list length ({}) for '{}'", i,
                                          n, property.name));
                }
                take(uint64_t(n) * type_size(property.type), i, element);
            }
            store_vertex(mesh, i, values, element, layout, *src);
        }
    }

    void read_faces(const Element& element, int index_property, MeshData& mesh) {
        const uint64_t vertex_count = mesh.positions.size() / 3;
        for (uint64_t i = 0; i < element.count; ++i) {
            for (size_t p = 0; p < element.properties.size(); ++p) {
                const Property& property = element.properties[p];
                if (!property.is_list) {
                    take(type_size(property.type), i, element);
                    continue;
                }
                int64_t n = load_integer(take(type_size(property.count_type), i, element),
                                         property.count_type, swap);
                if (int(p) != index_property) {
                    if (n < 0) {
                        src->fail(fmt::format("face {} has a negative list length ({}) for '{}'", i,
                                              n, property.name));
                    }
                    take(uint64_t(n) * type_size(property.type), i, element);
                    continue;
                }
                if (n < 3) {
                    src->fail(fmt::format("face {} has {} vertices, at least 3 needed", i, n));
                }
                if (!fits_fan(mesh, n, max_indices)) src->fail(too_many_triangles(i, mesh));
                size_t item = type_size(property.type);
                const char* items = take(uint64_t(n) * item, i, element);
                // Fan triangulation around the first corner.
                uint32_t corner[2] = {};
                for (int64_t k = 0; k < n; ++k) {
                    int64_t index = load_integer(items + size_t(k) * item, property.type, swap);
                    if (index < 0 || uint64_t(index) >= vertex_count) {
                        src->fail(
                            fmt::format("face {} has vertex index {} out of range "
                                        "(the file has {} vertices)",
                                        i, index, vertex_count));
                    }
                    uint32_t v = uint32_t(index);
                    if (k >= 2) mesh.indices.insert(mesh.indices.end(), {corner[0], corner[1], v});
                    if (k == 0) corner[0] = v;
                    corner[1] = v;
                }
            }
        }
    }
};

// ---- Ascii body --------------------------------------------------------------------

// Hands out the body's non-blank lines, each split into tokens, and their line numbers.
struct AsciiReader {
    std::string_view body;
    size_t pos = 0;
    size_t line_no = 0;  // of the line last returned
    std::vector<std::string_view> tokens;
    const Source* src = nullptr;
    uint64_t max_indices = 0;  // what the triangles' indices may grow to (fits_fan)

    // (a line is looked at up to its end or a NUL byte, which is refused: nothing after the
    // elements the header declares is read)
    bool next_line() {
        while (pos < body.size()) {
            const size_t eol = line_end(body, pos);
            ++line_no;
            if (eol < body.size() && body[eol] == '\0')
                src->fail_at(line_no, "a NUL byte in the ascii data (an ascii PLY body is text)");
            std::string_view rest = body.substr(pos, eol - pos);
            pos = eol < body.size() ? eol + 1 : eol;
            tokens.clear();
            for (std::string_view t = next_token(rest); !t.empty(); t = next_token(rest)) {
                tokens.push_back(t);
            }
            if (!tokens.empty()) return true;
        }
        return false;
    }

    void need_line(uint64_t done, const Element& element) {
        if (!next_line()) {
            src->fail(fmt::format("ascii data ends after {} of {} {} (file truncated?)", done,
                                  element.count, plural(element.name)));
        }
    }

    // How many values the current line would need, for the error when it runs short.
    size_t values_needed(const Element& element) const {
        size_t needed = 0;
        for (const Property& property : element.properties) {
            if (!property.is_list) {
                ++needed;
                continue;
            }
            if (needed >= tokens.size()) return needed + 1;
            int64_t n = 0;
            std::string_view t = tokens[needed];
            if (std::from_chars(t.data(), t.data() + t.size(), n).ec != std::errc() || n < 0) {
                return needed + 1;
            }
            needed += 1 + size_t(n);
        }
        return needed;
    }

    std::string_view token(size_t k, uint64_t i, const Element& element) const {
        if (k >= tokens.size()) {
            src->fail_at(line_no, fmt::format("{} {} has {} values, expected {}", element.name, i,
                                              tokens.size(), values_needed(element)));
        }
        return tokens[k];
    }

    int64_t integer(std::string_view t, ScalarType type, uint64_t i, const Element& element) const {
        if (t.size() > 1 && t[0] == '+') t.remove_prefix(1);
        int64_t value = 0;
        auto [end, ec] = std::from_chars(t.data(), t.data() + t.size(), value);
        auto [lo, hi] = integer_range(type);
        if (ec != std::errc() || end != t.data() + t.size() || value < lo || value > hi) {
            src->fail_at(line_no, fmt::format("{} {}: '{}' is not a valid {}", element.name, i,
                                              shown(t), type_name(type)));
        }
        return value;
    }

    double number(std::string_view t, ScalarType type, uint64_t i, const Element& element) const {
        if (is_integer(type)) return double(integer(t, type, i, element));
        if (t.size() > 1 && t[0] == '+') t.remove_prefix(1);
        double value = 0.0;
        auto [end, ec] = std::from_chars(t.data(), t.data() + t.size(), value);
        if (ec == std::errc::result_out_of_range) {
            src->fail_at(line_no, fmt::format("{} {}: value '{}' is out of range", element.name, i,
                                              shown(t)));
        }
        if (ec != std::errc() || end != t.data() + t.size()) {
            src->fail_at(line_no,
                         fmt::format("{} {}: '{}' is not a number", element.name, i, shown(t)));
        }
        return value;
    }

    // Consumes a list on the current line from token k on; returns its length.
    int64_t list_length(size_t& k, const Property& property, uint64_t i, const Element& element) {
        int64_t n = integer(token(k, i, element), property.count_type, i, element);
        if (n < 0) {
            src->fail_at(line_no, fmt::format("{} {} has a negative list length ({}) for '{}'",
                                              element.name, i, n, property.name));
        }
        ++k;
        return n;
    }

    // (an element without properties has a count of 0: parse_header)
    void skip_element(const Element& element) {
        for (uint64_t i = 0; i < element.count; ++i) need_line(i, element);
    }

    void read_vertices(const Element& element, const VertexLayout& layout, MeshData& mesh) {
        const std::vector<int> targets = layout.targets(element.properties.size());
        double values[9] = {};
        for (uint64_t i = 0; i < element.count; ++i) {
            need_line(i, element);
            size_t k = 0;
            for (size_t p = 0; p < element.properties.size(); ++p) {
                const Property& property = element.properties[p];
                if (property.is_list) {
                    int64_t n = list_length(k, property, i, element);
                    if (n > 0) token(k + size_t(n) - 1, i, element);
                    k += size_t(n);
                    continue;
                }
                std::string_view t = token(k++, i, element);
                if (targets[p] >= 0) values[targets[p]] = number(t, property.type, i, element);
            }
            store_vertex(mesh, i, values, element, layout, *src);
        }
    }

    void read_faces(const Element& element, int index_property, MeshData& mesh) {
        const uint64_t vertex_count = mesh.positions.size() / 3;
        for (uint64_t i = 0; i < element.count; ++i) {
            need_line(i, element);
            size_t k = 0;
            for (size_t p = 0; p < element.properties.size(); ++p) {
                const Property& property = element.properties[p];
                if (!property.is_list) {
                    token(k++, i, element);
                    continue;
                }
                int64_t n = list_length(k, property, i, element);
                if (int(p) != index_property) {
                    if (n > 0) token(k + size_t(n) - 1, i, element);
                    k += size_t(n);
                    continue;
                }
                if (n < 3) {
                    src->fail_at(line_no, fmt::format("face {} has {} vertices, at least 3 "
                                                      "needed",
                                                      i, n));
                }
                token(k + size_t(n) - 1, i, element);
                if (!fits_fan(mesh, n, max_indices))
                    src->fail_at(line_no, too_many_triangles(i, mesh));
                // Fan triangulation around the first corner.
                uint32_t corner[2] = {};
                for (int64_t c = 0; c < n; ++c) {
                    int64_t index = integer(tokens[k++], property.type, i, element);
                    if (index < 0 || uint64_t(index) >= vertex_count) {
                        src->fail_at(line_no, fmt::format("face {} has vertex index {} out of "
                                                          "range (the file has {} vertices)",
                                                          i, index, vertex_count));
                    }
                    uint32_t v = uint32_t(index);
                    if (c >= 2) mesh.indices.insert(mesh.indices.end(), {corner[0], corner[1], v});
                    if (c == 0) corner[0] = v;
                    corner[1] = v;
                }
            }
        }
    }
};

// Reads every element in file order with the given reader (ascii or binary).
template <class Reader>
void read_body(Reader& reader, const Header& header, const MeshLayout& layout, MeshData& mesh) {
    for (size_t e = 0; e < header.elements.size(); ++e) {
        const Element& element = header.elements[e];
        if (e == layout.vertex_element)
            reader.read_vertices(element, layout.vertex, mesh);
        else if (e == layout.face_element)
            reader.read_faces(element, layout.face_indices, mesh);
        else
            reader.skip_element(element);
    }
}

}  // namespace
}  // namespace ply

MeshData read_ply(const std::filesystem::path& path) {
    return read_mapped(path, [&](std::string_view bytes) { return parse_ply(bytes, path); });
}

MeshData parse_ply(std::string_view file, const std::filesystem::path& name) {
    using namespace ply;
    Source src{name.string()};
    Header header = parse_header(file, src);
    MeshLayout layout = find_mesh_layout(header, src);
    std::string_view body = file.substr(header.body_offset);
    const uint64_t memory = reader_memory_bound();
    check_claimed_sizes(header, layout, body.size(), memory, src);
    const uint64_t max_indices = (memory - vertex_memory(header, layout)) / sizeof(uint32_t);

    // Sizes are now known to fit in the file and in memory, so the arrays can be allocated.
    MeshData mesh;
    mesh.warnings = std::move(header.warnings);
    const Element& vertex = header.elements[layout.vertex_element];
    const Element& face = header.elements[layout.face_element];
    mesh.positions.resize(size_t(vertex.count) * 3);
    if (layout.vertex.has_colors()) mesh.colors.resize(size_t(vertex.count) * 3);
    if (layout.vertex.has_normals()) mesh.normals.resize(size_t(vertex.count) * 3);
    mesh.indices.reserve(size_t(face.count) * 3);

    if (header.format == Format::Ascii) {
        AsciiReader reader{body, 0, header.body_line - 1, {}, &src, max_indices};
        read_body(reader, header, layout, mesh);
    } else {
        bool file_big = header.format == Format::BinaryBigEndian;
        bool host_big = std::endian::native == std::endian::big;
        BinaryReader reader{body, 0, file_big != host_big, &src, max_indices};
        read_body(reader, header, layout, mesh);
    }
    return mesh;
}

}  // namespace cierzo
