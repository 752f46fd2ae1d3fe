// The estimator's plain settings, outside the per-ISA namespaces: one type that the scene,
// the scalar reference and every ISA's kernels share (no kernel types, no functions, so
// the per-ISA objects share no code through it).
#pragma once

#include <cstdint>

namespace cierzo {

// Which estimator renders the image (render.estimator, --estimator; names and descriptions
// in src/integrators/registry.h).
enum class Estimator : int32_t {
    kReport = 0,  // the report's: emitters are found only by the paths that hit them
    kNee = 1,     // next-event estimation: one emitter sample per Phong vertex
    kMis = 2,     // both strategies, weighted by the power heuristic
    kLt = 3,      // light tracing: paths from the lights, splatted through the pinhole
};

// Whether the estimator's paths start at the lights and land anywhere in the image (their
// sums are splatted, and their error comes from batch statistics).
inline constexpr bool splats(Estimator e) { return e == Estimator::kLt; }

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
    // nee and mis: triangles sampled by solid angle (a spherical triangle, where it subtends
    // at least kMinTriangleSolidAngle) instead of by area
    bool triangle_solid_angle = false;
    // The roulette (kThroughput: nee and mis only), and the vertex it starts at
    Roulette roulette = Roulette::kLobe;
    int32_t roulette_depth = 1;
};

// Below this solid angle (steradians) a triangle is sampled by area even under
// triangle_solid_angle: the spherical triangle's construction loses precision, and a
// triangle that small is sampled nearly uniformly in solid angle by area anyway.
inline constexpr float kMinTriangleSolidAngle = 1e-3f;

// Whether the lobe choice leaves out the path's death (the throughput roulette decides it).
inline constexpr bool normalised_lobes(const EstimatorSettings& e) {
    return e.roulette == Roulette::kThroughput;
}

}  // namespace cierzo
