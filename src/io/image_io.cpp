// Image files: float32 OpenEXR (ZIP, string metadata, extra layers) and PFM for HDR data;
// 8-bit PNG and BMP (through stb_image_write) and binary PPM for tone-mapped output.
#include "core/error.h"
#include "io/input_file.h"
#include "io/output_file.h"
#include "io/image.h"

#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfCompression.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfInputFile.h>
#include <OpenEXR/ImfOutputFile.h>
#include <OpenEXR/ImfStdIO.h>
#include <OpenEXR/ImfStringAttribute.h>
#include <stb/stb_image_write.h>
#include <zlib.h>

#include <algorithm>
#include <bit>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstring>
#include <fstream>
#include <system_error>

namespace cierzo {

namespace fs = std::filesystem;

namespace {

constexpr const char* kRgbNames[3] = {"R", "G", "B"};
// OpenEXR attribute and channel names hold at most 255 characters (longer ones are truncated
// silently by the library, so they are refused here).
constexpr size_t kMaxExrName = 255;

[[noreturn]] void write_error(const fs::path& path, const std::string& reason) {
    throw InputError(path.string() + ": cannot write: " + reason);
}

[[noreturn]] void read_error(const fs::path& path, const std::string& reason) {
    throw InputError(path.string() + ": " + reason);
}

std::string lower_extension(const fs::path& path) {
    std::string ext = path.extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(),
                   [](unsigned char c) { return char(std::tolower(c)); });
    return ext;
}

size_t pixel_count(const Image& image) { return size_t(image.width) * size_t(image.height); }

void check_writable_image(const fs::path& path, const Image& image) {
    if (image.width <= 0 || image.height <= 0) {
        write_error(path, "invalid image size " + std::to_string(image.width) + "x" +
                              std::to_string(image.height));
    }
    if (int64_t(image.width) * int64_t(image.height) > kMaxImagePixels) {
        write_error(path, "image of " + std::to_string(image.width) + "x" +
                              std::to_string(image.height) + " pixels is too large");
    }
    if (image.rgb.size() != pixel_count(image) * 3) {
        write_error(path, "pixel buffer holds " + std::to_string(image.rgb.size()) +
                              " floats, expected " + std::to_string(pixel_count(image) * 3));
    }
}

// Fails with a clear message for a missing path, or one that is not a regular file
// (input_file_exists), before a format reader opens it.
void check_readable_file(const fs::path& path) {
    if (!input_file_exists(path)) {
        read_error(path, "cannot read: " + std::generic_category().message(ENOENT));
    }
}

// ---- OpenEXR ------------------------------------------------------------------------------

void check_exr_name(const fs::path& path, const std::string& name, const char* what) {
    if (name.empty() || name.size() > kMaxExrName) {
        write_error(path, std::string(what) + " name '" + name +
                              "' must have between 1 and 255 characters");
    }
}

}  // namespace

// The data window of an EXR file from its header, read here before OpenEXR opens the file:
// OpenEXR sizes its line buffers and offset tables from the header alone, so a 100-byte
// file claiming a row of 2^28 pixels would cost gigabytes before any check of ours. A
// single-part scanline or tiled image is required; each side at most 65536 pixels (the
// largest image cierzo renders) and the area at most kMaxImagePixels. Every attribute's
// declared size, those after the data window too, must fit in the rest of the file (OpenEXR
// allocates a string's or an unknown type's size as declared).
namespace {

// The size of an EXR attribute type of fixed size, or -1 (strings, channel lists, opaque
// types: their declared size is theirs).
int32_t exr_type_size(const std::string& type) {
    static const std::pair<const char*, int32_t> kSizes[] = {{"box2i", 16},
                                                             {"box2f", 16},
                                                             {"int", 4},
                                                             {"float", 4},
                                                             {"double", 8},
                                                             {"v2i", 8},
                                                             {"v2f", 8},
                                                             {"v2d", 16},
                                                             {"v3i", 12},
                                                             {"v3f", 12},
                                                             {"v3d", 24},
                                                             {"m33f", 36},
                                                             {"m33d", 72},
                                                             {"m44f", 64},
                                                             {"m44d", 128},
                                                             {"compression", 1},
                                                             {"lineOrder", 1},
                                                             {"envmap", 1},
                                                             {"deepImageState", 1},
                                                             {"rational", 8},
                                                             {"timecode", 8},
                                                             {"keycode", 28},
                                                             {"tiledesc", 9},
                                                             {"chromaticities", 32}};
    for (const auto& [name, bytes] : kSizes)
        if (type == name) return bytes;
    return -1;
}

}  // namespace

void check_exr_header(const fs::path& path) {
    std::ifstream in(path, std::ios::binary);
    std::error_code ec;
    const int64_t file_size = int64_t(fs::file_size(path, ec));
    const auto bytes_left = [&] { return ec ? int64_t(0) : file_size - int64_t(in.tellg()); };
    uint8_t head[8];
    if (!in.read(reinterpret_cast<char*>(head), 8) || head[0] != 0x76 || head[1] != 0x2f ||
        head[2] != 0x31 || head[3] != 0x01)
        read_error(path, "not an OpenEXR file (no EXR magic number)");
    if (head[5] & 0x18)  // (version flags: 0x08 deep data, 0x10 multi-part)
        read_error(path,
                   "a deep or multi-part OpenEXR file is not read (a single-part "
                   "scanline or tiled image is)");
    const auto token = [&]() {
        std::string t;
        char c;
        while (in.get(c) && c != '\0') {
            t += c;
            if (t.size() > 255) read_error(path, "invalid OpenEXR header (a name too long)");
        }
        if (!in) read_error(path, "truncated OpenEXR header");
        return t;
    };
    bool window = false;
    for (int attributes = 0;; ++attributes) {
        const std::string name = token();
        if (name.empty()) break;
        const std::string type = token();
        int32_t size = 0;
        if (!in.read(reinterpret_cast<char*>(&size), 4) || size < 0 || size > bytes_left())
            read_error(path, "invalid OpenEXR header (attribute '" + name + "' of " +
                                 std::to_string(size) + " bytes)");
        // A type of a fixed size must declare that size: OpenEXR reads the type's bytes
        // whatever the size says and parses what follows as more attributes, which this
        // check would otherwise skip unseen
        const int32_t fixed = exr_type_size(type);
        if (fixed >= 0 && size != fixed)
            read_error(path, "invalid OpenEXR header (attribute '" + name + "' of type " + type +
                                 " declares " + std::to_string(size) + " bytes, not " +
                                 std::to_string(fixed) + ")");
        // A channel list is read by OpenEXR up to its empty name, not by its declared size:
        // it must end exactly there
        if (type == "chlist") {
            if (size > 65536)
                read_error(path, "invalid OpenEXR header (a channel list of " +
                                     std::to_string(size) + " bytes)");
            std::string list(size_t(size), '\0');
            if (!in.read(list.data(), size)) read_error(path, "truncated OpenEXR header");
            size_t at = 0;
            for (;;) {
                const size_t end = list.find('\0', at);
                if (end == std::string::npos)
                    read_error(path, "invalid OpenEXR header (a channel list without its end)");
                if (end == at) {
                    if (end + 1 != list.size())
                        read_error(path, "invalid OpenEXR header (attribute '" + name +
                                             "': the channel list ends before its declared size)");
                    break;
                }
                at = end + 1 + 16;  // (pixel type, linear, reserved, x and y sampling)
                if (at > list.size())
                    read_error(path, "invalid OpenEXR header (a channel list cut short)");
            }
            continue;
        }
        if (name == "dataWindow" && type == "box2i" && size == 16) {
            int32_t box[4];
            if (!in.read(reinterpret_cast<char*>(box), 16))
                read_error(path, "truncated OpenEXR header");
            const int64_t width = int64_t(box[2]) - box[0] + 1;
            const int64_t height = int64_t(box[3]) - box[1] + 1;
            if (width <= 0 || height <= 0 || width > 65536 || height > 65536 ||
                width * height > kMaxImagePixels)
                read_error(path, "refusing an image of " + std::to_string(width) + "x" +
                                     std::to_string(height) +
                                     " pixels (at most 65536 on a "
                                     "side and " +
                                     std::to_string(kMaxImagePixels) + " in all)");
            window = true;
            continue;
        }
        in.seekg(size, std::ios::cur);
        if (attributes > 100000) read_error(path, "invalid OpenEXR header (too many attributes)");
    }
    if (!window) read_error(path, "invalid OpenEXR header (no dataWindow)");
}

namespace {

// A scanline file's ZIP blocks must inflate to exactly the bytes their lines need, and an
// uncompressed file's lines hold exactly theirs: OpenEXR 3.1 accepts a shorter block and
// fills the rest of its lines from a buffer it never wrote (uninitialised memory in the
// pixels). Each block is inflated here first (zlib), before OpenEXR reads it; a block of the
// lines' size is stored raw.
void check_zip_blocks(const fs::path& path, Imf::InputFile& file) {
    const Imf::Header& header = file.header();
    const Imf::Compression compression = header.compression();
    const bool raw = compression == Imf::NO_COMPRESSION;
    if (!raw && compression != Imf::ZIP_COMPRESSION && compression != Imf::ZIPS_COMPRESSION) return;
    if (header.hasTileDescription()) return;  // (tiled: read by tiles, not checked here)
    const Imath::Box2i window = header.dataWindow();
    const int64_t width = int64_t(window.max.x) - window.min.x + 1;
    int64_t bytes_per_line = 0;
    for (auto it = header.channels().begin(); it != header.channels().end(); ++it) {
        if (it.channel().xSampling != 1 || it.channel().ySampling != 1) return;  // (refused later)
        bytes_per_line += width * (it.channel().type == Imf::HALF ? 2 : 4);
    }
    const int lines = compression == Imf::ZIP_COMPRESSION ? 16 : 1;
    std::vector<unsigned char> inflated;
    for (int64_t y = window.min.y; y <= window.max.y; y += lines) {
        const int64_t last = std::min<int64_t>(y + lines - 1, window.max.y);
        const int64_t need = bytes_per_line * (last - y + 1);
        const char* data = nullptr;
        int size = 0;
        file.rawPixelData(int(y), data, size);
        if (size == need) continue;  // (stored raw: deflating did not make it smaller)
        if (raw)
            read_error(path, "invalid OpenEXR file: the uncompressed line " + std::to_string(y) +
                                 " holds " + std::to_string(size) + " bytes, not the " +
                                 std::to_string(need) + " it needs");
        inflated.resize(size_t(need) + 1);
        uLongf got = uLongf(inflated.size());
        const int z =
            uncompress(inflated.data(), &got, reinterpret_cast<const Bytef*>(data), uLong(size));
        if (z != Z_OK || int64_t(got) != need)
            read_error(path, "invalid OpenEXR file: the ZIP block of lines " + std::to_string(y) +
                                 " to " + std::to_string(last) + " does not inflate to the " +
                                 std::to_string(need) + " bytes its lines need");
    }
}

Image read_exr_file(const fs::path& path, ImageMetadata* metadata, ImageLayers* layers) {
    check_readable_file(path);
    check_exr_header(path);
    try {
        Imf::InputFile file(path.c_str());
        const Imf::Header& header = file.header();
        const Imath::Box2i window = header.dataWindow();
        const int64_t width = int64_t(window.max.x) - int64_t(window.min.x) + 1;
        const int64_t height = int64_t(window.max.y) - int64_t(window.min.y) + 1;
        if (width <= 0 || height <= 0 || width * height > kMaxImagePixels) {
            read_error(path, "refusing an image of " + std::to_string(width) + "x" +
                                 std::to_string(height) + " pixels");
        }
        const Imf::ChannelList& channels = header.channels();
        for (const char* name : kRgbNames) {
            if (channels.findChannel(name) == nullptr) {
                read_error(path,
                           std::string("missing channel ") + name + " (an RGB image is required)");
            }
        }
        for (auto it = channels.begin(); it != channels.end(); ++it) {
            if (it.channel().xSampling != 1 || it.channel().ySampling != 1) {
                read_error(path, std::string("channel ") + it.name() +
                                     " is subsampled, which is not supported");
            }
        }
        if (!file.isComplete()) {
            read_error(path, "truncated OpenEXR file (pixel data missing)");
        }
        check_zip_blocks(path, file);

        Image image(static_cast<int>(width), static_cast<int>(height));
        Imf::FrameBuffer frame;
        const size_t stride = 3 * sizeof(float);
        for (int c = 0; c < 3; ++c) {
            frame.insert(kRgbNames[c], Imf::Slice::Make(Imf::FLOAT, image.rgb.data() + c, window,
                                                        stride, stride * size_t(width)));
        }
        ImageLayers extra;
        if (layers != nullptr) {
            for (auto it = channels.begin(); it != channels.end(); ++it) {
                const std::string name = it.name();
                if (name == "R" || name == "G" || name == "B") {
                    continue;
                }
                std::vector<float>& data = extra[name];
                data.assign(size_t(width) * size_t(height), 0.0f);
                frame.insert(name, Imf::Slice::Make(Imf::FLOAT, data.data(), window, sizeof(float),
                                                    sizeof(float) * size_t(width)));
            }
        }
        file.setFrameBuffer(frame);
        file.readPixels(window.min.y, window.max.y);

        if (metadata != nullptr) {
            metadata->clear();
            for (auto it = header.begin(); it != header.end(); ++it) {
                if (std::strcmp(it.attribute().typeName(), "string") == 0) {
                    (*metadata)[it.name()] =
                        static_cast<const Imf::StringAttribute&>(it.attribute()).value();
                }
            }
        }
        if (layers != nullptr) {
            *layers = std::move(extra);
        }
        return image;
    } catch (const InputError&) {
        throw;
    } catch (const std::exception& e) {
        read_error(path, std::string("invalid or truncated OpenEXR file: ") + e.what());
    }
}

// ---- PFM ----------------------------------------------------------------------------------

uint32_t byte_swap(uint32_t v) {
    return (v >> 24) | ((v >> 8) & 0xff00u) | ((v << 8) & 0xff0000u) | (v << 24);
}

// Reads the PFM header one byte at a time: whitespace-separated tokens, '#' comments
// allowed between them, and exactly one whitespace byte after the last token.
class PfmHeaderReader {
public:
    PfmHeaderReader(std::istream& in, const fs::path& path) : in_(in), path_(path) {}

    std::string token(const char* what) {
        int c = in_.get();
        while (c != EOF && (std::isspace(c) || c == '#')) {
            if (c == '#') {
                while (c != EOF && c != '\n') {
                    c = in_.get();
                }
            }
            c = in_.get();
        }
        std::string text;
        while (c != EOF && !std::isspace(c)) {
            if (text.size() >= 64) {
                read_error(path_, std::string("not a PFM file (bad ") + what + ")");
            }
            text.push_back(char(c));
            c = in_.get();
        }
        if (text.empty() || c == EOF) {
            read_error(path_, std::string("truncated PFM header (no ") + what + ")");
        }
        last_separator_ = c;
        return text;
    }

    int last_separator() const { return last_separator_; }

private:
    std::istream& in_;
    const fs::path& path_;
    int last_separator_ = 0;
};

int parse_pfm_size(const fs::path& path, const std::string& text, const char* what) {
    int value = 0;
    const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
    if (ec != std::errc() || end != text.data() + text.size() || value <= 0) {
        read_error(path, std::string("invalid PFM ") + what + " '" + text + "'");
    }
    return value;
}

void put_float_le(char* out, float v) {
    const uint32_t bits = std::bit_cast<uint32_t>(v);
    for (int i = 0; i < 4; ++i) {
        out[i] = char((bits >> (8 * i)) & 0xffu);
    }
}

// ---- LDR ----------------------------------------------------------------------------------

uint8_t to_byte(float v) {
    if (!(v > 0.0f)) {
        return 0;  // also NaN
    }
    if (v >= 1.0f) {
        return 255;
    }
    return uint8_t(std::lround(v * 255.0f));
}

std::vector<uint8_t> quantise(const Image& image) {
    std::vector<uint8_t> bytes(image.rgb.size());
    std::transform(image.rgb.begin(), image.rgb.end(), bytes.begin(), to_byte);
    return bytes;
}

void append_bytes(void* context, void* data, int size) {
    auto* buffer = static_cast<std::vector<char>*>(context);
    const char* begin = static_cast<const char*>(data);
    buffer->insert(buffer->end(), begin, begin + size);
}

}  // namespace

// ---- OpenEXR ------------------------------------------------------------------------------

void write_exr(const fs::path& path, const Image& image, const ImageMetadata& metadata,
               const ImageLayers& layers) {
    check_writable_image(path, image);
    Imf::Header header(image.width, image.height);
    header.compression() = Imf::ZIP_COMPRESSION;
    for (const char* name : kRgbNames) {
        header.channels().insert(name, Imf::Channel(Imf::FLOAT));
    }
    for (const auto& [name, data] : layers) {
        check_exr_name(path, name, "layer");
        if (name == "R" || name == "G" || name == "B") {
            write_error(path, "layer name '" + name + "' clashes with the colour channels");
        }
        if (data.size() != pixel_count(image)) {
            write_error(path, "layer '" + name + "' holds " + std::to_string(data.size()) +
                                  " floats, expected " + std::to_string(pixel_count(image)));
        }
        header.channels().insert(name, Imf::Channel(Imf::FLOAT));
    }
    for (const auto& [key, value] : metadata) {
        check_exr_name(path, key, "metadata key");
        if (header.find(key) != header.end()) {
            write_error(path, "metadata key '" + key + "' is a reserved OpenEXR attribute");
        }
        header.insert(key, Imf::StringAttribute(value));
    }

    write_output_stream(path, [&](std::ofstream& out) {
        Imf::StdOFStream stream(out, path.c_str());
        Imf::OutputFile file(stream, header);
        Imf::FrameBuffer frame;
        const size_t stride = 3 * sizeof(float);
        for (int c = 0; c < 3; ++c) {
            // OpenEXR only reads through output slices, but its API takes char*.
            frame.insert(
                kRgbNames[c],
                Imf::Slice(Imf::FLOAT,
                           const_cast<char*>(reinterpret_cast<const char*>(image.rgb.data() + c)),
                           stride, stride * size_t(image.width)));
        }
        for (const auto& [name, data] : layers) {
            frame.insert(name,
                         Imf::Slice(Imf::FLOAT,
                                    const_cast<char*>(reinterpret_cast<const char*>(data.data())),
                                    sizeof(float), sizeof(float) * size_t(image.width)));
        }
        file.setFrameBuffer(frame);
        file.writePixels(image.height);
    });
}

Image read_exr(const fs::path& path, ImageMetadata* metadata) {
    return read_exr_file(path, metadata, nullptr);
}

Image read_exr(const fs::path& path, ImageMetadata* metadata, ImageLayers* layers) {
    return read_exr_file(path, metadata, layers);
}

ExrShape read_exr_shape(const fs::path& path) {
    check_readable_file(path);
    check_exr_header(path);
    try {
        Imf::InputFile file(path.c_str());
        const Imath::Box2i window = file.header().dataWindow();
        ExrShape shape;
        shape.width = int64_t(window.max.x) - int64_t(window.min.x) + 1;
        shape.height = int64_t(window.max.y) - int64_t(window.min.y) + 1;
        const Imf::ChannelList& channels = file.header().channels();
        for (auto it = channels.begin(); it != channels.end(); ++it) ++shape.channels;
        return shape;
    } catch (const InputError&) {
        throw;
    } catch (const std::exception& e) {
        read_error(path, std::string("invalid or truncated OpenEXR file: ") + e.what());
    }
}

// ---- PFM ----------------------------------------------------------------------------------

void write_pfm(const fs::path& path, const Image& image) {
    check_writable_image(path, image);
    write_output_stream(path, [&](std::ofstream& out) {
        // A negative scale marks little-endian data; rows go from the bottom to the top.
        out << "PF\n" << image.width << ' ' << image.height << "\n-1.0\n";
        std::vector<char> row(size_t(image.width) * 3 * sizeof(float));
        for (int y = image.height - 1; y >= 0 && out; --y) {
            const float* src = image.pixel(0, y);
            for (size_t i = 0; i < size_t(image.width) * 3; ++i) {
                put_float_le(&row[i * 4], src[i]);
            }
            out.write(row.data(), std::streamsize(row.size()));
        }
    });
}

Image read_pfm(const fs::path& path) {
    check_readable_file(path);
    std::ifstream in(path, std::ios::binary);
    if (!in) {
        read_error(path, "cannot read: " + std::generic_category().message(errno));
    }
    std::error_code ec;
    const uintmax_t file_size = fs::file_size(path, ec);
    if (ec) {
        read_error(path, "cannot read: " + ec.message());
    }

    PfmHeaderReader header(in, path);
    const std::string magic = header.token("'PF' or 'Pf' signature");
    if (magic != "PF" && magic != "Pf") {
        read_error(path, "not a PFM file (expected 'PF' or 'Pf' signature)");
    }
    const int channels = magic == "PF" ? 3 : 1;
    const int width = parse_pfm_size(path, header.token("width"), "width");
    const int height = parse_pfm_size(path, header.token("height"), "height");
    const std::string scale_text = header.token("scale");
    float scale = 0.0f;
    const auto [end, scale_ec] =
        std::from_chars(scale_text.data(), scale_text.data() + scale_text.size(), scale);
    if (scale_ec != std::errc() || end != scale_text.data() + scale_text.size() ||
        !std::isfinite(scale) || scale == 0.0f) {
        read_error(path, "invalid PFM scale '" + scale_text + "' (a non-zero number expected)");
    }
    if (int64_t(width) * int64_t(height) > kMaxImagePixels) {
        read_error(path, "refusing an image of " + std::to_string(width) + "x" +
                             std::to_string(height) + " pixels");
    }

    const uint64_t row_bytes = uint64_t(width) * uint64_t(channels) * sizeof(float);
    const uint64_t expected = row_bytes * uint64_t(height);
    const std::streamoff header_end = in.tellg();
    if (header_end < 0) {
        read_error(path, "cannot read the PFM header");
    }
    uint64_t available = file_size - uint64_t(header_end);
    // Tolerate a "\r\n" line ending after the scale (files written on Windows).
    if (header.last_separator() == '\r' && available == expected + 1 && in.peek() == '\n') {
        in.get();
        --available;
    }
    if (available < expected) {
        read_error(path, "truncated PFM file: " + std::to_string(expected) +
                             " bytes of pixel data expected, " + std::to_string(available) +
                             " found");
    }
    if (available > expected) {
        read_error(path, "PFM file has " + std::to_string(available - expected) +
                             " unexpected bytes after the pixel data");
    }

    const bool swap = (scale < 0.0f) != (std::endian::native == std::endian::little);
    const float factor = std::fabs(scale);
    Image image(width, height);
    std::vector<uint32_t> row(size_t(width) * size_t(channels));
    for (int file_row = 0; file_row < height; ++file_row) {
        if (!in.read(reinterpret_cast<char*>(row.data()), std::streamsize(row_bytes))) {
            read_error(path, "truncated PFM file (read error in the pixel data)");
        }
        float* dst = image.pixel(0, height - 1 - file_row);
        for (size_t x = 0; x < size_t(width); ++x) {
            for (int c = 0; c < 3; ++c) {
                uint32_t bits = row[x * size_t(channels) + size_t(channels == 3 ? c : 0)];
                if (swap) {
                    bits = byte_swap(bits);
                }
                float v = std::bit_cast<float>(bits);
                if (factor != 1.0f) {
                    v *= factor;
                }
                dst[x * 3 + size_t(c)] = v;
            }
        }
    }
    return image;
}

// ---- By extension -------------------------------------------------------------------------

void write_hdr(const fs::path& path, const Image& image, const ImageMetadata& metadata,
               const ImageLayers& layers) {
    const std::string ext = lower_extension(path);
    if (ext == ".exr") {
        write_exr(path, image, metadata, layers);
    } else if (ext == ".pfm") {
        write_pfm(path, image);
    } else {
        write_error(path, "unsupported HDR format '" + ext + "' (expected .exr or .pfm)");
    }
}

Image read_hdr(const fs::path& path) {
    const std::string ext = lower_extension(path);
    if (ext == ".exr") {
        return read_exr(path);
    }
    if (ext == ".pfm") {
        return read_pfm(path);
    }
    read_error(path, "unsupported HDR format '" + ext + "' (expected .exr or .pfm)");
}

// ---- LDR ----------------------------------------------------------------------------------

void write_ldr(const fs::path& path, const Image& image) {
    const std::string ext = lower_extension(path);
    if (ext != ".png" && ext != ".ppm" && ext != ".bmp") {
        write_error(path, "unsupported LDR format '" + ext + "' (expected .png, .ppm or .bmp)");
    }
    check_writable_image(path, image);
    const std::vector<uint8_t> bytes = quantise(image);
    if (ext == ".ppm") {
        write_output_stream(path, [&](std::ofstream& out) {
            out << "P6\n" << image.width << ' ' << image.height << "\n255\n";
            out.write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
        });
        return;
    }
    std::vector<char> encoded;
    const int ok = ext == ".png"
                       ? stbi_write_png_to_func(append_bytes, &encoded, image.width, image.height,
                                                3, bytes.data(), image.width * 3)
                       : stbi_write_bmp_to_func(append_bytes, &encoded, image.width, image.height,
                                                3, bytes.data());
    if (ok == 0) {
        write_error(path, "image encoder failed");
    }
    write_output_stream(path, [&](std::ofstream& out) {
        out.write(encoded.data(), std::streamsize(encoded.size()));
    });
}

}  // namespace cierzo
