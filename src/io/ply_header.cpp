// PLY's header: its lines parsed and checked, the mesh's elements found in it, and its
// claimed counts checked against the file's size before anything is allocated (ply_header.h).
#include "io/ply_header.h"

#include <fmt/format.h>

#include <charconv>
#include <limits>
#include <unordered_set>

#include "core/error.h"

namespace cierzo::ply {

namespace {

constexpr uint64_t max_vertices_or_faces = uint64_t(1) << 31;

}  // namespace

// ---- Header ----------------------------------------------------------------------

// "element NAME COUNT" (after the keyword), with the 2^31 cap on vertices and faces.
// `names` holds the names of the elements before it (a set: a header may have many).
Element parse_element(std::string_view rest, size_t line_no, std::unordered_set<std::string>& names,
                      const Source& src) {
    Element element;
    element.name = std::string(next_token(rest));
    std::string_view count = next_token(rest);
    auto [end, ec] = std::from_chars(count.data(), count.data() + count.size(), element.count);
    if (element.name.empty() || count.empty() || ec != std::errc() ||
        end != count.data() + count.size()) {
        src.fail_at(line_no, fmt::format("bad element line 'element {} {}' (expected a name "
                                         "and a non-negative count)",
                                         shown(element.name), shown(count)));
    }
    if (!names.insert(element.name).second) {
        src.fail_at(line_no, fmt::format("second '{}' element", shown(element.name)));
    }
    bool is_mesh = element.name == "vertex" || element.name == "face";
    if (is_mesh && element.count > max_vertices_or_faces) {
        src.fail_at(line_no, fmt::format("header claims {} {}, more than the limit of 2^31",
                                         element.count, plural(element.name)));
    }
    element.line = line_no;
    return element;
}

// "property TYPE NAME" or "property list COUNT_TYPE ITEM_TYPE NAME" (after the keyword).
Property parse_property(std::string_view rest, size_t line_no, const Source& src) {
    auto type_of = [&](std::string_view name) {
        auto parsed = parse_type(name);
        if (!parsed)
            src.fail_at(line_no, fmt::format("unsupported property type '{}'", shown(name)));
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
                                             shown(count_type)));
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
        // One header line, without its '\n' (and any '\r'), up to a NUL byte at most.
        const size_t eol = line_end(file, pos);
        std::string_view rest = file.substr(pos, eol - pos);
        pos = eol < file.size() ? eol + 1 : eol;
        ++line_no;
        if (eol < file.size() && file[eol] == '\0') {
            if (line_no == 1) src.fail("not a PLY file (the first line is not 'ply')");
            src.fail_at(line_no, "a NUL byte in the header (not a PLY file, or one cut short)");
        }
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
            if (name == "ascii")
                header.format = Format::Ascii;
            else if (name == "binary_little_endian")
                header.format = Format::BinaryLittleEndian;
            else if (name == "binary_big_endian")
                header.format = Format::BinaryBigEndian;
            else
                src.fail_at(line_no, fmt::format("unknown format '{}'", shown(name)));
            if (version != "1.0") {
                src.fail_at(line_no,
                            fmt::format("unsupported format version '{}'", shown(version)));
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
                src.fail_at(line_no, fmt::format("unknown header keyword '{}'", shown(keyword)));
            header.warnings.push_back(fmt::format(
                "{}: line {}: '{}' is not a PLY header keyword; the line is read as a comment",
                src.path, line_no, shown(keyword)));
        }
    }
    if (line_no == 0) src.fail("file is empty");
    if (!ended) src.fail("header has no 'end_header' line (not a PLY file, or truncated)");
    if (!have_format) src.fail("header has no 'format' line");
    for (const Element& element : header.elements) {
        if (element.properties.empty() && element.count > 0) {
            src.fail_at(element.line,
                        fmt::format("element '{}' has no properties but a count of {} (such an "
                                    "element holds nothing: only a count of 0 is read)",
                                    shown(element.name), element.count));
        }
    }
    header.body_offset = pos;
    header.body_line = line_no + 1;
    return header;
}

// ---- Checks on the header's claims ------------------------------------------------

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
        if (property.name == "x")
            slot = &layout.vertex.x;
        else if (property.name == "y")
            slot = &layout.vertex.y;
        else if (property.name == "z")
            slot = &layout.vertex.z;
        else if (property.name == "red")
            slot = &layout.vertex.red;
        else if (property.name == "green")
            slot = &layout.vertex.green;
        else if (property.name == "blue")
            slot = &layout.vertex.blue;
        else if (property.name == "nx")
            slot = &layout.vertex.nx;
        else if (property.name == "ny")
            slot = &layout.vertex.ny;
        else if (property.name == "nz")
            slot = &layout.vertex.nz;
        if (!slot) continue;
        if (property.is_list) {
            src.fail(
                fmt::format("vertex property '{}' is a list, expected a number", property.name));
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
        if (!property.is_list)
            src.fail(fmt::format("face property '{}' is not a list", property.name));
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

uint64_t vertex_memory(const Header& header, const MeshLayout& layout) {
    const uint64_t arrays =
        1 + uint64_t(layout.vertex.has_colors()) + uint64_t(layout.vertex.has_normals());
    return header.elements[layout.vertex_element].count * arrays * 3 * sizeof(float);
}

void check_claimed_sizes(const Header& header, const MeshLayout& layout, uint64_t body_bytes,
                         uint64_t memory, const Source& src) {
    // The file: each element's fewest bytes (binary) or values (ascii) after the elements
    // before it. Each ascii value takes at least one character and one separator (bar the
    // last).
    const bool binary = header.format != Format::Ascii;
    const char* const unit = binary ? "bytes" : "values";
    const uint64_t room = binary ? body_bytes : (body_bytes + 1) / 2;
    uint64_t used = 0;  // by the elements before
    for (size_t e = 0; e < header.elements.size(); ++e) {
        const Element& element = header.elements[e];
        const uint64_t min_size =
            min_element_size(element, e == layout.face_element, layout.face_indices, binary);
        if (min_size == 0) continue;
        if (element.count > (room - used) / min_size) {
            const std::string need = element.count > std::numeric_limits<uint64_t>::max() / min_size
                                         ? std::string("more than 2^64")
                                         : fmt::format("{}", element.count * min_size);
            src.fail(fmt::format(
                "header claims {} '{}' elements, but the file is only {} bytes after the "
                "header{}: they need at least {} {} ({} each){}",
                element.count, shown(element.name), body_bytes,
                binary ? "" : fmt::format(" (room for {} values)", room), need, unit, min_size,
                used ? fmt::format(", after the {} {} of the elements before them", used, unit)
                     : ""));
        }
        used += element.count * min_size;
    }

    // Memory: the vertex arrays and one triangle per face, before a fan adds more
    const uint64_t faces = header.elements[layout.face_element].count;
    const uint64_t arrays = vertex_memory(header, layout) + faces * 3 * sizeof(uint32_t);
    if (arrays > memory) {
        src.fail(fmt::format(
            "header claims {} vertices and {} faces: their arrays need at least {} bytes, "
            "more than the {} bytes a file may take (half this machine's memory)",
            header.elements[layout.vertex_element].count, faces, arrays, memory));
    }
}

}  // namespace cierzo::ply
