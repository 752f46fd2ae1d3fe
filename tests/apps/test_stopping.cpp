// Stopping a render early, through the cierzo program: --time-budget and --target-error end
// it between passes with the same paths in every pixel, and SIGINT writes the image
// accumulated so far and exits with 130; the paths per pixel reached are in the stats.
#include <gtest/gtest.h>

#include <csignal>
#include <filesystem>
#include <fstream>
#include <thread>

#include <nlohmann/json.hpp>
#include <sys/wait.h>
#include <unistd.h>

#include "support/emulator.h"
#include "support/removed_at_exit.h"

namespace {

namespace fs = std::filesystem;

const fs::path kDir = fs::temp_directory_path() / ("cierzo_stop_" + std::to_string(getpid()));
const cierzo::test::RemovedAtExit kDirRemoved{kDir};
const std::string kScene = CIERZO_SOURCE_DIR "/scenes/cornell.json";

// Runs cierzo with arguments; with `interrupt_after` > 0 sends SIGINT after that many
// seconds. Returns the exit status.
int run(std::vector<std::string> args, double interrupt_after = 0.0) {
    fs::create_directories(kDir);
    const pid_t pid = fork();
    if (pid == 0) {
        // Through the emulator in a cross build: exec keeps the pid, so SIGINT reaches it,
        // and qemu-user hands the signal to the emulated program
        std::vector<std::string> words = cierzo::test::emulator_words();
        words.push_back(CIERZO_BINARY_DIR "/cierzo");
        words.insert(words.end(), args.begin(), args.end());
        std::vector<char*> argv;
        for (std::string& w : words) argv.push_back(w.data());
        argv.push_back(nullptr);
        execvp(argv[0], argv.data());
        _exit(127);
    }
    if (interrupt_after > 0.0) {
        std::this_thread::sleep_for(std::chrono::duration<double>(interrupt_after));
        kill(pid, SIGINT);
    }
    int status = 0;
    waitpid(pid, &status, 0);
    return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
}

nlohmann::json stats(const fs::path& p) {
    std::ifstream in(p);
    return nlohmann::json::parse(in);
}

TEST(Stopping, TimeBudgetEndsBetweenPassesWithEqualPathsPerPixel) {
    const auto start = std::chrono::steady_clock::now();
    ASSERT_EQ(run({"render", kScene, "--spp", "1000000", "--time-budget", "0.3", "--quiet", "--out",
                   (kDir / "tb.exr").string(), "--stats", (kDir / "tb.json").string()}),
              0);
    const double s =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    EXPECT_LT(s, 20.0);  // a million paths per pixel would take hours
    const auto j = stats(kDir / "tb.json");
    EXPECT_EQ(j["stopped_by"], "time budget");
    EXPECT_GT(j["spp_reached"].get<int64_t>(), 0);
    EXPECT_LT(j["spp_reached"].get<int64_t>(), 1000000);
    // Every pixel got the same paths: the path count is pixels × spp reached
    EXPECT_EQ(j["paths"].get<int64_t>(), 500 * 500 * j["spp_reached"].get<int64_t>());
    EXPECT_TRUE(fs::exists(kDir / "tb.exr"));
}

TEST(Stopping, TargetErrorStopsOnceReachedAndNotBefore16Paths) {
    ASSERT_EQ(run({"render", kScene, "--spp", "1000000", "--target-error", "0.1", "--quiet",
                   "--width", "64", "--height", "64", "--out", (kDir / "te.exr").string(),
                   "--stats", (kDir / "te.json").string()}),
              0);
    const auto j = stats(kDir / "te.json");
    EXPECT_EQ(j["stopped_by"], "target error");
    EXPECT_GE(j["spp_reached"].get<int64_t>(), 16);
    EXPECT_LE(j["mean_relative_error"].get<double>(), 0.1);
}

TEST(Stopping, InterruptWritesTheImageSoFarAndExits130) {
    const fs::path out = kDir / "int.exr";
    fs::remove(out);
    EXPECT_EQ(run({"render", kScene, "--spp", "1000000", "--quiet", "--out", out.string(),
                   "--stats", (kDir / "int.json").string()},
                  1.0),
              130);
    ASSERT_TRUE(fs::exists(out));
    const auto j = stats(kDir / "int.json");
    EXPECT_EQ(j["stopped_by"], "interrupted");
    EXPECT_GT(j["spp_reached"].get<int64_t>(), 0);
    EXPECT_EQ(j["paths"].get<int64_t>(), 500 * 500 * j["spp_reached"].get<int64_t>());
}

TEST(Stopping, AFullRenderSaysItWasNotStopped) {
    ASSERT_EQ(
        run({"render", kScene, "--spp", "4", "--width", "32", "--height", "32", "--quiet", "--out",
             (kDir / "full.exr").string(), "--stats", (kDir / "full.json").string()}),
        0);
    const auto j = stats(kDir / "full.json");
    EXPECT_EQ(j["stopped_by"], "");
    EXPECT_EQ(j["spp_reached"].get<int64_t>(), 4);
}

}  // namespace
