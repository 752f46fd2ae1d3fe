// Renders that outlive one process, through the cierzo program: under mpirun with 2 and 3
// ranks the image is byte-identical to a one-process render (scalar and wavefront); a time
// budget or SIGINT to mpirun stops every rank with the same paths in every pixel; a killed
// rank ends the run non-zero in bounded time. A render killed with SIGKILL and resumed from
// its checkpoint gives the uninterrupted image; a resume of another render is refused; a
// checkpoint that cannot be written (a file-size limit) leaves the previous one readable.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <csignal>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <optional>
#include <thread>

#include <nlohmann/json.hpp>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include "integrators/checkpoint.h"
#include "io/image.h"
#include "support/emulator.h"
#include "support/removed_at_exit.h"

namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

const fs::path kDir = fs::temp_directory_path() / ("cierzo_dist_" + std::to_string(getpid()));
const cierzo::test::RemovedAtExit kDirRemoved{kDir};
const std::string kScenes = CIERZO_SOURCE_DIR "/scenes/";
const std::string kCierzo = CIERZO_BINARY_DIR "/cierzo";

struct Launch {
    Launch(std::vector<std::string> a, int r = 0, std::optional<rlim_t> limit = std::nullopt)
        : args(std::move(a)), ranks(r), file_size_limit(limit) {}
    std::vector<std::string> args;  // after the program
    int ranks = 0;                  // > 0: through mpirun with this many ranks
    std::optional<rlim_t> file_size_limit;
};

struct Running {
    pid_t pid = -1;
    fs::path err;
};

// Starts cierzo (through mpirun, or the emulator of a cross build), stderr into a file.
Running start(const Launch& l, const std::string& name) {
    fs::create_directories(kDir);
    Running r{-1, kDir / (name + ".stderr")};
    std::vector<std::string> words;
    if (l.ranks > 0) {
        words = {CIERZO_TEST_MPIEXEC, "-np", std::to_string(l.ranks), "--oversubscribe"};
    } else {
        words = cierzo::test::emulator_words();
    }
    words.push_back(kCierzo);
    words.insert(words.end(), l.args.begin(), l.args.end());
    r.pid = fork();
    if (r.pid == 0) {
        // Open MPI refuses root without these (CI runs as root)
        setenv("OMPI_ALLOW_RUN_AS_ROOT", "1", 1);
        setenv("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1", 1);
        setpgid(0, 0);
        // Under AddressSanitizer, Open MPI's own allocations (in plugins it unloads, so the
        // reports cannot even name them) would fail every run at exit: leak checking is off
        // for the ranks only; addresses and undefined behaviour are still checked
        if (const char* asan = std::getenv("ASAN_OPTIONS"); asan && l.ranks > 0)
            setenv("ASAN_OPTIONS", (std::string(asan) + ":detect_leaks=0").c_str(), 1);
        if (l.file_size_limit) {
            rlimit lim{*l.file_size_limit, *l.file_size_limit};
            setrlimit(RLIMIT_FSIZE, &lim);
        }
        if (!freopen(r.err.c_str(), "w", stderr)) _exit(126);
        std::vector<char*> argv;
        for (std::string& w : words) argv.push_back(w.data());
        argv.push_back(nullptr);
        execvp(argv[0], argv.data());
        _exit(127);
    }
    return r;
}

// Waits at most `timeout` seconds; the exit status (128 + signal if killed), or -1 on timeout
// (the process group is then killed).
int finish(const Running& r, double timeout = 600.0) {
    const auto end = Clock::now() + std::chrono::duration<double>(timeout);
    int status = 0;
    while (waitpid(r.pid, &status, WNOHANG) == 0) {
        if (Clock::now() > end) {
            kill(-r.pid, SIGKILL);
            waitpid(r.pid, &status, 0);
            return -1;
        }
        std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
}

int run(const Launch& l, const std::string& name) { return finish(start(l, name)); }

std::string text(const fs::path& p) {
    std::ifstream in(p, std::ios::binary);
    return std::string((std::istreambuf_iterator<char>(in)), {});
}

nlohmann::json stats(const fs::path& p) { return nlohmann::json::parse(text(p)); }

// Every float of the image and of its variance layers, bit for bit.
::testing::AssertionResult same_pixels(const fs::path& a, const fs::path& b) {
    cierzo::ImageLayers la, lb;
    const cierzo::Image ia = cierzo::read_exr(a, nullptr, &la);
    const cierzo::Image ib = cierzo::read_exr(b, nullptr, &lb);
    if (ia.rgb.size() != ib.rgb.size() || la.size() != lb.size())
        return ::testing::AssertionFailure() << a << " and " << b << " differ in size";
    if (std::memcmp(ia.rgb.data(), ib.rgb.data(), ia.rgb.size() * sizeof(float)) != 0)
        return ::testing::AssertionFailure() << a << " and " << b << " differ in their pixels";
    for (const auto& [name, data] : la)
        if (!lb.count(name) ||
            std::memcmp(data.data(), lb[name].data(), data.size() * sizeof(float)))
            return ::testing::AssertionFailure() << a << " and " << b << " differ in " << name;
    return ::testing::AssertionSuccess();
}

// Under an emulator (the aarch64 suite under qemu, about 100 times slower): smaller renders.
bool emulated() { return cierzo::test::lighter_settings(); }

bool have_mpi() { return std::strlen(CIERZO_TEST_MPIEXEC) > 0; }

#define REQUIRE_MPI() \
    if (!have_mpi()) GTEST_SKIP() << "built without MPI (CIERZO_MPI=OFF or no MPI found)"

std::vector<std::string> render_args(const std::string& scene, const fs::path& out,
                                     std::vector<std::string> more) {
    std::vector<std::string> a = {"render", kScenes + scene, "--quiet", "--out", out.string()};
    a.insert(a.end(), more.begin(), more.end());
    return a;
}

// Every estimator, 2, 3 and 4 ranks (each rank owns a band of tiles and adds its passes; the
// splats of lt, bdpt and vcm travel to the owners of their pixels)
TEST(Mpi, TwoThreeAndFourRanksGiveTheOneProcessImageByteForByte) {
    REQUIRE_MPI();
    struct Case {
        std::string scene, integrator;
        std::vector<std::string> extra;
    };
    const std::vector<Case> cases = {
        {"cornell.json", "wavefront", {"--spp", "40", "--width", "72", "--height", "56"}},
        {"cornell.json", "scalar", {"--spp", "12", "--width", "40", "--height", "36"}},
        {"small_emitter.json",
         "wavefront",
         {"--spp", "24", "--width", "48", "--height", "40", "--estimator", "mis"}},
        {"caustic.json",
         "wavefront",
         {"--spp", "12", "--width", "48", "--height", "40", "--estimator", "nee"}},
        // (light tracing: splats of any unit land anywhere in the image)
        {"emitting_spheres.json",
         "wavefront",
         {"--spp", "24", "--width", "48", "--height", "40", "--estimator", "lt"}},
        {"point_lights.json",
         "scalar",
         {"--spp", "6", "--width", "40", "--height", "32", "--estimator", "lt"}},
        // (bidirectional: each unit's light subpaths splat anywhere, its camera paths connect
        // to them)
        {"caustic.json",
         "wavefront",
         {"--spp", "24", "--width", "48", "--height", "40", "--estimator", "bdpt"}},
        {"point_lights.json",
         "scalar",
         {"--spp", "6", "--width", "40", "--height", "32", "--estimator", "bdpt"}},
        // (vcm: a unit merges with its own light subpaths, per sample index)
        {"caustic.json",
         "wavefront",
         {"--spp", "12", "--width", "48", "--height", "40", "--estimator", "vcm"}},
        {"point_lights.json",
         "scalar",
         {"--spp", "4", "--width", "40", "--height", "32", "--estimator", "vcm", "--merge-radius",
          "0.2"}},
        // (bpm and ppm: merging alone, per-path sums as no light path splats)
        {"caustic_mirror.json",
         "wavefront",
         {"--spp", "12", "--width", "48", "--height", "40", "--estimator", "bpm"}},
        {"cornell.json",
         "scalar",
         {"--spp", "4", "--width", "40", "--height", "32", "--estimator", "ppm"}},
        // (the samplers other than the independent one: their streams too are keyed by the
        // pixel and sample, not by the rank)
        {"small_emitter.json",
         "wavefront",
         {"--spp", "24", "--width", "48", "--height", "40", "--estimator", "mis", "--sampler",
          "zsobol"}},
        {"emitting_spheres.json",
         "scalar",
         {"--spp", "6", "--width", "40", "--height", "32", "--estimator", "lt", "--sampler",
          "pmj02"}},
        // (path guiding: every rank's sums of an iteration are added up before each training,
        // at 16, 32 and 64 paths per pixel, and every rank trains the same trees; the
        // wavefront's guided paths too, at every vertex, in its lobe buckets)
        {"small_emitter.json",
         "scalar",
         {"--spp", "80", "--width", "48", "--height", "40", "--estimator", "mis", "--guiding",
          "sdtree"}},
        {"caustic.json",
         "wavefront",
         {"--spp", "80", "--width", "48", "--height", "40", "--estimator", "mis", "--guiding",
          "sdtree", "--guided-vertices", "0"}},
    };
    // (with the lighter settings, in the sanitizer job, 3 ranks alone, whose bands are
    // uneven; the native run has compared 2, 3 and 4 by then)
    const std::vector<int> rank_counts =
        emulated() ? std::vector<int>{3} : std::vector<int>{2, 3, 4};
    int k = 0;
    for (const Case& c : cases) {
        SCOPED_TRACE(c.scene + " " + c.integrator);
        std::vector<std::string> extra = c.extra;
        extra.insert(extra.end(), {"--integrator", c.integrator, "--variance"});
        const fs::path one = kDir / ("one" + std::to_string(k) + ".exr");
        ASSERT_EQ(run({render_args(c.scene, one, extra)}, "one"), 0) << text(kDir / "one.stderr");
        for (int ranks : rank_counts) {
            const fs::path out =
                kDir / ("mpi" + std::to_string(k) + "_" + std::to_string(ranks) + ".exr");
            const fs::path js = kDir / ("mpi" + std::to_string(k) + ".json");
            std::vector<std::string> a = render_args(c.scene, out, extra);
            a.insert(a.end(), {"--stats", js.string()});
            ASSERT_EQ(run({a, ranks}, "mpi"), 0) << text(kDir / "mpi.stderr");
            EXPECT_TRUE(same_pixels(one, out)) << ranks << " ranks";
            const auto j = stats(js);
            ASSERT_TRUE(j.contains("mpi"));
            EXPECT_EQ(j["mpi"]["ranks"], ranks);
            EXPECT_EQ(j["mpi"]["per_rank"].size(), size_t(ranks));
            uint64_t traced = 0;
            for (const auto& r : j["mpi"]["per_rank"]) traced += r["rays"].get<uint64_t>();
            EXPECT_EQ(traced, j["mpi"]["rays_traced"].get<uint64_t>());
            EXPECT_GE(traced, j["rays"]["total"].get<uint64_t>());  // (plus any work after a stop)
        }
        ++k;
    }
}

TEST(Mpi, ATimeBudgetStopsEveryRankWithEqualPathsPerPixel) {
    REQUIRE_MPI();
    const fs::path js = kDir / "tb.json";
    ASSERT_EQ(run({render_args("cornell.json", kDir / "tb.exr",
                               {"--spp", "1000000", "--width", "120", "--height", "100",
                                "--time-budget", "1", "--stats", js.string()}),
                   3},
                  "tb"),
              0)
        << text(kDir / "tb.stderr");
    const auto j = stats(js);
    EXPECT_EQ(j["stopped_by"], "time budget");
    const int64_t spp = j["spp_reached"];
    EXPECT_GT(spp, 0);
    EXPECT_LT(spp, 1000000);
    EXPECT_EQ(j["paths"].get<int64_t>(), 120 * 100 * spp);
    EXPECT_EQ(j["mpi"]["ranks"], 3);
}

// Every band reports its exact error sum at each pass's end, so a target error stops at the
// same pass, with the same image, as in one process (per-path sums, and the batch statistics
// of the estimators that splat)
TEST(Mpi, ATargetErrorStopsAtTheSamePassWithTheSameImageAsOneProcess) {
    REQUIRE_MPI();
    struct Case {
        std::string scene, estimator, target;
    };
    const std::vector<Case> cases = {{"cornell.json", "report", "0.08"},
                                     {"emitting_spheres.json", "lt", "0.1"},
                                     {"caustic.json", "bdpt", "0.1"}};
    for (const Case& c : cases) {
        SCOPED_TRACE(c.estimator);
        const std::vector<std::string> args = {
            "--spp", "100000",         "--width", "48",          "--height",
            "40",    "--target-error", c.target,  "--estimator", c.estimator};
        std::vector<std::string> one = render_args(c.scene, kDir / "te1.exr", args);
        one.insert(one.end(), {"--stats", (kDir / "te1.json").string()});
        ASSERT_EQ(run({one}, "te1"), 0) << text(kDir / "te1.stderr");
        const auto a = stats(kDir / "te1.json");
        EXPECT_EQ(a["stopped_by"], "target error");
        for (int ranks : {2, 4}) {
            std::vector<std::string> many = render_args(c.scene, kDir / "ten.exr", args);
            many.insert(many.end(), {"--stats", (kDir / "ten.json").string()});
            ASSERT_EQ(run({many, ranks}, "ten"), 0) << text(kDir / "ten.stderr");
            const auto b = stats(kDir / "ten.json");
            EXPECT_EQ(b["stopped_by"], "target error") << ranks;
            EXPECT_EQ(a["spp_reached"], b["spp_reached"]) << ranks;
            EXPECT_TRUE(same_pixels(kDir / "te1.exr", kDir / "ten.exr")) << ranks;
        }
    }
}

// A time budget stops every rank at one pass's end: the image is, bit for bit, a one-process
// render of the paths per pixel reached
TEST(Mpi, ATimeBudgetGivesTheOneProcessImageOfThePathsReached) {
    REQUIRE_MPI();
    for (const std::string estimator : {"mis", "bdpt"}) {
        SCOPED_TRACE(estimator);
        const fs::path js = kDir / "tbn.json";
        const std::vector<std::string> size = {"--width", "40",          "--height",
                                               "32",      "--estimator", estimator};
        std::vector<std::string> a = render_args("caustic.json", kDir / "tbn.exr", size);
        a.insert(a.end(), {"--spp", "1000000", "--time-budget", "0.5", "--stats", js.string()});
        ASSERT_EQ(run({a, 3}, "tbn"), 0) << text(kDir / "tbn.stderr");
        const auto j = stats(js);
        EXPECT_EQ(j["stopped_by"], "time budget");
        const int64_t spp = j["spp_reached"];
        ASSERT_GT(spp, 0);
        std::vector<std::string> one = render_args("caustic.json", kDir / "tb1.exr", size);
        one.insert(one.end(), {"--spp", std::to_string(spp)});
        ASSERT_EQ(run({one}, "tb1"), 0) << text(kDir / "tb1.stderr");
        EXPECT_TRUE(same_pixels(kDir / "tb1.exr", kDir / "tbn.exr")) << spp << " paths";
    }
}

// The paths per pixel of the whole passes in checkpoint `ck`, once it has some (waiting up
// to a minute; 0 if it never has).
int64_t finished_passes(const fs::path& ck) {
    for (int i = 0; i < 6000; ++i) {
        try {
            if (fs::exists(ck))
                if (const int64_t n = cierzo::read_checkpoint(ck).state.spp_done; n > 0) return n;
        } catch (const std::exception&) {  // (a file being renamed into place)
        }
        std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    return 0;
}

TEST(Mpi, SigintToMpirunWritesTheImageOfWholePasses) {
    REQUIRE_MPI();
    const fs::path out = kDir / "int.exr", js = kDir / "int.json", ck = kDir / "int.ckpt.exr";
    fs::remove(out), fs::remove(ck);
    const Running r =
        start({render_args("cornell.json", out,
                           {"--spp", "1000000", "--width", "120", "--height", "100", "--stats",
                            js.string(), "--checkpoint", ck.string(), "--checkpoint-every", "0.3"}),
               3},
              "int");
    // (once the render has a pass whole: a signal before cierzo's handlers are in, while MPI
    // starts or the scene loads on a loaded machine, ends a rank as the signal's default
    // does, a render stops at a pass's end at the earliest, and Open MPI ends the ranks a
    // second after passing the signal on)
    ASSERT_GT(finished_passes(ck), 0) << "the render wrote no checkpoint of a whole pass";
    kill(r.pid, SIGINT);
    const int code = finish(r, 60);
    ASSERT_NE(code, -1) << "mpirun did not end within 60 s of SIGINT";
    ASSERT_TRUE(fs::exists(out)) << text(kDir / "int.stderr");
    const auto j = stats(js);
    EXPECT_EQ(j["stopped_by"], "interrupted");
    const int64_t spp = j["spp_reached"];
    EXPECT_GT(spp, 0);
    EXPECT_EQ(j["paths"].get<int64_t>(), 120 * 100 * spp);
}

// The pid of the process of `rank` whose command line has `token`, or -1.
pid_t find_rank(const std::string& token, int rank) {
    for (const auto& e : fs::directory_iterator("/proc")) {
        const std::string name = e.path().filename();
        if (name.find_first_not_of("0123456789") != std::string::npos) continue;
        std::string cmd = text(e.path() / "cmdline"), env = text(e.path() / "environ");
        std::replace(cmd.begin(), cmd.end(), '\0', ' ');
        if (cmd.find(token) == std::string::npos || cmd.find("mpirun") != std::string::npos)
            continue;
        const std::string want = "OMPI_COMM_WORLD_RANK=" + std::to_string(rank);
        for (size_t at = 0; (at = env.find(want, at)) != std::string::npos; at += want.size())
            if ((at == 0 || env[at - 1] == '\0') &&
                (at + want.size() == env.size() || env[at + want.size()] == '\0'))
                return pid_t(std::stoi(name));
    }
    return -1;
}

TEST(Mpi, AKilledRankEndsTheRunNonZeroInBoundedTime) {
    REQUIRE_MPI();
    const fs::path out = kDir / "killed_rank.exr", ck = kDir / "killed_rank.ckpt.exr";
    fs::remove(out), fs::remove(ck);
    const Running r = start({render_args("cornell.json", out,
                                         {"--spp", "1000000", "--checkpoint", ck.string(),
                                          "--checkpoint-every", "0.2"}),
                             3},
                            "killed");
    pid_t victim = -1;
    for (int i = 0; i < 300 && victim < 0; ++i) {
        std::this_thread::sleep_for(std::chrono::milliseconds(50));
        victim = find_rank("killed_rank.exr", 2);
    }
    ASSERT_GT(victim, 0) << "rank 2 never started";
    // (once a checkpoint holds a whole pass)
    const int64_t before = finished_passes(ck);
    ASSERT_GT(before, 0) << "no checkpoint of a whole pass was written";
    kill(victim, SIGKILL);
    const auto killed = Clock::now();
    const int code = finish(r, 60);
    ASSERT_NE(code, -1) << "the run hung after a rank was killed";
    EXPECT_NE(code, 0);
    EXPECT_LT(std::chrono::duration<double>(Clock::now() - killed).count(), 60.0);
    EXPECT_FALSE(fs::exists(out)) << "an image was written by a run that lost a rank";
    // The last checkpoint is whole, and holds at least the passes it held before
    const cierzo::Checkpoint c = cierzo::read_checkpoint(ck);
    EXPECT_GE(c.state.spp_done, before);
}

// A checkpointed render is killed (SIGKILL) once a checkpoint holds part of it; the resume
// ends in the image of an uninterrupted render, byte for byte. Under MPI too, resumed in one
// process.
void kill_and_resume(int ranks, const std::string& scene_file = "cornell.json",
                     const std::vector<std::string>& estimator = {}, int resume_ranks = 0) {
    // (a file name of its own per case: the cases may run at the same time)
    std::string tag = (ranks ? "mpi" + std::to_string(ranks) : "one") +
                      (resume_ranks ? "to" + std::to_string(resume_ranks) : "");
    for (const std::string& a : estimator)
        if (a.rfind("--", 0) != 0) tag += "_" + a;
    const fs::path full = kDir / ("full_" + tag + ".exr"), ck = kDir / ("ck_" + tag + ".exr");
    const fs::path part = kDir / ("part_" + tag + ".exr"),
                   resumed = kDir / ("resumed_" + tag + ".exr");
    // (long enough that the kill lands mid-render: natively a 300-path render can end before
    // its first checkpoint, and the test would then have checked nothing)
    // (bdpt's paths cost several times a camera path's: a smaller image takes as long)
    const bool heavy = std::any_of(estimator.begin(), estimator.end(), [](const std::string& e) {
        return e == "bdpt" || e == "vcm" || e == "bpm" || e == "ppm";
    });
    // (a guided render, by the scalar integrator: past the trainings at 16 and 32 paths per
    // pixel, and natively a few more)
    const bool guided = std::find(estimator.begin(), estimator.end(), "sdtree") != estimator.end();
    // (under qemu a 32x24 pass of bidirectional paths takes a tenth of a second or more: 48
    // paths per pixel outlast the first checkpoint many times over; under a sanitizer,
    // tens of times faster, only 64x48 at 100 paths do)
    const bool qemu = !cierzo::test::emulator_words().empty();
    const std::string spp = guided       ? (emulated() ? "48" : "256")
                            : emulated() ? (heavy ? (qemu ? "48" : "100") : "300")
                            : heavy      ? "800"
                                         : "2000";
    const bool small = emulated() || heavy || guided;
    const bool smaller = qemu && heavy;
    const char* width = smaller ? "32" : small ? "64" : "160";
    const char* height = smaller ? "24" : small ? "48" : "120";
    std::vector<std::string> scene = {"--spp",    spp,    "--width",   width,
                                      "--height", height, "--variance"};
    scene.insert(scene.end(), estimator.begin(), estimator.end());
    ASSERT_EQ(run({render_args(scene_file, full, scene)}, "full"), 0);
    fs::remove(ck), fs::remove(part);
    std::vector<std::string> a = render_args(scene_file, part, scene);
    a.insert(a.end(), {"--checkpoint", ck.string(), "--checkpoint-every", "0.1"});
    const Running r = start({a, ranks}, "part");
    int64_t reached = 0;
    for (int i = 0; i < 12000 && reached == 0; ++i) {
        std::this_thread::sleep_for(std::chrono::milliseconds(10));
        try {
            if (fs::exists(ck)) reached = cierzo::read_checkpoint(ck).state.spp_done;
        } catch (const std::exception&) {
        }
    }
    // mpirun (or cierzo) and every rank (ranks may be in process groups of their own)
    kill(-r.pid, SIGKILL);
    for (int rank = 0; rank < ranks; ++rank)
        for (pid_t p; (p = find_rank(part.filename().string(), rank)) > 0;) {
            kill(p, SIGKILL);
            std::this_thread::sleep_for(std::chrono::milliseconds(20));
        }
    finish(r, 60);
    ASSERT_GT(reached, 0) << "no checkpoint with a finished pass was written";
    const cierzo::Checkpoint c = cierzo::read_checkpoint(ck);
    if (c.state.spp_done == std::stoll(spp))
        GTEST_SKIP() << "the render finished before it was killed";
    EXPECT_FALSE(fs::exists(part));
    std::vector<std::string> more = scene;
    more.insert(more.end(), {"--resume", ck.string(), "--stats", (kDir / "res.json").string()});
    ASSERT_EQ(run({render_args(scene_file, resumed, more), resume_ranks}, "resume"), 0)
        << text(kDir / "resume.stderr");
    EXPECT_TRUE(same_pixels(full, resumed)) << "resumed from " << c.state.spp_done;
    EXPECT_EQ(stats(kDir / "res.json")["spp_resumed"].get<int64_t>(), c.state.spp_done);
    // The resume kept checkpointing into the same file, which now holds the finished render
    EXPECT_EQ(cierzo::read_checkpoint(ck).state.spp_done, std::stoll(spp));
}

TEST(Checkpoints, KilledAndResumedGivesTheUninterruptedImage) { kill_and_resume(0); }

TEST(Checkpoints, KilledUnderMpiAndResumedInOneProcessGivesTheSameImage) {
    REQUIRE_MPI();
    kill_and_resume(2);
}

// A checkpoint holds the whole film whatever the bands were: it resumes on any number of ranks
TEST(Checkpoints, KilledUnderTwoRanksAndResumedUnderThreeGivesTheSameImage) {
    REQUIRE_MPI();
    kill_and_resume(2, "cornell.json", {}, 3);
}

TEST(Checkpoints, LightTracingKilledUnderThreeRanksAndResumedUnderTwoGivesTheSameImage) {
    REQUIRE_MPI();
    kill_and_resume(3, "emitting_spheres.json", {"--estimator", "lt"}, 2);
}

// Light tracing's checkpoints keep whole passes (the splats of a pass in progress are redone)
TEST(Checkpoints, KilledAndResumedLightTracingGivesTheUninterruptedImage) {
    kill_and_resume(0, "emitting_spheres.json", {"--estimator", "lt"});
}

TEST(Checkpoints, KilledAndResumedBidirectionalGivesTheUninterruptedImage) {
    kill_and_resume(0, "caustic.json", {"--estimator", "bdpt"});
}

TEST(Checkpoints, KilledAndResumedVertexMergingGivesTheUninterruptedImage) {
    kill_and_resume(0, "caustic.json", {"--estimator", "vcm"});
}

// (bpm: no splats, so the tiles done of the pass in progress are kept, as for camera paths)
TEST(Checkpoints, KilledAndResumedPhotonMappingGivesTheUninterruptedImage) {
    kill_and_resume(0, "caustic_mirror.json", {"--estimator", "bpm"});
}

// A guided render finished under 2 ranks at 48 paths per pixel (between the trainings at 32
// and 64: its checkpoint holds the ranks' sums of the passes since 32, added up) and at 16 (a
// training point, not yet trained), continued under 3 ranks to 80: the one-process image
TEST(Mpi, AGuidedRenderContinuedOnOtherRanksGivesTheOneProcessImage) {
    REQUIRE_MPI();
    const std::vector<std::string> scene = {"--width",    "48",           "--height", "40",
                                            "--variance", "--estimator",  "mis",      "--guiding",
                                            "sdtree",     "--integrator", "scalar"};
    const auto with = [&](std::vector<std::string> more) {
        more.insert(more.begin(), scene.begin(), scene.end());
        return more;
    };
    const fs::path one = kDir / "guided_one.exr";
    ASSERT_EQ(run({render_args("small_emitter.json", one, with({"--spp", "80"}))}, "g1"), 0)
        << text(kDir / "g1.stderr");
    for (const char* spp : {"16", "48"}) {
        SCOPED_TRACE(spp);
        const fs::path ck = kDir / ("guided_ck" + std::string(spp) + ".exr");
        const fs::path part = kDir / "guided_part.exr", rest = kDir / "guided_rest.exr";
        fs::remove(ck);
        ASSERT_EQ(run({render_args("small_emitter.json", part,
                                   with({"--spp", spp, "--checkpoint", ck.string()})),
                       2},
                      "g2"),
                  0)
            << text(kDir / "g2.stderr");
        EXPECT_EQ(cierzo::read_checkpoint(ck).state.spp_done, std::stoll(spp));
        ASSERT_EQ(run({render_args("small_emitter.json", rest,
                                   with({"--spp", "80", "--resume", ck.string()})),
                       3},
                      "g3"),
                  0)
            << text(kDir / "g3.stderr");
        EXPECT_TRUE(same_pixels(one, rest));
    }
}

// A guided render's checkpoint holds its path guide (the trees and the exact sums of the
// iteration's passes so far, added up over the ranks): resumed on another number of ranks,
// or in one process, the image is the uninterrupted one
TEST(Checkpoints, AGuidedRenderKilledAndResumedGivesTheUninterruptedImage) {
    kill_and_resume(0, "small_emitter.json",
                    {"--estimator", "mis", "--guiding", "sdtree", "--integrator", "scalar"});
}

TEST(Checkpoints, AGuidedRenderKilledUnderTwoRanksAndResumedUnderThreeGivesTheSameImage) {
    REQUIRE_MPI();
    kill_and_resume(2, "small_emitter.json",
                    {"--estimator", "mis", "--guiding", "sdtree", "--integrator", "scalar"}, 3);
}

TEST(Checkpoints, AGuidedRenderKilledUnderThreeRanksAndResumedInOneProcessGivesTheSameImage) {
    REQUIRE_MPI();
    kill_and_resume(3, "small_emitter.json",
                    {"--estimator", "nee", "--guiding", "sdtree", "--integrator", "scalar"});
}

TEST(Checkpoints, KilledAndResumedWithTheSobolSamplerGivesTheUninterruptedImage) {
    kill_and_resume(0, "cornell.json", {"--estimator", "mis", "--sampler", "sobol"});
}

TEST(Checkpoints, AResumeOfAnotherRenderIsRefusedAndDamagesNothing) {
    const fs::path ck = kDir / "other.exr", out = kDir / "keep.pfm";
    ASSERT_EQ(run({render_args("cornell.json", kDir / "o.exr",
                               {"--spp", "4", "--width", "32", "--height", "32", "--checkpoint",
                                ck.string()})},
                  "other"),
              0);
    std::ofstream(out) << "precious";
    const std::string before = text(ck);
    struct Case {
        std::vector<std::string> args;
        std::string says;
    };
    const std::vector<Case> cases = {
        {{"--seed", "5"}, "seed 1 (this render: 5)"},
        {{"--estimator", "nee"}, "estimator report (this render: nee)"},
        {{"--width", "48", "--height", "32"}, "resolution 32x32 (this render: 48x32)"},
        {{"--integrator", "scalar"}, "integrator wavefront (this render: scalar)"},
        {{"--spp", "2"}, "already has 4 paths per pixel"},
    };
    for (const Case& c : cases) {
        std::vector<std::string> a = {
            "render",   kScenes + "cornell.json", "--quiet", "--out", out.string(), "--resume",
            ck.string()};
        a.insert(a.end(), c.args.begin(), c.args.end());
        // (the settings the case does not change are the checkpoint's)
        for (const char* o : {"--width", "--height", "--spp"})
            if (std::find(c.args.begin(), c.args.end(), o) == c.args.end())
                a.insert(a.end(), {o, std::string(o) == "--spp" ? "8" : "32"});
        EXPECT_EQ(run({a}, "refused"), 1) << c.says;
        const std::string err = text(kDir / "refused.stderr");
        EXPECT_NE(err.find(c.says), std::string::npos) << err;
        EXPECT_NE(err.find("other.exr"), std::string::npos) << err;
    }
    // Another scene
    EXPECT_EQ(run({render_args(
                      "box.json", out,
                      {"--width", "32", "--height", "32", "--spp", "8", "--resume", ck.string()})},
                  "refused"),
              1);
    EXPECT_NE(text(kDir / "refused.stderr").find("scene content fingerprint"), std::string::npos);
    // The checkpoint and the image in one file
    EXPECT_EQ(run({render_args("cornell.json", ck, {"--checkpoint", ck.string()})}, "refused"), 1);
    EXPECT_NE(text(kDir / "refused.stderr").find("--checkpoint is the same file as --out"),
              std::string::npos);
    // An interval without a checkpoint file
    EXPECT_EQ(run({render_args("cornell.json", out, {"--checkpoint-every", "5"})}, "refused"), 1);
    EXPECT_NE(text(kDir / "refused.stderr").find("--checkpoint-every needs --checkpoint"),
              std::string::npos);
    EXPECT_TRUE(text(out) == "precious") << "the existing output was changed";
    EXPECT_TRUE(text(ck) == before) << "the checkpoint was changed";
}

TEST(Checkpoints, AWriteOverAFileSizeLimitKeepsThePreviousCheckpoint) {
    // (one process: under mpirun the limit would hold Open MPI's own shared-memory files too;
    // under MPI rank 0 writes the checkpoints through the same writer)
    const fs::path ck = kDir / "limited.exr";
    ASSERT_EQ(run({render_args("cornell.json", kDir / "l.exr",
                               {"--spp", "2", "--width", "96", "--height", "96", "--checkpoint",
                                ck.string()})},
                  "first"),
              0);
    const std::string before = text(ck);
    ASSERT_GT(before.size(), 400000u);
    // A longer render into the same checkpoint, with files limited to 300 kB: every
    // checkpoint write fails (EFBIG), the image (a 110 kB PFM) and the statistics are
    // written, and the exit status says that the last state was not
    Launch l{
        render_args("cornell.json", kDir / "l.pfm",
                    {"--spp", "64", "--width", "96", "--height", "96", "--checkpoint", ck.string(),
                     "--checkpoint-every", "0.05", "--stats", (kDir / "l.json").string()}),
        0, rlim_t(300000)};
    EXPECT_EQ(run(l, "limited"), 1) << text(kDir / "limited.stderr");
    const std::string err = text(kDir / "limited.stderr");
    EXPECT_NE(err.find("limited.exr: cannot write"), std::string::npos) << err;
    EXPECT_NE(err.find("the previous checkpoint is kept"), std::string::npos) << err;
    EXPECT_NE(err.find("limited.exr: the render's last state could not be written"),
              std::string::npos)
        << err;
    EXPECT_GE(stats(kDir / "l.json")["checkpoint"]["failed_writes"].get<int>(), 1);
    EXPECT_TRUE(text(ck) == before) << "the checkpoint was changed";
    EXPECT_EQ(cierzo::read_checkpoint(ck).state.spp_done, 2);
    EXPECT_TRUE(fs::exists(kDir / "l.pfm"));
    EXPECT_FALSE(stats(kDir / "l.json")["warnings"].empty());
    // No temporary file is left behind
    for (const auto& e : fs::directory_iterator(kDir))
        EXPECT_EQ(e.path().filename().string().find(".limited.exr.tmp"), std::string::npos)
            << e.path();
}

}  // namespace
