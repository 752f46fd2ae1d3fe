// Names and descriptions of the integrators (see registry.h).
#include "integrators/registry.h"

#include "core/error.h"

namespace cierzo {

namespace {

std::string joined(const std::vector<std::string>& names) {
    std::string text;
    for (const std::string& n : names) text += (text.empty() ? "" : ", ") + n;
    return text;
}

}  // namespace

const char* integrator_name(Integrator i) { return name_table::name_of(kIntegrators, i); }
std::optional<Integrator> parse_integrator(std::string_view n) {
    return name_table::parse(kIntegrators, n);
}

std::vector<std::string> integrator_names() { return name_table::names(kIntegrators); }

Integrator integrator_of(std::string_view name, std::string_view option) {
    if (const std::optional<Integrator> i = parse_integrator(name)) return *i;
    throw InputError(std::string(option) + ": unknown integrator '" + std::string(name) +
                     "' (valid: " + joined(integrator_names()) + ")");
}

std::string describe_integrators() { return name_table::describe(kIntegrators); }

}  // namespace cierzo
