// Bidirectional path tracing (--estimator bdpt) and vertex connection and merging (vcm)
// through both integrators and every ISA this CPU runs:
//   - exact answers: pbrt-v4's furnaces (src/pbrt/cpu/integrators_test.cpp): a unit sphere of
//     Kd = 0.5 seen from its centre, lit by one point light of I = π there, or by four of
//     π/4, has L = 1; pbrt's third (an emitting sphere of Le = 0.5 that also reflects) has no
//     counterpart here (an emitter ends paths), so the camera inside an emitting sphere sees
//     exactly Le instead; a point light inside a glass ball inside a diffuse room (only
//     paths from the light find it) has L = ρI/(πR²(1-ρ));
//   - the weights: along random paths (an emitting triangle or a point light, 1 to 5 Phong
//     or mirror vertices, the pinhole) the weights every strategy gives the same path sum to
//     1, and a reverse density 5% off, or a strategy left out, is seen;
//   - against mis per pixel on every scene of scenes/ (a z-test at Šidák-corrected
//     α = 0.01 passes on ≥ 99% of pixels, and the means agree within 4σ), and for each path
//     length alone (2 to 5); scalar against the wavefront on every ISA, and a pool smaller
//     than a job (several waves, the shadow queue traced as it fills) against the default;
//   - the image is the same bits for 1, 2 and 3 threads (MPI and resume: test_distributed);
//   - the light vertex cache's draws (the default) against the pairing with the sample's own
//     light subpath: each connection strategy's image the same in expectation, both
//     integrators alike for either;
//   - vcm: the furnaces and the glass ball hold for it exactly, with a large radius (on a
//     sphere the surface within distance r of a point has area π r², Archimedes' cap, so
//     merging is unbiased there: a wrong normalisation or weight shows); merging's weights
//     sum with the connections' to 1 along the random paths; it agrees with mis on every
//     scene, and its wavefront with its scalar reference; a point light's caustic seen in a
//     mirror, which no connection makes, is found, and its bias falls as the radius does.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "core/error.h"
#include "integrators/light_pilot.h"
#include "integrators/render.h"
#include "kernels/bidirectional.h"
#include "scene/scene_json.h"
#include "support/emulator.h"
#include "support/render_variants.h"

namespace cierzo {
namespace {

using test::image_mean;
using test::pixels_agreeing;
using Mean = test::ImageMean;
using test::run;
using test::Variant;
using test::variants;

Scene scene_of(const std::string& json, Estimator e, int spp, float merge_radius = 0.0f) {
    Scene s = parse_scene(json, "bdpt_test.json");
    use_estimator(s.settings.estimator, e);
    s.settings.spp = spp;
    s.settings.estimator.merge_radius = merge_radius;
    return s;
}

int spp(int native, int lighter) { return test::lighter_settings() ? lighter : native; }

// A unit sphere of Kd = 0.5 seen from its centre, with `lights` there
std::string furnace(const std::string& lights) {
    return R"({"render": {"width": 12, "height": 10, "seed": 3},
        "camera": {"position": [0, 0, 0], "look_at": [0.2, 0.1, 1], "up": [0, 1, 0], "vfov": 70},
        "materials": {"wall": {"kd": [0.5, 0.5, 0.5]}},
        "objects": [{"type": "sphere", "center": [0, 0, 0], "radius": 1, "material": "wall"}],
        "lights": [)" +
           lights + "]}";
}

TEST(Bidirectional, PbrtFurnacesHaveRadianceOne) {
    const std::string one =
        R"({"position": [0, 0, 0], "intensity": [3.14159265, 3.14159265, 3.14159265]})";
    const std::string quarter =
        R"({"position": [0, 0, 0], "intensity": [0.78539816, 0.78539816, 0.78539816]})";
    for (const std::string& lights :
         {one, quarter + "," + quarter + "," + quarter + "," + quarter}) {
        for (Estimator e : {Estimator::kBdpt, Estimator::kVcm, Estimator::kBpm, Estimator::kPpm}) {
            for (const Variant& v : variants()) {
                SCOPED_TRACE(v.integrator + " " + v.isa + " " + estimator_name(e));
                // (vcm: a radius at which merging carries most of the light; bpm and ppm: all)
                const RenderResult r = run(scene_of(furnace(lights), e, spp(1024, 128), 0.25f), v);
                const Mean m = image_mean(r.film, 1);
                std::printf("%s furnace, %s %s: %.5f ± %.5f (1)\n", estimator_name(e),
                            v.integrator.c_str(), v.isa.c_str(), m.mean, m.sigma);
                EXPECT_NEAR(m.mean, 1.0, std::max(4 * m.sigma, 0.002));
                EXPECT_LT(m.sigma,
                          (connects(e) ? 0.005 : 0.01) * (test::lighter_settings() ? 3 : 1));
                EXPECT_EQ(r.film.nonfinite_samples(), 0u);
            }
        }
    }
}

// The light vertex cache's connections count c = n / L times in the weights (L: the mean
// number of vertices a light subpath stores). In the furnace every light subpath hits the
// sphere, stores a vertex there and goes on with probability P = min(0.5, cap), so
// L = 1/(1 − P) exactly: 2, or 1/0.7 with a cap of 0.3. The pairing counts 1, as do the
// estimators that do not connect; the estimate is the same for a copy of the scene and a
// scene read again.
TEST(Bidirectional, LightVertexCacheCountsItsConnectionsAsOftenAsTheyAreMade) {
    const std::string one = R"({"position": [0, 0, 0], "intensity": [1, 1, 1]})";
    for (const auto& [cap, p] : {std::pair{0.9f, 0.5}, std::pair{0.3f, 0.3}}) {
        for (int32_t draws : {1, 3}) {
            SCOPED_TRACE("cap " + std::to_string(cap) + ", " + std::to_string(draws) + " draws");
            Scene s = scene_of(furnace(one), Estimator::kBdpt, 1);
            s.settings.estimator.survival_cap = cap;
            s.settings.estimator.light_connections = draws;
            // (the pilot's estimate is made by the integrators and kept by the scene; the
            // path context refuses to be taken without it)
            EXPECT_THROW(s.path_context(), std::logic_error);
            const double l = light_pilot(s);
            const PathContext c = s.path_context();
            // (four standard deviations of the mean of kLightPilotPaths geometric counts)
            EXPECT_NEAR(l, 1.0 / (1.0 - p),
                        4.0 * std::sqrt(p) / (1.0 - p) / std::sqrt(double(kLightPilotPaths)));
            EXPECT_FLOAT_EQ(c.connection_count, float(double(draws) / l));
            const Scene copy = s;
            EXPECT_EQ(copy.path_context().connection_count, c.connection_count);
            Scene again = scene_of(furnace(one), Estimator::kVcm, 1);
            again.settings.estimator.survival_cap = cap;
            again.settings.estimator.light_connections = draws;
            prepare_path_context(again);
            EXPECT_EQ(again.path_context().connection_count, c.connection_count);
        }
    }
    Scene s = scene_of(furnace(one), Estimator::kBdpt, 1);
    s.settings.estimator.light_connections = 0;
    EXPECT_EQ(s.path_context().connection_count, 1.0f);
    s.settings.estimator.light_connections = 2;
    s.settings.estimator.connection_count = 0.25f;
    EXPECT_EQ(s.path_context().connection_count, 0.25f);
    Scene bpm = scene_of(furnace(one), Estimator::kBpm, 1);
    EXPECT_EQ(bpm.path_context().connection_count, 1.0f);
}

TEST(Bidirectional, CameraInsideAnEmittingSphereSeesLeExactly) {
    const std::string json = R"({"render": {"width": 16, "height": 12, "seed": 2},
        "camera": {"position": [0.3, -0.2, 0.1], "look_at": [1, 0, 0], "up": [0, 1, 0], "vfov": 60},
        "materials": {"L": {"emission": [1, 2, 3]}},
        "objects": [{"type": "sphere", "center": [0, 0, 0], "radius": 2, "material": "L"}]})";
    for (const Variant& v : variants()) {
        for (Estimator e : {Estimator::kBdpt, Estimator::kVcm, Estimator::kBpm, Estimator::kPpm}) {
            SCOPED_TRACE(v.integrator + " " + v.isa + " " + estimator_name(e));
            const RenderResult r = run(scene_of(json, e, 8), v);
            for (size_t i = 0; i < r.film.pixels().size(); ++i)
                for (int c = 0; c < 3; ++c)
                    ASSERT_EQ(r.film.mean().rgb[3 * i + size_t(c)], float(c + 1));
        }
    }
}

// A closed diffuse sphere of radius 2 (albedo 0.5), a point light of intensity 1 at its
// centre inside a glass ball of radius 0.5; the camera inside, looking away from the ball.
TEST(Bidirectional, FindsAPointLightInsideAGlassBall) {
    const std::string json = R"({"render": {"width": 24, "height": 24, "seed": 7},
        "camera": {"position": [0, 0, -1.2], "forward": [0, 0, -1], "left": [-2, 0, 0], "up": [0, 2, 0]},
        "materials": {"wall": {"kd": [0.5, 0.5, 0.5]}, "glass": {"kt": [1, 1, 1], "ior": 1.5}},
        "objects": [{"type": "sphere", "center": [0, 0, 0], "radius": 2, "material": "wall"},
                    {"type": "sphere", "center": [0, 0, 0], "radius": 0.5, "material": "glass"}],
        "lights": [{"position": [0, 0, 0], "intensity": [1, 1, 1]}]})";
    const double expected = 0.5 / (M_PI * 4.0 * 0.5);
    for (const Variant& v : variants())
        for (Estimator e : {Estimator::kBdpt, Estimator::kVcm, Estimator::kBpm, Estimator::kPpm}) {
            SCOPED_TRACE(v.integrator + " " + v.isa + " " + estimator_name(e));
            const RenderResult r = run(scene_of(json, e, spp(512, 64), 0.4f), v);
            const Mean m = image_mean(r.film, 0);
            // (ppm's pixels share their photons, the tile's light paths', so its pixels are far
            // from independent and their own variances understate the mean's: its bound is the
            // relative one alone)
            if (e != Estimator::kPpm) {
                EXPECT_NEAR(m.mean, expected, std::max(4 * m.sigma, 0.002 * expected));
            }
            EXPECT_NEAR(m.mean, expected, 0.01 * expected * (test::lighter_settings() ? 4 : 1));
        }
}

// ---- The weights of every strategy of one path ----------------------------------------------

// A random path from a light to the pinhole through n Phong vertices, and the weight each
// strategy gives it, from the layer's own functions fed the path's vertices in the order
// the subpaths would reach them.
struct RandomPath {
    bool point;               // from the point light (else from the emitting triangle)
    Vec3f y0, ny0;            // the light's point (and the triangle's normal)
    std::vector<Vec3f> x, n;  // x[0] next to the light ... x[k-1] seen by the camera
    std::vector<PhongVertex<float>> phong;
    std::vector<bool> delta;  // a mirror vertex (no strategy connects or ends there)
};

const char* kWeightScene = R"({"render": {"width": 64, "height": 48, "seed": 1},
    "camera": {"position": [0, 0, -4], "look_at": [0, 0, 0], "up": [0, 1, 0], "vfov": 60},
    "materials": {"L": {"emission": [4, 4, 4]}, "w": {"kd": [0.5, 0.5, 0.5]}},
    "objects": [{"type": "triangle", "vertices": [[-0.5, 1.2, -0.5], [0.5, 1.2, -0.5], [0, 1.2, 0.6]],
                 "material": "L"},
                {"type": "sphere", "center": [0, -40, 0], "radius": 1, "material": "w"}],
    "lights": [{"position": [0.3, 0.9, 0.2], "intensity": [2, 2, 2]}]})";

// Sums the weights of every strategy of `path` (each taken out if `drop` names it: s; -2
// takes out merging), with merging's quantities mw (0: bdpt, no merging).
double weight_sum(const Scene& scene, const PathContext& c, const RandomPath& path, int drop = -1,
                  const MergeWeights<float>& mw = {}) {
    const LightStartTable lights = scene.light_starts.table();
    const PinholeFrame pin = scene.pinhole();
    const Vec3f cam{pin.origin[0], pin.origin[1], pin.origin[2]};
    const int k = int(path.x.size());
    const bool cosine = c.estimator.cosine_diffuse;
    // Vertex i's frame on the side of the vertex before it in the camera's order (i + 1, or
    // the camera) and of the one after (i - 1, or the light): both are on one side
    const auto frame = [&](int i) {
        VertexFrame<float> v;
        v.nf = v.nsf = path.n[size_t(i)];
        return v;
    };
    const auto toward_light = [&](int i) { return i == 0 ? path.y0 : path.x[size_t(i - 1)]; };
    const auto toward_camera = [&](int i) { return i == k - 1 ? cam : path.x[size_t(i + 1)]; };
    // The light subpath's quantities at x[0..s-2] (s - 1 vertices), as it reaches each
    LightStart<float> start;
    start.on_surface = !path.point;
    start.emitter = path.point ? -1 : 0;
    Vec3f d0 = normalize(path.x[0] - path.y0);
    start.cos_light = path.point ? 1.0f : std::abs(dot(d0, path.ny0));
    start.pdf_emit = path.point
                         ? lights.point_source[3] * (0.25f * kInvPi)
                         : lights.emitter_probability * emitter_position_pdf<float>(c.emitters, 0) *
                               start.cos_light * (0.5f * kInvPi);
    std::vector<SubpathMis<float>> light_at(static_cast<size_t>(k));
    SubpathMis<float> m = light_start_mis(c, start, mw);
    for (int i = 0; i < k; ++i) {
        const Vec3f from = toward_light(i);
        const float t = length(path.x[size_t(i)] - from);
        const Vec3f d = (path.x[size_t(i)] - from) * (1.0f / t);
        const float direct =
            i == 0 ? start_direct_pdf_area<float>(c, start, path.x[0], d, t) : 1.0f;
        mis_at_hit(m, t, std::abs(dot(d, path.n[size_t(i)])), direct);
        light_at[size_t(i)] = m;
        const Vec3f out = normalize(toward_camera(i) - path.x[size_t(i)]);
        mis_after_lobe<float>(c, m, path.delta[size_t(i)] ? kLobeMirror : kLobeDiffuse,
                              path.phong[size_t(i)], frame(i), d, out, mw);
    }
    // The camera subpath's, at x[k-1] down to x[0]
    std::vector<SubpathMis<float>> camera_at(static_cast<size_t>(k));
    m = camera_start_mis(c, pin, normalize(path.x[size_t(k - 1)] - cam));
    for (int i = k - 1; i >= 0; --i) {
        const Vec3f from = toward_camera(i);
        const float t = length(path.x[size_t(i)] - from);
        const Vec3f d = (path.x[size_t(i)] - from) * (1.0f / t);
        mis_at_hit(m, t, std::abs(dot(d, path.n[size_t(i)])));
        camera_at[size_t(i)] = m;
        const Vec3f out = normalize(toward_light(i) - path.x[size_t(i)]);
        mis_after_lobe<float>(c, m, path.delta[size_t(i)] ? kLobeMirror : kLobeDiffuse,
                              path.phong[size_t(i)], frame(i), d, out, mw);
    }
    const auto camera_vertex = [&](int i) {
        const Vec3f wo = normalize(toward_camera(i) - path.x[size_t(i)]);
        return CameraVertex<float>{
            path.x[size_t(i)], path.n[size_t(i)],     path.n[size_t(i)],    wo,
            path.x[size_t(i)], path.phong[size_t(i)], camera_at[size_t(i)], uint32_t(k - i + 1)};
    };
    const auto light_vertex = [&](int i) {
        const Vec3f wl = normalize(toward_light(i) - path.x[size_t(i)]);
        return LightVertex<float>{
            path.x[size_t(i)], path.n[size_t(i)],     path.n[size_t(i)],   wl,
            Vec3f(1.0f),       path.phong[size_t(i)], light_at[size_t(i)], 1.0f,
            uint32_t(i + 1)};
    };
    double sum = 0.0;
    const bool connecting = connects(c.estimator.kind);
    // s = 0: the camera subpath hits the triangle
    if (!path.point && drop != 0) {
        const Vec3f from = path.x[0];
        const float t = length(path.y0 - from);
        const Vec3f d = (path.y0 - from) * (1.0f / t);
        SubpathMis<float> at_light = m;  // (after x[0]'s scattering towards y0)
        const float cos_l = std::abs(dot(d, path.ny0));
        mis_at_hit(at_light, t, cos_l);
        sum += emitter_hit_mis<float>(c, lights, at_light, 0, from, d, t, cos_l, uint32_t(k + 2));
    }
    // s = 1: x[0] samples the light
    if (connecting && drop != 1 && !path.delta[0]) {
        const CameraVertex<float> v = camera_vertex(0);
        const Vec3f to = path.y0 - path.x[0];
        const float d2 = dot(to, to);
        const Vec3f wi = to * (1.0f / std::sqrt(d2));
        const BsdfEval<float> b = phong_eval(v.phong, v.wo, v.nsf, wi, cosine);
        if (path.point) {
            sum += point_light_mis(c, lights, 0, v, mw, b, wi, d2);
        } else {
            const float light_pdf = emitter_pdf<float>(c.emitters, 0, path.x[0], wi, std::sqrt(d2),
                                                       c.estimator.triangle_solid_angle);
            sum += emitter_sample_mis(c, lights, v, mw, b, wi, light_pdf, 0, false);
        }
    }
    // s = 2 .. k: light vertex x[s-2] connected to camera vertex x[s-1]
    for (int s = 2; connecting && s <= k; ++s) {
        if (drop == s || path.delta[size_t(s - 2)] || path.delta[size_t(s - 1)]) continue;
        const CameraVertex<float> v = camera_vertex(s - 1);
        const LightVertex<float> l = light_vertex(s - 2);
        const Vec3f to = l.p - v.p;
        const float d2 = dot(to, to);
        const Vec3f w = to * (1.0f / std::sqrt(d2));
        const BsdfEval<float> bc = phong_eval(v.phong, v.wo, v.nsf, w, cosine);
        const BsdfEval<float> bl = phong_eval(l.phong, l.wl, l.nsf, -w, cosine);
        sum += connection_mis(c, v, l, mw, bc, bl, w, d2);
    }
    // t = 1: x[k-1] seen by the pinhole
    if (connecting && drop != k + 1 && !path.delta[size_t(k - 1)]) {
        const CameraConnection<float> cc = connect_camera(pin, path.x[size_t(k - 1)]);
        EXPECT_TRUE(cc.ok);
        sum += camera_connection_mis(c, light_vertex(k - 1), cc, mw);
    }
    // vcm, bpm: each Phong vertex where both subpaths arrive, merged (-3 - i: that one
    // left out)
    if (mw.vm_weight > 0.0f && drop != -2)
        for (int i = 0; i < k; ++i) {
            if (path.delta[size_t(i)] || drop == -3 - i) continue;
            const CameraVertex<float> v = camera_vertex(i);
            const LightVertex<float> l = light_vertex(i);
            sum += merge_mis(c, v, l, mw, phong_eval(v.phong, v.wo, v.nsf, l.wl, cosine));
        }
    return sum;
}

// Random paths whose every vertex faces both its neighbours, in the camera's view.
std::vector<RandomPath> random_paths(std::mt19937& rng, bool point, bool mirrors, int count) {
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    std::vector<RandomPath> paths;
    while (int(paths.size()) < count) {
        RandomPath p;
        p.point = point;
        const float a = u(rng), b = u(rng);
        const float sa = std::sqrt(a);
        // (the triangle of kWeightScene, uniformly; its normal (0, ±1, 0))
        p.y0 = point ? Vec3f{0.3f, 0.9f, 0.2f}
                     : Vec3f{-0.5f, 1.2f, -0.5f} * (1 - sa) +
                           Vec3f{0.5f, 1.2f, -0.5f} * (sa * (1 - b)) +
                           Vec3f{0.0f, 1.2f, 0.6f} * (sa * b);
        p.ny0 = {0.0f, -1.0f, 0.0f};
        const int k = 1 + int(u(rng) * 5.0f);
        for (int i = 0; i < k; ++i)
            p.x.push_back({2.4f * u(rng) - 1.2f, 1.8f * u(rng) - 1.0f, 2.0f * u(rng) - 1.0f});
        p.n.resize(size_t(k));
        bool ok = point || p.x[0].y < 1.15f;
        for (int i = 0; i < k && ok; ++i) {
            const Vec3f prev = i == 0 ? p.y0 : p.x[size_t(i - 1)];
            const Vec3f next = i == k - 1 ? Vec3f{0.0f, 0.0f, -4.0f} : p.x[size_t(i + 1)];
            const Vec3f a1 = normalize(prev - p.x[size_t(i)]),
                        a2 = normalize(next - p.x[size_t(i)]);
            const Vec3f jitter{u(rng) - 0.5f, u(rng) - 0.5f, u(rng) - 0.5f};
            // (a mirror's normal halves the angle: its two directions reflect each other)
            p.delta.push_back(mirrors && u(rng) < 0.3f);
            p.n[size_t(i)] = normalize(a1 + a2 + (p.delta.back() ? Vec3f(0.0f) : jitter * 0.5f));
            ok = dot(a1, p.n[size_t(i)]) > 0.05f && dot(a2, p.n[size_t(i)]) > 0.05f;
            const float kd = 0.2f + 0.6f * u(rng), ks = u(rng) < 0.5f ? 0.0f : 0.3f * u(rng);
            Bsdf<float> m{Vec3f(kd), Vec3f(ks), Vec3f(0.0f), Vec3f(0.0f), 1.0f + 60.0f * u(rng),
                          1.0f};
            p.phong.push_back(phong_vertex(m, 0.9f));
        }
        if (ok) paths.push_back(p);
    }
    return paths;
}

TEST(Bidirectional, WeightsOfEveryStrategyOfAPathSumToOne) {
    Scene scene = scene_of(kWeightScene, Estimator::kBdpt, 1);
    prepare_path_context(scene);
    std::mt19937 rng(17);
    // The pairing (each connection made once), and the light vertex cache's connections
    // made fewer or more times than the other strategies (PathContext::connection_count)
    for (float count : {1.0f, 0.37f, 3.1f}) {
        // bdpt, and vcm with η = π r² N small and large (merging weak and strong)
        for (double eta : {0.0, 0.05, 20.0}) {
            const MergeWeights<float> mw =
                eta == 0.0 ? MergeWeights<float>{}
                           : merge_weights(float(std::sqrt(eta / (M_PI * 256.0))), 0.75f, 0, 256,
                                           256, true, count);
            for (bool point : {false, true}) {
                for (bool solid_angle : {true, false}) {
                    for (bool mirrors : {false, true}) {
                        scene.settings.estimator.triangle_solid_angle = solid_angle;
                        PathContext c = scene.path_context();
                        c.connection_count = count;
                        int planted = 0, dropped = 0, merge_dropped = 0, n = 0;
                        for (const RandomPath& p : random_paths(rng, point, mirrors, 300)) {
                            SCOPED_TRACE(std::string(point ? "point light" : "triangle") + ", " +
                                         std::to_string(p.x.size()) + " vertices");
                            // (from a point light, a path whose every strategy ends on a mirror has
                            // none)
                            const double sum = weight_sum(scene, c, p, -1, mw);
                            if (sum == 0.0 && point) continue;
                            EXPECT_NEAR(sum, 1.0, 2e-4)
                                << "eta " << eta << ", connections made " << count;
                            PathContext wrong = c;
                            wrong.estimator.reverse_pdf_scale = 1.05f;
                            planted += std::abs(weight_sum(scene, wrong, p, -1, mw) - 1.0) > 1e-3;
                            dropped += std::abs(weight_sum(scene, c, p, int(p.x.size()) + 1, mw) -
                                                1.0) > 1e-3;
                            if (eta > 0.0)
                                merge_dropped +=
                                    std::abs(weight_sum(scene, c, p, -2, mw) - 1.0) > 1e-3;
                            ++n;
                        }
                        // A 5% error in every reverse density, and the pinhole's strategy left out,
                        // are seen along most paths (a path of one vertex has no reverse density to
                        // weigh)
                        EXPECT_GT(planted, n / 3);
                        if (eta < 1.0) {
                            EXPECT_GT(dropped, n / 2);
                        }
                        // (merging left out: seen where it is strong)
                        if (eta > 1.0) {
                            EXPECT_GT(merge_dropped, n / 2);
                        }
                    }
                }
            }
        }
    }
}

// bpm: merging at every Phong vertex, weighed against merging alone, and the emitter hit
// where the camera came only through mirrors: the weights of a path's strategies sum to 1
// (a path from the point light through mirrors alone has none); a 5% error in the reverse
// densities, and one vertex's merge left out, are seen.
TEST(Bidirectional, BpmWeightsOfEveryMergeOfAPathSumToOne) {
    Scene scene = scene_of(kWeightScene, Estimator::kBpm, 1);
    std::mt19937 rng(29);
    for (double eta : {0.05, 20.0}) {
        const MergeWeights<float> mw =
            merge_weights(float(std::sqrt(eta / (M_PI * 256.0))), 0.75f, 0, 256, 256, false);
        EXPECT_EQ(mw.vc_weight, 0.0f);
        for (bool point : {false, true})
            for (bool mirrors : {false, true}) {
                const PathContext c = scene.path_context();
                int planted = 0, dropped = 0, n = 0;
                for (const RandomPath& p : random_paths(rng, point, mirrors, 300)) {
                    SCOPED_TRACE(std::string(point ? "point light" : "triangle") + ", " +
                                 std::to_string(p.x.size()) + " vertices");
                    const double sum = weight_sum(scene, c, p, -1, mw);
                    if (sum == 0.0 && point) continue;
                    EXPECT_NEAR(sum, 1.0, 2e-4) << "eta " << eta;
                    int phong = 0;
                    for (bool d : p.delta) phong += !d;
                    if (phong < 2) continue;
                    PathContext wrong = c;
                    wrong.estimator.reverse_pdf_scale = 1.05f;
                    planted += std::abs(weight_sum(scene, wrong, p, -1, mw) - 1.0) > 1e-3;
                    const int first =
                        int(std::find(p.delta.begin(), p.delta.end(), false) - p.delta.begin());
                    dropped += std::abs(weight_sum(scene, c, p, -3 - first, mw) - 1.0) > 1e-3;
                    ++n;
                }
                EXPECT_GT(n, 20);
                EXPECT_GT(planted, n / 2);
                EXPECT_GT(dropped, n / 2);
            }
    }
}

// ---- Against mis, and scalar against wavefront --------------------------------------------

// `e` at n paths per pixel against mis at 4n on every scene of scenes/, per pixel and in
// mean (within 4σ, plus `bias` of the mean: vcm's blur).
void expect_agreement_with_mis_on_every_scene(Estimator e, int n, uint32_t seed, double bias) {
    for (const auto& path : test::scenes_to_render()) {
        Scene scene = load_scene(path);
        SCOPED_TRACE(path.filename().string());
        scene.settings.width = 24, scene.settings.height = 20;
        Scene mis = scene, other = scene;
        use_estimator(mis.settings.estimator, Estimator::kMis);
        mis.settings.spp = 4 * n;
        use_estimator(other.settings.estimator, e);
        // (vcm at a fifth of its default radius: its blur, the bias, stays far below the
        // noise)
        if (merges(e)) other.settings.estimator.merge_radius = 0.2f * other.merge_radius();
        other.settings.spp = n;
        other.settings.seed = scene.settings.seed + seed;
        const RenderResult a = run(mis, variants().back()), b = run(other, variants().back());
        const double share = pixels_agreeing(a.film, b.film);
        std::printf("%-22s %s vs mis: %.2f%% of pixels agree\n", path.filename().c_str(),
                    estimator_name(e), 100 * share);
        EXPECT_GE(share, 0.99);
        for (int c = 0; c < 3; ++c) {
            const Mean x = image_mean(a.film, c), y = image_mean(b.film, c);
            EXPECT_NEAR(x.mean, y.mean, 4 * std::hypot(x.sigma, y.sigma) + bias * x.mean)
                << "channel " << c;
        }
        EXPECT_EQ(b.film.nonfinite_samples(), 0u);
    }
}

TEST(Bidirectional, AgreesWithMisOnEveryScene) {
    expect_agreement_with_mis_on_every_scene(Estimator::kBdpt, spp(512, 96), 101, 0.0);
}

// vcm agrees with mis as bdpt does (its bias, a blur of the radius, within 1% of the mean).
TEST(Bidirectional, VcmAgreesWithMisOnEveryScene) {
    // (the lighter settings' 128 paths: at 64, hard_shadow's shadow edge failed the z-test on
    // 1.1% of its pixels at the default radius and at a fifth of it alike)
    expect_agreement_with_mis_on_every_scene(Estimator::kVcm, spp(384, 128), 202, 0.01);
}

// bpm and ppm (merging alone, with neither next-event estimation nor connections: noisier,
// and their error's tails too heavy for a per-pixel z-test at these counts) agree with mis
// in the image's mean on every scene, at a fifth of the default radius, within 4σ and 1.5%
// of the mean for the blur.
TEST(Bidirectional, BpmAndPpmAgreeWithMisInMeanOnEveryScene) {
    const int n = spp(256, 64);
    for (const auto& path : test::scenes_to_render()) {
        Scene scene = load_scene(path);
        SCOPED_TRACE(path.filename().string());
        scene.settings.width = 24, scene.settings.height = 20;
        Scene mis = scene;
        use_estimator(mis.settings.estimator, Estimator::kMis);
        mis.settings.spp = (test::lighter_settings() ? 2 : 4) * n;  // (sigma counts it)
        const RenderResult a = run(mis, variants().back());
        for (Estimator e : {Estimator::kBpm, Estimator::kPpm}) {
            Scene other = scene;
            use_estimator(other.settings.estimator, e);
            other.settings.estimator.merge_radius = 0.2f * other.merge_radius();
            other.settings.spp = n;
            other.settings.seed = scene.settings.seed + 303;
            const RenderResult b = run(other, variants().back());
            for (int c = 0; c < 3; ++c) {
                const Mean x = image_mean(a.film, c), y = image_mean(b.film, c);
                std::printf("%-22s %s channel %d: %.5f ± %.5f, mis %.5f ± %.5f\n",
                            path.filename().c_str(), estimator_name(e), c, y.mean, y.sigma, x.mean,
                            x.sigma);
                EXPECT_NEAR(x.mean, y.mean, 4 * std::hypot(x.sigma, y.sigma) + 0.015 * x.mean)
                    << estimator_name(e) << " channel " << c;
            }
            EXPECT_EQ(b.film.nonfinite_samples(), 0u);
        }
    }
}

// A point light inside a glass ball over a floor, seen in a mirror (kr = 1): every path
// from the camera through the mirror is specular, diffuse, specular (the light is seen only
// through glass), which no connection makes. The mirror's image is the world reflected, so
// the scene equals the unfolded one: ball and light copied across the mirror's plane and no
// mirror, where the same floor is seen directly (connections make it). vcm in the mirror
// scene agrees with bdpt in the unfolded one; bdpt in the mirror scene misses most light.
TEST(Bidirectional, VcmFindsACausticSeenInAMirror) {
    const std::string head = R"({"render": {"width": 32, "height": 24, "seed": 5},
        "camera": {"position": [0.2, 1.5, -1.0], "look_at": [-2.0, -1.0, -0.5], "up": [0, 1, 0], "vfov": 35},
        "materials": {"floor": {"kd": [0.7, 0.7, 0.7]}, "glass": {"kt": [1, 1, 1], "ior": 1.5},
                      "mirror": {"kr": [1, 1, 1]}},
        "objects": [{"type": "plane", "normal": [0, 1, 0], "distance": 1, "material": "floor"},
                    {"type": "sphere", "center": [0, 0, 0], "radius": 0.3, "material": "glass"},)";
    const std::string light = R"({"position": [0, 0, 0], "intensity": [2, 2, 2]})";
    const std::string mirror =
        head +
        R"({"type": "plane", "normal": [1, 0, 0], "distance": 1.2, "material": "mirror"}],
        "lights": [)" +
        light + "]}";
    const std::string unfolded =
        head +
        R"({"type": "sphere", "center": [-2.4, 0, 0], "radius": 0.3, "material": "glass"}],
        "lights": [)" +
        light + R"(, {"position": [-2.4, 0, 0], "intensity": [2, 2, 2]}]})";
    const Variant v = variants().back();
    const RenderResult reference = run(scene_of(unfolded, Estimator::kBdpt, spp(1024, 256)), v);
    const RenderResult vcm = run(scene_of(mirror, Estimator::kVcm, spp(1024, 256), 0.1f), v);
    const RenderResult bdpt = run(scene_of(mirror, Estimator::kBdpt, spp(256, 64)), v);
    const Mean r = image_mean(reference.film, 1), m = image_mean(vcm.film, 1),
               b = image_mean(bdpt.film, 1);
    std::printf("caustic in a mirror: vcm %.5f ± %.5f, unfolded bdpt %.5f ± %.5f, bdpt %.5f\n",
                m.mean, m.sigma, r.mean, r.sigma, b.mean);
    // (merging's blur loses a little light at the floor's edge against the mirror)
    EXPECT_NEAR(m.mean, r.mean, 4 * std::hypot(m.sigma, r.sigma) + 0.02 * r.mean);
    EXPECT_LT(b.mean, 0.5 * r.mean);
    EXPECT_EQ(vcm.film.nonfinite_samples(), 0u);
    // bpm and ppm, merging alone, find it as vcm does
    for (Estimator e : {Estimator::kBpm, Estimator::kPpm}) {
        const RenderResult x = run(scene_of(mirror, e, spp(1024, 256), 0.1f), v);
        const Mean xm = image_mean(x.film, 1);
        std::printf("caustic in a mirror: %s %.5f ± %.5f\n", estimator_name(e), xm.mean, xm.sigma);
        EXPECT_NEAR(xm.mean, r.mean, 4 * std::hypot(xm.sigma, r.sigma) + 0.02 * r.mean)
            << estimator_name(e);
        EXPECT_EQ(x.film.nonfinite_samples(), 0u);
    }
}

// Glossy and diffuse surfaces, a glass ball, an emitting sphere, an emitting square of two
// triangles and a point light: every strategy has paths to weigh.
const char* kBox = R"({"render": {"width": 20, "height": 16, "seed": 11},
    "camera": {"position": [0, 0, -3.2], "look_at": [0, 0, 0], "up": [0, 1, 0], "vfov": 50},
    "materials": {"white": {"kd": [0.7, 0.7, 0.7]}, "red": {"kd": [0.7, 0.15, 0.1]},
                  "gloss": {"kd": [0.2, 0.4, 0.6], "ks": [0.3, 0.3, 0.3], "shininess": 20},
                  "glass": {"kt": [0.9, 0.9, 0.9], "ior": 1.5},
                  "L": {"emission": [6, 5, 4]}, "Q": {"emission": [3, 3, 5]}},
    "objects": [
      {"type": "plane", "normal": [0, 1, 0], "distance": 1, "material": "white"},
      {"type": "plane", "normal": [0, -1, 0], "distance": 1, "material": "white"},
      {"type": "plane", "normal": [1, 0, 0], "distance": 1, "material": "red"},
      {"type": "plane", "normal": [-1, 0, 0], "distance": 1, "material": "gloss"},
      {"type": "plane", "normal": [0, 0, -1], "distance": 1, "material": "white"},
      {"type": "plane", "normal": [0, 0, 1], "distance": 3.5, "material": "white"},
      {"type": "sphere", "center": [0.4, -0.6, 0.2], "radius": 0.4, "material": "gloss"},
      {"type": "sphere", "center": [-0.4, -0.65, -0.3], "radius": 0.3, "material": "glass"},
      {"type": "sphere", "center": [-0.5, 0.6, 0.3], "radius": 0.15, "material": "L"},
      {"type": "triangle", "vertices": [[0.2, 0.99, -0.2], [0.6, 0.99, -0.2], [0.6, 0.99, 0.2]],
       "material": "Q"},
      {"type": "triangle", "vertices": [[0.2, 0.99, -0.2], [0.6, 0.99, 0.2], [0.2, 0.99, 0.2]],
       "material": "Q"}],
    "lights": [{"position": [-0.3, 0.2, -0.5], "intensity": [0.3, 0.3, 0.2]}]})";

// kBox without its point light, and without the glass ball (`glass` false).
std::string box_without_point_light(bool glass) {
    std::string json = kBox;
    json.erase(json.find(R"(,
    "lights")"),
               std::string::npos);
    json += "}";
    const std::string ball = R"(
      {"type": "sphere", "center": [-0.4, -0.65, -0.3], "radius": 0.3, "material": "glass"},)";
    if (!glass) json.erase(json.find(ball), ball.size());
    return json;
}

TEST(Bidirectional, ScalarAndWavefrontAgree) {
    Scene s = scene_of(kBox, Estimator::kBdpt, spp(256, 48));
    test::expect_wavefront_agrees(s, "bdpt box");
    s.settings.estimator.triangle_solid_angle = false;
    s.settings.estimator.cosine_diffuse = false;
    s.settings.seed = 5;
    test::expect_wavefront_agrees(s, "bdpt box, area and uniform sampling");
    test::expect_wavefront_agrees(scene_of(kBox, Estimator::kVcm, spp(256, 48), 0.1f), "vcm box");
    // (both ways of connecting: every vertex of the sample's own light subpath, and draws from
    // the light vertex cache)
    for (int32_t draws : {0, 3}) {
        Scene d = scene_of(kBox, Estimator::kBdpt, spp(256, 48));
        d.settings.estimator.light_connections = draws;
        d.settings.seed = 6;
        test::expect_wavefront_agrees(d, "bdpt box, light_connections " + std::to_string(draws));
        Scene m = scene_of(kBox, Estimator::kVcm, spp(256, 48), 0.1f);
        m.settings.estimator.light_connections = draws;
        test::expect_wavefront_agrees(m, "vcm box, light_connections " + std::to_string(draws));
    }
    test::expect_wavefront_agrees(scene_of(kBox, Estimator::kBpm, spp(256, 48), 0.1f), "bpm box");
    test::expect_wavefront_agrees(scene_of(kBox, Estimator::kPpm, spp(256, 48), 0.1f), "ppm box");
}

// The light vertex cache (light_connections n ≥ 1) against the pairing (0, every vertex of
// the sample's own light subpath): each connection strategy's weighted image, alone, is the
// same in expectation, per pixel and in mean, for 1 and 3 draws (a draw's count V/(N·n)
// wrong by 5% shows: four standard deviations of the means' difference are below 2.5% of
// the mean, checked). Both weigh a connection as made once (EstimatorSettings::
// connection_count 1; the cache's own count, n over the light subpaths' mean number of
// vertices, changes its weights: WeightsOfEveryStrategyOfAPathSumToOne checks them with
// other counts, and the whole estimator's agreement with mis checks its own).
TEST(Bidirectional, LightVertexCacheAgreesWithThePairing) {
    // (the lighter settings, under sanitizers and emulation: a sixteenth of the paths, the
    // same tests at less resolution)
    const int n = spp(1024, 64);
    const Variant v = variants().back();
    for (const auto& [s, t] : {std::pair{2, 2}, std::pair{3, 2}, std::pair{2, 3}}) {
        Scene pairing = scene_of(kBox, Estimator::kBdpt, n);
        pairing.settings.width = spp(40, 20), pairing.settings.height = spp(32, 16);
        pairing.settings.estimator.light_connections = 0;
        pairing.settings.estimator.strategy_s = s, pairing.settings.estimator.strategy_t = t;
        pairing.settings.estimator.connection_count = 1.0f;
        const RenderResult a = run(pairing, v);
        for (int32_t draws : {1, 3}) {
            SCOPED_TRACE("strategy s=" + std::to_string(s) + " t=" + std::to_string(t) + ", " +
                         std::to_string(draws) + " draws");
            Scene cached = pairing;
            cached.settings.estimator.light_connections = draws;
            cached.settings.seed = 40 + uint32_t(draws);
            const RenderResult b = run(cached, v);
            EXPECT_GE(pixels_agreeing(a.film, b.film), 0.99);
            for (int c = 0; c < 3; ++c) {
                const Mean x = image_mean(a.film, c), y = image_mean(b.film, c);
                std::printf("s=%d t=%d, %d draws, channel %d: %.5f ± %.5f (pairing %.5f ± %.5f)\n",
                            s, t, draws, c, y.mean, y.sigma, x.mean, x.sigma);
                ASSERT_GT(x.mean, 0.0);
                EXPECT_NEAR(x.mean, y.mean, 4 * std::hypot(x.sigma, y.sigma)) << "channel " << c;
                // (the lighter settings' fewer paths resolve less)
                if (!test::lighter_settings()) {
                    EXPECT_LT(4 * std::hypot(x.sigma, y.sigma), 0.025 * x.mean) << "channel " << c;
                }
            }
            EXPECT_EQ(b.film.nonfinite_samples(), 0u);
        }
    }
}

// Each band of path lengths alone agrees with mis's. (Without the point light: it shines
// through the glass ball onto the floor, a caustic camera paths cannot find, which bdpt
// does: mis's image is short of it; FindsAPointLightInsideAGlassBall checks that light.)
TEST(Bidirectional, EachPathLengthAgreesWithMis) {
    const int n = spp(1024, 128);
    const Variant v = variants().back();
    const std::string json = box_without_point_light(true);
    for (int length : {2, 3, 4, 5}) {
        SCOPED_TRACE("length " + std::to_string(length));
        Scene mis = scene_of(json, Estimator::kMis, 4 * n),
              bdpt = scene_of(json, Estimator::kBdpt, n);
        for (Scene* s : {&mis, &bdpt})
            s->settings.estimator.min_length = s->settings.estimator.max_length = length;
        bdpt.settings.seed = 12;
        const RenderResult a = run(mis, v), b = run(bdpt, v);
        EXPECT_GE(pixels_agreeing(a.film, b.film), 0.99);
        for (int c = 0; c < 3; ++c) {
            const Mean x = image_mean(a.film, c), y = image_mean(b.film, c);
            EXPECT_NEAR(x.mean, y.mean, 4 * std::hypot(x.sigma, y.sigma)) << "channel " << c;
        }
    }
}

// The strategies of one length: their weighted images add up to the whole image of that
// length, and each strategy alone (unweighted) is an unbiased image of the paths it makes,
// the same as mis's where it makes all of them (kBox without its point light and glass:
// every strategy there can make every path of Phong vertices).
TEST(Bidirectional, EachStrategyAloneConvergesToTheSameImage) {
    const int n = spp(1024, 128);
    const Variant v = variants().back();
    const std::string json = box_without_point_light(false);
    const int length = 3;
    Scene base = scene_of(json, Estimator::kBdpt, n);
    base.settings.estimator.min_length = base.settings.estimator.max_length = length;
    Scene mis = scene_of(json, Estimator::kMis, 4 * n);
    mis.settings.estimator.min_length = mis.settings.estimator.max_length = length;
    mis.settings.seed = 77;
    const RenderResult whole = run(base, v), reference = run(mis, v);
    std::vector<double> sum(whole.film.mean().rgb.size(), 0.0);
    for (int s = 0; s <= length; ++s) {
        const int t = length + 1 - s;
        SCOPED_TRACE("strategy s=" + std::to_string(s) + " t=" + std::to_string(t));
        Scene weighted = base;
        weighted.settings.estimator.strategy_s = s, weighted.settings.estimator.strategy_t = t;
        const Image w = run(weighted, v).film.mean();
        for (size_t i = 0; i < sum.size(); ++i) sum[i] += w.rgb[i];
        Scene alone = weighted;
        alone.settings.estimator.unweighted = true;
        alone.settings.seed = 1000 + uint32_t(s);
        // (the image mean: a strategy alone has heavy tails where it is poor, which a
        // pixel's own variance estimate does not show)
        const RenderResult a = run(alone, v);
        for (int c = 0; c < 3; ++c) {
            const Mean x = image_mean(a.film, c), y = image_mean(reference.film, c);
            std::printf("length %d, s=%d t=%d alone, channel %d: %.5f ± %.5f (mis %.5f ± %.5f)\n",
                        length, s, t, c, x.mean, x.sigma, y.mean, y.sigma);
            EXPECT_NEAR(x.mean, y.mean, 4 * std::hypot(x.sigma, y.sigma)) << "channel " << c;
        }
    }
    // (the same paths with the same numbers: the sum differs from the whole by rounding)
    const Image all = whole.film.mean();
    for (size_t i = 0; i < sum.size(); ++i)
        ASSERT_NEAR(sum[i], all.rgb[i], 1e-5 + 1e-4 * std::abs(all.rgb[i])) << "value " << i;
    // A strategy left out is missed
    double dropped = 0, total = 0;
    for (size_t i = 0; i < sum.size(); ++i) total += all.rgb[i];
    Scene one = base;
    one.settings.estimator.strategy_s = 2, one.settings.estimator.strategy_t = 2;
    const Image two = run(one, v).film.mean();
    for (size_t i = 0; i < sum.size(); ++i) dropped += two.rgb[i];
    EXPECT_GT(dropped, 0.05 * total);
}

// The strategy images of one render (RenderOptions::strategies, `--strategies DIR`): each
// is, weighted and unweighted, the image of a render that keeps that strategy alone
// (--strategy S,T [--unweighted]) to rounding, the strategies of all lengths together; the
// render's own image is the same bits as without them; and they are the same bits for any
// number of threads.
TEST(Bidirectional, StrategyImagesOfOneRenderAreEachStrategysOwnRender) {
    Scene s = scene_of(kBox, Estimator::kBdpt, 8);
    RenderOptions o;
    o.integrator = Integrator::kScalar;
    o.progress = false;
    o.threads = 2;
    const StrategyLayout layout{4};
    StrategyFilm film(s.settings.width, s.settings.height, layout);
    o.strategies = &film;
    const RenderResult recorded = render(s, o);
    o.strategies = nullptr;
    const RenderResult plain = render(s, o);
    EXPECT_EQ(recorded.film.mean().rgb, plain.film.mean().rgb);
    ASSERT_EQ(layout.count(), 14);
    std::vector<double> sum(plain.film.mean().rgb.size(), 0.0);
    int lit = 0;
    for (int i = 0; i < layout.count(); ++i) {
        int st = 0, tt = 0;
        layout.strategy(i, st, tt);
        ASSERT_EQ(layout.index(uint32_t(st), uint32_t(tt)), i);
        for (bool weighted : {true, false}) {
            SCOPED_TRACE("strategy s=" + std::to_string(st) + " t=" + std::to_string(tt) +
                         (weighted ? "" : " unweighted"));
            Scene one = s;
            one.settings.estimator.strategy_s = st, one.settings.estimator.strategy_t = tt;
            one.settings.estimator.unweighted = !weighted;
            const Image want = render(one, o).film.mean();
            const Image got = film.image(i, weighted, s.settings.spp);
            float peak = 0.0f;
            for (float v : want.rgb) peak = std::max(peak, std::abs(v));
            if (peak > 0.0f) ++lit;
            for (size_t k = 0; k < want.rgb.size(); ++k)
                ASSERT_NEAR(got.rgb[k], want.rgb[k], 1e-5f * (peak + std::abs(want.rgb[k])))
                    << "value " << k;
        }
    }
    EXPECT_GE(lit, 20);  // (most strategies see light in this box)
    // Every length up to 4 alone: the weighted images add up to it. (With the pairing: the
    // light vertex cache's draws are from every stored vertex of the tile's light subpaths,
    // which a length limit cuts short, so with the cache the two agree in expectation only.)
    Scene paired = s;
    paired.settings.estimator.light_connections = 0;
    StrategyFilm paired_film(s.settings.width, s.settings.height, layout);
    o.strategies = &paired_film;
    render(paired, o);
    o.strategies = nullptr;
    for (int i = 0; i < layout.count(); ++i) {
        const Image got = paired_film.image(i, true, s.settings.spp);
        for (size_t k = 0; k < sum.size(); ++k) sum[k] += got.rgb[k];
    }
    Scene upto = paired;
    upto.settings.estimator.max_length = 4;
    const Image whole = render(upto, o).film.mean();
    for (size_t k = 0; k < sum.size(); ++k)
        ASSERT_NEAR(sum[k], whole.rgb[k], 1e-5 + 1e-4 * std::abs(whole.rgb[k])) << "value " << k;
    // The same bits for 1 and 3 threads
    for (int threads : {1, 3}) {
        StrategyFilm again(s.settings.width, s.settings.height, layout);
        o.threads = threads;
        o.strategies = &again;
        render(s, o);
        for (int i = 0; i < layout.count(); ++i)
            for (bool weighted : {true, false})
                ASSERT_EQ(again.image(i, weighted, 8).rgb, film.image(i, weighted, 8).rgb)
                    << threads << " threads, strategy " << i;
    }
}

TEST(Bidirectional, SameBitsForAnyNumberOfThreads) {
    test::expect_same_bits_for_any_threads(scene_of(kBox, Estimator::kBdpt, 20));
    for (int32_t draws : {0, 2}) {
        Scene s = scene_of(kBox, Estimator::kBdpt, 20);
        s.settings.estimator.light_connections = draws;
        test::expect_same_bits_for_any_threads(s);
    }
    test::expect_same_bits_for_any_threads(scene_of(kBox, Estimator::kVcm, 20, 0.1f));
    test::expect_same_bits_for_any_threads(scene_of(kBox, Estimator::kBpm, 20, 0.1f));
    test::expect_same_bits_for_any_threads(scene_of(kBox, Estimator::kPpm, 20, 0.1f));
}

// vcm at radii far too small and far too large for the scene (η = π r² N of 10^-37 and
// 10^21, whose squares overflow a float): nothing NaN or infinite reaches the image, in
// both integrators.
TEST(Bidirectional, VcmAtExtremeRadiiStaysFinite) {
    for (float radius : {1e-20f, 1e9f})
        for (const Variant& v : {variants().front(), variants().back()}) {
            SCOPED_TRACE(v.integrator + " " + v.isa + " r0 " + std::to_string(radius));
            const RenderResult r = run(scene_of(kBox, Estimator::kVcm, 8, radius), v);
            EXPECT_EQ(r.film.nonfinite_samples(), 0u);
            const Image m = r.film.mean();
            for (float x : m.rgb) ASSERT_TRUE(std::isfinite(x));
            EXPECT_GT(image_mean(r.film, 0).mean, 0.0);
        }
}

// A unit whose light subpaths need more light-vertex store than the limit is refused with
// a message naming the store and the survival cap, in both integrators; within the limit
// the render goes on.
TEST(Bidirectional, ALightStoreBeyondItsLimitIsRefused) {
    for (Estimator e : {Estimator::kBdpt, Estimator::kVcm})
        for (Integrator integrator : {Integrator::kScalar, Integrator::kWavefront}) {
            SCOPED_TRACE(std::string(estimator_name(e)) + " " + integrator_name(integrator));
            // (a white sphere: the roulette keeps a path with the cap's probability, so paths
            // have about 1,000 vertices)
            Scene s = scene_of(R"({"render": {"width": 8, "height": 8, "seed": 3},
                "camera": {"position": [0, 0, 0], "look_at": [0, 0, 1], "up": [0, 1, 0]},
                "materials": {"white": {"kd": [1, 1, 1]}},
                "objects": [{"type": "sphere", "center": [0, 0, 0], "radius": 1, "material": "white"}],
                "lights": [{"position": [0, 0.5, 0], "intensity": [1, 1, 1]}]})",
                               e, 1, 0.1f);
            s.settings.estimator.survival_cap = 0.999f;
            RenderOptions o;
            o.threads = 1;
            o.progress = false;
            o.integrator = integrator;
            o.light_store_limit = 64 << 10;
            try {
                render(s, o);
                ADD_FAILURE() << "not refused";
            } catch (const InputError& error) {
                const std::string m = error.what();
                EXPECT_NE(m.find("light-vertex store"), std::string::npos) << m;
                EXPECT_NE(m.find("survival_cap 0.999"), std::string::npos) << m;
            }
            s.settings.estimator.survival_cap = 0.9f;
            o.light_store_limit = 16 << 20;
            EXPECT_EQ(render(s, o).film.nonfinite_samples(), 0u);
        }
}

// A wavefront pool smaller than a job: the light subpaths and the camera paths run in
// several waves, the shadow queue fills and is traced mid-pass; the image agrees with the
// default pool's.
TEST(Bidirectional, SmallPoolsGiveTheSameImage) {
    for (Estimator e : {Estimator::kBdpt, Estimator::kVcm}) {
        SCOPED_TRACE(estimator_name(e));
        const Scene s = scene_of(kBox, e, 16, 0.1f);
        RenderOptions o;
        o.threads = 1;
        o.progress = false;
        const Image big = render(s, o).film.mean();
        o.pool_size = 16;
        const Image small = render(s, o).film.mean();
        ASSERT_EQ(big.rgb.size(), small.rgb.size());
        double worst = 0;
        for (size_t i = 0; i < big.rgb.size(); ++i)
            worst = std::max(worst, double(std::abs(big.rgb[i] - small.rgb[i])) /
                                        std::max(1e-3, double(std::abs(big.rgb[i]))));
        EXPECT_LT(worst, 1e-3);
    }
}

}  // namespace
}  // namespace cierzo
