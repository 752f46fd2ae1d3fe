// Names and descriptions of the integrators and estimators (see registry.h).
#include "integrators/registry.h"

#include "core/error.h"

namespace cierzo {

namespace {

template <class Entries>
std::vector<std::string> names_of(const Entries& entries) {
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

std::string joined(const std::vector<std::string>& names) {
    std::string text;
    for (const std::string& n : names) text += (text.empty() ? "" : ", ") + n;
    return text;
}

// The name of entry `id`, and the entry named `name`.
template <class Entries, class Id>
const char* name_in(const Entries& entries, Id id) {
    for (const auto& e : entries)
        if (e.id == id) return e.name;
    return "unknown";
}
template <class Entries>
auto parse_in(const Entries& entries, std::string_view name)
    -> std::optional<decltype(entries[0].id)> {
    for (const auto& e : entries)
        if (name == e.name) return e.id;
    return std::nullopt;
}

}  // namespace

const char* integrator_name(Integrator i) { return name_in(kIntegrators, i); }
const char* estimator_name(Estimator e) { return name_in(kEstimators, e); }
const char* roulette_name(Roulette r) { return name_in(kRoulettes, r); }
std::optional<Integrator> parse_integrator(std::string_view n) { return parse_in(kIntegrators, n); }
std::optional<Estimator> parse_estimator(std::string_view n) { return parse_in(kEstimators, n); }
std::optional<Roulette> parse_roulette(std::string_view n) { return parse_in(kRoulettes, n); }
const char* sampler_name(Sampler s) { return name_in(kSamplers, s); }
std::optional<Sampler> parse_sampler(std::string_view n) { return parse_in(kSamplers, n); }

void use_estimator(EstimatorSettings& e, Estimator kind) {
    e.kind = kind;
    const bool camera_sampling = kind == Estimator::kNee || kind == Estimator::kMis;
    const bool both_ends = bidirectional(kind);
    if (!(e.chosen & kChoseDiffuse)) e.cosine_diffuse = camera_sampling || both_ends;
    if (!(e.chosen & kChoseRoulette))
        e.roulette = camera_sampling ? Roulette::kThroughput : Roulette::kLobe;
    if (!(e.chosen & kChoseTriangles)) e.triangle_solid_angle = camera_sampling || both_ends;
    if (!(e.chosen & kChoseSampler))
        e.sampler = camera_sampling || both_ends ? Sampler::kSobol : Sampler::kIndependent;
}

void check_roulette(const EstimatorSettings& e, const std::string& source) {
    if (e.roulette == Roulette::kThroughput && e.kind != Estimator::kNee &&
        e.kind != Estimator::kMis)
        throw InputError(source + ": the throughput roulette is for the nee and mis estimators; " +
                         estimator_name(e.kind) +
                         (e.kind == Estimator::kReport
                              ? " keeps the report's roulette, exactly"
                              : " keeps the lobe roulette (its paths start at the lights, "
                                "with a throughput in units of power)") +
                         " (use --roulette lobe)");
}

std::vector<std::string> integrator_names() { return names_of(kIntegrators); }
std::vector<std::string> estimator_names() { return names_of(kEstimators); }
std::vector<std::string> roulette_names() { return names_of(kRoulettes); }
std::vector<std::string> sampler_names() { return names_of(kSamplers); }

Integrator integrator_of(std::string_view name, std::string_view option) {
    if (const std::optional<Integrator> i = parse_integrator(name)) return *i;
    throw InputError(std::string(option) + ": unknown integrator '" + std::string(name) +
                     "' (valid: " + joined(integrator_names()) + ")");
}

std::string describe_integrators() { return describe(kIntegrators); }
std::string describe_estimators() { return describe(kEstimators); }
std::string describe_roulettes() { return describe(kRoulettes); }
std::string describe_samplers() { return describe(kSamplers); }

}  // namespace cierzo
