// Scene set-up (BVHs, feature set) and the scalar closest-hit and shadow queries: the
// unbounded primitives and the scene BVH through the shared traversal (kernels/bvh/traverse.h)
// with T = float.
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
#include "scene/flat_tables.h"
#include "scene/pmj02.h"

namespace cierzo {

Camera look_at_camera(const Vec3f& position, const Vec3f& target, const Vec3f& up_hint,
                      float vfov_degrees, float aspect, Handedness hand) {
    const Vec3f f = normalize(target - position);
    const Vec3f right = hand == Handedness::kLeft ? normalize(cross(up_hint, f))
                                                  : normalize(cross(f, up_hint));
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
    for (const auto& [count, what] : {std::pair{spheres.size(), "spheres"},
                                      std::pair{planes.size(), "planes"},
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
    flat_tables = build_flat_tables(*this);
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
    c.lt = e == Estimator::kLt;
    c.nee = (e == Estimator::kNee || e == Estimator::kMis) && emitters.count() > 0;
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
                throw std::logic_error("Scene::path_context: no light pilot for these settings "
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
        const double half = 0.5 * std::sqrt(double(d.x) * d.x + double(d.y) * d.y + double(d.z) * d.z);
        if (half > 0.0 && std::isfinite(half)) return half;
    }
    return 1.0;
}

void Scene::build_light_starts() {
    LightStarts& ls = light_starts;
    ls = LightStarts{};
    // The medium around each point light: a ray from it whose first hit is a refractive
    // object seen from inside puts the light in that object. A light's intensity is the one
    // it has in its own medium (as for a physical light; a point light at the centre of a
    // glass ball lights the room around the ball with its I); the report's radiance, which
    // refraction keeps as it is, is that of the scene's medium, so its paths start with
    // (η_scene/η)² (kernels/estimator.h, Transport).
    std::vector<double> power;
    for (const PointLight& l : lights) {
        float ior = scene_ior;
        Hit hit;
        const Vec3f probe = normalize(Vec3f{0.267f, 0.873f, 0.408f});
        if (intersect({l.position, probe}, kRayFar, hit)) {
            const Material& m = materials[size_t(hit.material)];
            if (!m.kt.is_zero() && !m.is_emitter() && dot(probe, hit.n) > 0.0f) ior = m.ior;
        }
        ls.medium_ior.push_back(ior);
        const double scale = double(scene_ior / ior) * double(scene_ior / ior);
        const double p = 4.0 * double(kPi) * double(max_component(l.intensity)) * scale;
        power.push_back(std::isfinite(p) && p > 0.0 ? p : 0.0);
    }
    double point_power = 0.0;
    for (double p : power) point_power += p;
    const double emitter_power = 2.0 * double(kPi) * emitters.total_power;
    ls.total_power = point_power + emitter_power;
    if (!(ls.total_power > 0.0) || !std::isfinite(ls.total_power)) {
        ls.total_power = 0.0;
        return;
    }
    ls.emitter_probability = float(emitter_power / ls.total_power);
    if (!(point_power > 0.0)) {
        ls.emitter_probability = 1.0f;
        return;
    }
    if (emitter_power > 0.0 && ls.emitter_probability >= 1.0f) ls.emitter_probability = 0x1.fffffep-1f;
    // P(point lights) as the sampler computes it, from the float probability
    const double p_points = 1.0 - double(ls.emitter_probability);
    double cumulative = 0.0;
    for (size_t i = 0; i < lights.size(); ++i) {
        if (!(power[i] > 0.0)) continue;
        cumulative += power[i];
        ls.point_cdf.push_back(float(cumulative / point_power));
        const double pmf = power[i] / point_power;
        const double scale = double(scene_ior / ls.medium_ior[i]) *
                             double(scene_ior / ls.medium_ior[i]) / (p_points * pmf);
        const PointLight& l = lights[i];
        ls.point.insert(ls.point.end(),
                        {l.position.x, l.position.y, l.position.z, float(l.intensity.x * scale),
                         float(l.intensity.y * scale), float(l.intensity.z * scale)});
        ls.point_source.insert(ls.point_source.end(), {l.intensity.x, l.intensity.y, l.intensity.z,
                                                       float(p_points * pmf)});
    }
    ls.point_cdf.back() = 1.0f;
}

namespace {

// Vose's alias table for weights w (all > 0): q[i], alias[i] such that picking a slot
// uniformly, keeping it with probability q, else taking its alias, chooses i with
// probability w[i] / Σw.
void build_alias(const std::vector<double>& w, std::vector<float>& q,
                 std::vector<int32_t>& alias) {
    const size_t n = w.size();
    double total = 0.0;
    for (double x : w) total += x;
    std::vector<double> scaled(n);
    std::vector<int32_t> small, large;
    for (size_t i = 0; i < n; ++i) {
        scaled[i] = w[i] * double(n) / total;
        (scaled[i] < 1.0 ? small : large).push_back(int32_t(i));
    }
    q.assign(n, 1.0f);
    alias.resize(n);
    for (size_t i = 0; i < n; ++i) alias[i] = int32_t(i);
    while (!small.empty() && !large.empty()) {
        const int32_t s = small.back(), l = large.back();
        small.pop_back();
        q[size_t(s)] = float(scaled[size_t(s)]);
        alias[size_t(s)] = l;
        scaled[size_t(l)] -= 1.0 - scaled[size_t(s)];
        if (scaled[size_t(l)] < 1.0) {
            large.pop_back();
            small.push_back(l);
        }
    }
    // (what is left is 1 up to rounding: kept with probability 1)
}

// Two triangles (corners c[0..2] and c[3..5]) that are the halves of one rectangle: they share
// two corners (a diagonal), and the corners a and b they do not share make a parallelogram
// with it (a + b = the diagonal's ends' sum) with a right angle at a; within 10^-5 of the
// rectangle's size.
struct RectangleEmitter {
    Vec3f corner, e1, e2;
};
bool find_rectangle(const Vec3f (&c)[6], RectangleEmitter& r) {
    int shared_a[2], shared_b[2], n = 0;
    for (int i = 0; i < 3; ++i)
        for (int j = 3; j < 6; ++j)
            if (c[i].x == c[j].x && c[i].y == c[j].y && c[i].z == c[j].z) {
                if (n == 2) return false;
                shared_a[n] = i, shared_b[n] = j, ++n;
            }
    if (n != 2) return false;
    const int a = 3 - shared_a[0] - shared_a[1];
    int b = 3;
    while (b == shared_b[0] || b == shared_b[1]) ++b;
    const Vec3f s1 = c[shared_a[0]], s2 = c[shared_a[1]];
    const Vec3f e1 = s1 - c[a], e2 = s2 - c[a];
    const float l1 = length(e1), l2 = length(e2);
    if (!(l1 > 0.0f && l2 > 0.0f) || !std::isfinite(l1 * l2)) return false;
    const float size = std::max(l1, l2);
    if (length(c[a] + c[b] - s1 - s2) > 1e-5f * size) return false;
    if (std::abs(dot(e1, e2)) > 1e-5f * l1 * l2) return false;
    r = {c[a], e1, e2};
    return true;
}

}  // namespace

// The environment's tables (kernels/emitter_table.h, EnvironmentMap): radiance per texel,
// and the distribution of max RGB · sin θ over texels. A solid colour is one column of 64
// rows (the density then follows sin θ row by row).
void Scene::build_environment() {
    Emitters& e = emitters;
    e.environment_width = e.environment_height = 0;
    e.environment_id = -1;
    e.environment_mean = 0.0;
    if (!environment.present()) return;
    const ColorSource& c = environment.emission;
    int32_t w = 1, h = 64;
    std::vector<float>& rad = e.environment_radiance;
    if (c.kind == TextureKind::kImage) {
        const TextureImage& im = *images[size_t(c.image)];
        w = im.width, h = im.height;
        rad.resize(size_t(w) * size_t(h) * 3);
        const float* decode = im.srgb ? srgb_decode_table() : linear_decode_table();
        for (size_t i = 0; i < im.texels(); ++i)
            for (size_t k = 0; k < 3; ++k) {
                const float v = im.floats.empty()
                                    ? decode[(uint32_t(im.bytes[i]) >> (8 * k)) & 255u]
                                    : im.floats[4 * i + k];
                rad[3 * i + k] = v * c.a[int(k)];
            }
    } else {
        rad.resize(size_t(h) * 3);
        for (size_t i = 0; i < size_t(h); ++i)
            for (int k = 0; k < 3; ++k) rad[3 * i + size_t(k)] = c.a[k];
    }
    e.environment_width = w, e.environment_height = h;
    std::copy(environment.to_world, environment.to_world + 9, e.environment_to_world);
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) e.environment_to_local[3 * i + j] = environment.to_world[3 * j + i];
    // f = max RGB · sin θ at each row's centre; rows by their sums, columns within a row
    std::vector<double> f(size_t(w) * size_t(h)), row_sum(size_t(h), 0.0);
    double total = 0.0, mean = 0.0;
    for (int32_t y = 0; y < h; ++y) {
        const double t0 = kPi * double(y) / h, t1 = kPi * double(y + 1) / h;
        const double sin_c = std::sin(0.5 * (t0 + t1));
        const double omega = 2.0 * kPi / w * (std::cos(t0) - std::cos(t1));  // a texel's
        for (int32_t x = 0; x < w; ++x) {
            const size_t i = size_t(y) * size_t(w) + size_t(x);
            const double m = std::max({rad[3 * i], rad[3 * i + 1], rad[3 * i + 2]});
            f[i] = m * sin_c;
            row_sum[size_t(y)] += f[i];
            mean += m * omega;
        }
        total += row_sum[size_t(y)];
    }
    e.environment_mean = mean / (4.0 * kPi);
    e.environment_row_cdf.assign(size_t(h) + 1, 0.0f);
    e.environment_col_cdf.assign(size_t(h) * (size_t(w) + 1), 0.0f);
    e.environment_density.assign(size_t(w) * size_t(h), 0.0f);
    if (!(total > 0.0) || !std::isfinite(total)) return;  // (black: nothing to sample)
    double run = 0.0;
    for (int32_t y = 0; y < h; ++y) {
        run += row_sum[size_t(y)];
        e.environment_row_cdf[size_t(y) + 1] = y + 1 == h ? 1.0f : float(run / total);
        float* cdf = &e.environment_col_cdf[size_t(y) * (size_t(w) + 1)];
        double in_row = 0.0;
        for (int32_t x = 0; x < w; ++x) {
            const size_t i = size_t(y) * size_t(w) + size_t(x);
            in_row += f[i];
            cdf[x + 1] = x + 1 == w ? 1.0f
                         : row_sum[size_t(y)] > 0.0 ? float(in_row / row_sum[size_t(y)])
                                                    : float(x + 1) / float(w);
            e.environment_density[i] = float(f[i] / total * double(w) * double(h));
        }
    }
}

void Scene::build_emitters() {
    Emitters& e = emitters;
    e = Emitters{};
    build_environment();
    std::vector<double> power;
    std::vector<size_t> rectangles;  // the first entry of each
    const auto add = [&](EmitterKind kind, const float (&record)[kEmitterStride], double p) {
        e.kind.push_back(kind);
        e.data.insert(e.data.end(), record, record + kEmitterStride);
        power.push_back(p);
    };
    const auto solid_emission = [&](int32_t material, Vec3f& le) {
        const ColorSource& c = materials[size_t(material)].emission;
        le = c.a;
        return c.kind == TextureKind::kSolid && max_component(c.a) > 0.0f;
    };
    const auto emits = [&](int32_t material) { return materials[size_t(material)].is_emitter(); };
    e.sphere_id.assign(spheres.size(), -1);
    for (size_t i = 0; i < spheres.size(); ++i) {
        Vec3f le;
        const float r = spheres.radius[i];
        if (!emits(spheres.material[i])) continue;
        const double area = 4.0 * double(kPi) * double(r) * double(r);
        if (!solid_emission(spheres.material[i], le) || !(area > 0.0) || !std::isfinite(area)) {
            ++e.unsampled_objects;
            continue;
        }
        e.sphere_id[i] = int32_t(e.kind.size());
        const float record[kEmitterStride] = {spheres.cx[i], spheres.cy[i], spheres.cz[i], r, 0,
                                              0, 0, 0, 0, 0, 0, 0, 0, le.x, le.y, le.z};
        add(kEmitterSphere, record, area * double(max_component(le)));
        ++e.sampled_objects;
    }
    e.mesh_first.assign(meshes.size(), -1);
    for (size_t i = 0; i < meshes.size(); ++i) {
        const Mesh& m = meshes[i];
        Vec3f le;
        if (!emits(m.material)) continue;
        // (a cut-out emitter is found by the paths that hit it, never sampled: its holes
        // would make the area a sample lands on differ from the one that emits)
        if (!solid_emission(m.material, le) || materials[size_t(m.material)].alpha.masked()) {
            ++e.unsampled_objects;
            continue;
        }
        const Mesh& g = geometry_of(m);
        const auto world = [&](const Vec3f& v) {
            if (!m.instanced()) return v;
            const float* a = m.to_world;
            return Vec3f{a[0] * v.x + a[1] * v.y + a[2] * v.z + a[3],
                         a[4] * v.x + a[5] * v.y + a[6] * v.z + a[7],
                         a[8] * v.x + a[9] * v.y + a[10] * v.z + a[11]};
        };
        e.mesh_first[i] = int32_t(e.kind.size());
        for (size_t t = 0; t < g.triangle_count(); ++t) {
            const Vec3f v0 = world(g.positions[g.indices[3 * t]]);
            const Vec3f e1 = world(g.positions[g.indices[3 * t + 1]]) - v0;
            const Vec3f e2 = world(g.positions[g.indices[3 * t + 2]]) - v0;
            const Vec3f c = cross(e1, e2);
            const float twice = length(c);
            // (a degenerate triangle keeps its slot, with no power: it is never chosen)
            const Vec3f n = twice > 0.0f ? c * (1.0f / twice) : Vec3f(0.0f, 0.0f, 1.0f);
            const float record[kEmitterStride] = {v0.x, v0.y, v0.z, 0.5f * twice, e1.x, e1.y,
                                                  e1.z, e2.x, e2.y,  e2.z,        n.x,  n.y,
                                                  n.z,  le.x, le.y,  le.z};
            const double area = 0.5 * double(twice);
            add(kEmitterTriangle, record,
                std::isfinite(area) ? area * double(max_component(le)) : 0.0);
        }
        // Consecutive triangles that make a rectangle (the two halves of a quad) become one
        // rectangle, sampled as a whole (kernels/emitter_table.h)
        const size_t first = size_t(e.mesh_first[i]);
        for (size_t t = 0; t + 1 < g.triangle_count(); ++t) {
            Vec3f c[6];
            for (int k = 0; k < 6; ++k) c[k] = world(g.positions[g.indices[3 * t + size_t(k)]]);
            RectangleEmitter r;
            if (!find_rectangle(c, r)) continue;
            const Vec3f n = normalize(cross(r.e1, r.e2));
            const float area = length(cross(r.e1, r.e2));
            const float record[kEmitterStride] = {r.corner.x, r.corner.y, r.corner.z, area,
                                                  r.e1.x,     r.e1.y,     r.e1.z,     r.e2.x,
                                                  r.e2.y,     r.e2.z,     n.x,        n.y,
                                                  n.z,        le.x,       le.y,       le.z};
            for (size_t k : {first + t, first + t + 1}) {
                e.kind[k] = kEmitterRectangle;
                std::copy(record, record + kEmitterStride, e.data.begin() + ptrdiff_t(k * kEmitterStride));
            }
            power[first + t] = std::isfinite(area) ? double(area) * double(max_component(le)) : 0.0;
            power[first + t + 1] = 0.0;
            rectangles.push_back(first + t);
            ++t;
        }
        ++e.sampled_objects;
    }
    for (size_t i = 0; i < planes.size(); ++i) e.unsampled_objects += emits(planes.material[i]);
    for (const Quadric& q : quadrics) e.unsampled_objects += emits(q.material);
    // The environment, by π·R²·L̄ (R the radius of the scene's bounds)
    if (e.environment_mean > 0.0 && std::isfinite(e.environment_mean)) {
        const double radius = bounds_radius();
        const float record[kEmitterStride] = {};
        e.environment_id = int32_t(e.kind.size());
        add(kEmitterEnvironment, record, kPi * radius * radius * e.environment_mean);
        ++e.sampled_objects;
    }
    for (double p : power) e.total_power += p;
    if (!(e.total_power > 0.0) || !std::isfinite(e.total_power)) {
        // Nothing to sample (or a power that overflows): every emitter keeps the report's
        // estimator
        e.unsampled_objects += e.sampled_objects;
        const size_t unsampled = e.unsampled_objects;
        e = Emitters{};
        build_environment();  // (gathered by escaping paths, not sampled)
        e.sphere_id.assign(spheres.size(), -1);
        e.mesh_first.assign(meshes.size(), -1);
        e.unsampled_objects = unsampled;
        return;
    }
    e.pmf.resize(power.size());
    for (size_t i = 0; i < power.size(); ++i) e.pmf[i] = float(power[i] / e.total_power);
    // (a hit on a rectangle's second triangle has the rectangle's probability)
    for (size_t k : rectangles) e.pmf[k + 1] = e.pmf[k];
    build_alias(power, e.alias_q, e.alias);
}

void Scene::set_resolution(int width, int height) {
    settings.width = width;
    settings.height = height;
    if (look_at)
        camera = look_at_camera(look_at->position, look_at->target, look_at->up,
                                look_at->vfov_degrees, float(width) / float(height),
                                look_at->handedness);
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
    return traverse<true, float>(bvh.view(), make_traversal_ray(ray.o, ray.d), t, unused,
                                 alpha());
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
    return {color_at(m.kd, hit), color_at(m.ks, hit), color_at(m.kr, hit), color_at(m.kt, hit),
            m.shininess, m.ior};
}

Vec3f Scene::emission_at(const Hit& hit) const {
    return color_at(materials[size_t(hit.material)].emission, hit);
}

}  // namespace cierzo
