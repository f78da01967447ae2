// Image files: EXR round trips bit for bit (with AOV layers), readers report missing channels as
// InputError, writers are atomic (temp file + rename), and the PNG preview carries the published
// sRGB encoding of clamp(value * 2^exposure).

#include "core/image.h"

#include "core/error.h"
#include "core/rng.h"
#include "test_support.h"

#include <gtest/gtest.h>
#include <png.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <string>
#include <vector>

namespace fogmap {
namespace {

namespace fs = std::filesystem;

/// A fresh empty directory per test, removed afterwards.
class ImageIoTest : public ::testing::Test {
protected:
    std::string path(const std::string& name) const { return (tmp_.path() / name).string(); }

    /// Names in the test directory that contain ".tmp-" (left-over temp files).
    std::vector<std::string> temp_files() const {
        std::vector<std::string> found;
        for (const auto& entry : fs::directory_iterator(tmp_.path())) {
            const std::string name = entry.path().filename().string();
            if (name.find(".tmp-") != std::string::npos) found.push_back(name);
        }
        return found;
    }

    test::TempDir tmp_{"fogmap_image_io"};
};

/// Random finite floats spread over many binades and both signs, plus special values.
Image random_image(int width, int height, uint64_t stream) {
    Rng rng(20240601, stream);
    Image image(width, height);
    for (Color& p : image.pixels) {
        for (int c = 0; c < 3; ++c) {
            const float sign = rng.uniform() < 0.5f ? -1.0f : 1.0f;
            p[c] = sign * (1.0f + rng.uniform()) *
                   std::exp2(std::floor(rng.uniform() * 80.0f) - 40.0f);
        }
    }
    image.pixels[0] = Color(0.0f, -0.0f, std::numeric_limits<float>::denorm_min());
    image.pixels[1] = Color(std::numeric_limits<float>::max(), kInfinity, -kInfinity);
    return image;
}

/// Bitwise equality of all pixels (so -0.0 vs 0.0 or a changed denormal would show).
void expect_bit_equal(const Image& expected, const Image& actual) {
    ASSERT_EQ(expected.width, actual.width);
    ASSERT_EQ(expected.height, actual.height);
    ASSERT_EQ(expected.pixels.size(), actual.pixels.size());
    EXPECT_EQ(0, std::memcmp(expected.pixels.data(), actual.pixels.data(),
                             expected.pixels.size() * sizeof(Color)));
}

/// Published sRGB OETF (IEC 61966-2-1), in double, then 8-bit code with round-half-up.
int srgb8_reference(double linear) {
    const double v = std::min(1.0, std::max(0.0, linear));
    const double s = v <= 0.0031308 ? 12.92 * v : 1.055 * std::pow(v, 1.0 / 2.4) - 0.055;
    return static_cast<int>(std::floor(255.0 * s + 0.5));
}

/// Decodes an 8-bit RGB PNG with libpng's simplified reader.
std::vector<uint8_t> read_png_rgb(const std::string& file, int* width, int* height) {
    png_image png{};
    png.version = PNG_IMAGE_VERSION;
    if (!png_image_begin_read_from_file(&png, file.c_str())) {
        ADD_FAILURE() << "cannot open PNG " << file << ": " << png.message;
        return {};
    }
    png.format = PNG_FORMAT_RGB;
    std::vector<uint8_t> rgb(PNG_IMAGE_SIZE(png));
    if (!png_image_finish_read(&png, nullptr, rgb.data(), 0, nullptr)) {
        ADD_FAILURE() << "cannot decode PNG " << file << ": " << png.message;
        png_image_free(&png);
        return {};
    }
    *width = static_cast<int>(png.width);
    *height = static_cast<int>(png.height);
    return rgb;
}

TEST(Image, MeanAveragesAllPixelsAndChannels) {
    Image image(2, 1);
    image.at(0, 0) = Color(1.0f, 2.0f, 3.0f);
    image.at(1, 0) = Color(4.0f, 5.0f, 6.0f);
    // (1+2+3+4+5+6)/6 = 3.5 exactly representable; the sum is exact in double.
    EXPECT_EQ(3.5, image.mean());
}

TEST_F(ImageIoTest, ExrRoundTripIsBitExactWithLayers) {
    // Odd sizes so the last ZIP block (16 scanlines) is partial.
    const Image beauty = random_image(37, 23, 1);
    const Image direct = random_image(37, 23, 2);
    const Image volume = random_image(37, 23, 3);
    const std::string file = path("round_trip.exr");
    write_exr(file, beauty, {{"direct", &direct}, {"volume_single", &volume}});

    // FLOAT channels with lossless ZIP: every bit must come back.
    expect_bit_equal(beauty, read_exr(file));
    expect_bit_equal(direct, read_exr(file, "direct"));
    expect_bit_equal(volume, read_exr(file, "volume_single"));
    EXPECT_TRUE(temp_files().empty());
}

TEST_F(ImageIoTest, ReadingMissingLayerThrowsInputErrorListingChannels) {
    const Image beauty = random_image(4, 3, 1);
    const Image direct = random_image(4, 3, 2);
    const std::string file = path("layers.exr");
    write_exr(file, beauty, {{"direct", &direct}});
    try {
        read_exr(file, "caustic");
        FAIL() << "expected InputError for a missing layer";
    } catch (const InputError& e) {
        EXPECT_EQ(file, e.file);
        EXPECT_EQ("", e.field);
        EXPECT_NE(std::string::npos, e.reason.find("caustic.R")) << e.reason;
        for (const char* channel : {"R", "G", "B", "direct.R", "direct.G", "direct.B"}) {
            EXPECT_NE(std::string::npos, e.reason.find(channel)) << channel << ": " << e.reason;
        }
    }
}

TEST_F(ImageIoTest, ReadingMissingOrCorruptFileThrowsInputError) {
    const std::string missing = path("missing.exr");
    try {
        read_exr(missing);
        FAIL() << "expected InputError for a missing file";
    } catch (const InputError& e) {
        EXPECT_EQ(missing, e.file);
    }
    const std::string corrupt = path("corrupt.exr");
    std::ofstream(corrupt) << "not an EXR file";
    EXPECT_THROW(read_exr(corrupt), InputError);
}

TEST_F(ImageIoTest, FailedWriteThrowsNamingPathAndLeavesNoTempFile) {
    const Image image = random_image(4, 3, 1);
    // Directory that does not exist: the temp file cannot even be created.
    const std::string no_dir = path("no_such_dir/out.exr");
    try {
        write_exr(no_dir, image);
        FAIL() << "expected std::runtime_error";
    } catch (const std::runtime_error& e) {
        EXPECT_NE(std::string::npos, std::string(e.what()).find(no_dir)) << e.what();
    }
    EXPECT_THROW(write_png(path("no_such_dir/out.png"), image), std::runtime_error);
    EXPECT_FALSE(fs::exists(path("no_such_dir")));

    // Target is a directory: the temp file is written, then rename fails and must clean up.
    fs::create_directories(path("occupied.exr/child"));
    fs::create_directories(path("occupied.png/child"));
    EXPECT_THROW(write_exr(path("occupied.exr"), image), std::runtime_error);
    EXPECT_THROW(write_png(path("occupied.png"), image), std::runtime_error);
    EXPECT_TRUE(fs::is_directory(path("occupied.exr/child")));
    EXPECT_TRUE(temp_files().empty());
}

TEST_F(ImageIoTest, WritingOverExistingFileReplacesItAndLeavesNoTempFile) {
    const Image first = random_image(5, 4, 1);
    const Image second = random_image(6, 2, 2);
    const std::string exr = path("out.exr");
    const std::string png = path("out.png");
    write_exr(exr, first);
    write_png(png, first);
    write_exr(exr, second);
    write_png(png, second);

    expect_bit_equal(second, read_exr(exr));
    int width = 0, height = 0;
    read_png_rgb(png, &width, &height);
    EXPECT_EQ(6, width);
    EXPECT_EQ(2, height);
    EXPECT_TRUE(temp_files().empty());
}

TEST_F(ImageIoTest, PngDecodesToPublishedSrgbValues) {
    // Published sRGB values: 0.5 → 187.5 (188), 0.18 → 117.6 (118), and the breakpoint 0.0031308
    // where both branches give 0.04045 → 10.3 (10). Checked first so the reference is trusted.
    ASSERT_EQ(188, srgb8_reference(0.5));
    ASSERT_EQ(118, srgb8_reference(0.18));
    ASSERT_EQ(10, srgb8_reference(0.0031308));

    std::vector<float> values = {0.0f, 0.0031308f, 0.0031309f, 0.18f, 0.5f, 1.0f, 2.0f, -1.0f};
    // A ramp over [0, 1.1]; values whose exact code sits within 1e-3 of a .5 tie are skipped, as
    // the float encoder may round those either way (its transfer is good to ~1e-5 codes).
    for (int i = 0; i <= 1100; ++i) {
        const float v = static_cast<float>(i) / 1000.0f;
        const double code =
            255.0 * (v <= 0.0031308f ? 12.92 * v
                                     : 1.055 * std::pow(static_cast<double>(v), 1.0 / 2.4) - 0.055);
        if (v <= 1.0f && std::abs(code - std::floor(code) - 0.5) < 1e-3) continue;
        values.push_back(v);
    }
    const int width = 7;
    const int height = static_cast<int>((values.size() + 3 * width - 1) / (3 * width));
    Image image(width, height);
    for (size_t i = 0; i < values.size(); ++i) image.pixels[i / 3][i % 3] = values[i];

    const std::string file = path("ramp.png");
    write_png(file, image);
    int w = 0, h = 0;
    const std::vector<uint8_t> rgb = read_png_rgb(file, &w, &h);
    ASSERT_EQ(width, w);
    ASSERT_EQ(height, h);
    for (size_t i = 0; i < values.size(); ++i) {
        EXPECT_EQ(srgb8_reference(values[i]), rgb[i]) << "linear " << values[i];
    }
    // Padding pixels beyond the values are 0 → code 0.
    for (size_t i = values.size(); i < rgb.size(); ++i) EXPECT_EQ(0, rgb[i]);
}

TEST_F(ImageIoTest, PngExposurePlusOneDoublesBeforeEncoding) {
    // 0.09 → 0.18 → 118 and 0.25 → 0.5 → 188 (published values above); 0.6 → 1.2 clamps to 255.
    Image image(3, 1);
    image.at(0, 0) = Color(0.09f, 0.25f, 0.6f);
    image.at(1, 0) = Color(0.001f, 0.01f, 0.3f);
    image.at(2, 0) = Color(0.0f, 0.45f, 0.49f);
    const std::string file = path("exposure.png");
    write_png(file, image, 1.0f);
    int w = 0, h = 0;
    const std::vector<uint8_t> rgb = read_png_rgb(file, &w, &h);
    ASSERT_EQ(9u, rgb.size());
    EXPECT_EQ(118, rgb[0]);
    EXPECT_EQ(188, rgb[1]);
    EXPECT_EQ(255, rgb[2]);
    for (size_t i = 0; i < 9; ++i) {
        const double linear = image.pixels[i / 3][i % 3];
        EXPECT_EQ(srgb8_reference(2.0 * linear), rgb[i]) << "linear " << linear;
    }
}

TEST(LinearToSrgb, MatchesPublishedFormulaOnBothSidesOfTheBreakpoint) {
    // float evaluation of pow and the affine map: a few float ulps of values ≤ 1, so 1e-6.
    for (double v :
         {0.0, 1e-6, 0.001, 0.0031307, 0.0031308, 0.0031309, 0.01, 0.18, 0.5, 0.9, 1.0}) {
        const double expected = v <= 0.0031308 ? 12.92 * v : 1.055 * std::pow(v, 1.0 / 2.4) - 0.055;
        EXPECT_NEAR(expected, linear_to_srgb(static_cast<float>(v)), 1e-6) << "linear " << v;
    }
    EXPECT_NEAR(1.0, linear_to_srgb(1.0f), 1e-6);
}

}  // namespace
}  // namespace fogmap
