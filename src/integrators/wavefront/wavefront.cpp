// The wavefront integrator's scalar side: the scene's flat view (scene/flat_tables.h) with
// this renderer's feature set, per-thread path pools, the choice of instruction set, and the
// hand-over of finished paths to the film.
#include "integrators/wavefront/wavefront.h"

#include <algorithm>
#include <cstdlib>
#include <memory>
#include <new>
#include <stdexcept>
#include <vector>

#include <fmt/format.h>
#include <oneapi/tbb/enumerable_thread_specific.h>

#include "core/error.h"
#include "integrators/merge_grid.h"
#include "integrators/path_guide.h"
#include "integrators/registry.h"
#include "scene/flat_tables.h"

namespace cierzo {

namespace {

void finish_paths(void* film, int32_t count, const uint32_t* pixel, const float* r, const float* g,
                  const float* b) {
    // Pixel indices are y * width + x in the whole image (one division per radiant path)
    FilmTile& f = *static_cast<FilmTile*>(film);
    for (int32_t i = 0; i < count; ++i) f.at_index(pixel[i]).add_counted({r[i], g[i], b[i]});
}

void splat_paths(void* film, int32_t count, const uint32_t* pixel, const float* r, const float* g,
                 const float* b) {
    FilmTile& f = *static_cast<FilmTile*>(film);
    for (int32_t i = 0; i < count; ++i) f.splat(pixel[i], {r[i], g[i], b[i]});
}

// One thread's light-vertex store (bdpt), grown as a job's light subpaths need.
struct LightStoreMemory {
    struct Free {
        void operator()(float* p) const { std::free(p); }
    };
    std::unique_ptr<float[], Free> records;  // 64-byte aligned (a record: two lines)
    size_t record_floats = 0;
    std::vector<uint32_t> length, path, begin;
    std::vector<int32_t> order;
    MergeGrid grid;
    MergeTable merging;
    LightVertexStore store;
    const Scene& scene;  // (for the message of a unit refused)
    size_t limit;        // bytes (RenderOptions::light_store_limit)
    int32_t most;        // vertices within the limit (with vcm each also takes a photon)

    LightStoreMemory(const Scene& s, size_t limit_bytes) : scene(s), limit(limit_bytes) {
        const size_t each =
            kLightVertexBytes + (merges(s.settings.estimator.kind) ? sizeof(Photon) : 0);
        // (a record's first float's index, kLightVertexStride·v, within an int32 lane)
        most = int32_t(std::min<size_t>(limit / each, INT32_MAX / kLightVertexStride));
        store.owner = this;
        store.grid = &grid;
        store.merging = &merging;
        store.grow = [](LightVertexStore& st, int32_t vertices) {
            LightStoreMemory& m = *static_cast<LightStoreMemory*>(st.owner);
            if (vertices > m.most) refuse_light_store(m.scene, m.limit, size_t(st.count));
            m.resize(std::min(std::max(vertices, 2 * st.capacity), m.most));
        };
        resize(std::min(4096, most));
    }
    void resize(int32_t capacity) {
        const size_t floats = size_t(capacity) * kLightVertexStride;
        float* fresh = static_cast<float*>(std::aligned_alloc(64, floats * sizeof(float)));
        if (!fresh) throw std::bad_alloc();
        if (records) std::copy_n(records.get(), std::min(floats, record_floats), fresh);
        records.reset(fresh);
        record_floats = floats;
        store.records = records.get();
        length.resize(size_t(capacity)), path.resize(size_t(capacity)),
            order.resize(size_t(capacity));
        store.length = length.data(), store.path = path.data(), store.order = order.data();
        store.capacity = capacity;
    }
    // Room for a job of `paths` paths' ranges
    void reserve_paths(size_t paths) {
        if (begin.size() < paths + 1) begin.resize(paths + 1);
        store.begin = begin.data();
    }
    size_t bytes() const {
        return size_t(store.capacity) * kLightVertexBytes + begin.size() * sizeof(uint32_t) +
               grid.bytes();
    }
};

// One thread's table of a guided render's records (path_pool.h, GuideRecordTable), grown as
// a job's paths make them.
struct GuideRecordMemory {
    std::vector<GuideRecord> records;
    GuideRecordTable table;
    GuideRecordMemory() {
        table.owner = this;
        table.grow = [](GuideRecordTable& t, int32_t count) {
            GuideRecordMemory& m = *static_cast<GuideRecordMemory*>(t.owner);
            m.records.resize(std::max<size_t>(size_t(count), 2 * m.records.size()));
            t.records = m.records.data();
            t.capacity = int32_t(std::min<size_t>(m.records.size(), INT32_MAX));
        };
        table.grow(table, 4096);
    }
};

void deposit_record(void* guide, int32_t pass, const GuideRecord& record) {
    static_cast<PathGuide*>(guide)->deposit(pass, record);
}

// One thread's pool: an aligned block carved into SoA arrays.
struct PoolMemory {
    void* memory = nullptr;
    PathPool pool;
    PoolMemory(int32_t capacity, int32_t lights, int32_t materials, bool group) {
        const size_t bytes = path_pool_bytes(capacity, lights, materials, group);
        memory = std::aligned_alloc(64, (bytes + 63) / 64 * 64);
        if (!memory) throw std::bad_alloc();
        pool = carve_path_pool(memory, capacity, lights, materials, group);
    }
    PoolMemory(const PoolMemory&) = delete;
    PoolMemory& operator=(const PoolMemory&) = delete;
    ~PoolMemory() { std::free(memory); }
    std::unique_ptr<LightStoreMemory> light_store;     // bdpt only
    std::unique_ptr<GuideRecordMemory> guide_records;  // guided renders only
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

static bool samples_emitters(const Scene& scene);
static int32_t shadow_rays_per_vertex(const Scene& scene);

struct WavefrontRenderer::Data {
    const Scene& scene;
    FlatView view;  // the scene as the kernels read it (scene/flat_tables.h)
    RenderTileEntry entry = nullptr;
    int32_t pool_size;
    size_t light_store_limit;  // bytes per thread (RenderOptions::light_store_limit)
    mutable oneapi::tbb::enumerable_thread_specific<PoolMemory> pools;

    Data(const Scene& s, int32_t size, size_t limit, int32_t ray_group)
        : scene(s),
          view(flat_view(s)),
          pool_size(size),
          light_store_limit(limit),
          pools(size, shadow_rays_per_vertex(s), int32_t(s.materials.size()), ray_group > 1) {
        view.scene.ray_group = ray_group;
    }
};

// Whether the estimator samples emitters: nee or mis, and emitters it can sample.
static bool samples_emitters(const Scene& scene) {
    const Estimator e = scene.settings.estimator.kind;
    return traits(e).samples_emitters && scene.emitters.count() > 0;
}

// Shadow rays a Phong vertex may queue: one per point light, one emitter sample (bdpt: and
// room for a few connections; its queue is traced whenever it fills).
static int32_t shadow_rays_per_vertex(const Scene& scene) {
    const int32_t connections = bidirectional(scene.settings.estimator.kind) ? 3 : 0;
    return int32_t(scene.lights.size()) + (samples_emitters(scene) ? 1 : 0) + connections;
}

WavefrontRenderer::WavefrontRenderer(const Scene& scene, Isa isa, int32_t pool_size,
                                     bool specialise, size_t light_store_limit, int32_t ray_group)
    : isa_(isa == Isa::kAuto ? best_isa() : isa),
      pool_size_(pool_size > 0 ? pool_size : kDefaultPoolSize) {
    require_isa(isa_, "--isa");
    if (pool_size_ % 16 != 0 || pool_size_ < 16 || pool_size_ > (1 << 22))
        throw InputError("--pool: the path pool size must be a multiple of 16 in [16, 4194304]");
    if (ray_group < 1 || ray_group > kMaxTraversalGroup)
        throw InputError(fmt::format("--ray-group: rays in flight must be 1 to {}, not {}",
                                     int(kMaxTraversalGroup), ray_group));
    data_ = std::make_unique<Data>(scene, pool_size_, light_store_limit, ray_group);
    data_->entry = entry_of(isa_);
    FlatFeatures& f = data_->view.scene.features;
    if (!specialise) {
        // Every stage and lobe on: the general kernel a renderer without a feature set runs
        f = {true, true, true, f.meshes, f.bvh, f.packet,          true, true, true,
             true, true, true, true,     4,     f.texture_channels};
    }
    // Light tracing: camera paths shoot no shadow rays (the light paths bring every light)
    if (data_->view.scene.path.lt) f.lights = false;
}

WavefrontRenderer::~WavefrontRenderer() = default;

int32_t WavefrontRenderer::ray_group() const { return data_->view.scene.ray_group; }

size_t WavefrontRenderer::light_store_bytes() const {
    size_t most = 0;
    for (const PoolMemory& m : data_->pools)
        if (m.light_store) most = std::max(most, m.light_store->bytes());
    return most;
}

size_t WavefrontRenderer::guide_record_bytes() const {
    size_t most = 0;
    for (const PoolMemory& m : data_->pools)
        if (m.guide_records)
            most = std::max(most, m.guide_records->records.capacity() * sizeof(GuideRecord));
    return most;
}

size_t WavefrontRenderer::pool_bytes() const {
    return path_pool_bytes(pool_size_, shadow_rays_per_vertex(data_->scene),
                           int32_t(data_->scene.materials.size()), ray_group() > 1);
}

void WavefrontRenderer::render_tile(const Tile& tile, FilmTile& film, RayCounts& rays,
                                    LaneStats& lanes, PathGuide* guide, int32_t pass) const {
    // The camera stage splits path numbers into pixel and sample in float lanes (exact below 2^24)
    if (int64_t(tile.x1 - tile.x0) * (tile.y1 - tile.y0) >= (int64_t(1) << 23))
        throw std::logic_error("wavefront tiles must have fewer than 2^23 pixels");
    PoolMemory& memory = data_->pools.local();
    PathPool& pool = memory.pool;
    if (data_->view.scene.path.bdpt) {
        if (!memory.light_store)
            memory.light_store =
                std::make_unique<LightStoreMemory>(data_->scene, data_->light_store_limit);
        memory.light_store->reserve_paths(size_t(tile.x1 - tile.x0) * size_t(tile.y1 - tile.y0) *
                                          size_t(tile.s1 - tile.s0));
        pool.light_store = &memory.light_store->store;
    }
    TileJob job{tile.x0, tile.y0,    tile.x1, tile.y1,      tile.s0,
                tile.s1, tile.light, &film,   finish_paths, splat_paths};
    WavefrontGuide guided;
    if (guide && !tile.light) {
        if (!memory.guide_records) memory.guide_records = std::make_unique<GuideRecordMemory>();
        pool.guide_records = &memory.guide_records->table;
        const int32_t n = data_->scene.settings.estimator.guided_vertices;
        guided = {guide->view(), n > 0 ? n : INT32_MAX, pass, guide->learning() ? guide : nullptr,
                  deposit_record};
        job.guide = &guided;
    }
    WavefrontCounters c;
    // Every camera path of the job is counted now; the kernels hand over only the radiant ones
    if (!tile.light) film.count_paths(uint64_t(tile.s1 - tile.s0));
    data_->entry(data_->view.scene, pool, job, c);
    rays.camera += c.camera, rays.extension += c.extension, rays.shadow += c.shadow;
    rays.light += c.light;
    lanes.shade_active += c.lanes_active, lanes.shade_total += c.lanes_total;
    lanes.isect_active += c.isect_active, lanes.isect_total += c.isect_total;
    lanes.shadow_active += c.shadow_active, lanes.shadow_total += c.shadow_total;
}

void WavefrontRenderer::trace(const float* rays, size_t count, const TraceOptions& options,
                              TraceTotals& totals) const {
    trace_entry_of(isa_)(data_->view.scene, rays, count, options, totals);
}

}  // namespace cierzo
