// The materials of OBJ files' MTL libraries as cierzo materials (the mapping of
// docs/scene-format.md, "OBJ materials (MTL)"): each library read once, each of its materials
// added to the scene once, where a face first uses it. Used by the scene-file reader.
#pragma once

#include <cstdint>
#include <filesystem>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "io/mtl.h"
#include "scene/scene.h"
#include "scene/scene_images.h"

namespace cierzo {

struct MtlMaterials {
    MtlMaterials(Scene& scene, ImageRequests& images) : scene(scene), images(images) {}

    Scene& scene;           // where the materials, warnings and files read go
    ImageRequests& images;  // the texture maps' images
    std::map<std::filesystem::path, MtlLibrary> libraries;  // read so far, by path
    // (library, name) → material
    std::map<std::pair<std::filesystem::path, std::string>, int32_t> mtl_ids;
    int32_t default_material = -1;  // faces without a material, or with an unknown one

    // The library at `path`, which the OBJ file `obj` names; a file that does not exist is a
    // warning and an empty library, one that cannot be read read_mtl's InputError.
    const MtlLibrary& library(const std::filesystem::path& path, const std::filesystem::path& obj);
    // The scene's material for the MTL material `name` of the first of `libs` that defines
    // it, else the OBJ default (diffuse grey 0.8; with a warning naming `obj` where a name is
    // given).
    int32_t material(const std::string& name, const std::vector<const MtlLibrary*>& libs,
                     const std::string& obj);

private:
    // A cierzo material from an MTL one (the mapping of docs/scene-format.md, "OBJ materials").
    Material from_mtl(const MtlMaterial& mtl, const MtlLibrary& lib);
};

}  // namespace cierzo
