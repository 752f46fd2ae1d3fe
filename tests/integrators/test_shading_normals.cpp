// Smooth meshes (interpolated shading normals, kernels/shading.h) in both integrators: the
// normals a scene gets (the file's through the transform, or area-weighted ones), agreement
// of the wavefront with the scalar reference on every lobe and estimator, convergence towards
// the analytic surface the mesh approximates, no light through the geometric surface, and
// no NaN, Inf or energy gain at the extremes (opposite and zero vertex normals, grazing
// rays, huge and tiny scales).
#include <gtest/gtest.h>

#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "core/error.h"
#include "integrators/render.h"
#include "integrators/wavefront/isa.h"
#include "scene/scene_json.h"
#include "support/render_variants.h"
#include "support/uv_sphere.h"
#include "support/report_scene.h"
#include "integrators/registry.h"

namespace cierzo {
namespace {

namespace fs = std::filesystem;

// A folder of its own for the mesh files a test writes; removed at the end.
class ShadingNormals : public ::testing::Test {
protected:
    fs::path dir;
    void SetUp() override {
        dir = fs::temp_directory_path() /
              ("cierzo_shading_" + std::to_string(::getpid()) + "_" +
               ::testing::UnitTest::GetInstance()->current_test_info()->name());
        fs::create_directories(dir);
    }
    void TearDown() override { fs::remove_all(dir); }

    // A UV sphere as an OBJ file, with its exact radial normals as "vn" lines, or without.
    fs::path sphere_obj(const std::string& name, int rings, int segments, bool normals) {
        const test::TriangleMesh m = test::uv_sphere(rings, segments);
        std::ofstream out(dir / name);
        for (const Vec3f& p : m.positions) out << "v " << p.x << " " << p.y << " " << p.z << "\n";
        if (normals)
            for (const Vec3f& p : m.positions) {
                const Vec3f n = normalize(p);
                out << "vn " << n.x << " " << n.y << " " << n.z << "\n";
            }
        for (size_t i = 0; i < m.indices.size(); i += 3) {
            out << "f";
            for (int k = 0; k < 3; ++k) {
                const uint32_t v = m.indices[i + size_t(k)] + 1;
                out << " " << v;
                if (normals) out << "//" << v;
            }
            out << "\n";
        }
        return dir / name;
    }
    Scene scene(const std::string& json) { return parse_scene(json, dir / "scene.json"); }
};

double image_mean(const Image& img) {
    double s = 0.0;
    for (const float v : img.rgb) s += double(v);
    return s / double(img.rgb.size());
}

bool all_finite(const Image& img) {
    for (const float v : img.rgb)
        if (!std::isfinite(v)) return false;
    return true;
}

TEST_F(ShadingNormals, SceneNormalsComeFromTheFileThroughTheTransformOrAreAreaWeighted) {
    sphere_obj("with.obj", 12, 24, true);
    sphere_obj("without.obj", 12, 24, false);
    // An ellipsoid x² + (y/2)² + (2z)² = 1 from the unit sphere: its normal is the gradient
    // (x, y/4, 4z), what the inverse transpose of the scale gives the file's normals
    for (const char* file : {"with.obj", "without.obj"}) {
        for (const char* instance : {"false", "true"}) {
            SCOPED_TRACE(std::string(file) + " instance " + instance);
            const Scene s = scene(
                R"({"camera": {"position": [0, 0, -5], "look_at": [0, 0, 0]}, "objects": [
                   {"type": "mesh", "file": ")" +
                std::string(file) + R"(", "smooth": true,
                    "scale": [1, -2, 0.5], "instance": )" +
                instance + R"(, "material": {"kd": 0.5}}]})");
            ASSERT_EQ(s.meshes.size(), 1u);
            EXPECT_TRUE(s.smooth_shading);
            const Mesh& object = s.meshes[0];
            const Mesh& g = s.geometry_of(object);
            ASSERT_EQ(g.normals.size(), g.positions.size());
            double worst = 1.0;
            for (size_t i = 0; i < g.positions.size(); ++i) {
                // The vertex and its normal in world space
                Vec3f p = g.positions[i], n = g.normals[i];
                if (object.instanced()) {
                    const float* a = object.to_world;
                    const float* b = object.normal_to_world;
                    p = {a[0] * p.x + a[1] * p.y + a[2] * p.z + a[3],
                         a[4] * p.x + a[5] * p.y + a[6] * p.z + a[7],
                         a[8] * p.x + a[9] * p.y + a[10] * p.z + a[11]};
                    n = normalize(Vec3f{b[0] * n.x + b[1] * n.y + b[2] * n.z,
                                        b[3] * n.x + b[4] * n.y + b[5] * n.z,
                                        b[6] * n.x + b[7] * n.y + b[8] * n.z});
                }
                const Vec3f expected = normalize(Vec3f{p.x, p.y / 4.0f, 4.0f * p.z});
                worst = std::min(worst, double(std::abs(dot(n, expected))));
            }
            // The file's normals are exact; area-weighted ones of a 12 × 24 sphere close
            EXPECT_GT(worst, std::string(file) == "with.obj" ? 0.9999 : 0.98);
        }
    }
    // A flat object keeps no normals; 'smooth' must be a boolean
    const Scene flat = scene(R"({"camera": {"position": [0, 0, -5], "look_at": [0, 0, 0]},
        "objects": [{"type": "mesh", "file": "with.obj", "material": {"kd": 0.5}}]})");
    EXPECT_TRUE(flat.meshes[0].normals.empty());
    EXPECT_FALSE(flat.smooth_shading);
    try {
        scene(R"({"camera": {"position": [0, 0, -5], "look_at": [0, 0, 0]}, "objects": [
            {"type": "mesh", "file": "with.obj", "smooth": 1, "material": {"kd": 0.5}}]})");
        ADD_FAILURE() << "\"smooth\": 1 was accepted";
    } catch (const InputError& e) {
        EXPECT_NE(std::string(e.what()).find("'smooth' must be true or false"), std::string::npos)
            << e.what();
    }
}

// Every lobe on smooth meshes (a copy, a mirrored instance), lit by a point light and a sampled
// emitter: the wavefront on each ISA agrees with the scalar reference as in test_agreement
// (image means within 0.3%, under 2% of the pixels off by 2% of the mean).
TEST_F(ShadingNormals, WavefrontAgreesWithScalarOnEveryLobeAndEstimator) {
    sphere_obj("ball.obj", 8, 14, true);
    sphere_obj("plain.obj", 8, 14, false);
    Scene s = scene(R"({"render": {"width": 48, "height": 36, "spp": 24},
        "camera": {"position": [0, 0.4, -5], "look_at": [0, 0, 0], "vfov": 45},
        "materials": {
          "diffuse": {"kd": [0.7, 0.5, 0.3]},
          "glossy": {"kd": 0.2, "ks": 0.6, "shininess": 30},
          "mirror": {"kr": 0.8},
          "glass": {"kt": 0.9, "ior": 1.5},
          "mixed": {"kd": 0.2, "ks": 0.2, "kr": 0.2, "kt": 0.3, "ior": 1.3, "shininess": 10}},
        "objects": [
          {"type": "plane", "normal": [0, 1, 0], "distance": 1, "material": {"kd": 0.5}},
          {"type": "sphere", "center": [0, 4, -1], "radius": 1, "material": {"emission": 3}},
          {"type": "mesh", "file": "ball.obj", "smooth": true, "scale": 0.6,
           "translate": [-1.6, 0, 0], "material": "diffuse"},
          {"type": "mesh", "file": "plain.obj", "smooth": true, "scale": 0.6,
           "translate": [-0.3, 0.2, 0], "material": "glossy"},
          {"type": "mesh", "file": "ball.obj", "smooth": true, "scale": [0.6, -0.6, 0.6],
           "instance": true, "translate": [0.9, 0, 0], "material": "mirror"},
          {"type": "mesh", "file": "ball.obj", "smooth": true, "scale": 0.5,
           "instance": true, "translate": [2.0, 0.3, 0.5], "material": "glass"},
          {"type": "mesh", "file": "ball.obj", "smooth": true, "scale": 0.4,
           "translate": [0, -0.6, -1.2], "material": "mixed"}],
        "lights": [{"position": [2, 3, -3], "intensity": 8}]})");
    for (Estimator e : {Estimator::kReport, Estimator::kNee, Estimator::kMis}) {
        test::set_estimator(s, e);
        const RenderResult reference = test::run(s, {"scalar", "auto"});
        const Image ref = reference.film.mean();
        ASSERT_TRUE(all_finite(ref));
        for (const test::Variant& v : test::variants()) {
            if (v.integrator == "scalar") continue;
            SCOPED_TRACE(v.isa + " " + estimator_name(e));
            const Image img = test::run(s, v).film.mean();
            ASSERT_TRUE(all_finite(img));
            for (int c = 0; c < 3; ++c) {
                double mw = 0, ms = 0;
                for (size_t i = size_t(c); i < img.rgb.size(); i += 3)
                    mw += img.rgb[i], ms += ref.rgb[i];
                EXPECT_LT(std::abs(mw - ms) / ms, 0.003) << "channel " << c;
                const double mean = ms / double(img.rgb.size() / 3);
                size_t off = 0;
                for (size_t i = size_t(c); i < img.rgb.size(); i += 3)
                    off += std::abs(double(img.rgb[i]) - double(ref.rgb[i])) > 0.02 * mean + 1e-9;
                EXPECT_LT(double(off) / double(img.rgb.size() / 3), 0.02) << "channel " << c;
            }
        }
    }
}

// A coarse sphere mesh against the analytic sphere it approximates, lit by a point light
// alone: smooth shading must be much closer to the analytic image than flat shading.
TEST_F(ShadingNormals, SmoothShadingConvergesTowardsTheAnalyticSurface) {
    sphere_obj("coarse.obj", 10, 20, true);
    const std::string head = R"({"render": {"width": 64, "height": 64, "spp": 16},
        "camera": {"position": [0, 0, -4], "look_at": [0, 0, 0], "vfov": 32},
        "lights": [{"position": [-3, 3, -4], "intensity": 20}], "objects": [)";
    const std::string material = R"("material": {"kd": 0.6, "ks": 0.3, "shininess": 20}})";
    for (const test::Variant& v : test::variants()) {
        SCOPED_TRACE(v.integrator + " " + v.isa);
        const Image exact = test::run(scene(head + R"({"type": "sphere", "center": [0, 0, 0],
            "radius": 1, )" + material + "]}"),
                                      v)
                                .film.mean();
        double error[2] = {0, 0};
        for (int smooth = 0; smooth < 2; ++smooth) {
            const Image img = test::run(scene(head + R"({"type": "mesh", "file": "coarse.obj",
                "smooth": )" + std::string(smooth ? "true" : "false") +
                                              ", " + material + "]}"),
                                        v)
                                  .film.mean();
            for (size_t i = 0; i < img.rgb.size(); ++i)
                error[smooth] += std::abs(double(img.rgb[i]) - double(exact.rgb[i]));
        }
        EXPECT_LT(error[1], 0.5 * error[0]) << "flat " << error[0] << ", smooth " << error[1];
    }
}

// A floor triangle whose vertex normals lean 80° from its geometric normal, seen from above
// with nothing above it; the only light is an emitter below the floor. A reflection about the
// shading normal may point below the floor: it must not count (the geometric surface is in
// the way of the light), so the triangle's pixels stay exactly black. Flat, they are black too.
TEST_F(ShadingNormals, NoLightComesThroughTheGeometricSurface) {
    {
        std::ofstream out(dir / "leaning.obj");
        const float s = std::sin(80.0f * 3.14159265f / 180.0f),
                    c = std::cos(80.0f * 3.14159265f / 180.0f);
        out << "v -1 0 -1\nv 1 0 -1\nv 0 0 1.5\n";
        out << "vn " << s << " " << c << " 0\nvn " << -s << " " << c << " 0\nvn 0 " << c << " " << s
            << "\n";
        out << "f 1//1 3//3 2//2\n";
    }
    for (const char* material :
         {R"({"kd": 0.9})", R"({"kr": 0.9})", R"({"ks": 0.9, "shininess": 5})",
          R"({"kd": 0.3, "ks": 0.3, "kr": 0.3, "shininess": 2})"}) {
        Scene s = scene(R"({"render": {"width": 24, "height": 24, "spp": 32},
            "camera": {"position": [0, 3, 0], "look_at": [0, 0, 0], "up": [0, 0, 1], "vfov": 30},
            "objects": [
              {"type": "mesh", "file": "leaning.obj", "smooth": true, "material": )" +
                        std::string(material) + R"(},
              {"type": "sphere", "center": [0, -30, 0], "radius": 25, "material": {"emission": 5}}],
            "lights": [{"position": [0, -2, 3], "intensity": 50}]})");
        for (Estimator e : {Estimator::kReport, Estimator::kMis}) {
            test::set_estimator(s, e);
            for (const test::Variant& v : test::variants()) {
                SCOPED_TRACE(std::string(material) + " " + v.integrator + " " + v.isa + " " +
                             estimator_name(e));
                const Image img = test::run(s, v).film.mean();
                // The image's centre lies on the triangle
                double centre = 0.0;
                for (int y = 8; y < 16; ++y)
                    for (int x = 8; x < 16; ++x)
                        for (int k = 0; k < 3; ++k)
                            centre += img.rgb[(size_t(y) * 24 + size_t(x)) * 3 + size_t(k)];
                EXPECT_EQ(centre, 0.0);
            }
        }
    }
}

// Vertex normals that oppose each other, vanish, or are huge: finite images; a white
// furnace (a smooth sphere of kd 0.8 inside an emitter of Le 1) gains no energy; and the same
// scene at scales 1e-4 and 1e4, far from the origin, gives the same image mean.
TEST_F(ShadingNormals, ExtremesStayFiniteAndGainNoEnergy) {
    {
        // An octahedron whose normals point every way, one of them zero
        std::ofstream out(dir / "wild.obj");
        out << "v 1 0 0\nv -1 0 0\nv 0 1 0\nv 0 -1 0\nv 0 0 1\nv 0 0 -1\n";
        out << "vn 1 0 0\nvn 1 0 0\nvn 0 -1 0\nvn 0 0 0\nvn 1e30 1e30 0\nvn -1 -1 -1\n";
        for (const char* f :
             {"1 3 5", "3 2 5", "2 4 5", "4 1 5", "3 1 6", "2 3 6", "4 2 6", "1 4 6"}) {
            out << "f";
            for (const char* p = f; *p; ++p)
                if (*p != ' ') out << " " << *p << "//" << *p;
            out << "\n";
        }
    }
    sphere_obj("ball.obj", 10, 20, true);
    const std::string camera =
        R"("camera": {"position": [0, 0.05, -3], "look_at": [0, 0, 0], "vfov": 50})";
    Scene wild = scene(R"({"render": {"width": 32, "height": 32, "spp": 16}, )" + camera + R"(,
        "objects": [
          {"type": "mesh", "file": "wild.obj", "smooth": true,
           "material": {"kd": 0.3, "ks": 0.3, "kr": 0.1, "kt": 0.2, "shininess": 10000, "ior": 1.5}},
          {"type": "plane", "normal": [0, 1, 0], "distance": 1, "material": {"kd": 0.5}},
          {"type": "sphere", "center": [0, 4, 0], "radius": 1, "material": {"emission": 1e6}}],
        "lights": [{"position": [0, 0, -2], "intensity": 1e6}]})");
    for (Estimator e : {Estimator::kReport, Estimator::kMis}) {
        test::set_estimator(wild, e);
        for (const test::Variant& v : test::variants()) {
            SCOPED_TRACE(v.integrator + " " + v.isa);
            const RenderResult r = test::run(wild, v);
            EXPECT_TRUE(all_finite(r.film.mean()));
            EXPECT_GT(image_mean(r.film.mean()), 0.0);
        }
    }
    // The furnace: every path that leaves the sphere reaches the emitter, so a pixel's
    // expected value is kd·Le = 0.8 where smooth shading loses nothing, and less where it does
    Scene furnace = scene(R"({"render": {"width": 16, "height": 16, "spp": 64}, )" + camera + R"(,
        "objects": [{"type": "mesh", "file": "ball.obj", "smooth": true, "scale": 0.8,
                     "material": {"kd": 0.8}},
                    {"type": "sphere", "center": [0, 0, 0], "radius": 10, "material": {"emission": 1}}]})");
    for (const test::Variant& v : test::variants()) {
        SCOPED_TRACE(v.integrator + " " + v.isa);
        const Image img = test::run(furnace, v).film.mean();
        // the centre 6 × 6 pixels are on the sphere
        double sum = 0.0;
        for (int y = 5; y < 11; ++y)
            for (int x = 5; x < 11; ++x) sum += img.rgb[(size_t(y) * 16 + size_t(x)) * 3];
        const double mean = sum / 36.0;
        // (2304 paths, each at most 2 · 0.8 / 0.8 · 1 = 2: the mean's σ is below 0.02)
        EXPECT_LT(mean, 0.8 + 0.06);
        EXPECT_GT(mean, 0.6);
    }
    // Scales: the unit scene, then tiny and huge far from the origin
    double means[3];
    const char* transforms[3] = {R"("scale": 1)",
                                 R"("scale": 1e-4, "translate": [0.01, -0.01, 0.01])",
                                 R"("scale": 1e4, "translate": [1e5, 1e5, -1e5])"};
    for (int k = 0; k < 3; ++k) {
        const double scale = k == 0 ? 1.0 : k == 1 ? 1e-4 : 1e4;
        const double tx = k == 0   ? 0
                          : k == 1 ? 0.01
                                   : 1e5,
                     ty = k == 0   ? 0
                          : k == 1 ? -0.01
                                   : 1e5,
                     tz = k == 0   ? 0
                          : k == 1 ? 0.01
                                   : -1e5;
        char cam[512];
        std::snprintf(
            cam, sizeof cam,
            R"("camera": {"position": [%.9g, %.9g, %.9g], "look_at": [%.9g, %.9g, %.9g], "vfov": 40})",
            tx, ty + 0.5 * scale, tz - 3 * scale, tx, ty, tz);
        char light[256];
        std::snprintf(light, sizeof light,
                      R"("lights": [{"position": [%.9g, %.9g, %.9g], "intensity": %.9g}])",
                      tx - 2 * scale, ty + 2 * scale, tz - 2 * scale, 10 * scale * scale);
        const Scene sc =
            scene(R"({"render": {"width": 32, "height": 32, "spp": 8}, )" + std::string(cam) +
                  R"(, "objects": [{"type": "mesh", "file": "ball.obj", "smooth": true, )" +
                  transforms[k] + R"(, "material": {"kd": 0.5, "ks": 0.4, "shininess": 30}}], )" +
                  light + "}");
        const Image img = test::run(sc, {"scalar", "auto"}).film.mean();
        ASSERT_TRUE(all_finite(img));
        means[k] = image_mean(img);
    }
    EXPECT_NEAR(means[1], means[0], 0.02 * means[0]);
    EXPECT_NEAR(means[2], means[0], 0.02 * means[0]);
}

}  // namespace
}  // namespace cierzo
