// Speed against accuracy: the error of an image against a reference, and sweeps that render
// a scene at increasing paths per pixel for each combination of the knobs that trade time for
// error (integrator, ISA, pool size, roulette survival cap, diffuse sampling), recording the
// wall time and the error of each render. `cierzo converge` is the command-line front end.
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "integrators/render_types.h"

namespace cierzo {

// The relative MSE's guard against division by ~0 in black pixels: (x - r)² / (r² + ε).
inline constexpr double kRelMseEpsilon = 1e-2;

// The error of an image against a reference, averaged over pixels and channels. A rendered
// reference has noise of its own, which adds its variance to every squared difference:
// given the reference's per-pixel variance of the mean, that part is reported and removed
// from the `_corrected` values (clamped at 0), which then estimate the error against the
// true image.
struct ImageError {
    double mse = 0.0;            // mean (x - r)²
    double rel_mse = 0.0;        // mean (x - r)² / (r² + ε)
    double reference_mse = 0.0;  // the reference's own contribution to mse
    double reference_rel_mse = 0.0;
    double mse_corrected() const { return mse > reference_mse ? mse - reference_mse : 0.0; }
    double rel_mse_corrected() const {
        return rel_mse > reference_rel_mse ? rel_mse - reference_rel_mse : 0.0;
    }
};

// Throws InputError when the sizes differ. `reference_variance` may be null (an exact or
// external reference).
ImageError image_error(const Image& image, const Image& reference,
                       const Image* reference_variance = nullptr);

// One combination of the knobs. Knobs that do not apply to the integrator are ignored
// (the scalar reference has no ISA or pool).
struct ConvergeConfig {
    std::string integrator = "wavefront";
    std::string isa = "auto";
    int pool_size = 0;              // 0: the default
    float survival_cap = -1.0f;     // < 0: the scene's
    int cosine_diffuse = -1;        // -1: the scene's; 0 uniform, 1 cosine
    int estimator = -1;             // -1: the scene's; else an Estimator
    int roulette = -1;              // -1: the scene's; else a Roulette
    int triangle_solid_angle = -1;  // -1: the scene's; 0 area, 1 solid angle
    int roulette_depth = -1;        // -1: the scene's
    int sampler = -1;               // -1: the scene's; else a Sampler
    float merge_radius = -1.0f;     // vcm: < 0 the scene's (0: from the scene's size)
    float merge_alpha = -1.0f;      // vcm: < 0 the scene's
    int light_connections = -1;     // bdpt, vcm: < 0 the scene's
    int guiding = -1;               // -1: the scene's; else a Guiding (nee, mis)
    int guided_vertices = -1;       // -1: the scene's
};

struct ConvergePoint {
    ConvergeConfig config;
    EstimatorSettings estimator;  // the settings rendered with: the scene's and the config's
    float merge_radius = 0.0f;    // vcm: the r0 rendered with (the scene's rule resolved)
    int64_t spp = 0;
    int repeats = 0;
    double seconds = 0.0;                   // median over the repeats
    uint64_t rays = 0;                      // of one render
    ImageError error;                       // averaged over the repeats
    double estimated_relative_error = 0.0;  // the render's own estimate, averaged
    RenderStats stats;                      // of the first repeat
};

struct ConvergeSweep {
    std::vector<ConvergeConfig> configs;
    std::vector<int64_t> spp;  // paths per pixel, in the order rendered
    int repeats = 1;           // renders per point, seeds scene seed + 1 + k
    int threads = 0;
    // Set (e.g. by SIGINT) to stop: the sweep returns the points measured so far
    const std::atomic<bool>* cancel = nullptr;
};

// Renders every config at every spp of the sweep and compares each image with the
// reference; `on_point` (may be empty) sees each point as soon as it is measured.
std::vector<ConvergePoint> run_converge(const Scene& scene, const Image& reference,
                                        const Image* reference_variance, const ConvergeSweep& sweep,
                                        const std::function<void(const ConvergePoint&)>& on_point);

// The least-squares slope of log(y) against log(x) over the points with y > 0 (NaN when
// fewer than two): -1 for an unbiased estimator's MSE against paths per pixel.
double log_log_slope(const std::vector<double>& x, const std::vector<double>& y);

}  // namespace cierzo
