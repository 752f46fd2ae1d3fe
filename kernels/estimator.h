// The report's path-vertex estimator, written once for both integrators (T = float for the
// scalar reference, T = xsimd::batch for the wavefront kernels). At each hit:
//   - an emitter ends the path and adds throughput · Le;
//   - a Phong vertex (kd or ks non-zero) sends a shadow ray to every point light, adding
//     throughput · f(ωi, ωo) · cos θi · I / d²;
//   - one lobe is chosen by Russian roulette with probability proportional to its max RGB,
//     scaled so that at least 1 - survival_cap of the time the path dies;
//   - the chosen lobe samples a direction and the throughput is multiplied by
//     f · cos θ / (pdf · P(lobe)).
// Beyond the report (EstimatorSettings::kind), the sampled emitters (spheres and triangles
// of solid emission, kernels/emitter_table.h) are also reached from every Phong vertex:
//   - nee: one emitter sample per Phong vertex, f·cos θ·Le / pdf through a shadow ray; a
//     path that then hits a sampled emitter straight after a Phong bounce adds nothing;
//   - mis: both, each lobe's share weighted by the power heuristic between the emitter
//     sample's pdf and that lobe's own pdf P(lobe)·pdf_lobe (Veach 1997, §9.2).
// After the camera, a mirror or a refraction, and for emitters that cannot be sampled, an
// emitter hit counts in full as in the report.
//
// This header gathers its three parts: the material's lobes (kernels/bsdf.h), emitter
// sampling (kernels/emitter_sampling.h) and the MIS weights (kernels/mis_weights.h).
#pragma once

#include "bsdf.h"
#include "emitter_sampling.h"
#include "mis_weights.h"
#include "texture.h"
