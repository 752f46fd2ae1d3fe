// Tone-mapping operators (clamp, equalize, equalize-clamp, gamma, clamp-gamma, reinhard)
// applied per colour component after exposure, in double precision, into [0, 1].
#include "tonemap/tonemap.h"

#include "core/error.h"

#include <algorithm>
#include <charconv>
#include <cmath>

namespace cierzo {

namespace {

constexpr float kMaxExposure = 64.0f;

enum class Operator { Clamp, Equalize, EqualizeClamp, Gamma, ClampGamma, Reinhard };

struct OperatorEntry {
    Operator op;
    TonemapOperatorInfo info;
    bool uses_clamp;
};

const std::vector<OperatorEntry>& operator_table() {
    static const std::vector<OperatorEntry> table = {
        {Operator::Clamp, {"clamp", "min(x, V) / V              values above V saturate"}, true},
        {Operator::Equalize,
         {"equalize", "x / M                      linear normalisation by the maximum"},
         false},
        {Operator::EqualizeClamp,
         {"equalize-clamp", "min(x, V) / V              linear below V, saturated above"},
         true},
        {Operator::Gamma,
         {"gamma", "(x / M)^(1/G)              equalize, then gamma curve"},
         false},
        {Operator::ClampGamma,
         {"clamp-gamma", "(min(x, V) / V)^(1/G)      clamp at V, then gamma curve"},
         true},
        {Operator::Reinhard,
         {"reinhard", "x / (1 + x)                per channel, compresses all of [0, inf)"},
         false},
    };
    return table;
}

std::string number_text(float v) {
    char buffer[64];
    const auto result = std::to_chars(buffer, buffer + sizeof(buffer), v);
    return std::string(buffer, result.ptr);
}

std::string joined_names() {
    std::string text;
    for (const OperatorEntry& entry : operator_table()) {
        text += (text.empty() ? "" : ", ") + entry.info.name;
    }
    return text;
}

const OperatorEntry& find_operator(const std::string& name) {
    for (const OperatorEntry& entry : operator_table()) {
        if (entry.info.name == name) {
            return entry;
        }
    }
    throw InputError("unknown tone-mapping operator '" + name + "' (valid: " + joined_names() +
                     ")");
}

void validate(const TonemapOptions& options, const OperatorEntry& entry) {
    if (!std::isfinite(options.exposure) || std::fabs(options.exposure) > kMaxExposure) {
        throw InputError("--exposure must be between -64 and 64 (got " +
                         number_text(options.exposure) + ")");
    }
    if (!std::isfinite(options.gamma) || !(options.gamma > 0.0f)) {
        throw InputError("--gamma must be a positive number (got " + number_text(options.gamma) +
                         ")");
    }
    if (options.clamp) {
        if (!std::isfinite(*options.clamp) || !(*options.clamp > 0.0f)) {
            throw InputError("--clamp must be a positive number (got " +
                             number_text(*options.clamp) + ")");
        }
        if (!entry.uses_clamp) {
            throw InputError("--clamp has no effect with operator '" + entry.info.name +
                             "' (only clamp, equalize-clamp and clamp-gamma use it)");
        }
    }
}

}  // namespace

const std::vector<TonemapOperatorInfo>& tonemap_operators() {
    static const std::vector<TonemapOperatorInfo> infos = [] {
        std::vector<TonemapOperatorInfo> list;
        for (const OperatorEntry& entry : operator_table()) {
            list.push_back(entry.info);
        }
        return list;
    }();
    return infos;
}

std::vector<std::string> tonemap_operator_names() {
    std::vector<std::string> names;
    for (const OperatorEntry& entry : operator_table()) {
        names.push_back(entry.info.name);
    }
    return names;
}

Image tonemap(const Image& image, const TonemapOptions& options, TonemapStats* stats) {
    const OperatorEntry& entry = find_operator(options.op);
    validate(options, entry);
    if (image.width < 0 || image.height < 0 ||
        image.rgb.size() != size_t(image.width) * size_t(image.height) * 3) {
        throw InputError("tone mapping: image buffer does not match its size " +
                         std::to_string(image.width) + "x" + std::to_string(image.height));
    }

    const double scale = std::exp2(double(options.exposure));
    TonemapStats counts;
    const auto input = [&](float v) {
        if (!std::isfinite(v)) {
            return 0.0;
        }
        return v > 0.0f ? double(v) * scale : 0.0;
    };
    double max_value = 0.0;
    for (float v : image.rgb) {
        if (!std::isfinite(v)) {
            ++counts.non_finite;
        } else if (v < 0.0f) {
            ++counts.negative;
        }
        max_value = std::max(max_value, input(v));
    }

    const double limit = options.clamp.value_or(1.0f);
    const double inv_gamma = 1.0 / double(options.gamma);
    const auto map = [&](double x) {
        switch (entry.op) {
            case Operator::Clamp:
            case Operator::EqualizeClamp: return std::min(x, limit) / limit;
            case Operator::Equalize: return max_value > 0.0 ? x / max_value : 0.0;
            case Operator::Gamma: return max_value > 0.0 ? std::pow(x / max_value, inv_gamma) : 0.0;
            case Operator::ClampGamma: return std::pow(std::min(x, limit) / limit, inv_gamma);
            case Operator::Reinhard: return x / (1.0 + x);
        }
        return 0.0;
    };

    Image out(image.width, image.height);
    std::transform(image.rgb.begin(), image.rgb.end(), out.rgb.begin(),
                   [&](float v) { return float(std::clamp(map(input(v)), 0.0, 1.0)); });
    if (stats != nullptr) {
        *stats = counts;
    }
    return out;
}

}  // namespace cierzo
