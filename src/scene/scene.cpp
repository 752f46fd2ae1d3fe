// Scene set-up (bounding spheres, BVHs, feature set) and the scalar closest-hit and
// shadow queries over every primitive kind, using the templated kernels with T = float.
#include "scene/scene.h"

#include <cmath>

namespace cierzo {

Camera look_at_camera(const Vec3f& position, const Vec3f& target, const Vec3f& up_hint,
                      float vfov_degrees, float aspect) {
    const Vec3f f = normalize(target - position);
    const Vec3f right = normalize(cross(up_hint, f));
    const Vec3f up = cross(f, right);
    const float half = std::tan(vfov_degrees * kPi / 360.0f);
    Camera c;
    c.origin = position;
    c.forward = f;
    c.up = up * half;
    c.left = right * (-half * aspect);
    return c;
}

void Scene::finalize() {
    for (Mesh& m : meshes) {
        // Bounding sphere: centre of the bounding box, radius to the farthest vertex
        Vec3f lo(kRayFar), hi(-kRayFar);
        for (const Vec3f& p : m.positions) {
            lo = vmin(lo, p);
            hi = vmax(hi, p);
        }
        m.sphere_center = (lo + hi) * 0.5f;
        float r2 = 0.0f;
        for (const Vec3f& p : m.positions) {
            const Vec3f v = p - m.sphere_center;
            r2 = std::max(r2, dot(v, v));
        }
        m.sphere_radius = std::sqrt(r2) * (1.0f + 1e-5f) + 1e-30f;
        m.bvh.build(m.positions, m.indices);
    }
}

void Scene::set_resolution(int width, int height) {
    settings.width = width;
    settings.height = height;
    if (look_at)
        camera = look_at_camera(look_at->position, look_at->target, look_at->up,
                                look_at->vfov_degrees, float(width) / float(height));
}

SceneFeatures Scene::features() const {
    SceneFeatures f;
    f.spheres = spheres.size() > 0;
    f.planes = planes.size() > 0;
    f.quadrics = !quadrics.empty();
    f.meshes = !meshes.empty();
    f.point_lights = !lights.empty();
    for (const Material& m : materials) {
        f.emitters |= m.is_emitter();
        f.diffuse |= !m.kd.is_zero();
        f.specular |= !m.ks.is_zero();
        f.mirror |= !m.kr.is_zero();
        f.refraction |= !m.kt.is_zero();
        for (const ColorSource* c : {&m.emission, &m.kd, &m.ks, &m.kr, &m.kt}) {
            f.procedural_textures |= c->is_procedural();
            f.vertex_colors |= c->is_vertex();
        }
    }
    return f;
}

bool Scene::intersect(const Ray<float>& ray, float tmax, Hit& hit) const {
    float best = tmax;
    int kind = -1;  // 0 sphere, 1 plane, 2 quadric, 3 mesh
    size_t index = 0;
    TriangleHit tri{};
    // Analytic primitives, one kernel call each
    for (size_t i = 0; i < spheres.size(); ++i) {
        float t;
        const Vec3f c{spheres.cx[i], spheres.cy[i], spheres.cz[i]};
        if (intersect_sphere(ray, c, spheres.radius[i], best, t)) best = t, kind = 0, index = i;
    }
    for (size_t i = 0; i < planes.size(); ++i) {
        float t;
        const Vec3f n{planes.nx[i], planes.ny[i], planes.nz[i]};
        if (intersect_plane(ray, n, planes.distance[i], best, t)) best = t, kind = 1, index = i;
    }
    for (size_t i = 0; i < quadrics.size(); ++i) {
        float t;
        const Quadric& q = quadrics[i];
        if (intersect_quadric(ray, q.q, q.box_min, q.box_max, best, t))
            best = t, kind = 2, index = i;
    }
    // Meshes: the bounding sphere first, then the BVH
    for (size_t i = 0; i < meshes.size(); ++i) {
        const Mesh& m = meshes[i];
        const Vec3f oc = ray.o - m.sphere_center;
        const float b = dot(oc, ray.d);
        const float c = dot(oc, oc) - m.sphere_radius * m.sphere_radius;
        if (c > 0.0f && (b > 0.0f || b * b < c)) continue;  // outside and missing or behind
        if (c > 0.0f && -b - std::sqrt(b * b - c) >= best) continue;
        TriangleHit th;
        if (m.bvh.intersect(ray, best, th)) best = th.t, kind = 3, index = i, tri = th;
    }
    if (kind < 0) return false;

    // Hit point and outward geometric normal
    hit.t = best;
    hit.p = fma(ray.d, best, ray.o);
    hit.mesh = -1;
    switch (kind) {
        case 0: {
            const Vec3f c{spheres.cx[index], spheres.cy[index], spheres.cz[index]};
            hit.n = (hit.p - c) * (1.0f / spheres.radius[index]);
            hit.n = normalize(hit.n);
            hit.material = spheres.material[index];
            break;
        }
        case 1:
            hit.n = {planes.nx[index], planes.ny[index], planes.nz[index]};
            hit.material = planes.material[index];
            break;
        case 2:
            hit.n = normalize(quadric_gradient(quadrics[index].q, hit.p));
            hit.material = quadrics[index].material;
            break;
        default: {
            const Mesh& m = meshes[index];
            const uint32_t* v = &m.indices[size_t(tri.triangle) * 3];
            const Vec3f e1 = m.positions[v[1]] - m.positions[v[0]];
            const Vec3f e2 = m.positions[v[2]] - m.positions[v[0]];
            hit.n = normalize(cross(e1, e2));
            hit.material = m.material;
            hit.mesh = int32_t(index);
            hit.triangle = tri.triangle;
            break;
        }
    }
    return true;
}

bool Scene::occluded(const Ray<float>& ray, float tmax) const {
    float t;
    for (size_t i = 0; i < planes.size(); ++i) {
        const Vec3f n{planes.nx[i], planes.ny[i], planes.nz[i]};
        if (intersect_plane(ray, n, planes.distance[i], tmax, t)) return true;
    }
    for (size_t i = 0; i < spheres.size(); ++i) {
        const Vec3f c{spheres.cx[i], spheres.cy[i], spheres.cz[i]};
        if (intersect_sphere(ray, c, spheres.radius[i], tmax, t)) return true;
    }
    for (const Quadric& q : quadrics) {
        if (intersect_quadric(ray, q.q, q.box_min, q.box_max, tmax, t)) return true;
    }
    for (const Mesh& m : meshes) {
        if (m.bvh.occluded(ray, tmax)) return true;
    }
    return false;
}

Vec3f Scene::color_at(const ColorSource& c, const Hit& hit) const {
    if (!c.is_vertex()) return eval_pattern(c, hit.p);
    if (hit.mesh < 0 || meshes[size_t(hit.mesh)].colors.empty()) return c.a;
    const Mesh& m = meshes[size_t(hit.mesh)];
    const uint32_t* idx = &m.indices[size_t(hit.triangle) * 3];
    const Vec3f v[3] = {m.positions[idx[0]], m.positions[idx[1]], m.positions[idx[2]]};
    const Vec3f col[3] = {m.colors[idx[0]], m.colors[idx[1]], m.colors[idx[2]]};
    return eval_vertex_color(c, hit.p, v, col);
}

Bsdf<float> Scene::bsdf_at(const Hit& hit) const {
    const Material& m = materials[size_t(hit.material)];
    return {color_at(m.kd, hit), color_at(m.ks, hit), color_at(m.kr, hit), color_at(m.kt, hit),
            m.shininess, m.ior};
}

Vec3f Scene::emission_at(const Hit& hit) const {
    return color_at(materials[size_t(hit.material)].emission, hit);
}

}  // namespace cierzo
