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

}  // namespace

Vec3f trace_path(const Scene& scene, const Ray<float>& camera_ray, uint32_t key,
                 RayCounts& rays) {
    const EstimatorSettings& est = scene.settings.estimator;
    Vec3f radiance(0.0f);
    Vec3f throughput(1.0f);
    Ray<float> ray = camera_ray;
    // Next-event estimation (nee, mis) when the scene has emitters it can sample
    const bool nee = est.kind != Estimator::kReport && scene.emitters.count() > 0;
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
            if (nee)
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
        if (material.has_phong() && !scene.lights.empty())
            radiance += throughput * direct_point_lights(scene, m, hit, ray.d, vn, magnitude, rays);
        // One emitter sample at every Phong vertex
        if (nee && material.has_phong())
            radiance += throughput * direct_emitter(scene, emitters, m, hit, ray.d, vn, magnitude,
                                                    key, bounce, rays);

        // Russian roulette picks one lobe, or the path's death
        float p = 0.0f;
        const int32_t lobe = choose_lobe(m, uniform<float>(key, bounce, Purpose::kLobe),
                                         est.survival_cap, p);
        const float u1 = uniform<float>(key, bounce, Purpose::kDirection1);
        const float u2 = uniform<float>(key, bounce, Purpose::kDirection2);
        Scatter<float> s;
        switch (lobe) {
            case kLobeDiffuse: s = sample_diffuse(m, ns, u1, u2, p, est.cosine_diffuse); break;
            case kLobeSpecular: s = sample_specular(m, ray.d, ns, u1, u2, p); break;
            case kLobeMirror: s = sample_mirror(m, ray.d, ns, p); break;
            case kLobeRefract:
                s = sample_refraction(m, ray.d, hit.n, hit.ns, scene.scene_ior, p, shading);
                break;
            default: return radiance;
        }
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

void render_tile_scalar(const Scene& scene, const Tile& tile, FilmTile& film, RayCounts& rays) {
    const RenderSettings& rs = scene.settings;
    const float inv_w = 1.0f / float(rs.width), inv_h = 1.0f / float(rs.height);
    for (int y = tile.y0; y < tile.y1; ++y) {
        for (int x = tile.x0; x < tile.x1; ++x) {
            PixelSums& px = film.at(x, y);
            const uint32_t pixel = uint32_t(y) * uint32_t(rs.width) + uint32_t(x);
            for (int64_t s = tile.s0; s < tile.s1; ++s) {
                // A uniformly random point inside the pixel
                const uint32_t key = path_key(rs.seed, pixel, uint32_t(s));
                const float sx = float(x) + uniform<float>(key, 0u, Purpose::kPixelX);
                const float sy = float(y) + uniform<float>(key, 0u, Purpose::kPixelY);
                ++rays.camera;
                px.add(trace_path(scene, scene.camera.generate(sx, sy, inv_w, inv_h), key, rays));
            }
        }
    }
}

}  // namespace cierzo
