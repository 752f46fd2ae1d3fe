// What the scalar reference's path loops share (scalar.cpp, scalar_bdpt.cpp): the inlining
// of every kernel they call, and a shadow ray traced as soon as a vertex asks for it.
#pragma once

#include "integrators/render.h"
#include "kernels/path_vertex.h"
#include "scene/scene.h"

// The path loops inline every kernel they call, as the wavefront's stage loops do (and as
// the compiler chose to when the vertex rules were written inside them). Sanitizer builds
// skip it, for their compile time.
#if defined(__SANITIZE_ADDRESS__)
#define CIERZO_PATH_LOOP
#else
#define CIERZO_PATH_LOOP [[gnu::flatten]]
#endif

namespace cierzo {

// A shadow ray the vertex asked for, traced at once: what it adds if clear.
inline Vec3f trace_request(const Scene& scene, const ShadowRequest<float>& r, RayCounts& rays) {
    if (!r.want) return Vec3f(0.0f);
    ++rays.shadow;
    return scene.occluded({r.origin, r.dir}, r.tmax) ? Vec3f(0.0f) : r.value;
}

}  // namespace cierzo
