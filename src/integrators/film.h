// The film: per-pixel sums of path radiance and of its square (for the variance and the
// error estimate), and the count of finite samples; non-finite samples are counted and
// left out, so no NaN or Inf ever reaches an image.
#pragma once

#include <cstdint>
#include <optional>
#include <vector>

#include "io/image.h"
#include "kernels/vec3.h"

namespace cierzo {

// One pixel's running sums, accumulated in double so long renders do not lose precision.
struct PixelSums {
    double sum[3] = {0, 0, 0};
    double sum_sq[3] = {0, 0, 0};
    uint64_t count = 0;       // finite samples
    uint64_t nonfinite = 0;   // samples that were NaN or Inf, excluded

    void add(const Vec3f& L) {
        if (accumulate(L)) ++count;
    }

    // The same for a path already counted as a finite sample (by count_paths): the
    // wavefront counts every path of a tile up front and hands over only those whose
    // radiance is not zero, since adding +0 to the sums changes nothing.
    void add_counted(const Vec3f& L) {
        if (!accumulate(L)) --count;
    }

    // Adds a finite L to the sums and returns true; counts any other as non-finite.
    bool accumulate(const Vec3f& L) {
        if (!std::isfinite(L.x) || !std::isfinite(L.y) || !std::isfinite(L.z)) {
            ++nonfinite;
            return false;
        }
        const double v[3] = {L.x, L.y, L.z};
        for (int c = 0; c < 3; ++c) {
            sum[c] += v[c];
            sum_sq[c] += v[c] * v[c];
        }
        return true;
    }
};

class Film {
public:
    Film(int width, int height);
    int width() const { return width_; }
    int height() const { return height_; }
    PixelSums& at(int x, int y) { return pixels_[size_t(y) * size_t(width_) + size_t(x)]; }
    const PixelSums& at(int x, int y) const {
        return pixels_[size_t(y) * size_t(width_) + size_t(x)];
    }
    // The pixel at index y * width + x.
    PixelSums& at_index(size_t i) { return pixels_[i]; }
    // Counts `paths` more finite samples in every pixel of [x0, x1) × [y0, y1), for paths
    // whose radiance is then given with PixelSums::add_counted (or not at all, if zero).
    void count_paths(int x0, int y0, int x1, int y1, uint64_t paths);

    // The mean radiance per pixel.
    Image mean() const;
    // The variance of each pixel's mean (sample variance / count), per channel.
    Image variance_of_mean() const;
    // Mean over pixels of (standard error / |mean|), skipping pixels whose mean is ~0;
    // nothing where no pixel has two paths yet (one path gives no variance).
    std::optional<double> mean_relative_error() const;
    uint64_t nonfinite_samples() const;
    uint64_t min_samples() const;

private:
    int width_, height_;
    std::vector<PixelSums> pixels_;
};

}  // namespace cierzo
