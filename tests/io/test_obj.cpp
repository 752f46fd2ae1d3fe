// Tests for the OBJ reader (src/io/obj.cpp) and read_mesh: what a file means (positions,
// fan-triangulated faces, normals split per corner, colours, relative indices, groups), the
// number forms the two passes must read alike, and refusals that name the file and the line.
#include <gtest/gtest.h>

#include <unistd.h>

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <sstream>
#include <string>
#include <vector>

#include "core/error.h"
#include "io/mesh.h"
#include "io/obj.h"
#include "io/mtl.h"
#include "io/ply.h"
#include "support/assimp_models.h"
#include "support/scratch.h"
#include "support/sparse_file.h"

namespace {

namespace fs = std::filesystem;
using cierzo::InputError;
using cierzo::MeshData;
using cierzo::parse_obj;

MeshData parse(const std::string& text) { return parse_obj(text, "test.obj"); }

// The message of the InputError that parsing `text` throws ("" if it does not throw).
std::string refusal(const std::string& text) {
    try {
        parse(text);
    } catch (const InputError& e) {
        return e.what();
    }
    return "";
}

TEST(Obj, TrianglesAndPolygonsAreFanTriangulated) {
    const MeshData m = parse(
        "# a triangle and a quad\n"
        "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 2 0 0\n"
        "f 1 2 3\n"
        "f 1 3 4 5\n");
    ASSERT_EQ(m.positions.size(), 15u);
    EXPECT_EQ(m.positions[3], 1.0f);
    EXPECT_EQ(m.positions[14], 0.0f);
    EXPECT_TRUE(m.normals.empty());
    EXPECT_TRUE(m.colors.empty());
    const std::vector<uint32_t> expected = {0, 1, 2, 0, 2, 3, 0, 3, 4};
    EXPECT_EQ(m.indices, expected);
}

TEST(Obj, CornerNormalsSplitVerticesUsedWithDifferentNormals) {
    // Two triangles share the edge 1-3 but with different normals there: a crease
    const MeshData m = parse(
        "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n"
        "vn 0 0 1\nvn 0 1 0\n"
        "f 1//1 2//1 3//1\n"
        "f 1//2 3//2 4//2\n");
    // Vertices 1 and 3 appear with both normals: 6 vertices in all
    ASSERT_EQ(m.positions.size(), 18u);
    ASSERT_EQ(m.normals.size(), 18u);
    ASSERT_EQ(m.indices.size(), 6u);
    for (size_t c = 0; c < 6; ++c) {
        const uint32_t v = m.indices[c];
        const float expected_y = c < 3 ? 0.0f : 1.0f;
        EXPECT_EQ(m.normals[3 * v + 1], expected_y) << "corner " << c;
        EXPECT_EQ(m.normals[3 * v + 2], 1.0f - expected_y) << "corner " << c;
    }
    // The first corners of both faces are vertex 1 of the file at the same place
    const uint32_t a = m.indices[0], b = m.indices[3];
    EXPECT_NE(a, b);
    for (int k = 0; k < 3; ++k) EXPECT_EQ(m.positions[3 * a + k], m.positions[3 * b + k]);
}

TEST(Obj, TextureIndicesAreAcceptedAndNormalsKept) {
    const MeshData m = parse(
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nvn 0 0 -1\n"
        "f 1/1/1 2/2/1 3/3/1\n");
    ASSERT_EQ(m.normals.size(), 9u);
    EXPECT_EQ(m.normals[2], -1.0f);
    const MeshData t = parse("v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nf 1/1 2/1 3/1\n");
    EXPECT_TRUE(t.normals.empty());
    EXPECT_EQ(t.indices.size(), 3u);
}

TEST(Obj, NormalsAreDroppedUnlessEveryCornerHasOne) {
    const MeshData m = parse(
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nvn 0 0 1\n"
        "f 1//1 2//1 3//1\n"
        "f 2 4 3\n");
    EXPECT_TRUE(m.normals.empty());
    EXPECT_EQ(m.positions.size(), 12u);  // the file's vertices, not split
    EXPECT_EQ(m.indices.size(), 6u);
}

TEST(Obj, RelativeIndicesCountBackFromTheLastVertex) {
    const MeshData m = parse(
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nf -3 -2 -1\n"
        "v 5 5 5\nf -4 -3 -1\n");
    const std::vector<uint32_t> expected = {0, 1, 2, 0, 1, 3};
    EXPECT_EQ(m.indices, expected);
}

TEST(Obj, ColoursOnlyWhenEveryVertexHasOne) {
    const MeshData c = parse("v 0 0 0 1 0 0\nv 1 0 0 0 1 0\nv 0 1 0 0 0 1\nf 1 2 3\n");
    ASSERT_EQ(c.colors.size(), 9u);
    EXPECT_EQ(c.colors[0], 1.0f);
    EXPECT_EQ(c.colors[4], 1.0f);
    EXPECT_EQ(c.colors[8], 1.0f);
    EXPECT_EQ(c.colors[1], 0.0f);
    const MeshData some = parse("v 0 0 0 1 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
    EXPECT_TRUE(some.colors.empty());
}

TEST(Obj, GroupsObjectsMaterialsAndLineEndsAreOneMesh) {
    const MeshData m = parse(
        "mtllib missing.mtl\r\n"
        "o first\r\ng part\r\nusemtl red\r\ns 1\r\n"
        "v\t0 0 0\r\nv 1 0 0\r\nv 0 1 0\r\nv 1 1 0\r\n"
        "f 1 2 3\r\n"
        "o second\r\nusemtl blue\r\nl 1 2\r\np 3\r\n"
        "f 2 4 3\r\n"
        "# a comment at the end, without a line end");
    EXPECT_EQ(m.indices.size(), 6u);
    EXPECT_EQ(m.positions.size(), 12u);
}

// The line pass and tinyobjloader must read every accepted number form to the same value
TEST(Obj, NumberFormsReadAsTheirValues) {
    const MeshData m = parse(
        "v .5 5. -0\n"
        "v 1e-3 1E+3 +2\n"
        "v -1.25e2 3.0000001 0.1\n"
        "f 1 2 3\n");
    const std::vector<float> expected = {0.5f, 5.0f,    -0.0f,      1e-3f, 1e3f,
                                         2.0f, -125.0f, 3.0000001f, 0.1f};
    ASSERT_EQ(m.positions.size(), expected.size());
    for (size_t i = 0; i < expected.size(); ++i)
        EXPECT_EQ(m.positions[i], expected[i]) << "value " << i;
    // A weight w of 1 is accepted (and ignored)
    EXPECT_EQ(parse("v 0 0 0 1\nv 1 0 0 1.0\nv 0 1 0 1\nf 1 2 3\n").positions.size(), 9u);
}

// n vertices (vertex i at (i, i² mod 7, 0), i from 1) and one face of all of them in order,
// corner i written as `corner(i)`.
std::string polygon(size_t n, const std::function<std::string(size_t)>& corner) {
    std::string text;
    for (size_t i = 1; i <= n; ++i)
        text += "v " + std::to_string(i) + ' ' + std::to_string(i * i % 7) + " 0\n";
    text += "f";
    for (size_t i = 1; i <= n; ++i) text += ' ' + corner(i);
    return text + "\n";
}

std::string absolute(size_t i) { return std::to_string(i); }

// The triangles of the fan over vertices 0..n-1 from vertex 0: (0, k, k + 1)
std::vector<uint32_t> fan(size_t n) {
    std::vector<uint32_t> t;
    for (uint32_t k = 1; k + 1 < n; ++k) t.insert(t.end(), {0, k, k + 1});
    return t;
}

// tinyobjloader holds faces of at most 255 corners: longer ones reach it in pieces, and
// their triangles must still be the fan over the whole face
TEST(Obj, FacesOfAnyNumberOfCornersAreFanTriangulated) {
    for (const size_t n : {3, 4, 254, 255, 256, 257, 300, 508, 509, 510, 1000, 4321}) {
        const MeshData m = parse(polygon(n, absolute));
        EXPECT_EQ(m.positions.size(), 3 * n) << n << " corners";
        EXPECT_EQ(m.indices, fan(n)) << n << " corners";
    }
    // Relative indices (the first corner repeated in every piece stays the same vertex)
    const size_t n = 1000;
    EXPECT_EQ(
        parse(polygon(n, [&](size_t i) { return std::to_string(int64_t(i) - int64_t(n) - 1); }))
            .indices,
        fan(n));
    // Corner normals and texture coordinates (vertices split by the corners' combinations)
    const MeshData split = parse("vn 0 0 1\nvt 0.5 0.5\n" +
                                 polygon(300, [](size_t i) { return std::to_string(i) + "/1/1"; }));
    EXPECT_EQ(split.indices, fan(300));
    EXPECT_EQ(split.normals.size(), 3u * 300);
    EXPECT_EQ(split.uvs.size(), 2u * 300);
    // Each triangle keeps its face's material, the pieces' and the faces' after them
    const MeshData two = parse("usemtl a\n" + polygon(n, absolute) + "usemtl b\nf 1 2 3\n");
    std::vector<uint32_t> materials(n - 2, 0);
    materials.push_back(1);
    EXPECT_EQ(two.triangle_material, materials);
    ASSERT_EQ(two.material_names.size(), 2u);
    EXPECT_EQ(two.material_names[1], "b");
}

// A face of a million corners on one line (2 MB): read in time and memory in proportion to
// the line (each corner costs what a triangle's does), as every other face
TEST(Obj, AFaceOfAMillionCornersIsReadLikeAnyOther) {
    const size_t n = 1000000;
    std::string text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf";
    text.reserve(text.size() + 2 * n + 1);
    for (size_t i = 0; i < n; ++i) text += i % 3 == 0 ? " 1" : i % 3 == 1 ? " 2" : " 3";
    const MeshData m = parse(text + "\n");
    ASSERT_EQ(m.indices.size(), 3 * (n - 2));
    // Triangle k is (corner 1, corner k + 2, corner k + 3): vertices 0, (k+1) mod 3, (k+2) mod 3
    for (const size_t k : {size_t(0), size_t(252), size_t(253), size_t(254), n / 2, n - 3}) {
        EXPECT_EQ(m.indices[3 * k], 0u) << k;
        EXPECT_EQ(m.indices[3 * k + 1], (k + 1) % 3) << k;
        EXPECT_EQ(m.indices[3 * k + 2], (k + 2) % 3) << k;
    }
}

// assimp's test model box_longline.obj: a cube whose first face has 936 corners (its 4
// corners over and over); every face is read as the fan over its corners, as given
TEST(Obj, AssimpsBoxLonglineIsReadWithItsFaceOf936Corners) {
    const fs::path path = cierzo::test::kAssimpModels / "OBJ" / "box_longline.obj";
    if (!fs::exists(path)) GTEST_SKIP() << cierzo::test::assimp_models_missing();
    std::vector<uint32_t> expected;
    size_t longest = 0;
    std::ifstream in(path);
    for (std::string line; std::getline(in, line);) {
        std::istringstream words(line);
        std::string key;
        words >> key;
        if (key != "f") continue;
        std::vector<uint32_t> face;
        for (uint32_t v; words >> v;) face.push_back(v - 1);
        longest = std::max(longest, face.size());
        for (size_t k = 1; k + 1 < face.size(); ++k)
            expected.insert(expected.end(), {face[0], face[k], face[k + 1]});
    }
    ASSERT_EQ(longest, 936u);
    const MeshData m = cierzo::read_obj(path);
    EXPECT_EQ(m.positions.size(), 8u * 3);
    EXPECT_EQ(m.indices, expected);
}

TEST(Obj, RefusalsNameTheFileTheLineAndTheProblem) {
    struct Case {
        const char* text;
        const char* needle;
    };
    const Case cases[] = {
        {"v 0 0 0\nv 1 x 0\nv 0 1 0\nf 1 2 3\n", "test.obj: line 2: 'x' is not a number"},
        {"v 0 0 0\nv 1 nan 0\nv 0 1 0\nf 1 2 3\n", "line 2: 'nan' is not a number"},
        {"v 0 0 0\nv 1 1e39 0\nv 0 1 0\nf 1 2 3\n",
         "line 2: '1e39' is not a number in float range"},
        {"v 0 0 0\nv 1 0\nv 0 1 0\nf 1 2 3\n", "line 2: a vertex 'v' needs 3 numbers"},
        {"v 0 0 0 1 1\nf 1 1 1\n", "line 1: a vertex 'v' needs 3 numbers"},
        {"v 0 0 0 2\nf 1 1 1\n", "line 1: a vertex with a weight w other than 1"},
        {"v 0 0 0\nvn 0 1\nf 1 1 1\n", "line 2: a normal 'vn' needs 3 numbers"},
        {"v 0 0 0\nv 1 0 0\nf 1 2\n", "line 3: a face needs at least 3 corners, not 2"},
        {"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n", "line 4: bad face corner '0'"},
        {"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 x\n", "line 4: bad face corner 'x'"},
        {"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/2/3/4 2 3\n", "line 4: bad face corner '1/2/3/4'"},
        {"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n",
         "line 4: face refers to vertex 4, but the file has 3"},
        {"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 99999999999\n", "line 4: bad face corner"},
        {"v 0 0 0\nv 1 0 0\nv 0 1 0\nf -4 2 3\n",
         "line 4: face corner '-4' refers to vertex -4 before the first"},
        {"v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//1 3//2\n",
         "line 5: face refers to normal 2, but the file has 1"},
        {"v 0 0 0\nv 1 0 0\nv 0 1 0\n", "test.obj: has no faces"},
        {"", "test.obj: has no faces"},
    };
    for (const Case& c : cases) {
        const std::string message = refusal(c.text);
        EXPECT_NE(message.find(c.needle), std::string::npos)
            << "input:\n"
            << c.text << "\nmessage: " << message << "\nexpected: " << c.needle;
    }
    using namespace std::string_literals;
    EXPECT_NE(refusal("v 0 0 0\nv 1 0\0 0\n"s).find("test.obj: line 2: has a NUL byte"),
              std::string::npos);
    // A long face is checked corner by corner as a short one (the corner in its third piece)
    EXPECT_NE(refusal(polygon(600, [](size_t i) { return i == 550 ? "0" : absolute(i); }))
                  .find("test.obj: line 601: bad face corner '0'"),
              std::string::npos);
    EXPECT_NE(refusal(polygon(600, [](size_t i) { return absolute(i == 550 ? 601 : i); }))
                  .find("line 601: face refers to vertex 601, but the file has 600"),
              std::string::npos);
}

TEST(Obj, TruncatedFilesAreRefusedOrReadAsWhatTheyHold) {
    const std::string full = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 1 2 3\nf 2 4 3\n";
    // Every prefix is either refused with an InputError or read as a valid mesh
    for (size_t n = 0; n <= full.size(); ++n) {
        try {
            const MeshData m = parse(full.substr(0, n));
            ASSERT_EQ(m.indices.size() % 3, 0u);
            for (const uint32_t i : m.indices) ASSERT_LT(i, m.positions.size() / 3);
        } catch (const InputError& e) {
            EXPECT_NE(std::string(e.what()).find("test.obj"), std::string::npos);
        }
    }
    // A last face cut after two corners is refused, not read as a smaller mesh
    EXPECT_NE(refusal(full.substr(0, full.size() - 3)).find("line 6: a face needs at least 3"),
              std::string::npos);
}

class ObjFiles : public ::testing::Test {
protected:
    fs::path dir;
    void SetUp() override {
        dir = fs::temp_directory_path() / ("cierzo_test_obj_" + std::to_string(::getpid()));
        fs::create_directories(dir);
    }
    void TearDown() override { fs::remove_all(dir); }
    fs::path write(const std::string& name, const std::string& text) {
        const fs::path p = dir / name;
        std::ofstream(p, std::ios::binary) << text;
        return p;
    }
};

TEST_F(ObjFiles, ReadMeshChoosesTheReaderByExtension) {
    const fs::path obj = write("quad.OBJ", "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n");
    const fs::path ply = write("quad.ply",
                               "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\n"
                               "property float y\nproperty float z\nelement face 1\n"
                               "property list uchar int vertex_indices\nend_header\n"
                               "0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 1 2 3\n");
    const MeshData a = cierzo::read_mesh(obj), b = cierzo::read_mesh(ply);
    EXPECT_EQ(a.positions, b.positions);
    EXPECT_EQ(a.indices, b.indices);
    const fs::path stl = write("quad.stl", "solid x\n");
    try {
        cierzo::read_mesh(stl);
        ADD_FAILURE() << "an .stl file was read";
    } catch (const InputError& e) {
        EXPECT_NE(std::string(e.what()).find("quad.stl: unknown mesh format '.stl'"),
                  std::string::npos)
            << e.what();
    }
    for (const fs::path& p : {dir / "missing.obj", dir}) {
        try {
            cierzo::read_obj(p);
            ADD_FAILURE() << p << " was read";
        } catch (const InputError& e) {
            EXPECT_NE(std::string(e.what()).find(p.string()), std::string::npos) << e.what();
        }
    }
}

TEST_F(ObjFiles, A30GiBSparseFileIsRefusedAtItsFirstNulByte) {
    // OBJ and MTL files are text: the hole after their lines is refused at its first line
    // and not read beyond its first byte
    using namespace cierzo::test;
    const fs::path obj = dir / "huge.obj";
    if (!make_sparse_file(obj, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", k30GiB))
        GTEST_SKIP() << kNoSparseFiles;
    const ReadCost cost;
    EXPECT_EQ(refusal_of([&] { cierzo::read_mesh(obj); }),
              obj.string() + ": line 5: has a NUL byte (not a text OBJ file)");
    EXPECT_LT(cost.seconds(), kGenerousSeconds);
    EXPECT_LT(cost.peak_growth_bytes(), kGenerousGrowth);
    fs::remove(obj);

    const fs::path mtl = dir / "huge.mtl";
    if (!make_sparse_file(mtl, "newmtl grey\nKd 0.5 0.5 0.5", k30GiB))
        GTEST_SKIP() << kNoSparseFiles;
    EXPECT_EQ(refusal_of([&] { cierzo::read_mtl(mtl); }),
              mtl.string() + ": line 2: has a NUL byte (not a text MTL file)");
    EXPECT_LT(cost.seconds(), kGenerousSeconds);
    EXPECT_LT(cost.peak_growth_bytes(), kGenerousGrowth);
}

TEST(PlyNormals, VertexNormalsAreReadWhenAllThreeArePresent) {
    const std::string header =
        "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
        "property float z\n";
    const std::string faces =
        "element face 1\nproperty list uchar int vertex_indices\nend_header\n";
    const MeshData m =
        cierzo::parse_ply(header + "property float nx\nproperty float ny\nproperty float nz\n" +
                              faces + "0 0 0 0 0 1\n1 0 0 0 1 0\n0 1 0 1 0 0\n3 0 1 2\n",
                          "n.ply");
    const std::vector<float> expected = {0, 0, 1, 0, 1, 0, 1, 0, 0};
    EXPECT_EQ(m.normals, expected);
    const MeshData partial = cierzo::parse_ply(
        header + "property float nx\n" + faces + "0 0 0 1\n1 0 0 1\n0 1 0 1\n3 0 1 2\n", "n.ply");
    EXPECT_TRUE(partial.normals.empty());
    try {
        cierzo::parse_ply(header + "property float nx\nproperty float ny\nproperty float nz\n" +
                              faces + "0 0 0 0 0 1\n1 0 0 0 nan 0\n0 1 0 1 0 0\n3 0 1 2\n",
                          "n.ply");
        ADD_FAILURE() << "a NaN normal was accepted";
    } catch (const InputError& e) {
        EXPECT_NE(std::string(e.what()).find("n.ply"), std::string::npos) << e.what();
    }
}

}  // namespace
