// Tests for the PLY reader: the same mesh written as ascii, binary little-endian and binary
// big-endian (bytes built with explicit byte order) must read back identically; bad files fail.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <bit>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <random>
#include <string>
#include <string_view>
#include <type_traits>
#include <vector>

#include "core/error.h"
#include "io/mapped_file.h"
#include "io/ply.h"
#include "support/sparse_file.h"

namespace {

namespace fs = std::filesystem;
using cierzo::InputError;
using cierzo::MeshData;
using cierzo::read_ply;
using cierzo::test::k30GiB;
using cierzo::test::kGenerousGrowth;
using cierzo::test::kGenerousSeconds;
using cierzo::test::kNoSparseFiles;
using cierzo::test::make_sparse_file;
using cierzo::test::ReadCost;

enum class Fmt { Ascii, Le, Be };

const char* format_line(Fmt format) {
    switch (format) {
        case Fmt::Ascii: return "format ascii 1.0\n";
        case Fmt::Le: return "format binary_little_endian 1.0\n";
        case Fmt::Be: return "format binary_big_endian 1.0\n";
    }
    return "";
}

const char* format_label(Fmt format) {
    switch (format) {
        case Fmt::Ascii: return "ascii";
        case Fmt::Le: return "binary_little_endian";
        case Fmt::Be: return "binary_big_endian";
    }
    return "";
}

constexpr Fmt all_formats[] = {Fmt::Ascii, Fmt::Le, Fmt::Be};

template <size_t N>
using UIntOfSize = std::conditional_t<
    N == 1, uint8_t,
    std::conditional_t<N == 2, uint16_t, std::conditional_t<N == 4, uint32_t, uint64_t>>>;

// A PLY body in one encoding. Binary values are emitted byte by byte from their integer bit
// pattern, so the byte order in the file is the one asked for whatever the host's is.
class Body {
public:
    explicit Body(Fmt format) : format_(format) {}

    void value(std::string_view type, double v) {
        if (format_ == Fmt::Ascii) {
            if (!line_start_) bytes_ += ' ';
            bytes_ += ascii_text(type, v);
            line_start_ = false;
            return;
        }
        if (type == "char" || type == "int8")
            put(int8_t(v));
        else if (type == "uchar" || type == "uint8")
            put(uint8_t(v));
        else if (type == "short" || type == "int16")
            put(int16_t(v));
        else if (type == "ushort" || type == "uint16")
            put(uint16_t(v));
        else if (type == "int" || type == "int32")
            put(int32_t(v));
        else if (type == "uint" || type == "uint32")
            put(uint32_t(v));
        else if (type == "float" || type == "float32")
            put(float(v));
        else if (type == "double" || type == "float64")
            put(v);
        else
            ADD_FAILURE() << "test bug: unknown type " << type;
    }
    void end_element() {
        if (format_ == Fmt::Ascii) bytes_ += '\n';
        line_start_ = true;
    }
    const std::string& bytes() const { return bytes_; }

private:
    static std::string ascii_text(std::string_view type, double v) {
        char buffer[64];
        if (type == "float" || type == "float32") {
            std::snprintf(buffer, sizeof buffer, "%.9g", double(float(v)));
        } else if (type == "double" || type == "float64") {
            std::snprintf(buffer, sizeof buffer, "%.17g", v);
        } else {
            std::snprintf(buffer, sizeof buffer, "%lld", static_cast<long long>(v));
        }
        return buffer;
    }
    template <class T>
    void put(T v) {
        auto bits = std::bit_cast<UIntOfSize<sizeof(T)>>(v);
        for (size_t i = 0; i < sizeof(T); ++i) {
            size_t shift = format_ == Fmt::Le ? 8 * i : 8 * (sizeof(T) - 1 - i);
            bytes_ += char((uint64_t(bits) >> shift) & 0xff);
        }
    }

    Fmt format_;
    std::string bytes_;
    bool line_start_ = true;
};

std::string ply_file(Fmt format, std::string_view header_body, const Body& body) {
    return "ply\n" + std::string(format_line(format)) + std::string(header_body) + "end_header\n" +
           body.bytes();
}

// ---- The reference mesh: a triangle, a quad and a pentagon over six vertices ---------

const std::vector<std::array<double, 3>> float_positions = {{0.0, 0.0, 0.0},  {1.0, 0.0, 0.0},
                                                            {1.0, 1.0, 0.0},  {0.0, 1.0, 0.0},
                                                            {0.5, 2.0, -1.0}, {-1.25, 0.5, 3.0}};
// The same shape with small non-negative integers, for integer coordinate types.
const std::vector<std::array<double, 3>> integer_positions = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0},
                                                              {0, 1, 0}, {2, 2, 1}, {3, 1, 2}};
const std::vector<std::vector<int>> reference_faces = {{0, 1, 2}, {0, 2, 3, 5}, {1, 4, 5, 3, 2}};
// Fans: (0 1 2); (0 2 3)(0 3 5); (1 4 5)(1 5 3)(1 3 2).
const std::vector<uint32_t> reference_indices = {0, 1, 2, 0, 2, 3, 0, 3, 5,
                                                 1, 4, 5, 1, 5, 3, 1, 3, 2};
// Colour as a fraction of full scale per vertex and channel.
const std::vector<std::array<double, 3>> color_fractions = {{1.0, 0.0, 0.0}, {0.0, 1.0, 0.0},
                                                            {0.0, 0.0, 1.0}, {0.2, 0.4, 0.6},
                                                            {0.0, 0.0, 0.0}, {1.0, 1.0, 1.0}};

double full_scale(std::string_view type) {
    if (type == "char") return 127;
    if (type == "uchar") return 255;
    if (type == "short") return 32767;
    if (type == "ushort") return 65535;
    if (type == "int") return 2147483647.0;
    if (type == "uint") return 4294967295.0;
    return 1.0;  // float, double
}

// The value stored in the file for a colour fraction (rounded for integer types).
double raw_color(std::string_view type, double fraction) {
    double scale = full_scale(type);
    return scale == 1.0 ? fraction : std::round(fraction * scale);
}

bool is_float_type(std::string_view type) {
    return type == "float" || type == "float32" || type == "double" || type == "float64";
}

struct Layout {
    std::string coord_type = "float";
    std::string color_type = "uchar";  // empty: no colours
    std::string count_type = "uchar";
    std::string index_type = "int";
    std::string list_name = "vertex_indices";
    bool extras = false;  // unknown properties and elements everywhere
};

// Writes the reference mesh; with extras, unknown elements (with lists) come before, between
// and after the vertex and face elements, and both carry unknown scalar and list properties.
std::string reference_ply(Fmt format, const Layout& layout) {
    const auto& positions = is_float_type(layout.coord_type) ? float_positions : integer_positions;
    const bool colors = !layout.color_type.empty();
    std::string header;
    Body body(format);

    // Header.
    if (layout.extras) {
        header += "comment written by test_ply\nobj_info synthetic\n";
        header += "element material 2\nproperty list uchar float weights\nproperty uchar id\n";
    }
    header += "element vertex 6\n";
    if (layout.extras) header += "property float confidence\n";
    header += "property " + layout.coord_type + " x\nproperty " + layout.coord_type + " y\n";
    if (layout.extras) header += "property float nx\nproperty list ushort int neighbours\n";
    header += "property " + layout.coord_type + " z\n";
    if (colors) {
        for (const char* channel : {"red", "green", "blue"}) {
            header += "property " + layout.color_type + " " + channel + "\n";
        }
    }
    if (layout.extras) {
        header += "property double u\nproperty uchar alpha\n";
        header +=
            "comment between elements\nelement edge 2\nproperty int vertex1\n"
            "property int vertex2\nproperty uchar red\n";
    }
    header += "element face 3\n";
    if (layout.extras) header += "property uchar flags\n";
    header += "property list " + layout.count_type + " " + layout.index_type + " " +
              layout.list_name + "\n";
    if (layout.extras) {
        header += "property list uchar float texcoord\nproperty int material_index\n";
        header += "element tail 3\nproperty list int short blob\n";
    }

    // Body: material, vertex, edge, face, tail.
    if (layout.extras) {
        for (int m = 0; m < 2; ++m) {
            body.value("uchar", 3 * m);
            for (int k = 0; k < 3 * m; ++k) body.value("float", 0.25 * k);
            body.value("uchar", 7 + m);
            body.end_element();
        }
    }
    for (size_t v = 0; v < positions.size(); ++v) {
        if (layout.extras) body.value("float", 0.75);
        body.value(layout.coord_type, positions[v][0]);
        body.value(layout.coord_type, positions[v][1]);
        if (layout.extras) {
            body.value("float", -9.5);
            body.value("ushort", double(v % 3));  // neighbour lists of length 0, 1 and 2
            for (size_t k = 0; k < v % 3; ++k) body.value("int", 1000 + double(k));
        }
        body.value(layout.coord_type, positions[v][2]);
        for (int c = 0; c < 3 && colors; ++c) {
            body.value(layout.color_type, raw_color(layout.color_type, color_fractions[v][c]));
        }
        if (layout.extras) {
            body.value("double", 1e300);
            body.value("uchar", 200);
        }
        body.end_element();
    }
    if (layout.extras) {
        for (int e = 0; e < 2; ++e) {
            body.value("int", e);
            body.value("int", e + 1);
            body.value("uchar", 9);
            body.end_element();
        }
    }
    for (const auto& face : reference_faces) {
        if (layout.extras) body.value("uchar", 0xff);
        body.value(layout.count_type, double(face.size()));
        for (int index : face) body.value(layout.index_type, index);
        if (layout.extras) {
            body.value("uchar", double(2 * face.size()));
            for (size_t k = 0; k < 2 * face.size(); ++k) body.value("float", 0.5);
            body.value("int", -7);
        }
        body.end_element();
    }
    if (layout.extras) {
        for (int t = 0; t < 3; ++t) {
            body.value("int", t);
            for (int k = 0; k < t; ++k) body.value("short", -1);
            body.end_element();
        }
    }
    return ply_file(format, header, body);
}

// ---- Fixture and checks -------------------------------------------------------------

class PlyTest : public ::testing::Test {
protected:
    void SetUp() override {
        const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
        std::random_device random;
        dir_ = fs::temp_directory_path() / ("cierzo-test-ply-" + std::string(info->name()) + "-" +
                                            std::to_string(random()) + std::to_string(random()));
        fs::create_directories(dir_);
    }
    void TearDown() override {
        std::error_code ec;
        fs::remove_all(dir_, ec);
    }

    fs::path write(const std::string& name, std::string_view bytes) {
        fs::path path = dir_ / name;
        std::ofstream out(path, std::ios::binary);
        out.write(bytes.data(), std::streamsize(bytes.size()));
        EXPECT_TRUE(out.good()) << "could not write " << path;
        return path;
    }

    fs::path dir_;
};

// read_ply must throw InputError whose message starts with the path and contains `phrase`.
void expect_input_error(const fs::path& path, std::string_view phrase) {
    try {
        read_ply(path);
        ADD_FAILURE() << "no exception for " << path.filename() << " (expected '" << phrase << "')";
    } catch (const InputError& error) {
        std::string message = error.what();
        EXPECT_TRUE(message.starts_with(path.string())) << "message: " << message;
        EXPECT_NE(message.find(phrase), std::string::npos)
            << "message: " << message << "\nexpected phrase: " << phrase;
    } catch (const std::exception& error) {
        ADD_FAILURE() << "wrong exception type for " << path.filename() << ": " << error.what();
    }
}

void expect_positions(const MeshData& mesh, const std::vector<std::array<double, 3>>& expected) {
    ASSERT_EQ(mesh.positions.size(), expected.size() * 3);
    for (size_t v = 0; v < expected.size(); ++v) {
        for (size_t c = 0; c < 3; ++c) {
            EXPECT_EQ(mesh.positions[v * 3 + c], float(expected[v][c])) << "vertex " << v;
        }
    }
}

void expect_colors(const MeshData& mesh, std::string_view type) {
    ASSERT_EQ(mesh.colors.size(), color_fractions.size() * 3);
    for (size_t v = 0; v < color_fractions.size(); ++v) {
        for (size_t c = 0; c < 3; ++c) {
            double raw = raw_color(type, color_fractions[v][c]);
            if (type == "float") raw = double(float(raw));
            EXPECT_NEAR(mesh.colors[v * 3 + c], raw / full_scale(type), 1e-6)
                << "vertex " << v << " channel " << c << " type " << type;
        }
    }
}

// ---- Good files ---------------------------------------------------------------------

TEST_F(PlyTest, AsciiLittleAndBigEndianGiveTheSameMesh) {
    for (bool extras : {false, true}) {
        std::vector<MeshData> meshes;
        for (Fmt format : all_formats) {
            SCOPED_TRACE(std::string(format_label(format)) + (extras ? " with extras" : ""));
            Layout layout;
            layout.extras = extras;
            MeshData mesh = read_ply(write("mesh.ply", reference_ply(format, layout)));
            expect_positions(mesh, float_positions);
            expect_colors(mesh, "uchar");
            EXPECT_EQ(mesh.indices, reference_indices);
            meshes.push_back(std::move(mesh));
        }
        for (size_t m = 1; m < meshes.size(); ++m) {
            EXPECT_EQ(meshes[m].positions, meshes[0].positions);
            EXPECT_EQ(meshes[m].colors, meshes[0].colors);
            EXPECT_EQ(meshes[m].indices, meshes[0].indices);
        }
    }
}

TEST_F(PlyTest, BinaryBodiesReallyDifferInByteOrder) {
    std::string le = reference_ply(Fmt::Le, Layout{});
    std::string be = reference_ply(Fmt::Be, Layout{});
    size_t le_body = le.find("end_header\n") + 11;
    size_t be_body = be.find("end_header\n") + 11;
    ASSERT_EQ(le.size() - le_body, be.size() - be_body);
    EXPECT_NE(le.substr(le_body), be.substr(be_body));
    // Vertices are 15 bytes (x y z floats, rgb uchars); x of vertex 1 is 1.0f, stored as
    // 00 00 80 3f little-endian and 3f 80 00 00 big-endian.
    EXPECT_EQ(le.substr(le_body + 15, 4), std::string("\x00\x00\x80\x3f", 4));
    EXPECT_EQ(be.substr(be_body + 15, 4), std::string("\x3f\x80\x00\x00", 4));
}

TEST_F(PlyTest, LittleEndianBytesLabelledBigEndianAreNotReadAsTheSameMesh) {
    std::string file = reference_ply(Fmt::Le, Layout{});
    file.replace(file.find("binary_little_endian"), 20, "binary_big_endian   ");
    // Index 1 as int32 LE read big-endian is 16777216: out of range.
    expect_input_error(write("mislabelled.ply", file), "out of range");
}

TEST_F(PlyTest, EveryScalarTypeInEveryFormat) {
    const std::vector<std::string> coord_types = {"char", "uchar", "short",  "ushort", "int",
                                                  "uint", "float", "double", "int8",   "float64"};
    const std::vector<std::string> color_types = {"uchar", "char", "ushort", "short",
                                                  "uint",  "int",  "float",  "double"};
    const std::vector<std::string> count_types = {"uchar", "char", "ushort", "short",
                                                  "uint",  "int",  "uint8",  "int32"};
    const std::vector<std::string> index_types = {"int",   "uint", "short", "ushort",
                                                  "uchar", "char", "int32", "uint16"};
    for (Fmt format : all_formats) {
        for (size_t t = 0; t < coord_types.size(); ++t) {
            Layout layout;
            layout.coord_type = coord_types[t];
            layout.color_type = color_types[t % color_types.size()];
            layout.count_type = count_types[t % count_types.size()];
            layout.index_type = index_types[(t + 3) % index_types.size()];
            layout.extras = t % 2 == 1;
            SCOPED_TRACE(std::string(format_label(format)) + " coord " + layout.coord_type +
                         " colour " + layout.color_type + " count " + layout.count_type +
                         " index " + layout.index_type);
            MeshData mesh = read_ply(write("types.ply", reference_ply(format, layout)));
            expect_positions(
                mesh, is_float_type(layout.coord_type) ? float_positions : integer_positions);
            expect_colors(mesh, layout.color_type);
            EXPECT_EQ(mesh.indices, reference_indices);
        }
    }
}

TEST_F(PlyTest, ColorScaling) {
    // uchar 51/255 = 0.2, ushort 65535 = 1, char 127 = 1, float kept as is, none = empty.
    const char* header_start =
        "element vertex 1\nproperty float x\nproperty float y\n"
        "property float z\n";
    const char* face = "element face 1\nproperty list uchar int vertex_indices\n";
    struct Case {
        const char* type;
        double raw[3];
        float expected[3];
    };
    for (const Case& c : {Case{"uchar", {51, 255, 0}, {0.2f, 1.0f, 0.0f}},
                          Case{"ushort", {65535, 0, 13107}, {1.0f, 0.0f, 0.2f}},
                          Case{"char", {127, 0, 127}, {1.0f, 0.0f, 1.0f}},
                          Case{"float", {0.25, 1.5, 0.125}, {0.25f, 1.5f, 0.125f}}}) {
        for (Fmt format : all_formats) {
            SCOPED_TRACE(std::string(c.type) + " " + format_label(format));
            std::string header = header_start;
            for (const char* channel : {"red", "green", "blue"}) {
                header += std::string("property ") + c.type + " " + channel + "\n";
            }
            header += face;
            Body body(format);
            for (double v : {1.0, 2.0, 3.0}) body.value("float", v);
            for (double r : c.raw) body.value(c.type, r);
            body.end_element();
            for (double v : {3.0, 0.0, 0.0, 0.0}) body.value(v == 3.0 ? "uchar" : "int", v);
            body.end_element();
            MeshData mesh = read_ply(write("colour.ply", ply_file(format, header, body)));
            ASSERT_EQ(mesh.colors.size(), 3u);
            for (int k = 0; k < 3; ++k) EXPECT_FLOAT_EQ(mesh.colors[size_t(k)], c.expected[k]);
        }
    }
    Layout no_colors;
    no_colors.color_type.clear();
    MeshData mesh = read_ply(write("plain.ply", reference_ply(Fmt::Le, no_colors)));
    EXPECT_TRUE(mesh.colors.empty());
    EXPECT_EQ(mesh.positions.size(), 18u);
}

TEST_F(PlyTest, HexagonFanAndVertexIndexName) {
    std::string header =
        "element vertex 7\nproperty float x\nproperty float y\nproperty float z\n"
        "element face 2\nproperty list uchar uint vertex_index\n";
    for (Fmt format : all_formats) {
        Body body(format);
        for (int v = 0; v < 7; ++v) {
            for (double c : {double(v), double(v * v), -double(v)}) body.value("float", c);
            body.end_element();
        }
        body.value("uchar", 6);
        for (int v : {6, 5, 4, 3, 2, 1}) body.value("uint", v);
        body.end_element();
        body.value("uchar", 3);
        for (int v : {0, 6, 3}) body.value("uint", v);
        body.end_element();
        MeshData mesh = read_ply(write("hexagon.ply", ply_file(format, header, body)));
        const std::vector<uint32_t> fans = {6, 5, 4, 6, 4, 3, 6, 3, 2, 6, 2, 1, 0, 6, 3};
        EXPECT_EQ(mesh.indices, fans) << format_label(format);
        EXPECT_EQ(mesh.positions[3 * 5 + 1], 25.0f);
    }
}

TEST_F(PlyTest, CrLfLineEndingsCommentsAndTrailingGarbage) {
    std::string ascii =
        "ply\r\nformat ascii 1.0\r\ncomment hello\r\nelement vertex 3\r\n"
        "property float x\r\nproperty float y\r\nproperty float z\r\n"
        "element face 1\r\nproperty list uchar int vertex_indices\r\n"
        "end_header\r\n1 2 3\r\n\r\n4 5 6\r\n7 8 9\r\n3 2 1 0\r\n"
        "this is trailing junk\r\n";
    MeshData mesh = read_ply(write("crlf.ply", ascii));
    EXPECT_EQ(mesh.positions, (std::vector<float>{1, 2, 3, 4, 5, 6, 7, 8, 9}));
    EXPECT_EQ(mesh.indices, (std::vector<uint32_t>{2, 1, 0}));

    std::string binary = reference_ply(Fmt::Be, Layout{}) + std::string("\x01\x02\x03junk", 7);
    MeshData from_binary = read_ply(write("junk.ply", binary));
    EXPECT_EQ(from_binary.indices, reference_indices);
}

// Blender 2.4x wrote 'Created by Blender3D ...' after the format line, without 'comment'
// (assimp's test model Wuson.ply): before the first element such a line is a comment, with a
// warning naming the file and line.
TEST_F(PlyTest, AnUnknownLineBeforeTheFirstElementIsACommentWithAWarning) {
    const std::string text =
        "ply\nformat ascii 1.0\nCreated by Blender3D 247 - www.blender.org\n"
        "element vertex 3\nproperty float x\nproperty float y\n"
        "property float z\nelement face 1\n"
        "property list uchar int vertex_indices\nend_header\n"
        "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
    const MeshData mesh = read_ply(write("blender247.ply", text));
    EXPECT_EQ(mesh.indices, (std::vector<uint32_t>{0, 1, 2}));
    ASSERT_EQ(mesh.warnings.size(), 1u);
    EXPECT_NE(
        mesh.warnings[0].find("blender247.ply: line 3: 'Created' is not a PLY header keyword"),
        std::string::npos)
        << mesh.warnings[0];
    // A file without such a line has no warnings
    EXPECT_TRUE(read_ply(write("plain.ply", reference_ply(Fmt::Ascii, Layout{}))).warnings.empty());
}

TEST_F(PlyTest, EmptyMeshIsAllowed) {
    std::string header =
        "element vertex 0\nproperty float x\nproperty float y\nproperty float z\n"
        "element face 0\nproperty list uchar int vertex_indices\n";
    for (Fmt format : all_formats) {
        MeshData mesh = read_ply(write("empty.ply", ply_file(format, header, Body(format))));
        EXPECT_TRUE(mesh.positions.empty());
        EXPECT_TRUE(mesh.indices.empty());
    }
}

TEST_F(PlyTest, HundredThousandTrianglesLoadQuickly) {
    constexpr int n = 225;  // 225 x 225 vertices, 224 x 224 quads = 100352 triangles
    std::string header = "element vertex " + std::to_string(n * n) +
                         "\nproperty float x\nproperty float y\nproperty float z\n"
                         "element face " +
                         std::to_string((n - 1) * (n - 1)) +
                         "\nproperty list uchar int vertex_indices\n";
    for (Fmt format : all_formats) {
        Body body(format);
        for (int j = 0; j < n; ++j) {
            for (int i = 0; i < n; ++i) {
                for (double c : {double(i), double(j), 0.5 * (i + j)}) body.value("float", c);
                body.end_element();
            }
        }
        for (int j = 0; j + 1 < n; ++j) {
            for (int i = 0; i + 1 < n; ++i) {
                body.value("uchar", 4);
                for (int v : {j * n + i, j * n + i + 1, (j + 1) * n + i + 1, (j + 1) * n + i}) {
                    body.value("int", v);
                }
                body.end_element();
            }
        }
        fs::path path = write("grid.ply", ply_file(format, header, body));
        auto start = std::chrono::steady_clock::now();
        MeshData mesh = read_ply(path);
        double seconds =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        EXPECT_LT(seconds, 1.0) << format_label(format);
        ASSERT_EQ(mesh.indices.size(), size_t(3 * 2 * (n - 1) * (n - 1)));
        ASSERT_EQ(mesh.positions.size(), size_t(3 * n * n));
        size_t last_quad = size_t((n - 1) * (n - 1) - 1);
        EXPECT_EQ(mesh.indices[6 * last_quad + 5], uint32_t((n - 1) * n + n - 2));
        EXPECT_EQ(mesh.positions[3 * size_t(n * n - 1) + 2], float(n - 1));
        RecordProperty(std::string("seconds_") + format_label(format), std::to_string(seconds));
    }
}

// ---- Bad files ----------------------------------------------------------------------

const char* const plain_header =
    "element vertex 6\nproperty float x\nproperty float y\n"
    "property float z\nelement face 3\n"
    "property list uchar int vertex_indices\n";

// The reference mesh without colours, as a body to tamper with.
Body plain_body(Fmt format, const std::vector<std::vector<int>>& faces = reference_faces) {
    Body body(format);
    for (const auto& p : float_positions) {
        for (double c : p) body.value("float", c);
        body.end_element();
    }
    for (const auto& face : faces) {
        body.value("uchar", double(face.size()));
        for (int index : face) body.value("int", index);
        body.end_element();
    }
    return body;
}

TEST_F(PlyTest, MissingFileAndDirectory) {
    expect_input_error(dir_ / "no-such-file.ply", "does not exist");
    fs::create_directory(dir_ / "folder.ply");
    expect_input_error(dir_ / "folder.ply", "directory");
}

TEST_F(PlyTest, HeaderErrors) {
    struct Case {
        std::string file;
        std::string phrase;
    };
    const std::string vertex =
        "element vertex 1\nproperty float x\nproperty float y\n"
        "property float z\n";
    const std::string face = "element face 1\nproperty list uchar int vertex_indices\n";
    const std::string ok_body = "0 0 0\n3 0 0 0\n";
    const std::vector<Case> cases = {
        {"", "file is empty"},
        {"plx\nformat ascii 1.0\n" + vertex + face + "end_header\n" + ok_body, "not a PLY file"},
        {std::string("\x89PNG\r\n\x1a\n", 8) + "binary junk", "not a PLY file"},
        {"ply\nformat binary_middle_endian 1.0\n" + vertex + face + "end_header\n",
         "unknown format 'binary_middle_endian'"},
        {"ply\nformat ascii 2.0\n" + vertex + face + "end_header\n" + ok_body,
         "unsupported format version '2.0'"},
        {"ply\n" + vertex + face + "end_header\n" + ok_body, "no 'format' line"},
        {"ply\nformat ascii 1.0\n" + vertex + face, "no 'end_header' line"},
        {"ply\nformat ascii 1.0\nelement vertex 1\nproperty float128 x\n" + face + "end_header\n",
         "unsupported property type 'float128'"},
        {"ply\nformat ascii 1.0\n" + vertex +
             "element face 1\nproperty list float int vertex_indices\nend_header\n" + ok_body,
         "list count type 'float' is not an integer type"},
        {"ply\nformat ascii 1.0\n" + vertex +
             "element face 1\nproperty list uchar double vertex_indices\nend_header\n" + ok_body,
         "non-integer index type 'double'"},
        {"ply\nformat ascii 1.0\n" + face + "end_header\n3 0 0 0\n", "no 'vertex' element"},
        {"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float z\n" + face +
             "end_header\n0 0\n3 0 0 0\n",
         "no 'y' property"},
        {"ply\nformat ascii 1.0\n" + vertex + "end_header\n0 0 0\n", "no 'face' element"},
        {"ply\nformat ascii 1.0\n" + vertex +
             "element face 1\nproperty list uchar int corners\n"
             "end_header\n" +
             ok_body,
         "no 'vertex_indices' list property"},
        {"ply\nformat ascii 1.0\n" + vertex +
             "element face 1\nproperty int vertex_indices\n"
             "end_header\n0 0 0\n0\n",
         "'vertex_indices' is not a list"},
        {"ply\nformat ascii 1.0\nelement vertex x12\n", "bad element line"},
        {"ply\nformat ascii 1.0\nproperty float x\n", "property before any element"},
        {"ply\nformat ascii 1.0\n" + vertex + "frobnicate 3\n" + face + "end_header\n" + ok_body,
         "line 7: unknown header keyword 'frobnicate'"},
        // (before the first element a line is a comment, so a misspelt first 'element'
        // leaves its properties without one)
        {"ply\nformat ascii 1.0\nelment vertex 1\nproperty float x\n",
         "property before any element"},
    };
    for (size_t i = 0; i < cases.size(); ++i) {
        SCOPED_TRACE("case " + std::to_string(i));
        expect_input_error(write("header" + std::to_string(i) + ".ply", cases[i].file),
                           cases[i].phrase);
    }
}

TEST_F(PlyTest, TruncatedAscii) {
    // Long numbers, so that the cut files still pass the size check on the header's counts.
    // The header takes lines 1-9, vertices lines 10-15, faces lines 16-18.
    std::string full =
        "ply\n" + std::string(format_line(Fmt::Ascii)) + plain_header + "end_header\n";
    for (int v = 0; v < 6; ++v) {
        full += "0.100000000000 0.200000000000 0." + std::to_string(v) + "00000000000\n";
    }
    full += "3 0 1 2\n4 0 2 3 5\n5 1 4 5 3 2\n";
    ASSERT_EQ(read_ply(write("full.ply", full)).indices, reference_indices);
    size_t body = full.find("end_header\n") + 11;
    auto after_lines = [&](int lines) {
        size_t cut = body;
        for (int line = 0; line < lines; ++line) cut = full.find('\n', cut) + 1;
        return cut;
    };
    expect_input_error(write("cut_lines.ply", full.substr(0, after_lines(4))),
                       "ascii data ends after 4 of 6 vertices (file truncated?)");
    // Cut in the middle of the fourth vertex line, after two values.
    expect_input_error(write("cut_mid.ply", full.substr(0, after_lines(3) + 30)),
                       "line 13: vertex 3 has 2 values, expected 3");
    // Cut inside the last face: the pentagon lists 5 vertices but only 2 are left.
    expect_input_error(write("cut_face.ply", full.substr(0, full.rfind("5 1 4") + 5)),
                       "line 18: face 2 has 3 values, expected 6");
    expect_input_error(write("no_faces.ply", full.substr(0, after_lines(6))),
                       "ascii data ends after 0 of 3 faces");
}

TEST_F(PlyTest, TruncatedBinary) {
    for (Fmt format : {Fmt::Le, Fmt::Be}) {
        SCOPED_TRACE(format_label(format));
        std::string full = ply_file(format, plain_header, plain_body(format));
        // Body: 6 * 12 vertex bytes, faces of 13, 17 and 21 bytes.
        size_t body = full.find("end_header\n") + 11;
        ASSERT_EQ(full.size() - body, 72u + 13 + 17 + 21);
        expect_input_error(write("cut5.ply", full.substr(0, full.size() - 5)),
                           "binary data ends after 2 of 3 faces (file truncated?)");
        // Too short to hold even the minimum sizes the header claims.
        expect_input_error(write("cut60.ply", full.substr(0, body + 60)),
                           "header claims 6 'vertex' elements, but the file is only 60 bytes");
        expect_input_error(write("headeronly.ply", full.substr(0, body)), "only 0 bytes");
    }
}

TEST_F(PlyTest, LyingCounts) {
    auto with_counts = [](std::string file, const char* vertex, const char* face) {
        file.replace(file.find("element vertex 6"), 16, vertex);
        file.replace(file.find("element face 3"), 14, face);
        return file;
    };
    for (Fmt format : all_formats) {
        SCOPED_TRACE(format_label(format));
        std::string good = ply_file(format, plain_header, plain_body(format));
        // More faces than present (binary: 4 faces need at least 124 bytes, the file has 123).
        std::string more_faces = with_counts(good, "element vertex 6", "element face 4");
        expect_input_error(write("more_faces.ply", more_faces),
                           format == Fmt::Ascii ? "ascii data ends after 3 of 4 faces"
                                                : "header claims 4 'face' elements");
        // One more vertex than present: the first face is taken as a vertex; in ascii the
        // faces then run out, in binary the faces are read one byte off.
        std::string more_vertices = with_counts(good, "element vertex 7", "element face 3");
        expect_input_error(
            write("more_vertices.ply", more_vertices),
            format == Fmt::Ascii ? "ascii data ends after 2 of 3 faces" : "face 0 has ");
        // One vertex fewer: the last vertex is read as a face. Its first byte, the list
        // length, is 0x00 of -1.25f = bf a0 00 00 little-endian, 0xbf = 191 big-endian.
        std::string fewer_vertices = with_counts(good, "element vertex 5", "element face 3");
        const char* fewer_phrase[] = {"line 15: face 0: '-1.25' is not a valid uchar",
                                      "face 0 has 0 vertices, at least 3 needed",
                                      "binary data ends after 0 of 3 faces"};
        expect_input_error(write("fewer_vertices.ply", fewer_vertices), fewer_phrase[int(format)]);
    }
}

TEST_F(PlyTest, UnknownElementTruncated) {
    std::string header = std::string(plain_header) +
                         "element edge 2\nproperty int a\n"
                         "property list uchar int more\n";
    Body body = plain_body(Fmt::Ascii);
    body.value("int", 5);
    body.value("uchar", 0);
    body.end_element();
    expect_input_error(write("edges.ply", ply_file(Fmt::Ascii, header, body)),
                       "ascii data ends after 1 of 2 edges");

    Body binary = plain_body(Fmt::Le);
    binary.value("int", 5);
    binary.value("uchar", 0);
    binary.value("int", 6);
    binary.value("uchar", 200);  // claims 200 ints, has one
    binary.value("int", 7);
    expect_input_error(write("edges_bin.ply", ply_file(Fmt::Le, header, binary)),
                       "binary data ends after 1 of 2 edges");
}

TEST_F(PlyTest, IndexOutOfRangeAndNegative) {
    for (Fmt format : all_formats) {
        SCOPED_TRACE(format_label(format));
        auto faces = reference_faces;
        faces[1][2] = 6;
        expect_input_error(
            write("index6.ply", ply_file(format, plain_header, plain_body(format, faces))),
            "face 1 has vertex index 6 out of range (the file has 6 vertices)");
        faces = reference_faces;
        faces[2][4] = -1;
        expect_input_error(
            write("index_neg.ply", ply_file(format, plain_header, plain_body(format, faces))),
            "face 2 has vertex index -1 out of range");
        faces = reference_faces;
        faces[1] = {0, 1};
        expect_input_error(
            write("two.ply", ply_file(format, plain_header, plain_body(format, faces))),
            "face 1 has 2 vertices, at least 3 needed");
    }
}

TEST_F(PlyTest, NonFiniteCoordinates) {
    const std::string header =
        "element vertex 3\nproperty float x\nproperty double y\n"
        "property float z\nelement face 1\n"
        "property list uchar int vertex_indices\n";
    struct Case {
        double y;
        size_t vertex;
        const char* phrase;
    };
    const double nan = std::numeric_limits<double>::quiet_NaN();
    const double inf = std::numeric_limits<double>::infinity();
    for (const Case& c : {Case{nan, 1, "vertex 1 has a non-finite coordinate"},
                          Case{-inf, 2, "vertex 2 has a non-finite coordinate"},
                          Case{1e300, 0, "vertex 0 has coordinate 1e+300 beyond float range"}}) {
        for (Fmt format : all_formats) {
            SCOPED_TRACE(std::string(c.phrase) + " " + format_label(format));
            Body body(format);
            for (size_t v = 0; v < 3; ++v) {
                body.value("float", 1.0);
                body.value("double", v == c.vertex ? c.y : 2.0);
                body.value("float", 3.0);
                body.end_element();
            }
            for (double v : {3, 0, 1, 2}) body.value(v == 3 ? "uchar" : "int", v);
            body.end_element();
            expect_input_error(write("nonfinite.ply", ply_file(format, header, body)), c.phrase);
        }
    }
}

TEST_F(PlyTest, BadAsciiValues) {
    std::string good = ply_file(Fmt::Ascii, plain_header, plain_body(Fmt::Ascii));
    auto replaced = [&](std::string_view from, std::string_view to) {
        std::string file = good;
        file.replace(file.find(from, file.find("end_header")), from.size(), to);
        return file;
    };
    expect_input_error(write("word.ply", replaced("0.5 2 -1", "0.5 two -1")),
                       "line 14: vertex 4: 'two' is not a number");
    expect_input_error(write("huge.ply", replaced("0.5 2 -1", "0.5 1e999 -1")),
                       "vertex 4: value '1e999' is out of range");
    expect_input_error(write("count.ply", replaced("4 0 2 3 5", "300 0 2 3 5")),
                       "face 1: '300' is not a valid uchar");
    expect_input_error(write("fraction.ply", replaced("4 0 2 3 5", "4 0 2.5 3 5")),
                       "face 1: '2.5' is not a valid int");
}

TEST_F(PlyTest, AbsurdSizesFailFastWithoutAllocating) {
    const std::string tail =
        "property float x\nproperty float y\nproperty float z\n"
        "element face 1\nproperty list uchar int vertex_indices\n";
    struct Case {
        Fmt format;
        std::string counts;
        std::string phrase;
    };
    const std::vector<Case> cases = {
        {Fmt::Le, "element vertex 1000000000000\n",
         "header claims 1000000000000 vertices, more than the limit of 2^31"},
        {Fmt::Be, "element vertex 18446744073709551615\n", "more than the limit of 2^31"},
        {Fmt::Ascii, "element vertex 1000000000000\n", "more than the limit of 2^31"},
        // Under the cap, but far beyond what the file can hold.
        {Fmt::Le, "element vertex 2000000000\n",
         "header claims 2000000000 'vertex' elements, but the file is only"},
        {Fmt::Ascii, "element vertex 1500000000\n",
         "header claims 1500000000 'vertex' elements, but the file is only"},
    };
    for (const Case& c : cases) {
        SCOPED_TRACE(c.phrase);
        Body body(c.format);
        for (double v : {0.0, 0.0, 0.0}) body.value("float", v);
        body.end_element();
        fs::path path = write("absurd.ply", ply_file(c.format, c.counts + tail, body));
        auto start = std::chrono::steady_clock::now();
        expect_input_error(path, c.phrase);
        double seconds =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        EXPECT_LT(seconds, 0.1);
    }
    // A face count beyond the cap, and a huge unknown element, in binary.
    std::string faces = "element vertex 1\n" + tail;
    faces.replace(faces.find("element face 1"), 14, "element face 3000000000");
    expect_input_error(write("faces.ply", ply_file(Fmt::Le, faces, Body(Fmt::Le))),
                       "header claims 3000000000 faces, more than the limit of 2^31");
    std::string unknown =
        "element blob 900000000000000\nproperty double d\nelement vertex 1\n" + tail;
    expect_input_error(write("blob.ply", ply_file(Fmt::Le, unknown, Body(Fmt::Le))),
                       "header claims 900000000000000 'blob' elements");
}

// ---- Huge files: the header is read first, and nothing after what it declares -------

TEST_F(PlyTest, AnElementWithoutPropertiesNeedsACountOfZero) {
    // Its instances would take no bytes (binary) and no line (ascii): nothing could bound
    // its count, so only 0 is read
    for (Fmt format : all_formats) {
        SCOPED_TRACE(format_label(format));
        const std::string blob = "element blob 18446744073709551615\n";
        expect_input_error(
            write("blob.ply", ply_file(format, plain_header + blob, plain_body(format))),
            "line 9: element 'blob' has no properties but a count of 18446744073709551615");
        expect_input_error(
            write("blob1.ply", ply_file(format, "element blob 1\n" + std::string(plain_header),
                                        plain_body(format))),
            "line 3: element 'blob' has no properties but a count of 1");
        const MeshData mesh = read_ply(write(
            "blob0.ply",
            ply_file(format, "element blob 0\n" + std::string(plain_header) + "element tail 0\n",
                     plain_body(format))));
        EXPECT_EQ(mesh.indices, reference_indices);
    }
}

TEST_F(PlyTest, A30GiBSparseFileClaimingMoreIsRefusedFromItsHeader) {
    // 2e9 vertices of nine doubles: 144e9 bytes, or 18e9 values (at least 36e9 bytes)
    std::string vertex = "element vertex 2000000000\n";
    for (const char* name : {"x", "y", "z", "a", "b", "c", "d", "e", "f"})
        vertex += std::string("property double ") + name + "\n";
    const std::string face = "element face 1\nproperty list uchar int vertex_indices\n";
    for (Fmt format : all_formats) {
        SCOPED_TRACE(format_label(format));
        const fs::path path = dir_ / "huge.ply";
        if (!make_sparse_file(path, ply_file(format, vertex + face, Body(format)), k30GiB))
            GTEST_SKIP() << kNoSparseFiles;
        const ReadCost cost;
        expect_input_error(path,
                           "header claims 2000000000 'vertex' elements, but the file is only "
                           "32212254");  // (30 GiB less the header)
        EXPECT_LT(cost.seconds(), kGenerousSeconds);
        EXPECT_LT(cost.peak_growth_bytes(), kGenerousGrowth);
    }
}

TEST_F(PlyTest, A30GiBSparseFileClaimingMoreThanMemoryIsRefusedBeforeAllocating) {
    // 1.9e9 vertices (22.8e9 bytes or 5.7e9 values) and 2^31 triangles of one-byte indices
    // (8.6e9 bytes or values) fit in 30 GiB, but their arrays take 48.6e9 bytes of memory,
    // more than half of that of a machine of less than 97 GB
    const uint64_t vertices = 1'900'000'000, faces = uint64_t(1) << 31;
    const uint64_t memory = vertices * 12 + faces * 12;
    if (cierzo::reader_memory_bound() >= memory)
        GTEST_SKIP() << "a file may take " << cierzo::reader_memory_bound()
                     << " bytes of memory here, enough for the header's claim";
    const std::string header = "element vertex " + std::to_string(vertices) +
                               "\nproperty float x\nproperty float y\nproperty float z\n"
                               "element face " +
                               std::to_string(faces) +
                               "\nproperty list uchar uchar vertex_indices\n";
    for (Fmt format : all_formats) {
        SCOPED_TRACE(format_label(format));
        const fs::path path = dir_ / "memory.ply";
        if (!make_sparse_file(path, ply_file(format, header, Body(format)), k30GiB))
            GTEST_SKIP() << kNoSparseFiles;
        const ReadCost cost;
        expect_input_error(path,
                           "header claims 1900000000 vertices and 2147483648 faces: their "
                           "arrays need at least " +
                               std::to_string(memory) + " bytes, more than the " +
                               std::to_string(cierzo::reader_memory_bound()) +
                               " bytes a file may take");
        EXPECT_LT(cost.seconds(), kGenerousSeconds);
        EXPECT_LT(cost.peak_growth_bytes(), kGenerousGrowth);
    }
}

TEST_F(PlyTest, A30GiBSparseFileIsReadNoFurtherThanItsHeaderDeclares) {
    for (Fmt format : all_formats) {
        SCOPED_TRACE(format_label(format));
        const std::string file = reference_ply(format, Layout{});
        const size_t body = file.find("end_header\n") + 11;
        // The mesh, then 30 GiB of hole: the hole is never read
        const fs::path whole = dir_ / "whole.ply";
        if (!make_sparse_file(whole, file, k30GiB)) GTEST_SKIP() << kNoSparseFiles;
        ReadCost cost;
        const MeshData mesh = read_ply(whole);
        expect_positions(mesh, float_positions);
        EXPECT_EQ(mesh.indices, reference_indices);
        EXPECT_LT(cost.seconds(), kGenerousSeconds);
        EXPECT_LT(cost.peak_growth_bytes(), kGenerousGrowth);
        fs::remove(whole);

        // Two vertices, then the hole: ascii data stops at its first NUL byte, binary data
        // reads the hole as zeros, but only as far as the header declares (the first face
        // has 0 corners)
        const fs::path cut = dir_ / "cut.ply";
        const std::string two_vertices = file.substr(
            0, format == Fmt::Ascii ? file.find('\n', file.find('\n', body) + 1) + 1 : body + 30);
        const auto hole_line = std::count(two_vertices.begin(), two_vertices.end(), '\n') + 1;
        if (!make_sparse_file(cut, two_vertices, k30GiB)) GTEST_SKIP() << kNoSparseFiles;
        cost = ReadCost();
        expect_input_error(
            cut, format == Fmt::Ascii
                     ? "line " + std::to_string(hole_line) + ": a NUL byte in the ascii data"
                     : std::string("face 0 has 0 vertices, at least 3 needed"));
        EXPECT_LT(cost.seconds(), kGenerousSeconds);
        EXPECT_LT(cost.peak_growth_bytes(), kGenerousGrowth);
        fs::remove(cut);
    }
    // A header cut short by the hole
    const fs::path header = dir_ / "header.ply";
    if (!make_sparse_file(header, "ply\nformat ascii 1.0\nelement vertex 1\n", k30GiB))
        GTEST_SKIP() << kNoSparseFiles;
    const ReadCost cost;
    expect_input_error(header, "line 4: a NUL byte in the header");
    EXPECT_LT(cost.seconds(), kGenerousSeconds);
    EXPECT_LT(cost.peak_growth_bytes(), kGenerousGrowth);
}

TEST_F(PlyTest, AFileTheFileSystemWillNotMapIsReadInstead) {
    // sysfs refuses mappings (ENODEV), and its files hold less than their size says
    const fs::path sysfs = "/sys/kernel/mm/transparent_hugepage/enabled";
    std::ifstream in(sysfs, std::ios::binary);
    const std::string expected{std::istreambuf_iterator<char>(in), {}};
    if (expected.empty()) GTEST_SKIP() << sysfs << " cannot be read here";
    const cierzo::MappedFile file(sysfs);
    EXPECT_FALSE(file.mapped());
    EXPECT_EQ(file.bytes(), expected);

    const cierzo::MappedFile empty(write("empty.ply", ""));
    EXPECT_FALSE(empty.mapped());
    EXPECT_TRUE(empty.bytes().empty());
    const std::string ply = reference_ply(Fmt::Le, Layout{});
    const cierzo::MappedFile mapped(write("mapped.ply", ply));
    EXPECT_TRUE(mapped.mapped());
    EXPECT_EQ(mapped.bytes(), ply);
}

// The real Stanford bunny, kept in scenes/meshes/.
TEST_F(PlyTest, StanfordBunny) {
    MeshData mesh = read_ply(fs::path(CIERZO_SOURCE_DIR) / "scenes/meshes/bunny.ply");
    EXPECT_EQ(mesh.positions.size(), 1839u * 3);
    EXPECT_EQ(mesh.indices.size(), 3674u * 3);
    EXPECT_TRUE(mesh.colors.empty());
    float lo[3] = {1e30f, 1e30f, 1e30f}, hi[3] = {-1e30f, -1e30f, -1e30f};
    for (size_t i = 0; i < mesh.positions.size(); ++i) {
        lo[i % 3] = std::min(lo[i % 3], mesh.positions[i]);
        hi[i % 3] = std::max(hi[i % 3], mesh.positions[i]);
    }
    for (int k = 0; k < 3; ++k) {
        EXPECT_GT(hi[k] - lo[k], 0.1f);  // a solid, not a degenerate sliver
        EXPECT_LT(hi[k] - lo[k], 100.0f);
    }
    for (uint32_t index : mesh.indices) ASSERT_LT(index, 1839u);
}

}  // namespace
