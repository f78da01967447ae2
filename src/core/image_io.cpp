#include "core/image.h"

#include "core/error.h"
#include "core/input_file.h"
#include "core/parallel.h"

#include <ImathBox.h>
#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfInputFile.h>
#include <ImfOutputFile.h>
#include <ImfThreading.h>
#include <png.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <exception>
#include <stdexcept>

namespace fogmap {

namespace {

/// OpenEXR output through a CheckedFile: every write and seek is checked, and an error keeps
/// failing (OutputFile writes its line-offset table from its destructor, which swallows
/// exceptions; CheckedFile::close reports it then).
class CheckedExrStream : public Imf::OStream {
public:
    explicit CheckedExrStream(CheckedFile* file)
        : Imf::OStream(file->name().c_str()), file_(file) {}
    void write(const char c[], int n) override {
        if (!file_->write(c, static_cast<size_t>(n))) fail();
        pos_ += static_cast<uint64_t>(n);
    }
    uint64_t tellp() override { return pos_; }
    void seekp(uint64_t pos) override {
        if (!file_->seek(pos)) fail();
        pos_ = pos;
    }

private:
    [[noreturn]] void fail() const { throw std::runtime_error(std::strerror(file_->error())); }
    CheckedFile* file_;
    uint64_t pos_ = 0;
};

/// Adds channels <prefix>R, <prefix>G, <prefix>B of image to header and frame buffer.
void add_rgb(const std::string& prefix, const Image& image, Imf::Header* header,
             Imf::FrameBuffer* frame_buffer) {
    // Color is glm::vec3 of three tightly packed floats (row-major pixels, row 0 on top), which
    // matches EXR's default INCREASING_Y line order with the data window at the origin.
    static_assert(sizeof(Color) == 3 * sizeof(float), "Color must be three packed floats");
    const size_t x_stride = sizeof(Color);
    const size_t y_stride = sizeof(Color) * static_cast<size_t>(image.width);
    const char* names[3] = {"R", "G", "B"};
    for (int c = 0; c < 3; ++c) {
        const std::string name = prefix + names[c];
        header->channels().insert(name, Imf::Channel(Imf::FLOAT));
        // OpenEXR's Slice wants a non-const pointer even for writing; it only reads from it.
        char* base = const_cast<char*>(reinterpret_cast<const char*>(image.pixels.data())) +
                     c * sizeof(float);
        frame_buffer->insert(name, Imf::Slice(Imf::FLOAT, base, x_stride, y_stride));
    }
}

std::string channel_names(const Imf::ChannelList& channels) {
    std::string names;
    for (auto it = channels.begin(); it != channels.end(); ++it) {
        if (!names.empty()) names += ", ";
        names += it.name();
    }
    return names.empty() ? std::string("(none)") : names;
}

/// One 8-bit sRGB code: NaN and negatives → 0, above 1 → 255 (clamp before the transfer).
uint8_t srgb_code(float linear) {
    const float v = std::isnan(linear) ? 0.0f : std::min(1.0f, std::max(0.0f, linear));
    return static_cast<uint8_t>(std::lround(255.0 * static_cast<double>(linear_to_srgb(v))));
}

}  // namespace

double Image::mean() const {
    if (pixels.empty()) return 0.0;
    double sum = 0.0;
    for (const Color& p : pixels) sum += static_cast<double>(p.x) + p.y + p.z;
    return sum / (3.0 * static_cast<double>(pixels.size()));
}

void write_exr(const StagedFile& to, const Image& beauty, const std::vector<NamedImage>& layers) {
    const std::string& path = to.path;
    if (beauty.width <= 0 || beauty.height <= 0) {
        throw std::runtime_error(path + ": cannot write an empty image (" +
                                 std::to_string(beauty.width) + "x" +
                                 std::to_string(beauty.height) + ")");
    }
    for (const NamedImage& layer : layers) {
        if (layer.image == nullptr || layer.image->width != beauty.width ||
            layer.image->height != beauty.height) {
            throw std::runtime_error(path + ": layer '" + layer.name +
                                     "' is missing or differs in size from the beauty image");
        }
    }
    CheckedFile file(to.temp, path);
    try {
        Imf::Header header(beauty.width, beauty.height);
        header.compression() = Imf::ZIP_COMPRESSION;
        Imf::FrameBuffer frame_buffer;
        add_rgb("", beauty, &header, &frame_buffer);
        for (const NamedImage& layer : layers) {
            add_rgb(layer.name + ".", *layer.image, &header, &frame_buffer);
        }
        CheckedExrStream stream(&file);
        // OpenEXR compresses blocks of lines on the run's threads (the file's bytes do not
        // depend on how many). The line-offset table is written when `exr` goes out of scope;
        // a failure there is kept by `file` and reported by close() below.
        const int threads = active_thread_count();
        if (Imf::globalThreadCount() != threads) Imf::setGlobalThreadCount(threads);
        Imf::OutputFile exr(stream, header, threads);
        exr.setFrameBuffer(frame_buffer);
        exr.writePixels(beauty.height);
    } catch (const std::exception& e) {
        throw std::runtime_error(path + ": cannot write OpenEXR file: " +
                                 (file.error() ? std::strerror(file.error()) : e.what()));
    }
    file.close("OpenEXR file");
}

void write_exr(const std::string& path, const Image& beauty,
               const std::vector<NamedImage>& layers) {
    OutputFiles out;
    write_exr(out.stage(path), beauty, layers);
    out.commit();
}

Image read_exr(const std::string& path, const std::string& layer) {
    check_input_file(path, "", "OpenEXR image");
    try {
        Imf::InputFile file(path.c_str());
        const Imf::Header& header = file.header();
        const std::string prefix = layer.empty() ? std::string() : layer + ".";
        const std::string wanted[3] = {prefix + "R", prefix + "G", prefix + "B"};
        for (const std::string& name : wanted) {
            if (header.channels().findChannel(name) == nullptr) {
                throw InputError{path, "",
                                 "no channel '" + name + "'" +
                                     (layer.empty() ? "" : " (layer '" + layer + "')") +
                                     "; channels present: " + channel_names(header.channels())};
            }
        }
        const Imath::Box2i dw = header.dataWindow();
        Image image(dw.max.x - dw.min.x + 1, dw.max.y - dw.min.y + 1);
        // Slice::Make shifts the base pointer by the data window origin, so pixel (min.x, min.y)
        // lands at image.at(0, 0) whatever the window's offset. Stored HALF/UINT become float.
        Imf::FrameBuffer frame_buffer;
        for (int c = 0; c < 3; ++c) {
            frame_buffer.insert(
                wanted[c],
                Imf::Slice::Make(Imf::FLOAT, &image.pixels.data()->x + c, dw, sizeof(Color),
                                 sizeof(Color) * static_cast<size_t>(image.width)));
        }
        file.setFrameBuffer(frame_buffer);
        file.readPixels(dw.min.y, dw.max.y);
        return image;
    } catch (const InputError&) {
        throw;
    } catch (const std::exception& e) {
        throw InputError{path, "", std::string("cannot read OpenEXR file: ") + e.what()};
    }
}

void check_finite(const Image& image, const std::string& path) {
    for (size_t i = 0; i < image.pixels.size(); ++i) {
        const Color& p = image.pixels[i];
        if (is_finite(p)) continue;
        const auto text = [](float v) {
            char buf[32];
            std::snprintf(buf, sizeof buf, "%g", static_cast<double>(v));
            return std::string(buf);
        };
        throw InputError(path, "",
                         "pixel (" + std::to_string(i % static_cast<size_t>(image.width)) + ", " +
                             std::to_string(i / static_cast<size_t>(image.width)) + ") is (" +
                             text(p.x) + ", " + text(p.y) + ", " + text(p.z) +
                             "); a reference image must be finite everywhere (one NaN makes "
                             "every error metric NaN)");
    }
}

void write_png(const StagedFile& to, const Image& image, float exposure) {
    const std::string& path = to.path;
    if (image.width <= 0 || image.height <= 0) {
        throw std::runtime_error(path + ": cannot write an empty image (" +
                                 std::to_string(image.width) + "x" + std::to_string(image.height) +
                                 ")");
    }
    const float scale = std::exp2(exposure);
    std::vector<uint8_t> rgb(static_cast<size_t>(image.width) * image.height * 3);
    for (size_t i = 0; i < image.pixels.size(); ++i) {
        const Color& p = image.pixels[i];
        rgb[3 * i + 0] = srgb_code(p.x * scale);
        rgb[3 * i + 1] = srgb_code(p.y * scale);
        rgb[3 * i + 2] = srgb_code(p.z * scale);
    }
    // libpng's simplified API (1.6) reports errors through png_image::message instead of
    // longjmp, and tags 8-bit output with an sRGB chunk. Encoded in memory (into a buffer of the
    // largest size a PNG of this image can take), then written through a CheckedFile like every
    // output.
    png_image png{};
    png.version = PNG_IMAGE_VERSION;
    png.width = static_cast<png_uint_32>(image.width);
    png.height = static_cast<png_uint_32>(image.height);
    png.format = PNG_FORMAT_RGB;
    png_alloc_size_t size = PNG_IMAGE_PNG_SIZE_MAX(png);
    std::vector<uint8_t> encoded(size);
    const bool ok =
        png_image_write_to_memory(&png, encoded.data(), &size, 0, rgb.data(), 0, nullptr) != 0;
    if (!ok) {
        const std::string message = png.message;
        png_image_free(&png);
        throw std::runtime_error(path + ": cannot write PNG file: " + message);
    }
    CheckedFile file(to.temp, path);
    file.write(encoded.data(), size);
    file.close("PNG file");
}

void write_png(const std::string& path, const Image& image, float exposure) {
    OutputFiles out;
    write_png(out.stage(path), image, exposure);
    out.commit();
}

float linear_to_srgb(float v) {
    // IEC 61966-2-1 sRGB OETF: linear segment below 0.0031308, gamma 1/2.4 with offset above.
    if (v <= 0.0031308f) return 12.92f * v;
    return 1.055f * std::pow(v, 1.0f / 2.4f) - 0.055f;
}

}  // namespace fogmap
