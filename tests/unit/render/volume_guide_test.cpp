// The volume guide (render/volume_guide.h) is a proper one-sample MIS sampler: its mixture pdf
// integrates to 1 over the sphere (Monte Carlo over uniform directions), and directions drawn by
// sample() weighted by phase / pdf average to 1, the phase function's integral — so the guided
// path tracer is unbiased whatever the photons say (here: lobes from photons arriving from a
// few random directions with random powers).

#include "render/volume_guide.h"

#include "core/rng.h"
#include "core/sampling.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

namespace fogmap {
namespace {

PhotonMap cluster(uint64_t seed) {
    Rng rng(seed, 1);
    std::vector<Photon> photons;
    std::vector<Vec3> dirs;
    for (int i = 0; i < 3; ++i) dirs.push_back(sample_uniform_sphere(Vec2(rng.uniform(), rng.uniform())));
    for (int i = 0; i < 200; ++i) {
        const Vec3 p(rng.uniform() - 0.5f, rng.uniform() - 0.5f, rng.uniform() - 0.5f);
        photons.emplace_back(0.2f * p, dirs[i % 3], Color(0.1f + rng.uniform()));
    }
    PhotonMap map;
    map.tree = KdTree<Photon>(std::move(photons));
    map.photon_power = 1.0f;
    return map;
}

TEST(VolumeGuide, MixturePdfIntegratesToOneAndSamplesAreUnbiased) {
    for (float g : {0.0f, 0.85f, -0.5f}) {
        const PhotonMap map = cluster(3);
        GuideSettings settings;
        settings.radius = 1.0f;
        settings.phase_fraction = 0.3f;
        const VolumeGuide guide(map, settings);
        const PhaseMix phase(g);
        const Vec3 dir = glm::normalize(Vec3(0.2f, -1.0f, 0.4f));
        NeighborList scratch;
        GuideLobes lobes;
        guide.prepare(Vec3(0.0f), dir, phase, scratch, &lobes);
        ASSERT_FALSE(lobes.empty());
        constexpr int kN = 400000;
        double integral = 0.0, integral2 = 0.0, weight = 0.0, weight2 = 0.0;
        for (int i = 0; i < kN; ++i) {
            Rng rng(7, i);
            const Vec3 w = sample_uniform_sphere(Vec2(rng.uniform(), rng.uniform()));
            const double v = 4.0 * kPi * guide.pdf(lobes, phase, dir, w);
            integral += v;
            integral2 += v * v;
            float pdf;
            const Vec3 s = guide.sample(lobes, phase, dir, rng, &pdf);
            const double f = phase.eval(glm::dot(dir, s)) / pdf;
            weight += f;
            weight2 += f * f;
        }
        const double m1 = integral / kN, m2 = weight / kN;
        const double se1 = std::sqrt((integral2 / kN - m1 * m1) / kN);
        const double se2 = std::sqrt((weight2 / kN - m2 * m2) / kN);
        EXPECT_NEAR(m1, 1.0, 4.0 * se1) << "g " << g;
        EXPECT_NEAR(m2, 1.0, 4.0 * se2) << "g " << g;
    }
}

}  // namespace
}  // namespace fogmap
