// The wavefront's path states and work queues, structure of arrays, one block of memory per
// thread. Every array holds `capacity` entries (a multiple of the widest SIMD width, 16) and
// is 64-byte aligned; lanes past the live count are inert padding.
#pragma once

#include <cstddef>
#include <cstdint>
#include <type_traits>

#include "integrators/guide_record.h"

namespace cierzo {

class MergeGrid;
struct MergeTable;

inline constexpr int kMaxLanes = 16;

// The fields of a stored light-subpath vertex (bdpt: kernels/bidirectional.h, LightVertex),
// in its record of kLightVertexStride floats.
enum LightVertexField : int32_t {
    kLvPx,
    kLvPy,
    kLvPz,  // position
    kLvNx,
    kLvNy,
    kLvNz,  // geometric normal on the arriving side
    kLvSx,
    kLvSy,
    kLvSz,  // shading normal on that side
    kLvWx,
    kLvWy,
    kLvWz,  // towards the previous vertex
    kLvBr,
    kLvBg,
    kLvBb,  // throughput arriving
    kLvKdR,
    kLvKdG,
    kLvKdB,  // Phong lobes
    kLvKsR,
    kLvKsG,
    kLvKsB,
    kLvShininess,
    kLvPd,
    kLvPs,
    kLvVcm,
    kLvVc,
    kLvVm,  // the subpath's MIS quantities
    kLvMagnitude,
    kLightVertexFloats
};
// A record's floats: the fields and padding to two 64-byte lines, so that a connection's
// reads of a vertex drawn anywhere in the store touch two lines (one array per field made
// them 28, one per field).
inline constexpr int32_t kLightVertexStride = 32;
static_assert(kLightVertexFloats <= kLightVertexStride);

// One thread's store of the light subpaths' vertices of a job (bdpt), a record per vertex
// (the connections and merges read vertices in random order; their lengths and paths, which
// the grouping reads in order, are arrays of their own): vertices are appended as the light
// paths' waves reach them, then each path's are found
// through `begin` and `order` (begin[k]..begin[k+1] indexes `order`, path k's vertices in
// the order they were reached). `grow` (the renderer's) makes room for at least `vertices`
// vertices, keeping those stored; the memory is the thread's and is kept between jobs.
struct LightVertexStore {
    int32_t count = 0, capacity = 0;
    float* records = nullptr;  // kLightVertexStride floats a vertex, 64-byte aligned
    float* record(int32_t v) const { return records + size_t(v) * kLightVertexStride; }
    uint32_t* length = nullptr;  // segments from the light
    uint32_t* path = nullptr;    // the path's index in its job
    int32_t* order = nullptr;
    uint32_t* begin = nullptr;  // the job's paths + 1 entries
    // The job's light subpaths per sample index (its pixels) and its sample indices: path k
    // is of sample k / paths_per_sample (the light vertex cache's sets)
    int32_t paths_per_sample = 1, samples = 1;
    void* owner = nullptr;
    void (*grow)(LightVertexStore& store, int32_t vertices) = nullptr;
    // vcm: the grid over the job's vertices and its samples' merging quantities
    MergeGrid* grid = nullptr;
    MergeTable* merging = nullptr;
};

// Bytes per stored vertex.
inline constexpr size_t kLightVertexBytes = (kLightVertexStride + 3) * 4;

// The fields of a path's state that survive from bounce to bounce (PathPool::for_each_state),
// and sets of them: a bit per field.
enum PathField : int32_t {
    kFieldOx,
    kFieldOy,
    kFieldOz,
    kFieldDx,
    kFieldDy,
    kFieldDz,
    kFieldBetaR,
    kFieldBetaG,
    kFieldBetaB,
    kFieldRadR,
    kFieldRadG,
    kFieldRadB,
    kFieldLobePdf,
    kFieldMisVcm,
    kFieldMisVc,
    kFieldMisVm,
    kFieldKey,
    kFieldPixel,
    kFieldIndex,
    kFieldPathId,
    kFieldBounce,
    kFieldPhong,
    kFieldRecord
};
template <int32_t kField>
using Field = std::integral_constant<int32_t, kField>;
inline constexpr uint32_t field_bit(PathField f) { return 1u << f; }
inline constexpr uint32_t kRayFields = 0x3fu << kFieldOx;
inline constexpr uint32_t kBetaFields = 7u << kFieldBetaR;
inline constexpr uint32_t kRadianceFields = 7u << kFieldRadR;
inline constexpr uint32_t kMisFields = 7u << kFieldMisVcm;
// A guided render's camera paths: their Phong vertices so far, and their last record
inline constexpr uint32_t kGuideFields = field_bit(kFieldPhong) | field_bit(kFieldRecord);

// One thread's records of a guided render's camera paths (guide_record.h), appended as the
// paths make them and handed to the guide as the paths end; emptied at each job's start.
// `grow` (the renderer's) makes room for at least `records`, keeping those stored.
struct GuideRecordTable {
    GuideRecord* records = nullptr;
    int32_t count = 0, capacity = 0;
    void* owner = nullptr;
    void (*grow)(GuideRecordTable& table, int32_t records) = nullptr;
};

struct PathPool {
    int32_t capacity = 0;

    // Path state (survives from bounce to bounce; compacted when paths die)
    float *ox, *oy, *oz, *dx, *dy, *dz;  // current ray
    float *beta_r, *beta_g, *beta_b;     // throughput
    float *rad_r, *rad_g, *rad_b;        // radiance gathered so far
    uint32_t *key, *pixel, *bounce;
    uint32_t* index;  // the sample's index in its sequence (samplers other than independent)
    float* lobe_pdf;  // nee/mis: the density of the last Phong lobe's direction (0: none)
    // bdpt: each subpath's MIS quantities (kernels/bidirectional.h), its index in the job
    // (which pairs a camera path with its light path), and a light path's start until its
    // first hit (the emitter, -1 for a point light, and |cos θ| there)
    float *mis_vcm, *mis_vc, *mis_vm, *start_cos;
    uint32_t* path_id;
    int32_t* start_emitter;
    LightVertexStore* light_store = nullptr;
    // A guided render (kernels/guiding.h): each camera path's Phong vertices so far and its
    // last record in `guide_records` (-1: none)
    uint32_t* phong;
    int32_t* record;
    GuideRecordTable* guide_records = nullptr;

    // The path state above, each array once: f(Field<k>{}, array) for every PathField k (what
    // compaction moves: move_paths, compact_stage.h)
    template <class Fn>
    void for_each_state(Fn&& f) const {
        f(Field<kFieldOx>{}, ox), f(Field<kFieldOy>{}, oy), f(Field<kFieldOz>{}, oz);
        f(Field<kFieldDx>{}, dx), f(Field<kFieldDy>{}, dy), f(Field<kFieldDz>{}, dz);
        f(Field<kFieldBetaR>{}, beta_r), f(Field<kFieldBetaG>{}, beta_g);
        f(Field<kFieldBetaB>{}, beta_b);
        f(Field<kFieldRadR>{}, rad_r), f(Field<kFieldRadG>{}, rad_g), f(Field<kFieldRadB>{}, rad_b);
        f(Field<kFieldLobePdf>{}, lobe_pdf);
        f(Field<kFieldMisVcm>{}, mis_vcm), f(Field<kFieldMisVc>{}, mis_vc);
        f(Field<kFieldMisVm>{}, mis_vm);
        f(Field<kFieldKey>{}, key), f(Field<kFieldPixel>{}, pixel), f(Field<kFieldIndex>{}, index);
        f(Field<kFieldPathId>{}, path_id), f(Field<kFieldBounce>{}, bounce);
        f(Field<kFieldPhong>{}, phong), f(Field<kFieldRecord>{}, record);
    }

    // Per-bounce scratch: the hit, the surface and its material
    float* t;
    int32_t* prim;
    float *mesh_nx, *mesh_ny, *mesh_nz;
    int32_t* mesh_id;
    uint32_t* mesh_tri;
    float *px, *py, *pz, *nx, *ny, *nz;
    float *snx, *sny, *snz;  // scenes with smooth meshes: the shading normal (kernels/shading.h)
    int32_t* material;
    int32_t* emitter;  // nee/mis: the sampled emitter hit, or -1
    // A guided render: the guide each Phong vertex is served by (its quadtree's root, -1 for a
    // vertex the guide does not serve, and its share α), and the record the vertex made (-1)
    int32_t *guide_root, *made;
    float* guide_fraction;
    int32_t* alive;
    float* col[5][3];  // textured emission, kd, ks, kr, kt as the material stage evaluated them

    // Lobe choice and the per-lobe buckets (indices into the pool)
    int32_t* lobe;
    float* probability;
    float* roulette_draw;  // the throughput roulette's number, drawn with the lobe's
    int32_t* bucket[4];    // one per lobe (kLobeCount)
    int32_t bucket_size[4];
    int32_t* order;            // material-sorted indices
    int32_t* material_starts;  // material_count + 1 group starts

    // Shadow queue: origin, direction, distance, contribution, owner
    float *sox, *soy, *soz, *sdx, *sdy, *sdz, *stmax, *sc_r, *sc_g, *sc_b;
    int32_t* sowner;
    int32_t shadow_capacity = 0;
    int32_t shadow_count = 0;

    // Finished paths, flushed to the film after every bounce
    uint32_t* done_pixel;
    float *done_r, *done_g, *done_b;

    // The tree's rays of a stage traced with many in flight (FlatScene::ray_group > 1; null
    // in a pool carved without them): for each,
    // its set-up (16 floats: kernels/bvh/traverse.h, TraversalRay), its path or queue entry, its
    // interval's end, hit (3 words: BvhHit) and whether it hit; for as many rays as the
    // larger of the pool and the shadow queue; per shadow queue entry, whether its ray is
    // blocked. And the group's states and stacks.
    float* group_rays = nullptr;
    int32_t* group_ids = nullptr;
    float* group_t = nullptr;
    uint32_t* group_hits = nullptr;
    uint8_t *group_found = nullptr, *group_blocked = nullptr;
    void* group_scratch = nullptr;  // kTraversalGroupBytes
};

// Bytes of a group of rays in flight through the tree (kernels/bvh/traverse_group.h,
// TraversalGroupScratch: each ray's state and stack), which the per-ISA code checks.
inline constexpr size_t kTraversalGroupBytes = 360 * 1024;

// Bytes of memory a pool of `capacity` paths uses with `lights` shadow rays per path and
// bounce (point lights, plus one for an emitter sample).
// `group`: with the arrays of many rays in flight (about 360 kB more).
size_t path_pool_bytes(int32_t capacity, int32_t lights, int32_t materials, bool group = false);
// Carves a pool out of `memory` (64-byte aligned, path_pool_bytes long).
PathPool carve_path_pool(void* memory, int32_t capacity, int32_t lights, int32_t materials,
                         bool group = false);

}  // namespace cierzo
