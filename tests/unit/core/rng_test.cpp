// Rng: uniform() stays in [0, 1) with the moments of U(0, 1), equal-width bins are filled evenly
// (chi-square), streams from different (a, b) are uncorrelated and a stream is reproducible.
// Tolerances are 4 standard errors of the estimator (two-sided p ≈ 6e-5 per check).

#include "core/rng.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <utility>
#include <vector>

namespace fogmap {
namespace {

constexpr int kDraws = 1000000;
constexpr uint64_t kSeed = 0x5EEDF06ull;

/// Upper quantile of chi-square with k degrees of freedom by the Wilson–Hilferty cube
/// approximation: k (1 − 2/(9k) + z sqrt(2/(9k)))³, z the standard normal quantile.
double chi_square_quantile(double k, double z) {
    const double a = 2.0 / (9.0 * k);
    const double t = 1.0 - a + z * std::sqrt(a);
    return k * t * t * t;
}

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
    const double expected = static_cast<double>(kDraws) / kBins;
    double chi2 = 0.0;
    for (int c : counts) chi2 += (c - expected) * (c - expected) / expected;
    // 99 degrees of freedom, 0.999 quantile (z = 3.0902); Wilson–Hilferty is good to ~0.1% here.
    EXPECT_LT(chi2, chi_square_quantile(kBins - 1, 3.090232));
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

}  // namespace
}  // namespace fogmap
