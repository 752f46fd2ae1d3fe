// One render as `cierzo render` and the Python module run it: the command line's overrides
// of the scene's settings, the checks made before a long render, checkpoints and resuming,
// the outputs (image, its metadata and variance layers) and the --stats JSON.
#pragma once

#include <atomic>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "integrators/render.h"
#include "io/image.h"
#include "scene/scene.h"

namespace cierzo {

struct RenderJob {
    // Overrides of the scene's render settings (unset: the scene's)
    std::optional<int64_t> spp;
    std::optional<uint32_t> seed;
    std::optional<int> width, height;
    std::optional<float> survival_cap;
    std::optional<float> spatial_splits;           // the BVH's split budget (rebuilds it)
    std::optional<std::string> diffuse_sampling;   // uniform or cosine
    std::optional<std::string> triangle_sampling;  // area or solid-angle
    std::optional<std::string> roulette;           // lobe or throughput
    std::optional<int> roulette_depth;
    std::optional<std::string> sampler;              // independent, sobol, zsobol or pmj02
    std::optional<std::string> guiding;              // none or sdtree
    std::optional<int> guided_vertices;              // 0: every Phong vertex
    std::optional<int> min_length, max_length;       // path lengths that count
    std::vector<int> strategy;                       // bdpt: {s, t}, the one strategy kept
    bool unweighted = false;                         // ... without its weight
    std::optional<float> merge_radius, merge_alpha;  // vcm: r0 and α
    std::optional<int32_t> light_connections;        // bdpt, vcm: the light vertex cache's draws
    std::optional<std::string> estimator;            // report, nee or mis
    // bdpt: also record every strategy's image (integrators/strategies.h), written to
    // `strategies_dir` when outputs are written (the Python module keeps them)
    bool strategies = false;
    std::filesystem::path strategies_dir;
    // How to render
    int threads = 0;
    std::string integrator = "wavefront";
    bool integrator_given = false;  // (the strategy images refuse another than scalar)
    std::string isa = "auto";
    int pool = 0;
    int ray_group = 1;
    double time_budget = 0.0;
    double target_error = 0.0;
    bool progress = true;
    const std::atomic<bool>* cancel = nullptr;  // set to stop after the passes finished
    // Outputs: with `write_outputs`, the image (empty: the scene's render.output) and the
    // statistics (empty: none) are checked before the render and written after it;
    // without, the caller keeps the film (the Python module)
    bool write_outputs = true;
    bool variance = false;  // the EXR gets the variance layers
    std::filesystem::path out;
    std::filesystem::path stats;
    // Checkpoints and resuming (see integrators/checkpoint.h)
    std::filesystem::path checkpoint;
    double checkpoint_every = 300.0;
    bool checkpoint_every_given = false;
    std::filesystem::path resume;
    // Called once every check has passed, just before rendering (the CLI installs its
    // signal handlers there)
    std::function<void()> on_start;
};

struct RenderJobResult {
    Scene scene;  // with the overrides applied
    RenderResult result;
    std::vector<std::string> resume_warnings;  // already printed on stderr
    std::filesystem::path checkpoint;          // the file checkpoints went to, if any
    std::shared_ptr<StrategyFilm> strategies;  // the strategy images, if recorded
};

// The most memory the strategy images may take (StrategyFilm::bytes).
inline constexpr size_t kStrategyMemoryLimit = size_t(4) << 30;

// The strategy images' files in `dir`: strategy i's, weighted or not.
std::filesystem::path strategy_image_path(const std::filesystem::path& dir,
                                          const StrategyLayout& layout, int i, bool weighted);

// Refuses an instruction set this CPU lacks (before the scene is read, as the CLI does).
void check_render_isa(const RenderJob& job);

// Applies the job's overrides to the scene and checks the render size; throws InputError
// naming the scene file or option.
void apply_render_overrides(Scene& scene, const RenderJob& job);
// --spatial-splits: the scene's BVH built again with this split budget (InputError outside
// [0, 4]; nothing when unset or the scene's own).
void apply_spatial_splits(Scene& scene, std::optional<float> budget);

// Applies the overrides, checks everything that could fail late (outputs, checkpoints),
// resumes if asked, and renders. Throws InputError with the messages of `cierzo render`.
// Under MPI every rank calls it; only rank 0's result holds the image.
RenderJobResult run_render_job(Scene scene, const RenderJob& job);

// Threads of the whole run: this process's, or under MPI every rank's.
int total_threads(const RenderStats& stats);

// The EXR metadata of a finished render (scene, integrator, ISA, spp, seed, estimator).
ImageMetadata render_metadata(const Scene& scene, const RenderStats& stats);

// The --stats JSON: time, paths, rays by kind, rays/s, error, lanes, pool, BVH, and the
// checkpoint and MPI figures when there are any.
nlohmann::json render_stats_json(const Scene& scene, const RenderStats& stats,
                                 const std::filesystem::path& checkpoint);

// Writes the image (and its variance layers if asked) and the statistics the job names.
void write_render_outputs(const RenderJob& job, const RenderJobResult& done);

}  // namespace cierzo
