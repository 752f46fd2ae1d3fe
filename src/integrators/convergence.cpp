// Error metrics and convergence sweeps (see convergence.h).
#include "integrators/convergence.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <fmt/format.h>

#include "core/error.h"
#include "integrators/registry.h"
#include "integrators/render.h"

namespace cierzo {

ImageError image_error(const Image& image, const Image& reference,
                       const Image* reference_variance) {
    if (image.width != reference.width || image.height != reference.height)
        throw InputError(fmt::format("the reference is {}x{} but the image is {}x{}",
                                     reference.width, reference.height, image.width, image.height));
    if (reference_variance && (reference_variance->width != reference.width ||
                               reference_variance->height != reference.height))
        throw InputError("the reference's variance does not match its size");
    ImageError e;
    const size_t n = image.rgb.size();
    if (n == 0) return e;
    for (size_t i = 0; i < n; ++i) {
        const double r = reference.rgb[i];
        const double d = double(image.rgb[i]) - r;
        const double scale = 1.0 / (r * r + kRelMseEpsilon);
        e.mse += d * d;
        e.rel_mse += d * d * scale;
        if (reference_variance) {
            const double v = reference_variance->rgb[i];
            e.reference_mse += v;
            e.reference_rel_mse += v * scale;
        }
    }
    const double inv = 1.0 / double(n);
    e.mse *= inv, e.rel_mse *= inv, e.reference_mse *= inv, e.reference_rel_mse *= inv;
    return e;
}

namespace {

// The estimator settings with a config's knobs applied.
EstimatorSettings with_config(EstimatorSettings settings, const ConvergeConfig& config) {
    if (config.survival_cap >= 0.0f) settings.survival_cap = config.survival_cap;
    if (config.cosine_diffuse >= 0)
        settings.cosine_diffuse = config.cosine_diffuse, settings.chosen |= kChoseDiffuse;
    if (config.roulette >= 0)
        settings.roulette = Roulette(config.roulette), settings.chosen |= kChoseRoulette;
    if (config.triangle_solid_angle >= 0)
        settings.triangle_solid_angle = config.triangle_solid_angle,
        settings.chosen |= kChoseTriangles;
    if (config.roulette_depth >= 0) settings.roulette_depth = config.roulette_depth;
    if (config.sampler >= 0)
        settings.sampler = Sampler(config.sampler), settings.chosen |= kChoseSampler;
    if (config.merge_radius >= 0.0f) settings.merge_radius = config.merge_radius;
    if (config.merge_alpha >= 0.0f) settings.merge_alpha = config.merge_alpha;
    if (config.light_connections >= 0) settings.light_connections = config.light_connections;
    if (config.guiding >= 0) settings.guiding = Guiding(config.guiding);
    if (config.guided_vertices >= 0) settings.guided_vertices = config.guided_vertices;
    use_estimator(settings, config.estimator >= 0 ? Estimator(config.estimator) : settings.kind);
    return settings;
}

}  // namespace

std::vector<ConvergePoint> run_converge(const Scene& scene, const Image& reference,
                                        const Image* reference_variance, const ConvergeSweep& sweep,
                                        const std::function<void(const ConvergePoint&)>& on_point) {
    std::vector<ConvergePoint> points;
    for (const ConvergeConfig& config : sweep.configs) {
        Scene s = scene;
        s.settings.estimator = with_config(scene.settings.estimator, config);
        RenderOptions options;
        options.threads = sweep.threads;
        options.integrator = integrator_of(config.integrator);
        options.isa = config.isa;
        options.pool_size = config.pool_size;
        options.progress = false;
        options.cancel = sweep.cancel;
        for (int64_t spp : sweep.spp) {
            ConvergePoint point;
            point.config = config;
            point.estimator = s.settings.estimator;
            point.merge_radius = s.merge_radius();
            point.spp = spp;
            point.repeats = std::max(1, sweep.repeats);
            std::vector<double> seconds;
            for (int k = 0; k < point.repeats; ++k) {
                // Seeds other than the scene's own, which a rendered reference uses
                s.settings.spp = spp;
                s.settings.seed = scene.settings.seed + 1 + uint32_t(k);
                const RenderResult r = render(s, options);
                // (an interrupted render is not a point of the sweep)
                if (r.stats.stopped_by == "interrupted") return points;
                const ImageError e = image_error(r.film.mean(), reference, reference_variance);
                point.error.mse += e.mse / point.repeats;
                point.error.rel_mse += e.rel_mse / point.repeats;
                point.error.reference_mse = e.reference_mse;
                point.error.reference_rel_mse = e.reference_rel_mse;
                point.estimated_relative_error +=
                    r.stats.mean_relative_error.value_or(std::nan("")) / point.repeats;
                seconds.push_back(r.stats.seconds);
                if (k == 0) {
                    point.stats = r.stats;
                    point.rays = r.stats.rays.total();
                }
            }
            std::sort(seconds.begin(), seconds.end());
            const size_t m = seconds.size();
            point.seconds = m % 2 ? seconds[m / 2] : 0.5 * (seconds[m / 2 - 1] + seconds[m / 2]);
            if (on_point) on_point(point);
            points.push_back(point);
        }
    }
    return points;
}

double log_log_slope(const std::vector<double>& x, const std::vector<double>& y) {
    double sx = 0, sy = 0, sxx = 0, sxy = 0;
    int n = 0;
    for (size_t i = 0; i < std::min(x.size(), y.size()); ++i) {
        if (!(x[i] > 0) || !(y[i] > 0)) continue;
        const double lx = std::log(x[i]), ly = std::log(y[i]);
        sx += lx, sy += ly, sxx += lx * lx, sxy += lx * ly;
        ++n;
    }
    const double det = n * sxx - sx * sx;
    if (n < 2 || det == 0) return std::numeric_limits<double>::quiet_NaN();
    return (n * sxy - sx * sy) / det;
}

}  // namespace cierzo
