// Input files: the check every reader makes before it opens one (meshes, MTL libraries,
// image textures and environment maps, HDR images, scene files, checkpoints, ray files).
#pragma once

#include <filesystem>

namespace cierzo {

// Whether `path` names a file to read: true for a regular file (or a symbolic link to one),
// false when nothing is there (the caller says so in its own words). Anything else is
// refused before it is opened, as opening it could wait forever (a FIFO without a writer)
// or never reach an end (a device): throws InputError "PATH: is a FIFO (named pipe), not a
// regular file" (a directory, a character or block device, a socket), or "PATH: cannot
// read: WHY" when the path's status cannot be read (a loop of links, a folder without
// permission).
[[nodiscard]] bool input_file_exists(const std::filesystem::path& path);

}  // namespace cierzo
