// The phase function where media overlap (media/phase.h): its value is the σ_s-weighted mixture
// of the media's Henyey–Greenstein functions written out here, it reduces to one medium's HG where
// only that medium is present, and its sampled cosines follow the mixture's analytic CDF
// (chi-square), with the reported pdf equal to the value.

#include "media/phase.h"

#include "media/medium.h"
#include "test_support.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

namespace fogmap {
namespace {

constexpr double kPiD = 3.14159265358979323846;

double hg(double mu, double g) {
    return (1.0 - g * g) / (4.0 * kPiD * std::pow(1.0 + g * g - 2.0 * g * mu, 1.5));
}

/// CDF of cos θ for one HG (g != 0): (1−g²)/(2g) · (1/sqrt(1+g²−2gμ) − 1/(1+g)).
double hg_cdf(double mu, double g) {
    return (1.0 - g * g) / (2.0 * g) *
           (1.0 / std::sqrt(1.0 + g * g - 2.0 * g * mu) - 1.0 / (1.0 + g));
}

// Two overlapping boxes: a forward-scattering one (σ_s 3, g 0.8) over x < 1 and a backward one
// (σ_s 1, g −0.5) over x > −1; they overlap on |x| < 1.
std::vector<Medium> two_media() {
    return {Medium::homogeneous({Color(3.0f), Color(0.5f), 0.8f},
                                Box3{Vec3(-3.0f), Vec3(1.0f, 3.0f, 3.0f)}),
            Medium::homogeneous({Color(1.0f), Color(0.0f), -0.5f},
                                Box3{Vec3(-1.0f, -3.0f, -3.0f), Vec3(3.0f)})};
}

TEST(PhaseMix, IsTheScatteringWeightedMixtureOfTheMedia) {
    const std::vector<Medium> media = two_media();
    std::vector<Medium::Sampler> samplers;
    for (const Medium& m : media) samplers.emplace_back(m);
    const PhaseMix both(samplers, Vec3(0.0f));
    const PhaseMix forward_only(samplers, Vec3(-2.0f, 0.0f, 0.0f));
    const PhaseMix backward_only(samplers, Vec3(2.0f, 0.0f, 0.0f));
    for (double mu : {-1.0, -0.6, 0.0, 0.3, 0.9, 1.0}) {
        const double mixture = (3.0 * hg(mu, 0.8) + 1.0 * hg(mu, -0.5)) / 4.0;
        EXPECT_NEAR(both.eval(float(mu)), mixture, 1e-5 * mixture) << "mu " << mu;
        EXPECT_NEAR(forward_only.eval(float(mu)), hg(mu, 0.8), 1e-5 * hg(mu, 0.8));
        EXPECT_NEAR(backward_only.eval(float(mu)), hg(mu, -0.5), 1e-5 * hg(mu, -0.5));
    }
}

TEST(PhaseMix, SamplingFollowsTheMixtureAndReportsItsValue) {
    const std::vector<Medium> media = two_media();
    std::vector<Medium::Sampler> samplers;
    for (const Medium& m : media) samplers.emplace_back(m);
    const PhaseMix phase(samplers, Vec3(0.0f));
    const Vec3 dir = glm::normalize(Vec3(0.3f, -1.0f, 0.2f));
    // 40 bins of equal probability under the analytic mixture CDF, found by bisection.
    auto cdf = [](double mu) { return (3.0 * hg_cdf(mu, 0.8) + hg_cdf(mu, -0.5)) / 4.0; };
    constexpr int kBins = 40, kN = 200000;
    std::vector<double> edges{-1.0};
    for (int b = 1; b < kBins; ++b) {
        double lo = -1.0, hi = 1.0;
        for (int i = 0; i < 100; ++i)
            (cdf(0.5 * (lo + hi)) < double(b) / kBins ? lo : hi) = 0.5 * (lo + hi);
        edges.push_back(0.5 * (lo + hi));
    }
    edges.push_back(1.0);
    std::vector<int> count(kBins, 0);
    Rng rng(3, 0);
    for (int i = 0; i < kN; ++i) {
        float pdf;
        const Vec3 d = phase.sample(dir, rng, &pdf);
        const float mu = glm::dot(dir, d);
        ASSERT_NEAR(pdf, phase.eval(mu), 1e-4f * pdf);
        const int b =
            int(std::upper_bound(edges.begin(), edges.end(), double(mu)) - edges.begin()) - 1;
        ++count[std::clamp(b, 0, kBins - 1)];
    }
    // Chi-square with 39 degrees of freedom: the 99.9% quantile is 72.1.
    EXPECT_LT(test::chi_square(count, double(kN) / kBins), 72.1);
}

}  // namespace
}  // namespace fogmap
