// Sub-pixel sample positions (render/batches.h): permute is a bijection of [0, n) for any key;
// a pass's positions are N-rooks — one sample in each of its n columns and rows — inside the
// pixel, and each batch's n_b samples hold one each of n_b equal coarse columns and rows, for
// passes of any range and unit; the rows' order depends on the key. Plus independent checks of
// what they are for, against the coverage of a pixel by a half-plane through it (from a
// 2000 x 2000 midpoint grid): 16 samples have less than half the squared error of independent
// positions, and the batches' spread says the squared error of the pass's mean (where batches of
// consecutive columns, strips of the pixel, said several times more).

#include "render/batches.h"
#include "render/photon_integrator.h"
#include "render/tiles.h"

#include "core/rng.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <map>
#include <string>
#include <utility>
#include <vector>

namespace fogmap {
namespace {

TEST(PixelJitter, PermuteIsABijectionForAnyKey) {
    Rng rng(7, 1);
    for (uint32_t n : {1u, 2u, 3u, 7u, 8u, 9u, 64u, 100u, 1000u, 4097u}) {
        for (int trial = 0; trial < 20; ++trial) {
            const uint64_t key = (uint64_t(rng.next_u32()) << 32) | rng.next_u32();
            std::vector<int> seen(n, 0);
            for (uint32_t i = 0; i < n; ++i) {
                const uint32_t p = permute(i, n, key);
                ASSERT_LT(p, n);
                ++seen[p];
            }
            for (uint32_t i = 0; i < n; ++i) ASSERT_EQ(seen[i], 1) << "n " << n << " value " << i;
        }
    }
}

// Every order of a few strata is as likely as any other (uniform over the n! orders, each within
// 10% of its expectation at 2000 keys each): the strata of different keys (the batches', the
// samples' first vertex) are independent. Multiplies and adds alone gave 8 of the 24 orders of 4.
TEST(PixelJitter, PermuteDrawsEveryOrderOfFewStrataAlike) {
    for (uint32_t n : {3u, 4u}) {
        const int orders = n == 3 ? 6 : 24, keys = 2000 * orders;
        std::map<uint32_t, int> seen;
        for (int k = 0; k < keys; ++k) {
            const uint64_t key = mix64(uint64_t(k) * 0x9E3779B97F4A7C15ull);
            uint32_t code = 0;
            for (uint32_t i = 0; i < n; ++i) code = code * n + permute(i, n, key);
            ++seen[code];
        }
        ASSERT_EQ(int(seen.size()), orders) << n;
        for (const auto& [code, count] : seen) EXPECT_NEAR(count, 2000, 200) << n << " " << code;
    }
}

/// The positions of the samples [s0, s1) of a pixel keyed `key`, batched by `unit`s.
std::vector<Vec2> pass_positions(int s0, int s1, int unit, uint64_t key, Rng& rng) {
    const PassStrata strata(s0, s1, unit);
    std::vector<Vec2> out;
    for (int s = s0; s < s1; ++s)
        out.push_back(pass_jitter(strata, s, key, Vec2(rng.uniform(), rng.uniform())));
    return out;
}

TEST(PixelJitter, ThePassAndEachBatchHoldOneSampleInEachOfTheirColumnsAndRows) {
    Rng rng(7, 2);
    int identity = 0;
    struct Pass {
        int s0, s1, unit;
    };
    for (const Pass& pass : {Pass{0, 1, 1},
                             {0, 2, 1},
                             {0, 5, 1},
                             {0, 16, 1},
                             {0, 16, 4},
                             {0, 64, 4},
                             {0, 64, 16},
                             {0, 24, 4},
                             {8, 52, 4},
                             {16, 100, 4},
                             {0, 40, 1},
                             {0, 12, 3}}) {
        SCOPED_TRACE(std::to_string(pass.s0) + ".." + std::to_string(pass.s1) + " unit " +
                     std::to_string(pass.unit));
        const int n = pass.s1 - pass.s0;
        const std::array<int, kBatches> counts = batch_counts(pass.s0, pass.s1, pass.unit);
        for (uint64_t key = 1; key <= 50; ++key) {
            const std::vector<Vec2> p =
                pass_positions(pass.s0, pass.s1, pass.unit, key * 0x9E3779B97F4A7C15ull, rng);
            std::vector<int> cols(n, 0), rows(n, 0);
            std::vector<std::vector<int>> batch_cols(kBatches), batch_rows(kBatches);
            for (int b = 0; b < kBatches; ++b) {
                batch_cols[size_t(b)].assign(size_t(counts[size_t(b)]), 0);
                batch_rows[size_t(b)].assign(size_t(counts[size_t(b)]), 0);
            }
            bool is_identity = true;
            for (int s = pass.s0; s < pass.s1; ++s) {
                const Vec2 j = p[size_t(s - pass.s0)];
                ASSERT_GE(j.x, 0.0f);
                ASSERT_LT(j.x, 1.0f);
                ASSERT_GE(j.y, 0.0f);
                ASSERT_LT(j.y, 1.0f);
                ++cols[size_t(j.x * n)];
                ++rows[size_t(j.y * n)];
                const size_t b = size_t(s / pass.unit % kBatches);
                ++batch_cols[b][size_t(j.x * counts[b])];
                ++batch_rows[b][size_t(j.y * counts[b])];
                is_identity = is_identity && int(j.y * n) == s - pass.s0;
            }
            for (int i = 0; i < n; ++i) {
                ASSERT_EQ(cols[size_t(i)], 1);
                ASSERT_EQ(rows[size_t(i)], 1);
            }
            for (size_t b = 0; b < size_t(kBatches); ++b)
                for (int i = 0; i < counts[b]; ++i) {
                    ASSERT_EQ(batch_cols[b][size_t(i)], 1) << "batch " << b;
                    ASSERT_EQ(batch_rows[b][size_t(i)], 1) << "batch " << b;
                }
            identity += n == 16 && is_identity;
        }
    }
    EXPECT_EQ(identity, 0) << "rows should be shuffled per pixel";
}

// Fraction of the unit square with n·p < c, from a 2000 x 2000 midpoint grid (error ~1e-4 for a
// straight edge, far below the 16-sample errors compared).
double coverage(const Vec2& n, float c) {
    constexpr int kGrid = 2000;
    long inside = 0;
    for (int i = 0; i < kGrid; ++i)
        for (int j = 0; j < kGrid; ++j) {
            const float x = (i + 0.5f) / kGrid, y = (j + 0.5f) / kGrid;
            inside += n.x * x + n.y * y < c;
        }
    return double(inside) / (double(kGrid) * kGrid);
}

/// A straight edge through a pixel, n·p < c inside, at a random angle and within ±offset / 2 of
/// the pixel's centre, with its exact coverage.
struct Edge {
    Vec2 n;
    float c;
    double exact;
};
Edge random_edge(Rng& rng, float offset) {
    const float a = kTwoPi * rng.uniform();
    const Vec2 n(std::cos(a), std::sin(a));
    const float c = glm::dot(n, Vec2(0.5f)) + offset * (rng.uniform() - 0.5f);
    return {n, c, coverage(n, c)};
}

uint64_t random_key(Rng& rng) { return (uint64_t(rng.next_u32()) << 32) | rng.next_u32(); }

TEST(PixelJitter, EdgesCostLessErrorThanIndependentPositions) {
    constexpr int kSpp = 16, kEdges = 40, kPixels = 400;
    Rng rng(7, 3);
    double mse_rooks = 0.0, mse_random = 0.0;
    for (int e = 0; e < kEdges; ++e) {
        const auto [n, c, exact] = random_edge(rng, 0.3f);
        for (int p = 0; p < kPixels; ++p) {
            const uint64_t key = random_key(rng);
            int rooks = 0, random = 0;
            for (const Vec2& pos : pass_positions(0, kSpp, 1, key, rng)) {
                rooks += glm::dot(n, pos) < c;
                random += glm::dot(n, Vec2(rng.uniform(), rng.uniform())) < c;
            }
            mse_rooks += std::pow(rooks / double(kSpp) - exact, 2);
            mse_random += std::pow(random / double(kSpp) - exact, 2);
        }
    }
    // Independent positions: Var = q(1 − q)/16; N-rooks removes most of it for edges.
    EXPECT_LT(mse_rooks, 0.5 * mse_random);
}

// The batches' estimate of the squared error of a pixel's mean, Σ_b (m_b − m)² / (B (B − 1)),
// against the truth, over pixels cut by random edges (the shape of a spot light's cone or a
// caustic's edge: the pixel's value varies across it and each sample is exact). Batches that are
// strips of consecutive columns (the positions before render/batches.h: column = sample index)
// overstate it several times; stratified batches only by their coupling.
TEST(PixelJitter, TheBatchesSpreadSaysTheSquaredErrorOfThePassMean) {
    constexpr int kEdges = 30, kPixels = 300;
    struct Setting {
        int spp, unit;
    };
    Rng rng(7, 5);
    for (const Setting& set : {Setting{64, 16}, {64, 4}, {16, 4}, {32, 1}}) {
        SCOPED_TRACE(std::to_string(set.spp) + " spp, unit " + std::to_string(set.unit));
        const std::array<int, kBatches> counts = batch_counts(0, set.spp, set.unit);
        double truth = 0.0, estimate = 0.0, strips = 0.0;
        for (int e = 0; e < kEdges; ++e) {
            const auto [n, c, exact] = random_edge(rng, 0.6f);
            for (int p = 0; p < kPixels; ++p) {
                const uint64_t key = random_key(rng);
                const std::vector<Vec2> pos = pass_positions(0, set.spp, set.unit, key, rng);
                // The same samples with the old strips: column s, the rows as drawn.
                const auto spread = [&](auto&& inside) {
                    std::array<double, kBatches> sum{};
                    double mean = 0.0;
                    for (int s = 0; s < set.spp; ++s) {
                        const double v = inside(s);
                        sum[size_t(s / set.unit % kBatches)] += v;
                        mean += v / set.spp;
                    }
                    double sq = 0.0;
                    int held = 0;
                    for (size_t b = 0; b < size_t(kBatches); ++b)
                        if (counts[b] > 0) sq += std::pow(sum[b] / counts[b] - mean, 2), ++held;
                    return std::pair{mean, sq / (held * (held - 1.0))};
                };
                const auto [mean, v] =
                    spread([&](int s) { return glm::dot(n, pos[size_t(s)]) < c; });
                const auto [strip_mean, strip_v] = spread([&](int s) {
                    const Vec2 q(
                        (s + pos[size_t(s)].x * set.spp - std::floor(pos[size_t(s)].x * set.spp)) /
                            set.spp,
                        pos[size_t(s)].y);
                    return glm::dot(n, q) < c;
                });
                truth += std::pow(mean - exact, 2);
                estimate += v;
                strips += strip_v;
            }
        }
        EXPECT_GT(estimate, 0.9 * truth);
        EXPECT_LT(estimate, 2.0 * truth);
        std::printf("%d spp, unit %d: estimate / truth %.2f (strips %.2f)\n", set.spp, set.unit,
                    estimate / truth, strips / truth);
    }
}

// The tile shares of the ranks of a plain render: for any share count, every pixel of an image
// whose sides are not multiples of the tile is shaded exactly once over the shares, and each
// share reports the pixels it shaded.
TEST(TileShare, SharesCoverEveryPixelExactlyOnce) {
    const int w = 53, h = 37;
    for (int count : {1, 2, 3, 7, 13}) {
        SCOPED_TRACE(std::to_string(count) + " shares");
        std::vector<std::atomic<int>> hits(w * h);
        uint64_t total = 0;
        for (int index = 0; index < count; ++index) {
            struct State {};
            total += render_tiles(
                w, h, TileShare{index, count}, /*quiet=*/true, [] { return State{}; },
                [&](int x, int y, State&) { ++hits[size_t(y) * w + x]; }, [](const State&) {});
        }
        EXPECT_EQ(total, uint64_t(w) * h);
        for (int i = 0; i < w * h; ++i) ASSERT_EQ(hits[i].load(), 1) << "pixel " << i;
    }
}

// advanced.map_spp (Horvitz–Thompson): over many pixels, every sample index s is chosen for the
// photon-map lookups with probability 1 / step (binomial, within 5 standard deviations) and
// weighs step, so E[weight] = 1 for each s; each pixel chooses one sample in every whole block
// of step samples (and at most one in a last, partial one); and where batches share their
// columns (blocks of four batches at 64 spp, step 16) the chosen samples' columns are
// stratified: one in each quarter of the pixel.
TEST(MapWeight, EverySampleIsChosenWithProbabilityOneOverStep) {
    constexpr int kPixels = 20000;
    for (const auto& [spp, map_spp] :
         {std::pair{16, 1}, {16, 4}, {16, 5}, {12, 8}, {7, 2}, {64, 4}}) {
        SCOPED_TRACE(std::to_string(spp) + " spp, map_spp " + std::to_string(map_spp));
        const int step = std::max(1, spp / map_spp);
        std::vector<int> chosen(spp, 0);
        Rng rng(7, 6);
        for (int p = 0; p < kPixels; ++p) {
            const uint64_t key = pixel_key(9, static_cast<uint64_t>(p));
            std::vector<int> in_block((spp + step - 1) / step, 0);
            std::vector<int> quarters(4, 0);
            const std::vector<Vec2> pos = pass_positions(0, spp, step, key, rng);
            for (int s = 0; s < spp; ++s) {
                const float w = map_weight(PixelSample{s, spp, key}, map_step(spp, map_spp));
                if (w == 0.0f) continue;
                ASSERT_EQ(w, static_cast<float>(step));
                ++in_block[size_t(s / step)];
                ++quarters[size_t(pos[size_t(s)].x * 4)];
                ++chosen[s];
            }
            for (size_t b = 0; b < in_block.size(); ++b) {
                if ((b + 1) * step <= size_t(spp)) {
                    ASSERT_EQ(in_block[b], 1) << "block " << b;
                }
                ASSERT_LE(in_block[b], 1) << "block " << b;
            }
            if (spp == 64 && map_spp == 4) {
                for (int q = 0; q < 4; ++q) ASSERT_EQ(quarters[size_t(q)], 1) << "quarter " << q;
            }
        }
        const double q = 1.0 / step, sd = std::sqrt(kPixels * q * (1.0 - q));
        for (int s = 0; s < spp; ++s) EXPECT_NEAR(chosen[s], kPixels * q, 5.0 * sd + 1e-9) << s;
    }
    // map_spp 0 or >= spp: every sample, weight 1.
    for (int s = 0; s < 8; ++s) {
        EXPECT_EQ(map_weight(PixelSample{s, 8, 123}, map_step(8, 0)), 1.0f);
        EXPECT_EQ(map_weight(PixelSample{s, 8, 123}, map_step(8, 8)), 1.0f);
        EXPECT_EQ(map_weight(PixelSample{s, 8, 123}, map_step(8, 20)), 1.0f);
    }
}

// Adaptive sampling with the photon gather (docs/design.md, Where it applies): a pixel's samples
// come in a first pass of n1 and a second up to its own count n (PixelSample::spp is the pass's
// count), while the step stays the render's. Each pass's whole blocks of step samples then hold
// one chosen sample each, every sample index is chosen with probability 1 / step (binomial,
// within 5 standard deviations), so a pixel of n samples reads the maps n / step times, whatever
// its count, each reading weighing step.
TEST(MapWeight, APixelOfItsOwnCountReadsTheMapsOnceInEachStepOfItsSamples) {
    constexpr int kPixels = 20000, kStep = 4, kFirst = 8;  // 16 spp, map_spp 4
    for (const int n : {8, 12, 40, 256}) {
        SCOPED_TRACE(std::to_string(n) + " samples in the pixel");
        std::vector<int> chosen(size_t(n), 0);
        for (int p = 0; p < kPixels; ++p) {
            const uint64_t key = pixel_key(11, static_cast<uint64_t>(p));
            std::vector<int> in_block(size_t(n / kStep), 0);
            for (int s = 0; s < n; ++s) {
                const int total = s < kFirst ? kFirst : n;  // the pass's PixelSample::spp
                const float w = map_weight(PixelSample{s, total, key}, kStep);
                if (w == 0.0f) continue;
                ASSERT_EQ(w, static_cast<float>(kStep));
                ++in_block[size_t(s / kStep)];
                ++chosen[size_t(s)];
            }
            for (size_t b = 0; b < in_block.size(); ++b) ASSERT_EQ(in_block[b], 1) << "block " << b;
        }
        const double q = 1.0 / kStep, sd = std::sqrt(kPixels * q * (1.0 - q));
        for (int s = 0; s < n; ++s) EXPECT_NEAR(chosen[size_t(s)], kPixels * q, 5.0 * sd) << s;
    }
}

}  // namespace
}  // namespace fogmap
