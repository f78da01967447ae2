// Transmittance is not a coin toss: shadow rays through a homogeneous slab carry the exact
// exp(−σ_t d), so a plane lit by a sun through fog has a `direct` layer without variance, in the
// photon integrator and in the path tracer; and residual ratio tracking stays unbiased in a
// heterogeneous grid (against the optical depth integrated by quadrature here).

#include "media/volume_gen.h"
#include "render/path_tracer.h"
#include "render/pipeline.h"
#include "scene/scene.h"
#include "scene_builders.h"
#include "test_support.h"

#include <gtest/gtest.h>

#include <cmath>

namespace fogmap {
namespace {

using namespace test;

constexpr float kE = 2.0f, kAlbedo = 0.5f, kSigmaS = 0.6f, kSigmaA = 0.2f, kDepth = 1.5f;

// A diffuse plane at y = 0 under a sun from straight above, through a fog slab 0.5 < y < 2.
SceneDesc plane_under_fog() {
    SceneDesc d;
    d.lights.push_back(sun(Vec3(0.0f, -1.0f, 0.0f), kE));
    add_ground(&d, 0.0f, 20.0f, kAlbedo);
    d.media.push_back(
        homogeneous(Box3{Vec3(-20.0f, 0.5f, -20.0f), Vec3(20.0f, 0.5f + kDepth, 20.0f)},
                    Color(kSigmaS), Color(kSigmaA)));
    d.camera.position = Vec3(0.0f, 0.45f, 0.5f);  // below the fog, every pixel sees the plane
    d.camera.look_at = Vec3(0.0f, 0.0f, 0.0f);
    d.camera.width = 16;
    d.camera.height = 12;
    d.render.spp = 2;
    d.render.integrator = Integrator::Photon;  // its direct layer is under test
    d.photons.global = d.photons.caustic = 0;
    d.photons.volume = 0;
    return d;
}

// Lambertian plane under a sun at normal incidence behind the slab: (albedo/π) E e^{−σ_t d}.
double expected_direct() {
    return kAlbedo / 3.14159265358979323846 * kE * std::exp(-(kSigmaS + kSigmaA) * kDepth);
}

TEST(Transmittance, DirectLightThroughHomogeneousFogHasNoVarianceInThePhotonIntegrator) {
    const PipelineResult r = run_pipeline(plane_under_fog(), true);
    const Image& direct = r.film.layer(Layer::Direct);
    for (const Color& c : direct.pixels)
        EXPECT_NEAR(c.x, expected_direct(), 1e-5 * expected_direct());  // every pixel, exactly
}

TEST(Transmittance, DirectLightThroughHomogeneousFogHasNoVarianceInThePathTracer) {
    const auto scene = load_scene(plane_under_fog());
    const PathTracer tracer(*scene, 1);  // the first vertex only: NEE to the sun
    PathTracer::ThreadState ts = tracer.make_state();
    const Ray ray{Vec3(0.2f, 0.3f, 0.1f), glm::normalize(Vec3(0.1f, -1.0f, -0.2f))};
    for (int i = 0; i < 200; ++i) {
        Rng rng(21, i);
        EXPECT_NEAR(tracer.radiance(ray, rng, ts).x, expected_direct(), 1e-5 * expected_direct());
    }
}

// A smooth heterogeneous grid (densities between 0.2 and 1.8 inside, so residual tracking has a
// nonzero control and a residual): the mean of ratio_track equals exp(−τ) with τ integrated by a
// 20000-point midpoint rule of the trilinear density along the ray, within 3 standard errors.
TEST(Transmittance, ResidualRatioTrackingIsUnbiasedInAHeterogeneousGrid) {
    const TempDir dir("fogmap_residual");
    const auto path = dir.path() / "residual.vdb";
    write_float_grid(
        path.string(), "density", 16, 16, 16,
        [](int i, int j, int k) {
            return 1.0f + 0.8f * std::sin(0.7f * i + 0.3f * j) * std::cos(0.5f * k);
        },
        Vec3(0.125f), Vec3(0.0f));
    SceneDesc d;
    d.media.push_back(vdb_medium(path.string(), Color(1.5f, 1.0f, 0.5f), Color(0.5f)));
    const auto scene = load_scene(d);
    std::vector<Medium::Sampler> media;
    for (const Medium& m : scene->media) media.emplace_back(m);
    const Ray ray{Vec3(-0.5f, 0.9f, 1.1f), glm::normalize(Vec3(1.0f, 0.2f, -0.1f))};
    double optical_length = 0.0;  // ∫ density dt
    constexpr int kSteps = 20000;
    const double length = 4.0;
    for (int s = 0; s < kSteps; ++s)
        optical_length +=
            media[0].density(ray.at(float((s + 0.5) * length / kSteps))) * length / kSteps;
    ASSERT_GT(optical_length, 0.5);
    for (int c = 0; c < 3; ++c) {
        const double sigma_t = scene->media[0].sigma_t()[c];
        const MeanEstimate e = estimate_mean(20000, [&](int i) {
            Rng rng(31, i);
            return ratio_track(media, ray, kInfinity, rng)[c];
        });
        EXPECT_NEAR(e.mean, std::exp(-sigma_t * optical_length), 3.0 * e.standard_error + 1e-6)
            << "channel " << c;
    }
}

}  // namespace
}  // namespace fogmap
