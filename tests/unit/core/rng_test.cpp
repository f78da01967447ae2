// Rng: uniform() stays in [0, 1) with the moments of U(0, 1), equal-width bins are filled evenly
// (chi-square), streams from different (a, b) are uncorrelated and a stream is reproducible;
// seeds derived from a render seed and a stream key (derive_seed) never coincide.
// Tolerances are 4 standard errors of the estimator (two-sided p ≈ 6e-5 per check).

#include "core/rng.h"

#include "test_support.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <set>
#include <utility>
#include <vector>

namespace fogmap {
namespace {

constexpr int kDraws = 1000000;
constexpr uint64_t kSeed = 0x5EEDF06ull;

/// Sample Pearson correlation of two streams' uniform() draws.
double correlation(Rng x_rng, Rng y_rng, int n) {
    double sx = 0.0, sy = 0.0, sxx = 0.0, syy = 0.0, sxy = 0.0;
    for (int i = 0; i < n; ++i) {
        const double x = x_rng.uniform();
        const double y = y_rng.uniform();
        sx += x;
        sy += y;
        sxx += x * x;
        syy += y * y;
        sxy += x * y;
    }
    const double cov = sxy / n - (sx / n) * (sy / n);
    const double vx = sxx / n - (sx / n) * (sx / n);
    const double vy = syy / n - (sy / n) * (sy / n);
    return cov / std::sqrt(vx * vy);
}

TEST(Rng, UniformStaysInHalfOpenUnitInterval) {
    Rng rng(kSeed, 1, 2);
    for (int i = 0; i < kDraws; ++i) {
        const float u = rng.uniform();
        ASSERT_GE(u, 0.0f);
        ASSERT_LT(u, 1.0f);
        const double d = rng.uniform_double();
        ASSERT_GE(d, 0.0);
        ASSERT_LT(d, 1.0);
    }
}

TEST(Rng, MeanAndVarianceMatchUniformDistribution) {
    Rng rng(kSeed, 7, 0);
    double sum = 0.0, sum_sq = 0.0;
    for (int i = 0; i < kDraws; ++i) {
        const double u = rng.uniform();
        sum += u;
        sum_sq += u * u;
    }
    const double n = kDraws;
    const double mean = sum / n;
    const double variance = sum_sq / n - mean * mean;
    // U(0,1): mean 1/2, variance 1/12, fourth central moment 1/80. Standard errors:
    // mean sqrt(1/12 / n); sample variance sqrt((mu4 − sigma⁴) / n) = sqrt((1/80 − 1/144) / n).
    const double se_mean = std::sqrt(1.0 / 12.0 / n);
    const double se_variance = std::sqrt((1.0 / 80.0 - 1.0 / 144.0) / n);
    EXPECT_NEAR(0.5, mean, 4.0 * se_mean);
    EXPECT_NEAR(1.0 / 12.0, variance, 4.0 * se_variance);
}

TEST(Rng, ChiSquareOfHundredBinsIsBelowCriticalValue) {
    constexpr int kBins = 100;
    std::vector<int> counts(kBins, 0);
    Rng rng(kSeed, 3, 4);
    for (int i = 0; i < kDraws; ++i) ++counts[static_cast<int>(rng.uniform() * kBins)];
    const double chi2 = test::chi_square(counts, static_cast<double>(kDraws) / kBins);
    // 99 degrees of freedom, 0.999 quantile (z = 3.0902); Wilson–Hilferty is good to ~0.1% here.
    EXPECT_LT(chi2, test::chi_square_quantile(kBins - 1, 3.090232));
}

TEST(Rng, StreamsWithDifferentIndicesAreUncorrelated) {
    // Under independence the sample correlation has standard error 1/sqrt(n).
    constexpr int kN = 200000;
    const double tolerance = 4.0 / std::sqrt(static_cast<double>(kN));
    const std::pair<uint64_t, uint64_t> ab[][2] = {
        {{0, 0}, {1, 0}},                // neighbouring pixels, same sample
        {{0, 0}, {0, 1}},                // same pixel, neighbouring samples
        {{1, 0}, {0, 1}},                // a and b swapped
        {{5, 9}, {6, 10}},               // arbitrary nearby indices
        {{1u << 17, 0}, {0, 1u << 17}},  // a << 17 meets b in the state hash
    };
    for (const auto& pair : ab) {
        const Rng x(kSeed, pair[0].first, pair[0].second);
        const Rng y(kSeed, pair[1].first, pair[1].second);
        EXPECT_NEAR(0.0, correlation(x, y, kN), tolerance)
            << "(" << pair[0].first << "," << pair[0].second << ") vs (" << pair[1].first << ","
            << pair[1].second << ")";
    }
    // Different seeds, same indices.
    EXPECT_NEAR(0.0, correlation(Rng(1, 0, 0), Rng(2, 0, 0), kN), tolerance);
}

TEST(Rng, SameSeedAndIndicesGiveSameSequence) {
    Rng first(kSeed, 123, 456);
    Rng second(kSeed, 123, 456);
    Rng other(kSeed, 123, 457);
    int differing = 0;
    for (int i = 0; i < 10000; ++i) {
        const uint32_t v = first.next_u32();
        ASSERT_EQ(v, second.next_u32()) << "draw " << i;
        differing += v != other.next_u32();
    }
    // Another stream agrees on a draw with probability 2^-32: all 10000 should differ.
    EXPECT_EQ(10000, differing);
}

// derive_seed over the first 1000 render seeds, two indices each, against a brute-force set:
// every derived seed differs from every other (a collision among 2000 unrelated 64-bit values has
// probability ~1e-13). The xor form it replaced gave seeds 2j and 2j + 1 the same pair, swapped.
TEST(StreamKeys, DerivedSeedsOfDifferentSeedsNeverCoincide) {
    const auto xor_form = [](uint64_t seed, uint64_t k) {
        return mix64(seed ^ (stream::kAdaptive + k));
    };
    EXPECT_EQ(xor_form(6, 0), xor_form(7, 1));
    std::set<uint64_t> seen;
    for (uint64_t seed = 0; seed < 1000; ++seed)
        for (uint64_t k = 0; k < 2; ++k)
            EXPECT_TRUE(seen.insert(derive_seed(seed, stream::kAdaptive, k)).second)
                << "seed " << seed << ", index " << k;
    // Another key gives other seeds.
    for (uint64_t seed = 0; seed < 1000; ++seed)
        EXPECT_EQ(seen.count(derive_seed(seed, stream::kPixelEstimate, 0)), 0u) << seed;
}

}  // namespace
}  // namespace fogmap
