// Alpha cut-outs (a material's "alpha"; MTL d, Tr and map_d; kernels/bvh/traverse.h): a fully
// transparent quad is invisible and casts no shadow; a checkerboard mask lets through half
// the light and a constant alpha a the share 1 - a (analytic), in every estimator and
// integrator; the stochastic test passes a hit with probability alpha; the wavefront agrees
// with the scalar reference on masked meshes, instances and emitters; MTL's dissolve keys
// map as documented; bad alphas are refused naming the file.
#include <gtest/gtest.h>

#include <unistd.h>

#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <functional>
#include <random>
#include <string>
#include <vector>

#include "core/error.h"
#include "kernels/bvh/traverse.h"
#include "scene/scene_json.h"
#include "support/scratch.h"
#include "support/render_variants.h"

namespace cierzo {
namespace {

namespace fs = std::filesystem;

const fs::path& scratch() { return test::scratch("alpha"); }

using test::write_text;

// An uncompressed 32-bit TGA (written here byte by byte): texel (x, y), y from the top,
// has colour grey(x, y) and alpha alpha(x, y), both bytes.
void write_tga(const fs::path& path, int w, int h, const std::function<int(int, int)>& grey,
               const std::function<int(int, int)>& alpha) {
    std::string bytes(18, '\0');
    bytes[2] = 2;  // uncompressed true colour
    bytes[12] = char(w & 255), bytes[13] = char(w >> 8);
    bytes[14] = char(h & 255), bytes[15] = char(h >> 8);
    bytes[16] = 32;
    bytes[17] = char(0x28);  // 8 alpha bits, rows from the top
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            const char g = char(grey(x, y));
            bytes += {g, g, g, char(alpha(x, y))};
        }
    write_text(path, bytes);
}

using test::refusal_of;

// A quad at z = 1 that fills a 90-degree camera's view exactly (texture coordinates 0..1
// over it), black, with `alpha`; behind it at z = 3 a plane that emits radiance 1. Each
// pixel shows the share of its rays that pass the quad.
std::string veil_scene(const std::string& alpha) {
    return R"({
        "materials": {"veil": {"kd": 0, "alpha": )" +
           alpha + R"(},
                      "sky": {"emission": 1}},
        "objects": [
            {"type": "triangle", "vertices": [[-1, -1, 1], [1, -1, 1], [1, 1, 1]],
             "uvs": [[1, 0], [0, 0], [0, 1]], "material": "veil"},
            {"type": "triangle", "vertices": [[-1, -1, 1], [1, 1, 1], [-1, 1, 1]],
             "uvs": [[1, 0], [0, 1], [1, 1]], "material": "veil"},
            {"type": "plane", "normal": [0, 0, -1], "distance": 3, "material": "sky"}
        ],
        "camera": {"position": [0, 0, 0], "look_at": [0, 0, 1], "vfov": 90},
        "render": {"width": 32, "height": 32, "spp": 64, "seed": 5}})";
}

Scene scene_from(const std::string& name, const std::string& text) {
    write_text(scratch() / name, text);
    return load_scene(scratch() / name);
}

// The camera's rays through a veil of constant alpha a bring 1 - a; through a checkerboard
// mask (of 1 and 0 in its alpha channel, or in its grey) one half; through alpha 1 nothing.
TEST(Alpha, VeilsLetThroughOneMinusTheirAlpha) {
    write_tga(
        scratch() / "checker.tga", 64, 64, [](int, int) { return 255; },
        [](int x, int y) { return (x / 2 + y / 2) % 2 ? 255 : 0; });
    write_tga(
        scratch() / "grey_checker.tga", 64, 64,
        [](int x, int y) { return (x / 2 + y / 2) % 2 ? 0 : 255; }, [](int, int) { return 255; });
    const struct {
        std::string alpha;
        double expected;
    } cases[] = {
        {"1", 0.0},
        {"0", 1.0},
        {"0.3", 0.7},
        {"0.85", 0.15},
        {R"({"texture": "image", "file": "checker.tga"})", 0.5},
        {R"({"texture": "image", "file": "checker.tga", "factor": 0.5})", 0.75},
        {R"({"texture": "image", "file": "grey_checker.tga"})", 0.5},
        // (the grey checker's alpha channel is opaque: "a" chooses it)
        {R"({"texture": "image", "file": "grey_checker.tga", "channel": "a"})", 0.0},
    };
    for (const auto& c : cases) {
        Scene scene = scene_from("veil.json", veil_scene(c.alpha));
        for (const char* estimator : {"report", "mis", "lt"}) {
            use_estimator(scene.settings.estimator, *parse_estimator(estimator));
            for (const test::Variant& v : test::variants()) {
                const RenderResult r = test::run(scene, v);
                const test::ImageMean m = test::image_mean(r.film, 0);
                // (a checker's cells alias a little over 32² pixels: 1% of the mean)
                EXPECT_NEAR(m.mean, c.expected, 4.0 * m.sigma + 0.01)
                    << c.alpha << " " << estimator << " " << v.integrator << " " << v.isa;
            }
        }
    }
}

// The mask's orientation: the veil's texture coordinates are u = (1 - x) / 2, v = (y + 1) / 2,
// and an image's first row is v = 1 (the top, as OBJ's); the camera shows +x on the right and
// +y at the top. A mask opaque in its left half (u < 1/2) darkens the image's right half; one
// opaque in its top rows darkens the image's top half.
TEST(Alpha, MasksAreOrientedByTheirTextureCoordinates) {
    write_tga(
        scratch() / "left.tga", 16, 16, [](int, int) { return 255; },
        [](int x, int) { return x < 8 ? 255 : 0; });
    write_tga(
        scratch() / "top.tga", 16, 16, [](int, int) { return 255; },
        [](int, int y) { return y < 8 ? 255 : 0; });
    for (const char* mask : {"left", "top"}) {
        const Scene scene = scene_from(
            "oriented.json",
            veil_scene(std::string(R"({"texture": "image", "wrap": "clamp", "file": ")") + mask +
                       ".tga\"}"));
        for (const test::Variant& v : test::variants()) {
            const Image m = test::run(scene, v).film.mean();
            double first = 0, second = 0;  // left and right, or top and bottom, halves
            for (int y = 0; y < m.height; ++y)
                for (int x = 0; x < m.width; ++x) {
                    const bool in_first = mask[0] == 'l' ? x < m.width / 2 : y < m.height / 2;
                    (in_first ? first : second) += m.pixel(x, y)[0];
                }
            const double n = 0.5 * m.width * m.height;
            const bool first_dark = mask[0] == 't';
            // (the middle column or row blends: 1/16 of the half)
            EXPECT_NEAR((first_dark ? first : second) / n, 0.0, 0.07) << mask << " " << v.isa;
            EXPECT_NEAR((first_dark ? second : first) / n, 1.0, 0.07) << mask << " " << v.isa;
        }
    }
}

// A white floor lit by a point light above, with a black quad between them: a fully
// transparent quad (alpha 0, or a mask of zeros) changes no pixel, bit for bit; an opaque
// one shadows the floor; a checkerboard mask halves the light that reaches it.
TEST(Alpha, TransparentQuadIsInvisibleAndCastsNoShadowAndAMaskHalvesTheLight) {
    write_tga(
        scratch() / "clear.tga", 8, 8, [](int, int) { return 255; }, [](int, int) { return 0; });
    write_tga(
        scratch() / "fine.tga", 128, 128, [](int, int) { return 255; },
        [](int x, int y) { return (x + y) % 2 ? 255 : 0; });
    const auto floor_scene = [](const std::string& quad_alpha) {
        std::string quad;
        if (!quad_alpha.empty())
            quad = R"(,
            {"type": "triangle", "vertices": [[-4, 1, -4], [4, 1, -4], [4, 1, 4]],
             "uvs": [[0, 0], [8, 0], [8, 8]], "material": "quad"},
            {"type": "triangle", "vertices": [[-4, 1, -4], [4, 1, 4], [-4, 1, 4]],
             "uvs": [[0, 0], [8, 8], [0, 8]], "material": "quad"})";
        return R"({
            "materials": {"floor": {"kd": 0.8},
                          "quad": {"kd": 0, "alpha": )" +
               (quad_alpha.empty() ? std::string("1") : quad_alpha) + R"(},
                          "lamp": {"emission": 40}},
            "objects": [
                {"type": "plane", "normal": [0, 1, 0], "distance": 0, "material": "floor"},
                {"type": "sphere", "center": [0.3, 2.2, 0], "radius": 0.1, "material": "lamp"})" +
               quad + R"(
            ],
            "lights": [{"position": [-0.2, 2, 0.1], "intensity": 10}],
            "camera": {"position": [0, 0.5, 0.01], "look_at": [0, 0, 0], "vfov": 60},
            "render": {"width": 24, "height": 24, "spp": 32, "seed": 9}})";
    };
    Scene open = scene_from("open.json", floor_scene(""));
    Scene clear = scene_from("clear.json", floor_scene("0"));
    Scene clear_mask =
        scene_from("clear_mask.json", floor_scene(R"({"texture": "image", "file": "clear.tga"})"));
    Scene opaque = scene_from("opaque.json", floor_scene("1"));
    Scene checker =
        scene_from("checker.json", floor_scene(R"({"texture": "image", "file": "fine.tga"})"));
    for (const char* estimator : {"report", "nee", "mis", "lt"}) {
        for (Scene* s : {&open, &clear, &clear_mask, &opaque, &checker})
            use_estimator(s->settings.estimator, *parse_estimator(estimator));
        for (const test::Variant& v : test::variants()) {
            const std::string what = std::string(estimator) + " " + v.integrator + " " + v.isa;
            const Image base = test::run(open, v).film.mean();
            // The tree holds two more triangles, never hit: the same paths, the same pixels
            EXPECT_EQ(test::run(clear, v).film.mean().rgb, base.rgb) << what;
            EXPECT_EQ(test::run(clear_mask, v).film.mean().rgb, base.rgb) << what;
            const test::ImageMean b = test::image_mean(test::run(open, v).film, 0);
            const test::ImageMean o = test::image_mean(test::run(opaque, v).film, 0);
            EXPECT_LT(o.mean, 0.02 * b.mean) << what;  // (what the floor sends back up)
            // Light reaches the floor only straight from the lamps (the quad is black, the
            // floor's light that bounces up is lost through it or on it): half of it
            const test::ImageMean h = test::image_mean(test::run(checker, v).film, 0);
            EXPECT_NEAR(h.mean, 0.5 * (b.mean - o.mean) + o.mean,
                        0.02 * b.mean + 4.0 * std::hypot(h.sigma, b.sigma))
                << what;
        }
    }
}

// The stochastic test: over many rays a hit of alpha a counts a share a of the time; the
// same ray always decides the same way.
TEST(Alpha, StochasticTestPassesAShareAlphaOfRays) {
    std::mt19937 gen(7);
    std::uniform_real_distribution<float> uniform(0.0f, 1.0f);
    for (const float a : {0.05f, 0.3f, 0.5f, 0.9f}) {
        const int n = 200000;
        int passed = 0;
        for (int i = 0; i < n; ++i) {
            const float o[3] = {uniform(gen), uniform(gen), uniform(gen)};
            const float d[3] = {uniform(gen) - 0.5f, uniform(gen) - 0.5f, 1.0f};
            const bool p = alpha_passes(a, o, d, uint32_t(i % 3), uint32_t(i % 17));
            EXPECT_EQ(p, alpha_passes(a, o, d, uint32_t(i % 3), uint32_t(i % 17)));
            passed += p;
        }
        const double sigma = std::sqrt(double(a) * (1.0 - a) / n);
        EXPECT_NEAR(double(passed) / n, a, 4.0 * sigma) << a;
    }
    const float o[3] = {0, 0, 0}, d[3] = {0, 0, 1};
    EXPECT_TRUE(alpha_passes(1.0f, o, d, 0, 0));
    EXPECT_FALSE(alpha_passes(0.0f, o, d, 0, 0));
    EXPECT_FALSE(alpha_passes(std::nanf(""), o, d, 0, 0));
}

// Leaves: an OBJ quad with a leaf-shaped mask (a disc in the alpha channel), several times
// by instancing and once in world space, over a floor; a masked emitter and a veil of
// constant alpha. The wavefront agrees with the scalar reference pixel by pixel.
TEST(Alpha, WavefrontAgreesWithTheScalarReference) {
    const fs::path dir = scratch() / "leaves";
    fs::create_directories(dir);
    write_tga(
        dir / "leaf.tga", 32, 32, [](int x, int) { return 60 + 5 * x; },
        [](int x, int y) {
            const double dx = x - 15.5, dy = y - 15.5;
            return dx * dx + dy * dy < 14.0 * 14.0 ? 255 : 0;
        });
    write_text(dir / "leaf.obj",
               "mtllib leaf.mtl\nv -1 0 0\nv 1 0 0\nv 1 2 0\nv -1 2 0\nvt 0 0\nvt 1 0\nvt 1 1\n"
               "vt 0 1\nusemtl leaf\nf 1/1 2/2 3/3 4/4\n");
    write_text(dir / "leaf.mtl", "newmtl leaf\nKd 0.2 0.7 0.2\nmap_Kd leaf.tga\nmap_d leaf.tga\n");
    write_text(dir / "scene.json", R"({
        "materials": {
            "floor": {"kd": 0.7},
            "veil": {"kd": [0.6, 0.2, 0.2], "alpha": 0.4},
            "glow": {"emission": 3, "alpha": {"texture": "image", "file": "leaf.tga"}}
        },
        "objects": [
            {"type": "plane", "normal": [0, 1, 0], "distance": 0, "material": "floor"},
            {"type": "mesh", "file": "leaf.obj", "translate": [0, 0, 0], "rotate": [0, 20, 0]},
            {"type": "mesh", "file": "leaf.obj", "translate": [-1.5, 0, -1], "instance": true},
            {"type": "mesh", "file": "leaf.obj", "translate": [1.5, 0.2, -0.5],
             "rotate": [0, -30, 10], "instance": true},
            {"type": "triangle", "vertices": [[-2, 0, 1], [2, 0, 1], [2, 2.5, 1]],
             "material": "veil"},
            {"type": "mesh", "file": "leaf.obj", "material": "glow", "translate": [0, 3, -2],
             "rotate": [80, 0, 0]}
        ],
        "lights": [{"position": [1, 4, 3], "intensity": 25}],
        "camera": {"position": [0, 1.5, 5], "look_at": [0, 1, 0], "vfov": 50},
        "render": {"width": 24, "height": 18, "spp": 256, "seed": 2}
    })");
    Scene scene = load_scene(dir / "scene.json");
    ASSERT_TRUE(scene.alpha());
    for (const char* estimator : {"report", "mis", "lt"}) {
        use_estimator(scene.settings.estimator, *parse_estimator(estimator));
        test::expect_wavefront_agrees(scene, estimator);
    }
    // The masked emitter is found by the paths that hit it, never sampled
    EXPECT_EQ(scene.emitters.count(), 0u);
}

// MTL: d is the opacity and Tr its complement (the later wins), glass keeps no d, map_d is
// a mask with -imfchan choosing the channel; 'Tr 1' alone warns.
TEST(Alpha, MtlDissolveMapsToAlpha) {
    const fs::path dir = scratch() / "mtl";
    fs::create_directories(dir);
    write_tga(
        dir / "m.tga", 4, 4, [](int, int) { return 255; }, [](int, int) { return 0; });
    write_text(dir / "model.obj",
               "mtllib model.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nvt 0 0\nvt 1 0\nvt 1 1\n"
               "usemtl a\nf 1/1 2/2 3/3\nusemtl b\nf 1/1 2/2 3/3\nusemtl c\nf 1/1 2/2 3/3\n"
               "usemtl d\nf 1/1 2/2 3/3\nusemtl e\nf 1/1 2/2 3/3\nusemtl f\nf 1/1 2/2 3/3\n");
    write_text(dir / "model.mtl",
               "newmtl a\nKd 0.5 0.5 0.5\nd 0.25\n"
               "newmtl b\nKd 0.5 0.5 0.5\nTr 0.25\n"
               "newmtl c\nKd 0.5 0.5 0.5\nd 0.25\nTr 0.5\n"
               "newmtl d\nKs 0.1 0.1 0.1\nTf 1 1 1\nNi 1.5\nillum 7\nd 0.3\n"
               "newmtl e\nKd 0.5 0.5 0.5\nmap_d -imfchan g -s 2 2 1 m.tga\n"
               "newmtl f\nKd 0.5 0.5 0.5\nTr 1\n");
    write_text(dir / "scene.json",
               R"({"camera": {"position": [0.5, 0.5, 3], "look_at": [0.5, 0.5, 0]},
        "objects": [{"type": "mesh", "file": "model.obj"}]})");
    const Scene s = load_scene(dir / "scene.json");
    const auto named = [&](const std::string& n) -> const Material& {
        for (const Material& m : s.materials)
            if (m.name == "model.mtl:" + n) return m;
        ADD_FAILURE() << n;
        return s.materials[0];
    };
    EXPECT_EQ(named("a").alpha.constant, 0.25f);
    EXPECT_EQ(named("b").alpha.constant, 0.75f);
    EXPECT_EQ(named("c").alpha.constant, 0.5f);
    EXPECT_FALSE(named("d").alpha.masked());
    const Material& e = named("e");
    EXPECT_EQ(e.alpha.constant, 1.0f);
    ASSERT_GE(e.alpha.image, 0);
    EXPECT_EQ(e.alpha.channel, 1);
    EXPECT_EQ(e.alpha.uv_scale[0], 2.0f);
    EXPECT_EQ(named("f").alpha.constant, 0.0f);
    bool warned = false;
    for (const std::string& w : s.warnings)
        warned |= w.find("model.mtl: line 22") != std::string::npos &&
                  w.find("Tr 1") != std::string::npos;
    EXPECT_TRUE(warned);
}

TEST(Alpha, BadAlphasAreRefusedNamingTheFile) {
    const auto with = [](const std::string& object, const std::string& alpha) {
        return R"({"materials": {"m": {"kd": 0.5, "alpha": )" + alpha + R"(}},
                   "objects": [)" +
               object + R"(],
                   "camera": {"position": [0, 0, 3], "look_at": [0, 0, 0]}})";
    };
    const std::string tri =
        R"({"type": "triangle", "vertices": [[0, 0, 0], [1, 0, 0], [0, 1, 0]], "material": "m"})";
    const std::string sphere =
        R"({"type": "sphere", "center": [0, 0, 0], "radius": 1, "material": "m"})";
    write_text(scratch() / "nouv.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
    write_tga(
        scratch() / "ok.tga", 2, 2, [](int, int) { return 1; }, [](int, int) { return 0; });
    const struct {
        std::string text, message;
    } cases[] = {
        {with(tri, "1.5"), "opacity from 0"},
        {with(tri, "-0.1"), "opacity from 0"},
        {with(tri, "\"half\""), "opacity from 0"},
        {with(sphere, "0.5"), "triangles and meshes only"},
        {with(R"({"type": "plane", "normal": [0, 1, 0], "distance": 0, "material": "m"})", "0.5"),
         "used by a plane"},
        {with(tri, R"({"texture": "sin", "a": 1})"), "must be a number or"},
        {with(tri, R"({"texture": "image", "file": "missing.tga"})"), "missing.tga"},
        {with(tri, R"({"texture": "image", "file": "ok.tga", "channel": "x"})"), "'channel'"},
        {with(tri, R"({"texture": "image", "file": "ok.tga", "srgb": false})"), "srgb"},
        {with(R"({"type": "mesh", "file": "nouv.obj", "material": "m"})",
              R"({"texture": "image", "file": "ok.tga"})"),
         "no texture coordinates"},
    };
    for (const auto& c : cases) {
        write_text(scratch() / "bad.json", c.text);
        const std::string message = refusal_of([] { load_scene(scratch() / "bad.json"); });
        EXPECT_NE(message.find("bad.json"), std::string::npos) << c.text << "\n" << message;
        EXPECT_NE(message.find(c.message), std::string::npos) << c.text << "\n" << message;
    }
}

}  // namespace
}  // namespace cierzo
