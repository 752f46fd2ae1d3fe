// The image textures a scene file names: each file requested while the scene is read, then
// all of them decoded at once, in parallel, and given to the scene and its materials
// (scene_json.cpp reads the file; io/texture_image.h decodes an image).
#pragma once

#include <cstdint>
#include <filesystem>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "scene/load_options.h"

namespace cierzo {

class Scene;

// The image textures a scene names, each file decoded once (per colour encoding) after the
// whole scene is read, all of them in parallel.
struct ImageRequests {
    struct Request {
        std::filesystem::path path;
        bool srgb;
        std::string where;  // the first place that names it, for messages
    };
    std::map<std::pair<std::filesystem::path, bool>, int32_t> ids;
    std::vector<Request> requests;

    int32_t request(const std::filesystem::path& path, bool srgb, const std::string& where) {
        const auto [it, added] =
            ids.try_emplace({path.lexically_normal(), srgb}, int32_t(requests.size()));
        if (added) requests.push_back({path, srgb, where});
        return it->second;
    }
};

// Decodes every image texture named (in parallel; the first failing one in the order the
// scene names them is reported), gives the materials' sources their largest values, and
// refuses an image texture where there are no texture coordinates. First, from the files'
// headers alone, refuses an image outside `roots` and images that would take more than
// `budget` bytes of memory at once while decoded (each image's peak, as all may be decoded
// at the same time, and the environment's sampling tables). `file` is the scene file, for
// messages.
void load_images(Scene& scene, const ImageRequests& images, const std::filesystem::path& file,
                 const InputRoots& roots, uint64_t budget);

}  // namespace cierzo
