// The samplers (render.sampler, --sampler) through both integrators and every ISA this CPU
// runs:
//   - unbiased against analytic answers with every estimator: a point light at the centre of
//     a closed diffuse sphere (L = ρI/(πR²(1-ρ)) everywhere inside), and a diffuse ball inside
//     an emitting sphere (0.8 on the ball); each image mean within 3σ, σ < 1.5% (4.5% at the
//     lighter settings of the sanitizer and emulator jobs). σ comes from each pixel's sample
//     variance, which overstates a low-discrepancy sampler's error: the bound is conservative;
//   - per pixel against the independent sampler on a box with every lobe kind, sampled
//     emitters and a point light (a z-test at Šidák-corrected α = 0.01 passes on ≥ 99% of
//     pixels; means within 3.5σ), with the throughput roulette and solid-angle triangles too;
//   - bit for bit the same image on 1, 2 and 3 threads, and resumed from mid-render states;
//   - the scene key, its refusal of an unknown name, and the checkpoint's identity.
#include <gtest/gtest.h>

#include <cmath>
#include <mutex>
#include <string>

#include "core/error.h"
#include "integrators/checkpoint.h"
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
using test::pixels_agreeing;
using test::run;
using test::Variant;
using test::variants;

constexpr Sampler kLowDiscrepancy[] = {Sampler::kSobol, Sampler::kZSobol, Sampler::kPmj02};

int spp(int native, int lighter) { return test::lighter_settings() ? lighter : native; }
double sigma_bound() { return test::lighter_settings() ? 0.045 : 0.015; }

Scene with_sampler(const std::string& json, Estimator e, Sampler s, int spp) {
    Scene scene = parse_scene(json, "sampler_test.json");
    test::set_estimator(scene, e);
    scene.settings.estimator.sampler = s;
    scene.settings.spp = spp;
    return scene;
}

bool same_film(const Film& a, const Film& b) {
    const Image ma = a.mean(), mb = b.mean();
    return ma.rgb == mb.rgb;
}

TEST(Samplers, AnalyticAnswersWithEveryEstimator) {
    for (const Variant& v : variants()) {
        SCOPED_TRACE(v.integrator + " " + v.isa);
        for (Sampler s : kLowDiscrepancy) {
            for (Estimator e :
                 {Estimator::kReport, Estimator::kNee, Estimator::kMis, Estimator::kLt}) {
                SCOPED_TRACE(std::string(sampler_name(s)) + " " + estimator_name(e));
                test::expect_answer(run(with_sampler(test::kRoom, e, s, spp(256, 32)), v),
                                    test::kRoomL, sigma_bound());
                if (e == Estimator::kLt) continue;  // (the ball: camera paths' answer)
                test::expect_answer(run(with_sampler(test::kBall, e, s, spp(256, 32)), v), 0.8,
                                    sigma_bound());
            }
        }
    }
}

TEST(Samplers, AgreeWithTheIndependentSamplerPerPixel) {
    const int n = spp(512, 64);
    for (Estimator e : {Estimator::kReport, Estimator::kMis}) {
        SCOPED_TRACE(estimator_name(e));
        const RenderResult base =
            run(with_sampler(test::kLobes, e, Sampler::kIndependent, n), variants().back());
        for (const Variant& v : {variants().front(), variants().back()}) {
            for (Sampler s : kLowDiscrepancy) {
                SCOPED_TRACE(v.integrator + " " + v.isa + " " + sampler_name(s));
                Scene scene = with_sampler(test::kLobes, e, s, n);
                scene.settings.seed = 12;
                if (e == Estimator::kMis) {
                    scene.settings.estimator.roulette = Roulette::kThroughput;
                    scene.settings.estimator.triangle_solid_angle = true;
                    scene.settings.estimator.cosine_diffuse = true;
                }
                const RenderResult r = run(scene, v);
                const double share = pixels_agreeing(r.film, base.film);
                std::printf("%s vs independent, %s, %s %s: %.2f%% of pixels agree\n",
                            sampler_name(s), estimator_name(e), v.integrator.c_str(), v.isa.c_str(),
                            100 * share);
                EXPECT_GE(share, 0.99);
                for (int c = 0; c < 3 && e == Estimator::kMis; ++c) {
                    const ImageMean a = image_mean(r.film, c), b = image_mean(base.film, c);
                    EXPECT_NEAR(a.mean, b.mean, 3.5 * std::hypot(a.sigma, b.sigma));
                }
                EXPECT_EQ(r.film.nonfinite_samples(), 0u);
            }
        }
    }
}

TEST(Samplers, TheSameBitsOnAnyThreadCountAndResumed) {
    for (const Variant& v : {variants().front(), variants().back()}) {
        for (Sampler s : kLowDiscrepancy) {
            for (Estimator e : {Estimator::kMis, Estimator::kLt}) {
                SCOPED_TRACE(v.integrator + " " + v.isa + " " + sampler_name(s) + " " +
                             estimator_name(e));
                // (the lighter settings, under emulation and sanitizers: half the passes)
                Scene scene = with_sampler(test::kLobes, e, s, spp(24, 12));
                scene.settings.width = 40, scene.settings.height = 32;
                RenderOptions o;
                o.integrator = integrator_of(v.integrator);
                o.isa = v.isa;
                o.progress = false;
                o.threads = 2;
                std::vector<RenderState> states;
                std::mutex m;
                o.checkpoint_every = 0.0005;
                o.checkpoint = [&](const RenderState& st) {
                    std::lock_guard lock(m);
                    if (st.spp_done > 0 && st.spp_done < scene.settings.spp) states.push_back(st);
                };
                const RenderResult two = render(scene, o);
                o.checkpoint = nullptr;
                for (int threads : {1, 3}) {
                    o.threads = threads;
                    EXPECT_TRUE(same_film(two.film, render(scene, o).film))
                        << threads << " threads";
                }
                if (!states.empty()) {
                    o.resume = &states.front();
                    EXPECT_TRUE(same_film(two.film, render(scene, o).film))
                        << "resumed from " << states.front().spp_done;
                }
            }
        }
    }
}

TEST(Samplers, TheSceneKeyAndItsErrors) {
    const std::string base = R"({"camera": {"position": [0, 0, -2], "look_at": [0, 0, 0]},
        "objects": [{"type": "sphere", "center": [0, 0, 0], "radius": 1,
                     "material": {"kd": [0.5, 0.5, 0.5]}}], "render": {"sampler": )";
    EXPECT_EQ(parse_scene(base + R"("zsobol"}})", "s.json").settings.estimator.sampler,
              Sampler::kZSobol);
    EXPECT_EQ(parse_scene(base + R"("pmj02"}})", "s.json").settings.estimator.sampler,
              Sampler::kPmj02);
    EXPECT_EQ(parse_scene(R"({"camera": {"position": [0, 0, -2], "look_at": [0, 0, 0]},
        "objects": []})",
                          "s.json")
                  .settings.estimator.sampler,
              Sampler::kSobol)
        << "a scene that names no estimator takes mis's sampler";
    EXPECT_EQ(parse_scene(R"({"camera": {"position": [0, 0, -2], "look_at": [0, 0, 0]},
        "objects": [], "render": {"estimator": "report"}})",
                          "s.json")
                  .settings.estimator.sampler,
              Sampler::kIndependent);
    try {
        parse_scene(base + R"("halton"}})", "s.json");
        FAIL() << "an unknown sampler was accepted";
    } catch (const InputError& e) {
        EXPECT_NE(std::string(e.what()).find("s.json"), std::string::npos) << e.what();
        EXPECT_NE(std::string(e.what()).find("'sampler' must be"), std::string::npos) << e.what();
    }
    // A checkpoint names its sampler; zsobol's points depend on the power of two of the
    // paths per pixel, so a resume to another power is another render
    Scene scene = parse_scene(base + R"("zsobol"}})", "s.json");
    scene.settings.spp = 16;
    const CheckpointIdentity a = checkpoint_identity(scene, "wavefront", "auto", 0);
    scene.settings.spp = 12;
    EXPECT_EQ(checkpoint_identity(scene, "wavefront", "auto", 0).sampler, a.sampler);
    scene.settings.spp = 17;
    EXPECT_NE(checkpoint_identity(scene, "wavefront", "auto", 0).sampler, a.sampler);
    scene.settings.estimator.sampler = Sampler::kSobol;
    EXPECT_EQ(checkpoint_identity(scene, "wavefront", "auto", 0).sampler, "sobol");
}

}  // namespace
}  // namespace cierzo
