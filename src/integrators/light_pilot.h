// The light vertex cache's pilot: the mean number of vertices a light subpath of the scene
// stores, estimated once per scene and settings by tracing light subpaths, and kept by the
// scene, whose path_context() reads it for PathContext::connection_count.
#pragma once

#include "scene/scene.h"

namespace cierzo {

// The scene's estimate for its current settings (Scene::light_subpath_vertices), made now
// from kLightPilotPaths light subpaths (light_subpath_vertices of integrators/scalar.h) if
// the scene keeps none.
double light_pilot(const Scene& scene);

// Makes the estimate Scene::path_context needs for the scene's current settings, where it
// needs one (Scene::needs_light_pilot) and none is kept: before anything asks the scene for
// its path context (a render, a checkpoint's identity, a wavefront renderer).
void prepare_path_context(const Scene& scene);

}  // namespace cierzo
