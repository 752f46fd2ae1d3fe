// A float RGB image in memory, row-major from the top-left pixel, and its file formats:
// OpenEXR (float32, lossless) and PFM for HDR; PNG, PPM and BMP for tone-mapped LDR.
#pragma once

#include <cstdint>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

namespace cierzo {

struct Image {
    int width = 0;
    int height = 0;
    std::vector<float> rgb;  // width * height * 3 floats, row 0 is the top row

    Image() = default;
    Image(int w, int h) : width(w), height(h), rgb(size_t(w) * size_t(h) * 3, 0.0f) {}
    float* pixel(int x, int y) { return &rgb[(size_t(y) * size_t(width) + size_t(x)) * 3]; }
    const float* pixel(int x, int y) const {
        return &rgb[(size_t(y) * size_t(width) + size_t(x)) * 3];
    }
};

// Readers refuse images with more pixels than this before allocating anything.
inline constexpr int64_t kMaxImagePixels = int64_t(1) << 28;

// String key/value pairs stored in the EXR header (e.g. "cierzo:spp" -> "64").
using ImageMetadata = std::map<std::string, std::string>;

// Optional extra float channel layers written into the EXR beside R, G, B,
// e.g. {"variance.R", ...}. Each vector has width * height floats.
using ImageLayers = std::map<std::string, std::vector<float>>;

// Writers go through a temporary file in the same folder and rename it into place, so
// an existing file is never left damaged. They throw InputError naming the path on failure.
void write_exr(const std::filesystem::path& path, const Image& image,
               const ImageMetadata& metadata = {}, const ImageLayers& layers = {});
void write_pfm(const std::filesystem::path& path, const Image& image);
// Picks EXR or PFM from the extension (.exr, .pfm); anything else is an InputError.
void write_hdr(const std::filesystem::path& path, const Image& image,
               const ImageMetadata& metadata = {}, const ImageLayers& layers = {});

Image read_exr(const std::filesystem::path& path, ImageMetadata* metadata = nullptr);
// Also returns every channel other than R, G, B (converted to float) in `layers`.
Image read_exr(const std::filesystem::path& path, ImageMetadata* metadata, ImageLayers* layers);
// An EXR file's size and channels from its header alone (checked as read_exr checks it,
// nothing decoded): what decoding it would cost.
struct ExrShape {
    int64_t width = 0, height = 0;
    int channels = 0;
};
ExrShape read_exr_shape(const std::filesystem::path& path);
Image read_pfm(const std::filesystem::path& path);
Image read_hdr(const std::filesystem::path& path);  // by extension

// Refuses (InputError naming the file), from its bytes alone, an OpenEXR file whose header
// would make OpenEXR allocate more than the file can hold: no EXR magic, deep or multi-part
// data, an attribute declared larger than the rest of the file, or a data window of more
// than 65536 pixels a side or kMaxImagePixels in all. The readers call it before OpenEXR.
void check_exr_header(const std::filesystem::path& path);

// 8-bit output of an already tone-mapped image with values in [0, 1] (clamped, then
// quantised with rounding). Format from the extension: .png, .ppm, .bmp.
void write_ldr(const std::filesystem::path& path, const Image& image);

}  // namespace cierzo
