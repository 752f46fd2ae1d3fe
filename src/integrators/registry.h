// The integrators and estimators, by name: the one list that the command line, `converge`,
// `trace`, checkpoints, the Python module, --stats and --help take their names and
// descriptions from (and that a test holds the docs to). A new estimator is one entry of
// kEstimators, beside its code.
#pragma once

#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "kernels/emitter_table.h"

namespace cierzo {

// How paths are traced: the same estimator either way (kernels/estimator.h).
enum class Integrator : int32_t {
    kWavefront = 0,  // paths in SoA pools, one stage at a time, SIMD kernels
    kScalar = 1,     // the reference: one path at a time
};

struct IntegratorEntry {
    Integrator id;
    const char* name;
    const char* summary;  // for --help
};

struct EstimatorEntry {
    Estimator id;
    const char* name;
    const char* summary;  // for --help
};

inline constexpr IntegratorEntry kIntegrators[] = {
    {Integrator::kWavefront, "wavefront", "SoA batches, SIMD kernels; the default"},
    {Integrator::kScalar, "scalar", "the reference: one path at a time"},
};

// The estimator of a scene or model that names none: the most efficient on most scenes
// (docs/estimators.md). The report's scenes name "report" themselves.
inline constexpr Estimator kDefaultEstimator = Estimator::kMis;

inline constexpr EstimatorEntry kEstimators[] = {
    {Estimator::kReport, "report",
     "the report's: emitters found by the paths that hit them (the scenes of scenes/ name "
     "it)"},
    {Estimator::kNee, "nee", "next-event estimation: plus one emitter sample per Phong vertex"},
    {Estimator::kMis, "mis",
     "both strategies, weighted by the power heuristic; the default of a scene or model that "
     "names none"},
    {Estimator::kLt, "lt",
     "light tracing: paths from the lights, each vertex connected to the pinhole (a mirror or "
     "glass seen directly shows only what camera paths find)"},
    {Estimator::kBdpt, "bdpt",
     "bidirectional path tracing: each camera path with a light subpath, every connection "
     "of the two (and each end alone) weighted by the power heuristic"},
    {Estimator::kVcm, "vcm",
     "vertex connection and merging: bdpt plus each camera vertex merged with the light "
     "vertices near it (photon mapping's strategy, for paths no connection makes: a caustic "
     "seen in a mirror), all weighted by the power heuristic; biased, consistent"},
    {Estimator::kBpm, "bpm",
     "bidirectional photon mapping: vcm's merging at every camera vertex, weighted by the "
     "power heuristic against merging alone, without connections; biased, consistent"},
    {Estimator::kPpm, "ppm",
     "progressive photon mapping: a camera path goes on through mirrors and glass and "
     "merges where it scatters off a Phong surface, unweighted; biased, consistent"},
};

struct RouletteEntry {
    Roulette id;
    const char* name;
    const char* summary;  // for --help
};

inline constexpr RouletteEntry kRoulettes[] = {
    {Roulette::kLobe, "lobe",
     "the report's: one draw picks a lobe by its max RGB or the path's death, survival at "
     "most the cap; the only one of report and lt, and their default"},
    {Roulette::kThroughput, "throughput",
     "nee and mis: the lobe chosen among the lobes alone, and from vertex --roulette-depth on "
     "the path goes on with probability min(max RGB of its throughput, cap); the default of "
     "nee and mis"},
};
struct SamplerEntry {
    Sampler id;
    const char* name;
    const char* summary;  // for --help
};

inline constexpr SamplerEntry kSamplers[] = {
    {Sampler::kIndependent, "independent",
     "a hash of (seed, pixel, sample, bounce, decision), as the report draws them; the "
     "default of report and lt"},
    {Sampler::kSobol, "sobol",
     "Owen-scrambled Sobol (0,2) points, one shuffled pair per decision, per pixel; the "
     "default of nee, mis and bdpt"},
    {Sampler::kZSobol, "zsobol",
     "Sobol points spread over the image in Morton order (error as blue noise; the points "
     "depend on --spp)"},
    {Sampler::kPmj02, "pmj02", "progressive multi-jittered (0,2) tables, scrambled per pixel"},
};

// How nee and mis sample emitting triangles (render.triangle_sampling, --triangle-sampling):
// by area, or by the solid angle they subtend.
inline constexpr const char* kTriangleSamplingNames[] = {"area", "solid-angle"};
inline const char* triangle_sampling_name(const EstimatorSettings& e) {
    return kTriangleSamplingNames[e.triangle_solid_angle ? 1 : 0];
}
// The largest render.roulette_depth / --roulette-depth.
inline constexpr int kMaxRouletteDepth = 1024;

const char* integrator_name(Integrator i);
const char* estimator_name(Estimator e);
std::optional<Integrator> parse_integrator(std::string_view name);
std::optional<Estimator> parse_estimator(std::string_view name);
const char* roulette_name(Roulette r);
std::optional<Roulette> parse_roulette(std::string_view name);
const char* sampler_name(Sampler s);
std::optional<Sampler> parse_sampler(std::string_view name);

// Every name, in the order above (the valid values of an option).
std::vector<std::string> integrator_names();
std::vector<std::string> estimator_names();
std::vector<std::string> roulette_names();
std::vector<std::string> sampler_names();

// The integrator named by `name`, or InputError "<option>: unknown integrator 'x' (valid:
// wavefront, scalar)".
Integrator integrator_of(std::string_view name, std::string_view option = "--integrator");

// "name (summary), name (summary) or name (summary)", for --help.
std::string describe_integrators();
std::string describe_estimators();
std::string describe_roulettes();
std::string describe_samplers();

// Sets the estimator and gives the knobs not in e.chosen the estimator's defaults, chosen by
// measurement (docs/estimators.md, "Defaults"): for nee and mis cosine diffuse sampling, the
// throughput roulette, triangles by solid angle and the sobol sampler; for report (exactly
// the report's) and lt, uniform diffuse, the lobe roulette, area triangles and the
// independent sampler.
void use_estimator(EstimatorSettings& e, Estimator kind);

// Refuses (InputError naming `source`) a roulette the estimator does not take: the
// throughput roulette is for nee and mis only.
void check_roulette(const EstimatorSettings& e, const std::string& source);

}  // namespace cierzo
