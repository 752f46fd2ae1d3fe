// embree_pt: cierzo's report estimator on Embree 3, as a measured peer. It reads a scene with
// cierzo's own reader (same geometry, camera, materials and settings), traces every ray one
// at a time with rtcIntersect1 on one thread, and prints `key: value` lines. Only
// triangle-only diffuse scenes lit by emitters are accepted: for those it does the same work
// as cierzo's estimator (kernels/estimator.h), so the two image means agree in expectation.
//
//   embree_pt SCENE.json [--spp N] [--width W --height H] [--out image.pfm]
//   embree_pt SCENE.json --dump-rays FILE --count N     extension rays to a file
//   embree_pt SCENE.json --trace-rays FILE [--repeat R] [--api 1|16|1M]
//                                   time Embree alone over them, through one of its APIs:
//                                   rtcIntersect1 (default), rtcIntersect16 (the file's rays
//                                   in groups of 16, as they come) or the stream API
//                                   rtcIntersect1M (groups of 1024, incoherent)
//
// Any option may also be followed by --embree-config STRING, given to rtcNewDevice as is
// (e.g. "verbose=1" or "isa=sse4.2"); "threads=1" is always added in front of it; and by
// --quality low|medium|high, the build quality (default high).
#include <embree3/rtcore.h>
#if defined(__SSE__)
#include <pmmintrin.h>
#include <xmmintrin.h>
#endif

#include <algorithm>
#include <iterator>
#include <bit>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <string>
#include <utility>
#include <vector>

#include "core/error.h"
#include "io/image.h"
#include "scene/scene_json.h"

using namespace cierzo;

namespace {

// ---- The scene's triangles ------------------------------------------------------------
// Every mesh's world-space triangles in one vertex/index array, and each triangle's
// material. The only place that reads cierzo's Mesh, so a change to it (e.g. an
// object-to-world transform or shared vertices) is adapted here alone.
struct Triangles {
    std::vector<Vec3f> positions;
    std::vector<uint32_t> indices;  // 3 per triangle, into positions
    std::vector<int32_t> material;  // 1 per triangle, into Scene::materials
};

Triangles collect_triangles(const Scene& scene) {
    Triangles t;
    for (const Mesh& m : scene.meshes) {
        // An object sharing a mesh file is put into world space through its transform:
        // Embree then traces one flat BVH, its fastest layout
        const Mesh& g = scene.geometry_of(m);
        const auto base = uint32_t(t.positions.size());
        for (const Vec3f& p : g.positions) {
            if (!m.instanced()) {
                t.positions.push_back(p);
                continue;
            }
            const float* a = m.to_world;
            t.positions.push_back({a[0] * p.x + a[1] * p.y + a[2] * p.z + a[3],
                                   a[4] * p.x + a[5] * p.y + a[6] * p.z + a[7],
                                   a[8] * p.x + a[9] * p.y + a[10] * p.z + a[11]});
        }
        for (uint32_t i : g.indices) t.indices.push_back(base + i);
        t.material.insert(t.material.end(), g.triangle_count(), m.material);
    }
    return t;
}

// Empty if the estimator below is cierzo's for this scene; otherwise the reason it is not.
std::string unsupported(const Scene& scene) {
    if (scene.spheres.size() || scene.planes.size() || !scene.quadrics.empty())
        return "it has spheres, planes or quadrics (only triangles and meshes are traced)";
    if (!scene.lights.empty()) return "it has point lights (only emitters light the scene)";
    for (const Mesh& mesh : scene.meshes) {
        const Material& m = scene.materials[size_t(mesh.material)];
        // An emitter ends the path, so only its emission matters
        if (m.is_emitter()) {
            if (m.emission.kind != TextureKind::kSolid)
                return "emitter '" + m.name + "' has a textured emission";
        } else if (m.kd.kind != TextureKind::kSolid) {
            return "material '" + m.name + "' has a texture or vertex colours";
        } else if (!(m.ks.is_zero() && m.kr.is_zero() && m.kt.is_zero())) {
            return "material '" + m.name + "' is not diffuse (ks, kr or kt is non-zero)";
        }
    }
    return {};
}

// ---- Random numbers: PCG32 (O'Neill), one stream per pixel ---------------------------
// Streams that differ only in their increment are correlated, so the pixel is also hashed
// into the starting state (SplitMix64's finaliser).
uint64_t mix64(uint64_t x) {
    x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ull;
    x = (x ^ (x >> 27)) * 0x94d049bb133111ebull;
    return x ^ (x >> 31);
}

struct Pcg32 {
    uint64_t state = 0, inc;
    Pcg32(uint64_t seed, uint64_t stream) : inc(stream << 1 | 1) {
        next();
        state += mix64(seed ^ mix64(stream));
        next();
    }
    uint32_t next() {
        const uint64_t old = state;
        state = old * 6364136223846793005ull + inc;
        const auto xorshifted = uint32_t(((old >> 18) ^ old) >> 27);
        const auto rot = uint32_t(old >> 59);
        return (xorshifted >> rot) | (xorshifted << ((32 - rot) & 31));
    }
    float uniform() { return float(next() >> 8) * 0x1.0p-24f; }  // [0, 1), 24 bits
};

// ---- Embree ---------------------------------------------------------------------------
// One triangle geometry holding every mesh (one BVH, no instancing level), built by default
// with RTC_BUILD_QUALITY_HIGH (spatial splits), meant as the best trace speed Embree offers,
// at the price of a slower build, which is timed separately (--quality medium is the binned
// SAH without spatial splits, which traces as fast or faster on some meshes: measure both).
// Default scene flags: Embree's fast (not RTC_SCENE_FLAG_ROBUST) triangle test, as
// renderers built on it normally run.
RTCScene build_scene(RTCDevice device, const Triangles& t, RTCBuildQuality quality) {
    RTCScene scene = rtcNewScene(device);
    rtcSetSceneBuildQuality(scene, quality);
    if (!t.material.empty()) {
        RTCGeometry g = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
        rtcSetGeometryBuildQuality(g, quality);
        // Embree's own buffers, padded as its SIMD loads need
        void* v = rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                                          sizeof(Vec3f), t.positions.size());
        std::memcpy(v, t.positions.data(), t.positions.size() * sizeof(Vec3f));
        void* i = rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                          3 * sizeof(uint32_t), t.material.size());
        std::memcpy(i, t.indices.data(), t.indices.size() * sizeof(uint32_t));
        rtcCommitGeometry(g);
        rtcAttachGeometry(scene, g);
        rtcReleaseGeometry(g);
    }
    rtcCommitScene(scene);
    return scene;
}

// One rtcIntersect1 call for the ray o + t·d, 0 < t < tmax (tnear 0: origins are offset
// off the surface instead, as cierzo does). True if it hit; rh then holds the hit.
inline bool intersect1(RTCScene scene, const float o[3], const float d[3], float tmax,
                       RTCRayHit& rh) {
    rh.ray = {o[0], o[1], o[2], 0.0f, d[0], d[1], d[2], 0.0f, tmax, ~0u, 0u, 0u};
    rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    RTCIntersectContext context;
    rtcInitIntersectContext(&context);
    rtcIntersect1(scene, &context, &rh);
    return rh.hit.geomID != RTC_INVALID_GEOMETRY_ID;
}

// The renderer's rays: tmax = FLT_MAX (cierzo's kRayFar), and `rays` counts every call.
struct Tracer {
    RTCScene scene;
    uint64_t rays = 0;
    bool intersect(const Vec3f& o, const Vec3f& d, RTCRayHit& rh) {
        ++rays;
        const float of[3] = {o.x, o.y, o.z}, df[3] = {d.x, d.y, d.z};
        return intersect1(scene, of, df, kRayFar, rh);
    }
};

// A ray as the ray file stores it.
struct RayRecord {
    float o[3], d[3], tmax;
};

// ---- The estimator (kernels/estimator.h, restricted to diffuse and emitting surfaces) ----
// From the camera ray (o, d): at each hit an emitter adds throughput · Le and ends the path;
// otherwise the roulette keeps the path with P = min(max RGB of kd, survival_cap) and the
// diffuse lobe samples a direction, throughput *= f cos θ / (pdf · P). A miss adds nothing
// (cierzo's background is black). `dump`, if given, receives every extension ray.
Vec3f trace_path(Tracer& tracer, const Scene& scene, const Triangles& tris, Vec3f o, Vec3f d,
                 Pcg32& rng, std::vector<RayRecord>* dump) {
    const EstimatorSettings& est = scene.settings.estimator;
    Vec3f radiance(0.0f), throughput(1.0f);
    for (;;) {
        RTCRayHit rh;
        if (!tracer.intersect(o, d, rh)) break;
        const Material& mat = scene.materials[size_t(tris.material[rh.hit.primID])];
        if (mat.is_emitter()) {
            radiance += throughput * mat.emission.a;
            break;
        }
        // Hit point as cierzo computes it, and the unit normal on the incoming side
        const Vec3f p = fma(d, rh.ray.tfar, o);
        Vec3f n = normalize(Vec3f(rh.hit.Ng_x, rh.hit.Ng_y, rh.hit.Ng_z));
        if (dot(n, d) > 0.0f) n = -n;

        // Russian roulette, as choose_lobe does with the diffuse lobe alone
        const float pd = max_component(mat.kd.a);
        const float P = std::min(pd, est.survival_cap);
        if (!(rng.uniform() < P)) break;

        // A direction in the frame around n: uniform (pdf 1/2π) or cosine (pdf cos θ/π)
        const float u1 = rng.uniform(), u2 = rng.uniform();
        const float cos_t = est.cosine_diffuse ? std::sqrt(1.0f - u1) : u1;
        const float sin_t = std::sqrt(std::max(0.0f, 1.0f - cos_t * cos_t));
        const float phi = 2.0f * kPi * u2;
        const Vec3f a = std::abs(n.x) > 0.5f ? Vec3f(0.0f, 1.0f, 0.0f) : Vec3f(1.0f, 0.0f, 0.0f);
        const Vec3f t = normalize(cross(a, n)), b = cross(n, t);
        d = t * (sin_t * std::cos(phi)) + b * (sin_t * std::sin(phi)) + n * cos_t;
        // f cos θ / (pdf P) with f = kd/π: kd · 2cos θ / P (uniform), kd / P (cosine)
        throughput *= mat.kd.a * ((est.cosine_diffuse ? 1.0f : 2.0f * cos_t) / P);
        if (!(max_component(throughput) > 0.0f)) break;

        // cierzo's own offset off the surface, so self-intersection is avoided the same way
        o = offset_ray_origin(p, n, std::max(max_abs(p), max_abs(o)));
        if (dump) dump->push_back({{o.x, o.y, o.z}, {d.x, d.y, d.z}, kRayFar});
    }
    return radiance;
}

// Traces every pixel's paths in pixel order: the image, its mean and that mean's standard
// error. With `dump`, stops as soon as `dump` holds `count` rays.
struct RenderResult {
    Image image;
    double mean[3] = {0, 0, 0}, std_error[3] = {0, 0, 0};  // of the image mean
    uint64_t nonfinite = 0;
};

RenderResult render(Tracer& tracer, const Scene& scene, const Triangles& tris,
                    std::vector<RayRecord>* dump = nullptr, size_t count = 0) {
    const RenderSettings& rs = scene.settings;
    const Camera& cam = scene.camera;
    RenderResult r{Image(rs.width, rs.height)};
    double var_sum[3] = {0, 0, 0};
    for (uint64_t pass = 0;; ++pass) {
        const size_t before = dump ? dump->size() : 0;
        for (int y = 0; y < rs.height; ++y) {
            for (int x = 0; x < rs.width; ++x) {
                const uint64_t pixel = uint64_t(y) * uint64_t(rs.width) + uint64_t(x);
                Pcg32 rng(rs.seed + (pass << 32), pixel);
                double sum[3] = {0, 0, 0}, sum_sq[3] = {0, 0, 0};
                uint64_t n = 0;
                for (int64_t s = 0; s < rs.spp; ++s) {
                    // The report's pinhole: u = 1 − 2 sx/W, v = 1 − 2 sy/H at a jittered point
                    const float sx = float(x) + rng.uniform(), sy = float(y) + rng.uniform();
                    const float u = 1.0f - 2.0f * sx / float(rs.width);
                    const float v = 1.0f - 2.0f * sy / float(rs.height);
                    const Vec3f d = normalize(cam.forward + cam.left * u + cam.up * v);
                    const Vec3f L = trace_path(tracer, scene, tris, cam.origin, d, rng, dump);
                    if (dump && dump->size() >= count) {
                        dump->resize(count);
                        return r;
                    }
                    if (!(std::isfinite(L.x) && std::isfinite(L.y) && std::isfinite(L.z))) {
                        ++r.nonfinite;  // left out, as cierzo's film does
                        continue;
                    }
                    ++n;
                    for (int c = 0; c < 3; ++c) sum[c] += L[c], sum_sq[c] += double(L[c]) * L[c];
                }
                for (int c = 0; c < 3; ++c) {
                    const double mean = n ? sum[c] / double(n) : 0.0;
                    r.image.pixel(x, y)[c] = float(mean);
                    r.mean[c] += mean;
                    // The variance of this pixel's mean: sample variance / n
                    if (n > 1) var_sum[c] += (sum_sq[c] - mean * sum[c]) / double((n - 1) * n);
                }
            }
        }
        // A dump goes round again with new samples, unless a whole pass added no ray
        if (!dump || dump->size() == before) break;
    }
    const double pixels = double(rs.width) * double(rs.height);
    for (int c = 0; c < 3; ++c) {
        r.mean[c] /= pixels;
        r.std_error[c] = std::sqrt(var_sum[c]) / pixels;
    }
    return r;
}

// ---- Ray files: "CZRAYS1\0", uint64 count, count × 7 float32, all little-endian ------
static_assert(std::endian::native == std::endian::little, "ray files are little-endian");
constexpr char kMagic[8] = {'C', 'Z', 'R', 'A', 'Y', 'S', '1', '\0'};

void write_rays(const std::string& path, const std::vector<RayRecord>& rays) {
    std::ofstream f(path, std::ios::binary);
    const uint64_t n = rays.size();
    f.write(kMagic, 8).write(reinterpret_cast<const char*>(&n), 8);
    f.write(reinterpret_cast<const char*>(rays.data()), std::streamsize(n * sizeof(RayRecord)));
    if (!f.flush()) throw InputError(path + ": cannot write the ray file");
}

std::vector<RayRecord> read_rays(const std::string& path) {
    std::ifstream f(path, std::ios::binary | std::ios::ate);
    if (!f) throw InputError(path + ": cannot open the ray file");
    const auto size = uint64_t(f.tellg());
    char magic[8] = {};
    uint64_t n = 0;
    f.seekg(0).read(magic, 8).read(reinterpret_cast<char*>(&n), 8);
    if (!f || std::memcmp(magic, kMagic, 8) != 0 || (size - 16) / sizeof(RayRecord) != n ||
        (size - 16) % sizeof(RayRecord) != 0)
        throw InputError(path + ": not a ray file of the size its header says (CZRAYS1)");
    std::vector<RayRecord> rays(n);
    f.read(reinterpret_cast<char*>(rays.data()), std::streamsize(n * sizeof(RayRecord)));
    return rays;
}

double seconds_since(std::chrono::steady_clock::time_point t0) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// ---- The three modes ------------------------------------------------------------------
// --quality's values, parsed and printed by the same names.
constexpr std::pair<const char*, RTCBuildQuality> kQualities[] = {
    {"low", RTC_BUILD_QUALITY_LOW},
    {"medium", RTC_BUILD_QUALITY_MEDIUM},
    {"high", RTC_BUILD_QUALITY_HIGH}};

struct Options {
    std::string scene, out, dump_file, trace_file, config = "threads=1", api = "1";
    std::string quality = "high";
    long long spp = 0, width = 0, height = 0, count = 1000000, repeat = 1;
};

void run_render(Tracer& tracer, const Scene& scene, const Triangles& tris, const Options& o) {
    const RenderSettings& rs = scene.settings;
    const auto t0 = std::chrono::steady_clock::now();
    const RenderResult r = render(tracer, scene, tris);
    const double seconds = seconds_since(t0);
    std::printf(
        "width: %d\nheight: %d\nspp: %lld\nrender_seconds: %.6f\nrays: %llu\n"
        "camera_rays: %llu\nrays_per_second: %.0f\n",
        rs.width, rs.height, (long long)rs.spp, seconds, (unsigned long long)tracer.rays,
        (unsigned long long)(rs.spp * int64_t(rs.width) * rs.height),
        double(tracer.rays) / seconds);
    std::printf(
        "mean_rgb: %.9g %.9g %.9g\nmean_stderr_rgb: %.9g %.9g %.9g\n"
        "nonfinite_samples: %llu\n",
        r.mean[0], r.mean[1], r.mean[2], r.std_error[0], r.std_error[1], r.std_error[2],
        (unsigned long long)r.nonfinite);
    if (!o.out.empty()) write_pfm(o.out, r.image);
}

void run_dump(Tracer& tracer, const Scene& scene, const Triangles& tris, const Options& o) {
    std::vector<RayRecord> rays;
    rays.reserve(size_t(o.count));
    render(tracer, scene, tris, &rays, size_t(o.count));
    write_rays(o.dump_file, rays);
    std::printf("rays_written: %zu\nray_file: %s\n", rays.size(), o.dump_file.c_str());
}

// rtcIntersect16 over rays[0, count), count <= 16 (the rest of the packet invalid); the
// hits' count and distances are added.
void intersect16(RTCScene scene, const RayRecord* rays, int count, uint64_t& hits, double& sum_t) {
    alignas(64) int valid[16];
    alignas(64) RTCRayHit16 rh;
    for (int l = 0; l < 16; ++l) {
        const RayRecord& r = rays[l < count ? l : 0];
        valid[l] = l < count ? -1 : 0;
        rh.ray.org_x[l] = r.o[0], rh.ray.org_y[l] = r.o[1], rh.ray.org_z[l] = r.o[2];
        rh.ray.dir_x[l] = r.d[0], rh.ray.dir_y[l] = r.d[1], rh.ray.dir_z[l] = r.d[2];
        rh.ray.tnear[l] = 0.0f, rh.ray.tfar[l] = r.tmax, rh.ray.time[l] = 0.0f;
        rh.ray.mask[l] = ~0u, rh.ray.id[l] = unsigned(l), rh.ray.flags[l] = 0;
        rh.hit.geomID[l] = RTC_INVALID_GEOMETRY_ID;
    }
    RTCIntersectContext context;
    rtcInitIntersectContext(&context);
    rtcIntersect16(valid, scene, &context, &rh);
    for (int l = 0; l < count; ++l)
        if (rh.hit.geomID[l] != RTC_INVALID_GEOMETRY_ID) ++hits, sum_t += rh.ray.tfar[l];
}

// rtcIntersect1M over `count` rays (the stream API), incoherent, as extension rays are.
void intersect1m(RTCScene scene, const RayRecord* rays, int count, std::vector<RTCRayHit>& rh,
                 uint64_t& hits, double& sum_t) {
    for (int k = 0; k < count; ++k) {
        const RayRecord& r = rays[k];
        rh[size_t(k)].ray = {r.o[0], r.o[1], r.o[2], 0.0f, r.d[0],      r.d[1],
                             r.d[2], 0.0f,   r.tmax, ~0u,  unsigned(k), 0u};
        rh[size_t(k)].hit.geomID = RTC_INVALID_GEOMETRY_ID;
    }
    RTCIntersectContext context;
    rtcInitIntersectContext(&context);
    context.flags = RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT;
    rtcIntersect1M(scene, &context, rh.data(), unsigned(count), sizeof(RTCRayHit));
    for (int k = 0; k < count; ++k)
        if (rh[size_t(k)].hit.geomID != RTC_INVALID_GEOMETRY_ID)
            ++hits, sum_t += rh[size_t(k)].ray.tfar;
}

// Embree alone over a ray file through the API asked for: one untimed warm-up pass, then
// `repeat` timed ones (the time includes writing the rays into the API's structures).
void run_trace(RTCScene scene, const Options& o) {
    const std::vector<RayRecord> rays = read_rays(o.trace_file);
    constexpr int kStream = 1024;
    std::vector<RTCRayHit> stream(kStream);
    const size_t n = rays.size();
    uint64_t hits = 0;
    double sum_t = 0.0, seconds = 0.0;
    for (long long pass = 0; pass <= o.repeat; ++pass) {
        hits = 0, sum_t = 0.0;
        const auto t0 = std::chrono::steady_clock::now();
        if (o.api == "1") {
            for (const RayRecord& r : rays) {
                RTCRayHit rh;
                if (intersect1(scene, r.o, r.d, r.tmax, rh)) ++hits, sum_t += rh.ray.tfar;
            }
        } else if (o.api == "16") {
            for (size_t i = 0; i < n; i += 16)
                intersect16(scene, rays.data() + i, int(std::min<size_t>(16, n - i)), hits, sum_t);
        } else {
            for (size_t i = 0; i < n; i += kStream)
                intersect1m(scene, rays.data() + i, int(std::min<size_t>(kStream, n - i)), stream,
                            hits, sum_t);
        }
        if (pass > 0) seconds += seconds_since(t0);
    }
    std::printf(
        "api: rtcIntersect%s\nrays: %zu\nrepeat: %lld\ntrace_seconds: %.6f\n"
        "rays_per_second: %.0f\nhits: %llu\nsum_t: %.17g\n",
        o.api.c_str(), rays.size(), o.repeat, seconds,
        double(rays.size()) * double(o.repeat) / seconds, (unsigned long long)hits, sum_t);
}

Options parse_options(int argc, char** argv) {
    Options o;
    if (argc < 2 || argv[1][0] == '-')
        throw InputError(
            "usage: embree_pt SCENE.json [--spp N] [--width W] [--height H] "
            "[--out image.pfm] [--dump-rays FILE [--count N]] "
            "[--trace-rays FILE [--repeat R] [--api 1|16|1M]] "
            "[--quality low|medium|high] [--embree-config STRING]");
    o.scene = argv[1];
    for (int i = 2; i < argc; i += 2) {  // every option takes one value
        const std::string key = argv[i];
        if (i + 1 >= argc) throw InputError(key + ": needs a value");
        const std::string value = argv[i + 1];
        long long* number = key == "--spp"      ? &o.spp
                            : key == "--width"  ? &o.width
                            : key == "--height" ? &o.height
                            : key == "--count"  ? &o.count
                            : key == "--repeat" ? &o.repeat
                                                : nullptr;
        if (number) {
            const long long limit = key == "--width" || key == "--height" ? 65536 : (1ll << 32) - 1;
            size_t end = 0;
            try {
                *number = std::stoll(value, &end);
            } catch (const std::exception&) {
            }
            if (end != value.size() || *number < 1 || *number > limit)
                throw InputError(key + ": expected an integer in [1, " + std::to_string(limit) +
                                 "], got '" + value + "'");
        } else if (key == "--out" && value.ends_with(".pfm"))
            o.out = value;
        else if (key == "--out")
            throw InputError("--out: writes PFM only, give a .pfm name");
        else if (key == "--dump-rays")
            o.dump_file = value;
        else if (key == "--trace-rays")
            o.trace_file = value;
        else if (key == "--embree-config")
            o.config += "," + value;
        else if (key == "--api" && (value == "1" || value == "16" || value == "1M"))
            o.api = value;
        else if (key == "--api")
            throw InputError("--api: expected 1, 16 or 1M, got '" + value + "'");
        else if (key == "--quality" && std::any_of(std::begin(kQualities), std::end(kQualities),
                                                   [&](const auto& q) { return value == q.first; }))
            o.quality = value;
        else if (key == "--quality")
            throw InputError("--quality: expected low, medium or high, got '" + value + "'");
        else
            throw InputError("unknown option '" + key + "'");
    }
    return o;
}

}  // namespace

int main(int argc, char** argv) try {
    const Options o = parse_options(argc, argv);
    Scene scene = load_scene(o.scene);
    if (const std::string why = unsupported(scene); !why.empty())
        throw InputError(o.scene + ": cannot render this scene: " + why);
    if (o.spp) scene.settings.spp = o.spp;
    if (o.width || o.height)  // as `cierzo render` does: a look_at camera keeps its vfov
        scene.set_resolution(o.width ? int(o.width) : scene.settings.width,
                             o.height ? int(o.height) : scene.settings.height);

#if defined(__SSE__)
    // Embree asks for flush-to-zero and denormals-are-zero, for its speed
    _MM_SET_FLUSH_ZERO_MODE(_MM_FLUSH_ZERO_ON);
    _MM_SET_DENORMALS_ZERO_MODE(_MM_DENORMALS_ZERO_ON);
#endif
    RTCDevice device = rtcNewDevice(o.config.c_str());
    if (!device) throw InputError("rtcNewDevice(\"" + o.config + "\") failed");
    rtcSetDeviceErrorFunction(
        device,
        [](void*, RTCError, const char* what) {
            std::fprintf(stderr, "embree_pt: Embree error: %s\n", what);
            std::exit(1);
        },
        nullptr);

    const Triangles tris = collect_triangles(scene);
    const auto t0 = std::chrono::steady_clock::now();
    const auto quality = std::find_if(std::begin(kQualities), std::end(kQualities),
                                      [&](const auto& q) { return o.quality == q.first; });
    Tracer tracer{build_scene(device, tris, quality->second)};
    std::printf(
        "embree_version: %d.%d.%d\ntriangles: %zu\nbuild_quality: %s\n"
        "build_seconds: %.6f\n",
        RTC_VERSION_MAJOR, RTC_VERSION_MINOR, RTC_VERSION_PATCH, tris.material.size(),
        quality->first, seconds_since(t0));
    if (!o.dump_file.empty())
        run_dump(tracer, scene, tris, o);
    else if (!o.trace_file.empty())
        run_trace(tracer.scene, o);
    else
        run_render(tracer, scene, tris, o);
    rtcReleaseScene(tracer.scene);
    rtcReleaseDevice(device);
    return 0;
} catch (const std::exception& e) {
    std::fprintf(stderr, "embree_pt: %s\n", e.what());
    return 1;
}
