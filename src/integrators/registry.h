// The integrators and estimators, by name: the one list that the command line, `converge`,
// `trace`, checkpoints, the Python module, --stats and --help take their names and
// descriptions from (and that a test holds the docs to). A new estimator is one entry of
// kEstimators, beside its code. The estimators, roulettes and samplers are listed where the
// scene file reads them (scene/estimator_options.h, included here); the integrators here.
#pragma once

#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "scene/estimator_options.h"

namespace cierzo {

// How paths are traced: the same estimator either way (kernels/estimator.h).
enum class Integrator : int32_t {
    kWavefront = 0,  // paths in SoA pools, one stage at a time, SIMD kernels
    kScalar = 1,     // the reference: one path at a time
};

using IntegratorEntry = NamedEntry<Integrator>;

inline constexpr IntegratorEntry kIntegrators[] = {
    {Integrator::kWavefront, "wavefront", "SoA batches, SIMD kernels; the default"},
    {Integrator::kScalar, "scalar", "the reference: one path at a time"},
};

const char* integrator_name(Integrator i);
std::optional<Integrator> parse_integrator(std::string_view name);

// Every name, in the order above (the valid values of an option).
std::vector<std::string> integrator_names();

// The integrator named by `name`, or InputError "<option>: unknown integrator 'x' (valid:
// wavefront, scalar)".
Integrator integrator_of(std::string_view name, std::string_view option = "--integrator");

// "name (summary), name (summary) or name (summary)", for --help.
std::string describe_integrators();

}  // namespace cierzo
