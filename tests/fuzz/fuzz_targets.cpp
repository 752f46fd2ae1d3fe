// The fuzz targets: each parses the input, treats an InputError as a correct refusal and
// checks the invariants of whatever was accepted; every other outcome aborts the process,
// which is what libFuzzer and the fuzz_regressions test report as a failure.
#include "fuzz_targets.h"

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <string>
#include <string_view>
#include <system_error>
#include <vector>

#include "core/error.h"
#include "io/image.h"
#include "io/mtl.h"
#include "io/obj.h"
#include "io/ply.h"
#include "io/texture_image.h"
#include "scene/load_options.h"
#include "scene/scene_json.h"
#include "tonemap/tonemap.h"

#ifndef CIERZO_FUZZ_SCENE_ROOT
#error "CIERZO_FUZZ_SCENE_ROOT must name tests/fuzz/scene_root"
#endif

namespace cierzo {
namespace {

namespace fs = std::filesystem;

void require(bool ok, const char* what) { fuzz_require(ok, what); }

constexpr std::string_view kExrMagic = "\x76\x2f\x31\x01";

bool finite(const Vec3f& v) {
    return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z);
}

bool valid_colour(const ColorSource& c) {
    return finite(c.a) && finite(c.b) && std::isfinite(c.frequency) && finite(c.axis) &&
           finite(c.axis2) && c.a.x >= 0 && c.a.y >= 0 && c.a.z >= 0 && c.b.x >= 0 && c.b.y >= 0 &&
           c.b.z >= 0;
}

// A decoded image texture: within the size limits, one RGBA texel per pixel, float texels
// finite and >= 0, statistics finite with each mean at most its maximum.
void check_texture(const TextureImage& t) {
    require(t.width >= 1 && t.height >= 1 && t.width <= kMaxTextureSide &&
                t.height <= kMaxTextureSide && int64_t(t.texels()) <= kMaxTextureTexels,
            "image dimensions within limits");
    require(t.bytes.size() == t.texels() || t.floats.size() == 4 * t.texels(),
            "one RGBA texel per pixel");
    require(t.bytes.empty() != t.floats.empty(), "bytes or floats, not both");
    for (float f : t.floats) require(std::isfinite(f) && f >= 0.0f, "texel finite and >= 0");
    bool opaque = true;
    for (int32_t b : t.bytes) opaque &= (uint32_t(b) >> 24) == 255u;
    for (size_t i = 0; i < t.floats.size(); i += 4) opaque &= t.floats[i + 3] >= 1.0f;
    require(t.opaque == opaque, "opaque exactly when every alpha is 1");
    for (int c = 0; c < 3; ++c)
        require(std::isfinite(t.max_rgb[c]) && t.max_rgb[c] >= 0.0f &&
                    std::isfinite(t.mean_rgb[c]) && t.mean_rgb[c] >= 0.0 &&
                    t.mean_rgb[c] <= double(t.max_rgb[c]) * (1.0 + 1e-6) + 1e-30,
                "image statistics finite, 0 <= mean <= max");
}

// ---- Scene files -----------------------------------------------------------------------

// Whether `p` resolves (links followed) to a file beneath `root`.
bool beneath(const fs::path& p, const fs::path& root) {
    std::error_code ec;
    const fs::path r = fs::weakly_canonical(p, ec);
    if (ec) return false;
    const auto [end, _] = std::mismatch(root.begin(), root.end(), r.begin(), r.end());
    return end == root.end();
}

// What the scene's images gave it: every image texture and mask an image of the scene, the
// images decoded within the budget, the environment's tables finite, the textured meshes
// with texture coordinates, and every file the scene read beneath its folder.
void check_scene_images(const Scene& s) {
    const auto image_ok = [&](int32_t i) { return i >= 0 && size_t(i) < s.images.size(); };
    uint64_t memory = 0;
    for (const auto& image : s.images) {
        require(image != nullptr, "an image of the scene was decoded");
        check_texture(*image);
        memory += image->memory_bytes();
    }
    require(memory <= kFuzzImageMemory, "the decoded images within the image budget");
    std::vector<const ColorSource*> sources = {&s.environment.emission};
    for (const Material& m : s.materials)
        for (const ColorSource* c : {&m.emission, &m.kd, &m.ks, &m.kr, &m.kt}) sources.push_back(c);
    for (const ColorSource* c : sources)
        if (c->kind == TextureKind::kImage)
            require(image_ok(c->image) && std::isfinite(c->uv_scale[0]) &&
                        std::isfinite(c->uv_scale[1]) && std::isfinite(c->uv_offset[0]) &&
                        std::isfinite(c->uv_offset[1]),
                    "an image texture names an image of the scene, with a finite map");
    require(valid_colour(s.environment.emission), "environment colour finite and >= 0");
    for (const Material& m : s.materials) {
        const AlphaSource& a = m.alpha;
        require(a.constant >= 0.0f && a.constant <= 1.0f, "alpha in [0, 1]");
        require(a.image == -1 || image_ok(a.image), "an alpha mask names an image of the scene");
        require(a.channel >= -1 && a.channel <= 3, "alpha channel r, g, b, a or auto");
    }
    for (const Mesh& object : s.meshes) {
        const Mesh& g = object.instanced() ? s.meshes[size_t(object.geometry)] : object;
        const Material& m = s.materials[size_t(object.material)];
        bool imaged = m.alpha.image >= 0;
        for (const ColorSource* c : {&m.emission, &m.kd, &m.ks, &m.kr, &m.kt})
            imaged |= c->kind == TextureKind::kImage;
        require(g.uvs.empty() || g.uvs.size() == 2 * g.positions.size(),
                "one texture coordinate per mesh vertex");
        require(!imaged || !g.uvs.empty(), "a textured mesh has texture coordinates");
        for (float t : g.uvs) require(std::isfinite(t), "texture coordinate finite");
    }
    const Emitters& e = s.emitters;
    if (e.environment_width > 0) {
        const size_t w = size_t(e.environment_width), h = size_t(e.environment_height);
        require(e.environment_radiance.size() == 3 * w * h &&
                    e.environment_row_cdf.size() == h + 1 &&
                    e.environment_col_cdf.size() == h * (w + 1) &&
                    e.environment_density.size() == w * h,
                "environment tables of the environment's size");
        for (float v : e.environment_radiance)
            require(std::isfinite(v) && v >= 0.0f, "environment radiance finite and >= 0");
        for (const std::vector<float>* cdf : {&e.environment_row_cdf, &e.environment_col_cdf})
            for (float v : *cdf) require(v >= 0.0f && v <= 1.0f, "environment CDF in [0, 1]");
        for (float v : e.environment_density)
            require(std::isfinite(v) && v >= 0.0f, "environment density finite and >= 0");
        require(std::isfinite(e.environment_mean) && e.environment_mean >= 0.0,
                "environment mean finite and >= 0");
    }
    static const fs::path root = fs::canonical(CIERZO_FUZZ_SCENE_ROOT);
    for (const fs::path& f : s.files)
        require(beneath(f, root), "every file the scene read lies beneath its folder");
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
    check_scene_images(s);
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
    // (every name, however spelt, is the reader's to confine to scene_root: nothing else can
    // be read, so every run is reproducible; the image budget keeps decoding small)
    LoadOptions options;
    options.image_memory = kFuzzImageMemory;
    try {
        check_scene(parse_scene(text, fs::path(CIERZO_FUZZ_SCENE_ROOT) / "fuzz.json", options));
        return true;
    } catch (const InputError& e) {
        fuzz_refused(e);
        return false;
    }
}

bool fuzz_one_ply(const uint8_t* data, size_t size) {
    try {
        check_mesh(
            parse_ply(std::string_view(reinterpret_cast<const char*>(data), size), "fuzz.ply"));
        return true;
    } catch (const InputError& e) {
        fuzz_refused(e);
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
    } catch (const InputError& e) {
        fuzz_refused(e);
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
    } catch (const InputError& e) {
        fuzz_refused(e);
        return false;
    }
}

bool fuzz_one_image(const uint8_t* data, size_t size) {
    const std::string_view bytes(reinterpret_cast<const char*>(data), size);
    // Named by the signature, as the extension must agree with it: every decoder is
    // reachable (TGA has none: any bytes without another's are named .tga)
    const auto starts = [&](std::string_view magic) {
        return bytes.substr(0, magic.size()) == magic;
    };
    const char* extension = ".tga";
    if (starts("\x89PNG\r\n\x1a\n"))
        extension = ".png";
    else if (starts("\xff\xd8\xff"))
        extension = ".jpg";
    else if (starts("BM"))
        extension = ".bmp";
    else if (starts("P5") || starts("P6"))
        extension = ".ppm";
    else if (starts("#?RADIANCE\n") || starts("#?RGBE\n"))
        extension = ".hdr";
    else if (starts(kExrMagic))
        extension = ".exr";
    const fs::path file = fuzz_scratch_file(std::string("fuzz") + extension, bytes);
    // What a scene charges the image from its header, and what decoding it gives
    TextureShape shape;
    bool probed = false;
    try {
        shape = probe_texture_image(file);
        probed = true;
        require(shape.width >= 1 && shape.height >= 1 && shape.width <= kMaxTextureSide &&
                    shape.height <= kMaxTextureSide && int64_t(shape.texels()) <= kMaxTextureTexels,
                "probed dimensions within limits");
        require(shape.kept_bytes == (shape.floats ? 16 : 4) * shape.texels() &&
                    shape.peak_bytes >= shape.kept_bytes,
                "probed cost at least the texels kept");
    } catch (const InputError& e) {
        fuzz_refused(e);
    }
    bool accepted = false;
    for (const bool srgb : {true, false}) {
        try {
            const TextureImage t = read_texture_image(file, srgb);
            check_texture(t);
            require(probed, "an image that decodes is probed");
            require(shape.width == t.width && shape.height == t.height &&
                        shape.floats == !t.floats.empty() && shape.kept_bytes == t.memory_bytes(),
                    "an image decodes to the shape its probe gave");
            accepted = true;
        } catch (const InputError& e) {
            fuzz_refused(e);
        }
    }
    return accepted;
}

bool fuzz_one_hdr_image(const uint8_t* data, size_t size) {
    const std::string_view bytes(reinterpret_cast<const char*>(data), size);
    const bool exr = bytes.substr(0, kExrMagic.size()) == kExrMagic;
    const fs::path file = fuzz_scratch_file(exr ? "fuzz.exr" : "fuzz.pfm", bytes);
    Image image;
    try {
        image = read_hdr(file);
    } catch (const InputError& e) {
        fuzz_refused(e);
        return false;
    }
    const size_t pixels = size_t(image.width) * size_t(image.height);
    require(image.width >= 1 && image.height >= 1 && int64_t(pixels) <= kMaxImagePixels,
            "HDR image dimensions within limits");
    require(image.rgb.size() == 3 * pixels, "three floats per pixel");
    if (exr) {
        // The same file read with its metadata and layers (as converge reads a reference and
        // a scene an EXR texture), and its shape from the header alone (a scene's budget)
        try {
            ImageMetadata metadata;
            ImageLayers layers;
            const Image again = read_exr(file, &metadata, &layers);
            require(again.width == image.width && again.height == image.height &&
                        std::memcmp(again.rgb.data(), image.rgb.data(),
                                    image.rgb.size() * sizeof(float)) == 0,
                    "an EXR reads to the same pixels with its layers");
            for (const auto& [name, layer] : layers)
                require(name != "R" && name != "G" && name != "B" && layer.size() == pixels,
                        "one float per pixel in each layer other than R, G, B");
            const ExrShape shape = read_exr_shape(file);
            require(shape.width == image.width && shape.height == image.height &&
                        size_t(shape.channels) == 3 + layers.size(),
                    "an EXR's shape is the image read");
        } catch (const InputError&) {
            require(false, "an EXR read_hdr accepts is read with its layers and its shape");
        }
    }
    // cierzo-tonemap's every operator: display values in [0, 1], whatever the pixels
    size_t non_finite = 0, negative = 0;
    for (float v : image.rgb) {
        non_finite += !std::isfinite(v);
        negative += std::isfinite(v) && v < 0.0f;
    }
    for (const std::string& op : tonemap_operator_names()) {
        TonemapOptions options;
        options.op = op;
        TonemapStats stats;
        const Image out = tonemap(image, options, &stats);
        require(out.width == image.width && out.height == image.height &&
                    out.rgb.size() == image.rgb.size(),
                "a tone-mapped image of the input's size");
        for (float v : out.rgb) require(v >= 0.0f && v <= 1.0f, "display values in [0, 1]");
        require(stats.non_finite == non_finite && stats.negative == negative,
                "non-finite and negative values counted");
    }
    return true;
}

// ---- Shared by the bodies ------------------------------------------------------------------

void fuzz_refused(const std::exception& e) {
    static const bool verbose = std::getenv("CIERZO_FUZZ_VERBOSE") != nullptr;
    if (verbose) std::fprintf(stderr, "fuzz: refused: %s\n", e.what());
}

void fuzz_require(bool ok, const char* what) {
    if (ok) return;
    std::fprintf(stderr, "fuzz: accepted input breaks an invariant: %s\n", what);
    std::abort();
}

fs::path fuzz_scratch_file(std::string_view name, std::string_view bytes) {
    // (one folder per process, made once and removed at exit)
    static const struct Folder {
        fs::path path;
        Folder() {
            path = fs::temp_directory_path() / ("cierzo-fuzz-" + std::to_string(::getpid()));
            fs::create_directories(path);
        }
        ~Folder() {
            std::error_code ec;
            fs::remove_all(path, ec);
        }
    } folder;
    const fs::path file = folder.path / name;
    std::FILE* f = std::fopen(file.c_str(), "wb");
    require(
        f && std::fwrite(bytes.data(), 1, bytes.size(), f) == bytes.size() && std::fclose(f) == 0,
        "the input can be written to a scratch file");
    return file;
}

}  // namespace cierzo
