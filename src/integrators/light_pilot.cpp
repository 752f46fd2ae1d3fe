// The light vertex cache's pilot: light subpaths traced by the scalar reference for a scene
// and its settings, their mean stored vertices kept by the scene (see light_pilot.h).
#include "integrators/light_pilot.h"

#include "integrators/scalar.h"

namespace cierzo {

double light_pilot(const Scene& scene) {
    return scene.light_subpath_vertices([&scene](const PathContext& base) {
        return light_subpath_vertices(scene, base, kLightPilotPaths);
    });
}

void prepare_path_context(const Scene& scene) {
    if (scene.needs_light_pilot()) light_pilot(scene);
}

}  // namespace cierzo
