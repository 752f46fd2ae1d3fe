// Reading a scene file (JSON, documented key by key in docs/scene-format.md). One file is
// one reproducible experiment: camera, render settings, materials, objects and lights.
#pragma once

#include <filesystem>

#include "scene/load_options.h"
#include "scene/scene.h"

namespace cierzo {

// Parses, validates and finalizes a scene. Relative paths (meshes, output) resolve against
// the scene file's folder. Throws InputError naming the file, the place in it and the
// problem (malformed JSON, unknown or missing keys, values out of range). The files it names
// must lie beneath the scene file's folder or an allowed path, its "output" beneath its
// folder, and its images within the memory budget (load_options.h).
Scene load_scene(const std::filesystem::path& path, const LoadOptions& options = {});

// Whether load_scene reads `path` as a model (an OBJ or PLY file, by its extension, in any
// case) that it frames itself, rather than as a scene file.
bool is_model_file(const std::filesystem::path& path);

// The same from JSON text; `path` is used for messages and to resolve relative paths.
Scene parse_scene(const std::string& text, const std::filesystem::path& path,
                  const LoadOptions& options = {});

}  // namespace cierzo
