// Image textures (see texture_image.h): stb_image decodes the 8-bit formats and Radiance HDR,
// OpenEXR the EXR files (through read_exr).
#include "io/texture_image.h"

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <limits>
#include <memory>
#include <string_view>
#include <system_error>

#include <fmt/format.h>
#include <stb/stb_image.h>

#include "core/error.h"
#include "io/image.h"
#include "io/input_file.h"
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
                    fail(t.path,
                         fmt::format("texel ({}, {}) has the value {} in channel {}: "
                                     "texels must be finite and >= 0",
                                     i % size_t(t.width), i / size_t(t.width), px[c], "RGBA"[c]));
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
        t.floats[4 * i + 3] =
            alpha == layers.end() ? 1.0f : std::clamp(alpha->second[i], 0.0f, 1.0f);
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

namespace {

// Which format the bytes are, by their signature (TGA, which has none, by the name's
// extension and a plausible header); stb_image is only ever given these formats, never its
// others (GIF, PSD, PIC), and the name's extension must agree with the signature.
enum class Format { kUnknown, kPng, kJpeg, kBmp, kPnm, kHdr, kTga };

const char* format_name(Format f) {
    switch (f) {
        case Format::kPng: return "PNG";
        case Format::kJpeg: return "JPEG";
        case Format::kBmp: return "BMP";
        case Format::kPnm: return "PNM";
        case Format::kHdr: return "Radiance HDR";
        case Format::kTga: return "TGA";
        default: return "unknown";
    }
}

constexpr const char* kExtensions =
    "image textures are .png, .jpg (.jpeg), .tga, .bmp, .ppm (.pgm, .pnm), .hdr and .exr "
    "files";

Format format_of_extension(const std::string& ext) {
    if (ext == ".png") return Format::kPng;
    if (ext == ".jpg" || ext == ".jpeg" || ext == ".jpe" || ext == ".jfif") return Format::kJpeg;
    if (ext == ".bmp") return Format::kBmp;
    if (ext == ".ppm" || ext == ".pgm" || ext == ".pnm") return Format::kPnm;
    if (ext == ".hdr" || ext == ".rgbe") return Format::kHdr;
    if (ext == ".tga") return Format::kTga;
    return Format::kUnknown;
}

// A TGA header (18 bytes: no signature) that stb_image reads as a TGA and nothing else: a
// colour-mapped, true-colour or grey image, plain or run-length encoded, of a depth TGA has,
// and not the signature of one of stb_image's undocumented formats.
bool plausible_tga(std::string_view b) {
    if (b.size() < 18) return false;
    for (std::string_view other :
         {std::string_view("GIF8"), std::string_view("8BPS"), std::string_view("\x53\x80\xf6\x34")})
        if (b.substr(0, other.size()) == other) return false;
    const int map = uint8_t(b[1]), type = uint8_t(b[2]), bits = uint8_t(b[16]);
    const int map_bits = uint8_t(b[7]);
    if (map > 1) return false;
    if (!((type >= 1 && type <= 3) || (type >= 9 && type <= 11))) return false;
    if ((type == 1 || type == 9) != (map == 1)) return false;
    if (map == 1 && map_bits != 15 && map_bits != 16 && map_bits != 24 && map_bits != 32)
        return false;
    return bits == 8 || bits == 15 || bits == 16 || bits == 24 || bits == 32;
}

// The format of an image texture's first bytes, checked against its name: refused (naming
// the file, never quoting it) when the signature is of no documented format, or the
// extension says another.
Format format_of(std::string_view bytes, const fs::path& name) {
    const auto starts = [&](std::string_view magic) {
        return bytes.substr(0, magic.size()) == magic;
    };
    const std::string ext = lower_extension(name);
    const Format named = format_of_extension(ext);
    if (named == Format::kUnknown)
        fail(name, ext.empty() ? fmt::format("has no extension: {}", kExtensions)
                               : fmt::format("has the extension '{}': {}", ext, kExtensions));
    Format found = Format::kUnknown;
    if (starts("\x89PNG\r\n\x1a\n"))
        found = Format::kPng;
    else if (starts("\xff\xd8\xff"))
        found = Format::kJpeg;
    else if (starts("BM"))
        found = Format::kBmp;
    else if (starts("P5") || starts("P6"))
        found = Format::kPnm;
    else if (starts("#?RADIANCE\n") || starts("#?RGBE\n"))
        found = Format::kHdr;
    else if (named == Format::kTga && plausible_tga(bytes))
        found = Format::kTga;
    if (found == Format::kUnknown)
        fail(name, fmt::format("is not a {} file (its first bytes are no {} header; {})",
                               format_name(named), format_name(named), kExtensions));
    if (found != named)
        fail(name, fmt::format("is a {} file by its contents, but its name ends in '{}': the "
                               "extension must say what the file is",
                               format_name(found), ext));
    return found;
}

// The longest PNM header read (its comments included), and so the bytes of a file the probe
// reads before the image's decoder
constexpr size_t kMaxPnmHeader = 65536;

// A binary PNM's header (P5 grey, P6 colour: width, height, maxval, then one whitespace
// byte), checked against the data before stb_image reads it: 8 bits per sample only, and
// as many bytes as the header promises.
void check_pnm(std::string_view bytes, uint64_t file_size, const fs::path& name) {
    // (a header of comments over kMaxPnmHeader bytes is refused alike from a file's first
    // bytes, as probe_texture_image reads it, and from the whole file)
    bytes = bytes.substr(0, kMaxPnmHeader);
    size_t at = 2;
    int64_t values[3] = {0, 0, 0};
    for (int64_t& v : values) {
        for (;;) {  // whitespace and comments
            while (at < bytes.size() && std::isspace(static_cast<unsigned char>(bytes[at]))) ++at;
            if (at < bytes.size() && bytes[at] == '#') {
                while (at < bytes.size() && bytes[at] != '\n') ++at;
                continue;
            }
            break;
        }
        size_t digits = 0;
        while (at < bytes.size() && std::isdigit(static_cast<unsigned char>(bytes[at])) &&
               digits < 10)
            v = v * 10 + (bytes[at++] - '0'), ++digits;
        if (at >= kMaxPnmHeader)
            fail(name, fmt::format("is a PNM file whose header (with its comments) runs past {} "
                                   "bytes: it is not read",
                                   kMaxPnmHeader));
        if (digits == 0 || digits == 10) fail(name, "is not a valid PNM file (a bad header)");
    }
    if (values[2] < 1 || values[2] > 255)
        fail(name, fmt::format("is a PNM file of maxval {}: only 8-bit PNM (maxval 1 to 255) is "
                               "read",
                               values[2]));
    check_size(name, values[0], values[1]);
    const int64_t channels = bytes[1] == '5' ? 1 : 3;
    const int64_t need = int64_t(at) + 1 + values[0] * values[1] * channels;
    if (int64_t(file_size) < need)
        fail(name, fmt::format("is truncated: a {} x {} PNM needs {} bytes, the file has {}",
                               values[0], values[1], need, file_size));
}

uint32_t le16(std::string_view b, size_t at) {
    return uint32_t(uint8_t(b[at])) | uint32_t(uint8_t(b[at + 1])) << 8;
}
int64_t le32s(std::string_view b, size_t at) {
    return int32_t(le16(b, at) | le16(b, at + 2) << 16);
}

// An uncompressed TGA or BMP must hold the texels its header promises, and a run-length
// encoded TGA at least one packet per 128 of them: checked before stb_image allocates the
// image (a 30-byte file claiming 16384² texels would otherwise cost a gigabyte).
void check_raw_size(std::string_view bytes, uint64_t file_size, const fs::path& name,
                    Format format) {
    const auto need = [&](int64_t n, int64_t w, int64_t h) {
        check_size(name, w, h);
        if (int64_t(file_size) < n)
            fail(name, fmt::format("is truncated: its {} x {} texels need at least {} bytes, "
                                   "the file has {}",
                                   w, h, n, file_size));
    };
    if (format == Format::kTga && bytes.size() >= 18) {
        const int64_t w = le16(bytes, 12), h = le16(bytes, 14);
        const int type = uint8_t(bytes[2]), bits = uint8_t(bytes[16]);
        const int64_t head =
            18 + int64_t(uint8_t(bytes[0])) +
            (uint8_t(bytes[1]) ? int64_t(le16(bytes, 5)) * ((uint8_t(bytes[7]) + 7) / 8) : 0);
        const int64_t texel = std::max((bits + 7) / 8, 1);
        if (type >= 1 && type <= 3) need(head + w * h * texel, w, h);
        if (type >= 9 && type <= 11) need(head + (w * h + 127) / 128 * (1 + texel), w, h);
    }
    if (format == Format::kBmp && bytes.size() >= 34) {
        const int64_t offset = le32s(bytes, 10), w = le32s(bytes, 18), h = le32s(bytes, 22);
        const int64_t bits = le16(bytes, 28), compression = le32s(bytes, 30);
        if ((compression == 0 || compression == 3) && w > 0 && h != 0) {
            check_size(name, w, std::abs(h));  // (first: the product below stays small)
            need(offset + (w * bits + 31) / 32 * 4 * std::abs(h), w, std::abs(h));
        }
    }
}

}  // namespace

TextureImage decode_texture_image(const std::string& bytes, const fs::path& name, bool srgb) {
    if (bytes.size() > size_t(std::numeric_limits<int>::max()))
        fail(name, "is too large to be an image texture (over 2 GiB)");
    const Format format = format_of(bytes, name);
    if (format == Format::kPnm) check_pnm(bytes, bytes.size(), name);
    check_raw_size(bytes, bytes.size(), name, format);
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
    if (format == Format::kHdr) {
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

TextureShape probe_texture_image(const fs::path& path) {
    TextureShape shape;
    if (lower_extension(path) == ".exr") {
        ExrShape exr;
        try {
            exr = read_exr_shape(path);
        } catch (const InputError& e) {
            throw InputError(std::string(e.what()) + " (as an image texture)");
        }
        check_size(path, exr.width, exr.height);
        shape.width = int32_t(exr.width), shape.height = int32_t(exr.height);
        shape.floats = true;
        // (read_exr's RGB floats and a float layer per other channel, then RGBA floats)
        const uint64_t n = shape.texels();
        shape.kept_bytes = 16 * n;
        shape.peak_bytes = n * (12 + 4 * uint64_t(std::max(exr.channels - 3, 0)) + 16);
        return shape;
    }
    if (!input_file_exists(path)) fail(path, "file does not exist");
    std::error_code ec;
    const uint64_t size = fs::file_size(path, ec);
    if (ec) fail(path, "cannot read: " + ec.message());
    if (size > uint64_t(std::numeric_limits<int>::max()))
        fail(path, "is too large to be an image texture (over 2 GiB)");
    std::unique_ptr<FILE, int (*)(FILE*)> file(std::fopen(path.c_str(), "rb"), &std::fclose);
    if (!file) fail(path, "cannot open file for reading");
    std::string head(size_t(std::min<uint64_t>(size, kMaxPnmHeader)), '\0');
    if (std::fread(head.data(), 1, head.size(), file.get()) != head.size())
        fail(path, "read error");
    const Format format = format_of(head, path);
    if (format == Format::kPnm) check_pnm(head, size, path);
    check_raw_size(head, size, path, format);
    int w = 0, h = 0, channels = 0;
    std::rewind(file.get());
    if (!stbi_info_from_file(file.get(), &w, &h, &channels))
        fail(path, fmt::format("is not a valid {} file: {}", format_name(format),
                               stbi_failure_reason() ? stbi_failure_reason() : "a bad header"));
    check_size(path, w, h);
    shape.width = w, shape.height = h;
    const uint64_t n = shape.texels(), c = uint64_t(std::clamp(channels, 1, 4));
    if (format == Format::kHdr) {
        // (stb_image's RGBA floats, then ours)
        shape.floats = true;
        shape.kept_bytes = 16 * n;
        shape.peak_bytes = 32 * n;
    } else {
        // stb_image inflates (PNG) or decodes into the file's channels, converts to RGBA in a
        // second buffer, and the texels are copied out of that
        shape.kept_bytes = 4 * n;
        shape.peak_bytes = n * std::max({2 * c + 1, c + 4, uint64_t(8)});
    }
    return shape;
}

TextureImage read_texture_image(const fs::path& path, bool srgb) {
    if (lower_extension(path) == ".exr") return read_exr_texture(path);
    return decode_texture_image(read_mesh_bytes(path), path, srgb);
}

}  // namespace cierzo
