// Numerical extremes through both integrators and every ISA: a diffuse sphere inside a
// uniform emitter at scales from 1e-4 to 1e6 and far from the origin (no acne: no pixel
// darker than the analytic 0.8 allows; the same image at every scale); an ior-1 sphere
// that must vanish; total internal reflection; Phong s = 0 and 1e4; emitters of 1e6;
// albedo 1; a point light on a surface; degenerate primitives; and a forced NaN sample,
// which must be counted and kept out of the image.
#include <gtest/gtest.h>

#include <cmath>

#include "integrators/render.h"
#include "integrators/wavefront/isa_entries.h"
#include "scene/scene_json.h"

namespace cierzo {
namespace {

struct Variant {
    const char* integrator;
    const char* isa;
};

std::vector<Variant> variants() {
    std::vector<Variant> v = {{"scalar", "auto"}};
    for (Isa isa : {Isa::kAvx512, Isa::kAvx2, Isa::kSse42})
        if (isa_supported(isa)) v.push_back({"wavefront", isa == Isa::kAvx512 ? "avx512" : isa == Isa::kAvx2 ? "avx2" : "sse4.2"});
    return v;
}

RenderResult run(const Scene& scene, const Variant& v) {
    RenderOptions o;
    o.integrator = v.integrator;
    o.isa = v.isa;
    o.threads = 2;
    o.progress = false;
    return render(scene, o);
}

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
        "camera": {"position": )" + v(x, y, z - 3 * r) + R"(, "look_at": )" + v(x, y, z) +
           R"(, "vfov": 60},
        "materials": {"w": {"kd": 0.8}, "L": {"emission": 1}},
        "objects": [{"type": "sphere", "center": )" + v(x, y, z) + R"(, "radius": )" + radius +
           R"(, "material": "w"},
                    {"type": "sphere", "center": )" + v(x, y, z) + R"(, "radius": )" + big +
           R"(, "material": "L"}]})";
}

TEST(Extremes, NoAcneAndTheSameImageAtEveryScale) {
    // A diffuse sphere (0.8) inside a uniform emitter (1): each path that leaves the sphere
    // meets the emitter, so a sphere pixel is 0.8 in expectation and nothing is darker
    for (const Variant& v : variants()) {
        SCOPED_TRACE(std::string(v.integrator) + " " + v.isa);
        const RenderResult unit = run(parse_scene(sphere_in_emitter(0, 0, 0, 1), "/tmp/e.json"), v);
        const double reference = image_mean(unit.film, 0);
        for (auto [x, r] : {std::pair{0.0, 1e-4}, {0.0, 1e6}, {1e4, 1.0}, {-3e3, 1e-1}}) {
            SCOPED_TRACE(testing::Message() << "offset " << x << " radius " << r);
            const Scene scene = parse_scene(sphere_in_emitter(x, x, x, r), "/tmp/e.json");
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
        "materials": {"w": {"kd": 0.8}, "L": {"emission": 1})" + extra_materials + R"(},
        "objects": [)" + kBox + extra_objects + R"(], "lights": )" + lights + "}";
}

TEST(Extremes, AnIorOneSphereVanishes) {
    for (const Variant& v : variants()) {
        SCOPED_TRACE(std::string(v.integrator) + " " + v.isa);
        const RenderResult empty = run(parse_scene(box_scene("", "", 512), "/tmp/e.json"), v);
        const RenderResult glass = run(
            parse_scene(box_scene(R"(, "g": {"kt": 1, "ior": 1})",
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
        EXPECT_NEAR(image_mean(glass.film, 0), image_mean(empty.film, 0), 5.0 * se * std::sqrt(2.0));
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
        box_scene(R"(, "one": {"kd": 1})",
                  R"(, {"type": "sphere", "center": [0, -0.5, 0], "radius": 0.4, "material": "one"})",
                  32, R"([{"position": [0, -1, 0], "intensity": 1},
                         {"position": [0.2, 0.3, 0.1], "intensity": 1e6}])"),
        // Degenerate triangles and a nearly empty quadric; a black absorber
        box_scene(R"(, "black": {"kd": 0})",
                  R"(, {"type": "triangle", "vertices": [[0, 0, 0], [0, 0, 0], [1, 1, 1]], "material": "w"},
                     {"type": "triangle", "vertices": [[0, 0, 0], [0.5, 0.5, 0.5], [1, 1, 1]], "material": "w"},
                     {"type": "quadric", "coefficients": [0, 0, 0, 0, 0, 0, 0, 0, 1e-30, 0], "material": "w"},
                     {"type": "sphere", "center": [0, 0, 0.5], "radius": 0.3, "material": "black"})")};
    for (const std::string& text : cases) {
        const Scene scene = parse_scene(text, "/tmp/e.json");
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
    Scene scene = parse_scene(box_scene("", "", 8), "/tmp/e.json");
    for (Material& m : scene.materials)
        if (m.is_emitter()) m.emission.a.y = std::nanf("");
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

}  // namespace
}  // namespace cierzo
