// The scalar reference path tracer (see scalar.h): the report's estimator, one path at a
// time, using the same templated kernels as the wavefront integrator with T = float.
#include "integrators/scalar.h"

#include "integrators/path_guide.h"
#include "integrators/scalar_path.h"
#include "kernels/rng.h"

namespace cierzo {

Vec3f trace_path(const Scene& scene, const Ray<float>& camera_ray, uint32_t key, RayCounts& rays) {
    const PathContext c = scene.path_context();
    return trace_path(scene, c, camera_ray, independent_stream<float>(key), rays);
}

namespace {

// What a guided render's camera path records at each Phong vertex for the path guide
// (guide_record.h), the light it gathers after the vertex added as it comes.
constexpr int kMaxGuideRecords = 64;

void add(float* sum, const Vec3f& x) { sum[0] += x.x, sum[1] += x.y, sum[2] += x.z; }

}  // namespace

CIERZO_PATH_LOOP Vec3f trace_path(const Scene& scene, const PathContext& c,
                                  const Ray<float>& camera_ray, const SampleStream<float>& rng,
                                  RayCounts& rays, PathGuide* learn, int32_t pass) {
    Vec3f radiance(0.0f);
    Vec3f throughput(1.0f);
    Ray<float> ray = camera_ray;
    float lobe_pdf = 0.0f;  // the density of the last Phong lobe's direction; 0 after the
                            // camera, a mirror or a refraction
    // A guided render's records (learn: the guide that learns them). Its guide learns from
    // the whole light, whatever lengths the film counts (render.min_length, max_length): its
    // paths go on past max_length, and light of the lengths left out still reaches the
    // records (light that no record is yet there to gather is not traced), so the bands of a
    // guided render are the same paths with the same guide and add up to its whole image, as
    // an unguided render's do
    GuideRecord records[kMaxGuideRecords];  // (uninitialised: written before read)
    int recorded = 0;
    // The Phong vertices met so far, and how many the guide serves (guided_vertices)
    int32_t phong_vertices = 0;
    const int32_t served =
        c.estimator.guided_vertices > 0 ? c.estimator.guided_vertices : INT32_MAX;
    const auto counts = [&](uint32_t length) { return length_counts<float>(c.estimator, length); };
    const auto gain = [&](const Vec3f& x, bool counted) {
        if (counted) radiance += x;
        for (int i = 0; i < recorded; ++i) add(records[i].gathered, x);
    };
    for (uint32_t bounce = 0;; ++bounce) {
        Hit hit;
        if (!scene.intersect(ray, kRayFar, hit)) {
            // An escaping path gathers the environment
            if (has_environment(c) && (recorded > 0 || counts(bounce + 1)))
                gain(throughput * escaped_radiance<float>(c, ray.d, lobe_pdf), counts(bounce + 1));
            break;
        }
        const Material& material = scene.materials[size_t(hit.material)];

        // An emitter ends the path
        if (material.is_emitter()) {
            Vec3f le = scene.emission_at(hit);
            if (weighs_emitter_hits(c))
                le *= emitter_hit_weight<float>(c.emitters, c.estimator.kind, scene.emitter_id(hit),
                                                lobe_pdf, ray.o, ray.d, hit.t,
                                                c.estimator.triangle_solid_angle);
            if (recorded > 0 || counts(bounce + 1)) gain(throughput * le, counts(bounce + 1));
            break;
        }
        const Bsdf<float> m = scene.bsdf_at(hit);
        const float magnitude = max(max_abs(hit.p), max_abs(ray.o));
        const VertexFrame<float> v = vertex_frame(c.smooth, ray.d, hit.n, hit.ns);
        // The guide of this point's cell, where the render is guided and the guide serves
        // this vertex; a guided render records what comes back there
        const bool phong = material.has_phong();
        const bool guide_serves = phong && phong_vertices < served;
        phong_vertices += phong ? 1 : 0;
        const GuideAt<float> guide =
            c.guide && guide_serves ? guide_at(c.guide, hit.p) : GuideAt<float>{};
        const bool records_here = learn && guide_serves;

        // Direct light at every Phong vertex: the point lights, and an emitter sample
        if (phong && (c.light_count > 0 || c.nee) && (recorded > 0 || counts(bounce + 2))) {
            const bool counted = counts(bounce + 2);
            const Vec3f origin = shadow_origin(v, hit.p, magnitude);
            Vec3f lights(0.0f);
            for (int32_t j = 0; j < c.light_count; ++j)
                lights += trace_request(
                    scene, point_light_request(c, j, m, ray.d, v, origin, Vec3f(1.0f), true), rays);
            if (c.light_count > 0) gain(throughput * lights, counted);
            if (c.nee)
                gain(throughput * trace_request(scene,
                                                emitter_request(c, m, ray.d, v, origin, Vec3f(1.0f),
                                                                true, rng, bounce, &guide),
                                                rays),
                     counted);
        }

        // Russian roulette picks one lobe, or the path's death; the lobe continues it
        float p = 0.0f;
        float u_lobe, u_roulette;
        lobe_uniforms<float>(rng, bounce, normalised_lobes(c.estimator), u_lobe, u_roulette);
        const int32_t lobe =
            choose_lobe(m, u_lobe, c.estimator.survival_cap, p, normalised_lobes(c.estimator));
        // (past max_length a guided path goes on while a record is there, or is made here or
        // may be later, to gather what follows: the same paths as the whole render's)
        const bool recording = learn && (recorded > 0 || records_here || phong_vertices < served);
        if (lobe == kLobeAbsorbed || (!recording && !may_extend<float>(c.estimator, bounce))) break;
        ScalarContinuation next;
        GuidedScatter<float> drawn{};  // (where the guide drew the direction)
        const bool guided = lobe == kLobeDiffuse && guide.active();
        if (guided) {
            const GuidedContinuation g =
                continue_guided_diffuse(c, m, v, hit.p, hit.n, magnitude, p, guide, rng, bounce);
            next = g.next, drawn = g.g;
        } else {
            next = continue_path(lobe, c, m, ray.d, v, hit.p, hit.n, hit.ns, magnitude, p, rng,
                                 bounce);
        }
        // (what the guide's record divides by)
        RecordDensities<float> densities;
        if (records_here && lobe == kLobeDiffuse)
            densities = record_densities<kLobeDiffuse>(c, m, ray.d, v.nsf, next.d, guide, true,
                                                       guided, drawn, p);
        else if (records_here && lobe == kLobeSpecular)
            densities = record_densities<kLobeSpecular>(c, m, ray.d, v.nsf, next.d, guide, true,
                                                        guided, drawn, p);
        lobe_pdf = next.pdf;
        throughput = throughput_roulette(c.estimator, throughput * next.weight, u_roulette, bounce);
        if (records_here && lobe <= kLobeSpecular && recorded < kMaxGuideRecords) {
            GuideRecord& r = records[recorded++];
            r = {{hit.p.x, hit.p.y, hit.p.z},
                 {next.d.x, next.d.y, next.d.z},
                 densities.density,
                 {throughput.x, throughput.y, throughput.z},
                 {0.0f, 0.0f, 0.0f},
                 {0.0f, 0.0f, 0.0f},
                 0.0f,
                 0.0f,
                 0.0f,
                 0,
                 -1,
                 recorded - 1};
            if (lobe == kLobeDiffuse && guide.exists()) {
                const Vec3f f_cos = diffuse_f_cos(m, next.d, v.nsf);
                r.selection = 1;
                r.f_cos[0] = f_cos.x, r.f_cos[1] = f_cos.y, r.f_cos[2] = f_cos.z;
                r.guide_pdf = densities.guide_pdf, r.lobe_pdf = densities.lobe_pdf;
                r.fraction = guide.fraction;
            }
        }
        if (!(max_component(throughput) > 0.0f)) break;
        ray = {next.o, next.d};
        ++rays.extension;
    }
    if (learn)
        for (int i = 0; i < recorded; ++i) learn->deposit(pass, records[i]);
    return radiance;
}

namespace {

// Light tracing's use of the light-subpath walk (walk_light_subpath): the emitter's point and
// every Phong vertex, seen from the pinhole, land unweighted in the pixel they are seen in
// if nothing is in the way.
struct LightTracing {
    static constexpr bool kMis = false;
    const Scene& scene;
    const PathContext& c;
    const PinholeFrame& pinhole;
    FilmTile& film;
    RayCounts& rays;

    // A connection to the pinhole from `origin`: `value` lands in its pixel if nothing is in
    // the way
    void connect(const CameraConnection<float>& cc, const Vec3f& origin, const Vec3f& value) {
        if (!cc.ok || !(max_component(value) > 0.0f)) return;
        ++rays.shadow;
        if (!scene.occluded({origin, cc.wc}, cc.dist * (1.0f - 1e-5f)))
            film.splat(uint32_t(cc.pixel), value);
    }
    // The emitter's point itself, as the pinhole sees it (a point light is never seen)
    void start(const LightStart<float>& s) {
        if (!s.on_surface || !length_counts<float>(c.estimator, 1u)) return;
        const CameraConnection<float> cc = connect_camera(pinhole, s.p);
        const float cos_l = dot(cc.wc, s.n);
        connect(cc, offset_ray_origin(s.p, cos_l > 0.0f ? s.n : -s.n, max_abs(s.p)),
                s.le * (std::abs(cos_l) * cc.factor));
    }
    void vertex(const LightVertex<float>& lv, const Bsdf<float>& m) {
        if (!length_counts<float>(c.estimator, lv.length + 1)) return;
        const CameraConnection<float> cc = connect_camera(pinhole, lv.p);
        if (on_arriving_side(cc.wc, lv.nf))
            connect(cc, offset_ray_origin(lv.p, lv.nf, lv.magnitude),
                    camera_contribution(m, lv.beta, -lv.wl, lv.nf, lv.nsf, cc, c.smooth));
    }
};

}  // namespace

CIERZO_PATH_LOOP void trace_light_path(const Scene& scene, const PathContext& c,
                                       const PinholeFrame& pinhole,
                                       const SampleStream<float>& camera_rng, FilmTile& film,
                                       RayCounts& rays) {
    LightTracing at{scene, c, pinhole, film, rays};
    walk_light_subpath(scene, c, scene.light_starts.table(), camera_rng, MergeWeights<float>{}, at,
                       rays);
}

void render_tile_scalar(const Scene& scene, const Tile& tile, FilmTile& film, RayCounts& rays,
                        PathGuide* guide, int32_t pass) {
    const RenderSettings& rs = scene.settings;
    const float inv_w = 1.0f / float(rs.width), inv_h = 1.0f / float(rs.height);
    PathContext context = scene.path_context();
    if (guide) context.guide = guide->view();
    PathGuide* learn = guide && guide->learning() ? guide : nullptr;  // (records for it)
    if (tile.light) {
        // A batch of light paths: one per key of its pixels and samples
        const PinholeFrame pinhole = scene.pinhole();
        for (int y = tile.y0; y < tile.y1; ++y)
            for (int x = tile.x0; x < tile.x1; ++x) {
                const uint32_t pixel = uint32_t(y) * uint32_t(rs.width) + uint32_t(x);
                for (int64_t s = tile.s0; s < tile.s1; ++s)
                    trace_light_path(scene, context, pinhole,
                                     camera_stream<float>(context.sampler, rs.seed, pixel,
                                                          uint32_t(x), uint32_t(y), uint32_t(s)),
                                     film, rays);
            }
        return;
    }
    // (light tracing's tiles count their samples all the same)
    const bool camera_paths = scene.traces_camera_paths();
    for (int y = tile.y0; y < tile.y1; ++y) {
        for (int x = tile.x0; x < tile.x1; ++x) {
            PixelSums& px = film.at(x, y);
            if (!camera_paths) {
                px.count += uint64_t(tile.s1 - tile.s0);
                continue;
            }
            const uint32_t pixel = uint32_t(y) * uint32_t(rs.width) + uint32_t(x);
            for (int64_t s = tile.s0; s < tile.s1; ++s) {
                // A uniformly random point inside the pixel
                const SampleStream<float> rng = camera_stream<float>(
                    context.sampler, rs.seed, pixel, uint32_t(x), uint32_t(y), uint32_t(s));
                float jx, jy;
                uniform2<float>(rng, 0u, Purpose::kPixelX, jx, jy);
                ++rays.camera;
                px.add(trace_path(scene, context,
                                  scene.camera.generate(float(x) + jx, float(y) + jy, inv_w, inv_h),
                                  rng, rays, learn, pass));
            }
        }
    }
}

}  // namespace cierzo
