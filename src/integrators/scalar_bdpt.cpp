// The scalar reference of the bidirectional estimators (kernels/bidirectional.h): for each
// camera sample, its light subpath first (its Phong vertices stored, each connected to the
// pinhole), then its camera subpath, which at each Phong vertex samples the lights,
// connects to every stored vertex of its light subpath and (vcm) merges with the stored
// vertices near it of every light subpath of its sample index in the tile. One path at a
// time, with the same kernels as the wavefront's bidirectional stages. With strategy images
// (integrators/strategies.h), each contribution is also recorded under its strategy (s, t),
// with its weight and without: the second value comes from the same kernels with every
// weight 1 (strategy_weight), along the same shadow ray, traced once.
#include "integrators/scalar.h"

#include <vector>

#include "integrators/merge_vertex.h"
#include "integrators/scalar_path.h"
#include "integrators/strategies.h"
#include "kernels/bidirectional.h"
#include "kernels/rng.h"

namespace cierzo {

namespace {

// The light vertices a unit may keep at once (RenderOptions::light_store_limit), and in
// bytes.
struct StoreLimit {
    size_t vertices, bytes;
};

// Where a unit records its strategy images, if it does: its tile, the context whose weights
// are all 1, and the pixel of the camera sample being traced.
struct Recorder {
    StrategyTile* tile = nullptr;
    PathContext unweighted;
    int x = 0, y = 0;

    // Strategy (s, t)'s number, or -1 when it is not recorded (or nothing is).
    int strategy(uint32_t s, uint32_t t) const { return tile ? tile->layout().index(s, t) : -1; }
};

// trace_request for the request `make(context)` makes, of strategy number `strategy`: when
// that strategy is recorded, the shadow ray of the weighted request and of its unweighted
// twin (make(rec.unweighted): the same ray, every weight 1), traced once if either wants it,
// both values, times the camera subpath's throughput, going to the strategy's image. Returns
// what the weighted one adds (what trace_request would return).
template <class Make>
Vec3f trace_strategy(const Scene& scene, const PathContext& c, int strategy, const Make& make,
                     const Vec3f& throughput, Recorder& rec, RayCounts& rays) {
    const ShadowRequest<float> weighted = make(c);
    if (strategy < 0) return trace_request(scene, weighted, rays);
    const ShadowRequest<float> unweighted = make(rec.unweighted);
    if (!weighted.want && !unweighted.want) return Vec3f(0.0f);
    const ShadowRequest<float>& r = weighted.want ? weighted : unweighted;
    ++rays.shadow;
    if (scene.occluded({r.origin, r.dir}, r.tmax)) return Vec3f(0.0f);
    const Vec3f value = weighted.want ? weighted.value : Vec3f(0.0f);
    rec.tile->add(rec.x, rec.y, strategy, throughput * value,
                  unweighted.want ? throughput * unweighted.value : Vec3f(0.0f));
    return value;
}

// The bidirectional estimators' use of the light-subpath walk (walk_light_subpath): every
// Phong vertex appended to `store`, and its connection to the pinhole weighed and splatted
// (t = 1) on `film` (none without one).
struct LightSubpath {
    static constexpr bool kMis = true;
    const Scene& scene;
    const PathContext& c;
    const PinholeFrame& pinhole;
    const MergeWeights<float>& mw;
    std::vector<LightVertex<float>>& store;
    const StoreLimit& limit;
    FilmTile* film;
    const Recorder& rec;
    RayCounts& rays;

    void start(const LightStart<float>&) {}
    void vertex(const LightVertex<float>& lv, const Bsdf<float>& m) {
        if (store.size() >= limit.vertices) refuse_light_store(scene, limit.bytes, store.size());
        store.push_back(lv);
        // t = 1: the vertex seen from the pinhole
        if (!film || !connects(c.estimator.kind) ||
            !length_counts<float>(c.estimator, lv.length + 1))
            return;
        const CameraConnection<float> cc = connect_camera(pinhole, lv.p);
        if (!cc.ok || !on_arriving_side(cc.wc, lv.nf)) return;
        const Vec3f unweighted =
            camera_contribution(m, lv.beta, -lv.wl, lv.nf, lv.nsf, cc, c.smooth);
        const Vec3f value = unweighted * camera_connection_mis(c, lv, cc, mw);
        const int strategy = rec.strategy(lv.length + 1, 1);
        if (!(max_component(value) > 0.0f) && !(strategy >= 0 && max_component(unweighted) > 0.0f))
            return;
        ++rays.shadow;
        if (scene.occluded({offset_ray_origin(lv.p, lv.nf, lv.magnitude), cc.wc},
                           cc.dist * (1.0f - 1e-5f)))
            return;
        if (max_component(value) > 0.0f) film->splat(uint32_t(cc.pixel), value);
        if (strategy >= 0) rec.tile->splat(uint32_t(cc.pixel), strategy, value, unweighted);
    }
};

// One light subpath, with the numbers of the camera sample whose stream it takes: its Phong
// vertices appended to `store`, each one's connection to the pinhole splatted (t = 1) on
// `film` (none without one).
CIERZO_PATH_LOOP void trace_light_subpath(
    const Scene& scene, const PathContext& c, const LightStartTable& lights,
    const PinholeFrame& pinhole, const SampleStream<float>& camera_rng,
    const MergeWeights<float>& mw, std::vector<LightVertex<float>>& store, const StoreLimit& limit,
    FilmTile* film, const Recorder& rec, RayCounts& rays) {
    LightSubpath at{scene, c, pinhole, mw, store, limit, film, rec, rays};
    walk_light_subpath(scene, c, lights, camera_rng, mw, at, rays);
}

// The light vertices of a camera sample's sample index in the tile: vcm's grid of them (a
// camera vertex merges with every one near it) and the sample's merging quantities; the
// light vertex cache (light_connections ≥ 1): all of them and the light subpaths that stored
// them.
struct Merging {
    const MergeGrid* grid = nullptr;
    MergeWeights<float> weights;
    const LightVertex<float>* cache = nullptr;
    int32_t cache_vertices = 0, cache_paths = 0;
};

// The camera subpath of one sample, with every strategy that ends on it: what it brings to
// its pixel (the light subpath's vertices are `light`).
CIERZO_PATH_LOOP Vec3f trace_camera_subpath(const Scene& scene, const PathContext& c,
                                            const LightStartTable& lights,
                                            const PinholeFrame& pinhole,
                                            const Ray<float>& camera_ray,
                                            const SampleStream<float>& rng, const Merging& merging,
                                            const LightVertex<float>* light, size_t light_count,
                                            Recorder& rec, RayCounts& rays) {
    const MergeWeights<float>& mw = merging.weights;
    Vec3f radiance(0.0f);
    Vec3f throughput(1.0f);
    Ray<float> ray = camera_ray;
    SubpathMis<float> mis = camera_start_mis(c, pinhole, ray.d);
    const float cap = c.estimator.survival_cap;
    for (uint32_t bounce = 0;; ++bounce) {
        Hit hit;
        if (!scene.intersect(ray, kRayFar, hit)) {
            if (has_environment(c) && length_counts<float>(c.estimator, bounce + 1)) {
                const Vec3f unweighted =
                    throughput * environment_radiance(c.emitters.environment, ray.d);
                const Vec3f value = unweighted * environment_mis<float>(c, mis, ray.d, bounce + 2);
                radiance += value;
                if (const int i = rec.strategy(0, bounce + 2); i >= 0)
                    rec.tile->add(rec.x, rec.y, i, value, unweighted);
            }
            break;
        }
        const Material& material = scene.materials[size_t(hit.material)];
        const float cos_in = std::abs(dot(ray.d, hit.n));
        mis_at_hit(mis, hit.t, cos_in);

        // s = 0: an emitter ends the path
        if (material.is_emitter()) {
            if (length_counts<float>(c.estimator, bounce + 1)) {
                const Vec3f unweighted = throughput * scene.emission_at(hit);
                const Vec3f value =
                    unweighted * emitter_hit_mis<float>(c, lights, mis, scene.emitter_id(hit),
                                                        ray.o, ray.d, hit.t, cos_in, bounce + 2);
                radiance += value;
                if (const int i = rec.strategy(0, bounce + 2); i >= 0)
                    rec.tile->add(rec.x, rec.y, i, value, unweighted);
            }
            break;
        }
        const Bsdf<float> m = scene.bsdf_at(hit);
        const float magnitude = max(max_abs(hit.p), max_abs(ray.o));
        const VertexFrame<float> v = vertex_frame(c.smooth, ray.d, hit.n, hit.ns);
        const PhongVertex<float> pv = phong_vertex(m, cap);

        if (material.has_phong()) {
            const CameraVertex<float> cv{
                hit.p, v.nf, v.nsf,     -ray.d, shadow_origin(v, hit.p, magnitude),
                pv,    mis,  bounce + 2};
            // s = 1: the lights sampled from here
            const bool connecting = connects(c.estimator.kind);
            if (connecting && length_counts<float>(c.estimator, bounce + 2)) {
                Vec3f direct(0.0f);
                const int i = rec.strategy(1, bounce + 2);
                if (c.emitters.count > 0)
                    direct += trace_strategy(
                        scene, c, i,
                        [&](const PathContext& x) {
                            return nee_emitter(x, lights, cv, mw, rng, bounce, true);
                        },
                        throughput, rec, rays);
                for (int32_t j = 0; j < lights.point_count; ++j)
                    direct += trace_strategy(
                        scene, c, i,
                        [&](const PathContext& x) {
                            return nee_point_light(x, lights, j, cv, mw, true);
                        },
                        throughput, rec, rays);
                radiance += throughput * direct;
            }
            // s, t ≥ 2: every stored vertex of this sample's light subpath, or draws from the
            // light vertex cache
            Vec3f connected(0.0f);
            const int32_t draws = c.estimator.light_connections;
            if (connecting && draws > 0 && merging.cache_vertices > 0) {
                const float weight =
                    cache_draw_weight<float>(merging.cache_vertices, merging.cache_paths, draws);
                for (int32_t j = 0; j < draws; ++j) {
                    const LightVertex<float>& l = merging.cache[cache_vertex<float>(
                        connection_uniform<float>(rng, bounce, uint32_t(j)),
                        merging.cache_vertices)];
                    if (!length_counts<float>(c.estimator, l.length + bounce + 2)) continue;
                    connected += trace_strategy(
                        scene, c, rec.strategy(l.length + 1, bounce + 2),
                        [&](const PathContext& x) {
                            return connect_drawn_vertex(x, cv, l, mw, weight, true);
                        },
                        throughput, rec, rays);
                }
            }
            for (size_t k = 0; connecting && draws == 0 && k < light_count; ++k) {
                if (!length_counts<float>(c.estimator, light[k].length + bounce + 2)) continue;
                connected += trace_strategy(
                    scene, c, rec.strategy(light[k].length + 1, bounce + 2),
                    [&](const PathContext& x) {
                        return connect_vertices(x, cv, light[k], mw, true);
                    },
                    throughput, rec, rays);
            }
            radiance += throughput * connected;
            // vcm, bpm, ppm: the light vertices near it
            if (merging.grid && camera_vertex_merges<float>(c.estimator, cv))
                radiance += throughput * merge_at(c, *merging.grid, cv, 0u, mw);
        }

        // The roulette and the chosen lobe
        float p = 0.0f;
        const int32_t lobe = choose_lobe(m, uniform<float>(rng, bounce, Purpose::kLobe), cap, p);
        if (lobe == kLobeAbsorbed || camera_lobe_ends_path<float>(c, lobe) ||
            !may_extend<float>(c.estimator, bounce))
            break;
        const ScalarContinuation next =
            continue_path(lobe, c, m, ray.d, v, hit.p, hit.n, hit.ns, magnitude, p, rng, bounce);
        throughput *= next.weight;
        if (!(max_component(throughput) > 0.0f)) break;
        mis_after_lobe<float>(c, mis, lobe, pv, v, ray.d, next.d, mw);
        ray = {next.o, next.d};
        ++rays.extension;
    }
    return radiance;
}

}  // namespace

double light_subpath_vertices(const Scene& scene, const PathContext& context, int32_t paths) {
    PathContext c = context;
    c.sampler = SamplerSetup{};  // (independent numbers, whatever the render's sampler)
    const LightStartTable lights = scene.light_starts.table();
    if (!(lights.emitter_probability > 0.0f || lights.point_count > 0) || paths <= 0) return 0.0;
    const PinholeFrame pinhole = scene.pinhole();
    const StoreLimit limit{kLightStoreLimit / sizeof(LightVertex<float>), kLightStoreLimit};
    const Recorder rec;
    RayCounts rays;
    std::vector<LightVertex<float>> store;
    size_t vertices = 0;
    for (int32_t k = 0; k < paths; ++k) {
        const uint32_t x = uint32_t(k) % 64u, y = uint32_t(k) / 64u;
        store.clear();
        trace_light_subpath(scene, c, lights, pinhole,
                            camera_stream<float>(c.sampler, kLightPilotSeed, uint32_t(k), x, y, 0u),
                            MergeWeights<float>{}, store, limit, nullptr, rec, rays);
        vertices += store.size();
    }
    return double(vertices) / double(paths);
}

void render_tile_bdpt_scalar(const Scene& scene, const Tile& tile, FilmTile& film, RayCounts& rays,
                             size_t light_store_limit) {
    // (with vcm each vertex also takes a photon)
    const size_t vertex_bytes =
        sizeof(LightVertex<float>) + (merges(scene.settings.estimator.kind) ? sizeof(Photon) : 0);
    const StoreLimit store_limit{light_store_limit / vertex_bytes, light_store_limit};
    const RenderSettings& rs = scene.settings;
    const float inv_w = 1.0f / float(rs.width), inv_h = 1.0f / float(rs.height);
    const PathContext c = scene.path_context();
    const LightStartTable lights = scene.light_starts.table();
    const PinholeFrame pinhole = scene.pinhole();
    const bool has_lights = lights.emitter_probability > 0.0f || lights.point_count > 0;
    const auto stream = [&](int x, int y, int64_t s) {
        const uint32_t pixel = uint32_t(y) * uint32_t(rs.width) + uint32_t(x);
        return camera_stream<float>(c.sampler, rs.seed, pixel, uint32_t(x), uint32_t(y),
                                    uint32_t(s));
    };
    // The strategy images' recording, if the unit has them
    Recorder rec;
    rec.tile = film.strategies.get();
    rec.unweighted = c;
    rec.unweighted.estimator.unweighted = true;
    // Sample s of pixel (x, y)'s camera subpath, with its light subpath's vertices
    const auto camera = [&](int x, int y, const SampleStream<float>& rng, const Merging& merging,
                            const LightVertex<float>* light, size_t light_count) {
        float jx, jy;
        uniform2<float>(rng, 0u, Purpose::kPixelX, jx, jy);
        ++rays.camera;
        rec.x = x, rec.y = y;
        film.at(x, y).add(
            trace_camera_subpath(scene, c, lights, pinhole,
                                 scene.camera.generate(float(x) + jx, float(y) + jy, inv_w, inv_h),
                                 rng, merging, light, light_count, rec, rays));
    };
    std::vector<LightVertex<float>> store;
    const bool cached = c.estimator.light_connections > 0 && connects(c.estimator.kind);
    if (!merges(c.estimator.kind) && !cached) {
        // bdpt: each sample's light subpath, then its camera subpath
        const Merging none;
        for (int y = tile.y0; y < tile.y1; ++y)
            for (int x = tile.x0; x < tile.x1; ++x)
                for (int64_t s = tile.s0; s < tile.s1; ++s) {
                    const SampleStream<float> rng = stream(x, y, s);
                    store.clear();
                    if (has_lights)
                        trace_light_subpath(scene, c, lights, pinhole, rng, none.weights, store,
                                            store_limit, &film, rec, rays);
                    camera(x, y, rng, none, store.data(), store.size());
                }
        return;
    }
    // vcm and the light vertex cache: per sample index, the light subpaths of every pixel
    // (vcm: their grid), then the camera subpaths
    const int32_t width = tile.x1 - tile.x0, pixels = width * (tile.y1 - tile.y0);
    std::vector<uint32_t> begin(size_t(pixels) + 1);
    std::vector<Photon> photons;
    MergeGrid grid;
    for (int64_t s = tile.s0; s < tile.s1; ++s) {
        Merging merging;
        if (merges(c.estimator.kind))
            merging.weights = merge_weights(c.estimator.merge_radius, c.estimator.merge_alpha, s,
                                            has_lights ? pixels : 0, kMergeTilePaths,
                                            connects(c.estimator.kind), c.connection_count);
        store.clear();
        for (int32_t k = 0; k < pixels; ++k) {
            begin[size_t(k)] = uint32_t(store.size());
            if (has_lights)
                trace_light_subpath(scene, c, lights, pinhole,
                                    stream(tile.x0 + k % width, tile.y0 + k / width, s),
                                    merging.weights, store, store_limit, &film, rec, rays);
        }
        begin[size_t(pixels)] = uint32_t(store.size());
        if (cached) {
            merging.cache = store.data();
            merging.cache_vertices = int32_t(store.size());
            merging.cache_paths = pixels;
        }
        if (merges(c.estimator.kind)) {
            photons.clear();
            for (const LightVertex<float>& l : store) photons.push_back(photon_of(l, 0u));
            const float radius = std::sqrt(merging.weights.radius2);
            grid.build(photons.data(), photons.size(), &radius, 1);
            merging.grid = &grid;
        }
        for (int32_t k = 0; k < pixels; ++k) {
            const int x = tile.x0 + k % width, y = tile.y0 + k / width;
            camera(x, y, stream(x, y, s), merging, store.data() + begin[size_t(k)],
                   begin[size_t(k) + 1] - begin[size_t(k)]);
        }
    }
}

}  // namespace cierzo
