// The check every reader makes before it opens an input file (src/io/input_file.cpp): a
// regular file or a link to one is read, a missing one is left to the reader to report, and
// a directory, a FIFO or a device is refused naming the path before anything opens it (the
// open of a FIFO waits for a writer, for ever if none comes).
#include <gtest/gtest.h>

#include <filesystem>
#include <functional>
#include <string>

#include "core/error.h"
#include "integrators/checkpoint.h"
#include "io/image.h"
#include "io/input_file.h"
#include "io/mesh.h"
#include "io/mtl.h"
#include "io/obj.h"
#include "io/ply.h"
#include "io/texture_image.h"
#include "scene/scene_json.h"
#include "support/scratch.h"

namespace cierzo {
namespace {

namespace fs = std::filesystem;

const fs::path& scratch() { return test::scratch("input-file"); }

// A symbolic link at `link` to `target`, made anew
void make_link(const fs::path& target, const fs::path& link) {
    fs::remove(link);
    fs::create_symlink(target, link);
}

TEST(InputFile, RegularFilesAndLinksToThemAreReadMissingOnesLeftToTheReader) {
    const fs::path dir = scratch();
    test::write_text(dir / "plain.txt", "x");
    make_link(dir / "plain.txt", dir / "link.txt");
    make_link(dir / "missing.txt", dir / "dangling.txt");
    EXPECT_TRUE(input_file_exists(dir / "plain.txt"));
    EXPECT_TRUE(input_file_exists(dir / "link.txt"));
    EXPECT_FALSE(input_file_exists(dir / "missing.txt"));
    EXPECT_FALSE(input_file_exists(dir / "dangling.txt"));
}

TEST(InputFile, DirectoriesFifosDevicesAndLoopsOfLinksAreRefusedNamingThePath) {
    const fs::path dir = scratch();
    const fs::path fifo = test::make_fifo(dir / "pipe");
    make_link(fifo, dir / "pipe-link");
    make_link(dir / "loop-b", dir / "loop-a");
    make_link(dir / "loop-a", dir / "loop-b");
    const struct {
        fs::path path;
        const char* what;
    } cases[] = {
        {dir, ": is a directory, not a regular file"},
        {fifo, ": is a FIFO (named pipe), not a regular file"},
        {dir / "pipe-link", ": is a FIFO (named pipe), not a regular file"},
        {"/dev/null", ": is a character device, not a regular file"},
        {dir / "loop-a", ": cannot read: "},
    };
    for (const auto& c : cases) {
        const std::string m = test::refusal_of([&] { (void)input_file_exists(c.path); });
        EXPECT_NE(m.find(c.path.string() + c.what), std::string::npos) << m;
    }
}

// Every reader of an input file refuses a FIFO before opening it (the scene reader's uses
// of them, from an MTL's map_Kd to an environment map: test_textures.cpp)
TEST(InputFile, EveryReaderRefusesAFifoWithoutOpeningIt) {
    const fs::path dir = scratch() / "readers";
    fs::create_directories(dir);
    const struct {
        const char* name;
        std::function<void(const fs::path&)> read;
    } readers[] = {
        {"read_ply.ply", [](const fs::path& p) { read_ply(p); }},
        {"read_obj.obj", [](const fs::path& p) { read_obj(p); }},
        {"read_mesh.obj", [](const fs::path& p) { read_mesh(p); }},
        {"read_mtl.mtl", [](const fs::path& p) { read_mtl(p); }},
        {"read_texture_image.png", [](const fs::path& p) { read_texture_image(p, true); }},
        {"read_texture_image.exr", [](const fs::path& p) { read_texture_image(p, false); }},
        {"read_exr.exr", [](const fs::path& p) { read_exr(p); }},
        {"read_pfm.pfm", [](const fs::path& p) { read_pfm(p); }},
        {"read_hdr.pfm", [](const fs::path& p) { read_hdr(p); }},
        {"load_scene.json", [](const fs::path& p) { load_scene(p); }},
        {"load_scene.ply", [](const fs::path& p) { load_scene(p); }},
        {"read_checkpoint.exr", [](const fs::path& p) { read_checkpoint(p); }},
    };
    for (const auto& r : readers) {
        const fs::path fifo = test::make_fifo(dir / r.name);
        const std::string m = test::refusal_without_opening(fifo, [&] { r.read(fifo); });
        EXPECT_NE(m.find(fifo.string() + ": is a FIFO (named pipe), not a regular file"),
                  std::string::npos)
            << r.name << ": " << m;
    }
}

}  // namespace
}  // namespace cierzo
