// The scene-file reader's parts that its files share (scene_json.cpp: the document, the
// environment, camera and settings; scene_materials.cpp: colours, textures and materials;
// scene_objects.cpp: the objects, the mesh files and their transforms): the checked JSON
// object reader and the Loader that fills a Scene.
#pragma once

#include <cmath>
#include <cstdint>
#include <exception>
#include <filesystem>
#include <initializer_list>
#include <limits>
#include <map>
#include <set>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "core/error.h"
#include "io/mesh.h"
#include "scene/load_options.h"
#include "scene/mtl_materials.h"
#include "scene/scene.h"
#include "scene/scene_images.h"

namespace cierzo::scene_file {

using nlohmann::json;
namespace fs = std::filesystem;

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
        if (!v.is_number_integer() &&
            !(v.is_number() && v.get<double>() == std::floor(v.get<double>())))
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

// Helpers of the reader's files (scene_json.cpp)
std::string short_number(double x);
Vec3f rescaled(const Vec3f& v, int* exponent = nullptr);

// A colour (a number or [r, g, b]), a colour source under `key` of `parent` (a colour or a
// texture; an image texture's file is requested from `images`), and a material
// (scene_materials.cpp)
Vec3f colour_value(Reader& r, const json& v, const std::string& key);
ColorSource read_color(Reader& parent, const std::string& key, const fs::path& file,
                       ImageRequests& images);
Material read_material(const json& j, const std::string& where, const std::string& name,
                       const fs::path& file, ImageRequests& images);

// What reading one scene file builds up: the scene, its materials by name, the image and MTL
// requests, the mesh files read, and the first error met while the text was parsed.
struct Loader {
    fs::path file;
    LoadOptions options;
    InputRoots roots;  // where the files it names may be (the scene's folder, --allow-path)
    Scene scene;
    std::map<std::string, int32_t> material_ids;
    std::map<int32_t, Mesh> loose_triangles;  // by material
    ImageRequests images;
    MtlMaterials mtl{scene, images};  // the OBJ files' materials
    // Named materials and objects read while the text was parsed (parse_document), and the
    // first error met there, to be thrown where reading the whole document would meet it
    bool materials_read = false;
    std::exception_ptr materials_error, objects_error;

    explicit Loader(const fs::path& path, const LoadOptions& opts = {})
        : file(path), options(opts), roots(path, opts.allowed_paths) {
        scene.source = path;
        scene.settings.output = path.parent_path() / (path.stem().string() + ".exr");
    }

    // A file the scene names under `key` of `r` (`named`, relative to `folder`), refused
    // (through r) when it lies outside the roots.
    fs::path input(Reader& r, const fs::path& folder, const std::string& key,
                   const std::string& named) const {
        const fs::path path = folder / named;
        const std::string why = roots.refusal(path, named);
        if (!why.empty()) r.fail("'" + key + "': " + why);
        return path;
    }

    // "materials": each named material; and an object's "material"
    void materials(Reader& root, const json& mats);
    int32_t material_ref(Reader& r) {
        return material_value(r, r.get("material"), r.where("material"));
    }

    // A material by name, or an inline one.
    int32_t material_value(Reader& r, const json& v, const std::string& where);

    // The triangles of material group g of `data`, with only the vertices they use.
    static MeshData group_of(const MeshData& data, uint32_t g);

    // One element of "objects" (`where`: its place, for messages), and the kinds with a
    // reader of their own
    void object(const json& j, const std::string& where);
    void quadric(Reader& t);
    void triangle(Reader& t);

    // Mesh files read so far, by path: the file's data and the objects using it
    struct MeshFile {
        MeshData data;
        std::vector<size_t> objects;     // indices into scene.meshes
        std::vector<std::string> where;  // their place in the file, for messages
        std::vector<int> instance;       // per object: its "instance" (1, 0), or -1 for automatic
        size_t automatic = 0;            // objects of the file without "instance"
    };
    // A file used by several objects without "instance" is traced through instances when
    // their copies would hold more triangles than this in all; below, the copies are put
    // into world space (a flat BVH traces faster, and the memory is small).
    static constexpr size_t kInstanceAbove = 65536;
    std::map<fs::path, MeshFile> mesh_files;  // by file, or file#group (OBJ materials)
    std::map<fs::path, MeshData> raw_meshes;  // every mesh file as read, by path

    // A mesh file object: the file read once, the object's material or the file's own, and
    // its transform
    void mesh(Reader& t);

    // An object's transform (linear part a, translation) and the maps derived from it.
    static void set_transform(Mesh& m, const double a[3][3], const Vec3f& move);

    // After all objects, for each mesh file: an object traced as an instance ("instance":
    // true, or automatically when several objects use the file and their copies would hold
    // more than kInstanceAbove triangles) shares the file's vertices, kept once in the file's
    // space in the first such object; every other object keeps its world-space vertices
    // (with the winding reversed by a mirroring transform, so its normals are the file's
    // normals through the inverse transpose, as an instance's are).
    void finish_meshes();

    // Alpha cut-outs mask triangles only: a sphere, plane or quadric with one is refused.
    void check_alpha() const;

    // "environment": {"emission": COLOUR, "rotate": [x, y, z]}: a solid colour or an
    // equirectangular image, rotated (degrees, about x, then y, then z).
    void environment(const json& j);

    // "camera", for an image of aspect ratio `aspect`; "render"
    void camera(const json& j, float aspect);
    void render_settings(Reader& root);
};

}  // namespace cierzo::scene_file
