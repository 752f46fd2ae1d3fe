// The estimators, the roulettes and the samplers by name, with their descriptions, and the
// defaults an estimator gives the settings not chosen: what a scene file, the command line and
// the integrators' registry (src/integrators/registry.h) read them from.
#pragma once

#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "kernels/emitter_table.h"

namespace cierzo {

// A table of entries {id, name, summary}: the name of entry `id` ("unknown" if none), the
// entry named `name`, every name in order, and "name (summary), name (summary) or name
// (summary)" for --help.
namespace name_table {

template <class Entries, class Id>
const char* name_of(const Entries& entries, Id id) {
    for (const auto& e : entries)
        if (e.id == id) return e.name;
    return "unknown";
}
template <class Entries>
auto parse(const Entries& entries, std::string_view name)
    -> std::optional<decltype(entries[0].id)> {
    for (const auto& e : entries)
        if (name == e.name) return e.id;
    return std::nullopt;
}
template <class Entries>
std::vector<std::string> names(const Entries& entries) {
    std::vector<std::string> out;
    for (const auto& e : entries) out.push_back(e.name);
    return out;
}
template <class Entries>
std::string describe(const Entries& entries) {
    std::string text;
    const size_t n = std::size(entries);
    for (size_t i = 0; i < n; ++i) {
        if (i > 0) text += i + 1 == n ? " or " : ", ";
        text += entries[i].name;
        text += " (";
        text += entries[i].summary;
        text += ")";
    }
    return text;
}

}  // namespace name_table

// An entry of such a table.
template <class Id>
struct NamedEntry {
    Id id;
    const char* name;
    const char* summary;  // for --help
};

using EstimatorEntry = NamedEntry<Estimator>;

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

using RouletteEntry = NamedEntry<Roulette>;

inline constexpr RouletteEntry kRoulettes[] = {
    {Roulette::kLobe, "lobe",
     "the report's: one draw picks a lobe by its max RGB or the path's death, survival at "
     "most the cap; the only one of report and lt, and their default"},
    {Roulette::kThroughput, "throughput",
     "nee and mis: the lobe chosen among the lobes alone, and from vertex --roulette-depth on "
     "the path goes on with probability min(max RGB of its throughput, cap); the default of "
     "nee and mis"},
};

using SamplerEntry = NamedEntry<Sampler>;

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

using GuidingEntry = NamedEntry<Guiding>;

inline constexpr GuidingEntry kGuidings[] = {
    {Guiding::kNone, "none",
     "directions from the material's lobes alone; the default of every estimator (sdtree "
     "measured 0.58-0.77x the wavefront mis's efficiency at 30 s on small_emitter, caustic, "
     "mesh_200k and guiding/lantern, 0.87-0.98x the scalar mis's)"},
    {Guiding::kSdTree, "sdtree",
     "nee and mis: a share of the diffuse directions (learnt per cell: 0, 1/4, 1/2 or 3/4) "
     "from an SD-tree of the incident light, learnt pass by pass from filtered deposits "
     "(Mueller et al. 2017, 2019), at the first --guided-vertices Phong vertices, until "
     "its trainings have taken 2^25 records (then it keeps the last); both integrators "
     "(bands of lengths: scalar), in one process or under MPI, with checkpoints"},
};

// How nee and mis sample emitting triangles (render.triangle_sampling, --triangle-sampling):
// by area, or by the solid angle they subtend.
inline constexpr const char* kTriangleSamplingNames[] = {"area", "solid-angle"};
inline const char* triangle_sampling_name(const EstimatorSettings& e) {
    return kTriangleSamplingNames[e.triangle_solid_angle ? 1 : 0];
}
// The largest render.roulette_depth / --roulette-depth.
inline constexpr int kMaxRouletteDepth = 1024;

const char* estimator_name(Estimator e);
std::optional<Estimator> parse_estimator(std::string_view name);
const char* roulette_name(Roulette r);
std::optional<Roulette> parse_roulette(std::string_view name);
const char* sampler_name(Sampler s);
std::optional<Sampler> parse_sampler(std::string_view name);
const char* guiding_name(Guiding g);
std::optional<Guiding> parse_guiding(std::string_view name);

// Every name, in the order above (the valid values of an option).
std::vector<std::string> estimator_names();
std::vector<std::string> roulette_names();
std::vector<std::string> sampler_names();
std::vector<std::string> guiding_names();

// "name (summary), name (summary) or name (summary)", for --help.
std::string describe_estimators();
std::string describe_roulettes();
std::string describe_samplers();
std::string describe_guidings();

// Sets the estimator and gives the knobs not in e.chosen the estimator's defaults, chosen by
// measurement (docs/estimators.md, "Defaults"): for nee and mis cosine diffuse sampling, the
// throughput roulette, triangles by solid angle and the sobol sampler; for report (exactly
// the report's) and lt, uniform diffuse, the lobe roulette, area triangles and the
// independent sampler.
void use_estimator(EstimatorSettings& e, Estimator kind);

// Refuses (InputError naming `source`) a roulette the estimator does not take: the
// throughput roulette is for nee and mis only.
void check_roulette(const EstimatorSettings& e, const std::string& source);

// Refuses (InputError naming `source`) guiding for an estimator that does not take it: it
// guides the camera paths of nee and mis.
void check_guiding(const EstimatorSettings& e, const std::string& source);

}  // namespace cierzo
