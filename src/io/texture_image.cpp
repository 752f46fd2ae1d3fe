// Image textures (see texture_image.h): stb_image decodes the 8-bit formats and Radiance HDR,
// OpenEXR the EXR files (through read_exr).
#include "io/texture_image.h"

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <limits>

#include <fmt/format.h>
#include <stb/stb_image.h>

#include "core/error.h"
#include "io/image.h"
#include "io/mesh_file.h"

namespace cierzo {

namespace {

namespace fs = std::filesystem;

[[noreturn]] void fail(const fs::path& path, const std::string& what) {
    throw InputError(fmt::format("{}: {}", path.string(), what));
}

void check_size(const fs::path& path, int64_t width, int64_t height) {
    if (width <= 0 || height <= 0 || width > kMaxTextureSide || height > kMaxTextureSide ||
        width * height > kMaxTextureTexels)
        fail(path, fmt::format("an image texture of {} x {} texels is refused (at most {} on "
                               "a side and {} texels)",
                               width, height, kMaxTextureSide, kMaxTextureTexels));
}

// The statistics the scene needs of a decoded image (largest and mean value per channel,
// whether any texel is transparent), and the check that every float is a usable radiance.
void summarise(TextureImage& t) {
    const size_t n = t.texels();
    double sum[3] = {0.0, 0.0, 0.0};
    float biggest[3] = {0.0f, 0.0f, 0.0f};
    bool opaque = true;
    if (!t.floats.empty()) {
        for (size_t i = 0; i < n; ++i) {
            const float* px = &t.floats[4 * i];
            for (int c = 0; c < 4; ++c)
                if (!(px[c] >= 0.0f) || !std::isfinite(px[c]))
                    fail(t.path, fmt::format("texel ({}, {}) has the value {} in channel {}: "
                                             "texels must be finite and >= 0",
                                             i % size_t(t.width), i / size_t(t.width), px[c],
                                             "RGBA"[c]));
            for (int c = 0; c < 3; ++c) sum[c] += px[c], biggest[c] = std::max(biggest[c], px[c]);
            opaque &= px[3] >= 1.0f;
        }
    } else {
        const float* decode = t.srgb ? srgb_decode_table() : linear_decode_table();
        for (size_t i = 0; i < n; ++i) {
            const uint32_t v = uint32_t(t.bytes[i]);
            for (int c = 0; c < 3; ++c) {
                const float x = decode[(v >> (8 * c)) & 255u];
                sum[c] += x, biggest[c] = std::max(biggest[c], x);
            }
            opaque &= (v >> 24) == 255u;
        }
    }
    for (int c = 0; c < 3; ++c) t.mean_rgb[c] = sum[c] / double(n), t.max_rgb[c] = biggest[c];
    t.opaque = opaque;
}

std::string lower_extension(const fs::path& path) {
    std::string ext = path.extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(),
                   [](unsigned char c) { return char(std::tolower(c)); });
    return ext;
}

TextureImage read_exr_texture(const fs::path& path) {
    ImageLayers layers;
    Image image;
    try {
        image = read_exr(path, nullptr, &layers);
    } catch (const InputError& e) {
        // (read_exr's messages name the file already)
        throw InputError(std::string(e.what()) + " (as an image texture)");
    }
    TextureImage t;
    t.path = path;
    check_size(path, image.width, image.height);
    t.width = image.width, t.height = image.height;
    const auto alpha = layers.find("A");
    t.floats.resize(t.texels() * 4);
    for (size_t i = 0; i < t.texels(); ++i) {
        for (int c = 0; c < 3; ++c) t.floats[4 * i + size_t(c)] = image.rgb[3 * i + size_t(c)];
        t.floats[4 * i + 3] = alpha == layers.end() ? 1.0f : std::clamp(alpha->second[i], 0.0f, 1.0f);
    }
    summarise(t);
    return t;
}

}  // namespace

const float* srgb_decode_table() {
    static const std::array<float, 256> table = [] {
        std::array<float, 256> t{};
        for (int i = 0; i < 256; ++i) {
            const double c = i / 255.0;
            t[size_t(i)] = float(c <= 0.04045 ? c / 12.92 : std::pow((c + 0.055) / 1.055, 2.4));
        }
        return t;
    }();
    return table.data();
}

const float* linear_decode_table() {
    static const std::array<float, 256> table = [] {
        std::array<float, 256> t{};
        for (int i = 0; i < 256; ++i) t[size_t(i)] = float(i / 255.0);
        return t;
    }();
    return table.data();
}

TextureImage decode_texture_image(const std::string& bytes, const fs::path& name, bool srgb) {
    if (bytes.size() > size_t(std::numeric_limits<int>::max()))
        fail(name, "is too large to be an image texture (over 2 GiB)");
    const auto* data = reinterpret_cast<const stbi_uc*>(bytes.data());
    const int length = int(bytes.size());
    int w = 0, h = 0, channels = 0;
    if (!stbi_info_from_memory(data, length, &w, &h, &channels))
        fail(name, fmt::format("is not an image texture cierzo can read (PNG, JPEG, TGA, BMP, "
                               "PNM, HDR or EXR): {}",
                               stbi_failure_reason() ? stbi_failure_reason() : "unknown format"));
    check_size(name, w, h);
    TextureImage t;
    t.path = name;
    t.width = w, t.height = h;
    int dw = 0, dh = 0, dc = 0;
    if (stbi_is_hdr_from_memory(data, length)) {
        float* px = stbi_loadf_from_memory(data, length, &dw, &dh, &dc, 4);
        if (!px || dw != w || dh != h) {
            stbi_image_free(px);
            fail(name, fmt::format("cannot be decoded: {}", stbi_failure_reason()
                                                                ? stbi_failure_reason()
                                                                : "truncated or corrupt"));
        }
        t.floats.assign(px, px + t.texels() * 4);
        stbi_image_free(px);
        // (an HDR file's alpha, where stb makes one, is 1)
        for (size_t i = 0; i < t.texels(); ++i) t.floats[4 * i + 3] = 1.0f;
    } else {
        stbi_uc* px = stbi_load_from_memory(data, length, &dw, &dh, &dc, 4);
        if (!px || dw != w || dh != h) {
            stbi_image_free(px);
            fail(name, fmt::format("cannot be decoded: {}", stbi_failure_reason()
                                                                ? stbi_failure_reason()
                                                                : "truncated or corrupt"));
        }
        t.bytes.resize(t.texels());
        for (size_t i = 0; i < t.texels(); ++i) {
            const stbi_uc* q = px + 4 * i;
            t.bytes[i] = int32_t(uint32_t(q[0]) | uint32_t(q[1]) << 8 | uint32_t(q[2]) << 16 |
                                 uint32_t(q[3]) << 24);
        }
        stbi_image_free(px);
        t.srgb = srgb;
    }
    summarise(t);
    return t;
}

TextureImage read_texture_image(const fs::path& path, bool srgb) {
    if (lower_extension(path) == ".exr") return read_exr_texture(path);
    return decode_texture_image(read_mesh_bytes(path, "texture image"), path, srgb);
}

}  // namespace cierzo
