// Slab validation with 1e6 photons (label heavy): the comparisons of slab_test.cpp with standard
// errors ~3x smaller, so biases of ~1e-3 (ray marching's, the bounce cap's) would show; plus the
// march at half and twice the default step. References and tolerances as in slab_checks.h.

#include "slab_checks.h"

#include <gtest/gtest.h>

namespace fogmap {
namespace {

using namespace slab_checks;

constexpr uint64_t kPhotons = 1000000;
constexpr uint64_t kReferencePhotons = 4000000;

TEST(SlabValidationHeavy, McmlSlabMatchesVanDeHulst) {
    for (FreePathMethod method : kMethods) check_mcml(method, kPhotons);
}

TEST(SlabValidationHeavy, McmlSlabMatchesAtHalfAndTwiceTheMarchStep) {
    for (float step : {0.5f, 2.0f}) {
        SlabSettings s = settings(2.0, 0.9, 0.75, FreePathMethod::March, kPhotons);
        s.step_voxels = step;
        const SlabResult r = run_slab(s);
        expect_match(r.rd, {0.09739, 0.0}, label(s, "Rd") + ", step " + std::to_string(step));
        expect_match(r.tt, {0.66096, 0.0}, label(s, "Tt") + ", step " + std::to_string(step));
    }
}

TEST(SlabValidationHeavy, ConservativeSlabLosesNothing) {
    check_conservative(1.0, 0.5, kPhotons, kReferencePhotons);
    check_conservative(4.0, -0.5, kPhotons, kReferencePhotons);
}

TEST(SlabValidationHeavy, BlackSlabTransmitsExpMinusTau) {
    for (FreePathMethod method : kMethods) check_black(1.0, method, kPhotons);
}

TEST(SlabValidationHeavy, IsotropicThinSlabMatchesAnalogMonteCarlo) {
    check_against_analog(1.0, 0.99, 0.0, kPhotons, kReferencePhotons);
}

TEST(SlabValidationHeavy, ForwardScatteringSlabMatchesAnalogMonteCarlo) {
    check_against_analog(2.0, 0.95, 0.9, kPhotons, kReferencePhotons);
}

TEST(SlabValidationHeavy, SemiInfiniteMatchesChandrasekharH) {
    for (FreePathMethod method : kMethods) check_semi_infinite(kInf, 0.9, method, kPhotons);
}

TEST(SlabValidationHeavy, StiffSlabMatchesSemiInfiniteAtDefaultMarchStep) {
    for (double tau : {100.0, 1000.0})
        check_semi_infinite(tau, 0.9, FreePathMethod::March, kPhotons);
}

TEST(SlabValidationHeavy, HighAlbedoSlabsMatchAddingDoublingWithDefaultFlags) {
    check_adding_doubling(10.0, 0.99, 0.75, kPhotons);
    check_adding_doubling(100.0, 0.999, 0.99, kPhotons / 4);
    check_adding_doubling(10.0, 0.999, -0.5, kPhotons);
    check_adding_doubling(kInf, 0.99, -0.9, kPhotons / 4);
    check_adding_doubling(kInf, 0.999, 0.875, kPhotons / 20);
    check_adding_doubling(1e12, 0.9, 0.75, kPhotons / 4);
}

}  // namespace
}  // namespace fogmap
