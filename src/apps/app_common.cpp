// Shared checks of the `cierzo` subcommands (see app_common.h).
#include "apps/app_common.h"

#include <CLI/CLI.hpp>
#include <fmt/format.h>

#include "core/error.h"

namespace cierzo {

void InputOptions::add_to(CLI::App* command) {
    command
        ->add_option("--allow-path", allowed_paths,
                     "A folder besides the scene's own that the files the scene names (meshes, "
                     "MTL libraries, images) may come from; repeatable. By default a scene "
                     "reads only beneath its own folder, links followed (docs/scene-format.md)")
        ->check(CLI::ExistingDirectory);
    command->add_option(
        "--image-memory", image_memory,
        fmt::format("The most memory the scene's images may take while decoded, their "
                    "sampling tables included, e.g. 8G or 512M (powers of 1024); charged "
                    "from each image's header before any is decoded. Default: 4G, or half "
                    "this machine's memory where that is less (here {}): enough for an "
                    "8192x4096 HDR environment and dozens of 4096^2 textures",
                    format_bytes(default_image_memory())));
}

LoadOptions InputOptions::load_options() const {
    LoadOptions o;
    o.allowed_paths = allowed_paths;
    if (!image_memory.empty()) o.image_memory = parse_bytes(image_memory, "--image-memory");
    return o;
}

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
