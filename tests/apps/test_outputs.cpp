// The output-file policy (io/output_file.h), through the programs and directly: no output
// replaces an input, another output, a device or a link; links are written through, streams
// written directly, and every write error names the file and fails the command.
//
// Devices are made with mknod in the test's own folder (never the real /dev entries), which
// needs root: those tests skip with a message otherwise.
#include <gtest/gtest.h>

#include <cerrno>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <fcntl.h>
#include <sys/stat.h>
#include <sys/sysmacros.h>
#include <unistd.h>

#include <nlohmann/json.hpp>

#include "core/error.h"
#include "io/output_file.h"
#include "support/program_test.h"

namespace {

namespace fs = std::filesystem;
using cierzo::InputError;
using cierzo::OutputTarget;
using cierzo::test::Outcome;
using cierzo::test::quote;
using cierzo::test::read_file;
using nlohmann::json;

// 8 x 8 pixels, 2 paths each, with a mesh file so that the scene has two inputs.
const char* const kScene = R"({
    "render": {"width": 8, "height": 8, "spp": 2, "seed": 3},
    "camera": {"position": [0, 0, -3], "look_at": [0, 0, 0]},
    "materials": {"white": {"kd": 0.8}, "lamp": {"emission": 2}},
    "objects": [
        {"type": "mesh", "file": "tri.obj", "material": "white"},
        {"type": "sphere", "center": [0, 2, 0], "radius": 0.5, "material": "lamp"}
    ]
})";
const char* const kMesh = "v -1 -1 0\nv 1 -1 0\nv 0 1 0\nf 1 2 3\n";
const char* const kFast = " --threads 1 --quiet";
const char* const kConverge = " --spp 1 --reference-spp 2 --threads 1 --quiet";

bool is_link(const fs::path& p) { return fs::is_symlink(fs::symlink_status(p)); }

bool is_char_device(const fs::path& p) {
    struct stat st;
    return ::lstat(p.c_str(), &st) == 0 && S_ISCHR(st.st_mode);
}

bool is_exr(const fs::path& p) { return read_file(p).rfind("\x76\x2f\x31\x01", 0) == 0; }

bool is_json(const std::string& text) {
    return json::accept(text) && json::parse(text).contains("rays_per_second");
}

class outputs : public cierzo::test::ProgramTest {
protected:
    void SetUp() override {
        ProgramTest::SetUp();
        scene_ = write("scene.json", kScene);
        write("tri.obj", kMesh);
    }

    // A character device in the test folder (root only): 1,3 is the null device, 1,7 the full
    // one (every write fails with ENOSPC).
    bool make_device(const std::string& name, unsigned minor_number) {
        return ::mknod((dir_ / name).c_str(), S_IFCHR | 0666, makedev(1, minor_number)) == 0;
    }

    fs::path scene_;
};

// Each row of the issue's table: the scene, the image and a device are never replaced.
TEST_F(outputs, StatsOverTheSceneIsRefusedBeforeAnyWork) {
    const std::string before = read_file(scene_);
    const Outcome r = run(quote(scene_) + kFast + " --stats " + quote(scene_));
    EXPECT_EQ(r.exit_code, 1) << r.err;
    EXPECT_NE(r.err.find("--stats is the same file as the scene file " + scene_.string()),
              std::string::npos)
        << r.err;
    EXPECT_EQ(read_file(scene_), before);
    EXPECT_EQ(other_files({"scene.json", "tri.obj"}), std::vector<std::string>{});
}

TEST_F(outputs, StatsOverTheImageIsRefused) {
    const fs::path image = write("a.pfm", "precious");
    const Outcome r =
        run(quote(scene_) + kFast + " --out " + quote(image) + " --stats " + quote(image));
    EXPECT_EQ(r.exit_code, 1) << r.err;
    EXPECT_NE(r.err.find(image.string() + ": --stats is the same file as --out " + image.string()),
              std::string::npos)
        << r.err;
    EXPECT_EQ(read_file(image), "precious");
}

TEST_F(outputs, ConvergeOutOverTheSceneOrTheReferenceIsRefused) {
    const std::string before = read_file(scene_);
    Outcome r = run(quote(scene_) + kConverge + " --out " + quote(scene_), "converge");
    EXPECT_EQ(r.exit_code, 1) << r.err;
    EXPECT_NE(r.err.find("--out is the same file as the scene file"), std::string::npos) << r.err;
    EXPECT_EQ(read_file(scene_), before);
    // The reference read, and the reference saved against the CSV
    ASSERT_EQ(run(quote(scene_) + kFast + " --out " + quote(dir_ / "ref.exr")).exit_code, 0);
    const std::string ref = read_file(dir_ / "ref.exr");
    r = run(quote(scene_) + " --spp 1 --threads 1 --quiet --reference " + quote(dir_ / "ref.exr") +
                " --out " + quote(dir_ / "ref.exr"),
            "converge");
    EXPECT_EQ(r.exit_code, 1) << r.err;
    EXPECT_NE(r.err.find("--out is the same file as --reference"), std::string::npos) << r.err;
    EXPECT_EQ(read_file(dir_ / "ref.exr"), ref);
    fs::create_symlink("ref.exr", dir_ / "link.csv");
    r = run(quote(scene_) + kConverge + " --save-reference " + quote(dir_ / "ref.exr") + " --out " +
                quote(dir_ / "link.csv"),
            "converge");
    EXPECT_EQ(r.exit_code, 1) << r.err;
    EXPECT_NE(r.err.find("--save-reference is the same file as --out"), std::string::npos) << r.err;
    EXPECT_EQ(read_file(dir_ / "ref.exr"), ref);
}

TEST_F(outputs, AMeshFileIsAnInput) {
    const Outcome r = run(quote(scene_) + kFast + " --stats " + quote(dir_ / "tri.obj"));
    EXPECT_EQ(r.exit_code, 1) << r.err;
    EXPECT_NE(r.err.find("--stats is the same file as the mesh file"), std::string::npos) << r.err;
    EXPECT_EQ(read_file(dir_ / "tri.obj"), kMesh);
}

// Another name for the scene is the scene: a hard link, a symbolic link, a path through "..",
// an absolute and a relative spelling.
TEST_F(outputs, EveryNameOfTheSceneIsTheScene) {
    const std::string before = read_file(scene_);
    fs::create_hard_link(scene_, dir_ / "hard.json");
    fs::create_symlink("scene.json", dir_ / "soft.json");
    fs::create_directory(dir_ / "sub");
    const fs::path old_cwd = fs::current_path();
    fs::current_path(dir_);
    for (const std::string& other :
         {(dir_ / "hard.json").string(), (dir_ / "soft.json").string(),
          (dir_ / "sub" / ".." / "scene.json").string(), std::string("scene.json"),
          std::string("./sub/../scene.json")}) {
        SCOPED_TRACE(other);
        const Outcome r = run(quote(scene_) + kFast + " --stats " + quote(other));
        EXPECT_EQ(r.exit_code, 1) << r.err;
        EXPECT_NE(r.err.find("is the same file as the scene file"), std::string::npos) << r.err;
    }
    // ... and two outputs that do not exist yet, spelled apart
    const Outcome o = run(std::string("scene.json") + kFast + " --out sub/../new.exr --stats " +
                          quote(dir_ / "new.exr"));
    EXPECT_EQ(o.exit_code, 1) << o.err;
    EXPECT_NE(o.err.find("--stats is the same file as --out"), std::string::npos) << o.err;
    fs::current_path(old_cwd);
    EXPECT_EQ(read_file(scene_), before);
    EXPECT_TRUE(is_link(dir_ / "soft.json"));
    EXPECT_FALSE(fs::exists(dir_ / "new.exr"));
}

TEST_F(outputs, CheckpointsClashWithTheImageNotWithTheStateTheyContinue) {
    const fs::path ck = dir_ / "ck.exr";
    Outcome r = run(quote(scene_) + kFast + " --out " + quote(ck) + " --checkpoint " + quote(ck));
    EXPECT_EQ(r.exit_code, 1) << r.err;
    EXPECT_NE(r.err.find("--checkpoint is the same file as --out"), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(ck));
    // A checkpoint resumed and written again in one file is how resuming works
    ASSERT_EQ(run(quote(scene_) + kFast + " --spp 1 --out " + quote(dir_ / "a.exr") +
                  " --checkpoint " + quote(ck))
                  .exit_code,
              0);
    r = run(quote(scene_) + kFast + " --out " + quote(dir_ / "b.exr") + " --resume " + quote(ck));
    EXPECT_EQ(r.exit_code, 0) << r.err;
    // ... but the image may not go over it
    const std::string state = read_file(ck);
    r = run(quote(scene_) + kFast + " --out " + quote(ck) + " --resume " + quote(ck) +
            " --checkpoint " + quote(dir_ / "other.exr"));
    EXPECT_EQ(r.exit_code, 1) << r.err;
    EXPECT_NE(r.err.find("--out is the same file as --resume"), std::string::npos) << r.err;
    EXPECT_EQ(read_file(ck), state);
}

// A finished render continued to more paths: on the schedule of the larger count, no
// warning; off it (a small image's passes below 16 are joined), a warning that the bits
// differ from an uninterrupted render's.
TEST_F(outputs, AResumedFinishedRenderOffTheScheduleWarns) {
    const fs::path ck16 = dir_ / "ck16.exr", ck8 = dir_ / "ck8.exr";
    const std::string size = " --width 16 --height 16 --threads 1 --quiet";
    ASSERT_EQ(run(quote(scene_) + size + " --spp 16 --out " + quote(dir_ / "a.exr") +
                  " --checkpoint " + quote(ck16))
                  .exit_code,
              0);
    ASSERT_EQ(run(quote(scene_) + size + " --spp 8 --out " + quote(dir_ / "b.exr") +
                  " --checkpoint " + quote(ck8))
                  .exit_code,
              0);
    Outcome r = run(quote(scene_) + size + " --spp 32 --out " + quote(dir_ / "c.exr") +
                    " --resume " + quote(ck16));
    EXPECT_EQ(r.exit_code, 0) << r.err;
    EXPECT_EQ(r.err.find("not bit-identical"), std::string::npos) << r.err;
    r = run(quote(scene_) + size + " --spp 32 --out " + quote(dir_ / "d.exr") + " --resume " +
            quote(ck8));
    EXPECT_EQ(r.exit_code, 0) << r.err;
    EXPECT_NE(r.err.find("not bit-identical to an uninterrupted render of 32"), std::string::npos)
        << r.err;
}

// A link kept as "the latest render" stays a link, and points at the new image.
TEST_F(outputs, AnImageLinkIsWrittenThrough) {
    fs::create_directory(dir_ / "renders");
    write("renders/r1.exr", "old");
    fs::create_symlink("renders/r1.exr", dir_ / "latest.exr");
    fs::create_symlink("renders/r2.exr", dir_ / "next.exr");  // (dangling: created there)
    for (const char* name : {"latest.exr", "next.exr"}) {
        SCOPED_TRACE(name);
        const Outcome r = run(quote(scene_) + kFast + " --out " + quote(dir_ / name));
        ASSERT_EQ(r.exit_code, 0) << r.err;
        EXPECT_TRUE(is_link(dir_ / name));
        EXPECT_TRUE(is_exr(dir_ / name));
    }
    EXPECT_EQ(fs::read_symlink(dir_ / "latest.exr"), "renders/r1.exr");
    EXPECT_TRUE(is_exr(dir_ / "renders" / "r1.exr"));
    EXPECT_TRUE(is_exr(dir_ / "renders" / "r2.exr"));
    EXPECT_EQ(other_files({"scene.json", "tri.obj", "renders", "latest.exr", "next.exr"}),
              std::vector<std::string>{});
    EXPECT_EQ(std::distance(fs::directory_iterator(dir_ / "renders"), {}), 2);  // no temporary
}

// Standard output: "-", and a link to /proc/self/fd/1 (what /dev/stdout is).
TEST_F(outputs, StatisticsGoToStandardOutput) {
    Outcome r = run(quote(scene_) + kFast + " --out " + quote(dir_ / "a.exr") + " --stats -");
    ASSERT_EQ(r.exit_code, 0) << r.err;
    EXPECT_TRUE(is_json(r.out)) << r.out;
    fs::create_symlink("/proc/self/fd/1", dir_ / "stdout.json");
    r = run(quote(scene_) + kFast + " --out " + quote(dir_ / "a.exr") + " --stats " +
            quote(dir_ / "stdout.json"));
    ASSERT_EQ(r.exit_code, 0) << r.err;
    EXPECT_TRUE(is_json(r.out)) << r.out;
    EXPECT_TRUE(is_link(dir_ / "stdout.json"));
    // converge's CSV: rows on standard output, the table on standard error
    r = run(quote(scene_) + " --spp 1,2 --reference-spp 4 --threads 1 --integrator scalar --out -",
            "converge");
    ASSERT_EQ(r.exit_code, 0) << r.err;
    std::istringstream lines(r.out);
    std::vector<std::string> rows;
    for (std::string line; std::getline(lines, line);) rows.push_back(line);
    ASSERT_EQ(rows.size(), 3u) << r.out;
    EXPECT_EQ(rows[0].rfind("scene,integrator,", 0), 0u) << r.out;
    EXPECT_NE(r.err.find("relMSE"), std::string::npos) << r.err;
}

// The FIFO's reader is this test: it opens the FIFO first, and keeps a writer of its own open
// until the program has ended, so that a program that renamed a file over the FIFO instead
// fails the test rather than hanging it. (The statistics fit in the pipe's buffer.)
TEST_F(outputs, AFifoIsWrittenForItsReader) {
    const fs::path fifo = dir_ / "stats.fifo";
    ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
    const int reader = ::open(fifo.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC);
    ASSERT_GE(reader, 0);
    const int keep = ::open(fifo.c_str(), O_WRONLY | O_CLOEXEC);
    ASSERT_GE(keep, 0);
    ASSERT_EQ(::fcntl(reader, F_SETFL, 0), 0);  // (blocking reads from here on)
    const Outcome r =
        run(quote(scene_) + kFast + " --out " + quote(dir_ / "a.exr") + " --stats " + quote(fifo));
    ::close(keep);
    std::string received;
    char buffer[4096];
    for (ssize_t n; (n = ::read(reader, buffer, sizeof buffer)) > 0;)
        received.append(buffer, size_t(n));
    ::close(reader);
    EXPECT_EQ(r.exit_code, 0) << r.err;
    EXPECT_TRUE(is_json(received)) << received;
    struct stat st;
    ASSERT_EQ(::lstat(fifo.c_str(), &st), 0);
    EXPECT_TRUE(S_ISFIFO(st.st_mode));
}

TEST_F(outputs, TheNullDeviceTakesEveryOutputAndStaysADevice) {
    if (!make_device("null", 3)) GTEST_SKIP() << "mknod needs root: " << std::strerror(errno);
    fs::create_symlink("null", dir_ / "null.exr");
    fs::create_symlink("null", dir_ / "null.json");
    for (const char* stats : {"null", "null.json"}) {
        SCOPED_TRACE(stats);
        const Outcome r = run(quote(scene_) + kFast + " --out " + quote(dir_ / "null.exr") +
                              " --stats " + quote(dir_ / stats));
        EXPECT_EQ(r.exit_code, 0) << r.err;
        EXPECT_TRUE(is_char_device(dir_ / "null"));
        EXPECT_TRUE(is_link(dir_ / "null.exr"));
        EXPECT_TRUE(is_link(dir_ / "null.json"));
    }
    EXPECT_EQ(other_files({"scene.json", "tri.obj", "null", "null.exr", "null.json"}),
              std::vector<std::string>{});
}

// A full device as every kind of output: a non-zero exit naming the file, the device kept.
TEST_F(outputs, AFullDeviceFailsEveryOutputKindNamingIt) {
    if (!make_device("full", 7)) GTEST_SKIP() << "mknod needs root: " << std::strerror(errno);
    for (const char* link : {"full.exr", "full.png", "full.csv"})
        fs::create_symlink("full", dir_ / link);
    ASSERT_EQ(run(quote(scene_) + kFast + " --out " + quote(dir_ / "in.exr")).exit_code, 0);
    const fs::path full = dir_ / "full";
    const std::string out = " --out " + quote(dir_ / "a.exr");
    struct Case {
        const char* what;
        std::string program, args, names;
    };
    const std::vector<Case> cases = {
        {"image", "cierzo",
         "render " + quote(scene_) + kFast + " --out " + quote(dir_ / "full.exr"), "full.exr"},
        {"statistics", "cierzo",
         "render " + quote(scene_) + kFast + out + " --stats " + quote(full), "full"},
        {"checkpoint", "cierzo",
         "render " + quote(scene_) + kFast + out + " --checkpoint " + quote(dir_ / "full.exr"),
         "full.exr"},
        {"csv", "cierzo",
         "converge " + quote(scene_) + kConverge + " --out " + quote(dir_ / "full.csv"),
         "full.csv"},
        {"reference", "cierzo",
         "converge " + quote(scene_) + kConverge + " --save-reference " + quote(dir_ / "full.exr"),
         "full.exr"},
        {"tone-mapped image", "cierzo-tonemap",
         quote(dir_ / "in.exr") + " " + quote(dir_ / "full.png"), "full.png"},
    };
    for (const Case& c : cases) {
        SCOPED_TRACE(c.what);
        const Outcome r = run_program(c.program, c.args);
        EXPECT_NE(r.exit_code, 0) << r.err;
        EXPECT_NE(r.exit_code, -1) << "crashed: " << r.err;
        EXPECT_NE(r.err.find((dir_ / c.names).string() + ":"), std::string::npos) << r.err;
        EXPECT_TRUE(is_char_device(full));
    }
}

TEST_F(outputs, TheToneMapperKeepsItsInput) {
    ASSERT_EQ(run(quote(scene_) + kFast + " --out " + quote(dir_ / "in.exr")).exit_code, 0);
    const std::string before = read_file(dir_ / "in.exr");
    fs::create_symlink("in.exr", dir_ / "out.png");
    const Outcome r =
        run_program("cierzo-tonemap", quote(dir_ / "in.exr") + " " + quote(dir_ / "out.png"));
    EXPECT_EQ(r.exit_code, 1) << r.err;
    EXPECT_NE(r.err.find("the output image is the same file as the input image"), std::string::npos)
        << r.err;
    EXPECT_EQ(read_file(dir_ / "in.exr"), before);
}

// ---- The policy itself --------------------------------------------------------------------

class output_file : public cierzo::test::ProgramTest {};

std::string input_error(const std::function<void()>& f) {
    try {
        f();
    } catch (const InputError& e) {
        return e.what();
    }
    return "(no error)";
}

TEST_F(output_file, PathsResolveToWhatIsWritten) {
    write("file", "x");
    fs::create_symlink("file", dir_ / "a");
    fs::create_symlink("a", dir_ / "b");  // a chain
    fs::create_symlink("loop2", dir_ / "loop1");
    fs::create_symlink("loop1", dir_ / "loop2");
    fs::create_symlink("/proc/self/fd/2", dir_ / "err");
    OutputTarget t = cierzo::resolve_output(dir_ / "b");
    EXPECT_EQ(t.kind, OutputTarget::Kind::kFile);
    EXPECT_EQ(t.file, dir_ / "file");
    t = cierzo::resolve_output(dir_ / "new");
    EXPECT_EQ(t.kind, OutputTarget::Kind::kFile);
    EXPECT_EQ(t.file, dir_ / "new");
    t = cierzo::resolve_output("-");
    EXPECT_EQ(t.kind, OutputTarget::Kind::kStream);
    EXPECT_EQ(t.descriptor, 1);
    t = cierzo::resolve_output(dir_ / "err");
    EXPECT_EQ(t.kind, OutputTarget::Kind::kStream);
    EXPECT_EQ(t.descriptor, 2);
    EXPECT_NE(input_error([&] {
                  cierzo::resolve_output(dir_ / "loop1");
              }).find("too many levels of symbolic links"),
              std::string::npos);
    EXPECT_NE(input_error([&] {
                  cierzo::resolve_output(dir_, "the image");
              }).find(dir_.string() + ": cannot write the image: it is a folder"),
              std::string::npos);
    EXPECT_NE(input_error([&] {
                  cierzo::resolve_output(dir_ / "no" / "x.exr");
              }).find("folder '" + (dir_ / "no").string() + "' does not exist"),
              std::string::npos);
    EXPECT_NE(input_error([&] {
                  cierzo::resolve_output("/proc/self/fd/987");
              }).find("descriptor 987 is not open"),
              std::string::npos);
}

TEST_F(output_file, ABlockDeviceIsRefused) {
    if (::mknod((dir_ / "disk").c_str(), S_IFBLK | 0600, makedev(7, 0)) != 0)
        GTEST_SKIP() << "mknod needs root: " << std::strerror(errno);
    EXPECT_NE(input_error([&] {
                  cierzo::write_output_stream(dir_ / "disk", [](std::ofstream&) {});
              }).find("it is a block device"),
              std::string::npos);
    struct stat st;
    ASSERT_EQ(::lstat((dir_ / "disk").c_str(), &st), 0);
    EXPECT_TRUE(S_ISBLK(st.st_mode));
}

// Through a link into another folder: the temporary file goes beside the target, whose
// permission bits the new file keeps.
TEST_F(output_file, ALinkIsWrittenThroughKeepingTheTargetsMode) {
    fs::create_directories(dir_ / "x");
    fs::create_directories(dir_ / "y");
    write("y/target", "old");
    fs::permissions(dir_ / "y" / "target", fs::perms::owner_read | fs::perms::owner_write);
    fs::create_symlink("../y/target", dir_ / "x" / "link");
    fs::path seen;
    cierzo::write_output(dir_ / "x" / "link", [&](const fs::path& tmp) {
        seen = tmp;
        std::ofstream(tmp) << "new";
    });
    EXPECT_EQ(seen.parent_path(), dir_ / "x" / ".." / "y");
    EXPECT_FALSE(fs::exists(seen));
    EXPECT_TRUE(is_link(dir_ / "x" / "link"));
    EXPECT_EQ(read_file(dir_ / "y" / "target"), "new");
    EXPECT_EQ(fs::status(dir_ / "y" / "target").permissions() & fs::perms::all,
              fs::perms::owner_read | fs::perms::owner_write);
    EXPECT_EQ(std::distance(fs::directory_iterator(dir_ / "x"), {}), 1);
    EXPECT_EQ(std::distance(fs::directory_iterator(dir_ / "y"), {}), 1);
}

// A pipe whose reader has gone: EPIPE, named (SIGPIPE is ignored, as the programs ignore it).
TEST_F(output_file, AClosedPipeIsAnErrorNamingThePath) {
    const auto previous = std::signal(SIGPIPE, SIG_IGN);
    int fds[2];
    ASSERT_EQ(::pipe(fds), 0);
    ::close(fds[0]);
    const fs::path path = "/proc/self/fd/" + std::to_string(fds[1]);
    const std::string err = input_error(
        [&] { cierzo::write_output_stream(path, [](std::ofstream& out) { out << "data"; }); });
    ::close(fds[1]);
    std::signal(SIGPIPE, previous);
    EXPECT_NE(err.find(path.string() + ": cannot write: Broken pipe"), std::string::npos) << err;
}

TEST_F(output_file, AStreamReceivesTheBytesInOrder) {
    int fds[2];
    ASSERT_EQ(::pipe(fds), 0);
    std::string received;
    std::thread reader([&] {
        char buffer[4096];
        for (ssize_t n; (n = ::read(fds[0], buffer, sizeof buffer)) > 0;)
            received.append(buffer, size_t(n));
    });
    std::string sent;
    for (int i = 0; i < 200000; ++i) sent += char('a' + i % 26);  // more than a pipe buffers
    const fs::path path = "/dev/fd/" + std::to_string(fds[1]);
    cierzo::write_output_stream(path, [&](std::ofstream& out) { out << sent; });
    ::close(fds[1]);
    reader.join();
    ::close(fds[0]);
    EXPECT_EQ(received, sent);
}

}  // namespace
