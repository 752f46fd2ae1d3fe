// read_mesh: the mesh readers by file extension; and read_mesh_bytes, a whole file read into
// memory (for image textures: the mesh readers map theirs, read_mapped in mesh_file.h).
#include "io/mesh.h"

#include <algorithm>
#include <cctype>
#include <fstream>
#include <string>

#include "core/error.h"
#include "io/input_file.h"
#include "io/mesh_file.h"
#include "io/obj.h"
#include "io/ply.h"

namespace cierzo {

std::string read_mesh_bytes(const std::filesystem::path& path) {
    const std::string name = path.string();
    const auto fail = [&](const std::string& what) { throw InputError(name + ": " + what); };
    if (!input_file_exists(path)) fail("file does not exist");
    std::ifstream in(path, std::ios::binary);
    if (!in) fail("cannot open file for reading");
    in.seekg(0, std::ios::end);
    const std::streamoff size = in.tellg();
    if (size < 0) fail("cannot determine the file size");
    in.seekg(0, std::ios::beg);
    std::string bytes(size_t(size), '\0');
    if (!in.read(bytes.data(), size)) fail("read error");
    return bytes;
}

MeshData read_mesh(const std::filesystem::path& path) {
    std::string ext = path.extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(),
                   [](unsigned char c) { return char(std::tolower(c)); });
    if (ext == ".ply") return read_ply(path);
    if (ext == ".obj") return read_obj(path);
    throw InputError(path.string() + ": unknown mesh format '" + path.extension().string() +
                     "' (cierzo reads .ply and .obj files)");
}

}  // namespace cierzo
