// The strategy images' sums (see strategies.h).
#include "integrators/strategies.h"

#include <cmath>
#include <stdexcept>

namespace cierzo {

void StrategyLayout::strategy(int i, int& s, int& t) const {
    if (i < 0 || i >= count()) throw std::logic_error("no such strategy");
    int k = 1;
    while ((k * (k + 3)) / 2 <= i) ++k;  // (the first k whose strategies reach past i)
    s = i - (k - 1) * (k + 2) / 2;
    t = k + 1 - s;
}

StrategyTile::StrategyTile(const StrategyLayout& layout, int x0, int y0, int x1, int y1)
    : layout_(layout),
      x0_(x0),
      y0_(y0),
      x1_(x1),
      y1_(y1),
      sums_(size_t(x1 - x0) * size_t(y1 - y0) * 6 * size_t(layout.count()), 0.0f) {}

StrategyFilm::StrategyFilm(int width, int height, const StrategyLayout& layout)
    : width_(width),
      height_(height),
      layout_(layout),
      sums_(size_t(width) * size_t(height) * 6 * size_t(layout.count()), 0.0) {}

size_t StrategyFilm::bytes(int width, int height, const StrategyLayout& layout) {
    const size_t values = size_t(width) * size_t(height) * 6 * size_t(layout.count());
    return values * (sizeof(double) + 2 * sizeof(float));
}

void StrategyFilm::merge(const StrategyTile& tile) {
    const size_t stride = tile.stride();
    const size_t tile_width = size_t(tile.x1_ - tile.x0_);
    for (int y = tile.y0_; y < tile.y1_; ++y)
        for (int x = tile.x0_; x < tile.x1_; ++x) {
            const float* from = tile.sums_.data() +
                                (size_t(y - tile.y0_) * tile_width + size_t(x - tile.x0_)) * stride;
            double* to = sums_.data() + (size_t(y) * size_t(width_) + size_t(x)) * stride;
            for (size_t i = 0; i < stride; ++i) to[i] += double(from[i]);
        }
    const size_t pixels = size_t(width_) * size_t(height_);
    for (const StrategySplat& s : tile.splats_) {
        if (s.pixel >= pixels || int(s.strategy) >= layout_.count())
            throw std::logic_error("strategy splat outside the image");
        double* to = sums_.data() + size_t(s.pixel) * stride + 6 * size_t(s.strategy);
        // (a splat that is not finite is left out, as the film leaves it out)
        if (StrategyTile::finite(s.weighted))
            to[0] += s.weighted.x, to[1] += s.weighted.y, to[2] += s.weighted.z;
        if (StrategyTile::finite(s.unweighted))
            to[3] += s.unweighted.x, to[4] += s.unweighted.y, to[5] += s.unweighted.z;
    }
}

Image StrategyFilm::image(int i, bool weighted, int64_t paths) const {
    if (i < 0 || i >= layout_.count()) throw std::logic_error("no such strategy");
    Image out(width_, height_);
    const size_t stride = 6 * size_t(layout_.count());
    const double scale = paths > 0 ? 1.0 / double(paths) : 0.0;
    for (size_t p = 0; p < size_t(width_) * size_t(height_); ++p) {
        const double* v = sums_.data() + p * stride + 6 * size_t(i) + (weighted ? 0 : 3);
        for (int c = 0; c < 3; ++c) {
            const float f = float(v[c] * scale);
            out.rgb[3 * p + size_t(c)] = std::isfinite(f) ? f : 0.0f;
        }
    }
    return out;
}

}  // namespace cierzo
