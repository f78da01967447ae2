// Adaptive sampling (render/film.h, render_film; render/adaptive.cpp) with a made-up integrator
// whose noise and cost are known per pixel: 64 x 64 pixels in four 32 x 32 quadrants (whole
// tiles, so no pixel's neighbours straddle two), every sample y = 1 + σ n (n standard normal),
// σ 0.1 on the left and 0.4 on the right, costing 1 ray a sample at the top and 4 at the bottom.
// The counts that minimise the relMSE at a uniform render's work are worked out by hand: the
// first pass's 16 of 64, then the rest of the work spread as σ / sqrt(c).

#include "core/parallel.h"
#include "core/ranks.h"
#include "core/rng.h"
#include "render/error_estimate.h"
#include "render/film.h"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <condition_variable>
#include <limits>
#include <mutex>
#include <thread>
#include <vector>

namespace fogmap {
namespace {

constexpr int kW = 64, kH = 64, kSpp = 64;

struct State {
    uint64_t rays = 0, capped = 0, lookups = 0, gathered = 0;
    struct NoMedium {
        uint64_t steps() const { return 0; }
    };
    std::vector<NoMedium> media;
};

float sigma(int x) { return x < 32 ? 0.1f : 0.4f; }
int cost(int y) { return y < 32 ? 1 : 4; }

float normal(Rng& rng) {
    const float u = std::max(rng.uniform(), 1e-12f), v = rng.uniform();
    return std::sqrt(-2.0f * std::log(u)) * std::cos(6.2831853f * v);
}

CameraDesc camera_desc() {
    CameraDesc d;
    d.width = kW;
    d.height = kH;
    return d;
}

/// The made-up render; pixel `loud` (if any) has 1000 times the noise.
Film render(uint64_t seed, TileShare share = {}, int loud_x = -1, int loud_y = -1,
            RenderStats* stats = nullptr, int spp = kSpp, GivenSamples given = {}) {
    return render_film(
        Camera(camera_desc()), spp, seed, share, false, PhotonParts::None, 1, true, true, stats,
        [] { return State{}; },
        [&](const Ray&, Rng& rng, State& state, const PixelSample& ps) {
            state.rays += uint64_t(cost(ps.y));
            const float loud = ps.x == loud_x && ps.y == loud_y ? 1000.0f : 1.0f;
            FilmSample f;
            f.beauty = Color(1.0f + loud * sigma(ps.x) * normal(rng));
            return f;
        },
        given);
}

/// Per-pixel counts summed by quadrant ([bottom][right]), and their work (samples × cost).
struct Quadrants {
    double sum[2][2] = {}, work = 0.0;
    int least = std::numeric_limits<int>::max();
    explicit Quadrants(const std::vector<int>& counts) {
        for (int y = 0; y < kH; ++y)
            for (int x = 0; x < kW; ++x) {
                const int n = counts[size_t(y) * kW + x];
                least = std::min(least, n);
                sum[y >= 32][x >= 32] += n;
                work += double(n) * cost(y);
            }
    }
    double samples() const { return sum[0][0] + sum[0][1] + sum[1][0] + sum[1][1]; }
    /// Each quadrant's mean count within `tolerance` of want's.
    void expect_near(const double (&want)[2][2], double tolerance) const {
        for (int b = 0; b < 2; ++b)
            for (int r = 0; r < 2; ++r)
                EXPECT_NEAR(sum[b][r] / (32 * 32) / want[b][r], 1.0, tolerance)
                    << (b ? "bottom" : "top") << (r ? " right" : " left");
    }
};

// batch_counts in closed form against counting sample by sample.
TEST(Adaptive, BatchCountsCountEverySampleOfTheRangeInItsBatch) {
    for (int unit : {1, 4, 5})
        for (int s0 = 0; s0 < 90; s0 += 7)
            for (int s1 = s0; s1 < 200; s1 += 3) {
                std::array<int, kBatches> want{};
                for (int s = s0; s < s1; ++s) ++want[size_t((s / unit) % kBatches)];
                ASSERT_EQ(batch_counts(s0, s1, unit), want) << unit << " " << s0 << " " << s1;
            }
}

// The quadrants' counts by hand: weights σ / sqrt(c) = 0.1, 0.4 (top), 0.05, 0.2 (bottom); the
// rest of the work, 48 samples of every pixel at its cost, Σ 48 c = 48 · 10 a quarter of the
// pixels, over Σ σ sqrt(c) = (0.1 + 0.4 + 0.2 + 0.8) a quarter: 320 σ / sqrt(c) more samples.
TEST(Adaptive, SamplesGoWhereTheErrorPerWorkIsAtAUniformRendersWork) {
    RenderStats stats;
    const Film film = render(7, {}, -1, -1, &stats);
    ASSERT_EQ(film.pixel_spp.size(), size_t(kW * kH));
    const Quadrants q(film.pixel_spp);
    EXPECT_GE(q.least, first_pass_spp(kSpp, 1));
    q.expect_near({{16 + 32, 16 + 128}, {16 + 16, 16 + 64}}, 0.03);
    // The work of a uniform render, to the dither's rounding.
    EXPECT_NEAR(q.work / (kSpp * 2.5 * kW * kH), 1.0, 0.01);
    EXPECT_EQ(stats.samples, uint64_t(q.samples()));
    EXPECT_EQ(stats.rays, uint64_t(q.work));
}

// A pixel's count comes from its neighbours' first pass, not its own samples (which it would
// otherwise bias: a pixel that drew high would take more samples to dilute it): a pixel 1000
// times noisier keeps its count, and its neighbours take more.
TEST(Adaptive, APixelsCountDoesNotDependOnItsOwnSamples) {
    const Film quiet = render(3), loud = render(3, {}, 8, 8);
    const size_t p = 8 * kW + 8;
    EXPECT_EQ(loud.pixel_spp[p], quiet.pixel_spp[p]);
    EXPECT_GT(loud.pixel_spp[p + 1], 4 * quiet.pixel_spp[p + 1]);
    EXPECT_GT(loud.pixel_spp[p - kW], 4 * quiet.pixel_spp[p - kW]);
    // Each pixel's mean is of its own samples: unbiased, 1 within its standard error.
    for (int y = 0; y < kH; y += 5)
        for (int x = 0; x < kW; x += 5) {
            const size_t q = size_t(y) * kW + x;
            const double se = sigma(x) / std::sqrt(double(quiet.pixel_spp[q]));
            EXPECT_NEAR(quiet.beauty.pixels[q].x, 1.0, 5.0 * se) << x << "," << y;
        }
}

// Two ranks, each in a thread of its own, exchanging their tile sums as MPI_Allgather would.
class TwoRanks : public Ranks {
public:
    struct Shared {
        std::mutex m;
        std::condition_variable cv;
        std::array<std::vector<uint8_t>, 2> data;
        int in = 0;
    };
    TwoRanks(Shared* s, int rank) : s_(s), rank_(rank) {}
    int rank() const override { return rank_; }
    int size() const override { return 2; }
    std::vector<std::vector<uint8_t>> all_gather(const std::vector<uint8_t>& mine) override {
        std::unique_lock<std::mutex> lock(s_->m);
        s_->data[size_t(rank_)] = mine;
        ++s_->in;
        s_->cv.notify_all();
        s_->cv.wait(lock, [&] { return s_->in == 2; });
        return {s_->data[0], s_->data[1]};
    }
    void sum_to_root(std::vector<int64_t>*) override { FOGMAP_ASSERT(false, "not used"); }
    void sum_to_all(std::vector<int64_t>*) override { FOGMAP_ASSERT(false, "not used"); }
    bool any(bool) override { FOGMAP_ASSERT(false, "not used"); }
    void wait_all() override {}
    int on_this_machine() override { return 2; }
    std::unique_ptr<Ranks> split(int) override { return nullptr; }

private:
    Shared* s_;
    int rank_;
};

TEST(Adaptive, TheCountsAndPixelsAreTheSameAtAnyThreadOrRankCount) {
    const Film one = render(5);
    Film one_thread;
    {
        const ThreadLimit limit(1);
        one_thread = render(5);
    }
    EXPECT_EQ(one_thread.pixel_spp, one.pixel_spp);
    EXPECT_EQ(one_thread.beauty.pixels, one.beauty.pixels);

    TwoRanks::Shared shared;
    std::array<Film, 2> films;
    std::vector<std::thread> ranks;
    for (int r = 0; r < 2; ++r)
        ranks.emplace_back([&, r] {
            TwoRanks me(&shared, r);
            films[size_t(r)] = render(5, TileShare{r, 2, &me});
        });
    for (std::thread& t : ranks) t.join();
    for (int y = 0; y < kH; ++y)
        for (int x = 0; x < kW; ++x) {
            const size_t p = size_t(y) * kW + x;
            const int mine = ((y / kTile) * (kW / kTile) + x / kTile) % 2;
            ASSERT_EQ(films[size_t(mine)].pixel_spp[p], one.pixel_spp[p]) << x << "," << y;
            ASSERT_EQ(films[size_t(mine)].beauty.pixels[p], one.beauty.pixels[p]);
            ASSERT_EQ(films[size_t(1 - mine)].pixel_spp[p], 0);
        }
}

// The error estimate of an adaptive film, whose pixels' batches hold shares of their own: its
// expectation is Σ σ² / n / (1 + 0.01) over the values, and the truth lies below its upper bound.
TEST(Adaptive, TheEstimateOfAnAdaptiveFilmIsItsVarianceOverItsOwnSamples) {
    int covered = 0;
    double ratio = 0.0, layer = 0.0;
    constexpr int kSeeds = 20;
    for (int seed = 1; seed <= kSeeds; ++seed) {
        const Film film = render(uint64_t(100 + seed));
        const ErrorEstimate e = estimate_error(film, kSpp);
        ASSERT_TRUE(e.valid);
        double expected = 0.0, truth = 0.0;
        for (int y = 0; y < kH; ++y)
            for (int x = 0; x < kW; ++x) {
                const size_t p = size_t(y) * kW + x;
                const double v = double(sigma(x)) * sigma(x) / film.pixel_spp[p];
                expected += v / 1.01;
                const double d = film.beauty.pixels[p].x - 1.0;
                truth += d * d / 1.01;
                layer += e.variance.pixels[p].x / v / (kW * kH * kSeeds);
            }
        expected /= kW * kH;
        truth /= kW * kH;
        ratio += e.rel_mse.value / expected / kSeeds;
        covered += truth <= e.rel_mse.hi;
    }
    EXPECT_NEAR(ratio, 1.0, 0.05);
    EXPECT_NEAR(layer, 1.0, 0.02);  // the variance layer, pixel by pixel
    EXPECT_GE(covered, 18);
}

// Adaptive sampling across iterations: two measured iterations of 8 spp, each sampled as a plain
// render is (a first pass of 2, the rest where it shows the error), then every later iteration of
// 8 spp takes the work of a uniform one spread as σ / sqrt(c) from the two first passes: by hand,
// Σ c = 2.5 and Σ σ sqrt(c) = 0.375 a pixel on average, so a pixel takes 8 · 2.5 / 0.375 σ /
// sqrt(c) = 53.3 σ / sqrt(c): 5.33, 21.3 (top), 2.67, 10.7 (bottom).
TEST(Adaptive, IterationsAfterTheMeasuredOnesTakeAUniformIterationsWorkWhereTheErrorIs) {
    constexpr int kIterationSpp = 8;
    const int first = measured_spp(kIterationSpp, 1, /*adaptive=*/true);
    ASSERT_EQ(first, 2);
    std::array<Film, 2> measured;
    std::array<PassMeasure, 2> m;
    for (size_t i = 0; i < 2; ++i) {
        measured[i] = render(40 + i, {}, -1, -1, nullptr, kIterationSpp, {nullptr, &m[i]});
        EXPECT_FALSE(measured[i].pixel_spp.empty());  // its own second pass
    }
    // Its first pass again, for the measure alone (RunLoop::measure_again): the same measure, from
    // that pass's samples only.
    PassMeasure again;
    RenderStats first_only;
    render(40, {}, -1, -1, &first_only, kIterationSpp, {nullptr, &again, true});
    EXPECT_EQ(first_only.samples, uint64_t(first) * kW * kH);
    EXPECT_EQ(again.means.pixels, m[0].means.pixels);
    EXPECT_EQ(again.squares, m[0].squares);
    EXPECT_EQ(again.work, m[0].work);
    IterationMeasure forward, backward;  // the same sums whatever order adds them
    forward.add(m[0]);
    forward.add(m[1]);
    backward.add(m[1]);
    backward.add(m[0]);
    ASSERT_EQ(forward.values, backward.values);
    const std::vector<int> counts = forward.allocate(2, first, kIterationSpp, 1, 9);
    const Quadrants q(counts);
    EXPECT_GE(q.least, 1);
    q.expect_near({{5.33, 21.3}, {2.67, 10.7}}, 0.05);
    EXPECT_NEAR(q.work / (kIterationSpp * 2.5 * kW * kH), 1.0, 0.02);

    // A later iteration takes them, in one pass, and each pixel's mean is of its own samples.
    RenderStats stats;
    const Film later = render(42, {}, -1, -1, &stats, kIterationSpp, {&counts, nullptr});
    EXPECT_EQ(later.pixel_spp, counts);
    EXPECT_EQ(stats.samples, uint64_t(q.samples()));
    double z2 = 0.0;  // Σ of squared standardised errors: about one a pixel
    for (size_t p = 0; p < counts.size(); ++p) {
        const double se = sigma(int(p % kW)) / std::sqrt(double(counts[p]));
        z2 += std::pow((later.beauty.pixels[p].x - 1.0) / se, 2.0);
    }
    EXPECT_NEAR(z2 / double(counts.size()), 1.0, 0.1);
}

}  // namespace
}  // namespace fogmap
