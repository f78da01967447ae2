// Planck's law, the CIE fit and the Rec.709 conversion against published values: the
// Stefan–Boltzmann law, the chromaticities of CIE Illuminant A and of D65, and D65's white.

#include "media/blackbody.h"

#include <gtest/gtest.h>

#include <cmath>

namespace fogmap {
namespace {

constexpr double kStefanBoltzmann = 5.670374419e-8;  // W m⁻² K⁻⁴ (CODATA 2018)

DVec3 chromaticity(const DVec3& xyz) { return xyz / (xyz.x + xyz.y + xyz.z); }

/// CIE 1960 (u, v) of xy chromaticity.
glm::dvec2 uv(double x, double y) {
    const double d = -2.0 * x + 12.0 * y + 3.0;
    return {4.0 * x / d, 6.0 * y / d};
}

TEST(Blackbody, TotalRadianceFollowsStefanBoltzmann) {
    for (double t = 1000.0; t <= 10000.0; t += 500.0) {
        const double expected = kStefanBoltzmann * std::pow(t, 4) / kPi;
        EXPECT_NEAR(planck_total(t), expected, 0.01 * expected) << t << " K";
        // fogmap's emission: luminance 1e-6 of it, whatever the colour.
        EXPECT_NEAR(luminance(blackbody_radiance(t)), 1e-6 * expected, 0.01 * 1e-6 * expected)
            << t << " K";
    }
    EXPECT_EQ(planck_total(0.0), 0.0);
    EXPECT_EQ(blackbody_radiance(-5.0), Color(0.0f));
}

TEST(Blackbody, IlluminantAIsAPlanckianRadiatorAt2856K) {
    // CIE Illuminant A: Planck's spectrum at 2856 K with c2 = 1.435e-2 m·K, chromaticity
    // (0.44757, 0.40745) (CIE 15:2004). With today's c2 = 1.438777e-2 the same spectrum is at
    // 2856 × 1.438777 / 1.435 K. The analytic CIE fit departs from the tabulated functions by
    // up to ~0.007 (x̄ at 600 nm: 1.0559 against 1.0622), which moves this chromaticity by
    // 0.0017 in x: the tolerance is the fit's, not the Planck integration's.
    const DVec3 c = chromaticity(blackbody_xyz(2856.0 * 1.438777 / 1.435));
    EXPECT_NEAR(c.x, 0.44757, 0.0025);
    EXPECT_NEAR(c.y, 0.40745, 0.0025);
}

TEST(Blackbody, D65LiesJustOffThePlanckianLocusAt6504K) {
    // D65 is a daylight, not a black body: its correlated colour temperature is 6504 K and it
    // lies 0.0032 above the Planckian locus in CIE 1960 uv (CIE 15:2004, Δuv of D65). So the
    // black body at 6504 K is 0.0032 from D65 in uv, along the locus' normal, not on top of it.
    const DVec3 c = chromaticity(blackbody_xyz(6504.0));
    const glm::dvec2 planck = uv(c.x, c.y), d65 = uv(0.31271, 0.32902);
    EXPECT_NEAR(glm::length(d65 - planck), 0.0032, 0.0006);
    EXPECT_GT(d65.y, planck.y) << "D65 lies above (greener than) the locus";
}

TEST(Blackbody, D65WhiteIsRgbWhite) {
    // Rec.709's white point is D65: XYZ (0.95047, 1, 1.08883) is RGB (1, 1, 1).
    const DVec3 rgb = xyz_to_rec709(DVec3(0.95047, 1.0, 1.08883));
    EXPECT_NEAR(rgb.x, 1.0, 1e-3);
    EXPECT_NEAR(rgb.y, 1.0, 1e-3);
    EXPECT_NEAR(rgb.z, 1.0, 1e-3);
}

TEST(Blackbody, FlamesAreRedAndHotStarsBlue) {
    const Color warm = blackbody_radiance(1500.0), cool = blackbody_radiance(20000.0);
    EXPECT_GT(warm.x, warm.y);
    EXPECT_GT(warm.y, warm.z);
    EXPECT_GT(cool.z, cool.x);
    EXPECT_GE(warm.z, 0.0f) << "out-of-gamut channels are clamped";
}

}  // namespace
}  // namespace fogmap
