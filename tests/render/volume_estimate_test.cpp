// The spherical volume estimate against the path tracer: in a homogeneous albedo-0.8 cube under
// a uniform sky, the volume map's estimate of in-scattered radiance from light that has scattered
// at least once (first interactions are not stored) converges, as photons grow, to the path
// tracer's value averaged over the same ball.

#include "media/henyey_greenstein.h"
#include "photon/estimators.h"
#include "render/path_tracer.h"
#include "render/run_setup.h"
#include "scene_builders.h"
#include "test_support.h"

#include <gtest/gtest.h>

namespace fogmap {
namespace {

constexpr float kSigmaS = 0.8f, kSigmaA = 0.2f, kG = 0.3f, kRadius = 0.35f;

SceneDesc cube_under_sky() {
    SceneDesc d;
    d.render.integrator = Integrator::Photon;  // the volume map is what this test checks
    d.lights.push_back(test::environment(1.0f));
    d.media.push_back(
        test::homogeneous(Box3{Vec3(-1.0f), Vec3(1.0f)}, Color(kSigmaS), Color(kSigmaA), kG));
    return d;
}

// Distance from x (inside the cube [-1,1]^3) to its boundary along unit d.
float exit_distance(const Vec3& x, const Vec3& d) {
    float t = kInfinity;
    for (int a = 0; a < 3; ++a) {
        if (d[a] > 0.0f) t = std::min(t, (1.0f - x[a]) / d[a]);
        if (d[a] < 0.0f) t = std::min(t, (-1.0f - x[a]) / d[a]);
    }
    return t;
}

// σ_s ∫ p L_ms dω averaged over the ball of radius kRadius around c, for light leaving along wo:
// x uniform in the ball, travel direction ω ~ p(ω·wo) (so the phase cancels its pdf), and the
// path tracer's radiance arriving along ω minus its unscattered part T·L_sky.
test::MeanEstimate reference(const Scene& scene, const Vec3& c, const Vec3& wo, int n) {
    const PathTracer tracer(scene, 100000);
    PathTracer::ThreadState ts = tracer.make_state();
    const float sigma_t = kSigmaS + kSigmaA;
    return test::estimate_mean(n, [&](int i) {
        Rng rng(77, i);
        Vec3 offset;
        do {
            offset = Vec3(rng.uniform(), rng.uniform(), rng.uniform()) * 2.0f - 1.0f;
        } while (glm::dot(offset, offset) > 1.0f);
        const Vec3 x = c + kRadius * offset;
        float pdf;
        const Vec3 travel = hg_sample(wo, kG, Vec2(rng.uniform(), rng.uniform()), &pdf);
        const Vec3 back = -travel;
        const double L = tracer.radiance(Ray{x, back}, rng, ts).x;
        const double direct = std::exp(-sigma_t * exit_distance(x, back));
        return kSigmaS * (L - direct);
    });
}

TEST(VolumeEstimate, HomogeneousInScatteringConvergesToThePathTracer) {
    SceneDesc d = cube_under_sky();
    const std::vector<Vec3> points{Vec3(0.0f), Vec3(0.4f, 0.0f, 0.0f), Vec3(0.0f, -0.4f, 0.2f)};
    const Vec3 wo(0.0f, 0.0f, 1.0f);
    const auto scene = load_scene(d);
    std::vector<test::MeanEstimate> ref;
    for (const Vec3& p : points) ref.push_back(reference(*scene, p, wo, 40000));

    // Independent photon maps (8 seeds) give each estimate's standard error from their spread:
    // one photon path can deposit several photons in a ball, so counting photons would
    // understate it.
    constexpr int kSeeds = 8;
    double previous = 1e30;
    for (uint64_t n : {10000u, 80000u}) {
        d.photons.volume = n;
        std::vector<std::vector<double>> est(points.size());
        for (int seed = 0; seed < kSeeds; ++seed) {
            d.render.seed = 100 + seed;
            const auto s = load_scene(d);
            PhotonMaps maps = build_trees(
                trace_photons(*s, make_plan(d), d.photons, d.march, d.render.seed, true));
            ASSERT_TRUE(maps.volume.has_value());
            NeighborList scratch;
            for (size_t i = 0; i < points.size(); ++i)
                est[i].push_back(volume_inscattered(*maps.volume, points[i], wo, PhaseMix(kG),
                                                    1 << 30, kRadius, scratch)
                                     .x);
        }
        double error = 0.0;  // mean relative error of single maps
        for (size_t i = 0; i < points.size(); ++i) {
            test::SampleStats<> maps;
            for (double e : est[i]) {
                maps.add(e);
                error += std::abs(e - ref[i].mean) / ref[i].mean;
            }
            const double mean = maps.mean();
            const double se_pm = maps.standard_error_unbiased();
            const double se =
                std::sqrt(se_pm * se_pm + ref[i].standard_error * ref[i].standard_error);
            if (n == 80000u) {
                EXPECT_NEAR(mean, ref[i].mean, 3.0 * se) << "point " << i;
            }
        }
        error /= points.size() * kSeeds;
        // 8x the photons: the expected error of one map falls by sqrt(8) ≈ 2.8.
        EXPECT_LT(error, previous) << n << " photons: mean relative error " << error;
        previous = error;
    }
}

}  // namespace
}  // namespace fogmap
