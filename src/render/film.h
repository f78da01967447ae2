#pragma once
// The image side of every integrator: the output layers (one enumeration and its name table,
// in EXR order), one camera sample's radiance split into them, the film of pixel means and its
// fixed-point sum over iterations, the render statistics, and the per-pixel sample loop every
// integrator runs (pixel key, position (render/batches.h), the sample's Rng(seed, pixel, s),
// non-finite samples dropped, the mean). A layered film's beauty is the sum of its layers; an
// unlayered one holds beauty alone. Beside the mean, every film keeps kBatches batch means of the
// beauty, from which the run estimates its own error (render/error_estimate.h). Deterministic:
// pixel (x, y), sample s draws from Rng(seed, y*width+x, s) and falls in batch (s / unit) mod
// kBatches, whatever the thread.

#include "core/error.h"
#include "core/image.h"
#include "core/parallel.h"
#include "core/rng.h"
#include "core/timer.h"
#include "render/batches.h"
#include "render/camera.h"
#include "render/tiles.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <limits>
#include <optional>
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
    Color beauty{0.0f};  ///< read by unlayered films (a layered one adds up the layers)
    /// Where the sample read a photon map in batches (render/volume_map_end.h, PhotonBatches):
    /// its value with batch t's map alone less its value, per photon batch t, and each photon
    /// half's estimate of the map's bias in it (RadiusBias).
    std::array<Color, kBatches> photon_delta{};
    std::array<Color, 2> bias_half{};
    bool batched = false;  ///< whether it read one (else the two above are 0 and unread)
    Color& operator[](Layer l) { return layers[static_cast<int>(l)]; }
    Color layer_sum() const {
        Color sum(0.0f);
        for (const Color& c : layers) sum += c;
        return sum;
    }
};

/// Adds to `delta` (a FilmSample::photon_delta) what a sample's map term `term` would change by
/// with each photon batch's map alone, whose estimate is the whole's times its share.
inline void add_photon_delta(const Color& term, const std::array<float, kBatches>& shares,
                             std::array<Color, kBatches>* delta) {
    for (size_t t = 0; t < shares.size(); ++t) (*delta)[t] += (shares[t] - 1.0f) * term;
}

/// Which camera sample of its pixel a ray is: sample s of spp, and the pixel's own key (a stream
/// apart from the samples'), for integrators that treat some samples of a pixel apart.
struct PixelSample {
    int s = 0, spp = 1;
    uint64_t key = 0;
    int x = 0, y = 0;   ///< the pixel
    float time = 0.0f;  ///< seconds from the frame within the camera's shutter (0: none)
};

/// The time of sample s of a pass of a pixel within `shutter`: the pass's samples stratified over
/// the shutter as `strata` says (each batch's over it too, in an order shuffled per pixel), each
/// uniform in its stratum, from a stream of their own (the samples' Rng untouched).
inline float shutter_time(const ShutterDesc& shutter, const PassStrata& strata, int s,
                          uint64_t seed, uint64_t pixel) {
    const uint64_t key = derive_seed(seed, stream::kShutter, pixel);
    const int stratum = strata.stratum(s, key, true);
    const float u = Rng(key, static_cast<uint64_t>(s)).uniform();
    return shutter.seconds(std::min((float(stratum) + u) / float(strata.size()), 1.0f));
}

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

/// Pixel means: beauty, and for a layered film one image per Layer (beauty = their sum); the
/// beauty's mean over each batch's samples, and each batch's share of the samples (the shares
/// sum to 1; beauty = the batch means weighted by them). The pipeline adds the estimate's
/// per-pixel variance of the mean and the samples per pixel (empty until then).
struct Film {
    Image beauty;
    std::vector<Image> layers;   ///< kLayerCount images, or none
    std::vector<Image> batches;  ///< kBatches images
    std::array<double, kBatches> batch_share{};
    /// Per pixel, the variance of the mean that one photon map read by every sample adds, which
    /// the batches cannot see (PhotonBatchSums): empty unless the samples read a map in batches
    /// (render_film), and for a sum of iterations (each has a map of its own, and batches hold
    /// its noise).
    Image map_variance;
    /// Per pixel, 2 s + h: the mean over sample half s of photon half h's estimate of the map's
    /// bias (BiasHalves); kept and emptied as map_variance is.
    std::vector<Image> bias_halves;
    Image variance, samples;  ///< written as EXR layers when set
    /// Adaptive sampling (render/adaptive.cpp): each pixel's samples, batched by whole `unit`s as
    /// render_film batches them, so that its batches' shares differ from pixel to pixel
    /// (Film::shares; batch_share then holds the first pass's, which every pixel took, or with
    /// counts given in advance (GivenSamples) a uniform render's, unread); empty when every pixel
    /// has the same.
    std::vector<int> pixel_spp;
    int unit = 1;
    /// A sum of iterations' mean (FixedFilm::mean) whose pixels took samples of their own: each
    /// pixel's samples per batch (pixel_spp their sum); empty otherwise.
    std::vector<std::array<int, kBatches>> batch_spp;

    Film() = default;
    Film(int width, int height, bool layered)
        : beauty(width, height),
          layers(layered ? kLayerCount : 0, Image(width, height)),
          batches(kBatches, Image(width, height)) {}
    bool layered() const { return !layers.empty(); }
    /// Pixel p's batch shares: batch_share, or its own under adaptive sampling (batch_spp's, or
    /// pixel_spp's batched by `unit`).
    std::array<double, kBatches> shares(size_t p) const;
    /// Pixel p's samples per batch where pixels have their own (pixel_spp set).
    std::array<int, kBatches> batch_samples(size_t p) const {
        return batch_spp.empty() ? batch_counts(0, pixel_spp[p], unit) : batch_spp[p];
    }
    const Image& layer(Layer l) const {
        FOGMAP_ASSERT(layered(), "an unlayered film has no layers");
        return layers[static_cast<int>(l)];
    }
    /// The EXR's extra layers, named: the Layers (none for an unlayered film), then variance and
    /// samples when set.
    std::vector<NamedImage> named_layers() const {
        std::vector<NamedImage> out;
        for (size_t l = 0; l < layers.size(); ++l) out.push_back({kLayerNames[l], &layers[l]});
        if (!variance.pixels.empty()) out.push_back({"variance", &variance});
        if (!samples.pixels.empty()) out.push_back({"samples", &samples});
        return out;
    }
};

/// a + b, or where that would overflow the int64 bound on b's side, with `*saturated` set: the
/// fixed-point sums' one addition (FixedFilm, IterationMeasure).
inline int64_t saturating_add(int64_t a, int64_t b, bool* saturated = nullptr) {
    int64_t r;
    if (!__builtin_add_overflow(a, b, &r)) return r;
    if (saturated) *saturated = true;
    return b > 0 ? INT64_MAX : INT64_MIN;
}

/// Sums of films in 64-bit fixed point (2^-32 units per value): integer addition is exact and
/// associative, so a sum over iterations has the same bits whatever order — or rank — the
/// iterations were added in (docs/design.md, Determinism). Values beyond ±2^24 (radiance 1.7e7),
/// and sums that would overflow, are clamped and counted (the pipeline warns). Iteration i's
/// beauty is also summed into batch (i - 1) mod kBatches: the sum of iterations 1 .. count holds
/// count / kBatches of them in each batch, one more in the first count mod kBatches. With `bias`,
/// iteration i's estimate of its maps' bias from photon half h, over all its samples (an
/// iteration of one sample a pixel has but one sample half), is summed into bias half
/// 2 ((i - 1) mod 2) + h: halves of different parities come from different iterations, whose
/// samples and maps are independent, so that the mean film's bias_halves keep their contract.
/// Each iteration's pixel means weigh by the pixel's samples in it over the iteration's spp (1
/// for a uniform iteration), so that under adaptive sampling a pixel's mean is that of all its
/// samples, and each pixel's samples per batch are summed too (integers, after the images).
struct FixedFilm {
    static constexpr double kUnit = 4294967296.0;  // 2^32
    int width = 0, height = 0;
    bool layered = false, bias = false;
    /// Beauty, each layer, each batch's beauty, with `bias` the four bias halves (3 per pixel),
    /// then each pixel's samples per batch (kBatches).
    std::vector<int64_t> values;
    uint64_t clamped = 0;

    /// The values of a sum of `width` x `height` films, layered or not, with bias halves or not.
    static size_t value_count(int width, int height, bool layered, bool bias) {
        return size_t(width) * height *
               (3 * (1 + (layered ? kLayerCount : 0) + kBatches + (bias ? 4 : 0)) + kBatches);
    }
    /// An empty sum (all zero) of films of this shape.
    void zero(int w, int h, bool with_layers, bool with_bias) {
        width = w;
        height = h;
        layered = with_layers;
        bias = with_bias;
        values.assign(value_count(w, h, with_layers, with_bias), 0);
    }
    /// Adds iteration `index`'s `film` of `spp` samples a pixel, or of its own (Film::pixel_spp)
    /// (its shape is taken when empty; with `bias`, the film has bias_halves).
    void add(const Film& film, int index, int spp) {
        if (values.empty())
            zero(film.beauty.width, film.beauty.height, film.layered(), !film.bias_halves.empty());
        const size_t pixels = size_t(width) * height, image = 3 * pixels,
                     first_batch = 1 + film.layers.size(),
                     batch = size_t(class_of(index, kBatches));
        std::vector<double> weight(pixels, 1.0);
        const size_t samples = values.size() - kBatches * pixels;
        for (size_t p = 0; p < pixels; ++p) {
            const int n = film.pixel_spp.empty() ? spp : film.pixel_spp[p];
            FOGMAP_ASSERT(n >= 0 && n <= 64 * spp,
                          "a pixel takes at most 64 times an iteration's spp");
            values[samples + kBatches * p + batch] += n;
            weight[p] = double(n) / spp;
        }
        add_image(film.beauty, weight, 0);
        for (size_t l = 0; l < film.layers.size(); ++l)
            add_image(film.layers[l], weight, (1 + l) * image);
        const uint64_t counted = clamped;  // the beauty's clamps are counted once
        add_image(film.beauty, weight, (first_batch + batch) * image);
        clamped = counted;
        if (!bias) return;
        FOGMAP_ASSERT(film.bias_halves.size() == 4, "a sum with bias halves adds films with them");
        // Photon half h's estimate over all the pixel's samples: its sample halves' weighted by
        // their shares of them (sample half s holds every other batch).
        std::array<Image, 2> whole{Image(width, height), Image(width, height)};
        for (size_t p = 0; p < pixels; ++p) {
            const std::array<double, kBatches> shares = film.shares(p);
            float share[2] = {0.0f, 0.0f};
            for (size_t b = 0; b < size_t(kBatches); ++b) share[b % 2] += float(shares[b]);
            for (size_t h = 0; h < 2; ++h)
                whole[h].pixels[p] = share[0] * film.bias_halves[h].pixels[p] +
                                     share[1] * film.bias_halves[2 + h].pixels[p];
        }
        for (size_t h = 0; h < 2; ++h)
            add_image(whole[h], weight,
                      (first_batch + kBatches + 2 * size_t(class_of(index, 2)) + h) * image);
        clamped = counted;
    }
    /// The mean over iterations 1 .. `count` of `spp` samples a pixel each (or their own),
    /// batched by iteration; each pixel's samples, and where pixels' batches differ, their own.
    Film mean(int count, int spp) const {
        Film film(width, height, layered);
        const size_t pixels = size_t(width) * height, samples = values.size() - kBatches * pixels;
        // Pixel p's samples in the batches whose bit is set in `mask`; the weight its values add.
        auto samples_in = [&](size_t p, unsigned mask) {
            int64_t n = 0;
            for (size_t b = 0; b < size_t(kBatches); ++b)
                if (mask >> b & 1u) n += values[samples + kBatches * p + b];
            return n;
        };
        size_t n = 0;
        auto read_image = [&](Image& img, unsigned mask) {
            for (size_t p = 0; p < img.pixels.size(); ++p) {
                const double of = double(samples_in(p, mask)) / spp;
                const double scale = of > 0.0 ? 1.0 / (kUnit * of) : 0.0;
                for (int k = 0; k < 3; ++k) img.pixels[p][k] = float(values[n++] * scale);
            }
        };
        static_assert(kBatches % 2 == 0 && kBatches <= 8,
                      "batch b holds iterations of parity b mod 2");
        constexpr unsigned kAll = (1u << kBatches) - 1u, kEven = 0x55u & kAll;
        read_image(film.beauty, kAll);
        for (Image& img : film.layers) read_image(img, kAll);
        bool uniform = true;  // every pixel's batches hold their iterations' spp
        for (int b = 0; b < kBatches; ++b) {
            read_image(film.batches[size_t(b)], 1u << b);
            const int iterations = in_class(count, b, kBatches);
            film.batch_share[size_t(b)] = double(iterations) / count;
            for (size_t p = 0; p < pixels && uniform; ++p)
                uniform = samples_in(p, 1u << b) == int64_t(iterations) * spp;
        }
        if (bias && count >= 2) {  // both parities hold iterations (batch b has parity b mod 2)
            film.bias_halves.assign(4, Image(width, height));
            for (int i = 0; i < 4; ++i)
                read_image(film.bias_halves[size_t(i)], i / 2 == 0 ? kEven : kAll & ~kEven);
        }
        film.samples = Image(width, height);
        for (size_t p = 0; p < pixels; ++p)
            film.samples.pixels[p] = Color(float(samples_in(p, kAll)));
        if (uniform) return film;
        film.pixel_spp.resize(pixels);
        film.batch_spp.resize(pixels);
        for (size_t p = 0; p < pixels; ++p) {
            film.pixel_spp[p] = int(samples_in(p, kAll));
            for (size_t b = 0; b < size_t(kBatches); ++b)
                film.batch_spp[p][b] = int(values[samples + kBatches * p + b]);
        }
        return film;
    }

private:
    /// Adds `img`, each pixel times its `weight`, to the values from value `at` on.
    void add_image(const Image& img, const std::vector<double>& weight, size_t at) {
        for (size_t p = 0; p < img.pixels.size(); ++p)
            for (int k = 0; k < 3; ++k, ++at)
                values[at] = add_saturated(values[at], img.pixels[p][k], weight[p]);
    }
    /// Iteration `index` (from 1) falls in class (index − 1) mod `classes`: its batch (kBatches)
    /// and its bias halves' parity (2).
    static int class_of(int index, int classes) { return (index - 1) % classes; }
    /// Of iterations 1 .. count, those in class k of `classes`.
    static int in_class(int count, int k, int classes) {
        return count / classes + (k < count % classes ? 1 : 0);
    }
    /// sum + v w in fixed point, v clamped to ±2^24 (w at most 2^6, so v w kUnit fits).
    int64_t add_saturated(int64_t sum, float v, double w) {
        constexpr double kMax = 16777216.0;  // 2^24
        const double x = double(v);
        int64_t fixed;
        if (!(std::abs(x) <= kMax)) {
            ++clamped;
            fixed = std::llround((x > 0.0 ? kMax : -kMax) * w * kUnit);
        } else {
            fixed = std::llround(x * w * kUnit);
        }
        bool over = false;
        const int64_t r = saturating_add(sum, fixed, &over);
        clamped += over;
        return r;
    }
};

inline std::array<double, kBatches> Film::shares(size_t p) const {
    if (pixel_spp.empty()) return batch_share;
    const int n = pixel_spp[p];
    const std::array<int, kBatches> counts = batch_samples(p);
    std::array<double, kBatches> out{};
    for (size_t b = 0; b < size_t(kBatches); ++b) out[b] = n > 0 ? double(counts[b]) / n : 0.0;
    return out;
}

/// A pixel's samples' photon_delta summed per photon batch t and sample batch b, and from them
/// the variance one photon map read by every sample adds to the pixel's mean. The deviation of
/// batch t's estimate from the whole, averaged over one sample batch, is the map's error that
/// the pixel's samples share plus noise of those samples' own; over two independent sample
/// batches only the shared error correlates, so the mean product of pairs is (K − 1) times its
/// variance (K photon batches, each K times sparser). Unbiased for any batch sizes.
struct PhotonBatchSums {
    std::array<std::array<Color, kBatches>, kBatches> sum{};  ///< [photon batch][sample batch]
    void add(const std::array<Color, kBatches>& delta, size_t b) {
        for (size_t t = 0; t < size_t(kBatches); ++t) sum[t][b] += delta[t];
    }
    /// `inv`: 1 / (samples in the sample batch), 0 for an empty one.
    Color variance(const std::array<float, kBatches>& inv) const {
        int active = 0;
        for (float w : inv) active += w > 0.0f;
        if (active < 2) return Color(0.0f);
        DVec3 pairs(0.0);
        for (const auto& row : sum) {
            DVec3 all(0.0), squares(0.0);
            for (size_t b = 0; b < size_t(kBatches); ++b) {
                const DVec3 a = DVec3(row[b]) * double(inv[b]);
                all += a;
                squares += a * a;
            }
            pairs += all * all - squares;
        }
        const DVec3 v = pairs / double(kBatches * (kBatches - 1) * active * (active - 1));
        const double max = std::numeric_limits<float>::max();  // a float holds the result
        return Color(glm::clamp(v, DVec3(-max), DVec3(max)));
    }
};

/// A pixel's samples' bias_half summed per sample half (even and odd batches) and photon half.
/// The means of two that differ in both halves are estimates of one bias from independent
/// samples and photons, whose product is its square in expectation (render/error_estimate.h).
struct BiasHalves {
    std::array<std::array<Color, 2>, 2> sum{};  ///< [sample half][photon half]
    std::array<int, 2> n{};                     ///< samples per sample half
    void add(const std::array<Color, 2>& bias, size_t batch) {
        for (size_t h = 0; h < 2; ++h) sum[batch % 2][h] += bias[h];
        count(batch);
    }
    /// A sample of `batch` whose bias is 0 (it read no map).
    void count(size_t batch) { ++n[batch % 2]; }
    Color mean(size_t s, size_t h) const {
        return n[s] > 0 ? sum[s][h] / float(n[s]) : Color(0.0f);
    }
};

/// The samples one pass of render_film takes in a pixel: [s0, s1), their positions (and shutter
/// times) stratified among them, of the pixel's `total` (PixelSample::spp).
struct PixelRange {
    int s0 = 0, s1 = 0, total = 0;
};

/// What the first pass of adaptive sampling measures per pixel beside its film: the beauty's sum
/// of squares over the pass's finite samples, its work per sample (state_work), and where
/// render_film hands the measure out (GivenSamples::measure) the pass's means.
struct PassMeasure {
    std::vector<Color> squares;
    std::vector<float> work;
    Image means;
};

/// Adaptive sampling (render.adaptive; render/adaptive.cpp, docs/design.md): the samples a first
/// pass takes in every pixel at a render of `spp` in batches of whole `unit`s (at least two
/// units, so that every pixel's estimate has two batches); spp (a uniform render) below
/// kAdaptiveMinSpp or when it leaves nothing to allocate.
int first_pass_spp(int spp, int unit);
/// The samples every pixel takes in render_film's first pass, which its PassMeasure measures:
/// first_pass_spp with `adaptive`, else all spp.
inline int measured_spp(int spp, int unit, bool adaptive) {
    return adaptive ? first_pass_spp(spp, unit) : spp;
}
/// Below this many samples a pixel, a first pass says too little to pay for itself (the path
/// tracer at 4 spp: the same relMSE at 1.1-1.4x the time; docs/measurements.md).
inline constexpr int kAdaptiveMinSpp = 8;
/// Every pixel's samples (0 outside `share`'s tiles): the first pass's n1, and where the first
/// pass's neighbours of a pixel (5 x 5 within its tile, not the pixel itself: its count must not
/// depend on its own samples) show relative variance σ²/(y² + 0.01) and work per sample c, more
/// in whole units: the work the rest of a uniform render would take, spread in proportion to
/// σ / (sqrt(y² + 0.01) sqrt(c)), which minimises the relMSE at that work; at most kAdaptiveMax
/// times spp. The image's sums are added tile by tile in tile order (over share.ranks' tiles too)
/// and units rounded by a dither of (seed, pixel): the counts are the same at any thread or rank
/// count.
std::vector<int> allocate_samples(const Film& first, const PassMeasure& measure, int spp, int n1,
                                  int unit, uint64_t seed, TileShare share);
/// The most samples adaptive sampling gives a pixel, in multiples of render.spp.
inline constexpr int kAdaptiveMax = 16;

/// Adaptive sampling across a progressive run's iterations (RunSetup::measured, docs/design.md):
/// what the first passes of its measured iterations, each of the same samples in every pixel, add
/// up to per pixel — the beauty's means, the squares of its samples, its work per sample — in
/// 64-bit fixed point, so that the sums are exact and the same whatever order, thread or rank
/// added them.
struct IterationMeasure {
    static constexpr double kUnit = 16777216.0;  // 2^24
    int width = 0, height = 0;
    std::vector<int64_t> values;  ///< per pixel: beauty (3), squares (3), work (1)

    /// All zero, of a width x height image (a process that measured none of them).
    void zero(int w, int h) {
        width = w;
        height = h;
        values.assign(7 * size_t(w) * h, 0);
    }
    /// Adds a measured iteration's PassMeasure (with its means).
    void add(const PassMeasure& measure);
    /// Every pixel's samples in each later iteration of `spp` samples a pixel (in whole `unit`s, at
    /// least one): the work of a uniform iteration spread as allocate_samples spreads its rest,
    /// from `iterations` measures of `measured` samples a pixel (measured_spp); rounded by a
    /// dither of (seed, pixel).
    std::vector<int> allocate(int iterations, int measured, int spp, int unit, uint64_t seed) const;
};

/// What adaptive sampling across iterations asks of one iteration's render_film: every pixel's
/// samples given (the iterations after the measured ones, in place of its own `adaptive`), or,
/// with `measure`, the first pass's PassMeasure (the measured ones, which sample as a plain render
/// does: their own passes where adaptive), and with `first_pass_only` that pass alone (a measured
/// iteration rendered again for its measure).
struct GivenSamples {
    const std::vector<int>* counts = nullptr;
    PassMeasure* measure = nullptr;
    bool first_pass_only = false;
};
/// One pixel's means over one pass's samples (render_pass), and what its photon batches give.
struct PixelMeans {
    Color beauty{0.0f};
    std::array<Color, kLayerCount> layers{};
    std::array<Color, kBatches> batches{};
    Color map_variance{0.0f};
    std::array<Color, 4> halves{};  ///< Film::bias_halves' order
};

/// Pixel p of `film` holding samples [0, n1) and `later` those of [n1, n) as one of its n
/// samples: means weighted by their samples, batch by batch and half by half; the map variance
/// by samples where the later pass has two batches.
void merge_pixel(Film* film, size_t p, const PixelMeans& later, int n1, int n, int unit);

/// The counts render_film sums from its tiles' states.
struct PassCounters {
    std::atomic<uint64_t> samples{0}, rays{0}, nonfinite{0}, capped{0}, steps{0}, lookups{0},
        gathered{0};
    void write(RenderStats* stats) const {
        stats->samples = samples.load();
        stats->rays = rays.load();
        stats->nonfinite = nonfinite.load();
        stats->capped = capped.load();
        stats->steps = steps.load();
        stats->lookups = lookups.load();
        stats->gathered = gathered.load();
    }
};

/// The cost of a render's counted events in medium steps: least-squares fits to the phase times
/// of single-threaded runs of path, guided and photon on smoke.json, smoke1 and the Disney cloud
/// over the ground at 16 and 64 spp (docs/measurements.md; 65 ns a render step), rounded: steps
/// 1, Embree queries 0.93, lookups 2.2, gathered photons 1.1, within 8% of every run's time.
inline constexpr double kRayWork = 1.0;       ///< an Embree query
inline constexpr double kLookupWork = 2.0;    ///< a volume-map, guide or sun-grid lookup
inline constexpr double kGatheredWork = 1.0;  ///< a photon a lookup gathered from a kd-tree

/// A state's medium steps so far (its media samplers').
template <class State>
uint64_t state_steps(const State& state) {
    uint64_t steps = 0;
    for (const auto& m : state.media) steps += m.steps();
    return steps;
}

/// A state's work so far, in medium steps (the cost model above).
template <class State>
double state_work(const State& state) {
    return double(state_steps(state)) + kRayWork * double(state.rays) +
           kLookupWork * double(state.lookups) + kGatheredWork * double(state.gathered);
}

/// One pass of render_film into `film` (of the image's shape, with the parts' images that
/// `photon_parts` asks for): every pixel of `share`'s tiles takes the samples range(pixel index)
/// (none: the pixel is left as it is), its means written, or with `merge` (adaptive sampling's
/// second pass) merged into the range's first s0 samples that `film` holds; `measure` (may be
/// null) gets the pass's PassMeasure; progress on stderr as `what` unless quiet.
template <class MakeState, class Trace, class Range>
void render_pass(const Camera& camera, uint64_t seed, TileShare share, PhotonParts photon_parts,
                 int unit, bool merge, bool quiet, const char* what, PassCounters* counters,
                 MakeState&& make_state, Trace&& trace, Range&& range, PassMeasure* measure,
                 Film* film) {
    const int w = camera.width(), h = camera.height();
    const std::optional<ShutterDesc>& shutter = camera.shutter();
    const bool layered = film->layered(), photon_batches = keeps_noise(photon_parts),
               bias = keeps_bias(photon_parts);
    if (measure) {
        measure->squares.assign(size_t(w) * h, Color(0.0f));
        measure->work.assign(size_t(w) * h, 0.0f);
    }
    auto shade = [&](int x, int y, auto& state) {
        const uint64_t pixel = static_cast<uint64_t>(y) * w + x;
        const PixelRange r = range(size_t(pixel));
        const int n = r.s1 - r.s0;
        if (n <= 0) return;
        const std::array<float, kBatches> batch_inv = batch_inverse(batch_counts(r.s0, r.s1, unit));
        FilmSample sum;
        std::array<Color, kBatches> batch{};
        PhotonBatchSums photons;
        BiasHalves halves;
        Color squares(0.0f);
        uint64_t dropped = 0;
        const double work = measure ? state_work(state) : 0.0;
        const uint64_t jitter_key = pixel_key(seed, pixel);
        const PassStrata strata(r.s0, r.s1, unit);
        for (int s = r.s0; s < r.s1; ++s) {
            Rng rng(seed, pixel, static_cast<uint64_t>(s));
            const Vec2 j = pass_jitter(strata, s, jitter_key, Vec2(rng.uniform(), rng.uniform()));
            PixelSample ps{s, r.total, jitter_key, x, y};
            if (shutter) ps.time = shutter_time(*shutter, strata, s, seed, pixel);
            const FilmSample c = trace(camera.generate(x + j.x, y + j.y), rng, state, ps);
            const Color beauty = layered ? c.layer_sum() : c.beauty;
            if (!is_finite(beauty)) {
                ++dropped;
                continue;
            }
            if (!layered) sum.beauty += c.beauty;
            for (int l = 0; layered && l < kLayerCount; ++l) sum.layers[l] += c.layers[l];
            const size_t b = size_t((s / unit) % kBatches);
            batch[b] += beauty;
            if (measure) squares += beauty * beauty;
            // A non-finite part (an overflow) leaves the sample out of the map's parts only.
            const auto finite = [](const auto& colors) {
                return std::all_of(colors.begin(), colors.end(),
                                   [](const Color& v) { return is_finite(v); });
            };
            if (!c.batched) {
                if (bias) halves.count(b);
            } else {
                if (photon_batches && finite(c.photon_delta)) photons.add(c.photon_delta, b);
                if (bias && finite(c.bias_half)) halves.add(c.bias_half, b);
            }
        }
        const float inv = 1.0f / static_cast<float>(n);
        PixelMeans m;
        for (size_t b = 0; b < size_t(kBatches); ++b) m.batches[b] = batch[b] * batch_inv[b];
        if (photon_batches) m.map_variance = photons.variance(batch_inv);
        for (size_t i = 0; bias && i < 4; ++i) m.halves[i] = halves.mean(i / 2, i % 2);
        m.beauty = (layered ? sum.layer_sum() : sum.beauty) * inv;
        for (int l = 0; layered && l < kLayerCount; ++l) m.layers[size_t(l)] = sum.layers[l] * inv;
        if (merge) {
            merge_pixel(film, pixel, m, r.s0, r.s1, unit);
        } else {
            for (int b = 0; b < kBatches; ++b) film->batches[size_t(b)].at(x, y) = m.batches[b];
            if (photon_batches) film->map_variance.at(x, y) = m.map_variance;
            for (size_t i = 0; bias && i < 4; ++i) film->bias_halves[i].at(x, y) = m.halves[i];
            film->beauty.at(x, y) = m.beauty;
            for (int l = 0; layered && l < kLayerCount; ++l)
                film->layers[size_t(l)].at(x, y) = m.layers[size_t(l)];
        }
        if (measure) {
            measure->squares[pixel] = squares;
            measure->work[pixel] = float((state_work(state) - work) / n);
        }
        counters->samples += uint64_t(n);
        if (dropped) counters->nonfinite += dropped;
    };
    auto end_tile = [&](const auto& state) {
        counters->rays += state.rays;
        counters->capped += state.capped;
        counters->lookups += state.lookups;
        counters->gathered += state.gathered;
        counters->steps += state_steps(state);
    };
    render_tiles(w, h, share, quiet, make_state, shade, end_tile, what);
}

/// The per-pixel sample loop of every integrator: for each pixel of `camera`'s image in `share`'s
/// tiles (the others stay 0), spp samples at PassStrata's positions, sample s drawing from
/// Rng(seed, pixel, s) first its two position uniforms, then trace(ray, rng, state, PixelSample)
/// -> FilmSample; non-finite samples are dropped (counted) and the film holds the mean over its
/// samples, and the mean over each batch's samples (a dropped sample counts as 0 in both).
/// state = make_state() per tile; state.rays, state.capped, state.lookups, state.gathered and the
/// steps of state.media are summed into *stats (may be null). `photon_parts`: what the samples'
/// photon_delta and bias_half give (film.map_variance, film.bias_halves).
/// `unit` consecutive samples of a pixel make one unit of its estimate (an integrator that takes
/// some term at every unit-th sample alone: photon_integrator.h, map_weight): sample s falls in
/// batch (s / unit) mod kBatches, so that batches hold whole units and are alike.
/// `adaptive`: spp sets the work (of spp samples in every pixel): a first pass of first_pass_spp
/// samples in every pixel, then a second of allocate_samples' counts (film.pixel_spp).
/// `given` (adaptive sampling across iterations): its counts replace `adaptive`; its measure gets
/// the first pass's.
template <class MakeState, class Trace>
Film render_film(const Camera& camera, int spp, uint64_t seed, TileShare share, bool layered,
                 PhotonParts photon_parts, int unit, bool adaptive, bool quiet, RenderStats* stats,
                 MakeState&& make_state, Trace&& trace, GivenSamples given = {}) {
    const Timer timer;
    PassCounters counters;
    Film film(camera.width(), camera.height(), layered);
    if (keeps_noise(photon_parts)) film.map_variance = Image(film.beauty.width, film.beauty.height);
    if (keeps_bias(photon_parts))
        film.bias_halves.assign(4, Image(film.beauty.width, film.beauty.height));
    const int n1 = given.counts ? spp : measured_spp(spp, unit, adaptive);
    const auto pass = [&](bool merge, auto&& range, PassMeasure* measure) {
        const char* what = n1 >= spp ? "render"
                           : merge   ? "render, more where the error is"
                                     : "render, first pass";
        render_pass(camera, seed, share, photon_parts, unit, merge, quiet, what, &counters,
                    make_state, trace, range, measure, &film);
    };
    const std::array<int, kBatches> counts = batch_counts(0, n1, unit);
    for (size_t b = 0; b < size_t(kBatches); ++b) film.batch_share[b] = double(counts[b]) / n1;
    const auto first = [&](size_t) { return PixelRange{0, n1, n1}; };
    if (given.counts) {
        film.pixel_spp = *given.counts;
        film.unit = unit;
        const std::vector<int>& n = film.pixel_spp;
        const auto each_its_own = [&](size_t p) { return PixelRange{0, n[p], n[p]}; };
        pass(false, each_its_own, nullptr);
    } else {
        PassMeasure own;
        PassMeasure* measure = given.measure ? given.measure : n1 < spp ? &own : nullptr;
        pass(false, first, measure);
        if (given.measure) given.measure->means = film.beauty;
        if (n1 < spp && !given.first_pass_only) {
            film.pixel_spp = allocate_samples(film, *measure, spp, n1, unit, seed, share);
            film.unit = unit;
            const std::vector<int>& n = film.pixel_spp;
            const auto more = [&](size_t p) { return PixelRange{n1, n[p], n[p]}; };
            pass(true, more, nullptr);
        }
    }
    if (stats) {
        counters.write(stats);
        stats->render_s = timer.seconds();
        stats->threads = active_thread_count();
    }
    return film;
}

}  // namespace fogmap
