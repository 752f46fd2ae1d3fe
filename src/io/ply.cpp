// PLY mesh reader: parses the header, checks the claimed sizes against the file, then reads
// ascii or binary (either byte order) vertices and faces into flat arrays, fanning polygons.
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
#include "io/mesh_file.h"

namespace cierzo {
namespace {

constexpr uint64_t max_vertices_or_faces = uint64_t(1) << 31;

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

std::optional<ScalarType> parse_type(std::string_view name) {
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

const char* type_name(ScalarType type) {
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

size_t type_size(ScalarType type) {
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

bool is_integer(ScalarType type) {
    return type != ScalarType::Float32 && type != ScalarType::Float64;
}

// The value that maps to full intensity for a colour channel of this type.
double color_scale(ScalarType type) {
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
std::pair<int64_t, int64_t> integer_range(ScalarType type) {
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

std::string plural(std::string_view element_name) {
    if (element_name == "vertex") return "vertices";
    return std::string(element_name) + "s";
}

bool is_space(char c) {
    return c == ' ' || c == '\t' || c == '\n' || c == '\r' || c == '\v' || c == '\f';
}

// Splits off the next whitespace-separated token of `rest`; empty when none is left.
std::string_view next_token(std::string_view& rest) {
    size_t begin = 0;
    while (begin < rest.size() && is_space(rest[begin])) ++begin;
    size_t end = begin;
    while (end < rest.size() && !is_space(rest[end])) ++end;
    std::string_view token = rest.substr(begin, end - begin);
    rest.remove_prefix(end);
    return token;
}

// ---- Header ----------------------------------------------------------------------

// "element NAME COUNT" (after the keyword), with the 2^31 cap on vertices and faces.
// `names` holds the names of the elements before it (a set: a header may have many).
Element parse_element(std::string_view rest, size_t line_no,
                      std::unordered_set<std::string>& names, const Source& src) {
    Element element;
    element.name = std::string(next_token(rest));
    std::string_view count = next_token(rest);
    auto [end, ec] = std::from_chars(count.data(), count.data() + count.size(), element.count);
    if (element.name.empty() || count.empty() || ec != std::errc() ||
        end != count.data() + count.size()) {
        src.fail_at(line_no, fmt::format("bad element line 'element {} {}' (expected a name "
                                         "and a non-negative count)",
                                         element.name, count));
    }
    if (!names.insert(element.name).second) {
        src.fail_at(line_no, fmt::format("second '{}' element", element.name));
    }
    bool is_mesh = element.name == "vertex" || element.name == "face";
    if (is_mesh && element.count > max_vertices_or_faces) {
        src.fail_at(line_no, fmt::format("header claims {} {}, more than the limit of 2^31",
                                         element.count, plural(element.name)));
    }
    return element;
}

// "property TYPE NAME" or "property list COUNT_TYPE ITEM_TYPE NAME" (after the keyword).
Property parse_property(std::string_view rest, size_t line_no, const Source& src) {
    auto type_of = [&](std::string_view name) {
        auto parsed = parse_type(name);
        if (!parsed) src.fail_at(line_no, fmt::format("unsupported property type '{}'", name));
        return *parsed;
    };
    Property property;
    std::string_view type = next_token(rest);
    if (type == "list") {
        property.is_list = true;
        std::string_view count_type = next_token(rest);
        property.count_type = type_of(count_type);
        if (!is_integer(property.count_type)) {
            src.fail_at(line_no, fmt::format("list count type '{}' is not an integer type",
                                             count_type));
        }
        type = next_token(rest);
    }
    property.type = type_of(type);
    property.name = std::string(next_token(rest));
    if (property.name.empty()) src.fail_at(line_no, "property without a name");
    return property;
}

Header parse_header(std::string_view file, const Source& src) {
    Header header;
    size_t pos = 0;
    size_t line_no = 0;
    bool have_format = false;
    bool ended = false;
    std::unordered_set<std::string> element_names;
    while (pos < file.size() && !ended) {
        // One header line, without its '\n' (and any '\r').
        size_t eol = file.find('\n', pos);
        size_t next = eol == std::string_view::npos ? file.size() : eol + 1;
        std::string_view rest = file.substr(pos, next - pos);
        pos = next;
        ++line_no;
        std::string_view keyword = next_token(rest);
        if (line_no == 1) {
            if (keyword != "ply" || !next_token(rest).empty()) {
                src.fail("not a PLY file (the first line is not 'ply')");
            }
            continue;
        }

        // format, element, property, comment, obj_info, end_header.
        if (keyword == "format") {
            if (have_format) src.fail_at(line_no, "second 'format' line");
            std::string_view name = next_token(rest);
            std::string_view version = next_token(rest);
            if (name == "ascii") header.format = Format::Ascii;
            else if (name == "binary_little_endian") header.format = Format::BinaryLittleEndian;
            else if (name == "binary_big_endian") header.format = Format::BinaryBigEndian;
            else src.fail_at(line_no, fmt::format("unknown format '{}'", name));
            if (version != "1.0") {
                src.fail_at(line_no, fmt::format("unsupported format version '{}'", version));
            }
            have_format = true;
        } else if (keyword == "element") {
            header.elements.push_back(parse_element(rest, line_no, element_names, src));
        } else if (keyword == "property") {
            if (header.elements.empty()) src.fail_at(line_no, "property before any element");
            header.elements.back().properties.push_back(parse_property(rest, line_no, src));
        } else if (keyword == "end_header") {
            ended = true;
        } else if (keyword != "comment" && keyword != "obj_info" && !keyword.empty()) {
            // Before the first element nothing can be lost (a misspelt 'element' leaves the
            // properties after it without one, which is refused): a line there is read as a
            // comment, as Blender 2.4x wrote 'Created by Blender3D ...' without the keyword
            if (!header.elements.empty())
                src.fail_at(line_no, fmt::format("unknown header keyword '{}'", keyword));
            header.warnings.push_back(fmt::format(
                "{}: line {}: '{}' is not a PLY header keyword; the line is read as a comment",
                src.path, line_no, keyword));
        }
    }
    if (line_no == 0) src.fail("file is empty");
    if (!ended) src.fail("header has no 'end_header' line (not a PLY file, or truncated)");
    if (!have_format) src.fail("header has no 'format' line");
    header.body_offset = pos;
    header.body_line = line_no + 1;
    return header;
}

// ---- Checks on the header's claims ------------------------------------------------

struct MeshLayout {
    size_t vertex_element = 0;
    size_t face_element = 0;
    VertexLayout vertex;
    int face_indices = -1;  // the list property with the vertex indices
};

MeshLayout find_mesh_layout(const Header& header, const Source& src) {
    MeshLayout layout;
    bool have_vertex = false, have_face = false;
    for (size_t e = 0; e < header.elements.size(); ++e) {
        if (header.elements[e].name == "vertex") {
            layout.vertex_element = e;
            have_vertex = true;
        } else if (header.elements[e].name == "face") {
            layout.face_element = e;
            have_face = true;
        }
    }
    if (!have_vertex) src.fail("header has no 'vertex' element");
    if (!have_face) src.fail("header has no 'face' element (point clouds are not supported)");

    // Vertex: x, y, z required; red, green, blue and nx, ny, nz used only if all three
    // of each are there.
    const Element& vertex = header.elements[layout.vertex_element];
    for (size_t p = 0; p < vertex.properties.size(); ++p) {
        const Property& property = vertex.properties[p];
        int* slot = nullptr;
        if (property.name == "x") slot = &layout.vertex.x;
        else if (property.name == "y") slot = &layout.vertex.y;
        else if (property.name == "z") slot = &layout.vertex.z;
        else if (property.name == "red") slot = &layout.vertex.red;
        else if (property.name == "green") slot = &layout.vertex.green;
        else if (property.name == "blue") slot = &layout.vertex.blue;
        else if (property.name == "nx") slot = &layout.vertex.nx;
        else if (property.name == "ny") slot = &layout.vertex.ny;
        else if (property.name == "nz") slot = &layout.vertex.nz;
        if (!slot) continue;
        if (property.is_list) {
            src.fail(fmt::format("vertex property '{}' is a list, expected a number",
                                 property.name));
        }
        if (*slot >= 0) src.fail(fmt::format("vertex property '{}' appears twice", property.name));
        *slot = int(p);
    }
    for (auto [slot, name] : {std::pair{layout.vertex.x, "x"}, std::pair{layout.vertex.y, "y"},
                              std::pair{layout.vertex.z, "z"}}) {
        if (slot < 0) src.fail(fmt::format("vertex element has no '{}' property", name));
    }

    // Face: the list of vertex indices, with an integer item type.
    const Element& face = header.elements[layout.face_element];
    for (size_t p = 0; p < face.properties.size(); ++p) {
        const Property& property = face.properties[p];
        if (property.name != "vertex_indices" && property.name != "vertex_index") continue;
        if (!property.is_list) src.fail(fmt::format("face property '{}' is not a list",
                                                    property.name));
        if (!is_integer(property.type)) {
            src.fail(fmt::format("face property '{}' has non-integer index type '{}'",
                                 property.name, type_name(property.type)));
        }
        layout.face_indices = int(p);
        break;
    }
    if (layout.face_indices < 0) {
        src.fail("face element has no 'vertex_indices' list property");
    }
    return layout;
}

// Fewest bytes (binary) or values (ascii) that one instance of the element can take up.
uint64_t min_element_size(const Element& element, bool is_face, int face_indices, bool binary) {
    uint64_t size = 0;
    for (size_t p = 0; p < element.properties.size(); ++p) {
        const Property& property = element.properties[p];
        if (!property.is_list) {
            size += binary ? type_size(property.type) : 1;
            continue;
        }
        size += binary ? type_size(property.count_type) : 1;
        if (is_face && int(p) == face_indices) size += 3 * (binary ? type_size(property.type) : 1);
    }
    return size;
}

// Refuses counts the file cannot hold before anything is allocated for them.
void check_claimed_sizes(const Header& header, const MeshLayout& layout, uint64_t body_bytes,
                         const Source& src) {
    bool binary = header.format != Format::Ascii;
    // Each ascii value takes at least one character and one separator (bar the last).
    uint64_t budget = binary ? body_bytes : (body_bytes + 1) / 2;
    for (size_t e = 0; e < header.elements.size(); ++e) {
        const Element& element = header.elements[e];
        uint64_t min_size = min_element_size(element, e == layout.face_element,
                                             layout.face_indices, binary);
        if (min_size == 0) continue;
        if (element.count > budget / min_size) {
            src.fail(fmt::format("header claims {} '{}' elements, but the file is only {} bytes "
                                 "after the header (needs at least {} {} each)",
                                 element.count, element.name, body_bytes, min_size,
                                 binary ? "bytes" : "values"));
        }
        budget -= element.count * min_size;
    }
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
            if (property.is_list) fixed = false;
            else stride += type_size(property.type);
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
                    src->fail(fmt::format("vertex {} has a negative list length ({}) for '{}'",
                                          i, n, property.name));
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
                        src->fail(fmt::format("face {} has a negative list length ({}) for '{}'",
                                              i, n, property.name));
                    }
                    take(uint64_t(n) * type_size(property.type), i, element);
                    continue;
                }
                if (n < 3) {
                    src->fail(fmt::format("face {} has {} vertices, at least 3 needed", i, n));
                }
                size_t item = type_size(property.type);
                const char* items = take(uint64_t(n) * item, i, element);
                // Fan triangulation around the first corner.
                uint32_t corner[2] = {};
                for (int64_t k = 0; k < n; ++k) {
                    int64_t index = load_integer(items + size_t(k) * item, property.type, swap);
                    if (index < 0 || uint64_t(index) >= vertex_count) {
                        src->fail(fmt::format("face {} has vertex index {} out of range "
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

    bool next_line() {
        while (pos < body.size()) {
            size_t eol = body.find('\n', pos);
            size_t next = eol == std::string_view::npos ? body.size() : eol + 1;
            std::string_view rest = body.substr(pos, next - pos);
            if (!rest.empty() && rest.back() == '\n') rest.remove_suffix(1);
            pos = next;
            ++line_no;
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
            src->fail_at(line_no, fmt::format("{} {} has {} values, expected {}", element.name,
                                              i, tokens.size(), values_needed(element)));
        }
        return tokens[k];
    }

    int64_t integer(std::string_view t, ScalarType type, uint64_t i, const Element& element) const {
        if (t.size() > 1 && t[0] == '+') t.remove_prefix(1);
        int64_t value = 0;
        auto [end, ec] = std::from_chars(t.data(), t.data() + t.size(), value);
        auto [lo, hi] = integer_range(type);
        if (ec != std::errc() || end != t.data() + t.size() || value < lo || value > hi) {
            src->fail_at(line_no, fmt::format("{} {}: '{}' is not a valid {}", element.name, i, t,
                                              type_name(type)));
        }
        return value;
    }

    double number(std::string_view t, ScalarType type, uint64_t i, const Element& element) const {
        if (is_integer(type)) return double(integer(t, type, i, element));
        if (t.size() > 1 && t[0] == '+') t.remove_prefix(1);
        double value = 0.0;
        auto [end, ec] = std::from_chars(t.data(), t.data() + t.size(), value);
        if (ec == std::errc::result_out_of_range) {
            src->fail_at(line_no, fmt::format("{} {}: value '{}' is out of range", element.name,
                                              i, t));
        }
        if (ec != std::errc() || end != t.data() + t.size()) {
            src->fail_at(line_no, fmt::format("{} {}: '{}' is not a number", element.name, i, t));
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

    void skip_element(const Element& element) {
        if (element.properties.empty()) return;
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
        if (e == layout.vertex_element) reader.read_vertices(element, layout.vertex, mesh);
        else if (e == layout.face_element) reader.read_faces(element, layout.face_indices, mesh);
        else reader.skip_element(element);
    }
}

}  // namespace

MeshData read_ply(const std::filesystem::path& path) {
    const std::string file = read_mesh_bytes(path);
    return parse_ply(file, path);
}

MeshData parse_ply(std::string_view file, const std::filesystem::path& name) {
    Source src{name.string()};
    Header header = parse_header(file, src);
    MeshLayout layout = find_mesh_layout(header, src);
    std::string_view body = file.substr(header.body_offset);
    check_claimed_sizes(header, layout, body.size(), src);

    // Sizes are now known to fit in the file, so the arrays can be allocated.
    MeshData mesh;
    mesh.warnings = std::move(header.warnings);
    const Element& vertex = header.elements[layout.vertex_element];
    const Element& face = header.elements[layout.face_element];
    mesh.positions.resize(size_t(vertex.count) * 3);
    if (layout.vertex.has_colors()) mesh.colors.resize(size_t(vertex.count) * 3);
    if (layout.vertex.has_normals()) mesh.normals.resize(size_t(vertex.count) * 3);
    mesh.indices.reserve(size_t(face.count) * 3);

    if (header.format == Format::Ascii) {
        AsciiReader reader{body, 0, header.body_line - 1, {}, &src};
        read_body(reader, header, layout, mesh);
    } else {
        bool file_big = header.format == Format::BinaryBigEndian;
        bool host_big = std::endian::native == std::endian::big;
        BinaryReader reader{body, 0, file_big != host_big, &src};
        read_body(reader, header, layout, mesh);
    }
    return mesh;
}

}  // namespace cierzo
