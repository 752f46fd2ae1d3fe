// The scalar reference path tracer (see scalar.h): the report's estimator, one path at a
// time, using the same templated kernels as the wavefront integrator with T = float.
#include "integrators/scalar.h"

#include "kernels/rng.h"
#include "kernels/shading.h"

namespace cierzo {

namespace {

// The normals at a vertex: nf, the geometric normal on the side the ray arrives from, and
// ns, the normal the lobes are sampled and evaluated about (nf, or a smooth mesh's shading
// normal turned to that side; kernels/shading.h). `shading`: the scene has smooth meshes,
// and directions are also checked against nf.
struct VertexNormals {
    Vec3f nf, ns;
    bool shading;
};

// Point lights seen from a Phong vertex: f·cos θ·I/d² for each unoccluded light.
Vec3f direct_point_lights(const Scene& scene, const Bsdf<float>& m, const Hit& hit,
                          const Vec3f& d, const VertexNormals& vn, float magnitude,
                          RayCounts& rays) {
    Vec3f sum(0.0f);
    const Vec3f origin = offset_ray_origin(hit.p, vn.nf, magnitude);
    for (const PointLight& light : scene.lights) {
        const Vec3f to = light.position - origin;
        const float d2 = dot(to, to);
        const float dist = std::sqrt(d2);
        const Vec3f wi = to * (1.0f / dist);
        const Vec3f f_cos = phong_f_cos(m, d, vn.ns, wi);
        if (!(max_component(f_cos) > 0.0f)) continue;
        if (vn.shading && !on_arriving_side(wi, vn.nf)) continue;
        ++rays.shadow;
        if (scene.occluded({origin, wi}, dist * (1.0f - 1e-5f))) continue;
        sum += f_cos * light.intensity * (1.0f / d2);
    }
    return sum;
}

// One emitter sample at a Phong vertex (next-event estimation, kernels/estimator.h): what it
// brings if its shadow ray reaches the sampled point.
Vec3f direct_emitter(const Scene& scene, const EmitterTable& emitters, const Bsdf<float>& m,
                     const Hit& hit, const Vec3f& d, const VertexNormals& vn, float magnitude,
                     uint32_t key, uint32_t bounce, RayCounts& rays) {
    const Vec3f origin = offset_ray_origin(hit.p, vn.nf, magnitude);
    const EmitterShadow<float> s = emitter_shadow(emitters, scene.settings.estimator, m, d,
                                                  vn.ns, origin, key, bounce);
    if (!s.ok) return Vec3f(0.0f);
    if (vn.shading && !on_arriving_side(s.wi, vn.nf)) return Vec3f(0.0f);
    ++rays.shadow;
    if (scene.occluded({origin, s.wi}, s.tmax)) return Vec3f(0.0f);
    return s.value;
}

// The lobe the roulette chose (kernels/estimator.h), sampled in transport mode kMode: the
// camera's paths carry radiance, the lights' importance.
template <Transport kMode>
Scatter<float> sample_lobe(const Scene& scene, int32_t lobe, const Bsdf<float>& m, const Hit& hit,
                           const Vec3f& d, const Vec3f& ns, float p, uint32_t key,
                           uint32_t bounce) {
    const EstimatorSettings& est = scene.settings.estimator;
    const float u1 = uniform<float>(key, bounce, Purpose::kDirection1);
    const float u2 = uniform<float>(key, bounce, Purpose::kDirection2);
    switch (lobe) {
        case kLobeDiffuse: return sample_diffuse(m, ns, u1, u2, p, est.cosine_diffuse);
        case kLobeSpecular: return sample_specular(m, d, ns, u1, u2, p);
        case kLobeMirror: return sample_mirror(m, d, ns, p);
        default:
            return sample_refraction<kMode>(m, d, hit.n, hit.ns, scene.scene_ior, p,
                                            scene.smooth_shading);
    }
}

}  // namespace

Vec3f trace_path(const Scene& scene, const Ray<float>& camera_ray, uint32_t key,
                 RayCounts& rays) {
    const EstimatorSettings& est = scene.settings.estimator;
    Vec3f radiance(0.0f);
    Vec3f throughput(1.0f);
    Ray<float> ray = camera_ray;
    // Next-event estimation (nee, mis) when the scene has emitters it can sample; with lt,
    // camera paths bring only the emitters no light path starts on
    const bool nee =
        (est.kind == Estimator::kNee || est.kind == Estimator::kMis) && scene.emitters.count() > 0;
    const bool lt = est.kind == Estimator::kLt;
    const EmitterTable emitters = scene.emitters.table();
    const bool shading = scene.smooth_shading;  // some mesh has shading normals
    float lobe_pdf = 0.0f;  // the density of the last Phong lobe's direction; 0 after the
                            // camera, a mirror or a refraction
    for (uint32_t bounce = 0;; ++bounce) {
        Hit hit;
        if (!scene.intersect(ray, kRayFar, hit)) break;
        const Material& material = scene.materials[size_t(hit.material)];

        // An emitter ends the path
        if (material.is_emitter()) {
            Vec3f le = scene.emission_at(hit);
            if (nee || lt)
                le *= emitter_hit_weight<float>(emitters, est.kind, scene.emitter_id(hit),
                                                lobe_pdf, ray.o, ray.d, hit.t);
            radiance += throughput * le;
            break;
        }
        const Bsdf<float> m = scene.bsdf_at(hit);
        const Vec3f nf = facing_normal(hit.n, ray.d);
        const VertexNormals vn{nf, shading ? facing_shading_normal(hit.ns, nf) : nf, shading};
        const Vec3f& ns = vn.ns;
        const float magnitude = max(max_abs(hit.p), max_abs(ray.o));

        // Point lights through shadow rays at every Phong vertex
        if (material.has_phong() && !scene.lights.empty() && !lt)
            radiance += throughput * direct_point_lights(scene, m, hit, ray.d, vn, magnitude, rays);
        // One emitter sample at every Phong vertex
        if (nee && material.has_phong())
            radiance += throughput * direct_emitter(scene, emitters, m, hit, ray.d, vn, magnitude,
                                                    key, bounce, rays);

        // Russian roulette picks one lobe, or the path's death
        float p = 0.0f;
        const int32_t lobe = choose_lobe(m, uniform<float>(key, bounce, Purpose::kLobe),
                                         est.survival_cap, p);
        if (lobe == kLobeAbsorbed) return radiance;
        const Scatter<float> s =
            sample_lobe<Transport::kRadiance>(scene, lobe, m, hit, ray.d, ns, p, key, bounce);
        // A reflection about the shading normal must leave on the geometric surface's side
        if (shading && lobe != kLobeRefract && !on_arriving_side(s.dir, nf)) break;
        if (nee) {
            lobe_pdf = lobe == kLobeDiffuse
                           ? sampled_lobe_pdf<kLobeDiffuse>(m, ray.d, ns, s.dir, p,
                                                            est.cosine_diffuse)
                       : lobe == kLobeSpecular
                           ? sampled_lobe_pdf<kLobeSpecular>(m, ray.d, ns, s.dir, p, false)
                           : 0.0f;
        }

        // Continue with the lobe's weight from just off the surface, on the new side
        throughput *= s.weight;
        if (!(max_component(throughput) > 0.0f)) break;
        ray.o = offset_ray_origin(hit.p, dot(s.dir, hit.n) > 0.0f ? hit.n : -hit.n, magnitude);
        ray.d = s.dir;
        ++rays.extension;
    }
    return radiance;
}

void trace_light_path(const Scene& scene, const PinholeFrame& pinhole, uint32_t camera_key,
                      FilmTile& film, RayCounts& rays) {
    const EstimatorSettings& est = scene.settings.estimator;
    const uint32_t key = light_path_key(camera_key);
    const LightStart<float> start =
        sample_light_start<float>(scene.emitters.table(), scene.light_starts.table(), key);
    if (!start.ok) return;
    const bool shading = scene.smooth_shading;
    // A connection to the pinhole from just off the surface at p (normal n, towards the
    // pinhole's side): `value` lands in its pixel if nothing is in the way
    const auto connect = [&](const CameraConnection<float>& c, const Vec3f& p, const Vec3f& n,
                             float magnitude, const Vec3f& value) {
        if (!(max_component(value) > 0.0f)) return;
        ++rays.shadow;
        const Vec3f origin = offset_ray_origin(p, n, magnitude);
        if (!scene.occluded({origin, c.wc}, c.dist * (1.0f - 1e-5f)))
            film.splat(uint32_t(c.pixel), value);
    };
    // The emitter's point itself, as the pinhole sees it (a point light is never seen)
    if (start.on_surface) {
        const CameraConnection<float> c = connect_camera(pinhole, start.p);
        const float cos_l = dot(c.wc, start.n);
        if (c.ok)
            connect(c, start.p, cos_l > 0.0f ? start.n : -start.n, max_abs(start.p),
                    start.le * (std::abs(cos_l) * c.factor));
    }
    ++rays.light;
    Ray<float> ray{start.on_surface
                       ? offset_ray_origin(start.p, dot(start.dir, start.n) > 0.0f ? start.n : -start.n,
                                           max_abs(start.p))
                       : start.p,
                   start.dir};
    Vec3f beta = start.beta;
    for (uint32_t bounce = 1;; ++bounce) {
        Hit hit;
        if (!scene.intersect(ray, kRayFar, hit)) break;
        const Material& material = scene.materials[size_t(hit.material)];
        if (material.is_emitter()) break;  // emitters absorb what reaches them
        const Bsdf<float> m = scene.bsdf_at(hit);
        const Vec3f nf = facing_normal(hit.n, ray.d);
        const Vec3f ns = shading ? facing_shading_normal(hit.ns, nf) : nf;
        const float magnitude = max(max_abs(hit.p), max_abs(ray.o));

        // Every Phong vertex is seen from the pinhole
        if (material.has_phong()) {
            const CameraConnection<float> c = connect_camera(pinhole, hit.p);
            if (c.ok && on_arriving_side(c.wc, nf))
                connect(c, hit.p, nf, magnitude,
                        camera_contribution(m, beta, ray.d, nf, ns, c, shading));
        }

        // The roulette and the chosen lobe, in importance mode
        float p = 0.0f;
        const int32_t lobe = choose_lobe(m, uniform<float>(key, bounce, Purpose::kLobe),
                                         est.survival_cap, p);
        if (lobe == kLobeAbsorbed) break;
        Scatter<float> s =
            sample_lobe<Transport::kImportance>(scene, lobe, m, hit, ray.d, ns, p, key, bounce);
        if (shading) {
            if (lobe != kLobeRefract && !on_arriving_side(s.dir, nf)) break;
            s.weight *= shading_correction(-ray.d, s.dir, hit.n, ns);
        }
        beta *= s.weight;
        if (!(max_component(beta) > 0.0f)) break;
        ray.o = offset_ray_origin(hit.p, dot(s.dir, hit.n) > 0.0f ? hit.n : -hit.n, magnitude);
        ray.d = s.dir;
        ++rays.extension;
    }
}

void render_tile_scalar(const Scene& scene, const Tile& tile, FilmTile& film, RayCounts& rays) {
    const RenderSettings& rs = scene.settings;
    const float inv_w = 1.0f / float(rs.width), inv_h = 1.0f / float(rs.height);
    // Light tracing: one path from the lights per camera path; the camera's own paths only
    // where some emitter is not sampled (they bring nothing else)
    const bool lt = splats(rs.estimator.kind);
    const bool camera_paths = !lt || scene.emitters.unsampled_objects > 0;
    const PinholeFrame pinhole = scene.pinhole();
    for (int y = tile.y0; y < tile.y1; ++y) {
        for (int x = tile.x0; x < tile.x1; ++x) {
            PixelSums& px = film.at(x, y);
            const uint32_t pixel = uint32_t(y) * uint32_t(rs.width) + uint32_t(x);
            for (int64_t s = tile.s0; s < tile.s1; ++s) {
                // A uniformly random point inside the pixel
                const uint32_t key = path_key(rs.seed, pixel, uint32_t(s));
                if (camera_paths) {
                    const float sx = float(x) + uniform<float>(key, 0u, Purpose::kPixelX);
                    const float sy = float(y) + uniform<float>(key, 0u, Purpose::kPixelY);
                    ++rays.camera;
                    px.add(trace_path(scene, scene.camera.generate(sx, sy, inv_w, inv_h), key,
                                      rays));
                } else {
                    ++px.count;
                }
                if (lt) trace_light_path(scene, pinhole, key, film, rays);
            }
        }
    }
}

}  // namespace cierzo
