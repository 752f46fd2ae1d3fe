// What the `cierzo` subcommands share: the inputs their outputs are checked against, early
// checks of render sizes, and the variance layers of an EXR.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "io/image.h"
#include "io/output_file.h"
#include "scene/load_options.h"
#include "scene/scene.h"

namespace CLI {
class App;
}

namespace cierzo {

// What a subcommand that reads a scene lets the user widen: the folders the scene's inputs
// may come from (--allow-path DIR, repeatable) and its images' memory (--image-memory SIZE).
struct InputOptions {
    std::vector<std::filesystem::path> allowed_paths;
    std::string image_memory;  // as given; empty: the default
    // The options, added to `command`
    void add_to(CLI::App* command);
    // As load_scene takes them; throws InputError for a malformed --image-memory
    LoadOptions load_options() const;
};

// The files a scene was made from (the scene file, its meshes), as inputs that no output may
// replace (check_outputs in io/output_file.h).
std::vector<InputPath> scene_inputs(const Scene& scene);

// Refuses an image of more than 2^28 pixels or a render of more than 1e12 paths, naming the
// scene file, before anything is allocated.
void check_render_size(const Scene& scene, const std::filesystem::path& scene_file);

// The "variance.R/G/B" layers `render --variance` writes, from and to an image.
ImageLayers variance_layers(const Image& variance);
// Throws InputError naming `path` when a layer is missing.
Image variance_from_layers(const ImageLayers& layers, int width, int height,
                           const std::filesystem::path& path);

}  // namespace cierzo
