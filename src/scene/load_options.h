// What reading a scene may do beyond its own file: which folders its inputs may come from
// (a scene downloaded from anywhere reads only beneath its own folder unless the user allows
// more) and how much memory its decoded images may take (charged from each image's header,
// before any is decoded).
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

namespace cierzo {

// The default budget of a scene's decoded images: 4 GiB, or half the machine's memory where
// that is less. 4 GiB holds an 8192 × 4096 HDR environment map with its sampling tables
// (charged 2.0 GB: 60 bytes a texel) and dozens of 4096² 8-bit textures (128 MB each while
// decoded); a 16384² image, the largest accepted, is charged 2 GiB as an 8-bit texture and 9 GiB as
// an environment, where it needs the budget raised.
uint64_t default_image_memory();

struct LoadOptions {
    // Folders besides the scene file's own that its inputs (meshes, MTL libraries, images)
    // may come from (--allow-path); "/" allows any.
    std::vector<std::filesystem::path> allowed_paths;
    // The most a scene's images may take decoded, in bytes, their sampling tables included
    // (--image-memory); refused from the headers, before anything is decoded.
    uint64_t image_memory = default_image_memory();
    // The command line names the output (--out): the scene's "output" is then not used, and
    // not checked against the scene's folder.
    bool output_named = false;
};

// "4 GiB", "512 MiB", "1.5 GiB": a byte count for messages.
std::string format_bytes(uint64_t bytes);

// Parses a byte count as the command line takes it: a number with an optional suffix K, M,
// G or T (powers of 1024; "KiB", "MB" and the like too), e.g. "8G", "1536M", "0.5G".
// Throws InputError naming `option` for anything else or a value over 2^50 bytes.
uint64_t parse_bytes(const std::string& text, const std::string& option);

// `p` absolute, its links and its . and .. resolved (as far as it exists).
std::filesystem::path resolved_path(const std::filesystem::path& p);

// The folders a scene's inputs may come from: the scene file's folder and the allowed paths,
// each resolved (absolute, links followed). A named input is refused when the file it
// resolves to (links followed) lies outside all of them.
class InputRoots {
public:
    InputRoots() = default;  // (no confinement: every path is allowed)
    InputRoots(const std::filesystem::path& scene_file,
               const std::vector<std::filesystem::path>& allowed);

    // Whether `path` (as named, relative to the working folder or absolute) lies beneath one
    // of the roots.
    bool allows(const std::filesystem::path& path) const;

    // Empty when `path` is allowed; else the reason, for a message: "'NAME' resolves to
    // PATH, outside the scene's folder DIR ... (--allow-path DIR allows another folder)".
    std::string refusal(const std::filesystem::path& path, const std::string& named) const;

    const std::filesystem::path& folder() const { return roots_.front(); }  // (confined)

private:
    std::vector<std::filesystem::path> roots_;
    bool confined_ = false;
};

}  // namespace cierzo
