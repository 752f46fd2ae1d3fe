// Decoding the image textures a scene file names, in parallel, and giving them to the scene
// (see scene_images.h).
#include "scene/scene_images.h"

#include <chrono>
#include <exception>
#include <memory>
#include <new>

#include <tbb/parallel_for.h>

#include "core/error.h"
#include "io/texture_image.h"
#include "scene/scene.h"

namespace cierzo {

void load_images(Scene& scene, const ImageRequests& images, const std::filesystem::path& file) {
    const auto& requests = images.requests;
    if (requests.empty()) return;
    const auto start = std::chrono::steady_clock::now();
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
