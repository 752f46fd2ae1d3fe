// Wavefront stage 1, regeneration: free slots of the pool take new camera paths of the tile,
// in (sample, pixel) order, each with its random-number key and a jittered pinhole ray; the
// pixel and sample of each new path are worked out in the lanes.
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
    int32_t x = 0, y = 0;  // pixel of path `next`, in the tile
    uint32_t sample = 0;   // sample index of path `next`
};

// A cursor at the start of a job: its first sample of its first pixel.
inline TileCursor tile_cursor(const TileJob& job) {
    TileCursor c;
    c.job = job;
    c.tile_width = job.x1 - job.x0;
    c.tile_pixels = c.tile_width * (job.y1 - job.y0);
    c.total = int64_t(c.tile_pixels) * (job.sample_end - job.sample_begin);
    c.sample = uint32_t(job.sample_begin);
    return c;
}

// floor(a / b) and the remainder, for whole numbers 0 <= a < 2^24 and 0 < b < 2^24 held in
// floats: the rounded quotient is off by at most one, and the remainder's sign corrects it.
template <class F>
F floor_divide(const F& a, const F& b, F& remainder) {
    F q = floor(a / b);
    F r = a - q * b;
    q = select(r < F(0.0f), q - F(1.0f), q);
    r = select(r < F(0.0f), r + b, r);
    q = select(r >= b, q + F(1.0f), q);
    remainder = select(r >= b, r - b, r);
    return q;
}

// kRadiance: the pool carries each path's radiance (zeroed here); without it, shading hands
// the emission that ends a path straight to the film.
template <bool kRadiance, class A>
CIERZO_STAGE_LOOP void generate_camera_paths(Wave<A>& w, TileCursor& c) {
    using F = typename Wave<A>::F;
    using U = typename Wave<A>::U;
    constexpr int32_t K = Wave<A>::K;
    PathPool& p = w.pool;
    const FlatScene& s = w.scene;
    const int32_t first = w.live;
    const int32_t count = int32_t(std::min<int64_t>(p.capacity - first, c.total - c.next));
    if (count <= 0) return;

    // New path k (0 <= k < count) is pixel `start + k` of the tile's row-by-row scan, wrapping
    // to the next sample after the last pixel. The lanes work that out in float arithmetic,
    // exact because every number stays below 2^24 (tiles have fewer than 2^23 pixels and
    // pools at most 2^22 paths: WavefrontRenderer checks both).
    const int32_t start = c.y * c.tile_width + c.x;
    const uint32_t sample0 = c.sample;
    const int64_t scanned = int64_t(start) + count;
    c.sample += uint32_t(scanned / c.tile_pixels);
    const int32_t rest = int32_t(scanned % c.tile_pixels);
    c.y = rest / c.tile_width, c.x = rest % c.tile_width;
    c.next += count;
    w.counters.camera += uint64_t(count);

    // Jittered camera rays, K at a time (the batch containing `first` is redone whole)
    const Vec3f origin{s.cam_origin[0], s.cam_origin[1], s.cam_origin[2]};
    const Vec3f forward{s.cam_forward[0], s.cam_forward[1], s.cam_forward[2]};
    const Vec3f left{s.cam_left[0], s.cam_left[1], s.cam_left[2]};
    const Vec3f up{s.cam_up[0], s.cam_up[1], s.cam_up[2]};
    const float inv_w = 1.0f / float(s.width), inv_h = 1.0f / float(s.height);
    const F tile_width(float(c.tile_width)), tile_pixels(float(c.tile_pixels));
    const int32_t end = first + count;
    // Batch i's new paths; kPartial: the batch holding `first` when paths before it in the
    // same batch are still in flight, whose lanes keep what they have (every other batch is
    // new in every lane, and is stored without reading the pool)
    auto generate = [&](int32_t i, auto partial) {
        constexpr bool kPartial = decltype(partial)::value;
        const auto fresh = Wave<A>::lane_index() >= F(float(first - i));
        const auto fresh_u = mask_u32(fresh);
        const auto keep_f = [&](const F& v, const float* a) {
            return kPartial ? select(fresh, v, F::load_aligned(a + i)) : v;
        };
        const auto keep_u = [&](const U& v, const uint32_t* a) {
            return kPartial ? select(fresh_u, v, U::load_aligned(a + i)) : v;
        };
        const auto keep3 = [&](const Vec3<F>& v, float* x, float* y, float* z) {
            keep_f(v.x, x).store_aligned(x + i), keep_f(v.y, y).store_aligned(y + i);
            keep_f(v.z, z).store_aligned(z + i);
        };
        // Pixel (x, y) and sample of each new path (lanes before `first` compute nonsense
        // that the selects discard)
        const F scan = Wave<A>::lane_index() + F(float(start + i - first));
        F at, x;
        const F wraps = floor_divide(max(scan, F(0.0f)), tile_pixels, at);
        const F y = floor_divide(at, tile_width, x);
        const F px = x + F(float(c.job.x0)), py = y + F(float(c.job.y0));  // pixel corner
        const auto to_u = [](const F& v) { return xsimd::bitwise_cast<U>(to_int(v)); };
        const U pixel = to_u(py) * U(uint32_t(s.width)) + to_u(px);
        const U sample = U(sample0) + to_u(wraps);
        keep_u(pixel, p.pixel).store_aligned(p.pixel + i);
        const SampleStream<F> rng =
            camera_stream<F>(s.path.sampler, s.seed, pixel, to_u(px), to_u(py), sample);
        keep_u(rng.key, p.key).store_aligned(p.key + i);
        if (s.path.sampler.kind != Sampler::kIndependent)
            keep_u(rng.index, p.index).store_aligned(p.index + i);
        keep_u(U(0u), p.bounce).store_aligned(p.bounce + i);
        F jx, jy;
        uniform2<F>(rng, U(0u), Purpose::kPixelX, jx, jy);
        const F sx = px + jx;
        const F sy = py + jy;
        const Ray<F> ray = pinhole_ray(origin, forward, left, up, sx, sy, inv_w, inv_h);
        keep3(ray.o, p.ox, p.oy, p.oz);
        keep3(ray.d, p.dx, p.dy, p.dz);
        keep3(Vec3<F>(F(1.0f)), p.beta_r, p.beta_g, p.beta_b);
        if constexpr (kRadiance) keep3(Vec3<F>(F(0.0f)), p.rad_r, p.rad_g, p.rad_b);
        if (s.path.nee) keep_f(F(0.0f), p.lobe_pdf).store_aligned(p.lobe_pdf + i);
        if (w.guide) {  // (a guided render: no Phong vertex met, no record made)
            keep_u(U(0u), p.phong).store_aligned(p.phong + i);
            const U none = keep_u(U(~0u), reinterpret_cast<const uint32_t*>(p.record));
            none.store_aligned(reinterpret_cast<uint32_t*>(p.record) + i);
        }
    };
    int32_t i = first / K * K;
    if (i < first) {
        generate(i, std::true_type{});
        i += K;
    }
    for (; i < end; i += K) generate(i, std::false_type{});
    w.live = end;
}

}  // namespace CIERZO_ISA_NAMESPACE
}  // namespace cierzo
