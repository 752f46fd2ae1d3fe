// Scene set-up (BVHs, feature set) and the scalar closest-hit and shadow queries: the
// unbounded primitives and the scene BVH through the shared traversal (kernels/bvh/traverse.h)
// with T = float; the path context the estimators read. The light tables that finalize builds
// are in emitter_tables.cpp.
#include "scene/scene.h"

#include <algorithm>
#include <bit>
#include <chrono>
#include <cmath>
#include <map>
#include <stdexcept>

#include "core/error.h"
#include "kernels/prim_id.h"
#include "kernels/shading.h"
#include "kernels/bvh/traverse.h"
#include "scene/pmj02.h"

namespace cierzo {

Camera look_at_camera(const Vec3f& position, const Vec3f& target, const Vec3f& up_hint,
                      float vfov_degrees, float aspect, Handedness hand) {
    const Vec3f f = normalize(target - position);
    const Vec3f right =
        hand == Handedness::kLeft ? normalize(cross(up_hint, f)) : normalize(cross(f, up_hint));
    const Vec3f up = hand == Handedness::kLeft ? cross(f, right) : cross(right, f);
    const float half = std::tan(vfov_degrees * kPi / 360.0f);
    Camera c;
    c.origin = position;
    c.forward = f;
    c.up = up * half;
    c.left = right * (-half * aspect);
    return c;
}

namespace {

// Area-weighted vertex normals: each vertex gets the sum of (v1 - v0) × (v2 - v0) of the
// triangles around it (twice their areas, along their normals), normalised; 0 for a vertex
// of degenerate triangles only. In double, so huge meshes do not overflow.
std::vector<Vec3f> area_weighted_normals(const std::vector<Vec3f>& p,
                                         const std::vector<uint32_t>& indices) {
    std::vector<double> sum(p.size() * 3, 0.0);
    for (size_t t = 0; t + 2 < indices.size(); t += 3) {
        const Vec3f& a = p[indices[t]];
        const Vec3f& b = p[indices[t + 1]];
        const Vec3f& c = p[indices[t + 2]];
        const double e1[3] = {double(b.x) - a.x, double(b.y) - a.y, double(b.z) - a.z};
        const double e2[3] = {double(c.x) - a.x, double(c.y) - a.y, double(c.z) - a.z};
        const double n[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2],
                             e1[0] * e2[1] - e1[1] * e2[0]};
        for (int k = 0; k < 3; ++k)
            for (int j = 0; j < 3; ++j) sum[3 * size_t(indices[t + size_t(k)]) + size_t(j)] += n[j];
    }
    std::vector<Vec3f> out(p.size(), Vec3f(0.0f));
    for (size_t i = 0; i < p.size(); ++i) {
        const double* s = &sum[3 * i];
        const double len = std::sqrt(s[0] * s[0] + s[1] * s[1] + s[2] * s[2]);
        if (len > 0.0 && std::isfinite(len))
            out[i] = {float(s[0] / len), float(s[1] / len), float(s[2] / len)};
    }
    return out;
}

}  // namespace

void Scene::finalize() {
    const auto start = std::chrono::steady_clock::now();
    light_pilot_ = std::make_shared<LightPilot>();
    // (hit records hold an index of 24 bits: kernels/prim_id.h)
    for (const auto& [count, what] :
         {std::pair{spheres.size(), "spheres"}, std::pair{planes.size(), "planes"},
          std::pair{quadrics.size(), "quadrics"}})
        if (count > size_t(kPrimIndexMask))
            throw InputError(source.string() + ": " + std::to_string(count) + " " + what +
                             "; a scene holds at most 16,777,215 of each");
    // Shading normals: every smooth object's geometry has one per vertex (the file's, or
    // area-weighted ones)
    smooth_shading = false;
    for (const Mesh& m : meshes) {
        if (!m.smooth) continue;
        smooth_shading = true;
        Mesh& g = meshes[size_t(m.instanced() ? m.geometry : &m - meshes.data())];
        if (g.normals.empty()) g.normals = area_weighted_normals(g.positions, g.indices);
        if (g.normals.size() != g.positions.size())
            throw InputError(m.source + ": " + std::to_string(g.normals.size()) +
                             " vertex normals for " + std::to_string(g.positions.size()) +
                             " vertices");
    }
    BvhInput in;
    for (size_t i = 0; i < meshes.size(); ++i) {
        Mesh& m = meshes[i];
        if (m.geometry != int32_t(i)) continue;
        auto bvh = std::make_shared<Bvh>();
        bvh->build(m.positions, m.indices, settings.spatial_splits);
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
    in.split_budget = settings.spatial_splits;
    bvh.build(in);
    bvh_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    build_alpha();
    build_emitters();
    build_light_starts();
    light_data.clear();
    for (const PointLight& l : lights)
        light_data.insert(light_data.end(), {l.position.x, l.position.y, l.position.z,
                                             l.intensity.x, l.intensity.y, l.intensity.z});
    build_flat_tables();
}

void Scene::build_alpha() {
    alpha_tables.reset();
    bool any = false;
    for (const Mesh& m : meshes) any |= materials[size_t(m.material)].alpha.masked();
    if (!any) return;
    auto t = std::make_shared<AlphaTables>();
    std::map<int32_t, int32_t> mask_of;    // material → its mask
    std::map<size_t, size_t> geometry_of;  // geometry entry → its copy of uvs and indices
    t->meshes.resize(meshes.size());
    for (size_t i = 0; i < meshes.size(); ++i) {
        const Mesh& m = meshes[i];
        const AlphaSource& a = materials[size_t(m.material)].alpha;
        if (!a.masked()) continue;
        const auto [it, added] = mask_of.try_emplace(m.material, int32_t(t->masks.size()));
        if (added) {
            AlphaMask mask;
            mask.constant = a.constant;
            if (a.image >= 0) {
                const ImageView& v = image_views[size_t(a.image)];
                const std::shared_ptr<const TextureImage>& image = images[size_t(a.image)];
                mask.bytes = v.bytes, mask.floats = v.floats;
                mask.decode = linear_decode_table();  // (a mask is data, never sRGB)
                mask.width = v.width, mask.height = v.height;
                mask.channel = a.channel >= 0 ? a.channel : image->opaque ? 0 : 3;
                std::copy(a.uv_scale, a.uv_scale + 2, mask.uv_scale);
                std::copy(a.uv_offset, a.uv_offset + 2, mask.uv_offset);
                mask.clamp = a.clamp ? 1u : 0u;
                t->images.push_back(image);
            }
            t->masks.push_back(mask);
        }
        MeshAlpha& out = t->meshes[i];
        out.mask = it->second;
        if (a.image < 0) continue;
        const size_t g = m.instanced() ? size_t(m.geometry) : i;
        const auto [copy, fresh] = geometry_of.try_emplace(g, t->uvs.size());
        if (fresh) {
            t->uvs.push_back(meshes[g].uvs);
            t->indices.push_back(meshes[g].indices);
        }
        out.uvs = t->uvs[copy->second].data();  // (a vector's buffer stays where it is
                                                // when the outer vector moves it)
        out.indices = t->indices[copy->second].data();
    }
    t->table = {t->meshes.data(), t->masks.data()};
    alpha_tables = std::move(t);
}

PathContext Scene::pilot_context() const {
    PathContext c;
    const Estimator e = settings.estimator.kind;
    c.emitters = emitters.table();
    c.estimator = settings.estimator;
    c.sampler.kind = settings.estimator.sampler;
    c.sampler.log2_spp = uint32_t(std::bit_width(uint64_t(std::max<int64_t>(settings.spp, 1) - 1)));
    if (c.sampler.kind == Sampler::kPmj02) c.sampler.pmj02 = pmj02_tables();
    c.lt = traits(e).light_batches;
    c.nee = traits(e).samples_emitters && emitters.count() > 0;
    c.lights = light_data.data();
    c.bdpt = bidirectional(e);
    c.unstarted_light = emitters.unsampled_objects > 0 || c.emitters.environment.width > 0;
    c.light_count = c.lt || c.bdpt ? 0 : int32_t(light_data.size() / 6);
    c.scene_ior = scene_ior;
    c.smooth = smooth_shading;
    if (merges(e)) c.estimator.merge_radius = merge_radius();
    return c;
}

bool Scene::needs_light_pilot() const {
    const EstimatorSettings& e = settings.estimator;
    return connects(e.kind) && !(e.connection_count > 0.0f) && e.light_connections > 0;
}

PathContext Scene::path_context() const {
    PathContext c = pilot_context();
    const Estimator e = settings.estimator.kind;
    if (connects(e) && settings.estimator.connection_count > 0.0f) {
        c.connection_count = settings.estimator.connection_count;
    } else if (connects(e) && settings.estimator.light_connections > 0) {
        double kept = 0.0;
        {
            std::lock_guard lock(light_pilot_->mutex);
            const LightPilot::Entry* k = kept_light_pilot(c.estimator);
            if (!k)
                throw std::logic_error(
                    "Scene::path_context: no light pilot for these settings "
                    "(integrators/light_pilot.h, prepare_path_context)");
            kept = k->vertices;
        }
        const double vertices = std::max(kept, kMinLightPilotVertices);
        c.connection_count = float(double(settings.estimator.light_connections) / vertices);
    }
    return c;
}

const Scene::LightPilot::Entry* Scene::kept_light_pilot(const EstimatorSettings& e) const {
    for (const LightPilot::Entry& k : light_pilot_->entries)
        if (k.survival_cap == e.survival_cap && k.cosine_diffuse == e.cosine_diffuse &&
            k.min_length == e.min_length && k.max_length == e.max_length)
            return &k;
    return nullptr;
}

double Scene::light_subpath_vertices(
    const std::function<double(const PathContext&)>& estimate) const {
    const PathContext base = pilot_context();
    const EstimatorSettings& e = base.estimator;
    std::lock_guard lock(light_pilot_->mutex);
    if (const LightPilot::Entry* k = kept_light_pilot(e)) return k->vertices;
    const double vertices = estimate(base);
    light_pilot_->entries.push_back(
        {e.survival_cap, e.cosine_diffuse, e.min_length, e.max_length, vertices});
    return vertices;
}

float Scene::merge_radius() const {
    if (settings.estimator.merge_radius > 0.0f) return settings.estimator.merge_radius;
    // (the box around the bounded primitives and the camera: planes have no size, and the
    // camera's distance is the scale at which the image is seen)
    Vec3f lo = camera.origin, hi = camera.origin;
    if (!bvh.empty()) lo = vmin(lo, bvh.bounds_min()), hi = vmax(hi, bvh.bounds_max());
    const Vec3f d = hi - lo;
    const double half = 0.5 * std::sqrt(double(d.x) * d.x + double(d.y) * d.y + double(d.z) * d.z);
    const double radius = half > 0.0 && half < 1e30 ? half : 1.0;
    return float(kMergeRadiusFraction * radius);
}

double Scene::bounds_radius() const {
    if (!bvh.empty()) {
        const Vec3f d = bvh.bounds_max() - bvh.bounds_min();
        const double half =
            0.5 * std::sqrt(double(d.x) * d.x + double(d.y) * d.y + double(d.z) * d.z);
        if (half > 0.0 && std::isfinite(half)) return half;
    }
    return 1.0;
}

void Scene::set_resolution(int width, int height) {
    settings.width = width;
    settings.height = height;
    if (look_at)
        camera =
            look_at_camera(look_at->position, look_at->target, look_at->up, look_at->vfov_degrees,
                           float(width) / float(height), look_at->handedness);
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
            f.image_textures |= c->kind == TextureKind::kImage;
        }
    }
    for (const Mesh& m : meshes) f.smooth |= m.smooth;
    return f;
}

namespace {

// The scene's planes and unbounded quadrics for the shared loops of kernels/bvh/traverse.h.
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

}  // namespace

bool Scene::intersect(const Ray<float>& ray, float tmax, Hit& hit) const {
    float best = tmax;
    int32_t id = -1;
    closest_unbounded(ray, best, id, int32_t(planes.size()), ScalarPlanes{planes},
                      kPrimPlane << kPrimShift, int32_t(unbounded_quadrics.size()),
                      ScalarQuadrics{quadrics, unbounded_quadrics}, kPrimQuadric << kPrimShift);
    BvhHit tree{};
    const bool in_tree =
        traverse<false, float>(bvh.view(), make_traversal_ray(ray.o, ray.d), best, tree, alpha());
    if (!in_tree && id < 0) return false;

    // Hit point and outward geometric normal
    hit.t = best;
    hit.p = fma(ray.d, best, ray.o);
    hit.mesh = -1;
    hit.sphere = -1;
    hit.plane = false;
    const auto quadric = [&](size_t index) {
        hit.n = normalize(quadric_gradient(quadrics[index].q, hit.p));
        hit.material = quadrics[index].material;
    };
    if (!in_tree) {
        if (id >> kPrimShift == kPrimQuadric) {
            quadric(size_t(id & kPrimIndexMask));
        } else {
            const size_t i = size_t(id & kPrimIndexMask);
            hit.n = {planes.nx[i], planes.ny[i], planes.nz[i]};
            hit.material = planes.material[i];
            hit.plane = true;
        }
        hit.ns = hit.n;
        return true;
    }
    const BvhView& v = bvh.view();
    switch (tree.kind) {
        case kLeafSpheres: {
            const size_t i = hit_sphere(v, tree);
            hit.sphere = int32_t(i);
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
            const Mesh& object = meshes[size_t(hit.mesh)];
            hit.material = object.material;
            hit.ns = object.smooth ? shading_normal(object, hit) : hit.n;
            return true;
        }
    }
    hit.ns = hit.n;
    return true;
}

Vec3f Scene::shading_normal(const Mesh& object, const Hit& hit) const {
    const Mesh& g = geometry_of(object);
    const uint32_t* idx = &g.indices[size_t(hit.triangle) * 3];
    const Vec3f v[3] = {g.positions[idx[0]], g.positions[idx[1]], g.positions[idx[2]]};
    const Vec3f vn[3] = {g.normals[idx[0]], g.normals[idx[1]], g.normals[idx[2]]};
    // (an instance's vertices and normals are in the file's space: so is the point)
    const float p[3] = {hit.p.x, hit.p.y, hit.p.z};
    const Vec3f at = object.instanced() ? affine_point(object.to_object, p) : hit.p;
    const Vec3f n = interpolate_normal(v, vn, at, Vec3f(0.0f));
    if (n.x == 0.0f && n.y == 0.0f && n.z == 0.0f) return hit.n;
    if (!object.instanced()) return n;
    const float c[3] = {n.x, n.y, n.z};
    const Vec3f w = linear_map(object.normal_to_world, 3, c);
    const float len = length(w);
    return len > 0.0f && std::isfinite(len) ? w * (1.0f / len) : hit.n;
}

bool Scene::occluded(const Ray<float>& ray, float tmax) const {
    if (occluded_unbounded(ray, tmax, false, int32_t(planes.size()), ScalarPlanes{planes},
                           int32_t(unbounded_quadrics.size()),
                           ScalarQuadrics{quadrics, unbounded_quadrics}))
        return true;
    BvhHit unused;
    float t = tmax;
    return traverse<true, float>(bvh.view(), make_traversal_ray(ray.o, ray.d), t, unused, alpha());
}

int32_t Scene::add_image(std::shared_ptr<const TextureImage> image) {
    ImageView view;
    if (image->floats.empty()) {
        view.bytes = image->bytes.data();
        view.decode = image->srgb ? srgb_decode_table() : linear_decode_table();
    } else {
        view.floats = image->floats.data();
    }
    view.width = image->width, view.height = image->height;
    images.push_back(std::move(image));
    image_views.push_back(view);
    return int32_t(images.size() - 1);
}

void Scene::hit_uv(const Hit& hit, float& u, float& v) const {
    u = v = 0.0f;
    if (hit.sphere >= 0) return sphere_uv(hit.n, u, v);
    if (hit.plane) return plane_uv(hit.n, hit.p, u, v);
    if (hit.mesh < 0) return;
    const Mesh& object = meshes[size_t(hit.mesh)];
    const Mesh& m = geometry_of(object);
    if (m.uvs.empty()) return;
    const uint32_t* idx = &m.indices[size_t(hit.triangle) * 3];
    const Vec3f corner[3] = {m.positions[idx[0]], m.positions[idx[1]], m.positions[idx[2]]};
    // (an instance's vertices are in the file's space: so is the point)
    const float p[3] = {hit.p.x, hit.p.y, hit.p.z};
    const Vec3f at = object.instanced() ? affine_point(object.to_object, p) : hit.p;
    float b[3];
    barycentrics(corner, at, b[0], b[1], b[2]);
    for (int k = 0; k < 3; ++k) {
        u = std::fma(m.uvs[2 * size_t(idx[k])], b[k], u);
        v = std::fma(m.uvs[2 * size_t(idx[k]) + 1], b[k], v);
    }
}

Vec3f Scene::color_at(const ColorSource& c, const Hit& hit) const {
    if (c.kind == TextureKind::kImage) {
        float u, v;
        hit_uv(hit, u, v);
        const Texel<float> t = sample_image(image_views[size_t(c.image)], c, u, v);
        return t.rgb * c.a;
    }
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
    return {color_at(m.kd, hit), color_at(m.ks, hit), color_at(m.kr, hit),
            color_at(m.kt, hit), m.shininess,         m.ior};
}

Vec3f Scene::emission_at(const Hit& hit) const {
    return color_at(materials[size_t(hit.material)].emission, hit);
}

}  // namespace cierzo
