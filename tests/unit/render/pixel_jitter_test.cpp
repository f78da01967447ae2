// Sub-pixel sample positions (render/tiles.h): permute is a bijection of [0, n) for any key, and
// the spp positions of a pixel are N-rooks — one sample in each column and in each row — inside
// the pixel; the rows' order depends on the key. Plus an independent check of what it is for:
// the coverage of a pixel by a half-plane through it, estimated from 16 samples, has less than half
// the squared error of independent positions (true coverage from a 2000 x 2000 midpoint grid).

#include "render/photon_integrator.h"
#include "render/tiles.h"

#include "core/rng.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <cmath>
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

TEST(PixelJitter, EachColumnAndRowOfThePixelHoldsOneSample) {
    Rng rng(7, 2);
    int identity = 0;
    for (int spp : {1, 2, 5, 16, 64}) {
        for (uint64_t key = 1; key <= 50; ++key) {
            std::vector<int> cols(spp, 0), rows(spp, 0);
            bool is_identity = true;
            for (int s = 0; s < spp; ++s) {
                const Vec2 j = pixel_jitter(s, spp, key * 0x9E3779B97F4A7C15ull,
                                            Vec2(rng.uniform(), rng.uniform()));
                ASSERT_GE(j.x, 0.0f);
                ASSERT_LT(j.x, 1.0f);
                ASSERT_GE(j.y, 0.0f);
                ASSERT_LT(j.y, 1.0f);
                ++cols[static_cast<int>(j.x * spp)];
                ++rows[static_cast<int>(j.y * spp)];
                is_identity = is_identity && static_cast<int>(j.y * spp) == s;
            }
            for (int i = 0; i < spp; ++i) {
                EXPECT_EQ(cols[i], 1);
                EXPECT_EQ(rows[i], 1);
            }
            identity += spp == 16 && is_identity;
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

TEST(PixelJitter, EdgesCostLessErrorThanIndependentPositions) {
    constexpr int kSpp = 16, kEdges = 40, kPixels = 400;
    Rng rng(7, 3);
    double mse_rooks = 0.0, mse_random = 0.0;
    for (int e = 0; e < kEdges; ++e) {
        const float a = kTwoPi * rng.uniform();
        const Vec2 n(std::cos(a), std::sin(a));
        const float c = glm::dot(n, Vec2(0.5f)) + 0.3f * (rng.uniform() - 0.5f);
        const double exact = coverage(n, c);
        for (int p = 0; p < kPixels; ++p) {
            const uint64_t key = (uint64_t(rng.next_u32()) << 32) | rng.next_u32();
            int rooks = 0, random = 0;
            for (int s = 0; s < kSpp; ++s) {
                const Vec2 u(rng.uniform(), rng.uniform());
                rooks += glm::dot(n, pixel_jitter(s, kSpp, key, u)) < c;
                random += glm::dot(n, Vec2(rng.uniform(), rng.uniform())) < c;
            }
            mse_rooks += std::pow(rooks / double(kSpp) - exact, 2);
            mse_random += std::pow(random / double(kSpp) - exact, 2);
        }
    }
    // Independent positions: Var = q(1 − q)/16; N-rooks removes most of it for edges.
    EXPECT_LT(mse_rooks, 0.5 * mse_random);
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
// weighs step, so E[weight] = 1 for each s; each pixel chooses about spp / step samples, at most
// one per block of step consecutive N-rooks columns.
TEST(MapWeight, EverySampleIsChosenWithProbabilityOneOverStep) {
    constexpr int kPixels = 20000;
    for (const auto& [spp, map_spp] : {std::pair{16, 1}, {16, 4}, {16, 5}, {12, 8}, {7, 2}}) {
        SCOPED_TRACE(std::to_string(spp) + " spp, map_spp " + std::to_string(map_spp));
        const int step = std::max(1, spp / map_spp);
        std::vector<int> chosen(spp, 0);
        for (int p = 0; p < kPixels; ++p) {
            const uint64_t key = pixel_key(9, static_cast<uint64_t>(p));
            int in_pixel = 0, last = -step;
            for (int s = 0; s < spp; ++s) {
                const float w = map_weight(PixelSample{s, spp, key}, map_spp);
                if (w == 0.0f) continue;
                ASSERT_EQ(w, static_cast<float>(step));
                ASSERT_GE(s - last, step) << "two chosen samples within one block";
                last = s;
                ++chosen[s];
                ++in_pixel;
            }
            ASSERT_GE(in_pixel, spp / step);
            ASSERT_LE(in_pixel, (spp + step - 1) / step);
        }
        const double q = 1.0 / step, sd = std::sqrt(kPixels * q * (1.0 - q));
        for (int s = 0; s < spp; ++s) EXPECT_NEAR(chosen[s], kPixels * q, 5.0 * sd + 1e-9) << s;
    }
    // map_spp 0 or >= spp: every sample, weight 1.
    for (int s = 0; s < 8; ++s) {
        EXPECT_EQ(map_weight(PixelSample{s, 8, 123}, 0), 1.0f);
        EXPECT_EQ(map_weight(PixelSample{s, 8, 123}, 8), 1.0f);
        EXPECT_EQ(map_weight(PixelSample{s, 8, 123}, 20), 1.0f);
    }
}

}  // namespace
}  // namespace fogmap
