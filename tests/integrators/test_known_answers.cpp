// Renders with known answers, through a whole integrator (this file is built once for the
// scalar reference and once per ISA for the wavefront): a camera inside an
// emitting sphere; a diffuse plane under a point light; a point light inside a diffuse
// sphere (multiple bounces, L = ρI/(πr²(1-ρ))); each lobe between two emitting planes
// (E[L] = lobe albedo × Le). Monte Carlo means must lie within 4 standard errors, and the
// standard error must be small enough that a 5% error would be caught.
#include <gtest/gtest.h>

#include <cmath>

#include "integrators/registry.h"
#include "integrators/render.h"
#include "integrators/scalar.h"
#include "kernels/rng.h"
#include "scene/scene_json.h"
#include "support/isa.h"
#include "support/report_scene.h"
#include "support/statistics.h"

namespace cierzo {
namespace {

Scene scene_from(const std::string& json) {
    return test::parse_report_scene(json, "/tmp/known.json");
}

// The integrator under test: this file is built once per integrator (and ISA).
#ifndef CIERZO_TEST_INTEGRATOR
#define CIERZO_TEST_INTEGRATOR "scalar"
#endif
#ifndef CIERZO_TEST_ISA
#define CIERZO_TEST_ISA "auto"
#endif
const char* g_integrator = CIERZO_TEST_INTEGRATOR;

RenderResult render_quiet(const Scene& scene, int threads = 1) {
    RenderOptions o;
    o.integrator = integrator_of(g_integrator);
    o.isa = CIERZO_TEST_ISA;
    o.threads = threads;
    o.progress = false;
    return render(scene, o);
}

// The wavefront builds of this file skip where the CPU lacks their ISA, saying what it lacks
class KnownAnswer : public testing::Test {
protected:
    void SetUp() override { CIERZO_REQUIRE_ISA(parse_isa(CIERZO_TEST_ISA)); }
};
using Determinism = KnownAnswer;

TEST_F(KnownAnswer, InsideAnEmittingSphereEveryPixelIsItsEmission) {
    const Scene scene = scene_from(R"({
        "render": {"width": 12, "height": 9, "spp": 3},
        "camera": {"position": [0.1, -0.2, 0.3], "look_at": [1, 1, 1], "vfov": 90},
        "objects": [{"type": "sphere", "center": [0, 0, 0], "radius": 2,
                     "material": {"emission": [0.25, 1.5, 3.0], "kd": 0.5}}]})");
    const Image img = render_quiet(scene).film.mean();
    for (int y = 0; y < img.height; ++y)
        for (int x = 0; x < img.width; ++x) {
            EXPECT_EQ(img.pixel(x, y)[0], 0.25f);
            EXPECT_EQ(img.pixel(x, y)[1], 1.5f);
            EXPECT_EQ(img.pixel(x, y)[2], 3.0f);
        }
}

TEST_F(KnownAnswer, DiffusePlaneUnderAPointLight) {
    // L = I·kd·cos θ / (π d²) at the point the ray hits; nothing else in the scene
    const Scene scene = scene_from(R"({
        "camera": {"position": [0, 1, -3], "look_at": [0, 0, 0]},
        "objects": [{"type": "plane", "normal": [0, 1, 0], "distance": 0,
                     "material": {"kd": [0.5, 0.25, 0.8]}}],
        "lights": [{"position": [0.5, 2, 0.3], "intensity": [3, 3, 6]}]})");
    for (Vec3f target : {Vec3f{0, 0, 0}, Vec3f{1.3f, 0, -0.4f}, Vec3f{-2, 0, 3}}) {
        const Vec3f o{0.2f, 1.5f, -3.0f};
        const Ray<float> ray{o, normalize(target - o)};
        const Vec3f to = Vec3f{0.5f, 2, 0.3f} - target;
        const float d2 = dot(to, to);
        const float cos_t = to.y / std::sqrt(d2);
        for (uint32_t key : {1u, 99u, 12345u}) {
            RayCounts rays;
            const Vec3f L = trace_path(scene, ray, key, rays);
            EXPECT_NEAR(L.x, 3 * 0.5f * cos_t / (kPi * d2), 1e-5f);
            EXPECT_NEAR(L.y, 3 * 0.25f * cos_t / (kPi * d2), 1e-5f);
            EXPECT_NEAR(L.z, 6 * 0.8f * cos_t / (kPi * d2), 1e-5f);
            EXPECT_EQ(rays.shadow, 1u);
        }
    }
}

// Mean and standard error over every sample of a render whose pixels all share one
// expected value.
void expect_image_mean(const RenderResult& r, const Vec3f& expected, double power = 0.008) {
    for (int c = 0; c < 3; ++c) {
        double sum = 0, sum_sq = 0, n = 0;
        for (int y = 0; y < r.film.height(); ++y)
            for (int x = 0; x < r.film.width(); ++x) {
                const PixelSums& p = r.film.at(x, y);
                sum += p.sum[c], sum_sq += p.sum_sq[c], n += double(p.count);
            }
        const double mean = sum / n;
        const double se = std::sqrt((sum_sq / n - mean * mean) / (n - 1));
        EXPECT_LT(se, power * expected[c]) << "channel " << c << ": test too weak";
        EXPECT_NEAR(mean, expected[c], 4.0 * se) << "channel " << c;
    }
}

TEST_F(KnownAnswer, PointLightInsideADiffuseSphereBothSamplers) {
    // Every bounce sees the same irradiance: L = ρ·I/(π r² (1 - ρ)) per channel
    const float r = 2.0f, I = 5.0f;
    const Vec3f rho{0.5f, 0.3f, 0.7f};
    for (const char* sampling : {"uniform", "cosine"}) {
        SCOPED_TRACE(sampling);
        const Scene scene = scene_from(std::string(R"({
            "render": {"width": 16, "height": 16, "spp": 1024, "seed": 3,
                       "diffuse_sampling": ")") +
                                       sampling + R"("},
            "camera": {"position": [0.3, 0.2, 0.1], "look_at": [0, 0, 1], "vfov": 120},
            "objects": [{"type": "sphere", "center": [0, 0, 0], "radius": 2,
                         "material": {"kd": [0.5, 0.3, 0.7]}}],
            "lights": [{"position": [0, 0, 0], "intensity": 5}]})");
        Vec3f expected;
        for (int c = 0; c < 3; ++c) (&expected.x)[c] = rho[c] * I / (kPi * r * r * (1.0f - rho[c]));
        expect_image_mean(render_quiet(scene, 2), expected);
    }
}

// A lobe plane y = 0 between emitting planes y = 2 (Le_top) and y = -2 (Le_bottom); the
// camera at y = 1 looks straight down through a 0.5° field of view. Every direction the
// lobe sends upwards meets the top emitter, every transmitted one the bottom emitter.
void expect_slab(const std::string& material, const Vec3f& expected) {
    const Scene scene = scene_from(R"({
        "render": {"width": 16, "height": 16, "spp": 1200, "seed": 5},
        "camera": {"position": [0, 1, 0], "look_at": [0, 0, 0], "up": [0, 0, 1], "vfov": 0.5},
        "materials": {"top": {"emission": [1, 2, 3]}, "bottom": {"emission": [3, 2, 1]}},
        "objects": [
            {"type": "plane", "normal": [0, -1, 0], "distance": 2, "material": "top"},
            {"type": "plane", "normal": [0, 1, 0], "distance": 2, "material": "bottom"},
            {"type": "plane", "normal": [0, 1, 0], "distance": 0, "material": )" +
                                   material + "}]}");
    expect_image_mean(render_quiet(scene, 2), expected);
}

const Vec3f kTop{1, 2, 3}, kBottom{3, 2, 1};

TEST_F(KnownAnswer, DiffuseLobeBetweenEmitters) {
    const Vec3f kd{0.6f, 0.4f, 0.2f};
    expect_slab(R"({"kd": [0.6, 0.4, 0.2]})", kd * kTop);
}

TEST_F(KnownAnswer, MirrorAndRefractionLobesBetweenEmitters) {
    expect_slab(R"({"kr": [0.7, 0.5, 0.3]})", Vec3f{0.7f, 0.5f, 0.3f} * kTop);
    // Transmitted paths cross the plane into the bottom emitter (the report's estimator
    // carries radiance through refraction without the η² factor)
    expect_slab(R"({"kt": [0.3, 0.5, 0.8], "ior": 1.5})", Vec3f{0.3f, 0.5f, 0.8f} * kBottom);
}

TEST_F(KnownAnswer, PhongSpecularLobeBetweenEmitters) {
    // Directions the lobe sends below the plane are lost, so E[L] = ks·A(s, θ)·Le with A
    // the lobe's directional albedo; at normal incidence and s = 20 it is
    // (s+2)/(2π)∫cos^s θ cos θ dω = (s+2)/(s+2) = 1
    expect_slab(R"({"ks": [0.6, 0.4, 0.2], "shininess": 20})", Vec3f{0.6f, 0.4f, 0.2f} * kTop);
}

TEST_F(KnownAnswer, AllLobesOnOneMaterialAddUp) {
    // kd + ks(normal incidence, albedo 1) + kr upwards, kt downwards
    const Vec3f up = Vec3f{0.2f, 0.1f, 0.1f} + Vec3f{0.1f, 0.2f, 0.1f} + Vec3f{0.1f, 0.1f, 0.2f};
    expect_slab(R"({"kd": [0.2, 0.1, 0.1], "ks": [0.1, 0.2, 0.1], "shininess": 30,
                    "kr": [0.1, 0.1, 0.2], "kt": [0.2, 0.2, 0.2], "ior": 1.3})",
                up * kTop + Vec3f(0.2f) * kBottom);
}

TEST_F(Determinism, SameImageForOneAndTwoThreads) {
    Scene scene = load_scene(CIERZO_SOURCE_DIR "/scenes/four_lobes.json");
    scene.set_resolution(40, 30);
    scene.settings.spp = 4;
    const Image a = render_quiet(scene, 1).film.mean();
    const Image b = render_quiet(scene, 2).film.mean();
    ASSERT_EQ(a.rgb.size(), b.rgb.size());
    EXPECT_EQ(0, std::memcmp(a.rgb.data(), b.rgb.data(), a.rgb.size() * sizeof(float)));
    // and a different seed gives a different image
    scene.settings.seed = 2;
    const Image c = render_quiet(scene, 2).film.mean();
    EXPECT_NE(0, std::memcmp(a.rgb.data(), c.rgb.data(), a.rgb.size() * sizeof(float)));
}

}  // namespace
}  // namespace cierzo
