// The estimators, roulettes and samplers by name, and the defaults an estimator gives the
// settings not chosen (see estimator_options.h).
#include "scene/estimator_options.h"

#include "core/error.h"

namespace cierzo {

const char* estimator_name(Estimator e) { return name_table::name_of(kEstimators, e); }
const char* roulette_name(Roulette r) { return name_table::name_of(kRoulettes, r); }
const char* sampler_name(Sampler s) { return name_table::name_of(kSamplers, s); }
std::optional<Estimator> parse_estimator(std::string_view n) {
    return name_table::parse(kEstimators, n);
}
std::optional<Roulette> parse_roulette(std::string_view n) {
    return name_table::parse(kRoulettes, n);
}
std::optional<Sampler> parse_sampler(std::string_view n) { return name_table::parse(kSamplers, n); }
const char* guiding_name(Guiding g) { return name_table::name_of(kGuidings, g); }
std::optional<Guiding> parse_guiding(std::string_view n) { return name_table::parse(kGuidings, n); }

void use_estimator(EstimatorSettings& e, Estimator kind) {
    e.kind = kind;
    const bool camera_sampling = traits(kind).samples_emitters;
    const bool both_ends = bidirectional(kind);
    if (!(e.chosen & kChoseDiffuse)) e.cosine_diffuse = camera_sampling || both_ends;
    if (!(e.chosen & kChoseRoulette))
        e.roulette = camera_sampling ? Roulette::kThroughput : Roulette::kLobe;
    if (!(e.chosen & kChoseTriangles)) e.triangle_solid_angle = camera_sampling || both_ends;
    if (!(e.chosen & kChoseSampler))
        e.sampler = camera_sampling || both_ends ? Sampler::kSobol : Sampler::kIndependent;
}

void check_roulette(const EstimatorSettings& e, const std::string& source) {
    if (e.roulette == Roulette::kThroughput && !traits(e.kind).samples_emitters)
        throw InputError(source + ": the throughput roulette is for the nee and mis estimators; " +
                         estimator_name(e.kind) +
                         (e.kind == Estimator::kReport
                              ? " keeps the report's roulette, exactly"
                              : " keeps the lobe roulette (its paths start at the lights, "
                                "with a throughput in units of power)") +
                         " (use --roulette lobe)");
}

void check_guiding(const EstimatorSettings& e, const std::string& source) {
    if (e.guiding != Guiding::kNone && !traits(e.kind).samples_emitters)
        throw InputError(source + ": guiding (" + guiding_name(e.guiding) +
                         ") is for the nee and mis estimators, whose camera paths it guides; " +
                         estimator_name(e.kind) + " takes none (use --guiding none)");
}

std::vector<std::string> estimator_names() { return name_table::names(kEstimators); }
std::vector<std::string> roulette_names() { return name_table::names(kRoulettes); }
std::vector<std::string> sampler_names() { return name_table::names(kSamplers); }
std::vector<std::string> guiding_names() { return name_table::names(kGuidings); }

std::string describe_estimators() { return name_table::describe(kEstimators); }
std::string describe_roulettes() { return name_table::describe(kRoulettes); }
std::string describe_samplers() { return name_table::describe(kSamplers); }
std::string describe_guidings() { return name_table::describe(kGuidings); }

}  // namespace cierzo
