// A triangle mesh as the mesh readers return it (PLY: ply.h, OBJ: obj.h), before any
// transform: shared vertices with optional colours and normals, and triangles. (The readers
// include this; io/mesh.h, which reads a file by its extension, includes them.)
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace cierzo {

struct MeshData {
    std::vector<float> positions;   // 3 floats per vertex
    std::vector<float> colors;      // 3 floats per vertex in [0, 1], or empty
    std::vector<float> normals;     // 3 floats per vertex (as the file gives them, not
                                    // necessarily unit; a zero one is allowed), or empty
    std::vector<float> uvs;         // texture coordinates u, v per vertex, or empty
    std::vector<uint32_t> indices;  // 3 per triangle, each < vertex count
    // OBJ materials: the 'usemtl' names in order of first use ("" for faces before any), the
    // material of each triangle (an index into those names; empty when the file has no
    // 'usemtl'), and the files its 'mtllib' lines name, as written ('\' made '/')
    std::vector<std::string> material_names;
    std::vector<uint32_t> triangle_material;
    std::vector<std::string> libraries;
    // What the reader let pass but a user should hear of, each naming the file and line
    std::vector<std::string> warnings;
};

}  // namespace cierzo
