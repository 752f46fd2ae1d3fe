// The scene's flat form: the tables built once by Scene::finalize, and the view that binds
// them to the scene (flat_tables.h).
#include "scene/flat_tables.h"

#include <cstdlib>
#include <initializer_list>
#include <new>

#include "core/error.h"
#include "kernels/bvh/traverse.h"
#include "scene/scene.h"

namespace cierzo {

namespace {

// A copy of a table padded with zeros to a multiple of 16 entries, and 16 more.
template <class T>
std::vector<T> padded(const std::vector<T>& v) {
    std::vector<T> out(v);
    out.resize((v.size() + 15) / 16 * 16 + 16, T(0));
    return out;
}

// 64-byte aligned floats (the lane tables are read with aligned vector loads).
struct AlignedFloats {
    std::unique_ptr<float[], void (*)(void*)> memory{nullptr, std::free};
    const float* data() const { return memory.get(); }
};

// Every value of `values` repeated in 16 lanes: value i at [16i, 16i + 16).
AlignedFloats lanes_of(const std::vector<float>& values) {
    const size_t bytes = (values.size() * 16 + 16) * sizeof(float);
    AlignedFloats out;
    out.memory.reset(static_cast<float*>(std::aligned_alloc(64, (bytes + 63) / 64 * 64)));
    if (!out.memory) throw std::bad_alloc();
    for (size_t i = 0; i < values.size(); ++i)
        std::fill_n(out.memory.get() + 16 * i, 16, values[i]);
    return out;
}
// Value k of primitive j of four SoA arrays, repeated in 16 lanes at [(4j + k) * 16, +16).
AlignedFloats lanes_of(std::initializer_list<const std::vector<float>*> arrays) {
    const size_t n = (*arrays.begin())->size();
    std::vector<float> values(4 * n);
    size_t k = 0;
    for (const std::vector<float>* a : arrays) {
        for (size_t j = 0; j < n; ++j) values[4 * j + k] = (*a)[j];
        ++k;
    }
    return lanes_of(values);
}

FlatColor flatten(const ColorSource& c) {
    return {uint32_t(c.kind), {c.a.x, c.a.y, c.a.z},          {c.b.x, c.b.y, c.b.z},
            c.frequency,      {c.axis.x, c.axis.y, c.axis.z}, {c.axis2.x, c.axis2.y, c.axis2.z},
            c.image,          {c.uv_scale[0], c.uv_scale[1]}, {c.uv_offset[0], c.uv_offset[1]},
            c.clamp ? 1u : 0u};
}

}  // namespace

struct FlatTables {
    std::vector<float> sphere[4], plane[4];
    AlignedFloats plane_lanes, quadric_lanes;
    std::vector<int32_t> sphere_material, plane_material;
    std::vector<float> quadric, color, shininess, ior;
    std::vector<int32_t> quadric_material, unbounded_quadrics, mesh_material, emitter, phong,
        textured, sphere_emitter, mesh_emitter;
    std::vector<FlatColor> sources;
    std::vector<FlatImage> images;
    uint32_t texture_channels = 0;  // bit c: some material textures colour channel c
};

void Scene::build_flat_tables() {
    const Scene& scene = *this;
    auto t = std::make_shared<FlatTables>();
    // Analytic primitives: padded copies of the scene's SoA arrays, quadrics as 16 floats
    const Spheres& sp = scene.spheres;
    const Planes& pl = scene.planes;
    t->sphere[0] = padded(sp.cx), t->sphere[1] = padded(sp.cy), t->sphere[2] = padded(sp.cz);
    t->sphere[3] = padded(sp.radius), t->sphere_material = padded(sp.material);
    t->plane[0] = padded(pl.nx), t->plane[1] = padded(pl.ny), t->plane[2] = padded(pl.nz);
    t->plane[3] = padded(pl.distance), t->plane_material = padded(pl.material);
    t->plane_lanes = lanes_of({&pl.nx, &pl.ny, &pl.nz, &pl.distance});
    for (const Quadric& q : scene.quadrics) {
        t->quadric.insert(t->quadric.end(), {q.q.a, q.q.b, q.q.c, q.q.d, q.q.e, q.q.f, q.q.g, q.q.h,
                                             q.q.i, q.q.j, q.box_min.x, q.box_min.y, q.box_min.z,
                                             q.box_max.x, q.box_max.y, q.box_max.z});
        t->quadric_material.push_back(q.material);
    }
    t->quadric = padded(t->quadric), t->quadric_material = padded(t->quadric_material);
    t->quadric_lanes = lanes_of(t->quadric);
    t->unbounded_quadrics = padded(scene.unbounded_quadrics);
    for (const Mesh& m : scene.meshes) {
        // Vertex colours gather x, y, z of vertex v at 3v + k with 32-bit indices
        if (scene.geometry_of(m).positions.size() > (size_t(1) << 29))
            throw InputError(m.source + ": more than 2^29 vertices");
        t->mesh_material.push_back(m.material);
    }
    t->mesh_material = padded(t->mesh_material);

    // Materials as SoA [channel][component][material], each row padded to 16
    const size_t mc = scene.materials.size();
    const size_t stride = (mc + 15) / 16 * 16;
    t->color.assign(kColCount * 3 * stride + 16, 0.0f);
    for (size_t m = 0; m < mc; ++m) {
        const Material& mat = scene.materials[m];
        const ColorSource* ch[kColCount] = {&mat.emission, &mat.kd, &mat.ks, &mat.kr, &mat.kt};
        int32_t tex = 0;  // bit c: channel c is textured
        for (int c = 0; c < kColCount; ++c) {
            for (int k = 0; k < 3; ++k)
                t->color[(size_t(c) * 3 + size_t(k)) * stride + m] = ch[c]->a[k];
            t->sources.push_back(flatten(*ch[c]));
            if (ch[c]->kind != TextureKind::kSolid) tex |= 1 << c;
        }
        t->texture_channels |= uint32_t(tex);
        t->shininess.push_back(mat.shininess);
        t->ior.push_back(mat.ior);
        t->emitter.push_back(mat.is_emitter() ? 1 : 0);
        t->phong.push_back(mat.has_phong() ? 1 : 0);
        t->textured.push_back(tex);
    }
    for (const ImageView& im : scene.image_views)
        t->images.push_back({im.bytes, im.floats, im.decode, im.width, im.height});
    t->shininess = padded(t->shininess), t->ior = padded(t->ior), t->emitter = padded(t->emitter);
    t->phong = padded(t->phong), t->textured = padded(t->textured);
    // Next-event estimation's emitters, per sphere and mesh the id of its (first) emitter
    t->sphere_emitter = padded(scene.emitters.sphere_id);
    t->mesh_emitter = padded(scene.emitters.mesh_first);
    flat_tables = std::move(t);
}

FlatView flat_view(const Scene& scene) {
    if (!scene.flat_tables) throw std::logic_error("flat_view of a scene not finalized");
    FlatView view;
    view.tables = scene.flat_tables;
    const FlatTables& t = *view.tables;
    FlatScene& f = view.scene;

    f.sphere_count = int32_t(scene.spheres.size());
    f.sphere_cx = t.sphere[0].data(), f.sphere_cy = t.sphere[1].data();
    f.sphere_cz = t.sphere[2].data(), f.sphere_r = t.sphere[3].data();
    f.sphere_material = t.sphere_material.data();
    f.plane_count = int32_t(scene.planes.size());
    f.plane_nx = t.plane[0].data(), f.plane_ny = t.plane[1].data();
    f.plane_nz = t.plane[2].data(), f.plane_d = t.plane[3].data();
    f.plane_material = t.plane_material.data();
    f.plane_lanes = t.plane_lanes.data();
    f.quadric_count = int32_t(scene.quadrics.size());
    f.quadric = t.quadric.data();
    f.quadric_lanes = t.quadric_lanes.data();
    f.quadric_material = t.quadric_material.data();
    f.unbounded_quadric_count = int32_t(scene.unbounded_quadrics.size());
    f.unbounded_quadrics = t.unbounded_quadrics.data();
    f.bvh = &scene.bvh.view();
    f.alpha = scene.alpha();
    // The meshes: the scene's own vertex arrays
    static_assert(sizeof(Vec3f) == 3 * sizeof(float));
    for (const Mesh& m : scene.meshes) {
        const Mesh& g = scene.geometry_of(m);
        FlatMesh flat;
        flat.indices = reinterpret_cast<const int32_t*>(g.indices.data());
        flat.positions = &g.positions.data()->x;
        flat.colors = g.colors.empty() ? nullptr : &g.colors.data()->x;
        flat.to_object = m.instanced() ? m.to_object : nullptr;
        flat.normals = m.smooth ? &g.normals.data()->x : nullptr;
        flat.normal_to_world = m.instanced() ? m.normal_to_world : nullptr;
        flat.uvs = g.uvs.empty() ? nullptr : g.uvs.data();
        view.meshes.push_back(flat);
    }
    f.meshes = view.meshes.data();
    f.mesh_count = int32_t(scene.meshes.size());
    f.mesh_material = t.mesh_material.data();

    const size_t mc = scene.materials.size();
    f.material_count = int32_t(mc);
    f.material_stride = int32_t((mc + 15) / 16 * 16);
    f.color = t.color.data(), f.shininess = t.shininess.data(), f.ior = t.ior.data();
    f.emitter = t.emitter.data(), f.phong = t.phong.data(), f.textured = t.textured.data();
    f.sources = t.sources.data();
    f.images = t.images.data();
    f.light_count = int32_t(scene.lights.size());
    f.light = scene.light_data.data();  // (6 floats each, as the path context has them)
    f.sphere_emitter = t.sphere_emitter.data();
    f.mesh_emitter = t.mesh_emitter.data();

    // What changes after finalize: the estimator (path context), the camera and the image
    f.path = scene.path_context();
    f.light_starts = scene.light_starts.table();
    f.pinhole = scene.pinhole();
    f.camera_paths = scene.traces_camera_paths();
    const Camera& c = scene.camera;
    for (int k = 0; k < 3; ++k) {
        f.cam_origin[k] = c.origin[k], f.cam_forward[k] = c.forward[k];
        f.cam_left[k] = c.left[k], f.cam_up[k] = c.up[k];
    }
    f.width = scene.settings.width, f.height = scene.settings.height;
    f.seed = scene.settings.seed;
    const SceneFeatures sf = scene.features();
    const bool tree = !scene.bvh.empty();
    const bool packet = tree && packet_tree(scene.bvh.view());
    f.ray_group = 1;
    f.features = {sf.spheres,
                  sf.planes,
                  sf.quadrics,
                  sf.meshes,
                  tree,
                  packet,
                  sf.point_lights,
                  sf.emitters,
                  sf.diffuse,
                  sf.specular,
                  sf.mirror,
                  sf.refraction,
                  sf.procedural_textures || sf.vertex_colors || sf.image_textures,
                  int(sf.diffuse) + int(sf.specular) + int(sf.mirror) + int(sf.refraction),
                  t.texture_channels};
    return view;
}

}  // namespace cierzo
