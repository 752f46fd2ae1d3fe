// What the `cierzo` subcommands share: early checks of outputs and render sizes, and the
// variance layers of an EXR.
#pragma once

#include <filesystem>

#include "io/image.h"
#include "scene/scene.h"

namespace cierzo {

// Fails early, before a long render, if an output could never be written.
void check_writable_folder(const std::filesystem::path& path, const char* what);

// Refuses an image of more than 2^28 pixels or a render of more than 1e12 paths, naming the
// scene file, before anything is allocated.
void check_render_size(const Scene& scene, const std::filesystem::path& scene_file);

// The "variance.R/G/B" layers `render --variance` writes, from and to an image.
ImageLayers variance_layers(const Image& variance);
// Throws InputError naming `path` when a layer is missing.
Image variance_from_layers(const ImageLayers& layers, int width, int height,
                           const std::filesystem::path& path);

}  // namespace cierzo
