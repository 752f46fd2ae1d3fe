// The scene file's objects read into the scene: spheres, planes, quadrics, loose triangles
// and mesh files, each file read once and its objects put into world space or traced as
// instances of it, through their transforms (Loader, scene_loader.h).
#include "scene/scene_loader.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <map>
#include <string>
#include <utility>
#include <vector>

namespace cierzo::scene_file {

namespace {

// A normal scaled to unit length (in double: any finite one), or 0 when it has none.
Vec3f unit_or_zero(const Vec3f& n) {
    const double len = std::sqrt(double(n.x) * n.x + double(n.y) * n.y + double(n.z) * n.z);
    if (!(len > 0.0) || !std::isfinite(len)) return Vec3f(0.0f);
    return {float(n.x / len), float(n.y / len), float(n.z / len)};
}

}  // namespace

MeshData Loader::group_of(const MeshData& data, uint32_t g) {
    MeshData out;
    std::vector<uint32_t> remap(data.positions.size() / 3, UINT32_MAX);
    for (size_t tri = 0; tri < data.triangle_material.size(); ++tri) {
        if (data.triangle_material[tri] != g) continue;
        for (size_t k = 0; k < 3; ++k) {
            const uint32_t v = data.indices[3 * tri + k];
            if (remap[v] == UINT32_MAX) {
                remap[v] = uint32_t(out.positions.size() / 3);
                const auto copy = [v](const std::vector<float>& from, std::vector<float>& to,
                                      size_t n) {
                    if (!from.empty())
                        to.insert(to.end(), from.begin() + n * v, from.begin() + n * (v + 1));
                };
                copy(data.positions, out.positions, 3);
                copy(data.colors, out.colors, 3);
                copy(data.normals, out.normals, 3);
                copy(data.uvs, out.uvs, 2);
            }
            out.indices.push_back(remap[v]);
        }
    }
    return out;
}

void Loader::object(const json& j, const std::string& where) {
    Reader r(j, where, file);
    const std::string type = r.string("type");
    Reader t(j, where + " (" + type + ")", file);
    t.allow({"type"});
    if (type == "sphere") {
        const Vec3f c = t.vec3("center");
        const double radius = t.number("radius");
        if (!(radius > 0.0)) t.fail("'radius' must be > 0, got " + std::to_string(radius));
        auto& s = scene.spheres;
        s.cx.push_back(c.x), s.cy.push_back(c.y), s.cz.push_back(c.z);
        s.radius.push_back(float(radius));
        s.material.push_back(material_ref(t));
    } else if (type == "plane") {
        // Rescaled first, so that a normal of any size has a length: n·p + d = 0 is the
        // plane (n/|n|)·p + d/|n| = 0, with d/|n| in double and then range-checked (for
        // in-range values, rounding that to float gives exactly the float quotient)
        int exponent = 0;
        const Vec3f n = rescaled(t.vec3("normal"), &exponent);
        const float len = length(n);
        if (!(len > 0.0f)) t.fail("'normal' must not be the zero vector");
        const double given = float(t.number("distance"));
        const double distance = std::ldexp(given, -exponent) / double(len);
        if (!(std::fabs(distance) <= double(std::numeric_limits<float>::max())))
            t.fail("'distance' / |normal| is beyond float range (" + short_number(distance) +
                   "): the plane is too far from the origin");
        auto& p = scene.planes;
        p.nx.push_back(n.x / len), p.ny.push_back(n.y / len), p.nz.push_back(n.z / len);
        p.distance.push_back(float(distance));
        p.material.push_back(material_ref(t));
    } else if (type == "quadric") {
        quadric(t);
    } else if (type == "triangle") {
        triangle(t);
    } else if (type == "mesh") {
        mesh(t);
    } else {
        t.fail("unknown object type '" + type +
               "' (valid: sphere, plane, quadric, triangle, mesh)");
    }
    t.finish();
}

void Loader::quadric(Reader& t) {
    const json& c = t.get("coefficients");
    if (!c.is_array() || c.size() != 10)
        t.fail(
            "'coefficients' must be an array of 10 numbers [A..J] of "
            "Ax²+By²+Cz²+Dxy+Eyz+Fxz+Gx+Hy+Iz+J=0");
    float k[10];
    for (size_t i = 0; i < 10; ++i) {
        if (!c[i].is_number() || !std::isfinite(c[i].get<float>()))
            t.fail("'coefficients' must be 10 finite numbers");
        k[i] = c[i].get<float>();
    }
    bool any_nonconstant = false;
    for (int i = 0; i < 9; ++i) any_nonconstant |= k[i] != 0.0f;
    if (!any_nonconstant) t.fail("'coefficients' A..I are all zero: not a surface");
    Quadric q;
    q.q = {k[0], k[1], k[2], k[3], k[4], k[5], k[6], k[7], k[8], k[9]};
    q.box_min = Vec3f(-kRayFar);
    q.box_max = Vec3f(kRayFar);
    if (t.has("bounds")) {
        Reader b(t.get("bounds"), t.where("bounds"), file);
        q.box_min = b.vec3("min");
        q.box_max = b.vec3("max");
        b.finish();
        if (!(q.box_min.x <= q.box_max.x && q.box_min.y <= q.box_max.y &&
              q.box_min.z <= q.box_max.z))
            t.fail("'bounds': min must be <= max on every axis");
    }
    q.material = material_ref(t);
    scene.quadrics.push_back(q);
}

void Loader::triangle(Reader& t) {
    const json& v = t.get("vertices");
    if (!v.is_array() || v.size() != 3) t.fail("'vertices' must be 3 points [[x,y,z], ...]");
    const int32_t mat = material_ref(t);
    Mesh& m = loose_triangles[mat];
    m.material = mat;
    m.source = file.string() + " (triangles)";
    const uint32_t base = uint32_t(m.positions.size());
    for (size_t i = 0; i < 3; ++i) {
        const json wrapped = json::object({{"p", v[i]}});  // outlives the Reader using it
        Reader tmp(wrapped, t.where("vertices"), file);
        m.positions.push_back(tmp.vec3("p"));
    }
    if (t.has("colors")) {
        const json& c = t.get("colors");
        if (!c.is_array() || c.size() != 3) t.fail("'colors' must be 3 colours, one per vertex");
        for (size_t i = 0; i < 3; ++i) m.colors.push_back(colour_value(t, c[i], "colors"));
    } else {
        t.allow({"colors"});
        m.colors.insert(m.colors.end(), 3, Vec3f(1.0f));
    }
    // Texture coordinates: given, or (0, 0), (1, 0), (0, 1)
    if (t.has("uvs")) {
        const json& uv = t.get("uvs");
        const auto ok = [](const json& x) {
            return x.is_array() && x.size() == 2 && x[0].is_number() && x[1].is_number() &&
                   std::fabs(x[0].get<double>()) <= 1e6 && std::fabs(x[1].get<double>()) <= 1e6;
        };
        if (!uv.is_array() || uv.size() != 3 || !ok(uv[0]) || !ok(uv[1]) || !ok(uv[2]))
            t.fail(
                "'uvs' must be 3 texture coordinates [[u, v], [u, v], [u, v]], each at "
                "most 1e6 in magnitude");
        for (size_t i = 0; i < 3; ++i)
            m.uvs.insert(m.uvs.end(), {uv[i][0].get<float>(), uv[i][1].get<float>()});
    } else {
        t.allow({"uvs"});
        m.uvs.insert(m.uvs.end(), {0.0f, 0.0f, 1.0f, 0.0f, 0.0f, 1.0f});
    }
    for (uint32_t i = 0; i < 3; ++i) m.indices.push_back(base + i);
}

void Loader::mesh(Reader& t) {
    int instance = -1;  // automatic
    if (t.has("instance")) {
        const json& v = t.get("instance");
        if (!v.is_boolean()) t.fail("'instance' must be true or false");
        instance = v.get<bool>() ? 1 : 0;
    }
    bool smooth = false;
    if (t.has("smooth")) {
        const json& v = t.get("smooth");
        if (!v.is_boolean()) t.fail("'smooth' must be true or false");
        smooth = v.get<bool>();
    } else {
        t.allow({"smooth"});
    }
    const fs::path ply = input(t, file.parent_path(), "file", t.string("file"));
    const fs::path key = ply.lexically_normal();
    auto raw = raw_meshes.find(key);
    if (raw == raw_meshes.end()) {
        MeshData data;
        try {
            data = read_mesh(ply);
        } catch (const InputError& e) {
            t.fail(std::string("mesh file: ") + e.what());
        }
        if (data.indices.empty()) t.fail("'" + ply.string() + "' has no faces");
        for (const std::string& w : data.warnings) scene.warnings.push_back(w);
        scene.files.push_back(ply);
        raw = raw_meshes.emplace(key, std::move(data)).first;
    }
    const MeshData& data = raw->second;
    // The objects to add: the whole file with the object's material, or with the file's
    // own materials one object per material group
    std::vector<std::pair<fs::path, int32_t>> parts;  // (mesh_files key, material)
    if (t.has("material") || data.material_names.empty()) {
        if (!t.has("material"))
            t.fail("missing required key 'material' ('" + ply.string() +
                   "' names no materials of its own: no 'usemtl')");
        if (t.has("materials"))
            t.fail(
                "'materials' overrides the OBJ file's own materials by name; with "
                "'material' every face takes that one");
        t.allow({"materials"});
        const int32_t mat = material_ref(t);
        parts.push_back({key, mat});
    } else {
        t.allow({"material"});
        std::vector<const MtlLibrary*> libs;
        for (const std::string& name : data.libraries) {
            const fs::path lib = ply.parent_path() / name;
            const std::string why = roots.refusal(lib, name);
            if (!why.empty()) t.fail("'" + ply.string() + "': material library (mtllib): " + why);
            try {
                libs.push_back(&mtl.library(lib, ply));
            } catch (const InputError& e) {
                t.fail(std::string("material library (mtllib): ") + e.what());
            }
        }
        std::map<std::string, int32_t> overrides;
        if (t.has("materials")) {
            const json& o = t.get("materials");
            if (!o.is_object()) t.fail("'materials' must be an object of MTL name: material");
            for (auto it = o.begin(); it != o.end(); ++it) {
                if (std::find(data.material_names.begin(), data.material_names.end(), it.key()) ==
                    data.material_names.end()) {
                    std::string known;
                    for (const std::string& n : data.material_names)
                        if (!n.empty()) known += (known.empty() ? "" : ", ") + n;
                    t.fail("'materials' overrides '" + it.key() + "', which '" + ply.string() +
                           "' does not use (its materials: " + known + ")");
                }
                overrides[it.key()] =
                    material_value(t, it.value(), t.where("materials." + it.key()));
            }
        } else {
            t.allow({"materials"});
        }
        std::vector<size_t> used(data.material_names.size(), 0);
        for (const uint32_t g : data.triangle_material) ++used[g];
        for (uint32_t g = 0; g < data.material_names.size(); ++g) {
            if (used[g] == 0) continue;
            const std::string& name = data.material_names[g];
            const auto o = overrides.find(name);
            const int32_t mat =
                o != overrides.end() ? o->second : mtl.material(name, libs, ply.string());
            parts.push_back({fs::path(key.string() + "#" + std::to_string(g)), mat});
        }
    }
    for (const auto& [part, material] : parts) {
        if (mesh_files.find(part) != mesh_files.end()) continue;
        MeshData piece =
            part == key
                ? data
                : group_of(data,
                           uint32_t(std::stoul(part.string().substr(key.string().size() + 1))));
        mesh_files.emplace(part, MeshFile{std::move(piece), {}, {}, {}, 0});
    }
    // Transform: scale, then rotate about x, y, z (degrees), then translate
    Vec3f scale(1.0f);
    if (t.has("scale")) {
        const json& s = t.get("scale");
        scale = s.is_number() ? Vec3f(s.get<float>()) : t.vec3("scale");
        if (!(std::isfinite(scale.x) && std::isfinite(scale.y) && std::isfinite(scale.z)))
            t.fail("'scale' must be finite");
        if (!(scale.x != 0.0f && scale.y != 0.0f && scale.z != 0.0f))
            t.fail("'scale' must be non-zero on every axis");
    }
    const Vec3f rot = t.vec3("rotate", Vec3f(0.0f)) * (kPi / 180.0f);
    const Vec3f move = t.vec3("translate", Vec3f(0.0f));
    const auto transform = [&](Vec3f p) {
        p = {p.x * scale.x, p.y * scale.y, p.z * scale.z};
        float c = std::cos(rot.x), s = std::sin(rot.x);
        p = {p.x, c * p.y - s * p.z, s * p.y + c * p.z};
        c = std::cos(rot.y), s = std::sin(rot.y);
        p = {c * p.x + s * p.z, p.y, -s * p.x + c * p.z};
        c = std::cos(rot.z), s = std::sin(rot.z);
        p = {c * p.x - s * p.y, s * p.x + c * p.y, p.z};
        return p + move;
    };
    // The same map as a matrix, for instancing: to_world = T Rz Ry Rx S, in double
    double a[3][3] = {{scale.x, 0, 0}, {0, scale.y, 0}, {0, 0, scale.z}};
    const auto rotate = [&](int axis, double angle) {
        const double c = std::cos(double(float(angle))), s = std::sin(double(float(angle)));
        double r[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
        const int i = (axis + 1) % 3, j = (axis + 2) % 3;
        r[i][i] = c, r[i][j] = -s, r[j][i] = s, r[j][j] = c;
        double out[3][3];
        for (int x = 0; x < 3; ++x)
            for (int y = 0; y < 3; ++y)
                out[x][y] = r[x][0] * a[0][y] + r[x][1] * a[1][y] + r[x][2] * a[2][y];
        std::memcpy(a, out, sizeof a);
    };
    rotate(0, rot.x), rotate(1, rot.y), rotate(2, rot.z);
    for (const auto& [part, material] : parts) {
        MeshFile& f = mesh_files.at(part);
        const MeshData& piece = f.data;
        Mesh m;
        m.source = ply.string();
        m.smooth = smooth;
        m.material = material;
        // The world-space vertices (kept if the file turns out to have one object), each
        // checked to stay in float range
        // (kept unless the object will surely be an instance: the first object of a file
        // may be its only one)
        const size_t n = piece.positions.size() / 3;
        const size_t triangles = piece.indices.size() / 3;
        const bool first = f.objects.empty();
        const bool keep =
            instance == 0 ||
            (instance < 0 && (first || (f.automatic + 1) * triangles <= kInstanceAbove));
        if (keep) m.positions.reserve(n);
        for (size_t i = 0; i < n; ++i) {
            const Vec3f p = transform(
                {piece.positions[3 * i], piece.positions[3 * i + 1], piece.positions[3 * i + 2]});
            if (!(std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z)))
                t.fail("'scale', 'rotate' and 'translate' take vertex " + std::to_string(i) +
                       " of '" + ply.string() + "' beyond float range");
            if (keep) m.positions.push_back(p);
        }
        set_transform(m, a, move);
        f.objects.push_back(scene.meshes.size());
        f.where.push_back(t.where("scale"));
        f.instance.push_back(instance);
        f.automatic += instance < 0;
        scene.meshes.push_back(std::move(m));
    }
}

void Loader::set_transform(Mesh& m, const double a[3][3], const Vec3f& move) {
    const double det = a[0][0] * (a[1][1] * a[2][2] - a[1][2] * a[2][1]) -
                       a[0][1] * (a[1][0] * a[2][2] - a[1][2] * a[2][0]) +
                       a[0][2] * (a[1][0] * a[2][1] - a[1][1] * a[2][0]);
    double inv[3][3];
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) {
            // cofactor of a[j][i] over det
            const int r0 = (j + 1) % 3, r1 = (j + 2) % 3, c0 = (i + 1) % 3, c1 = (i + 2) % 3;
            inv[i][j] = (a[r0][c0] * a[r1][c1] - a[r0][c1] * a[r1][c0]) / det;
        }
    const double t[3] = {move.x, move.y, move.z};
    for (int i = 0; i < 3; ++i) {
        for (int j = 0; j < 3; ++j) {
            m.to_world[4 * i + j] = float(a[i][j]);
            m.to_object[4 * i + j] = float(inv[i][j]);
            m.normal_to_world[3 * i + j] = float(inv[j][i]);
        }
        m.to_world[4 * i + 3] = float(t[i]);
        m.to_object[4 * i + 3] = float(-(inv[i][0] * t[0] + inv[i][1] * t[1] + inv[i][2] * t[2]));
    }
    m.mirrored = det < 0.0;
}

void Loader::finish_meshes() {
    for (auto& [path, f] : mesh_files) {
        const size_t triangles = f.data.indices.size() / 3;
        const bool automatic = f.automatic >= 2 && f.automatic * triangles > kInstanceAbove;
        int64_t owner = -1;
        for (size_t k = 0; k < f.objects.size(); ++k) {
            Mesh& m = scene.meshes[f.objects[k]];
            const bool instanced = f.instance[k] == 1 || (f.instance[k] < 0 && automatic);
            if (!instanced) {
                m.indices = f.data.indices;
                if (m.mirrored)
                    for (size_t i = 0; i + 2 < m.indices.size(); i += 3)
                        std::swap(m.indices[i + 1], m.indices[i + 2]);
                for (size_t i = 0; i + 2 < f.data.colors.size(); i += 3)
                    m.colors.push_back(
                        {f.data.colors[i], f.data.colors[i + 1], f.data.colors[i + 2]});
                m.uvs = f.data.uvs;
                // (the file's normals through the inverse transpose; Scene::finalize
                // makes area-weighted ones where the file has none)
                if (m.smooth)
                    for (size_t i = 0; i + 2 < f.data.normals.size(); i += 3) {
                        const float* n = &f.data.normals[i];
                        const float* a = m.normal_to_world;
                        m.normals.push_back(
                            unit_or_zero({a[0] * n[0] + a[1] * n[1] + a[2] * n[2],
                                          a[3] * n[0] + a[4] * n[1] + a[5] * n[2],
                                          a[6] * n[0] + a[7] * n[1] + a[8] * n[2]}));
                    }
                continue;
            }
            for (const float v : m.to_object)
                if (!std::isfinite(v))
                    throw InputError(file.string() + ": " + f.where[k] +
                                     ": the transform cannot be inverted in float (a scale "
                                     "below about 1e-38), which an instance needs");
            m.positions.clear();
            m.positions.shrink_to_fit();
            if (owner < 0) {
                owner = int64_t(f.objects[k]);
                const size_t n = f.data.positions.size() / 3;
                m.positions.resize(n);
                for (size_t i = 0; i < n; ++i)
                    m.positions[i] = {f.data.positions[3 * i], f.data.positions[3 * i + 1],
                                      f.data.positions[3 * i + 2]};
                m.indices = f.data.indices;
                for (size_t i = 0; i + 2 < f.data.colors.size(); i += 3)
                    m.colors.push_back(
                        {f.data.colors[i], f.data.colors[i + 1], f.data.colors[i + 2]});
                m.uvs = f.data.uvs;
                for (size_t i = 0; i + 2 < f.data.normals.size(); i += 3)
                    m.normals.push_back(unit_or_zero(
                        {f.data.normals[i], f.data.normals[i + 1], f.data.normals[i + 2]}));
            }
            m.geometry = int32_t(owner);
        }
    }
    mesh_files.clear();
    raw_meshes.clear();
}

}  // namespace cierzo::scene_file
