// The units of work and the passes of a render, and the refusal of a light-vertex store past
// its limit (render_types.h).
#include "integrators/render_types.h"

#include <algorithm>

#include <fmt/format.h>

#include "core/error.h"

namespace cierzo {

void refuse_light_store(const Scene& scene, size_t limit, size_t vertices) {
    const std::string bound = limit >= (size_t(1) << 20)
                                  ? fmt::format("{:.0f} MiB", double(limit) / double(1 << 20))
                                  : fmt::format("{} bytes", limit);
    throw InputError(fmt::format(
        "{}: {}: a unit's light subpaths need more than {} of light-vertex store (over {} "
        "vertices): paths this long come from a survival cap near 1 (survival_cap {}); lower "
        "it (--survival-cap), or use an estimator without light subpaths",
        scene.source.string(), estimator_name(scene.settings.estimator.kind), bound, vertices,
        scene.settings.estimator.survival_cap));
}

std::vector<int64_t> pass_bounds(int64_t start, int64_t spp, int64_t pixels) {
    // Boundaries 1, 2, 4, 8, 16 (those of passes of kMinPassPaths paths or more) and then
    // every 16: so a finished render of a multiple of 16 paths per pixel (in a large image,
    // of a power of two too) ends on a boundary, and can be continued to more paths with the
    // very bits of an uninterrupted render of more
    std::vector<int64_t> bounds{start};
    int64_t kept = 0;  // the last boundary of the schedule from zero
    for (int64_t b = 1; b < spp + 16; b = b < 16 ? 2 * b : b + 16) {
        if (b < 16 && b < spp && (b - kept) * std::max<int64_t>(pixels, 1) < kMinPassPaths)
            continue;
        kept = b;
        const int64_t end = std::min(b, spp);
        if (end > bounds.back()) bounds.push_back(end);
        if (end == spp) break;
    }
    return bounds;
}

int64_t pass_pixels(const Scene& scene) {
    if (splats(scene.settings.estimator.kind)) return kMinPassPaths;
    return int64_t(scene.settings.width) * int64_t(scene.settings.height);
}

std::vector<Tile> image_tiles(int width, int height) {
    std::vector<Tile> tiles;
    for (int y = 0; y < height; y += kTileSize)
        for (int x = 0; x < width; x += kTileSize)
            tiles.push_back(
                {x, y, std::min(x + kTileSize, width), std::min(y + kTileSize, height)});
    return tiles;
}

int light_batch_rows(int width) {
    return std::max(1, (kLightBatchPixels + width / 2) / std::max(width, 1));
}

std::vector<Tile> work_units(int width, int height, bool light) {
    std::vector<Tile> units;
    if (light) {
        const int rows = light_batch_rows(width);
        for (int y = 0; y < height; y += rows) {
            Tile batch{0, y, width, std::min(y + rows, height)};
            batch.light = true;
            units.push_back(batch);
        }
    }
    const std::vector<Tile> tiles = image_tiles(width, height);
    units.insert(units.end(), tiles.begin(), tiles.end());
    return units;
}

}  // namespace cierzo
