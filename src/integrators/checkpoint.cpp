// Checkpoint files: the exact render state in UINT channels of an OpenEXR file.
#include "integrators/checkpoint.h"

#include <algorithm>
#include <bit>
#include <cinttypes>
#include <cstring>
#include <fstream>
#include <sstream>

#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfInputFile.h>
#include <OpenEXR/ImfOutputFile.h>
#include <OpenEXR/ImfStdIO.h>
#include <OpenEXR/ImfStringAttribute.h>
#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "core/error.h"
#include "io/input_file.h"
#include "io/output_file.h"
#include "integrators/light_pilot.h"
#include "integrators/path_guide.h"
#include "integrators/registry.h"

namespace cierzo {

namespace fs = std::filesystem;

namespace {

constexpr const char* kFormat = "cierzo checkpoint 2";

// FNV-1a, 64 bits, taken eight bytes at a time (a mesh of millions of triangles is
// hundreds of megabytes: byte by byte took a second).
struct Hash {
    uint64_t h = 1469598103934665603ull;
    void bytes(const void* data, size_t n) {
        const auto* p = static_cast<const unsigned char*>(data);
        size_t i = 0;
        for (; i + 8 <= n; i += 8) {
            uint64_t w;
            std::memcpy(&w, p + i, 8);
            h = (h ^ w) * 1099511628211ull;
        }
        for (; i < n; ++i) h = (h ^ p[i]) * 1099511628211ull;
    }
    template <typename T>
    void vec(const std::vector<T>& v) {
        const uint64_t n = v.size();
        bytes(&n, sizeof(n));
        bytes(v.data(), v.size() * sizeof(T));
    }
};

// The numbers of one pixel as 16 words: sum, sum_sq (3 doubles each), count, nonfinite.
constexpr int kWords = 16;
const char* kWordNames[kWords] = {"sum.R.hi",   "sum.R.lo",   "sum.G.hi",     "sum.G.lo",
                                  "sum.B.hi",   "sum.B.lo",   "sumsq.R.hi",   "sumsq.R.lo",
                                  "sumsq.G.hi", "sumsq.G.lo", "sumsq.B.hi",   "sumsq.B.lo",
                                  "count.hi",   "count.lo",   "nonfinite.hi", "nonfinite.lo"};

void to_words(const PixelSums& p, uint32_t* w) {
    uint64_t v[8];
    for (int c = 0; c < 3; ++c) {
        v[c] = std::bit_cast<uint64_t>(p.sum[c]);
        v[3 + c] = std::bit_cast<uint64_t>(p.sum_sq[c]);
    }
    v[6] = p.count, v[7] = p.nonfinite;
    for (int i = 0; i < 8; ++i) w[2 * i] = uint32_t(v[i] >> 32), w[2 * i + 1] = uint32_t(v[i]);
}

PixelSums from_words(const uint32_t* w) {
    uint64_t v[8];
    for (int i = 0; i < 8; ++i) v[i] = (uint64_t(w[2 * i]) << 32) | w[2 * i + 1];
    PixelSums p;
    for (int c = 0; c < 3; ++c) {
        p.sum[c] = std::bit_cast<double>(v[c]);
        p.sum_sq[c] = std::bit_cast<double>(v[3 + c]);
    }
    p.count = v[6], p.nonfinite = v[7];
    return p;
}

// Words of every pixel, word-major (kWords planes of width × height).
std::vector<uint32_t> film_words(const Film& film) {
    const size_t n = film.pixels().size();
    std::vector<uint32_t> planes(n * kWords);
    uint32_t w[kWords];
    for (size_t i = 0; i < n; ++i) {
        to_words(film.pixels()[i], w);
        for (int k = 0; k < kWords; ++k) planes[size_t(k) * n + i] = w[k];
    }
    return planes;
}

void words_to_film(const std::vector<uint32_t>& planes, Film& film) {
    const size_t n = film.pixels().size();
    uint32_t w[kWords];
    for (size_t i = 0; i < n; ++i) {
        for (int k = 0; k < kWords; ++k) w[k] = planes[size_t(k) * n + i];
        film.pixels()[i] = from_words(w);
    }
}

std::string get(const Imf::Header& h, const fs::path& path, const std::string& key) {
    const auto* a = h.findTypedAttribute<Imf::StringAttribute>(key);
    if (!a)
        throw InputError(path.string() + ": not a cierzo checkpoint (no '" + key +
                         "' in its header)");
    return a->value();
}

int64_t get_int(const Imf::Header& h, const fs::path& path, const std::string& key) {
    const std::string v = get(h, path, key);
    try {
        size_t used = 0;
        const long long x = std::stoll(v, &used);
        if (used != v.size()) throw std::invalid_argument(v);
        return x;
    } catch (const std::exception&) {
        throw InputError(path.string() + ": checkpoint header '" + key + "' is not a number: '" +
                         v + "'");
    }
}

}  // namespace

std::string scene_fingerprint(const Scene& scene) {
    Hash h;
    // The scene file without its render settings (resolution, spp, seed... are compared
    // one by one, so a difference can be named)
    std::ifstream in(scene.source, std::ios::binary);
    if (in) {
        try {
            nlohmann::json j = nlohmann::json::parse(in);
            if (j.is_object()) j.erase("render");
            const std::string text = j.dump();
            h.bytes(text.data(), text.size());
        } catch (const std::exception&) {
        }
    }
    for (const Mesh& m : scene.meshes) {
        h.vec(m.positions);
        h.vec(m.colors);
        h.vec(m.indices);
        h.bytes(m.to_world, sizeof(m.to_world));
        h.bytes(&m.material, sizeof(m.material));
        if (!m.uvs.empty()) h.vec(m.uvs);
    }
    for (const auto& image : scene.images) {
        h.vec(image->bytes);
        h.vec(image->floats);
    }
    // Materials' values (those of an OBJ's MTL files are in no scene text), field by field
    const auto f = [&](const auto&... v) { (h.bytes(&v, sizeof v), ...); };
    for (const Material& m : scene.materials) {
        for (const ColorSource* c : {&m.emission, &m.kd, &m.ks, &m.kr, &m.kt})
            f(c->kind, c->a, c->b, c->frequency, c->axis, c->axis2, c->image, c->uv_scale,
              c->uv_offset, c->clamp);
        const AlphaSource& a = m.alpha;
        f(m.shininess, m.ior, a.constant, a.image, a.channel, a.uv_scale, a.uv_offset, a.clamp);
    }
    return fmt::format("{:016x}", h.h);
}

namespace {
std::string roulette_identity(const EstimatorSettings& e) {
    return e.roulette == Roulette::kLobe
               ? std::string(roulette_name(e.roulette))
               : fmt::format("{} from {}", roulette_name(e.roulette), e.roulette_depth);
}
// zsobol's points depend on the paths per pixel rounded up to a power of two: a render
// resumed to another power would not be the one it continues
std::string sampler_identity(const RenderSettings& s) {
    if (s.estimator.sampler != Sampler::kZSobol) return sampler_name(s.estimator.sampler);
    const int l = int(std::bit_width(uint64_t(std::max<int64_t>(s.spp, 1) - 1)));
    return fmt::format("{} in blocks of 2^{} paths", sampler_name(s.estimator.sampler), l);
}
}  // namespace

CheckpointIdentity checkpoint_identity(const Scene& scene, const std::string& integrator,
                                       const std::string& isa, int pool) {
    const RenderSettings& s = scene.settings;
    CheckpointIdentity id;
    id.scene = scene.source.string();
    id.fingerprint = scene_fingerprint(scene);
    id.width = s.width, id.height = s.height;
    id.seed = s.seed;
    id.estimator = estimator_name(s.estimator.kind);
    // (vcm's radius as set, 0 for the scene's rule, and its exponent)
    if (merges(s.estimator.kind))
        id.estimator +=
            fmt::format(" r0 {:a} alpha {:a}", s.estimator.merge_radius, s.estimator.merge_alpha);
    // (and the connections: a cache's draws, 0 for the pairing, and how many times its MIS
    // weights count each, which a build whose weights differ would not match)
    if (connects(s.estimator.kind) && s.estimator.light_connections > 0) {
        prepare_path_context(scene);
        id.estimator += fmt::format(" draws {} counted {:a}", s.estimator.light_connections,
                                    scene.path_context().connection_count);
    }
    // (a guided render's image depends on its guide: path_guide.h)
    if (s.estimator.guiding != Guiding::kNone)
        id.estimator += fmt::format(" guided {} vertices {}", guiding_name(s.estimator.guiding),
                                    s.estimator.guided_vertices);
    id.survival_cap = fmt::format("{:a}", s.estimator.survival_cap);
    id.diffuse_sampling = s.estimator.cosine_diffuse ? "cosine" : "uniform";
    id.roulette = roulette_identity(s.estimator);
    id.triangle_sampling = triangle_sampling_name(s.estimator);
    id.sampler = sampler_identity(s);
    id.lengths = s.estimator.max_length == kNoLengthLimit
                     ? fmt::format("{}..", s.estimator.min_length)
                     : fmt::format("{}..{}", s.estimator.min_length, s.estimator.max_length);
    // (bdpt's strategy filter changes what the sums hold, as the lengths do)
    if (s.estimator.strategy_s >= 0)
        id.lengths += fmt::format(" s{}t{}{}", s.estimator.strategy_s, s.estimator.strategy_t,
                                  s.estimator.unweighted ? " unweighted" : "");
    id.integrator = integrator;
    id.isa = integrator == "wavefront" ? isa : "scalar";
    id.pool = integrator == "wavefront" ? pool : 0;
    id.spp = s.spp;
    return id;
}

void write_checkpoint(const fs::path& path, const CheckpointIdentity& id,
                      const RenderState& state) {
    const Film& film = state.film;
    const int w = film.width(), h = film.height();
    Imf::Header header(w, h);
    // Uncompressed: ZIP took four times as long as the write itself (and the words of
    // doubles compress poorly); a checkpoint is 76 bytes per pixel (140 with a pass in progress)
    header.compression() = Imf::NO_COMPRESSION;
    auto put = [&](const std::string& k, const std::string& v) {
        header.insert(k, Imf::StringAttribute(v));
    };
    put("cierzo:checkpoint", kFormat);
    put("cierzo:scene", id.scene);
    put("cierzo:fingerprint", id.fingerprint);
    put("cierzo:seed", std::to_string(id.seed));
    put("cierzo:estimator", id.estimator);
    put("cierzo:survival_cap", id.survival_cap);
    put("cierzo:diffuse_sampling", id.diffuse_sampling);
    put("cierzo:roulette", id.roulette);
    put("cierzo:triangle_sampling", id.triangle_sampling);
    put("cierzo:sampler", id.sampler);
    put("cierzo:path_lengths", id.lengths);
    put("cierzo:integrator", id.integrator);
    put("cierzo:isa", id.isa);
    put("cierzo:pool", std::to_string(id.pool));
    put("cierzo:spp", std::to_string(id.spp));
    put("cierzo:spp_reached", std::to_string(state.spp_done));
    put("cierzo:pending_end", std::to_string(state.pending_end));
    // (the pending tiles' sums hold the film's with the pass added; files written before
    // this attribute hold the pass's own sums, and are read as such)
    put("cierzo:pending_form", "added");
    put("cierzo:rays", fmt::format("{} {} {} {}", state.rays.camera, state.rays.extension,
                                   state.rays.shadow, state.rays.light));
    // (estimators that splat: the film's passes are batches; see Film::merge_batch)
    put("cierzo:batches", fmt::format("{} {}", film.batches(), film.nonfinite_splats()));
    put("cierzo:seconds", fmt::format("{:.6f}", state.seconds));
    put("cierzo:tile_size", std::to_string(kTileSize));
    // (a guided render's path guide: PathGuide::save's bytes)
    if (!state.guide.empty())
        header.insert("cierzo:guide",
                      Imf::StringAttribute(std::string(state.guide.begin(), state.guide.end())));
    const bool pending = !state.pending_tiles.empty();
    for (const char* c : {"R", "G", "B"}) header.channels().insert(c, Imf::Channel(Imf::FLOAT));
    for (const char* n : kWordNames) {
        header.channels().insert(n, Imf::Channel(Imf::UINT));
        if (pending) header.channels().insert(std::string("pending.") + n, Imf::Channel(Imf::UINT));
    }
    const Image mean = film.mean();
    const std::vector<uint32_t> words = film_words(film);
    const std::vector<uint32_t> pending_words =
        pending ? film_words(state.pending) : std::vector<uint32_t>{};
    const size_t n = size_t(w) * size_t(h);
    write_output_stream(path, [&](std::ofstream& out) {
        Imf::StdOFStream stream(out, path.c_str());
        Imf::OutputFile file(stream, header);
        Imf::FrameBuffer frame;
        const size_t stride = 3 * sizeof(float);
        const char* names[3] = {"R", "G", "B"};
        for (int c = 0; c < 3; ++c)
            frame.insert(
                names[c],
                Imf::Slice(Imf::FLOAT,
                           const_cast<char*>(reinterpret_cast<const char*>(mean.rgb.data() + c)),
                           stride, stride * size_t(w)));
        for (int k = 0; k < kWords; ++k) {
            frame.insert(kWordNames[k], Imf::Slice(Imf::UINT,
                                                   const_cast<char*>(reinterpret_cast<const char*>(
                                                       words.data() + size_t(k) * n)),
                                                   sizeof(uint32_t), sizeof(uint32_t) * size_t(w)));
            if (pending)
                frame.insert(std::string("pending.") + kWordNames[k],
                             Imf::Slice(Imf::UINT,
                                        const_cast<char*>(reinterpret_cast<const char*>(
                                            pending_words.data() + size_t(k) * n)),
                                        sizeof(uint32_t), sizeof(uint32_t) * size_t(w)));
        }
        file.setFrameBuffer(frame);
        file.writePixels(h);
    });
}

Checkpoint read_checkpoint(const fs::path& path) {
    if (!input_file_exists(path)) throw InputError(path.string() + ": no such checkpoint file");
    try {
        Imf::InputFile file(path.c_str());
        const Imf::Header& header = file.header();
        if (get(header, path, "cierzo:checkpoint") != kFormat)
            throw InputError(path.string() + ": a checkpoint of another format ('" +
                             get(header, path, "cierzo:checkpoint") + "', this cierzo reads '" +
                             kFormat + "')");
        if (!file.isComplete())
            throw InputError(path.string() + ": truncated checkpoint (pixel data missing)");
        const Imath::Box2i win = header.dataWindow();
        const int64_t w = int64_t(win.max.x) - win.min.x + 1,
                      h = int64_t(win.max.y) - win.min.y + 1;
        if (win.min.x != 0 || win.min.y != 0 || w <= 0 || h <= 0 || w * h > kMaxImagePixels)
            throw InputError(path.string() + ": checkpoint of an invalid size " +
                             std::to_string(w) + "x" + std::to_string(h));
        Checkpoint c;
        CheckpointIdentity& id = c.id;
        id.scene = get(header, path, "cierzo:scene");
        id.fingerprint = get(header, path, "cierzo:fingerprint");
        id.width = int(w), id.height = int(h);
        id.seed = uint32_t(get_int(header, path, "cierzo:seed"));
        id.estimator = get(header, path, "cierzo:estimator");
        id.survival_cap = get(header, path, "cierzo:survival_cap");
        id.diffuse_sampling = get(header, path, "cierzo:diffuse_sampling");
        // (a checkpoint written before the throughput roulette existed used the lobe one)
        id.roulette = header.findTypedAttribute<Imf::StringAttribute>("cierzo:roulette")
                          ? get(header, path, "cierzo:roulette")
                          : std::string("lobe");
        id.triangle_sampling =
            header.findTypedAttribute<Imf::StringAttribute>("cierzo:triangle_sampling")
                ? get(header, path, "cierzo:triangle_sampling")
                : std::string("area");
        id.sampler = header.findTypedAttribute<Imf::StringAttribute>("cierzo:sampler")
                         ? get(header, path, "cierzo:sampler")
                         : std::string("independent");
        id.lengths = header.findTypedAttribute<Imf::StringAttribute>("cierzo:path_lengths")
                         ? get(header, path, "cierzo:path_lengths")
                         : std::string("1..");
        id.integrator = get(header, path, "cierzo:integrator");
        id.isa = get(header, path, "cierzo:isa");
        id.pool = int(get_int(header, path, "cierzo:pool"));
        id.spp = get_int(header, path, "cierzo:spp");
        if (get_int(header, path, "cierzo:tile_size") != kTileSize)
            throw InputError(path.string() + ": checkpoint of another tile size");
        RenderState& s = c.state;
        s.spp_done = get_int(header, path, "cierzo:spp_reached");
        if (const auto* g = header.findTypedAttribute<Imf::StringAttribute>("cierzo:guide")) {
            s.guide.assign(g->value().begin(), g->value().end());
            try {
                PathGuide check;
                check.restore(s.guide);
            } catch (const GuideStateError& e) {
                throw InputError(path.string() +
                                 ": the checkpoint's path guide is damaged: " + e.what());
            }
        }
        s.pending_end = get_int(header, path, "cierzo:pending_end");
        std::istringstream rays(get(header, path, "cierzo:rays"));
        if (!(rays >> s.rays.camera >> s.rays.extension >> s.rays.shadow >> s.rays.light))
            throw InputError(path.string() + ": checkpoint header 'cierzo:rays' is malformed");
        std::istringstream batches(get(header, path, "cierzo:batches"));
        int64_t batch_count = 0;
        uint64_t nonfinite_splats = 0;
        if (!(batches >> batch_count >> nonfinite_splats) || batch_count < 0)
            throw InputError(path.string() + ": checkpoint header 'cierzo:batches' is malformed");
        s.seconds = std::stod(get(header, path, "cierzo:seconds"));

        const Imf::ChannelList& channels = header.channels();
        const bool pending = channels.findChannel("pending.count.lo") != nullptr;
        for (const char* n : kWordNames) {
            for (const std::string& name : {std::string(n), "pending." + std::string(n)}) {
                if (!pending && name.starts_with("pending.")) continue;
                const Imf::Channel* ch = channels.findChannel(name);
                if (!ch)
                    throw InputError(path.string() + ": checkpoint channel '" + name +
                                     "' is missing");
                if (ch->type != Imf::UINT || ch->xSampling != 1 || ch->ySampling != 1)
                    throw InputError(path.string() + ": checkpoint channel '" + name +
                                     "' is not a full-resolution UINT channel");
            }
        }
        const size_t n = size_t(w) * size_t(h);
        std::vector<uint32_t> words(n * kWords), pending_words(pending ? n * kWords : 0);
        Imf::FrameBuffer frame;
        for (int k = 0; k < kWords; ++k) {
            frame.insert(
                kWordNames[k],
                Imf::Slice(Imf::UINT, reinterpret_cast<char*>(words.data() + size_t(k) * n),
                           sizeof(uint32_t), sizeof(uint32_t) * size_t(w)));
            if (pending)
                frame.insert(
                    std::string("pending.") + kWordNames[k],
                    Imf::Slice(Imf::UINT,
                               reinterpret_cast<char*>(pending_words.data() + size_t(k) * n),
                               sizeof(uint32_t), sizeof(uint32_t) * size_t(w)));
        }
        file.setFrameBuffer(frame);
        file.readPixels(0, int(h) - 1);
        s.film = Film(int(w), int(h));
        words_to_film(words, s.film);
        s.film.set_batches(batch_count, nonfinite_splats);

        // Consistency: every pixel of the film has spp_done paths; a pending tile's pixels
        // all have pending_end (pending_end - spp_done in an older file), the others none
        if (s.spp_done < 0 || s.spp_done > id.spp)
            throw InputError(path.string() + ": checkpoint claims " + std::to_string(s.spp_done) +
                             " of " + std::to_string(id.spp) + " paths per pixel");
        for (const PixelSums& p : s.film.pixels())
            if (int64_t(p.count + p.nonfinite) != s.spp_done)
                throw InputError(path.string() + ": checkpoint pixels do not all hold its " +
                                 std::to_string(s.spp_done) + " paths (damaged file?)");
        if (pending) {
            if (s.pending_end <= s.spp_done)
                throw InputError(path.string() +
                                 ": checkpoint has tiles of a pass but no pass in progress");
            s.pending = Film(int(w), int(h));
            words_to_film(pending_words, s.pending);
            const std::vector<Tile> tiles = image_tiles(int(w), int(h));
            s.pending_tiles.assign(tiles.size(), 0);
            const bool added =
                header.findTypedAttribute<Imf::StringAttribute>("cierzo:pending_form") &&
                get(header, path, "cierzo:pending_form") == "added";
            const uint64_t paths = uint64_t(added ? s.pending_end : s.pending_end - s.spp_done);
            for (size_t t = 0; t < tiles.size(); ++t) {
                const Tile& g = tiles[t];
                const PixelSums& first = s.pending.at(g.x0, g.y0);
                const uint64_t have = first.count + first.nonfinite;
                if (have != 0 && have != paths)
                    throw InputError(path.string() + ": checkpoint tile " + std::to_string(t) +
                                     " of the pass in progress is damaged");
                for (int y = g.y0; y < g.y1; ++y)
                    for (int x = g.x0; x < g.x1; ++x) {
                        const PixelSums& p = s.pending.at(x, y);
                        if (p.count + p.nonfinite != have)
                            throw InputError(path.string() + ": checkpoint tile " +
                                             std::to_string(t) +
                                             " of the pass in progress is damaged");
                    }
                s.pending_tiles[t] = have != 0;
                // (an older file's pass sums: the film's added first, as a render adds them)
                if (!added && have != 0)
                    for (int y = g.y0; y < g.y1; ++y)
                        for (int x = g.x0; x < g.x1; ++x) {
                            PixelSums p = s.film.at(x, y);
                            p.merge(s.pending.at(x, y));
                            s.pending.at(x, y) = p;
                        }
            }
        }
        return c;
    } catch (const InputError&) {
        throw;
    } catch (const std::exception& e) {
        throw InputError(path.string() + ": damaged or truncated checkpoint: " + e.what());
    }
}

std::vector<std::string> check_resume(const fs::path& path, const Checkpoint& c,
                                      const CheckpointIdentity& now) {
    const CheckpointIdentity& was = c.id;
    std::vector<std::string> diffs;
    auto differ = [&](const std::string& what, const std::string& a, const std::string& b) {
        if (a != b) diffs.push_back(what + " " + a + " (this render: " + b + ")");
    };
    differ("scene content fingerprint", was.fingerprint + " of " + was.scene,
           now.fingerprint + " of " + now.scene);
    differ("resolution", fmt::format("{}x{}", was.width, was.height),
           fmt::format("{}x{}", now.width, now.height));
    differ("seed", std::to_string(was.seed), std::to_string(now.seed));
    differ("estimator", was.estimator, now.estimator);
    differ("survival cap", was.survival_cap, now.survival_cap);
    differ("diffuse sampling", was.diffuse_sampling, now.diffuse_sampling);
    differ("roulette", was.roulette, now.roulette);
    differ("triangle sampling", was.triangle_sampling, now.triangle_sampling);
    differ("sampler", was.sampler, now.sampler);
    differ("path lengths", was.lengths, now.lengths);
    differ("integrator", was.integrator, now.integrator);
    if (!diffs.empty()) {
        std::string msg =
            path.string() + ": cannot resume: the checkpoint was rendered with another ";
        for (size_t i = 0; i < diffs.size(); ++i) msg += (i ? "; " : "") + diffs[i];
        throw InputError(msg);
    }
    std::vector<std::string> warnings;
    if (was.isa != now.isa || was.pool != now.pool)
        warnings.push_back(fmt::format(
            "{}: the checkpoint was rendered with {} kernels and a pool of {} paths, this run "
            "uses {} and {}: the image will be right but not bit-identical to an "
            "uninterrupted render",
            path.string(), was.isa, was.pool, now.isa, now.pool));
    return warnings;
}

}  // namespace cierzo
