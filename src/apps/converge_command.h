// `cierzo converge`: error against time for every knob that trades one for the other.
// The command line's options (ConvergeArgs) drive one sweep, which the Python module runs
// too (run_converge_job).
#pragma once

#include <atomic>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "apps/app_common.h"
#include "scene/scene.h"

namespace CLI {
class App;
}

namespace cierzo {

// The options of `cierzo converge` (see its --help and the README).
struct ConvergeArgs {
    std::filesystem::path scene;
    InputOptions inputs;  // --allow-path, --image-memory
    std::filesystem::path reference;
    std::filesystem::path save_reference;
    int64_t reference_spp = 4096;
    std::string reference_integrator = "wavefront";  // (names: integrators/registry.h)
    std::vector<int64_t> spp = {1, 2, 4, 8, 16, 32, 64, 128, 256, 512, 1024};
    std::vector<std::string> integrators = {"scalar", "wavefront"};
    std::vector<std::string> isas = {"auto"};
    std::vector<int> pools = {0};
    std::vector<float> survival_caps;
    std::vector<std::string> diffuse_sampling;
    std::vector<std::string> estimators;
    std::vector<std::string> roulettes;
    std::vector<std::string> triangle_sampling;
    std::vector<std::string> samplers;
    std::vector<std::string> guidings;  // nee and mis only
    std::optional<int> guided_vertices;
    std::vector<float> merge_radii, merge_alphas;  // vcm only
    std::vector<int> light_connections;            // bdpt and vcm only
    std::optional<int> roulette_depth;
    std::optional<std::string> reference_estimator;
    std::optional<int> width, height;
    int threads = 0;
    int repeats = 1;
    std::filesystem::path out;
    bool quiet = false;   // print only the summary
    bool summary = true;  // print the reference's time and each configuration's slope
    const std::atomic<bool>* cancel = nullptr;  // set to stop: the rows measured so far
};

// Adds the subcommand to `app`; returns it so main can see whether it was chosen and run it.
CLI::App* add_converge_command(CLI::App& app);
int run_converge_command();

// The sweep on a loaded scene (whose `scene` and options are the args' other fields):
// checks, the reference (read or rendered), every point. Returns the CSV rows, which are
// also written to `out` after each point; the columns are converge_csv_header()'s.
std::vector<std::string> run_converge_job(Scene scene, const ConvergeArgs& args);
std::string converge_csv_header();

}  // namespace cierzo
