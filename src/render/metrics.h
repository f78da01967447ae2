#pragma once
// Image error metrics against a reference (docs/measurements.md), over all pixels
// and channels: RMSE, relative MSE = mean of (x−y)²/(y²+kRelMseFloor), mean bias = mean(x−y).
// Pure functions; thread-safe.

#include "core/image.h"

namespace fogmap {

/// relMSE's floor under y²: the relative error of near-black pixels counts as absolute, so they
/// do not dominate the mean (docs/measurements.md).
inline constexpr double kRelMseFloor = 0.01;

/// One value's relative squared error: squared_error / (y² + kRelMseFloor), y the reference.
inline double relative_squared_error(double squared_error, double y) {
    return squared_error / (y * y + kRelMseFloor);
}

struct ImageError {
    double rmse = 0.0;
    double rel_mse = 0.0;
    double bias = 0.0;
};

/// Error of `image` against `reference`; throws std::invalid_argument if the sizes differ.
ImageError image_error(const Image& image, const Image& reference);

}  // namespace fogmap
