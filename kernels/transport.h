// Paths from the lights (light tracing, --estimator lt), written once for both integrators
// (T = float for the scalar reference, T = xsimd::batch for the wavefront kernels):
//   - the start: a light chosen by power, a point and a direction leaving it, and the
//     throughput β they carry (kernels/light_sampling.h samples each part);
//   - the camera connection: where a vertex lands on the film and what it adds there (a
//     shadow ray to the pinhole decides whether it does);
//   - importance transport at a vertex: the roulette and the lobes of kernels/estimator.h in
//     importance mode (Transport::kImportance: the refraction's η², and the shading normals'
//     correction).
//
// The image an estimator from the lights makes is the same measurement as the camera's:
// pixel j's value is (1/N) Σ over N light paths of every vertex's connection to the pinhole,
// β·f·|cos θx|·We_j·cos θc / d², with the pinhole's importance We_j = W·H / (A·cos⁴θc) for
// the directions through pixel j (kernels/camera.h). A render traces N = W·H·spp light
// paths (one per camera path it would have traced), so each connection adds
// β·f·|cos θx| / (A·cos³θc·d²) to its pixel's sum, which the film divides by spp.
#pragma once

#include "camera.h"
#include "light_sampling.h"
#include "sampler.h"

namespace cierzo {
inline namespace CIERZO_ISA_NAMESPACE {

inline PinholeFrame pinhole_frame(const Vec3f& origin, const Vec3f& forward, const Vec3f& left,
                                  const Vec3f& up, int width, int height) {
    PinholeFrame f;
    const Vec3f n = pinhole_film_normal(forward, left, up);
    for (int k = 0; k < 3; ++k) {
        f.origin[k] = origin[k], f.forward[k] = forward[k], f.left[k] = left[k];
        f.up[k] = up[k], f.film_normal[k] = n[k];
    }
    f.width = float(width), f.height = float(height);
    f.film_area = pinhole_film_area(forward, left, up);
    return f;
}

// A point's connection to the pinhole: the unit direction to it and the distance, the pixel
// it lands in, and the factor 1 / (A·cos³θc·d²) of its contribution (see above). Not ok
// behind the camera, off the film, or where the factor is not finite.
template <class T>
struct CameraConnection {
    Vec3<T> wc;
    T dist;
    I32<T> pixel;
    T factor;
    Mask<T> ok;
};

template <class T>
CameraConnection<T> connect_camera(const PinholeFrame& c, const Vec3<T>& p) {
    CameraConnection<T> out;
    const auto v3 = [](const float* a) { return Vec3f{a[0], a[1], a[2]}; };
    const Vec3f origin = v3(c.origin);
    const Vec3<T> to = Vec3<T>(origin) - p;
    const T d2 = dot(to, to);
    out.dist = sqrt(d2);
    out.wc = to * (T(1.0f) / out.dist);
    const FilmPoint<T> fp =
        pinhole_project(origin, v3(c.forward), v3(c.left), v3(c.up), p, c.width, c.height);
    const T cos_c = -dot(out.wc, Vec3<T>(v3(c.film_normal)));
    out.factor = T(1.0f / c.film_area) / (cos_c * cos_c * cos_c * d2);
    out.ok = fp.on_film & (cos_c > T(0.0f)) & (d2 > T(0.0f)) & (out.factor < T(kRayFar));
    const T sx = select(out.ok, fp.sx, T(0.0f)), sy = select(out.ok, fp.sy, T(0.0f));
    const I32<T> x = min(to_int(sx), I32<T>(int32_t(c.width) - 1));
    const I32<T> y = min(to_int(sy), I32<T>(int32_t(c.height) - 1));
    out.pixel = y * I32<T>(int32_t(c.width)) + x;
    return out;
}

// The start of a light path: the point and, for an emitter, its normal, Le over the point's
// density (what a connection of the point itself carries before f, cosine and camera), the
// direction leaving it and the throughput along that direction.
template <class T>
struct LightStart {
    Vec3<T> p, n;
    Vec3<T> le;  // Le / (P(emitter)·pdf_A); 0 for a point light (never seen by the camera)
    Vec3<T> dir;
    Vec3<T> beta;  // Le·|cos θ| / (P·pdf_A·pdf_ω) = 2π·Le / (P·pdf_A); or 4π·I / P
    Mask<T> ok;
    Mask<T> on_surface;  // an emitter (else a point light)
    // For the bidirectional estimators' weights: the emitter (-1: a point light), the density
    // of the whole start, P·pdf_A·pdf_ω (a point light: P·pdf_ω), and |cos θ| at the emitter
    I32<T> emitter;
    T pdf_emit, cos_light;
};

// The random numbers of a light path's start, drawn at bounce 0 with the camera path's
// purposes: kLobe picks emitters or point lights, kEmitterPick the one (and its alias slot),
// kEmitter1/2 the point, kDirection1/2 the direction.
template <class T>
LightStart<T> sample_light_start(const EmitterTable& e, const LightStartTable& lights,
                                 const SampleStream<T>& rng) {
    using I = I32<T>;
    const U32<T> b0(0u);
    LightStart<T> out;
    const T u_kind = uniform<T>(rng, b0, Purpose::kLobe);
    out.on_surface = u_kind < T(lights.emitter_probability);
    T u1, u2;
    uniform2<T>(rng, b0, Purpose::kDirection1, u1, u2);
    out.p = out.n = out.le = out.dir = out.beta = Vec3<T>(T(0.0f));
    out.ok = out.on_surface & !out.on_surface;
    out.emitter = I(-1);
    out.pdf_emit = out.cos_light = T(1.0f);
    if (e.count > 0 && any(out.on_surface)) {
        T u_pick(0.0f), u_alias(0.0f), u3, u4;
        if (e.count > 1) uniform_pair<T>(rng, b0, Purpose::kEmitterPick, u_pick, u_alias);
        uniform2<T>(rng, b0, Purpose::kEmitter1, u3, u4);
        const EmitterPosition<T> ep = sample_emitter_position(e, u_pick, u_alias, u3, u4);
        const EmittedDirection<T> ed = sample_emitted_direction(ep.n, u1, u2);
        const T inv = T(1.0f) / (ep.pdf * T(lights.emitter_probability));
        const auto ok = out.on_surface & ep.ok & (ed.cos_theta > T(0.0f)) & (inv < T(kRayFar));
        out.p = select(ok, ep.p, out.p);
        out.n = select(ok, ep.n, out.n);
        out.le = select(ok, ep.le * inv, out.le);
        out.dir = select(ok, ed.dir, out.dir);
        out.beta = select(ok, ep.le * (inv * T(2.0f * kPi)), out.beta);
        out.ok = ok;
        out.emitter = select(mask_i32(ok), ep.id, out.emitter);
        out.pdf_emit = select(ok, ep.pdf * T(lights.emitter_probability) * ed.pdf, out.pdf_emit);
        out.cos_light = select(ok, ed.cos_theta, out.cos_light);
    }
    const auto point = !out.on_surface;
    if (lights.point_count > 0 && any(point)) {
        // The point light whose cumulative probability u first stays below (few lights: a scan)
        const T u = (u_kind - T(lights.emitter_probability)) / T(1.0f - lights.emitter_probability);
        I id(0);
        for (int32_t j = 0; j + 1 < lights.point_count; ++j)
            id = id + select(mask_i32(u >= T(lights.point_cdf[j])), I(1), I(0));
        const auto at = [&](int k) {
            return lights.point_count == 1 ? T(lights.point[k])
                                           : gather_table(lights.point, id * I(6) + I(k));
        };
        const PointLightDirection<T> pd = sample_point_light_direction(u1, u2);
        out.p = select(point, Vec3<T>{at(0), at(1), at(2)}, out.p);
        out.dir = select(point, pd.dir, out.dir);
        out.beta = select(point, Vec3<T>{at(3), at(4), at(5)} * (T(1.0f) / pd.pdf), out.beta);
        out.ok = out.ok | point;
        if (lights.point_source) {
            const T chosen = lights.point_count == 1
                                 ? T(lights.point_source[3])
                                 : gather_table(lights.point_source, id * I(4) + I(3));
            out.pdf_emit = select(point, chosen * pd.pdf, out.pdf_emit);
        }
    }
    return out;
}

// The shading normal's correction of a light path's throughput (Veach 1997, §5.3): the
// camera-path estimators take the cosine of the direction towards the light about the
// shading normal ns; a path from the lights, which arrives from wl (unit, towards the
// previous vertex) and leaves along wo, carries |wl·ns|·|wo·n| / (|wl·n|·|wo·ns|) more than
// the lobe's weight (itself written with |wo·ns|) so that both estimate the same image. 1 with
// ns = n; 0 where a cosine about n is 0.
template <class T>
T shading_correction(const Vec3<T>& wl, const Vec3<T>& wo, const Vec3<T>& n, const Vec3<T>& ns) {
    const T num = abs(dot(wl, ns)) * abs(dot(wo, n));
    const T den = abs(dot(wl, n)) * abs(dot(wo, ns));
    return select(den > T(0.0f), num / den, T(0.0f));
}

// What a Phong vertex of a light path adds to the pixel it projects to, if the shadow ray to
// the pinhole is clear: β·f(wl, wc)·|wc·n|·factor (with the shading correction, where the
// scene has smooth meshes: |wc·ns| in f_cos, then |wl·ns|·|wc·n| / (|wl·n|·|wc·ns|)). d is
// the direction the path arrived along, nf the geometric normal on that side, nsf the
// shading normal turned to it. Zero where the pinhole is not on the side the light came from.
template <class T>
Vec3<T> camera_contribution(const Bsdf<T>& m, const Vec3<T>& beta, const Vec3<T>& d,
                            const Vec3<T>& nf, const Vec3<T>& nsf, const CameraConnection<T>& c,
                            bool shading) {
    Vec3<T> v = beta * phong_f_cos(m, d, nsf, c.wc) * c.factor;
    if (shading)
        v = v * select(dot(c.wc, nf) > T(0.0f), shading_correction(-d, c.wc, nf, nsf), T(0.0f));
    return v;
}

}  // namespace CIERZO_ISA_NAMESPACE
}  // namespace cierzo
