// Henyey–Greenstein: the phase function is normalised over the sphere, sampling follows it (chi-
// square against the analytic CDF), the sampled cosine equals an independent inverse CDF and
// stays finite at g = ±0.999 and g → 0, and hg_sample returns unit directions with that cosine.

#include "media/henyey_greenstein.h"

#include "core/math.h"
#include "core/rng.h"
#include "test_support.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

namespace fogmap {
namespace {

constexpr double kPiD = 3.14159265358979323846;

/// Analytic CDF of cos θ: (1−g²)/(2g) · (1/sqrt(1+g²−2gμ) − 1/(1+g)); g → 0 limit (1+μ)/2.
/// 1+g²−2gμ is formed around the peak, (1∓g)² ± 2g(1∓μ), so it keeps its digits at |g| → 1.
double hg_cdf(double mu, double g) {
    mu = std::min(1.0, std::max(-1.0, mu));
    if (std::abs(g) < 1e-12) return 0.5 * (1.0 + mu);
    const double d = g >= 0.0 ? (1.0 - g) * (1.0 - g) + 2.0 * g * (1.0 - mu)
                              : (1.0 + g) * (1.0 + g) - 2.0 * g * (1.0 + mu);
    return (1.0 - g * g) / (2.0 * g) * (1.0 / std::sqrt(d) - 1.0 / (1.0 + g));
}

/// μ with hg_cdf(μ) = p, by bisection (independent of the header's closed-form inverse).
double hg_cdf_inverse_bisect(double p, double g) {
    double lo = -1.0, hi = 1.0;
    for (int i = 0; i < 200 && hi - lo > 1e-16; ++i) {
        const double mid = 0.5 * (lo + hi);
        (hg_cdf(mid, g) < p ? lo : hi) = mid;
    }
    return 0.5 * (lo + hi);
}

/// Textbook inverse CDF, cos θ = (1+g²−((1−g²)/(1−g+2gξ))²)/(2g), in long double (g ≠ 0).
long double hg_inverse_textbook(long double g, long double xi) {
    const long double q = (1.0L - g * g) / (1.0L - g + 2.0L * g * xi);
    return (1.0L + g * g - q * q) / (2.0L * g);
}

/// 2π ∫ p(μ) dμ over [−1, 1] by composite Simpson on dyadic panels graded towards the peak
/// (μ = sign(g)), with every node μ = m · 2^-24 exactly representable as a float, so that
/// hg_phase sees the node itself and not a rounded neighbour.
double integrate_phase(float g) {
    const double sign = g < 0.0f ? -1.0 : 1.0;
    constexpr int kSub = 1 << 12;  // Simpson subintervals per panel (even)
    const double h0 = std::ldexp(1.0, -24);
    auto f = [&](double d) {
        return static_cast<double>(hg_phase(static_cast<float>(sign * (1.0 - d)), g));
    };
    auto simpson = [&](double a, double h) {
        double sum = f(a) + f(a + kSub * h);
        for (int i = 1; i < kSub; ++i) sum += (i % 2 == 1 ? 4.0 : 2.0) * f(a + i * h);
        return sum * h / 3.0;
    };
    // Panel 0 is [0, kSub h0]; panel j ≥ 1 is [2^(j−1) kSub h0, 2^j kSub h0], width h0 2^(j−1);
    // the last ends at d = 2 (μ = −sign).
    double total = simpson(0.0, h0);
    for (double a = kSub * h0, h = h0; a < 2.0; a *= 2.0, h *= 2.0) total += simpson(a, h);
    return 2.0 * kPiD * total;
}

TEST(HenyeyGreenstein, PhaseIntegratesToOneOverSphere) {
    for (float g : {-0.999f, -0.9f, 0.0f, 1e-7f, 0.5f, 0.99f, 0.999f}) {
        // Simpson error ≈ h⁴/180 · |p''''| with p''''/p ≤ 59/w⁴ near the peak, whose width is
        // w = (1−|g|)²/(2|g|). With float cosines h cannot go below 2^-24 ≈ 6e-8 there; at
        // |g| = 0.999 (w ≈ 5e-7, h/w ≈ 0.12) that bounds the error by ≈ 7e-5 on the peak and
        // less overall, so 1e-4. For |g| ≤ 0.99 (w ≥ 5e-5) the bound is < 1e-12; what remains
        // is hg_phase's float rounding, ≤ 2^-24 relative per value, so 1e-6 there.
        const double tolerance = std::abs(g) > 0.995f ? 1e-4 : 1e-6;
        EXPECT_NEAR(1.0, integrate_phase(g), tolerance) << "g = " << g;
    }
}

TEST(HenyeyGreenstein, PhaseMatchesClosedFormAtPoles) {
    // p(μ = 1) = (1+g)/(4π(1−g)²), p(μ = −1) = (1−g)/(4π(1+g)²); float result, 1e-6 relative.
    for (float g : {-0.999f, -0.5f, 0.0f, 1e-7f, 0.5f, 0.999f}) {
        const double gd = g;
        const double forward = (1.0 + gd) / (4.0 * kPiD * (1.0 - gd) * (1.0 - gd));
        const double backward = (1.0 - gd) / (4.0 * kPiD * (1.0 + gd) * (1.0 + gd));
        EXPECT_NEAR(forward, hg_phase(1.0f, g), 1e-6 * forward) << "g = " << g;
        EXPECT_NEAR(backward, hg_phase(-1.0f, g), 1e-6 * backward) << "g = " << g;
    }
}

TEST(HenyeyGreenstein, PhaseMatchesTheTextbookFormulaInLongDouble) {
    // hg_phase runs in float; (1−g²)/(4π(1+g²−2gμ)^{3/2}) in long double at the same float μ. Its
    // few roundings (each ≤ 2^-24 relative; the sum's terms are both non-negative) stay within
    // 2e-6, also where 1+g²−2gμ cancels (|g| near 1, μ near sign(g)).
    for (float g : {-0.999f, -0.9f, -0.5f, 0.0f, 0.3f, 0.5f, 0.85f, 0.999f}) {
        for (int i = 0; i <= 4000; ++i) {
            const float mu = i == 4000 ? 1.0f : -1.0f + static_cast<float>(i) / 2000.0f;
            const long double gl = g, d = 1.0L + gl * gl - 2.0L * gl * mu;
            const long double exact = (1.0L - gl * gl) / (4.0L * kPiD * d * std::sqrt(d));
            const double rel = static_cast<double>(std::abs(hg_phase(mu, g) - exact) / exact);
            EXPECT_LT(rel, 2e-6) << "g = " << g << ", mu = " << mu;
        }
    }
}

TEST(HenyeyGreenstein, SampledCosinesFollowAnalyticCdf) {
    constexpr int kBins = 100;
    constexpr int kSamples = 1000000;
    for (float g : {-0.999f, -0.9f, 0.0f, 0.5f, 0.99f, 0.999f}) {
        // Equal-probability bins, edges CDF⁻¹(k / kBins) by bisection on the CDF. hg_sample_cos
        // returns a float: near |μ| = 1 floats are 6e-8 apart while bins at g = 0.99 are only
        // ~1e-6 wide, so each edge is snapped to a float and its bin's probability taken between
        // the round-to-nearest boundaries (midpoints to the float below). Edges that coincide
        // after snapping (|g| = 0.999) are merged, and the degrees of freedom drop accordingly.
        std::vector<float> edges;
        std::vector<double> probability;
        double cdf_below = 0.0;
        for (int k = 1; k < kBins; ++k) {
            const float edge =
                static_cast<float>(hg_cdf_inverse_bisect(static_cast<double>(k) / kBins, g));
            if (edge <= -1.0f || (!edges.empty() && edges.back() == edge)) continue;
            edges.push_back(edge);
            const double boundary = 0.5 * (static_cast<double>(std::nextafter(edge, -2.0f)) + edge);
            const double cdf = hg_cdf(boundary, g);
            probability.push_back(cdf - cdf_below);
            cdf_below = cdf;
        }
        probability.push_back(1.0 - cdf_below);

        std::vector<int> counts(probability.size(), 0);
        Rng rng(0xC0FFEEull, static_cast<uint64_t>(1000.0f * (g + 1.0f)));
        for (int i = 0; i < kSamples; ++i) {
            const float c = hg_sample_cos(g, rng.uniform());
            ++counts[std::upper_bound(edges.begin(), edges.end(), c) - edges.begin()];
        }
        std::vector<double> expected;
        for (double p : probability) expected.push_back(kSamples * p);
        const double chi2 = test::chi_square(counts, expected);
        // Critical value at p = 0.001 (z = 3.0902) for bins − 1 degrees of freedom,
        // by Wilson–Hilferty (≈ 148.2 for 99).
        const double critical =
            test::chi_square_quantile(static_cast<double>(counts.size()) - 1.0, 3.090232);
        EXPECT_LT(chi2, critical) << "g = " << g << ", bins = " << counts.size();
    }
}

TEST(HenyeyGreenstein, SamplingStaysFiniteAndMatchesInverseCdfNearGOneAndZero) {
    const float u_max = 1.0f - std::ldexp(1.0f, -24);  // largest value Rng::uniform() returns
    for (float g : {-0.999f, 0.999f, 1e-7f}) {
        for (int i = 0; i <= (1 << 20); ++i) {
            const float u = i == (1 << 20) ? u_max : std::ldexp(static_cast<float>(i), -20);
            const float c = hg_sample_cos(g, u);
            ASSERT_TRUE(std::isfinite(c)) << "g = " << g << ", u = " << u;
            ASSERT_GE(c, -1.0f);
            ASSERT_LE(c, 1.0f);
            const long double ref = std::clamp(hg_inverse_textbook(g, u), -1.0L, 1.0L);
            // c is the double result rounded to float: half a float ulp of ref, plus the
            // double evaluation error of the header, ≲ 1e-16 / (1−|g|)² ≈ 1e-10 at |g| = 0.999.
            const float ref_f = static_cast<float>(ref);
            const double half_ulp = 0.5 * (std::nextafter(std::abs(ref_f), 2.0f) - std::abs(ref_f));
            const double err = std::abs(static_cast<double>(c) - static_cast<double>(ref));
            ASSERT_LE(err, half_ulp + 1e-9)
                << "g = " << g << ", u = " << u << ", ref = " << static_cast<double>(ref);
        }
        EXPECT_EQ(-1.0f, hg_sample_cos(g, 0.0f)) << "g = " << g;
    }
}

TEST(HenyeyGreenstein, SampleReturnsUnitDirectionWithSampledCosineAndPhaseAsPdf) {
    Rng rng(0xD1CEull, 0);
    std::vector<Vec3> dirs = {Vec3(0, 0, 1), Vec3(0, 0, -1), Vec3(1, 0, 0), Vec3(0, -1, 0)};
    for (int i = 0; i < 200; ++i) {
        // Uniform direction on the sphere (Archimedes: z uniform in [−1, 1]).
        const float z = 2.0f * rng.uniform() - 1.0f;
        const float phi = kTwoPi * rng.uniform();
        const float r = std::sqrt(std::max(0.0f, 1.0f - z * z));
        dirs.push_back(glm::normalize(Vec3(r * std::cos(phi), r * std::sin(phi), z)));
    }
    for (float g : {-0.999f, -0.5f, 0.0f, 1e-7f, 0.7f, 0.999f}) {
        for (const Vec3& dir : dirs) {
            for (int k = 0; k < 20; ++k) {
                const Vec2 u(rng.uniform(), rng.uniform());
                float pdf = -1.0f;
                const Vec3 w = hg_sample(dir, g, u, &pdf);
                const float cos_theta = hg_sample_cos(g, u.x);
                // Float frame construction, rotation and normalisation: a few ulps each; 2e-6
                // (≈ 16 ulps of 1) covers length and cosine.
                EXPECT_NEAR(1.0f, glm::length(w), 2e-6f);
                EXPECT_NEAR(cos_theta, glm::dot(dir, w), 2e-6f) << "g = " << g;
                // hg_sample computes the pdf from 1 − μ in double; hg_phase from the float μ,
                // whose rounding (≤ 6e-8 near ±1) moves p by 3|g|·Δμ/(1+g²−2gμ) relatively.
                const double denom = 1.0 + double(g) * g - 2.0 * double(g) * cos_theta;
                const double rel = 3.0 * std::abs(g) * 6e-8 / denom + 1e-6;
                EXPECT_NEAR(hg_phase(cos_theta, g), pdf, rel * pdf) << "g = " << g;
            }
        }
    }
}

}  // namespace
}  // namespace fogmap
