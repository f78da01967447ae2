// Image error metrics against values worked out by hand: zero against itself, a constant offset,
// a ± pattern and a single changed value (render/metrics.h: RMSE, relMSE =
// mean of (x−y)²/(y²+0.01), bias = mean(x−y), over all pixels and channels).

#include "render/metrics.h"

#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>

namespace fogmap {
namespace {

// 2x1 reference whose values make the relMSE terms simple: y² + 0.01 = 0.01, 0.02, 0.1.
Image reference_2x1() {
    Image ref(2, 1);
    ref.at(0, 0) = Color(0.0f, 0.1f, 0.3f);
    ref.at(1, 0) = Color(0.3f, 0.1f, 0.0f);
    return ref;
}

TEST(ImageError, ZeroAgainstItself) {
    Image img(5, 3);
    for (int y = 0; y < 3; ++y)
        for (int x = 0; x < 5; ++x) img.at(x, y) = Color(0.1f * x, 0.37f * y, 2.5f + x * y);
    const ImageError e = image_error(img, img);
    EXPECT_EQ(e.rmse, 0.0);
    EXPECT_EQ(e.rel_mse, 0.0);
    EXPECT_EQ(e.bias, 0.0);
}

TEST(ImageError, ConstantOffsetGivesHandComputedValues) {
    const Image ref = reference_2x1();
    Image img = ref;
    for (Color& c : img.pixels) c += Color(0.1f);
    const ImageError e = image_error(img, ref);
    // d = 0.1 everywhere: RMSE = 0.1, bias = 0.1; relMSE terms 0.01/(y²+0.01) =
    // 1, 0.5, 0.1 for y = 0, 0.1, 0.3, each twice: (1 + 0.5 + 0.1) * 2 / 6 = 0.5333...
    // Tolerance: the inputs are floats (0.1f, 0.3f), relative error ~1e-7.
    EXPECT_NEAR(e.rmse, 0.1, 1e-6);
    EXPECT_NEAR(e.bias, 0.1, 1e-6);
    EXPECT_NEAR(e.rel_mse, 3.2 / 6.0, 1e-6);
}

TEST(ImageError, AlternatingPatternHasNoBias) {
    const Image ref = reference_2x1();
    Image img = ref;
    // +0.2, −0.2 alternating over the six values: squared error 0.04 each, signed sum 0.
    const float d[6] = {0.2f, -0.2f, 0.2f, -0.2f, 0.2f, -0.2f};
    for (int i = 0; i < 6; ++i) img.pixels[i / 3][i % 3] += d[i];
    const ImageError e = image_error(img, ref);
    EXPECT_NEAR(e.rmse, 0.2, 1e-6);
    EXPECT_NEAR(e.bias, 0.0, 1e-7);
    // 0.04 / (y² + 0.01) for y = 0, 0.1, 0.3, 0.3, 0.1, 0 = 4 + 2 + 0.4 + 0.4 + 2 + 4 = 12.8.
    EXPECT_NEAR(e.rel_mse, 12.8 / 6.0, 1e-5);
}

TEST(ImageError, SingleChangedValue) {
    const Image ref = reference_2x1();
    Image img = ref;
    img.at(1, 0)[1] += 0.3f;  // y = 0.1 there
    const ImageError e = image_error(img, ref);
    // One of six values off by 0.3: RMSE = sqrt(0.09 / 6), bias = 0.3 / 6,
    // relMSE = (0.09 / 0.02) / 6 = 0.75.
    EXPECT_NEAR(e.rmse, std::sqrt(0.09 / 6.0), 1e-6);
    EXPECT_NEAR(e.bias, 0.05, 1e-7);
    EXPECT_NEAR(e.rel_mse, 0.75, 1e-5);
}

TEST(ImageError, SizeMismatchThrows) {
    EXPECT_THROW(image_error(Image(2, 1), Image(1, 2)), std::invalid_argument);
}

}  // namespace
}  // namespace fogmap
