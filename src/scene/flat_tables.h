// The scene's flat form (scene/flat_scene.h), built in one place. The tables the SIMD loads
// need (every primitive and material table padded to whole registers, plane and quadric
// values repeated in 16 lanes, the materials as structure of arrays) are built once, by
// Scene::finalize, and shared by copies of the scene; a view binds them, with the scene's own BVH,
// vertices, emitters and light starts, to the camera and the settings the scene has when it is
// taken.
#pragma once

#include <memory>
#include <vector>

#include "scene/flat_scene.h"

namespace cierzo {

class Scene;
struct FlatTables;

// (The tables themselves are built by Scene::finalize, through Scene::build_flat_tables,
// defined in flat_tables.cpp; the scene's primitives and materials must not change
// afterwards without calling finalize again.)

// `scene` as the wavefront kernels read it: the tables built by finalize, pointers into the
// scene's own arrays, and its camera, resolution, seed, estimator and features now. Valid
// while the scene lives and is not changed. Moving a view keeps it valid; it is not copied.
struct FlatView {
    FlatScene scene{};
    std::vector<FlatMesh> meshes;  // FlatScene::meshes points here
    std::shared_ptr<const FlatTables> tables;
    FlatView() = default;
    FlatView(FlatView&&) = default;
    FlatView& operator=(FlatView&&) = default;
    FlatView(const FlatView&) = delete;
    FlatView& operator=(const FlatView&) = delete;
};
FlatView flat_view(const Scene& scene);

}  // namespace cierzo
