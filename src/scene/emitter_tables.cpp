// The scene's light tables, built by Scene::finalize: the emitters next-event estimation
// samples (a power-weighted alias table over spheres, triangles, rectangles and the
// environment, kernels/emitter_table.h) and where paths from the lights start (LightStarts).
#include "scene/scene.h"

#include <algorithm>
#include <cmath>
#include <vector>

namespace cierzo {

void Scene::build_light_starts() {
    LightStarts& ls = light_starts;
    ls = LightStarts{};
    // The medium around each point light: a ray from it whose first hit is a refractive
    // object seen from inside puts the light in that object. A light's intensity is the one
    // it has in its own medium (as for a physical light; a point light at the centre of a
    // glass ball lights the room around the ball with its I); the report's radiance, which
    // refraction keeps as it is, is that of the scene's medium, so its paths start with
    // (η_scene/η)² (kernels/bsdf.h, Transport).
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
    if (emitter_power > 0.0 && ls.emitter_probability >= 1.0f)
        ls.emitter_probability = 0x1.fffffep-1f;
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
void build_alias(const std::vector<double>& w, std::vector<float>& q, std::vector<int32_t>& alias) {
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
        for (int j = 0; j < 3; ++j)
            e.environment_to_local[3 * i + j] = environment.to_world[3 * j + i];
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
            cdf[x + 1] = x + 1 == w                 ? 1.0f
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
    const auto add = [&](EmitterKind kind, const float(&record)[kEmitterStride], double p) {
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
        const float record[kEmitterStride] = {
            spheres.cx[i], spheres.cy[i], spheres.cz[i], r, 0, 0, 0, 0, 0, 0, 0, 0, 0,
            le.x,          le.y,          le.z};
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
                                                  e1.z, e2.x, e2.y, e2.z,         n.x,  n.y,
                                                  n.z,  le.x, le.y, le.z};
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
            const float record[kEmitterStride] = {
                r.corner.x, r.corner.y, r.corner.z, area, r.e1.x, r.e1.y, r.e1.z, r.e2.x,
                r.e2.y,     r.e2.z,     n.x,        n.y,  n.z,    le.x,   le.y,   le.z};
            for (size_t k : {first + t, first + t + 1}) {
                e.kind[k] = kEmitterRectangle;
                std::copy(record, record + kEmitterStride,
                          e.data.begin() + ptrdiff_t(k * kEmitterStride));
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

}  // namespace cierzo
