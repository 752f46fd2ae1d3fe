// Light tracing (--estimator lt) through both integrators and every ISA this CPU runs:
//   - analytic answers: a point light at the centre of a lossless glass ball inside a closed
//     diffuse sphere (only light paths find it: L = ρI/(πR²(1-ρ)); the camera-path
//     estimators give exactly 0); the same room without the ball (every estimator gives L);
//     the camera inside an emitting sphere (camera paths: exactly Le; lt: Le);
//   - the adjoint of the report's refraction: an emitter inside a glass ball lights the room
//     the same through lt as through mis (a missing or misplaced η² is a factor 2.25);
//   - lt against mis per pixel on a scene whose emitters can all be sampled and where the
//     camera sees no mirror or glass (a z-test at Šidák-corrected α = 0.01 passes on ≥ 99%
//     of pixels, and the means agree within 3σ); scalar and wavefront lt likewise;
//   - the image is the same bits for 1, 2 and 3 threads; the splat sums are the same bits
//     in any order and any split; the units of a pass (batches of light paths, then camera
//     tiles) each cover the image once, and a batch of light paths cut into rows splats
//     the same bits as whole;
//   - a scene with no light is refused; one whose emitters cannot be sampled renders with
//     a warning, and is then the report's image bit for bit.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "core/error.h"
#include "integrators/render.h"
#include "integrators/scalar.h"
#include "integrators/scheduler.h"
#include "integrators/wavefront/wavefront.h"
#include "scene/scene_json.h"
#include "support/emulator.h"
#include "support/render_variants.h"
#include "support/report_scene.h"

namespace cierzo {
namespace {

using test::image_mean;
using test::pixels_agreeing;
using Mean = test::ImageMean;
using test::run;
using test::Variant;
using test::variants;

Scene scene_of(const std::string& json, Estimator e, int spp) {
    Scene s = parse_scene(json, "lt_test.json");
    test::set_estimator(s, e);
    s.settings.spp = spp;
    return s;
}

// A closed diffuse sphere of radius 2 (albedo 0.5) with a point light of intensity 1 at its
// centre, optionally inside a glass ball of radius 0.5; the camera inside, looking away
// from the centre (it never looks through the ball).
std::string room(bool ball, const std::string& extra = "", bool light = true) {
    return std::string(R"({"render": {"width": 24, "height": 24, "seed": 7},
        "camera": {"position": [0, 0, -1.2], "forward": [0, 0, -1], "left": [-2, 0, 0],
                   "up": [0, 2, 0]},
        "materials": {"wall": {"kd": [0.5, 0.5, 0.5]}, "glass": {"kt": [1, 1, 1], "ior": 1.5},
                      "hot": {"emission": [10, 10, 10]}},
        "objects": [{"type": "sphere", "center": [0, 0, 0], "radius": 2, "material": "wall"})") +
           (ball
                ? R"(, {"type": "sphere", "center": [0, 0, 0], "radius": 0.5, "material": "glass"})"
                : "") +
           extra + "]" +
           (light ? R"(, "lights": [{"position": [0, 0, 0], "intensity": [1, 1, 1]}])" : "") + "}";
}
constexpr double kRoomL = 0.5 * 1.0 / (M_PI * 4.0 * (1.0 - 0.5));  // ρI/(πR²(1-ρ)) = 0.0796

int spp(int native, int lighter) { return test::lighter_settings() ? lighter : native; }

TEST(LightTracing, FindsAPointLightInsideAGlassBall) {
    for (const Variant& v : variants()) {
        SCOPED_TRACE(v.integrator + " " + v.isa);
        const RenderResult r = run(scene_of(room(true), Estimator::kLt, spp(2048, 128)), v);
        const Mean m = image_mean(r.film, 0);
        std::printf("lt, glass ball, %s %s: mean %.5f ± %.5f (L = %.5f)\n", v.integrator.c_str(),
                    v.isa.c_str(), m.mean, m.sigma, kRoomL);
        EXPECT_LT(m.sigma, 0.004 * kRoomL * (test::lighter_settings() ? 4 : 1));
        EXPECT_NEAR(m.mean, kRoomL, std::max(4 * m.sigma, 0.002 * kRoomL));
        EXPECT_NEAR(m.mean, kRoomL, 0.01 * kRoomL * (test::lighter_settings() ? 4 : 1));
        EXPECT_EQ(r.film.nonfinite_samples(), 0u);
    }
    // No camera path can reach it: the camera-path estimators' limit, exactly black
    for (Estimator e : {Estimator::kReport, Estimator::kNee, Estimator::kMis}) {
        const RenderResult r = run(scene_of(room(true), e, 4), variants().back());
        EXPECT_EQ(image_mean(r.film, 0).mean, 0.0);
    }
}

TEST(LightTracing, EveryEstimatorLightsTheRoomWithoutTheBall) {
    for (Estimator e : {Estimator::kReport, Estimator::kNee, Estimator::kMis, Estimator::kLt}) {
        for (const Variant& v : variants()) {
            SCOPED_TRACE(std::string(estimator_name(e)) + " " + v.integrator + " " + v.isa);
            const RenderResult r = run(scene_of(room(false), e, spp(512, 64)), v);
            const Mean m = image_mean(r.film, 1);
            EXPECT_NEAR(m.mean, kRoomL, std::max(4 * m.sigma, 0.002 * kRoomL));
            EXPECT_NEAR(m.mean, kRoomL, 0.015 * kRoomL * (test::lighter_settings() ? 3 : 1));
        }
    }
}

// The camera inside an emitting sphere of Le (1, 2, 3): camera paths see exactly Le, light
// paths bring it through the emitter's own points connected to the pinhole.
TEST(LightTracing, CameraInsideAnEmittingSphere) {
    const std::string json = R"({"render": {"width": 16, "height": 12, "seed": 2},
        "camera": {"position": [0.3, -0.2, 0.1], "look_at": [1, 0, 0], "up": [0, 1, 0], "vfov": 60},
        "materials": {"L": {"emission": [1, 2, 3]}},
        "objects": [{"type": "sphere", "center": [0, 0, 0], "radius": 2, "material": "L"}]})";
    for (const Variant& v : variants()) {
        SCOPED_TRACE(v.integrator + " " + v.isa);
        for (Estimator e : {Estimator::kReport, Estimator::kMis}) {
            const RenderResult r = run(scene_of(json, e, 4), v);
            for (size_t i = 0; i < r.film.pixels().size(); ++i)
                for (int c = 0; c < 3; ++c)
                    ASSERT_EQ(r.film.mean().rgb[3 * i + size_t(c)], float(c + 1));
        }
        const RenderResult r = run(scene_of(json, Estimator::kLt, spp(2048, 128)), v);
        for (int c = 0; c < 3; ++c) {
            const Mean m = image_mean(r.film, c);
            EXPECT_NEAR(m.mean, c + 1.0, std::max(4 * m.sigma, 0.002 * (c + 1)));
            EXPECT_LT(m.sigma, 0.01 * (c + 1) * (test::lighter_settings() ? 4 : 1));
        }
    }
}

// An emitter inside the glass ball: camera paths reach it through the glass (radiance
// unchanged by the report's refraction), light paths leave the glass with (η_i/η_t)² = 2.25:
// the two estimate the same image only with the adjoint right.
TEST(LightTracing, RefractionIsTheAdjointOfTheCamerasRefraction) {
    const std::string json = room(
        true, R"(, {"type": "sphere", "center": [0, 0, 0], "radius": 0.25, "material": "hot"})",
        false);
    const Variant v = variants().back();
    const RenderResult lt = run(scene_of(json, Estimator::kLt, spp(512, 64)), v);
    const RenderResult mis = run(scene_of(json, Estimator::kMis, spp(512, 64)), v);
    const Mean a = image_mean(lt.film, 0), b = image_mean(mis.film, 0);
    std::printf("emitter in glass: lt %.5f ± %.5f, mis %.5f ± %.5f\n", a.mean, a.sigma, b.mean,
                b.sigma);
    const double sigma = std::hypot(a.sigma, b.sigma);
    // (a factor 2.25 is then far outside)
    EXPECT_LT(sigma, 0.03 * b.mean * (test::lighter_settings() ? 3 : 1));
    EXPECT_NEAR(a.mean, b.mean, 3.5 * sigma);
}

// A box of diffuse and glossy planes lit by an emitting sphere, an emitting square of two
// triangles and a point light; a glossy sphere on the floor. Everything samplable, no
// mirror or glass.
const char* kBox = R"({"render": {"width": 20, "height": 16, "seed": 11},
    "camera": {"position": [0, 0, -3.2], "look_at": [0, 0, 0], "up": [0, 1, 0], "vfov": 50},
    "materials": {"white": {"kd": [0.7, 0.7, 0.7]}, "red": {"kd": [0.7, 0.15, 0.1]},
                  "gloss": {"kd": [0.2, 0.4, 0.6], "ks": [0.3, 0.3, 0.3], "shininess": 20},
                  "L": {"emission": [6, 5, 4]}, "Q": {"emission": [3, 3, 5]}},
    "objects": [
      {"type": "plane", "normal": [0, 1, 0], "distance": 1, "material": "white"},
      {"type": "plane", "normal": [0, -1, 0], "distance": 1, "material": "white"},
      {"type": "plane", "normal": [1, 0, 0], "distance": 1, "material": "red"},
      {"type": "plane", "normal": [-1, 0, 0], "distance": 1, "material": "gloss"},
      {"type": "plane", "normal": [0, 0, -1], "distance": 1, "material": "white"},
      {"type": "plane", "normal": [0, 0, 1], "distance": 3.5, "material": "white"},
      {"type": "sphere", "center": [0.4, -0.6, 0.2], "radius": 0.4, "material": "gloss"},
      {"type": "sphere", "center": [-0.5, 0.6, 0.3], "radius": 0.15, "material": "L"},
      {"type": "triangle", "vertices": [[0.2, 0.99, -0.2], [0.6, 0.99, -0.2], [0.6, 0.99, 0.2]],
       "material": "Q"},
      {"type": "triangle", "vertices": [[0.2, 0.99, -0.2], [0.6, 0.99, 0.2], [0.2, 0.99, 0.2]],
       "material": "Q"}],
    "lights": [{"position": [-0.3, 0.2, -0.5], "intensity": [0.3, 0.3, 0.2]}]})";

TEST(LightTracing, AgreesWithMisPerPixel) {
    const int n = spp(1024, 128);
    const Variant wavefront = variants().back();
    const RenderResult mis = run(scene_of(kBox, Estimator::kMis, n), wavefront);
    for (const Variant& v : variants()) {
        SCOPED_TRACE(v.integrator + " " + v.isa);
        Scene s = scene_of(kBox, Estimator::kLt, n);
        s.settings.seed = 12;  // independent of the mis render
        const RenderResult lt = run(s, v);
        const double share = pixels_agreeing(lt.film, mis.film);
        std::printf("lt vs mis, %s %s: %.2f%% of pixels agree\n", v.integrator.c_str(),
                    v.isa.c_str(), 100 * share);
        EXPECT_GE(share, 0.99);
        for (int c = 0; c < 3; ++c) {
            const Mean a = image_mean(lt.film, c), b = image_mean(mis.film, c);
            EXPECT_NEAR(a.mean, b.mean, 3.5 * std::hypot(a.sigma, b.sigma));
            EXPECT_LT(std::hypot(a.sigma, b.sigma), 0.02 * b.mean);
        }
        EXPECT_EQ(lt.film.nonfinite_samples(), 0u);
    }
}

// A 5% error in the light paths' weight (planted as a 5% brighter light for lt only) fails
// the same check: the tolerance is tight enough to see it.
TEST(LightTracing, APlantedFivePercentErrorIsCaught) {
    const int n = spp(1024, 128);
    const Variant v = variants().back();
    const RenderResult mis = run(scene_of(kBox, Estimator::kMis, n), v);
    // Every start weight 5% high: emitters' and point lights' alike
    std::string json = kBox;
    for (const auto& [from, to] :
         {std::pair<std::string, std::string>{"[6, 5, 4]", "[6.3, 5.25, 4.2]"},
          {"[3, 3, 5]", "[3.15, 3.15, 5.25]"},
          {"[0.3, 0.3, 0.2]", "[0.315, 0.315, 0.21]"}}) {
        const size_t at = json.find(from);
        ASSERT_NE(at, std::string::npos);
        json.replace(at, from.size(), to);
    }
    Scene brighter = scene_of(json, Estimator::kLt, n);
    brighter.settings.seed = 12;
    const RenderResult lt = run(brighter, v);
    bool caught = false;
    for (int c = 0; c < 3; ++c) {
        const Mean a = image_mean(lt.film, c), b = image_mean(mis.film, c);
        caught = caught || std::abs(a.mean - b.mean) > 3.5 * std::hypot(a.sigma, b.sigma);
    }
    EXPECT_TRUE(caught);
}

TEST(LightTracing, ScalarAndWavefrontAgree) {
    const int n = spp(512, 64);
    const RenderResult scalar = run(scene_of(kBox, Estimator::kLt, n), variants().front());
    for (const Variant& v : variants()) {
        if (v.integrator == "scalar") continue;
        SCOPED_TRACE(v.isa);
        Scene s = scene_of(kBox, Estimator::kLt, n);
        s.settings.seed = 99;
        const RenderResult w = run(s, v);
        EXPECT_GE(pixels_agreeing(w.film, scalar.film), 0.99);
        for (int c = 0; c < 3; ++c) {
            const Mean a = image_mean(w.film, c), b = image_mean(scalar.film, c);
            EXPECT_NEAR(a.mean, b.mean, 3.5 * std::hypot(a.sigma, b.sigma));
        }
    }
}

TEST(LightTracing, SameBitsForAnyNumberOfThreads) {
    test::expect_same_bits_for_any_threads(scene_of(kBox, Estimator::kLt, 40));
}

TEST(SplatSums, SameBitsInAnyOrderAndSplit) {
    std::mt19937 rng(5);
    std::uniform_real_distribution<float> value(-1e3f, 1e6f);
    std::uniform_int_distribution<uint32_t> pixel(0, 63);
    std::vector<Splat> all;
    for (int i = 0; i < 5000; ++i) {
        const float scale = std::ldexp(1.0f, int(pixel(rng)) - 40);
        all.push_back({pixel(rng), Vec3f(value(rng) * scale, value(rng), -value(rng) * 1e-3f)});
    }
    SplatSums one;
    one.reset(64);
    one.add(all);
    for (int trial = 0; trial < 3; ++trial) {
        std::vector<Splat> shuffled = all;
        std::shuffle(shuffled.begin(), shuffled.end(), rng);
        SplatSums split;
        split.reset(64);
        const size_t a = shuffled.size() / (trial + 2), b = shuffled.size() / 2 + 7;
        split.add({shuffled.begin() + long(b), shuffled.end()});
        split.add({shuffled.begin(), shuffled.begin() + long(a)});
        split.add({shuffled.begin() + long(a), shuffled.begin() + long(b)});
        for (size_t p = 0; p < 64; ++p)
            for (int c = 0; c < 3; ++c) ASSERT_EQ(split.at(p, c), one.at(p, c));
    }
    // Against a double sum, to the rounding of each value to 2^-40
    double exact = 0.0;
    for (const Splat& s : all)
        if (s.pixel == 3) exact += double(s.value.y);
    EXPECT_NEAR(one.at(3, 1), exact, 1e-9 * std::abs(exact) + 5000 * 0x1.0p-40);
    // Not finite, or too large to add: counted and left out
    SplatSums bad;
    bad.reset(2);
    bad.add({{1, Vec3f(NAN, 0, 0)},
             {1, Vec3f(0, INFINITY, 0)},
             {0, Vec3f(1e30f, 0, 0)},
             {0, Vec3f(2.0f, 0, 0)}});
    EXPECT_EQ(bad.nonfinite(), 3u);
    EXPECT_EQ(bad.at(0, 0), 2.0);
    EXPECT_EQ(bad.at(1, 0), 0.0);
}

// Each value is rounded to the nearest multiple of 2^-40, ties to even, on both sides of
// 2^22 (where a value stops fitting a 64-bit count of 2^-40 units and is rounded another
// way), and of either sign.
TEST(SplatSums, RoundEachValueToTheNearestUnitTiesToEven) {
    const float unit = 0x1.0p-40f;
    struct Case {
        float value;
        double expected;
    };
    const std::vector<Case> cases = {
        {0.5f * unit, 0.0},         // a tie: to the even 0
        {1.5f * unit, 2.0 * unit},  // a tie: to the even 2
        {2.5f * unit, 2.0 * unit},  // a tie: to the even 2
        {-1.5f * unit, -2.0 * unit},
        {0.75f * unit, 1.0 * unit},
        {0.25f * unit, 0.0},
        {3.0f, 3.0},
        {0x1.0p21f, 0x1.0p21},  // below 2^22: one instruction
        {0x1.fffffep21f, 0x1.fffffep21},
        {0x1.0p22f, 0x1.0p22},  // from 2^22 on: the other way
        {-0x1.8p40f, -0x1.8p40},
        {0x1.fffffep79f, 0x1.fffffep79},  // the largest kept
    };
    for (const Case& c : cases) {
        SCOPED_TRACE(c.value);
        SplatSums s;
        s.reset(1);
        s.add({{0, Vec3f(c.value, -c.value, 0.0f)}});
        EXPECT_EQ(s.at(0, 0), c.expected);
        EXPECT_EQ(s.at(0, 1), -c.expected);
        EXPECT_EQ(s.nonfinite(), 0u);
    }
    // Sums across 2^22 units: a value of each kind in one pixel
    SplatSums mixed;
    mixed.reset(1);
    mixed.add({{0, Vec3f(0x1.0p30f, 1.5f * unit, 0)},
               {0, Vec3f(1.0f, 0x1.0p23f, 0)},
               {0, Vec3f(-3.0f, -0x1.0p23f, 0)}});
    EXPECT_EQ(mixed.at(0, 0), 0x1.0p30 - 2.0);
    EXPECT_EQ(mixed.at(0, 1), 2.0 * unit);
}

TEST(WorkUnits, LightBatchesAndTilesEachCoverTheImageOnce) {
    for (const auto& [w, h] : std::vector<std::pair<int, int>>{
             {1, 1}, {7, 3}, {48, 40}, {250, 250}, {1000, 3}, {5000, 2}, {33, 2049}}) {
        SCOPED_TRACE(std::to_string(w) + "x" + std::to_string(h));
        const std::vector<Tile> tiles = image_tiles(w, h);
        const std::vector<Tile> camera = work_units(w, h, false);
        ASSERT_EQ(camera.size(), tiles.size());
        for (size_t i = 0; i < tiles.size(); ++i) {
            EXPECT_FALSE(camera[i].light);
            EXPECT_EQ(camera[i].x0, tiles[i].x0);
            EXPECT_EQ(camera[i].y1, tiles[i].y1);
        }
        const std::vector<Tile> units = work_units(w, h, true);
        std::vector<int> by_light(size_t(w) * size_t(h), 0), by_tile(by_light.size(), 0);
        bool tiles_begun = false;
        int next_row = 0;
        for (const Tile& u : units) {
            ASSERT_LT(u.x0, u.x1);
            ASSERT_LT(u.y0, u.y1);
            if (u.light) {
                EXPECT_FALSE(tiles_begun) << "light batches come first";
                // Whole rows, in order, about kLightBatchPixels pixels (the last may be less)
                EXPECT_EQ(u.x0, 0);
                EXPECT_EQ(u.x1, w);
                EXPECT_EQ(u.y0, next_row);
                next_row = u.y1;
                if (u.y1 < h && w <= kLightBatchPixels) {
                    EXPECT_LE(std::abs((u.y1 - u.y0) * w - kLightBatchPixels), w);
                }
            } else {
                tiles_begun = true;
            }
            for (int y = u.y0; y < u.y1; ++y)
                for (int x = u.x0; x < u.x1; ++x)
                    ++(u.light ? by_light : by_tile)[size_t(y) * size_t(w) + size_t(x)];
        }
        EXPECT_EQ(next_row, h);
        EXPECT_EQ(std::count(by_light.begin(), by_light.end(), 1), long(by_light.size()));
        EXPECT_EQ(std::count(by_tile.begin(), by_tile.end(), 1), long(by_tile.size()));
    }
}

// A batch of light paths cut into batches of fewer rows, in any order, splats the same bits
// as the whole batch: a light path's key is that of its pixel and sample, nothing of the
// unit it runs in (so the scheduler may cut the work as it likes).
TEST(LightTracing, ABatchCutIntoRowsSplatsTheSameBits) {
    Scene s = scene_of(kBox, Estimator::kLt, 3);
    const int w = s.settings.width, h = s.settings.height;
    const auto sums_of = [&](const Variant& v, const std::vector<std::pair<int, int>>& rows,
                             uint64_t& light) {
        std::unique_ptr<WavefrontRenderer> wavefront;
        if (v.integrator == "wavefront")
            wavefront = std::make_unique<WavefrontRenderer>(s, parse_isa(v.isa));
        SplatSums sums;
        sums.reset(size_t(w) * size_t(h));
        light = 0;
        for (const auto& [y0, y1] : rows) {
            Tile batch{0, y0, w, y1, 1, 3};
            batch.light = true;
            FilmTile film(0, y0, 0, y0, w);
            RayCounts rays;
            LaneStats lanes;
            if (wavefront)
                wavefront->render_tile(batch, film, rays, lanes);
            else
                render_tile_scalar(s, batch, film, rays);
            EXPECT_TRUE(film.pixels().empty());
            sums.add(film.splats);
            light += rays.light;
        }
        EXPECT_LE(light, uint64_t(w) * uint64_t(h) * 2u);  // one per pixel and sample at most
        return sums;
    };
    for (const Variant& v : variants()) {
        SCOPED_TRACE(v.integrator + " " + v.isa);
        uint64_t light_whole = 0, light_cut = 0;
        const SplatSums whole = sums_of(v, {{0, h}}, light_whole);
        const SplatSums cut = sums_of(v, {{5, 6}, {h - 1, h}, {0, 5}, {6, h - 1}}, light_cut);
        EXPECT_GT(light_whole, uint64_t(w) * uint64_t(h));
        EXPECT_EQ(light_cut, light_whole);
        double total = 0.0;
        for (size_t p = 0; p < size_t(w) * size_t(h); ++p)
            for (int c = 0; c < 3; ++c) {
                ASSERT_EQ(cut.at(p, c), whole.at(p, c)) << "pixel " << p;
                total += whole.at(p, c);
            }
        EXPECT_GT(total, 0.0);  // (the light paths reached the camera)
    }
}

TEST(LightTracing, RefusesASceneWithoutLight) {
    const std::string dark = R"({"render": {"width": 4, "height": 4},
        "camera": {"position": [0, 0, -2], "look_at": [0, 0, 0], "up": [0, 1, 0], "vfov": 40},
        "materials": {"w": {"kd": [0.5, 0.5, 0.5]}},
        "objects": [{"type": "sphere", "center": [0, 0, 0], "radius": 1, "material": "w"}]})";
    try {
        run(scene_of(dark, Estimator::kLt, 1), variants().front());
        FAIL() << "rendered a scene without light";
    } catch (const InputError& e) {
        EXPECT_NE(std::string(e.what()).find("lt_test.json"), std::string::npos) << e.what();
        EXPECT_NE(std::string(e.what()).find("no point light and no emitter"), std::string::npos)
            << e.what();
    }
}

// Only an emitting plane (never sampled): the camera's paths bring it, as the report's
// estimator does, with the same random numbers: the same image bit for bit, and a warning.
TEST(LightTracing, EmittersThatCannotBeSampledAreTheCamerasAlone) {
    const std::string json = R"({"render": {"width": 12, "height": 10, "seed": 4},
        "camera": {"position": [0, 0, -2], "look_at": [0, 0, 0], "up": [0, 1, 0], "vfov": 60},
        "materials": {"w": {"kd": [0.5, 0.5, 0.5]}, "sky": {"emission": [1, 1, 2]}},
        "objects": [{"type": "sphere", "center": [0, 0, 0], "radius": 1, "material": "w"},
                    {"type": "plane", "normal": [0, -1, 0], "distance": 3, "material": "sky"}]})";
    for (const Variant& v : variants()) {
        SCOPED_TRACE(v.integrator + " " + v.isa);
        const RenderResult lt = run(scene_of(json, Estimator::kLt, 16), v);
        const RenderResult report = run(scene_of(json, Estimator::kReport, 16), v);
        EXPECT_EQ(lt.film.mean().rgb, report.film.mean().rgb);
        EXPECT_GT(image_mean(lt.film, 2).mean, 0.1);
        ASSERT_EQ(lt.stats.warnings.size(), 1u);
        EXPECT_NE(lt.stats.warnings[0].find("light tracing adds nothing"), std::string::npos);
    }
}

}  // namespace
}  // namespace cierzo
