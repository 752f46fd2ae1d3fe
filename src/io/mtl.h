// Wavefront MTL material libraries (the materials an OBJ file's 'mtllib' names), read by
// cierzo's own line parser so every value is checked and every refusal names the line. MTL's
// model is the report's Phong model: Kd, Ks and Ns (the Phong exponent), plus emission (Ke),
// mirror and glass through 'illum', dissolve (d, Tr) and texture maps. How each key becomes a
// cierzo material: docs/scene-format.md, "OBJ materials (MTL)".
#pragma once

#include <cstddef>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace cierzo {

// A texture map statement ("map_Kd -s 2 2 1 wood.png"): the file as written (Windows '\'
// separators turned into '/'), and the options cierzo uses.
struct MtlMap {
    std::string file;
    float scale[2] = {1.0f, 1.0f};   // -s u v
    float offset[2] = {0.0f, 0.0f};  // -o u v
    bool clamp = false;              // -clamp on
    char channel = 0;                // -imfchan r|g|b|m|l|z (0: not given)
    int srgb = -1;                   // -colorspace sRGB (1) | linear (0); -1: not given
    size_t line = 0;
};

struct MtlMaterial {
    std::string name;
    size_t line = 0;  // of its 'newmtl'
    // Colours (linear RGB) as given, with whether the file gives them; scalars as given
    bool has_kd = false, has_ks = false, has_ke = false, has_tf = false;
    float kd_rgb[3] = {0, 0, 0}, ks_rgb[3] = {0, 0, 0}, ke_rgb[3] = {0, 0, 0},
          tf_rgb[3] = {1, 1, 1};
    float ns = 0.0f;  // Phong exponent
    float ni = 1.0f;  // index of refraction (0 when a file leaves it unset)
    size_t ni_line = 0;
    float d = 1.0f;          // dissolve (opacity): 1 opaque; Tr is 1 - d
    size_t d_line = 0;       // the line that set it (0: not given)
    bool d_from_tr = false;  // set by Tr (the later of d and Tr wins)
    int illum = -1;          // illumination model, -1 when not given
    std::optional<MtlMap> map_kd, map_ks, map_ke, map_d;
};

struct MtlLibrary {
    std::filesystem::path path;
    std::vector<MtlMaterial> materials;
    // Keys cierzo cannot model (bump and normal maps, PBR extensions, reflection maps...),
    // one message per key and file, and each 'newmtl' without a name: "FILE: line N: ...",
    // in file order
    std::vector<std::string> warnings;
    const MtlMaterial* find(std::string_view name) const {
        for (const MtlMaterial& m : materials)
            if (m.name == name) return &m;
        return nullptr;
    }
};

// Throws InputError naming the file and line: a number that does not parse or is out of
// range (colours finite and >= 0, Ns in [0, 1e6], Ni in [0, 1000], d and Tr in [0, 1], illum
// 0..10), a colour given as a spectral curve or in CIE XYZ, a value before the first 'newmtl', a
// map without a file name, a name defined twice. A 'newmtl' without a name is a warning; its
// material is called "#unnamed-line-N" (N its line), which no 'newmtl' can name, as '#'
// starts a comment.
MtlLibrary read_mtl(const std::filesystem::path& path);
MtlLibrary parse_mtl(std::string_view bytes, const std::filesystem::path& name);

}  // namespace cierzo
