// The scene-file reader: strict JSON (comments allowed), every key checked, every value
// range-checked, with messages of the form "FILE: objects[2] (sphere): radius must be > 0".
#include "scene/scene_json.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cctype>
#include <cstring>
#include <exception>
#include <fstream>
#include <limits>
#include <map>
#include <set>
#include <system_error>

#include <nlohmann/json.hpp>

#include "core/error.h"
#include "io/input_file.h"
#include "io/mesh.h"
#include "io/mtl.h"
#include "scene/estimator_options.h"
#include "scene/mtl_materials.h"
#include "scene/scene_images.h"
#include "scene/strict_json.h"

namespace cierzo {

namespace {

using nlohmann::json;
namespace fs = std::filesystem;

// Limits that refuse absurd requests before anything is allocated.
constexpr int64_t kMaxDimension = 1 << 16;
constexpr int64_t kMaxPixels = int64_t(1) << 28;

// A JSON object being read: knows where it is for messages and which keys were used, so
// that an unknown (misspelt) key is an error rather than silently ignored.
class Reader {
public:
    Reader(const json& j, std::string where, const fs::path& file)
        : j_(j), where_(std::move(where)), file_(file) {
        if (!j_.is_object()) fail("must be a JSON object");
    }

    [[noreturn]] void fail(const std::string& what) const {
        throw InputError(file_.string() + ": " + where_ + ": " + what);
    }
    bool has(const std::string& key) const { return j_.contains(key); }
    const json& get(const std::string& key) {
        used_.insert(key);
        if (!j_.contains(key)) fail("missing required key '" + key + "'");
        return j_.at(key);
    }
    std::string where(const std::string& key) const { return where_ + "." + key; }

    double number(const std::string& key) {
        const json& v = get(key);
        if (!v.is_number()) fail("'" + key + "' must be a number");
        const double d = v.get<double>();
        // Every number is stored as a float: beyond its range it would become infinite
        if (!std::isfinite(d) || std::fabs(d) > double(std::numeric_limits<float>::max()))
            fail("'" + key + "' must be finite (within float range), got " + v.dump());
        return d;
    }
    double number(const std::string& key, double fallback) {
        return has(key) ? number(key) : (used_.insert(key), fallback);
    }
    int64_t integer(const std::string& key, int64_t fallback, int64_t lo, int64_t hi) {
        if (!has(key)) return used_.insert(key), fallback;
        const json& v = get(key);
        if (!v.is_number_integer() && !(v.is_number() && v.get<double>() == std::floor(v.get<double>())))
            fail("'" + key + "' must be an integer");
        const double d = v.get<double>();
        if (d < double(lo) || d > double(hi))
            fail("'" + key + "' must be in [" + std::to_string(lo) + ", " + std::to_string(hi) +
                 "], got " + v.dump());
        return int64_t(d);
    }
    std::string string(const std::string& key) {
        const json& v = get(key);
        if (!v.is_string()) fail("'" + key + "' must be a string");
        return v.get<std::string>();
    }
    std::string string(const std::string& key, const std::string& fallback) {
        return has(key) ? string(key) : (used_.insert(key), fallback);
    }
    Vec3f vec3(const std::string& key) {
        const json& v = get(key);
        if (!v.is_array() || v.size() != 3)
            fail("'" + key + "' must be an array of 3 numbers, got " + v.dump());
        Vec3f r;
        float* out[3] = {&r.x, &r.y, &r.z};
        for (int i = 0; i < 3; ++i) {
            if (!v[size_t(i)].is_number()) fail("'" + key + "' must be an array of 3 numbers");
            *out[i] = v[size_t(i)].get<float>();
            if (!std::isfinite(*out[i])) fail("'" + key + "' must be finite");
        }
        return r;
    }
    Vec3f vec3(const std::string& key, const Vec3f& fallback) {
        return has(key) ? vec3(key) : (used_.insert(key), fallback);
    }

    // Every key of the object must have been read.
    void finish() const {
        for (auto it = j_.begin(); it != j_.end(); ++it) {
            if (used_.count(it.key())) continue;
            std::string valid;
            for (const std::string& k : used_) valid += (valid.empty() ? "" : ", ") + k;
            fail("unknown key '" + it.key() + "' (valid here: " + valid + ")");
        }
    }
    // Mark keys as valid for this object without reading them (for the message above).
    void allow(std::initializer_list<const char*> keys) {
        for (const char* k : keys) used_.insert(k);
    }

private:
    const json& j_;
    std::string where_;
    const fs::path& file_;
    std::set<std::string> used_;
};

// A normal scaled to unit length (in double: any finite one), or 0 when it has none.
Vec3f unit_or_zero(const Vec3f& n) {
    const double len = std::sqrt(double(n.x) * n.x + double(n.y) * n.y + double(n.z) * n.z);
    if (!(len > 0.0) || !std::isfinite(len)) return Vec3f(0.0f);
    return {float(n.x / len), float(n.y / len), float(n.z / len)};
}

// A number for a message: "1e+60", not sixty digits.
std::string short_number(double x) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%g", x);
    return buf;
}

// A vector scaled by a power of two so that its largest component is in [0.5, 1): the same
// direction, and the same bits of v / |v|, but |v|² neither overflows nor underflows a float
// (it would beyond about 1e19 or below 1e-19). The zero vector stays zero.
Vec3f rescaled(const Vec3f& v, int* exponent = nullptr) {
    const float biggest = std::max({std::fabs(v.x), std::fabs(v.y), std::fabs(v.z)});
    int e = 0;
    if (biggest > 0.0f) std::frexp(biggest, &e);
    if (exponent) *exponent = e;
    const auto scale = [e](float x) { return float(std::ldexp(double(x), -e)); };
    return {scale(v.x), scale(v.y), scale(v.z)};
}

// Whether every camera ray direction forward + u·left + v·up (u, v in [-1, 1]) can be
// normalised in float: its squared length is largest at a corner, and must stay finite.
bool frame_is_normalisable(const Vec3f& forward, const Vec3f& left, const Vec3f& up) {
    for (float u : {-1.0f, 1.0f})
        for (float v : {-1.0f, 1.0f}) {
            const Vec3f d = forward + left * u + up * v;
            if (!std::isfinite(dot(d, d))) return false;
        }
    return true;
}

// ---- Colours and textures ----------------------------------------------------------

Vec3f colour_value(Reader& r, const json& v, const std::string& key) {
    if (v.is_number()) {
        const float g = v.get<float>();
        if (!std::isfinite(g) || g < 0.0f) r.fail("'" + key + "' must be finite and >= 0");
        return Vec3f(g);
    }
    if (!v.is_array() || v.size() != 3) r.fail("'" + key + "' must be a number or [r, g, b]");
    Vec3f c;
    float* out[3] = {&c.x, &c.y, &c.z};
    for (int i = 0; i < 3; ++i) {
        if (!v[size_t(i)].is_number()) r.fail("'" + key + "' must be a number or [r, g, b]");
        *out[i] = v[size_t(i)].get<float>();
        if (!std::isfinite(*out[i]) || *out[i] < 0.0f)
            r.fail("'" + key + "' components must be finite and >= 0, got " + v.dump());
    }
    return c;
}

void read_uv_map(Reader& r, float scale[2], float offset[2], bool& clamp);

// Reads {"texture": "image", ...} (kind already read).
void read_image_color(Reader& r, ColorSource& c, const fs::path& file, ImageRequests& images) {
    const std::string name = r.string("file");
    if (name.empty()) r.fail("'file' must name an image file");
    const bool srgb = [&] {
        if (!r.has("srgb")) return r.allow({"srgb"}), true;
        const json& v = r.get("srgb");
        if (!v.is_boolean()) r.fail("'srgb' must be true (8-bit colours are sRGB-encoded, as "
                                    "in colour maps) or false (linear, as in data maps)");
        return v.get<bool>();
    }();
    c.image = images.request(file.parent_path() / name, srgb, r.where("file"));
    c.a = Vec3f(1.0f);
    if (r.has("factor")) c.a = colour_value(r, r.get("factor"), "factor");
    else r.allow({"factor"});
    read_uv_map(r, c.uv_scale, c.uv_offset, c.clamp);
}

// The map of texture coordinates of an image ("scale", "offset", "wrap").
void read_uv_map(Reader& r, float scale[2], float offset[2], bool& clamp) {
    const auto pair = [&](const char* key, float fallback, float out[2]) {
        out[0] = out[1] = fallback;
        if (!r.has(key)) return r.allow({key});
        const json& v = r.get(key);
        const auto ok = [](const json& x) {
            return x.is_number() && std::isfinite(x.get<double>()) &&
                   std::fabs(x.get<double>()) <= 1e6;
        };
        if (ok(v)) {
            out[0] = out[1] = v.get<float>();
        } else if (v.is_array() && v.size() == 2 && ok(v[0]) && ok(v[1])) {
            out[0] = v[0].get<float>(), out[1] = v[1].get<float>();
        } else {
            r.fail(std::string("'") + key + "' must be a number or [u, v], finite and at most "
                   "1e6 in magnitude, got " + v.dump());
        }
    };
    pair("scale", 1.0f, scale);
    pair("offset", 0.0f, offset);
    const std::string wrap = r.string("wrap", "repeat");
    if (wrap != "repeat" && wrap != "clamp")
        r.fail("'wrap' must be \"repeat\" (the image tiles) or \"clamp\" (its border extends)");
    clamp = wrap == "clamp";
}

// A material's "alpha": a number in [0, 1], or {"texture": "image", "file": ..., "channel":
// "r" | "g" | "b" | "a" | "auto", "factor": [0, 1], "scale", "offset", "wrap"}.
AlphaSource read_alpha(Reader& parent, const fs::path& file, ImageRequests& images) {
    const json& v = parent.get("alpha");
    AlphaSource a;
    const auto unit = [&](Reader& r, const json& x, const std::string& key) {
        if (!x.is_number() || !(x.get<double>() >= 0.0 && x.get<double>() <= 1.0))
            r.fail("'" + key + "' must be an opacity from 0 (a hole) to 1 (opaque), got " +
                   x.dump());
        return x.get<float>();
    };
    if (!v.is_object()) {
        a.constant = unit(parent, v, "alpha");
        return a;
    }
    Reader r(v, parent.where("alpha"), file);
    if (r.string("texture") != "image")
        r.fail("'alpha' must be a number or {\"texture\": \"image\", \"file\": ...}");
    const std::string name = r.string("file");
    if (name.empty()) r.fail("'file' must name an image file");
    // (a mask is data: its bytes are read as they are, never as sRGB, whatever the decoded
    // image says; asked for as a colour map, so that a colour map with an alpha channel that
    // is also the mask is decoded once)
    a.image = images.request(file.parent_path() / name, true, r.where("file"));
    if (r.has("factor")) a.constant = unit(r, r.get("factor"), "factor");
    else r.allow({"factor"});
    const std::string channel = r.string("channel", "auto");
    static const std::map<std::string, int32_t> channels = {
        {"auto", -1}, {"r", 0}, {"g", 1}, {"b", 2}, {"a", 3}};
    const auto it = channels.find(channel);
    if (it == channels.end())
        r.fail("'channel' must be \"auto\" (the image's alpha where it has one, else its red), "
               "\"r\", \"g\", \"b\" or \"a\"; got \"" + channel + "\"");
    a.channel = it->second;
    read_uv_map(r, a.uv_scale, a.uv_offset, a.clamp);
    r.finish();
    return a;
}

ColorSource read_color(Reader& parent, const std::string& key, const fs::path& file,
                       ImageRequests& images) {
    const json& v = parent.get(key);
    ColorSource c;
    if (!v.is_object()) {
        c.a = colour_value(parent, v, key);
        return c;
    }
    Reader r(v, parent.where(key), file);
    const std::string kind = r.string("texture");
    static const std::map<std::string, TextureKind> kinds = {
        {"solid", TextureKind::kSolid},           {"sin", TextureKind::kSin},
        {"sin2", TextureKind::kSin2},             {"sincos", TextureKind::kSinCos},
        {"vertex_nearest", TextureKind::kVertexNearest},
        {"vertex_weighted", TextureKind::kVertexWeighted},
        {"image", TextureKind::kImage}};
    const auto it = kinds.find(kind);
    if (it == kinds.end())
        r.fail("unknown texture '" + kind +
               "' (valid: solid, sin, sin2, sincos, vertex_nearest, vertex_weighted, image)");
    c.kind = it->second;
    if (c.kind == TextureKind::kImage) {
        read_image_color(r, c, file, images);
    } else if (c.is_vertex()) {
        c.a = Vec3f(1.0f);
        if (r.has("scale")) c.a = colour_value(r, r.get("scale"), "scale");
        else r.allow({"scale"});
    } else {
        c.a = colour_value(r, r.get("a"), "a");
        if (c.kind != TextureKind::kSolid) {
            c.b = colour_value(r, r.get("b"), "b");
            c.frequency = float(r.number("frequency", 1.0));
            c.axis = r.vec3("axis", c.axis);
            c.axis2 = r.vec3("axis2", c.axis2);
        }
    }
    r.finish();
    return c;
}

Material read_material(const json& j, const std::string& where, const std::string& name,
                       const fs::path& file, ImageRequests& images) {
    Reader r(j, where, file);
    Material m;
    m.name = name;
    for (auto [key, dst] : {std::pair{"emission", &m.emission}, {"kd", &m.kd}, {"ks", &m.ks},
                            {"kr", &m.kr}, {"kt", &m.kt}}) {
        if (r.has(key)) *dst = read_color(r, key, file, images);
        else r.allow({key});
    }
    m.shininess = float(r.number("shininess", 0.0));
    if (m.shininess < 0.0f || m.shininess > 1e6f) r.fail("'shininess' must be in [0, 1e6]");
    m.ior = float(r.number("ior", 1.0));
    if (!(m.ior > 0.0f)) r.fail("'ior' must be > 0");
    if (r.has("alpha")) m.alpha = read_alpha(r, file, images);
    else r.allow({"alpha"});
    r.finish();
    return m;
}

// ---- Geometry ----------------------------------------------------------------------

struct Loader {
    fs::path file;
    Scene scene;
    std::map<std::string, int32_t> material_ids;
    std::map<int32_t, Mesh> loose_triangles;  // by material
    ImageRequests images;
    MtlMaterials mtl{scene, images};  // the OBJ files' materials
    // Named materials and objects read while the text was parsed (parse_document), and the
    // first error met there, to be thrown where reading the whole document would meet it
    bool materials_read = false;
    std::exception_ptr materials_error, objects_error;

    explicit Loader(const fs::path& path) : file(path) {
        scene.source = path;
        scene.settings.output = path.parent_path() / (path.stem().string() + ".exr");
    }

    void materials(Reader& root, const json& mats) {
        if (!mats.is_object()) root.fail("'materials' must be an object of name: material");
        for (auto it = mats.begin(); it != mats.end(); ++it) {
            material_ids[it.key()] = int32_t(scene.materials.size());
            scene.materials.push_back(
                read_material(it.value(), "materials." + it.key(), it.key(), file, images));
        }
    }

    int32_t material_ref(Reader& r) { return material_value(r, r.get("material"), r.where("material")); }

    // A material by name, or an inline one.
    int32_t material_value(Reader& r, const json& v, const std::string& where) {
        if (v.is_string()) {
            const auto it = material_ids.find(v.get<std::string>());
            if (it == material_ids.end())
                r.fail("unknown material '" + v.get<std::string>() + "'");
            return it->second;
        }
        scene.materials.push_back(read_material(v, where, "", file, images));
        return int32_t(scene.materials.size() - 1);
    }

    // The triangles of material group g of `data`, with only the vertices they use.
    static MeshData group_of(const MeshData& data, uint32_t g) {
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
                        if (!from.empty()) to.insert(to.end(), from.begin() + n * v, from.begin() + n * (v + 1));
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

    void object(const json& j, const std::string& where) {
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
            t.fail("unknown object type '" + type + "' (valid: sphere, plane, quadric, triangle, mesh)");
        }
        t.finish();
    }

    void quadric(Reader& t) {
        const json& c = t.get("coefficients");
        if (!c.is_array() || c.size() != 10)
            t.fail("'coefficients' must be an array of 10 numbers [A..J] of "
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

    void triangle(Reader& t) {
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
                t.fail("'uvs' must be 3 texture coordinates [[u, v], [u, v], [u, v]], each at "
                       "most 1e6 in magnitude");
            for (size_t i = 0; i < 3; ++i)
                m.uvs.insert(m.uvs.end(), {uv[i][0].get<float>(), uv[i][1].get<float>()});
        } else {
            t.allow({"uvs"});
            m.uvs.insert(m.uvs.end(), {0.0f, 0.0f, 1.0f, 0.0f, 0.0f, 1.0f});
        }
        for (uint32_t i = 0; i < 3; ++i) m.indices.push_back(base + i);
    }

    // Mesh files read so far, by path: the file's data and the objects using it
    struct MeshFile {
        MeshData data;
        std::vector<size_t> objects;  // indices into scene.meshes
        std::vector<std::string> where;  // their place in the file, for messages
        std::vector<int> instance;    // per object: its "instance" (1, 0), or -1 for automatic
        size_t automatic = 0;         // objects of the file without "instance"
    };
    // A file used by several objects without "instance" is traced through instances when
    // their copies would hold more triangles than this in all; below, the copies are put
    // into world space (a flat BVH traces faster, and the memory is small).
    static constexpr size_t kInstanceAbove = 65536;
    std::map<fs::path, MeshFile> mesh_files;  // by file, or file#group (OBJ materials)
    std::map<fs::path, MeshData> raw_meshes;  // every mesh file as read, by path

    void mesh(Reader& t) {
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
        const fs::path ply = file.parent_path() / t.string("file");
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
                t.fail("'materials' overrides the OBJ file's own materials by name; with "
                       "'material' every face takes that one");
            t.allow({"materials"});
            const int32_t mat = material_ref(t);
            parts.push_back({key, mat});
        } else {
            t.allow({"material"});
            std::vector<const MtlLibrary*> libs;
            for (const std::string& name : data.libraries) {
                try {
                    libs.push_back(&mtl.library(ply.parent_path() / name, ply));
                } catch (const InputError& e) {
                    t.fail(std::string("material library (mtllib): ") + e.what());
                }
            }
            std::map<std::string, int32_t> overrides;
            if (t.has("materials")) {
                const json& o = t.get("materials");
                if (!o.is_object())
                    t.fail("'materials' must be an object of MTL name: material");
                for (auto it = o.begin(); it != o.end(); ++it) {
                    if (std::find(data.material_names.begin(), data.material_names.end(),
                                  it.key()) == data.material_names.end()) {
                        std::string known;
                        for (const std::string& n : data.material_names)
                            if (!n.empty()) known += (known.empty() ? "" : ", ") + n;
                        t.fail("'materials' overrides '" + it.key() + "', which '" +
                               ply.string() + "' does not use (its materials: " + known + ")");
                    }
                    overrides[it.key()] = material_value(t, it.value(), t.where("materials." + it.key()));
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
                const int32_t mat = o != overrides.end() ? o->second
                                                         : mtl.material(name, libs, ply.string());
                parts.push_back({fs::path(key.string() + "#" + std::to_string(g)), mat});
            }
        }
        for (const auto& [part, material] : parts) {
            if (mesh_files.find(part) != mesh_files.end()) continue;
            MeshData piece = part == key ? data : group_of(data, uint32_t(std::stoul(
                                                      part.string().substr(key.string().size() + 1))));
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
            const bool keep = instance == 0 ||
                              (instance < 0 && (first || (f.automatic + 1) * triangles <= kInstanceAbove));
            if (keep) m.positions.reserve(n);
            for (size_t i = 0; i < n; ++i) {
                const Vec3f p = transform({piece.positions[3 * i], piece.positions[3 * i + 1],
                                           piece.positions[3 * i + 2]});
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

    // An object's transform (linear part a, translation) and the maps derived from it.
    static void set_transform(Mesh& m, const double a[3][3], const Vec3f& move) {
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
            m.to_object[4 * i + 3] =
                float(-(inv[i][0] * t[0] + inv[i][1] * t[1] + inv[i][2] * t[2]));
        }
        m.mirrored = det < 0.0;
    }

    // After all objects, for each mesh file: an object traced as an instance ("instance":
    // true, or automatically when several objects use the file and their copies would hold
    // more than kInstanceAbove triangles) shares the file's vertices, kept once in the file's
    // space in the first such object; every other object keeps its world-space vertices
    // (with the winding reversed by a mirroring transform, so its normals are the file's
    // normals through the inverse transpose, as an instance's are).
    void finish_meshes() {
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
                            m.normals.push_back(unit_or_zero(
                                {a[0] * n[0] + a[1] * n[1] + a[2] * n[2],
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

    // Alpha cut-outs mask triangles only: a sphere, plane or quadric with one is refused.
    void check_alpha() const {
        std::vector<uint8_t> masked(scene.materials.size());
        bool any = false;
        for (size_t i = 0; i < masked.size(); ++i)
            any |= (masked[i] = scene.materials[i].alpha.masked()) != 0;
        if (!any) return;  // (the usual case: a million spheres are not looked at)
        const auto refuse = [&](int32_t material, const char* what) {
            if (!masked[size_t(material)]) return;
            const Material& m = scene.materials[size_t(material)];
            throw InputError(file.string() + ": " +
                             (m.name.empty() ? std::string("an inline material")
                                             : "material '" + m.name + "'") +
                             " has an 'alpha' below 1, but is used by a " + what +
                             ": alpha cut-outs apply to triangles and meshes only");
        };
        for (int32_t mat : scene.spheres.material) refuse(mat, "sphere");
        for (int32_t mat : scene.planes.material) refuse(mat, "plane");
        for (const Quadric& q : scene.quadrics) refuse(q.material, "quadric");
    }

    // "environment": {"emission": COLOUR, "rotate": [x, y, z]}: a solid colour or an
    // equirectangular image, rotated (degrees, about x, then y, then z).
    void environment(const json& j) {
        Reader r(j, "environment", file);
        ColorSource c = read_color(r, "emission", file, images);
        if (c.kind != TextureKind::kSolid && c.kind != TextureKind::kImage)
            r.fail("'emission' must be a colour or an image texture (an equirectangular map)");
        if (c.kind == TextureKind::kImage &&
            (c.clamp || c.uv_scale[0] != 1.0f || c.uv_scale[1] != 1.0f ||
             c.uv_offset[0] != 0.0f || c.uv_offset[1] != 0.0f))
            r.fail("an environment image covers every direction once: 'scale', 'offset' and "
                   "'wrap' do not apply (turn it with 'rotate')");
        const Vec3f rot = r.vec3("rotate", Vec3f(0.0f)) * (kPi / 180.0f);
        double a[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
        for (int axis = 0; axis < 3; ++axis) {
            const double angle = double(rot[axis]);
            const double cs = std::cos(angle), sn = std::sin(angle);
            double m[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
            const int i = (axis + 1) % 3, k = (axis + 2) % 3;
            m[i][i] = cs, m[i][k] = -sn, m[k][i] = sn, m[k][k] = cs;
            double out[3][3];
            for (int x = 0; x < 3; ++x)
                for (int y = 0; y < 3; ++y)
                    out[x][y] = m[x][0] * a[0][y] + m[x][1] * a[1][y] + m[x][2] * a[2][y];
            std::memcpy(a, out, sizeof a);
        }
        r.finish();
        scene.environment.emission = c;
        for (int x = 0; x < 3; ++x)
            for (int y = 0; y < 3; ++y) scene.environment.to_world[3 * x + y] = float(a[x][y]);
    }

    void camera(const json& j, float aspect) {
        Reader r(j, "camera", file);
        const Vec3f position = r.vec3("position");
        if (r.has("look_at")) {
            const Vec3f target = r.vec3("look_at");
            // Only the direction of 'up' matters: rescaled so a tiny or huge one works too
            const Vec3f up = rescaled(r.vec3("up", Vec3f(0.0f, 1.0f, 0.0f)));
            const double vfov = r.number("vfov", 40.0);
            if (!(vfov > 0.0 && vfov < 180.0)) r.fail("'vfov' must be in (0, 180) degrees");
            if (!(length(target - position) > 0.0f)) r.fail("'look_at' equals 'position'");
            if (!std::isfinite(length(target - position)))
                r.fail("'look_at' is too far from 'position' (beyond about 1e19: their "
                       "distance squared overflows a float)");
            if (!(length(cross(up, target - position)) > 0.0f))
                r.fail("'up' is parallel to the viewing direction");
            if (r.has("forward") || r.has("left"))
                r.fail("'forward' and 'left' belong to the explicit frame form; they cannot be "
                       "combined with 'look_at'");
            const std::string hand = r.string("handedness", "left");
            if (hand != "left" && hand != "right")
                r.fail("'handedness' must be \"left\" (the report's: up +y and looking along +z "
                       "put +x on the right) or \"right\" (OBJ, glTF, Blender: +x on the left)");
            const Handedness h = hand == "left" ? Handedness::kLeft : Handedness::kRight;
            scene.look_at = LookAt{position, target, up, float(vfov), h};
            scene.camera = look_at_camera(position, target, up, float(vfov), aspect, h);
            // In float, a vfov just below 180 can round to a half-angle past 90 degrees (an
            // upside-down frame) and one just above 0 to a frame of zero size
            if (!(dot(scene.camera.up, up) > 0.0f) ||
                !frame_is_normalisable(scene.camera.forward, scene.camera.left, scene.camera.up))
                r.fail("'vfov' " + short_number(vfov) + " is too close to 0 or 180 degrees "
                       "to build a camera frame in float");
        } else {
            scene.camera.origin = position;
            scene.camera.forward = r.vec3("forward");
            scene.camera.left = r.vec3("left");
            scene.camera.up = r.vec3("up");
            if (!(length(scene.camera.forward) > 0.0f) || !(length(scene.camera.left) > 0.0f) ||
                !(length(scene.camera.up) > 0.0f))
                r.fail("'forward', 'left' and 'up' must be non-zero");
            if (!frame_is_normalisable(scene.camera.forward, scene.camera.left, scene.camera.up))
                r.fail("'forward', 'left' and 'up' are too long: forward ± left ± up must stay "
                       "below about 1e19 in length, or the ray directions overflow a float");
            if (r.has("vfov"))
                r.fail("'vfov' belongs to the 'look_at' form; in the explicit frame form the "
                       "lengths of 'left' and 'up' set the field of view");
            if (r.has("handedness"))
                r.fail("'handedness' belongs to the 'look_at' form; in the explicit frame form "
                       "'left' says where the image's left is");
        }
        r.finish();
    }

    void render_settings(Reader& root) {
        RenderSettings& s = scene.settings;
        if (!root.has("render")) {
            root.allow({"render"});
            return;
        }
        Reader r(root.get("render"), "render", file);
        s.width = int(r.integer("width", s.width, 1, kMaxDimension));
        s.height = int(r.integer("height", s.height, 1, kMaxDimension));
        if (int64_t(s.width) * s.height > kMaxPixels)
            r.fail("image of " + std::to_string(s.width) + "x" + std::to_string(s.height) +
                   " pixels exceeds the limit of 2^28 pixels");
        s.spp = r.integer("spp", s.spp, 1, int64_t(UINT32_MAX));
        s.seed = uint32_t(r.integer("seed", s.seed, 0, int64_t(UINT32_MAX)));
        s.spatial_splits = float(r.number("spatial_splits", s.spatial_splits));
        if (!(s.spatial_splits >= 0.0f && s.spatial_splits <= kBvhMaxSplitBudget))
            r.fail("'spatial_splits' must be in [0, 4]: the fraction of extra triangle references "
                   "the BVH's spatial splits may make (0: none)");
        s.estimator.survival_cap = float(r.number("survival_cap", s.estimator.survival_cap));
        if (!(s.estimator.survival_cap > 0.0f && s.estimator.survival_cap < 1.0f))
            r.fail("'survival_cap' must be in (0, 1): every path needs a chance to die");
        // (the four knobs whose defaults depend on the estimator: use_estimator below)
        EstimatorSettings& e = s.estimator;
        if (r.has("diffuse_sampling")) {
            const std::string sampling = r.string("diffuse_sampling", "uniform");
            if (sampling != "uniform" && sampling != "cosine")
                r.fail("'diffuse_sampling' must be \"uniform\" or \"cosine\"");
            e.cosine_diffuse = sampling == "cosine";
            e.chosen |= kChoseDiffuse;
        }
        if (r.has("triangle_sampling")) {
            const std::string triangles = r.string("triangle_sampling", "area");
            if (triangles != "area" && triangles != "solid-angle")
                r.fail("'triangle_sampling' must be \"area\" or \"solid-angle\"");
            e.triangle_solid_angle = triangles == "solid-angle";
            e.chosen |= kChoseTriangles;
        }
        if (r.has("roulette")) {
            const std::optional<Roulette> rule = parse_roulette(r.string("roulette", "lobe"));
            if (!rule) r.fail("'roulette' must be \"lobe\" or \"throughput\"");
            e.roulette = *rule;
            e.chosen |= kChoseRoulette;
        }
        e.roulette_depth = int32_t(r.integer("roulette_depth", e.roulette_depth, 0, kMaxRouletteDepth));
        if (r.has("sampler")) {
            const std::optional<Sampler> source = parse_sampler(r.string("sampler", "independent"));
            if (!source)
                r.fail("'sampler' must be \"independent\", \"sobol\", \"zsobol\" or \"pmj02\"");
            e.sampler = *source;
            e.chosen |= kChoseSampler;
        }
        e.min_length = int32_t(r.integer("min_length", 1, 1, kMaxLengthLimit));
        e.max_length = r.has("max_length") ? int32_t(r.integer("max_length", 1, 1, kMaxLengthLimit))
                                           : kNoLengthLimit;
        if (e.max_length < e.min_length)
            r.fail("'max_length' (" + std::to_string(e.max_length) + ") is below 'min_length' (" +
                   std::to_string(e.min_length) + "): no path would count");
        const std::optional<Estimator> kind = parse_estimator(r.string("estimator", "report"));
        if (!kind) {
            std::string names;
            for (const std::string& n : estimator_names())
                names += (names.empty() ? "\"" : ", \"") + n + "\"";
            r.fail("'estimator' must be one of " + names);
        }
        use_estimator(e, *kind);
        if (r.has("merge_radius")) {
            const double r0 = r.number("merge_radius", 0.0);
            if (!(r0 > 0.0) || !std::isfinite(float(r0)))
                r.fail("'merge_radius' must be a positive length (the first merging radius of vcm, bpm and ppm)");
            e.merge_radius = float(r0);
        } else {
            r.allow({"merge_radius"});
        }
        if (r.has("merge_alpha")) {
            const double alpha = r.number("merge_alpha", kMergeAlpha);
            if (!(alpha > 0.0 && alpha < 1.0))
                r.fail("'merge_alpha' must be in (0, 1), exclusive (how fast the merging radius shrinks)");
            e.merge_alpha = float(alpha);
        } else {
            r.allow({"merge_alpha"});
        }
        if (r.has("light_connections")) {
            const double n = r.number("light_connections", 0.0);
            if (!(n >= 0.0 && n <= double(kMaxLightConnections)) || n != std::floor(n))
                r.fail("'light_connections' must be a whole number in 0.." +
                       std::to_string(kMaxLightConnections) +
                       " (0: every vertex of the sample's own light subpath; n: n draws from the "
                       "light vertex cache)");
            if (!connects(e.kind))
                r.fail("'light_connections' is bdpt's and vcm's (the estimator is \"" +
                       std::string(estimator_name(e.kind)) + "\")");
            e.light_connections = int32_t(n);
        } else {
            r.allow({"light_connections"});
        }
        if ((r.has("merge_radius") || r.has("merge_alpha")) && !merges(e.kind))
            r.fail("'merge_radius' and 'merge_alpha' are vcm's, bpm's and ppm's (the estimator is \"" +
                   std::string(estimator_name(e.kind)) + "\")");
        if (r.has("output")) s.output = file.parent_path() / r.string("output");
        else r.allow({"output"});
        r.finish();
    }
};

// The scene file's JSON document. Where "materials" comes before "objects" (as in every
// generated scene), the objects are read as the parser hands them over and never kept in the
// document, so a scene of a million spheres is never a document of a million objects; else
// they are read from the document by build_scene. Either way the same error is reported:
// one met here is kept and thrown by build_scene where reading in order would meet it.
json parse_document(const std::string& text, Loader& l) {
    JsonStream stream;
    stream.key = "objects";
    stream.begin = [&l](const json& document) {
        const auto mats = document.find("materials");
        if (mats == document.end()) return false;
        l.materials_read = true;
        try {
            Reader root(document, "scene", l.file);
            l.materials(root, *mats);
        } catch (const InputError&) {
            l.materials_error = std::current_exception();
        }
        return true;
    };
    stream.element = [&l](const json& object, size_t i) {
        if (l.materials_error || l.objects_error) return;  // (the first error is reported)
        try {
            l.object(object, "objects[" + std::to_string(i) + "]");
        } catch (const InputError&) {
            l.objects_error = std::current_exception();
        }
    };
    return parse_strict_json(text, l.file, &stream);
}

Scene build_scene(Loader& l, const json& root) {
    const fs::path& path = l.file;
    Reader r(root, "scene", path);
    l.render_settings(r);
    l.scene.scene_ior = float(r.number("scene_ior", 1.0));
    if (!(l.scene.scene_ior > 0.0f)) r.fail("'scene_ior' must be > 0");

    // Materials by name, then objects that refer to them
    if (r.has("materials")) {
        const json& mats = r.get("materials");
        if (l.materials_error) std::rethrow_exception(l.materials_error);
        if (!l.materials_read) l.materials(r, mats);
    } else {
        r.allow({"materials"});
    }
    const json& objects = r.get("objects");
    if (!objects.is_array()) r.fail("'objects' must be an array");
    if (l.objects_error) std::rethrow_exception(l.objects_error);
    for (size_t i = 0; i < objects.size(); ++i)  // (none if they were read while parsing)
        l.object(objects[i], "objects[" + std::to_string(i) + "]");
    l.finish_meshes();
    for (auto& [mat, mesh] : l.loose_triangles) l.scene.meshes.push_back(std::move(mesh));
    if (r.has("environment")) l.environment(r.get("environment"));
    else r.allow({"environment"});
    load_images(l.scene, l.images, l.file);
    l.check_alpha();

    // Point lights
    if (r.has("lights")) {
        const json& lights = r.get("lights");
        if (!lights.is_array()) r.fail("'lights' must be an array");
        for (size_t i = 0; i < lights.size(); ++i) {
            Reader lr(lights[i], "lights[" + std::to_string(i) + "]", path);
            const std::string type = lr.string("type", "point");
            if (type != "point") lr.fail("unknown light type '" + type + "' (valid: point)");
            PointLight pl;
            pl.position = lr.vec3("position");
            pl.intensity = colour_value(lr, lr.get("intensity"), "intensity");
            lr.finish();
            l.scene.lights.push_back(pl);
        }
    } else {
        r.allow({"lights"});
    }
    l.camera(r.get("camera"), float(l.scene.settings.width) / float(l.scene.settings.height));
    r.finish();
    l.scene.finalize();
    return std::move(l.scene);
}

}  // namespace

Scene parse_scene(const std::string& text, const fs::path& path) {
    Loader l(path);
    const json root = parse_document(text, l);
    return build_scene(l, root);
}

// A mesh file rendered directly (`cierzo render model.obj`): the file with its own materials
// (an OBJ's MTL; a PLY or an OBJ without materials in diffuse grey 0.8), under a white sky of
// radiance 1, seen by a right-handed camera of 40 degrees that frames its bounding sphere
// from the front, above and to the right; 512 × 512 pixels, 16 paths, written to
// STEM.exr in the current folder.
Scene load_mesh_as_scene(const fs::path& path) {
    std::string ext = path.extension().string();
    for (char& c : ext) c = char(std::tolower(static_cast<unsigned char>(c)));
    const bool obj = ext == ".obj";
    json j = json::parse(R"({
        "materials": {"grey": {"kd": 0.8}},
        "environment": {"emission": 1},
        "camera": {"position": [0, 0, 1], "look_at": [0, 0, 0], "handedness": "right"},
        "render": {"width": 512, "height": 512, "spp": 16}})");
    json object = {{"type", "mesh"}, {"file", path.filename().string()}};
    if (!obj) object["material"] = "grey";
    j["objects"] = json::array({object});
    // (messages name the mesh file: it is the one the user gave)
    Scene scene;
    try {
        scene = parse_scene(j.dump(), path);
    } catch (const InputError& e) {
        // An OBJ without 'usemtl': every face grey (read again: a rare case)
        const std::string m = e.what();
        if (!obj || m.find("names no materials of its own") == std::string::npos) throw;
        j["objects"][0]["material"] = "grey";
        scene = parse_scene(j.dump(), path);
    }
    scene.source = path;
    scene.settings.output = path.stem().string() + ".exr";
    // Frame the bounding sphere
    const Vec3f lo = scene.bvh.bounds_min(), hi = scene.bvh.bounds_max();
    const Vec3f centre = (lo + hi) * 0.5f;
    const float radius = std::max(0.5f * length(hi - lo), 1e-6f);
    const float vfov = 40.0f;
    const float distance = radius / std::sin(0.5f * vfov * kPi / 180.0f) * 1.05f;
    const Vec3f from = centre + normalize(Vec3f{0.45f, 0.35f, 1.0f}) * distance;
    scene.look_at = LookAt{from, centre, Vec3f{0.0f, 1.0f, 0.0f}, vfov, Handedness::kRight};
    scene.set_resolution(scene.settings.width, scene.settings.height);
    if (!scene.files.empty() && scene.files.front() != path) scene.files.insert(scene.files.begin(), path);
    return scene;
}

namespace {
Scene load_scene_untimed(const fs::path& path);
}  // namespace

Scene load_scene(const fs::path& path) {
    const auto start = std::chrono::steady_clock::now();
    Scene scene = load_scene_untimed(path);
    scene.load_seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return scene;
}

namespace {
Scene load_scene_untimed(const fs::path& path) {
    {
        std::string ext = path.extension().string();
        for (char& c : ext) c = char(std::tolower(static_cast<unsigned char>(c)));
        if (ext == ".obj" || ext == ".ply") return load_mesh_as_scene(path);
    }
    std::ifstream in;
    if (input_file_exists(path)) in.open(path, std::ios::binary);
    if (!in.is_open()) throw InputError(path.string() + ": cannot open scene file");
    Loader l(path);
    json root;
    {
        // Read at its size (no second copy), and freed before the scene is built
        std::string text;
        std::error_code size_unknown;
        const auto size = fs::file_size(path, size_unknown);
        if (!size_unknown) text.reserve(size);
        char chunk[1 << 16];
        while (in.read(chunk, sizeof chunk) || in.gcount() > 0)
            text.append(chunk, size_t(in.gcount()));
        if (in.bad()) throw InputError(path.string() + ": cannot read scene file");
        root = parse_document(text, l);
    }
    Scene scene = build_scene(l, root);
    scene.files.insert(scene.files.begin(), path);
    return scene;
}

}  // namespace

}  // namespace cierzo
