// What the integrator tests render with: the scalar reference and the wavefront on every
// ISA this CPU runs, two threads; and every scene file of scenes/ that can be read here.
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

#include "integrators/registry.h"
#include "integrators/render.h"
#include "integrators/wavefront/isa.h"
#include "scene/scene_json.h"
#include "support/emulator.h"

namespace cierzo::test {

struct Variant {
    std::string integrator, isa;
};

// The scalar reference, then the wavefront on each ISA the CPU runs.
inline std::vector<Variant> variants() {
    std::vector<Variant> v = {{"scalar", "auto"}};
    for (Isa isa : compiled_isas())
        if (isa_supported(isa)) v.push_back({"wavefront", isa_name(isa)});
    return v;
}

inline RenderResult run(const Scene& scene, const Variant& v) {
    RenderOptions o;
    o.integrator = integrator_of(v.integrator);
    o.isa = v.isa;
    o.threads = 2;
    o.progress = false;
    return render(scene, o);
}

// Mean of channel c over the image and its standard error (from each pixel's variance of
// its mean); every pixel's mean must be finite.
struct ImageMean {
    double mean = 0, sigma = 0;
};
inline ImageMean image_mean(const Film& film, int c) {
    const Image m = film.mean(), v = film.variance_of_mean();
    const double n = double(m.rgb.size() / 3);
    ImageMean out;
    for (size_t i = size_t(c); i < m.rgb.size(); i += 3) {
        EXPECT_TRUE(std::isfinite(m.rgb[i]));
        out.mean += m.rgb[i];
        out.sigma += v.rgb[i];
    }
    out.mean /= n;
    out.sigma = std::sqrt(out.sigma) / n;
    return out;
}

// Per-pixel agreement of two renders: the share of pixels (over channels) whose z-test
// passes at the Šidák-corrected level for α = 0.01 over every pixel and channel.
inline double pixels_agreeing(const Film& a, const Film& b) {
    const Image ma = a.mean(), va = a.variance_of_mean(), mb = b.mean(), vb = b.variance_of_mean();
    const size_t n = ma.rgb.size();
    const double alpha = 1.0 - std::pow(1.0 - 0.01, 1.0 / double(n));
    // The two-sided critical z for alpha (by bisection on erfc)
    double lo = 0, hi = 10;
    for (int k = 0; k < 60; ++k) {
        const double mid = 0.5 * (lo + hi);
        (std::erfc(mid / std::sqrt(2.0)) > alpha ? lo : hi) = mid;
    }
    size_t pass = 0;
    for (size_t i = 0; i < n; ++i) {
        const double d = double(ma.rgb[i]) - double(mb.rgb[i]);
        const double s = std::sqrt(double(va.rgb[i]) + double(vb.rgb[i]));
        pass += std::abs(d) <= lo * s || d == 0.0;
    }
    return double(pass) / double(n);
}

// Every .json file of scenes/, sorted.
inline std::vector<std::filesystem::path> all_scenes() {
    std::vector<std::filesystem::path> out;
    for (const auto& e : std::filesystem::directory_iterator(CIERZO_SOURCE_DIR "/scenes"))
        if (e.path().extension() == ".json") out.push_back(e.path());
    std::sort(out.begin(), out.end());
    return out;
}

// The scenes of scenes/ a test of every scene renders: all of them natively; every other
// one (in name order: the first, third, ...) under the lighter settings of the qemu and
// sanitizer jobs, where such a test takes minutes. The scenes it renders get the same
// settings, seeds and tolerances either way.
inline std::vector<std::filesystem::path> scenes_to_render() {
    std::vector<std::filesystem::path> out = all_scenes();
    if (!lighter_settings()) return out;
    std::vector<std::filesystem::path> half;
    for (size_t i = 0; i < out.size(); i += 2) half.push_back(out[i]);
    return half;
}

// Every variant renders `scene` to the same bits with 1, 2 and 3 threads.
inline void expect_same_bits_for_any_threads(const Scene& scene) {
    for (const Variant& v : variants()) {
        std::vector<Image> images;
        for (int threads : {1, 2, 3}) {
            RenderOptions o;
            o.integrator = integrator_of(v.integrator);
            o.isa = v.isa;
            o.threads = threads;
            o.progress = false;
            images.push_back(render(scene, o).film.mean());
        }
        EXPECT_EQ(images[0].rgb, images[1].rgb) << v.integrator << " " << v.isa;
        EXPECT_EQ(images[0].rgb, images[2].rgb) << v.integrator << " " << v.isa;
    }
}

// The wavefront on every ISA agrees with the scalar reference on `scene`: at least 99% of
// pixels pass the per-pixel z-test, and each channel's image mean within 4σ. `what` names
// the case in failures.
inline void expect_wavefront_agrees(const Scene& scene, const std::string& what) {
    const std::vector<Variant> vs = variants();
    const RenderResult reference = run(scene, vs[0]);
    for (size_t k = 1; k < vs.size(); ++k) {
        const RenderResult w = run(scene, vs[k]);
        EXPECT_GE(pixels_agreeing(reference.film, w.film), 0.99) << what << " " << vs[k].isa;
        for (int c = 0; c < 3; ++c) {
            const ImageMean a = image_mean(reference.film, c), b = image_mean(w.film, c);
            EXPECT_NEAR(a.mean, b.mean, 4 * std::hypot(a.sigma, b.sigma))
                << what << " " << vs[k].isa << " channel " << c;
        }
    }
}

}  // namespace cierzo::test
