// Scene set-up (BVHs, feature set) and the scalar closest-hit and shadow queries: the
// unbounded primitives and the scene BVH through the shared traversal (kernels/traverse.h)
// with T = float.
#include "scene/scene.h"

#include <algorithm>
#include <chrono>
#include <cmath>

#include "kernels/traverse.h"

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
    const auto start = std::chrono::steady_clock::now();
    BvhInput in;
    for (size_t i = 0; i < meshes.size(); ++i) {
        Mesh& m = meshes[i];
        if (m.geometry != int32_t(i)) continue;
        auto bvh = std::make_shared<Bvh>();
        bvh->build(m.positions, m.indices);
        m.bvh = std::move(bvh);
    }
    for (size_t i = 0; i < meshes.size(); ++i) {
        const Mesh& m = meshes[i];
        if (!m.instanced()) {
            in.triangles.push_back({m.positions, m.indices, uint32_t(i)});
            continue;
        }
        BvhObjectInstance inst;
        inst.geometry = meshes[size_t(m.geometry)].bvh;
        std::copy(m.to_object, m.to_object + 12, inst.to_object);
        std::copy(m.normal_to_world, m.normal_to_world + 9, inst.normal_to_world);
        std::copy(m.to_world, m.to_world + 12, inst.to_world);
        inst.mesh = uint32_t(i);
        in.instances.push_back(inst);
    }
    in.sphere_x = spheres.cx, in.sphere_y = spheres.cy, in.sphere_z = spheres.cz;
    in.sphere_r = spheres.radius;
    std::vector<float> table;
    unbounded_quadrics.clear();
    for (size_t i = 0; i < quadrics.size(); ++i) {
        const Quadric& q = quadrics[i];
        table.insert(table.end(), {q.q.a, q.q.b, q.q.c, q.q.d, q.q.e, q.q.f, q.q.g, q.q.h, q.q.i,
                                   q.q.j, q.box_min.x, q.box_min.y, q.box_min.z, q.box_max.x,
                                   q.box_max.y, q.box_max.z});
        // (a quadric without bounds has the box ±kRayFar)
        const bool bounded = q.box_min.x > -kRayFar && q.box_max.x < kRayFar &&
                             q.box_min.y > -kRayFar && q.box_max.y < kRayFar &&
                             q.box_min.z > -kRayFar && q.box_max.z < kRayFar;
        if (bounded)
            in.quadrics.push_back({uint32_t(i), q.box_min, q.box_max});
        else
            unbounded_quadrics.push_back(int32_t(i));
    }
    in.quadric_table = table;
    bvh.build(in);
    bvh_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
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

namespace {

// The scene's planes and unbounded quadrics for the shared loops of kernels/traverse.h.
struct ScalarPlanes {
    const Planes& p;
    PlaneLanes<float> operator()(int32_t j) const {
        const size_t i = size_t(j);
        return {{p.nx[i], p.ny[i], p.nz[i]}, p.distance[i]};
    }
};
struct ScalarQuadrics {
    const std::vector<Quadric>& q;
    const std::vector<int32_t>& list;
    QuadricOfLanes<float> operator()(int32_t j) const {
        const int32_t i = list[size_t(j)];
        const Quadric& x = q[size_t(i)];
        return {x.q, x.box_min, x.box_max, i};
    }
};

// Hit kinds of the unbounded list's ids
constexpr int32_t kPlaneId = 0;
constexpr int32_t kQuadricId = 1 << 30;

}  // namespace

bool Scene::intersect(const Ray<float>& ray, float tmax, Hit& hit) const {
    float best = tmax;
    int32_t id = -1;
    closest_unbounded(ray, best, id, int32_t(planes.size()), ScalarPlanes{planes}, kPlaneId,
                      int32_t(unbounded_quadrics.size()),
                      ScalarQuadrics{quadrics, unbounded_quadrics}, kQuadricId);
    BvhHit tree{};
    const bool in_tree =
        traverse<false, float>(bvh.view(), make_traversal_ray(ray.o, ray.d), best, tree);
    if (!in_tree && id < 0) return false;

    // Hit point and outward geometric normal
    hit.t = best;
    hit.p = fma(ray.d, best, ray.o);
    hit.mesh = -1;
    const auto quadric = [&](size_t index) {
        hit.n = normalize(quadric_gradient(quadrics[index].q, hit.p));
        hit.material = quadrics[index].material;
    };
    if (!in_tree) {
        if (id >= kQuadricId) {
            quadric(size_t(id - kQuadricId));
        } else {
            const size_t i = size_t(id);
            hit.n = {planes.nx[i], planes.ny[i], planes.nz[i]};
            hit.material = planes.material[i];
        }
        return true;
    }
    const BvhView& v = bvh.view();
    switch (tree.kind) {
        case kLeafSpheres: {
            const size_t i = hit_sphere(v, tree);
            const Vec3f c{spheres.cx[i], spheres.cy[i], spheres.cz[i]};
            hit.n = normalize((hit.p - c) * (1.0f / spheres.radius[i]));
            hit.material = spheres.material[i];
            break;
        }
        case kLeafQuadrics: quadric(tree.lane); break;
        default: {
            hit.mesh = int32_t(hit_mesh(v, tree));
            hit.triangle = hit_triangle(v, tree);
            hit.n = hit_triangle_normal(v, tree);
            hit.material = meshes[size_t(hit.mesh)].material;
            break;
        }
    }
    return true;
}

bool Scene::occluded(const Ray<float>& ray, float tmax) const {
    if (occluded_unbounded(ray, tmax, false, int32_t(planes.size()), ScalarPlanes{planes},
                           int32_t(unbounded_quadrics.size()),
                           ScalarQuadrics{quadrics, unbounded_quadrics}))
        return true;
    BvhHit unused;
    float t = tmax;
    return traverse<true, float>(bvh.view(), make_traversal_ray(ray.o, ray.d), t, unused);
}

Vec3f Scene::color_at(const ColorSource& c, const Hit& hit) const {
    if (!c.is_vertex()) return eval_pattern(c, hit.p);
    if (hit.mesh < 0) return c.a;
    const Mesh& object = meshes[size_t(hit.mesh)];
    const Mesh& m = geometry_of(object);
    if (m.colors.empty()) return c.a;
    const uint32_t* idx = &m.indices[size_t(hit.triangle) * 3];
    const Vec3f v[3] = {m.positions[idx[0]], m.positions[idx[1]], m.positions[idx[2]]};
    const Vec3f col[3] = {m.colors[idx[0]], m.colors[idx[1]], m.colors[idx[2]]};
    // (an instance's vertices are in the file's space: so is the point)
    const float p[3] = {hit.p.x, hit.p.y, hit.p.z};
    const Vec3f at = object.instanced() ? affine_point(object.to_object, p) : hit.p;
    return eval_vertex_color(c, at, v, col);
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
