// MTL material libraries (see mtl.h).
#include "io/mtl.h"

#include <cctype>
#include <charconv>
#include <cmath>
#include <set>

#include <fmt/format.h>

#include "core/error.h"
#include "io/mesh_file.h"

namespace cierzo {

namespace {

std::string_view trim(std::string_view s) {
    while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
    while (!s.empty() && (s.back() == ' ' || s.back() == '\t')) s.remove_suffix(1);
    return s;
}

bool parse_number(std::string_view token, float& out) {
    if (!token.empty() && token[0] == '+') token.remove_prefix(1);
    double d = 0.0;
    const auto [end, ec] =
        std::from_chars(token.data(), token.data() + token.size(), d, std::chars_format::general);
    if (token.empty() || ec != std::errc() || end != token.data() + token.size() ||
        !std::isfinite(d) || std::fabs(d) > 3.0e38)
        return false;
    out = float(d);
    return true;
}

// Keys read and used, read and deliberately ignored (no meaning in a path tracer, or
// superseded), and known but not modelled (a warning).
const std::set<std::string_view> kIgnored = {"Ka", "map_Ka"};
struct Unmodelled {
    std::string_view key, what;
};
constexpr Unmodelled kUnmodelled[] = {
    {"bump", "a bump map"},
    {"map_bump", "a bump map"},
    {"map_Bump", "a bump map"},
    {"norm", "a normal map"},
    {"map_norm", "a normal map"},
    {"disp", "a displacement map"},
    {"decal", "a decal map"},
    {"refl", "a reflection map"},
    {"map_refl", "a reflection map"},
    {"map_Ns", "a shininess map"},
    {"map_Ni", "an index map"},
    {"map_Tr", "a transparency map (use map_d)"},
    {"sharpness", "reflection sharpness"},
    {"Pr", "PBR roughness"},
    {"Pm", "PBR metallic"},
    {"Ps", "PBR sheen"},
    {"Pc", "PBR clearcoat"},
    {"Pcr", "PBR clearcoat roughness"},
    {"aniso", "PBR anisotropy"},
    {"anisor", "PBR anisotropy rotation"},
    {"map_Pr", "a PBR roughness map"},
    {"map_Pm", "a PBR metallic map"},
    {"map_Ps", "a PBR sheen map"},
    {"map_Pc", "a PBR clearcoat map"},
    {"map_Pcr", "a PBR clearcoat roughness map"},
    {"map_Ke_ior", "an emission map"},
};

struct LineReader {
    const MeshSource& src;
    size_t line;
    std::string_view key;

    [[noreturn]] void fail(std::string_view what) const { src.fail_at(line, what); }

    // "Kd r [g b]": one number is grey
    void colour(std::string_view rest, float out[3]) const {
        std::string_view first = next_token(rest);
        if (first == "spectral" || first == "xyz")
            fail(
                fmt::format("'{} {}': spectral and CIE XYZ colours are not supported (give "
                            "linear RGB)",
                            key, first));
        float v[3];
        size_t n = 0;
        for (std::string_view t = first; !t.empty(); t = next_token(rest)) {
            if (n == 3) fail(fmt::format("'{}' takes 1 or 3 numbers, not more", key));
            if (!parse_number(t, v[n]))
                fail(fmt::format("'{}' in '{}' is not a number in float range", t, key));
            ++n;
        }
        if (n != 1 && n != 3) fail(fmt::format("'{}' takes 1 or 3 numbers, not {}", key, n));
        if (n == 1) v[1] = v[2] = v[0];
        for (int k = 0; k < 3; ++k)
            if (!(v[k] >= 0.0f))
                fail(fmt::format("'{}' has the component {}: colours must be >= 0", key, v[k]));
        for (int k = 0; k < 3; ++k) out[k] = v[k];
    }

    float scalar(std::string_view rest, float lo, float hi, bool open_lo = false) const {
        const std::string_view t = next_token(rest);
        float v = 0.0f;
        if (!parse_number(t, v)) fail(fmt::format("'{}' needs a number, got '{}'", key, t));
        if (!next_token(rest).empty()) fail(fmt::format("'{}' takes one number", key));
        if (open_lo ? !(v > lo) : !(v >= lo)) fail(fmt::format("'{}' {} is out of range", key, v));
        if (!(v <= hi)) fail(fmt::format("'{}' {} is out of range (at most {})", key, v, hi));
        return v;
    }

    // "map_Kd [-opt args]... file name": options, then the rest of the line is the file
    MtlMap map(std::string_view rest) const {
        MtlMap m;
        m.line = line;
        for (;;) {
            std::string_view probe = rest;
            const std::string_view t = next_token(probe);
            if (t.size() < 2 || t[0] != '-' || !std::isalpha(static_cast<unsigned char>(t[1])))
                break;
            rest = probe;
            const auto numbers = [&](size_t most, float* out) {
                size_t n = 0;
                for (;;) {
                    std::string_view look = rest;
                    const std::string_view x = next_token(look);
                    float v;
                    if (n == most || !parse_number(x, v)) break;
                    if (out) out[n] = v;
                    ++n;
                    rest = look;
                }
                if (n == 0) fail(fmt::format("'{}' option '{}' needs a number", key, t));
                return n;
            };
            const auto on_off = [&] {
                const std::string_view x = next_token(rest);
                if (x != "on" && x != "off")
                    fail(fmt::format("'{}' option '{}' takes on or off, got '{}'", key, t, x));
                return x == "on";
            };
            if (t == "-s" || t == "-o") {
                float v[3] = {1.0f, 1.0f, 1.0f};
                if (t == "-o") v[0] = v[1] = v[2] = 0.0f;
                numbers(3, v);
                for (int k = 0; k < 2; ++k)
                    if (!(std::fabs(v[k]) <= 1e6f))
                        fail(fmt::format("'{}' option '{}' {} is out of range (at most 1e6)", key,
                                         t, v[k]));
                float* out = t == "-s" ? m.scale : m.offset;
                out[0] = v[0], out[1] = v[1];
            } else if (t == "-clamp") {
                m.clamp = on_off();
            } else if (t == "-blendu" || t == "-blendv" || t == "-cc") {
                on_off();
            } else if (t == "-bm" || t == "-boost" || t == "-texres") {
                numbers(1, nullptr);
            } else if (t == "-mm") {
                numbers(2, nullptr);
            } else if (t == "-t") {
                numbers(3, nullptr);
            } else if (t == "-imfchan") {
                const std::string_view x = next_token(rest);
                if (x.size() != 1 ||
                    std::string_view("rgbmlz").find(x[0]) == std::string_view::npos)
                    fail(fmt::format("'{}' option -imfchan takes r, g, b, m, l or z, got '{}'", key,
                                     x));
                m.channel = x[0];
            } else if (t == "-colorspace") {
                // (tinyobjloader's extension: how an 8-bit file's values are encoded)
                std::string x(next_token(rest));
                for (char& c : x) c = char(std::tolower(static_cast<unsigned char>(c)));
                if (x != "srgb" && x != "linear")
                    fail(fmt::format("'{}' option -colorspace takes sRGB or linear, got '{}'", key,
                                     x));
                m.srgb = x == "srgb" ? 1 : 0;
            } else if (t == "-type") {
                next_token(rest);
            } else {
                fail(fmt::format("'{}' has the unknown option '{}'", key, t));
            }
        }
        std::string file(trim(rest));
        if (file.empty()) fail(fmt::format("'{}' names no file", key));
        for (char& c : file)
            if (c == '\\') c = '/';
        m.file = std::move(file);
        return m;
    }
};

}  // namespace

MtlLibrary parse_mtl(std::string_view bytes, const std::filesystem::path& name) {
    const MeshSource src{name.string()};
    MtlLibrary lib;
    lib.path = name;
    std::set<std::string_view> warned;
    MtlMaterial* m = nullptr;
    TextLines lines{bytes, src, "MTL"};
    for (std::string_view line; lines.next(line);) {
        const size_t line_no = lines.number;
        const size_t hash = line.find('#');
        if (hash != std::string_view::npos) line = line.substr(0, hash);
        std::string_view rest = line;
        const std::string_view key = next_token(rest);
        if (key.empty()) continue;
        const LineReader r{src, line_no, key};
        if (key == "newmtl") {
            const std::string_view n = trim(rest);
            if (lib.find(n)) r.fail(fmt::format("material '{}' is defined twice", n));
            lib.materials.emplace_back();
            m = &lib.materials.back();
            m->line = line_no;
            if (n.empty()) {
                // A name with '#' in it: no 'newmtl' can give it (the line ends at '#')
                m->name = fmt::format("#unnamed-line-{}", line_no);
                lib.warnings.push_back(
                    fmt::format("{}: line {}: 'newmtl' without a name: the "
                                "material is called '{}'",
                                src.path, line_no, m->name));
            } else {
                m->name = std::string(n);
            }
            continue;
        }
        if (kIgnored.count(key)) continue;
        bool unmodelled = false;
        for (const Unmodelled& u : kUnmodelled) {
            if (u.key != key) continue;
            unmodelled = true;
            if (warned.insert(u.key).second)
                lib.warnings.push_back(
                    fmt::format("{}: line {}: '{}' ({}) is not modelled by "
                                "cierzo and is ignored",
                                src.path, line_no, key, u.what));
        }
        if (unmodelled) continue;
        // (before the first 'newmtl': not an MTL library, and nothing of it is quoted, as the
        // file may be any file of the user's that an OBJ named)
        if (!m)
            r.fail(
                "is not an MTL library: its first statement is not 'newmtl' (an MTL "
                "library starts with 'newmtl NAME')");
        if (key == "Kd") {
            r.colour(rest, m->kd_rgb), m->has_kd = true;
        } else if (key == "Ks") {
            r.colour(rest, m->ks_rgb), m->has_ks = true;
        } else if (key == "Ke") {
            r.colour(rest, m->ke_rgb), m->has_ke = true;
        } else if (key == "Tf" || key == "Kt") {
            r.colour(rest, m->tf_rgb), m->has_tf = true;
        } else if (key == "Ns") {
            m->ns = r.scalar(rest, 0.0f, 1e6f);
        } else if (key == "Ni") {
            // (0 is common in exported files for "not set": only glass needs Ni > 0)
            m->ni = r.scalar(rest, 0.0f, 1e3f);
            m->ni_line = line_no;
        } else if (key == "d") {
            std::string_view probe = rest;
            if (next_token(probe) == "-halo") rest = probe;  // (the halo form: as plain d)
            m->d = r.scalar(rest, 0.0f, 1.0f);
            m->d_line = line_no, m->d_from_tr = false;
        } else if (key == "Tr") {
            m->d = 1.0f - r.scalar(rest, 0.0f, 1.0f);
            m->d_line = line_no, m->d_from_tr = true;
        } else if (key == "illum") {
            const float v = r.scalar(rest, 0.0f, 10.0f);
            if (v != std::floor(v)) r.fail("'illum' must be an integer from 0 to 10");
            m->illum = int(v);
        } else if (key == "map_Kd") {
            m->map_kd = r.map(rest);
        } else if (key == "map_Ks") {
            m->map_ks = r.map(rest);
        } else if (key == "map_Ke") {
            m->map_ke = r.map(rest);
        } else if (key == "map_d") {
            m->map_d = r.map(rest);
        } else {
            if (warned.insert(key).second)
                lib.warnings.push_back(fmt::format("{}: line {}: unknown key '{}' is ignored",
                                                   src.path, line_no, key));
        }
    }
    return lib;
}

MtlLibrary read_mtl(const std::filesystem::path& path) {
    return read_mapped(path, [&](std::string_view bytes) { return parse_mtl(bytes, path); });
}

}  // namespace cierzo
