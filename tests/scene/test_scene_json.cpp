// The scene-file reader (src/scene/scene_json.cpp): every scene in scenes/ loads, every key
// lands in its field of Scene, and every kind of bad input is an InputError naming the file.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <map>
#include <limits>
#include <random>
#include <numbers>
#include <string>
#include <vector>

#include <unistd.h>

#include <nlohmann/json.hpp>

#include "core/error.h"
#include "integrators/render.h"
#include "io/image.h"
#include "scene/scene_json.h"

namespace cierzo {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

// parse_scene never touches the disk for these, except for meshes; the folder must not exist
// so that a mesh reference in an error test can never be satisfied by accident.
const char* const kFake = "/nonexistent-cierzo-folder/x/test.json";

// A small valid scene to change one key at a time.
json base_scene() {
    return json::parse(R"({
        "camera": {"position": [0, 0, -3], "look_at": [0, 0, 0]},
        "materials": {"white": {"kd": 0.8}},
        "objects": [{"type": "sphere", "center": [0, 0, 0], "radius": 1, "material": "white"}]
    })");
}

Scene parse(const json& j) { return parse_scene(j.dump(), kFake); }
Scene parse_text(const std::string& text) { return parse_scene(text, kFake); }

// Parsing must throw an InputError whose message names the file and contains `phrase`.
::testing::AssertionResult text_fails_with(const std::string& text, const std::string& phrase,
                                           const fs::path& path = kFake) {
    try {
        parse_scene(text, path);
    } catch (const InputError& e) {
        const std::string m = e.what();
        if (m.find(path.string()) == std::string::npos)
            return ::testing::AssertionFailure() << "message does not name the file: " << m;
        if (m.find(phrase) == std::string::npos)
            return ::testing::AssertionFailure() << "message lacks '" << phrase << "': " << m;
        return ::testing::AssertionSuccess();
    } catch (const std::exception& e) {
        return ::testing::AssertionFailure() << "not an InputError: " << e.what();
    }
    return ::testing::AssertionFailure() << "no error for: " << text;
}
::testing::AssertionResult fails_with(const json& j, const std::string& phrase) {
    return text_fails_with(j.dump(), phrase);
}
// The whole message of the InputError that parsing `text` throws, or what happened instead.
std::string error_of(const std::string& text) {
    try {
        parse_scene(text, kFake);
    } catch (const InputError& e) {
        return e.what();
    } catch (const std::exception& e) {
        return std::string("not an InputError: ") + e.what();
    }
    return "no error";
}

// A fresh folder per test for the cases that need real files.
class TempDir {
public:
    TempDir() {
        const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
        path_ = fs::temp_directory_path() /
                ("cierzo_test_scene_json_" + std::to_string(getpid()) + "_" + info->name());
        fs::remove_all(path_);
        fs::create_directories(path_);
    }
    ~TempDir() {
        std::error_code ec;
        fs::remove_all(path_, ec);
    }
    const fs::path& path() const { return path_; }
    fs::path write(const std::string& name, const std::string& text) const {
        const fs::path p = path_ / name;
        fs::create_directories(p.parent_path());
        std::ofstream(p, std::ios::binary) << text;
        return p;
    }

private:
    fs::path path_;
};

void expect_vec(const Vec3f& v, float x, float y, float z, float tol = 0.0f) {
    EXPECT_NEAR(v.x, x, tol);
    EXPECT_NEAR(v.y, y, tol);
    EXPECT_NEAR(v.z, z, tol);
}

// ---- Every scene shipped in scenes/ -----------------------------------------------

std::vector<std::string> shipped_scenes() {
    std::vector<std::string> names;
    for (const auto& e : fs::directory_iterator(fs::path(CIERZO_SOURCE_DIR) / "scenes"))
        if (e.path().extension() == ".json") names.push_back(e.path().filename().string());
    std::sort(names.begin(), names.end());
    return names;
}

TEST(scene_json_shipped, ThereAreScenesToCheck) {
    // Guards the parameterised test below against an empty or wrong folder
    EXPECT_GE(shipped_scenes().size(), 15u);
}

class scene_json_scene : public ::testing::TestWithParam<std::string> {};

TEST_P(scene_json_scene, Loads) {
    const fs::path path = fs::path(CIERZO_SOURCE_DIR) / "scenes" / GetParam();
    Scene s;
    ASSERT_NO_THROW(s = load_scene(path));
    EXPECT_EQ(s.source, path);
    EXPECT_EQ(s.settings.output, path.parent_path() / (path.stem().string() + ".exr"));
    const size_t objects = s.spheres.size() + s.planes.size() + s.quadrics.size() + s.meshes.size();
    EXPECT_GT(objects, 0u);
    EXPECT_GT(length(s.camera.forward), 0.0f);
    for (int32_t m : s.spheres.material) EXPECT_LT(size_t(m), s.materials.size());
    for (int32_t m : s.planes.material) EXPECT_LT(size_t(m), s.materials.size());
    for (const Quadric& q : s.quadrics) EXPECT_LT(size_t(q.material), s.materials.size());
    for (const Mesh& m : s.meshes) EXPECT_LT(size_t(m.material), s.materials.size());
    for (size_t i = 0; i < s.planes.size(); ++i) {
        EXPECT_NEAR(std::hypot(s.planes.nx[i], s.planes.ny[i], s.planes.nz[i]), 1.0, 1e-6);
    }
}

INSTANTIATE_TEST_SUITE_P(shipped, scene_json_scene, ::testing::ValuesIn(shipped_scenes()),
                         [](const auto& info) {
                             std::string n = fs::path(info.param).stem().string();
                             for (char& c : n)
                                 if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
                             return n;
                         });

TEST(scene_json_shipped, BleedingValuesLandInPlace) {
    // One shipped scene checked value by value against its file
    const Scene s = load_scene(fs::path(CIERZO_SOURCE_DIR) / "scenes" / "bleeding.json");
    EXPECT_EQ(s.settings.width, 500);
    EXPECT_EQ(s.settings.spp, 64);
    ASSERT_EQ(s.planes.size(), 5u);
    ASSERT_EQ(s.spheres.size(), 2u);
    EXPECT_EQ(s.materials[size_t(s.planes.material[0])].name, "red");
    EXPECT_EQ(s.materials[size_t(s.planes.material[1])].name, "green");
    EXPECT_EQ(s.materials[size_t(s.spheres.material[1])].name, "light");
    EXPECT_TRUE(s.materials[size_t(s.spheres.material[1])].is_emitter());
    expect_vec(s.camera.forward, 0, 0, 3);
}

// ---- Values land where they should -------------------------------------------------

TEST(scene_json_values, SphereCentreRadiusAndNamedMaterial) {
    json j = base_scene();
    j["materials"]["black"] = json::object();
    j["objects"] = json::parse(R"([
        {"type": "sphere", "center": [1, -2, 3.5], "radius": 0.25, "material": "white"},
        {"type": "sphere", "center": [0, 0, 9], "radius": 2, "material": "black"},
        {"type": "sphere", "center": [0, 0, 7], "radius": 3, "material": "white"}])");
    const Scene s = parse(j);
    ASSERT_EQ(s.spheres.size(), 3u);
    EXPECT_EQ(s.spheres.cx[0], 1.0f);
    EXPECT_EQ(s.spheres.cy[0], -2.0f);
    EXPECT_EQ(s.spheres.cz[0], 3.5f);
    EXPECT_EQ(s.spheres.radius[0], 0.25f);
    EXPECT_EQ(s.spheres.radius[1], 2.0f);
    ASSERT_EQ(s.materials.size(), 2u);  // named materials only, each stored once
    EXPECT_EQ(s.materials[size_t(s.spheres.material[0])].name, "white");
    EXPECT_EQ(s.materials[size_t(s.spheres.material[1])].name, "black");
    EXPECT_EQ(s.spheres.material[2], s.spheres.material[0]);
    expect_vec(s.materials[size_t(s.spheres.material[0])].kd.a, 0.8f, 0.8f, 0.8f);
}

TEST(scene_json_values, PlaneIsNormalised) {
    json j = base_scene();
    j["objects"] = json::parse(R"([
        {"type": "plane", "normal": [2, 0, 0], "distance": 2, "material": "white"},
        {"type": "plane", "normal": [0, -3, 4], "distance": -10, "material": "white"}])");
    const Scene s = parse(j);
    ASSERT_EQ(s.planes.size(), 2u);
    EXPECT_FLOAT_EQ(s.planes.nx[0], 1.0f);
    EXPECT_FLOAT_EQ(s.planes.ny[0], 0.0f);
    EXPECT_FLOAT_EQ(s.planes.nz[0], 0.0f);
    EXPECT_FLOAT_EQ(s.planes.distance[0], 1.0f);
    EXPECT_FLOAT_EQ(s.planes.nx[1], 0.0f);
    EXPECT_FLOAT_EQ(s.planes.ny[1], -0.6f);
    EXPECT_FLOAT_EQ(s.planes.nz[1], 0.8f);
    EXPECT_FLOAT_EQ(s.planes.distance[1], -2.0f);
}

TEST(scene_json_values, QuadricCoefficientsAndBounds) {
    json j = base_scene();
    j["objects"] = json::parse(R"([
        {"type": "quadric", "coefficients": [1, 2, 3, 4, 5, 6, 7, 8, 9, 10],
         "bounds": {"min": [-1, -2, -3], "max": [1, 2, 3]}, "material": "white"},
        {"type": "quadric", "coefficients": [0, 0, 0, 0, 0, 0, 0, 1, 0, -0.5],
         "material": {"kd": 0.1}}])");
    const Scene s = parse(j);
    ASSERT_EQ(s.quadrics.size(), 2u);
    const QuadricCoefficients<float>& q = s.quadrics[0].q;
    const float got[10] = {q.a, q.b, q.c, q.d, q.e, q.f, q.g, q.h, q.i, q.j};
    for (int i = 0; i < 10; ++i) EXPECT_EQ(got[i], float(i + 1)) << "coefficient " << i;
    expect_vec(s.quadrics[0].box_min, -1, -2, -3);
    expect_vec(s.quadrics[0].box_max, 1, 2, 3);
    EXPECT_EQ(s.materials[size_t(s.quadrics[0].material)].name, "white");
    // Without bounds the quadric is unbounded; a linear one (only H, J) is accepted
    EXPECT_EQ(s.quadrics[1].q.h, 1.0f);
    EXPECT_EQ(s.quadrics[1].q.j, -0.5f);
    EXPECT_EQ(s.quadrics[1].box_min.x, -kRayFar);
    EXPECT_EQ(s.quadrics[1].box_max.z, kRayFar);
}

TEST(scene_json_values, TrianglesBecomeOneMeshPerMaterial) {
    json j = base_scene();
    j["materials"]["red"] = {{"kd", {0.8, 0.1, 0.1}}};
    j["objects"] = json::parse(R"([
        {"type": "triangle", "vertices": [[0, 0, 0], [1, 0, 0], [0, 1, 0]],
         "colors": [[1, 0, 0], 0.5, [0, 0, 1]], "material": "white"},
        {"type": "triangle", "vertices": [[0, 0, 1], [1, 0, 1], [0, 1, 1]], "material": "red"},
        {"type": "triangle", "vertices": [[5, 5, 5], [6, 5, 5], [5, 6, 5]], "material": "white"}
    ])");
    const Scene s = parse(j);
    ASSERT_EQ(s.meshes.size(), 2u);
    const Mesh* white = nullptr;
    const Mesh* red = nullptr;
    for (const Mesh& m : s.meshes)
        (s.materials[size_t(m.material)].name == "white" ? white : red) = &m;
    ASSERT_TRUE(white && red);
    ASSERT_EQ(white->positions.size(), 6u);
    ASSERT_EQ(white->colors.size(), 6u);
    EXPECT_EQ(white->triangle_count(), 2u);
    EXPECT_EQ(white->indices, (std::vector<uint32_t>{0, 1, 2, 3, 4, 5}));
    expect_vec(white->positions[1], 1, 0, 0);
    expect_vec(white->positions[5], 5, 6, 5);
    expect_vec(white->colors[0], 1, 0, 0);
    expect_vec(white->colors[1], 0.5f, 0.5f, 0.5f);
    expect_vec(white->colors[2], 0, 0, 1);
    expect_vec(white->colors[3], 1, 1, 1);  // no colours: white vertices
    ASSERT_EQ(red->positions.size(), 3u);
    expect_vec(red->positions[2], 0, 1, 1);
    // finalize() ran: the scene BVH holds every triangle, within its bounds
    EXPECT_EQ(s.bvh.stats().primitives, 3u);
    for (const Vec3f& p : white->positions) {
        EXPECT_GE(p.x, s.bvh.bounds_min().x);
        EXPECT_LE(p.x, s.bvh.bounds_max().x);
        EXPECT_GE(p.y, s.bvh.bounds_min().y);
        EXPECT_LE(p.y, s.bvh.bounds_max().y);
    }
}

TEST(scene_json_values, InlineAndNamedMaterials) {
    json j = base_scene();
    j["objects"] = json::parse(R"([
        {"type": "sphere", "center": [0, 0, 0], "radius": 1,
         "material": {"ks": [0.1, 0.2, 0.3], "shininess": 12, "kr": 0.25, "kt": [0.5, 0.6, 0.7],
                      "ior": 1.33, "emission": [4, 5, 6]}},
        {"type": "sphere", "center": [0, 0, 0], "radius": 1, "material": "white"},
        {"type": "sphere", "center": [0, 0, 0], "radius": 1, "material": {"kd": 0.3}}])");
    const Scene s = parse(j);
    ASSERT_EQ(s.materials.size(), 3u);
    const Material& inl = s.materials[size_t(s.spheres.material[0])];
    EXPECT_EQ(inl.name, "");
    expect_vec(inl.ks.a, 0.1f, 0.2f, 0.3f);
    expect_vec(inl.kr.a, 0.25f, 0.25f, 0.25f);
    expect_vec(inl.kt.a, 0.5f, 0.6f, 0.7f);
    expect_vec(inl.emission.a, 4, 5, 6);
    expect_vec(inl.kd.a, 0, 0, 0);  // absent colours are zero
    EXPECT_EQ(inl.shininess, 12.0f);
    EXPECT_FLOAT_EQ(inl.ior, 1.33f);
    EXPECT_TRUE(inl.is_emitter());
    EXPECT_EQ(s.materials[size_t(s.spheres.material[1])].name, "white");
    EXPECT_NE(s.spheres.material[2], s.spheres.material[0]);
    expect_vec(s.materials[size_t(s.spheres.material[2])].kd.a, 0.3f, 0.3f, 0.3f);
    // Defaults of a named material
    const Material& white = s.materials[size_t(s.spheres.material[1])];
    EXPECT_EQ(white.shininess, 0.0f);
    EXPECT_EQ(white.ior, 1.0f);
    EXPECT_FALSE(white.is_emitter());
}

TEST(scene_json_values, TextureKinds) {
    json j = base_scene();
    j["materials"] = json::parse(R"({
        "solid": {"kd": {"texture": "solid", "a": [0.1, 0.2, 0.3]}},
        "sin": {"kd": {"texture": "sin", "a": 0.1, "b": [0.9, 0.8, 0.7]}},
        "sin2": {"ks": {"texture": "sin2", "a": 0.2, "b": 0.4, "frequency": 15,
                        "axis": [0, 1, 0]}},
        "sincos": {"kr": {"texture": "sincos", "a": 0, "b": 1, "frequency": 2.5,
                          "axis": [0, 0, 1], "axis2": [1, 1, 0]}},
        "white": {"kd": {"texture": "vertex_nearest"}},
        "weighted": {"emission": {"texture": "vertex_weighted", "scale": [2, 3, 4]}}
    })");
    const Scene s = parse(j);
    std::map<std::string, const Material*> m;
    for (const Material& mat : s.materials) m[mat.name] = &mat;
    ASSERT_EQ(m.size(), 6u);
    m["near"] = m["white"];
    EXPECT_EQ(m["solid"]->kd.kind, TextureKind::kSolid);
    expect_vec(m["solid"]->kd.a, 0.1f, 0.2f, 0.3f);
    const ColorSource& sn = m["sin"]->kd;
    EXPECT_EQ(sn.kind, TextureKind::kSin);
    expect_vec(sn.a, 0.1f, 0.1f, 0.1f);
    expect_vec(sn.b, 0.9f, 0.8f, 0.7f);
    EXPECT_EQ(sn.frequency, 1.0f);  // defaults
    expect_vec(sn.axis, 1, 0, 0);
    expect_vec(sn.axis2, 0, 1, 0);
    const ColorSource& s2 = m["sin2"]->ks;
    EXPECT_EQ(s2.kind, TextureKind::kSin2);
    EXPECT_EQ(s2.frequency, 15.0f);
    expect_vec(s2.axis, 0, 1, 0);
    const ColorSource& sc = m["sincos"]->kr;
    EXPECT_EQ(sc.kind, TextureKind::kSinCos);
    EXPECT_EQ(sc.frequency, 2.5f);
    expect_vec(sc.axis, 0, 0, 1);
    expect_vec(sc.axis2, 1, 1, 0);
    EXPECT_EQ(m["near"]->kd.kind, TextureKind::kVertexNearest);
    expect_vec(m["near"]->kd.a, 1, 1, 1);  // default scale
    EXPECT_EQ(m["weighted"]->emission.kind, TextureKind::kVertexWeighted);
    expect_vec(m["weighted"]->emission.a, 2, 3, 4);
    EXPECT_TRUE(s.features().procedural_textures);
    EXPECT_TRUE(s.features().vertex_colors);
}

TEST(scene_json_values, LookAtCameraPutsPlusXOnTheRight) {
    json j = base_scene();
    j["render"] = {{"width", 200}, {"height", 100}};
    j["camera"] = {{"position", {0, 0, -3}}, {"look_at", {0, 0, 5}}, {"vfov", 90}};
    const Scene s = parse(j);
    const Camera& c = s.camera;
    expect_vec(c.origin, 0, 0, -3);
    expect_vec(c.forward, 0, 0, 1, 1e-6f);
    expect_vec(c.up, 0, 1, 0, 1e-6f);     // length tan(vfov / 2) = 1
    expect_vec(c.left, -2, 0, 0, 1e-6f);  // times the aspect 2; +x is on the right
    // The top-left corner of the image looks left (-x) and up (+y)
    const Ray<float> tl = c.generate(0.0f, 0.0f, 1.0f / 200, 1.0f / 100);
    EXPECT_LT(tl.d.x, 0.0f);
    EXPECT_GT(tl.d.y, 0.0f);
    const Ray<float> br = c.generate(200.0f, 100.0f, 1.0f / 200, 1.0f / 100);
    EXPECT_GT(br.d.x, 0.0f);
    EXPECT_LT(br.d.y, 0.0f);
    EXPECT_NEAR(br.d.x / br.d.z, 2.0f, 1e-5f);
}

// Bit-for-bit equality of two vectors.
void expect_same(const Vec3f& a, const Vec3f& b) {
    EXPECT_EQ(a.x, b.x);
    EXPECT_EQ(a.y, b.y);
    EXPECT_EQ(a.z, b.z);
}

// A right-handed camera (OBJ, glTF, Blender) sees the left-handed image mirrored: the same
// forward and up, the opposite left, bit for bit; a new aspect ratio keeps the handedness;
// and a render shows an emitter at +x on the left instead of the right.
TEST(scene_json_values, RightHandedCameraMirrorsTheImage) {
    json j = base_scene();
    j["camera"] = {{"position", {0.3, -0.2, -3}},
                   {"look_at", {0.1, 0.4, 5}},
                   {"up", {0.1, 1, 0}},
                   {"vfov", 50}};
    const Scene left = parse(j);
    j["camera"]["handedness"] = "right";
    Scene right = parse(j);
    expect_same(right.camera.forward, left.camera.forward);
    expect_same(right.camera.up, left.camera.up);
    expect_same(right.camera.left, -left.camera.left);
    right.set_resolution(300, 100);
    Scene wide = left;
    wide.set_resolution(300, 100);
    expect_same(right.camera.left, -wide.camera.left);
    j["camera"]["handedness"] = "left";
    expect_same(parse(j).camera.left, left.camera.left);

    // Looking along +z with up +y at an emitter at +x: its light lands on the right of a
    // left-handed image and on the left of a right-handed one
    json scene = json::parse(R"({
        "render": {"width": 16, "height": 8, "spp": 2},
        "camera": {"position": [0, 0, 0], "look_at": [0, 0, 1], "vfov": 60},
        "materials": {"lamp": {"emission": 1}},
        "objects": [{"type": "sphere", "center": [1, 0, 3], "radius": 0.5, "material": "lamp"}]
    })");
    for (const char* hand : {"left", "right"}) {
        SCOPED_TRACE(hand);
        scene["camera"]["handedness"] = hand;
        RenderOptions o;
        o.integrator = Integrator::kScalar;
        o.threads = 1;
        o.progress = false;
        const Image image = render(parse(scene), o).film.mean();
        double halves[2] = {0, 0};
        for (int y = 0; y < image.height; ++y)
            for (int x = 0; x < image.width; ++x)
                halves[x * 2 / image.width] += image.pixel(x, y)[0];
        const int lit = std::string(hand) == "left" ? 1 : 0;
        EXPECT_GT(halves[lit], 0.0);
        EXPECT_EQ(halves[1 - lit], 0.0);
    }
}

TEST(scene_json_values, HandednessIsCheckedAndBelongsToLookAt) {
    json j = base_scene();
    j["camera"]["handedness"] = "up";
    EXPECT_TRUE(fails_with(j, "camera: 'handedness' must be \"left\""));
    j["camera"] = {{"position", {0, 0, -3}},
                   {"forward", {0, 0, 1}},
                   {"left", {-1, 0, 0}},
                   {"up", {0, 1, 0}},
                   {"handedness", "right"}};
    EXPECT_TRUE(fails_with(j, "'handedness' belongs to the 'look_at' form"));
}

// project() is generate()'s inverse: a point anywhere along a pixel's ray lands on that
// image position, for look_at cameras of either handedness and aspect, and for a skewed
// explicit frame (the report's form takes any three vectors).
TEST(camera_projection, ProjectInvertsGenerate) {
    std::vector<std::pair<Camera, std::pair<int, int>>> cameras;
    json j = base_scene();
    for (const char* hand : {"left", "right"})
        for (const auto& [w, h] : {std::pair{64, 48}, std::pair{40, 90}}) {
            j["render"] = {{"width", w}, {"height", h}};
            j["camera"] = {{"position", {0.3, -1, -3}},
                           {"look_at", {0.1, 0.4, 5}},
                           {"up", {0.2, 1, 0}},
                           {"vfov", 70},
                           {"handedness", hand}};
            cameras.push_back({parse(j).camera, {w, h}});
        }
    Camera skewed;
    skewed.origin = {1, 2, 3};
    skewed.forward = {0.1f, 0.2f, 2.0f};
    skewed.left = {-0.8f, 0.3f, 0.1f};
    skewed.up = {0.2f, 0.9f, -0.3f};
    cameras.push_back({skewed, {50, 50}});
    std::mt19937 rng(17);
    std::uniform_real_distribution<float> unit(0.0f, 1.0f);
    for (const auto& [c, size] : cameras) {
        const auto [w, h] = size;
        double worst = 0.0;
        for (int i = 0; i < 2000; ++i) {
            const float sx = unit(rng) * float(w), sy = unit(rng) * float(h);
            const Ray<float> ray = c.generate(sx, sy, 1.0f / float(w), 1.0f / float(h));
            const float t = std::exp(unit(rng) * 9.0f - 4.0f);  // 0.02 to 150
            const FilmPoint<float> f = c.project(ray.o + ray.d * t, float(w), float(h));
            if (sx > 1e-3f && sy > 1e-3f && sx < float(w) - 1e-3f && sy < float(h) - 1e-3f) {
                EXPECT_TRUE(f.on_film) << sx << " " << sy;
            }
            worst = std::max({worst, double(std::fabs(f.sx - sx)), double(std::fabs(f.sy - sy))});
            // The same point seen behind the camera is off the film
            EXPECT_FALSE(c.project(ray.o - ray.d * t, float(w), float(h)).on_film);
        }
        EXPECT_LT(worst, 2e-3) << "pixels";
    }
}

TEST(camera_projection, PointsOffTheFilmAndNonFinitePointsAreRefused) {
    json j = base_scene();
    j["render"] = {{"width", 100}, {"height", 50}};
    j["camera"] = {{"position", {0, 0, 0}}, {"look_at", {0, 0, 1}}, {"vfov", 90}};
    const Camera c = parse(j).camera;  // tan(vfov/2) = 1: the film spans x in [-2, 2] at z = 1
    EXPECT_TRUE(c.project(Vec3f(1.9f, 0.9f, 1.0f), 100.0f, 50.0f).on_film);
    EXPECT_FALSE(c.project(Vec3f(2.1f, 0.0f, 1.0f), 100.0f, 50.0f).on_film);
    EXPECT_FALSE(c.project(Vec3f(0.0f, 1.1f, 1.0f), 100.0f, 50.0f).on_film);
    EXPECT_FALSE(c.project(Vec3f(0.0f, 0.0f, 0.0f), 100.0f, 50.0f).on_film);  // the pinhole
    EXPECT_FALSE(c.project(Vec3f(1.0f, 0.0f, 0.0f), 100.0f, 50.0f).on_film);  // beside it
    const float nan = std::numeric_limits<float>::quiet_NaN();
    const float inf = std::numeric_limits<float>::infinity();
    EXPECT_FALSE(c.project(Vec3f(nan, 0.0f, 1.0f), 100.0f, 50.0f).on_film);
    EXPECT_FALSE(c.project(Vec3f(0.0f, 0.0f, inf), 100.0f, 50.0f).on_film);
    // +x is on the right of this left-handed frame: the point lands right of the centre
    EXPECT_GT(c.project(Vec3f(1.0f, 0.0f, 1.0f), 100.0f, 50.0f).sx, 50.0f);
    EXPECT_NEAR(c.project(Vec3f(1.0f, 0.0f, 1.0f), 100.0f, 50.0f).sx, 75.0f, 1e-4f);
}

// The importance is normalised: ∫_film We·cos θ dω = 1, estimated over directions drawn
// uniformly on the sphere (a planted 5% error in the film area fails it).
TEST(camera_projection, ImportanceIntegratesToOneOverTheFilm) {
    json j = base_scene();
    j["render"] = {{"width", 80}, {"height", 60}};
    j["camera"] = {
        {"position", {0, 0, 0}}, {"look_at", {0.3, 0.2, 1}}, {"up", {0.1, 1, 0}}, {"vfov", 60}};
    for (bool skew : {false, true}) {
        Camera c = parse(j).camera;
        if (skew) c.left = c.left + c.up * 0.3f;  // a non-orthogonal frame
        const Vec3f n = c.film_normal();
        const float area = c.film_area();
        std::mt19937 rng(5);
        std::uniform_real_distribution<float> unit(0.0f, 1.0f);
        const int samples = 400000;
        double sum = 0.0, sum_sq = 0.0;
        for (int i = 0; i < samples; ++i) {
            const float z = 1.0f - 2.0f * unit(rng), phi = 2.0f * 3.14159265f * unit(rng);
            const float r = std::sqrt(std::max(0.0f, 1.0f - z * z));
            const Vec3f d(r * std::cos(phi), r * std::sin(phi), z);
            double v = 0.0;
            if (c.project(c.origin + d, 80.0f, 60.0f).on_film) {
                const float cos_t = dot(d, n);
                v = double(pinhole_importance(cos_t, area) * cos_t) * 4.0 * 3.14159265358979;
            }
            sum += v, sum_sq += v * v;
        }
        const double mean = sum / samples;
        const double sigma = std::sqrt((sum_sq / samples - mean * mean) / samples);
        EXPECT_NEAR(mean, 1.0, std::max(4.0 * sigma, 1e-3)) << (skew ? "skewed" : "look_at");
        EXPECT_LT(sigma, 0.01);  // (so that a 5% error cannot hide in the noise)
    }
}

TEST(scene_json_values, LookAtCameraDefaults) {
    // up = +y, vfov = 40 degrees, aspect from the default 256 x 256
    const Scene s = parse(base_scene());
    const float half = std::tan(20.0f * std::numbers::pi_v<float> / 180.0f);
    expect_vec(s.camera.forward, 0, 0, 1, 1e-6f);
    expect_vec(s.camera.up, 0, half, 0, 1e-6f);
    expect_vec(s.camera.left, -half, 0, 0, 1e-6f);
}

TEST(scene_json_values, LookAtCameraWithAnotherUp) {
    // Looking down -y with up = +z: the image's right is up × forward = +x
    json j = base_scene();
    j["camera"] = {
        {"position", {0, 5, 0}}, {"look_at", {0, 0, 0}}, {"up", {0, 0, 1}}, {"vfov", 90}};
    const Scene s = parse(j);
    expect_vec(s.camera.forward, 0, -1, 0, 1e-6f);
    expect_vec(s.camera.up, 0, 0, 1, 1e-6f);
    const Vec3f right = cross(Vec3f(0, 0, 1), Vec3f(0, -1, 0));  // up × forward
    expect_vec(s.camera.left, -right.x, -right.y, -right.z, 1e-6f);
}

TEST(scene_json_values, ExplicitCameraFrameIsKeptAsGiven) {
    json j = base_scene();
    j["camera"] = {{"position", {0, 0, -3.5}},
                   {"forward", {0, 0, 3}},
                   {"left", {-1, 0, 0}},
                   {"up", {0, 1, 0}}};
    const Scene s = parse(j);
    expect_vec(s.camera.origin, 0, 0, -3.5f);
    expect_vec(s.camera.forward, 0, 0, 3);  // not normalised: its length sets the field of view
    expect_vec(s.camera.left, -1, 0, 0);
    expect_vec(s.camera.up, 0, 1, 0);
}

TEST(scene_json_values, RenderDefaultsAndOverrides) {
    const Scene d = parse(base_scene());
    EXPECT_EQ(d.settings.width, 256);
    EXPECT_EQ(d.settings.height, 256);
    EXPECT_EQ(d.settings.spp, 16);
    EXPECT_EQ(d.settings.seed, 1u);
    EXPECT_EQ(d.settings.estimator.survival_cap, 0.9f);
    // A scene that names no estimator (with a "render" object or without) renders with mis
    // and mis's defaults; one that names the report's keeps the report's
    const auto expect_mis = [](const EstimatorSettings& e) {
        EXPECT_EQ(e.kind, Estimator::kMis);
        EXPECT_TRUE(e.cosine_diffuse);
        EXPECT_EQ(e.roulette, Roulette::kThroughput);
        EXPECT_TRUE(e.triangle_solid_angle);
        EXPECT_EQ(e.sampler, Sampler::kSobol);
    };
    expect_mis(d.settings.estimator);  // (no "render" object)
    json unnamed = base_scene();
    unnamed["render"] = {{"width", 8}};
    expect_mis(parse(unnamed).settings.estimator);
    json named = base_scene();
    named["render"]["estimator"] = "report";
    const EstimatorSettings r = parse(named).settings.estimator;
    EXPECT_EQ(r.kind, Estimator::kReport);
    EXPECT_FALSE(r.cosine_diffuse);
    EXPECT_EQ(r.roulette, Roulette::kLobe);
    EXPECT_FALSE(r.triangle_solid_angle);
    EXPECT_EQ(r.sampler, Sampler::kIndependent);
    EXPECT_EQ(d.scene_ior, 1.0f);
    EXPECT_EQ(d.settings.output, fs::path("/nonexistent-cierzo-folder/x/test.exr"));

    json j = base_scene();
    j["render"] = {{"width", 640},
                   {"height", 480},
                   {"spp", 4294967295LL},
                   {"seed", 4294967295LL},
                   {"survival_cap", 0.5},
                   {"diffuse_sampling", "cosine"},
                   {"triangle_sampling", "solid-angle"},
                   {"output", "out/img.pfm"}};
    j["scene_ior"] = 1.25;
    const Scene s = parse(j);
    EXPECT_EQ(s.settings.width, 640);
    EXPECT_EQ(s.settings.height, 480);
    EXPECT_EQ(s.settings.spp, 4294967295LL);
    EXPECT_EQ(s.settings.seed, 4294967295u);
    EXPECT_EQ(s.settings.estimator.survival_cap, 0.5f);
    EXPECT_TRUE(s.settings.estimator.cosine_diffuse);
    EXPECT_TRUE(s.settings.estimator.triangle_solid_angle);
    EXPECT_EQ(s.scene_ior, 1.25f);
    // Output relative to the scene's folder, not the working directory
    EXPECT_EQ(s.settings.output, fs::path("/nonexistent-cierzo-folder/x/out/img.pfm"));
    j["render"] = {{"output", "/nonexistent-cierzo-folder/x/elsewhere.exr"},
                   {"diffuse_sampling", "uniform"},
                   {"width", 1.0e1}};  // an integral float counts as an integer
    const Scene a = parse(j);
    EXPECT_EQ(a.settings.output, fs::path("/nonexistent-cierzo-folder/x/elsewhere.exr"));
    EXPECT_FALSE(a.settings.estimator.cosine_diffuse);       // chosen, over mis's default
    EXPECT_TRUE(a.settings.estimator.triangle_solid_angle);  // mis's default
    EXPECT_EQ(a.settings.width, 10);
}

TEST(scene_json_values, LargestImageIsAccepted) {
    // 65536 x 4096 is exactly 2^28 pixels: on the limit, not over it
    json j = base_scene();
    j["render"] = {{"width", 65536}, {"height", 4096}};
    EXPECT_EQ(parse(j).settings.width, 65536);
}

TEST(scene_json_values, CommentsAreAllowed) {
    const Scene s = parse_text(R"({
        // a line comment
        "camera": {"position": [0, 0, -3], /* a block comment */ "look_at": [0, 0, 0]},
        "objects": [{"type": "sphere", "center": [0, 0, 0], "radius": 7,  // trailing
                     "material": {"kd": 0.5}}]
    })");
    ASSERT_EQ(s.spheres.size(), 1u);
    EXPECT_EQ(s.spheres.radius[0], 7.0f);
}

TEST(scene_json_values, ALongArrayOfObjectsLoadsInOrder) {
    // 20,000 spheres, one in four with a material of its own: each lands in its place; a
    // duplicate key in the last is named by its index, and a syntax error after it by its line
    const int n = 20000;
    const auto scene = [&](const std::string& last, const std::string& end) {
        std::string text = R"({"camera": {"position": [0, 0, -3], "look_at": [0, 0, 0]},
            "materials": {"w": {"kd": 0.5}},
            "objects": [)";
        for (int i = 0; i < n - 1; ++i) {
            text += R"({"type": "sphere", "center": [)" + std::to_string(i) +
                    R"(, 0, 0], "radius": 0.25, "material": )";
            text += i % 4 == 3 ? R"({"kd": [0.5, 0.25, )" + std::to_string(i) + "]}" : R"("w")";
            text += "},\n";
        }
        return text + last + end;
    };
    const std::string last =
        R"({"type": "sphere", "center": [-1, 0, 0], "radius": 2, "material": "w"})";
    const Scene s = parse_text(scene(last, "]}"));
    ASSERT_EQ(s.spheres.size(), size_t(n));
    EXPECT_EQ(s.materials.size(), size_t(1 + (n - 1) / 4));
    size_t misplaced = 0;
    for (int i = 0; i < n - 1; ++i) {
        const Material& m = s.materials[size_t(s.spheres.material[size_t(i)])];
        misplaced += s.spheres.cx[size_t(i)] != float(i) ||
                     (i % 4 == 3 ? m.kd.a.z != float(i) : m.name != "w");
    }
    EXPECT_EQ(misplaced, 0u);
    EXPECT_EQ(s.spheres.cx[size_t(n - 1)], -1.0f);
    EXPECT_EQ(s.spheres.radius[size_t(n - 1)], 2.0f);
    EXPECT_EQ(error_of(scene(R"({"type": "sphere", "radius": 1, "radius": 2})", "]}")),
              std::string(kFake) +
                  ": objects[19999]: duplicate key 'radius' (each key may "
                  "be given once)");
    EXPECT_TRUE(text_fails_with(scene(last, "\n]]"), "line 20003, column 2"));
}

TEST(scene_json_values, PointLights) {
    json j = base_scene();
    j["lights"] = json::parse(R"([{"position": [1, 2, 3], "intensity": [4, 5, 6]},
                                  {"type": "point", "position": [0, 0, 0], "intensity": 2}])");
    const Scene s = parse(j);
    ASSERT_EQ(s.lights.size(), 2u);
    expect_vec(s.lights[0].position, 1, 2, 3);
    expect_vec(s.lights[0].intensity, 4, 5, 6);
    expect_vec(s.lights[1].intensity, 2, 2, 2);
}

// A PLY with one triangle (and vertex colours), for the mesh cases.
const char* const kTrianglePly = R"(ply
format ascii 1.0
element vertex 3
property float x
property float y
property float z
property uchar red
property uchar green
property uchar blue
element face 1
property list uchar int vertex_indices
end_header
1 0 0 255 0 0
0 1 0 0 255 0
0 0 1 0 0 51
3 0 1 2
)";

TEST(scene_json_values, MeshFileIsRelativeToTheSceneAndTransformed) {
    TempDir dir;
    dir.write("meshes/tri.ply", kTrianglePly);
    // scale, then rotate about x, then y, then z (degrees), then translate
    const fs::path scene = dir.write("scene.json", R"({
        "camera": {"position": [0, 0, -3], "look_at": [0, 0, 0]},
        "objects": [
            {"type": "mesh", "file": "meshes/tri.ply", "scale": 2, "material": {"kd": 0.5},
             "instance": true},
            {"type": "mesh", "file": "meshes/tri.ply", "rotate": [90, 90, 0],
             "material": {"kd": 0.5}, "instance": true},
            {"type": "mesh", "file": "meshes/tri.ply", "scale": [1, 2, 3], "rotate": [0, 0, 90],
             "translate": [10, 20, 30], "material": {"kd": 0.5}, "instance": true}]
    })");
    const Scene s = load_scene(scene);
    ASSERT_EQ(s.meshes.size(), 3u);
    EXPECT_EQ(s.meshes[0].source, (dir.path() / "meshes/tri.ply").string());
    // One file, three objects, all instances: read once, kept in the file's space in the
    // first object
    for (const Mesh& m : s.meshes) EXPECT_EQ(m.geometry, 0);
    EXPECT_TRUE(s.meshes[1].positions.empty());
    EXPECT_TRUE(s.meshes[2].positions.empty());
    expect_vec(s.meshes[0].positions[1], 0, 1, 0);
    EXPECT_EQ(s.meshes[0].indices, (std::vector<uint32_t>{0, 1, 2}));
    ASSERT_EQ(s.meshes[0].colors.size(), 3u);
    expect_vec(s.meshes[0].colors[0], 1, 0, 0);
    expect_vec(s.meshes[0].colors[2], 0, 0, 0.2f, 1e-6f);
    // Vertex k of object i in world space, through its transform
    const auto world = [&](size_t i, size_t k) {
        const Vec3f p = s.meshes[0].positions[k];
        const float* m = s.meshes[i].to_world;
        return Vec3f(m[0] * p.x + m[1] * p.y + m[2] * p.z + m[3],
                     m[4] * p.x + m[5] * p.y + m[6] * p.z + m[7],
                     m[8] * p.x + m[9] * p.y + m[10] * p.z + m[11]);
    };
    expect_vec(world(0, 0), 2, 0, 0);
    expect_vec(world(0, 1), 0, 2, 0);
    // x first: (0,1,0) -> (0,0,1), then y: -> (1,0,0); y first then x would give (0,0,1)
    expect_vec(world(1, 1), 1, 0, 0, 1e-6f);
    expect_vec(world(1, 0), 0, 0, -1, 1e-6f);  // x: stays, y: -> (0,0,-1)
    expect_vec(world(1, 2), 0, -1, 0, 1e-6f);  // x: -> (0,-1,0), y: stays
    // scale (1,2,3), rotate z by 90: (x,y) -> (-y,x), translate
    expect_vec(world(2, 0), 10, 21, 30, 1e-5f);
    expect_vec(world(2, 1), 8, 20, 30, 1e-5f);
    expect_vec(world(2, 2), 10, 20, 33, 1e-5f);
    // to_object inverts to_world; normal_to_world is its transpose
    for (const Mesh& m : s.meshes) {
        for (int i = 0; i < 3; ++i) {
            for (int j = 0; j < 3; ++j) {
                float e = 0.0f;
                for (int k = 0; k < 3; ++k) e += m.to_object[4 * i + k] * m.to_world[4 * k + j];
                EXPECT_NEAR(e, i == j ? 1.0f : 0.0f, 1e-6f);
                EXPECT_EQ(m.normal_to_world[3 * i + j], m.to_object[4 * j + i]);
            }
        }
    }
}

TEST(scene_json_values, AFileUsedOnceIsInWorldSpaceAndMirroringKeepsItsNormals) {
    TempDir dir;
    dir.write("meshes/tri.ply", kTrianglePly);
    dir.write("meshes/tri2.ply", kTrianglePly);
    const fs::path scene = dir.write("scene.json", R"({
        "camera": {"position": [0, 0, -3], "look_at": [0, 0, 0]},
        "objects": [
            {"type": "mesh", "file": "meshes/tri.ply", "scale": [1, 2, 3], "rotate": [0, 0, 90],
             "translate": [10, 20, 30], "material": {"kd": 0.5}},
            {"type": "mesh", "file": "meshes/tri2.ply", "scale": [-1, 1, 1],
             "material": {"kd": 0.5}}]
    })");
    const Scene s = load_scene(scene);
    ASSERT_EQ(s.meshes.size(), 2u);
    EXPECT_EQ(s.meshes[0].geometry, -1);
    expect_vec(s.meshes[0].positions[0], 10, 21, 30, 1e-5f);
    expect_vec(s.meshes[0].positions[1], 8, 20, 30, 1e-5f);
    expect_vec(s.meshes[0].positions[2], 10, 20, 33, 1e-5f);
    EXPECT_EQ(s.meshes[0].indices, (std::vector<uint32_t>{0, 1, 2}));
    // Mirrored in x: the winding is reversed, so the normal is the file's normal through the
    // inverse transpose (a mirror image of it), as it is for an instance
    EXPECT_EQ(s.meshes[1].indices, (std::vector<uint32_t>{0, 2, 1}));
}

TEST(scene_json_values, ASmallFileUsedTwiceIsCopiedUnlessInstancingIsAskedFor) {
    TempDir dir;
    dir.write("meshes/tri.ply", kTrianglePly);
    const fs::path scene = dir.write("scene.json", R"({
        "camera": {"position": [0, 0, -3], "look_at": [0, 0, 0]},
        "objects": [
            {"type": "mesh", "file": "meshes/tri.ply", "material": {"kd": 0.5}},
            {"type": "mesh", "file": "meshes/tri.ply", "translate": [5, 0, 0],
             "material": {"kd": 0.5}},
            {"type": "mesh", "file": "meshes/tri.ply", "translate": [9, 0, 0],
             "material": {"kd": 0.5}, "instance": true}]
    })");
    const Scene s = load_scene(scene);
    ASSERT_EQ(s.meshes.size(), 3u);
    // Two copies of one triangle: in world space, each with its own vertices and colours
    EXPECT_EQ(s.meshes[0].geometry, -1);
    EXPECT_EQ(s.meshes[1].geometry, -1);
    expect_vec(s.meshes[1].positions[0], 6, 0, 0);
    EXPECT_EQ(s.meshes[1].colors.size(), 3u);
    // The third asked to be an instance: it owns the file's vertices
    EXPECT_EQ(s.meshes[2].geometry, 2);
    expect_vec(s.meshes[2].positions[0], 1, 0, 0);
    ASSERT_TRUE(s.meshes[2].bvh);
    EXPECT_EQ(s.bvh.stats().primitives, 3u);  // two triangles and one instance
    EXPECT_TRUE(text_fails_with(
        R"({"camera": {"position": [0, 0, -3], "look_at": [0, 0, 0]}, "objects": [
            {"type": "mesh", "file": "meshes/tri.ply", "instance": 1, "material": {"kd": 1}}]})",
        "'instance' must be true or false", dir.path() / "bad.json"));
}

TEST(scene_json_values, LoadSceneReadsTheFile) {
    TempDir dir;
    json j = base_scene();
    j["render"] = {{"output", "img.exr"}};
    const fs::path p = dir.write("a.json", j.dump());
    const Scene s = load_scene(p);
    EXPECT_EQ(s.source, p);
    EXPECT_EQ(s.settings.output, dir.path() / "img.exr");
    EXPECT_EQ(s.spheres.size(), 1u);
}

// The fenced blocks of one language in a Markdown file, in order.
std::vector<std::string> fenced_blocks(const fs::path& md, const std::string& lang) {
    std::ifstream in(md);
    std::vector<std::string> blocks;
    std::string line, block;
    bool inside = false;
    while (std::getline(in, line)) {
        if (!inside && line == "```" + lang) {
            inside = true;
            block.clear();
        } else if (inside && line == "```") {
            inside = false;
            blocks.push_back(block);
        } else if (inside) {
            block += line + "\n";
        }
    }
    return blocks;
}

TEST(scene_json_values, DocumentedExamplesLoad) {
    // docs/scene-format.md: the minimal and the full example, with the full one's PLY
    const fs::path md = fs::path(CIERZO_SOURCE_DIR) / "docs" / "scene-format.md";
    const std::vector<std::string> scenes = fenced_blocks(md, "json");
    const std::vector<std::string> plys = fenced_blocks(md, "ply");
    ASSERT_EQ(scenes.size(), 2u);
    ASSERT_EQ(plys.size(), 1u);
    TempDir dir;
    dir.write("meshes/quad.ply", plys[0]);
    const Scene minimal = load_scene(dir.write("minimal.json", scenes[0]));
    EXPECT_EQ(minimal.spheres.size(), 1u);
    EXPECT_EQ(minimal.settings.output, dir.path() / "minimal.exr");
    const Scene full = load_scene(dir.write("full.json", scenes[1]));
    EXPECT_EQ(full.planes.size(), 5u);
    EXPECT_EQ(full.spheres.size(), 3u);
    EXPECT_EQ(full.quadrics.size(), 1u);
    ASSERT_EQ(full.meshes.size(), 2u);               // the loose triangle and the PLY
    EXPECT_EQ(full.meshes[0].triangle_count(), 2u);  // the quad, fan-triangulated
    EXPECT_EQ(full.lights.size(), 1u);
    EXPECT_EQ(full.settings.output, dir.path() / "renders" / "full.exr");
    EXPECT_TRUE(full.settings.estimator.cosine_diffuse);
    const SceneFeatures f = full.features();
    EXPECT_TRUE(f.emitters && f.diffuse && f.specular && f.mirror && f.refraction);
    EXPECT_TRUE(f.procedural_textures && f.vertex_colors && f.point_lights);
}

// ---- Errors: InputError naming the file and the problem ----------------------------

TEST(scene_json_errors, MalformedJsonWithLineInfo) {
    EXPECT_TRUE(text_fails_with("{\n  \"camera\": {},\n  \"objects\": [,]\n}", "line 3"));
    EXPECT_TRUE(text_fails_with("{\"objects\": [", "invalid JSON"));
    EXPECT_TRUE(text_fails_with("", "invalid JSON"));
    EXPECT_TRUE(text_fails_with("[1, 2]", "scene: must be a JSON object"));
}

TEST(scene_json_errors, UnknownTopLevelKey) {
    json j = base_scene();
    j["light"] = json::array();
    EXPECT_TRUE(fails_with(j, "unknown key 'light'"));
}

TEST(scene_json_errors, ADuplicateKeyIsRefusedWhereverItIs) {
    // (written as text: a JSON object cannot hold one key twice)
    const std::string camera = R"("camera": {"position": [0, 0, -3], "look_at": [0, 0, 0]})";
    const std::string objects =
        R"("objects": [{"type": "sphere", "center": [0, 0, 0], "radius": 1, "material": "w"}])";
    const std::string materials = R"("materials": {"w": {"kd": 0.5}})";
    const auto scene = [&](const std::string& render, const std::string& mats,
                           const std::string& objs) {
        return "{" + render + camera + ", " + mats + ", " + objs + "}";
    };
    // The given case: spp twice renders neither silently
    EXPECT_TRUE(text_fails_with(scene(R"("render": {"spp": 64, "spp": 2}, )", materials, objects),
                                "render: duplicate key 'spp'"));
    EXPECT_TRUE(text_fails_with(scene("", R"("materials": {"w": {"kd": 0.5, "kd": 0.1}})", objects),
                                "materials.w: duplicate key 'kd'"));
    EXPECT_TRUE(
        text_fails_with(scene("", R"("materials": {"w": {"kd": 0.5}, "w": {"kd": 0.1}})", objects),
                        "materials: duplicate key 'w'"));
    EXPECT_TRUE(text_fails_with(
        scene("", materials,
              R"("objects": [{"type": "plane", "normal": [0, 1, 0], "distance": 1, "material": "w"},
                             {"type": "sphere", "radius": 1, "center": [0, 0, 0], "radius": 2,
                              "material": "w"}])"),
        "objects[1]: duplicate key 'radius'"));
    EXPECT_TRUE(text_fails_with(
        scene(R"("render": {"width": 8}, "render": {"width": 9}, )", materials, objects),
        "scene: duplicate key 'render'"));
    // The same key in different objects is no duplicate
    EXPECT_NO_THROW(
        parse_text(scene(R"("render": {"width": 8, "height": 8}, )",
                         R"("materials": {"w": {"kd": 0.5}, "v": {"kd": 0.5}})", objects)));
}
TEST(scene_json_errors, ADuplicateKeyDeepInsideIsNamedByItsPath) {
    const std::string cam = R"("camera": {"position": [0, 0, -3], "look_at": [0, 0, 0]})";
    const std::string sphere =
        R"({"type": "sphere", "center": [0, 0, 0], "radius": 1, "material": {"kd": 1}})";
    const std::string file = std::string(kFake) + ": ";
    const std::string once = " (each key may be given once)";
    // In a texture, in an inline material, in the second object
    EXPECT_EQ(error_of("{" + cam + R"(, "objects": [)" + sphere + R"(, {"type": "sphere",
                  "center": [0, 0, 0], "radius": 1, "material": {"kd": {"texture": "sin",
                  "a": 1, "b": 0, "a": 2}}}]})"),
              file + "objects[1].material.kd: duplicate key 'a'" + once);
    // In an object inside an array inside an array
    EXPECT_EQ(error_of("{" + cam + R"(, "objects": [)" + sphere + R"(, {"type": "triangle",
                  "vertices": [[0, 0, 0], [1, 0, 0], {"x": 0, "x": 1}], "material": "w"}]})"),
              file + "objects[1].vertices[2]: duplicate key 'x'" + once);
    // Every element before it counts once, whatever it is: number, string, array, object, null
    EXPECT_EQ(error_of("{" + cam + R"(, "objects": [1, "two", [3, [4]], {"five": {"six": 6}},
                  null, {"k": 1, "k": 2}]})"),
              file + "objects[5]: duplicate key 'k'" + once);
    // In a point light, after the objects; in the camera; at the top of the file
    EXPECT_EQ(error_of("{" + cam + R"(, "objects": [], "lights": [{"position": [0, 0, 0],
                  "intensity": 1}, {"position": [0, 0, 0], "position": [1, 1, 1]}]})"),
              file + "lights[1]: duplicate key 'position'" + once);
    EXPECT_EQ(error_of(R"({"camera": {"position": [0, 0, -3], "look_at": [0, 0, 0],
                  "position": [0, 0, 3]}, "objects": []})"),
              file + "camera: duplicate key 'position'" + once);
    EXPECT_EQ(error_of("{" + cam + R"(, "objects": [], "objects": []})"),
              file + "scene: duplicate key 'objects'" + once);
    // A document that is an array is "scene" too
    EXPECT_EQ(error_of(R"([{"a": 1}, [{"a": 1, "a": 1}]])"),
              file + "scene[1][0]: duplicate key 'a'" + once);
    // Found while reading: before a syntax error further on, after one before it
    EXPECT_EQ(error_of("{" + cam + R"(, "objects": [{"r": 1, "r": 1}, ,]})"),
              file + "objects[0]: duplicate key 'r'" + once);
    EXPECT_TRUE(
        text_fails_with("{" + cam + R"(, "objects": [, {"r": 1, "r": 1}]})", "syntax error"));
}

// A scene as text with "materials" before "objects" (whose objects the reader takes while it
// parses) or after them (read from the whole document): the same scene, the same errors.
std::string ordered_scene(bool materials_first, const std::string& materials,
                          const std::string& objects, const std::string& after = "") {
    const std::string cam = R"("camera": {"position": [0, 0, -3], "look_at": [0, 0, 0]})";
    const std::string m = R"("materials": )" + materials;
    const std::string o = R"("objects": )" + objects;
    return "{" + cam + ", " + (materials_first ? m + ", " + o : o + ", " + m) + after + "}";
}

TEST(scene_json_values, MaterialsBeforeOrAfterTheObjectsGiveTheSameScene) {
    const std::string materials = R"({"w": {"kd": 0.5}, "a": {"kr": [0.25, 0.5, 1]}})";
    const std::string objects = R"([
        {"type": "sphere", "center": [1, 2, 3], "radius": 0.5, "material": "w"},
        {"type": "plane", "normal": [0, 2, 0], "distance": 1, "material": {"kd": [0.1, 0.2, 0.3]}},
        {"type": "triangle", "vertices": [[0, 0, 0], [1, 0, 0], [0, 1, 0]], "material": "a"},
        {"type": "sphere", "center": [4, 5, 6], "radius": 2, "material": {"emission": 3}},
        {"type": "sphere", "center": [7, 8, 9], "radius": 1, "material": "a"}])";
    const Scene first = parse_text(ordered_scene(true, materials, objects));
    const Scene last = parse_text(ordered_scene(false, materials, objects));
    for (const Scene* s : {&first, &last}) {
        ASSERT_EQ(s->spheres.size(), 3u);
        EXPECT_EQ(s->spheres.cx, (std::vector<float>{1, 4, 7}));
        EXPECT_EQ(s->spheres.radius, (std::vector<float>{0.5f, 2, 1}));
        ASSERT_EQ(s->planes.size(), 1u);
        EXPECT_EQ(s->planes.distance[0], 0.5f);
        ASSERT_EQ(s->meshes.size(), 1u);
        // Named materials first, in name order, then the inline ones in the order of the file
        ASSERT_EQ(s->materials.size(), 4u);
        EXPECT_EQ(s->materials[0].name, "a");
        EXPECT_EQ(s->materials[1].name, "w");
        expect_vec(s->materials[2].kd.a, 0.1f, 0.2f, 0.3f);
        expect_vec(s->materials[3].emission.a, 3, 3, 3);
        EXPECT_EQ(s->spheres.material, (std::vector<int32_t>{1, 3, 0}));
        EXPECT_EQ(s->planes.material[0], 2);
        EXPECT_EQ(s->meshes[0].material, 0);
    }
}

TEST(scene_json_errors, MaterialsBeforeOrAfterTheObjectsGiveTheSameError) {
    const std::string w = R"({"w": {"kd": 0.5}})";
    const std::string good =
        R"({"type": "sphere", "center": [0, 0, 0], "radius": 1, "material": "w"})";
    const std::string bad =
        R"({"type": "sphere", "center": [0, 0, 0], "radius": -1, "material": "w"})";
    const auto objects = [&](const std::string& second, const std::string& fourth) {
        return "[" + good + ", " + second + ", " + good + ", " + fourth + "]";
    };
    struct Case {
        std::string materials, objects, after, error;
    };
    const std::string radius = "objects[1] (sphere): 'radius' must be > 0";
    const std::vector<Case> cases = {
        // The first bad object, not a later one
        {w, objects(bad, R"({"type": "cone"})"), "", radius},
        // Keys read before the objects, whatever their place in the file
        {w, objects(bad, good), R"(, "render": {"spp": 0})", "render: 'spp' must be in"},
        {w, objects(bad, good), R"(, "scene_ior": -1)", "scene: 'scene_ior' must be > 0"},
        {R"({"w": {"kd": -1}})", objects(bad, good), R"(, "render": {"spp": 0})",
         "render: 'spp' must be in"},
        {R"({"w": {"kd": -1}})", objects(bad, good), "", "materials.w: 'kd' must be finite"},
        {"[1]", objects(bad, good), "", "scene: 'materials' must be an object"},
        // and after them
        {w, objects(bad, good), R"(, "lights": [{"position": 1}], "extra": 1)", radius},
        {w, objects(good, good), R"(, "lights": [{"position": 1}], "extra": 1)",
         "lights[0]: 'position' must be an array of 3 numbers"},
        {w,
         objects(R"({"type": "sphere", "center": [0, 0, 0], "radius": 1, "material": "x"})", good),
         R"(, "extra": 1)", "objects[1] (sphere): unknown material 'x'"},
        // Errors of the JSON itself come first, wherever they are
        {w, objects(bad, R"({"type": "sphere", "radius": 1, "radius": 1})"), "",
         "objects[3]: duplicate key 'radius'"},
        {w, objects(bad, good), R"(, "render": {"spp": 0}, "x": [1,])", "invalid JSON"},
        {w, objects(bad, good), R"(, "render": {"spp": 0}, "x": 1e400)", "number overflow"},
    };
    for (const Case& c : cases)
        for (bool materials_first : {true, false}) {
            SCOPED_TRACE(std::string(materials_first ? "materials first: " : "objects first: ") +
                         c.error);
            EXPECT_TRUE(text_fails_with(
                ordered_scene(materials_first, c.materials, c.objects, c.after), c.error));
        }
}

TEST(scene_json_errors, NestingDeeperThan64LevelsIsRefused) {
    // The document is level 1, 'objects' 2, the sphere 3, its centre 4, and each array in
    // the centre one more. 64 levels are read (the centre is then refused for its shape),
    // 65 are refused by the JSON reader before anything recurses on them.
    const auto scene = [](int levels) {
        const int inner = levels - 4;
        return R"({"camera": {"position": [0, 0, -3], "look_at": [0, 0, 0]},
            "objects": [{"type": "sphere", "radius": 1, "material": {"kd": 1}, "center": [)" +
               std::string(size_t(inner), '[') + "0" + std::string(size_t(inner), ']') + "]}]}";
    };
    const std::string deep =
        std::string(kFake) + ": invalid JSON: arrays and objects nested deeper than 64 levels";
    EXPECT_TRUE(text_fails_with(scene(64), "objects[0] (sphere): 'center' must be an array"));
    EXPECT_EQ(error_of(scene(65)), deep);
    EXPECT_EQ(error_of(scene(1000)), deep);
    // Objects count as arrays do: a material of 62 nested objects is levels 3 to 64
    std::string material = "1";
    for (int i = 0; i < 62; ++i) material = R"({"m": )" + material + "}";
    const std::string cam = R"({"camera": {"position": [0, 0, -3], "look_at": [0, 0, 0]}, )";
    EXPECT_TRUE(text_fails_with(cam + R"("materials": {"w": )" + material + R"(}, "objects": []})",
                                "materials.w: unknown key 'm'"));
    EXPECT_EQ(error_of(cam + R"("materials": {"w": {"m": )" + material + R"(}}, "objects": []})"),
              deep);
}

TEST(scene_json_errors, UnknownKeyInAMaterialListsTheValidOnes) {
    json j = base_scene();
    j["materials"]["white"]["shininnes"] = 10;
    EXPECT_TRUE(fails_with(j, "materials.white: unknown key 'shininnes'"));
    EXPECT_TRUE(fails_with(j, "shininess"));
}

TEST(scene_json_errors, UnknownKeysElsewhere) {
    json j = base_scene();
    j["objects"][0]["colour"] = 1;
    EXPECT_TRUE(fails_with(j, "objects[0] (sphere): unknown key 'colour'"));
    j = base_scene();
    j["render"] = {{"widht", 5}};
    // The list of valid keys includes those left at their defaults
    EXPECT_TRUE(fails_with(j, "unknown key 'widht'"));
    EXPECT_TRUE(fails_with(j, "width"));
    j = base_scene();
    j["camera"]["fov"] = 30;
    EXPECT_TRUE(fails_with(j, "unknown key 'fov'"));
    j = base_scene();
    j["objects"][0] = json::parse(R"({"type": "quadric", "coefficients": [1,1,1,0,0,0,0,0,0,-1],
        "bounds": {"min": [0, 0, 0], "max": [1, 1, 1], "mid": [0, 0, 0]}, "material": "white"})");
    EXPECT_TRUE(fails_with(j, "unknown key 'mid'"));
    j = base_scene();
    j["materials"]["white"]["kd"] = {{"texture", "solid"}, {"a", 1}, {"b", 2}};
    EXPECT_TRUE(fails_with(j, "unknown key 'b'"));
    j = base_scene();
    j["lights"] = json::parse(R"([{"position": [0, 0, 0], "intensity": 1, "radius": 1}])");
    EXPECT_TRUE(fails_with(j, "lights[0]: unknown key 'radius'"));
}

TEST(scene_json_errors, MissingRequiredKeys) {
    json j = base_scene();
    j["objects"][0].erase("radius");
    EXPECT_TRUE(fails_with(j, "objects[0] (sphere): missing required key 'radius'"));
    j = base_scene();
    j["objects"][0].erase("material");
    EXPECT_TRUE(fails_with(j, "missing required key 'material'"));
    j = base_scene();
    j.erase("objects");
    EXPECT_TRUE(fails_with(j, "missing required key 'objects'"));
    j = base_scene();
    j.erase("camera");
    EXPECT_TRUE(fails_with(j, "missing required key 'camera'"));
    j = base_scene();
    j["camera"] = {{"position", {0, 0, 0}}, {"forward", {0, 0, 1}}, {"up", {0, 1, 0}}};
    EXPECT_TRUE(fails_with(j, "missing required key 'left'"));
    j = base_scene();
    j["lights"] = json::parse(R"([{"position": [0, 0, 0]}])");
    EXPECT_TRUE(fails_with(j, "missing required key 'intensity'"));
    j = base_scene();
    j["materials"]["white"]["kd"] = {{"texture", "sin"}, {"a", 1}};
    EXPECT_TRUE(fails_with(j, "missing required key 'b'"));
}

TEST(scene_json_errors, SphereRadius) {
    json j = base_scene();
    j["objects"][0]["radius"] = -1;
    EXPECT_TRUE(fails_with(j, "'radius' must be > 0"));
    j["objects"][0]["radius"] = 0;
    EXPECT_TRUE(fails_with(j, "'radius' must be > 0"));
    j["objects"][0]["radius"] = "1";
    EXPECT_TRUE(fails_with(j, "'radius' must be a number"));
}

TEST(scene_json_errors, ZeroPlaneNormal) {
    json j = base_scene();
    j["objects"][0] = {
        {"type", "plane"}, {"normal", {0, 0, 0}}, {"distance", 1}, {"material", "white"}};
    EXPECT_TRUE(fails_with(j, "'normal' must not be the zero vector"));
    j["objects"][0]["normal"] = {0, 1};
    EXPECT_TRUE(fails_with(j, "'normal' must be an array of 3 numbers"));
}

TEST(scene_json_errors, UnknownMaterialObjectTypeAndTexture) {
    json j = base_scene();
    j["objects"][0]["material"] = "whit";
    EXPECT_TRUE(fails_with(j, "unknown material 'whit'"));
    j = base_scene();
    j["objects"][0]["type"] = "cube";
    EXPECT_TRUE(fails_with(j, "unknown object type 'cube'"));
    j = base_scene();
    j["materials"]["white"]["kd"] = {{"texture", "checker"}, {"a", 1}};
    EXPECT_TRUE(fails_with(j, "unknown texture 'checker'"));
    j = base_scene();
    j["lights"] = json::parse(R"([{"type": "spot", "position": [0, 0, 0], "intensity": 1}])");
    EXPECT_TRUE(fails_with(j, "unknown light type 'spot'"));
}

TEST(scene_json_errors, NegativeColours) {
    json j = base_scene();
    j["materials"]["white"]["kd"] = {0.5, -0.1, 0.2};
    EXPECT_TRUE(fails_with(j, "'kd' components must be finite and >= 0"));
    j["materials"]["white"]["kd"] = -0.5;
    EXPECT_TRUE(fails_with(j, "'kd' must be finite and >= 0"));
    j = base_scene();
    j["materials"]["white"]["emission"] = {{"texture", "sin"}, {"a", 1}, {"b", {1, -1, 1}}};
    EXPECT_TRUE(fails_with(j, "'b' components must be finite and >= 0"));
    j = base_scene();
    j["lights"] = json::parse(R"([{"position": [0, 0, 0], "intensity": -2}])");
    EXPECT_TRUE(fails_with(j, "'intensity' must be finite and >= 0"));
    j = base_scene();
    j["objects"][0] = json::parse(R"({"type": "triangle", "vertices": [[0,0,0],[1,0,0],[0,1,0]],
        "colors": [1, 1, -1], "material": "white"})");
    EXPECT_TRUE(fails_with(j, "'colors' must be finite and >= 0"));
}

TEST(scene_json_errors, OverflowingNumbersAreRefused) {
    // 1e400 overflows a double: the JSON reader refuses it. 1e39 is a finite double but
    // overflows the float every value is stored in: it must not become an infinite float.
    const std::string cam = R"("camera": {"position": [0, 0, -3], "look_at": [0, 0, 0]})";
    auto sphere = [&](const std::string& centre, const std::string& radius, const std::string& kd) {
        return "{" + cam + R"(, "objects": [{"type": "sphere", "center": )" + centre +
               R"(, "radius": )" + radius + R"(, "material": {"kd": )" + kd + "}}]}";
    };
    EXPECT_NO_THROW(parse_text(sphere("[0, 0, 0]", "1", "0.5")));
    EXPECT_TRUE(text_fails_with(sphere("[0, 0, 0]", "1e400", "0.5"), "number overflow"));
    EXPECT_TRUE(text_fails_with(sphere("[0, -1e400, 0]", "1", "0.5"), "invalid JSON"));
    EXPECT_TRUE(text_fails_with(sphere("[0, 0, 0]", "1", "1e400"), "'1e400'"));
    EXPECT_TRUE(text_fails_with(sphere("[0, 0, 0]", "1e39", "0.5"), "'radius' must be finite"));
    EXPECT_TRUE(text_fails_with(sphere("[0, -1e39, 0]", "1", "0.5"), "'center' must be finite"));
    EXPECT_TRUE(text_fails_with(sphere("[0, 0, 0]", "1", "1e39"), "'kd' must be finite"));
    EXPECT_TRUE(text_fails_with(sphere("[0, 0, 0]", "1", "[1, 1e39, 1]"),
                                "'kd' components must be finite"));
    EXPECT_TRUE(text_fails_with("{" + cam + R"(, "scene_ior": 1e39, "objects": []})",
                                "'scene_ior' must be finite"));
    EXPECT_TRUE(text_fails_with("{" + cam + R"(, "objects": [{"type": "plane",
        "normal": [0, 1, 0], "distance": -1e39, "material": {"kd": 1}}]})",
                                "'distance' must be finite"));
    EXPECT_TRUE(text_fails_with("{" + cam + R"(, "objects": [{"type": "quadric",
        "material": {"kd": 1}, "coefficients": [1, 1, 1, 0, 0, 0, 0, 0, 0, -1e39]}]})",
                                "10 finite numbers"));
    EXPECT_TRUE(text_fails_with("{" + cam + R"(, "materials": {"m": {"ior": 1e39}},
        "objects": []})",
                                "'ior' must be finite"));
    EXPECT_TRUE(text_fails_with("{" + cam + R"(, "render": {"spp": 1e39}, "objects": []})",
                                "'spp' must be in"));
}

TEST(scene_json_errors, SurvivalCapMustBeInsideZeroOne) {
    json j = base_scene();
    for (double cap : {1.0, 0.0, -0.5, 1.5}) {
        j["render"] = {{"survival_cap", cap}};
        EXPECT_TRUE(fails_with(j, "'survival_cap' must be in (0, 1)")) << cap;
    }
    j["render"] = {{"survival_cap", 0.999}};
    EXPECT_NO_THROW(parse(j));
}

TEST(scene_json_errors, SpatialSplitsMustBeABudgetFromZeroToFour) {
    json j = base_scene();
    for (double budget : {-0.1, 4.5, 100.0}) {
        j["render"] = {{"spatial_splits", budget}};
        EXPECT_TRUE(fails_with(j, "'spatial_splits' must be in [0, 4]")) << budget;
    }
    j["render"] = {{"spatial_splits", 1e39}};
    EXPECT_TRUE(fails_with(j, "'spatial_splits' must be finite"));
    j["render"] = {{"spatial_splits", 4}};
    EXPECT_NO_THROW(parse(j));
}

TEST(scene_json, SpatialSplitsReachTheSceneTree) {
    // Long thin triangles at random angles: with a budget the tree cuts some of them (more
    // references than triangles, at most the budget more); without, none
    json j = base_scene();
    std::mt19937 rng(7);
    std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
    for (int i = 0; i < 400; ++i) {
        const float a[3] = {unit(rng), unit(rng), unit(rng)},
                    b[3] = {unit(rng), unit(rng), unit(rng)};
        j["objects"].push_back(
            {{"type", "triangle"},
             {"material", {{"kd", 0.5}}},
             {"vertices", {{a[0], a[1], a[2]}, {b[0], b[1], b[2]}, {a[0] + 0.01f, a[1], a[2]}}}});
    }
    const Scene none = parse(j);
    EXPECT_EQ(none.settings.spatial_splits, 0.0f);
    EXPECT_EQ(none.bvh.stats().references, none.bvh.stats().primitives);
    j["render"] = {{"spatial_splits", 0.5}};
    const Scene cut = parse(j);
    EXPECT_EQ(cut.settings.spatial_splits, 0.5f);
    EXPECT_GT(cut.bvh.stats().references, cut.bvh.stats().primitives);
    EXPECT_LE(cut.bvh.stats().references, cut.bvh.stats().primitives * 3 / 2);
}

TEST(scene_json_errors, ImageSizeLimits) {
    json j = base_scene();
    j["render"] = {{"width", 0}};
    EXPECT_TRUE(fails_with(j, "'width' must be in [1, 65536], got 0"));
    j["render"] = {{"width", 1000000}};
    EXPECT_TRUE(fails_with(j, "'width' must be in [1, 65536]"));
    j["render"] = {{"width", 1000000}, {"height", 1000000}};
    EXPECT_TRUE(fails_with(j, "must be in [1, 65536]"));
    j["render"] = {{"height", 65537}};
    EXPECT_TRUE(fails_with(j, "'height' must be in [1, 65536]"));
    // Each side within its limit, the product over 2^28
    j["render"] = {{"width", 65536}, {"height", 4097}};
    EXPECT_TRUE(fails_with(j, "exceeds the limit of 2^28 pixels"));
    j["render"] = {{"width", 10.5}};
    EXPECT_TRUE(fails_with(j, "'width' must be an integer"));
    j["render"] = {{"spp", 0}};
    EXPECT_TRUE(fails_with(j, "'spp' must be in"));
    j["render"] = {{"seed", -1}};
    EXPECT_TRUE(fails_with(j, "'seed' must be in"));
    j["render"] = {{"diffuse_sampling", "importance"}};
    EXPECT_TRUE(fails_with(j, "'diffuse_sampling' must be"));
    j["render"] = {{"triangle_sampling", "solid_angle"}};
    EXPECT_TRUE(fails_with(j, "'triangle_sampling' must be"));
}

TEST(scene_json_errors, DegenerateQuadrics) {
    json j = base_scene();
    j["objects"][0] = {{"type", "quadric"},
                       {"coefficients", {0, 0, 0, 0, 0, 0, 0, 0, 0, 1}},
                       {"material", "white"}};
    EXPECT_TRUE(fails_with(j, "A..I are all zero"));
    j["objects"][0]["coefficients"] = {1, 1, 1, 0, 0, 0, 0, 0, 0};
    EXPECT_TRUE(fails_with(j, "'coefficients' must be an array of 10 numbers"));
    j["objects"][0]["coefficients"] = {1, 1, 1, 0, 0, 0, 0, 0, 0, -1};
    j["objects"][0]["bounds"] = {{"min", {0, 2, 0}}, {"max", {1, 1, 1}}};
    EXPECT_TRUE(fails_with(j, "min must be <= max"));
    j["objects"][0]["bounds"] = {{"min", {0, 0, 0}}};
    EXPECT_TRUE(fails_with(j, "missing required key 'max'"));
}

TEST(scene_json_errors, MissingMeshFileNamesThePly) {
    json j = base_scene();
    j["objects"][0] = {{"type", "mesh"}, {"file", "bunny.ply"}, {"material", "white"}};
    EXPECT_TRUE(fails_with(j, "/nonexistent-cierzo-folder/x/bunny.ply"));
    EXPECT_TRUE(fails_with(j, "objects[0] (mesh)"));
}

TEST(scene_json_errors, BadMeshTransform) {
    TempDir dir;
    dir.write("tri.ply", kTrianglePly);
    const std::string head = R"({"camera": {"position": [0, 0, -3], "look_at": [0, 0, 0]},
        "objects": [{"type": "mesh", "file": "tri.ply", "material": {"kd": 1}, )";
    const fs::path zero = dir.write("zero.json", head + R"("scale": [1, 0, 1]}]})");
    const fs::path inf = dir.write("inf.json", head + R"("scale": 1e39}]})");
    const fs::path ok = dir.write("ok.json", head + R"("scale": -1}]})");
    auto read = [](const fs::path& p) {
        std::ifstream in(p);
        return std::string(std::istreambuf_iterator<char>(in), {});
    };
    EXPECT_NO_THROW(load_scene(ok));
    EXPECT_TRUE(text_fails_with(read(zero), "'scale' must be non-zero", zero));
    EXPECT_TRUE(text_fails_with(read(inf), "'scale' must be finite", inf));
}

TEST(scene_json_errors, MaterialRanges) {
    json j = base_scene();
    j["materials"]["white"]["shininess"] = -1;
    EXPECT_TRUE(fails_with(j, "'shininess' must be in [0, 1e6]"));
    j = base_scene();
    j["materials"]["white"]["ior"] = 0;
    EXPECT_TRUE(fails_with(j, "'ior' must be > 0"));
    j["materials"]["white"]["ior"] = -1.5;
    EXPECT_TRUE(fails_with(j, "'ior' must be > 0"));
    j = base_scene();
    j["scene_ior"] = 0;
    EXPECT_TRUE(fails_with(j, "'scene_ior' must be > 0"));
    j = base_scene();
    j["materials"] = {{"white", 0.8}};
    EXPECT_TRUE(fails_with(j, "materials.white: must be a JSON object"));
}

TEST(scene_json_errors, CameraProblems) {
    json j = base_scene();
    j["camera"] = {{"position", {0, 0, 0}}, {"look_at", {0, 5, 0}}};  // up defaults to +y
    EXPECT_TRUE(fails_with(j, "'up' is parallel to the viewing direction"));
    j["camera"] = {{"position", {0, 0, 0}}, {"look_at", {0, 0, 1}}, {"up", {0, 0, -2}}};
    EXPECT_TRUE(fails_with(j, "'up' is parallel to the viewing direction"));
    j["camera"] = {{"position", {1, 1, 1}}, {"look_at", {1, 1, 1}}};
    EXPECT_TRUE(fails_with(j, "'look_at' equals 'position'"));
    j["camera"] = {{"position", {0, 0, 0}}, {"look_at", {0, 0, 1}}, {"vfov", 180}};
    EXPECT_TRUE(fails_with(j, "'vfov' must be in (0, 180)"));
    j["camera"] = {
        {"position", {0, 0, 0}}, {"forward", {0, 0, 1}}, {"left", {0, 0, 0}}, {"up", {0, 1, 0}}};
    EXPECT_TRUE(fails_with(j, "must be non-zero"));
}

TEST(scene_json_errors, CameraFormsDoNotMix) {
    // A key of the other form would be ignored: an error instead
    json j = base_scene();
    j["camera"] = {{"position", {0, 0, 0}}, {"look_at", {0, 0, 1}}, {"forward", {0, 0, 1}}};
    EXPECT_TRUE(fails_with(j, "cannot be combined with 'look_at'"));
    j["camera"] = {{"position", {0, 0, 0}},
                   {"forward", {0, 0, 1}},
                   {"left", {-1, 0, 0}},
                   {"up", {0, 1, 0}},
                   {"vfov", 60}};
    EXPECT_TRUE(fails_with(j, "'vfov' belongs to the 'look_at' form"));
}

TEST(scene_json_errors, WrongShapes) {
    json j = base_scene();
    j["objects"] = json::object();
    EXPECT_TRUE(fails_with(j, "'objects' must be an array"));
    j = base_scene();
    j["objects"][0] = {
        {"type", "triangle"}, {"vertices", {{0, 0, 0}, {1, 0, 0}}}, {"material", "white"}};
    EXPECT_TRUE(fails_with(j, "'vertices' must be 3 points"));
    j["objects"][0]["vertices"] = {{0, 0, 0}, {1, 0, 0}, {0, "y", 0}};
    EXPECT_TRUE(fails_with(j, "must be an array of 3 numbers"));
    j = base_scene();
    j["objects"][0]["type"] = 3;
    EXPECT_TRUE(fails_with(j, "'type' must be a string"));
}

TEST(scene_json_errors, LoadSceneOfAMissingFile) {
    const fs::path p = "/nonexistent-cierzo-folder/none.json";
    try {
        load_scene(p);
        ADD_FAILURE() << "no error";
    } catch (const InputError& e) {
        EXPECT_NE(std::string(e.what()).find(p.string() + ": cannot open scene file"),
                  std::string::npos)
            << e.what();
    }
}

}  // namespace
}  // namespace cierzo

namespace cierzo {
namespace {

TEST(SceneResolution, LookAtCameraKeepsItsFieldOfViewAtANewAspect) {
    Scene s = parse_scene(R"({"render": {"width": 100, "height": 100},
        "camera": {"position": [0, 0, 0], "look_at": [0, 0, 1], "vfov": 90},
        "objects": [{"type": "sphere", "center": [0, 0, 5], "radius": 1, "material": {"kd": 1}}]})",
                          "/tmp/res.json");
    s.set_resolution(200, 100);
    // vfov 90: the up vector's length is tan(45°) = 1; the width doubles with the aspect
    EXPECT_NEAR(length(s.camera.up), 1.0f, 1e-6f);
    EXPECT_NEAR(length(s.camera.left), 2.0f, 1e-6f);
    EXPECT_EQ(s.settings.width, 200);
    // An explicit frame is kept as given
    Scene e = parse_scene(R"({"camera": {"position": [0, 0, 0], "forward": [0, 0, 1],
        "left": [-1, 0, 0], "up": [0, 1, 0]},
        "objects": [{"type": "sphere", "center": [0, 0, 5], "radius": 1, "material": {"kd": 1}}]})",
                          "/tmp/res.json");
    e.set_resolution(300, 100);
    EXPECT_NEAR(length(e.camera.left), 1.0f, 1e-6f);
}

// ---- What a scene may read and write, and its images' memory ---------------------------

// The message of the InputError that loading `scene` throws, or what happened instead
std::string load_error(const fs::path& scene, const LoadOptions& options = {}) {
    try {
        load_scene(scene, options);
    } catch (const InputError& e) {
        return e.what();
    } catch (const std::exception& e) {
        return std::string("not an InputError: ") + e.what();
    }
    return "no error";
}

std::string mesh_scene(const std::string& file) {
    return json{
        {"camera", {{"position", {0, 0, -3}}, {"look_at", {0, 0, 0}}}},
        {"objects", json::array({{{"type", "mesh"}, {"file", file}, {"material", {{"kd", 0.5}}}}})}}
        .dump();
}

// A downloaded scene names files beneath its own folder only: a mesh, an OBJ's MTL library
// or an image elsewhere (by "..", an absolute path or a link out of the folder) is refused
// before it is read, unless the user allows the folder it is in
TEST(scene_json_paths, InputsOutsideTheScenesFolderAreRefusedUnlessAllowed) {
    TempDir dir;
    const fs::path outside = dir.write("outside/tri.ply", kTrianglePly).parent_path();
    dir.write("scene/inside/tri.ply", kTrianglePly);
    EXPECT_EQ(load_scene(dir.write("scene/ok.json", mesh_scene("inside/tri.ply"))).meshes.size(),
              1u);
    EXPECT_EQ(load_scene(dir.write("scene/dots.json", mesh_scene("inside/../inside/tri.ply")))
                  .meshes.size(),
              1u);
    fs::create_symlink(outside / "tri.ply", dir.path() / "scene/link.ply");
    for (const std::string& named :
         {std::string("../outside/tri.ply"), (outside / "tri.ply").string(),
          std::string("link.ply"), std::string("inside/../../outside/tri.ply")}) {
        SCOPED_TRACE(named);
        const fs::path scene = dir.write("scene/out.json", mesh_scene(named));
        const std::string m = load_error(scene);
        EXPECT_NE(m.find("out.json: objects[0] (mesh): 'file': '" + named + "' resolves to "),
                  std::string::npos)
            << m;
        EXPECT_NE(m.find("outside the scene's folder"), std::string::npos) << m;
        EXPECT_NE(m.find("--allow-path"), std::string::npos) << m;
        LoadOptions allowed;
        allowed.allowed_paths = {outside};
        EXPECT_EQ(load_scene(scene, allowed).meshes.size(), 1u);
        allowed.allowed_paths = {"/"};
        EXPECT_EQ(load_scene(scene, allowed).meshes.size(), 1u);
    }
    // An OBJ inside whose mtllib is outside; an image texture outside
    dir.write("outside/m.mtl", "newmtl a\nKd 0.5 0.5 0.5\n");
    dir.write("scene/m.obj",
              "mtllib ../outside/m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl a\nf 1 2 3\n");
    const std::string lib = load_error(dir.write(
        "scene/obj.json", json{{"camera", {{"position", {0, 0, -3}}, {"look_at", {0, 0, 0}}}},
                               {"objects", json::array({{{"type", "mesh"}, {"file", "m.obj"}}})}}
                              .dump()));
    EXPECT_NE(lib.find("material library (mtllib): '../outside/m.mtl' resolves to"),
              std::string::npos)
        << lib;
    write_ldr(outside / "wood.png", Image(2, 2));
    const std::string image = load_error(dir.write(
        "scene/image.json",
        json{{"camera", {{"position", {0, 0, -3}}, {"look_at", {0, 0, 0}}}},
             {"objects",
              json::array({{{"type", "sphere"},
                            {"center", {0, 0, 0}},
                            {"radius", 1},
                            {"material",
                             {{"kd", {{"texture", "image"}, {"file", "../outside/wood.png"}}}}}}})}}
            .dump()));
    EXPECT_NE(image.find("image.json: objects[0] (sphere).material.kd.file: "), std::string::npos)
        << image;
    EXPECT_NE(image.find("outside the scene's folder"), std::string::npos) << image;
}

// A scene's "output" lands beneath its own folder: a scene does not choose where files are
// written (--out on the command line does)
TEST(scene_json_paths, TheOutputMustLieBeneathTheScenesFolder) {
    TempDir dir;
    const auto with_output = [&](const std::string& output) {
        return dir.write("scene/s.json",
                         json{{"camera", {{"position", {0, 0, -3}}, {"look_at", {0, 0, 0}}}},
                              {"objects", json::array()},
                              {"render", {{"output", output}}}}
                             .dump());
    };
    EXPECT_EQ(load_scene(with_output("renders/x.exr")).settings.output,
              dir.path() / "scene/renders/x.exr");
    for (const std::string& output :
         {std::string("../elsewhere/x.exr"), (dir.path() / "elsewhere/x.exr").string(),
          std::string("/tmp/x.exr")}) {
        SCOPED_TRACE(output);
        const std::string m = load_error(with_output(output));
        EXPECT_NE(m.find("s.json: render: 'output': '" + output + "' resolves to"),
                  std::string::npos)
            << m;
        EXPECT_NE(m.find("--out"), std::string::npos) << m;
        // (allowing inputs from elsewhere does not let a scene write there)
        LoadOptions allowed;
        allowed.allowed_paths = {"/"};
        EXPECT_NE(load_error(with_output(output), allowed).find("'output'"), std::string::npos);
    }
}

// A PNG's header claiming 16384² grey texels: 45 bytes that would cost 2 GiB decoded
std::string huge_png_header() {
    std::string png(
        "\x89PNG\r\n\x1a\n\x00\x00\x00\x0dIHDR\x00\x00\x40\x00\x00\x00\x40\x00"
        "\x08\x00\x00\x00\x00\x00\x00\x00\x00",
        33);
    return png + std::string("\x00\x00\x00\x00IEND\xae\x42\x60\x82", 12);
}

// The images a scene names are charged from their headers, before any is decoded, against
// the budget: ten 16384² PNGs, or one as the environment (with its sampling tables), are
// refused at once naming the files, the bytes and the option; within a budget raised by the
// user, the same scene goes on to decode them
TEST(scene_json_paths, ImagesAreChargedFromTheirHeadersAgainstTheBudget) {
    TempDir dir;
    json objects = json::array();
    for (int i = 0; i < 10; ++i) {
        const std::string name = "big" + std::to_string(i) + ".png";
        dir.write("scene/" + name, huge_png_header());
        objects.push_back({{"type", "sphere"},
                           {"center", {3 * i, 0, 0}},
                           {"radius", 1},
                           {"material", {{"kd", {{"texture", "image"}, {"file", name}}}}}});
    }
    const json camera = {{"position", {0, 0, -3}}, {"look_at", {0, 0, 0}}};
    const fs::path ten =
        dir.write("scene/ten.json", json{{"camera", camera}, {"objects", objects}}.dump());
    LoadOptions options;
    options.image_memory = uint64_t(4) << 30;
    const std::string m = load_error(ten, options);
    EXPECT_NE(m.find("ten.json: its 10 images would take 20 GiB of memory while decoded, over "
                     "the budget of 4 GiB"),
              std::string::npos)
        << m;
    EXPECT_NE(m.find("big0.png (2 GiB)"), std::string::npos) << m;
    EXPECT_NE(m.find("--image-memory"), std::string::npos) << m;
    // One as the environment: 2 GiB decoded and 7 GiB of tables
    const fs::path sky = dir.write(
        "scene/sky.json",
        json{{"camera", camera},
             {"objects", json::array()},
             {"environment", {{"emission", {{"texture", "image"}, {"file", "big0.png"}}}}}}
            .dump());
    const std::string e = load_error(sky, options);
    EXPECT_NE(e.find("big0.png (9 GiB as the environment, with its sampling tables)"),
              std::string::npos)
        << e;
    // Within a budget that holds them, the headers pass and decoding the lying file fails
    options.image_memory = uint64_t(64) << 30;
    const std::string decoded = load_error(sky, options);
    EXPECT_EQ(decoded.find("budget"), std::string::npos) << decoded;
    EXPECT_NE(decoded.find("big0.png"), std::string::npos) << decoded;
    // A real image against a tiny budget, and within the default one
    write_ldr(dir.path() / "scene/small.png", Image(64, 32));
    const fs::path small = dir.write(
        "scene/small.json",
        json{{"camera", camera},
             {"objects", json::array()},
             {"environment", {{"emission", {{"texture", "image"}, {"file", "small.png"}}}}}}
            .dump());
    options.image_memory = 1000;
    EXPECT_NE(load_error(small, options).find("over the budget of 1000 bytes"), std::string::npos);
    EXPECT_EQ(load_scene(small).images.size(), 1u);
}

TEST(scene_json_paths, SizesAreParsedAndPrinted) {
    EXPECT_EQ(parse_bytes("4G", "--x"), uint64_t(4) << 30);
    EXPECT_EQ(parse_bytes("512MiB", "--x"), uint64_t(512) << 20);
    EXPECT_EQ(parse_bytes("1.5g", "--x"), uint64_t(3) << 29);
    EXPECT_EQ(parse_bytes("1000", "--x"), 1000u);
    EXPECT_EQ(parse_bytes("2KB", "--x"), 2048u);
    for (const char* bad : {"", "G", "-1G", "4X", "nan", "inf", "2000T"}) {
        SCOPED_TRACE(bad);
        try {
            parse_bytes(bad, "--image-memory");
            ADD_FAILURE() << "accepted";
        } catch (const InputError& e) {
            EXPECT_NE(std::string(e.what()).find("--image-memory"), std::string::npos);
        }
    }
    EXPECT_EQ(format_bytes(uint64_t(4) << 30), "4 GiB");
    EXPECT_EQ(format_bytes(1536), "1.5 KiB");
    EXPECT_EQ(format_bytes(1000), "1000 bytes");
    EXPECT_GT(default_image_memory(), uint64_t(0));
    EXPECT_LE(default_image_memory(), uint64_t(4) << 30);
}

}  // namespace
}  // namespace cierzo
