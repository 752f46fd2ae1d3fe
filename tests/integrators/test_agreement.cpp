// Wavefront against the scalar reference, on every scene in scenes/ (with each estimator
// that samples its emitters) and on every ISA this CPU has. Both integrators draw the same random
// numbers for the same path vertex, so they trace the same paths and their images differ only where
// rounding sends a path elsewhere. Tolerances (per channel): the image means within 0.3%, and fewer
// than 2% of pixels off by more than 2% of the image mean. A 5% error in any one lobe's weight
// breaks them (the second test plants one in each lobe of a four-lobe material and checks it is
// caught).
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>

#include "integrators/registry.h"
#include "integrators/render.h"
#include "integrators/wavefront/isa.h"
#include "scene/scene_json.h"
#include "support/render_variants.h"
#include "support/report_scene.h"

namespace cierzo {
namespace {

namespace fs = std::filesystem;

struct Difference {
    double mean_rel[3];    // |mean_w - mean_s| / mean_s
    double pixels_off[3];  // fraction of pixels off by more than 2% of the image mean
};

Difference compare(const Film& a, const Film& b) {
    const Image x = a.mean(), y = b.mean();
    Difference d{};
    for (int c = 0; c < 3; ++c) {
        double mx = 0, my = 0;
        for (size_t i = size_t(c); i < x.rgb.size(); i += 3) mx += x.rgb[i], my += y.rgb[i];
        mx /= double(x.rgb.size() / 3), my /= double(y.rgb.size() / 3);
        d.mean_rel[c] = std::abs(mx - my) / std::max(my, 1e-12);
        size_t off = 0;
        for (size_t i = size_t(c); i < x.rgb.size(); i += 3)
            off += std::abs(double(x.rgb[i]) - double(y.rgb[i])) > 0.02 * my + 1e-9;
        d.pixels_off[c] = double(off) / double(x.rgb.size() / 3);
    }
    return d;
}

RenderResult render_with(const Scene& scene, const std::string& integrator,
                         const std::string& isa) {
    RenderOptions o;
    o.integrator = integrator_of(integrator);
    o.isa = isa;
    o.threads = 2;
    o.progress = false;
    return render(scene, o);
}

using test::all_scenes;

TEST(Agreement, WavefrontMatchesScalarOnEverySceneAndIsa) {
    const std::vector<fs::path> scenes = all_scenes();
    ASSERT_GE(scenes.size(), 6u);
    for (const fs::path& path : scenes) {
        Scene scene = load_scene(path);
        scene.set_resolution(40, 40);
        scene.settings.spp = 16;
        // Every estimator that differs from the report's here (nee and mis, where the scene
        // has emitters they sample)
        for (Estimator e : {Estimator::kReport, Estimator::kNee, Estimator::kMis}) {
            if (e != Estimator::kReport && scene.emitters.count() == 0) continue;
            test::set_estimator(scene, e);
            const RenderResult reference = render_with(scene, "scalar", "auto");
            for (Isa isa : compiled_isas()) {
                if (!isa_supported(isa)) continue;
                SCOPED_TRACE(path.filename().string() + " " + isa_name(isa) + " " +
                             estimator_name(e));
                const RenderResult w = render_with(scene, "wavefront", isa_name(isa));
                EXPECT_EQ(w.stats.paths, reference.stats.paths);
                EXPECT_EQ(w.stats.rays.shadow > 0, reference.stats.rays.shadow > 0);
                const Difference d = compare(w.film, reference.film);
                for (int c = 0; c < 3; ++c) {
                    EXPECT_LT(d.mean_rel[c], 0.003) << "channel " << c;
                    EXPECT_LT(d.pixels_off[c], 0.02) << "channel " << c;
                }
            }
        }
    }
}

TEST(Agreement, EveryPixelGetsItsPathsWhateverThePoolAndTileShapes) {
    // 37 x 23 leaves edge tiles of 5 x 16, 16 x 7 and 5 x 7 pixels; a pool of 16 paths holds
    // part of one sample of a tile, a pool of 2048 several samples of it. The camera stage
    // splits path numbers into pixel and sample; every pixel must get exactly its paths, the
    // same ones (keyed by pixel and sample) whatever the pool.
    Scene scene = load_scene(CIERZO_SOURCE_DIR "/scenes/four_lobes.json");
    scene.set_resolution(37, 23);
    scene.settings.spp = 5;
    for (Isa isa : compiled_isas()) {
        if (!isa_supported(isa)) continue;
        SCOPED_TRACE(isa_name(isa));
        std::vector<Image> images;
        for (int pool : {16, 48, 512, 2048}) {
            RenderOptions o;
            o.integrator = Integrator::kWavefront;
            o.isa = isa_name(isa);
            o.threads = 1;
            o.pool_size = pool;
            o.progress = false;
            const RenderResult r = render(scene, o);
            for (int y = 0; y < r.film.height(); ++y)
                for (int x = 0; x < r.film.width(); ++x)
                    ASSERT_EQ(r.film.at(x, y).count + r.film.at(x, y).nonfinite, 5u)
                        << "pool " << pool << ", pixel " << x << ", " << y;
            images.push_back(r.film.mean());
        }
        for (size_t k = 1; k < images.size(); ++k)
            for (size_t i = 0; i < images[0].rgb.size(); ++i)
                ASSERT_NEAR(images[k].rgb[i], images[0].rgb[i], 1e-5f * (1.0f + images[0].rgb[i]))
                    << "pool index " << k << ", value " << i;
    }
}

TEST(Agreement, TexturesOnEveryKindOfHitAndLobe) {
    // Vertex colours on two coloured meshes sharing one material (the kernel takes a mesh's
    // lanes at a time), on a mesh without colours and on a sphere (both: the scale alone),
    // as emission too; a procedural ks beside textured kd, so four lobes mix textured and
    // solid channels through the lobe buckets.
    const std::string ico = "meshes/icosphere.ply";  // (beneath the scene's folder, scenes/)
    Scene scene = test::parse_report_scene(R"({
        "render": {"width": 40, "height": 40, "spp": 16},
        "camera": {"position": [0, 0, -3.5], "forward": [0, 0, 3], "left": [-1, 0, 0],
                   "up": [0, 1, 0]},
        "materials": {
            "light": {"emission": 1},
            "white": {"kd": 0.7},
            "painted": {"kd": {"texture": "vertex_weighted", "scale": 0.8},
                        "ks": {"texture": "sin", "a": 0.05, "b": 0.2, "frequency": 9},
                        "shininess": 12, "kr": 0.1},
            "nearest": {"kd": {"texture": "vertex_nearest", "scale": [0.9, 0.6, 0.3]},
                        "kt": 0.2, "ior": 1.4},
            "glow": {"emission": {"texture": "vertex_nearest", "scale": 0.5}, "kd": 0.2}},
        "objects": [
            {"type": "plane", "normal": [1, 0, 0], "distance": 1, "material": "white"},
            {"type": "plane", "normal": [-1, 0, 0], "distance": 1, "material": "white"},
            {"type": "plane", "normal": [0, 1, 0], "distance": 1, "material": "white"},
            {"type": "plane", "normal": [0, -1, 0], "distance": 1, "material": "light"},
            {"type": "plane", "normal": [0, 0, -1], "distance": 1, "material": "white"},
            {"type": "mesh", "file": ")" + ico +
                                               R"(", "scale": 0.3,
             "translate": [-0.5, -0.6, 0.2], "material": "painted"},
            {"type": "mesh", "file": ")" + ico +
                                               R"(", "scale": 0.3,
             "translate": [0.5, -0.6, 0.2], "material": "painted"},
            {"type": "sphere", "center": [0.5, 0.3, 0.3], "radius": 0.25, "material": "nearest"},
            {"type": "sphere", "center": [-0.5, 0.5, 0.5], "radius": 0.2, "material": "glow"}]})",
                                           CIERZO_SOURCE_DIR "/scenes/textures_everywhere.json");
    // A tetrahedron without vertex colours, of material "nearest"
    Mesh plain;
    plain.source = "tetrahedron";
    const Vec3f corner{-0.2f, 0.1f, 0.3f};
    plain.positions = {corner, corner + Vec3f{0.5f, 0, 0}, corner + Vec3f{0, 0.5f, 0},
                       corner + Vec3f{0, 0, 0.5f}};
    plain.indices = {0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3};
    for (size_t i = 0; i < scene.materials.size(); ++i)
        if (scene.materials[i].name == "nearest") plain.material = int32_t(i);
    scene.meshes.push_back(std::move(plain));
    scene.finalize();
    const RenderResult reference = render_with(scene, "scalar", "auto");
    for (Isa isa : compiled_isas()) {
        if (!isa_supported(isa)) continue;
        SCOPED_TRACE(isa_name(isa));
        const Difference d =
            compare(render_with(scene, "wavefront", isa_name(isa)).film, reference.film);
        for (int c = 0; c < 3; ++c) {
            EXPECT_LT(d.mean_rel[c], 0.003) << "channel " << c;
            EXPECT_LT(d.pixels_off[c], 0.02) << "channel " << c;
        }
    }
}

// The box of cornell.json around a sphere of one material with all four lobes, every colour
// channel non-zero; `scale` multiplies the channels below each lobe's max by (1 + error).
Scene mixed_scene(int lobe, float error) {
    float c[4][3] = {
        {0.30f, 0.20f, 0.25f}, {0.20f, 0.15f, 0.10f}, {0.20f, 0.10f, 0.15f}, {0.15f, 0.20f, 0.10f}};
    if (lobe >= 0)
        for (float& v : c[lobe])
            if (v < std::max({c[lobe][0], c[lobe][1], c[lobe][2]})) v *= 1.0f + error;
    // (fmt-free and appended piecewise: GCC 12 warns falsely on "[" + std::string)
    auto rgb = [](const float* v) {
        std::string out = "[";
        for (int k = 0; k < 3; ++k) out += std::to_string(v[k]) + (k < 2 ? ", " : "]");
        return out;
    };
    const std::string mat = R"({"kd": )" + rgb(c[0]) + R"(, "ks": )" + rgb(c[1]) +
                            R"(, "shininess": 20, "kr": )" + rgb(c[2]) + R"(, "kt": )" + rgb(c[3]) +
                            R"(, "ior": 1.5})";
    return test::parse_report_scene(R"({
        "render": {"width": 40, "height": 40, "spp": 16},
        "camera": {"position": [0, 0, -3.5], "forward": [0, 0, 3], "left": [-1, 0, 0],
                   "up": [0, 1, 0]},
        "materials": {"light": {"emission": 1}, "white": {"kd": 0.8},
                      "red": {"kd": [0.8, 0.1, 0.1]}, "green": {"kd": [0.1, 0.8, 0.1]}},
        "objects": [
            {"type": "plane", "normal": [1, 0, 0], "distance": 1, "material": "red"},
            {"type": "plane", "normal": [-1, 0, 0], "distance": 1, "material": "green"},
            {"type": "plane", "normal": [0, 1, 0], "distance": 1, "material": "white"},
            {"type": "plane", "normal": [0, -1, 0], "distance": 1, "material": "light"},
            {"type": "plane", "normal": [0, 0, -1], "distance": 1, "material": "white"},
            {"type": "sphere", "center": [0, -0.3, 0], "radius": 0.65, "material": )" +
                                        mat + "}]}",
                                    "/tmp/mixed.json");
}

bool differs(const Difference& d) {
    bool out = false;
    for (int c = 0; c < 3; ++c) out |= d.mean_rel[c] >= 0.003 || d.pixels_off[c] >= 0.02;
    return out;
}

TEST(Agreement, TheToleranceCatchesAFivePercentLobeError) {
    // Scaling a lobe's non-maximal channels keeps the roulette (the max RGB) and so the
    // paths, and changes only that lobe's weight: a stand-in for a 5% weight error
    const RenderResult reference = render_with(mixed_scene(-1, 0.0f), "scalar", "auto");
    EXPECT_FALSE(differs(
        compare(render_with(mixed_scene(-1, 0.0f), "wavefront", "auto").film, reference.film)));
    for (int lobe = 0; lobe < 4; ++lobe) {
        const RenderResult w = render_with(mixed_scene(lobe, 0.05f), "wavefront", "auto");
        EXPECT_TRUE(differs(compare(w.film, reference.film)))
            << "a 5% error in lobe " << lobe << " went unnoticed";
    }
}

}  // namespace
}  // namespace cierzo
