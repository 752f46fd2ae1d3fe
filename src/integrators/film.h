// The film: per-pixel sums of path radiance and of its square (for the variance and the
// error estimate), and the count of finite samples; non-finite samples are counted and
// left out, so no NaN or Inf ever reaches an image.
#pragma once

#include <algorithm>
#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <vector>

#include "core/huge_pages.h"
#include "io/image.h"
#include "kernels/vec3.h"

namespace cierzo {

class StrategyTile;  // integrators/strategies.h

// One pixel's running sums, accumulated in double so long renders do not lose precision.
struct PixelSums {
    double sum[3] = {0, 0, 0};
    double sum_sq[3] = {0, 0, 0};
    uint64_t count = 0;      // finite samples
    uint64_t nonfinite = 0;  // samples that were NaN or Inf, excluded

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
    // Adds another set of sums (of later samples of the same pixel).
    void merge(const PixelSums& o) {
        for (int c = 0; c < 3; ++c) {
            sum[c] += o.sum[c];
            sum_sq[c] += o.sum_sq[c];
        }
        count += o.count;
        nonfinite += o.nonfinite;
    }

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

// One contribution of a path from the lights to a pixel of the image (anywhere in it).
struct Splat {
    uint32_t pixel;  // y * width + x
    Vec3f value;
};

// A pass's splats, added up exactly: each value is rounded once to a multiple of 2^-40 and
// summed as a 128-bit integer, so the sums are the same bits whatever order the splats come
// in (from any thread, any process, any split of the work). A value that is not finite, or
// of magnitude 2^80 or more, is counted and left out; one below 2^-41 rounds to 0.
class SplatSums {
public:
    __extension__ typedef __int128 Fixed;
    static constexpr double kScale = 0x1.0p40;  // units per 1

    // Zero sums for `pixels` pixels.
    void reset(size_t pixels) { sums_.assign(3 * pixels, Fixed(0)), nonfinite_ = 0; }
    void add(const std::vector<Splat>& splats);
    // Pixel i's sums of one channel, as a double.
    double at(size_t pixel, int channel) const {
        return double(sums_[3 * pixel + size_t(channel)]) / kScale;
    }
    uint64_t nonfinite() const { return nonfinite_; }

private:
    std::vector<Fixed, Uninitialised<Fixed>> sums_;  // (in huge pages: see core/huge_pages.h)
    uint64_t nonfinite_ = 0;
};

// Adds one pass of a pixel as one batch (estimators that splat, Film::merge_batch): the
// pass's total, its camera paths' sum plus its splats' (`splat`), and that total squared
// over the pass's paths. The one rule, for a film and for a rank's own tiles.
[[gnu::always_inline]] inline void add_batch(PixelSums& p, const PixelSums& camera,
                                             const double splat[3]) {
    const double n = double(std::max<uint64_t>(camera.count, 1));
    for (int c = 0; c < 3; ++c) {
        const double total = camera.sum[c] + splat[c];
        p.sum[c] += total;
        p.sum_sq[c] += total * total / n;
    }
    p.count += camera.count;
    p.nonfinite += camera.nonfinite;
}

// The mean relative error's sum over pixels (Film::mean_relative_error), added exactly: each
// pixel's term is rounded once to a multiple of 2^-40 and summed as a 128-bit integer, so
// the pixels split over any number of processes add up to the same bits, and a target
// error stops a render at the same pass however it is split.
struct ErrorSum {
    SplatSums::Fixed total = 0;  // the terms, in units of 2^-40
    uint64_t used = 0;           // pixels with a term (a mean not ~0 in some channel)
    uint64_t estimated = 0;      // pixels whose variance can be estimated
    // Adds pixels' terms; `batches` as Film::batches()
    void add(std::span<const PixelSums> pixels, int64_t batches);
    void merge(const ErrorSum& o) { total += o.total, used += o.used, estimated += o.estimated; }
    // The mean relative error; nothing when no pixel's variance can be estimated
    std::optional<double> value() const;
};

// The sums of one tile of pixels [x0, x1) × [y0, y1) over one pass, starting from zero: what
// a thread (or another process) renders, merged into the film with Film::merge once the
// whole pass is done. Each pixel's image is therefore the sum, in pass order, of per-pass
// sums, whichever thread or process rendered each pass: the same bits for any split of the
// work.
class FilmTile {
public:
    FilmTile() = default;
    // A tile owning its zeroed memory.
    FilmTile(int x0, int y0, int x1, int y1, int image_width)
        : x0_(x0),
          y0_(y0),
          x1_(x1),
          y1_(y1),
          image_width_(image_width),
          n_(size_t(x1 - x0) * size_t(y1 - y0)),
          own_(n_) {
        px_ = own_.data();
    }
    // The same in borrowed memory of at least its pixels (a TilePool's, given back to it
    // with release()), zeroed here.
    FilmTile(int x0, int y0, int x1, int y1, int image_width, PixelSums* memory)
        : x0_(x0),
          y0_(y0),
          x1_(x1),
          y1_(y1),
          image_width_(image_width),
          n_(size_t(x1 - x0) * size_t(y1 - y0)),
          px_(memory),
          borrowed_(true) {
        std::fill(px_, px_ + n_, PixelSums{});
    }
    FilmTile(FilmTile&& o) noexcept { *this = std::move(o); }
    FilmTile& operator=(FilmTile&& o) noexcept {
        x0_ = o.x0_, y0_ = o.y0_, x1_ = o.x1_, y1_ = o.y1_, image_width_ = o.image_width_;
        n_ = o.n_, borrowed_ = o.borrowed_;
        own_ = std::move(o.own_);
        px_ = borrowed_ ? o.px_ : own_.data();
        o.px_ = nullptr, o.n_ = 0, o.borrowed_ = false;
        splats = std::move(o.splats);
        strategies = std::move(o.strategies);
        return *this;
    }
    // (a copy owns its memory)
    FilmTile(const FilmTile& o)
        : splats(o.splats),
          strategies(o.strategies),
          x0_(o.x0_),
          y0_(o.y0_),
          x1_(o.x1_),
          y1_(o.y1_),
          image_width_(o.image_width_),
          n_(o.n_),
          own_(o.px_, o.px_ + o.n_) {
        px_ = own_.data();
    }
    FilmTile& operator=(const FilmTile& o) {
        if (this != &o) *this = FilmTile(o);
        return *this;
    }

    // The borrowed memory, handed back (null if the tile owns its memory or none); the tile
    // then has no pixels.
    PixelSums* release() {
        PixelSums* m = borrowed_ ? px_ : nullptr;
        own_.clear();
        px_ = nullptr, n_ = 0, borrowed_ = false;
        return m;
    }
    int x0() const { return x0_; }
    int y0() const { return y0_; }
    int x1() const { return x1_; }
    int y1() const { return y1_; }
    PixelSums& at(int x, int y) {
        return px_[size_t(y - y0_) * size_t(x1_ - x0_) + size_t(x - x0_)];
    }
    const PixelSums& at(int x, int y) const {
        return px_[size_t(y - y0_) * size_t(x1_ - x0_) + size_t(x - x0_)];
    }
    // The pixel whose index in the whole image is y * image width + x.
    PixelSums& at_index(size_t image_index) {
        return at(int(image_index % size_t(image_width_)), int(image_index / size_t(image_width_)));
    }
    // Counts `paths` more finite samples in every pixel, for paths whose radiance is then
    // given with PixelSums::add_counted (or not at all, if zero).
    void count_paths(uint64_t paths) {
        for (PixelSums& p : pixels()) p.count += paths;
    }
    // Every pixel, row by row within the tile.
    std::span<PixelSums> pixels() { return {px_, n_}; }
    std::span<const PixelSums> pixels() const { return {px_, n_}; }

    // What paths from the lights traced for this unit added to the image, anywhere in it
    // (in the order they were traced; the coordinator adds them up exactly, SplatSums).
    std::vector<Splat> splats;
    void splat(uint32_t image_index, const Vec3f& v) { splats.push_back({image_index, v}); }
    // bdpt's strategy images, when they are recorded (RenderOptions::strategies): this
    // unit's contributions to each
    std::shared_ptr<StrategyTile> strategies;

private:
    int x0_ = 0, y0_ = 0, x1_ = 0, y1_ = 0, image_width_ = 0;
    size_t n_ = 0;
    PixelSums* px_ = nullptr;  // own_'s, or borrowed
    bool borrowed_ = false;
    std::vector<PixelSums> own_;
};

// A film's pixels: in huge pages, and grown without being written (Film zeroes its own).
using PixelArray = std::vector<PixelSums, Uninitialised<PixelSums>>;

class Film {
public:
    Film(int width, int height);
    int width() const { return width_; }
    int height() const { return height_; }
    PixelSums& at(int x, int y) { return pixels_[size_t(y) * size_t(width_) + size_t(x)]; }
    const PixelSums& at(int x, int y) const {
        return pixels_[size_t(y) * size_t(width_) + size_t(x)];
    }
    // Adds a tile's sums of one pass to its pixels.
    void merge(const FilmTile& tile);
    // Estimators that splat (light tracing): adds one pass of `paths` paths per pixel as one
    // batch, the tile's camera-path sums plus the pass's splats at each of its pixels. A
    // pixel's sum then grows by the pass's total S, sum_sq by S²/n (n its paths), so the
    // variance comes from the spread of the passes' means (batch statistics: a splatted
    // path has no per-pixel sample of its own). end_batch() counts the pass once its tiles
    // are in.
    void merge_batch(const FilmTile& tile, const SplatSums& splats);
    void end_batch(uint64_t nonfinite_splats) { ++batches_, nonfinite_splats_ += nonfinite_splats; }
    // Passes added as batches (0: the film holds per-path sums), and the splats left out
    // as not finite
    int64_t batches() const { return batches_; }
    uint64_t nonfinite_splats() const { return nonfinite_splats_; }
    void set_batches(int64_t batches, uint64_t nonfinite_splats) {
        batches_ = batches, nonfinite_splats_ = nonfinite_splats;
    }
    // Every pixel, row by row (for checkpoints).
    PixelArray& pixels() { return pixels_; }
    const PixelArray& pixels() const { return pixels_; }

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
    // Whether pixel p's variance can be estimated (two paths, or two passes of batches), and
    // then its mean's variance in one channel (per-path or batch statistics)
    bool estimable(const PixelSums& p) const;
    double variance_of_mean(const PixelSums& p, int channel) const;

    int width_, height_;
    PixelArray pixels_;
    int64_t batches_ = 0;
    uint64_t nonfinite_splats_ = 0;
};

}  // namespace cierzo
