// The fuzz targets: each parses the input, treats an InputError as a correct refusal and
// checks the invariants of whatever was accepted; every other outcome aborts the process,
// which is what libFuzzer and the fuzz_regressions test report as a failure.
#include "fuzz_targets.h"

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "core/error.h"
#include "io/obj.h"
#include "io/ply.h"
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
           finite(c.axis2) && c.a.x >= 0 && c.a.y >= 0 && c.a.z >= 0 && c.b.x >= 0 &&
           c.b.y >= 0 && c.b.z >= 0;
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
                if (it.key() == "file" && it->is_string() &&
                    !stays_inside(it->get<std::string>()))
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
            for (const float v : object.to_world) require(std::isfinite(v), "instance transform finite");
            for (const float v : object.to_object) require(std::isfinite(v), "instance inverse finite");
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
    require(m.colors.empty() || m.colors.size() == m.positions.size(),
            "one colour per vertex");
    require(m.normals.empty() || m.normals.size() == m.positions.size(),
            "one normal per vertex");
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
        check_mesh(parse_ply(std::string_view(reinterpret_cast<const char*>(data), size),
                             "fuzz.ply"));
        return true;
    } catch (const InputError&) {
        return false;
    }
}

bool fuzz_one_obj(const uint8_t* data, size_t size) {
    try {
        check_mesh(parse_obj(std::string_view(reinterpret_cast<const char*>(data), size),
                             "fuzz.obj"));
        return true;
    } catch (const InputError&) {
        return false;
    }
}

}  // namespace cierzo
