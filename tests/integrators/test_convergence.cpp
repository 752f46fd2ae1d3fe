// Error metrics and convergence sweeps: the metrics against hand-computed values, the
// reference-noise correction, and sweeps whose error falls as 1/N for an unbiased render,
// rises when the survival cap is lowered, and stands out when the reference is 5% off.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <iostream>
#include <string>

#include "core/error.h"
#include "integrators/convergence.h"
#include "integrators/render.h"
#include "scene/scene_json.h"
#include "support/emulator.h"

namespace cierzo {
namespace {

Image constant_image(int w, int h, float v) {
    Image img(w, h);
    for (float& x : img.rgb) x = v;
    return img;
}

TEST(ImageError, HandComputedValues) {
    const Image ref = constant_image(3, 2, 0.5f);
    Image img = ref;
    img.rgb[0] = 1.5f;  // one channel of one pixel off by 1: 18 values in all
    const ImageError e = image_error(img, ref);
    EXPECT_DOUBLE_EQ(e.mse, 1.0 / 18.0);
    EXPECT_DOUBLE_EQ(e.rel_mse, 1.0 / (0.25 + kRelMseEpsilon) / 18.0);
    EXPECT_EQ(e.reference_mse, 0.0);
    EXPECT_DOUBLE_EQ(e.mse_corrected(), e.mse);
}

TEST(ImageError, ReferenceNoiseIsRemovedAndClampedAtZero) {
    const Image ref = constant_image(4, 4, 1.0f);
    const Image img = constant_image(4, 4, 1.1f);
    const Image var = constant_image(4, 4, 0.004f);
    const ImageError e = image_error(img, ref, &var);
    EXPECT_NEAR(e.mse, 0.01, 1e-7);
    EXPECT_NEAR(e.reference_mse, 0.004, 1e-9);
    EXPECT_NEAR(e.mse_corrected(), 0.006, 1e-7);
    EXPECT_NEAR(e.rel_mse_corrected(), 0.006 / (1.0 + kRelMseEpsilon), 1e-7);
    const ImageError exact = image_error(ref, ref, &var);
    EXPECT_EQ(exact.mse_corrected(), 0.0);
}

TEST(ImageError, SizesMustMatch) {
    EXPECT_THROW(image_error(constant_image(4, 4, 0), constant_image(4, 5, 0)), InputError);
    const Image var = constant_image(2, 2, 0);
    EXPECT_THROW(image_error(constant_image(4, 4, 0), constant_image(4, 4, 0), &var), InputError);
}

TEST(LogLogSlope, PowerLaws) {
    const std::vector<double> x = {1, 2, 4, 8, 16};
    std::vector<double> y;
    for (double v : x) y.push_back(3.0 / v);
    EXPECT_NEAR(log_log_slope(x, y), -1.0, 1e-12);
    for (double& v : y) v = v * v;
    EXPECT_NEAR(log_log_slope(x, y), -2.0, 1e-12);
    EXPECT_TRUE(std::isnan(log_log_slope({1}, {1})));
    EXPECT_TRUE(std::isnan(log_log_slope({1, 2}, {0, 0})));  // no positive errors
}

// A small closed box of diffuse walls with an emitting ceiling and a Phong sphere: every
// path bounces until the roulette ends it.
const char* kBox = R"({"render": {"width": 24, "height": 24, "spp": 1, "seed": 7},
    "camera": {"position": [0, 0, -3], "look_at": [0, 0, 0], "vfov": 60},
    "materials": {"w": {"kd": 0.7}, "L": {"emission": 2}, "p": {"kd": 0.3, "ks": 0.4, "shininess": 20}},
    "objects": [
        {"type": "plane", "normal": [1, 0, 0], "distance": 1, "material": "w"},
        {"type": "plane", "normal": [-1, 0, 0], "distance": 1, "material": "w"},
        {"type": "plane", "normal": [0, 1, 0], "distance": 1, "material": "w"},
        {"type": "plane", "normal": [0, -1, 0], "distance": 1, "material": "L"},
        {"type": "plane", "normal": [0, 0, -1], "distance": 1, "material": "w"},
        {"type": "plane", "normal": [0, 0, 1], "distance": 4, "material": "w"},
        {"type": "sphere", "center": [0, -0.5, 0], "radius": 0.4, "material": "p"}]})";

struct Reference {
    Image mean, variance;
};

// Under an emulator (CIERZO_TEST_EMULATED=1: scripts/test_aarch64.sh runs the suite in
// qemu-user, about 100 times slower than natively) the reference has 4096 paths per pixel,
// not 16384: ctest runs each test in a process of its own, so every test renders it, and it
// is most of their time. The tests still fail as they would: the errors are corrected for
// the reference's noise, whose estimate is only less certain.
bool emulated() { return test::lighter_settings(); }

// The box at 16384 paths per pixel (4096 under an emulator), rendered once for all tests.
const Reference& box_reference() {
    static const Reference ref = [] {
        Scene s = parse_scene(kBox, "/tmp/box.json");
        s.settings.spp = emulated() ? 4096 : 16384;
        if (emulated()) std::cout << "CIERZO_TEST_EMULATED: a reference of 4096 paths per pixel\n";
        RenderOptions o;
        o.progress = false;
        const RenderResult r = render(s, o);
        return Reference{r.film.mean(), r.film.variance_of_mean()};
    }();
    return ref;
}

TEST(Converge, MseFallsAsOneOverPathsPerPixel) {
    const Scene scene = parse_scene(kBox, "/tmp/box.json");
    const Reference& ref = box_reference();
    ConvergeSweep sweep;
    sweep.configs = {{"scalar"}, {"wavefront"}};
    sweep.spp = {1, 4, 16, 64};
    sweep.repeats = 2;
    const auto points = run_converge(scene, ref.mean, &ref.variance, sweep, {});
    ASSERT_EQ(points.size(), 8u);
    for (size_t c = 0; c < 2; ++c) {
        std::vector<double> x, y;
        for (size_t i = 0; i < 4; ++i) {
            const ConvergePoint& p = points[c * 4 + i];
            EXPECT_EQ(p.spp, sweep.spp[i]);
            EXPECT_GT(p.rays, 0u);
            x.push_back(double(p.spp));
            y.push_back(p.error.mse_corrected());
        }
        // Unbiased: MSE ∝ 1/N. Against the uncorrected MSE the slope would flatten as N
        // approaches the reference's paths per pixel.
        EXPECT_NEAR(log_log_slope(x, y), -1.0, 0.1) << sweep.configs[c].integrator;
    }
}

TEST(Converge, AFivePercentBiasStandsAboveTheNoise) {
    const Scene scene = parse_scene(kBox, "/tmp/box.json");
    const Reference& ref = box_reference();
    Reference biased = ref;
    for (float& v : biased.mean.rgb) v *= 1.05f;
    ConvergeSweep sweep;
    sweep.configs = {{"wavefront"}};
    // At 4096 paths per pixel the noise is below a 5% bias (of the mean squared value)
    sweep.spp = {4096};
    const double fair =
        run_converge(scene, ref.mean, &ref.variance, sweep, {})[0].error.mse_corrected();
    const double off =
        run_converge(scene, biased.mean, &biased.variance, sweep, {})[0].error.mse_corrected();
    EXPECT_GT(off, 2.0 * fair);
}

TEST(Converge, ALowerSurvivalCapCostsAccuracy) {
    // Fewer bounces survive: less time per path, more variance per path
    const Scene scene = parse_scene(kBox, "/tmp/box.json");
    const Reference& ref = box_reference();
    ConvergeSweep sweep;
    sweep.configs = {{"wavefront", "auto", 0, 0.9f}, {"wavefront", "auto", 0, 0.3f}};
    sweep.spp = {64};
    sweep.repeats = 2;
    const auto points = run_converge(scene, ref.mean, &ref.variance, sweep, {});
    ASSERT_EQ(points.size(), 2u);
    EXPECT_GT(points[1].error.mse_corrected(), 1.2 * points[0].error.mse_corrected());
    EXPECT_LT(points[1].rays, points[0].rays);
}

}  // namespace
}  // namespace cierzo
