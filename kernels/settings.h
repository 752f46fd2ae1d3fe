// The estimator's plain settings, outside the per-ISA namespaces: one type that the scene,
// the scalar reference and every ISA's kernels share (no kernel types, and only small
// constexpr functions that are always inlined, so the per-ISA objects share no code through
// it: isa_objects_share_no_inline_code checks).
#pragma once

#include <cstdint>

namespace cierzo {

// Which estimator renders the image (render.estimator, --estimator; names and descriptions
// in src/scene/estimator_options.h).
enum class Estimator : int32_t {
    kReport = 0,  // the report's: emitters are found only by the paths that hit them
    kNee = 1,     // next-event estimation: one emitter sample per Phong vertex
    kMis = 2,     // both strategies, weighted by the power heuristic
    kLt = 3,      // light tracing: paths from the lights, splatted through the pinhole
    kBdpt = 4,    // bidirectional: every connection of a camera and a light subpath, by MIS
    kVcm = 5,     // bdpt and vertex merging (photon mapping's strategy), by MIS
    kBpm = 6,     // bidirectional photon mapping: merging at every camera vertex, by MIS
    kPpm = 7,     // progressive photon mapping: merging where a camera path first scatters
                  // diffusely (it goes on only through mirrors and glass), unweighted
};

// What each estimator is, as the drivers, the scheduler and the options ask it: one row per
// estimator (traits(), below), so that the code outside its kernel asks these
// questions and never names the estimator. docs/architecture.md lists what a new estimator
// touches.
struct EstimatorTraits {
    // An emitter sample at each Phong camera vertex, by next-event estimation (nee, mis); the
    // throughput roulette and the camera-side defaults (cosine diffuse sampling, triangles
    // by solid angle, the sobol sampler) are theirs
    bool samples_emitters = false;
    // Chooses emitters from the emitter table: to sample them or to start light paths (all
    // but the report's, which only finds them); a table of at most 2^24 emitters
    bool draws_emitters = false;
    // Units of light paths beside the camera tiles, which trace camera paths only where
    // some emitter cannot be sampled (lt)
    bool light_batches = false;
    // Paths start at the lights and land anywhere in the image: their sums are splatted, and
    // their error comes from batch statistics
    bool splats = false;
    // Each camera path is paired with a light subpath (kernels/bidirectional.h)
    bool bidirectional = false;
    // Camera vertices merge with the light vertices near them
    bool merges = false;
    // Connects vertices: next-event estimation (s = 1), a light vertex to a camera vertex
    // (s, t ≥ 2) and to the pinhole (t = 1). bpm and ppm only merge, and count an emitter
    // hit (s = 0) only where merging cannot make the path (kernels/bidirectional.h,
    // emitter_hit_mis)
    bool connects = false;
    // Each strategy (s, t) can be rendered as an image of its own (--strategies)
    bool strategy_images = false;
};

// Each estimator's row. (A switch, not a table, and always inlined: a table, or a copy of
// this function that a build does not inline, would be one symbol that every instruction
// set's objects share; -Wswitch names an estimator without its row.)
[[gnu::always_inline]] inline constexpr EstimatorTraits traits(Estimator e) {
    // clang-format off
    switch (e) {
        case Estimator::kReport: return {};
        case Estimator::kNee: return {.samples_emitters = true, .draws_emitters = true};
        case Estimator::kMis: return {.samples_emitters = true, .draws_emitters = true};
        case Estimator::kLt: return {.draws_emitters = true, .light_batches = true, .splats = true};
        case Estimator::kBdpt: return {.draws_emitters = true, .splats = true, .bidirectional = true,
                                       .connects = true, .strategy_images = true};
        case Estimator::kVcm: return {.draws_emitters = true, .splats = true, .bidirectional = true,
                                      .merges = true, .connects = true};
        case Estimator::kBpm: return {.draws_emitters = true, .bidirectional = true, .merges = true};
        case Estimator::kPpm: return {.draws_emitters = true, .bidirectional = true, .merges = true};
    }
    // clang-format on
    return {};
}

// The questions asked most, by name.
inline constexpr bool splats(Estimator e) { return traits(e).splats; }
inline constexpr bool bidirectional(Estimator e) { return traits(e).bidirectional; }
inline constexpr bool merges(Estimator e) { return traits(e).merges; }
inline constexpr bool connects(Estimator e) { return traits(e).connects; }

// vcm's merging radius (render.merge_radius, --merge-radius; render.merge_alpha,
// --merge-alpha): sample n (from 0) merges within r0 · (n + 1)^((α − 1) / 2). r0 = 0 takes
// kMergeRadiusFraction of the scene's size (Scene::merge_radius; chosen by measured
// efficiency, docs/estimators.md "vcm").
inline constexpr float kMergeAlpha = 0.75f;
// The N of vcm's merging weights in every tile: a full tile's pixels (kernels/bidirectional.h,
// merge_weights; src/integrators/render.h checks it against kTileSize).
inline constexpr int32_t kMergeTilePaths = 256;
inline constexpr float kMergeRadiusFraction = 0.05f;

// bdpt's and vcm's connections (render.light_connections, --light-connections): 0 joins a
// Phong camera vertex to every stored vertex of its own light subpath (the pairing of
// SmallVCM); n ≥ 1 to n vertices drawn from the light vertex cache, every stored vertex of
// the light subpaths of its sample index in its tile (kernels/bidirectional.h, "The light
// vertex cache"). At most kMaxLightConnections.
inline constexpr int32_t kMaxLightConnections = 64;
// The cache's MIS weights need the mean number of vertices a light subpath stores
// (PathContext::connection_count): estimated before the render from kLightPilotPaths light
// subpaths of seed kLightPilotSeed (Scene::light_subpath_vertices), and taken at least
// kMinLightPilotVertices (a scene whose light subpaths store nearly nothing connects nearly
// never, whatever weight it has).
inline constexpr int32_t kLightPilotPaths = 1024;
inline constexpr uint32_t kLightPilotSeed = 0x6c696768u;
inline constexpr double kMinLightPilotVertices = 1.0 / 64.0;

// The roulette that ends paths (render.roulette, --roulette).
enum class Roulette : int32_t {
    // The report's: one draw picks a lobe or the path's death at every vertex, P(lobe) the
    // lobe's max RGB, scaled so that the survival never exceeds the cap.
    kLobe = 0,
    // For the camera-path estimators that sample emitters (nee, mis): the lobe is chosen in
    // proportion to the lobes' max RGB alone (a path dies at a vertex only where every lobe
    // is black), and from vertex `roulette_depth` on (the camera's first hit is vertex 0) a
    // second draw lets the path go on with probability q = min(max RGB of its throughput,
    // cap), its throughput divided by q.
    kThroughput = 1,
};

// How a path's random numbers are drawn (render.sampler, --sampler; kernels/sampler.h and
// docs/estimators.md, "samplers").
enum class Sampler : int32_t {
    kIndependent = 0,  // a hash of (seed, pixel, sample, bounce, purpose): the report's
    kSobol = 1,        // Owen-scrambled Sobol (0,2) points, padded and shuffled per pixel
    kZSobol = 2,       // the same points spread over the image in Morton order
    kPmj02 = 3,        // progressive multi-jittered (0,2) tables, shuffled and scrambled
};

// Path guiding (render.guiding, --guiding; docs/guiding.md).
enum class Guiding : int32_t {
    kNone = 0,    // directions from the material's lobes alone
    kSdTree = 1,  // an SD-tree learned between passes (Müller, Gross and Novák 2017)
};

// pmj02: tables of points made once per process (src/scene/pmj02.cpp), each x | y << 16 in
// 16-bit fixed point.
inline constexpr uint32_t kPmj02Tables = 16;
inline constexpr uint32_t kPmj02Points = 4096;

// What a sampler needs beyond a path's numbers (built with the path context).
struct SamplerSetup {
    Sampler kind = Sampler::kIndependent;
    // zsobol: log2 of the render's paths per pixel, rounded up (a pixel's block of indices)
    uint32_t log2_spp = 0;
    // pmj02: kPmj02Tables × kPmj02Points points
    const uint32_t* pmj02 = nullptr;
};

// EstimatorSettings::max_length when paths have no limit, and the largest limit that may be
// set (render.min_length, render.max_length, --min-length, --max-length).
inline constexpr int32_t kNoLengthLimit = INT32_MAX;
inline constexpr int32_t kMaxLengthLimit = 1 << 20;

// Settings of the estimator that a scene or the command line may change.
struct EstimatorSettings {
    // The roulette's total survival probability never exceeds this, so every path ends.
    float survival_cap = 0.9f;
    // Diffuse directions: uniform over the hemisphere as in the report, or cosine-weighted.
    bool cosine_diffuse = false;
    // The report's estimator, next-event estimation, or multiple importance sampling.
    Estimator kind = Estimator::kReport;
    // Multiplies the emitter-sampling pdf that next-event estimation divides by. Always 1;
    // the tests set it to 1.05 to show that a 5% error in that pdf is caught.
    float light_pdf_scale = 1.0f;
    // Multiplies the reverse densities the bidirectional estimators weigh with
    // (kernels/bidirectional.h). Always 1; the tests set it to 1.05 to show that a 5% error
    // in a reverse density is caught.
    float reverse_pdf_scale = 1.0f;
    // nee and mis: triangles sampled by solid angle (a spherical triangle, where it subtends
    // at least kMinTriangleSolidAngle) instead of by area
    bool triangle_solid_angle = false;
    // The roulette (kThroughput: nee and mis only), and the vertex it starts at
    Roulette roulette = Roulette::kLobe;
    int32_t roulette_depth = 1;
    // Path guiding (render.guiding, --guiding): nee's and mis's camera paths draw part of
    // their diffuse directions from the incident light learned from earlier passes
    // (kernels/guiding.h, src/integrators/path_guide.h)
    Guiding guiding = Guiding::kNone;
    // The Phong vertices of a camera path that the guide serves, counted from the camera: it
    // draws their diffuse directions, weighs with its density there and learns from their
    // records alone (render.guided_vertices, --guided-vertices; 0: every Phong vertex)
    int32_t guided_vertices = 1;
    // Always true; the tests clear it to show that a MIS weight without the guide's density
    // is caught
    bool guide_in_mis = true;
    // Where the uniform numbers come from (every estimator)
    Sampler sampler = Sampler::kIndependent;
    // Only light carried by paths of min_length..max_length segments counts (the camera
    // seeing an emitter is 1 segment, direct light at the first hit 2): to isolate a length
    int32_t min_length = 1;
    int32_t max_length = kNoLengthLimit;
    // bdpt: only strategy (strategy_s, strategy_t) counts, with its weight or (unweighted)
    // without; -1: every strategy (render.strategy, --strategy, --unweighted), each with its
    // weight (unweighted: without, as the strategy images' second evaluation takes them)
    int32_t strategy_s = -1, strategy_t = -1;
    bool unweighted = false;
    // vcm: the first sample's merging radius r0 (0: from the scene's size) and the exponent α
    // in (0, 1) of its decrease (kMergeAlpha)
    float merge_radius = 0.0f;
    float merge_alpha = kMergeAlpha;
    // bdpt, vcm: 0 connects to every vertex of the camera sample's own light subpath; n ≥ 1
    // to n vertices drawn from the light vertex cache (kMaxLightConnections; 1 measured the
    // most efficient on most scenes of scenes/, docs/estimators.md)
    int32_t light_connections = 1;
    // The cache's connections count this many times in the MIS weights
    // (PathContext::connection_count); 0, always but in tests: light_connections over the
    // light subpaths' mean number of stored vertices (Scene::light_subpath_vertices). The
    // tests set 1, the pairing's count, to compare the cache's weighted images with it.
    float connection_count = 0.0f;
    // Which of the four knobs whose default depends on the estimator (diffuse sampling,
    // roulette, triangle sampling, sampler) a scene, the command line or a sweep chose;
    // use_estimator (src/scene/estimator_options.h) gives the others the estimator's defaults
    uint32_t chosen = 0;
};
inline constexpr uint32_t kChoseDiffuse = 1, kChoseRoulette = 2, kChoseTriangles = 4,
                          kChoseSampler = 8;

// Below this solid angle (steradians) a triangle is sampled by area even under
// triangle_solid_angle: the spherical triangle's construction loses precision, and a
// triangle that small is sampled nearly uniformly in solid angle by area anyway.
inline constexpr float kMinTriangleSolidAngle = 1e-3f;

// Whether the path length limits leave anything out.
inline constexpr bool limits_length(const EstimatorSettings& e) {
    return e.min_length > 1 || e.max_length != kNoLengthLimit;
}

// Whether the lobe choice leaves out the path's death (the throughput roulette decides it).
inline constexpr bool normalised_lobes(const EstimatorSettings& e) {
    return e.roulette == Roulette::kThroughput;
}

}  // namespace cierzo
