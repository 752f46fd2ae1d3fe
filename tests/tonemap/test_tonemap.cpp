// Tests for the tone-mapping operators on hand-computed values (clamp, equalize,
// equalize-clamp, gamma, clamp-gamma, reinhard), exposure, bad samples and options, and the
// cierzo-tonemap program run end to end.
#include "core/error.h"
#include "io/image.h"
#include "tonemap/tonemap.h"
#include "support/emulator.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include <sys/wait.h>
#include <unistd.h>

namespace cierzo {
namespace {

namespace fs = std::filesystem;

constexpr float kInf = std::numeric_limits<float>::infinity();

// A one-row image holding `values` as consecutive components (padded with zeros to whole
// pixels); returns the tone-mapped components in the same order.
std::vector<float> map_values(const std::vector<float>& values, const TonemapOptions& options,
                              TonemapStats* stats = nullptr) {
    const int width = int((values.size() + 2) / 3);
    Image image(width, 1);
    std::copy(values.begin(), values.end(), image.rgb.begin());
    const Image out = tonemap(image, options, stats);
    EXPECT_EQ(out.width, width);
    EXPECT_EQ(out.height, 1);
    return std::vector<float>(out.rgb.begin(), out.rgb.begin() + std::ptrdiff_t(values.size()));
}

TonemapOptions op(const std::string& name, std::optional<float> clamp = std::nullopt,
                  float gamma = 2.2f, float exposure = 0.0f) {
    TonemapOptions options;
    options.op = name;
    options.clamp = clamp;
    options.gamma = gamma;
    options.exposure = exposure;
    return options;
}

void expect_near_all(const std::vector<float>& actual, const std::vector<float>& expected) {
    ASSERT_EQ(actual.size(), expected.size());
    for (size_t i = 0; i < actual.size(); ++i) {
        EXPECT_NEAR(actual[i], expected[i], 1e-6f) << "component " << i;
    }
}

TEST(Tonemap, OperatorNamesAndDefaults) {
    EXPECT_EQ(tonemap_operator_names(),
              (std::vector<std::string>{"clamp", "equalize", "equalize-clamp", "gamma",
                                        "clamp-gamma", "reinhard"}));
    ASSERT_EQ(tonemap_operators().size(), 6u);
    for (const TonemapOperatorInfo& info : tonemap_operators()) {
        EXPECT_FALSE(info.formula.empty()) << info.name;
    }
    const TonemapOptions defaults;
    EXPECT_EQ(defaults.op, "gamma");
    EXPECT_EQ(defaults.exposure, 0.0f);
    EXPECT_EQ(defaults.gamma, 2.2f);
    EXPECT_FALSE(defaults.clamp.has_value());
}

TEST(Tonemap, ClampDividesByTheClampValueAndSaturatesAboveIt) {
    expect_near_all(map_values({1.0f, 3.0f, 0.0f, 2.0f, 0.5f, 10.0f}, op("clamp", 2.0f)),
                    {0.5f, 1.0f, 0.0f, 1.0f, 0.25f, 1.0f});
    expect_near_all(map_values({0.5f, 1.5f, 0.25f}, op("clamp")), {0.5f, 1.0f, 0.25f});
}

TEST(Tonemap, EqualizeDividesByTheLargestComponent) {
    // Channels are mapped independently but share the image maximum (8, in another pixel).
    expect_near_all(map_values({1.0f, 2.0f, 4.0f, 8.0f, 0.0f, 6.0f}, op("equalize")),
                    {0.125f, 0.25f, 0.5f, 1.0f, 0.0f, 0.75f});
}

TEST(Tonemap, EqualizeClampUsesTheClampValue) {
    expect_near_all(map_values({2.0f, 8.0f, 4.0f}, op("equalize-clamp", 4.0f)), {0.5f, 1.0f, 1.0f});
    expect_near_all(map_values({0.75f, 8.0f, 1.0f}, op("equalize-clamp")), {0.75f, 1.0f, 1.0f});
}

TEST(Tonemap, GammaEqualizesThenAppliesTheCurve) {
    // max = 4: 0.25 * max -> 0.25^(1/2) = 0.5; 0.5625 * max -> 0.75.
    expect_near_all(map_values({1.0f, 4.0f, 0.0f, 2.25f}, op("gamma", std::nullopt, 2.0f)),
                    {0.5f, 1.0f, 0.0f, 0.75f});
    const float default_curve = std::pow(0.5f, 1.0f / 2.2f);
    expect_near_all(map_values({1.0f, 2.0f, 0.0f}, op("gamma")), {default_curve, 1.0f, 0.0f});
}

TEST(Tonemap, ClampGammaClampsThenAppliesTheCurve) {
    expect_near_all(map_values({0.5f, 2.0f, 5.0f, 0.125f}, op("clamp-gamma", 2.0f, 2.0f)),
                    {0.5f, 1.0f, 1.0f, 0.25f});
    expect_near_all(map_values({0.5f, 3.0f, 1.0f}, op("clamp-gamma")),
                    {std::pow(0.5f, 1.0f / 2.2f), 1.0f, 1.0f});
}

TEST(Tonemap, ReinhardIsPerChannel) {
    expect_near_all(map_values({1.0f, 3.0f, 0.0f, 9.0f, 1e30f, 0.25f}, op("reinhard")),
                    {0.5f, 0.75f, 0.0f, 0.9f, 1.0f, 0.2f});
}

TEST(Tonemap, ExposureScalesByAPowerOfTwoBeforeTheOperator) {
    expect_near_all(map_values({0.25f, 0.5f, 1.0f}, op("clamp", std::nullopt, 2.2f, 1.0f)),
                    {0.5f, 1.0f, 1.0f});
    expect_near_all(map_values({2.0f, 4.0f, 1.0f}, op("clamp", std::nullopt, 2.2f, -2.0f)),
                    {0.5f, 1.0f, 0.25f});
    expect_near_all(map_values({0.5f, 1.5f, 0.0f}, op("reinhard", std::nullopt, 2.2f, 1.0f)),
                    {0.5f, 0.75f, 0.0f});
    // Equalising divides the exposure out again.
    expect_near_all(map_values({1.0f, 2.0f, 4.0f}, op("equalize", std::nullopt, 2.2f, 3.0f)),
                    {0.25f, 0.5f, 1.0f});
}

TEST(Tonemap, NonFiniteAndNegativeValuesBecomeZeroAndAreCounted) {
    const float nan = std::numeric_limits<float>::quiet_NaN();
    for (const std::string& name : tonemap_operator_names()) {
        SCOPED_TRACE(name);
        TonemapStats stats;
        const auto out = map_values({nan, kInf, -kInf, -1.0f, 0.5f, -0.0f, 1.0f, -1e30f, 0.25f},
                                    op(name), &stats);
        EXPECT_EQ(stats.non_finite, 3u);
        EXPECT_EQ(stats.negative, 2u);
        for (size_t i : {0u, 1u, 2u, 3u, 5u, 7u}) {
            EXPECT_EQ(out[i], 0.0f) << "component " << i;
        }
        for (float v : out) {
            EXPECT_TRUE(v >= 0.0f && v <= 1.0f) << v;
        }
    }
    // Infinity does not become the maximum that equalize divides by.
    expect_near_all(map_values({kInf, 0.5f, 0.25f}, op("equalize")), {0.0f, 1.0f, 0.5f});
}

TEST(Tonemap, BlackImageStaysBlack) {
    for (const std::string& name : tonemap_operator_names()) {
        SCOPED_TRACE(name);
        expect_near_all(map_values({0.0f, -2.0f, 0.0f}, op(name)), {0.0f, 0.0f, 0.0f});
    }
}

TEST(Tonemap, OutputAlwaysLiesInTheUnitInterval) {
    std::mt19937 rng(7);
    std::lognormal_distribution<float> big(0.0f, 8.0f);
    Image image(64, 16);
    for (float& v : image.rgb) {
        v = big(rng);
    }
    image.rgb[5] = std::numeric_limits<float>::max();
    for (const std::string& name : tonemap_operator_names()) {
        SCOPED_TRACE(name);
        TonemapOptions options = op(name, std::nullopt, 2.2f, 64.0f);
        const Image out = tonemap(image, options);
        for (float v : out.rgb) {
            ASSERT_TRUE(v >= 0.0f && v <= 1.0f) << v;
        }
    }
}

TEST(Tonemap, UnknownOperatorListsTheValidNames) {
    Image image(1, 1);
    for (const std::string bad : {"filmic", "", "Clamp"}) {
        try {
            tonemap(image, op(bad));
            ADD_FAILURE() << "no error for '" << bad << "'";
        } catch (const InputError& e) {
            const std::string message = e.what();
            EXPECT_NE(message.find("'" + bad + "'"), std::string::npos) << message;
            for (const std::string& name : tonemap_operator_names()) {
                EXPECT_NE(message.find(name), std::string::npos) << message;
            }
        }
    }
}

TEST(Tonemap, InvalidOptionsAreRejected) {
    Image image(1, 1);
    const float nan = std::numeric_limits<float>::quiet_NaN();
    EXPECT_THROW(tonemap(image, op("gamma", std::nullopt, 0.0f)), InputError);
    EXPECT_THROW(tonemap(image, op("gamma", std::nullopt, -2.0f)), InputError);
    EXPECT_THROW(tonemap(image, op("clamp-gamma", 1.0f, nan)), InputError);
    EXPECT_THROW(tonemap(image, op("clamp", 0.0f)), InputError);
    EXPECT_THROW(tonemap(image, op("clamp", -1.0f)), InputError);
    EXPECT_THROW(tonemap(image, op("clamp", kInf)), InputError);
    EXPECT_THROW(tonemap(image, op("clamp", std::nullopt, 2.2f, 65.0f)), InputError);
    EXPECT_THROW(tonemap(image, op("clamp", std::nullopt, 2.2f, nan)), InputError);
    // A clamp value for an operator that ignores it is a mistake worth reporting.
    for (const char* name : {"equalize", "gamma", "reinhard"}) {
        EXPECT_THROW(tonemap(image, op(name, 2.0f)), InputError) << name;
    }
    EXPECT_NO_THROW(tonemap(image, op("clamp", 2.0f, 2.2f, -64.0f)));
}

// ---- The cierzo-tonemap program -----------------------------------------------------------

class TonemapProgram : public ::testing::Test {
protected:
    void SetUp() override {
        if (!fs::exists(binary_)) {
            FAIL() << binary_ << " is missing: build the cierzo-tonemap target";
        }
        const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
        dir_ = fs::temp_directory_path() /
               ("cierzo_test_tonemap_" + std::to_string(::getpid()) + "_" + info->name());
        fs::remove_all(dir_);
        fs::create_directories(dir_);
    }
    void TearDown() override {
        std::error_code ignored;
        fs::remove_all(dir_, ignored);
    }

    // Runs the program with `args` (already quoted as needed); returns its exit status and
    // keeps its standard output and error in out_ and err_.
    int run(const std::string& args) {
        const std::string command = test::emulated("'" + binary_.string() + "'") + " " + args +
                                    " >'" + (dir_ / "stdout.txt").string() + "' 2>'" +
                                    (dir_ / "stderr.txt").string() + "'";
        const int status = std::system(command.c_str());
        out_ = read_text(dir_ / "stdout.txt");
        err_ = read_text(dir_ / "stderr.txt");
        return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    }
    static std::string read_text(const fs::path& path) {
        std::ifstream in(path, std::ios::binary);
        return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
    }
    std::string quoted(const std::string& name) const { return "'" + (dir_ / name).string() + "'"; }

    // The pixel bytes of a binary PPM written by the program (header "P6\nW H\n255\n").
    std::string ppm_pixels(const std::string& name, const std::string& header) const {
        const std::string bytes = read_text(dir_ / name);
        EXPECT_EQ(bytes.substr(0, header.size()), header);
        return bytes.size() > header.size() ? bytes.substr(header.size()) : std::string();
    }

    fs::path binary_ = CIERZO_BINARY_DIR "/cierzo-tonemap";
    fs::path dir_;
    std::string out_;
    std::string err_;
};

TEST_F(TonemapProgram, ConvertsAnExrWithTheChosenOperator) {
    Image image(2, 1);
    image.rgb = {1.0f, 3.0f, 0.5f, 0.0f, 2.0f, 0.2f};
    write_exr(dir_ / "in.exr", image);
    ASSERT_EQ(run(quoted("in.exr") + " " + quoted("out.ppm") + " --op clamp --clamp 2"), 0) << err_;
    // min(v, 2) / 2 -> 0.5, 1, 0.25, 0, 1, 0.1 -> bytes 128, 255, 64, 0, 255, 26
    EXPECT_EQ(ppm_pixels("out.ppm", "P6\n2 1\n255\n"), std::string("\x80\xff\x40\x00\xff\x1a", 6));
    EXPECT_TRUE(err_.empty()) << err_;
}

TEST_F(TonemapProgram, AcceptsNegativeExposureAndReadsPfm) {
    Image image(1, 1);
    image.rgb = {1.0f, 4.0f, 0.5f};
    write_pfm(dir_ / "in.pfm", image);
    ASSERT_EQ(run(quoted("in.pfm") + " " + quoted("out.ppm") + " --op clamp --exposure -1"), 0)
        << err_;
    EXPECT_EQ(ppm_pixels("out.ppm", "P6\n1 1\n255\n"), std::string("\x80\xff\x40", 3));
}

TEST_F(TonemapProgram, DefaultOperatorIsGamma) {
    Image image(2, 1);
    image.rgb = {1.0f, 0.0f, 0.25f, 0.5f, 0.0f, 0.0f};
    write_exr(dir_ / "in.exr", image);
    ASSERT_EQ(run(quoted("in.exr") + " " + quoted("out.ppm")), 0) << err_;
    const auto byte = [](float v) { return char(std::lround(std::pow(v, 1.0f / 2.2f) * 255)); };
    EXPECT_EQ(ppm_pixels("out.ppm", "P6\n2 1\n255\n"),
              std::string({'\xff', '\0', byte(0.25f), byte(0.5f), '\0', '\0'}));
}

TEST_F(TonemapProgram, WarnsAboutNonFiniteValues) {
    Image image(2, 1);
    image.rgb = {std::numeric_limits<float>::quiet_NaN(), kInf, 0.5f, 1.0f, 1.0f, 1.0f};
    write_exr(dir_ / "in.exr", image);
    ASSERT_EQ(run(quoted("in.exr") + " " + quoted("out.png") + " --op equalize"), 0) << err_;
    EXPECT_NE(err_.find("warning"), std::string::npos) << err_;
    EXPECT_NE(err_.find("2 non-finite"), std::string::npos) << err_;
    EXPECT_TRUE(fs::exists(dir_ / "out.png"));
}

TEST_F(TonemapProgram, BadInputFailsWithTheFileNameAndNoOutput) {
    EXPECT_EQ(run(quoted("missing.exr") + " " + quoted("out.png")), 1);
    EXPECT_EQ(err_.rfind("cierzo-tonemap: ", 0), 0u) << err_;
    EXPECT_NE(err_.find((dir_ / "missing.exr").string()), std::string::npos) << err_;

    std::ofstream(dir_ / "garbage.exr") << "not an image at all";
    EXPECT_EQ(run(quoted("garbage.exr") + " " + quoted("out.png")), 1);
    EXPECT_NE(err_.find((dir_ / "garbage.exr").string()), std::string::npos) << err_;
    EXPECT_FALSE(fs::exists(dir_ / "out.png"));
}

TEST_F(TonemapProgram, BadOptionsFail) {
    Image image(1, 1);
    write_exr(dir_ / "in.exr", image);
    EXPECT_NE(run(quoted("in.exr") + " " + quoted("out.png") + " --op filmic"), 0);
    EXPECT_NE(err_.find("filmic"), std::string::npos) << err_;
    EXPECT_EQ(run(quoted("in.exr") + " " + quoted("out.png") + " --op gamma --gamma 0"), 1);
    EXPECT_NE(err_.find("--gamma"), std::string::npos) << err_;
    EXPECT_EQ(run(quoted("in.exr") + " " + quoted("out.jpg")), 1);
    EXPECT_NE(err_.find("out.jpg"), std::string::npos) << err_;
    EXPECT_NE(run(quoted("in.exr")), 0);
    EXPECT_FALSE(fs::exists(dir_ / "out.png"));
}

TEST_F(TonemapProgram, HelpDocumentsOperatorsAndDefaults) {
    ASSERT_EQ(run("--help"), 0);
    for (const TonemapOperatorInfo& info : tonemap_operators()) {
        EXPECT_NE(out_.find(info.name), std::string::npos) << info.name;
        EXPECT_NE(out_.find(info.formula), std::string::npos) << info.formula;
    }
    for (const char* text : {"--exposure", "--gamma", "--clamp", "2.2", "default"}) {
        EXPECT_NE(out_.find(text), std::string::npos) << text << "\n" << out_;
    }
}

}  // namespace
}  // namespace cierzo
