// The film (render/film.h) against values computed here: FixedFilm's mean over added films equals
// the mean taken directly (exactly, for values on the fixed-point grid), its sums do not depend
// on the order of the films, values beyond ±2^24 and sums beyond int64 are clamped and counted as
// worked out by hand; a layered film has one image per layer in EXR order; and render_film's
// pixels hold the mean over spp of the samples traced (dropped non-finite ones counting 0), the
// beauty of a layered film being the sum of its layers, over the tiles of its share alone.

#include "render/film.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

namespace fogmap {
namespace {

/// A w x h film whose every value is f(image, pixel, channel); image 0 is the beauty.
template <class F>
Film film_of(int w, int h, bool layered, F&& f) {
    Film film(w, h, layered);
    auto fill = [&](Image& img, int index) {
        for (size_t p = 0; p < img.pixels.size(); ++p)
            for (int c = 0; c < 3; ++c) img.pixels[p][c] = f(index, int(p), c);
    };
    fill(film.beauty, 0);
    for (size_t l = 0; l < film.layers.size(); ++l) fill(film.layers[l], int(l) + 1);
    return film;
}

TEST(Film, LayeredFilmHasOneImagePerLayerInExrOrder) {
    const Film film(5, 3, true);
    ASSERT_TRUE(film.layered());
    ASSERT_EQ(film.layers.size(), size_t(kLayerCount));
    EXPECT_EQ(film.beauty.width, 5);
    EXPECT_EQ(film.beauty.height, 3);
    for (const Image& img : film.layers) {
        EXPECT_EQ(img.width, 5);
        EXPECT_EQ(img.height, 3);
        EXPECT_EQ(img.pixels.size(), 15u);
    }
    const std::vector<NamedImage> named = film.named_layers();
    const char* expected[] = {"direct",  "volume_single", "volume_multiple",
                              "caustic", "indirect",      "emission"};
    ASSERT_EQ(named.size(), 6u);
    for (int l = 0; l < 6; ++l) {
        EXPECT_EQ(named[l].name, expected[l]);
        EXPECT_EQ(named[l].image, &film.layers[l]);
    }
    EXPECT_EQ(&film.layer(Layer::Emission), &film.layers[5]);
    EXPECT_EQ(&film.layer(Layer::Direct), &film.layers[0]);

    const Film plain(4, 2, false);
    EXPECT_FALSE(plain.layered());
    EXPECT_TRUE(plain.named_layers().empty());
    EXPECT_EQ(plain.beauty.pixels.size(), 8u);
}

TEST(FilmSample, LayerSumAddsEveryLayer) {
    FilmSample s;
    for (int l = 0; l < kLayerCount; ++l) s.layers[l] = Color(1.0f * (l + 1), 0.5f, -0.25f * l);
    s[Layer::Caustic] += Color(10.0f);
    // 1 + ... + 6 = 21, plus 10; 6 × 0.5 + 10; −0.25 × 15 + 10.
    EXPECT_EQ(s.layer_sum(), Color(31.0f, 13.0f, 6.25f));
}

TEST(FixedFilm, MeanOfGridValuesIsTheExactMean) {
    // Values k / 256 in [−64, 64]: on the 2^−32 grid, so the fixed-point sums are exact, and with
    // 4 films the mean is exact as well.
    const int w = 3, h = 2, count = 4;
    std::vector<Film> films;
    for (int f = 0; f < count; ++f)
        films.push_back(film_of(w, h, true, [&](int img, int p, int c) {
            return float(((img * 37 + p * 11 + c * 5 + f * 23) % 257 - 128)) / 2.0f +
                   float(f) / 256.0f;
        }));
    FixedFilm sum;
    for (int f = 0; f < count; ++f) sum.add(films[f], f + 1, 1);
    EXPECT_EQ(sum.width, w);
    EXPECT_EQ(sum.height, h);
    EXPECT_TRUE(sum.layered);
    EXPECT_EQ(sum.values.size(), size_t(w * h * (3 * (1 + kLayerCount + kBatches) + kBatches)));
    EXPECT_EQ(sum.clamped, 0u);
    const Film mean = sum.mean(count, 1);
    ASSERT_TRUE(mean.layered());
    auto check = [&](const Image& got, auto&& image_of) {
        for (size_t p = 0; p < got.pixels.size(); ++p)
            for (int c = 0; c < 3; ++c) {
                double direct = 0.0;
                for (const Film& f : films) direct += image_of(f).pixels[p][c];
                ASSERT_EQ(got.pixels[p][c], float(direct / count)) << "pixel " << p << " c " << c;
            }
    };
    check(mean.beauty, [](const Film& f) -> const Image& { return f.beauty; });
    for (int l = 0; l < kLayerCount; ++l)
        check(mean.layers[l], [l](const Film& f) -> const Image& { return f.layers[l]; });
}

TEST(FixedFilm, MeanOfAnyValuesIsTheMeanToRounding) {
    // Arbitrary floats are rounded to 2^−32 once each; the mean of 3 is then within that plus
    // a float's rounding of the direct mean.
    const int count = 3;
    std::vector<Film> films;
    for (int f = 0; f < count; ++f)
        films.push_back(film_of(4, 4, false, [&](int, int p, int c) {
            return std::sin(0.37f * float(p * 3 + c) + float(f)) * 1000.0f + 0.1f * float(f);
        }));
    FixedFilm sum;
    for (int f = 0; f < count; ++f) sum.add(films[f], f + 1, 1);
    const Film mean = sum.mean(count, 1);
    EXPECT_FALSE(mean.layered());
    for (size_t p = 0; p < mean.beauty.pixels.size(); ++p)
        for (int c = 0; c < 3; ++c) {
            double direct = 0.0;
            for (const Film& f : films) direct += f.beauty.pixels[p][c];
            direct /= count;
            EXPECT_NEAR(mean.beauty.pixels[p][c], direct,
                        std::abs(direct) * std::numeric_limits<float>::epsilon() + 1e-9);
        }
}

TEST(FixedFilm, IterationIGoesToBatchIMinusOneModKAndItsMeanIsTheBatchsMean) {
    // 19 iterations, film f's every value f: batch b holds iterations b + 1, b + 1 + 8, ... (3 in
    // batches 0-2, 2 in the others), its mean their mean index, its share its count / 19.
    const int count = 19;
    FixedFilm sum;
    for (int f = 1; f <= count; ++f)
        sum.add(film_of(2, 2, false, [&](int, int, int) { return float(f); }), f, 1);
    const Film mean = sum.mean(count, 1);
    double shares = 0.0, weighted = 0.0;
    for (int b = 0; b < kBatches; ++b) {
        double indices = 0.0;
        int n = 0;
        for (int i = b + 1; i <= count; i += kBatches, ++n) indices += i;
        EXPECT_EQ(mean.batch_share[b], double(n) / count) << "batch " << b;
        EXPECT_FLOAT_EQ(mean.batches[b].at(1, 1).y, float(indices / n)) << "batch " << b;
        shares += mean.batch_share[b];
        weighted += mean.batch_share[b] * mean.batches[b].at(1, 1).y;
    }
    EXPECT_DOUBLE_EQ(shares, 1.0);
    EXPECT_NEAR(weighted, mean.beauty.at(1, 1).y, 1e-5);  // (1 + ... + 19) / 19 = 10
    EXPECT_FLOAT_EQ(mean.beauty.at(0, 0).x, 10.0f);
}

// Iteration f's bias halves: sample half s, photon half h holds 100 s + 10 h + f, and its sample
// halves hold shares 3/4 and 1/4 (batches 0, 2, 4 of one sample, 1 of one). The sum keeps, for
// photon half h, the iterations' share-weighted means over both sample halves, 10 h + 25 + f,
// odd iterations in half 0, even ones in half 1: their means over 1, 3, 5 and 2, 4.
TEST(FixedFilm, BiasHalvesAreSummedByIterationParity) {
    const int count = 5;
    FixedFilm sum;
    for (int f = 1; f <= count; ++f) {
        Film film = film_of(2, 1, true, [&](int, int, int) { return float(f); });
        film.bias_halves.assign(4, Image(2, 1));
        for (int i = 0; i < 4; ++i)
            for (Color& c : film.bias_halves[size_t(i)].pixels)
                c = Color(float(100 * (i / 2) + 10 * (i % 2) + f));
        film.batch_share = {0.25, 0.25, 0.25, 0.0, 0.25, 0.0, 0.0, 0.0};
        sum.add(film, f, 1);
    }
    EXPECT_TRUE(sum.bias);
    EXPECT_EQ(sum.values.size(), size_t(2 * (3 * (1 + kLayerCount + kBatches + 4) + kBatches)));
    const Film mean = sum.mean(count, 1);
    ASSERT_EQ(mean.bias_halves.size(), 4u);
    for (int i = 0; i < 4; ++i) {
        const double iterations = i / 2 == 0 ? (1 + 3 + 5) / 3.0 : (2 + 4) / 2.0;
        EXPECT_NEAR(mean.bias_halves[size_t(i)].at(1, 0).y, 10 * (i % 2) + 25 + iterations, 1e-5)
            << "half " << i;
    }
    EXPECT_TRUE(sum.mean(1, 1).bias_halves.empty());  // one parity alone: no independent pair
}

// Adaptive sampling in iterations: each film's pixels have samples of their own (Film::pixel_spp,
// batched in units of 2) beside an iteration's nominal 5. Pixel 0 took 6 (batches 0, 1, 2 two
// each: sample half 0 holds 4 / 6 of them), pixel 1 took 2 (batch 0: half 0 holds all), in films
// 1 and 2; film 3 took 5 in each (half 0 holds 1 / 2). Film f's pixel p is f + 10 p, and bias
// half s, h holds 100 s + 10 h, so a film's estimate for photon half h is 10 h + 100 times its
// sample half 1's share. The sum weighs each film's pixel by its samples there.
TEST(FixedFilm, AdaptiveFilmsWeighTheirPixelsBySamples) {
    FixedFilm sum;
    for (int f = 1; f <= 3; ++f) {
        Film film = film_of(2, 1, true, [&](int, int p, int) { return float(f + 10 * p); });
        film.bias_halves.assign(4, Image(2, 1));
        for (int i = 0; i < 4; ++i)
            for (Color& c : film.bias_halves[size_t(i)].pixels)
                c = Color(float(100 * (i / 2) + 10 * (i % 2)));
        if (f < 3) {
            film.pixel_spp = {6, 2};
            film.unit = 2;
        }
        film.batch_share = {0.5, 0.5, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0};  // the first pass's
        sum.add(film, f, 5);
    }
    const Film mean = sum.mean(3, 5);
    EXPECT_EQ(mean.samples.at(0, 0), Color(17.0f));  // 6 + 6 + 5
    EXPECT_EQ(mean.samples.at(1, 0), Color(9.0f));   // 2 + 2 + 5
    EXPECT_NEAR(mean.beauty.at(0, 0).y, (6 * 1 + 6 * 2 + 5 * 3) / 17.0, 1e-5);
    EXPECT_NEAR(mean.beauty.at(1, 0).y, (2 * 11 + 2 * 12 + 5 * 13) / 9.0, 1e-5);
    // Each batch holds one film: its mean is that film's, its share of the pixel its samples'.
    ASSERT_EQ(mean.pixel_spp, (std::vector<int>{17, 9}));
    const std::array<double, kBatches> share0 = mean.shares(0), share1 = mean.shares(1);
    for (int b = 0; b < 3; ++b) {
        EXPECT_NEAR(mean.batches[size_t(b)].at(1, 0).y, 11.0 + b, 1e-5);
        EXPECT_DOUBLE_EQ(share0[size_t(b)], (b < 2 ? 6.0 : 5.0) / 17.0);
        EXPECT_DOUBLE_EQ(share1[size_t(b)], (b < 2 ? 2.0 : 5.0) / 9.0);
    }
    ASSERT_EQ(mean.bias_halves.size(), 4u);
    for (int h = 0; h < 2; ++h) {  // films 1 and 3 (odd) in half 0 + h, 2 in half 2 + h
        EXPECT_NEAR(mean.bias_halves[size_t(2 + h)].at(0, 0).y, 10 * h + 100.0 / 3.0, 1e-4);
        EXPECT_NEAR(mean.bias_halves[size_t(2 + h)].at(1, 0).y, 10 * h, 1e-5);
        EXPECT_NEAR(mean.bias_halves[size_t(h)].at(0, 0).y,
                    (6 * (10 * h + 100.0 / 3.0) + 5 * (10 * h + 50)) / 11.0, 1e-4);
        EXPECT_NEAR(mean.bias_halves[size_t(h)].at(1, 0).y, (2 * 10 * h + 5 * (10 * h + 50)) / 7.0,
                    1e-5);
    }
}

// Films of the same samples in every pixel: the mean is the films' plain mean, and it keeps no
// samples of each pixel's own.
TEST(FixedFilm, UniformFilmsKeepOneShareForEveryPixel) {
    FixedFilm sum;
    for (int f = 1; f <= 3; ++f) {
        Film film = film_of(2, 1, false, [&](int, int p, int) { return float(f + 10 * p); });
        if (f == 2) film.pixel_spp = {4, 4};  // given, but as many as the others
        sum.add(film, f, 4);
    }
    const Film mean = sum.mean(3, 4);
    EXPECT_TRUE(mean.pixel_spp.empty());
    EXPECT_TRUE(mean.batch_spp.empty());
    EXPECT_FLOAT_EQ(mean.beauty.at(1, 0).y, 12.0f);
    EXPECT_EQ(mean.samples.at(1, 0), Color(12.0f));
}

TEST(FixedFilm, SumDoesNotDependOnTheOrderOfTheFilms) {
    // Floats that a float sum would round differently in another order.
    std::vector<Film> films;
    for (int f = 0; f < 5; ++f)
        films.push_back(film_of(3, 3, true, [&](int img, int p, int c) {
            return std::pow(10.0f, float((img + p + c + 2 * f) % 9) - 4.0f) *
                   (f % 2 ? -1.3f : 1.7f);
        }));
    std::vector<int> order{0, 1, 2, 3, 4};
    FixedFilm reference;
    for (int i : order) reference.add(films[i], i + 1, 1);
    int permutations = 0;
    while (std::next_permutation(order.begin(), order.end())) {
        FixedFilm sum;
        for (int i : order) sum.add(films[i], i + 1, 1);
        ASSERT_EQ(sum.values, reference.values);
        ++permutations;
    }
    EXPECT_EQ(permutations, 119);
}

TEST(FixedFilm, ValuesBeyondTwoToThe24AreClampedAndCounted) {
    constexpr float kMax = 16777216.0f;  // 2^24
    Film film(2, 1, false);
    film.beauty.at(0, 0) = Color(kMax, -kMax, 3.0f);  // at the limit: kept
    film.beauty.at(1, 0) = Color(2.0f * kMax, -std::numeric_limits<float>::infinity(), 1e30f);
    FixedFilm sum;
    sum.add(film, 1, 1);
    EXPECT_EQ(sum.clamped, 3u);
    const Film mean = sum.mean(1, 1);
    EXPECT_EQ(mean.beauty.at(0, 0), Color(kMax, -kMax, 3.0f));
    EXPECT_EQ(mean.beauty.at(1, 0), Color(kMax, -kMax, kMax));
}

TEST(FixedFilm, SumsThatWouldOverflowSaturateAndAreCounted) {
    // 2^24 is 2^56 in fixed point; int64 holds 127 of them (127 × 2^56 < 2^63 − 1), the 128th
    // overflows, and so does every addition after it: 3 of 130 films. −2^24: −128 × 2^56 = −2^63
    // is INT64_MIN and fits, the 129th and 130th overflow: 2. The third channel never does.
    Film film(1, 1, false);
    film.beauty.at(0, 0) = Color(16777216.0f, -16777216.0f, 1.0f);
    FixedFilm sum;
    for (int i = 0; i < 130; ++i) sum.add(film, i + 1, 1);
    EXPECT_EQ(sum.clamped, 5u);
    EXPECT_EQ(sum.values[0], INT64_MAX);
    EXPECT_EQ(sum.values[1], INT64_MIN);
    EXPECT_EQ(sum.values[2], int64_t(130) << 32);
}

// render_film with a made-up integrator: sample s of pixel (x, y) gives layer l the radiance
// (l + 1, x, y + s) / 8, beauty (unlayered) (x, y, s); one sample is NaN.
struct State {
    uint64_t rays = 0, capped = 0, lookups = 0, gathered = 0;
    struct FakeMedium {
        uint64_t steps() const { return 5; }
    };
    std::vector<FakeMedium> media{FakeMedium{}, FakeMedium{}};
};

constexpr int kW = 20, kH = 18, kSpp = 4;  // 2 x 2 tiles of 16, the right and bottom ones cut

CameraDesc camera_desc() {
    CameraDesc d;
    d.width = kW;
    d.height = kH;
    return d;
}

Film render_made_up(bool layered, TileShare share, RenderStats* stats) {
    return render_film(
        Camera(camera_desc()), kSpp, 99, share, layered, PhotonParts::None, 1, false, true, stats,
        [] { return State{}; },
        [&](const Ray&, Rng&, State& state, const PixelSample& ps) {
            ++state.rays;
            state.lookups += 2;
            FilmSample f;
            const float x = float(ps.x), y = float(ps.y), s = float(ps.s);
            for (int l = 0; l < kLayerCount; ++l) f.layers[l] = Color(l + 1.0f, x, y + s) / 8.0f;
            f.beauty = Color(x, y, s);
            if (ps.x == 17 && ps.y == 3 && ps.s == 2) {
                f.layers[4].y = std::numeric_limits<float>::quiet_NaN();
                f.beauty.z = std::numeric_limits<float>::infinity();
            }
            return f;
        });
}

TEST(RenderFilm, SampleSFallsInBatchSModKAndADroppedSampleCountsAsZero) {
    // kSpp = 4 samples: batch s holds sample s alone (its value (x, y, s)), batches 4-7 none.
    const Film film = render_made_up(false, TileShare{}, nullptr);
    for (int b = 0; b < kBatches; ++b)
        EXPECT_EQ(film.batch_share[b], b < kSpp ? 1.0 / kSpp : 0.0) << "batch " << b;
    for (int b = 0; b < kSpp; ++b) {
        EXPECT_EQ(film.batches[b].at(5, 7), Color(5.0f, 7.0f, float(b))) << "batch " << b;
        // Pixel (17, 3)'s sample 2 is infinite: dropped, its batch holds 0.
        EXPECT_EQ(film.batches[b].at(17, 3), b == 2 ? Color(0.0f) : Color(17.0f, 3.0f, float(b)));
    }
    EXPECT_EQ(film.batches[kSpp].at(5, 7), Color(0.0f));
}

TEST(RenderFilm, PixelsHoldTheMeanOverSppAndLayersAddUpToTheBeauty) {
    RenderStats stats;
    const Film film = render_made_up(true, TileShare{}, &stats);
    ASSERT_TRUE(film.layered());
    for (int y = 0; y < kH; ++y)
        for (int x = 0; x < kW; ++x) {
            const bool dropped = x == 17 && y == 3;  // sample 2 dropped: mean of s = 0, 1, 3
            const double kept = dropped ? 3.0 : kSpp;
            const double s_sum = dropped ? 0.0 + 1.0 + 3.0 : 0.0 + 1.0 + 2.0 + 3.0;
            Color sum(0.0f);
            for (int l = 0; l < kLayerCount; ++l) {
                const Color want(float((l + 1) * kept / 8.0 / kSpp), float(x * kept / 8.0 / kSpp),
                                 float((y * kept + s_sum) / 8.0 / kSpp));
                const Color got = film.layers[l].at(x, y);
                for (int c = 0; c < 3; ++c)
                    ASSERT_NEAR(got[c], want[c], 1e-6f * (1.0f + want[c]))
                        << "layer " << l << " pixel " << x << "," << y;
                sum += got;
            }
            for (int c = 0; c < 3; ++c)
                ASSERT_NEAR(film.beauty.at(x, y)[c], sum[c], 1e-5f * (1.0f + sum[c]))
                    << "pixel " << x << "," << y;
        }
    EXPECT_EQ(stats.samples, uint64_t(kW * kH * kSpp));
    EXPECT_EQ(stats.rays, uint64_t(kW * kH * kSpp));
    EXPECT_EQ(stats.lookups, uint64_t(2 * kW * kH * kSpp));
    EXPECT_EQ(stats.nonfinite, 1u);
    EXPECT_EQ(stats.steps, 4u * 2u * 5u);  // 4 tiles, 2 media of 5 steps each
}

// Photon parts (film.h, PhotonBatchSums and BiasHalves): every sample of pixel (x, y) says that
// photon batch t alone would give d_t = (t − 3.5) a more, a = x + 1: one map error that all its
// samples share, whose variance of the mean the pairs estimate as Σ_t d_t² / (K (K − 1)) =
// 42 a² / 56; its bias halves are (x, 2x) in each sample half. One sample's parts are infinite:
// they are left out, and its pixel's map variance stays finite.
Film render_photon_parts(PhotonParts parts) {
    return render_film(
        Camera(camera_desc()), kSpp, 99, TileShare{}, false, parts, 1, false, true, nullptr,
        [] { return State{}; },
        [&](const Ray&, Rng&, State&, const PixelSample& ps) {
            FilmSample f;
            f.beauty = Color(1.0f);
            f.batched = true;
            const float a = float(ps.x + 1);
            for (int t = 0; t < kBatches; ++t) f.photon_delta[t] = Color((float(t) - 3.5f) * a);
            f.bias_half = {Color(float(ps.x)), Color(2.0f * float(ps.x))};
            if (ps.x == 5 && ps.y == 4 && ps.s == 1)
                f.photon_delta[3].x = f.bias_half[1].y = std::numeric_limits<float>::infinity();
            return f;
        });
}

TEST(RenderFilm, PhotonPartsGiveTheSharedMapVarianceAndTheBiasHalves) {
    const Film film = render_photon_parts(PhotonParts::NoiseAndBias);
    // An iteration of a run of iterations keeps the bias halves alone, the same.
    const Film bias_alone = render_photon_parts(PhotonParts::Bias);
    EXPECT_TRUE(bias_alone.map_variance.pixels.empty());
    ASSERT_EQ(bias_alone.bias_halves.size(), 4u);
    for (int i = 0; i < 4; ++i)
        EXPECT_EQ(bias_alone.bias_halves[size_t(i)].pixels, film.bias_halves[size_t(i)].pixels);
    ASSERT_EQ(film.bias_halves.size(), 4u);
    for (int y = 0; y < kH; ++y)
        for (int x = 0; x < kW; ++x) {
            const float a = float(x + 1);
            const Color v = film.map_variance.at(x, y);
            ASSERT_TRUE(is_finite(v));
            if (x == 5 && y == 4) continue;
            for (int c = 0; c < 3; ++c) ASSERT_NEAR(v[c], 42.0f * a * a / 56.0f, 1e-4f * a * a);
            for (int i = 0; i < 4; ++i)
                ASSERT_EQ(film.bias_halves[size_t(i)].at(x, y), Color(float(x) * float(1 + i % 2)));
        }
}

// Samples 2 and 3 of each pixel read no batched map, their parts either unread (garbage, batched
// false) or zeros that are read: the same films.
Film render_some_unbatched(bool garbage) {
    return render_film(
        Camera(camera_desc()), kSpp, 99, TileShare{}, false, PhotonParts::NoiseAndBias, 1, false,
        true, nullptr, [] { return State{}; },
        [&](const Ray&, Rng&, State&, const PixelSample& ps) {
            FilmSample f;
            f.beauty = Color(1.0f);
            const bool reads = ps.s < 2;
            f.batched = reads || !garbage;
            const float a = float(ps.x + 1 + ps.s);
            for (int t = 0; t < kBatches; ++t)
                f.photon_delta[t] = Color(reads ? (float(t) - 3.5f) * a : garbage ? 1e6f : 0.0f);
            const float b = reads ? float(ps.y) : garbage ? -1e6f : 0.0f;
            f.bias_half = {Color(b), Color(2.0f * b)};
            return f;
        });
}

TEST(RenderFilm, ASampleThatReadNoBatchedMapCountsAsZeroParts) {
    const Film skipped = render_some_unbatched(true), zeros = render_some_unbatched(false);
    EXPECT_EQ(skipped.map_variance.pixels, zeros.map_variance.pixels);
    ASSERT_EQ(skipped.bias_halves.size(), 4u);
    for (int i = 0; i < 4; ++i)
        EXPECT_EQ(skipped.bias_halves[size_t(i)].pixels, zeros.bias_halves[size_t(i)].pixels);
    // One of each sample half's two samples (batches 0, 2 and 1, 3) carries y and 2y: the means
    // y / 2 and y.
    for (int i = 0; i < 4; ++i)
        EXPECT_EQ(skipped.bias_halves[size_t(i)].at(3, 6), Color(i % 2 ? 6.0f : 3.0f));
}

TEST(RenderFilm, UnlayeredFilmHoldsTheBeautyMeanOverItsShareOfTiles) {
    // Share 1 of 2: tiles 1 and 3, the right column x in [16, 20); the rest stays 0.
    RenderStats stats;
    const Film film = render_made_up(false, TileShare{1, 2}, &stats);
    EXPECT_FALSE(film.layered());
    for (int y = 0; y < kH; ++y)
        for (int x = 0; x < kW; ++x) {
            Color want(0.0f);
            if (x >= 16) {
                const bool dropped = x == 17 && y == 3;
                const double kept = dropped ? 3.0 : kSpp;
                want = Color(float(x * kept / kSpp), float(y * kept / kSpp),
                             float((dropped ? 4.0 : 6.0) / kSpp));
            }
            for (int c = 0; c < 3; ++c)
                ASSERT_NEAR(film.beauty.at(x, y)[c], want[c], 1e-6f * (1.0f + want[c]))
                    << "pixel " << x << "," << y;
        }
    EXPECT_EQ(stats.samples, uint64_t(4 * kH * kSpp));
    EXPECT_EQ(stats.nonfinite, 1u);
    EXPECT_EQ(stats.steps, 2u * 2u * 5u);
}

}  // namespace
}  // namespace fogmap
