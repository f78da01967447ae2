#pragma once
// The image side of every integrator: the output layers (one enumeration and its name table,
// in EXR order), one camera sample's radiance split into them, the film of pixel means and its
// fixed-point sum over iterations, the render statistics, and the per-pixel sample loop every
// integrator runs (pixel key, N-rooks position, the sample's Rng(seed, pixel, s), non-finite
// samples dropped, the mean). A layered film's beauty is the sum of its layers; an unlayered one
// holds beauty alone. Deterministic: pixel (x, y), sample s draws from Rng(seed, y*width+x, s)
// whatever the thread.

#include "core/error.h"
#include "core/image.h"
#include "core/parallel.h"
#include "core/rng.h"
#include "core/timer.h"
#include "render/camera.h"
#include "render/tiles.h"

#include <array>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <vector>

namespace fogmap {

/// Additive parts of the beauty image, each its own EXR layer. A new layer: one enumerator and
/// its name below (kLayerCount counts to the last enumerator; the static_assert checks the two).
enum class Layer { Direct, VolumeSingle, VolumeMultiple, Caustic, Indirect, Emission };
inline constexpr int kLayerCount = static_cast<int>(Layer::Emission) + 1;  ///< Emission is last
/// EXR layer names, in Layer order.
inline constexpr std::array kLayerNames{"direct",  "volume_single", "volume_multiple",
                                        "caustic", "indirect",      "emission"};
static_assert(kLayerNames.size() == size_t(kLayerCount),
              "one name per Layer, and kLayerCount up to the last one");

/// One camera sample: its radiance per layer (layered integrators) or whole (beauty only).
struct FilmSample {
    std::array<Color, kLayerCount> layers{};
    Color beauty{0.0f};  ///< unlayered integrators only
    Color& operator[](Layer l) { return layers[static_cast<int>(l)]; }
    Color layer_sum() const {
        Color sum(0.0f);
        for (const Color& c : layers) sum += c;
        return sum;
    }
};

/// Which camera sample of its pixel a ray is: sample s of spp, and the pixel's own key (a stream
/// apart from the samples'), for integrators that treat some samples of a pixel apart.
struct PixelSample {
    int s = 0, spp = 1;
    uint64_t key = 0;
    int x = 0, y = 0;  ///< the pixel
};

struct RenderStats {
    double render_s = 0.0;   ///< wall time of the render pass
    uint64_t samples = 0;    ///< camera samples traced
    uint64_t rays = 0;       ///< Embree queries (closest hit + occlusion)
    uint64_t nonfinite = 0;  ///< samples dropped because they were NaN or infinite
    uint64_t capped = 0;     ///< samples whose path render.max_depth cut while it carried light
    uint64_t steps = 0;      ///< medium density evaluations and tentative collisions
    uint64_t lookups = 0;    ///< photon-map and sun-grid lookups
    uint64_t gathered = 0;   ///< photons those lookups gathered from kd-trees
    int threads = 0;         ///< worker threads used
};

/// Pixel means: beauty, and for a layered film one image per Layer (beauty = their sum).
struct Film {
    Image beauty;
    std::vector<Image> layers;  ///< kLayerCount images, or none

    Film() = default;
    Film(int width, int height, bool layered)
        : beauty(width, height), layers(layered ? kLayerCount : 0, Image(width, height)) {}
    bool layered() const { return !layers.empty(); }
    const Image& layer(Layer l) const {
        FOGMAP_ASSERT(layered(), "an unlayered film has no layers");
        return layers[static_cast<int>(l)];
    }
    /// The EXR's extra layers, named (none for an unlayered film).
    std::vector<NamedImage> named_layers() const {
        std::vector<NamedImage> out;
        for (size_t l = 0; l < layers.size(); ++l) out.push_back({kLayerNames[l], &layers[l]});
        return out;
    }
};

/// Sums of films in 64-bit fixed point (2^-32 units per value): integer addition is exact and
/// associative, so a sum over iterations has the same bits whatever order — or rank — the
/// iterations were added in (docs/design.md, Determinism). Values beyond ±2^24 (radiance 1.7e7),
/// and sums that would overflow, are clamped and counted (the pipeline warns).
struct FixedFilm {
    static constexpr double kUnit = 4294967296.0;  // 2^32
    int width = 0, height = 0;
    bool layered = false;
    std::vector<int64_t> values;  ///< beauty, then each layer; 3 per pixel
    uint64_t clamped = 0;

    /// Adds `film` (its shape is taken when empty).
    void add(const Film& film) {
        if (values.empty()) {
            width = film.beauty.width;
            height = film.beauty.height;
            layered = film.layered();
            values.assign(size_t(3) * width * height * (1 + film.layers.size()), 0);
        }
        size_t n = 0;
        auto add_image = [&](const Image& img) {
            for (const Color& c : img.pixels)
                for (int k = 0; k < 3; ++k, ++n) values[n] = add_saturated(values[n], c[k]);
        };
        add_image(film.beauty);
        for (const Image& img : film.layers) add_image(img);
    }
    /// The mean over `count` added films.
    Film mean(int count) const {
        Film film(width, height, layered);
        const double scale = 1.0 / (kUnit * count);
        size_t n = 0;
        auto read_image = [&](Image& img) {
            for (Color& c : img.pixels)
                for (int k = 0; k < 3; ++k) c[k] = static_cast<float>(values[n++] * scale);
        };
        read_image(film.beauty);
        for (Image& img : film.layers) read_image(img);
        return film;
    }

private:
    int64_t add_saturated(int64_t sum, float v) {
        constexpr double kMax = 16777216.0;  // 2^24
        const double x = double(v);
        int64_t fixed;
        if (!(std::abs(x) <= kMax)) {
            ++clamped;
            fixed = x > 0.0 ? int64_t(kMax * kUnit) : -int64_t(kMax * kUnit);
        } else {
            fixed = std::llround(x * kUnit);
        }
        int64_t r;
        if (__builtin_add_overflow(sum, fixed, &r)) {
            ++clamped;
            r = fixed > 0 ? INT64_MAX : INT64_MIN;
        }
        return r;
    }
};

/// The per-pixel sample loop of every integrator: for each pixel of `camera`'s image in `share`'s
/// tiles (the others stay 0), spp samples
/// at N-rooks positions, sample s drawing from Rng(seed, pixel, s) first its two position
/// uniforms, then trace(ray, rng, state, PixelSample) -> FilmSample; non-finite samples are dropped
/// (counted) and the film holds the mean over spp. state = make_state() per tile; state.rays,
/// state.capped, state.lookups, state.gathered and the steps of state.media are summed into
/// *stats (may be null).
template <class MakeState, class Trace>
Film render_film(const Camera& camera, int spp, uint64_t seed, TileShare share, bool layered,
                 bool quiet, RenderStats* stats, MakeState&& make_state, Trace&& trace) {
    const int w = camera.width(), h = camera.height();
    Film film(w, h, layered);
    std::atomic<uint64_t> rays{0}, nonfinite{0}, capped{0}, steps{0}, lookups{0}, gathered{0};
    const float inv = 1.0f / static_cast<float>(spp);
    const Timer timer;
    auto shade = [&](int x, int y, auto& state) {
        FilmSample sum;
        uint64_t dropped = 0;
        const uint64_t pixel = static_cast<uint64_t>(y) * w + x;
        const uint64_t jitter_key = pixel_key(seed, pixel);
        for (int s = 0; s < spp; ++s) {
            Rng rng(seed, pixel, static_cast<uint64_t>(s));
            const Vec2 j = pixel_jitter(s, spp, jitter_key, Vec2(rng.uniform(), rng.uniform()));
            const FilmSample c = trace(camera.generate(x + j.x, y + j.y), rng, state,
                                       PixelSample{s, spp, jitter_key, x, y});
            if (!is_finite(layered ? c.layer_sum() : c.beauty)) {
                ++dropped;
                continue;
            }
            if (!layered) sum.beauty += c.beauty;
            for (int l = 0; layered && l < kLayerCount; ++l) sum.layers[l] += c.layers[l];
        }
        film.beauty.at(x, y) = (layered ? sum.layer_sum() : sum.beauty) * inv;
        for (int l = 0; layered && l < kLayerCount; ++l)
            film.layers[l].at(x, y) = sum.layers[l] * inv;
        if (dropped) nonfinite += dropped;
    };
    auto end_tile = [&](const auto& state) {
        rays += state.rays;
        capped += state.capped;
        lookups += state.lookups;
        gathered += state.gathered;
        for (const auto& m : state.media) steps += m.steps();
    };
    const uint64_t pixels = render_tiles(w, h, share, quiet, make_state, shade, end_tile);
    if (stats) {
        stats->render_s = timer.seconds();
        stats->samples = pixels * static_cast<uint64_t>(spp);
        stats->rays = rays.load();
        stats->nonfinite = nonfinite.load();
        stats->capped = capped.load();
        stats->steps = steps.load();
        stats->lookups = lookups.load();
        stats->gathered = gathered.load();
        stats->threads = active_thread_count();
    }
    return film;
}

}  // namespace fogmap
