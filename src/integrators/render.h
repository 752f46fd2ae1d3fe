// Rendering a scene: the integrator chosen, this process's threads or MPI's ranks, progress,
// statistics, checkpoints (the types they share: integrators/render_types.h).
#pragma once

#include "integrators/render_types.h"
#include "scene/scene.h"

namespace cierzo {

// Renders the scene with its settings (resolution, spp, seed) and the options, in passes of
// a few paths per pixel over the whole image, so it can stop between passes with the same
// number of paths in every pixel. Samples are keyed by index: passes change nothing else.
// Under MPI (integrators/distributed.h, when this process is one of several ranks) every
// rank calls it; rank 0 hands out the work and returns the image, the others an empty film.
RenderResult render(const Scene& scene, const RenderOptions& options);

}  // namespace cierzo
