// OBJ files' MTL materials as cierzo materials: the libraries read once, each material
// converted where a face first uses it, its texture maps requested (see mtl_materials.h).
#include "scene/mtl_materials.h"

#include <algorithm>
#include <system_error>

#include "core/error.h"

namespace cierzo {

namespace fs = std::filesystem;

const MtlLibrary& MtlMaterials::library(const fs::path& path, const fs::path& obj) {
    const fs::path key = path.lexically_normal();
    auto it = libraries.find(key);
    if (it != libraries.end()) return it->second;
    MtlLibrary lib;
    lib.path = path;
    std::error_code ec;
    if (!fs::exists(path, ec) && !ec) {
        // (OBJ files are often passed around without their MTL: tinyobjloader, Blender and
        // assimp read them all the same; so does cierzo, with the default material)
        scene.warnings.push_back(
            obj.string() + ": material library (mtllib) " + path.string() +
            ": file does not exist; the materials it would define take the default "
            "(diffuse grey 0.8)");
        return libraries.emplace(key, std::move(lib)).first->second;
    }
    lib = read_mtl(path);
    scene.files.push_back(path);
    for (const std::string& w : lib.warnings) scene.warnings.push_back(w);
    return libraries.emplace(key, std::move(lib)).first->second;
}

Material MtlMaterials::from_mtl(const MtlMaterial& mtl, const MtlLibrary& lib) {
    const fs::path folder = lib.path.parent_path();
    const auto solid = [](const float c[3]) {
        ColorSource s;
        s.a = {c[0], c[1], c[2]};
        return s;
    };
    const auto image = [&](const MtlMap& map, bool srgb) {
        ColorSource s;
        s.kind = TextureKind::kImage;
        s.a = Vec3f(1.0f);
        // (-colorspace, where the file gives it, over the map's default)
        s.image = images.request(folder / map.file, map.srgb >= 0 ? map.srgb == 1 : srgb,
                                 lib.path.string() + ": line " + std::to_string(map.line));
        s.uv_scale[0] = map.scale[0], s.uv_scale[1] = map.scale[1];
        s.uv_offset[0] = map.offset[0], s.uv_offset[1] = map.offset[1];
        s.clamp = map.clamp;
        return s;
    };
    Material m;
    m.name = lib.path.filename().string() + ":" + mtl.name;
    const float grey[3] = {0.8f, 0.8f, 0.8f};
    m.kd = mtl.map_kd ? image(*mtl.map_kd, true) : solid(mtl.has_kd ? mtl.kd_rgb : grey);
    const ColorSource ks = mtl.map_ks ? image(*mtl.map_ks, true) : solid(mtl.ks_rgb);
    const int illum = mtl.illum < 0 ? 2 : mtl.illum;
    if (illum == 3 || illum == 5 || illum == 8) {
        m.kr = ks;  // a mirror: Ks is its reflectance
    } else if (illum == 4 || illum == 6 || illum == 7 || illum == 9) {
        m.kr = ks;  // glass: Ks reflects, Tf transmits through the index Ni
        m.kt = solid(mtl.tf_rgb);
        if (!(mtl.ni > 0.0f))
            throw InputError(lib.path.string() + ": line " +
                             std::to_string(mtl.ni_line ? mtl.ni_line : mtl.line) + ": material '" +
                             mtl.name + "' is glass (illum " + std::to_string(illum) +
                             ") and needs an index Ni > 0");
        m.ior = mtl.ni;
    } else if (illum >= 2) {
        m.ks = ks;
        m.shininess = mtl.ns;
    }
    if (mtl.map_ke)
        m.emission = image(*mtl.map_ke, true);
    else if (mtl.has_ke)
        m.emission = solid(mtl.ke_rgb);
    // Dissolve: d (or 1 - Tr) is the opacity, map_d a mask; glass is transparent by
    // refraction, and its d is not applied (exporters write d < 1 for glass)
    const bool glass = !m.kt.is_zero();
    if (!glass) m.alpha.constant = mtl.d;
    if (!glass && mtl.d == 0.0f && mtl.d_from_tr && !mtl.map_d)
        scene.warnings.push_back(lib.path.string() + ": line " + std::to_string(mtl.d_line) +
                                 ": material '" + mtl.name +
                                 "' has 'Tr 1', fully transparent: it is invisible (some exporters "
                                 "write Tr as the opacity; 'd 1' would make it opaque)");
    if (mtl.map_d) {
        const ColorSource s = image(*mtl.map_d, true);  // (the bytes as they are: a mask)
        m.alpha.image = s.image;
        std::copy(s.uv_scale, s.uv_scale + 2, m.alpha.uv_scale);
        std::copy(s.uv_offset, s.uv_offset + 2, m.alpha.uv_offset);
        m.alpha.clamp = s.clamp;
        static const std::string channels = "rgbm";  // -imfchan: m, the matte, is alpha
        const size_t c = channels.find(mtl.map_d->channel);
        m.alpha.channel = mtl.map_d->channel != 0 && c != std::string::npos ? int32_t(c) : -1;
    }
    return m;
}

int32_t MtlMaterials::material(const std::string& name, const std::vector<const MtlLibrary*>& libs,
                               const std::string& obj) {
    for (const MtlLibrary* lib : libs) {
        const MtlMaterial* mtl = lib->find(name);
        if (!mtl) continue;
        const auto [it, added] = mtl_ids.try_emplace({lib->path.lexically_normal(), name},
                                                     int32_t(scene.materials.size()));
        if (added) scene.materials.push_back(from_mtl(*mtl, *lib));
        return it->second;
    }
    if (!name.empty())
        scene.warnings.push_back(obj + ": 'usemtl " + name +
                                 "' names a material no "
                                 "material library of the file defines: its faces take "
                                 "the default material (diffuse grey 0.8)");
    if (default_material < 0) {
        Material m;
        m.name = "(OBJ default)";
        m.kd.a = Vec3f(0.8f);
        default_material = int32_t(scene.materials.size());
        scene.materials.push_back(m);
    }
    return default_material;
}

}  // namespace cierzo
