// Wavefront OBJ reader (see obj.h). tinyobjloader parses the file; before it, one pass over
// the lines checks what tinyobjloader would accept silently (a number that does not parse
// reads as 0 there, an out-of-range index is only a warning), so that every refusal names
// the line, and hands it only the lines it has checked (v, vn, vt, f; the others become
// empty lines: tinyobjloader's readers of lines cierzo does not use are not exposed to the
// file, e.g. its 'vw' reader converts a huge joint id to int, undefined behaviour found by
// fuzzing). A face of more corners than tinyobjloader holds (it stores a face's size in a
// byte) reaches it in pieces whose fans make the face's fan. After it, the counts of both
// passes must agree and every index is checked again before it is used.
#include "io/obj.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <unordered_map>
#include <vector>

#include <fmt/format.h>
// (the parser is compiled into this file: Debian's header holds it, and so the aarch64 build
// and the fuzzers need no library of it)
#define TINYOBJLOADER_IMPLEMENTATION
#include <tiny_obj_loader.h>

#include "core/error.h"
#include "io/mapped_file.h"
#include "io/mesh_file.h"

namespace cierzo {

namespace {

// tinyobjloader stores a face's size in a byte: a longer face is handed to it in pieces of
// at most this many corners.
constexpr size_t kMaxPieceCorners = 255;

// Reading an OBJ file takes up to this many times the bytes of its checked lines at once
// (them, tinyobjloader's copy of them, its arrays and the mesh; measured: a 59 MB file of
// 'v' and 'f' lines, a million vertices and quads, peaks at 404 MB): lines beyond
// reader_memory_bound() divided by this are refused as they are reached, before
// tinyobjloader allocates.
constexpr uint64_t kMemoryPerCheckedByte = 8;

using Source = MeshSource;

// A decimal number, all of the token (a leading '+' allowed), finite and within float range.
bool parse_number(std::string_view token, double& out) {
    if (!token.empty() && token[0] == '+') token.remove_prefix(1);
    const auto [end, ec] =
        std::from_chars(token.data(), token.data() + token.size(), out, std::chars_format::general);
    return ec == std::errc() && end == token.data() + token.size() && std::isfinite(out) &&
           std::fabs(out) <= double(std::numeric_limits<float>::max());
}

// An OBJ index: a non-zero integer (negative: relative to the elements read so far).
bool parse_index(std::string_view token, int64_t& out) {
    if (!token.empty() && token[0] == '+') token.remove_prefix(1);
    const auto [end, ec] = std::from_chars(token.data(), token.data() + token.size(), out);
    return !token.empty() && ec == std::errc() && end == token.data() + token.size() && out != 0 &&
           out > -(int64_t(1) << 31) && out < (int64_t(1) << 31);
}

// What the line pass counted: the elements tinyobjloader must then report.
struct Counts {
    uint64_t vertices = 0, normals = 0, texcoords = 0, faces = 0, corners = 0;
    // The faces and corners handed to tinyobjloader: a face of more than kMaxPieceCorners
    // is several pieces, each after the first repeating two corners
    uint64_t pieces = 0, piece_corners = 0;
    bool colors = true;            // every vertex has a colour
    bool corner_normals = true;    // every corner names a normal
    bool corner_texcoords = true;  // every corner names a texture coordinate
    size_t max_line = 0;           // the line of the largest absolute vertex index, for its message
    int64_t max_vertex = 0, max_normal = 0, max_texcoord = 0;
    size_t max_normal_line = 0, max_texcoord_line = 0;
    std::string checked;  // the file's checked lines, every other line emptied
    // 'usemtl' names in order of first use, each piece's, and the 'mtllib' files
    std::vector<std::string> material_names;
    std::vector<uint32_t> piece_material;
    std::vector<std::string> libraries;
    bool materials = false;  // some 'usemtl'
};

Counts check_lines(std::string_view bytes, const Source& src) {
    Counts c;
    const uint64_t budget = reader_memory_bound() / kMemoryPerCheckedByte;
    // (a larger file is not reserved for: its lines are refused when they outgrow the budget,
    // or at its first NUL byte)
    if (bytes.size() <= budget) c.checked.reserve(bytes.size() + 1);
    // Each line is checked to fit before it is copied (a face's pieces add a few bytes more)
    const auto make_room = [&](size_t more, size_t line_no) {
        if (more > budget - std::min<uint64_t>(c.checked.size(), budget))
            src.fail_at(line_no, fmt::format("reading the file up to here needs more than the "
                                             "{} bytes a file may take (half this machine's "
                                             "memory; an OBJ file takes about {} times its "
                                             "size to read)",
                                             reader_memory_bound(), kMemoryPerCheckedByte));
    };
    uint32_t current_material = 0;  // faces before any 'usemtl': "" (added when needed)
    TextLines lines{bytes, src, "OBJ"};
    for (std::string_view line; lines.next(line);) {
        const size_t line_no = lines.number;
        std::string_view rest = line;
        const std::string_view key = next_token(rest);
        const bool kept = key == "v" || key == "vn" || key == "vt" || key == "f";
        make_room(kept ? line.size() + 1 : 1, line_no);
        // (a face is written below, corner by corner)
        if (key == "v" || key == "vn" || key == "vt") c.checked.append(line);
        if (key != "f") c.checked.push_back('\n');
        if (key == "usemtl") {
            std::string_view name = rest;
            while (!name.empty() && (name.front() == ' ' || name.front() == '\t'))
                name.remove_prefix(1);
            while (!name.empty() && (name.back() == ' ' || name.back() == '\t'))
                name.remove_suffix(1);
            // (an empty name is the default material, as before any 'usemtl')
            if (!c.materials && c.faces > 0) c.material_names.push_back("");
            c.materials = true;
            const auto it = std::find(c.material_names.begin(), c.material_names.end(), name);
            current_material = uint32_t(it - c.material_names.begin());
            if (it == c.material_names.end()) c.material_names.emplace_back(name);
            continue;
        }
        if (key == "mtllib") {
            size_t n = 0;
            for (std::string_view t = next_token(rest); !t.empty(); t = next_token(rest), ++n) {
                std::string file(t);
                for (char& ch : file)
                    if (ch == '\\') ch = '/';
                if (std::find(c.libraries.begin(), c.libraries.end(), file) == c.libraries.end())
                    c.libraries.push_back(std::move(file));
            }
            if (n == 0) src.fail_at(line_no, "'mtllib' needs a file name");
            continue;
        }
        if (key == "v" || key == "vn") {
            double value[8];
            size_t n = 0;
            for (std::string_view t = next_token(rest); !t.empty(); t = next_token(rest)) {
                if (n == 7 || !parse_number(t, value[n]))
                    src.fail_at(line_no, fmt::format("'{}' is not a number in float range "
                                                     "(or there are too many values)",
                                                     t));
                ++n;
            }
            if (key == "vn") {
                if (n != 3)
                    src.fail_at(line_no, fmt::format("a normal 'vn' needs 3 numbers, "
                                                     "not {}",
                                                     n));
                ++c.normals;
                continue;
            }
            if (n == 4 && value[3] != 1.0)
                src.fail_at(line_no,
                            "a vertex with a weight w other than 1 (rational "
                            "geometry) is not supported");
            if (n != 3 && n != 4 && n != 6)
                src.fail_at(line_no, fmt::format("a vertex 'v' needs 3 numbers (x y z), 4 "
                                                 "(x y z 1) or 6 (x y z r g b), not {}",
                                                 n));
            c.colors &= n == 6;
            ++c.vertices;
        } else if (key == "vt") {
            // (not used, but tinyobjloader reads them: u [v [w]], numbers)
            double value;
            size_t n = 0;
            for (std::string_view t = next_token(rest); !t.empty(); t = next_token(rest), ++n)
                if (n == 3 || !parse_number(t, value))
                    src.fail_at(line_no, fmt::format("'{}' is not a number in float range "
                                                     "(or there are too many values)",
                                                     t));
            if (n == 0) src.fail_at(line_no, "a texture coordinate 'vt' needs 1 to 3 numbers");
            ++c.texcoords;
        } else if (key == "f") {
            // Corners 1..n go to tinyobjloader as "f 1 2 .. 255", then "f 1 255 256 .. 508"
            // and so on: each piece's fan from corner 1 goes on where the last one stopped,
            // so the triangles are those of the face's fan
            c.checked.append("f");
            std::string_view first, previous;
            size_t corners = 0, in_piece = 0;
            for (std::string_view t = next_token(rest); !t.empty(); t = next_token(rest)) {
                // v, v/vt, v//vn or v/vt/vn
                std::string_view part[3];
                size_t parts = 0;
                for (size_t a = 0;;) {
                    const size_t slash = t.find('/', a);
                    if (parts == 3) src.fail_at(line_no, fmt::format("bad face corner '{}'", t));
                    part[parts++] =
                        t.substr(a, slash == std::string_view::npos ? slash : slash - a);
                    if (slash == std::string_view::npos) break;
                    a = slash + 1;
                }
                int64_t index[3] = {0, 0, 0};
                for (size_t k = 0; k < parts; ++k) {
                    if (k == 1 && part[k].empty() && parts == 3) continue;  // v//vn
                    if (!parse_index(part[k], index[k]))
                        src.fail_at(line_no,
                                    fmt::format("bad face corner '{}' (indices are non-zero "
                                                "integers; 1 is the first element)",
                                                t));
                }
                // Relative (negative) indices count back from the last element read
                const uint64_t count[3] = {c.vertices, c.texcoords, c.normals};
                const char* what[3] = {"vertex", "texture coordinate", "normal"};
                for (size_t k = 0; k < 3; ++k) {
                    if (index[k] < 0 && uint64_t(-index[k]) > count[k])
                        src.fail_at(line_no, fmt::format("face corner '{}' refers to {} {} "
                                                         "before the first",
                                                         t, what[k], index[k]));
                }
                const int64_t v = index[0] < 0 ? int64_t(c.vertices) + index[0] + 1 : index[0];
                if (v > c.max_vertex) c.max_vertex = v, c.max_line = line_no;
                if (parts == 3) {
                    const int64_t vn = index[2] < 0 ? int64_t(c.normals) + index[2] + 1 : index[2];
                    if (vn > c.max_normal) c.max_normal = vn, c.max_normal_line = line_no;
                } else {
                    c.corner_normals = false;
                }
                if (parts >= 2 && !part[1].empty()) {
                    const int64_t vt =
                        index[1] < 0 ? int64_t(c.texcoords) + index[1] + 1 : index[1];
                    if (vt > c.max_texcoord) c.max_texcoord = vt, c.max_texcoord_line = line_no;
                } else {
                    c.corner_texcoords = false;
                }
                if (in_piece == kMaxPieceCorners) {
                    c.checked.append("\nf ").append(first).append(" ").append(previous);
                    c.piece_corners += in_piece;
                    ++c.pieces;
                    c.piece_material.push_back(current_material);
                    in_piece = 2;
                }
                c.checked.append(" ").append(t);
                if (corners == 0) first = t;
                previous = t;
                ++in_piece;
                ++corners;
            }
            c.checked.push_back('\n');
            if (corners < 3)
                src.fail_at(line_no,
                            fmt::format("a face needs at least 3 corners, not {}", corners));
            ++c.faces;
            c.corners += corners;
            c.piece_corners += in_piece;
            ++c.pieces;
            c.piece_material.push_back(current_material);
        }
    }
    if (uint64_t(c.max_vertex) > c.vertices)
        src.fail_at(c.max_line, fmt::format("face refers to vertex {}, but the file has {} "
                                            "vertices",
                                            c.max_vertex, c.vertices));
    if (uint64_t(c.max_normal) > c.normals)
        src.fail_at(c.max_normal_line, fmt::format("face refers to normal {}, but the file has "
                                                   "{} normals",
                                                   c.max_normal, c.normals));
    if (uint64_t(c.max_texcoord) > c.texcoords)
        src.fail_at(c.max_texcoord_line,
                    fmt::format("face refers to texture coordinate {}, but the file has {}",
                                c.max_texcoord, c.texcoords));
    if (c.faces == 0) src.fail("has no faces ('f' lines)");
    if (c.vertices >= (uint64_t(1) << 31)) src.fail("has more than 2^31 vertices");
    return c;
}

}  // namespace

MeshData parse_obj(std::string_view bytes, const std::filesystem::path& name) {
    const Source src{name.string()};
    const Counts counts = check_lines(bytes, src);

    tinyobj::ObjReaderConfig config;
    config.triangulate = false;   // fan-triangulated below, as PLY faces are
    config.vertex_color = false;  // colours only when every vertex has them
    tinyobj::ObjReader reader;
    // (materials are the scene's: the file's mtllib is not read)
    if (!reader.ParseFromString(counts.checked, std::string(), config))
        src.fail("cannot be parsed: " + reader.Error());
    const tinyobj::attrib_t& attrib = reader.GetAttrib();
    const auto& shapes = reader.GetShapes();

    // Both passes must have seen the same file
    uint64_t faces = 0, corners = 0;
    for (const tinyobj::shape_t& shape : shapes) {
        faces += shape.mesh.num_face_vertices.size();
        for (const unsigned char n : shape.mesh.num_face_vertices) corners += n;
        if (shape.mesh.indices.size() != [&] {
                size_t sum = 0;
                for (const unsigned char n : shape.mesh.num_face_vertices) sum += n;
                return sum;
            }())
            src.fail("inconsistent face sizes from the OBJ parser");
    }
    if (attrib.vertices.size() != counts.vertices * 3 ||
        attrib.normals.size() != counts.normals * 3 ||
        attrib.texcoords.size() != counts.texcoords * 2 || faces != counts.pieces ||
        corners != counts.piece_corners)
        src.fail(
            fmt::format("the OBJ parser read {} vertices, {} normals and {} faces where "
                        "the file has {}, {} and {}: a line it reads otherwise",
                        attrib.vertices.size() / 3, attrib.normals.size() / 3, faces,
                        counts.vertices, counts.normals, counts.pieces));

    MeshData mesh;
    const size_t nv = attrib.vertices.size() / 3, nn = attrib.normals.size() / 3;
    const bool colors = counts.colors && attrib.colors.size() == attrib.vertices.size();
    const bool normals = counts.corner_normals && nn > 0;
    const auto finite = [](const std::vector<float>& v) {
        for (const float x : v)
            if (!std::isfinite(x)) return false;
        return true;
    };
    if (!finite(attrib.vertices) || (normals && !finite(attrib.normals)) ||
        (colors && !finite(attrib.colors)))
        src.fail("has a value outside the float range");

    // Corners become vertices: a file vertex as it is without normals and texture
    // coordinates; with them, one vertex per distinct (position, coordinate, normal)
    const size_t nt = attrib.texcoords.size() / 2;
    const bool texcoords = counts.corner_texcoords && nt > 0;
    if (texcoords && !finite(attrib.texcoords)) src.fail("has a value outside the float range");
    struct Corner {
        uint32_t v, t, n;
        bool operator==(const Corner&) const = default;
    };
    struct CornerHash {
        size_t operator()(const Corner& c) const {
            uint64_t h = (uint64_t(c.v) << 32 | c.n) * 0x9e3779b97f4a7c15ull;
            return size_t(h ^ (uint64_t(c.t) * 0xc2b2ae3d27d4eb4full) ^ (h >> 29));
        }
    };
    std::unordered_map<Corner, uint32_t, CornerHash> split;
    const auto vertex_of = [&](const tinyobj::index_t& idx) -> uint32_t {
        if (idx.vertex_index < 0 || size_t(idx.vertex_index) >= nv)
            src.fail(fmt::format("face refers to vertex {} of {}", idx.vertex_index + 1, nv));
        if (!normals && !texcoords) return uint32_t(idx.vertex_index);
        if (normals && (idx.normal_index < 0 || size_t(idx.normal_index) >= nn))
            src.fail(fmt::format("face refers to normal {} of {}", idx.normal_index + 1, nn));
        if (texcoords && (idx.texcoord_index < 0 || size_t(idx.texcoord_index) >= nt))
            src.fail(fmt::format("face refers to texture coordinate {} of {}",
                                 idx.texcoord_index + 1, nt));
        const Corner key{uint32_t(idx.vertex_index), texcoords ? uint32_t(idx.texcoord_index) : 0u,
                         normals ? uint32_t(idx.normal_index) : 0u};
        const auto [it, added] = split.try_emplace(key, uint32_t(mesh.positions.size() / 3));
        if (added) {
            for (int k = 0; k < 3; ++k) {
                mesh.positions.push_back(attrib.vertices[3 * size_t(idx.vertex_index) + k]);
                if (normals)
                    mesh.normals.push_back(attrib.normals[3 * size_t(idx.normal_index) + k]);
                if (colors) mesh.colors.push_back(attrib.colors[3 * size_t(idx.vertex_index) + k]);
            }
            if (texcoords)
                for (int k = 0; k < 2; ++k)
                    mesh.uvs.push_back(attrib.texcoords[2 * size_t(idx.texcoord_index) + k]);
        }
        return it->second;
    };
    if (!normals && !texcoords) {
        mesh.positions = attrib.vertices;
        if (colors) mesh.colors = attrib.colors;
    }
    mesh.indices.reserve(size_t(counts.corners - 2 * counts.faces) * 3);
    size_t piece = 0;  // (the shapes hold the pieces in file order: every 'o' and 'g' line
                       // was emptied, so there is one)
    for (const tinyobj::shape_t& shape : shapes) {
        size_t at = 0;
        for (const unsigned char n : shape.mesh.num_face_vertices) {
            const uint32_t first = vertex_of(shape.mesh.indices[at]);
            uint32_t previous = vertex_of(shape.mesh.indices[at + 1]);
            for (size_t k = 2; k < n; ++k) {
                const uint32_t next = vertex_of(shape.mesh.indices[at + k]);
                mesh.indices.insert(mesh.indices.end(), {first, previous, next});
                if (counts.materials)
                    mesh.triangle_material.push_back(counts.piece_material[piece]);
                previous = next;
            }
            at += n;
            ++piece;
        }
    }
    if (counts.materials) mesh.material_names = counts.material_names;
    mesh.libraries = counts.libraries;
    return mesh;
}

MeshData read_obj(const std::filesystem::path& path) {
    return read_mapped(path, [&](std::string_view bytes) { return parse_obj(bytes, path); });
}

}  // namespace cierzo
