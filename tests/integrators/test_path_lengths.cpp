// Path length limits (render.min_length, render.max_length, --min-length, --max-length),
// through both integrators and every ISA this CPU runs:
//   - the images of lengths 1..2, 3 and 4.. add up, pixel by pixel, to the whole image (the
//     same paths with the same numbers: equal but for the rounding of the film's sums), with
//     every estimator and with the independent and sobol samplers;
//   - analytic answers by length (within 4σ): a point light at the centre of a closed diffuse
//   sphere
//     gives ρI/(πR²)·ρ^(n-2) at length n; a diffuse ball inside an emitting sphere gives all
//     of its 0.8 at length 2 and exactly nothing at lengths 1 and 3..;
//   - the scene keys, and their refusal of a maximum below the minimum.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "core/error.h"
#include "integrators/render.h"
#include "scene/scene_json.h"
#include "support/analytic_scenes.h"
#include "support/emulator.h"
#include "support/render_variants.h"
#include "support/report_scene.h"

namespace cierzo {
namespace {

using test::image_mean;
using test::ImageMean;
using test::run;
using test::Variant;
using test::variants;

Scene limited(const std::string& json, Estimator e, int min_length, int max_length, int spp) {
    Scene s = parse_scene(json, "lengths_test.json");
    test::set_estimator(s, e);
    s.settings.estimator.min_length = min_length;
    s.settings.estimator.max_length = max_length;
    s.settings.spp = spp;
    return s;
}

TEST(PathLengths, BandsAddUpToTheWholeImage) {
    for (const Variant& v : variants()) {
        for (Estimator e : {Estimator::kReport, Estimator::kNee, Estimator::kMis, Estimator::kLt}) {
            for (Sampler smp : {Sampler::kIndependent, Sampler::kSobol}) {
                SCOPED_TRACE(v.integrator + " " + v.isa + " " + estimator_name(e) + " " +
                             sampler_name(smp));
                const auto image = [&](int lo, int hi) {
                    Scene s = limited(test::kLobes, e, lo, hi, 8);
                    s.settings.estimator.sampler = smp;
                    return run(s, v).film.mean();
                };
                const Image whole = image(1, kNoLengthLimit), direct = image(1, 2),
                            first = image(3, 3), rest = image(4, kNoLengthLimit);
                double largest = 0, worst = 0, in_bands[3] = {0, 0, 0};
                for (size_t i = 0; i < whole.rgb.size(); ++i) {
                    const double sum = double(direct.rgb[i]) + first.rgb[i] + rest.rgb[i];
                    largest = std::max(largest, double(whole.rgb[i]));
                    worst = std::max(worst, std::abs(sum - whole.rgb[i]));
                    in_bands[0] += direct.rgb[i], in_bands[1] += first.rgb[i];
                    in_bands[2] += rest.rgb[i];
                }
                EXPECT_LE(worst, 1e-5 * largest + 1e-6);
                // Each band holds light of its own (the box has every lengths' paths)
                for (double b : in_bands) EXPECT_GT(b, 0.0);
            }
        }
    }
}

TEST(PathLengths, AnalyticAnswersByLength) {
    // (4σ: a few hundred checks of fixed seeds; a wrong factor per length, ρ or 2, is far
    // beyond; σ under 5%, and 12% at the lighter settings' 64 paths)
    const int spp = test::lighter_settings() ? 64 : 256;
    const double sigma_bound = test::lighter_settings() ? 0.12 : 0.05;
    const double l2 = 0.5 / (M_PI * 4.0);  // ρI/(πR²): light at the first hit
    for (const Variant& v : variants()) {
        for (Estimator e : {Estimator::kReport, Estimator::kMis, Estimator::kLt}) {
            SCOPED_TRACE(v.integrator + " " + v.isa + " " + estimator_name(e));
            struct Band {
                int lo, hi;
                double expected;
            };
            // (the point light is never seen: nothing at length 1)
            for (const Band& b : {Band{1, 1, 0.0}, Band{2, 2, l2}, Band{3, 3, l2 * 0.5},
                                  Band{4, kNoLengthLimit, l2 * 0.5}}) {
                const RenderResult r = run(limited(test::kRoom, e, b.lo, b.hi, spp), v);
                for (int c = 0; c < 3; ++c) {
                    const ImageMean m = image_mean(r.film, c);
                    if (b.expected == 0.0) {
                        EXPECT_EQ(m.mean, 0.0) << "lengths " << b.lo << ".." << b.hi;
                    } else {
                        // (+ float rounding: direct light here has no variance at all)
                        EXPECT_NEAR(m.mean, b.expected, 4.0 * m.sigma + 1e-4 * b.expected)
                            << "lengths " << b.lo << ".." << b.hi;
                        EXPECT_LT(m.sigma, sigma_bound * b.expected);
                    }
                }
            }
            if (e == Estimator::kLt) continue;  // (the ball: camera paths' answer)
            for (const auto& [lo, hi, expected] : {std::tuple{1, 1, 0.0}, std::tuple{2, 2, 0.8},
                                                   std::tuple{3, kNoLengthLimit, 0.0}}) {
                const RenderResult r = run(limited(test::kBall, e, lo, hi, spp), v);
                for (int c = 0; c < 3; ++c) {
                    const ImageMean m = image_mean(r.film, c);
                    if (expected == 0.0)
                        EXPECT_EQ(m.mean, 0.0) << "lengths " << lo << ".." << hi;
                    else
                        EXPECT_NEAR(m.mean, expected, 4.0 * m.sigma + 1e-4 * expected);
                }
            }
        }
    }
}

TEST(PathLengths, SceneKeysAndTheirErrors) {
    const std::string base = R"({"camera": {"position": [0, 0, -2], "look_at": [0, 0, 0]},
        "objects": [], "render": )";
    const Scene s = parse_scene(base + R"({"min_length": 2, "max_length": 3}})", "l.json");
    EXPECT_EQ(s.settings.estimator.min_length, 2);
    EXPECT_EQ(s.settings.estimator.max_length, 3);
    const Scene d = parse_scene(base + R"({}})", "l.json");
    EXPECT_EQ(d.settings.estimator.min_length, 1);
    EXPECT_EQ(d.settings.estimator.max_length, kNoLengthLimit);
    for (const char* bad : {R"({"min_length": 4, "max_length": 3}})", R"({"max_length": 0}})",
                            R"({"min_length": -1}})", R"({"max_length": 1e9}})"}) {
        try {
            parse_scene(base + bad, "l.json");
            ADD_FAILURE() << "accepted " << bad;
        } catch (const InputError& e) {
            EXPECT_NE(std::string(e.what()).find("l.json"), std::string::npos) << e.what();
            EXPECT_NE(std::string(e.what()).find("length"), std::string::npos) << e.what();
        }
    }
}

}  // namespace
}  // namespace cierzo
