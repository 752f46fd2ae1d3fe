// The pieces of paths from the lights (kernels/transport.h), against what they must invert
// or match:
//   - connect_camera is the inverse of the camera's ray generation: a point along the ray of
//     a random film position lands in that pixel, its direction is the ray's reversed, and
//     its factor is 1/(A·cos³θ·d²); points behind the camera or beside the film are refused;
//   - the pinhole's importance integrates to 1 over the film (Monte Carlo over the sphere);
//   - light starts choose emitters and point lights in proportion to their power
//     (chi-square), and their throughput is the light's power over the number of paths;
//   - importance-mode refraction: the same direction as radiance mode, the weight times
//     (η_i/η_t)² entering and leaving, unchanged under total internal reflection;
//   - the shading correction is 1 where the shading normal is the geometric one.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "kernels/transport.h"
#include "support/emitter_tests.h"
#include "support/statistics.h"

namespace cierzo {
namespace {

using test::Uniforms;

TEST(Transport, ConnectCameraInvertsRayGeneration) {
    const Scene scene = parse_scene(R"({"render": {"width": 37, "height": 23},
        "camera": {"position": [0.5, -1, -4], "look_at": [0.2, 0.1, 0], "up": [0.1, 1, 0], "vfov": 55},
        "materials": {"w": {"kd": 0.5}}, "objects": []})",
                                    "/tmp/camera.json");
    const PinholeFrame frame = scene.pinhole();
    const int w = scene.settings.width, h = scene.settings.height;
    Uniforms u;
    for (int k = 0; k < 2000; ++k) {
        const int px = int(u() * float(w)), py = int(u() * float(h));
        // (away from the pixel's edges, where rounding may pick the neighbour)
        const float sx = float(px) + 0.05f + 0.9f * u(), sy = float(py) + 0.05f + 0.9f * u();
        const Ray<float> r = scene.camera.generate(sx, sy, 1.0f / float(w), 1.0f / float(h));
        const float t = 0.1f + 20.0f * u();
        const Vec3f p = r.o + r.d * t;
        const CameraConnection<float> c = connect_camera(frame, p);
        ASSERT_TRUE(c.ok);
        ASSERT_EQ(c.pixel, py * w + px) << sx << " " << sy;
        EXPECT_NEAR(c.dist, t, 1e-4f * t);
        EXPECT_NEAR(dot(c.wc, r.d), -1.0f, 1e-5f);
        const double cos_c = dot(r.d, scene.camera.film_normal());
        const double expected =
            1.0 / (double(scene.camera.film_area()) * cos_c * cos_c * cos_c * t * t);
        EXPECT_NEAR(c.factor, expected, 1e-3 * expected);
    }
    // Behind the camera, and beside the film
    const Ray<float> centre = scene.camera.generate(18.5f, 11.5f, 1.0f / float(w), 1.0f / float(h));
    EXPECT_FALSE(connect_camera(frame, centre.o - centre.d * 2.0f).ok);
    const Ray<float> edge = scene.camera.generate(-0.5f, 11.5f, 1.0f / float(w), 1.0f / float(h));
    EXPECT_FALSE(connect_camera(frame, edge.o + edge.d * 3.0f).ok);
    EXPECT_FALSE(connect_camera(frame, Vec3f(0.5f, -1.0f, -4.0f)).ok);  // the pinhole itself
}

// ∫ over the directions through the film of We·cos θ dω = 1, with We = 1/(A·cos⁴θ): for
// uniform directions ω (pdf 1/4π), the points at distance 1 land on the film where they
// should, and their factor·d² = 1/(A·cos³θ) = We·cos θ.
TEST(Transport, PinholeImportanceIntegratesToOne) {
    const Scene scene = parse_scene(R"({"render": {"width": 30, "height": 20},
        "camera": {"position": [0, 0, 0], "look_at": [1, 0.2, 0.3], "up": [0, 1, 0], "vfov": 70},
        "materials": {"w": {"kd": 0.5}}, "objects": []})",
                                    "/tmp/camera.json");
    const PinholeFrame frame = scene.pinhole();
    std::mt19937 rng(3);
    std::normal_distribution<double> g;
    test::MeanEstimate integral;
    for (int k = 0; k < 400000; ++k) {
        Vec3f d{float(g(rng)), float(g(rng)), float(g(rng))};
        d = normalize(d);
        const CameraConnection<float> c =
            connect_camera(frame, -d);  // the point at -d sees the pinhole along d
        integral.add(c.ok ? double(c.factor) * 4.0 * M_PI : 0.0);
    }
    EXPECT_NEAR(integral.mean(), 1.0, 4 * integral.standard_error());
    EXPECT_LT(integral.standard_error(), 0.01);
}

TEST(Transport, LightStartsFollowPower) {
    // Two emitting spheres (power 2π·A·max Le: radius 0.5 with Le max 2, radius 0.25 with
    // Le 7) and two point lights (power 4π·max I: I 1 and 3)
    Scene scene =
        parse_scene(R"({"camera": {"position": [0, 0, -5], "look_at": [0, 0, 0], "vfov": 40},
        "materials": {"L": {"emission": [2, 1, 0.5]}, "M": {"emission": 7}},
        "objects": [{"type": "sphere", "center": [0, 0, 0], "radius": 0.5, "material": "L"},
                    {"type": "sphere", "center": [2, 0, 0], "radius": 0.25, "material": "M"}],
        "lights": [{"position": [0, 3, 0], "intensity": 1}, {"position": [0, -3, 0], "intensity": [3, 1, 0]}]})",
                    "/tmp/lights.json");
    const double power[4] = {2 * M_PI * (4 * M_PI * 0.25) * 2, 2 * M_PI * (4 * M_PI * 0.0625) * 7,
                             4 * M_PI * 1, 4 * M_PI * 3};
    const double total = power[0] + power[1] + power[2] + power[3];
    const EmitterTable e = scene.emitters.table();
    const LightStartTable lights = scene.light_starts.table();
    std::vector<double> observed(4, 0.0), expected(4, 0.0);
    const int n = 200000;
    for (int k = 0; k < n; ++k) {
        const LightStart<float> s = sample_light_start<float>(
            e, lights, independent_stream<float>(hash32(uint32_t(k) * 7919u)));
        ASSERT_TRUE(s.ok);
        int which;
        if (s.on_surface) {
            which = length(s.p - Vec3f(0.0f)) < 0.6f ? 0 : 1;
            // Le / (P·pdf_A) and the throughput 2π·that, P·pdf_A = power_i/total / area_i
            const double area = 4 * M_PI * (which == 0 ? 0.25 : 0.0625);
            const double le = which == 0 ? 2.0 : 7.0;
            EXPECT_NEAR(s.le.x, le * area * total / power[which], 1e-3 * s.le.x);
            EXPECT_NEAR(s.beta.x, 2 * M_PI * s.le.x, 1e-4 * s.beta.x);
            EXPECT_NEAR(
                std::abs(dot(s.n, normalize(s.p - (which == 0 ? Vec3f(0.0f) : Vec3f(2, 0, 0))))),
                1.0f, 1e-4f);
        } else {
            which = s.p.y > 0 ? 2 : 3;
            // 4π·I / P
            const double i = which == 2 ? 1.0 : 3.0;
            EXPECT_NEAR(s.beta.x, 4 * M_PI * i * total / power[which], 1e-3 * s.beta.x);
            EXPECT_EQ(s.le.x, 0.0f);
        }
        observed[size_t(which)] += 1;
    }
    for (int i = 0; i < 4; ++i) expected[size_t(i)] = n * power[i] / total;
    const auto [stat, dof] = test::chi_square(observed, expected);
    EXPECT_LT(stat, test::chi_square_critical(dof));
}

TEST(Transport, ImportanceRefractionCarriesEtaSquared) {
    Bsdf<float> m{};
    m.kt = Vec3f(0.9f, 0.8f, 0.7f);
    m.ior = 1.5f;
    const Vec3f n{0, 0, 1};
    Uniforms u;
    for (int k = 0; k < 200; ++k) {
        // Entering (d·n < 0) and leaving, at every angle
        const float z = 0.02f + 0.97f * u();
        const float phi = 6.283f * u();
        const float r = std::sqrt(1 - z * z);
        for (float side : {-1.0f, 1.0f}) {
            const Vec3f d{r * std::cos(phi), r * std::sin(phi), side * z};
            const Scatter<float> a =
                sample_refraction<Transport::kRadiance>(m, d, n, n, 1.0f, 0.5f);
            const Scatter<float> b =
                sample_refraction<Transport::kImportance>(m, d, n, n, 1.0f, 0.5f);
            ASSERT_EQ(a.dir.x, b.dir.x);
            ASSERT_EQ(a.dir.z, b.dir.z);
            const bool entering = side < 0;
            const bool tir = !entering && z * z < 1 - 1 / (1.5f * 1.5f);
            const float eta = entering ? 1.0f / 1.5f : 1.5f;  // η_i / η_t
            const float expected = tir ? 1.0f : eta * eta;
            EXPECT_NEAR(b.weight.y / a.weight.y, expected, 1e-5f * expected);
            EXPECT_NEAR(a.weight.y, 0.8f / 0.5f, 1e-6f);
        }
    }
}

TEST(Transport, ShadingCorrectionIsOneWithoutShadingNormals) {
    Uniforms u;
    const Vec3f n = normalize(Vec3f{0.2f, 0.9f, -0.1f});
    for (int k = 0; k < 100; ++k) {
        const Vec3f a = normalize(Vec3f{u() - 0.5f, u() - 0.5f, u() - 0.5f});
        const Vec3f b = normalize(Vec3f{u() - 0.5f, u() - 0.5f, u() - 0.5f});
        EXPECT_NEAR(shading_correction(a, b, n, n), 1.0f, 1e-5f);
        // and |wl·ns|·|wo·n| / (|wl·n|·|wo·ns|) with another shading normal
        const Vec3f ns = normalize(n + Vec3f(0.1f, 0.0f, 0.2f));
        const float expected = std::abs(dot(a, ns)) * std::abs(dot(b, n)) /
                               (std::abs(dot(a, n)) * std::abs(dot(b, ns)));
        EXPECT_NEAR(shading_correction(a, b, n, ns), expected, 1e-4f * expected);
    }
}

}  // namespace
}  // namespace cierzo
