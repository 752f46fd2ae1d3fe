// Checkpoint files: the exact render state in UINT channels of an OpenEXR file.
#include "integrators/checkpoint.h"

#include <algorithm>
#include <array>
#include <bit>
#include <charconv>
#include <cinttypes>
#include <cmath>
#include <cstring>
#include <fstream>
#include <span>
#include <string_view>

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

// (3: with cierzo:checksum, and the pass in progress always with the film added)
constexpr const char* kFormat = "cierzo checkpoint 3";

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

// The checksum of a checkpoint (cierzo:checksum): a 64-bit hash of its size, its cierzo:
// attributes and every word of its channels, so that damage anywhere in what a resume reads
// is refused rather than resumed. 64-bit words go round four lanes; a lane takes a word by
// an xor, a multiply by an odd constant and an xor-shift, each one-to-one, and the lanes are
// folded together by the same step, so a change confined to one word (any one damaged byte)
// always changes the checksum; other damage changes it but with odds of 2^-64.
class Checksum {
public:
    void word(uint64_t w) {
        uint64_t& lane = lanes_[words_++ & 3];
        lane = step(lane, w);
    }
    // A byte string: its length, then its bytes eight to a word, the first in the low byte
    void text(std::string_view s) {
        word(s.size());
        for (size_t i = 0; i < s.size(); i += 8) {
            uint64_t w = 0;
            for (size_t k = 0; k < 8 && i + k < s.size(); ++k)
                w |= uint64_t(uint8_t(s[i + k])) << (8 * k);
            word(w);
        }
    }
    // 32-bit words: their count, then two to a word, the first in the low half
    void words32(std::span<const uint32_t> v) {
        word(v.size());
        const auto pair = [&](size_t i) { return uint64_t(v[i]) | uint64_t(v[i + 1]) << 32; };
        size_t i = 0;
        for (; (words_ & 3) != 0 && i + 2 <= v.size(); i += 2) word(pair(i));
        // (four words at a time, one to a lane, while they last)
        uint64_t a = lanes_[0], b = lanes_[1], c = lanes_[2], d = lanes_[3];
        const size_t start = i;
        for (; i + 8 <= v.size(); i += 8) {
            a = step(a, pair(i)), b = step(b, pair(i + 2));
            c = step(c, pair(i + 4)), d = step(d, pair(i + 6));
        }
        lanes_ = {a, b, c, d};
        words_ += (i - start) / 2;
        for (; i + 2 <= v.size(); i += 2) word(pair(i));
        if (i < v.size()) word(v[i]);
    }
    uint64_t value() const {
        uint64_t h = step(0x6a09e667f3bcc909ull, words_);
        for (uint64_t lane : lanes_) h = step(h, lane);
        h = (h ^ (h >> 32)) * 0xd6e8feb86659fd93ull;
        return h ^ (h >> 32);
    }

private:
    static uint64_t step(uint64_t h, uint64_t w) {
        h = (h ^ w) * 0x9e3779b97f4a7c15ull;
        return h ^ (h >> 29);
    }
    std::array<uint64_t, 4> lanes_ = {0x243f6a8885a308d3ull, 0x13198a2e03707344ull,
                                      0xa4093822299f31d0ull, 0x082efa98ec4e6c89ull};
    uint64_t words_ = 0;
};

constexpr const char* kChecksumKey = "cierzo:checksum";

// What the checksum covers: the data window, every cierzo: attribute but the checksum
// (name and value, in the header's order), and the channels' words: the film's, the pass in
// progress's (none without one) and the preview's R, G, B.
uint64_t payload_checksum(const Imf::Header& header, std::span<const uint32_t> words,
                          std::span<const uint32_t> pending_words,
                          std::span<const uint32_t> preview) {
    Checksum c;
    const Imath::Box2i& win = header.dataWindow();
    for (int v : {win.min.x, win.min.y, win.max.x, win.max.y}) c.word(uint32_t(v));
    for (auto it = header.begin(); it != header.end(); ++it) {
        const std::string_view name = it.name();
        if (!name.starts_with("cierzo:") || name == kChecksumKey) continue;
        c.text(name);
        const auto* s = dynamic_cast<const Imf::StringAttribute*>(&it.attribute());
        c.text(s ? std::string_view(s->value()) : std::string_view(it.attribute().typeName()));
    }
    c.words32(words);
    c.words32(pending_words);
    c.words32(preview);
    return c.value();
}

// A checkpoint's header, read strictly: every value present, of its form and in its range,
// or an InputError naming the file and the attribute.
struct HeaderReader {
    const Imf::Header& header;
    const fs::path& path;

    [[noreturn]] void fail(const std::string& what) const {
        throw InputError(path.string() + ": " + what);
    }
    [[noreturn]] void malformed(const std::string& key, const std::string& v) const {
        fail("checkpoint header '" + key + "' is malformed: '" + v + "'");
    }
    std::string text(const std::string& key) const {
        const auto* a = header.findTypedAttribute<Imf::StringAttribute>(key);
        if (!a) fail("checkpoint header has no '" + key + "' (damaged file?)");
        return a->value();
    }
    // Decimal integers separated by single spaces, each in [lo, hi]
    template <typename T>
    std::vector<T> integers(const std::string& key, size_t n, T lo, T hi) const {
        const std::string v = text(key);
        std::vector<T> out(n);
        const char* p = v.data();
        const char* end = v.data() + v.size();
        for (size_t i = 0; i < n; ++i) {
            if (i > 0 && (p == end || *p++ != ' ')) malformed(key, v);
            const auto [next, ec] = std::from_chars(p, end, out[i]);
            if (ec != std::errc() || next == p) malformed(key, v);
            if (out[i] < lo || out[i] > hi)
                fail(fmt::format("checkpoint header '{}' is {}, not in [{}, {}]", key, v, lo, hi));
            p = next;
        }
        if (p != end) malformed(key, v);
        return out;
    }
    int64_t integer(const std::string& key, int64_t lo, int64_t hi) const {
        return integers<int64_t>(key, 1, lo, hi)[0];
    }
    // A finite number of seconds, at least 0
    double seconds(const std::string& key) const {
        const std::string v = text(key);
        double x = 0.0;
        const auto [next, ec] = std::from_chars(v.data(), v.data() + v.size(), x);
        if (ec != std::errc() || next != v.data() + v.size() || !std::isfinite(x) || x < 0.0)
            malformed(key, v);
        return x;
    }
};

// Radiance is never negative (every BSDF value, cosine, weight and splat is clamped at 0),
// so neither is a sum of it nor of its squares; nor is any infinite or NaN (non-finite
// samples are counted apart). -0 passes: it is 0.
bool sums_valid(const PixelSums& p) {
    for (int c = 0; c < 3; ++c)
        if (!(p.sum[c] >= 0.0) || !(p.sum_sq[c] >= 0.0) || !std::isfinite(p.sum[c]) ||
            !std::isfinite(p.sum_sq[c]))
            return false;
    return true;
}

// Whether a pixel holds exactly `paths` paths, finite and not (without wrapping around)
bool holds(const PixelSums& p, uint64_t paths) {
    return p.count <= paths && p.nonfinite == paths - p.count;
}

// The film's pixels: valid sums, and spp_done paths each.
void check_film(const HeaderReader& r, const Film& film, int64_t spp_done) {
    for (int y = 0; y < film.height(); ++y)
        for (int x = 0; x < film.width(); ++x) {
            const PixelSums& p = film.at(x, y);
            if (!sums_valid(p))
                r.fail(fmt::format(
                    "checkpoint pixel ({}, {}) holds a sum that is negative or not finite: "
                    "{} {} {}, squares {} {} {} (damaged file?)",
                    x, y, p.sum[0], p.sum[1], p.sum[2], p.sum_sq[0], p.sum_sq[1], p.sum_sq[2]));
            if (!holds(p, uint64_t(spp_done)))
                r.fail(fmt::format(
                    "checkpoint pixels do not all hold its {} paths: pixel ({}, {}) holds {} "
                    "and {} not finite (damaged file?)",
                    spp_done, x, y, p.count, p.nonfinite));
        }
}

// The tiles of the pass in progress: each one done (every pixel at pending_end paths, with
// valid sums) or not (every pixel empty). Returns which are done.
std::vector<uint8_t> check_pending(const HeaderReader& r, const Film& pending,
                                   int64_t pending_end) {
    const std::vector<Tile> tiles = image_tiles(pending.width(), pending.height());
    std::vector<uint8_t> done(tiles.size(), 0);
    for (size_t t = 0; t < tiles.size(); ++t) {
        const Tile& g = tiles[t];
        const PixelSums& first = pending.at(g.x0, g.y0);
        done[t] = first.count != 0 || first.nonfinite != 0;
        const uint64_t paths = done[t] ? uint64_t(pending_end) : 0;
        for (int y = g.y0; y < g.y1; ++y)
            for (int x = g.x0; x < g.x1; ++x) {
                const PixelSums& p = pending.at(x, y);
                const bool empty = p.sum[0] == 0.0 && p.sum[1] == 0.0 && p.sum[2] == 0.0 &&
                                   p.sum_sq[0] == 0.0 && p.sum_sq[1] == 0.0 && p.sum_sq[2] == 0.0;
                if (!holds(p, paths) || !sums_valid(p) || (!done[t] && !empty))
                    r.fail(fmt::format(
                        "checkpoint tile {} of the pass in progress is damaged (pixel ({}, "
                        "{}) holds {} paths and {} not finite, of {})",
                        t, x, y, p.count, p.nonfinite, paths));
            }
    }
    return done;
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
    std::vector<uint32_t> preview(mean.rgb.size());  // (the floats' bits, for the checksum)
    std::memcpy(preview.data(), mean.rgb.data(), preview.size() * sizeof(float));
    const std::vector<uint32_t> words = film_words(film);
    const std::vector<uint32_t> pending_words =
        pending ? film_words(state.pending) : std::vector<uint32_t>{};
    put(kChecksumKey,
        fmt::format("{:016x}", payload_checksum(header, words, pending_words, preview)));
    const size_t n = size_t(w) * size_t(h);
    write_output_stream(path, [&](std::ofstream& out) {
        Imf::StdOFStream stream(out, path.c_str());
        Imf::OutputFile file(stream, header);
        Imf::FrameBuffer frame;
        const auto slice = [&](Imf::PixelType type, const uint32_t* at, size_t step) {
            return Imf::Slice(type, const_cast<char*>(reinterpret_cast<const char*>(at)),
                              step * sizeof(uint32_t), step * sizeof(uint32_t) * size_t(w));
        };
        const char* names[3] = {"R", "G", "B"};
        for (int c = 0; c < 3; ++c) frame.insert(names[c], slice(Imf::FLOAT, &preview[c], 3));
        for (int k = 0; k < kWords; ++k) {
            frame.insert(kWordNames[k], slice(Imf::UINT, &words[size_t(k) * n], 1));
            if (pending)
                frame.insert(std::string("pending.") + kWordNames[k],
                             slice(Imf::UINT, &pending_words[size_t(k) * n], 1));
        }
        file.setFrameBuffer(frame);
        file.writePixels(h);
    });
}

Checkpoint read_checkpoint(const fs::path& path) {
    if (!input_file_exists(path)) throw InputError(path.string() + ": no such checkpoint file");
    // (OpenEXR sizes its buffers from the header as declared: checked before it reads it)
    check_exr_header(path);
    try {
        Imf::InputFile file(path.c_str());
        const Imf::Header& header = file.header();
        const HeaderReader r{header, path};

        // What it is: a checkpoint of this format, with its checksum
        const auto* format = header.findTypedAttribute<Imf::StringAttribute>("cierzo:checkpoint");
        if (!format) r.fail("not a cierzo checkpoint (no 'cierzo:checkpoint' in its header)");
        if (format->value() == "cierzo checkpoint 1" || format->value() == "cierzo checkpoint 2")
            r.fail("a checkpoint written by an older cierzo ('" + format->value() +
                   "'), which has no checksum to verify it by: render again without --resume "
                   "(this cierzo reads '" +
                   std::string(kFormat) + "')");
        if (format->value() != kFormat)
            r.fail("a checkpoint of another format ('" + format->value() +
                   "', this cierzo reads '" + kFormat + "')");
        for (auto it = header.begin(); it != header.end(); ++it)
            if (std::string_view(it.name()).starts_with("cierzo:") &&
                std::strcmp(it.attribute().typeName(), "string") != 0)
                r.fail(std::string("checkpoint header '") + it.name() + "' is of type '" +
                       it.attribute().typeName() + "', not a string (damaged file?)");
        const std::string checksum = r.text(kChecksumKey);
        if (checksum.size() != 16 ||
            checksum.find_first_not_of("0123456789abcdef") != std::string::npos)
            r.malformed(kChecksumKey, checksum);
        if (!file.isComplete()) r.fail("truncated checkpoint (pixel data missing)");

        // Its size and channels: R, G, B as floats and the words of the film, and of the
        // pass in progress if any, uncompressed (so the file holds every byte they need)
        const Imath::Box2i win = header.dataWindow();
        const int64_t w = int64_t(win.max.x) - win.min.x + 1,
                      h = int64_t(win.max.y) - win.min.y + 1;
        if (win.min.x != 0 || win.min.y != 0 || w <= 0 || h <= 0 || w * h > kMaxImagePixels)
            r.fail("checkpoint of an invalid size " + std::to_string(w) + "x" + std::to_string(h));
        const Imf::ChannelList& channels = header.channels();
        const bool pending = channels.findChannel("pending.count.lo") != nullptr;
        std::vector<std::string> expected = {"R", "G", "B"};
        for (const char* n : kWordNames) {
            expected.push_back(n);
            if (pending) expected.push_back("pending." + std::string(n));
        }
        for (const std::string& name : expected) {
            const Imf::Channel* ch = channels.findChannel(name);
            if (!ch) r.fail("checkpoint channel '" + name + "' is missing");
            const Imf::PixelType type = name.size() == 1 ? Imf::FLOAT : Imf::UINT;
            if (ch->type != type || ch->xSampling != 1 || ch->ySampling != 1)
                r.fail("checkpoint channel '" + name + "' is not a full-resolution " +
                       (type == Imf::FLOAT ? "FLOAT" : "UINT") + " channel");
        }
        size_t channel_count = 0;
        for (auto it = channels.begin(); it != channels.end(); ++it) ++channel_count;
        if (channel_count != expected.size())
            r.fail(
                fmt::format("checkpoint of {} channels, not {}", channel_count, expected.size()));
        if (header.compression() != Imf::NO_COMPRESSION)
            r.fail("checkpoint compressed (cierzo writes them uncompressed)");
        const size_t n = size_t(w) * size_t(h);
        std::error_code ec;
        const uintmax_t file_bytes = fs::file_size(path, ec);
        if (ec || file_bytes / 4 / expected.size() < n) r.fail("truncated checkpoint");

        // Every word, and the checksum over them and the header
        std::vector<uint32_t> words(n * kWords), pending_words(pending ? n * kWords : 0);
        std::vector<uint32_t> preview(n * 3);
        Imf::FrameBuffer frame;
        const auto slice = [&](Imf::PixelType type, uint32_t* at, size_t step) {
            return Imf::Slice(type, reinterpret_cast<char*>(at), step * sizeof(uint32_t),
                              step * sizeof(uint32_t) * size_t(w));
        };
        for (int c = 0; c < 3; ++c)
            frame.insert(expected[size_t(c)], slice(Imf::FLOAT, &preview[size_t(c)], 3));
        for (int k = 0; k < kWords; ++k) {
            frame.insert(kWordNames[k], slice(Imf::UINT, &words[size_t(k) * n], 1));
            if (pending)
                frame.insert(std::string("pending.") + kWordNames[k],
                             slice(Imf::UINT, &pending_words[size_t(k) * n], 1));
        }
        file.setFrameBuffer(frame);
        file.readPixels(0, int(h) - 1);
        if (fmt::format("{:016x}", payload_checksum(header, words, pending_words, preview)) !=
            checksum)
            r.fail(
                "checksum mismatch: the file is damaged (its contents are not those "
                "cierzo wrote); resume from another copy, or render again");

        // What it belongs to
        Checkpoint c;
        CheckpointIdentity& id = c.id;
        id.scene = r.text("cierzo:scene");
        id.fingerprint = r.text("cierzo:fingerprint");
        if (id.fingerprint.size() != 16 ||
            id.fingerprint.find_first_not_of("0123456789abcdef") != std::string::npos)
            r.malformed("cierzo:fingerprint", id.fingerprint);
        id.width = int(w), id.height = int(h);
        id.seed = uint32_t(r.integer("cierzo:seed", 0, UINT32_MAX));
        id.estimator = r.text("cierzo:estimator");
        id.survival_cap = r.text("cierzo:survival_cap");
        id.diffuse_sampling = r.text("cierzo:diffuse_sampling");
        id.roulette = r.text("cierzo:roulette");
        id.triangle_sampling = r.text("cierzo:triangle_sampling");
        id.sampler = r.text("cierzo:sampler");
        id.lengths = r.text("cierzo:path_lengths");
        id.integrator = r.text("cierzo:integrator");
        id.isa = r.text("cierzo:isa");
        id.pool = int(r.integer("cierzo:pool", 0, INT32_MAX));
        id.spp = r.integer("cierzo:spp", 1, UINT32_MAX);
        r.integer("cierzo:tile_size", kTileSize, kTileSize);

        // How far it got: every pixel of the film at spp_done paths, and the tiles done of
        // the pass in progress [spp_done, pending_end) at pending_end
        RenderState& s = c.state;
        s.spp_done = r.integer("cierzo:spp_reached", 0, id.spp);
        s.pending_end = r.integer("cierzo:pending_end", 0, INT64_MAX);
        if (pending ? s.pending_end <= s.spp_done
                    : s.pending_end != 0 && s.pending_end <= s.spp_done)
            r.fail(fmt::format("checkpoint of {} paths per pixel with a pass in progress to {}",
                               s.spp_done, s.pending_end));
        const std::vector<uint64_t> rays = r.integers<uint64_t>("cierzo:rays", 4, 0, UINT64_MAX);
        s.rays.camera = rays[0], s.rays.extension = rays[1], s.rays.shadow = rays[2],
        s.rays.light = rays[3];
        const std::vector<uint64_t> batches =
            r.integers<uint64_t>("cierzo:batches", 2, 0, UINT64_MAX);
        if (batches[0] > uint64_t(s.spp_done))
            r.fail(fmt::format("checkpoint of {} batches in {} paths per pixel", batches[0],
                               s.spp_done));
        s.seconds = r.seconds("cierzo:seconds");
        s.film = Film(int(w), int(h));
        words_to_film(words, s.film);
        s.film.set_batches(int64_t(batches[0]), batches[1]);
        check_film(r, s.film, s.spp_done);
        if (pending) {
            s.pending = Film(int(w), int(h));
            words_to_film(pending_words, s.pending);
            s.pending_tiles = check_pending(r, s.pending, s.pending_end);
        }

        // A guided render's guide: a state PathGuide takes, trained at most to spp_done,
        // and in a checkpoint of whole passes (of a guided estimator)
        if (const auto* g = header.findTypedAttribute<Imf::StringAttribute>("cierzo:guide")) {
            s.guide.assign(g->value().begin(), g->value().end());
            try {
                PathGuide check;
                check.restore(s.guide);
                if (check.trained_through() > s.spp_done)
                    throw GuideStateError(fmt::format("trained to {} paths per pixel, of {}",
                                                      check.trained_through(), s.spp_done));
            } catch (const GuideStateError& e) {
                r.fail(std::string("the checkpoint's path guide is damaged: ") + e.what());
            }
            if (pending) r.fail("checkpoint of a guided render with tiles of a pass in progress");
        }
        if (s.guide.empty() != (id.estimator.find(" guided ") == std::string::npos))
            r.fail("checkpoint of estimator '" + id.estimator + "' " +
                   (s.guide.empty() ? "without" : "with") + " a path guide");
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
