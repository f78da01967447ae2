// The end of a camera path in the volume map (render/volume_map_end.h) against analytic values:
// the kernel-averaged σ_s of a linear density ramp is the ramp itself (a box average of a linear
// function is its centre value, and trilinear interpolation keeps it), and the estimate in a
// homogeneous medium filled with photons of known density, power and direction is
// ρ ΔΦ f(θ) / σ_s per channel — with the phase function's argument the right way round.

#include "render/volume_map_end.h"

#include "core/rng.h"
#include "media/volume_gen.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <memory>
#include <vector>

namespace fogmap {
namespace {

float ramp(float x, float y, float z) { return 0.1f + 0.2f * x + 0.1f * y + 0.05f * z; }

TEST(KernelDensity, AveragesALinearRampToItsValue) {
    const int n = 40;
    const float voxel = 0.1f;
    const auto path = std::filesystem::temp_directory_path() / "fogmap_kernel_density_ramp.vdb";
    write_float_grid(
        path.string(), "density", n, n, n,
        [&](int i, int j, int k) { return ramp(i * voxel, j * voxel, k * voxel); }, Vec3(voxel));
    const std::shared_ptr<const DensityGrid> grid =
        DensityGrid::load(path.string(), "density", "");
    std::filesystem::remove(path);
    const Color sigma_s(2.0f, 1.0f, 0.5f);
    const std::vector<Medium> media{
        Medium::heterogeneous({sigma_s, Color(0.0f), 0.0f}, grid, Mat4(1.0f))};
    const float radius = 0.2f;
    const KernelDensity density(media, radius);
    Rng rng(7, 1);
    for (int i = 0; i < 50; ++i) {
        // At least a cube's half edge (0.16) inside the outermost voxel centres.
        const Vec3 x = Vec3(0.8f) + 2.2f * Vec3(rng.uniform(), rng.uniform(), rng.uniform());
        const Color expected = sigma_s * ramp(x.x, x.y, x.z);
        const Color got = density.at(x);
        for (int c = 0; c < 3; ++c) EXPECT_NEAR(got[c], expected[c], 1e-4f * expected[c]) << i;
    }
    EXPECT_EQ(density.at(Vec3(-5.0f)), Color(0.0f));  // beyond the grid: no medium
}

TEST(KernelDensity, HomogeneousMediumIsItsSigmaSInsideAndZeroFarOutside) {
    const Color sigma_s(3.0f, 1.5f, 0.25f);
    const std::vector<Medium> media{
        Medium::homogeneous({sigma_s, Color(1.0f), 0.0f}, Box3{Vec3(-1.0f), Vec3(1.0f)})};
    const KernelDensity density(media, 0.1f);
    for (const Vec3& x : {Vec3(0.0f), Vec3(0.7f, -0.6f, 0.2f)}) {
        const Color got = density.at(x);
        for (int c = 0; c < 3; ++c) EXPECT_NEAR(got[c], sigma_s[c], 1e-5f * sigma_s[c]);
    }
    EXPECT_EQ(density.at(Vec3(1.6f, 0.0f, 0.0f)), Color(0.0f));
}

TEST(VolumeMapEnd, HomogeneousPhotonCloudGivesDensityTimesPowerTimesPhaseOverSigmaS) {
    const int count = 200000;
    Rng rng(11, 2);
    std::vector<Photon> photons;
    const Vec3 travel(1.0f, 0.0f, 0.0f);
    for (int i = 0; i < count; ++i) {
        const Vec3 p = 2.0f * Vec3(rng.uniform(), rng.uniform(), rng.uniform()) - Vec3(1.0f);
        photons.emplace_back(p, travel, Color(1.0f));
    }
    PhotonMap map;
    map.tree = KdTree<Photon>(std::move(photons));
    map.photon_power = 0.003f;
    const float g = 0.5f;
    const Color sigma_s(2.0f, 1.0f, 0.5f);
    const std::vector<Medium> media{
        Medium::homogeneous({sigma_s, Color(0.1f), g}, Box3{Vec3(-2.0f), Vec3(2.0f)})};
    const float radius = 0.3f;
    const VolumeMapEnd end(map, media, radius, 2);
    const PhaseMix phase(g);
    NeighborList scratch;
    const double rho = count / 8.0;  // photons per unit volume
    // Expected photons in the ball: 2827; Poisson: 1.9% standard deviation, 4 of them allowed.
    const double tolerance = 4.0 / std::sqrt(rho * 4.0 / 3.0 * kPi * std::pow(radius, 3.0));
    // A path travelling along −x leaves towards +x, the photons' own direction: forward
    // scattering, f(1); along +x it leaves against them, f(−1) (27 times smaller at g 0.5).
    for (const float along : {-1.0f, 1.0f}) {
        const Color got =
            end.inscattered(Vec3(0.1f, -0.2f, 0.05f), Vec3(along, 0.0f, 0.0f), phase, scratch);
        const double f = phase.eval(-along);
        for (int c = 0; c < 3; ++c) {
            const double expected = rho * map.photon_power * f / sigma_s[c];
            EXPECT_NEAR(got[c] / expected, 1.0, tolerance) << "along " << along << ", channel " << c;
        }
    }
}

}  // namespace
}  // namespace fogmap
