// The volume guide (render/volume_guide.h) is a proper one-sample MIS sampler: its mixture pdf
// integrates to 1 over the sphere (Monte Carlo over uniform directions), and directions drawn by
// sample() weighted by phase / pdf average to 1, the phase function's integral — so the guided
// path tracer is unbiased whatever the photons say (here: lobes from photons arriving from a
// few random directions with random powers). The adjoint grid's light to come in a homogeneous
// medium filled with photons of known density is ρ ΔΦ / (4π σ_s) per channel where the photons'
// directions are isotropic, also in cells the medium fills only in part (σ̄_s then counts the
// empty part), and ρ ΔΦ (1 + a₁ b cos θ) / (4π σ_s) for directions ∝ 1 + b cos θ (a field the
// phase's l ≤ 1 series holds exactly).

#include "render/volume_guide.h"

#include "core/rng.h"
#include "core/sampling.h"
#include "media/medium.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

namespace fogmap {
namespace {

PhotonMap cluster(uint64_t seed) {
    Rng rng(seed, 1);
    std::vector<Photon> photons;
    std::vector<Vec3> dirs;
    for (int i = 0; i < 3; ++i)
        dirs.push_back(sample_uniform_sphere(Vec2(rng.uniform(), rng.uniform())));
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

// Photons of power 1 (photon_power 0.001) uniform in the box [−1, 1]² × [−1, 0.125] (the grid's
// cells of 0.25 from the box's corner leave the top layer half in the medium), travelling along
// directions ∝ 1 + b cos θ about +z; L̃ towards +z (a path travelling along −z), averaged over the
// 64 cells of a layer.
TEST(AdjointGrid, IsThePhotonDensityOverFourPiSigmaS) {
    const Box3 box{Vec3(-1.0f), Vec3(1.0f, 1.0f, 0.125f)};
    const Color sigma_s(2.0f, 1.0f, 0.5f);
    const float g = 0.3f;
    const std::vector<Medium> media{Medium::homogeneous({sigma_s, Color(0.1f), g}, box)};
    const PhaseMix phase(g);
    for (const float b : {0.0f, 0.9f}) {
        constexpr int kCount = 400000;
        Rng rng(11, 2);
        std::vector<Photon> photons;
        const Vec3 extent = box.hi - box.lo;
        for (int i = 0; i < kCount; ++i) {
            const Vec3 u(rng.uniform(), rng.uniform(), rng.uniform());
            // cos θ by inverting F(μ) = (μ + 1) / 2 + b (μ² − 1) / 4.
            const float v = rng.uniform();
            const float mu = b > 0.0f
                                 ? (-1.0f + std::sqrt(1.0f - 2.0f * b + b * b + 4.0f * b * v)) / b
                                 : 2.0f * v - 1.0f;
            const float phi = 2.0f * kPi * rng.uniform(),
                        s = std::sqrt(std::max(0.0f, 1 - mu * mu));
            photons.emplace_back(box.lo + u * extent,
                                 Vec3(s * std::cos(phi), s * std::sin(phi), mu), Color(1.0f));
        }
        PhotonMap map;
        map.tree = KdTree<Photon>(std::move(photons));
        map.photon_power = 0.001f;
        const AdjointGrid grid(map, media, 0.25f);
        const double rho = kCount / double(extent.x * extent.y * extent.z);
        const Vec3 dir(0.0f, 0.0f, -1.0f);
        for (const float z : {-0.6f, 0.06f, 0.12f}) {  // a full cell, the half-filled layer twice
            double sum[3] = {0.0, 0.0, 0.0};
            constexpr int kCells = 64;
            for (int i = 0; i < kCells; ++i) {
                const Vec3 x(-0.875f + 0.25f * (i % 8), -0.875f + 0.25f * (i / 8), z);
                const Color got = grid.at(x, dir, phase);
                for (int c = 0; c < 3; ++c) sum[c] += got[c];
            }
            for (int c = 0; c < 3; ++c) {
                const double expected =
                    rho * map.photon_power * kInvFourPi * (1.0 + g * b) / sigma_s[c];
                // 1389 photons a full cell: 2.7% each, 0.34% over a layer (half-filled: 0.5%).
                EXPECT_NEAR(sum[c] / kCells, expected, 0.02 * expected)
                    << "b " << b << " z " << z << " channel " << c;
            }
        }
        EXPECT_EQ(grid.at(Vec3(0.0f, 0.0f, 0.3f), dir, phase), Color(0.0f));  // beyond the grid
    }
}

}  // namespace
}  // namespace fogmap
