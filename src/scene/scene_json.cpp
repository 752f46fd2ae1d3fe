// The scene-file reader: strict JSON (comments allowed), every key checked, every value
// range-checked, with messages of the form "FILE: objects[2] (sphere): radius must be > 0".
// Here the document, environment, camera and settings; materials are read in
// scene_materials.cpp, the objects and mesh files in scene_objects.cpp, OBJ materials in
// mtl_materials.cpp, and images loaded in scene_images.cpp.
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
#include <system_error>

#include <nlohmann/json.hpp>

#include "core/error.h"
#include "io/input_file.h"
#include "scene/estimator_options.h"
#include "scene/scene_loader.h"
#include "scene/strict_json.h"

namespace cierzo {

namespace scene_file {

// Limits that refuse absurd requests before anything is allocated.
constexpr int64_t kMaxDimension = 1 << 16;
constexpr int64_t kMaxPixels = int64_t(1) << 28;

// A number for a message: "1e+60", not sixty digits.
std::string short_number(double x) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%g", x);
    return buf;
}

// A vector scaled by a power of two so that its largest component is in [0.5, 1): the same
// direction, and the same bits of v / |v|, but |v|² neither overflows nor underflows a float
// (it would beyond about 1e19 or below 1e-19). The zero vector stays zero.
Vec3f rescaled(const Vec3f& v, int* exponent) {
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

void Loader::check_alpha() const {
    std::vector<uint8_t> masked(scene.materials.size());
    bool any = false;
    for (size_t i = 0; i < masked.size(); ++i)
        any |= (masked[i] = scene.materials[i].alpha.masked()) != 0;
    if (!any) return;  // (the usual case: a million spheres are not looked at)
    const auto refuse = [&](int32_t material, const char* what) {
        if (!masked[size_t(material)]) return;
        const Material& m = scene.materials[size_t(material)];
        throw InputError(
            file.string() + ": " +
            (m.name.empty() ? std::string("an inline material") : "material '" + m.name + "'") +
            " has an 'alpha' below 1, but is used by a " + what +
            ": alpha cut-outs apply to triangles and meshes only");
    };
    for (int32_t mat : scene.spheres.material) refuse(mat, "sphere");
    for (int32_t mat : scene.planes.material) refuse(mat, "plane");
    for (const Quadric& q : scene.quadrics) refuse(q.material, "quadric");
}

void Loader::environment(const json& j) {
    Reader r(j, "environment", file);
    ColorSource c = read_color(r, "emission", file, images);
    if (c.kind != TextureKind::kSolid && c.kind != TextureKind::kImage)
        r.fail("'emission' must be a colour or an image texture (an equirectangular map)");
    if (c.kind == TextureKind::kImage &&
        (c.clamp || c.uv_scale[0] != 1.0f || c.uv_scale[1] != 1.0f || c.uv_offset[0] != 0.0f ||
         c.uv_offset[1] != 0.0f))
        r.fail(
            "an environment image covers every direction once: 'scale', 'offset' and "
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

void Loader::camera(const json& j, float aspect) {
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
            r.fail(
                "'look_at' is too far from 'position' (beyond about 1e19: their "
                "distance squared overflows a float)");
        if (!(length(cross(up, target - position)) > 0.0f))
            r.fail("'up' is parallel to the viewing direction");
        if (r.has("forward") || r.has("left"))
            r.fail(
                "'forward' and 'left' belong to the explicit frame form; they cannot be "
                "combined with 'look_at'");
        const std::string hand = r.string("handedness", "left");
        if (hand != "left" && hand != "right")
            r.fail(
                "'handedness' must be \"left\" (the report's: up +y and looking along +z "
                "put +x on the right) or \"right\" (OBJ, glTF, Blender: +x on the left)");
        const Handedness h = hand == "left" ? Handedness::kLeft : Handedness::kRight;
        scene.look_at = LookAt{position, target, up, float(vfov), h};
        scene.camera = look_at_camera(position, target, up, float(vfov), aspect, h);
        // In float, a vfov just below 180 can round to a half-angle past 90 degrees (an
        // upside-down frame) and one just above 0 to a frame of zero size
        if (!(dot(scene.camera.up, up) > 0.0f) ||
            !frame_is_normalisable(scene.camera.forward, scene.camera.left, scene.camera.up))
            r.fail("'vfov' " + short_number(vfov) +
                   " is too close to 0 or 180 degrees "
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
            r.fail(
                "'forward', 'left' and 'up' are too long: forward ± left ± up must stay "
                "below about 1e19 in length, or the ray directions overflow a float");
        if (r.has("vfov"))
            r.fail(
                "'vfov' belongs to the 'look_at' form; in the explicit frame form the "
                "lengths of 'left' and 'up' set the field of view");
        if (r.has("handedness"))
            r.fail(
                "'handedness' belongs to the 'look_at' form; in the explicit frame form "
                "'left' says where the image's left is");
    }
    r.finish();
}

void Loader::render_settings(Reader& root) {
    RenderSettings& s = scene.settings;
    if (!root.has("render")) {
        root.allow({"render"});
        use_estimator(s.estimator, kDefaultEstimator);
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
        r.fail(
            "'spatial_splits' must be in [0, 4]: the fraction of extra triangle references "
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
    if (r.has("guiding")) {
        const std::optional<Guiding> g = parse_guiding(r.string("guiding", "none"));
        if (!g) r.fail("'guiding' must be \"none\" or \"sdtree\"");
        e.guiding = *g;
    }
    e.guided_vertices =
        int32_t(r.integer("guided_vertices", e.guided_vertices, 0, kMaxLengthLimit));
    e.min_length = int32_t(r.integer("min_length", 1, 1, kMaxLengthLimit));
    e.max_length = r.has("max_length") ? int32_t(r.integer("max_length", 1, 1, kMaxLengthLimit))
                                       : kNoLengthLimit;
    if (e.max_length < e.min_length)
        r.fail("'max_length' (" + std::to_string(e.max_length) + ") is below 'min_length' (" +
               std::to_string(e.min_length) + "): no path would count");
    const std::optional<Estimator> kind =
        parse_estimator(r.string("estimator", estimator_name(kDefaultEstimator)));
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
            r.fail(
                "'merge_radius' must be a positive length (the first merging radius of vcm, bpm "
                "and ppm)");
        e.merge_radius = float(r0);
    } else {
        r.allow({"merge_radius"});
    }
    if (r.has("merge_alpha")) {
        const double alpha = r.number("merge_alpha", kMergeAlpha);
        if (!(alpha > 0.0 && alpha < 1.0))
            r.fail(
                "'merge_alpha' must be in (0, 1), exclusive (how fast the merging radius shrinks)");
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
    if (r.has("output")) {
        // (written only beneath the scene's own folder: a downloaded scene does not choose
        // where files land; --out names any place)
        const std::string named = r.string("output");
        const fs::path out = file.parent_path() / named;
        const InputRoots folder(file, {});
        if (!options.output_named && !folder.allows(out))
            r.fail("'output': '" + named + "' resolves to " + resolved_path(out).string() +
                   ", outside the scene's folder " + folder.folder().string() +
                   ": a scene writes its image only beneath its own folder; --out names "
                   "another place");
        s.output = out;
    } else
        r.allow({"output"});
    r.finish();
}

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
    if (r.has("environment"))
        l.environment(r.get("environment"));
    else
        r.allow({"environment"});
    load_images(l.scene, l.images, l.file, l.roots, l.options.image_memory);
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

}  // namespace scene_file

using nlohmann::json;
namespace fs = std::filesystem;
using scene_file::build_scene;
using scene_file::Loader;
using scene_file::parse_document;

Scene parse_scene(const std::string& text, const fs::path& path, const LoadOptions& options) {
    Loader l(path, options);
    const json root = parse_document(text, l);
    return build_scene(l, root);
}

// A mesh file rendered directly (`cierzo render model.obj`): the file with its own materials
// (an OBJ's MTL; a PLY or an OBJ without materials in diffuse grey 0.8), under a white sky of
// radiance 1, seen by a right-handed camera of 40 degrees that frames its bounding sphere
// from the front, above and to the right; 512 × 512 pixels, 16 paths of the default
// estimator (mis, with its defaults), written to STEM.exr in the current folder.
Scene load_mesh_as_scene(const fs::path& path, const LoadOptions& options) {
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
        scene = parse_scene(j.dump(), path, options);
    } catch (const InputError& e) {
        // An OBJ without 'usemtl': every face grey (read again: a rare case)
        const std::string m = e.what();
        if (!obj || m.find("names no materials of its own") == std::string::npos) throw;
        j["objects"][0]["material"] = "grey";
        scene = parse_scene(j.dump(), path, options);
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
    if (!scene.files.empty() && scene.files.front() != path)
        scene.files.insert(scene.files.begin(), path);
    return scene;
}

bool is_model_file(const fs::path& path) {
    std::string ext = path.extension().string();
    for (char& c : ext) c = char(std::tolower(static_cast<unsigned char>(c)));
    return ext == ".obj" || ext == ".ply";
}

namespace {
Scene load_scene_untimed(const fs::path& path, const LoadOptions& options);
}  // namespace

Scene load_scene(const fs::path& path, const LoadOptions& options) {
    const auto start = std::chrono::steady_clock::now();
    Scene scene = load_scene_untimed(path, options);
    scene.load_seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return scene;
}

namespace {
Scene load_scene_untimed(const fs::path& path, const LoadOptions& options) {
    if (is_model_file(path)) return load_mesh_as_scene(path, options);
    std::ifstream in;
    if (input_file_exists(path)) in.open(path, std::ios::binary);
    if (!in.is_open()) throw InputError(path.string() + ": cannot open scene file");
    Loader l(path, options);
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
