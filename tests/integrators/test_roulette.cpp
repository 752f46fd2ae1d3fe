// The throughput roulette (render.roulette "throughput", --roulette throughput; nee and mis),
// through both integrators and every ISA this CPU runs:
//   - unbiased against analytic answers: a point light of intensity I at the centre of a
//     closed diffuse sphere (radius R, albedo ρ: L = ρI/(πR²(1-ρ)) everywhere inside), and a
//     diffuse ball inside an emitting sphere (ρ·Le on the ball), each image mean within 3σ
//     (σ < 1.5%; 4.5% at the lighter settings of the sanitizer and emulator jobs), with
//     the roulette from vertex 0, 3 and 1024;
//   - per pixel against the lobe roulette on a box with every lobe kind (diffuse, glossy,
//     mirror, glass), sampled emitters and a point light (a z-test at Šidák-corrected
//     α = 0.01 passes on ≥ 99% of pixels; with mis, means within 3.5σ and σ < 2% of the
//     mean, tight enough to catch a 5% error in a lobe's weight);
//   - a closed box of perfect mirrors around an emitter: every path ends, nothing is NaN;
//   - refused for report and lt, and a bad name or depth in a scene file.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "core/error.h"
#include "integrators/render.h"
#include "scene/scene_json.h"
#include "support/emulator.h"
#include "support/analytic_scenes.h"
#include "support/render_variants.h"
#include "support/report_scene.h"

namespace cierzo {
namespace {

using test::image_mean;
using test::ImageMean;
using test::kBall;
using test::kLobes;
using test::kRoom;
using test::kRoomL;
using test::pixels_agreeing;
using test::run;
using test::Variant;
using test::variants;

int spp(int native, int lighter) { return test::lighter_settings() ? lighter : native; }
// The largest relative σ of an analytic case's image mean: 1.5% at 256 paths per pixel, and
// √8 times that at the lighter settings' 32
double sigma_bound() { return test::lighter_settings() ? 0.045 : 0.015; }

Scene with_roulette(const std::string& json, Estimator e, Roulette r, int depth, int spp) {
    Scene s = parse_scene(json, "roulette_test.json");
    test::set_estimator(s, e);
    s.settings.estimator.roulette = r;
    s.settings.estimator.roulette_depth = depth;
    s.settings.spp = spp;
    return s;
}

TEST(ThroughputRoulette, AnalyticAnswersAtEveryDepth) {
    for (const Variant& v : variants()) {
        SCOPED_TRACE(v.integrator + " " + v.isa);
        for (Estimator e : {Estimator::kNee, Estimator::kMis}) {
            for (int depth : {0, 3, 1024}) {
                SCOPED_TRACE(std::string(estimator_name(e)) + " from vertex " +
                             std::to_string(depth));
                test::expect_answer(
                    run(with_roulette(kRoom, e, Roulette::kThroughput, depth, spp(256, 32)), v),
                    kRoomL, sigma_bound());
                test::expect_answer(
                    run(with_roulette(kBall, e, Roulette::kThroughput, depth, spp(256, 32)), v),
                    0.8, sigma_bound());
            }
        }
    }
}

TEST(ThroughputRoulette, AgreesWithTheLobeRoulettePerPixel) {
    const int n = spp(1024, 128);
    for (Estimator e : {Estimator::kNee, Estimator::kMis}) {
        SCOPED_TRACE(estimator_name(e));
        const RenderResult lobe =
            run(with_roulette(kLobes, e, Roulette::kLobe, 3, n), variants().back());
        for (const Variant& v : variants()) {
            SCOPED_TRACE(v.integrator + " " + v.isa);
            Scene s = with_roulette(kLobes, e, Roulette::kThroughput, 3, n);
            s.settings.seed = 12;  // independent of the lobe roulette's render
            const RenderResult thr = run(s, v);
            const double share = pixels_agreeing(thr.film, lobe.film);
            std::printf("throughput vs lobe roulette, %s, %s %s: %.2f%% of pixels agree\n",
                        estimator_name(e), v.integrator.c_str(), v.isa.c_str(), 100 * share);
            EXPECT_GE(share, 0.99);
            // (nee's image is too noisy here for a tight mean: the small emitter seen in the
            // mirror and through the glass)
            for (int c = 0; c < 3 && e == Estimator::kMis; ++c) {
                const ImageMean a = image_mean(thr.film, c), b = image_mean(lobe.film, c);
                EXPECT_NEAR(a.mean, b.mean, 3.5 * std::hypot(a.sigma, b.sigma));
                const double bound = test::lighter_settings() ? 0.06 : 0.02;
                EXPECT_LT(std::hypot(a.sigma, b.sigma), bound * b.mean);
            }
            EXPECT_EQ(thr.film.nonfinite_samples(), 0u);
        }
    }
}

TEST(ThroughputRoulette, EveryPathEndsInABoxOfPerfectMirrors) {
    // Six mirror planes (kr 1) around an emitting sphere and a diffuse ball: without the
    // cap a path between the mirrors would keep its throughput and never end
    const std::string json = R"({"render": {"width": 8, "height": 8, "seed": 2},
        "camera": {"position": [0, 0, -0.5], "look_at": [0, 0, 0], "up": [0, 1, 0], "vfov": 60},
        "materials": {"m": {"kr": [1, 1, 1]}, "d": {"kd": [0.5, 0.5, 0.5]},
                      "L": {"emission": [1000000, 1000000, 1000000]}},
        "objects": [
          {"type": "plane", "normal": [0, 1, 0], "distance": 1, "material": "m"},
          {"type": "plane", "normal": [0, -1, 0], "distance": 1, "material": "m"},
          {"type": "plane", "normal": [1, 0, 0], "distance": 1, "material": "m"},
          {"type": "plane", "normal": [-1, 0, 0], "distance": 1, "material": "m"},
          {"type": "plane", "normal": [0, 0, 1], "distance": 1, "material": "m"},
          {"type": "plane", "normal": [0, 0, -1], "distance": 1, "material": "m"},
          {"type": "sphere", "center": [0.5, 0.5, 0.5], "radius": 0.01, "material": "L"},
          {"type": "sphere", "center": [0, -0.5, 0.3], "radius": 0.3, "material": "d"}]})";
    for (const Variant& v : variants()) {
        SCOPED_TRACE(v.integrator + " " + v.isa);
        for (int depth : {0, 1024}) {
            const RenderResult r =
                run(with_roulette(json, Estimator::kMis, Roulette::kThroughput, depth, 16), v);
            EXPECT_EQ(r.stats.nonfinite_samples, 0u);
            bool finite = true;
            for (int c = 0; c < 3; ++c) {
                const ImageMean m = image_mean(r.film, c);
                finite = finite && std::isfinite(m.mean) && m.mean > 0.0;
            }
            EXPECT_TRUE(finite);
        }
    }
}

TEST(ThroughputRoulette, RefusedWhereTheEstimatorKeepsTheLobeRoulette) {
    for (Estimator e : {Estimator::kReport, Estimator::kLt}) {
        const Scene s = with_roulette(kRoom, e, Roulette::kThroughput, 3, 1);
        RenderOptions o;
        o.progress = false;
        try {
            render(s, o);
            ADD_FAILURE() << estimator_name(e) << " rendered with the throughput roulette";
        } catch (const InputError& x) {
            const std::string what = x.what();
            EXPECT_NE(what.find("roulette_test.json"), std::string::npos) << what;
            EXPECT_NE(what.find("throughput roulette"), std::string::npos) << what;
        }
    }
    // In a scene file: the names and the depth's range
    const std::string head = R"({"camera": {"position": [0, 0, -2], "look_at": [0, 0, 0]},
        "materials": {"w": {"kd": [0.5, 0.5, 0.5]}},
        "objects": [{"type": "sphere", "center": [0, 0, 0], "radius": 1, "material": "w"}],
        "render": {)";
    EXPECT_THROW(parse_scene(head + R"("roulette": "russian"}})", "r.json"), InputError);
    EXPECT_THROW(parse_scene(head + R"("roulette_depth": -1}})", "r.json"), InputError);
    EXPECT_THROW(parse_scene(head + R"("roulette_depth": 1025}})", "r.json"), InputError);
    const Scene ok = parse_scene(
        head + R"("estimator": "mis", "roulette": "throughput", "roulette_depth": 5}})", "r.json");
    EXPECT_EQ(ok.settings.estimator.roulette, Roulette::kThroughput);
    EXPECT_EQ(ok.settings.estimator.roulette_depth, 5);
    EXPECT_EQ(parse_scene(head + "}}", "r.json").settings.estimator.roulette, Roulette::kThroughput)
        << "a scene that names no estimator takes mis's roulette";
    EXPECT_EQ(
        parse_scene(head + R"("estimator": "report"}})", "r.json").settings.estimator.roulette,
        Roulette::kLobe);
}

}  // namespace
}  // namespace cierzo
