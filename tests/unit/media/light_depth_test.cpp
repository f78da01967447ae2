// The optical depth towards a distant light, tabulated along it (media/light_depth.h), against a
// brute-force integral of the same trilinear density (10 000 midpoint steps along the ray), at
// random points in, beside and below the medium, at two spacings; and the sun's transmittance built
// from it (render/sun_shadows.h) against the mean of ratio-tracking walks towards the sun.

#include "media/light_depth.h"

#include "render/sun_shadows.h"
#include "scene_builders.h"
#include "test_support.h"

#include <gtest/gtest.h>
#include <glm/gtc/matrix_transform.hpp>

#include <cmath>
#include <functional>
#include <memory>

namespace fogmap {
namespace {

// An n³ grid of voxel `voxel` from (−3, 1, 2).
std::shared_ptr<const DensityGrid> grid_of(int n, float voxel,
                                           const std::function<float(int, int, int)>& value) {
    return test::density_grid(n, n, n, value, Vec3(voxel), Vec3(-3.0f, 1.0f, 2.0f));
}

// ∫ density from x along `dir` over `length`, 10 000 midpoint steps.
double brute_force_depth(Medium::Sampler& sampler, const Vec3& x, const Vec3& dir, float length) {
    const int steps = 10000;
    const double h = double(length) / steps;
    double sum = 0.0;
    for (int s = 0; s < steps; ++s) sum += sampler.density(x + float((s + 0.5) * h) * dir);
    return sum * h;
}

struct DepthError {
    double worst = 0.0;    ///< largest |grid − brute force| over the points
    double largest = 0.0;  ///< largest brute-force depth met
    int inside = 0, beside = 0, below = 0;
};

// Random points in the medium's box grown by half its size on every side; nodes `spacing` apart.
DepthError compare(const Medium& medium, const Vec3& to_light, float spacing) {
    const LightDepth grid(medium, to_light, spacing, size_t(1) << 25);
    Medium::Sampler sampler(medium);
    const Box3& box = medium.world_bounds();
    const Vec3 extent = box.extent(), lo = box.lo - 0.5f * extent;
    const float length = 4.0f * glm::length(extent);
    DepthError e;
    Rng rng(11, 0);
    for (int i = 0; i < 400; ++i) {
        const Vec3 x = lo + 2.0f * extent * Vec3(rng.uniform(), rng.uniform(), rng.uniform());
        const double expected = brute_force_depth(sampler, x, to_light, length);
        e.worst = std::max(e.worst, std::abs(double(grid.depth(x)) - expected));
        e.largest = std::max(e.largest, expected);
        if (box.contains(x))
            ++e.inside;
        else if (expected > 0.0)
            ++e.below;
        else
            ++e.beside;
    }
    return e;
}

// A Gaussian puff (40^3 voxels of 0.5, σ 7 voxels): the depth is exact along each column up to
// the quadrature, and trilinear between columns, so its error is second order in the spacing:
// h² τ''/8, 0.3% of the largest depth at one voxel (the bias render/sun_shadows.h accepts), and
// a quarter of that at half a voxel.
TEST(LightDepth, SmoothDensityMatchesABruteForceIntegralToSecondOrder) {
    const auto grid = grid_of(40, 0.5f, [](int i, int j, int k) {
        const float r2 = float((i - 20) * (i - 20) + (j - 18) * (j - 18) + (k - 22) * (k - 22));
        return 2.0f * std::exp(-r2 / (2.0f * 7.0f * 7.0f));
    });
    const Medium m = Medium::heterogeneous({Color(1.0f), Color(0.0f), 0.0f}, grid, Mat4(1.0f));
    const Vec3 to_light = glm::normalize(Vec3(0.5f, 0.7f, 0.5f));
    const DepthError voxel = compare(m, to_light, 0.5f), half = compare(m, to_light, 0.25f);
    std::printf(
        "puff: worst error %.5f (one voxel), %.5f (half) of depths up to %.3f (%d inside, "
        "%d below, %d beside)\n",
        voxel.worst, half.worst, voxel.largest, voxel.inside, voxel.below, voxel.beside);
    EXPECT_GT(voxel.inside, 20);
    EXPECT_GT(voxel.below, 20);   // the whole chord, from below the box
    EXPECT_GT(voxel.beside, 20);  // 0: the ray misses the box
    EXPECT_LT(voxel.worst, 0.005 * voxel.largest);
    EXPECT_LT(half.worst, voxel.worst / 3.0);
}

TEST(SunShadows, TransmittanceMatchesRatioTrackingTowardsTheSun) {
    // Two overlapping chromatic media; the sun travels along −to_light.
    const auto a = grid_of(24, 0.5f, [](int i, int, int k) { return 0.05f * float(i + k); });
    const auto b = grid_of(24, 0.4f, [](int, int j, int) { return 0.08f * float(j % 7); });
    std::vector<Medium> media;
    media.push_back(
        Medium::heterogeneous({Color(0.3f, 0.4f, 0.5f), Color(0.1f), 0.0f}, a, Mat4(1.0f)));
    media.push_back(Medium::heterogeneous({Color(0.6f), Color(0.0f, 0.1f, 0.2f), 0.0f}, b,
                                          glm::translate(Mat4(1.0f), Vec3(2.0f, 1.0f, 0.0f))));
    const Vec3 to_light = glm::normalize(Vec3(0.2f, 0.9f, -0.4f));
    std::vector<Light> lights{make_light(test::environment(1.0f)),
                              make_light(test::sun(-to_light, 1.0f))};
    const SunShadows sun(lights, media, 1.0f);
    EXPECT_FALSE(sun.covers(0));
    ASSERT_TRUE(sun.covers(1));
    EXPECT_EQ(sun.grids(), 2u);
    std::vector<Medium::Sampler> samplers;
    for (const Medium& m : media) samplers.emplace_back(m);
    Rng rng(3, 0);
    for (const Vec3 x : {Vec3(3.0f, 4.0f, 8.0f), Vec3(5.0f, 6.0f, 5.0f), Vec3(1.0f, -6.0f, 9.0f)}) {
        const int n = 4000;
        test::SampleStats<DVec3> walks;
        for (int i = 0; i < n; ++i)
            walks.add(DVec3(ratio_track(samplers, Ray{x, to_light}, kInfinity, rng)));
        const DVec3 mean = walks.mean(), se = walks.standard_error();
        const Color expected = sun.transmittance(1, x);
        for (int c = 0; c < 3; ++c)
            EXPECT_NEAR(expected[c], mean[c], 4.0 * se[c] + 0.005) << "channel " << c;
        EXPECT_LT(max_component(expected), 0.95f);  // the points are shadowed
    }
    // A sun wider than 1° keeps its walks (its penumbra is not a voxel's blur).
    LightDesc wide = test::sun(-to_light, 1.0f);
    wide.angular_radius_deg = 2.0f;
    lights.push_back(make_light(wide));
    const SunShadows two(lights, media, 1.0f);
    EXPECT_TRUE(two.covers(1));
    EXPECT_FALSE(two.covers(2));
    lights.pop_back();
    // A homogeneous medium keeps its exact walks: no grids at all.
    media.push_back(
        Medium::homogeneous({Color(1.0f), Color(0.0f), 0.0f}, Box3{Vec3(0.0f), Vec3(1.0f)}));
    EXPECT_FALSE(SunShadows(lights, media, 1.0f).covers(1));
    EXPECT_FALSE(
        SunShadows(lights, std::vector<Medium>(media.begin(), media.begin() + 2), 0.0f).covers(1));
}

}  // namespace
}  // namespace fogmap
