#pragma once
// Images and their files: a linear RGB float image, multi-layer OpenEXR in and out, and an sRGB
// PNG preview. Every writer writes "<path>.tmp-<pid>" (each write and the close checked) and
// renames it over <path> only when it is complete (core/output_files.h; the StagedFile overloads
// let one OutputFiles commit several files together), so a failed run never leaves half a file
// and never destroys an older one. Not thread-safe per Image.

#include "core/math.h"
#include "core/output_files.h"

#include <string>
#include <utility>
#include <vector>

namespace fogmap {

struct Image {
    int width = 0;
    int height = 0;
    std::vector<Color> pixels;  ///< row-major, row 0 at the top

    Image() = default;
    Image(int w, int h) : width(w), height(h), pixels(static_cast<size_t>(w) * h, Color(0.0f)) {}
    Color& at(int x, int y) { return pixels[static_cast<size_t>(y) * width + x]; }
    const Color& at(int x, int y) const { return pixels[static_cast<size_t>(y) * width + x]; }
    /// Mean over all pixels and channels.
    double mean() const;
};

/// A named extra layer (AOV) of an EXR file: channels "<name>.R", "<name>.G", "<name>.B".
struct NamedImage {
    std::string name;
    const Image* image;
};

/// Writes beauty as channels R, G, B (float) plus each layer; all images must share the size.
/// Atomic (temp file + rename). Throws std::runtime_error naming the path on I/O failure.
void write_exr(const std::string& path, const Image& beauty,
               const std::vector<NamedImage>& layers = {});
/// The same into to.temp, for OutputFiles::commit() to rename; errors name to.path.
void write_exr(const StagedFile& to, const Image& beauty,
               const std::vector<NamedImage>& layers = {});

/// Reads the R, G, B channels (or "<layer>.R/G/B" when layer is given) of an EXR file.
/// Throws InputError{path, "", reason} if the file is missing, unreadable or lacks the channels.
Image read_exr(const std::string& path, const std::string& layer = "");

/// 8-bit sRGB PNG of image * 2^exposure (clamped). Atomic. Throws std::runtime_error on failure.
void write_png(const std::string& path, const Image& image, float exposure = 0.0f);
/// The same into to.temp, for OutputFiles::commit() to rename; errors name to.path.
void write_png(const StagedFile& to, const Image& image, float exposure = 0.0f);

/// Throws InputError{path, "", reason} naming the first pixel (x, y) with a NaN or infinite
/// channel: a reference image must be finite (one NaN makes every error metric NaN).
void check_finite(const Image& image, const std::string& path);

/// Linear → sRGB transfer function on [0, 1].
float linear_to_srgb(float v);

}  // namespace fogmap
