// Free-path sampling and transmittance against closed forms: exp(-σ_t d) through homogeneous and
// constant-density VDB media (with the half-voxel ramp of trilinear sampling at the boundary),
// per-channel weights for chromatic media, and the product rule for overlapping media.

#include "media/medium.h"

#include "test_support.h"

#include <gtest/gtest.h>

#include <memory>

namespace fogmap {
namespace {

using test::MeanEstimate;

// One sampler per medium (samplers are move-only, so no initializer lists).
std::vector<Medium::Sampler> samplers(std::initializer_list<const Medium*> media) {
    std::vector<Medium::Sampler> out;
    for (const Medium* m : media) out.emplace_back(*m);
    return out;
}

// A cube of n^3 voxels (index 0..n-1) of density 1.
std::shared_ptr<const DensityGrid> constant_cube(int n, float voxel_size) {
    return test::density_grid(
        n, n, n, [](int, int, int) { return 1.0f; }, Vec3(voxel_size));
}

TEST(RatioTracking, HomogeneousSlabMatchesBeerLambert) {
    const float sigma_t = 2.0f, d = 1.5f;
    Box3 box{Vec3(0.0f), Vec3(d, 10.0f, 10.0f)};
    const Medium m = Medium::homogeneous({Color(sigma_t * 0.7f), Color(sigma_t * 0.3f), 0.0f}, box);
    std::vector<Medium::Sampler> media = samplers({&m});
    const Ray ray{Vec3(-1.0f, 5.0f, 5.0f), Vec3(1.0f, 0.0f, 0.0f)};
    const MeanEstimate e = test::estimate_mean(20000, [&](int i) {
        Rng rng(7, i);
        return ratio_track(media, ray, kInfinity, rng).x;
    });
    const double expected = std::exp(-sigma_t * d);
    EXPECT_NEAR(e.mean, expected, 3.0 * e.standard_error + 1e-12);
}

TEST(DeltaTracking, EscapeProbabilityMatchesBeerLambert) {
    const float sigma_t = 1.0f, d = 2.0f;
    const Medium m = Medium::homogeneous({Color(sigma_t), Color(0.0f), 0.3f},
                                         Box3{Vec3(0.0f), Vec3(d, 1.0f, 1.0f)});
    std::vector<Medium::Sampler> media = samplers({&m});
    const Ray ray{Vec3(-0.5f, 0.5f, 0.5f), Vec3(1.0f, 0.0f, 0.0f)};
    const int n = 40000;
    double mean_t = 0.0;
    int scattered = 0;
    for (int i = 0; i < n; ++i) {
        Rng rng(3, i);
        Color beta(1.0f);
        const TrackResult r = delta_track(media, ray, kInfinity, rng, &beta);
        EXPECT_EQ(beta, Color(1.0f));  // grey medium: weights are exactly 1
        if (r.event == TrackEvent::Scattered) {
            ++scattered;
            mean_t += r.t - 0.5;
        }
    }
    const double p = 1.0 - std::exp(-sigma_t * d);  // collision probability
    EXPECT_NEAR(static_cast<double>(scattered) / n, p, 3.0 * std::sqrt(p * (1 - p) / n));
    // Mean depth of a collision given one happened in [0, d]: 1/σ − d e^{−σd}/(1 − e^{−σd}).
    const double expected_depth = 1.0 / sigma_t - d * std::exp(-sigma_t * d) / p;
    EXPECT_NEAR(mean_t / scattered, expected_depth, 0.02);  // SE ≈ 0.55/sqrt(25000) ≈ 0.0035
}

TEST(DeltaTracking, ChromaticWeightsGiveEachChannelsTransmittance) {
    // Escaping weight averages to exp(−σ_t,c d) per channel (σ_a only, so scattering is absent).
    const Color sigma_a(0.5f, 1.0f, 2.0f);
    const float d = 1.0f;
    const Medium m =
        Medium::homogeneous({Color(0.0f), sigma_a, 0.0f}, Box3{Vec3(0.0f), Vec3(d, 1.0f, 1.0f)});
    std::vector<Medium::Sampler> media = samplers({&m});
    const Ray ray{Vec3(-1.0f, 0.5f, 0.5f), Vec3(1.0f, 0.0f, 0.0f)};
    for (int c = 0; c < 3; ++c) {
        const MeanEstimate e = test::estimate_mean(40000, [&](int i) {
            Rng rng(11, i);
            Color beta(1.0f);
            const TrackResult r = delta_track(media, ray, kInfinity, rng, &beta);
            return r.event == TrackEvent::Escaped ? beta[c] : 0.0f;
        });
        EXPECT_NEAR(e.mean, std::exp(-sigma_a[c] * d), 3.0 * e.standard_error) << "channel " << c;
    }
}

TEST(RatioTracking, OverlappingMediaMultiply) {
    const Medium a = Medium::homogeneous({Color(1.0f), Color(0.0f), 0.0f},
                                         Box3{Vec3(0.0f), Vec3(2.0f, 1.0f, 1.0f)});
    const Medium b = Medium::homogeneous({Color(0.5f), Color(0.25f), 0.0f},
                                         Box3{Vec3(1.0f, 0.0f, 0.0f), Vec3(3.0f, 1.0f, 1.0f)});
    std::vector<Medium::Sampler> media = samplers({&a, &b});
    const Ray ray{Vec3(-1.0f, 0.5f, 0.5f), Vec3(1.0f, 0.0f, 0.0f)};
    const MeanEstimate e = test::estimate_mean(40000, [&](int i) {
        Rng rng(5, i);
        return ratio_track(media, ray, kInfinity, rng).x;
    });
    // Homogeneous media are integrated exactly (residual ratio tracking with the whole σ_t as
    // control): no variance, and the value to float rounding.
    EXPECT_EQ(e.standard_error, 0.0);
    EXPECT_NEAR(e.mean, std::exp(-1.0 * 2.0 - 0.75 * 2.0), 1e-6 * e.mean);
}

// The camera segment's walk (ratio_track_pick) against quadrature of the closed forms, per
// channel, through two overlapping chromatic media: E[weight] = ∫ σ_s T dt, E[weight t] =
// ∫ σ_s T t dt, E[weight; medium b] = ∫ σ_s,b T dt, E[transmittance] = T(end). Channels with
// different σ_t make the ratio-tracking product chromatic, and the pick ∝ average(a) must still
// weight each channel right.
TEST(RatioTrackPick, WeightsIntegrateInscatteringAndTransmittance) {
    const Color sa_s(1.0f, 0.5f, 0.2f), sa_a(0.1f), sb_s(0.5f), sb_a(0.25f, 0.5f, 1.0f);
    const Medium a =
        Medium::homogeneous({sa_s, sa_a, 0.0f}, Box3{Vec3(0.0f), Vec3(2.0f, 1.0f, 1.0f)});
    const Medium b = Medium::homogeneous({sb_s, sb_a, 0.0f},
                                         Box3{Vec3(1.0f, 0.0f, 0.0f), Vec3(3.0f, 1.0f, 1.0f)});
    std::vector<Medium::Sampler> media = samplers({&a, &b});
    const Ray ray{Vec3(-1.0f, 0.5f, 0.5f), Vec3(1.0f, 0.0f, 0.0f)};
    const float t_max = 3.5f;  // ends inside b: x = 2.5
    // Quadrature (midpoint rule, 200 000 steps) of the closed forms along x = t − 1.
    const auto in = [](double x, double lo, double hi) { return x >= lo && x < hi ? 1.0 : 0.0; };
    for (int c = 0; c < 3; ++c) {
        double w = 0.0, wt = 0.0, wb = 0.0, tau = 0.0;
        const int steps = 200000;
        const double dt = t_max / steps;
        for (int i = 0; i < steps; ++i) {
            const double t = (i + 0.5) * dt, x = t - 1.0;
            const double ia = in(x, 0.0, 2.0), ib = in(x, 1.0, 3.0);
            const double s = ia * sa_s[c] + ib * sb_s[c];
            const double st = s + ia * sa_a[c] + ib * sb_a[c];
            const double T = std::exp(-(tau + 0.5 * st * dt));
            w += s * T * dt;
            wt += s * T * t * dt;
            wb += ib * sb_s[c] * T * dt;
            tau += st * dt;
        }
        const auto check = [&](double expected, auto&& f, const char* what) {
            const MeanEstimate e = test::estimate_mean(100000, [&](int i) {
                Rng rng(13, i);
                return f(ratio_track_pick(media, ray, t_max, rng));
            });
            EXPECT_NEAR(e.mean, expected, 4.0 * e.standard_error + 1e-6)
                << what << ", channel " << c;
        };
        check(
            w, [&](const InscatterPick& p) { return p.weight[c]; }, "weight");
        check(
            wt, [&](const InscatterPick& p) { return p.weight[c] * p.t; }, "weight t");
        check(
            wb, [&](const InscatterPick& p) { return p.medium == 1 ? p.weight[c] : 0.0f; },
            "weight in b");
        check(
            std::exp(-tau), [&](const InscatterPick& p) { return p.transmittance[c]; },
            "transmittance");
    }
}

// The walk's emission estimate, Σ T_i σ_a L_e / μ_i over the tentative collisions, against the
// closed form ∫ T σ_a L_e dt = L_e σ_a/σ_t (1 − e^{−σ_t d}) of a homogeneous emitting slab, per
// channel.
TEST(RatioTrackPick, EmissionIntegratesAlongTheRay) {
    const Color sigma_s(0.5f), sigma_a(2.0f, 1.0f, 0.5f), Le(1.0f, 2.0f, 3.0f);
    const float d = 0.75f;
    Medium m = Medium::homogeneous({sigma_s, sigma_a, 0.0f}, Box3{Vec3(0.0f), Vec3(d, 1.0f, 1.0f)});
    EmissionParams e;
    e.color = Le;
    m.set_emission(Emission::constant(e), Mat4(1.0f));
    std::vector<Medium::Sampler> media = samplers({&m});
    const Ray ray{Vec3(-1.0f, 0.5f, 0.5f), Vec3(1.0f, 0.0f, 0.0f)};
    for (int c = 0; c < 3; ++c) {
        const MeanEstimate est = test::estimate_mean(40000, [&](int i) {
            Rng rng(17, i);
            Color emitted(0.0f);
            ratio_track_pick(media, ray, kInfinity, rng, &emitted);
            return emitted[c];
        });
        const double st = double(sigma_s[c]) + sigma_a[c];
        const double want = Le[c] * sigma_a[c] / st * -std::expm1(-st * d);
        EXPECT_NEAR(est.mean, want, 4.0 * est.standard_error + 1e-6) << "channel " << c;
    }
}

// Constant-density VDB cube of n voxels: trilinear sampling ramps the density from 0 at index −1
// to 1 at index 0 (and down again from n−1 to n), so the optical depth along a line through voxel
// centres is σ_t · n · voxel_size — as if the density filled the voxel faces exactly.
TEST(RatioTracking, ConstantVdbCubeMatchesBeerLambertWithHalfVoxelRamp) {
    const int n = 16;
    const float voxel = 0.25f, sigma_t = 0.5f;
    const auto grid = constant_cube(n, voxel);
    const Medium m = Medium::heterogeneous({Color(sigma_t), Color(0.0f), 0.0f}, grid, Mat4(1.0f));
    std::vector<Medium::Sampler> media = samplers({&m});
    // Through voxel centres (index y = z = 7): full density across.
    const Ray centre{Vec3(-2.0f, 7.0f * voxel, 7.0f * voxel), Vec3(1.0f, 0.0f, 0.0f)};
    const MeanEstimate e = test::estimate_mean(40000, [&](int i) {
        Rng rng(13, i);
        return ratio_track(media, centre, kInfinity, rng).x;
    });
    EXPECT_NEAR(e.mean, std::exp(-sigma_t * n * voxel), 3.0 * e.standard_error);
    // Along index y = −0.5 (half a voxel outside the outermost centres): density 0.5 across.
    const Ray ramp{Vec3(-2.0f, -0.5f * voxel, 7.0f * voxel), Vec3(1.0f, 0.0f, 0.0f)};
    const MeanEstimate r = test::estimate_mean(40000, [&](int i) {
        Rng rng(17, i);
        return ratio_track(media, ramp, kInfinity, rng).x;
    });
    EXPECT_NEAR(r.mean, std::exp(-0.5 * sigma_t * n * voxel), 3.0 * r.standard_error);
    // Along the diagonal x = z the trilinear density is the product of the two 1D profiles
    // f(x) f(z) = f(s)^2, whose ramps integrate to 1/3 each instead of 1/2:
    // tau = sigma_t * sqrt(2) * v * ((n - 1) + 2/3). Checked by delta tracking's escape fraction.
    const Vec3 dir = glm::normalize(Vec3(1.0f, 0.0f, 1.0f));
    const Ray diag{Vec3(-2.0f, 7.0f * voxel, -2.0f), dir};
    const double tau = sigma_t * std::sqrt(2.0) * voxel * (n - 1.0 / 3.0);
    int escaped = 0;
    const int trials = 40000;
    for (int i = 0; i < trials; ++i) {
        Rng rng(19, i);
        Color beta(1.0f);
        escaped += delta_track(media, diag, kInfinity, rng, &beta).event == TrackEvent::Escaped;
    }
    const double p = std::exp(-tau);
    EXPECT_NEAR(static_cast<double>(escaped) / trials, p, 3.0 * std::sqrt(p * (1 - p) / trials));
}

TEST(Medium, EmptyGridIsVacuum) {
    const std::shared_ptr<const DensityGrid> grid =
        test::density_grid(4, 4, 4, [](int, int, int) { return 0.0f; });
    const Medium m = Medium::heterogeneous({Color(1.0f), Color(0.0f), 0.0f}, grid, Mat4(1.0f));
    std::vector<Medium::Sampler> media = samplers({&m});
    Rng rng(1, 2);
    const Ray ray{Vec3(-1.0f, 1.0f, 1.0f), Vec3(1.0f, 0.0f, 0.0f)};
    EXPECT_EQ(ratio_track(media, ray, kInfinity, rng), Color(1.0f));
    Color beta(1.0f);
    EXPECT_EQ(delta_track(media, ray, kInfinity, rng, &beta).event, TrackEvent::Escaped);
}

}  // namespace
}  // namespace fogmap
