// The fuzz targets: each parses the input, treats an InputError as a correct refusal and
// checks the invariants of whatever was accepted; every other outcome aborts the process,
// which is what libFuzzer and the fuzz_regressions test report as a failure.
#include "fuzz_targets.h"

#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "core/error.h"
#include "io/mtl.h"
#include "io/obj.h"
#include "io/ply.h"
#include "io/texture_image.h"
#include "scene/scene_json.h"

#ifndef CIERZO_FUZZ_SCENE_ROOT
#error "CIERZO_FUZZ_SCENE_ROOT must name tests/fuzz/scene_root"
#endif

namespace cierzo {
namespace {

namespace fs = std::filesystem;

// An accepted input that breaks an invariant is a bug, reported like a crash.
void require(bool ok, const char* what) {
    if (ok) return;
    std::fprintf(stderr, "fuzz: accepted input breaks an invariant: %s\n", what);
    std::abort();
}

bool finite(const Vec3f& v) {
    return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z);
}

bool valid_colour(const ColorSource& c) {
    return finite(c.a) && finite(c.b) && std::isfinite(c.frequency) && finite(c.axis) &&
           finite(c.axis2) && c.a.x >= 0 && c.a.y >= 0 && c.a.z >= 0 && c.b.x >= 0 && c.b.y >= 0 &&
           c.b.z >= 0;
}

// ---- Scene files -----------------------------------------------------------------------

// Whether a mesh "file" value resolves inside the scene's folder: relative, without "..".
// Anything else would let the fuzzer read arbitrary files (/dev/stdin, the growing corpus),
// which makes runs depend on the machine; such inputs are skipped, not parsed.
bool stays_inside(const std::string& name) {
    const fs::path p(name);
    if (p.has_root_name() || p.has_root_directory()) return false;
    for (const fs::path& part : p)
        if (part == "..") return false;
    return true;
}

// Every string under a "file" key, anywhere in the document, must stay inside. The JSON is
// read exactly as parse_scene reads it; a walk with an explicit stack copes with any depth.
bool mesh_files_stay_inside(const std::string& text) {
    nlohmann::json root;
    try {
        root = nlohmann::json::parse(text, nullptr, true, /*ignore_comments=*/true);
    } catch (const nlohmann::json::exception&) {
        return true;  // parse_scene refuses it before looking at any file
    }
    std::vector<const nlohmann::json*> stack = {&root};
    while (!stack.empty()) {
        const nlohmann::json& j = *stack.back();
        stack.pop_back();
        if (j.is_object()) {
            for (auto it = j.begin(); it != j.end(); ++it) {
                if (it.key() == "file" && it->is_string() && !stays_inside(it->get<std::string>()))
                    return false;
                stack.push_back(&*it);
            }
        } else if (j.is_array()) {
            for (const nlohmann::json& item : j) stack.push_back(&item);
        }
    }
    return true;
}

void check_scene(const Scene& s) {
    const auto material_ok = [&](int32_t m) { return m >= 0 && size_t(m) < s.materials.size(); };
    require(s.settings.width >= 1 && s.settings.height >= 1 &&
                int64_t(s.settings.width) * s.settings.height <= (int64_t(1) << 28),
            "image size within limits");
    require(s.settings.spp >= 1, "spp >= 1");
    require(s.settings.estimator.survival_cap > 0 && s.settings.estimator.survival_cap < 1,
            "survival_cap in (0, 1)");
    require(std::isfinite(s.scene_ior) && s.scene_ior > 0, "scene_ior finite and > 0");
    require(finite(s.camera.origin) && finite(s.camera.forward) && finite(s.camera.left) &&
                finite(s.camera.up),
            "camera frame finite");
    for (float u : {-1.0f, 1.0f})
        for (float v : {-1.0f, 1.0f}) {
            const Vec3f d = s.camera.forward + s.camera.left * u + s.camera.up * v;
            require(std::isfinite(dot(d, d)), "camera ray directions can be normalised");
        }
    if (s.look_at)
        require(dot(s.camera.up, s.look_at->up) > 0.0f, "look_at camera not upside down");
    for (const Material& m : s.materials) {
        for (const ColorSource* c : {&m.emission, &m.kd, &m.ks, &m.kr, &m.kt})
            require(valid_colour(*c), "material colours finite and >= 0");
        require(std::isfinite(m.shininess) && m.shininess >= 0, "shininess finite and >= 0");
        require(std::isfinite(m.ior) && m.ior > 0, "ior finite and > 0");
    }
    for (size_t i = 0; i < s.spheres.size(); ++i) {
        require(finite({s.spheres.cx[i], s.spheres.cy[i], s.spheres.cz[i]}),
                "sphere centre finite");
        require(std::isfinite(s.spheres.radius[i]) && s.spheres.radius[i] > 0,
                "sphere radius finite and > 0");
        require(material_ok(s.spheres.material[i]), "sphere material in range");
    }
    for (size_t i = 0; i < s.planes.size(); ++i) {
        const Vec3f n{s.planes.nx[i], s.planes.ny[i], s.planes.nz[i]};
        require(finite(n) && std::fabs(length(n) - 1.0f) < 1e-3f, "plane normal unit length");
        require(std::isfinite(s.planes.distance[i]), "plane distance finite");
        require(material_ok(s.planes.material[i]), "plane material in range");
    }
    for (const Quadric& q : s.quadrics) {
        const QuadricCoefficients<float>& k = q.q;
        for (float c : {k.a, k.b, k.c, k.d, k.e, k.f, k.g, k.h, k.i, k.j})
            require(std::isfinite(c), "quadric coefficients finite");
        require(material_ok(q.material), "quadric material in range");
    }
    for (size_t i = 0; i < s.meshes.size(); ++i) {
        const Mesh& object = s.meshes[i];
        require(object.geometry < int32_t(s.meshes.size()), "instance geometry in range");
        if (object.instanced()) {
            const Mesh& g = s.meshes[size_t(object.geometry)];
            require(g.geometry == object.geometry && g.bvh, "instance geometry owns its BVH");
            for (const float v : object.to_world)
                require(std::isfinite(v), "instance transform finite");
            for (const float v : object.to_object)
                require(std::isfinite(v), "instance inverse finite");
        }
        if (object.instanced() && object.geometry != int32_t(i)) {
            require(object.positions.empty() && object.indices.empty(),
                    "an instance keeps no vertices of its own");
            require(material_ok(object.material), "mesh material in range");
            continue;
        }
        const Mesh& m = object;
        require(!m.indices.empty() && m.indices.size() % 3 == 0, "mesh has whole triangles");
        for (uint32_t i : m.indices) require(i < m.positions.size(), "mesh index in range");
        for (const Vec3f& p : m.positions) require(finite(p), "mesh vertex finite");
        require(m.colors.empty() || m.colors.size() == m.positions.size(),
                "one colour per mesh vertex");
        require(m.normals.empty() || m.normals.size() == m.positions.size(),
                "one normal per mesh vertex");
        for (const Vec3f& n : m.normals)
            require(finite(n) && (dot(n, n) == 0.0f || std::fabs(dot(n, n) - 1.0f) < 1e-4f),
                    "mesh normal unit or zero");
        for (const Vec3f& c : m.colors) require(finite(c), "mesh colour finite");
        require(material_ok(m.material), "mesh material in range");
    }
    for (const PointLight& l : s.lights)
        require(finite(l.position) && finite(l.intensity), "light finite");
}

// ---- Mesh files (PLY, OBJ) ---------------------------------------------------------------

void check_mesh(const MeshData& m) {
    require(m.positions.size() % 3 == 0, "three coordinates per vertex");
    require(m.colors.empty() || m.colors.size() == m.positions.size(), "one colour per vertex");
    require(m.normals.empty() || m.normals.size() == m.positions.size(), "one normal per vertex");
    for (float n : m.normals) require(std::isfinite(n), "normal finite");
    require(m.indices.size() % 3 == 0, "three indices per triangle");
    const size_t vertices = m.positions.size() / 3;
    for (uint32_t i : m.indices) require(i < vertices, "index in range");
    for (float x : m.positions) require(std::isfinite(x), "coordinate finite");
    for (float c : m.colors) require(std::isfinite(c), "colour finite");
}

}  // namespace

bool fuzz_one_scene(const uint8_t* data, size_t size) {
    const std::string text(reinterpret_cast<const char*>(data), size);
    if (!mesh_files_stay_inside(text)) return false;
    try {
        check_scene(parse_scene(text, fs::path(CIERZO_FUZZ_SCENE_ROOT) / "fuzz.json"));
        return true;
    } catch (const InputError&) {
        return false;
    }
}

bool fuzz_one_ply(const uint8_t* data, size_t size) {
    try {
        check_mesh(
            parse_ply(std::string_view(reinterpret_cast<const char*>(data), size), "fuzz.ply"));
        return true;
    } catch (const InputError&) {
        return false;
    }
}

bool fuzz_one_mtl(const uint8_t* data, size_t size) {
    try {
        const MtlLibrary lib =
            parse_mtl(std::string_view(reinterpret_cast<const char*>(data), size), "fuzz.mtl");
        for (const MtlMaterial& m : lib.materials) {
            for (const float* c : {m.kd_rgb, m.ks_rgb, m.ke_rgb, m.tf_rgb})
                for (int i = 0; i < 3; ++i)
                    require(std::isfinite(c[i]) && c[i] >= 0.0f, "MTL colour finite and >= 0");
            require(std::isfinite(m.ns) && m.ns >= 0.0f && m.ns <= 1e6f, "Ns in [0, 1e6]");
            require(std::isfinite(m.ni) && m.ni >= 0.0f, "Ni finite and >= 0");
            require(m.d >= 0.0f && m.d <= 1.0f, "d in [0, 1]");
            require(m.illum >= -1 && m.illum <= 10, "illum in range");
            for (const auto* map : {&m.map_kd, &m.map_ks, &m.map_ke, &m.map_d})
                if (*map)
                    require(!(*map)->file.empty() && std::isfinite((*map)->scale[0]) &&
                                std::isfinite((*map)->scale[1]) &&
                                std::isfinite((*map)->offset[0]) &&
                                std::isfinite((*map)->offset[1]),
                            "a map names a file, with finite options");
        }
        return true;
    } catch (const InputError&) {
        return false;
    }
}

bool fuzz_one_obj(const uint8_t* data, size_t size) {
    const std::string_view all(reinterpret_cast<const char*>(data), size);
    const size_t split = all.find("\n#%mtl\n");
    const std::string_view obj = all.substr(0, split);
    bool ok = true;
    if (split != std::string_view::npos) {
        const std::string_view mtl = all.substr(split + 7);
        ok = fuzz_one_mtl(reinterpret_cast<const uint8_t*>(mtl.data()), mtl.size());
    }
    try {
        const MeshData m = parse_obj(obj, "fuzz.obj");
        check_mesh(m);
        require(m.uvs.empty() || m.uvs.size() / 2 == m.positions.size() / 3,
                "one texture coordinate per vertex");
        for (float t : m.uvs) require(std::isfinite(t), "texture coordinate finite");
        require(m.triangle_material.empty() || m.triangle_material.size() == m.indices.size() / 3,
                "one material per triangle");
        for (uint32_t g : m.triangle_material)
            require(g < m.material_names.size(), "triangle material in range");
        return ok;
    } catch (const InputError&) {
        return false;
    }
}

bool fuzz_one_image(const uint8_t* data, size_t size) {
    const std::string bytes(reinterpret_cast<const char*>(data), size);
    // An EXR is read from a file (OpenEXR's reader); anything else from memory, as a TGA
    // where it has no other format's signature
    const bool exr = bytes.compare(0, 4, "\x76\x2f\x31\x01") == 0;
    static const fs::path exr_file =
        fs::temp_directory_path() / ("cierzo-fuzz-" + std::to_string(::getpid()) + ".exr");
    struct Removed {
        bool on;
        ~Removed() {
            if (on) std::remove(exr_file.c_str());
        }
    } removed{exr};
    if (exr) {
        std::FILE* f = std::fopen(exr_file.c_str(), "wb");
        require(f && std::fwrite(bytes.data(), 1, bytes.size(), f) == bytes.size() &&
                    std::fclose(f) == 0,
                "the EXR input can be written to a scratch file");
    }
    try {
        for (const bool srgb : {true, false}) {
            const TextureImage t = exr ? read_texture_image(exr_file, srgb)
                                       : decode_texture_image(bytes, "fuzz.tga", srgb);
            require(t.width >= 1 && t.height >= 1 && t.width <= kMaxTextureSide &&
                        t.height <= kMaxTextureSide && int64_t(t.texels()) <= kMaxTextureTexels,
                    "image dimensions within limits");
            require(t.bytes.size() == t.texels() || t.floats.size() == 4 * t.texels(),
                    "one RGBA texel per pixel");
            require(t.bytes.empty() != t.floats.empty(), "bytes or floats, not both");
            for (float f : t.floats)
                require(std::isfinite(f) && f >= 0.0f, "texel finite and >= 0");
            for (int c = 0; c < 3; ++c)
                require(std::isfinite(t.max_rgb[c]) && std::isfinite(t.mean_rgb[c]) &&
                            t.mean_rgb[c] <= double(t.max_rgb[c]) * (1.0 + 1e-6) + 1e-30,
                        "image statistics finite, mean <= max");
        }
        return true;
    } catch (const InputError&) {
        return false;
    }
}

}  // namespace cierzo
