// Image textures as files give them: PNG, JPEG, TGA, BMP, PNM (8 bits per channel), Radiance
// HDR and OpenEXR (linear floats). Every image becomes four channels (red, green, blue,
// alpha): grey is repeated into the colour channels, a missing alpha is 1.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

namespace cierzo {

// Textures larger than this on either side, or with more texels in all, are refused before
// anything is allocated (16384² is 1 GiB as bytes).
inline constexpr int32_t kMaxTextureSide = 32768;
inline constexpr int64_t kMaxTextureTexels = int64_t(1) << 28;

struct TextureImage {
    std::filesystem::path path;  // for messages
    int32_t width = 0, height = 0;
    // One of the two: RGBA8 packed in an int32 (red in the low byte) for 8-bit files, or
    // RGBA32F for HDR and EXR files
    std::vector<int32_t> bytes;
    std::vector<float> floats;
    bool srgb = false;  // the bytes' colour channels are sRGB-encoded (decoded on look-up)
    float max_rgb[3] = {0.0f, 0.0f, 0.0f};  // the largest linear value of each channel
    double mean_rgb[3] = {0.0, 0.0, 0.0};   // the mean linear value of each channel
    bool opaque = true;                     // every alpha is 1

    size_t texels() const { return size_t(width) * size_t(height); }
    size_t memory_bytes() const { return bytes.size() * 4 + floats.size() * 4; }
};

// What decoding an image texture costs, from its file's header alone (nothing decoded).
struct TextureShape {
    int32_t width = 0, height = 0;
    bool floats = false;      // HDR and EXR: RGBA floats, 16 bytes a texel; else 4 bytes
    uint64_t kept_bytes = 0;  // what the decoded TextureImage holds
    uint64_t peak_bytes = 0;  // the most memory decoding it takes at once, the result included
    uint64_t texels() const { return uint64_t(width) * uint64_t(height); }
};

// The shape of an image texture, read from the header of the file (for EXR, through
// OpenEXR's header; for the others, through stb_image's, after the signature and extension
// checks of read_texture_image). Throws InputError as read_texture_image does for a file
// that is missing, of an unknown or disagreeing format, or of absurd dimensions.
TextureShape probe_texture_image(const std::filesystem::path& path);

// Reads an image texture; `srgb` says whether an 8-bit file's colours are sRGB-encoded
// (colour maps) or linear (data maps; HDR and EXR files are always linear). Throws InputError
// naming the file: missing, not a regular file (a directory, a FIFO, a device: refused before
// it is opened), not an image of a documented format (known by its signature; a TGA, which
// has none, by a plausible header), of a format its extension does not name, truncated or
// undecodable, of absurd dimensions, or holding a value that is negative, NaN or infinite.
TextureImage read_texture_image(const std::filesystem::path& path, bool srgb);

// The same from bytes in memory, for every format but EXR (which read_texture_image reads
// from its file): PNG, JPEG, BMP, PNM (8-bit P5, P6) and HDR known by their signatures, TGA
// by a plausible header; the extension of `name` must name the same format (.png, .jpg or
// .jpeg, .bmp, .ppm, .pgm or .pnm, .hdr, .tga); `name` is otherwise only used in messages.
TextureImage decode_texture_image(const std::string& bytes, const std::filesystem::path& name,
                                  bool srgb);

// The 256-entry tables the kernels decode bytes with: the sRGB curve (IEC 61966-2-1) and
// byte / 255.
const float* srgb_decode_table();
const float* linear_decode_table();

}  // namespace cierzo
