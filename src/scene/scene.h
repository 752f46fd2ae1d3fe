// The scene as the integrators see it: primitives grouped by kind in structure-of-arrays
// form, materials, point lights, camera and render settings. Built by scene_json.cpp;
// kernels read it, never write it.
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "accel/bvh.h"
#include "io/texture_image.h"
#include "kernels/estimator.h"
#include "kernels/intersect.h"
#include "kernels/transport.h"
#include "scene/camera.h"

namespace cierzo {

struct FlatTables;  // scene/flat_tables.h

// A material's alpha cut-out ("alpha"; MTL d, Tr and map_d): the opacity of its triangles,
// `constant` times a channel of an image at the hit's texture coordinates. Where it is below
// 1, a ray passes through the surface with probability 1 - alpha (kernels/bvh/traverse.h,
// alpha_passes), in closest-hit and shadow rays alike.
struct AlphaSource {
    float constant = 1.0f;
    int32_t image = -1;    // Scene::images, or -1
    int32_t channel = -1;  // 0, 1, 2, 3: red, green, blue, alpha; -1: the image's alpha
                           // where it has one, else its red (a grey mask)
    float uv_scale[2] = {1.0f, 1.0f}, uv_offset[2] = {0.0f, 0.0f};
    bool clamp = false;
    bool masked() const { return image >= 0 || constant < 1.0f; }
};

struct Material {
    std::string name;
    ColorSource emission, kd, ks, kr, kt;
    AlphaSource alpha;
    float shininess = 0.0f;
    float ior = 1.0f;

    bool is_emitter() const { return !emission.is_zero(); }
    bool has_phong() const { return !kd.is_zero() || !ks.is_zero(); }
};

struct Spheres {
    std::vector<float> cx, cy, cz, radius;
    std::vector<int32_t> material;
    size_t size() const { return radius.size(); }
};

struct Planes {
    std::vector<float> nx, ny, nz, distance;  // unit normal n, plane n·p + distance = 0
    std::vector<int32_t> material;
    size_t size() const { return distance.size(); }
};

struct Quadric {
    QuadricCoefficients<float> q;
    Vec3f box_min, box_max;
    int32_t material;
};

// A triangle mesh object: a PLY file's triangles, or the scene's loose triangles of one
// material. A file used by one object has its vertices in world space (the object's
// transform applied when it was read), and its triangles go into the scene's BVH itself. A
// file used by several objects is read once: its vertices stay in the file's space, in the
// first of those objects (`geometry` = its own index), which also holds their BVH, and
// every one of them (`geometry` = that index) is traced through its transform.
struct Mesh {
    std::string source;            // file name, for messages
    std::vector<Vec3f> positions;  // world space, or the file's space (geometry owner); or
                                   // empty (an instance of another entry's geometry)
    std::vector<Vec3f> colors;     // per vertex, or empty
    std::vector<Vec3f> normals;    // per vertex, unit or zero (in the space of positions), for
                                   // shading; filled for "smooth" objects (and the geometry of
                                   // smooth instances), else empty
    std::vector<float> uvs;        // texture coordinates u, v per vertex, or empty
    std::vector<uint32_t> indices;
    int32_t material = 0;
    int32_t geometry = -1;  // -1: own world-space vertices; else the entry with the vertices
    float to_world[12] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0};  // row-major 3 × 4 (instances)
    float to_object[12] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0};
    float normal_to_world[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};  // inverse transpose of to_world
    bool mirrored = false;                                   // to_world has a negative determinant
    bool smooth = false;             // shaded with the interpolated vertex normals
    std::shared_ptr<const Bvh> bvh;  // geometry owners only: over the file-space triangles
    bool instanced() const { return geometry >= 0; }
    size_t triangle_count() const { return indices.size() / 3; }
};

struct PointLight {
    Vec3f position;
    Vec3f intensity;  // radiant intensity, RGB; irradiance at distance d is I / d²
};

struct RenderSettings {
    int width = 256;
    int height = 256;
    int64_t spp = 16;  // paths per pixel
    uint32_t seed = 1;
    std::filesystem::path output;  // resolved against the scene file's folder
    EstimatorSettings estimator;
    // The BVH's spatial splits: at most this fraction of extra triangle references
    // (BvhInput::split_budget; 0: none)
    float spatial_splits = kBvhDefaultSplitBudget;
};

// Which features a scene uses, so a render pays only for those.
struct SceneFeatures {
    bool spheres = false, planes = false, quadrics = false, meshes = false;
    bool point_lights = false, emitters = false;
    bool diffuse = false, specular = false, mirror = false, refraction = false;
    bool procedural_textures = false, vertex_colors = false, image_textures = false;
    bool smooth = false;  // a mesh is shaded with interpolated normals
};

// A closest hit as the scalar integrator records it.
struct Hit {
    float t = kRayFar;
    Vec3f p, n;  // point and unit geometric normal (outward: sphere out, plane n, quadric ∇f)
    Vec3f ns;    // unit shading normal: n, or on a smooth mesh the interpolated vertex normal
    int32_t material = -1;
    int32_t mesh = -1;  // for vertex colours
    uint32_t triangle = 0;
    int32_t sphere = -1;  // the sphere's index, when a sphere was hit
    bool plane = false;   // a plane was hit
};

// The emitters next-event estimation samples: every sphere and triangle whose material has
// a solid, non-zero emission (a textured emission, a plane or a quadric is not sampled, and
// keeps the report's estimator in every estimator). Built by Scene::finalize.
struct Emitters {
    std::vector<float> alias_q, pmf, data;  // see EmitterTable
    std::vector<int32_t> alias, kind;
    std::vector<int32_t> sphere_id;   // per sphere: its emitter, or -1
    std::vector<int32_t> mesh_first;  // per mesh entry: the emitter of its triangle 0, or -1
    size_t sampled_objects = 0;       // sampled spheres and emitting mesh objects
    size_t unsampled_objects = 0;     // emitting objects no estimator samples
    double total_power = 0.0;         // Σ area × max Le of the sampled emitters
    // The environment's tables (EnvironmentMap), its frame and its entry (-1: none)
    int32_t environment_width = 0, environment_height = 0, environment_id = -1;
    std::vector<float> environment_radiance, environment_row_cdf, environment_col_cdf,
        environment_density;
    float environment_to_local[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
    float environment_to_world[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
    double environment_mean = 0.0;  // mean max-RGB radiance over directions

    size_t count() const { return pmf.size(); }
    EmitterTable table() const {
        EmitterTable t{int32_t(pmf.size()),
                       alias_q.data(),
                       alias.data(),
                       pmf.data(),
                       kind.data(),
                       data.data(),
                       {}};
        if (environment_width > 0) {
            EnvironmentMap& m = t.environment;
            m.width = environment_width, m.height = environment_height;
            m.radiance = environment_radiance.data();
            m.row_cdf = environment_row_cdf.data();
            m.col_cdf = environment_col_cdf.data();
            m.density = environment_density.data();
            std::copy(environment_to_local, environment_to_local + 9, m.to_local);
            std::copy(environment_to_world, environment_to_world + 9, m.to_world);
            m.emitter = environment_id;
        }
        return t;
    }
};

// The environment light (top-level "environment"): its emission, a solid colour or an
// equirectangular image (kernels/emitter_table.h, EnvironmentMap, says how directions map to
// it), and its rotation. Scene::finalize makes its tables (Emitters).
struct Environment {
    ColorSource emission;                             // zero: no environment
    float to_world[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};  // row-major rotation
    bool present() const { return !emission.is_zero(); }
};

// Where paths from the lights start (light tracing; kernels/transport.h): the sampled
// emitters, with power 2π·A·max Le (emission is two-sided), and the point lights, with
// power 4π·max I, chosen by power. Built by Scene::finalize.
struct LightStarts {
    float emitter_probability = 0.0f;
    std::vector<float> point_cdf, point, point_source;  // see LightStartTable
    // Per point light: the refractive index of the medium it sits in (the scene's, or that
    // of the refractive object around it), and whether any light can start at all
    std::vector<float> medium_ior;
    double total_power = 0.0;
    LightStartTable table() const {
        return {emitter_probability, int32_t(point_cdf.size()), point_cdf.data(), point.data(),
                point_source.data()};
    }
};

// A camera given by position, target, up and vertical field of view: kept so the frame can
// be rebuilt for another aspect ratio.
struct LookAt {
    Vec3f position, target, up;
    float vfov_degrees;
    Handedness handedness = Handedness::kLeft;
};

// The alpha cut-outs of a scene's meshes as the traversal reads them (AlphaTable), with
// the texture coordinates and triangles of the masked meshes it points into. Built by
// Scene::finalize; copies of the scene share it.
struct AlphaTables {
    std::vector<AlphaMask> masks;
    std::vector<MeshAlpha> meshes;  // per Scene::meshes entry
    std::vector<std::vector<float>> uvs;
    std::vector<std::vector<uint32_t>> indices;
    std::vector<std::shared_ptr<const TextureImage>> images;  // the masks' images
    AlphaTable table;
};

class Scene {
public:
    Camera camera;
    std::optional<LookAt> look_at;  // set when the camera was given in the look_at form
    RenderSettings settings;
    float scene_ior = 1.0f;
    std::vector<Material> materials;
    Spheres spheres;
    Planes planes;
    std::vector<Quadric> quadrics;
    std::vector<Mesh> meshes;
    std::vector<PointLight> lights;
    Environment environment;
    // The image textures the materials name (ColorSource::image), each decoded once, and
    // their views for the kernels (set by add_image)
    std::vector<std::shared_ptr<const TextureImage>> images;
    std::vector<ImageView> image_views;
    std::filesystem::path source;  // the scene file, for messages
    // Every file read to make the scene (the scene file, mesh files), which no output may
    // replace (io/output_file.h)
    std::vector<std::filesystem::path> files;
    // What the scene's files hold that cierzo reads but cannot model (an MTL key, a material
    // name no library defines), one message each, for the program to print
    std::vector<std::string> warnings;

    // The acceleration structure over every bounded primitive (spheres, quadrics with a
    // finite box, world-space triangles, instances), and the quadrics tested beside it.
    Bvh bvh;
    std::vector<int32_t> unbounded_quadrics;
    double bvh_seconds = 0.0;     // building every BVH, in finalize()
    double load_seconds = 0.0;    // load_scene() as a whole: reading, decoding, building
    double image_seconds = 0.0;   // decoding the image textures (in parallel), in load_scene()
    bool smooth_shading = false;  // some mesh is smooth (set by finalize())
    Emitters emitters;
    LightStarts light_starts;
    std::vector<float> light_data;  // the point lights, 6 floats each (set by finalize())
    // The tables of the scene's flat form (scene/flat_tables.h), for the wavefront kernels
    std::shared_ptr<const FlatTables> flat_tables;
    // The meshes' alpha cut-outs; null when no material is masked
    std::shared_ptr<const AlphaTables> alpha_tables;
    const AlphaTable* alpha() const { return alpha_tables ? &alpha_tables->table : nullptr; }

    // Call once after filling the arrays: builds the BVHs, the emitters and the flat tables
    // (a copy of the scene shares its meshes' BVHs and the flat tables; change no primitive
    // or material afterwards without calling it again).
    void finalize();

    // The mesh entry holding the vertices and indices of mesh m (itself, or the geometry it
    // instances).
    const Mesh& geometry_of(const Mesh& m) const {
        return m.instanced() ? meshes[size_t(m.geometry)] : m;
    }

    // Changes the image size; a look_at camera keeps its vertical field of view and takes
    // the new aspect ratio (an explicit frame keeps its vectors, as the file gave them).
    void set_resolution(int width, int height);

    SceneFeatures features() const;

    // Adds an image texture; returns its index for ColorSource::image.
    int32_t add_image(std::shared_ptr<const TextureImage> image);
    // The texture coordinates of a hit (kernels/texture.h: a mesh's per-vertex (u, v), 0
    // without them; a sphere's longitude and latitude; a plane's own frame; 0 on a quadric).
    void hit_uv(const Hit& hit, float& u, float& v) const;

    // Closest hit in (0, tmax); fills hit and returns true if there is one.
    bool intersect(const Ray<float>& ray, float tmax, Hit& hit) const;
    // Any hit in (0, tmax).
    bool occluded(const Ray<float>& ray, float tmax) const;

    // The material's colours at a hit (textures and vertex colours evaluated).
    Bsdf<float> bsdf_at(const Hit& hit) const;
    Vec3f emission_at(const Hit& hit) const;
    // The sampled emitter a hit is on, or -1 (not an emitter, or one that is not sampled).
    int32_t emitter_id(const Hit& hit) const {
        if (hit.sphere >= 0) return emitters.sphere_id[size_t(hit.sphere)];
        if (hit.mesh < 0) return -1;
        const int32_t first = emitters.mesh_first[size_t(hit.mesh)];
        return first < 0 ? -1 : first + int32_t(hit.triangle);
    }

    // Whether the camera tiles trace camera paths: always, but with light tracing (lt) only where
    // some emitter cannot be sampled (the light paths bring every other light).
    bool traces_camera_paths() const {
        return !traits(settings.estimator.kind).light_batches || emitters.unsampled_objects > 0 ||
               environment.present();
    }

    // What a path vertex needs of the scene (kernels/path_vertex.h), for both integrators
    // (vcm's merge_radius resolved: merge_radius()). Where the estimator connects through
    // the light vertex cache (needs_light_pilot()), its connection_count comes from the
    // estimate light_subpath_vertices keeps, which must have been made for these settings
    // (integrators/light_pilot.h, prepare_path_context): else std::logic_error.
    PathContext path_context() const;
    // path_context() without PathContext::connection_count (left 1): what the light pilot
    // traces its subpaths with.
    PathContext pilot_context() const;
    // Whether path_context() needs the light pilot's estimate: a connecting estimator with
    // the light vertex cache's draws (light_connections) and no connection_count set.
    bool needs_light_pilot() const;

    // The mean number of vertices a light subpath stores under the scene's estimator
    // settings: the light vertex cache's MIS (PathContext::connection_count). Estimated once
    // for the scene and the settings that shape light subpaths (survival cap, diffuse
    // sampling, length limits) by the integrators' pilot, `estimate(pilot_context())`, which
    // is called only where no estimate is kept for them (integrators/light_pilot.h); kept
    // for the scene and its copies.
    double light_subpath_vertices(const std::function<double(const PathContext&)>& estimate) const;

    // vcm's r0: render.merge_radius / --merge-radius if set, else kMergeRadiusFraction of
    // half the diagonal of the box around the bounded primitives and the camera (1 if that
    // is empty or not finite).
    float merge_radius() const;
    // The scene's radius: half the diagonal of the box around its bounded primitives
    // (spheres, meshes, bounded quadrics; planes have none), or 1 with none.
    double bounds_radius() const;

    // The pinhole as paths from the lights see it (kernels/transport.h).
    PinholeFrame pinhole() const {
        return pinhole_frame(camera.origin, camera.forward, camera.left, camera.up, settings.width,
                             settings.height);
    }

    // The unit shading normal of a hit on smooth mesh `object` (Hit::ns).
    Vec3f shading_normal(const Mesh& object, const Hit& hit) const;

private:
    // light_subpath_vertices's estimates, by the settings they were made with (finalize()
    // starts afresh; copies share them, as they share the geometry)
    struct LightPilot {
        struct Entry {
            float survival_cap;
            bool cosine_diffuse;
            int32_t min_length, max_length;
            double vertices;
        };
        std::mutex mutex;
        std::vector<Entry> entries;
    };
    std::shared_ptr<LightPilot> light_pilot_ = std::make_shared<LightPilot>();
    // The estimate kept for `e`'s settings, or nothing (the caller holds the lock).
    const LightPilot::Entry* kept_light_pilot(const EstimatorSettings& e) const;

    void build_alpha();
    void build_emitters();
    void build_environment();
    void build_light_starts();
    // (in scene/flat_tables.cpp, with the flat view that reads the tables)
    void build_flat_tables();
    Vec3f color_at(const ColorSource& c, const Hit& hit) const;
};

}  // namespace cierzo
