// Wavefront stage 1, regeneration: free slots of the pool take new camera paths of the tile,
// in (sample, pixel) order, each with its random-number key and a jittered pinhole ray.
#pragma once

#include "integrators/wavefront/wave.h"
#include "kernels/camera.h"

namespace cierzo {
inline namespace CIERZO_ISA_NAMESPACE {

// Tile progress: paths handed out so far of tile_pixels × samples.
struct TileCursor {
    TileJob job;
    int64_t next = 0;
    int64_t total = 0;
    int32_t tile_width = 0, tile_pixels = 0;
    int32_t x = 0, y = 0;    // pixel of path `next`, in the tile
    uint32_t sample = 0;     // sample index of path `next`
};

template <class A>
void generate_camera_paths(Wave<A>& w, TileCursor& c) {
    using F = typename Wave<A>::F;
    using U = typename Wave<A>::U;
    PathPool& p = w.pool;
    const FlatScene& s = w.scene;
    const int32_t first = w.live;
    const int32_t count = int32_t(std::min<int64_t>(p.capacity - first, c.total - c.next));
    if (count <= 0) return;

    // Pixel and sample of each new path, walking the tile row by row, sample by sample (the
    // sample index waits in `bounce` until the keys are made)
    for (int32_t i = first; i < first + count; ++i) {
        const int32_t x = c.job.x0 + c.x, y = c.job.y0 + c.y;
        p.pixel[i] = uint32_t(y) * uint32_t(s.width) + uint32_t(x);
        p.bounce[i] = c.sample;
        p.px[i] = float(x);
        p.py[i] = float(y);
        if (++c.x == c.tile_width) {
            c.x = 0;
            if (++c.y * c.tile_width == c.tile_pixels) c.y = 0, ++c.sample;
        }
    }
    c.next += count;
    w.counters.camera += uint64_t(count);

    // Jittered camera rays, K at a time (the batch containing `first` is redone whole)
    const Vec3f origin{s.cam_origin[0], s.cam_origin[1], s.cam_origin[2]};
    const Vec3f forward{s.cam_forward[0], s.cam_forward[1], s.cam_forward[2]};
    const Vec3f left{s.cam_left[0], s.cam_left[1], s.cam_left[2]};
    const Vec3f up{s.cam_up[0], s.cam_up[1], s.cam_up[2]};
    const float inv_w = 1.0f / float(s.width), inv_h = 1.0f / float(s.height);
    const int32_t end = first + count;
    for (int32_t i = first / Wave<A>::K * Wave<A>::K; i < end; i += Wave<A>::K) {
        const auto fresh = Wave<A>::lane_index() >= F(float(first - i));
        const U pixel = U::load_aligned(p.pixel + i);
        const U key = select(mask_u32(fresh), path_key(s.seed, pixel, U::load_aligned(p.bounce + i)),
                             U::load_aligned(p.key + i));
        key.store_aligned(p.key + i);
        select(mask_u32(fresh), U(0u), U::load_aligned(p.bounce + i)).store_aligned(p.bounce + i);
        const F sx = F::load_aligned(p.px + i) + uniform<F>(key, U(0u), Purpose::kPixelX);
        const F sy = F::load_aligned(p.py + i) + uniform<F>(key, U(0u), Purpose::kPixelY);
        const Ray<F> ray = pinhole_ray(origin, forward, left, up, sx, sy, inv_w, inv_h);
        // Lanes before `first` keep their rays
        store3(select(fresh, ray.o, load3<F>(p.ox, p.oy, p.oz, i)), p.ox, p.oy, p.oz, i);
        store3(select(fresh, ray.d, load3<F>(p.dx, p.dy, p.dz, i)), p.dx, p.dy, p.dz, i);
        const Vec3<F> one(F(1.0f)), zero(F(0.0f));
        store3(select(fresh, one, load3<F>(p.beta_r, p.beta_g, p.beta_b, i)), p.beta_r, p.beta_g,
               p.beta_b, i);
        store3(select(fresh, zero, load3<F>(p.rad_r, p.rad_g, p.rad_b, i)), p.rad_r, p.rad_g,
               p.rad_b, i);
    }
    w.live = end;
}

}  // namespace CIERZO_ISA_NAMESPACE
}  // namespace cierzo
