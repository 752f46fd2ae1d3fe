// Carving one thread's block of memory into the SoA arrays of its path pool.
#include "integrators/wavefront/path_pool.h"

#include <algorithm>

namespace cierzo {

namespace {

// Hands out 64-byte aligned arrays from a block (or only counts the bytes when it is null).
class Carver {
public:
    explicit Carver(char* base) : base_(base) {}
    template <class T>
    T* take(size_t count) {
        const size_t bytes = (count * sizeof(T) + 63) / 64 * 64;
        T* p = base_ ? reinterpret_cast<T*>(base_ + used_) : nullptr;
        used_ += bytes;
        return p;
    }
    size_t used() const { return used_; }

private:
    char* base_;
    size_t used_ = 0;
};

PathPool carve(char* base, int32_t capacity, int32_t lights, int32_t materials, bool group,
               size_t* bytes) {
    Carver c(base);
    PathPool p;
    p.capacity = capacity;
    const size_t n = size_t(capacity);
    for (float** a : {&p.ox,       &p.oy,          &p.oz,
                      &p.dx,       &p.dy,          &p.dz,
                      &p.beta_r,   &p.beta_g,      &p.beta_b,
                      &p.rad_r,    &p.rad_g,       &p.rad_b,
                      &p.t,        &p.mesh_nx,     &p.mesh_ny,
                      &p.mesh_nz,  &p.px,          &p.py,
                      &p.pz,       &p.nx,          &p.ny,
                      &p.nz,       &p.snx,         &p.sny,
                      &p.snz,      &p.probability, &p.roulette_draw,
                      &p.lobe_pdf, &p.mis_vcm,     &p.mis_vc,
                      &p.mis_vm,   &p.start_cos,   &p.done_r,
                      &p.done_g,   &p.done_b,      &p.guide_fraction})
        *a = c.take<float>(n);
    for (auto& channel : p.col)
        for (float*& a : channel) a = c.take<float>(n);
    for (uint32_t** a :
         {&p.key, &p.pixel, &p.bounce, &p.index, &p.mesh_tri, &p.done_pixel, &p.path_id, &p.phong})
        *a = c.take<uint32_t>(n);
    for (int32_t** a : {&p.prim, &p.mesh_id, &p.material, &p.emitter, &p.alive, &p.lobe, &p.order,
                        &p.start_emitter, &p.record, &p.guide_root, &p.made})
        *a = c.take<int32_t>(n);
    for (int32_t*& a : p.bucket) a = c.take<int32_t>(n);
    p.material_starts = c.take<int32_t>(size_t(materials) + 1);
    // Shadow queue: one ray per path and light (or emitter sample) at most
    p.shadow_capacity = capacity * std::max(lights, 1);
    const size_t s = size_t(p.shadow_capacity) + 16;
    for (float** a :
         {&p.sox, &p.soy, &p.soz, &p.sdx, &p.sdy, &p.sdz, &p.stmax, &p.sc_r, &p.sc_g, &p.sc_b})
        *a = c.take<float>(s);
    p.sowner = c.take<int32_t>(s);
    if (group) {
        const size_t g = std::max(n, s);
        p.group_rays = c.take<float>(16 * g);
        p.group_ids = c.take<int32_t>(g);
        p.group_t = c.take<float>(g);
        p.group_hits = c.take<uint32_t>(3 * g);
        p.group_found = c.take<uint8_t>(g);
        p.group_blocked = c.take<uint8_t>(g);
        p.group_scratch = c.take<char>(kTraversalGroupBytes);
    }
    if (bytes) *bytes = c.used();
    return p;
}

}  // namespace

size_t path_pool_bytes(int32_t capacity, int32_t lights, int32_t materials, bool group) {
    size_t bytes = 0;
    carve(nullptr, capacity, lights, materials, group, &bytes);
    return bytes;
}

PathPool carve_path_pool(void* memory, int32_t capacity, int32_t lights, int32_t materials,
                         bool group) {
    return carve(static_cast<char*>(memory), capacity, lights, materials, group, nullptr);
}

}  // namespace cierzo
