// The `cierzo` program end to end: it renders tiny scenes to EXR/PFM, writes consistent --stats,
// lets options override the file, and refuses bad input with a message and no damaged output.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include <spawn.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <nlohmann/json.hpp>

#include "integrators/registry.h"
#include "integrators/wavefront/isa.h"
#include "support/emulator.h"
#include "support/program_test.h"
#include "support/scratch.h"
#include "support/sparse_file.h"

namespace {

namespace fs = std::filesystem;
using cierzo::test::Outcome;
using cierzo::test::quote;
using cierzo::test::read_file;
using nlohmann::json;

// 8 x 8 pixels, 2 paths each: a diffuse floor and sphere under a point light and an emitter,
// so that camera, extension and shadow rays are all traced.
const char* const kTinyScene = R"({
    "render": {"width": 8, "height": 8, "spp": 2, "seed": 3},
    "camera": {"position": [0, 0, -3], "look_at": [0, 0, 0]},
    "materials": {"white": {"kd": 0.8}, "lamp": {"emission": 2}},
    "objects": [
        {"type": "plane", "normal": [0, 1, 0], "distance": 1, "material": "white"},
        {"type": "sphere", "center": [0, 0, 0], "radius": 0.5, "material": "white"},
        {"type": "sphere", "center": [0, 2, 0], "radius": 0.5, "material": "lamp"}
    ],
    "lights": [{"position": [1, 1, -1], "intensity": 1}]
})";

// The attributes of an OpenEXR header, name -> raw value bytes; empty if not an EXR.
std::map<std::string, std::string> exr_header(const fs::path& path) {
    const std::string b = read_file(path);
    std::map<std::string, std::string> attrs;
    if (b.size() < 8 || b.compare(0, 4, "\x76\x2f\x31\x01") != 0) return attrs;
    size_t pos = 8;
    auto cstr = [&](std::string& out) {
        const size_t end = b.find('\0', pos);
        if (end == std::string::npos) return false;
        out = b.substr(pos, end - pos);
        pos = end + 1;
        return true;
    };
    std::string name, type;
    while (cstr(name) && !name.empty() && cstr(type) && pos + 4 <= b.size()) {
        int32_t size;
        std::memcpy(&size, b.data() + pos, 4);  // little-endian, as on x86
        pos += 4;
        if (size < 0 || pos + size_t(size) > b.size()) return {};
        attrs[name] = b.substr(pos, size_t(size));
        pos += size_t(size);
    }
    return attrs;
}

// Width and height from an EXR's dataWindow (box2i: xMin, yMin, xMax, yMax).
std::pair<int, int> exr_size(const fs::path& path) {
    const auto h = exr_header(path);
    const auto it = h.find("dataWindow");
    if (it == h.end() || it->second.size() != 16) return {-1, -1};
    int32_t box[4];
    std::memcpy(box, it->second.data(), 16);
    return {box[2] - box[0] + 1, box[3] - box[1] + 1};
}

// (a class of this name: the tests' names stay "cli.*")
class cli : public cierzo::test::ProgramTest {};

const char* const kQuiet = " --threads 1 --quiet";

TEST_F(cli, RendersAnExrNextToTheScene) {
    const fs::path scene = write("tiny.json", kTinyScene);
    const Outcome r = run(quote(scene) + kQuiet);
    ASSERT_EQ(r.exit_code, 0) << r.err;
    const fs::path exr = dir_ / "tiny.exr";  // default: the scene's name, in its folder
    ASSERT_TRUE(fs::exists(exr)) << r.err;
    EXPECT_EQ(exr_size(exr), std::make_pair(8, 8));
    EXPECT_NE(r.err.find(exr.string()), std::string::npos) << r.err;  // the summary line
    EXPECT_EQ(other_files({"tiny.json", "tiny.exr"}), std::vector<std::string>{});
}

TEST_F(cli, WritesPfmByExtension) {
    const fs::path scene = write("tiny.json", kTinyScene);
    const fs::path out = dir_ / "image.pfm";
    const Outcome r = run(quote(scene) + kQuiet + " --out " + quote(out));
    ASSERT_EQ(r.exit_code, 0) << r.err;
    EXPECT_EQ(read_file(out).substr(0, 7), "PF\n8 8\n");
    EXPECT_FALSE(fs::exists(dir_ / "tiny.exr"));
}

// Every ISA this CPU cannot run, whether this build lacks its kernels (neon on x86-64,
// avx512 on aarch64: always at least one) or the CPU lacks its instructions, is refused by
// render and converge with the reason and a non-zero exit, before anything is written.
TEST_F(cli, AnIsaThisCpuCannotRunIsRefusedWithTheReason) {
    const fs::path scene = write("tiny.json", kTinyScene);
    int refused = 0;
    for (cierzo::Isa isa :
         {cierzo::Isa::kAvx512, cierzo::Isa::kAvx2, cierzo::Isa::kSse42, cierzo::Isa::kNeon}) {
        if (cierzo::isa_supported(isa)) continue;
        const std::string name = cierzo::isa_name(isa);
        SCOPED_TRACE(name);
        const std::string why = cierzo::isa_unsupported_reason(isa);
        ASSERT_FALSE(why.empty());
        const fs::path out = dir_ / "refused.exr";
        const Outcome r = run(quote(scene) + kQuiet + " --isa " + name + " --out " + quote(out));
        EXPECT_EQ(r.exit_code, 1) << r.err;
        EXPECT_NE(r.err.find("--isa " + name + ": " + why), std::string::npos) << r.err;
        EXPECT_NE(r.err.find("valid here: " + cierzo::usable_isa_names()), std::string::npos)
            << r.err;
        EXPECT_FALSE(fs::exists(out));
        const Outcome c =
            run(quote(scene) + " --spp 1 --reference-spp 2 --threads 1 --isa " + name, "converge");
        EXPECT_EQ(c.exit_code, 1) << c.err;
        EXPECT_NE(c.err.find(why), std::string::npos) << c.err;
        ++refused;
    }
    EXPECT_GE(refused, 1);  // the other architecture's ISA at least
}

// `cierzo isas` lists exactly the ISAs of this build, says which this CPU runs as the
// library decides it, and marks one (the widest it runs) as auto's choice.
TEST_F(cli, IsasListsEveryIsaOfThisBuildAndWhatTheCpuRuns) {
    const Outcome r = run("", "isas");
    ASSERT_EQ(r.exit_code, 0) << r.err;
    std::vector<std::string> names;
    int autos = 0;
    std::istringstream lines(r.out);
    for (std::string line; std::getline(lines, line);) {
        std::vector<std::string> f;
        std::istringstream cols(line);
        for (std::string col; std::getline(cols, col, '\t');) f.push_back(col);
        ASSERT_GE(f.size(), 3u) << line;
        const cierzo::Isa isa = cierzo::parse_isa(f[0]);
        names.push_back(f[0]);
        EXPECT_EQ(f[1], std::to_string(cierzo::isa_width(isa)) + " lanes");
        EXPECT_EQ(f[2] != "no", cierzo::isa_supported(isa)) << line;
        if (f[2] == "yes, auto") {
            ++autos;
            EXPECT_EQ(isa, cierzo::best_isa());
        }
        EXPECT_EQ(f.size() > 3 ? f[3] : "", cierzo::isa_unsupported_reason(isa)) << line;
    }
    std::vector<std::string> expected;
    for (cierzo::Isa isa : cierzo::compiled_isas()) expected.push_back(cierzo::isa_name(isa));
    EXPECT_EQ(names, expected);
    EXPECT_EQ(autos, 1);
}

// A render on one thread hands nothing between threads: each unit is rendered and handed in
// by the thread that took it, and a finished unit wakes nobody. (When every unit crossed
// threads, this render of 1,280 units made about 1,000 voluntary context switches; it makes
// about a dozen.) The count comes from the kernel (wait4), not from a clock.
TEST_F(cli, OneThreadHandsNothingBetweenThreads) {
    if (cierzo::test::lighter_settings() || !cierzo::test::emulator_words().empty())
        GTEST_SKIP() << "an emulator's or sanitizer's runtime switches threads of its own";
    const std::string program = CIERZO_BINARY_DIR "/cierzo";
    const std::string scene = CIERZO_SOURCE_DIR "/scenes/cornell.json";
    const std::string out = (dir_ / "c.exr").string(), stats = (dir_ / "c.json").string();
    std::vector<std::string> args = {
        program,        "render",    scene,   "--width",   "250",     "--height",
        "250",          "--spp",     "16",    "--threads", "1",       "--quiet",
        "--integrator", "wavefront", "--out", out,         "--stats", stats};
    std::vector<char*> argv;
    for (std::string& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    pid_t pid = 0;
    ASSERT_EQ(posix_spawn(&pid, program.c_str(), nullptr, nullptr, argv.data(), environ), 0);
    int status = 0;
    rusage usage{};
    ASSERT_EQ(wait4(pid, &status, 0, &usage), pid);
    ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0);
    const json j = json::parse(read_file(stats));
    // 16 x 16 tiles, one pass of 16 (62,500 pixels: the passes below 16 are joined)
    EXPECT_EQ(j["scheduler"]["units"], 16 * 16);
    EXPECT_LT(usage.ru_nvcsw, 100) << "voluntary context switches";
}

// The registry is the one list of names: each name reads back as its entry, `render` and
// `converge` offer every one (a name the program refuses would be a second list), and the
// docs describe every one (an entry added without docs fails here).
TEST_F(cli, EveryIntegratorAndEstimatorIsOfferedAndDocumented) {
    const std::string render_help = run("--help").out,
                      converge_help = run("--help", "converge").out;
    const std::string estimators_doc = read_file(CIERZO_SOURCE_DIR "/docs/estimators.md");
    const std::string readme = read_file(CIERZO_SOURCE_DIR "/README.md");
    for (const cierzo::IntegratorEntry& e : cierzo::kIntegrators) {
        SCOPED_TRACE(e.name);
        EXPECT_EQ(cierzo::parse_integrator(e.name), e.id);
        EXPECT_EQ(std::string(cierzo::integrator_name(e.id)), e.name);
        EXPECT_NE(render_help.find(e.name), std::string::npos);
        EXPECT_NE(converge_help.find(e.name), std::string::npos);
        EXPECT_NE(readme.find(std::string("**") + e.name + "**"), std::string::npos);
    }
    for (const cierzo::EstimatorEntry& e : cierzo::kEstimators) {
        SCOPED_TRACE(e.name);
        EXPECT_EQ(cierzo::parse_estimator(e.name), e.id);
        EXPECT_EQ(std::string(cierzo::estimator_name(e.id)), e.name);
        EXPECT_NE(render_help.find(e.summary), std::string::npos);
        EXPECT_NE(converge_help.find(e.summary), std::string::npos);
        EXPECT_NE(estimators_doc.find(std::string("`") + e.name + "`"), std::string::npos);
        // ... and a scene file may name it
        json j = json::parse(kTinyScene);
        j["render"]["estimator"] = e.name;
        const Outcome r = run(quote(write("e.json", j.dump())) + kQuiet + " --spp 1");
        EXPECT_EQ(r.exit_code, 0) << r.err;
    }
    EXPECT_FALSE(cierzo::parse_estimator("sppm"));
    EXPECT_FALSE(cierzo::parse_integrator("gpu"));
}

TEST_F(cli, StatsAreConsistent) {
    const fs::path scene = write("tiny.json", kTinyScene);
    const fs::path stats = dir_ / "stats.json";
    for (const std::string integrator : {"scalar", "wavefront"}) {
        SCOPED_TRACE(integrator);
        const Outcome r =
            run(quote(scene) + kQuiet + " --integrator " + integrator + " --stats " + quote(stats));
        ASSERT_EQ(r.exit_code, 0) << r.err;
        const json j = json::parse(read_file(stats));
        for (const char* key :
             {"scene", "integrator", "isa", "threads", "width", "height", "spp", "spp_reached",
              "seed", "seconds", "paths", "rays", "rays_per_second", "rays_per_second_per_thread",
              "nonfinite_samples", "mean_relative_error"})
            EXPECT_TRUE(j.contains(key)) << key;
        EXPECT_EQ(j["scene"], scene.string());
        EXPECT_EQ(j["integrator"], integrator);
        EXPECT_EQ(j["threads"], 1);
        EXPECT_EQ(j["width"], 8);
        EXPECT_EQ(j["height"], 8);
        EXPECT_EQ(j["spp"], 2);
        EXPECT_EQ(j["spp_reached"], 2);
        EXPECT_EQ(j["seed"], 3);
        EXPECT_EQ(j["paths"].get<uint64_t>(), 8u * 8u * 2u);
        const json& rays = j["rays"];
        const uint64_t camera = rays["camera"], extension = rays["extension"],
                       shadow = rays["shadow"], total = rays["total"];
        EXPECT_EQ(camera, j["paths"].get<uint64_t>());
        EXPECT_EQ(total, camera + extension + shadow);
        EXPECT_GT(extension, 0u);  // the floor and sphere are diffuse: paths continue
        EXPECT_GT(shadow, 0u);     // and see the point light
        const double seconds = j["seconds"], rps = j["rays_per_second"];
        EXPECT_GE(seconds, 0.0);
        EXPECT_NEAR(rps, seconds > 0 ? double(total) / seconds : 0.0, 1e-6 * rps + 1e-9);
        EXPECT_EQ(j["rays_per_second_per_thread"].get<double>(), rps);  // 1 thread
        EXPECT_EQ(j["nonfinite_samples"], 0);
        if (integrator == "wavefront") {
            // Lane utilisation of shading, intersection and shadow-ray batches
            for (const char* stage : {"shading", "intersection", "shadow"}) {
                const double u = j["lane_utilisation"][stage];
                EXPECT_GT(u, 0.0) << stage;
                EXPECT_LE(u, 1.0) << stage;
            }
        }
        fs::remove(stats);
    }
}

TEST_F(cli, OptionsOverrideTheFile) {
    const fs::path scene = write("tiny.json", kTinyScene);
    const fs::path out = dir_ / "o.exr", stats = dir_ / "s.json";
    const Outcome r = run(quote(scene) + kQuiet + " --spp 3 --seed 7 --width 5 --out " +
                          quote(out) + " --stats " + quote(stats));
    ASSERT_EQ(r.exit_code, 0) << r.err;
    const json j = json::parse(read_file(stats));
    EXPECT_EQ(j["width"], 5);
    EXPECT_EQ(j["height"], 8);  // from the file
    EXPECT_EQ(j["spp"], 3);
    EXPECT_EQ(j["seed"], 7);
    EXPECT_EQ(j["paths"].get<uint64_t>(), 5u * 8u * 3u);
    EXPECT_EQ(exr_size(out), std::make_pair(5, 8));
    const auto header = exr_header(out);
    ASSERT_TRUE(header.count("cierzo:seed") && header.count("cierzo:spp"));
    EXPECT_EQ(header.at("cierzo:seed"), "7");
    EXPECT_EQ(header.at("cierzo:spp"), "3");
    EXPECT_FALSE(fs::exists(dir_ / "tiny.exr"));  // --out replaced the default output

    const Outcome h = run(quote(scene) + kQuiet + " --height 3 --out " + quote(out));
    ASSERT_EQ(h.exit_code, 0) << h.err;
    EXPECT_EQ(exr_size(out), std::make_pair(8, 3));
}

TEST_F(cli, TheEstimatorIsChosenRecordedAndChecked) {
    // The scene's lamp is a sphere: sampled by nee and mis. A scene that names no estimator
    // renders with mis.
    const fs::path scene = write("tiny.json", kTinyScene);
    const fs::path out = dir_ / "o.exr", stats = dir_ / "s.json";
    uint64_t shadow[3] = {};
    const char* names[3] = {"report", "nee", "mis"};
    for (int k = 0; k < 3; ++k) {
        SCOPED_TRACE(names[k]);
        const std::string option = std::string(" --estimator ") + names[k];
        const Outcome r = run(quote(scene) + kQuiet + option + " --out " + quote(out) +
                              " --stats " + quote(stats));
        ASSERT_EQ(r.exit_code, 0) << r.err;
        const json j = json::parse(read_file(stats));
        EXPECT_EQ(j["estimator"], names[k]);
        EXPECT_EQ(j["emitters"]["sampled"], 1);
        EXPECT_EQ(j["emitters"]["unsampled_objects"], 0);
        shadow[k] = j["rays"]["shadow"];
        const auto header = exr_header(out);
        ASSERT_TRUE(header.count("cierzo:estimator"));
        EXPECT_EQ(header.at("cierzo:estimator"), names[k]);
    }
    // One emitter sample per Phong vertex on top of the point light's shadow rays
    EXPECT_GT(shadow[1], shadow[0]);
    EXPECT_EQ(shadow[1], shadow[2]);
    ASSERT_EQ(
        run(quote(scene) + kQuiet + " --out " + quote(out) + " --stats " + quote(stats)).exit_code,
        0);
    EXPECT_EQ(json::parse(read_file(stats))["estimator"], "mis") << "the default";

    // From the scene file, and refused when unknown (file and option)
    std::string text = kTinyScene;
    text.replace(text.find("\"seed\": 3"), 9, "\"seed\": 3, \"estimator\": \"nee\"");
    const fs::path with = write("with.json", text);
    ASSERT_EQ(
        run(quote(with) + kQuiet + " --out " + quote(out) + " --stats " + quote(stats)).exit_code,
        0);
    EXPECT_EQ(json::parse(read_file(stats))["estimator"], "nee");
    text.replace(text.find("\"nee\""), 5, "\"path\"");
    const fs::path bad = write("bad.json", text);
    const Outcome b = run(quote(bad) + kQuiet);
    EXPECT_EQ(b.exit_code, 1);
    EXPECT_NE(b.err.find("bad.json"), std::string::npos) << b.err;
    EXPECT_NE(
        b.err.find("'estimator' must be one of \"report\", \"nee\", \"mis\", \"lt\", \"bdpt\""),
        std::string::npos)
        << b.err;
    const Outcome o = run(quote(scene) + kQuiet + " --estimator sppm");
    EXPECT_GT(o.exit_code, 0);
    EXPECT_NE(o.err.find("--estimator"), std::string::npos) << o.err;
}

// vcm's radius and exponent: refused outside their ranges, or with another estimator, on
// the command line and in the scene file, each message naming the option; no image written.
TEST_F(cli, MergingOptionsOutOfRangeAreRefused) {
    const fs::path scene = write("scene.json", kTinyScene);
    const fs::path out = dir_ / "merge.exr";
    const std::pair<std::string, std::string> cases[] = {
        {" --estimator vcm --merge-radius 0", "--merge-radius"},
        {" --estimator vcm --merge-radius -1", "--merge-radius"},
        {" --estimator vcm --merge-radius inf", "--merge-radius"},
        {" --estimator vcm --merge-alpha 0", "--merge-alpha"},
        {" --estimator vcm --merge-alpha 1", "--merge-alpha"},
        {" --estimator vcm --merge-alpha 1.5", "--merge-alpha"},
        {" --estimator bdpt --merge-radius 0.1", "merging is vcm's"},
        {" --estimator vcm --strategy 1,2", "--strategy"},
        {" --estimator bdpt --light-connections -1", "--light-connections"},
        {" --estimator bdpt --light-connections 65", "--light-connections"},
        {" --estimator mis --light-connections 2", "connections are bdpt's and vcm's"},
    };
    for (const auto& [args, message] : cases) {
        SCOPED_TRACE(args);
        const Outcome o = run(quote(scene) + kQuiet + args + " --out " + quote(out));
        EXPECT_GT(o.exit_code, 0);
        EXPECT_NE(o.err.find(message), std::string::npos) << o.err;
        EXPECT_FALSE(fs::exists(out));
    }
    std::string text = kTinyScene;
    text.replace(text.find("\"seed\": 3"), 9,
                 "\"seed\": 3, \"estimator\": \"vcm\", \"merge_radius\": -0.5");
    const Outcome b = run(quote(write("bad_radius.json", text)) + kQuiet + " --out " + quote(out));
    EXPECT_EQ(b.exit_code, 1);
    EXPECT_NE(b.err.find("bad_radius.json"), std::string::npos) << b.err;
    EXPECT_NE(b.err.find("'merge_radius' must be a positive length"), std::string::npos) << b.err;
    for (const char* value : {"1.5", "-2", "100"}) {
        text = kTinyScene;
        text.replace(
            text.find("\"seed\": 3"), 9,
            std::string("\"seed\": 3, \"estimator\": \"bdpt\", \"light_connections\": ") + value);
        const Outcome c =
            run(quote(write("bad_draws.json", text)) + kQuiet + " --out " + quote(out));
        EXPECT_EQ(c.exit_code, 1) << value;
        EXPECT_NE(c.err.find("bad_draws.json"), std::string::npos) << c.err;
        EXPECT_NE(c.err.find("'light_connections' must be a whole number in 0..64"),
                  std::string::npos)
            << c.err;
        EXPECT_FALSE(fs::exists(out));
    }
    // (and accepted in range: the image is written)
    const Outcome ok = run(quote(scene) + kQuiet +
                           " --estimator vcm --merge-radius 0.05 "
                           "--merge-alpha 0.5 --spp 2 --out " +
                           quote(out));
    EXPECT_EQ(ok.exit_code, 0) << ok.err;
    EXPECT_TRUE(fs::exists(out));
    fs::remove(out);
    const fs::path stats = dir_ / "drawn.json";
    const Outcome drawn = run(quote(scene) + kQuiet +
                              " --estimator bdpt --light-connections 3 "
                              "--spp 2 --out " +
                              quote(out) + " --stats " + quote(stats));
    EXPECT_EQ(drawn.exit_code, 0) << drawn.err;
    EXPECT_TRUE(fs::exists(out));
    // --stats gives the cache's draws, its estimate of the light subpaths' vertices and the
    // count its weights give each connection (draws over vertices)
    const json cache = json::parse(read_file(stats))["light_vertex_cache"];
    EXPECT_EQ(cache["draws"], 3);
    const double vertices = cache["mean_light_vertices"], count = cache["connection_count"];
    EXPECT_GT(vertices, 0.0);
    EXPECT_NEAR(count, 3.0 / vertices, 1e-5 * count);
    fs::remove(out);
    ASSERT_EQ(run(quote(scene) + kQuiet + " --estimator mis --spp 1 --out " + quote(out) +
                  " --stats " + quote(stats))
                  .exit_code,
              0);
    EXPECT_FALSE(json::parse(read_file(stats)).contains("light_vertex_cache"));
}

// --strategies DIR: every strategy's image of paths up to --max-length, weighted and
// unweighted, named and labelled by its strategy; what it cannot do is refused before any
// work, with nothing written and the folder not made.
TEST_F(cli, StrategiesWritesEveryStrategysImagesOrIsRefused) {
    const fs::path scene = write("scene.json", kTinyScene);
    const fs::path out = dir_ / "whole.exr", strategies = dir_ / "strategies";
    const Outcome ok =
        run(quote(scene) + kQuiet + " --estimator bdpt --max-length 3 --strategies " +
            quote(strategies) + " --out " + quote(out));
    ASSERT_EQ(ok.exit_code, 0) << ok.err;
    EXPECT_TRUE(fs::exists(out));
    std::vector<std::string> names;
    for (const auto& e : fs::directory_iterator(strategies)) names.push_back(e.path().filename());
    std::sort(names.begin(), names.end());
    std::vector<std::string> want;
    for (int k = 1; k <= 3; ++k)
        for (int st = 0; st <= k; ++st)
            for (const char* w : {"", "_unweighted"})
                want.push_back("length" + std::to_string(k) + "_s" + std::to_string(st) + "_t" +
                               std::to_string(k + 1 - st) + w + ".exr");
    std::sort(want.begin(), want.end());
    EXPECT_EQ(names, want);
    const auto header = exr_header(strategies / "length3_s2_t2_unweighted.exr");
    ASSERT_TRUE(header.count("cierzo:strategy"));
    EXPECT_NE(header.at("cierzo:strategy").find("s=2 t=2 length=3"), std::string::npos);
    EXPECT_NE(header.at("cierzo:weighted").find("unweighted"), std::string::npos);

    const fs::path file = write("a_file", "keep me");
    const fs::path fresh = dir_ / "fresh";
    const std::pair<std::string, std::string> cases[] = {
        {" --estimator vcm --strategies " + quote(fresh), "strategy images are bdpt's"},
        {" --estimator mis --strategies " + quote(fresh), "strategy images are bdpt's"},
        {" --estimator bdpt --integrator wavefront --strategies " + quote(fresh), "scalar"},
        {" --estimator bdpt --strategy 1,2 --strategies " + quote(fresh), "--strategy"},
        {" --estimator bdpt --max-length 13 --strategies " + quote(fresh), "12"},
        {" --estimator bdpt --width 4000 --height 4000 --max-length 12 --strategies " +
             quote(fresh),
         "GiB"},
        {" --estimator bdpt --checkpoint " + quote(dir_ / "c.exr") + " --strategies " +
             quote(fresh),
         "checkpoint"},
        {" --estimator bdpt --strategies " + quote(file), "must name a folder"},
        {" --estimator bdpt --strategies " + quote(dir_ / "no" / "such"), "does not exist"},
    };
    for (const auto& [args, message] : cases) {
        SCOPED_TRACE(args);
        const fs::path other = dir_ / "refused.exr";
        const Outcome o = run(quote(scene) + kQuiet + args + " --out " + quote(other));
        EXPECT_EQ(o.exit_code, 1);
        EXPECT_NE(o.err.find("--strategies"), std::string::npos) << o.err;
        EXPECT_NE(o.err.find(message), std::string::npos) << o.err;
        EXPECT_FALSE(fs::exists(other));
        EXPECT_FALSE(fs::exists(fresh));
    }
    EXPECT_EQ(read_file(file), "keep me");
}

TEST_F(cli, OnePathPerPixelHasNoRelativeError) {
    const fs::path scene = write("tiny.json", kTinyScene);
    const fs::path stats = dir_ / "s.json";
    const Outcome one = run(quote(scene) + " --threads 1 --spp 1 --stats " + quote(stats));
    ASSERT_EQ(one.exit_code, 0) << one.err;
    EXPECT_NE(one.err.find("relative error not available"), std::string::npos) << one.err;
    EXPECT_EQ(one.err.find("relative error 0"), std::string::npos) << one.err;
    EXPECT_TRUE(json::parse(read_file(stats))["mean_relative_error"].is_null());
    const Outcome two = run(quote(scene) + " --threads 1 --spp 2 --stats " + quote(stats));
    ASSERT_EQ(two.exit_code, 0) << two.err;
    EXPECT_NE(two.err.find("relative error 0."), std::string::npos) << two.err;
    EXPECT_GT(json::parse(read_file(stats))["mean_relative_error"].get<double>(), 0.0);
}

TEST_F(cli, MissingSceneFile) {
    const fs::path scene = dir_ / "absent.json";
    const Outcome r = run(quote(scene) + kQuiet);
    EXPECT_GT(r.exit_code, 0);
    EXPECT_NE(r.err.find(scene.string()), std::string::npos) << r.err;
}

TEST_F(cli, MalformedScene) {
    const fs::path scene = write("bad.json", "{\n  \"camera\": {\n");
    const Outcome r = run(quote(scene) + kQuiet);
    EXPECT_EQ(r.exit_code, 1);
    EXPECT_NE(r.err.find(scene.string()), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("invalid JSON"), std::string::npos) << r.err;
    EXPECT_EQ(other_files({"bad.json"}), std::vector<std::string>{});
}

TEST_F(cli, OutputIntoAMissingFolder) {
    const fs::path scene = write("tiny.json", kTinyScene);
    const fs::path out = dir_ / "nope" / "x.exr";
    const Outcome r = run(quote(scene) + kQuiet + " --out " + quote(out));
    EXPECT_EQ(r.exit_code, 1);
    EXPECT_NE(r.err.find(out.string()), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("does not exist"), std::string::npos) << r.err;
    // The same through render.output, which is relative to the scene's folder
    json j = json::parse(kTinyScene);
    j["render"]["output"] = "nope/y.exr";
    const fs::path scene2 = write("tiny2.json", j.dump());
    const Outcome r2 = run(quote(scene2) + kQuiet);
    EXPECT_EQ(r2.exit_code, 1);
    EXPECT_NE(r2.err.find((dir_ / "nope" / "y.exr").string()), std::string::npos) << r2.err;
    EXPECT_EQ(other_files({"tiny.json", "tiny2.json"}), std::vector<std::string>{});
}

TEST_F(cli, OutputWithABadExtension) {
    const fs::path scene = write("tiny.json", kTinyScene);
    const fs::path out = dir_ / "x.png";
    const Outcome r = run(quote(scene) + kQuiet + " --out " + quote(out));
    EXPECT_EQ(r.exit_code, 1);
    EXPECT_NE(r.err.find(out.string()), std::string::npos) << r.err;
    EXPECT_NE(r.err.find(".exr or .pfm"), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(out));
}

// A scene reads beneath its own folder unless --allow-path names another, and writes its
// image beneath it unless --out names the place; --image-memory takes a size
TEST_F(cli, AScenesFilesStayInItsFolderUnlessTheCommandLineSaysOtherwise) {
    fs::create_directories(dir_ / "scene");
    fs::create_directories(dir_ / "shared");
    write("shared/tri.ply",
          "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
          "property float z\nelement face 1\nproperty list uchar int vertex_indices\n"
          "end_header\n-1 -1 0\n1 -1 0\n0 1 0\n3 0 1 2\n");
    json j = json::parse(kTinyScene);
    j["objects"].push_back(
        {{"type", "mesh"}, {"file", "../shared/tri.ply"}, {"material", "white"}});
    const fs::path scene = write("scene/s.json", j.dump());
    const Outcome refused = run(quote(scene) + kQuiet);
    EXPECT_EQ(refused.exit_code, 1);
    EXPECT_NE(refused.err.find("'../shared/tri.ply' resolves to"), std::string::npos)
        << refused.err;
    EXPECT_NE(refused.err.find("--allow-path"), std::string::npos) << refused.err;
    EXPECT_FALSE(fs::exists(dir_ / "scene" / "s.exr"));
    const Outcome allowed = run(quote(scene) + kQuiet + " --allow-path " + quote(dir_ / "shared"));
    EXPECT_EQ(allowed.exit_code, 0) << allowed.err;
    EXPECT_TRUE(fs::exists(dir_ / "scene" / "s.exr"));
    // "output" outside the folder: refused; --out anywhere is the user's choice
    j["render"]["output"] = "../elsewhere.exr";
    const fs::path scene2 = write("scene/s2.json", j.dump());
    const std::string allow = " --allow-path " + quote(dir_ / "shared");
    const Outcome out = run(quote(scene2) + kQuiet + allow);
    EXPECT_EQ(out.exit_code, 1);
    EXPECT_NE(out.err.find("'output': '../elsewhere.exr' resolves to"), std::string::npos)
        << out.err;
    EXPECT_FALSE(fs::exists(dir_ / "elsewhere.exr"));
    const Outcome named = run(quote(scene2) + kQuiet + allow + " --out " + quote(dir_ / "o.exr"));
    EXPECT_EQ(named.exit_code, 0) << named.err;
    EXPECT_TRUE(fs::exists(dir_ / "o.exr"));
    EXPECT_FALSE(fs::exists(dir_ / "elsewhere.exr"));
    // A size that is not one
    const Outcome bad = run(quote(scene) + kQuiet + allow + " --image-memory lots");
    EXPECT_EQ(bad.exit_code, 1);
    EXPECT_NE(bad.err.find("--image-memory: 'lots' is not a size"), std::string::npos) << bad.err;
    EXPECT_EQ(run(quote(scene) + kQuiet + allow + " --image-memory 512M").exit_code, 0);
}

TEST_F(cli, TooManyPathsAreRefusedQuickly) {
    // 65536 x 4096 = 2^28 pixels (allowed) x 4e6 paths per pixel = 1.07e15 paths > 1e12
    const fs::path scene = write("tiny.json", kTinyScene);
    const Outcome r = run(quote(scene) + kQuiet + " --width 65536 --height 4096 --spp 4000000");
    EXPECT_EQ(r.exit_code, 1);
    EXPECT_LT(r.seconds, 10.0);
    EXPECT_NE(r.err.find("paths"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find(scene.string()), std::string::npos) << r.err;
    EXPECT_EQ(other_files({"tiny.json"}), std::vector<std::string>{});
}

TEST_F(cli, AHugeSparseMeshIsRefusedFromItsHeaderNotReadWhole) {
    // 30 GiB whose header claims 2e9 vertices of nine doubles (144e9 bytes): refused from the
    // header at once, with exit status 1 (an input error), never read into memory
    std::string header = "ply\nformat binary_little_endian 1.0\nelement vertex 2000000000\n";
    for (const char* name : {"x", "y", "z", "a", "b", "c", "d", "e", "f"})
        header += std::string("property double ") + name + "\n";
    header += "element face 1\nproperty list uchar int vertex_indices\nend_header\n";
    const fs::path mesh = dir_ / "huge.ply";
    if (!cierzo::test::make_sparse_file(mesh, header, cierzo::test::k30GiB))
        GTEST_SKIP() << cierzo::test::kNoSparseFiles;
    const fs::path scene = write("huge.json", R"({
        "camera": {"position": [0, 0, -3], "look_at": [0, 0, 0]},
        "materials": {"grey": {"kd": 0.5}},
        "objects": [{"type": "mesh", "file": "huge.ply", "material": "grey"}]
    })");
    const Outcome r = run(quote(scene) + kQuiet + " --width 8 --height 8");
    EXPECT_EQ(r.exit_code, 1) << r.err;
    EXPECT_NE(r.err.find(mesh.string() + ": header claims 2000000000 'vertex' elements"),
              std::string::npos)
        << r.err;
    EXPECT_EQ(r.err.find("internal error"), std::string::npos) << r.err;
    EXPECT_LT(r.seconds, 60.0);
    // (the largest peak of any program this test program has run: a read of the file whole
    // would take 30 GiB)
    struct rusage children = {};
    ::getrusage(RUSAGE_CHILDREN, &children);
    EXPECT_LT(uint64_t(children.ru_maxrss) * 1024, uint64_t(1) << 30);
    EXPECT_EQ(other_files({"huge.ply", "huge.json"}), std::vector<std::string>{});
}

TEST_F(cli, AModelRendersWithMisAndSaysHowToAskForMorePaths) {
    // A tetrahedron with no materials: grey under the white sky
    const fs::path model = write("tet.obj",
                                 "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\n"
                                 "f 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n");
    const fs::path out = dir_ / "tet.exr", stats = dir_ / "s.json";
    const std::string common = quote(model) + kQuiet + " --width 8 --height 8 --out " + quote(out) +
                               " --stats " + quote(stats);
    Outcome r = run(common);
    ASSERT_EQ(r.exit_code, 0) << r.err;
    EXPECT_EQ(json::parse(read_file(stats))["estimator"], "mis");
    EXPECT_EQ(json::parse(read_file(stats))["spp"], 16);
    EXPECT_NE(r.err.find("tet.obj: a model: mis at 16 paths per pixel; --spp N for more paths"),
              std::string::npos)
        << r.err;
    // The line names what the options chose, and goes once both are given
    r = run(common + " --spp 2");
    ASSERT_EQ(r.exit_code, 0) << r.err;
    EXPECT_NE(r.err.find("a model: mis at 2 paths per pixel"), std::string::npos) << r.err;
    r = run(common + " --spp 2 --estimator nee");
    ASSERT_EQ(r.exit_code, 0) << r.err;
    EXPECT_EQ(r.err.find("a model:"), std::string::npos) << r.err;
    EXPECT_EQ(json::parse(read_file(stats))["estimator"], "nee");
    // A scene file says nothing of the kind
    r = run(quote(write("tiny.json", kTinyScene)) + kQuiet + " --out " + quote(out));
    ASSERT_EQ(r.exit_code, 0) << r.err;
    EXPECT_EQ(r.err.find("a model:"), std::string::npos) << r.err;
}

TEST_F(cli, FailedRenderLeavesAnExistingOutputAlone) {
    static const char kBytes[] = "not an image \x00\x01\x02 keep me";
    const std::string before(kBytes, sizeof(kBytes) - 1);
    const fs::path out = write("out.exr", before);
    const fs::path bad = write("bad.json", "{\"camera\": ");
    const fs::path good = write("tiny.json", kTinyScene);
    // A malformed scene
    Outcome r = run(quote(bad) + kQuiet + " --out " + quote(out));
    EXPECT_EQ(r.exit_code, 1) << r.err;
    EXPECT_EQ(read_file(out), before);
    // A good scene whose statistics could not be written
    r = run(quote(good) + kQuiet + " --out " + quote(out) + " --stats " +
            quote(dir_ / "nope" / "s.json"));
    EXPECT_EQ(r.exit_code, 1) << r.err;
    EXPECT_EQ(read_file(out), before);
    // A refused render
    r = run(quote(good) + kQuiet + " --out " + quote(out) + " --width 65536 --height 4096 " +
            "--spp 4000000");
    EXPECT_EQ(r.exit_code, 1) << r.err;
    EXPECT_EQ(read_file(out), before);
    EXPECT_EQ(other_files({"out.exr", "bad.json", "tiny.json"}), std::vector<std::string>{});
}

// `cierzo converge`: one CSV row per integrator and paths per pixel, errors that fall with
// more paths, a saved reference that reads back, and a reference of the wrong size refused.
std::vector<std::vector<std::string>> read_csv(const fs::path& p) {
    std::vector<std::vector<std::string>> rows;
    std::ifstream in(p);
    for (std::string line; std::getline(in, line);) {
        std::vector<std::string> cells;
        size_t start = 0;
        for (size_t comma; (comma = line.find(',', start)) != std::string::npos; start = comma + 1)
            cells.push_back(line.substr(start, comma - start));
        cells.push_back(line.substr(start));
        rows.push_back(cells);
    }
    return rows;
}

TEST_F(cli, ConvergeWritesOneRowPerPoint) {
    const fs::path scene = write("tiny.json", kTinyScene);
    const fs::path csv = dir_ / "c.csv", ref = dir_ / "ref.exr";
    const Outcome r =
        run(quote(scene) + kQuiet + " --spp 1,16 --integrator scalar,wavefront " +
                "--reference-spp 1024 --save-reference " + quote(ref) + " --out " + quote(csv),
            "converge");
    ASSERT_EQ(r.exit_code, 0) << r.err;
    const auto rows = read_csv(csv);
    ASSERT_EQ(rows.size(), 5u);
    const auto& h = rows[0];
    auto col = [&](const char* name) {
        return size_t(std::find(h.begin(), h.end(), name) - h.begin());
    };
    ASSERT_LT(col("rmse_corrected"), h.size());
    ASSERT_LT(col("reference_mse"), h.size());
    const std::string integrators[] = {"scalar", "scalar", "wavefront", "wavefront"};
    for (size_t i = 1; i < rows.size(); ++i) {
        ASSERT_EQ(rows[i].size(), h.size());
        EXPECT_EQ(rows[i][col("integrator")], integrators[i - 1]);
        EXPECT_GT(std::stod(rows[i][col("reference_mse")]), 0.0);  // a noisy reference
    }
    EXPECT_EQ(rows[1][col("spp")], "1");
    EXPECT_EQ(rows[2][col("spp")], "16");
    EXPECT_LT(std::stod(rows[2][col("rmse_corrected")]), std::stod(rows[1][col("rmse_corrected")]));
    EXPECT_LT(std::stod(rows[4][col("rmse_corrected")]), std::stod(rows[3][col("rmse_corrected")]));

    // The saved reference, variance layers and all, gives the same errors when read back
    const fs::path csv2 = dir_ / "c2.csv";
    const Outcome again = run(quote(scene) + kQuiet + " --spp 1,16 --integrator scalar " +
                                  "--reference " + quote(ref) + " --out " + quote(csv2),
                              "converge");
    ASSERT_EQ(again.exit_code, 0) << again.err;
    const auto rows2 = read_csv(csv2);
    ASSERT_EQ(rows2.size(), 3u);
    for (const char* c : {"mse", "reference_mse", "rel_mse_corrected"})
        EXPECT_EQ(rows2[1][col(c)], rows[1][col(c)]) << c;
}

TEST_F(cli, ConvergeSweepsTheEstimator) {
    const fs::path scene = write("tiny.json", kTinyScene);
    const fs::path csv = dir_ / "c.csv";
    const Outcome r = run(quote(scene) + kQuiet + " --spp 4 --integrator wavefront " +
                              "--estimator report,nee,mis --reference-spp 64 " +
                              "--reference-estimator mis --out " + quote(csv),
                          "converge");
    ASSERT_EQ(r.exit_code, 0) << r.err;
    const auto rows = read_csv(csv);
    ASSERT_EQ(rows.size(), 4u);
    const auto& h = rows[0];
    const size_t col = size_t(std::find(h.begin(), h.end(), "estimator") - h.begin());
    ASSERT_LT(col, h.size());
    EXPECT_EQ(rows[1][col], "report");
    EXPECT_EQ(rows[2][col], "nee");
    EXPECT_EQ(rows[3][col], "mis");
    EXPECT_GT(run(quote(scene) + kQuiet + " --estimator mcmc", "converge").exit_code, 0);
}

// --light-connections sweeps bdpt's and vcm's draws (the others' rows once, the column
// empty); out of range, or with no estimator that connects, it is refused naming itself.
TEST_F(cli, ConvergeSweepsTheLightConnections) {
    const fs::path scene = write("tiny.json", kTinyScene);
    const fs::path csv = dir_ / "c.csv";
    const Outcome r = run(quote(scene) + kQuiet + " --spp 2 --integrator wavefront " +
                              "--estimator mis,bdpt --light-connections 0,3 --reference-spp 16 " +
                              "--reference-estimator mis --out " + quote(csv),
                          "converge");
    ASSERT_EQ(r.exit_code, 0) << r.err;
    const auto rows = read_csv(csv);
    ASSERT_EQ(rows.size(), 4u);
    const auto& h = rows[0];
    const auto col = [&](const char* name) {
        return size_t(std::find(h.begin(), h.end(), name) - h.begin());
    };
    ASSERT_LT(col("light_connections"), h.size());
    EXPECT_EQ(rows[1][col("estimator")], "mis");
    EXPECT_EQ(rows[1][col("light_connections")], "");
    EXPECT_EQ(rows[2][col("estimator")], "bdpt");
    EXPECT_EQ(rows[2][col("light_connections")], "0");
    EXPECT_EQ(rows[3][col("light_connections")], "3");
    // (another number of draws is another image: another error)
    EXPECT_NE(rows[2][col("mse")], rows[3][col("mse")]);
    for (const std::string& args : {std::string(" --estimator bdpt --light-connections 65"),
                                    std::string(" --estimator mis --light-connections 1")}) {
        const Outcome bad = run(quote(scene) + kQuiet + args, "converge");
        EXPECT_GT(bad.exit_code, 0) << args;
        EXPECT_NE(bad.err.find("--light-connections"), std::string::npos) << bad.err;
    }
}

TEST_F(cli, ConvergeRefusesBadReferencesAndKnobs) {
    const fs::path scene = write("tiny.json", kTinyScene);
    const fs::path small = dir_ / "small.pfm";
    ASSERT_EQ(run(quote(scene) + kQuiet + " --width 4 --height 4 --out " + quote(small)).exit_code,
              0);
    Outcome r = run(quote(scene) + kQuiet + " --reference " + quote(small), "converge");
    EXPECT_EQ(r.exit_code, 1) << r.err;
    EXPECT_NE(r.err.find(small.string()), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("4x4"), std::string::npos) << r.err;
    r = run(quote(scene) + kQuiet + " --pool 24", "converge");
    EXPECT_EQ(r.exit_code, 1) << r.err;
    EXPECT_NE(r.err.find("--pool"), std::string::npos) << r.err;
    // A given reference leaves nothing for the options of a rendered one to do
    r = run(quote(scene) + kQuiet + " --reference " + quote(small) + " --save-reference " +
                quote(dir_ / "r.exr"),
            "converge");
    EXPECT_GT(r.exit_code, 0) << r.err;
    EXPECT_NE(r.err.find("--save-reference"), std::string::npos) << r.err;
    r = run(quote(scene) + kQuiet + " --survival-cap 0.5,1.5", "converge");
    EXPECT_GT(r.exit_code, 0) << r.err;
    EXPECT_NE(r.err.find("--survival-cap"), std::string::npos) << r.err;
    r = run(quote(scene) + kQuiet + " --out " + quote(dir_ / "missing" / "c.csv"), "converge");
    EXPECT_EQ(r.exit_code, 1) << r.err;
    EXPECT_NE(r.err.find("missing"), std::string::npos) << r.err;
}

}  // namespace

// ---- cierzo trace ---------------------------------------------------------------------------
namespace {

// A ray file: the magic, the count, then 7 floats per ray (origin, direction, tmax).
std::string ray_file(const std::vector<std::array<float, 7>>& rays, uint64_t count) {
    std::string s("CZRAYS1\0", 8);
    s.append(reinterpret_cast<const char*>(&count), 8);
    for (const auto& r : rays) s.append(reinterpret_cast<const char*>(r.data()), 28);
    return s;
}

// key: value lines of a program's output.
std::map<std::string, std::string> key_values(const std::string& text) {
    std::map<std::string, std::string> m;
    std::istringstream in(text);
    for (std::string line; std::getline(in, line);) {
        const size_t colon = line.find(": ");
        if (colon != std::string::npos) m[line.substr(0, colon)] = line.substr(colon + 2);
    }
    return m;
}

}  // namespace

TEST_F(cli, TraceFindsTheSameHitsWithEveryIntegratorAndIsa) {
    const fs::path scene = write("s.json", kTinyScene);
    // Rays from the camera towards the floor, the spheres and the sky, one with a short tmax
    std::vector<std::array<float, 7>> rays;
    for (int i = 0; i < 200; ++i) {
        const float x = float(i % 20) / 10.0f - 1.0f, y = float(i / 20) / 5.0f - 1.0f;
        const float n = std::sqrt(x * x + y * y + 9.0f);
        rays.push_back({0, 0, -3, x / n, y / n, 3 / n, i == 7 ? 0.5f : 3.4028235e38f});
    }
    const fs::path file = write("r.rays", ray_file(rays, rays.size()));
    const Outcome scalar =
        run(quote(scene) + " --rays " + quote(file) + " --integrator scalar", "trace");
    ASSERT_EQ(scalar.exit_code, 0) << scalar.err;
    const auto want = key_values(scalar.out);
    EXPECT_EQ(want.at("rays"), "200");
    const int hits = std::stoi(want.at("hits"));
    EXPECT_GT(hits, 50);
    EXPECT_LT(hits, 200);  // some rays go to the sky
    for (const cierzo::Isa isa : cierzo::compiled_isas()) {
        if (!cierzo::isa_supported(isa)) continue;
        const Outcome w = run(
            quote(scene) + " --rays " + quote(file) + " --isa " + cierzo::isa_name(isa), "trace");
        ASSERT_EQ(w.exit_code, 0) << w.err;
        const auto got = key_values(w.out);
        EXPECT_EQ(got.at("hits"), want.at("hits")) << cierzo::isa_name(isa);
        EXPECT_NEAR(std::stod(got.at("sum_t")), std::stod(want.at("sum_t")),
                    1e-5 * std::stod(want.at("sum_t")));
    }
}

// --spatial-splits builds the BVH again with cut references: the same hits at the same
// distances as the tree without, in every ISA and the scalar traversal; --stats counts the
// references; a budget out of range is refused before any work.
TEST_F(cli, SpatialSplitsFindWhatTheTreeWithoutFinds) {
    // 1,000 straws (long thin triangles of every direction) in a box of 4
    std::string objects;
    uint32_t h = 777;
    const auto unit = [&] {
        h = h * 1664525u + 1013904223u;
        return float(h >> 8) * 0x1p-24f * 2 - 1;
    };
    for (int i = 0; i < 1000; ++i) {
        const float a[3] = {2 * unit(), 2 * unit(), 2 * unit()};
        const float b[3] = {a[0] + unit(), a[1] + unit(), a[2] + unit()};
        const auto point = [](float x, float y, float z) {
            return "[" + std::to_string(x) + ", " + std::to_string(y) + ", " + std::to_string(z) +
                   "]";
        };
        objects += std::string(i ? ",\n" : "") + "{\"type\": \"triangle\", \"vertices\": [" +
                   point(a[0], a[1], a[2]) + ", " + point(b[0], b[1], b[2]) + ", " +
                   point(a[0] + 0.04f, a[1], a[2] + 0.04f) + "], \"material\": {\"kd\": 0.5}}";
    }
    const fs::path scene = write("straws.json", R"({"render": {"width": 8, "height": 8},
        "camera": {"position": [0, 0, -8], "look_at": [0, 0, 0]},
        "objects": [)" + objects + "]}");
    std::vector<std::array<float, 7>> rays;
    for (int i = 0; i < 4000; ++i) {
        const float o[3] = {3 * unit(), 3 * unit(), 3 * unit()};
        float d[3] = {unit(), unit(), unit()};
        const float n = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]) + 1e-3f;
        rays.push_back({o[0], o[1], o[2], d[0] / n, d[1] / n, d[2] / n, 3.4028235e38f});
    }
    const fs::path file = write("straws.rays", ray_file(rays, rays.size()));
    const std::string args = quote(scene) + " --rays " + quote(file);
    const Outcome plain = run(args + " --integrator scalar", "trace");
    ASSERT_EQ(plain.exit_code, 0) << plain.err;
    const auto want = key_values(plain.out);
    EXPECT_GT(std::stoi(want.at("hits")), 300);
    std::vector<std::string> variants = {" --integrator scalar"};
    for (const cierzo::Isa isa : cierzo::compiled_isas())
        if (cierzo::isa_supported(isa))
            variants.push_back(std::string(" --isa ") + cierzo::isa_name(isa));
    for (const std::string& v : variants) {
        const Outcome cut = run(args + v + " --spatial-splits 1", "trace");
        ASSERT_EQ(cut.exit_code, 0) << cut.err;
        const auto got = key_values(cut.out);
        EXPECT_EQ(got.at("hits"), want.at("hits")) << v;
        EXPECT_NEAR(std::stod(got.at("sum_t")), std::stod(want.at("sum_t")),
                    1e-6 * std::stod(want.at("sum_t")))
            << v;
    }
    const fs::path out = dir_ / "straws.pfm", stats = dir_ / "straws.stats.json";
    ASSERT_EQ(run(quote(scene) + kQuiet + " --spatial-splits 1 --out " + quote(out) + " --stats " +
                  quote(stats))
                  .exit_code,
              0);
    const json bvh = json::parse(read_file(stats))["bvh"];
    EXPECT_EQ(bvh["primitives"], 1000);
    EXPECT_GT(bvh["references"].get<int>(), 1000);
    EXPECT_LE(bvh["references"].get<int>(), 2000);
    EXPECT_EQ(bvh["spatial_splits"], 1.0);
    fs::remove(out);
    const Outcome refused =
        run(quote(scene) + kQuiet + " --spatial-splits 4.5 --out " + quote(out));
    EXPECT_EQ(refused.exit_code, 1);
    EXPECT_NE(refused.err.find("--spatial-splits: must be in [0, 4]"), std::string::npos)
        << refused.err;
    EXPECT_FALSE(fs::exists(out));
}

// Ray streams (`--stream`) find the same hits at the same distances as single rays, on a
// tree of many nodes, with every ISA; where they cannot be used (a one-node tree, the
// scalar integrator) they are not, or refused.
TEST_F(cli, TraceWithRayStreamsFindsWhatSingleRaysFind) {
    std::string objects;
    for (int i = 0; i < 400; ++i) {
        const int x = i % 20, z = i / 20;
        objects += std::string(i ? ",\n" : "") + "{\"type\": \"sphere\", \"center\": [" +
                   std::to_string(x - 10) + ", " + std::to_string(0.3 * (i % 7)) + ", " +
                   std::to_string(z) + "], \"radius\": " + std::to_string(0.2 + 0.05 * (i % 5)) +
                   ", \"material\": {\"kd\": 0.5}}";
        objects += ",\n{\"type\": \"triangle\", \"vertices\": [[" + std::to_string(x - 10.4) +
                   ", 0, " + std::to_string(z) + "], [" + std::to_string(x - 9.6) + ", 0, " +
                   std::to_string(z) + "], [" + std::to_string(x - 10) + ", 1.5, " +
                   std::to_string(z + 0.3) + "]], \"material\": {\"kd\": 0.5}}";
    }
    const fs::path scene = write("field.json", R"({"render": {"width": 8, "height": 8},
        "camera": {"position": [0, 4, -12], "look_at": [0, 0, 8], "vfov": 50},
        "objects": [)" + objects + "]}");
    std::vector<std::array<float, 7>> rays;
    uint32_t h = 12345;
    const auto unit = [&] {
        h = h * 1664525u + 1013904223u;
        return float(h >> 8) * 0x1p-24f * 2 - 1;
    };
    for (int i = 0; i < 3000; ++i) {
        // From in front of the field towards a point in it
        const float o[3] = {unit() * 8, 1 + unit(), unit() * 2 - 8};
        float d[3] = {unit() * 10 - o[0], 0.5f + 0.5f * unit() - o[1], 10 + 10 * unit() - o[2]};
        const float n = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
        rays.push_back({o[0], o[1], o[2], d[0] / n, d[1] / n, d[2] / n, 3.4028235e38f});
    }
    const fs::path file = write("field.rays", ray_file(rays, rays.size()));
    const std::string args = quote(scene) + " --rays " + quote(file);
    for (const cierzo::Isa isa : cierzo::compiled_isas()) {
        if (!cierzo::isa_supported(isa)) continue;
        const std::string with_isa = args + " --isa " + cierzo::isa_name(isa);
        const Outcome single = run(with_isa, "trace");
        ASSERT_EQ(single.exit_code, 0) << single.err;
        const auto want = key_values(single.out);
        EXPECT_EQ(want.at("streamed_rays"), "0");
        EXPECT_GT(std::stoi(want.at("hits")), 1000);
        EXPECT_LT(std::stoi(want.at("hits")), 3000);
        for (const char* stream : {" --stream 16 --single-below 1", " --stream 1000",
                                   " --stream 65536 --single-below 8"}) {
            const Outcome s = run(with_isa + stream, "trace");
            ASSERT_EQ(s.exit_code, 0) << s.err;
            const auto got = key_values(s.out);
            EXPECT_EQ(got.at("streamed_rays"), "3000") << stream;
            EXPECT_EQ(got.at("hits"), want.at("hits")) << cierzo::isa_name(isa) << stream;
            EXPECT_EQ(got.at("sum_t"), want.at("sum_t")) << cierzo::isa_name(isa) << stream;
        }
    }
    const Outcome scalar = run(args + " --integrator scalar --stream 64", "trace");
    EXPECT_EQ(scalar.exit_code, 1);
    EXPECT_NE(scalar.err.find("--stream"), std::string::npos) << scalar.err;
    const Outcome tiny = run(
        quote(write("s.json", kTinyScene)) + " --rays " + quote(file) + " --stream 64", "trace");
    ASSERT_EQ(tiny.exit_code, 0) << tiny.err;
    EXPECT_EQ(key_values(tiny.out).at("streamed_rays"), "0") << "a one-node tree is not streamed";
}

TEST_F(cli, TraceRefusesABadRayFileNamingIt) {
    const fs::path scene = write("s.json", kTinyScene);
    const std::array<float, 7> ray{0, 0, -3, 0, 0, 1, 1e30f};
    const struct {
        const char* name;
        std::string bytes;
        const char* phrase;
    } cases[] = {
        {"magic.rays", "NOTRAYS!" + std::string(8, '\0'), "not a ray file"},
        {"short.rays", std::string("CZRAYS1\0", 8), "no ray count"},
        {"lying.rays", ray_file({ray, ray}, 3), "the header says 3 rays"},
        {"long.rays", ray_file({ray, ray}, 1), "the header says 1 rays"},
        {"nan.rays", ray_file({{0, 0, -3, std::nanf(""), 0, 1, 1e30f}}, 1), "non-finite"},
    };
    for (const auto& c : cases) {
        const fs::path file = write(c.name, c.bytes);
        const Outcome r = run(quote(scene) + " --rays " + quote(file), "trace");
        EXPECT_EQ(r.exit_code, 1) << c.name;
        EXPECT_NE(r.err.find(file.string()), std::string::npos) << r.err;
        EXPECT_NE(r.err.find(c.phrase), std::string::npos) << r.err;
    }
    // A FIFO, refused before it is opened (its open would wait for a writer; a missing file
    // and a folder are the command line's to refuse)
    const fs::path fifo = cierzo::test::make_fifo(dir_ / "fifo.rays");
    const Outcome r = run(quote(scene) + " --rays " + quote(fifo), "trace");
    EXPECT_EQ(r.exit_code, 1);
    EXPECT_NE(r.err.find(fifo.string() + ": is a FIFO (named pipe), not a regular file"),
              std::string::npos)
        << r.err;
}
