// Where a scene's inputs may come from, and its image memory budget (see load_options.h).
#include "scene/load_options.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <system_error>

#include <fmt/format.h>

#include "core/error.h"
#include "io/mapped_file.h"

namespace cierzo {

namespace fs = std::filesystem;

uint64_t default_image_memory() { return std::min(uint64_t(4) << 30, physical_memory_bytes() / 2); }

std::string format_bytes(uint64_t bytes) {
    static const char* const kUnits[] = {"bytes", "KiB", "MiB", "GiB", "TiB", "PiB"};
    double v = double(bytes);
    int unit = 0;
    while (v >= 1024.0 && unit < 5) v /= 1024.0, ++unit;
    if (unit == 0) return fmt::format("{} bytes", bytes);
    if (v == std::floor(v)) return fmt::format("{:.0f} {}", v, kUnits[unit]);
    return fmt::format("{:.1f} {}", v, kUnits[unit]);
}

uint64_t parse_bytes(const std::string& text, const std::string& option) {
    const auto bad = [&] {
        throw InputError(
            fmt::format("{}: '{}' is not a size: a number of bytes with an optional K, M, G or T "
                        "(powers of 1024), e.g. 8G or 1536M, at most 1024T",
                        option, text));
    };
    size_t end = 0;
    double value = 0.0;
    try {
        value = std::stod(text, &end);
    } catch (const std::exception&) {
        bad();
    }
    std::string unit = text.substr(end);
    for (char& c : unit) c = char(std::toupper(static_cast<unsigned char>(c)));
    for (const char* tail : {"IB", "B"})
        if (unit.size() > 1 && unit.size() >= std::string(tail).size() &&
            unit.compare(unit.size() - std::string(tail).size(), std::string::npos, tail) == 0) {
            unit.resize(unit.size() - std::string(tail).size());
            break;
        }
    double scale = 1.0;
    if (unit == "K")
        scale = 0x1p10;
    else if (unit == "M")
        scale = 0x1p20;
    else if (unit == "G")
        scale = 0x1p30;
    else if (unit == "T")
        scale = 0x1p40;
    else if (!unit.empty() && unit != "B")
        bad();
    const double bytes = value * scale;
    if (!std::isfinite(bytes) || bytes < 0.0 || bytes > 0x1p50 || text.empty()) bad();
    return uint64_t(bytes);
}

fs::path resolved_path(const fs::path& p) {
    std::error_code ec;
    fs::path a = fs::absolute(p, ec);
    if (ec) return p.lexically_normal();
    fs::path c = fs::weakly_canonical(a, ec);
    return ec ? a.lexically_normal() : c;
}

namespace {

bool beneath(const fs::path& path, const fs::path& root) {
    auto p = path.begin();
    for (auto r = root.begin(); r != root.end(); ++r, ++p) {
        if (r->empty()) continue;  // (a root's trailing separator)
        if (p == path.end() || *p != *r) return false;
    }
    return true;
}

}  // namespace

InputRoots::InputRoots(const fs::path& scene_file, const std::vector<fs::path>& allowed)
    : confined_(true) {
    const fs::path folder = scene_file.has_parent_path() ? scene_file.parent_path() : ".";
    roots_.push_back(resolved_path(folder));
    for (const fs::path& a : allowed) roots_.push_back(resolved_path(a));
}

bool InputRoots::allows(const fs::path& path) const {
    if (!confined_) return true;
    const fs::path p = resolved_path(path);
    return std::any_of(roots_.begin(), roots_.end(),
                       [&](const fs::path& root) { return beneath(p, root); });
}

std::string InputRoots::refusal(const fs::path& path, const std::string& named) const {
    if (allows(path)) return {};
    std::string others;
    for (size_t i = 1; i < roots_.size(); ++i) others += (i == 1 ? "" : ", ") + roots_[i].string();
    return fmt::format(
        "'{}' resolves to {}, outside the scene's folder {}{}: a scene reads files only "
        "beneath its own folder (links followed); --allow-path DIR allows another folder",
        named, resolved_path(path).string(), roots_[0].string(),
        others.empty() ? std::string() : " and the allowed " + others);
}

}  // namespace cierzo
