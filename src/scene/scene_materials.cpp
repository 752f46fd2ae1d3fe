// The scene file's colours, textures and materials: a colour as a number or [r, g, b], a
// texture (procedural or an image, with its map of texture coordinates), an alpha cut-out,
// and a material of them, named or inline (Loader, scene_loader.h).
#include "scene/scene_loader.h"

#include <string>
#include <utility>

namespace cierzo::scene_file {

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
        if (!v.is_boolean())
            r.fail(
                "'srgb' must be true (8-bit colours are sRGB-encoded, as "
                "in colour maps) or false (linear, as in data maps)");
        return v.get<bool>();
    }();
    c.image = images.request(file.parent_path() / name, srgb, r.where("file"));
    c.a = Vec3f(1.0f);
    if (r.has("factor"))
        c.a = colour_value(r, r.get("factor"), "factor");
    else
        r.allow({"factor"});
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
            r.fail(std::string("'") + key +
                   "' must be a number or [u, v], finite and at most "
                   "1e6 in magnitude, got " +
                   v.dump());
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
    if (r.has("factor"))
        a.constant = unit(r, r.get("factor"), "factor");
    else
        r.allow({"factor"});
    const std::string channel = r.string("channel", "auto");
    static const std::map<std::string, int32_t> channels = {
        {"auto", -1}, {"r", 0}, {"g", 1}, {"b", 2}, {"a", 3}};
    const auto it = channels.find(channel);
    if (it == channels.end())
        r.fail(
            "'channel' must be \"auto\" (the image's alpha where it has one, else its red), "
            "\"r\", \"g\", \"b\" or \"a\"; got \"" +
            channel + "\"");
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
        {"solid", TextureKind::kSolid},
        {"sin", TextureKind::kSin},
        {"sin2", TextureKind::kSin2},
        {"sincos", TextureKind::kSinCos},
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
        if (r.has("scale"))
            c.a = colour_value(r, r.get("scale"), "scale");
        else
            r.allow({"scale"});
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
    for (auto [key, dst] : {std::pair{"emission", &m.emission},
                            {"kd", &m.kd},
                            {"ks", &m.ks},
                            {"kr", &m.kr},
                            {"kt", &m.kt}}) {
        if (r.has(key))
            *dst = read_color(r, key, file, images);
        else
            r.allow({key});
    }
    m.shininess = float(r.number("shininess", 0.0));
    if (m.shininess < 0.0f || m.shininess > 1e6f) r.fail("'shininess' must be in [0, 1e6]");
    m.ior = float(r.number("ior", 1.0));
    if (!(m.ior > 0.0f)) r.fail("'ior' must be > 0");
    if (r.has("alpha"))
        m.alpha = read_alpha(r, file, images);
    else
        r.allow({"alpha"});
    r.finish();
    return m;
}

void Loader::materials(Reader& root, const json& mats) {
    if (!mats.is_object()) root.fail("'materials' must be an object of name: material");
    for (auto it = mats.begin(); it != mats.end(); ++it) {
        material_ids[it.key()] = int32_t(scene.materials.size());
        scene.materials.push_back(
            read_material(it.value(), "materials." + it.key(), it.key(), file, images));
    }
}

int32_t Loader::material_value(Reader& r, const json& v, const std::string& where) {
    if (v.is_string()) {
        const auto it = material_ids.find(v.get<std::string>());
        if (it == material_ids.end()) r.fail("unknown material '" + v.get<std::string>() + "'");
        return it->second;
    }
    scene.materials.push_back(read_material(v, where, "", file, images));
    return int32_t(scene.materials.size() - 1);
}

}  // namespace cierzo::scene_file
