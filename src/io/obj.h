// Wavefront OBJ mesh reader (through tinyobjloader): vertex positions, optional vertex colours
// ("v x y z r g b") and normals ("vn"), polygonal faces of any size, fan-triangulated like PLY
// faces. Every group and object of the file goes into one mesh; texture coordinates,
// materials (mtllib, usemtl), lines, points and free-form geometry are ignored.
#pragma once

#include <filesystem>
#include <string_view>

#include "io/mesh_data.h"

namespace cierzo {

// Throws InputError naming the file (and the line, where there is one) and what is wrong: a
// number that does not parse or is outside the float range, a vertex of the wrong number of
// values, a face of fewer than 3 corners or with an index of 0 or out of range, no faces.
// A corner's normal comes from its "v//vn" or "v/vt/vn" index; a vertex used with different
// normals is split. Normals are kept only when every corner of every face names one.
MeshData read_obj(const std::filesystem::path& path);

// The same from the bytes of an OBJ file held in memory; `name` is only used in messages.
MeshData parse_obj(std::string_view bytes, const std::filesystem::path& name);

}  // namespace cierzo
