#pragma once
// Image error metrics against a reference (docs/measurements.md), over all pixels
// and channels: RMSE, relative MSE = mean of (x−y)²/(y²+0.01), mean bias = mean(x−y).
// Pure functions; thread-safe.

#include "core/image.h"

namespace fogmap {

struct ImageError {
    double rmse = 0.0;
    double rel_mse = 0.0;
    double bias = 0.0;
};

/// Error of `image` against `reference`; throws std::invalid_argument if the sizes differ.
ImageError image_error(const Image& image, const Image& reference);

}  // namespace fogmap
