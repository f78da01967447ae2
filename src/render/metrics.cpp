#include "render/metrics.h"

#include <cmath>
#include <stdexcept>

namespace fogmap {

ImageError image_error(const Image& image, const Image& reference) {
    if (image.width != reference.width || image.height != reference.height)
        throw std::invalid_argument("image is " + std::to_string(image.width) + "x" +
                                    std::to_string(image.height) + ", reference is " +
                                    std::to_string(reference.width) + "x" +
                                    std::to_string(reference.height));
    double se = 0.0, rel = 0.0, bias = 0.0;
    for (size_t i = 0; i < image.pixels.size(); ++i) {
        for (int c = 0; c < 3; ++c) {
            const double x = image.pixels[i][c], y = reference.pixels[i][c];
            const double d = x - y;
            se += d * d;
            rel += relative_squared_error(d * d, y);
            bias += d;
        }
    }
    const double n = 3.0 * static_cast<double>(image.pixels.size());
    if (n == 0.0) return {};
    return {std::sqrt(se / n), rel / n, bias / n};
}

}  // namespace fogmap
