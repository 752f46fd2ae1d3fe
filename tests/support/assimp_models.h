#pragma once
// Debian's assimp-testmodels: real files of many exporters (OBJ with MTL libraries and JPEG
// textures, PLY, malformed files among them), read by the readers' tests where installed.

#include <filesystem>
#include <string>

namespace cierzo::test {

inline const std::filesystem::path kAssimpModels = "/usr/share/assimp/models";

// Why a test of these files is skipped where they are missing
inline std::string assimp_models_missing() {
    return kAssimpModels.string() +
           " is missing (Debian package assimp-testmodels, which "
           "scripts/install_deps.sh installs for the tests)";
}

}  // namespace cierzo::test
