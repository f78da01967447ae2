// The photon pass: maps the Plan leaves out are never allocated, results do not depend on the
// thread count, a scene that stores nothing stops at the emission cap with a warning, and the
// caustic map's irradiance on a wall lit through a mirror converges to the analytic E sin θ,
// and photons focused on the media carry the power that crosses any sphere (E π r², 4π² r² L).

#include "photon/photon_pass.h"

#include "core/parallel.h"
#include "photon/estimators.h"
#include "scene_builders.h"

#include <gtest/gtest.h>

#include <cstring>

namespace fogmap {
namespace {

using namespace test;

MediumDesc fog_box() {
    return homogeneous(Box3{Vec3(-1.0f), Vec3(1.0f)}, Color(1.0f), Color(0.1f));
}

TEST(PhotonPass, MapsThePlanLeavesOutAreNeverAllocated) {
    SceneDesc d;  // smoke only: a medium under a sun, no surfaces
    d.lights.push_back(sun(Vec3(0.0f, -1.0f, 0.0f), 2.0f));
    d.media.push_back(fog_box());
    d.photons.volume = 1000;
    const Plan plan = make_plan(d);
    const auto scene = load_scene(d);
    ASSERT_FALSE(plan.global_map.on);
    ASSERT_FALSE(plan.caustic_map.on);
    EXPECT_EQ(scene->surfaces, nullptr);  // no Embree scene either
    const PhotonPassResult r = trace_photons(*scene, plan, d.photons, d.march, d.render.seed, true);
    EXPECT_FALSE(r.global.has_value());
    EXPECT_FALSE(r.caustic.has_value());
    ASSERT_TRUE(r.volume.has_value());
    EXPECT_GE(r.volume->photons.size(), 1000u);

    d.photons.volume = 0;  // budget 0: the plan turns the map off and nothing is traced
    const Plan off = make_plan(d);
    EXPECT_FALSE(off.volume_map.on);
    const PhotonPassResult none =
        trace_photons(*load_scene(d), off, d.photons, d.march, d.render.seed, true);
    EXPECT_FALSE(none.volume.has_value());
    EXPECT_EQ(none.emitted, 0u);
}

TEST(PhotonPass, OneAndTwoThreadsStoreIdenticalPhotons) {
    SceneDesc d;
    d.lights.push_back(sun(Vec3(0.3f, -1.0f, 0.1f), 2.0f));
    d.materials["floor"] = MaterialDesc{};
    d.shapes.push_back(
        quad(Vec3(-3.0f, -1.0f, -3.0f), Vec3(0.0f, 0.0f, 6.0f), Vec3(6.0f, 0.0f, 0.0f), "floor"));
    d.media.push_back(fog_box());
    d.photons.volume = 20000;
    d.photons.global = 5000;
    const auto scene = load_scene(d);
    const Plan plan = make_plan(d);
    PhotonPassResult one, two;
    {
        const ThreadLimit limit(1);
        one = trace_photons(*scene, plan, d.photons, d.march, d.render.seed, true);
    }
    {
        const ThreadLimit limit(2);
        two = trace_photons(*scene, plan, d.photons, d.march, d.render.seed, true);
    }
    for (auto [a, b] : {std::pair{&one.volume, &two.volume}, std::pair{&one.global, &two.global}}) {
        ASSERT_TRUE(a->has_value() && b->has_value());
        ASSERT_EQ((*a)->photons.size(), (*b)->photons.size());
        EXPECT_EQ(0, std::memcmp((*a)->photons.data(), (*b)->photons.data(),
                                 (*a)->photons.size() * sizeof(Photon)));
        EXPECT_EQ((*a)->emitted, (*b)->emitted);
    }
}

TEST(PhotonPass, SceneThatStoresNothingStopsAtTheCapWithAWarning) {
    // A sun over a lone floor: every photon's first hit is direct light (not stored) and the
    // bounce escapes to the sky, so the global map never fills.
    SceneDesc d;
    d.lights.push_back(sun(Vec3(0.0f, -1.0f, 0.0f), 1.0f));
    d.materials["floor"] = MaterialDesc{};
    d.shapes.push_back(
        quad(Vec3(-1.0f, 0.0f, -1.0f), Vec3(0.0f, 0.0f, 2.0f), Vec3(2.0f, 0.0f, 0.0f), "floor"));
    d.photons.global = 100;
    d.photons.max_emitted = 50000;
    const PhotonPassResult r =
        trace_photons(*load_scene(d), make_plan(d), d.photons, d.march, d.render.seed, true);
    EXPECT_EQ(r.emitted, 50000u);
    ASSERT_TRUE(r.global.has_value());
    EXPECT_EQ(r.global->photons.size(), 0u);
    ASSERT_EQ(r.warnings.size(), 1u);
    EXPECT_NE(r.warnings[0].find("global map: 0 of 100"), std::string::npos) << r.warnings[0];
}

TEST(PhotonPass, BounceCapCountsEveryPathItCuts) {
    // A point light at the centre of an albedo-1 cube [-1, 1]^3 and max_bounces = 1: a photon is
    // cut iff it scatters before leaving, with probability 1 − e^{−σ d(ω)} for the distance d(ω)
    // to the cube's surface along its direction; averaged here over a Fibonacci sphere of
    // directions. Albedo 1 keeps every cut photon's power at 1.
    const float sigma = 0.7f;
    SceneDesc d;
    LightDesc point;
    point.type = LightType::Point;
    point.position = Vec3(0.0f);
    point.intensity = Color(1.0f);
    d.lights.push_back(point);
    MediumDesc m = fog_box();
    m.sigma_s = Color(sigma);
    m.sigma_a = Color(0.0f);
    d.media.push_back(m);
    d.photons.global = d.photons.caustic = 0;
    d.photons.volume = 1;  // never stored (max_bounces 1 ends paths first): runs to the cap
    d.photons.max_bounces = 1;
    d.photons.max_emitted = 200000;
    d.march.method = FreePathMethod::Delta;
    const PhotonPassResult r =
        trace_photons(*load_scene(d), make_plan(d), d.photons, d.march, d.render.seed, true);
    ASSERT_EQ(r.emitted, 200000u);
    double expected = 0.0;
    const int n = 200000;
    for (int i = 0; i < n; ++i) {
        const double z = 1.0 - (2.0 * i + 1.0) / n, phi = i * 2.399963229728653;
        const double s = std::sqrt(1.0 - z * z);
        const double dir[3] = {s * std::cos(phi), s * std::sin(phi), z};
        double t = 1e30;
        for (double c : dir)
            if (c != 0.0) t = std::min(t, 1.0 / std::abs(c));
        expected += 1.0 - std::exp(-sigma * t);
    }
    expected /= n;
    const double fraction = double(r.capped) / double(r.emitted);
    const double se = std::sqrt(expected * (1.0 - expected) / double(r.emitted));
    EXPECT_NEAR(fraction, expected, 4.0 * se);
    EXPECT_NEAR(r.capped_power, fraction, 1e-6);  // each cut photon still carries its power 1
    bool warned = false;
    for (const std::string& w : r.warnings) warned |= w.find("photons.max_bounces = 1") == 0;
    EXPECT_TRUE(warned);
}

// A sun at 45° over a mirror floor; the reflected beam lights a vertical diffuse wall (normal −x)
// with irradiance E · cos(angle to the wall normal) = E sin θ. Only L S D photons reach the
// caustic map, so its disc estimate (fixed radius, k unbounded) must converge to E sin θ.
TEST(SurfaceEstimate, CausticIrradianceThroughAMirrorConvergesToAnalytic) {
    const float theta = 45.0f * kPi / 180.0f, E = 2.0f, r = 1.0f;
    SceneDesc d;
    d.lights.push_back(sun(Vec3(std::sin(theta), -std::cos(theta), 0.0f), E));
    d.materials["mirror"] = MaterialDesc{MaterialType::Mirror, Color(1.0f), 1.5f};
    d.materials["wall"] = MaterialDesc{MaterialType::Diffuse, Color(0.5f), 1.5f};
    d.shapes.push_back(quad(Vec3(-20.0f, 0.0f, -10.0f), Vec3(0.0f, 0.0f, 20.0f),
                            Vec3(25.0f, 0.0f, 0.0f), "mirror"));
    d.shapes.push_back(
        quad(Vec3(5.0f, 0.0f, -10.0f), Vec3(0.0f, 0.0f, 20.0f), Vec3(0.0f, 10.0f, 0.0f), "wall"));
    d.photons.global = 0;
    const double expected = E * std::sin(theta);
    double previous_error = 1e30;
    for (uint64_t n : {4000u, 16000u, 64000u}) {
        d.photons.caustic = n;
        const auto scene = load_scene(d);
        PhotonMaps maps = build_trees(
            trace_photons(*scene, make_plan(d), d.photons, d.march, d.render.seed, true));
        ASSERT_TRUE(maps.caustic.has_value());
        NeighborList scratch;
        double error = 0.0, sum = 0.0;
        int count = 0;
        for (float y : {3.0f, 5.0f, 7.0f}) {
            for (float z : {-4.0f, 0.0f, 4.0f}) {
                const Vec3 x(5.0f, y, z);
                const Color e = surface_irradiance(*maps.caustic, x, Vec3(-1.0f, 0.0f, 0.0f),
                                                   1 << 30, r, 0.0f, 0, scratch);
                error += std::abs(e.x - expected);
                sum += e.x;
                count += static_cast<int>(scratch.size());
            }
        }
        error /= 9.0;
        // Fixed seed; 4x the photons halves the expected (Poisson) error.
        EXPECT_LT(error, previous_error) << n << " photons";
        previous_error = error;
        if (n == 64000u) {
            // Poisson: the relative standard error of the mean is 1/sqrt(photons counted).
            const double se = expected / std::sqrt(static_cast<double>(count));
            EXPECT_NEAR(sum / 9.0, expected, 3.0 * se) << count << " photons in the discs";
        }
    }
}

// Power carried into a test sphere by n photons of `light`, with and without a focus:
// Σ weight × [the ray enters the sphere] × Φ / n, with its standard error.
struct Flux {
    double mean, standard_error;
};

Flux flux_into_sphere(const Light& light, const Box3& scene, const PhotonFocus* focus,
                      const Vec3& centre, float radius, int n) {
    const double power = average(light_power(light, scene));
    double sum = 0.0, sum2 = 0.0;
    for (int i = 0; i < n; ++i) {
        Rng rng(11, i);
        Ray ray;
        float weight = 0.0f;
        if (!sample_photon(light, scene, focus, rng, &ray, &weight)) continue;
        const Vec3 oc = centre - ray.o;
        const float along = glm::dot(oc, ray.d);
        const bool hits = along > 0.0f && glm::dot(oc, oc) - along * along < radius * radius;
        const double v = hits ? weight * power : 0.0;
        sum += v;
        sum2 += v * v;
    }
    const double mean = sum / n;
    return {mean, std::sqrt(std::max(0.0, sum2 / n - mean * mean) / n)};
}

TEST(PhotonFocus, FocusedSunAndSkyPhotonsCarryTheRightPowerEverywhere) {
    const Box3 scene{Vec3(-8.0f, 0.0f, -8.0f), Vec3(8.0f, 4.0f, 8.0f)};
    PhotonFocus focus;
    focus.bounds = Box3{Vec3(-1.0f, 0.5f, -1.0f), Vec3(1.0f, 2.5f, 1.0f)};
    Light sunlight = make_light(sun(Vec3(-0.4f, -1.0f, -0.3f), 2.0f));
    LightDesc sky_desc;
    sky_desc.type = LightType::Environment;
    sky_desc.radiance = Color(0.5f);
    const Light sky = make_light(sky_desc);
    // Test spheres inside the focus, far outside it, and across its edge.
    const std::vector<std::pair<Vec3, float>> spheres{{Vec3(0.0f, 1.5f, 0.0f), 0.5f},
                                                      {Vec3(5.0f, 1.0f, 4.0f), 2.0f},
                                                      {Vec3(1.5f, 1.5f, 0.5f), 1.0f}};
    for (const auto& [centre, radius] : spheres) {
        const double sun_expected = 2.0 * kPi * radius * radius;
        const double sky_expected = 4.0 * kPi * kPi * radius * radius * 0.5;
        for (const PhotonFocus* f :
             {static_cast<const PhotonFocus*>(nullptr), static_cast<const PhotonFocus*>(&focus)}) {
            const Flux a = flux_into_sphere(sunlight, scene, f, centre, radius, 1000000);
            EXPECT_NEAR(a.mean, sun_expected, 4.0 * a.standard_error)
                << "sun, sphere at x " << centre.x << (f ? ", focused" : "");
            const Flux b = flux_into_sphere(sky, scene, f, centre, radius, 1000000);
            EXPECT_NEAR(b.mean, sky_expected, 4.0 * b.standard_error)
                << "sky, sphere at x " << centre.x << (f ? ", focused" : "");
        }
    }
    // The focus puts more photons into its own sphere: a lower standard error there.
    const Flux plain =
        flux_into_sphere(sunlight, scene, nullptr, Vec3(0.0f, 1.5f, 0.0f), 0.5f, 100000);
    const Flux focused =
        flux_into_sphere(sunlight, scene, &focus, Vec3(0.0f, 1.5f, 0.0f), 0.5f, 100000);
    EXPECT_LT(focused.standard_error, 0.5 * plain.standard_error);
}

}  // namespace
}  // namespace fogmap
