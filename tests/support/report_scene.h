// Scenes for the tests written for the report's estimator. A scene that names no estimator
// renders with mis (kDefaultEstimator); these tests measure the report's estimator, or switch
// estimators over the report's knobs, as they were written to.
#pragma once

#include <filesystem>
#include <regex>
#include <string>

#include "integrators/registry.h"
#include "scene/scene_json.h"

namespace cierzo::test {

// `json` naming the report's estimator where it names none: its "render" object gains the
// key, or the scene gains a "render" object with the key alone.
inline std::string naming_report(const std::string& json) {
    if (json.find("\"estimator\"") != std::string::npos) return json;
    const std::regex render(R"re("render"\s*:\s*\{)re");
    if (std::regex_search(json, render))
        return std::regex_replace(json, render, R"("render": {"estimator": "report", )",
                                  std::regex_constants::format_first_only);
    const size_t open = json.find('{');
    return json.substr(0, open + 1) + R"("render": {"estimator": "report"}, )" +
           json.substr(open + 1);
}

// parse_scene of `json` with the report's estimator where it names none.
inline Scene parse_report_scene(const std::string& json, const std::filesystem::path& path) {
    return parse_scene(naming_report(json), path);
}

// The scene's estimator set to `e` over the knobs (diffuse sampling, roulette, triangle
// sampling, sampler) the report's estimator takes where the scene chose none, rather than
// the defaults of `e`.
inline void set_estimator(Scene& scene, Estimator e) {
    use_estimator(scene.settings.estimator, Estimator::kReport);
    scene.settings.estimator.kind = e;
}

}  // namespace cierzo::test
