// Film resolution: means, variances and the relative standard error of a render.
#include "integrators/film.h"

#include <algorithm>
#include <cmath>

namespace cierzo {

Film::Film(int width, int height)
    : width_(width), height_(height), pixels_(size_t(width) * size_t(height)) {}

void Film::merge(const FilmTile& tile) {
    const std::vector<PixelSums>& src = tile.pixels();
    const size_t w = size_t(tile.x1() - tile.x0());
    for (int y = tile.y0(); y < tile.y1(); ++y)
        for (int x = tile.x0(); x < tile.x1(); ++x)
            at(x, y).merge(src[size_t(y - tile.y0()) * w + size_t(x - tile.x0())]);
}

Image Film::mean() const {
    Image img(width_, height_);
    for (size_t i = 0; i < pixels_.size(); ++i) {
        const PixelSums& p = pixels_[i];
        const double inv = p.count ? 1.0 / double(p.count) : 0.0;
        for (int c = 0; c < 3; ++c) img.rgb[i * 3 + size_t(c)] = float(p.sum[c] * inv);
    }
    return img;
}

Image Film::variance_of_mean() const {
    Image img(width_, height_);
    for (size_t i = 0; i < pixels_.size(); ++i) {
        const PixelSums& p = pixels_[i];
        if (p.count < 2) continue;
        const double n = double(p.count);
        for (int c = 0; c < 3; ++c) {
            const double m = p.sum[c] / n;
            const double var = std::max(0.0, (p.sum_sq[c] / n - m * m) * n / (n - 1.0));
            img.rgb[i * 3 + size_t(c)] = float(var / n);
        }
    }
    return img;
}

std::optional<double> Film::mean_relative_error() const {
    // Per pixel: the mean over its non-black channels of standard error / |mean|
    double total = 0.0;
    size_t used = 0, estimable = 0;
    for (const PixelSums& p : pixels_) {
        if (p.count < 2) continue;
        ++estimable;
        const double n = double(p.count);
        double rel = 0.0;
        int channels = 0;
        for (int c = 0; c < 3; ++c) {
            const double m = p.sum[c] / n;
            if (std::abs(m) < 1e-12) continue;
            const double var = std::max(0.0, (p.sum_sq[c] / n - m * m) * n / (n - 1.0));
            rel += std::sqrt(var / n) / std::abs(m);
            ++channels;
        }
        if (channels == 0) continue;
        total += rel / channels;
        ++used;
    }
    if (estimable == 0) return std::nullopt;
    return used ? total / double(used) : 0.0;
}

uint64_t Film::nonfinite_samples() const {
    uint64_t n = 0;
    for (const PixelSums& p : pixels_) n += p.nonfinite;
    return n;
}

uint64_t Film::min_samples() const {
    uint64_t n = pixels_.empty() ? 0 : pixels_[0].count + pixels_[0].nonfinite;
    for (const PixelSums& p : pixels_) n = std::min(n, p.count + p.nonfinite);
    return n;
}

}  // namespace cierzo
