// RadiusBias for the photon gather's lookups (photon/estimators.h, BatchSums::bias): photons whose
// density grows as 1 + 4 x² across the plane x = 0 make an estimate at a point of that plane
// high by 4 times the kernel's average of x², which Richardson's 2 (E(ρ) − E(ρ/√2)) gets exactly
// for a quadratic: ρ²/5 for a ball and for the beam's kernel (a ball's line integral), ρ²/4 for a
// disc and, with Jensen's cone filter of constant k, ∫ x² w / ∫ w over the disc. Each photon
// half's estimate, averaged over lookups, must give bias / estimate within 0.015 (the noise of
// the few thousand photons between the two radii, about 0.5% a lookup).

#include "core/rng.h"
#include "core/sampling.h"
#include "media/phase.h"
#include "photon/beam_tree.h"
#include "photon/estimators.h"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <vector>

namespace fogmap {
namespace {

/// n photons in [-1, 1]³ (z = 0 when `flat`) of density ∝ 1 + 4 x², each in a random batch.
PhotonMap quadratic_map(size_t n, bool flat, Rng& rng) {
    std::vector<Photon> photons;
    while (photons.size() < n) {
        Vec3 p = 2.0f * Vec3(rng.uniform(), rng.uniform(), rng.uniform()) - Vec3(1.0f);
        if (flat) p.z = 0.0f;
        if (5.0f * rng.uniform() > 1.0f + 4.0f * p.x * p.x) continue;
        const Vec3 dir = flat ? Vec3(0.0f, 0.0f, 1.0f)
                              : sample_uniform_sphere(Vec2(rng.uniform(), rng.uniform()));
        Photon photon(p, dir, Color(1.0f));
        photon.set_batch(int(rng.uniform() * Photon::kBatches));
        photons.push_back(photon);
    }
    PhotonMap map;
    map.tree = KdTree<Photon>(std::move(photons));
    map.photon_power = 1e-6f;
    return map;
}

/// The bias / estimate each photon half gives, averaged over `lookups` calls of lookup(i, sums).
template <class Lookup>
std::array<double, 2> mean_bias(int lookups, float kappa, Lookup&& lookup) {
    std::array<double, 2> mean{};
    for (int i = 0; i < lookups; ++i) {
        BatchSums sums;
        lookup(i, &sums);
        const std::array<float, 2> bias = sums.bias(kappa);
        for (int h = 0; h < 2; ++h) mean[h] += bias[h] / lookups;
    }
    return mean;
}

constexpr float kRadius = 0.3f;
constexpr int kLookups = 40;

TEST(RadiusBias, EachPhotonHalfEstimatesTheBiasOfTheBallEstimate) {
    Rng rng(41, 2);
    const PhotonMap map = quadratic_map(3000000, false, rng);
    const PhaseMix phase(0.5f);
    NeighborList scratch;
    const std::array<double, 2> mean = mean_bias(kLookups, kBallKappa, [&](int, BatchSums* sums) {
        const Vec3 x(0.0f, 0.8f * rng.uniform() - 0.4f, 0.8f * rng.uniform() - 0.4f);
        const Vec3 wo = sample_uniform_sphere(Vec2(rng.uniform(), rng.uniform()));
        volume_inscattered(map, x, wo, phase, 0, kRadius, scratch, sums);
    });
    const double blur = 4.0 * kRadius * kRadius / 5.0, expected = blur / (1.0 + blur);
    for (int h = 0; h < 2; ++h) EXPECT_NEAR(mean[h], expected, 0.015) << "half " << h;
}

TEST(RadiusBias, EachPhotonHalfEstimatesTheBiasOfTheDiscEstimateBoxedOrConed) {
    Rng rng(43, 2);
    const PhotonMap map = quadratic_map(400000, true, rng);
    NeighborList scratch;
    for (const double cone : {0.0, 1.1}) {
        const std::array<double, 2> mean =
            mean_bias(kLookups, kDiscKappa, [&](int, BatchSums* sums) {
                const Vec3 x(0.0f, 0.8f * rng.uniform() - 0.4f, 0.0f);
                surface_irradiance(map, x, Vec3(0.0f, 0.0f, 1.0f), 0, kRadius, float(cone), 0,
                                   scratch, sums);
            });
        // E[x²] = E[d²] / 2 over the disc, each distance d weighed by w(d) d (1 − d / (k r) for the
        // cone): r² (1/4 − 1/(5k)) / (1/2 − 1/(3k)) / 2, r² / 4 for the box.
        const double r2 = double(kRadius) * kRadius;
        const double x2 =
            cone > 0.0 ? r2 * (0.25 - 0.2 / cone) / (0.5 - 1.0 / (3.0 * cone)) / 2.0 : r2 / 4.0;
        const double expected = 4.0 * x2 / (1.0 + 4.0 * x2);
        for (int h = 0; h < 2; ++h)
            EXPECT_NEAR(mean[h], expected, 0.015) << "cone " << cone << ", half " << h;
    }
}

// The beam estimate (VolumeGather::beam_estimate): each photon's kernel along a segment through
// the cube, and its kernel over r/√2 (BeamTree::for_each_hit's inner), added as the beam estimate
// does.
TEST(RadiusBias, EachPhotonHalfEstimatesTheBiasOfTheBeamEstimate) {
    Rng rng(47, 2);
    const PhotonMap map = quadratic_map(1000000, false, rng);
    const BeamTree tree(map, 0, kRadius);
    const std::array<double, 2> mean = mean_bias(kLookups, 1.0f, [&](int, BatchSums* sums) {
        const Ray ray{Vec3(0.0f, 0.8f * rng.uniform() - 0.4f, -2.0f), Vec3(0.0f, 0.0f, 1.0f)};
        tree.for_each_hit<true>(
            ray, 0.0f, 4.0f, [&](const BeamTree::Record& p, float, float kernel, float inner) {
                sums->add(p.batch, average(p.power) * kernel, average(p.power) * inner);
            });
    });
    const double blur = 4.0 * kRadius * kRadius / 5.0, expected = blur / (1.0 + blur);
    for (int h = 0; h < 2; ++h) EXPECT_NEAR(mean[h], expected, 0.015) << "half " << h;
}

}  // namespace
}  // namespace fogmap
