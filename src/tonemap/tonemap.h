// Tone mapping: the operators that turn a linear HDR render into display values in [0, 1]
// (clamp, equalize, equalize-clamp, gamma, clamp-gamma, reinhard), with exposure and the
// handling of negative and non-finite samples.
#pragma once

#include "io/image.h"

#include <cstddef>
#include <optional>
#include <string>
#include <vector>

namespace cierzo {

struct TonemapOptions {
    std::string op = "gamma";    // one of tonemap_operator_names()
    float exposure = 0.0f;       // input is multiplied by 2^exposure first; |exposure| <= 64
    float gamma = 2.2f;          // gamma and clamp-gamma: output = x^(1/gamma); > 0
    std::optional<float> clamp;  // V for clamp, equalize-clamp and clamp-gamma (default 1); > 0
};

// What the input contained that the operators cannot use; those values were replaced by 0.
struct TonemapStats {
    size_t non_finite = 0;  // NaN or infinite components
    size_t negative = 0;    // finite components below zero
};

struct TonemapOperatorInfo {
    std::string name;
    std::string formula;  // one line for --help and the documentation
};

// The operators in a fixed order, each with its formula.
const std::vector<TonemapOperatorInfo>& tonemap_operators();
std::vector<std::string> tonemap_operator_names();

// Maps every colour component independently: x = max(v, 0) * 2^exposure (non-finite v
// counts as 0), then the operator (see tonemap_operators()); the result lies in [0, 1] and
// is the final display value (no further sRGB encoding). Throws InputError for an unknown
// operator (listing the valid ones), for an invalid exposure, gamma or clamp value, and for
// a clamp value given to an operator that does not use it.
Image tonemap(const Image& image, const TonemapOptions& options, TonemapStats* stats = nullptr);

}  // namespace cierzo
