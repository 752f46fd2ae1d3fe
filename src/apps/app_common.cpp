// Shared checks of the `cierzo` subcommands (see app_common.h).
#include "apps/app_common.h"

#include <fmt/format.h>

#include "core/error.h"

namespace cierzo {

namespace fs = std::filesystem;

namespace {
// The limit on paths in one render (pixels × paths per pixel): well beyond any useful
// experiment on a CPU, and refused before anything is allocated.
constexpr double kMaxPaths = 1e12;
constexpr const char* kVarianceLayers[3] = {"variance.R", "variance.G", "variance.B"};
}  // namespace

std::vector<InputPath> scene_inputs(const Scene& scene) {
    std::vector<InputPath> inputs;
    for (const fs::path& file : scene.files)
        inputs.push_back({file, file == scene.source ? "the scene file" : "the mesh file"});
    return inputs;
}

void check_render_size(const Scene& scene, const fs::path& scene_file) {
    const RenderSettings& s = scene.settings;
    if (double(s.width) * double(s.height) > double(kMaxImagePixels))
        throw InputError(fmt::format("--width/--height: {}x{} exceeds the limit of 2^28 pixels",
                                     s.width, s.height));
    if (double(s.width) * double(s.height) * double(s.spp) > kMaxPaths)
        throw InputError(
            fmt::format("{}: {}x{} pixels x {} paths per pixel exceeds the limit "
                        "of 1e12 paths in one render",
                        scene_file.string(), s.width, s.height, s.spp));
}

ImageLayers variance_layers(const Image& variance) {
    ImageLayers layers;
    for (int c = 0; c < 3; ++c) {
        std::vector<float> layer(size_t(variance.width) * size_t(variance.height));
        for (size_t i = 0; i < layer.size(); ++i) layer[i] = variance.rgb[i * 3 + size_t(c)];
        layers[kVarianceLayers[c]] = std::move(layer);
    }
    return layers;
}

Image variance_from_layers(const ImageLayers& layers, int width, int height, const fs::path& path) {
    Image v(width, height);
    for (int c = 0; c < 3; ++c) {
        const auto it = layers.find(kVarianceLayers[c]);
        if (it == layers.end() || it->second.size() != v.rgb.size() / 3)
            throw InputError(path.string() + ": no " + kVarianceLayers[c] +
                             " layer of the image's size (render it with --variance)");
        for (size_t i = 0; i < it->second.size(); ++i) v.rgb[i * 3 + size_t(c)] = it->second[i];
    }
    return v;
}

}  // namespace cierzo
