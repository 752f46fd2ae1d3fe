// bdpt's strategy images (`cierzo render --strategies DIR`, the Python module's
// strategies=True): in one render, every strategy (s, t) of every path length up to a limit,
// each with its MIS weight (the images of one length add up to that length's share of the
// image) and without it (each an unbiased image of the paths that strategy alone can make).
// The scalar integrator records them (integrators/scalar_bdpt.cpp): each unit's
// contributions go into its own StrategyTile, and the coordinator adds the units of a pass to
// the StrategyFilm in tile order when it adds them to the film, so the images are the same
// bits for any number of threads.
#pragma once

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "io/image.h"
#include "kernels/vec3.h"

namespace cierzo {

// The strategies recorded: path lengths k = s + t - 1 from 1 to max_length (s light
// vertices, t camera vertices, the pinhole one of them), k + 1 strategies each, numbered by
// length and then by s.
struct StrategyLayout {
    int max_length = 0;

    // Lengths recorded when no --max-length is given, and the most there may be.
    static constexpr int kDefaultLength = 5;
    static constexpr int kLengthLimit = 12;

    int count() const { return max_length * (max_length + 3) / 2; }
    // Strategy (s, t)'s number, or -1 when it is not recorded.
    int index(uint32_t s, uint32_t t) const {
        const int64_t k = int64_t(s) + int64_t(t) - 1;
        if (t < 1 || k < 1 || k > max_length) return -1;
        return int((k - 1) * (k + 2) / 2 + int64_t(s));
    }
    // The (s, t) of strategy number i.
    void strategy(int i, int& s, int& t) const;
};

// A strategy's contribution to a pixel anywhere in the image (paths from the lights that
// reach the pinhole, t = 1).
struct StrategySplat {
    uint32_t pixel;     // y * width + x
    uint32_t strategy;  // StrategyLayout::index
    Vec3f weighted, unweighted;
};

// One unit's contributions: per pixel of its tile and per strategy, the sums of its paths'
// weighted and unweighted values; its splats in the order they were made.
class StrategyTile {
public:
    StrategyTile(const StrategyLayout& layout, int x0, int y0, int x1, int y1);
    const StrategyLayout& layout() const { return layout_; }
    // (a value that is not finite is left out, as the film leaves such samples out)
    void add(int x, int y, int strategy, const Vec3f& weighted, const Vec3f& unweighted) {
        float* v = sums_.data() +
                   (size_t(y - y0_) * size_t(x1_ - x0_) + size_t(x - x0_)) * stride() +
                   6 * size_t(strategy);
        if (finite(weighted)) v[0] += weighted.x, v[1] += weighted.y, v[2] += weighted.z;
        if (finite(unweighted)) v[3] += unweighted.x, v[4] += unweighted.y, v[5] += unweighted.z;
    }
    static bool finite(const Vec3f& v) {
        return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z);
    }
    void splat(uint32_t pixel, int strategy, const Vec3f& weighted, const Vec3f& unweighted) {
        splats_.push_back({pixel, uint32_t(strategy), weighted, unweighted});
    }

private:
    friend class StrategyFilm;
    size_t stride() const { return 6 * size_t(layout_.count()); }
    StrategyLayout layout_;
    int x0_, y0_, x1_, y1_;
    std::vector<float> sums_;
    std::vector<StrategySplat> splats_;
};

// The whole image's sums per strategy, in double.
class StrategyFilm {
public:
    StrategyFilm(int width, int height, const StrategyLayout& layout);
    const StrategyLayout& layout() const { return layout_; }
    int width() const { return width_; }
    int height() const { return height_; }
    // The memory a render of width × height with `layout` takes for its strategies: this
    // film and the tiles of the two passes in flight.
    static size_t bytes(int width, int height, const StrategyLayout& layout);
    // Adds one unit's contributions (the coordinator, in tile order).
    void merge(const StrategyTile& tile);
    // Strategy i's image, weighted or not, as the mean over `paths` paths per pixel.
    Image image(int i, bool weighted, int64_t paths) const;

private:
    int width_, height_;
    StrategyLayout layout_;
    std::vector<double> sums_;  // per pixel, per strategy: weighted rgb, unweighted rgb
};

}  // namespace cierzo
