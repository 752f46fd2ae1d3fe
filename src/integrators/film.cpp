// Film resolution: means, variances and the relative standard error of a render.
#include "integrators/film.h"

#include <algorithm>
#include <cmath>
#if defined(__SSE2__)
#include <emmintrin.h>
#endif

namespace cierzo {

Film::Film(int width, int height) : width_(width), height_(height) {
    // (in huge pages: a 960x540 film is 33 MB, 8,000 small pages faulted in)
    pixels_.resize(size_t(std::max(width, 0)) * size_t(std::max(height, 0)));
    std::fill(pixels_.begin(), pixels_.end(), PixelSums{});
}

void Film::merge(const FilmTile& tile) {
    const std::span<const PixelSums> src = tile.pixels();
    const size_t w = size_t(tile.x1() - tile.x0());
    for (int y = tile.y0(); y < tile.y1(); ++y)
        for (int x = tile.x0(); x < tile.x1(); ++x)
            at(x, y).merge(src[size_t(y - tile.y0()) * w + size_t(x - tile.x0())]);
}

namespace {

// x rounded to the nearest integer, ties to even (as std::nearbyint in the default rounding
// mode), as a 128-bit integer, for |x| < 2^81. Below 2^62 in one instruction: on the
// baseline x86-64 std::nearbyint and the conversion to 128 bits are two library calls, and
// a bdpt render makes one per channel of every splat (measured: 5% of `caustic.json`).
SplatSums::Fixed round_to_fixed(double x) {
    if (std::abs(x) < 0x1.0p62) {
#if defined(__SSE2__)
        return SplatSums::Fixed(_mm_cvtsd_si64(_mm_set_sd(x)));  // (MXCSR: to nearest even)
#else
        return SplatSums::Fixed(std::llrint(x));
#endif
    }
    return SplatSums::Fixed(std::nearbyint(x));
}

}  // namespace

void SplatSums::add(const std::vector<Splat>& splats) {
    // Splats land anywhere in the image, whose sums (48 bytes a pixel) outgrow the caches
    // from about 200x200 on: each pixel's sums are asked for kAhead splats before they are
    // added, so the misses overlap (measured: this loop was 6.6% of a 500x500 bdpt render).
    constexpr size_t kAhead = 8;
    const auto prefetch = [&](size_t k) {
        if (k >= splats.size()) return;
        const char* at = reinterpret_cast<const char*>(sums_.data() + 3 * size_t(splats[k].pixel));
        __builtin_prefetch(at, 1);
        __builtin_prefetch(at + 3 * sizeof(Fixed) - 1, 1);
    };
    for (size_t k = 0; k < kAhead; ++k) prefetch(k);
    for (size_t k = 0; k < splats.size(); ++k) {
        prefetch(k + kAhead);
        const Splat& s = splats[k];
        const double v[3] = {s.value.x, s.value.y, s.value.z};
        bool ok = true;
        for (double c : v) ok = ok && std::isfinite(c) && std::abs(c) < 0x1.0p80;
        if (!ok) {
            ++nonfinite_;
            continue;
        }
        for (int c = 0; c < 3; ++c)
            sums_[3 * size_t(s.pixel) + size_t(c)] += round_to_fixed(v[c] * kScale);
    }
}

void Film::merge_batch(const FilmTile& tile, const SplatSums& splats) {
    for (int y = tile.y0(); y < tile.y1(); ++y) {
        for (int x = tile.x0(); x < tile.x1(); ++x) {
            const size_t i = size_t(y) * size_t(width_) + size_t(x);
            const double splat[3] = {splats.at(i, 0), splats.at(i, 1), splats.at(i, 2)};
            add_batch(at(x, y), tile.at(x, y), splat);
        }
    }
}

namespace {

[[gnu::always_inline]] inline bool estimable(const PixelSums& p, int64_t batches) {
    return batches > 0 ? batches >= 2 && p.count > 0 : p.count >= 2;
}

[[gnu::always_inline]] inline double variance_of_mean(const PixelSums& p, int c, int64_t batches) {
    const double n = double(p.count);
    if (batches > 0) {
        // Σ n_k (m_k - m)² over the passes k, over (passes - 1), per path
        const double spread = std::max(0.0, p.sum_sq[c] - p.sum[c] * p.sum[c] / n);
        return spread / (double(batches - 1) * n);
    }
    const double m = p.sum[c] / n;
    const double var = std::max(0.0, (p.sum_sq[c] / n - m * m) * n / (n - 1.0));
    return var / n;
}

}  // namespace

bool Film::estimable(const PixelSums& p) const { return cierzo::estimable(p, batches_); }

double Film::variance_of_mean(const PixelSums& p, int c) const {
    return cierzo::variance_of_mean(p, c, batches_);
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
        if (!estimable(p)) continue;
        for (int c = 0; c < 3; ++c) img.rgb[i * 3 + size_t(c)] = float(variance_of_mean(p, c));
    }
    return img;
}

void ErrorSum::add(std::span<const PixelSums> pixels, int64_t batches) {
    // Per pixel: the mean over its non-black channels of standard error / |mean|, rounded
    // to a multiple of 2^-40 (a term of 2^70 or more, or not finite, counts as 2^70)
    constexpr double kScale = 0x1.0p40, kMost = 0x1.0p70;
    for (const PixelSums& p : pixels) {
        if (!cierzo::estimable(p, batches)) continue;
        ++estimated;
        const double n = double(p.count);
        double rel = 0.0;
        int channels = 0;
        for (int c = 0; c < 3; ++c) {
            const double m = p.sum[c] / n;
            if (std::abs(m) < 1e-12) continue;
            rel += std::sqrt(cierzo::variance_of_mean(p, c, batches)) / std::abs(m);
            ++channels;
        }
        if (channels == 0) continue;
        double term = rel / channels;
        if (!(term < kMost)) term = kMost;  // (NaN too)
        total += round_to_fixed(term * kScale);
        ++used;
    }
}

std::optional<double> ErrorSum::value() const {
    if (estimated == 0) return std::nullopt;
    return used ? double(total) / 0x1.0p40 / double(used) : 0.0;
}

std::optional<double> Film::mean_relative_error() const {
    ErrorSum e;
    e.add({pixels_.data(), pixels_.size()}, batches_);
    return e.value();
}

uint64_t Film::nonfinite_samples() const {
    uint64_t n = 0;
    for (const PixelSums& p : pixels_) n += p.nonfinite;
    return n + nonfinite_splats_;
}

uint64_t Film::min_samples() const {
    uint64_t n = pixels_.empty() ? 0 : pixels_[0].count + pixels_[0].nonfinite;
    for (const PixelSums& p : pixels_) n = std::min(n, p.count + p.nonfinite);
    return n;
}

}  // namespace cierzo
