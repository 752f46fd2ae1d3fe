// The large scenes of scripts/make_scenes.py (written into the build folder by the
// generate_scenes fixture): the wavefront on every ISA against the scalar reference with
// test_agreement's tolerances (image means within 0.3%, fewer than 2% of pixels off by more
// than 2% of the mean), the same image bit for bit on one and two threads, and what
// instancing saves.
#include <gtest/gtest.h>

#include <cstring>
#include <filesystem>

#include "integrators/registry.h"
#include "integrators/render.h"
#include "integrators/wavefront/isa.h"
#include "scene/scene_json.h"

namespace cierzo {
namespace {

namespace fs = std::filesystem;

const fs::path kScenes = CIERZO_BINARY_DIR "/scenes-generated";

Scene load(const std::string& name) {
    const fs::path p = kScenes / (name + ".json");
    if (!fs::exists(p))
        throw std::runtime_error(p.string() +
                                 " is missing: the generate_scenes test writes it "
                                 "(scripts/make_scenes.py --out " +
                                 kScenes.string() + ")");
    return load_scene(p);
}

RenderResult render_with(const Scene& scene, const std::string& integrator, const std::string& isa,
                         int threads) {
    RenderOptions o;
    o.integrator = integrator_of(integrator);
    o.isa = isa;
    o.threads = threads;
    o.progress = false;
    return render(scene, o);
}

void expect_close(const Film& a, const Film& b) {
    const Image x = a.mean(), y = b.mean();
    for (int c = 0; c < 3; ++c) {
        double mx = 0, my = 0;
        for (size_t i = size_t(c); i < x.rgb.size(); i += 3) mx += x.rgb[i], my += y.rgb[i];
        mx /= double(x.rgb.size() / 3), my /= double(y.rgb.size() / 3);
        size_t off = 0;
        for (size_t i = size_t(c); i < x.rgb.size(); i += 3)
            off += std::abs(double(x.rgb[i]) - double(y.rgb[i])) > 0.02 * my + 1e-9;
        EXPECT_LT(std::abs(mx - my) / std::max(my, 1e-12), 0.003) << "channel " << c;
        EXPECT_LT(double(off) / double(x.rgb.size() / 3), 0.02) << "channel " << c;
    }
}

class Generated : public testing::TestWithParam<const char*> {};

TEST_P(Generated, WavefrontMatchesScalarOnEveryIsaAndThreadsDoNotChangeTheImage) {
    Scene scene = load(GetParam());
    scene.set_resolution(40, 40);
    scene.settings.spp = 16;
    const RenderResult reference = render_with(scene, "scalar", "auto", 2);
    EXPECT_GT(reference.stats.rays.extension, 0u);
    for (Isa isa : compiled_isas()) {
        if (!isa_supported(isa)) continue;
        SCOPED_TRACE(isa_name(isa));
        const RenderResult w = render_with(scene, "wavefront", isa_name(isa), 2);
        EXPECT_EQ(w.stats.paths, reference.stats.paths);
        expect_close(w.film, reference.film);
    }
    for (const char* integrator : {"scalar", "wavefront"}) {
        SCOPED_TRACE(integrator);
        scene.settings.spp = 4;
        const Image a = render_with(scene, integrator, "auto", 1).film.mean();
        const Image b = render_with(scene, integrator, "auto", 2).film.mean();
        ASSERT_EQ(a.rgb.size(), b.rgb.size());
        EXPECT_EQ(0, std::memcmp(a.rgb.data(), b.rgb.data(), a.rgb.size() * sizeof(float)));
    }
}

INSTANTIATE_TEST_SUITE_P(Scenes, Generated,
                         testing::Values("spheres_10", "spheres_1000", "spheres_10000", "mesh_200k",
                                         "instances_100"),
                         [](const auto& info) { return std::string(info.param); });

TEST(Generated, AHundredInstancesCostAboutOneMesh) {
    const Scene s = load("instances_100");
    size_t objects = 0, owners = 0, vertex_bytes = 0, tree_bytes = 0;
    for (const Mesh& m : s.meshes) {
        if (!m.instanced()) continue;
        ++objects;
        vertex_bytes += m.positions.size() * sizeof(Vec3f) + m.indices.size() * sizeof(uint32_t);
        if (m.bvh) ++owners, tree_bytes += m.bvh->stats().bytes;
    }
    EXPECT_GE(objects, 100u);
    EXPECT_EQ(owners, 1u);
    // The scene tree over 100 instances and the box is small beside the one mesh's own
    EXPECT_LT(s.bvh.stats().bytes, tree_bytes / 10);
    EXPECT_GT(vertex_bytes, 0u);
}

}  // namespace
}  // namespace cierzo
