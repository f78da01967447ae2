// Emitting media: L_e from constant, scalar and blackbody emission, and the power the photon
// pass's emission sampling stands for, against closed forms.

#include "media/blackbody.h"
#include "media/medium.h"
#include "media/volume_gen.h"
#include "test_support.h"

#include <gtest/gtest.h>

#include <cmath>

namespace fogmap {
namespace {

constexpr int kN = 8;       // the block's voxels per axis
constexpr float kH = 0.1f;  // voxel size

std::shared_ptr<const DensityGrid> block(const test::TempDir& dir, const std::string& name,
                                         float value, int n = kN, float h = kH,
                                         Vec3 translation = Vec3(0.0f)) {
    const std::string path = (dir.path() / (name + ".vdb")).string();
    write_float_grid(
        path, name, n, n, n, [&](int, int, int) { return value; }, Vec3(h), translation);
    return DensityGrid::load(path, name, "");
}

TEST(Emission, ConstantBlockEmitsItsAnalyticPower) {
    // A block of N³ voxels of density 1: with the trilinear ramps (one voxel wide, from the outer
    // voxel centres to 0) ∫ density dV = (N h)³ exactly, so it emits 4π σ_a L_e (N h)³.
    const test::TempDir dir("emission");
    const MediumParams params{Color(0.5f), Color(2.0f, 1.0f, 0.5f), 0.0f};
    Medium m = Medium::heterogeneous(params, block(dir, "density", 1.0f), Mat4(1.0f));
    EmissionParams e;
    e.color = Color(1.0f, 0.5f, 0.25f);
    e.scale = 3.0f;
    m.set_emission(Emission::constant(e), Mat4(1.0f));
    const double volume = std::pow(double(kN) * kH, 3);
    const DVec3 expected = 4.0 * kPi * volume * DVec3(params.sigma_a * e.color * e.scale);

    // The photon pass's estimate: each attempt stands for bound_power, accepted ones carry
    // their colour (channel average 1).
    Medium::Sampler s(m);
    constexpr int kAttempts = 200000;
    test::SampleStats<DVec3> power;
    for (int i = 0; i < kAttempts; ++i) {
        Rng rng(7, static_cast<uint64_t>(i));
        Vec3 p;
        Color c;
        if (!s.sample_emission(rng, &p, &c)) {
            power.add(DVec3(0.0));  // a rejected attempt carries nothing
            continue;
        }
        EXPECT_TRUE(m.world_bounds().contains(p));
        power.add(m.emission_bound_power() * DVec3(c));
    }
    const DVec3 mean = power.mean(), se = power.standard_error();
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(mean[c], expected[c], 4.0 * se[c]) << "channel " << c;
    EXPECT_NEAR(m.emitted_power(), (expected.x + expected.y + expected.z) / 3.0, 0.01 * expected.x);
}

TEST(Emission, HomogeneousBoxEmitsExactly) {
    const Box3 box{Vec3(-1.0f, 0.0f, 0.0f), Vec3(1.0f, 0.5f, 2.0f)};
    Medium m = Medium::homogeneous({Color(0.0f), Color(0.4f), 0.0f}, box);
    EmissionParams e;
    e.color = Color(2.0f, 1.0f, 3.0f);
    m.set_emission(Emission::constant(e), Mat4(1.0f));
    EXPECT_NEAR(m.emitted_power(), 4.0 * kPi * 0.4 * 2.0 * 2.0, 1e-4);  // acceptance is 1
}

TEST(Emission, GridValuesMapToRadiance) {
    // The emission grid has its own voxel size and placement: 4 voxels of 0.25 from -0.5.
    const test::TempDir dir("emission");
    const Vec3 p(0.1f, 0.05f, 0.0f);  // inside both grids' plateaus
    const auto density = block(dir, "density", 1.0f, 8, 0.1f, Vec3(-0.35f));
    Medium m = Medium::heterogeneous({Color(1.0f), Color(1.0f), 0.0f}, density, Mat4(1.0f));

    EmissionParams bb;
    bb.kind = EmissionKind::Blackbody;
    bb.temperature_scale = 100.0f;
    bb.temperature_offset = 20.0f;
    bb.scale = 2.0f;
    m.set_emission(
        Emission::from_grid(bb, block(dir, "temperature", 14.8f, 4, 0.25f, Vec3(-0.375f))),
        Mat4(1.0f));
    Medium::Sampler s(m);
    const Color want = 2.0f * blackbody_radiance(1500.0);  // 14.8 × 100 + 20 K
    const Color got = s.emission(p);
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(got[c], want[c], 1e-3f * want[c] + 1e-7f) << c;
    EXPECT_NEAR(m.emission()->max_kelvin(), 1500.0, 1e-3);

    EmissionParams sc;
    sc.kind = EmissionKind::Scalar;
    sc.color = Color(1.0f, 0.5f, 0.2f);
    sc.scale = 4.0f;
    m.set_emission(Emission::from_grid(sc, block(dir, "heat", 0.5f, 4, 0.25f, Vec3(-0.375f))),
                   Mat4(1.0f));
    Medium::Sampler s2(m);
    const Color heat = s2.emission(p);
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(heat[c], 0.5f * sc.color[c] * 4.0f, 1e-5f) << c;
    EXPECT_EQ(s2.emission(Vec3(5.0f)), Color(0.0f)) << "outside the emission grid";
}

}  // namespace
}  // namespace fogmap
