// The environment light (kernels/environment.h, the scene's "environment"): a diffuse plane
// under a constant sky shows exactly ρL in every estimator and integrator; the importance
// sampler draws texels in proportion to max RGB · sin θ (chi-square) with the density it
// reports, and its estimate of the sky's integral is unbiased; under a high-dynamic-range sky
// every estimator agrees with the report's, and the wavefront with the scalar reference;
// bad environments are refused naming the file.
#include <gtest/gtest.h>

#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "core/error.h"
#include "io/image.h"
#include "kernels/environment.h"
#include "kernels/rng.h"
#include "scene/scene_json.h"
#include "support/scratch.h"
#include "support/render_variants.h"
#include "support/statistics.h"

namespace cierzo {
namespace {

namespace fs = std::filesystem;

const fs::path& scratch() { return test::scratch("environment"); }

Scene scene_from(const std::string& name, const std::string& text) {
    const fs::path path = scratch() / name;
    std::ofstream(path) << text;
    return load_scene(path);
}

// An HDR sky: blue above the horizon, grey below, a small sun of radiance 400, one black
// texel.
void write_sky(const fs::path& path) {
    Image sky(32, 16);
    for (int y = 0; y < 16; ++y)
        for (int x = 0; x < 32; ++x) {
            float* p = sky.pixel(x, y);
            p[0] = y < 8 ? 0.3f : 0.2f, p[1] = y < 8 ? 0.5f : 0.2f, p[2] = y < 8 ? 1.0f : 0.2f;
        }
    for (int y = 3; y < 5; ++y)
        for (int x = 10; x < 12; ++x)
            sky.pixel(x, y)[0] = sky.pixel(x, y)[1] = sky.pixel(x, y)[2] = 400.0f;
    float* black = sky.pixel(30, 12);
    black[0] = black[1] = black[2] = 0.0f;
    write_exr(path, sky);
}

const char* const kPlane = R"({
    "materials": {"p": {"kd": 0.5}},
    "objects": [{"type": "plane", "normal": [0, 1, 0], "distance": 0, "material": "p"}],
    "environment": {"emission": [1, 2, 3], "rotate": [10, 30, 0]},
    "camera": {"position": [0, 3, 0.01], "look_at": [0, 0, 0], "vfov": 40},
    "render": {"width": 16, "height": 16, "spp": 64, "seed": 3}})";

// Every point of an infinite diffuse plane sees the whole sky above it once: ρ·L, whatever the
// estimator (each hits or samples the sky) and the rotation.
TEST(Environment, DiffusePlaneUnderAConstantSkyShowsAlbedoTimesRadiance) {
    Scene scene = scene_from("plane.json", kPlane);
    const double expected[3] = {0.5, 1.0, 1.5};
    for (const char* estimator : {"report", "nee", "mis", "lt"}) {
        use_estimator(scene.settings.estimator, *parse_estimator(estimator));
        for (const test::Variant& v : test::variants()) {
            const RenderResult r = test::run(scene, v);
            for (int c = 0; c < 3; ++c) {
                const test::ImageMean m = test::image_mean(r.film, c);
                EXPECT_NEAR(m.mean, expected[c], 4.0 * m.sigma + 1e-4 * expected[c])
                    << estimator << " " << v.integrator << " " << v.isa << " channel " << c;
            }
        }
    }
}

// The sampler against its own tables: texels drawn in proportion to max RGB · sin θ (of the
// row's centre), each direction's reported density equal to environment_pdf there, and
// E[L / pdf] the sky's integral ∫ L dω computed from the texels' solid angles.
TEST(Environment, ImportanceSamplerMatchesItsDistributionAndDensity) {
    write_sky(scratch() / "sky.exr");
    const Scene scene = scene_from("sampler.json", R"({
        "materials": {"p": {"kd": 0.5}},
        "objects": [{"type": "sphere", "center": [0, 0, 0], "radius": 1, "material": "p"}],
        "environment": {"emission": {"texture": "image", "file": "sky.exr", "factor": 0.5},
                        "rotate": [0, 70, 20]},
        "camera": {"position": [0, 0, 4], "look_at": [0, 0, 0]}})");
    const EnvironmentMap env = scene.emitters.table().environment;
    ASSERT_EQ(env.width, 32);
    ASSERT_EQ(env.height, 16);
    ASSERT_GE(env.emitter, 0);
    const size_t texels = size_t(env.width) * size_t(env.height);
    std::vector<double> weight(texels), observed(texels, 0.0);
    double total = 0.0, integral[3] = {0, 0, 0};
    for (int y = 0; y < env.height; ++y) {
        const double t0 = M_PI * y / env.height, t1 = M_PI * (y + 1) / env.height;
        const double omega = 2.0 * M_PI / env.width * (std::cos(t0) - std::cos(t1));
        for (int x = 0; x < env.width; ++x) {
            const size_t i = size_t(y * env.width + x);
            const float* l = env.radiance + 3 * i;
            weight[i] = std::max({l[0], l[1], l[2]}) * std::sin(0.5 * (t0 + t1));
            total += weight[i];
            for (int c = 0; c < 3; ++c) integral[c] += l[c] * omega;
        }
    }
    const int n = 400000;
    test::MeanEstimate estimate[3];
    int density_mismatches = 0;
    for (int k = 0; k < n; ++k) {
        const float u1 = float(hash32(uint32_t(2 * k) + 17u) >> 8) * 0x1p-24f,
                    u2 = float(hash32(uint32_t(2 * k + 1) + 17u) >> 8) * 0x1p-24f;
        const EnvironmentSample<float> s = sample_environment(env, u1, u2);
        ASSERT_TRUE(s.ok) << k;
        float sin_theta;
        const int32_t texel = environment_texel(env, s.wi, sin_theta);
        observed[size_t(texel)] += 1.0;
        const float pdf = environment_pdf(env, s.wi);
        density_mismatches += std::abs(pdf - s.pdf) > 1e-3f * s.pdf;
        for (int c = 0; c < 3; ++c) estimate[c].add(s.le[c] / s.pdf);
    }
    std::vector<double> expected(texels);
    for (size_t i = 0; i < texels; ++i) expected[i] = weight[i] / total * n;
    EXPECT_EQ(observed[size_t(12 * env.width + 30)], 0.0);  // the black texel
    const auto [stat, dof] = test::chi_square(observed, expected);
    EXPECT_LT(stat, test::chi_square_critical(dof)) << "dof " << dof;
    // (a direction on a texel's border may round into its neighbour)
    EXPECT_LT(density_mismatches, n / 1000);
    for (int c = 0; c < 3; ++c)
        EXPECT_NEAR(estimate[c].mean(), integral[c], 4.0 * estimate[c].standard_error())
            << "channel " << c;
}

// A high-dynamic-range sky over diffuse, glossy, mirror and glass objects: nee, mis and lt
// agree with the report's estimator in the image mean, and the wavefront with the scalar
// reference pixel by pixel.
TEST(Environment, EstimatorsAndIntegratorsAgreeUnderAnHdrSky) {
    write_sky(scratch() / "sky.exr");
    Scene scene = scene_from("hdr.json", R"({
        "materials": {"floor": {"kd": [0.5, 0.45, 0.4]},
                      "gloss": {"kd": [0.4, 0.3, 0.2], "ks": 0.3, "shininess": 40},
                      "mirror": {"kr": 0.9}, "glass": {"kt": 0.95, "ior": 1.5},
                      "lamp": {"emission": [4, 4, 3]}},
        "objects": [{"type": "plane", "normal": [0, 1, 0], "distance": 0, "material": "floor"},
                    {"type": "sphere", "center": [-1.1, 1, 0], "radius": 1, "material": "gloss"},
                    {"type": "sphere", "center": [1.1, 0.8, 0.3], "radius": 0.8, "material": "mirror"},
                    {"type": "sphere", "center": [0, 0.5, 1.6], "radius": 0.5, "material": "glass"},
                    {"type": "sphere", "center": [2, 3, 1], "radius": 0.3, "material": "lamp"}],
        "environment": {"emission": {"texture": "image", "file": "sky.exr", "factor": 0.25},
                        "rotate": [0, 60, 0]},
        "camera": {"position": [0, 2, 6], "look_at": [0, 0.8, 0], "vfov": 45},
        "render": {"width": 16, "height": 12, "spp": 512, "seed": 8}})");
    const std::vector<test::Variant> vs = test::variants();
    use_estimator(scene.settings.estimator, Estimator::kReport);
    const RenderResult reference = test::run(scene, vs[0]);
    for (const char* estimator : {"nee", "mis", "lt"}) {
        use_estimator(scene.settings.estimator, *parse_estimator(estimator));
        const RenderResult scalar = test::run(scene, vs[0]);
        for (int c = 0; c < 3; ++c) {
            const test::ImageMean a = test::image_mean(reference.film, c),
                                  b = test::image_mean(scalar.film, c);
            EXPECT_NEAR(b.mean, a.mean, 4.0 * std::hypot(a.sigma, b.sigma))
                << estimator << " channel " << c;
        }
        for (size_t k = 1; k < vs.size(); ++k) {
            const RenderResult w = test::run(scene, vs[k]);
            EXPECT_GE(test::pixels_agreeing(scalar.film, w.film), 0.99)
                << estimator << " " << vs[k].isa;
        }
    }
}

TEST(Environment, BadEnvironmentsAreRefusedNamingTheFile) {
    const auto refusal = [](const std::string& environment) {
        const std::string text = R"({"materials": {"p": {"kd": 0.5}},
            "objects": [{"type": "sphere", "center": [0, 0, 0], "radius": 1, "material": "p"}],
            "camera": {"position": [0, 0, 4], "look_at": [0, 0, 0]},
            "environment": )" + environment +
                                 "}";
        try {
            scene_from("bad.json", text);
        } catch (const InputError& e) {
            return std::string(e.what());
        }
        return std::string();
    };
    std::string m = refusal(R"({"emission": {"texture": "sin", "a": 1, "b": 0}})");
    EXPECT_NE(m.find("bad.json"), std::string::npos) << m;
    EXPECT_NE(m.find("'emission'"), std::string::npos) << m;
    m = refusal(R"({"emission": -1})");
    EXPECT_NE(m.find(">= 0"), std::string::npos) << m;
    m = refusal(R"({"emission": {"texture": "image", "file": "nowhere.hdr"}})");
    EXPECT_NE(m.find("nowhere.hdr"), std::string::npos) << m;
    write_sky(scratch() / "sky.exr");
    m = refusal(R"({"emission": {"texture": "image", "file": "sky.exr", "scale": 2}})");
    EXPECT_NE(m.find("'scale'"), std::string::npos) << m;
    m = refusal(R"({"emission": 1, "turn": 3})");
    EXPECT_NE(m.find("unknown key 'turn'"), std::string::npos) << m;
}

}  // namespace
}  // namespace cierzo
