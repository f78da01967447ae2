// The end of a camera path in the volume map (render/volume_map_end.h) against analytic values:
// the kernel-averaged σ_s of a linear density ramp is the ramp itself (a box average of a linear
// function is its centre value, and trilinear interpolation keeps it), and the estimate in a
// homogeneous medium filled with photons of known density, power and direction is
// ρ ΔΦ f(θ) / σ_s per channel — with the phase function's argument the right way round.

#include "render/volume_map_end.h"

#include "core/rng.h"
#include "core/sampling.h"
#include "media/henyey_greenstein.h"
#include "test_support.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

namespace fogmap {
namespace {

float ramp(float x, float y, float z) { return 0.1f + 0.2f * x + 0.1f * y + 0.05f * z; }

// The ramp on 40³ voxels of 0.1.
std::shared_ptr<const DensityGrid> load_ramp() {
    const int n = 40;
    const float voxel = 0.1f;
    return test::density_grid(
        n, n, n, [&](int i, int j, int k) { return ramp(i * voxel, j * voxel, k * voxel); },
        Vec3(voxel));
}

TEST(KernelDensity, AveragesALinearRampToItsValue) {
    const std::shared_ptr<const DensityGrid> grid = load_ramp();
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

// The summed-volume table integrates σ_s exactly over cubes: a linear ramp's average over a cube is
// its value at the centre (cells sample it at their centres, and partial cells at the cube's faces
// cost at most 0.002 here; the table one cell off would be 0.02 off), and a cube astride a
// homogeneous medium's face holds σ_s over the part inside.
TEST(SigmaTable, CubeAveragesMatchALinearRampAndAHalfFilledCube) {
    const std::shared_ptr<const DensityGrid> grid = load_ramp();
    const Color sigma_s(2.0f, 1.0f, 0.5f);
    const SigmaTable ramp_table(
        {Medium::heterogeneous({sigma_s, Color(0.0f), 0.0f}, grid, Mat4(1.0f))}, 0.5f);
    Rng rng(7, 2);
    for (int i = 0; i < 50; ++i) {
        const float edge = 0.2f + 0.6f * rng.uniform();
        const Vec3 x = Vec3(0.5f) + 2.8f * Vec3(rng.uniform(), rng.uniform(), rng.uniform());
        const Color got = ramp_table.cube_average(x, edge);
        for (int c = 0; c < 3; ++c)
            EXPECT_NEAR(got[c], sigma_s[c] * ramp(x.x, x.y, x.z), 0.005f * sigma_s[c]) << i;
    }
    const SigmaTable box_table(
        {Medium::homogeneous({sigma_s, Color(0.0f), 0.0f}, Box3{Vec3(-1.0f), Vec3(1.0f)})}, 0.5f);
    const float edge = 0.5f, cell = 3.0f / 128.0f;  // the box's cells: its extent / 128
    for (const Vec3& x : {Vec3(0.2f, -0.3f, 0.1f), Vec3(1.0f, 0.0f, 0.2f), Vec3(1.0f, -1.0f, 0.0f),
                          Vec3(1.6f, 0.0f, 0.0f)}) {
        float inside = 1.0f;  // the share of the cube inside the box
        for (int a = 0; a < 3; ++a)
            inside *= std::clamp(
                (std::min(x[a] + 0.5f * edge, 1.0f) - std::max(x[a] - 0.5f * edge, -1.0f)) / edge,
                0.0f, 1.0f);
        const Color got = box_table.cube_average(x, edge);
        for (int c = 0; c < 3; ++c)
            EXPECT_NEAR(got[c], sigma_s[c] * inside, 2.0f * sigma_s[c] * cell / edge) << x.x;
    }
}

// cube_average against a brute-force average over exactly the cube its contract names (edge
// `edge` about x) of a field that is not linear, so that a cube of the wrong size gives another
// value: density 0.2, and 1.0 in the octant of voxels i, j, k >= 20 (voxels of 0.1, centres at
// index × 0.1), which the grid's trilinear interpolation makes 0.2 + 0.8 r(x) r(y) r(z), r
// ramping from 0 at 1.9 to 1 at 2.0. The cubes (random centres and edges) keep their faces out of
// [1.8, 2.1] and inside [0.5, 3.4]: there σ_s is constant over the table's partial cells (edge
// 0.1, the voxel), and over whole cells its cell-centre values integrate r exactly (r is a step
// blurred by a box one cell wide; the product over axes stays exact), so the table's average is
// exact up to float rounding (below 1e-4 σ_s). The reference: the midpoint rule on n³ points of
// the cube, of σ_s as the medium samples it. In 1-D its error is at most h² / (8 w) per kink of r
// (h = edge / n, two kinks of slope change 1/w, w = 0.1), so the average's error is at most
// 0.8 σ_s × 3 × 2 h² / (8 w edge) = 0.6 σ_s edge / (w n²): 1e-3 σ_s at edge 1.4 and n = 96.
// A cube of twice or half the edge moves the averages by 0.01-0.1 σ_s here (e.g. at x = 2.0³,
// edge 0.6: 0.359 against 0.327 at edge 1.2 and 0.437 at 0.3), ten times the tolerance or more.
TEST(SigmaTable, TheEqualVolumeCubeHoldsTheBallsVolume) {
    // The smaller ball's σ_s is averaged over this cube: its volume must be the ball's, 4/3 π r³.
    for (float r : {1e-3f, 0.25f, 1.0f, 37.0f}) {
        const double edge = equal_volume_edge(r), ball = 4.0 / 3.0 * 3.14159265358979 * r * r * r;
        EXPECT_NEAR(edge * edge * edge / ball, 1.0, 1e-6) << r;
    }
}

TEST(SigmaTable, CubeAverageMatchesABruteForceAverageOverTheCubeOfItsEdge) {
    const int voxels = 40, n = 96;
    const float voxel = 0.1f, low = 0.2f, high = 1.0f;
    const std::shared_ptr<const DensityGrid> grid = test::density_grid(
        voxels, voxels, voxels,
        [&](int i, int j, int k) { return i >= 20 && j >= 20 && k >= 20 ? high : low; },
        Vec3(voxel));
    const Color sigma_s(2.0f, 1.0f, 0.5f);
    const std::vector<Medium> media{
        Medium::heterogeneous({sigma_s, Color(0.0f), 0.0f}, grid, Mat4(1.0f))};
    const SigmaTable table(media, 0.5f);
    std::vector<Medium::Sampler> samplers;
    for (const Medium& m : media) samplers.emplace_back(m);
    const auto face_ok = [](float f) { return f >= 0.5f && f <= 3.4f && (f < 1.8f || f > 2.1f); };
    Rng rng(7, 3);
    int cubes = 0, straddling = 0;
    while (cubes < 12) {
        const float edge = 0.3f + 1.1f * rng.uniform();
        const Vec3 x = Vec3(1.2f) + 1.6f * Vec3(rng.uniform(), rng.uniform(), rng.uniform());
        bool ok = true;
        for (int a = 0; a < 3; ++a)
            ok = ok && face_ok(x[a] - 0.5f * edge) && face_ok(x[a] + 0.5f * edge);
        if (!ok) continue;
        ++cubes;
        DVec3 sum(0.0);
        const float h = edge / float(n);
        for (int k = 0; k < n; ++k)
            for (int j = 0; j < n; ++j)
                for (int i = 0; i < n; ++i) {
                    const Vec3 p =
                        x - Vec3(0.5f * edge) + h * (Vec3(float(i), float(j), float(k)) + 0.5f);
                    sum += DVec3(sigma_s_at(samplers, p));
                }
        const DVec3 expected = sum / (double(n) * n * n);
        const Color got = table.cube_average(x, edge);
        bool mixed = false;  // the cube holds both densities
        for (int c = 0; c < 3; ++c) {
            const double tol =
                sigma_s[c] * ((high - low) * 3.0 * 2.0 * h * h / (8.0 * voxel * edge) + 1e-4);
            EXPECT_NEAR(got[c], expected[c], tol)
                << "x " << x.x << " " << x.y << " " << x.z << " edge " << edge << " channel " << c;
            mixed = mixed || (expected[c] > sigma_s[c] * (low + 0.01f) &&
                              expected[c] < sigma_s[c] * (high - 0.01f));
        }
        straddling += mixed;
    }
    EXPECT_GE(straddling, 6);  // most cubes see the step, so their size matters
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
            EXPECT_NEAR(got[c] / expected, 1.0, tolerance)
                << "along " << along << ", channel " << c;
        }
    }
}

// Photons whose travel directions follow an HG(g_p) lobe about an oblique axis (as once-scattered
// sunlight's do, with g_p = g) seen through the HG(g) phase: the estimate is
// ρ ΔΦ f(ω_o · axis; g g_p) / σ_s, since two HG lobes compose to the HG of the product of their g
// (Legendre coefficients multiply). At g = kMomentGridMaxG the lookup interpolates the photons'
// moments and cuts the series after l = 2, which misses Σ_{l≥3} (2l+1) (g g_p)^l P_l(cos θ) / 4π —
// allowed on top of 4 Poisson deviations. Without the l = 2 term the estimate is 10% low
// forwards, 20% backwards; with l = 1's sign flipped the two swap (2.6 times apart).
TEST(VolumeMapEnd, InterpolatedMomentsMatchTheComposedPhaseFunction) {
    const int count = 1000000;
    const float g = kMomentGridMaxG, g_p = g, g_composed = g * g_p;
    Rng rng(13, 4);
    std::vector<Photon> photons;
    const Vec3 axis = glm::normalize(Vec3(0.6f, 0.7f, -0.6f));  // every moment's component in use
    for (int i = 0; i < count; ++i) {
        const Vec3 p = 2.0f * Vec3(rng.uniform(), rng.uniform(), rng.uniform()) - Vec3(1.0f);
        float pdf;
        const Vec3 travel = hg_sample(axis, g_p, Vec2(rng.uniform(), rng.uniform()), &pdf);
        photons.emplace_back(p, travel, Color(1.0f));
    }
    PhotonMap map;
    map.tree = KdTree<Photon>(std::move(photons));
    map.photon_power = 0.002f;
    const Color sigma_s(2.0f, 1.0f, 0.5f);
    const std::vector<Medium> media{
        Medium::homogeneous({sigma_s, Color(0.1f), g}, Box3{Vec3(-2.0f), Vec3(2.0f)})};
    const float radius = 0.5f;  // 65 000 photons in the ball: 0.4% Poisson deviation
    const VolumeMapEnd end(map, media, radius, 3);
    ASSERT_TRUE(end.interpolates());
    const PhaseMix phase(g);
    NeighborList scratch;
    const double rho = count / 8.0;
    const double poisson = 4.0 / std::sqrt(rho * 4.0 / 3.0 * kPi * std::pow(radius, 3.0));
    // The series' tail beyond l = 2 at cos θ: Σ_{l≥3} (2l+1) (g g_p)^l P_l(cos θ) / 4π.
    const auto missed = [&](double cos) {
        double p_prev = 1.0, p = cos, sum = 0.0;  // P_0, P_1; Bonnet's recursion
        for (int l = 1; l < 60; ++l) {
            const double next = ((2 * l + 1) * cos * p - l * p_prev) / (l + 1);
            p_prev = p;
            p = next;  // P_{l+1}
            if (l + 1 >= 3) sum += (2 * l + 3) * std::pow(g_composed, l + 1) * p / (4.0 * kPi);
        }
        return std::abs(sum);
    };
    // The light leaves along ω_o: along the photons (cos 1), across (0) and against them (−1).
    const Vec3 across = glm::normalize(glm::cross(axis, Vec3(0.0f, 0.0f, 1.0f)));
    for (const Vec3& out : {axis, across, glm::cross(axis, across), -axis}) {
        const Vec3 x(0.13f, -0.21f, 0.07f);  // between the grid's points
        const Color got = end.inscattered(x, -out, phase, scratch);
        const double f = hg_phase(glm::dot(axis, out), g_composed);
        for (int c = 0; c < 3; ++c) {
            const double expected = rho * map.photon_power * f / sigma_s[c];
            EXPECT_NEAR(got[c] / expected, 1.0, poisson + missed(glm::dot(axis, out)) / f)
                << "cos " << glm::dot(axis, out) << ", channel " << c;
        }
    }
}

// Light that falls off as exp(−x / ℓ) into a medium, ℓ = 0.25, far below the map's radius 1 (a
// dense core's mean free path under a radius set by a plume's thin parts): the ball's average of
// it about depth 0.6 is 1.7 times the light there. Where the ball holds n > 2k photons the lookup
// gathers within r (k / n)^⅓ (≈ 0.09 here) and divides by σ_s over that radius's cube: within 4
// Poisson deviations of the mean over 100 lookups plus the smaller ball's own blur (the average
// of exp over a ball of radius a ℓ is 3 (a cosh a − sinh a) / a³: 1.4% at a = 0.37, allowed 3%).
// Without the table the lookups keep the radius and come out 1.6 times too bright. The same for
// g 0.8, whose lookups search the kd-tree and take the counts from the grid: the photons point
// every way, so each adds f(ω_p · ω_o), of mean 1 / 4π and, for HG, second moment
// (1 − g²)² / 2 · ((1 − g)⁻⁴ − (1 + g)⁻⁴) / 4g over (1 / 4π)² (12.7 at g 0.8), which scales the
// deviations by its square root.
TEST(VolumeMapEnd, ManyPhotonsInTheBallGatherWithinASmallerRadius) {
    const int count = 1000000;
    const float depth_scale = 0.25f, k = 100.0f;
    Rng rng(17, 5);
    std::vector<Photon> photons;
    for (int i = 0; i < count; ++i) {
        float x;
        do x = -depth_scale * std::log1p(-rng.uniform());
        while (x >= 4.0f);
        const Vec3 p(x, 4.0f * rng.uniform() - 2.0f, 4.0f * rng.uniform() - 2.0f);
        photons.emplace_back(p, sample_uniform_sphere(Vec2(rng.uniform(), rng.uniform())),
                             Color(1.0f));
    }
    PhotonMap map;
    map.tree = KdTree<Photon>(std::move(photons));
    map.photon_power = 0.001f;
    const Color sigma_s(2.0f, 1.0f, 0.5f);
    const float radius = 1.0f, x0 = 0.6f;
    // Photons per unit volume at depth x0 (the depth pdf over the 4 × 4 cross-section).
    const double rho = count * std::exp(-x0 / depth_scale) / depth_scale / 16.0;
    NeighborList scratch;
    for (const float g : {0.0f, 0.8f}) {
        SCOPED_TRACE("g " + std::to_string(g));
        const std::vector<Medium> media{Medium::homogeneous(
            {sigma_s, Color(0.1f), g}, Box3{Vec3(0.0f, -2.0f, -2.0f), Vec3(4.0f, 2.0f, 2.0f)})};
        const SigmaTable table(media, 2.0f * radius);
        const PhaseMix phase(g);
        const auto mean_ratio = [&](const VolumeMapEnd& end) {
            Color sum(0.0f);
            for (int i = 0; i < 10; ++i)
                for (int j = 0; j < 10; ++j) {
                    const Vec3 x(x0, -0.9f + 0.2f * i, -0.9f + 0.2f * j);  // balls 0.2 apart
                    sum += end.inscattered(x, Vec3(0.0f, 0.0f, 1.0f), phase, scratch);
                }
            return sum / (100.0f * float(rho * map.photon_power * kInvFourPi) / sigma_s);
        };
        VolumeMapEnd end(map, media, radius, 3, k);
        EXPECT_EQ(end.interpolates(), g == 0.0f);
        ASSERT_TRUE(end.wants_table());
        end.set_table(&table);
        const Color adaptive = mean_ratio(end);
        const double second_moment =
            g == 0.0f ? 1.0
                      : (1.0 - g * g) * (1.0 - g * g) / 2.0 *
                            (std::pow(1.0 - g, -4.0) - std::pow(1.0 + g, -4.0)) / (4.0 * g);
        const double tolerance = 4.0 * std::sqrt(second_moment / (100.0 * k)) + 0.03;
        for (int c = 0; c < 3; ++c) EXPECT_NEAR(adaptive[c], 1.0, tolerance) << "channel " << c;
        const Color fixed = mean_ratio(VolumeMapEnd(map, media, radius, 3));
        EXPECT_GT(fixed.x, 1.4f);  // the blur the adaptive radius removes
    }
}

// LeanCorrection: σ_s = 0.05 + x (a ramp along x) and light L = x (isotropic), photons drawn
// ∝ σ_s L. The ball's σ_s-weighted average of L is L(x) + (r²/5) L' σ_s' / σ_s (exact for linear
// σ_s and L): at r 0.8 and x 1.2–1.6, +7.1% uncorrected over the three balls; the corrected
// estimate came to +1.1% (+0.2%, +0.8%, +0.8% with other photon seeds: 2·10⁶ photons, about
// 40 000 in each ball, and the first-order correction's own second-order rest).
TEST(VolumeMapEnd, TheEstimateIsTheLightAtTheBallsCentreWhereTheDensityVaries) {
    const int n = 40, count = 2000000;
    const float voxel = 0.1f;
    const std::shared_ptr<const DensityGrid> grid = test::density_grid(
        n, n, n, [&](int i, int, int) { return 0.05f + i * voxel; }, Vec3(voxel));
    const std::vector<Medium> media{
        Medium::heterogeneous({Color(1.0f), Color(0.0f), 0.0f}, grid, Mat4(1.0f))};
    // Photons in [0.3, 3.7]³ with density ∝ (0.05 + x) x (rejection against its top, at 3.7).
    const float lo = 0.3f, hi = 3.7f, top = (0.05f + hi) * hi;
    Rng rng(23, 4);
    std::vector<Photon> photons;
    while (photons.size() < size_t(count)) {
        const Vec3 p = Vec3(lo) + (hi - lo) * Vec3(rng.uniform(), rng.uniform(), rng.uniform());
        if (rng.uniform() * top < (0.05f + p.x) * p.x)
            photons.emplace_back(p, sample_uniform_sphere(Vec2(rng.uniform(), rng.uniform())),
                                 Color(1.0f));
    }
    PhotonMap map;
    map.tree = KdTree<Photon>(std::move(photons));
    map.photon_power = 1.0f / count;
    // ∫ σ_s L over the photons' box: the photons per unit volume at x are count σ_s L / z.
    const double side = hi - lo;
    const double z = side * side *
                     ((std::pow(hi, 3.0) - std::pow(lo, 3.0)) / 3.0 +
                      0.025 * (double(hi) * hi - double(lo) * lo));
    const float radius = 0.8f;
    const VolumeMapEnd end(map, media, radius, 3);
    ASSERT_TRUE(end.interpolates());
    const PhaseMix phase(0.0f);
    NeighborList scratch;
    // At the grid's points, where its trilinear interpolation of the photons' sums (a convex
    // function of x here: +2.3% between them) is exact.
    const KernelDensity grid_points(media, radius);
    const Vec3 origin = grid_points.node_position(0);
    const auto node = [&](float v, int a) {
        return origin[a] + std::round((v - origin[a]) / grid_points.cell()) * grid_points.cell();
    };
    double got = 0.0, expected = 0.0, uncorrected = 0.0;
    for (const float at : {1.2f, 1.4f, 1.6f}) {
        const Vec3 p(node(at, 0), node(2.0f, 1), node(2.0f, 2));
        const double x = p.x;
        // E = ρ ΔΦ f / σ_s with ρ = count σ_s L / z: L / (4π z) at the centre.
        const double light = x / (4.0 * kPi * z);
        got += end.inscattered(p, Vec3(0.0f, 0.0f, 1.0f), phase, scratch).x;
        expected += light;
        uncorrected += light * (1.0 + radius * radius / 5.0 / ((0.05 + x) * x));
    }
    EXPECT_GT(uncorrected / expected, 1.05);  // the lean the correction removes
    EXPECT_NEAR(got / expected, 1.0, 0.02) << "uncorrected " << uncorrected / expected;
}

// `count` photons of power 1 (photon_power 0.001) uniform in the cube [−half, half]³, pointing
// every way.
PhotonMap uniform_photons(int count, float half, Rng& rng) {
    std::vector<Photon> photons;
    for (int i = 0; i < count; ++i) {
        const Vec3 p = half * (2.0f * Vec3(rng.uniform(), rng.uniform(), rng.uniform()) - 1.0f);
        photons.emplace_back(p, sample_uniform_sphere(Vec2(rng.uniform(), rng.uniform())),
                             Color(1.0f));
    }
    PhotonMap map;
    map.tree = KdTree<Photon>(std::move(photons));
    map.photon_power = 0.001f;
    return map;
}

// Buffers: maps built in the memory an earlier map left (progressive iterations) give exactly
// the lookups of maps built afresh, whether that memory was larger (a smaller radius before: a
// finer grid) or smaller, with the moments, the crowded lookups' counts and the kd-tree's.
TEST(VolumeMapEnd, MapsBuiltInRecycledMemoryLookUpAsFreshOnes) {
    const std::vector<Medium> media{Medium::heterogeneous(
        {Color(1.0f, 0.8f, 0.6f), Color(0.1f), 0.3f}, load_ramp(), Mat4(1.0f))};
    Rng rng(29, 2);
    std::vector<Photon> photons;
    for (int i = 0; i < 60000; ++i)
        photons.emplace_back(Vec3(0.1f) + 3.8f * Vec3(rng.uniform(), rng.uniform(), rng.uniform()),
                             sample_uniform_sphere(Vec2(rng.uniform(), rng.uniform())),
                             Color(1.0f));
    PhotonMap map;
    map.tree = KdTree<Photon>(std::move(photons));
    map.photon_power = 0.001f;
    const SigmaTable table(media, 1.0f);
    const PhaseMix phase(0.3f);
    NeighborList scratch;
    VolumeMapEnd::Buffers buffers;
    // k 20 crowds the balls (AdaptiveRadius, counts kept for FineEnough's max_tau 0.5).
    for (const float radius : {0.3f, 0.5f, 0.25f, 0.4f}) {
        SCOPED_TRACE("radius " + std::to_string(radius));
        VolumeMapEnd fresh(map, media, radius, 3, 20.0f, 0.5f);
        VolumeMapEnd recycled(map, media, radius, 3, 20.0f, 0.5f, &buffers);
        ASSERT_TRUE(fresh.interpolates());
        ASSERT_TRUE(fresh.wants_table());
        EXPECT_EQ(recycled.nodes(), fresh.nodes());
        EXPECT_EQ(recycled.interpolates(), fresh.interpolates());
        EXPECT_EQ(recycled.wants_table(), fresh.wants_table());
        fresh.set_table(&table);
        recycled.set_table(&table);
        Rng at(31, 7);
        for (int i = 0; i < 200; ++i) {
            const Vec3 x = 3.8f * Vec3(at.uniform(), at.uniform(), at.uniform()) + 0.1f;
            const Vec3 dir = sample_uniform_sphere(Vec2(at.uniform(), at.uniform()));
            const Color a = fresh.inscattered(x, dir, phase, scratch);
            const Color b = recycled.inscattered(x, dir, phase, scratch);
            for (int c = 0; c < 3; ++c) EXPECT_EQ(a[c], b[c]) << "at " << i;
            EXPECT_EQ(fresh.optical_radius(x), recycled.optical_radius(x)) << "at " << i;
        }
    }
}

// FineEnough: inside a homogeneous medium the ball spans σ_s r scattering mean free paths (the
// most scattering channel's); a path ends at its D-th medium vertex where that is at most
// max_tau, else at the first later vertex where it is, and at vertex 4D in any case.
TEST(VolumeMapEnd, PathsEndWhereTheBallSpansFewMeanFreePaths) {
    Rng rng(3, 1);
    const PhotonMap map = uniform_photons(20000, 1.0f, rng);
    const std::vector<Medium> media{Medium::homogeneous(
        {Color(2.0f, 1.0f, 0.5f), Color(0.1f), 0.0f}, Box3{Vec3(-1.0f), Vec3(1.0f)})};
    const float radius = 0.25f;  // σ_s r = 0.5 for the red channel
    const VolumeMapEnd fine(map, media, radius, 3, 0.0f, 0.6f);
    const VolumeMapEnd coarse(map, media, radius, 3, 0.0f, 0.4f);
    const VolumeMapEnd always(map, media, radius, 3);
    const Vec3 inside(0.1f, -0.2f, 0.3f), beyond(1.8f, 0.0f, 0.0f);
    EXPECT_NEAR(fine.optical_radius(inside), 0.5f, 1e-4f);
    EXPECT_EQ(fine.optical_radius(beyond), 0.0f);
    EXPECT_FALSE(fine.ends_at(inside, 2));
    EXPECT_TRUE(fine.ends_at(inside, 3));
    for (int vertex = 3; vertex < 12; ++vertex) EXPECT_FALSE(coarse.ends_at(inside, vertex));
    EXPECT_TRUE(coarse.ends_at(inside, 12));
    EXPECT_TRUE(coarse.ends_at(beyond, 3));
    EXPECT_TRUE(always.ends_at(inside, 3));
    EXPECT_FALSE(always.ends_at(inside, 2));
}

// FineEnough with AdaptiveRadius: where the map's radius spans too many mean free paths, whether a
// path ends depends on the photon count about x. Uniform photons in a homogeneous medium, max_tau
// set where the smaller ball spans it at the mean count: about half the points end. Their
// lookups must average what every lookup averages (itself ρ ΔΦ / (4π σ_s) within the map's
// noise, ±1%): a decision read from the lookup's own photons ends where the count is high by
// chance, +4.4%, +5.8% and +4.2% above every lookup's mean with three photon seeds; read about
// the offset points (kDecisionOffset), −0.2%, −0.1%, −0.1%.
TEST(VolumeMapEnd, WhetherAPathEndsDoesNotFollowTheNoiseOfTheLookupsPhotons) {
    const int count = 200000;
    Rng rng(29, 3);
    const PhotonMap map = uniform_photons(count, 2.0f, rng);
    const float sigma_s = 8.0f, radius = 0.3f, k = 50.0f;
    const std::vector<Medium> media{
        Medium::homogeneous({Color(sigma_s), Color(0.1f), 0.0f}, Box3{Vec3(-2.0f), Vec3(2.0f)})};
    const double rho = count / 64.0;
    const double mean_count = rho * (4.0 / 3.0) * kPi * std::pow(radius, 3.0);  // 353
    const float max_tau = sigma_s * radius * float(std::cbrt(k / mean_count));
    VolumeMapEnd end(map, media, radius, 3, k, max_tau);
    const SigmaTable table(media, 2.0f * radius);
    ASSERT_TRUE(end.wants_table());
    end.set_table(&table);
    const PhaseMix phase(0.0f);
    NeighborList scratch;
    double ended = 0.0, all = 0.0;
    int n_ended = 0;
    const int points = 2000;
    for (int i = 0; i < points; ++i) {
        const Vec3 x = 1.6f * Vec3(rng.uniform(), rng.uniform(), rng.uniform()) - 0.8f;
        const double e = end.inscattered(x, Vec3(0.0f, 0.0f, 1.0f), phase, scratch).x;
        all += e;
        if (end.ends_at(x, 3)) ended += e, ++n_ended;
    }
    const double expected = rho * map.photon_power * kInvFourPi / sigma_s;
    std::printf("ended %d of %d: their mean / expected %.4f, every lookup's %.4f\n", n_ended,
                points, ended / n_ended / expected, all / points / expected);
    ASSERT_GT(n_ended, points / 5);
    ASSERT_LT(n_ended, points * 4 / 5);
    EXPECT_NEAR(all / points / expected, 1.0, 0.015);
    EXPECT_NEAR((ended / n_ended) / (all / points), 1.0, 0.02);
}

// A photon of power 1 at p pointing every way, in a random one of the batches.
Photon batched_photon(const Vec3& p, Rng& rng) {
    Photon photon(p, sample_uniform_sphere(Vec2(rng.uniform(), rng.uniform())), Color(1.0f));
    photon.set_batch(int(rng.uniform() * Photon::kBatches));
    return photon;
}

PhotonMap map_of(std::vector<Photon> photons, float photon_power) {
    PhotonMap map;
    map.tree = KdTree<Photon>(std::move(photons));
    map.photon_power = photon_power;
    return map;
}

// PhotonBatches: a batched map's lookup, times a batch's share, is the lookup of a map holding
// that batch's photons alone at kBatches times their power — computed here from such a map. Grey
// photons pointing every way in a homogeneous medium: at g 0 the grid's lookups (the power's
// share is then exact: the phase is flat), at g 0.8 the kd-tree's (each photon's phase × power).
// The photons are in the second photon half's batches (4-7) alone, so that the kd-tree's
// BlurCorrection, which needs both halves, leaves both maps' lookups as they are.
TEST(VolumeMapEnd, ABatchsShareOfALookupIsTheLookupOfItsPhotonsAlone) {
    for (const float g : {0.0f, 0.8f}) {
        Rng rng(17, 5);
        std::vector<Photon> all, alone;
        const int batch = 5;
        for (int i = 0; i < 40000; ++i) {
            const Vec3 p = 2.0f * Vec3(rng.uniform(), rng.uniform(), rng.uniform()) - Vec3(1.0f);
            const Vec3 travel = sample_uniform_sphere(Vec2(rng.uniform(), rng.uniform()));
            Photon photon(p, travel, Color(0.5f + rng.uniform()));
            photon.set_batch(Photon::kBatches / 2 + int(rng.uniform() * Photon::kBatches / 2));
            all.push_back(photon);
            if (photon.batch() == batch) alone.push_back(photon);
        }
        ASSERT_GT(alone.size(), 8000u);
        const PhotonMap map_all = map_of(std::move(all), 0.01f);
        const PhotonMap map_alone = map_of(std::move(alone), 0.01f * Photon::kBatches);
        const std::vector<Medium> media{Medium::homogeneous(
            {Color(2.0f, 1.0f, 0.5f), Color(0.1f), g}, Box3{Vec3(-2.0f), Vec3(2.0f)})};
        const float radius = 0.3f;
        const VolumeMapEnd batched(map_all, media, radius, 2, 0.0f, 0.0f, nullptr,
                                   PhotonParts::NoiseAndBias);
        const VolumeMapEnd own(map_alone, media, radius, 2);
        ASSERT_EQ(batched.interpolates(), g == 0.0f);
        const PhaseMix phase(g);
        NeighborList scratch;
        for (int i = 0; i < 20; ++i) {
            const Vec3 x = 1.2f * Vec3(rng.uniform(), rng.uniform(), rng.uniform()) - 0.6f;
            const Vec3 dir = sample_uniform_sphere(Vec2(rng.uniform(), rng.uniform()));
            VolumeMapEnd::Parts parts;
            const Color whole = batched.inscattered(x, dir, phase, scratch, &parts);
            const auto& shares = parts.shares;
            const Color expected = own.inscattered(x, dir, phase, scratch);
            double mean_share = 0.0;
            for (float s : shares) mean_share += s / Photon::kBatches;
            EXPECT_NEAR(mean_share, 1.0, 1e-5) << "g " << g << ", lookup " << i;
            for (int c = 0; c < 3; ++c)
                EXPECT_NEAR(whole[c] * shares[batch], expected[c], 1e-4f * expected[c])
                    << "g " << g << ", lookup " << i << ", channel " << c;
        }
    }
}

// RadiusBias: photons whose density grows as 1 + 4 x² about the plane x = 0 (pointing every way,
// in a homogeneous medium). A ball of radius ρ about a point of the plane averages x² to ρ²/5,
// so the lookup is (1 + 0.8 ρ²) times the light there: at ρ 0.3, 6.7% of the estimate is bias.
// Richardson's estimate is exact for this quadratic; each photon half's, averaged over 40
// lookups on the plane, must give it within 0.015 (its noise: about 0.6% a lookup's annulus of
// 13 000 photons, the lookups overlapping). The grid's lookups (g 0) and the kd-tree's (g 0.8).
// With the σ_s table set (κ from it: each grid point's where lookups interpolate, the corners'
// where they search the kd-tree), the same: σ_s is uniform, so σ̄'s ratio is 1.
TEST(VolumeMapEnd, EachPhotonHalfEstimatesTheBiasOfTheBallsBlur) {
    for (const auto& [g, table_set] : {std::pair{0.0f, false}, std::pair{0.8f, false},
                                       std::pair{0.0f, true}, std::pair{0.8f, true}}) {
        Rng rng(19, 6);
        std::vector<Photon> photons;
        while (photons.size() < 3000000) {
            const Vec3 p = 2.0f * Vec3(rng.uniform(), rng.uniform(), rng.uniform()) - Vec3(1.0f);
            if (5.0f * rng.uniform() > 1.0f + 4.0f * p.x * p.x) continue;
            photons.push_back(batched_photon(p, rng));
        }
        const PhotonMap map = map_of(std::move(photons), 1e-6f);
        const std::vector<Medium> media{
            Medium::homogeneous({Color(1.0f), Color(0.1f), g}, Box3{Vec3(-2.0f), Vec3(2.0f)})};
        const float radius = 0.3f;
        VolumeMapEnd end(map, media, radius, 2, 0.0f, 0.0f, nullptr, PhotonParts::NoiseAndBias);
        ASSERT_EQ(end.interpolates(), g == 0.0f);
        const SigmaTable table(media, 2.0f * radius);
        if (table_set) end.set_table(&table);
        const PhaseMix phase(g);
        NeighborList scratch;
        const double expected = 0.8 * radius * radius / (1.0 + 0.8 * radius * radius);
        std::array<double, 2> mean{};
        const int lookups = 40;
        for (int i = 0; i < lookups; ++i) {
            const Vec3 x(0.0f, 0.8f * rng.uniform() - 0.4f, 0.8f * rng.uniform() - 0.4f);
            VolumeMapEnd::Parts parts;
            end.inscattered(x, sample_uniform_sphere(Vec2(rng.uniform(), rng.uniform())), phase,
                            scratch, &parts);
            for (int h = 0; h < 2; ++h) mean[h] += parts.bias[h] / lookups;
        }
        std::printf("g %.1f, table %d: bias / estimate from the halves %.4f, %.4f; expected %.4f\n",
                    g, int(table_set), mean[0], mean[1], expected);
        for (int h = 0; h < 2; ++h)
            EXPECT_NEAR(mean[h], expected, 0.015) << "g " << g << ", table " << table_set;
    }
}

// RadiusBias just outside dense smoke: σ_s 1 for x < 0, a haze of 1e-4 beyond, photons as dense
// as σ_s (a uniform light field: the estimate has no bias). Lookups at x in (0.18, 0.24) have
// their inner cube (ρ/√2) in the haze alone and their outer cube (ρ) reaching into the smoke:
// σ̄'s ratio is hundreds, and the inner estimate a few photons over the haze's σ̄. Its ratio
// taken at most kMaxSigmaRatio, each half's bias stays within a few estimates (without the
// bound the kd-tree's lookups, g 0.8, reached 1.07e3 here, and one such pixel made smoke1's
// 960 x 540 bias² 0.23).
TEST(VolumeMapEnd, TheBiasHalvesStayBoundedJustOutsideDenseSmoke) {
    for (const float g : {0.0f, 0.8f}) {
        Rng rng(23, 4);
        std::vector<Photon> photons;
        const auto add = [&](float x0, float x1, int n) {
            for (int i = 0; i < n; ++i) {
                const Vec3 p(x0 + (x1 - x0) * rng.uniform(), 4.0f * rng.uniform() - 2.0f,
                             4.0f * rng.uniform() - 2.0f);
                photons.push_back(batched_photon(p, rng));
            }
        };
        add(-2.0f, 0.0f, 2000000);
        add(0.0f, 2.0f, 200);  // 1e-4 of the smoke's photons a volume
        const PhotonMap map = map_of(std::move(photons), 1e-6f);
        const std::vector<Medium> media{
            Medium::homogeneous({Color(1.0f), Color(0.1f), g},
                                Box3{Vec3(-2.0f), Vec3(0.0f, 2.0f, 2.0f)}),
            Medium::homogeneous({Color(1e-4f), Color(1e-5f), g},
                                Box3{Vec3(0.0f, -2.0f, -2.0f), Vec3(2.0f)})};
        const float radius = 0.3f;
        VolumeMapEnd end(map, media, radius, 2, 0.0f, 0.0f, nullptr, PhotonParts::NoiseAndBias);
        const SigmaTable table(media, 2.0f * radius);
        end.set_table(&table);
        const PhaseMix phase(g);
        NeighborList scratch;
        float most = 0.0f;
        for (int i = 0; i < 200; ++i) {
            const Vec3 x(0.18f + 0.06f * rng.uniform(), rng.uniform() - 0.5f, rng.uniform() - 0.5f);
            VolumeMapEnd::Parts parts;
            end.inscattered(x, sample_uniform_sphere(Vec2(rng.uniform(), rng.uniform())), phase,
                            scratch, &parts);
            for (int h = 0; h < 2; ++h) most = std::max(most, std::abs(parts.bias[h]));
        }
        std::printf("g %.1f: the largest bias half, in estimates, %.3g\n", g, most);
        EXPECT_LT(most, 50.0f) << "g " << g;
    }
}

// BlurCorrection, where lookups search the kd-tree (g 0.5): σ_s = e^{a x} on the grid, light
// L = e^{b x}, photons drawn ∝ σ_s L in [0.4, 3.6]³. Uncorrected, the ball's estimate would be
// L(x) times the ball's mean of e^{(a+b)·u} over the cube's mean of e^{a·u} (σ̄_s), both in
// closed form: at ρ 0.5, light falling as e^{2x} alone 10.4% bright, σ_s rising as e^{2x} into
// light falling as fast (a sun-lit face) 10.1% dark, σ_s's gradient alone 0.7% dark. Corrected,
// it must be L(x) within 2.5% at 16 points between the σ̄_s grid's, so the first two fail
// uncorrected. The expected value takes the grid's own σ̄_s as given (E = the ball's σ_s L over
// it): its interpolation between points, up to 3.6% here, is another blur than the ball's.
TEST(VolumeMapEnd, AKdTreeLookupIsTheLightAtItsCentreWhereLightAndDensityFallExponentially) {
    const int n = 40, count = 2000000;
    const float voxel = 0.1f, lo = 0.4f, hi = 3.6f, radius = 0.5f, g = 0.5f;
    for (const auto& [a, b] :
         {std::pair{0.0f, 2.0f}, std::pair{2.0f, -2.0f}, std::pair{2.0f, 0.0f}}) {
        const std::shared_ptr<const DensityGrid> grid = test::density_grid(
            n, n, n, [&](int i, int, int) { return std::exp(a * i * voxel); }, Vec3(voxel));
        const std::vector<Medium> media{
            Medium::heterogeneous({Color(1.0f), Color(0.0f), g}, grid, Mat4(1.0f))};
        const float c = a + b;  // the photons' density ∝ e^{c x}
        Rng rng(29, 5);
        std::vector<Photon> photons;
        while (photons.size() < size_t(count)) {
            const Vec3 p = Vec3(lo) + (hi - lo) * Vec3(rng.uniform(), rng.uniform(), rng.uniform());
            if (rng.uniform() > std::exp(c * (p.x - (c > 0.0f ? hi : lo)))) continue;
            photons.push_back(batched_photon(p, rng));
        }
        const PhotonMap map = map_of(std::move(photons), 1.0f / count);
        const double side = hi - lo;
        const double z =
            side * side * (c == 0.0f ? side : (std::exp(c * hi) - std::exp(c * lo)) / c);
        const VolumeMapEnd end(map, media, radius, 3);
        ASSERT_FALSE(end.interpolates());
        const PhaseMix phase(g);
        NeighborList scratch;
        const KernelDensity sigma_bar(media, radius);  // the lookups' σ̄_s grid
        const double t = a * equal_volume_edge(radius) / 2.0;
        const double cube = t == 0.0 ? 1.0 : std::sinh(t) / t;  // the cube's mean of e^{a·u}
        double got = 0.0, expected = 0.0;
        for (int i = 0; i < 16; ++i) {
            const Vec3 p =
                Vec3(1.8f, 1.4f, 1.4f) +
                Vec3(0.4f, 1.2f, 1.2f) * Vec3(rng.uniform(), rng.uniform(), rng.uniform());
            got += end.inscattered(p, sample_uniform_sphere(Vec2(rng.uniform(), rng.uniform())),
                                   phase, scratch)
                       .x;
            // The photons a volume at p are count σ_s L / z, ΔΦ = 1 / count, and f averages 1/4π
            // over directions pointing every way: σ_s L / (4π z), over σ̄_s.
            const double sigma_l = std::exp(double(c) * p.x) / (4.0 * kPi * z);
            expected += sigma_l * cube / sigma_bar.at(p).x;
        }
        const auto ball = [](double s) {
            return s == 0.0 ? 1.0 : 3.0 * (s * std::cosh(s) - std::sinh(s)) / (s * s * s);
        };
        std::printf("a %.0f, b %.0f: uncorrected %.4f, the estimate / expected %.4f\n", a, b,
                    ball(c * radius) / cube, got / expected);
        EXPECT_NEAR(got / expected, 1.0, 0.025) << "a " << a << ", b " << b;
    }
}

}  // namespace
}  // namespace fogmap
