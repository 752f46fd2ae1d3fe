// The emitters that next-event estimation samples, as plain arrays both integrators read
// (built once per scene by Scene::finalize; see kernels/estimator.h for how they are used).
// No kernel types here: the per-ISA objects and the scalar side share this layout only.
#pragma once

#include <cstdint>

#include "settings.h"

namespace cierzo {

// The kinds of emitter that can be sampled. A rectangle is two triangles of one mesh that
// make one (Scene::finalize finds them): both triangles' entries hold the rectangle, the
// first with its power, the second with none (never chosen, but a hit on it has the
// rectangle's pmf and density).
enum EmitterKind : int32_t {
    kEmitterSphere = 0,
    kEmitterTriangle = 1,
    kEmitterRectangle = 2,
    kEmitterEnvironment = 3,  // the scene's environment (EnvironmentMap; its record is unused)
};

// The environment light: radiance arriving from infinitely far in every direction, an
// equirectangular grid of width × height texels (one texel for a constant one is refined
// into rows, so its density follows sin θ). Direction ω in the environment's own frame
// (to_local · world direction) is the texel at u = ½ + atan2(ω.x, ω.z) / 2π across and
// θ / π down, θ = acos ω.y (row 0 looks up +y, the middle column along +z); radiance is
// piecewise constant over texels. Sampling picks a texel in proportion to max RGB · sin θ
// (a row by row_cdf, then a column by its row's col_cdf) and a point in it uniformly in
// (u, v); the density in solid angle is density[texel] / (2π² sin θ) (kernels/environment.h).
struct EnvironmentMap {
    int32_t width = 0, height = 0;    // 0: the scene has no environment
    const float* radiance = nullptr;  // RGB per texel, row-major from the top
    const float* row_cdf = nullptr;   // height + 1 entries, the first 0 and the last 1
    const float* col_cdf = nullptr;   // per row, width + 1 entries, the first 0, the last 1
    const float* density = nullptr;   // per texel: the density of the (u, v) it covers
    float to_local[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};  // row-major rotations
    float to_world[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
    int32_t emitter = -1;  // its entry in the emitter table, or -1 (not sampled)
};

// Floats per emitter record in EmitterTable::data:
//   [0, 3)   sphere centre, or the triangle's first vertex v0 (world space), or the
//            rectangle's corner
//   3        sphere radius, or the triangle's or rectangle's area
//   [4, 7)   triangle edge v1 - v0 (a rectangle's first side)     [7, 10) edge v2 - v0 (its
//            second side, at a right angle to the first)     [10, 13) unit normal
//   [13, 16) emitted radiance Le (RGB)
inline constexpr int32_t kEmitterStride = 16;

// Emitters chosen in proportion to their power (area × max Le) through Vose's alias table:
// slot i of `count` is kept with probability alias_q[i], else alias[i] is taken.
struct EmitterTable {
    int32_t count = 0;
    const float* alias_q = nullptr;  // count (padded)
    const int32_t* alias = nullptr;  // count
    const float* pmf = nullptr;      // count: the probability of choosing each emitter
    const int32_t* kind = nullptr;   // count: EmitterKind
    const float* data = nullptr;     // count * kEmitterStride
    EnvironmentMap environment;      // the scene's, which paths that escape gather
};

// Where paths from the lights start (light tracing, kernels/transport.h): a sampled emitter
// of the table above or a point light, chosen by power. Built by the scene
// (Scene::light_starts).
struct LightStartTable {
    float emitter_probability = 0.0f;  // of starting on a sampled emitter
    int32_t point_count = 0;
    const float* point_cdf = nullptr;  // point_count cumulative probabilities, the last 1
    // Per point light, 6 floats: its position, and its intensity over the probability of
    // choosing it (with the point lights' share), times (η_scene/η_medium)² for a light that
    // sits inside a refractive object (docs/estimators.md, "light tracing")
    const float* point = nullptr;
    // Per point light, 4 floats: its intensity as camera paths see it, and the probability
    // of starting a light path at it (the bidirectional estimators' weights)
    const float* point_source = nullptr;
};

// The pinhole as paths from the lights see it: the frame (kernels/camera.h), the image
// size, the film's area at distance 1 and its unit normal.
struct PinholeFrame {
    float origin[3], forward[3], left[3], up[3];
    float width = 1.0f, height = 1.0f;
    float film_area = 1.0f;
    float film_normal[3];
};

struct GuideView;  // kernels/guiding.h

// What a path vertex needs of the scene beyond its hit (kernels/path_vertex.h): the
// emitters, the estimator, the point lights camera paths shoot shadow rays to, the scene's
// refractive index, and three switches. Built by Scene::path_context for both integrators.
struct PathContext {
    EmitterTable emitters;
    EstimatorSettings estimator;
    SamplerSetup sampler;
    const float* lights = nullptr;  // 6 floats each: position, intensity
    int32_t light_count = 0;        // 0 under lt (its light paths bring point lights)
    float scene_ior = 1.0f;
    bool smooth = false;  // some mesh shades with interpolated normals (kernels/shading.h)
    bool nee = false;     // the estimator samples emitters: nee or mis, with emitters to sample
    bool lt = false;      // light tracing: camera paths count only emitters never sampled
    bool bdpt = false;    // bidirectional (kernels/bidirectional.h): no nee, no point lights
                          // of the report's kind; the pairs of subpaths bring every light
    // Light no path from the lights starts at: emitters not sampled (planes, quadrics,
    // textured emission) or an environment (ppm's camera paths then go on past a merge)
    bool unstarted_light = false;
    // bdpt and vcm with the light vertex cache (EstimatorSettings::light_connections n ≥ 1):
    // how many times a camera vertex connects, on average, to the light vertices of a given
    // index where the pairing connects once, c = n / L (L: the mean number of vertices a
    // light subpath stores, Scene::light_subpath_vertices); their MIS weights count each
    // connection c times (kernels/bidirectional.h, connection_count2). 1 otherwise.
    float connection_count = 1.0f;
    // The path guide the camera paths of this pass sample from (nee, mis with
    // EstimatorSettings::guiding, once a first pass has trained it; kernels/guiding.h)
    const GuideView* guide = nullptr;
};

// Whether emitter hits are weighed (so a hit needs its emitter's id): nee and mis (emitters
// they sample), lt (all sampled), bdpt (kernels/bidirectional.h).
inline bool weighs_emitter_hits(const PathContext& c) { return c.nee || c.lt || c.bdpt; }

}  // namespace cierzo
