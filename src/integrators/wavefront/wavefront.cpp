// The wavefront integrator's scalar side: the flat view of the scene that the per-ISA
// kernels read (the scene BVH, the unbounded primitives, meshes' vertex arrays), per-thread path pools, the
// choice of instruction set, and the hand-over of finished paths to the film.
#include "integrators/wavefront/wavefront.h"

#include <algorithm>
#include <cstdlib>
#include <memory>
#include <new>
#include <stdexcept>

#include <oneapi/tbb/enumerable_thread_specific.h>

#include "core/error.h"
#include "kernels/traverse.h"

namespace cierzo {

namespace {

void finish_paths(void* film, int32_t count, const uint32_t* pixel, const float* r,
                  const float* g, const float* b) {
    // Pixel indices are y * width + x in the whole image (one division per radiant path)
    FilmTile& f = *static_cast<FilmTile*>(film);
    for (int32_t i = 0; i < count; ++i) f.at_index(pixel[i]).add_counted({r[i], g[i], b[i]});
}

void splat_paths(void* film, int32_t count, const uint32_t* pixel, const float* r,
                 const float* g, const float* b) {
    FilmTile& f = *static_cast<FilmTile*>(film);
    for (int32_t i = 0; i < count; ++i) f.splat(pixel[i], {r[i], g[i], b[i]});
}

FlatColor flatten(const ColorSource& c) {
    return {uint32_t(c.kind), {c.a.x, c.a.y, c.a.z}, {c.b.x, c.b.y, c.b.z}, c.frequency,
            {c.axis.x, c.axis.y, c.axis.z}, {c.axis2.x, c.axis2.y, c.axis2.z}};
}

// One thread's pool: an aligned block carved into SoA arrays.
struct PoolMemory {
    void* memory = nullptr;
    PathPool pool;
    PoolMemory(int32_t capacity, int32_t lights, int32_t materials) {
        const size_t bytes = path_pool_bytes(capacity, lights, materials);
        memory = std::aligned_alloc(64, (bytes + 63) / 64 * 64);
        if (!memory) throw std::bad_alloc();
        pool = carve_path_pool(memory, capacity, lights, materials);
    }
    PoolMemory(const PoolMemory&) = delete;
    PoolMemory& operator=(const PoolMemory&) = delete;
    ~PoolMemory() { std::free(memory); }
};

}  // namespace

// ---- Instruction sets ---------------------------------------------------------------------

namespace {

// (CIERZO_BUILT_<ISA> is 1 for the ISAs with kernels, 0 for the rest and for every ISA of
// the other architecture)
TraceRaysEntry trace_entry_of(Isa isa) {
    switch (isa) {
#if CIERZO_BUILT_AVX512
        case Isa::kAvx512: return trace_rays_avx512;
#endif
#if CIERZO_BUILT_AVX2
        case Isa::kAvx2: return trace_rays_avx2;
#endif
#if CIERZO_BUILT_SSE42
        case Isa::kSse42: return trace_rays_sse42;
#endif
#if CIERZO_BUILT_NEON
        case Isa::kNeon: return trace_rays_neon;
#endif
        default: throw std::logic_error("no wavefront kernels for " + isa_name(isa));
    }
}

RenderTileEntry entry_of(Isa isa) {
    switch (isa) {
#if CIERZO_BUILT_AVX512
        case Isa::kAvx512: return render_tile_avx512;
#endif
#if CIERZO_BUILT_AVX2
        case Isa::kAvx2: return render_tile_avx2;
#endif
#if CIERZO_BUILT_SSE42
        case Isa::kSse42: return render_tile_sse42;
#endif
#if CIERZO_BUILT_NEON
        case Isa::kNeon: return render_tile_neon;
#endif
        default: throw std::logic_error("no wavefront kernels for " + isa_name(isa));
    }
}

}  // namespace

// ---- The renderer -----------------------------------------------------------------------------

// A copy of a table padded with zeros to a multiple of 16 entries.
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
    for (size_t i = 0; i < values.size(); ++i) std::fill_n(out.memory.get() + 16 * i, 16, values[i]);
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

static bool samples_emitters(const Scene& scene);
static int32_t shadow_rays_per_vertex(const Scene& scene);

struct WavefrontRenderer::Data {
    const Scene& scene;
    FlatScene flat{};
    std::vector<float> sphere[4], plane[4];
    AlignedFloats plane_lanes, quadric_lanes;
    std::vector<int32_t> sphere_material, plane_material;
    std::vector<float> quadric, color, shininess, ior, light;
    std::vector<int32_t> quadric_material, unbounded_quadrics, mesh_material, emitter, phong,
        textured, sphere_emitter, mesh_emitter;
    std::vector<FlatMesh> meshes;
    std::vector<FlatColor> sources;
    RenderTileEntry entry = nullptr;
    int32_t pool_size;
    mutable oneapi::tbb::enumerable_thread_specific<PoolMemory> pools;

    Data(const Scene& s, int32_t size)
        : scene(s),
          pool_size(size),
          pools(size, shadow_rays_per_vertex(s), int32_t(s.materials.size())) {}
};

// Whether the estimator samples emitters: nee or mis, and emitters it can sample.
static bool samples_emitters(const Scene& scene) {
    const Estimator e = scene.settings.estimator.kind;
    return (e == Estimator::kNee || e == Estimator::kMis) && scene.emitters.count() > 0;
}

// Shadow rays a Phong vertex may queue: one per point light, one emitter sample.
static int32_t shadow_rays_per_vertex(const Scene& scene) {
    return int32_t(scene.lights.size()) + (samples_emitters(scene) ? 1 : 0);
}

WavefrontRenderer::WavefrontRenderer(const Scene& scene, Isa isa, int32_t pool_size,
                                     bool specialise)
    : isa_(isa == Isa::kAuto ? best_isa() : isa),
      pool_size_(pool_size > 0 ? pool_size : kDefaultPoolSize) {
    require_isa(isa_, "--isa");
    if (pool_size_ % 16 != 0 || pool_size_ < 16 || pool_size_ > (1 << 22))
        throw InputError("--pool: the path pool size must be a multiple of 16 in [16, 4194304]");
    data_ = std::make_unique<Data>(scene, pool_size_);
    Data& d = *data_;
    FlatScene& f = d.flat;
    d.entry = entry_of(isa_);

    // Analytic primitives: padded copies of the scene's SoA arrays, quadrics as 16 floats
    const Spheres& sp = scene.spheres;
    const Planes& pl = scene.planes;
    d.sphere[0] = padded(sp.cx), d.sphere[1] = padded(sp.cy), d.sphere[2] = padded(sp.cz);
    d.sphere[3] = padded(sp.radius), d.sphere_material = padded(sp.material);
    d.plane[0] = padded(pl.nx), d.plane[1] = padded(pl.ny), d.plane[2] = padded(pl.nz);
    d.plane[3] = padded(pl.distance), d.plane_material = padded(pl.material);
    f.sphere_count = int32_t(sp.size());
    f.sphere_cx = d.sphere[0].data(), f.sphere_cy = d.sphere[1].data();
    f.sphere_cz = d.sphere[2].data(), f.sphere_r = d.sphere[3].data();
    f.sphere_material = d.sphere_material.data();
    f.plane_count = int32_t(pl.size());
    f.plane_nx = d.plane[0].data(), f.plane_ny = d.plane[1].data();
    f.plane_nz = d.plane[2].data(), f.plane_d = d.plane[3].data();
    f.plane_material = d.plane_material.data();
    d.plane_lanes = lanes_of({&pl.nx, &pl.ny, &pl.nz, &pl.distance});
    f.plane_lanes = d.plane_lanes.data();
    for (const Quadric& q : scene.quadrics) {
        d.quadric.insert(d.quadric.end(), {q.q.a, q.q.b, q.q.c, q.q.d, q.q.e, q.q.f, q.q.g, q.q.h,
                                           q.q.i, q.q.j, q.box_min.x, q.box_min.y, q.box_min.z,
                                           q.box_max.x, q.box_max.y, q.box_max.z});
        d.quadric_material.push_back(q.material);
    }
    d.quadric = padded(d.quadric), d.quadric_material = padded(d.quadric_material);
    f.quadric_count = int32_t(scene.quadrics.size());
    f.quadric = d.quadric.data();
    d.quadric_lanes = lanes_of(d.quadric);
    f.quadric_lanes = d.quadric_lanes.data();
    f.quadric_material = d.quadric_material.data();
    d.unbounded_quadrics = padded(scene.unbounded_quadrics);
    f.unbounded_quadric_count = int32_t(scene.unbounded_quadrics.size());
    f.unbounded_quadrics = d.unbounded_quadrics.data();
    f.bvh = &scene.bvh.view();
    for (const Mesh& m : scene.meshes) {
        // Vertex colours gather x, y, z of vertex v at 3v + k with 32-bit indices
        const Mesh& g = scene.geometry_of(m);
        if (g.positions.size() > (size_t(1) << 29))
            throw InputError(m.source + ": more than 2^29 vertices");
        static_assert(sizeof(Vec3f) == 3 * sizeof(float));
        d.mesh_material.push_back(m.material);
        FlatMesh flat;
        flat.indices = reinterpret_cast<const int32_t*>(g.indices.data());
        flat.positions = &g.positions.data()->x;
        flat.colors = g.colors.empty() ? nullptr : &g.colors.data()->x;
        flat.to_object = m.instanced() ? m.to_object : nullptr;
        flat.normals = m.smooth ? &g.normals.data()->x : nullptr;
        flat.normal_to_world = m.instanced() ? m.normal_to_world : nullptr;
        d.meshes.push_back(flat);
    }
    f.meshes = d.meshes.data();
    d.mesh_material = padded(d.mesh_material);
    f.mesh_count = int32_t(scene.meshes.size());
    f.mesh_material = d.mesh_material.data();

    // Materials as SoA [channel][component][material], each row padded to 16
    const size_t mc = scene.materials.size();
    const size_t stride = (mc + 15) / 16 * 16;
    uint32_t texture_channels = 0;
    d.color.assign(kColCount * 3 * stride + 16, 0.0f);
    for (size_t m = 0; m < mc; ++m) {
        const Material& mat = scene.materials[m];
        const ColorSource* ch[kColCount] = {&mat.emission, &mat.kd, &mat.ks, &mat.kr, &mat.kt};
        int32_t tex = 0;  // bit c: channel c is textured
        for (int c = 0; c < kColCount; ++c) {
            for (int k = 0; k < 3; ++k)
                d.color[(size_t(c) * 3 + size_t(k)) * stride + m] = ch[c]->a[k];
            d.sources.push_back(flatten(*ch[c]));
            if (ch[c]->kind != TextureKind::kSolid) tex |= 1 << c;
        }
        texture_channels |= uint32_t(tex);
        d.shininess.push_back(mat.shininess);
        d.ior.push_back(mat.ior);
        d.emitter.push_back(mat.is_emitter() ? 1 : 0);
        d.phong.push_back(mat.has_phong() ? 1 : 0);
        d.textured.push_back(tex);
    }
    d.shininess = padded(d.shininess), d.ior = padded(d.ior), d.emitter = padded(d.emitter);
    d.phong = padded(d.phong), d.textured = padded(d.textured);
    f.material_count = int32_t(mc);
    f.material_stride = int32_t(stride);
    f.color = d.color.data(), f.shininess = d.shininess.data(), f.ior = d.ior.data();
    f.emitter = d.emitter.data(), f.phong = d.phong.data(), f.textured = d.textured.data();
    f.sources = d.sources.data();
    for (const PointLight& l : scene.lights)
        d.light.insert(d.light.end(), {l.position.x, l.position.y, l.position.z, l.intensity.x,
                                       l.intensity.y, l.intensity.z});
    f.light_count = int32_t(scene.lights.size());
    f.light = d.light.data();
    // Next-event estimation's emitters: the scene's table, and per sphere and mesh the id
    // of its (first) emitter
    d.sphere_emitter = padded(scene.emitters.sphere_id);
    d.mesh_emitter = padded(scene.emitters.mesh_first);
    f.sphere_emitter = d.sphere_emitter.data();
    f.mesh_emitter = d.mesh_emitter.data();
    f.path = scene.path_context();
    f.light_starts = scene.light_starts.table();
    f.pinhole = scene.pinhole();
    f.lt_camera_paths = scene.emitters.unsampled_objects > 0;

    // Camera, settings, features
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
    f.features = {sf.spheres, sf.planes, sf.quadrics, sf.meshes, tree, packet,
                  sf.point_lights, sf.emitters, sf.diffuse, sf.specular, sf.mirror, sf.refraction,
                  sf.procedural_textures || sf.vertex_colors,
                  int(sf.diffuse) + int(sf.specular) + int(sf.mirror) + int(sf.refraction),
                  texture_channels};
    if (!specialise) {
        // Every stage and lobe on: the general kernel a renderer without a feature set runs
        const bool meshes = f.features.meshes;
        f.features = {true, true, true, meshes, tree, packet, true, true, true,
                      true, true, true, true, 4,    texture_channels};
    }
    // Light tracing: camera paths shoot no shadow rays (the light paths bring every light)
    if (f.path.lt) f.features.lights = false;
}

WavefrontRenderer::~WavefrontRenderer() = default;

size_t WavefrontRenderer::pool_bytes() const {
    return path_pool_bytes(pool_size_, shadow_rays_per_vertex(data_->scene),
                           int32_t(data_->scene.materials.size()));
}

void WavefrontRenderer::render_tile(const Tile& tile, FilmTile& film, RayCounts& rays,
                                    LaneStats& lanes) const {
    // The camera stage splits path numbers into pixel and sample in float lanes (exact below 2^24)
    if (int64_t(tile.x1 - tile.x0) * (tile.y1 - tile.y0) >= (int64_t(1) << 23))
        throw std::logic_error("wavefront tiles must have fewer than 2^23 pixels");
    PathPool& pool = data_->pools.local().pool;
    const TileJob job{tile.x0, tile.y0,    tile.x1,     tile.y1, tile.s0,
                      tile.s1, tile.light, &film, finish_paths, splat_paths};
    WavefrontCounters c;
    // Every camera path of the job is counted now; the kernels hand over only the radiant ones
    if (!tile.light) film.count_paths(uint64_t(tile.s1 - tile.s0));
    data_->entry(data_->flat, pool, job, c);
    rays.camera += c.camera, rays.extension += c.extension, rays.shadow += c.shadow;
    rays.light += c.light;
    lanes.shade_active += c.lanes_active, lanes.shade_total += c.lanes_total;
    lanes.isect_active += c.isect_active, lanes.isect_total += c.isect_total;
    lanes.shadow_active += c.shadow_active, lanes.shadow_total += c.shadow_total;
}

void WavefrontRenderer::trace(const float* rays, size_t count, TraceTotals& totals) const {
    trace_entry_of(isa_)(data_->flat, rays, count, totals);
}

}  // namespace cierzo
