// Image textures (src/io/texture_image.cpp, kernels/texture.h) and OBJ materials (src/io/mtl.cpp
// and the scene reader): decoding against values computed here, bilinear look-ups and wrap
// modes, texture coordinates of every primitive, each MTL key's mapping, refusals that name
// the file (and line), and renders: a textured plane's image follows the texture's mean
// albedo, and the scalar reference agrees with the wavefront on a textured scene.
#include <gtest/gtest.h>

#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <functional>
#include <fstream>
#include <optional>
#include <string>
#include <vector>

#include "core/error.h"
#include "io/image.h"
#include "io/mtl.h"
#include "io/texture_image.h"
#include "scene/scene_json.h"
#include "support/assimp_models.h"
#include "support/scratch.h"
#include "support/render_variants.h"

namespace cierzo {
namespace {

namespace fs = std::filesystem;

const fs::path& scratch() { return test::scratch("textures"); }

using test::write_text;

using test::refusal_of;

// sRGB decoding (IEC 61966-2-1) computed here in double
double srgb_to_linear(int byte) {
    const double c = byte / 255.0;
    return c <= 0.04045 ? c / 12.92 : std::pow((c + 0.055) / 1.055, 2.4);
}

TEST(Textures, DecodeTablesFollowTheSrgbCurveAndTheLinearScale) {
    const float* srgb = srgb_decode_table();
    const float* lin = linear_decode_table();
    for (int b = 0; b < 256; ++b) {
        EXPECT_NEAR(srgb[b], srgb_to_linear(b), 1e-7) << b;
        EXPECT_NEAR(lin[b], b / 255.0, 1e-7) << b;
    }
    EXPECT_EQ(srgb[0], 0.0f);
    EXPECT_EQ(srgb[255], 1.0f);
    EXPECT_NEAR(srgb[128], 0.2158605, 1e-6);  // the textbook value of mid-grey
}

// A PNG written by the project's own writer: 8-bit values come back, decoded either way.
TEST(Textures, PngTexelsDecodeFromSrgbOrAsData) {
    Image img(3, 2);
    const float values[6] = {0.0f, 0.25f, 0.5f, 0.75f, 1.0f, 0.1f};
    for (int i = 0; i < 6; ++i)
        for (int c = 0; c < 3; ++c)
            img.rgb[size_t(3 * i + c)] = c == 1 ? values[i] : 1.0f - values[i];
    const fs::path png = scratch() / "six.png";
    write_ldr(png, img);
    for (const bool srgb : {true, false}) {
        const TextureImage t = read_texture_image(png, srgb);
        ASSERT_EQ(t.width, 3);
        ASSERT_EQ(t.height, 2);
        ASSERT_EQ(t.bytes.size(), 6u);
        EXPECT_TRUE(t.opaque);
        double mean_g = 0.0;
        for (int i = 0; i < 6; ++i) {
            const int byte = int(std::lround(values[i] * 255.0));
            const int green = (t.bytes[size_t(i)] >> 8) & 255;
            EXPECT_EQ(green, byte) << i;
            mean_g += srgb ? srgb_to_linear(byte) : byte / 255.0;
        }
        EXPECT_NEAR(t.mean_rgb[1], mean_g / 6.0, 1e-6);
        EXPECT_NEAR(t.max_rgb[1], 1.0, 1e-7);
    }
}

// A float image in a scene, for look-ups: texel (x, y) has red = x + 10 y, green = 1.
struct FloatImage {
    Scene scene;
    int32_t id;
    FloatImage(int w, int h) {
        Image img(w, h);
        for (int y = 0; y < h; ++y)
            for (int x = 0; x < w; ++x) {
                float* p = img.pixel(x, y);
                p[0] = float(x + 10 * y), p[1] = 1.0f, p[2] = 0.0f;
            }
        const fs::path exr =
            scratch() / ("grid" + std::to_string(w) + "x" + std::to_string(h) + ".exr");
        write_exr(exr, img);
        id = scene.add_image(std::make_shared<const TextureImage>(read_texture_image(exr, true)));
    }
    float red(float u, float v, bool clamp = false, float su = 1, float ou = 0) const {
        ColorSource c;
        c.kind = TextureKind::kImage;
        c.image = id;
        c.clamp = clamp;
        c.uv_scale[0] = su, c.uv_offset[0] = ou;
        return sample_image(scene.image_views[size_t(id)], c, u, v).rgb.x;
    }
};

TEST(Textures, BilinearLookUpsAtTexelCentresAndBetween) {
    const FloatImage im(4, 2);  // texel centres at u = 1/8, 3/8, 5/8, 7/8; v = 3/4 (row 0), 1/4
    // At a centre: that texel exactly (v = 3/4 is the top row, y = 0)
    EXPECT_FLOAT_EQ(im.red(0.125f, 0.75f), 0.0f);
    EXPECT_FLOAT_EQ(im.red(0.625f, 0.75f), 2.0f);
    EXPECT_FLOAT_EQ(im.red(0.375f, 0.25f), 11.0f);
    // Halfway between two centres on each axis: the mean of the four
    EXPECT_FLOAT_EQ(im.red(0.25f, 0.5f), (0.0f + 1.0f + 10.0f + 11.0f) / 4.0f);
    // A quarter of the way from texel 1 to 2 along u in row 0
    EXPECT_NEAR(im.red(0.375f + 0.0625f, 0.75f), 1.25f, 1e-5f);
}

TEST(Textures, RepeatWrapsAndClampExtendsTheBorder) {
    const FloatImage im(4, 2);
    // Repeat: whole periods change nothing, negative coordinates included
    for (const float u : {0.125f, 0.3f, 0.625f, 0.9f})
        for (const float shift : {-3.0f, -1.0f, 1.0f, 2.0f, 100.0f})
            EXPECT_NEAR(im.red(u + shift, 0.75f), im.red(u, 0.75f), 2e-4f) << u << " " << shift;
    // Between the last texel's centre and the first's (across the seam): both
    EXPECT_NEAR(im.red(0.0f, 0.75f), 0.5f * (3.0f + 0.0f), 1e-5f);
    // Clamp: beyond the border, the border texel
    EXPECT_FLOAT_EQ(im.red(-0.5f, 0.75f, true), 0.0f);
    EXPECT_FLOAT_EQ(im.red(1.7f, 0.75f, true), 3.0f);
    EXPECT_FLOAT_EQ(im.red(0.0f, 0.75f, true), 0.0f);
    // Scale and offset: u·2 + 0.25 at u = 0.1875 is 0.625, texel 2's centre
    EXPECT_FLOAT_EQ(im.red(0.1875f, 0.75f, false, 2.0f, 0.25f), 2.0f);
    // Coordinates that are NaN or huge read as 0, never out of the image
    const float nan = std::nanf("");
    EXPECT_TRUE(std::isfinite(im.red(nan, nan)));
    EXPECT_TRUE(std::isfinite(im.red(1e30f, -1e30f)));
    EXPECT_TRUE(std::isfinite(im.red(1e30f, -1e30f, true)));
}

TEST(Textures, TextureCoordinatesOfSpheresAndPlanes) {
    // A sphere: +z is u = ½, +x a quarter turn on (u = ¾), the top v = 1, the equator ½
    float u, v;
    sphere_uv(Vec3f{0, 0, 1}, u, v);
    EXPECT_NEAR(u, 0.5f, 1e-6f);
    EXPECT_NEAR(v, 0.5f, 1e-6f);
    sphere_uv(Vec3f{1, 0, 0}, u, v);
    EXPECT_NEAR(u, 0.75f, 1e-6f);
    sphere_uv(Vec3f{0, 1, 0}, u, v);
    EXPECT_NEAR(v, 1.0f, 1e-6f);
    sphere_uv(Vec3f{0, -1, 0}, u, v);
    EXPECT_NEAR(v, 0.0f, 1e-6f);
    // A plane: the frame is orthonormal and in the plane, so moving by d along the plane
    // moves (u, v) by |d|, and moving along the normal moves nothing
    for (const Vec3f n : {Vec3f{0, 1, 0}, Vec3f{0, 0, -1}, normalize(Vec3f{1, 2, -3})}) {
        const Vec3f p{0.3f, -1.0f, 2.0f};
        float u0, v0, u1, v1, u2, v2;
        plane_uv(n, p, u0, v0);
        plane_uv(n, p + n * 5.0f, u1, v1);
        EXPECT_NEAR(u1, u0, 1e-5f);
        EXPECT_NEAR(v1, v0, 1e-5f);
        const Vec3f t = normalize(cross(n, Vec3f{0.3f, 0.5f, 0.7f}));
        plane_uv(n, p + t * 2.0f, u2, v2);
        EXPECT_NEAR(std::hypot(u2 - u0, v2 - v0), 2.0f, 1e-4f);
    }
}

TEST(Textures, BadImagesAreRefusedNamingTheFile) {
    const fs::path dir = scratch();
    // Missing, a folder, not an image
    EXPECT_NE(
        refusal_of([&] { read_texture_image(dir / "missing.png", true); }).find("missing.png"),
        std::string::npos);
    EXPECT_NE(refusal_of([&] { read_texture_image(dir, true); }).find("directory"),
              std::string::npos);
    write_text(dir / "text.png", "this is not a PNG file at all");
    EXPECT_NE(refusal_of([&] { read_texture_image(dir / "text.png", true); }).find("text.png"),
              std::string::npos);
    // Truncated: a valid PNG cut in the middle of its pixel data
    Image img(64, 64);
    for (size_t i = 0; i < img.rgb.size(); ++i) img.rgb[i] = float((i * 7919) % 256) / 255.0f;
    write_ldr(dir / "whole.png", img);
    std::ifstream in(dir / "whole.png", std::ios::binary);
    const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    ASSERT_GT(bytes.size(), 200u);
    write_text(dir / "cut.png", bytes.substr(0, bytes.size() / 2));
    const std::string cut = refusal_of([&] { read_texture_image(dir / "cut.png", true); });
    EXPECT_NE(cut.find("cut.png"), std::string::npos) << cut;
    // Absurd dimensions in a BMP header: refused before anything is allocated
    std::string bmp(54, '\0');
    const auto put32 = [&](size_t at, uint32_t v) {
        for (int k = 0; k < 4; ++k) bmp[at + size_t(k)] = char(v >> (8 * k));
    };
    bmp[0] = 'B', bmp[1] = 'M';
    put32(2, 54), put32(10, 54), put32(14, 40), put32(18, 100000), put32(22, 100000);
    bmp[26] = 1, bmp[28] = 24;
    write_text(dir / "huge.bmp", bmp);
    const std::string huge = refusal_of([&] { read_texture_image(dir / "huge.bmp", true); });
    EXPECT_NE(huge.find("huge.bmp"), std::string::npos) << huge;
    EXPECT_NE(huge.find("100000"), std::string::npos) << huge;
    // A negative texel in an EXR
    Image neg(2, 2);
    neg.rgb[4] = -1.0f;
    write_exr(dir / "negative.exr", neg);
    const std::string n = refusal_of([&] { read_texture_image(dir / "negative.exr", true); });
    EXPECT_NE(n.find("negative.exr"), std::string::npos) << n;
    EXPECT_NE(n.find(">= 0"), std::string::npos) << n;
}

// Only the documented formats are decoded, known by their signatures, and a file's
// extension must name the format its bytes are: a GIF or a PSD named .tga (which stb_image
// would decode, trying every format it has) is refused, as is a PNG named .jpg.
TEST(Textures, OnlyDocumentedFormatsAreDecodedAndTheExtensionMustAgree) {
    const fs::path dir = scratch();
    // A 1 x 1 GIF (a white texel), which stb_image decodes given the chance
    const std::string gif(
        "GIF89a\x01\x00\x01\x00\x80\x00\x00\xff\xff\xff\x00\x00\x00"
        "\x2c\x00\x00\x00\x00\x01\x00\x01\x00\x00\x02\x02\x44\x01\x00\x3b",
        35);
    for (const char* name : {"gif.tga", "gif.png", "gif.gif"}) {
        SCOPED_TRACE(name);
        const std::string m = refusal_of([&] { decode_texture_image(gif, name, true); });
        EXPECT_NE(m.find(name), std::string::npos) << m;
        EXPECT_EQ(m.find("GIF89a"), std::string::npos) << "the file's bytes are not quoted: " << m;
        write_text(dir / name, gif);
        EXPECT_NE(refusal_of([&] { read_texture_image(dir / name, true); }).find(name),
                  std::string::npos);
        EXPECT_NE(refusal_of([&] { probe_texture_image(dir / name); }).find(name),
                  std::string::npos);
    }
    // A PSD signature with a header stb_image would read is no TGA either
    std::string psd(
        "8BPS\x00\x01\x00\x00\x00\x00\x00\x00\x00\x03\x00\x00\x00\x01"
        "\x00\x00\x00\x01\x00\x08\x00\x03",
        26);
    psd += std::string(64, '\0');
    EXPECT_NE(refusal_of([&] { decode_texture_image(psd, "psd.tga", true); }).find("psd.tga"),
              std::string::npos);
    // A real PNG: decoded as .png, refused as .jpg, .tga or with an unknown extension
    Image img(4, 3);
    for (size_t i = 0; i < img.rgb.size(); ++i) img.rgb[i] = float(i % 5) / 4.0f;
    write_ldr(dir / "real.png", img);
    std::ifstream in(dir / "real.png", std::ios::binary);
    const std::string png((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    EXPECT_EQ(decode_texture_image(png, "real.png", true).width, 4);
    EXPECT_EQ(decode_texture_image(png, "REAL.PNG", true).height, 3);
    const std::string as_jpg = refusal_of([&] { decode_texture_image(png, "real.jpg", true); });
    EXPECT_NE(as_jpg.find("is a PNG file by its contents"), std::string::npos) << as_jpg;
    EXPECT_NE(as_jpg.find("'.jpg'"), std::string::npos) << as_jpg;
    EXPECT_NE(refusal_of([&] { decode_texture_image(png, "real.tga", true); }).find("real.tga"),
              std::string::npos);
    const std::string odd = refusal_of([&] { decode_texture_image(png, "real.img", true); });
    EXPECT_NE(odd.find("'.img'"), std::string::npos) << odd;
    // A real TGA (2 x 1, 24-bit, uncompressed) is read, and a TGA header with a depth TGA
    // has not, refused
    std::string tga(18, '\0');
    tga[2] = 2, tga[12] = 2, tga[14] = 1, tga[16] = 24;
    tga += std::string("\x00\x00\xff\xff\x00\x00", 6);  // (BGR: red, blue)
    const TextureImage t = decode_texture_image(tga, "two.tga", false);
    ASSERT_EQ(t.texels(), 2u);
    EXPECT_EQ(uint32_t(t.bytes[0]) & 0xffffffu, 0x0000ffu);
    EXPECT_EQ(uint32_t(t.bytes[1]) & 0xffffffu, 0xff0000u);
    std::string deep = tga;
    deep[16] = 7;
    EXPECT_NE(refusal_of([&] { decode_texture_image(deep, "deep.tga", true); }).find("deep.tga"),
              std::string::npos);
}

// What decoding an image costs is read from its header alone, without decoding it: a
// 16384² greyscale PNG's header (a 57-byte file) costs 8 bytes a texel at the peak
TEST(Textures, ProbeReadsTheCostFromTheHeaderAlone) {
    const fs::path dir = scratch();
    std::string png(
        "\x89PNG\r\n\x1a\n\x00\x00\x00\x0dIHDR\x00\x00\x40\x00\x00\x00\x40\x00"
        "\x08\x00\x00\x00\x00\x00\x00\x00\x00",
        33);
    png += std::string("\x00\x00\x00\x00IEND\xae\x42\x60\x82", 12);
    write_text(dir / "huge_grey.png", png);
    const TextureShape shape = probe_texture_image(dir / "huge_grey.png");
    EXPECT_EQ(shape.width, 16384);
    EXPECT_EQ(shape.height, 16384);
    EXPECT_FALSE(shape.floats);
    EXPECT_EQ(shape.kept_bytes, uint64_t(4) << 28);
    EXPECT_EQ(shape.peak_bytes, uint64_t(8) << 28);
    // An EXR's cost counts its channels
    Image e(8, 4);
    write_exr(dir / "small.exr", e, {}, {{"A", std::vector<float>(32, 1.0f)}});
    const TextureShape exr = probe_texture_image(dir / "small.exr");
    EXPECT_TRUE(exr.floats);
    EXPECT_EQ(exr.texels(), 32u);
    EXPECT_EQ(exr.kept_bytes, 16u * 32u);
    EXPECT_EQ(exr.peak_bytes, (12u + 4u + 16u) * 32u);
}

// ---- MTL ------------------------------------------------------------------------------

TEST(Mtl, EveryKeyIsReadAndBadValuesNameTheLine) {
    const MtlLibrary lib = parse_mtl(
        "# comment\n"
        "newmtl wood\n"
        "Ka 0.1 0.1 0.1\n"
        "Kd 0.5 0.25 0.125\n"
        "Ks 0.2\n"
        "Ns 40\n"
        "map_Kd -s 2 3 1 -o 0.5 0.25 0 -clamp on textures\\wood grain.png\n"
        "bump bumps.png\n"
        "newmtl glass\n"
        "illum 7\n"
        "Ni 1.5\n"
        "Tf 0.9 1 0.8\n"
        "Ke 1 2 3\n"
        "Tr 0.25\n"
        "map_bump more.png\n",
        "lib.mtl");
    ASSERT_EQ(lib.materials.size(), 2u);
    const MtlMaterial& w = lib.materials[0];
    EXPECT_EQ(w.name, "wood");
    EXPECT_FLOAT_EQ(w.kd_rgb[1], 0.25f);
    EXPECT_FLOAT_EQ(w.ks_rgb[2], 0.2f);
    EXPECT_FLOAT_EQ(w.ns, 40.0f);
    ASSERT_TRUE(w.map_kd);
    EXPECT_EQ(w.map_kd->file, "textures/wood grain.png");
    EXPECT_FLOAT_EQ(w.map_kd->scale[1], 3.0f);
    EXPECT_FLOAT_EQ(w.map_kd->offset[0], 0.5f);
    EXPECT_TRUE(w.map_kd->clamp);
    const MtlMaterial& g = lib.materials[1];
    EXPECT_EQ(g.illum, 7);
    EXPECT_FLOAT_EQ(g.ni, 1.5f);
    EXPECT_FLOAT_EQ(g.tf_rgb[2], 0.8f);
    EXPECT_FLOAT_EQ(g.ke_rgb[2], 3.0f);
    EXPECT_FLOAT_EQ(g.d, 0.75f);
    // One warning per unmodelled key, naming the file and line
    ASSERT_EQ(lib.warnings.size(), 2u);
    EXPECT_NE(lib.warnings[0].find("lib.mtl: line 8: 'bump'"), std::string::npos)
        << lib.warnings[0];
    EXPECT_NE(lib.warnings[1].find("line 15: 'map_bump'"), std::string::npos) << lib.warnings[1];

    const auto refused = [](const std::string& text) {
        return refusal_of([&] { parse_mtl(text, "bad.mtl"); });
    };
    EXPECT_NE(refused("newmtl a\nKd 0.5 x 0.5\n").find("bad.mtl: line 2"), std::string::npos);
    EXPECT_NE(refused("newmtl a\nKd -0.5\n").find(">= 0"), std::string::npos);
    EXPECT_NE(refused("newmtl a\nKd 1 2\n").find("1 or 3"), std::string::npos);
    EXPECT_NE(refused("newmtl a\nKd spectral x.rfl\n").find("spectral"), std::string::npos);
    EXPECT_NE(refused("Kd 0.5\n").find("is not an MTL library"), std::string::npos);
    // A file that is not an MTL library (any file an OBJ's mtllib names) is never quoted
    const std::string secret = refused("root:x:0:0:root:/root:/bin/bash\nsecret 1\n");
    EXPECT_NE(secret.find("bad.mtl: line 1: is not an MTL library"), std::string::npos) << secret;
    EXPECT_EQ(secret.find("root:x"), std::string::npos) << secret;
    EXPECT_NE(refused("newmtl a\nNs -1\n").find("line 2"), std::string::npos);
    EXPECT_NE(refused("newmtl a\nNi -1\n").find("'Ni'"), std::string::npos);
    EXPECT_NE(refused("newmtl a\nd 1.5\n").find("'d'"), std::string::npos);
    EXPECT_NE(refused("newmtl a\nillum 2.5\n").find("integer"), std::string::npos);
    EXPECT_NE(refused("newmtl a\nmap_Kd -s\n").find("needs a number"), std::string::npos);
    EXPECT_NE(refused("newmtl a\nmap_Kd -clamp on\n").find("names no file"), std::string::npos);
    EXPECT_NE(refused("newmtl a\nnewmtl a\n").find("defined twice"), std::string::npos);
    EXPECT_NE(refused("newmtl a\nmap_Kd -colorspace rec2020 x.png\n")
                  .find("-colorspace takes sRGB or linear, got 'rec2020'"),
              std::string::npos);
}

// A 'newmtl' without a name (Blender 2.61 wrote one: assimp's empty_mat.mtl) is a warning;
// the material keeps its values under a made-up name no 'newmtl' can give
TEST(Mtl, NewmtlWithoutANameIsAWarningAndAMadeUpName) {
    const MtlLibrary lib = parse_mtl(
        "newmtl \t\n"
        "Kd 0.25 0.5 0.75\n"
        "Ns 10\n"
        "newmtl unnamed-line-1\n"
        "Kd 0.125\n"
        "newmtl # only a comment\n"
        "Ks 0.5\n",
        "lib.mtl");
    ASSERT_EQ(lib.materials.size(), 3u);
    const MtlMaterial& first = lib.materials[0];
    EXPECT_EQ(first.name, "#unnamed-line-1");
    EXPECT_EQ(first.line, 1u);
    EXPECT_FLOAT_EQ(first.kd_rgb[2], 0.75f);
    EXPECT_FLOAT_EQ(first.ns, 10.0f);
    EXPECT_EQ(lib.materials[2].name, "#unnamed-line-6");
    EXPECT_FLOAT_EQ(lib.materials[2].ks_rgb[0], 0.5f);
    // The real material of the name closest to it is still itself
    ASSERT_NE(lib.find("unnamed-line-1"), nullptr);
    EXPECT_FLOAT_EQ(lib.find("unnamed-line-1")->kd_rgb[0], 0.125f);
    EXPECT_EQ(lib.find(""), nullptr);
    ASSERT_EQ(lib.warnings.size(), 2u);
    EXPECT_NE(lib.warnings[0].find("lib.mtl: line 1: 'newmtl' without a name: the material is "
                                   "called '#unnamed-line-1'"),
              std::string::npos)
        << lib.warnings[0];
    EXPECT_NE(lib.warnings[1].find("lib.mtl: line 6:"), std::string::npos) << lib.warnings[1];
}

// A folder with an OBJ of two quads (materials a and b, and a triangle before any usemtl),
// its MTL, and a 2 × 2 PNG.
struct ObjFolder {
    fs::path dir;
    explicit ObjFolder(const std::string& name, const std::string& mtl) {
        dir = scratch() / name;
        fs::create_directories(dir);
        write_text(dir / "model.obj",
                   "mtllib model.mtl\n"
                   "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 2 0 0\nv 2 1 0\n"
                   "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n"
                   "f 1/1 2/2 5/3\n"
                   "usemtl a\nf 1/1 2/2 3/3 4/4\n"
                   "usemtl b\nf 2/1 5/2 6/3 3/4\n");
        write_text(dir / "model.mtl", mtl);
        Image img(2, 2);
        for (size_t i = 0; i < img.rgb.size(); ++i) img.rgb[i] = 0.5f;
        write_ldr(dir / "tex.png", img);
    }
    Scene load(const std::string& object_extra = "") const {
        const std::string scene =
            R"({"camera": {"position": [1, 0.5, 3], "look_at": [1, 0.5, 0]},
                "materials": {"red": {"kd": [0.9, 0, 0]}},
                "objects": [{"type": "mesh", "file": "model.obj")" +
            object_extra + "}]}";
        write_text(dir / "scene.json", scene);
        return load_scene(dir / "scene.json");
    }
};

const Material* material_named(const Scene& s, const std::string& name) {
    for (const Material& m : s.materials)
        if (m.name == name) return &m;
    return nullptr;
}

TEST(Mtl, MaterialsMapToThePhongModel) {
    const ObjFolder f("mapping",
                      "newmtl a\nKd 0.5 0.25 0.125\nKs 0.25 0.25 0.25\nNs 30\nillum 2\n"
                      "newmtl b\nKd 0.1 0.1 0.1\nKs 0.7 0.8 0.9\nillum 3\nKe 0 2 0\n");
    const Scene s = f.load();
    // Three groups: the triangle before any usemtl (default), a, b; each a mesh of its own
    ASSERT_EQ(s.meshes.size(), 3u);
    const Material* a = material_named(s, "model.mtl:a");
    const Material* b = material_named(s, "model.mtl:b");
    const Material* d = material_named(s, "(OBJ default)");
    ASSERT_TRUE(a && b && d);
    EXPECT_EQ(a->kd.a.y, 0.25f);
    EXPECT_EQ(a->ks.a.x, 0.25f);
    EXPECT_EQ(a->shininess, 30.0f);
    EXPECT_TRUE(a->kr.is_zero());
    // illum 3: a mirror of reflectance Ks beside the diffuse Kd, and Ke emits
    EXPECT_EQ(b->kr.a.z, 0.9f);
    EXPECT_TRUE(b->ks.is_zero());
    EXPECT_EQ(b->kd.a.x, 0.1f);
    EXPECT_EQ(b->emission.a.y, 2.0f);
    EXPECT_EQ(d->kd.a.x, 0.8f);
    // The quads keep their texture coordinates, 2 triangles each
    size_t triangles = 0;
    for (const Mesh& m : s.meshes) {
        triangles += m.triangle_count();
        EXPECT_EQ(m.uvs.size(), m.positions.size() * 2);
    }
    EXPECT_EQ(triangles, 5u);
}

TEST(Mtl, GlassTexturesAndOverrides) {
    const ObjFolder f("glass",
                      "newmtl a\nKd 0 0 0\nKs 0.1 0.1 0.1\nTf 0.9 0.8 0.7\nNi 1.33\nillum 7\n"
                      "newmtl b\nKd 0.3 0.3 0.3\nmap_Kd -s 4 4 1 .\\tex.png\n");
    const Scene s = f.load();
    const Material* a = material_named(s, "model.mtl:a");
    const Material* b = material_named(s, "model.mtl:b");
    ASSERT_TRUE(a && b);
    EXPECT_EQ(a->kt.a.y, 0.8f);
    EXPECT_EQ(a->ior, 1.33f);
    EXPECT_EQ(a->kr.a.x, 0.1f);
    ASSERT_EQ(b->kd.kind, TextureKind::kImage);
    EXPECT_EQ(b->kd.uv_scale[0], 4.0f);
    ASSERT_EQ(s.images.size(), 1u);
    EXPECT_NEAR(b->kd.b.x, srgb_to_linear(128), 1e-6);  // the image's largest value
    // An override by MTL name, by scene name or inline
    const Scene o = f.load(R"(, "materials": {"a": "red", "b": {"kd": 0.5}})");
    for (const Mesh& m : o.meshes) EXPECT_NE(o.materials[size_t(m.material)].name, "model.mtl:a");
    EXPECT_FALSE(material_named(o, "model.mtl:b"));
    // 'material' gives every face one material, as for any mesh
    const Scene one = f.load(R"(, "material": "red")");
    ASSERT_EQ(one.meshes.size(), 1u);
    EXPECT_EQ(one.materials[size_t(one.meshes[0].material)].name, "red");
}

// tinyobjloader's -colorspace: how a map's 8-bit values are encoded, over the map's own
// default (sRGB for colours)
TEST(Mtl, ColorspaceOptionChoosesTheDecoding) {
    const MtlLibrary lib = parse_mtl(
        "newmtl a\nmap_Kd -colorspace linear -s 2 2 x.png\n"
        "map_Ks -colorspace SRGB y.png\nmap_Ke z.png\n",
        "lib.mtl");
    ASSERT_TRUE(lib.materials[0].map_kd && lib.materials[0].map_ks && lib.materials[0].map_ke);
    EXPECT_EQ(lib.materials[0].map_kd->srgb, 0);
    EXPECT_EQ(lib.materials[0].map_kd->file, "x.png");
    EXPECT_FLOAT_EQ(lib.materials[0].map_kd->scale[0], 2.0f);
    EXPECT_EQ(lib.materials[0].map_ks->srgb, 1);
    EXPECT_EQ(lib.materials[0].map_ke->srgb, -1);
    // The same 2 × 2 PNG of 128s: sRGB-decoded by default, byte / 255 when linear
    const auto kd_of = [](const std::string& name, const std::string& option) {
        const ObjFolder f(name, "newmtl a\nKd 0 0 0\nnewmtl b\nmap_Kd " + option + "tex.png\n");
        const Scene s = f.load();
        const Material* b = material_named(s, "model.mtl:b");
        EXPECT_TRUE(b && b->kd.kind == TextureKind::kImage);
        return b ? b->kd.b.x : -1.0f;
    };
    EXPECT_NEAR(kd_of("colorspace_default", ""), srgb_to_linear(128), 1e-6);
    EXPECT_NEAR(kd_of("colorspace_srgb", "-colorspace sRGB "), srgb_to_linear(128), 1e-6);
    EXPECT_NEAR(kd_of("colorspace_linear", "-colorspace linear "), 128.0f / 255.0f, 1e-6);
}

TEST(Mtl, BadMaterialsAndTexturesAreRefusedNamingTheFile) {
    const ObjFolder f("refusals", "newmtl a\nKd 0.5\nmap_Kd missing.png\nnewmtl b\nKd 0.5\n");
    std::string m = refusal_of([&] { f.load(); });
    EXPECT_NE(m.find("missing.png"), std::string::npos) << m;
    EXPECT_NE(m.find("model.mtl: line 3"), std::string::npos) << m;
    m = refusal_of([&] { f.load(R"(, "materials": {"c": "red"})"); });
    EXPECT_NE(m.find("'c'"), std::string::npos) << m;
    EXPECT_NE(m.find("a, b"), std::string::npos) << m;
    m = refusal_of([&] { f.load(R"(, "material": "red", "materials": {"a": "red"})"); });
    EXPECT_NE(m.find("'materials'"), std::string::npos) << m;
    // A missing library: a warning naming the OBJ and the library, and every material it
    // would define the default grey (as tinyobjloader, Blender and assimp read such a file)
    const ObjFolder g("nolib", "");
    fs::remove(g.dir / "model.mtl");
    const Scene nolib = g.load();
    ASSERT_FALSE(nolib.warnings.empty());
    EXPECT_NE(nolib.warnings[0].find("model.obj: material library (mtllib)"), std::string::npos)
        << nolib.warnings[0];
    EXPECT_NE(nolib.warnings[0].find("model.mtl: file does not exist"), std::string::npos)
        << nolib.warnings[0];
    for (const Mesh& mesh : nolib.meshes) {
        const Material& mat = nolib.materials[size_t(mesh.material)];
        EXPECT_EQ(mat.kd.a.x, 0.8f) << mat.name;
        EXPECT_EQ(mat.kd.a.z, 0.8f) << mat.name;
        EXPECT_FALSE(mat.is_emitter()) << mat.name;
    }
    // A library that is there but cannot be read is still refused
    fs::create_directories(g.dir / "model.mtl");
    m = refusal_of([&] { g.load(); });
    EXPECT_NE(m.find("model.mtl"), std::string::npos) << m;
    // An image texture on a mesh without texture coordinates, or on a quadric
    write_text(f.dir / "plain.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
    write_text(f.dir / "s.json",
               R"({"camera": {"position": [0, 0, 3], "look_at": [0, 0, 0]},
                   "materials": {"t": {"kd": {"texture": "image", "file": "tex.png"}}},
                   "objects": [{"type": "mesh", "file": "plain.obj", "material": "t"}]})");
    m = refusal_of([&] { load_scene(f.dir / "s.json"); });
    EXPECT_NE(m.find("no texture coordinates"), std::string::npos) << m;
    write_text(f.dir / "q.json",
               R"({"camera": {"position": [0, 0, 3], "look_at": [0, 0, 0]},
                   "materials": {"t": {"kd": {"texture": "image", "file": "tex.png"}}},
                   "objects": [{"type": "quadric", "coefficients": [1,1,1,0,0,0,0,0,0,-1],
                                "material": "t"}]})");
    m = refusal_of([&] { load_scene(f.dir / "q.json"); });
    EXPECT_NE(m.find("quadric"), std::string::npos) << m;
    // Bad texture keys
    write_text(f.dir / "k.json",
               R"({"camera": {"position": [0, 0, 3], "look_at": [0, 0, 0]},
                   "materials": {"t": {"kd": {"texture": "image", "file": "tex.png", "wrap": "mirror"}}},
                   "objects": [{"type": "sphere", "center": [0,0,0], "radius": 1, "material": "t"}]})");
    m = refusal_of([&] { load_scene(f.dir / "k.json"); });
    EXPECT_NE(m.find("'wrap'"), std::string::npos) << m;
}

// A map, a library, a mesh or an environment map that is a FIFO (whose open waits for a
// writer: `cierzo render` waited for ever on such a map_Kd) or a directory is refused at once,
// naming it and where the scene names it
TEST(Mtl, TexturesLibrariesMeshesAndEnvironmentsThatAreNotFilesAreRefusedAtOnce) {
    const char* fifo_is = ": is a FIFO (named pipe), not a regular file";
    const ObjFolder f("not-files", "newmtl a\nKd 0.5\nmap_Kd tex.fifo\nnewmtl b\nKd 0.5\n");
    const fs::path texture = test::make_fifo(f.dir / "tex.fifo");
    std::string m = test::refusal_without_opening(texture, [&] { f.load(); });
    EXPECT_NE(m.find("model.mtl: line 3"), std::string::npos) << m;
    EXPECT_NE(m.find(texture.string() + fifo_is), std::string::npos) << m;

    const ObjFolder d("directory-texture", "newmtl a\nmap_Kd maps\nnewmtl b\n");
    fs::create_directories(d.dir / "maps");
    m = refusal_of([&] { d.load(); });
    EXPECT_NE(m.find((d.dir / "maps").string() + ": is a directory, not a regular file"),
              std::string::npos)
        << m;

    const ObjFolder l("fifo-library", "");
    const fs::path library = test::make_fifo(l.dir / "model.mtl");
    m = test::refusal_without_opening(library, [&] { l.load(); });
    EXPECT_NE(m.find("material library (mtllib): " + library.string() + fifo_is), std::string::npos)
        << m;

    const fs::path mesh = test::make_fifo(f.dir / "pipe.ply");
    write_text(f.dir / "mesh.json",
               R"({"camera": {"position": [0, 0, 3], "look_at": [0, 0, 0]},
                   "materials": {"grey": {"kd": 0.5}},
                   "objects": [{"type": "mesh", "file": "pipe.ply", "material": "grey"}]})");
    m = test::refusal_without_opening(mesh, [&] { load_scene(f.dir / "mesh.json"); });
    EXPECT_NE(m.find("mesh file: " + mesh.string() + fifo_is), std::string::npos) << m;

    const fs::path sky = test::make_fifo(f.dir / "sky.exr");
    write_text(f.dir / "sky.json",
               R"({"camera": {"position": [0, 0, 3], "look_at": [0, 0, 0]},
                   "environment": {"emission": {"texture": "image", "file": "sky.exr"}},
                   "materials": {"grey": {"kd": 0.5}},
                   "objects": [{"type": "sphere", "center": [0, 0, 0], "radius": 1,
                                "material": "grey"}]})");
    m = test::refusal_without_opening(sky, [&] { load_scene(f.dir / "sky.json"); });
    EXPECT_NE(m.find("sky.json: environment"), std::string::npos) << m;
    EXPECT_NE(m.find(sky.string() + fifo_is), std::string::npos) << m;
}

// ---- Renders ---------------------------------------------------------------------------

// A plane textured with a fine checkerboard (many tiles per pixel) under a point light, and
// the same plane of the texture's mean albedo: the two images agree in mean, in every
// integrator. A texture read in the wrong encoding, or a factor dropped, moves the textured
// mean by far more than the tolerance.
TEST(TexturedRenders, ImageMeanFollowsTheTexturesMeanAlbedo) {
    Image checker(8, 8);
    for (int y = 0; y < 8; ++y)
        for (int x = 0; x < 8; ++x) {
            float* p = checker.pixel(x, y);
            const bool on = (x + y) % 2 == 0;
            p[0] = on ? 1.0f : 0.2f, p[1] = on ? 0.6f : 0.0f, p[2] = 0.4f;
        }
    const fs::path dir = scratch() / "furnace";
    fs::create_directories(dir);
    write_ldr(dir / "checker.png", checker);
    const TextureImage t = read_texture_image(dir / "checker.png", true);
    const std::string common =
        R"("camera": {"position": [0, 4, 0.01], "look_at": [0, 0, 0], "vfov": 30},
           "lights": [{"position": [0, 6, 0], "intensity": 60}],
           "render": {"width": 24, "height": 24, "spp": 64})";
    write_text(dir / "textured.json",
               "{" + common + R"(, "materials": {"t": {"kd": {"texture": "image",
                    "file": "checker.png", "scale": 40, "factor": 0.9}}},
                    "objects": [{"type": "plane", "normal": [0, 1, 0], "distance": 0,
                                 "material": "t"}]})");
    write_text(dir / "solid.json", "{" + common + R"(, "materials": {"s": {"kd": [)" +
                                       std::to_string(0.9 * t.mean_rgb[0]) + "," +
                                       std::to_string(0.9 * t.mean_rgb[1]) + "," +
                                       std::to_string(0.9 * t.mean_rgb[2]) + R"(]}},
                    "objects": [{"type": "plane", "normal": [0, 1, 0], "distance": 0,
                                 "material": "s"}]})");
    const Scene textured = load_scene(dir / "textured.json");
    const Scene solid = load_scene(dir / "solid.json");
    for (const test::Variant& v : test::variants()) {
        const RenderResult a = test::run(textured, v), b = test::run(solid, v);
        for (int c = 0; c < 3; ++c) {
            const test::ImageMean ma = test::image_mean(a.film, c),
                                  mb = test::image_mean(b.film, c);
            // (the solid plane has no variance across pixels' samples but the light's: the
            // texture adds its own; 2% covers the texture's aliasing over 576 pixels)
            EXPECT_NEAR(ma.mean, mb.mean, 0.02 * mb.mean + 5 * ma.sigma)
                << v.integrator << " " << v.isa << " channel " << c;
        }
    }
}

// A scene of every textured primitive (sphere, plane, triangles with uvs, an OBJ with vt and
// an instance of it), repeat and clamp, through the estimators: the wavefront agrees with the
// scalar reference pixel by pixel.
TEST(TexturedRenders, WavefrontAgreesWithTheScalarReference) {
    const fs::path dir = scratch() / "agreement";
    fs::create_directories(dir);
    Image img(16, 8);
    for (int y = 0; y < 8; ++y)
        for (int x = 0; x < 16; ++x) {
            float* p = img.pixel(x, y);
            p[0] = float(x) / 15.0f, p[1] = float(y) / 7.0f,
            p[2] = (x / 4 + y / 4) % 2 ? 0.9f : 0.1f;
        }
    write_ldr(dir / "ramp.png", img);
    write_text(dir / "quad.obj",
               "v -1 0 0\nv 1 0 0\nv 1 2 0\nv -1 2 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n"
               "f 1/1 2/2 3/3 4/4\n");
    write_text(dir / "scene.json", R"({
        "materials": {
            "img": {"kd": {"texture": "image", "file": "ramp.png"}},
            "tiles": {"kd": {"texture": "image", "file": "ramp.png", "scale": [0.5, 0.25],
                             "offset": 0.1}, "ks": 0.1, "shininess": 20},
            "edge": {"kd": {"texture": "image", "file": "ramp.png", "wrap": "clamp",
                            "scale": 1.5, "offset": -0.25}},
            "light": {"emission": 6}
        },
        "objects": [
            {"type": "plane", "normal": [0, 1, 0], "distance": 0, "material": "tiles"},
            {"type": "sphere", "center": [-1.5, 1, 0], "radius": 1, "material": "img"},
            {"type": "triangle", "vertices": [[0.5, 0, -1], [2.5, 0, -1], [2.5, 2, -1]],
             "uvs": [[0, 0], [1, 0], [1, 1]], "material": "edge"},
            {"type": "mesh", "file": "quad.obj", "material": "img", "translate": [1.5, 0, 0.5],
             "rotate": [0, 30, 0]},
            {"type": "mesh", "file": "quad.obj", "material": "edge", "translate": [-0.5, 0, 1.5],
             "scale": 0.5, "instance": true},
            {"type": "sphere", "center": [0, 5, 3], "radius": 1, "material": "light"}
        ],
        "lights": [{"position": [2, 4, 4], "intensity": 20}],
        "camera": {"position": [0, 2.5, 6], "look_at": [0, 0.8, 0], "vfov": 50},
        "render": {"width": 24, "height": 18, "spp": 256}
    })");
    Scene scene = load_scene(dir / "scene.json");
    for (const char* estimator : {"report", "mis"}) {
        use_estimator(scene.settings.estimator, *parse_estimator(estimator));
        scene.finalize();
        test::expect_wavefront_agrees(scene, estimator);
    }
}

}  // namespace
}  // namespace cierzo

namespace cierzo {
namespace {

// Every OBJ that Debian's assimp-testmodels ships (real files: MTL libraries with Windows
// paths, JPEG textures, malformed files among them) renders or is refused with an InputError
// naming it; none crashes or puts a NaN in the image. The textured spider keeps its JPEG
// textures.
// A real file rendered at 8 × 8 × 2 with every pixel finite (its scene returned), or refused
// with a message that names it (nothing returned).
std::optional<Scene> rendered_or_refused(const fs::path& path) {
    try {
        Scene scene = load_scene(path);
        scene.set_resolution(8, 8);
        scene.settings.spp = 2;
        const RenderResult r = test::run(scene, test::variants().back());
        for (const float v : r.film.mean().rgb) EXPECT_TRUE(std::isfinite(v));
        return scene;
    } catch (const InputError& e) {
        EXPECT_NE(std::string(e.what()).find(path.filename().string()), std::string::npos)
            << e.what();
        return std::nullopt;
    }
}

TEST(RealFiles, EveryAssimpTestModelObjRendersOrIsRefusedCleanly) {
    const fs::path root = test::kAssimpModels;
    if (!fs::exists(root / "OBJ")) GTEST_SKIP() << test::assimp_models_missing();
    size_t rendered = 0, refused = 0;
    for (const char* folder : {"OBJ", "invalid"})
        for (const auto& entry : fs::directory_iterator(root / folder)) {
            if (entry.path().extension() != ".obj") continue;
            SCOPED_TRACE(entry.path().string());
            const std::optional<Scene> scene = rendered_or_refused(entry.path());
            if (!scene) {
                ++refused;
                continue;
            }
            ++rendered;
            if (entry.path().filename() == "spider.obj") {
                EXPECT_GE(scene->images.size(), 3u);
                size_t textured = 0;
                for (const Material& m : scene->materials)
                    textured += m.kd.kind == TextureKind::kImage;
                EXPECT_GE(textured, 3u);
            }
        }
    EXPECT_GE(rendered, 10u);
    RecordProperty("rendered", int(rendered));
    RecordProperty("refused", int(refused));
}

TEST(RealFiles, EveryAssimpTestModelPlyRendersOrIsRefusedCleanly) {
    const fs::path root = test::kAssimpModels / "PLY";
    if (!fs::exists(root)) GTEST_SKIP() << test::assimp_models_missing();
    size_t rendered = 0;
    bool wuson = false;
    for (const auto& entry : fs::directory_iterator(root)) {
        if (entry.path().extension() != ".ply") continue;
        SCOPED_TRACE(entry.path().string());
        const std::optional<Scene> scene = rendered_or_refused(entry.path());
        if (!scene) continue;
        ++rendered;
        if (entry.path().filename() == "Wuson.ply") {
            // (Blender 2.47's 'Created by' header line: a comment, with a warning)
            wuson = true;
            ASSERT_FALSE(scene->warnings.empty());
            EXPECT_NE(scene->warnings[0].find("line 3: 'Created'"), std::string::npos)
                << scene->warnings[0];
        }
    }
    EXPECT_GE(rendered, 4u);
    if (fs::exists(root / "Wuson.ply")) {
        EXPECT_TRUE(wuson);
    }
}

// assimp's empty_mat.obj: its library's one material has no name ('newmtl ' alone), and its
// faces 'usemtl ' none either (the default material)
TEST(RealFiles, AssimpsEmptyMatLoadsWithAWarningForItsUnnamedMaterial) {
    const fs::path obj = test::kAssimpModels / "OBJ" / "empty_mat.obj";
    if (!fs::exists(obj)) GTEST_SKIP() << test::assimp_models_missing();
    const MtlLibrary lib = read_mtl(obj.parent_path() / "empty_mat.mtl");
    ASSERT_EQ(lib.materials.size(), 1u);
    EXPECT_EQ(lib.materials[0].name, "#unnamed-line-3");
    EXPECT_FLOAT_EQ(lib.materials[0].kd_rgb[1], 0.8f);
    EXPECT_EQ(lib.materials[0].illum, 2);
    const Scene scene = load_scene(obj);
    EXPECT_FALSE(scene.meshes.empty());
    bool warned = false;
    for (const std::string& w : scene.warnings)
        warned |= w.find("empty_mat.mtl: line 3: 'newmtl' without a name") != std::string::npos;
    EXPECT_TRUE(warned);
}

TEST(Mtl, GlassWithoutAnIndexIsRefusedWithItsLine) {
    const ObjFolder f("glass-ni", "newmtl a\nillum 7\nNi 0\nnewmtl b\nKd 0.5\n");
    const std::string m = refusal_of([&] { f.load(); });
    EXPECT_NE(m.find("model.mtl: line 3"), std::string::npos) << m;
    EXPECT_NE(m.find("Ni > 0"), std::string::npos) << m;
}

}  // namespace
}  // namespace cierzo
