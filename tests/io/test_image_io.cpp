// Tests for the image files: bit-exact float32 EXR (metadata, layers), PFM row order and
// byte order, 8-bit PNG/PPM/BMP contents, atomic writes and the rejection of bad files.
#include "core/error.h"
#include "io/output_file.h"
#include "io/image.h"

#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfInputFile.h>
#include <OpenEXR/ImfOutputFile.h>
#include <gtest/gtest.h>
#include <stb/stb_image.h>

#include <bit>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <iterator>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include <sys/stat.h>
#include <unistd.h>

namespace cierzo {
namespace {

namespace fs = std::filesystem;

// A fresh directory per test, removed afterwards.
class ImageIoTest : public ::testing::Test {
protected:
    void SetUp() override {
        const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
        dir_ = fs::temp_directory_path() /
               ("cierzo_test_image_io_" + std::to_string(::getpid()) + "_" + info->name());
        fs::remove_all(dir_);
        fs::create_directories(dir_);
    }
    void TearDown() override {
        std::error_code ignored;
        fs::permissions(dir_, fs::perms::owner_all, fs::perm_options::add, ignored);
        fs::remove_all(dir_, ignored);
    }
    fs::path path(const std::string& name) const { return dir_ / name; }
    std::vector<std::string> directory_entries() const {
        std::vector<std::string> names;
        for (const auto& entry : fs::directory_iterator(dir_)) {
            names.push_back(entry.path().filename().string());
        }
        return names;
    }

    fs::path dir_;
};

std::string read_bytes(const fs::path& path) {
    std::ifstream in(path, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

void write_bytes(const fs::path& path, const std::string& bytes) {
    std::ofstream out(path, std::ios::binary);
    out.write(bytes.data(), std::streamsize(bytes.size()));
}

// An image whose every component is different, so swapped rows or channels are noticed.
Image numbered_image(int width, int height) {
    Image image(width, height);
    for (size_t i = 0; i < image.rgb.size(); ++i) {
        image.rgb[i] = 0.25f * float(i) + 0.125f;
    }
    return image;
}

void expect_bit_identical(const std::vector<float>& a, const std::vector<float>& b) {
    ASSERT_EQ(a.size(), b.size());
    for (size_t i = 0; i < a.size(); ++i) {
        EXPECT_EQ(std::bit_cast<uint32_t>(a[i]), std::bit_cast<uint32_t>(b[i]))
            << "component " << i << ": " << a[i] << " vs " << b[i];
    }
}

// Expects `f` to throw InputError whose message contains every string in `parts`.
template <class F>
void expect_input_error(F&& f, const std::vector<std::string>& parts) {
    try {
        f();
        ADD_FAILURE() << "no InputError thrown";
    } catch (const InputError& e) {
        const std::string message = e.what();
        for (const std::string& part : parts) {
            EXPECT_NE(message.find(part), std::string::npos)
                << "'" << part << "' missing from: " << message;
        }
    }
}

std::string float_bytes(float v, bool big_endian) {
    const uint32_t bits = std::bit_cast<uint32_t>(v);
    std::string out(4, '\0');
    for (int i = 0; i < 4; ++i) {
        const int shift = big_endian ? 8 * (3 - i) : 8 * i;
        out[size_t(i)] = char((bits >> shift) & 0xffu);
    }
    return out;
}

Image special_values_image() {
    const std::vector<float> values = {0.0f,
                                       -0.0f,
                                       1.0f,
                                       1e30f,
                                       -1e30f,
                                       1e-30f,
                                       std::numeric_limits<float>::denorm_min(),
                                       1e-40f,
                                       -3e-42f,
                                       std::numeric_limits<float>::max(),
                                       std::numeric_limits<float>::min(),
                                       3.14159265f,
                                       0.1f,
                                       65504.0f,
                                       65520.0f,
                                       1.0f / 3.0f,
                                       123456.789f,
                                       -7.5f};
    Image image(3, 2);
    image.rgb = values;
    return image;
}

// ---- OpenEXR ------------------------------------------------------------------------------

TEST_F(ImageIoTest, ExrRoundTripIsBitExactForTinyHugeAndDenormalValues) {
    const Image image = special_values_image();
    write_exr(path("a.exr"), image);
    const Image back = read_exr(path("a.exr"));
    EXPECT_EQ(back.width, 3);
    EXPECT_EQ(back.height, 2);
    expect_bit_identical(back.rgb, image.rgb);
}

TEST_F(ImageIoTest, ExrIsFloat32WithZipCompression) {
    write_exr(path("a.exr"), numbered_image(4, 3));
    Imf::InputFile file(path("a.exr").c_str());
    EXPECT_EQ(file.header().compression(), Imf::ZIP_COMPRESSION);
    std::vector<std::string> names;
    for (auto it = file.header().channels().begin(); it != file.header().channels().end(); ++it) {
        names.push_back(it.name());
        EXPECT_EQ(it.channel().type, Imf::FLOAT) << it.name();
    }
    EXPECT_EQ(names, (std::vector<std::string>{"B", "G", "R"}));
}

TEST_F(ImageIoTest, ExrKeepsRowsAndChannelsInPlace) {
    Image image(5, 3);
    image.pixel(0, 0)[0] = 10.0f;  // top-left, red only
    image.pixel(4, 2)[2] = 20.0f;  // bottom-right, blue only
    write_exr(path("a.exr"), image);
    const Image back = read_exr(path("a.exr"));
    ASSERT_EQ(back.width, 5);
    ASSERT_EQ(back.height, 3);
    EXPECT_EQ(back.pixel(0, 0)[0], 10.0f);
    EXPECT_EQ(back.pixel(4, 2)[2], 20.0f);
    expect_bit_identical(back.rgb, image.rgb);
}

TEST_F(ImageIoTest, ExrMetadataRoundTrip) {
    const ImageMetadata metadata = {
        {"cierzo:spp", "64"}, {"cierzo:scene", "cornell box, ñ and spaces"}, {"cierzo:empty", ""}};
    write_exr(path("a.exr"), numbered_image(2, 2), metadata);
    ImageMetadata back = {{"stale", "entry"}};
    read_exr(path("a.exr"), &back);
    EXPECT_EQ(back, metadata);
}

TEST_F(ImageIoTest, ExrRefusesReservedOrEmptyMetadataKeys) {
    expect_input_error(
        [&] {
            write_exr(path("a.exr"), numbered_image(2, 2), {{"channels", "x"}});
        },
        {path("a.exr").string(), "channels"});
    expect_input_error(
        [&] {
            write_exr(path("a.exr"), numbered_image(2, 2), {{"", "x"}});
        },
        {path("a.exr").string()});
    EXPECT_FALSE(fs::exists(path("a.exr")));
}

TEST_F(ImageIoTest, ExrExtraLayersRoundTrip) {
    const Image image = numbered_image(4, 3);
    ImageLayers layers;
    float offset = 0.0f;
    for (const char* name : {"variance.R", "variance.G", "variance.B", "albedo.R"}) {
        std::vector<float> data(12);
        offset += 1000.0f;
        for (size_t i = 0; i < data.size(); ++i) {
            data[i] = offset + 0.5f * float(i);  // distinct in every layer
        }
        layers[name] = data;
    }
    layers["variance.G"][5] = 1e-41f;
    write_exr(path("a.exr"), image, {}, layers);
    ImageLayers back;
    ImageMetadata metadata;
    const Image colour = read_exr(path("a.exr"), &metadata, &back);
    expect_bit_identical(colour.rgb, image.rgb);
    ASSERT_EQ(back.size(), layers.size());
    for (const auto& [name, data] : layers) {
        ASSERT_TRUE(back.count(name)) << name;
        expect_bit_identical(back.at(name), data);
    }
}

TEST_F(ImageIoTest, ExrRefusesBadLayers) {
    expect_input_error(
        [&] {
            write_exr(path("a.exr"), numbered_image(2, 2), {}, {{"depth", {1.0f, 2.0f}}});
        },
        {path("a.exr").string(), "depth"});
    expect_input_error(
        [&] {
            write_exr(path("a.exr"), numbered_image(2, 2), {}, {{"G", std::vector<float>(4)}});
        },
        {path("a.exr").string(), "'G'"});
}

TEST_F(ImageIoTest, ExrWithDataWindowOffsetIsRead) {
    Imf::Header header(100, 100);
    header.dataWindow() = Imath::Box2i(Imath::V2i(10, 20), Imath::V2i(12, 21));
    for (const char* name : {"R", "G", "B"}) {
        header.channels().insert(name, Imf::Channel(Imf::FLOAT));
    }
    std::vector<float> rgb(3 * 2 * 3);
    for (size_t i = 0; i < rgb.size(); ++i) {
        rgb[i] = float(i);
    }
    {
        Imf::OutputFile file(path("offset.exr").c_str(), header);
        Imf::FrameBuffer frame;
        for (int c = 0; c < 3; ++c) {
            frame.insert(std::string(1, "RGB"[c]),
                         Imf::Slice::Make(Imf::FLOAT, rgb.data() + c, header.dataWindow(),
                                          3 * sizeof(float), 3 * 3 * sizeof(float)));
        }
        file.setFrameBuffer(frame);
        file.writePixels(2);
    }
    const Image back = read_exr(path("offset.exr"));
    EXPECT_EQ(back.width, 3);
    EXPECT_EQ(back.height, 2);
    expect_bit_identical(back.rgb, rgb);
}

TEST_F(ImageIoTest, ExrWithoutRgbChannelsIsRejected) {
    Imf::Header header(2, 2);
    header.channels().insert("Y", Imf::Channel(Imf::FLOAT));
    std::vector<float> y(4, 1.0f);
    {
        Imf::OutputFile file(path("grey.exr").c_str(), header);
        Imf::FrameBuffer frame;
        frame.insert("Y", Imf::Slice(Imf::FLOAT, reinterpret_cast<char*>(y.data()), sizeof(float),
                                     2 * sizeof(float)));
        file.setFrameBuffer(frame);
        file.writePixels(2);
    }
    expect_input_error([&] { read_exr(path("grey.exr")); },
                       {path("grey.exr").string(), "missing channel R"});
}

TEST_F(ImageIoTest, ExrWithAbsurdDimensionsIsRejectedBeforeAllocating) {
    Imf::Header header(100000, 100000);
    for (const char* name : {"R", "G", "B"}) {
        header.channels().insert(name, Imf::Channel(Imf::FLOAT));
    }
    { Imf::OutputFile file(path("huge.exr").c_str(), header); }  // header only, no pixels
    expect_input_error([&] { read_exr(path("huge.exr")); },
                       {path("huge.exr").string(), "100000x100000"});
}

TEST_F(ImageIoTest, TruncatedExrIsRejected) {
    Image image(64, 64);
    for (size_t i = 0; i < image.rgb.size(); ++i) {
        image.rgb[i] = std::sin(float(i) * 0.37f) * 100.0f;  // poorly compressible
    }
    write_exr(path("full.exr"), image);
    const std::string bytes = read_bytes(path("full.exr"));
    for (size_t keep : {bytes.size() / 2, bytes.size() - 10, size_t(200)}) {
        write_bytes(path("cut.exr"), bytes.substr(0, keep));
        expect_input_error([&] { read_exr(path("cut.exr")); },
                           {path("cut.exr").string(), "truncated"});
    }
}

TEST_F(ImageIoTest, GarbageAndMissingFilesAreRejectedWithTheirName) {
    write_bytes(path("garbage.exr"), "this is certainly not an OpenEXR file\n");
    expect_input_error([&] { read_exr(path("garbage.exr")); }, {path("garbage.exr").string()});
    write_bytes(path("empty.exr"), "");
    expect_input_error([&] { read_exr(path("empty.exr")); }, {path("empty.exr").string()});
    expect_input_error([&] { read_exr(path("none.exr")); },
                       {path("none.exr").string(), "No such file or directory"});
    expect_input_error([&] { read_pfm(path("none.pfm")); },
                       {path("none.pfm").string(), "No such file or directory"});
    write_bytes(path("garbage.pfm"), "P6\n1 1\n255\nabc");
    expect_input_error([&] { read_pfm(path("garbage.pfm")); },
                       {path("garbage.pfm").string(), "not a PFM file"});
    write_pfm(path("real.pfm"), numbered_image(2, 2));
    fs::copy_file(path("real.pfm"), path("pfm_named.exr"));
    expect_input_error([&] { read_exr(path("pfm_named.exr")); }, {path("pfm_named.exr").string()});
}

// ---- PFM ----------------------------------------------------------------------------------

TEST_F(ImageIoTest, PfmRoundTripIsBitExact) {
    const Image image = special_values_image();
    write_pfm(path("a.pfm"), image);
    const Image back = read_pfm(path("a.pfm"));
    EXPECT_EQ(back.width, 3);
    EXPECT_EQ(back.height, 2);
    expect_bit_identical(back.rgb, image.rgb);
}

TEST_F(ImageIoTest, PfmIsLittleEndianWithRowsFromTheBottom) {
    Image image(4, 3);
    image.pixel(0, 0)[0] = image.pixel(0, 0)[1] = image.pixel(0, 0)[2] = 100.0f;  // top-left
    image.pixel(3, 2)[1] = 7.0f;  // bottom-right, green
    write_pfm(path("a.pfm"), image);
    const std::string bytes = read_bytes(path("a.pfm"));
    const std::string header = "PF\n4 3\n-1.0\n";
    ASSERT_EQ(bytes.size(), header.size() + 4 * 3 * 3 * 4);
    EXPECT_EQ(bytes.substr(0, header.size()), header);
    const size_t row = 4 * 3 * 4;
    // The file starts with the bottom row: its last pixel's green is 7.
    EXPECT_EQ(bytes.substr(header.size() + 3 * 12 + 4, 4), float_bytes(7.0f, false));
    // The top row is stored last and starts with the bright pixel.
    EXPECT_EQ(bytes.substr(header.size() + 2 * row, 4), float_bytes(100.0f, false));
    EXPECT_EQ(bytes.substr(header.size(), 4), float_bytes(0.0f, false));

    const Image back = read_pfm(path("a.pfm"));
    EXPECT_EQ(back.pixel(0, 0)[0], 100.0f);
    EXPECT_EQ(back.pixel(0, 2)[0], 0.0f);
    EXPECT_EQ(back.pixel(3, 2)[1], 7.0f);
}

TEST_F(ImageIoTest, BigEndianPfmIsRead) {
    // 2x2, positive scale = big-endian; first stored row is the bottom one.
    std::string bytes = "PF\n2 2\n1.0\n";
    const float bottom[6] = {1.0f, 2.0f, 3.0f, 4.0f, 5.0f, 6.0f};
    const float top[6] = {-1.5f, 1e30f, 0.25f, 8.0f, 9.0f, 1e-40f};
    for (float v : bottom) {
        bytes += float_bytes(v, true);
    }
    for (float v : top) {
        bytes += float_bytes(v, true);
    }
    write_bytes(path("be.pfm"), bytes);
    const Image image = read_pfm(path("be.pfm"));
    ASSERT_EQ(image.width, 2);
    ASSERT_EQ(image.height, 2);
    std::vector<float> expected(top, top + 6);
    expected.insert(expected.end(), bottom, bottom + 6);
    expect_bit_identical(image.rgb, expected);
}

TEST_F(ImageIoTest, GreyscalePfmIsReplicatedToRgb) {
    std::string bytes = "Pf\n3 1\n-1.0\n";
    for (float v : {0.5f, 2.0f, -4.0f}) {
        bytes += float_bytes(v, false);
    }
    write_bytes(path("grey.pfm"), bytes);
    const Image image = read_pfm(path("grey.pfm"));
    ASSERT_EQ(image.width, 3);
    ASSERT_EQ(image.height, 1);
    EXPECT_EQ(image.rgb,
              (std::vector<float>{0.5f, 0.5f, 0.5f, 2.0f, 2.0f, 2.0f, -4.0f, -4.0f, -4.0f}));
}

TEST_F(ImageIoTest, PfmScaleMagnitudeMultipliesAndCommentsAndCrLfAreAccepted) {
    std::string bytes = "PF\r\n# made by hand\r\n1 1\r\n-2.0\r\n";
    for (float v : {1.5f, 0.25f, -3.0f}) {
        bytes += float_bytes(v, false);
    }
    write_bytes(path("s.pfm"), bytes);
    const Image image = read_pfm(path("s.pfm"));
    EXPECT_EQ(image.rgb, (std::vector<float>{3.0f, 0.5f, -6.0f}));
}

TEST_F(ImageIoTest, BadPfmFilesAreRejectedWithTheirName) {
    write_pfm(path("good.pfm"), numbered_image(3, 2));
    const std::string good = read_bytes(path("good.pfm"));
    const std::string data = good.substr(good.find("-1.0\n") + 5);
    const std::vector<std::pair<std::string, std::string>> cases = {
        {good.substr(0, good.size() - 5), "truncated"},
        {good.substr(0, 9), "truncated"},
        {good + "xyz", "unexpected"},
        {"PF\n-3 2\n-1.0\n" + data, "width"},
        {"PF\n3 0\n-1.0\n" + data, "height"},
        {"PF\n3 2x\n-1.0\n" + data, "height"},
        {"PF\n3 2\n0\n" + data, "scale"},
        {"PF\n3 2\nabc\n" + data, "scale"},
        {"PF\n3 2\nnan\n" + data, "scale"},
        {"PF\n100000 100000\n-1.0\n" + data, "100000x100000"},
        {"PF\n99999999999 1\n-1.0\n" + data, "width"},
        {"", "truncated"},
        {"PX\n3 2\n-1.0\n" + data, "not a PFM file"},
    };
    for (const auto& [bytes, reason] : cases) {
        SCOPED_TRACE(reason);
        write_bytes(path("bad.pfm"), bytes);
        expect_input_error([&] { read_pfm(path("bad.pfm")); }, {path("bad.pfm").string(), reason});
    }
}

TEST_F(ImageIoTest, HdrFormatFollowsTheExtension) {
    const Image image = numbered_image(3, 2);
    write_hdr(path("a.EXR"), image);
    write_hdr(path("b.pfm"), image);
    EXPECT_EQ(read_bytes(path("a.EXR")).substr(0, 4), std::string("\x76\x2f\x31\x01", 4));
    EXPECT_EQ(read_bytes(path("b.pfm")).substr(0, 3), "PF\n");
    expect_bit_identical(read_hdr(path("a.EXR")).rgb, image.rgb);
    expect_bit_identical(read_hdr(path("b.pfm")).rgb, image.rgb);
    expect_input_error([&] { write_hdr(path("c.tiff"), image); }, {path("c.tiff").string()});
    expect_input_error([&] { read_hdr(path("b.png")); }, {path("b.png").string()});
    EXPECT_FALSE(fs::exists(path("c.tiff")));
}

// ---- LDR ----------------------------------------------------------------------------------

// Values and their expected bytes: clamp to [0, 1], then round(v * 255); NaN gives 0.
const std::vector<float> kLdrValues = {0.0f,          1.0f,         0.5f,         -0.3f,
                                       2.0f,          100.4f / 255, 100.6f / 255, 0.2f,
                                       std::nanf(""), 1.0f / 255,   0.4f / 255,   0.999f};
const std::vector<uint8_t> kLdrBytes = {0, 255, 128, 0, 255, 100, 101, 51, 0, 1, 0, 255};

Image ldr_test_image() {
    Image image(2, 2);  // 12 components
    image.rgb = kLdrValues;
    return image;
}

TEST_F(ImageIoTest, PpmIsBinaryP6WithRoundedValues) {
    write_ldr(path("a.ppm"), ldr_test_image());
    const std::string bytes = read_bytes(path("a.ppm"));
    std::istringstream in(bytes);
    std::string magic;
    int width = 0;
    int height = 0;
    int max_value = 0;
    in >> magic >> width >> height >> max_value;
    in.get();  // the single whitespace before the pixels
    EXPECT_EQ(magic, "P6");
    EXPECT_EQ(width, 2);
    EXPECT_EQ(height, 2);
    EXPECT_EQ(max_value, 255);
    const std::string pixels = bytes.substr(size_t(in.tellg()));
    ASSERT_EQ(pixels.size(), kLdrBytes.size());
    for (size_t i = 0; i < pixels.size(); ++i) {
        EXPECT_EQ(uint8_t(pixels[i]), kLdrBytes[i]) << "component " << i;
    }
}

void expect_decodes_to(const fs::path& path, int width, int height,
                       const std::vector<uint8_t>& expected) {
    const std::string bytes = read_bytes(path);
    int w = 0;
    int h = 0;
    int channels = 0;
    const auto* encoded = reinterpret_cast<const unsigned char*>(bytes.data());
    unsigned char* data = stbi_load_from_memory(encoded, int(bytes.size()), &w, &h, &channels, 3);
    ASSERT_NE(data, nullptr) << path;
    EXPECT_EQ(w, width);
    EXPECT_EQ(h, height);
    EXPECT_EQ(std::vector<uint8_t>(data, data + expected.size()), expected);
    stbi_image_free(data);
}

TEST_F(ImageIoTest, PngHasSignatureSizeAndPixels) {
    write_ldr(path("a.png"), ldr_test_image());
    const std::string bytes = read_bytes(path("a.png"));
    ASSERT_GT(bytes.size(), 24u);
    EXPECT_EQ(bytes.substr(0, 8), std::string("\x89PNG\r\n\x1a\n", 8));
    EXPECT_EQ(bytes.substr(12, 4), "IHDR");
    EXPECT_EQ(bytes.substr(16, 8), std::string("\0\0\0\x02\0\0\0\x02", 8));  // 2 x 2
    expect_decodes_to(path("a.png"), 2, 2, kLdrBytes);
}

TEST_F(ImageIoTest, BmpHasSignatureAndPixels) {
    Image image(2, 2);
    image.rgb = kLdrValues;
    write_ldr(path("a.bmp"), image);
    EXPECT_EQ(read_bytes(path("a.bmp")).substr(0, 2), "BM");
    expect_decodes_to(path("a.bmp"), 2, 2, kLdrBytes);
}

TEST_F(ImageIoTest, LdrKeepsTopRowFirst) {
    Image image(3, 2);
    image.pixel(0, 0)[0] = 1.0f;  // top-left red
    write_ldr(path("a.png"), image);
    std::vector<uint8_t> expected(18, 0);
    expected[0] = 255;
    expect_decodes_to(path("a.png"), 3, 2, expected);
}

TEST_F(ImageIoTest, BadLdrRequestsAreRejected) {
    expect_input_error([&] { write_ldr(path("a.jpg"), ldr_test_image()); },
                       {path("a.jpg").string(), ".jpg"});
    expect_input_error([&] { write_ldr(path("a.png"), Image()); }, {path("a.png").string()});
    Image inconsistent(2, 2);
    inconsistent.rgb.pop_back();
    expect_input_error([&] { write_ldr(path("a.png"), inconsistent); }, {path("a.png").string()});
    expect_input_error([&] { write_exr(path("a.exr"), Image(0, 3)); }, {path("a.exr").string()});
    expect_input_error([&] { write_pfm(path("a.pfm"), Image(3, 0)); }, {path("a.pfm").string()});
    Image negative;
    negative.width = -2;
    negative.height = -2;
    negative.rgb.resize(12);
    expect_input_error([&] { write_pfm(path("a.pfm"), negative); }, {path("a.pfm").string()});
    EXPECT_TRUE(directory_entries().empty());
}

// ---- Atomic writes ------------------------------------------------------------------------

TEST_F(ImageIoTest, WritingIntoAMissingDirectoryNamesThePath) {
    const Image image = numbered_image(2, 2);
    for (const std::string name : {"x.exr", "x.pfm", "x.png", "x.ppm", "x.bmp"}) {
        const fs::path target = path("missing") / name;
        expect_input_error(
            [&] {
                if (name.ends_with(".exr") || name.ends_with(".pfm")) {
                    write_hdr(target, image);
                } else {
                    write_ldr(target, image);
                }
            },
            {target.string() + ": cannot write: folder '" + path("missing").string() +
             "' does not exist"});
    }
    EXPECT_FALSE(fs::exists(path("missing")));
}

TEST_F(ImageIoTest, WritingOverADirectoryIsRefused) {
    fs::create_directory(path("out.exr"));
    expect_input_error([&] { write_exr(path("out.exr"), numbered_image(2, 2)); },
                       {path("out.exr").string() + ": cannot write: it is a folder"});
    EXPECT_TRUE(fs::is_directory(path("out.exr")));
    EXPECT_EQ(directory_entries(), std::vector<std::string>{"out.exr"});
}

TEST_F(ImageIoTest, WritingIntoAReadOnlyDirectoryIsRefused) {
    if (::geteuid() == 0) {
        GTEST_SKIP() << "root ignores directory permissions";
    }
    fs::create_directory(path("ro"));
    fs::permissions(path("ro"), fs::perms::owner_read | fs::perms::owner_exec);
    expect_input_error([&] { write_pfm(path("ro") / "a.pfm", numbered_image(2, 2)); },
                       {(path("ro") / "a.pfm").string(), "Permission denied"});
}

TEST_F(ImageIoTest, AtomicWriteReplacesTheFileThroughATemporaryInTheSameFolder) {
    write_bytes(path("t.bin"), "old contents");
    fs::path seen;
    write_output(path("t.bin"), [&](const fs::path& tmp) {
        seen = tmp;
        EXPECT_EQ(tmp.parent_path(), path("t.bin").parent_path());
        EXPECT_NE(tmp, path("t.bin"));
        EXPECT_TRUE(fs::exists(tmp));
        EXPECT_EQ(read_bytes(path("t.bin")), "old contents");  // untouched while writing
        write_bytes(tmp, "new contents");
    });
    EXPECT_EQ(read_bytes(path("t.bin")), "new contents");
    EXPECT_FALSE(fs::exists(seen));
    EXPECT_EQ(directory_entries(), std::vector<std::string>{"t.bin"});
}

TEST_F(ImageIoTest, FailingWriterLeavesTheExistingFileByteIdentical) {
    write_exr(path("keep.exr"), numbered_image(3, 3));
    const std::string before = read_bytes(path("keep.exr"));

    expect_input_error(
        [&] {
            write_output(path("keep.exr"), [&](const fs::path& tmp) {
                write_bytes(tmp, "half a file");
                throw std::runtime_error("simulated disk failure");
            });
        },
        {path("keep.exr").string() + ": cannot write: simulated disk failure"});
    EXPECT_EQ(read_bytes(path("keep.exr")), before);

    expect_input_error(
        [&] {
            write_output_stream(path("keep.exr"), [](std::ofstream& out) {
                out << "partial";
                out.setstate(std::ios::badbit);
            });
        },
        {path("keep.exr").string(), "write error"});
    EXPECT_EQ(read_bytes(path("keep.exr")), before);

    // An InputError from the writer passes through unchanged.
    expect_input_error(
        [&] {
            write_output(path("keep.exr"),
                         [](const fs::path&) { throw InputError("writer's own message"); });
        },
        {"writer's own message"});
    EXPECT_EQ(read_bytes(path("keep.exr")), before);

    // A write refused by the image writer itself does not touch the file either.
    expect_input_error(
        [&] {
            write_exr(path("keep.exr"), numbered_image(3, 3), {}, {{"bad", {1.0f}}});
        },
        {path("keep.exr").string()});
    EXPECT_EQ(read_bytes(path("keep.exr")), before);
    EXPECT_EQ(directory_entries(), std::vector<std::string>{"keep.exr"});
}

TEST_F(ImageIoTest, ImageWritersReplaceAnExistingFile) {
    write_pfm(path("a.pfm"), numbered_image(2, 2));
    const Image second = numbered_image(3, 1);
    write_pfm(path("a.pfm"), second);
    expect_bit_identical(read_pfm(path("a.pfm")).rgb, second.rgb);
    EXPECT_EQ(directory_entries(), std::vector<std::string>{"a.pfm"});
}

TEST_F(ImageIoTest, RelativePathsInTheWorkingDirectoryWork) {
    const fs::path previous = fs::current_path();
    fs::current_path(dir_);
    const Image image = numbered_image(2, 1);
    write_pfm("plain.pfm", image);
    fs::current_path(previous);
    expect_bit_identical(read_pfm(path("plain.pfm")).rgb, image.rgb);
}

}  // namespace
}  // namespace cierzo
