// Decoding the image textures a scene file names, in parallel, and giving them to the scene
// (see scene_images.h).
#include "scene/scene_images.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <exception>
#include <memory>
#include <new>

#include <fmt/format.h>
#include <tbb/parallel_for.h>

#include "core/error.h"
#include "io/texture_image.h"
#include "scene/scene.h"

namespace cierzo {

namespace fs = std::filesystem;

namespace {

// What the environment's tables take per texel of its image while they are built (radiance
// 12 bytes, column CDF 4, density 4, and a double per texel during the build): see
// Scene::build_environment.
constexpr uint64_t kEnvironmentBytesPerTexel = 28;

// Refuses (naming the scene file, the place and the image) an image outside the roots, and
// images whose decoding would take more than `budget` bytes at once, charged from their
// headers: each image's peak while decoded (all may be decoded at the same time) and the
// environment's tables.
void check_images(const Scene& scene, const ImageRequests& images, const fs::path& file,
                  const InputRoots& roots, uint64_t budget) {
    const auto& requests = images.requests;
    const auto refuse = [&](size_t i, const std::string& what) {
        throw InputError(file.string() + ": " + requests[i].where + ": " + what);
    };
    for (size_t i = 0; i < requests.size(); ++i) {
        const std::string why = roots.refusal(requests[i].path, requests[i].path.string());
        if (!why.empty()) refuse(i, why);
    }
    const int32_t environment = scene.environment.emission.kind == TextureKind::kImage
                                    ? scene.environment.emission.image
                                    : -1;
    std::vector<std::pair<uint64_t, size_t>> cost(requests.size());
    uint64_t total = 0;
    for (size_t i = 0; i < requests.size(); ++i) {
        TextureShape shape;
        try {
            shape = probe_texture_image(requests[i].path);
        } catch (const InputError& e) {
            refuse(i, e.what());
        }
        uint64_t bytes = shape.peak_bytes;
        if (int32_t(i) == environment) bytes += kEnvironmentBytesPerTexel * shape.texels();
        cost[i] = {bytes, i};
        total += bytes;
    }
    if (total <= budget) return;
    // (the largest first; among equals, in the order the scene names them)
    std::stable_sort(cost.begin(), cost.end(),
                     [](const auto& a, const auto& b) { return a.first > b.first; });
    std::string largest;
    for (size_t k = 0; k < std::min<size_t>(3, cost.size()); ++k)
        largest += fmt::format("{}{} ({}{})", k ? ", " : "", requests[cost[k].second].path.string(),
                               format_bytes(cost[k].first),
                               int32_t(cost[k].second) == environment
                                   ? " as the environment, with its sampling tables"
                                   : "");
    throw InputError(fmt::format(
        "{}: its {} image{} would take {} of memory while decoded, over the budget of {}; "
        "the largest: {}. --image-memory SIZE raises the budget (read from each image's "
        "header: nothing was decoded)",
        file.string(), requests.size(), requests.size() == 1 ? "" : "s", format_bytes(total),
        format_bytes(budget), largest));
}

}  // namespace

void load_images(Scene& scene, const ImageRequests& images, const fs::path& file,
                 const InputRoots& roots, uint64_t budget) {
    const auto& requests = images.requests;
    if (requests.empty()) return;
    const auto start = std::chrono::steady_clock::now();
    check_images(scene, images, file, roots, budget);
    std::vector<std::shared_ptr<const TextureImage>> decoded(requests.size());
    std::vector<std::exception_ptr> errors(requests.size());
    tbb::parallel_for(size_t(0), requests.size(), [&](size_t i) {
        try {
            decoded[i] = std::make_shared<const TextureImage>(
                read_texture_image(requests[i].path, requests[i].srgb));
        } catch (...) {
            errors[i] = std::current_exception();
        }
    });
    for (size_t i = 0; i < requests.size(); ++i) {
        if (!errors[i]) continue;
        try {
            std::rethrow_exception(errors[i]);
        } catch (const InputError& e) {
            throw InputError(file.string() + ": " + requests[i].where + ": " + e.what());
        } catch (const std::bad_alloc&) {
            throw InputError(file.string() + ": " + requests[i].where + ": " +
                             requests[i].path.string() + ": out of memory decoding it");
        }
    }
    for (size_t i = 0; i < requests.size(); ++i) {
        scene.add_image(decoded[i]);
        scene.files.push_back(requests[i].path);
    }
    scene.image_seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    std::vector<ColorSource*> sources = {&scene.environment.emission};
    for (Material& m : scene.materials)
        for (ColorSource* c : {&m.emission, &m.kd, &m.ks, &m.kr, &m.kt}) sources.push_back(c);
    for (ColorSource* c : sources)
        if (c->kind == TextureKind::kImage) {
            const TextureImage& im = *scene.images[size_t(c->image)];
            c->b = {c->a.x * im.max_rgb[0], c->a.y * im.max_rgb[1], c->a.z * im.max_rgb[2]};
            // (the largest texel times the factor bounds every value the texture gives: finite
            // here, so is every colour and every table built from them)
            for (int k = 0; k < 3; ++k)
                if (!std::isfinite(c->b[k]))
                    throw InputError(fmt::format(
                        "{}: {}: the image's largest value {} times its factor {} overflows a "
                        "float: lower the factor",
                        file.string(), requests[size_t(c->image)].where, im.max_rgb[k], c->a[k]));
        }
    const auto imaged = [&](int32_t material) {
        const Material& m = scene.materials[size_t(material)];
        for (const ColorSource* c : {&m.emission, &m.kd, &m.ks, &m.kr, &m.kt})
            if (c->kind == TextureKind::kImage) return true;
        return false;
    };
    const auto name = [&](int32_t material) {
        const std::string& n = scene.materials[size_t(material)].name;
        return n.empty() ? std::string("an inline material") : "material '" + n + "'";
    };
    for (const Mesh& m : scene.meshes)
        if (imaged(m.material) && scene.geometry_of(m).uvs.empty())
            throw InputError(file.string() + ": " + name(m.material) +
                             " has an image texture, but the mesh '" + m.source +
                             "' has no texture coordinates (OBJ 'vt')");
    for (const Mesh& m : scene.meshes)
        if (scene.materials[size_t(m.material)].alpha.image >= 0 &&
            scene.geometry_of(m).uvs.empty())
            throw InputError(file.string() + ": " + name(m.material) +
                             " has an alpha mask image, but the mesh '" + m.source +
                             "' has no texture coordinates (OBJ 'vt')");
    for (size_t i = 0; i < scene.quadrics.size(); ++i)
        if (imaged(scene.quadrics[i].material))
            throw InputError(file.string() + ": " + name(scene.quadrics[i].material) +
                             " has an image texture, but a quadric has no texture "
                             "coordinates (use a sin, sin2 or sincos pattern there)");
}

}  // namespace cierzo
