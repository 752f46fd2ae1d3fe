// Numerical extremes through both integrators and every ISA: a diffuse sphere inside a
// uniform emitter at scales from 1e-4 to 1e6 and far from the origin (no acne: no pixel
// darker than the analytic 0.8 allows; the same image at every scale); an ior-1 sphere
// that must vanish; total internal reflection; Phong s = 0 and 1e4; emitters of 1e6;
// albedo 1; a point light on a surface; degenerate primitives; a forced NaN sample, which
// must be counted and kept out of the image; and, with exact or analytic answers:
//   - grazing rays: a camera exactly in the plane of a floor (every sample exactly the
//     emission), 1e-7 above it, and looking at it at 89.99° and 89.9999° incidence (the
//     walls exactly E, the floor its analytic ρE within statistical error);
//   - a camera inside a refracting sphere in a uniform emitter: the image is kt without
//     total internal reflection; with it, kt times the escaping fraction of the camera's
//     rays (worked out from the camera), and trapped pixels exactly 0;
//   - emission and point-light intensity from 1e-6 to 1e6: the same image scaled linearly;
//   - albedo 0: a black box shows exactly the direct view of its emitter;
//   - ior 3.5 (and 0.3) spheres of kt = 1 in a uniform emitter: image mean 1;
//   - a closed, watertight absorbing triangle mesh around the camera and in front of it,
//     with rays aimed within float precision of its vertices and edges: every pixel 0.
//   - hundreds of mirror or total-internal reflections inside a closed sphere stay inside.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <string>
#include <vector>

#include "integrators/render.h"
#include "integrators/wavefront/isa.h"
#include "scene/camera.h"
#include "scene/scene_json.h"
#include "support/render_variants.h"
#include "support/report_scene.h"
#include "support/uv_sphere.h"

namespace cierzo {
namespace {

using test::run;
using test::Variant;
using test::variants;

// Mean of a channel over the image, and whether every pixel is finite.
double image_mean(const Film& film, int c, bool* finite = nullptr) {
    const Image img = film.mean();
    double sum = 0;
    for (size_t i = size_t(c); i < img.rgb.size(); i += 3) {
        if (finite && !std::isfinite(img.rgb[i])) *finite = false;
        sum += img.rgb[i];
    }
    return sum / double(img.rgb.size() / 3);
}

std::string sphere_in_emitter(double x, double y, double z, double r) {
    auto v = [](double a, double b, double c) {
        char buf[160];
        std::snprintf(buf, sizeof buf, "[%.9g, %.9g, %.9g]", a, b, c);
        return std::string(buf);
    };
    char radius[40], big[40];
    std::snprintf(radius, sizeof radius, "%.9g", r);
    std::snprintf(big, sizeof big, "%.9g", 10 * r);
    return R"({"render": {"width": 24, "height": 24, "spp": 64},
        "camera": {"position": )" +
           v(x, y, z - 3 * r) + R"(, "look_at": )" + v(x, y, z) +
           R"(, "vfov": 60},
        "materials": {"w": {"kd": 0.8}, "L": {"emission": 1}},
        "objects": [{"type": "sphere", "center": )" +
           v(x, y, z) + R"(, "radius": )" + radius +
           R"(, "material": "w"},
                    {"type": "sphere", "center": )" +
           v(x, y, z) + R"(, "radius": )" + big + R"(, "material": "L"}]})";
}

TEST(Extremes, NoAcneAndTheSameImageAtEveryScale) {
    // A diffuse sphere (0.8) inside a uniform emitter (1): each path that leaves the sphere
    // meets the emitter, so a sphere pixel is 0.8 in expectation and nothing is darker
    for (const Variant& v : variants()) {
        SCOPED_TRACE(std::string(v.integrator) + " " + v.isa);
        const RenderResult unit =
            run(test::parse_report_scene(sphere_in_emitter(0, 0, 0, 1), "/tmp/e.json"), v);
        const double reference = image_mean(unit.film, 0);
        for (auto [x, r] : {std::pair{0.0, 1e-4}, {0.0, 1e6}, {1e4, 1.0}, {-3e3, 1e-1}}) {
            SCOPED_TRACE(testing::Message() << "offset " << x << " radius " << r);
            const Scene scene =
                test::parse_report_scene(sphere_in_emitter(x, x, x, r), "/tmp/e.json");
            const RenderResult res = run(scene, v);
            bool finite = true;
            EXPECT_NEAR(image_mean(res.film, 0, &finite), reference, 1e-3 * reference);
            EXPECT_TRUE(finite);
            // Acne: the fraction of pixels darker than 0.8 by more than 5 standard errors
            const Image mean = res.film.mean(), var = res.film.variance_of_mean();
            size_t dark = 0;
            for (size_t i = 0; i < mean.rgb.size(); i += 3)
                dark += mean.rgb[i] < 0.8 - 5.0 * std::sqrt(var.rgb[i]) - 1e-6;
            EXPECT_EQ(dark, 0u);
        }
    }
}

const char* kBox = R"(
    {"type": "plane", "normal": [1, 0, 0], "distance": 1, "material": "w"},
    {"type": "plane", "normal": [-1, 0, 0], "distance": 1, "material": "w"},
    {"type": "plane", "normal": [0, 1, 0], "distance": 1, "material": "w"},
    {"type": "plane", "normal": [0, -1, 0], "distance": 1, "material": "L"},
    {"type": "plane", "normal": [0, 0, -1], "distance": 1, "material": "w"},
    {"type": "plane", "normal": [0, 0, 1], "distance": 4, "material": "w"})";

std::string box_scene(const std::string& extra_materials, const std::string& extra_objects,
                      int spp = 32, const std::string& lights = "[]") {
    return R"({"render": {"width": 24, "height": 24, "spp": )" + std::to_string(spp) + R"(},
        "camera": {"position": [0, 0, -3], "look_at": [0, 0, 0], "vfov": 60},
        "materials": {"w": {"kd": 0.8}, "L": {"emission": 1})" +
           extra_materials + R"(},
        "objects": [)" +
           kBox + extra_objects + R"(], "lights": )" + lights + "}";
}

TEST(Extremes, AnIorOneSphereVanishes) {
    for (const Variant& v : variants()) {
        SCOPED_TRACE(std::string(v.integrator) + " " + v.isa);
        const RenderResult empty =
            run(test::parse_report_scene(box_scene("", "", 512), "/tmp/e.json"), v);
        const RenderResult glass =
            run(test::parse_report_scene(
                    box_scene(R"(, "g": {"kt": 1, "ior": 1})",
                              R"(, {"type": "sphere", "center": [0, 0, 0], "radius": 0.5,
                                        "material": "g"})",
                              512),
                    "/tmp/e.json"),
                v);
        // Standard error of the image mean from the per-pixel variances
        const Image var = empty.film.variance_of_mean();
        double v_sum = 0;
        for (size_t i = 0; i < var.rgb.size(); i += 3) v_sum += var.rgb[i];
        const double se = std::sqrt(v_sum) / double(var.rgb.size() / 3);
        EXPECT_NEAR(image_mean(glass.film, 0), image_mean(empty.film, 0),
                    5.0 * se * std::sqrt(2.0));
    }
}

TEST(Extremes, HardMaterialsAndLightsStayFinite) {
    const std::string cases[] = {
        // Camera inside a refracting sphere of index 3: total internal reflection
        box_scene(R"(, "g": {"kt": 0.9, "ior": 3})",
                  R"(, {"type": "sphere", "center": [0, 0, -3], "radius": 0.5, "material": "g"})"),
        // Phong s = 0 and s = 1e4, an emitter of 1e6
        box_scene(R"(, "p": {"ks": 0.9, "shininess": 10000}, "q": {"ks": 0.9, "shininess": 0},
                     "hot": {"emission": 1e6})",
                  R"(, {"type": "sphere", "center": [-0.5, 0, 0], "radius": 0.4, "material": "p"},
                     {"type": "sphere", "center": [0.5, 0, 0], "radius": 0.4, "material": "q"},
                     {"type": "sphere", "center": [0, 0.8, 0], "radius": 0.05, "material": "hot"})"),
        // Albedo 1 everywhere, a point light on the floor and one of 1e6
        box_scene(
            R"(, "one": {"kd": 1})",
            R"(, {"type": "sphere", "center": [0, -0.5, 0], "radius": 0.4, "material": "one"})", 32,
            R"([{"position": [0, -1, 0], "intensity": 1},
                         {"position": [0.2, 0.3, 0.1], "intensity": 1e6}])"),
        // Degenerate triangles and a nearly empty quadric; a black absorber
        box_scene(
            R"(, "black": {"kd": 0})",
            R"(, {"type": "triangle", "vertices": [[0, 0, 0], [0, 0, 0], [1, 1, 1]], "material": "w"},
                     {"type": "triangle", "vertices": [[0, 0, 0], [0.5, 0.5, 0.5], [1, 1, 1]], "material": "w"},
                     {"type": "quadric", "coefficients": [0, 0, 0, 0, 0, 0, 0, 0, 1e-30, 0], "material": "w"},
                     {"type": "sphere", "center": [0, 0, 0.5], "radius": 0.3, "material": "black"})")};
    for (const std::string& text : cases) {
        const Scene scene = test::parse_report_scene(text, "/tmp/e.json");
        for (const Variant& v : variants()) {
            SCOPED_TRACE(std::string(v.integrator) + " " + v.isa);
            const RenderResult r = run(scene, v);
            EXPECT_EQ(r.stats.nonfinite_samples, 0u);
            bool finite = true;
            for (int c = 0; c < 3; ++c) image_mean(r.film, c, &finite);
            EXPECT_TRUE(finite);
        }
    }
}

TEST(Extremes, ANonFiniteSampleIsCountedAndKeptOutOfTheImage) {
    // A NaN emission (not expressible in a scene file) on the ceiling: every path that
    // reaches it yields a NaN sample, which the film must count and exclude
    Scene scene = test::parse_report_scene(box_scene("", "", 8), "/tmp/e.json");
    for (Material& m : scene.materials)
        if (m.is_emitter()) m.emission.a.y = std::nanf("");
    scene.finalize();  // (the tables built from the materials)
    for (const Variant& v : variants()) {
        SCOPED_TRACE(std::string(v.integrator) + " " + v.isa);
        const RenderResult r = run(scene, v);
        EXPECT_GT(r.stats.nonfinite_samples, 0u);
        EXPECT_LT(r.stats.nonfinite_samples, r.stats.paths);
        bool finite = true;
        for (int c = 0; c < 3; ++c) image_mean(r.film, c, &finite);
        EXPECT_TRUE(finite);
    }
}

// ---- Helpers for the exact and analytic cases ---------------------------------------

// Mean and standard error over every sample of the pixels `keep` selects, in one channel.
struct SampleMean {
    double mean = 0, se = 0;
    uint64_t n = 0;
};
SampleMean sample_mean(const Film& film, const std::function<bool(int, int)>& keep, int c = 0) {
    double sum = 0, sum_sq = 0;
    uint64_t n = 0;
    for (int y = 0; y < film.height(); ++y)
        for (int x = 0; x < film.width(); ++x) {
            if (!keep(x, y)) continue;
            const PixelSums& p = film.at(x, y);
            sum += p.sum[c], sum_sq += p.sum_sq[c], n += p.count;
        }
    SampleMean m;
    m.n = n;
    if (n < 2) return m;
    m.mean = sum / double(n);
    m.se = std::sqrt(std::max(sum_sq / double(n) - m.mean * m.mean, 0.0) / double(n - 1));
    return m;
}
bool every_pixel(int, int) { return true; }

// Whether every sample of the pixel was exactly 0 or exactly `value` (sums of such samples
// are exact in double), in every channel.
bool samples_are_zero_or(const PixelSums& p, double value) {
    for (int c = 0; c < 3; ++c) {
        const double k = p.sum[c] / value;
        if (k != std::floor(k) || k < 0 || k > double(p.count)) return false;
        if (p.sum_sq[c] != p.sum[c] * value) return false;
    }
    return true;
}

std::string vec(double a, double b, double c) {
    char buf[100];
    std::snprintf(buf, sizeof buf, "[%.9g, %.9g, %.9g]", a, b, c);
    return buf;
}

// ---- Grazing rays and rays parallel to a plane ----------------------------------------

// A diffuse floor y = 0 (kd 0.8) in a box |x| < w, y < w, |z| < far whose other five walls
// all emit 1: from the floor every direction upwards meets an emitter, so a floor point's
// radiance is exactly 0.8, and a sample that meets a wall directly is exactly 1. (Cosine
// sampling: a floor sample is then 0 or kd/P = 1.)
std::string floor_box(const std::string& camera, int size, int spp, double half_width, double far) {
    char walls[900];
    std::snprintf(walls, sizeof walls, R"(
        {"type": "plane", "normal": [1, 0, 0], "distance": %.9g, "material": "L"},
        {"type": "plane", "normal": [-1, 0, 0], "distance": %.9g, "material": "L"},
        {"type": "plane", "normal": [0, -1, 0], "distance": %.9g, "material": "L"},
        {"type": "plane", "normal": [0, 0, -1], "distance": %.9g, "material": "L"},
        {"type": "plane", "normal": [0, 0, 1], "distance": %.9g, "material": "L"},
        {"type": "plane", "normal": [0, 1, 0], "distance": 0, "material": "floor"})",
                  half_width, half_width, half_width, far, far);
    return R"({"render": {"width": )" + std::to_string(size) + R"(, "height": )" +
           std::to_string(size) + R"(, "spp": )" + std::to_string(spp) +
           R"(, "seed": 9, "diffuse_sampling": "cosine"},
        "camera": )" +
           camera + R"(,
        "materials": {"floor": {"kd": 0.8}, "L": {"emission": 1}},
        "objects": [)" +
           walls + "]}";
}

TEST(Extremes, ACameraInThePlaneOfAFloorSeesOnlyTheEmitters) {
    // Exactly in the plane y = 0, looking along it: rays going down start on the floor
    // (t = 0, not a hit) and rays along it are parallel (t = NaN, not a hit), so every
    // ray meets an emitting wall and every sample is exactly 1
    const Scene scene = test::parse_report_scene(
        floor_box(R"({"position": [0, 0, -3], "look_at": [0, 0, 0], "vfov": 60})", 24, 8, 2, 4),
        "/tmp/e.json");
    for (const Variant& v : variants()) {
        SCOPED_TRACE(std::string(v.integrator) + " " + v.isa);
        const RenderResult r = run(scene, v);
        EXPECT_EQ(r.stats.nonfinite_samples, 0u);
        for (int y = 0; y < 24; ++y)
            for (int x = 0; x < 24; ++x) {
                const PixelSums& p = r.film.at(x, y);
                ASSERT_EQ(p.count, 8u);
                ASSERT_EQ(p.sum[0], 8.0) << "pixel " << x << ", " << y;
                ASSERT_EQ(p.sum_sq[0], 8.0) << "pixel " << x << ", " << y;
            }
    }
}

TEST(Extremes, ACameraJustAboveAFloorSeesItAtGrazingAngles) {
    // 1e-7 above the floor: the top half of the image is the walls (every sample exactly
    // 1), the bottom half the floor down to incidence angles of 90° - 1e-6° (0.8, each
    // sample 0 or 1); the row next to the horizon is the most grazing
    const int size = 24, spp = 64;
    const Scene scene = test::parse_report_scene(
        floor_box(R"({"position": [0, 1e-7, -3], "look_at": [0, 1e-7, 0], "vfov": 60})", size, spp,
                  2, 4),
        "/tmp/e.json");
    for (const Variant& v : variants()) {
        SCOPED_TRACE(std::string(v.integrator) + " " + v.isa);
        const RenderResult r = run(scene, v);
        EXPECT_EQ(r.stats.nonfinite_samples, 0u);
        for (int y = 0; y < size; ++y)
            for (int x = 0; x < size; ++x) {
                const PixelSums& p = r.film.at(x, y);
                if (y < size / 2) {
                    ASSERT_EQ(p.sum[0], double(spp)) << "pixel " << x << ", " << y;
                    ASSERT_EQ(p.sum_sq[0], double(spp)) << "pixel " << x << ", " << y;
                }
                ASSERT_LE(p.sum[0], double(spp) * (1 + 1e-6)) << "pixel " << x << ", " << y;
            }
        const SampleMean floor = sample_mean(r.film, [&](int, int y) { return y >= size / 2; });
        EXPECT_NEAR(floor.mean, 0.8, 4 * floor.se);
        EXPECT_LT(floor.se, 0.01);
        const SampleMean horizon = sample_mean(r.film, [&](int, int y) { return y == size / 2; });
        EXPECT_NEAR(horizon.mean, 0.8, 5 * horizon.se);
    }
}

TEST(Extremes, AFloorSeenAt89Point99DegreesHasItsAnalyticValue) {
    // The camera h above the floor looks down at elevation e = 0.01° (incidence 89.99°)
    // and 1e-4° (89.9999°) with a field of view of e/2: every ray meets the floor between
    // 0.8 d and 1.34 d away (d = h / tan e), well inside the box of half-width 4 d, so
    // every pixel is 0.8
    for (double elevation : {0.01, 1e-4}) {
        const double h = 0.01;
        const double d = h / std::tan(elevation * kPi / 180);
        char vfov[40];
        std::snprintf(vfov, sizeof vfov, "%.9g", elevation / 2);
        const std::string camera = R"({"position": )" + vec(0, h, 0) + R"(, "look_at": )" +
                                   vec(0, 0, d) + R"(, "vfov": )" + vfov + "}";
        const Scene scene =
            test::parse_report_scene(floor_box(camera, 16, 64, 4 * d, 4 * d), "/tmp/e.json");
        for (const Variant& v : variants()) {
            SCOPED_TRACE(testing::Message()
                         << v.integrator << " " << v.isa << ", elevation " << elevation << "°");
            const RenderResult r = run(scene, v);
            EXPECT_EQ(r.stats.nonfinite_samples, 0u);
            for (int y = 0; y < 16; ++y)
                for (int x = 0; x < 16; ++x)
                    ASSERT_LE(r.film.at(x, y).sum[0], 64 * (1 + 1e-6))
                        << "pixel " << x << ", " << y;
            const SampleMean m = sample_mean(r.film, every_pixel);
            EXPECT_NEAR(m.mean, 0.8, 4 * m.se);
            EXPECT_LT(m.se, 0.01);
        }
    }
}

// ---- Refraction: energy through Snell's law and total internal reflection ------------

// A sphere of radius 1 at the origin made of `material` inside an emitting sphere of
// radius 10 (emission 1), seen by the given camera.
std::string sphere_in_emitter(const std::string& material, const std::string& camera, int size,
                              int spp, double survival_cap = 0.9) {
    char cap[40];
    std::snprintf(cap, sizeof cap, "%.9g", survival_cap);
    return R"({"render": {"width": )" + std::to_string(size) + R"(, "height": )" +
           std::to_string(size) + R"(, "spp": )" + std::to_string(spp) +
           R"(, "seed": 4, "survival_cap": )" + cap + R"(},
        "camera": )" +
           camera + R"(, "materials": {"glass": )" + material +
           R"(, "L": {"emission": 1}},
        "objects": [{"type": "sphere", "center": [0, 0, 0], "radius": 1, "material": "glass"},
                    {"type": "sphere", "center": [0, 0, 0], "radius": 10, "material": "L"}]})";
}

// The same with a refracting sphere.
std::string glass_in_emitter(double kt, double ior, const std::string& camera, int size, int spp,
                             double survival_cap = 0.9) {
    char material[100];
    std::snprintf(material, sizeof material, R"({"kt": %.9g, "ior": %.9g})", kt, ior);
    return sphere_in_emitter(material, camera, size, spp, survival_cap);
}

// The camera 0.9 from the centre of the sphere, looking half outwards. Seen from there, a
// ray whose impact parameter b = |o × d| exceeds 1/ior meets the surface of a sphere of that
// ior beyond the critical angle, and in a sphere it keeps meeting it at that angle: it is
// trapped. Per pixel of a size² image: the fraction of its area whose rays escape (b ≤ 1/ior,
// on a 32 × 32 grid) and whether all of it is trapped with a margin of 0.01 in b.
const char* kOffCentreCamera = R"({"position": [0.9, 0, 0], "look_at": [1.9, 0, 1], "vfov": 90})";
struct Escaping {
    std::vector<double> fraction;
    std::vector<char> trapped;
    double mean = 0;
};
Escaping escaping_rays(const Scene& scene, int size, float ior) {
    const int grid = 32;
    const Vec3f o = scene.camera.origin;
    Escaping e;
    for (int y = 0; y < size; ++y)
        for (int x = 0; x < size; ++x) {
            int escape = 0;
            float least_b = 2.0f;
            for (int j = 0; j <= grid; ++j)
                for (int i = 0; i <= grid; ++i) {
                    const float sx = float(x) + float(i) / grid, sy = float(y) + float(j) / grid;
                    const Ray<float> ray =
                        scene.camera.generate(sx, sy, 1.0f / float(size), 1.0f / float(size));
                    const float b = length(cross(o, ray.d));
                    least_b = std::min(least_b, b);
                    if (i < grid && j < grid) escape += b <= 1.0f / ior;
                }
            e.fraction.push_back(double(escape) / (grid * grid));
            e.trapped.push_back(least_b > 1.0f / ior + 0.01f);
            e.mean += e.fraction.back() / (size * size);
        }
    return e;
}

TEST(Extremes, InsideARefractingSphereTheImageIsKtWithoutTotalInternalReflection) {
    // The camera 0.374 from the centre of a sphere of ior 1.5: every ray leaves at an
    // impact parameter below 1/1.5, so it refracts out once and meets the emitter. The
    // roulette keeps it with P = min(kt, 0.9) and weights it kt/P: the image is kt
    const std::string camera = R"({"position": [0.3, 0.2, 0.1], "look_at": [1, 1, 1], "vfov": 90})";
    for (double kt : {1.0, 0.6}) {
        const Scene scene =
            test::parse_report_scene(glass_in_emitter(kt, 1.5, camera, 24, 32), "/tmp/e.json");
        for (const Variant& v : variants()) {
            SCOPED_TRACE(testing::Message() << v.integrator << " " << v.isa << ", kt " << kt);
            const RenderResult r = run(scene, v);
            EXPECT_EQ(r.stats.nonfinite_samples, 0u);
            const SampleMean m = sample_mean(r.film, every_pixel);
            EXPECT_NEAR(m.mean, kt, 4 * m.se);
            EXPECT_LT(m.se, 0.005);
        }
    }
}

TEST(Extremes, TotalInternalReflectionInsideASphereNeitherLeaksNorGains) {
    // A sphere of ior 1.5 around the off-centre camera: trapped rays must carry nothing
    // (exactly 0), the others refract out once (kt in expectation), so the image mean is kt
    // times the escaping fraction of the camera's rays. survival_cap 0.5 keeps the chains of
    // reflections short (HundredsOfReflectionsStayInsideAClosedSphere tests long ones).
    const int size = 24, spp = 32;
    for (double kt : {1.0, 0.6}) {
        const Scene scene = test::parse_report_scene(
            glass_in_emitter(kt, 1.5, kOffCentreCamera, size, spp, 0.5), "/tmp/e.json");
        const Escaping escaping = escaping_rays(scene, size, 1.5f);
        size_t trapped_pixels = 0;
        for (char t : escaping.trapped) trapped_pixels += t;
        ASSERT_GT(trapped_pixels, size_t(size * size / 4));
        ASSERT_GT(escaping.mean, 0.2);
        for (const Variant& v : variants()) {
            SCOPED_TRACE(testing::Message() << v.integrator << " " << v.isa << ", kt " << kt);
            const RenderResult r = run(scene, v);
            EXPECT_EQ(r.stats.nonfinite_samples, 0u);
            for (int y = 0; y < size; ++y)
                for (int x = 0; x < size; ++x)
                    if (escaping.trapped[size_t(y * size + x)]) {
                        ASSERT_EQ(r.film.at(x, y).sum[0], 0.0) << "pixel " << x << ", " << y;
                    }
            const SampleMean m = sample_mean(r.film, every_pixel);
            EXPECT_NEAR(m.mean, kt * escaping.mean, 4 * m.se + 1e-3);
            const SampleMean out = sample_mean(r.film, [&](int x, int y) {
                return escaping.fraction[size_t(y * size + x)] == 1.0;
            });
            EXPECT_NEAR(out.mean, kt, 4 * out.se);
        }
    }
}

// A reflected direction d - 2(d·n)n keeps |d| = 1 only to rounding; unless it is
// renormalised its length grows by about an ulp per bounce, the sphere test (which assumes
// |d| = 1) drifts, and after ~60 bounces a ray trapped inside a closed mirror sphere, or by
// total internal reflection, escapes through the surface carrying (1/P)^60 of throughput
// (without the renormalisation, 44 of 2048 such paths leak at survival_cap 0.99).
TEST(Extremes, HundredsOfReflectionsStayInsideAClosedSphere) {
    const int size = 16, spp = 32;
    // A closed mirror sphere around the camera: no light can reach it
    const Scene mirror = test::parse_report_scene(
        sphere_in_emitter(R"({"kr": 1})", kOffCentreCamera, size, spp, 0.99), "/tmp/e.json");
    // Trapped rays in a sphere of ior 1.5
    const Scene glass = test::parse_report_scene(
        glass_in_emitter(1.0, 1.5, kOffCentreCamera, size, spp, 0.99), "/tmp/e.json");
    const Escaping escaping = escaping_rays(glass, size, 1.5f);
    for (const Variant& v : variants()) {
        SCOPED_TRACE(std::string(v.integrator) + " " + v.isa);
        const RenderResult in_mirror = run(mirror, v);
        const RenderResult in_glass = run(glass, v);
        for (int y = 0; y < size; ++y)
            for (int x = 0; x < size; ++x) {
                EXPECT_EQ(in_mirror.film.at(x, y).sum[0], 0.0)
                    << "mirror, pixel " << x << ", " << y;
                if (escaping.trapped[size_t(y * size + x)]) {
                    EXPECT_EQ(in_glass.film.at(x, y).sum[0], 0.0)
                        << "glass, pixel " << x << ", " << y;
                }
            }
    }
}

TEST(Extremes, HighIorSpheresInAUniformEmitterNeitherGainNorLoseEnergy) {
    // kt = 1: every ray that enters a sphere leaves it (from outside the internal angle is
    // below the critical one), so the image is the emitter's 1 everywhere in expectation.
    // ior 3.5 from outside and from inside (0.2 from the centre: no total internal
    // reflection below an impact parameter of 1/3.5), and ior 0.3, where rays are totally
    // reflected on the way in
    const std::string outside = R"({"position": [0, 0, -3], "look_at": [0, 0, 0], "vfov": 50})";
    const std::string inside = R"({"position": [0.2, 0, 0], "look_at": [1, 0.5, 2], "vfov": 90})";
    for (auto [ior, camera] : {std::pair{3.5, outside}, {3.5, inside}, {0.3, outside}}) {
        const Scene scene =
            test::parse_report_scene(glass_in_emitter(1.0, ior, camera, 24, 32), "/tmp/e.json");
        for (const Variant& v : variants()) {
            SCOPED_TRACE(testing::Message() << v.integrator << " " << v.isa << ", ior " << ior
                                            << (camera == inside ? " inside" : " outside"));
            const RenderResult r = run(scene, v);
            EXPECT_EQ(r.stats.nonfinite_samples, 0u);
            bool finite = true;
            image_mean(r.film, 0, &finite);
            EXPECT_TRUE(finite);
            const SampleMean m = sample_mean(r.film, every_pixel);
            EXPECT_NEAR(m.mean, 1.0, 4 * m.se);
            EXPECT_LT(m.se, 0.01);
        }
    }
}

// ---- Emitters from 1e-6 to 1e6 -----------------------------------------------------

TEST(Extremes, TheImageScalesLinearlyWithTheLightsFrom1eMinus6To1e6) {
    // The same paths for every scale (same seed; nothing but the emission and the point
    // light's intensity changes), so every pixel scales by E, to float rounding
    const auto scene_at = [](double e) {
        char text[200];
        std::snprintf(text, sizeof text, R"(, "glossy": {"kd": 0.3, "ks": 0.5, "shininess": 20},
                      "lamp": {"emission": %.9g})",
                      e);
        char light[120];
        std::snprintf(light, sizeof light, R"([{"position": [0.3, 0.6, -0.2], "intensity": %.9g}])",
                      e);
        std::string json = box_scene(text, R"(,
            {"type": "sphere", "center": [-0.4, -0.5, 0], "radius": 0.4, "material": "glossy"},
            {"type": "sphere", "center": [0.5, 0.8, 0.5], "radius": 0.1, "material": "lamp"})",
                                     16, light);
        // The ceiling's emission too
        const std::string from = R"("L": {"emission": 1})";
        char to[60];
        std::snprintf(to, sizeof to, R"("L": {"emission": %.9g})", e);
        json.replace(json.find(from), from.size(), to);
        return test::parse_report_scene(json, "/tmp/e.json");
    };
    const Scene unit = scene_at(1.0);
    for (const Variant& v : variants()) {
        SCOPED_TRACE(std::string(v.integrator) + " " + v.isa);
        const RenderResult base = run(unit, v);
        const Image reference = base.film.mean();
        const double reference_mean = image_mean(base.film, 0);
        ASSERT_GT(reference_mean, 0.1);
        for (double e : {1e-6, 1e-3, 1e3, 1e6}) {
            SCOPED_TRACE(testing::Message() << "E = " << e);
            const RenderResult r = run(scene_at(e), v);
            EXPECT_EQ(r.stats.nonfinite_samples, 0u);
            EXPECT_NEAR(image_mean(r.film, 0) / e, reference_mean, 1e-4 * reference_mean);
            const Image img = r.film.mean();
            for (size_t i = 0; i < img.rgb.size(); ++i)
                ASSERT_NEAR(double(img.rgb[i]) / e, reference.rgb[i],
                            1e-4 * reference.rgb[i] + 1e-30)
                    << "value " << i;
        }
    }
}

// ---- Albedo 0 ----------------------------------------------------------------------

TEST(Extremes, ABlackBoxShowsExactlyTheDirectViewOfItsEmitter) {
    // Walls of kd = 0 (and a point light, which a black surface must not reflect): every
    // sample is the ceiling's emission 1.5 if the camera ray meets the ceiling first, else
    // 0. Pixels whose whole area sees the ceiling are exactly 1.5, those that see none of it
    // exactly 0 (worked out from the camera rays against the six planes)
    const int size = 24, spp = 16;
    std::string json = box_scene("", "", spp, R"([{"position": [0, 0, 0], "intensity": 5}])");
    using Edit = std::pair<std::string, std::string>;
    for (auto [from, to] : {Edit{R"("w": {"kd": 0.8})", R"("w": {"kd": 0})"},
                            Edit{R"("L": {"emission": 1})", R"("L": {"emission": 1.5})"}})
        json.replace(json.find(from), from.size(), to);
    const Scene scene = test::parse_report_scene(json, "/tmp/e.json");
    // Which plane a ray meets first: the box is -1 < x, y < 1, -4 < z < 1, the ceiling y = 1
    const auto sees_ceiling = [&](const Ray<float>& ray) {
        double best = 1e30;
        bool ceiling = false;
        const double o[3] = {ray.o.x, ray.o.y, ray.o.z}, d[3] = {ray.d.x, ray.d.y, ray.d.z};
        const double lo[3] = {-1, -1, -4}, hi[3] = {1, 1, 1};
        for (int a = 0; a < 3; ++a)
            for (double wall : {lo[a], hi[a]}) {
                const double t = (wall - o[a]) / d[a];
                if (t > 0 && t < best) best = t, ceiling = a == 1 && wall == 1;
            }
        return ceiling;
    };
    std::vector<int> kind(size_t(size * size));  // 1 all ceiling, -1 none, 0 mixed
    for (int y = 0; y < size; ++y)
        for (int x = 0; x < size; ++x) {
            int hits = 0;
            const int grid = 8;
            for (int j = 0; j <= grid; ++j)
                for (int i = 0; i <= grid; ++i)
                    hits += sees_ceiling(scene.camera.generate(float(x) + float(i) / grid,
                                                               float(y) + float(j) / grid,
                                                               1.0f / size, 1.0f / size));
            kind[size_t(y * size + x)] = hits == (grid + 1) * (grid + 1) ? 1 : hits == 0 ? -1 : 0;
        }
    size_t full = 0, empty = 0;
    for (int k : kind) full += k == 1, empty += k == -1;
    ASSERT_GT(full, 20u);
    ASSERT_GT(empty, 200u);
    for (const Variant& v : variants()) {
        SCOPED_TRACE(std::string(v.integrator) + " " + v.isa);
        const RenderResult r = run(scene, v);
        EXPECT_EQ(r.stats.nonfinite_samples, 0u);
        EXPECT_EQ(r.stats.rays.shadow, 0u) << "a black surface sent shadow rays";
        for (int y = 0; y < size; ++y)
            for (int x = 0; x < size; ++x) {
                const PixelSums& p = r.film.at(x, y);
                ASSERT_TRUE(samples_are_zero_or(p, 1.5)) << "pixel " << x << ", " << y;
                const int k = kind[size_t(y * size + x)];
                if (k == 1) {
                    ASSERT_EQ(p.sum[0], 1.5 * spp) << "pixel " << x << ", " << y;
                }
                if (k == -1) {
                    ASSERT_EQ(p.sum[0], 0.0) << "pixel " << x << ", " << y;
                }
            }
    }
}

// ---- A watertight mesh ---------------------------------------------------------------

// An emitting sphere (radius 5, emission 1) around a closed UV-sphere mesh of radius 1 at
// the origin (shared vertices, fans at the poles) made of a black absorber: no ray may
// pass between its triangles, so wherever the camera sees the mesh the image is exactly 0.
struct MeshInEmitter {
    Scene scene;
    test::TriangleMesh mesh;
};
MeshInEmitter mesh_in_emitter(int size, int spp) {
    MeshInEmitter m{test::parse_report_scene(R"({"render": {"width": )" + std::to_string(size) +
                                                 R"(, "height": )" + std::to_string(size) +
                                                 R"(, "spp": )" + std::to_string(spp) + R"(},
        "camera": {"position": [0, 0, 0], "look_at": [0, 0, 1]},
        "materials": {"L": {"emission": 1}, "black": {"kd": 0}},
        "objects": [{"type": "sphere", "center": [0, 0, 0], "radius": 5, "material": "L"}]})",
                                             "/tmp/e.json"),
                    test::uv_sphere(12, 24)};
    Mesh mesh;
    mesh.source = "uv_sphere(12, 24)";
    mesh.positions = m.mesh.positions;
    mesh.indices = m.mesh.indices;
    for (size_t i = 0; i < m.scene.materials.size(); ++i)
        if (m.scene.materials[i].name == "black") mesh.material = int32_t(i);
    m.scene.meshes.push_back(std::move(mesh));
    m.scene.finalize();
    return m;
}

void expect_black(const RenderResult& r) {
    EXPECT_EQ(r.stats.nonfinite_samples, 0u);
    for (int y = 0; y < r.film.height(); ++y)
        for (int x = 0; x < r.film.width(); ++x) {
            const PixelSums& p = r.film.at(x, y);
            ASSERT_EQ(p.sum[0] + p.sum[1] + p.sum[2], 0.0)
                << "light leaks at pixel " << x << ", " << y;
        }
}

TEST(Extremes, AClosedAbsorbingMeshAroundTheCameraLetsNoLightIn) {
    // Wide views along the axes (the poles' fans included), then narrow ones (0.001° and
    // 0.00001°: rays within a few float ulps of one point) aimed from the centre and from an
    // off-centre point at vertices and at edge midpoints
    MeshInEmitter m = mesh_in_emitter(16, 16);
    std::vector<std::pair<Vec3f, Vec3f>> views;  // position, target
    for (Vec3f axis : {Vec3f{1, 0, 0}, Vec3f{-1, 0, 0}, Vec3f{0, 1, 0}, Vec3f{0, -1, 0},
                       Vec3f{0, 0, 1}, Vec3f{0, 0, -1}})
        views.push_back({Vec3f{0.0f}, axis});
    const std::vector<Vec3f>& p = m.mesh.positions;
    const std::vector<uint32_t>& t = m.mesh.indices;
    std::vector<Vec3f> targets;
    for (size_t i = 0; i < p.size(); i += 7) targets.push_back(p[i]);
    targets.push_back(p.back());  // a pole
    for (size_t i = 0; i < t.size(); i += 3 * 29) targets.push_back((p[t[i]] + p[t[i + 1]]) * 0.5f);
    for (const Vec3f& target : targets) {
        views.push_back({Vec3f{0.0f}, target});
        views.push_back({Vec3f{0.3f, -0.2f, 0.1f}, target});
    }
    for (const Variant& v : variants()) {
        SCOPED_TRACE(std::string(v.integrator) + " " + v.isa);
        for (size_t i = 0; i < views.size(); ++i) {
            const auto [position, target] = views[i];
            SCOPED_TRACE(testing::Message() << "view " << i);
            const std::vector<float> fovs =
                i < 6 ? std::vector<float>{120.0f} : std::vector<float>{1e-3f, 1e-5f};
            for (float vfov : fovs) {
                const Vec3f up = std::fabs(target.y - position.y) > 0.9f * length(target - position)
                                     ? Vec3f{1, 0, 0}
                                     : Vec3f{0, 1, 0};
                m.scene.camera = look_at_camera(position, target, up, vfov, 1.0f);
                expect_black(run(m.scene, v));
            }
        }
    }
}

TEST(Extremes, AClosedAbsorbingMeshHitAtItsVerticesHidesTheEmitterBehindIt) {
    // The camera outside the mesh, looking at vertices and edge midpoints of the side facing
    // it through a 0.001° field of view: every ray meets the mesh within float precision
    // of a vertex or an edge, and the emitter behind must stay hidden
    MeshInEmitter m = mesh_in_emitter(8, 16);
    const Vec3f eye{0.4f, 0.5f, -3.0f};
    const std::vector<Vec3f>& p = m.mesh.positions;
    const std::vector<uint32_t>& t = m.mesh.indices;
    std::vector<Vec3f> targets;
    const auto facing = [&](const Vec3f& q) { return dot(q, eye - q) > 0.3f * length(eye - q); };
    for (const Vec3f& q : p)
        if (facing(q)) targets.push_back(q);
    for (size_t i = 0; i < t.size(); i += 3) {
        const Vec3f mid = (p[t[i]] + p[t[i + 2]]) * 0.5f;
        if (facing(mid) && i % 5 == 0) targets.push_back(mid);
    }
    ASSERT_GT(targets.size(), 40u);
    for (const Variant& v : variants()) {
        SCOPED_TRACE(std::string(v.integrator) + " " + v.isa);
        for (size_t i = 0; i < targets.size(); ++i) {
            SCOPED_TRACE(testing::Message() << "target " << i);
            m.scene.camera = look_at_camera(eye, targets[i], Vec3f{0, 1, 0}, 1e-3f, 1.0f);
            expect_black(run(m.scene, v));
        }
    }
    // And a wide view: the mesh's silhouette is seen against the emitter, so the image is
    // neither all black nor all lit, and pixels well inside the silhouette are black
    for (const Variant& v : variants()) {
        SCOPED_TRACE(std::string(v.integrator) + " " + v.isa);
        m.scene.camera = look_at_camera(eye, Vec3f{0.0f}, Vec3f{0, 1, 0}, 50.0f, 1.0f);
        m.scene.settings.width = m.scene.settings.height = 32;
        const RenderResult r = run(m.scene, v);
        const SampleMean all = sample_mean(r.film, every_pixel);
        EXPECT_GT(all.mean, 0.3);
        EXPECT_LT(all.mean, 0.9);
        const SampleMean centre = sample_mean(r.film, [](int x, int y) {
            return (x - 15.5) * (x - 15.5) + (y - 15.5) * (y - 15.5) < 8.0 * 8.0;
        });
        EXPECT_EQ(centre.mean, 0.0);
        m.scene.settings.width = m.scene.settings.height = 8;
    }
}

}  // namespace
}  // namespace cierzo
