// Checkpoints in one process: every state a render hands out (mid-pass ones included), when
// resumed, ends in the very film of the uninterrupted render, bit for bit; the file keeps
// the state exactly; a checkpoint of another scene or setting is refused naming what
// differs; a damaged file (any byte of it, a value out of range, counts its header does not
// account for, an attribute declared larger than the file) is refused naming the file, and
// never read as another state.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <map>
#include <mutex>
#include <optional>
#include <tuple>

#include <unistd.h>

#include "core/error.h"
#include "integrators/checkpoint.h"
#include "integrators/path_guide.h"
#include "integrators/registry.h"
#include "integrators/render.h"
#include "io/image.h"
#include "scene/scene_json.h"
#include "support/emulator.h"
#include "support/render_variants.h"
#include "support/removed_at_exit.h"

namespace cierzo {
namespace {

namespace fs = std::filesystem;

const fs::path kDir = fs::temp_directory_path() / ("cierzo_ckpt_" + std::to_string(getpid()));
const test::RemovedAtExit kDirRemoved{kDir};

Scene scene_at(const char* file, int w, int h, int64_t spp) {
    Scene s = load_scene(fs::path(CIERZO_SOURCE_DIR "/scenes") / file);
    s.set_resolution(w, h);
    s.settings.spp = spp;
    return s;
}

// Bit-for-bit equality of every pixel's sums and counts.
::testing::AssertionResult same_film(const Film& a, const Film& b) {
    if (a.width() != b.width() || a.height() != b.height())
        return ::testing::AssertionFailure() << "sizes differ";
    for (size_t i = 0; i < a.pixels().size(); ++i) {
        const PixelSums &p = a.pixels()[i], &q = b.pixels()[i];
        if (std::memcmp(p.sum, q.sum, sizeof(p.sum)) ||
            std::memcmp(p.sum_sq, q.sum_sq, sizeof(p.sum_sq)) || p.count != q.count ||
            p.nonfinite != q.nonfinite)
            return ::testing::AssertionFailure()
                   << "pixel " << i << " differs: " << p.sum[0] << " vs " << q.sum[0] << ", "
                   << p.count << " vs " << q.count << " paths";
    }
    return ::testing::AssertionSuccess();
}

// Bit-for-bit equality of two checkpoints' identity and state.
::testing::AssertionResult same_checkpoint(const Checkpoint& a, const Checkpoint& b) {
    const CheckpointIdentity &x = a.id, &y = b.id;
    if (std::tie(x.scene, x.fingerprint, x.width, x.height, x.seed, x.estimator, x.survival_cap,
                 x.roulette, x.sampler, x.lengths, x.triangle_sampling, x.diffuse_sampling,
                 x.integrator, x.isa, x.pool, x.spp) !=
        std::tie(y.scene, y.fingerprint, y.width, y.height, y.seed, y.estimator, y.survival_cap,
                 y.roulette, y.sampler, y.lengths, y.triangle_sampling, y.diffuse_sampling,
                 y.integrator, y.isa, y.pool, y.spp))
        return ::testing::AssertionFailure() << "the identity differs";
    const RenderState &s = a.state, &t = b.state;
    const auto rays = [](const RayCounts& r) {
        return std::tuple(r.camera, r.extension, r.shadow, r.light);
    };
    if (s.spp_done != t.spp_done || s.pending_end != t.pending_end ||
        s.pending_tiles != t.pending_tiles || s.guide != t.guide || rays(s.rays) != rays(t.rays) ||
        std::memcmp(&s.seconds, &t.seconds, sizeof(double)) != 0 ||
        s.film.batches() != t.film.batches() ||
        s.film.nonfinite_splats() != t.film.nonfinite_splats())
        return ::testing::AssertionFailure() << "the progress differs";
    if (::testing::AssertionResult r = same_film(s.film, t.film); !r) return r;
    return same_film(s.pending, t.pending);
}

std::string file_bytes(const fs::path& p) {
    std::ifstream in(p, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), {});
}

void write_file(const fs::path& p, const std::string& bytes) {
    std::ofstream(p, std::ios::binary).write(bytes.data(), std::streamsize(bytes.size()));
}

// Overwrites byte `at` of an existing file in place (6 us here; rewriting a whole file of
// 19 KB took 2.6 ms, its old blocks discarded).
void put_byte(const fs::path& p, size_t at, char byte) {
    std::fstream f(p, std::ios::binary | std::ios::in | std::ios::out);
    f.seekp(std::streamoff(at));
    f.put(byte);
}

// Whether reading the checkpoint `p` fails with an InputError naming it and saying `needle`.
::testing::AssertionResult refused(const fs::path& p, const std::string& needle) {
    try {
        read_checkpoint(p);
    } catch (const InputError& e) {
        const std::string what = e.what();
        if (what.find(p.filename().string()) == std::string::npos ||
            what.find(needle) == std::string::npos)
            return ::testing::AssertionFailure() << "refused, but saying: " << what;
        return ::testing::AssertionSuccess();
    }
    return ::testing::AssertionFailure() << p << " was read";
}

// Under an emulator (the aarch64 suite runs under qemu, about 100 times slower): the
// scalar reference and one wavefront ISA, on smaller images.
bool emulated() { return test::lighter_settings(); }

// The paths of the pass in progress that a state holds: its pending tiles hold the film's
// pixels with the pass added (pending_end paths each).
uint64_t pass_paths_done(const RenderState& s) {
    uint64_t have = 0;
    for (const PixelSums& p : s.pending.pixels())
        if (p.count + p.nonfinite > 0) {
            EXPECT_EQ(int64_t(p.count + p.nonfinite), s.pending_end);
            have += p.count + p.nonfinite - uint64_t(s.spp_done);
        }
    return have;
}

std::vector<test::Variant> checked_variants() {
    std::vector<test::Variant> v = test::variants();
    if (emulated() && v.size() > 2) v.resize(2);
    return v;
}

RenderOptions options_for(const test::Variant& v, int threads) {
    RenderOptions o;
    o.integrator = integrator_of(v.integrator);
    o.isa = v.isa;
    o.threads = threads;
    o.progress = false;
    return o;
}

// A state holding a finished render of `scene` (its film; every pixel at its spp).
RenderState finished_state(const Scene& scene) {
    fs::create_directories(kDir);
    RenderState s;
    s.film = render(scene, options_for(test::variants().front(), 2)).film;
    s.spp_done = scene.settings.spp;
    return s;
}

TEST(PassBounds, StartAtZeroOrAtAResumedCountAndEndAtSpp) {
    // (an image of 2^20 pixels: every pass of one path per pixel or more has enough paths)
    const int64_t kLarge = kMinPassPaths;
    EXPECT_EQ(pass_bounds(0, 40, kLarge), (std::vector<int64_t>{0, 1, 2, 4, 8, 16, 32, 40}));
    EXPECT_EQ(pass_bounds(0, 1, kLarge), (std::vector<int64_t>{0, 1}));
    EXPECT_EQ(pass_bounds(0, 3, kLarge), (std::vector<int64_t>{0, 1, 2, 3}));
    EXPECT_EQ(pass_bounds(0, 48, kLarge), (std::vector<int64_t>{0, 1, 2, 4, 8, 16, 32, 48}));
    // From a boundary: the same boundaries above it; a finished render of a power of two or a
    // multiple of 16 is on a boundary
    EXPECT_EQ(pass_bounds(16, 40, kLarge), (std::vector<int64_t>{16, 32, 40}));
    const std::vector<int64_t> big = pass_bounds(0, 16384, kLarge);
    EXPECT_NE(std::find(big.begin(), big.end(), 4096), big.end());
    EXPECT_EQ(pass_bounds(4096, 4128, kLarge), (std::vector<int64_t>{4096, 4112, 4128}));
    // From a finished render's count that is not a boundary: the first pass is shorter
    EXPECT_EQ(pass_bounds(20, 40, kLarge), (std::vector<int64_t>{20, 32, 40}));
    EXPECT_EQ(pass_bounds(40, 40, kLarge), (std::vector<int64_t>{40}));
    // Passes never exceed 16 paths per pixel
    for (size_t i = 1; i < big.size(); ++i) EXPECT_LE(big[i] - big[i - 1], 16);
}

// A small image's early passes are joined until each has kMinPassPaths paths (or reaches 16
// paths per pixel); from 16 on, every 16 as for any image.
TEST(PassBounds, ASmallImageJoinsItsEarlyPasses) {
    const int64_t k = kMinPassPaths;
    EXPECT_EQ(pass_bounds(0, 40, k / 2), (std::vector<int64_t>{0, 2, 4, 8, 16, 32, 40}));
    EXPECT_EQ(pass_bounds(0, 40, k / 4), (std::vector<int64_t>{0, 4, 8, 16, 32, 40}));
    EXPECT_EQ(pass_bounds(0, 40, 250 * 250), (std::vector<int64_t>{0, 16, 32, 40}));
    EXPECT_EQ(pass_bounds(0, 16, 250 * 250), (std::vector<int64_t>{0, 16}));
    EXPECT_EQ(pass_bounds(0, 3, 64 * 64), (std::vector<int64_t>{0, 3}));
    EXPECT_EQ(pass_bounds(0, 1, 1), (std::vector<int64_t>{0, 1}));
    EXPECT_EQ(pass_bounds(16, 40, 64 * 64), (std::vector<int64_t>{16, 32, 40}));
    // (a pass between two kept boundaries is never below the minimum unless it reaches 16)
    for (int64_t pixels : {int64_t(1), int64_t(4096), k / 3, k / 2 + 1, k}) {
        const std::vector<int64_t> b = pass_bounds(0, 4096, pixels);
        for (size_t i = 1; i < b.size(); ++i) {
            EXPECT_LE(b[i] - b[i - 1], 16);
            if (b[i] < 16) {
                EXPECT_GE((b[i] - b[i - 1]) * pixels, k) << pixels << " pixels";
            }
        }
        EXPECT_NE(std::find(b.begin(), b.end(), 16), b.end());
    }
}

// The heart of it: states taken every few milliseconds, each resumed, each ending in the
// film of the uninterrupted render, for the scalar reference and every wavefront ISA.
TEST(Checkpoint, EveryStateResumesToTheUninterruptedFilm) {
    size_t mid_total = 0;
    const int w = emulated() ? 48 : 96, h = emulated() ? 40 : 80;
    for (const test::Variant& v : checked_variants()) {
        SCOPED_TRACE(v.integrator + " " + v.isa);
        Scene scene = scene_at("cornell.json", w, h, v.integrator == "scalar" ? 24 : 80);
        const RenderResult full = render(scene, options_for(v, 2));

        std::vector<RenderState> states;
        std::mutex m;
        RenderOptions o = options_for(v, 2);
        o.checkpoint_every = 0.002;
        o.checkpoint = [&](const RenderState& s) {
            std::lock_guard lock(m);
            states.push_back(s);
        };
        const RenderResult again = render(scene, o);
        ASSERT_TRUE(same_film(full.film, again.film)) << "checkpointing changed the image";
        ASSERT_FALSE(states.empty());
        // The last state is the finished render
        EXPECT_EQ(states.back().spp_done, scene.settings.spp);
        EXPECT_TRUE(same_film(states.back().film, full.film));

        // Up to 4 mid-render states, spread over the render
        std::vector<const RenderState*> mids;
        for (const RenderState& s : states)
            if (s.spp_done < scene.settings.spp) mids.push_back(&s);
        const size_t step = std::max<size_t>(1, (mids.size() + 3) / 4);
        size_t mid = 0, with_pending = 0;
        for (size_t i = 0; i < mids.size(); i += step) {
            const RenderState& s = *mids[i];
            ++mid;
            with_pending += !s.pending_tiles.empty();
            // The film of a state holds whole passes: the same paths in every pixel
            for (const PixelSums& p : s.film.pixels())
                ASSERT_EQ(int64_t(p.count + p.nonfinite), s.spp_done);
            RenderOptions r = options_for(v, 1);  // another thread count, too
            r.resume = &s;
            const RenderResult resumed = render(scene, r);
            ASSERT_TRUE(same_film(full.film, resumed.film))
                << "resumed from " << s.spp_done << " paths per pixel with "
                << std::count(s.pending_tiles.begin(), s.pending_tiles.end(), 1)
                << " tiles of the next pass";
            EXPECT_EQ(resumed.stats.spp_resumed, s.spp_done);
            // ...and it rendered only what the state lacked (a resume that started over
            // would end in the same film, so the paths traced tell them apart)
            EXPECT_EQ(
                resumed.stats.rays.camera,
                uint64_t(w * h) * uint64_t(scene.settings.spp - s.spp_done) - pass_paths_done(s));
        }
        std::printf("%s %s: %zu mid-render states resumed, %zu with tiles of a pass\n",
                    v.integrator.c_str(), v.isa.c_str(), mid, with_pending);
        mid_total += mid;
    }
    // (timing decides how many states fall mid-render; a run that saw none checked only
    // the finished state, so it says so)
    if (mid_total == 0) GTEST_SKIP() << "every render ended before a checkpoint was taken";
}

// In the first pass of a render from zero, units' sums go into the film as they come (the
// memory of each is used again at once); a state taken then must still hold an empty film
// and the done tiles apart, and resume to the uninterrupted film, from 1 and from 2
// threads. A snapshot that copied the film as it is would hold tiles of the first pass in
// its film (counts other than 0) and render them twice.
TEST(Checkpoint, AStateTakenInTheFirstPassHoldsAnEmptyFilm) {
    const test::Variant v = test::variants().front();  // (scalar: the longest first pass)
    ASSERT_EQ(v.integrator, "scalar");
    // (one pass of 64: 64 x 48 pixels are far below the 2^20 paths of a pass)
    Scene scene = scene_at("cornell.json", 64, 48, 64);
    const RenderResult full = render(scene, options_for(v, 1));
    size_t seen = 0;
    for (int threads : {1, 2}) {
        SCOPED_TRACE(std::to_string(threads) + " threads");
        for (int attempt = 0; attempt < 8; ++attempt) {
            std::vector<RenderState> states;
            std::mutex m;
            RenderOptions o = options_for(v, threads);
            o.checkpoint_every = 0.0005;
            o.checkpoint = [&](const RenderState& s) {
                std::lock_guard lock(m);
                if (s.spp_done == 0 && !s.pending_tiles.empty()) states.push_back(s);
            };
            const RenderResult again = render(scene, o);
            ASSERT_TRUE(same_film(full.film, again.film)) << "checkpointing changed the image";
            if (states.empty()) continue;  // (the pass ended before a checkpoint was due)
            const RenderState& s = states[states.size() / 2];
            for (const PixelSums& p : s.film.pixels()) {
                ASSERT_EQ(p.count + p.nonfinite, 0u) << "a first-pass state's film holds paths";
                ASSERT_EQ(p.sum[0], 0.0);
            }
            const uint64_t have = pass_paths_done(s);
            ASSERT_GT(have, 0u);
            RenderOptions r = options_for(v, 3 - threads);
            r.resume = &s;
            const RenderResult resumed = render(scene, r);
            ASSERT_TRUE(same_film(full.film, resumed.film));
            EXPECT_EQ(resumed.stats.rays.camera, uint64_t(64 * 48 * 64) - have);
            ++seen;
            break;
        }
    }
    if (seen == 0) GTEST_SKIP() << "every render ended its first pass before a checkpoint";
}

// An interrupted render's final state keeps the tiles done of the pass in progress; resumed,
// it ends in the uninterrupted film. The cancel flag is set by the checkpoint callback once
// a state holds a first pass and some tiles of the next; the render threads may still finish
// that pass before the stop is seen (then the state holds whole passes only, which is right
// too), so up to 8 renders are tried for one that stops mid-pass. A renderer that dropped
// the tiles of a stopped pass would fail every one of them.
TEST(Checkpoint, AnInterruptedStateWithTilesOfAPassResumesExactly) {
    const test::Variant v = test::variants().back();
    Scene scene = scene_at("caustic.json", 80, 64, 64);
    const RenderResult full = render(scene, options_for(v, 2));
    int interrupted = 0, attempts = 0;
    for (; attempts < 8; ++attempts) {
        std::atomic<bool> cancel{false};
        std::vector<RenderState> states;
        RenderOptions o = options_for(v, 2);
        o.cancel = &cancel;
        o.checkpoint_every = 0.001;
        o.checkpoint = [&](const RenderState& s) {
            states.push_back(s);
            if (s.spp_done > 0 && !s.pending_tiles.empty()) cancel = true;
        };
        const RenderResult stopped = render(scene, o);
        ASSERT_FALSE(states.empty());
        const RenderState& last = states.back();
        if (stopped.stats.stopped_by != "interrupted") continue;  // (it ended first)
        ++interrupted;
        EXPECT_EQ(last.spp_done, stopped.stats.spp_reached);
        EXPECT_TRUE(same_film(last.film, stopped.film));
        if (last.pending_tiles.empty()) continue;  // (stopped on a pass boundary)
        RenderOptions r = options_for(v, 2);
        r.resume = &last;
        const RenderResult resumed = render(scene, r);
        EXPECT_TRUE(same_film(full.film, resumed.film));
        const uint64_t have = pass_paths_done(last);
        EXPECT_GT(have, 0u);
        EXPECT_EQ(resumed.stats.rays.camera,
                  uint64_t(80 * 64) * uint64_t(64 - last.spp_done) - have);
        std::printf(
            "stopped mid-pass in render %d, at %lld paths per pixel with %zu tiles of the next "
            "pass\n",
            attempts + 1, static_cast<long long>(last.spp_done),
            size_t(std::count(last.pending_tiles.begin(), last.pending_tiles.end(), 1)));
        return;
    }
    if (interrupted == 0) GTEST_SKIP() << "every render ended before the stop";
    FAIL() << interrupted << " of " << attempts
           << " interrupted renders kept no tiles of the pass in progress";
}

// A finished render of 16 paths per pixel (a pass boundary), continued to 48: the film of
// an uninterrupted render of 48.
TEST(Checkpoint, AFinishedRenderOnABoundaryContinuesToTheBitsOfALongerOne) {
    const test::Variant v = test::variants().back();
    Scene longer = scene_at("caustic.json", 40, 32, 48);
    const RenderResult full = render(longer, options_for(v, 2));
    Scene shorter = longer;
    shorter.settings.spp = 16;
    std::optional<RenderState> last;
    RenderOptions o = options_for(v, 2);
    o.checkpoint = [&](const RenderState& s) { last = s; };
    render(shorter, o);
    ASSERT_TRUE(last);
    ASSERT_EQ(last->spp_done, 16);
    RenderOptions r = options_for(v, 2);
    r.resume = &*last;
    const RenderResult continued = render(longer, r);
    EXPECT_TRUE(same_film(full.film, continued.film));
    EXPECT_EQ(continued.stats.rays.camera, uint64_t(40 * 32 * 32));
    // Resumed to the paths it has reached, it ends at once with its film (it once waited
    // forever for a pass that did not exist)
    r.resume = &*last;
    const RenderResult same = render(shorter, r);
    EXPECT_TRUE(same_film(last->film, same.film));
    EXPECT_EQ(same.stats.rays.camera, 0u);
}

TEST(CheckpointFile, KeepsTheStateExactlyWithTilesOfAPass) {
    Scene scene = scene_at("cornell.json", 37, 21, 8);  // tiles cut at the edges
    RenderState s = finished_state(scene);
    s.pending_end = 15;
    s.rays = {1, 2, 3};
    s.seconds = 1.5;
    const std::vector<Tile> tiles = image_tiles(37, 21);
    s.pending_tiles.assign(tiles.size(), 0);
    s.pending = Film(37, 21);
    s.pending_tiles[1] = s.pending_tiles[4] = 1;
    for (size_t t : {size_t(1), size_t(4)})
        for (int y = tiles[t].y0; y < tiles[t].y1; ++y)
            for (int x = tiles[t].x0; x < tiles[t].x1; ++x) {
                PixelSums& p = s.pending.at(x, y);
                p.sum[0] = 0.1 * x + 1e-17, p.sum_sq[2] = -0.0, p.count = 14, p.nonfinite = 1;
            }
    const CheckpointIdentity id = checkpoint_identity(scene, "scalar", "scalar", 0);
    write_checkpoint(kDir / "k.exr", id, s);
    const Checkpoint c = read_checkpoint(kDir / "k.exr");
    EXPECT_TRUE(same_film(c.state.film, s.film));
    EXPECT_TRUE(same_film(c.state.pending, s.pending));
    EXPECT_EQ(c.state.pending_tiles, s.pending_tiles);
    EXPECT_EQ(c.state.spp_done, 8);
    EXPECT_EQ(c.state.pending_end, 15);
    EXPECT_EQ(c.state.rays.shadow, 3u);
    EXPECT_EQ(c.id.fingerprint, id.fingerprint);
    EXPECT_NO_THROW(check_resume(kDir / "k.exr", c, id));
    // Its R, G, B are the image so far
    const Image img = read_exr(kDir / "k.exr");
    EXPECT_FLOAT_EQ(img.rgb[0], float(s.film.pixels()[0].sum[0] / 8.0));
}

TEST(CheckpointFile, AResumeOfAnotherRenderIsRefusedNamingWhatDiffers) {
    fs::create_directories(kDir);
    Scene scene = scene_at("cornell.json", 16, 16, 4);
    RenderState s;
    s.film = Film(16, 16);
    const CheckpointIdentity id = checkpoint_identity(scene, "wavefront", "avx2", 512);
    write_checkpoint(kDir / "id.exr", id, s);
    const Checkpoint c = read_checkpoint(kDir / "id.exr");
    auto refused = [&](const CheckpointIdentity& now, const std::string& needle) {
        try {
            check_resume(kDir / "id.exr", c, now);
        } catch (const InputError& e) {
            const std::string what = e.what();
            EXPECT_NE(what.find("id.exr"), std::string::npos) << what;
            EXPECT_NE(what.find(needle), std::string::npos) << what;
            return;
        }
        ADD_FAILURE() << "not refused: " << needle;
    };
    CheckpointIdentity other = id;
    other.seed = 9;
    refused(other, "seed 1 (this render: 9)");
    other = id, other.estimator = "mis";
    refused(other, "estimator report (this render: mis)");
    other = id, other.width = 32;
    refused(other, "resolution 16x16 (this render: 32x16)");
    other = id, other.integrator = "scalar";
    refused(other, "integrator wavefront (this render: scalar)");
    Scene box = scene_at("box.json", 16, 16, 4);
    refused(checkpoint_identity(box, "wavefront", "avx2", 512), "scene content fingerprint");
    // bdpt's connections: the light vertex cache's draws (0: the pairing) are the estimator's
    Scene drawn = scene;
    use_estimator(drawn.settings.estimator, Estimator::kBdpt);
    const CheckpointIdentity one = checkpoint_identity(drawn, "wavefront", "avx2", 512);
    EXPECT_NE(one.estimator.find("bdpt draws 1"), std::string::npos) << one.estimator;
    // (and the count its weights give each connection)
    Scene counted = drawn;
    counted.settings.estimator.connection_count = 0.5f;
    const CheckpointIdentity half = checkpoint_identity(counted, "wavefront", "avx2", 512);
    EXPECT_NE(half.estimator.find("counted 0x1p-1"), std::string::npos) << half.estimator;
    EXPECT_NE(half.estimator, one.estimator);
    drawn.settings.estimator.light_connections = 0;
    EXPECT_EQ(checkpoint_identity(drawn, "wavefront", "avx2", 512).estimator, "bdpt");
    // Other kernels: allowed, with a warning that the bits may differ
    other = id, other.isa = "sse4.2";
    const std::vector<std::string> w = check_resume(kDir / "id.exr", c, other);
    ASSERT_EQ(w.size(), 1u);
    EXPECT_NE(w[0].find("not bit-identical"), std::string::npos);
    // The fingerprint follows the content, not the render settings
    Scene reseeded = scene;
    reseeded.settings.seed = 77;
    EXPECT_EQ(scene_fingerprint(reseeded), id.fingerprint);
}

// A file of an older format carries no checksum: it is refused, saying so, rather than
// resumed unverified (the older format is made by changing the format's name, same length).
TEST(CheckpointFile, AFileOfAnOlderCierzoIsRefusedSayingSo) {
    Scene scene = scene_at("cornell.json", 37, 21, 8);
    write_checkpoint(kDir / "older.exr", checkpoint_identity(scene, "scalar", "scalar", 0),
                     finished_state(scene));
    std::string bytes = file_bytes(kDir / "older.exr");
    const size_t at = bytes.find("cierzo checkpoint 3");
    ASSERT_NE(at, std::string::npos);
    bytes[at + 18] = '2';
    write_file(kDir / "older.exr", bytes);
    EXPECT_TRUE(refused(kDir / "older.exr", "written by an older cierzo"));
    EXPECT_TRUE(refused(kDir / "older.exr", "render again"));
}

TEST(CheckpointFile, ADamagedOrForeignFileIsRefusedNamingIt) {
    Scene scene = scene_at("cornell.json", 32, 32, 4);
    RenderState s = finished_state(scene);
    write_checkpoint(kDir / "good.exr", checkpoint_identity(scene, "scalar", "scalar", 0), s);
    auto refused = [&](const fs::path& p, const std::string& needle) {
        try {
            read_checkpoint(p);
        } catch (const InputError& e) {
            const std::string what = e.what();
            EXPECT_NE(what.find(p.filename().string()), std::string::npos) << what;
            EXPECT_NE(what.find(needle), std::string::npos) << what;
            return;
        }
        ADD_FAILURE() << p << " was read";
    };
    // Truncated
    {
        std::ifstream in(kDir / "good.exr", std::ios::binary);
        std::string bytes((std::istreambuf_iterator<char>(in)), {});
        std::ofstream(kDir / "cut.exr", std::ios::binary)
            .write(bytes.data(), std::streamsize(bytes.size() * 2 / 3));
    }
    refused(kDir / "cut.exr", "truncated");
    // An ordinary image is no checkpoint
    write_exr(kDir / "image.exr", Image(8, 8));
    refused(kDir / "image.exr", "not a cierzo checkpoint");
    refused(kDir / "missing.exr", "no such checkpoint");
    // Pixels that do not hold the paths the header claims
    s.film.pixels()[5].count += 1;
    write_checkpoint(kDir / "lying.exr", checkpoint_identity(scene, "scalar", "scalar", 0), s);
    refused(kDir / "lying.exr", "do not all hold");
}

// ---- Damage: every value checked, and a checksum over them all ------------------------------

// A state of 20 x 6 pixels (two tiles) at 4 paths per pixel, with its first tile done of a
// pass in progress to 8: the film's sums added to themselves.
RenderState small_state(const Scene& scene) {
    RenderState s = finished_state(scene);
    s.pending_end = 8;
    const std::vector<Tile> tiles = image_tiles(s.film.width(), s.film.height());
    s.pending_tiles.assign(tiles.size(), 0);
    s.pending_tiles[0] = 1;
    s.pending = Film(s.film.width(), s.film.height());
    for (int y = tiles[0].y0; y < tiles[0].y1; ++y)
        for (int x = tiles[0].x0; x < tiles[0].x1; ++x) {
            s.pending.at(x, y) = s.film.at(x, y);
            s.pending.at(x, y).merge(s.film.at(x, y));
        }
    s.rays = {480, 1234, 567, 0};
    s.seconds = 2.25;
    return s;
}

// Radiance is never negative nor infinite: a sum or a sum of squares that is (or NaN) is
// damage, in the film or in a tile of the pass in progress, and is refused. (A NaN sum once
// resumed into a NaN pixel, and a sum with its sign flipped into a wrong image, exit 0.)
TEST(CheckpointFile, ASumThatIsNaNInfiniteOrNegativeIsRefused) {
    Scene scene = scene_at("cornell.json", 20, 6, 4);
    const RenderState good = small_state(scene);
    const CheckpointIdentity id = checkpoint_identity(scene, "scalar", "scalar", 0);
    const double nan = std::numeric_limits<double>::quiet_NaN();
    const double inf = std::numeric_limits<double>::infinity();
    int damage = 0;
    for (double v : {nan, -nan, inf, -inf, -1.646, -1e-300}) {
        for (int where = 0; where < 3; ++where) {
            SCOPED_TRACE(std::to_string(v) + " at " + std::to_string(where));
            RenderState s = good;
            PixelSums& p = where == 2 ? s.pending.at(3, 2) : s.film.at(7, 5);
            (where == 1 ? p.sum_sq[2] : p.sum[1]) = v;
            const fs::path file = kDir / ("sum_" + std::to_string(damage++) + ".exr");
            write_checkpoint(file, id, s);
            EXPECT_TRUE(refused(file, where == 2 ? "tile 0 of the pass in progress is damaged"
                                                 : "negative or not finite"));
        }
    }
    // (-0 is 0: a sum of nothing, or of zeros)
    RenderState s = good;
    s.film.at(0, 0).sum_sq[0] = -0.0;
    write_checkpoint(kDir / "zero.exr", id, s);
    EXPECT_TRUE(same_checkpoint(read_checkpoint(kDir / "zero.exr"), {id, s}));
}

// Path counts that the header does not account for: a count and a non-finite count adding
// up to the film's paths only by wrapping around 2^64, a tile not done of the pass in
// progress holding sums, more batches than paths, a pass in progress that is not after the
// film's paths, and more paths than asked for.
TEST(CheckpointFile, CountsInconsistentWithTheHeaderAreRefused) {
    Scene scene = scene_at("cornell.json", 20, 6, 4);
    const RenderState good = small_state(scene);
    const CheckpointIdentity id = checkpoint_identity(scene, "scalar", "scalar", 0);
    const fs::path file = kDir / "counts.exr";
    write_checkpoint(file, id, good);
    ASSERT_TRUE(same_checkpoint(read_checkpoint(file), {id, good}));

    RenderState s = good;
    s.film.at(2, 1).count = std::numeric_limits<uint64_t>::max();
    s.film.at(2, 1).nonfinite = 5;  // (2^64 - 1 + 5 = 4, modulo 2^64)
    write_checkpoint(file, id, s);
    EXPECT_TRUE(refused(file, "do not all hold its 4 paths: pixel (2, 1)"));

    s = good;
    s.pending.at(18, 3).sum[0] = 0.5;  // (tile 1 is not done)
    write_checkpoint(file, id, s);
    EXPECT_TRUE(refused(file, "tile 1 of the pass in progress is damaged"));

    s = good;
    s.pending.at(1, 1).nonfinite += 1;  // (9 paths in a pass to 8)
    write_checkpoint(file, id, s);
    EXPECT_TRUE(refused(file, "tile 0 of the pass in progress is damaged"));

    s = good;
    s.film.set_batches(5, 0);
    write_checkpoint(file, id, s);
    EXPECT_TRUE(refused(file, "5 batches in 4 paths per pixel"));

    s = good;
    s.pending_end = 4;
    write_checkpoint(file, id, s);
    EXPECT_TRUE(refused(file, "with a pass in progress to 4"));

    CheckpointIdentity fewer = id;
    fewer.spp = 3;
    write_checkpoint(file, fewer, good);
    EXPECT_TRUE(refused(file, "'cierzo:spp_reached' is 4, not in [0, 3]"));
}

// A guided render's guide must be one PathGuide takes, trained no further than the film's
// paths, and in a checkpoint of a guided estimator; an unguided one holds none.
TEST(CheckpointFile, AGuideThatDoesNotFitItsStateIsRefused) {
    // (passes of 16 and 32 paths per pixel: a training before the second)
    Scene scene = scene_at("cornell.json", 16, 16, 32);
    use_estimator(scene.settings.estimator, Estimator::kMis);
    scene.settings.estimator.guiding = Guiding::kSdTree;
    RenderOptions o = options_for(test::variants().front(), 2);
    RenderState last;
    o.checkpoint = [&](const RenderState& s) { last = s; };
    render(scene, o);
    ASSERT_EQ(last.spp_done, 32);
    ASSERT_FALSE(last.guide.empty());
    last.seconds = 1.5;  // (kept to the microsecond)
    fs::create_directories(kDir);
    const CheckpointIdentity id = checkpoint_identity(scene, "scalar", "scalar", 0);
    const fs::path file = kDir / "guide.exr";
    write_checkpoint(file, id, last);
    EXPECT_TRUE(same_checkpoint(read_checkpoint(file), {id, last}));

    // Trained past the film's paths: the film said to hold fewer
    PathGuide g;
    g.restore(last.guide);
    ASSERT_GT(g.trained_through(), 1);
    RenderState s = last;
    s.spp_done = g.trained_through() - 1;
    for (PixelSums& p : s.film.pixels()) p.count = uint64_t(s.spp_done), p.nonfinite = 0;
    write_checkpoint(file, id, s);
    EXPECT_TRUE(refused(file, "path guide is damaged: trained to"));
    // A guide in a checkpoint of an unguided estimator, and none in one of a guided one
    Scene plain = scene;
    plain.settings.estimator.guiding = Guiding::kNone;
    write_checkpoint(file, checkpoint_identity(plain, "scalar", "scalar", 0), last);
    EXPECT_TRUE(refused(file, "with a path guide"));
    s = last;
    s.guide.clear();
    write_checkpoint(file, id, s);
    EXPECT_TRUE(refused(file, "without a path guide"));
}

// The 4-byte size after an attribute's name and type, in an EXR file's header.
size_t attribute_size_at(const std::string& bytes, const std::string& name,
                         const std::string& type) {
    const std::string key = name + '\0' + type + '\0';
    const size_t at = bytes.find(key);
    return at == std::string::npos ? at : at + key.size();
}

// OpenEXR allocates a string attribute's declared size before reading it: a checkpoint whose
// header declares one of 1.6 GB is refused from its bytes, before OpenEXR parses it, naming
// the attribute; so is a size larger than the file after the data window (which the header
// check once stopped at).
TEST(CheckpointFile, AnAttributeDeclaredLargerThanTheFileIsRefusedFromTheHeader) {
    Scene scene = scene_at("cornell.json", 20, 6, 4);
    write_checkpoint(kDir / "sized.exr", checkpoint_identity(scene, "scalar", "scalar", 0),
                     small_state(scene));
    const std::string good = file_bytes(kDir / "sized.exr");
    for (const auto& [name, type] : {std::pair<std::string, std::string>{"cierzo:scene", "string"},
                                     {"screenWindowWidth", "float"}}) {
        SCOPED_TRACE(name);
        std::string bytes = good;
        const size_t at = attribute_size_at(bytes, name, type);
        ASSERT_NE(at, std::string::npos);
        const uint32_t declared = 0x60000000;  // 1.6 GB, little-endian
        for (int k = 0; k < 4; ++k) bytes[at + size_t(k)] = char((declared >> (8 * k)) & 0xff);
        write_file(kDir / "sized.exr", bytes);
        EXPECT_TRUE(refused(kDir / "sized.exr", "attribute '" + name + "' of 1610612736 bytes"));
    }
}

// A byte damaged in the pixels or in the header's values is a checksum mismatch, named as
// such (they were read as another state, the header's values as other values).
TEST(CheckpointFile, ADamagedByteIsAChecksumMismatch) {
    Scene scene = scene_at("cornell.json", 20, 6, 4);
    const fs::path file = kDir / "checksum.exr";
    write_checkpoint(file, checkpoint_identity(scene, "scalar", "scalar", 0), small_state(scene));
    const std::string good = file_bytes(file);
    // The last byte: the high byte of the last pixel's word of its last channel
    std::string bytes = good;
    bytes.back() ^= 0x01;
    write_file(file, bytes);
    EXPECT_TRUE(refused(file, "checksum mismatch: the file is damaged"));
    // A digit of the seconds so far, and of the rays
    for (const char* key : {"cierzo:seconds", "cierzo:rays"}) {
        bytes = good;
        const size_t at = attribute_size_at(bytes, key, "string");
        ASSERT_NE(at, std::string::npos);
        bytes[at + 4] = bytes[at + 4] == '1' ? '2' : '1';
        write_file(file, bytes);
        EXPECT_TRUE(refused(file, "checksum mismatch")) << key;
    }
}

// The target: every byte of a small render's checkpoint (with a pass in progress) damaged in
// turn, every bit of it flipped and then one bit alone, is refused with an InputError or read
// as the very state and identity written (a byte no reader uses, as a channel's pLinear
// flag), bit for bit: never another state, a crash or another exception. Under an emulator or
// a sanitizer (CIERZO_TEST_EMULATED=1), every 7th byte only.
TEST(CheckpointFile, EveryByteDamagedInTurnIsRefusedOrReadAsWritten) {
    Scene scene = scene_at("cornell.json", 20, 6, 4);
    const RenderState state = small_state(scene);
    const CheckpointIdentity id = checkpoint_identity(scene, "scalar", "scalar", 0);
    const fs::path file = kDir / "whole.exr", damaged = kDir / "damaged.exr";
    write_checkpoint(file, id, state);
    const Checkpoint want{id, state};
    ASSERT_TRUE(same_checkpoint(read_checkpoint(file), want));
    const std::string good = file_bytes(file);
    const size_t step = test::lighter_settings() ? 7 : 1;
    size_t flips = 0, refusals = 0, unchanged = 0;
    std::map<std::string, size_t> reasons;
    const auto start = std::chrono::steady_clock::now();
    write_file(damaged, good);
    for (size_t i = 0; i < good.size(); i += step)
        for (const unsigned char mask : {0xffu, 1u << (i % 8)}) {
            put_byte(damaged, i, char(uint8_t(good[i]) ^ mask));
            ++flips;
            try {
                const Checkpoint c = read_checkpoint(damaged);
                EXPECT_TRUE(same_checkpoint(c, want))
                    << "byte " << i << " ^ " << int(mask) << " read as another state";
                ++unchanged;
            } catch (const InputError& e) {
                const std::string what = e.what();
                EXPECT_NE(what.find(damaged.string()), std::string::npos) << what;
                ++refusals;
                // (the reason, without the file's name and the numbers)
                const size_t from = what.find(": ") + 2;
                reasons[what.substr(from, what.find_first_of("(':0123456789", from) - from)]++;
            } catch (const std::exception& e) {
                ADD_FAILURE() << "byte " << i << " ^ " << int(mask)
                              << ": not an InputError: " << e.what();
            }
            put_byte(damaged, i, good[i]);
        }
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    std::printf("%zu bytes, %zu damaged files in %.1f s: %zu refused, %zu read as written\n",
                good.size(), flips, seconds, refusals, unchanged);
    for (const auto& [why, n] : reasons) std::printf("  %6zu %s\n", n, why.c_str());
    // (those read as written are bytes of the header no reader uses, such as the channels'
    // spare fields and the display window, and line offsets OpenEXR finds again: 564 of
    // 37,920 when written)
    EXPECT_LT(unchanged, flips / 20);
}

}  // namespace
}  // namespace cierzo
