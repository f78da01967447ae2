// The photon pass: maps the Plan leaves out are never allocated, results do not depend on the
// thread count, a scene that stores nothing stops at the emission cap with a warning, and the
// caustic map's irradiance on a wall lit through a mirror converges to the analytic E sin θ;
// photon streams partition every light's paths, carrying its power into any sphere.

#include "photon/photon_pass.h"

#include "core/parallel.h"
#include "core/sampling.h"
#include "photon/estimators.h"
#include "photon/streams.h"
#include "render/run_setup.h"
#include "scene_builders.h"

#include <gtest/gtest.h>

#include <cstring>

namespace fogmap {
namespace {

using namespace test;

/// The description with the photon integrator: the photon pass is what these tests are about.
SceneDesc photon(SceneDesc d) {
    d.render.integrator = Integrator::Photon;
    return d;
}

MediumDesc fog_box() {
    return homogeneous(Box3{Vec3(-1.0f), Vec3(1.0f)}, Color(1.0f), Color(0.1f));
}

TEST(PhotonPass, MapsThePlanLeavesOutAreNeverAllocated) {
    SceneDesc d;  // smoke only: a medium under a sun, no surfaces
    d.lights.push_back(sun(Vec3(0.0f, -1.0f, 0.0f), 2.0f));
    d.media.push_back(fog_box());
    d.photons.volume = 1000;
    d.render.integrator = Integrator::Photon;
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
    d.render.integrator = Integrator::Photon;
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

// Photon batches (photon/photon.h): a path's photons share one, so in the order they are stored
// (a path's photons one after another) neighbours agree far more often than the 1/8 of
// independent draws; and the batches split the paths evenly: each holds 1/8 of the photons within
// 6 binomial deviations of the paths they come from (about 2 photons a path in this fog; the
// bound takes 4).
TEST(PhotonPass, APathsPhotonsShareABatchAndBatchesSplitTheMapEvenly) {
    SceneDesc d;
    d.lights.push_back(sun(Vec3(0.3f, -1.0f, 0.1f), 2.0f));
    d.media.push_back(fog_box());
    d.photons.volume = 20000;
    const PhotonPassResult r = trace_photons(*load_scene(photon(d)), make_plan(photon(d)),
                                             d.photons, d.march, d.render.seed, true);
    ASSERT_TRUE(r.volume.has_value());
    const std::vector<Photon>& photons = r.volume->photons;
    std::array<double, Photon::kBatches> count{};
    size_t same = 0;
    for (size_t i = 0; i < photons.size(); ++i) {
        count[size_t(photons[i].batch())] += 1.0;
        if (i > 0 && photons[i].batch() == photons[i - 1].batch()) ++same;
    }
    const double n = double(photons.size()), paths = n / 4.0;
    std::printf("%.0f photons, %llu paths emitted, neighbours in one batch %.3f\n", n,
                (unsigned long long)r.emitted, double(same) / n);
    EXPECT_GT(double(same) / n, 0.5);
    for (double c : count)
        EXPECT_NEAR(c / n, 1.0 / Photon::kBatches, 6.0 * std::sqrt(0.125 * 0.875 / paths));
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
    const PhotonPassResult r = trace_photons(*load_scene(d), make_plan(photon(d)), d.photons,
                                             d.march, d.render.seed, true);
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
    const PhotonPassResult r = trace_photons(*load_scene(d), make_plan(photon(d)), d.photons,
                                             d.march, d.render.seed, true);
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

// Σ over a map's photons of their power (W).
double map_power(const StoredPhotons& map) {
    double sum = 0.0;
    for (const Photon& p : map.photons) sum += average(p.power());
    return sum * map.photon_power;
}

// A sun over a 10 km ground and a 2 × 2 × 2 box of smoke standing on it.
SceneDesc box_over_a_wide_ground(const Color& sigma_s, const Color& sigma_a) {
    SceneDesc d;
    d.lights.push_back(sun(Vec3(0.3f, -1.0f, 0.2f), 2.0f));
    add_ground(&d, 0.0f, 5000.0f, 0.5f);
    d.media.push_back(
        homogeneous(Box3{Vec3(-1.0f, 0.0f, -1.0f), Vec3(1.0f, 2.0f, 1.0f)}, sigma_s, sigma_a));
    return d;
}

// A dense smoke box (optical thickness 10, albedo 0.95) over a 10 km ground under a sun: the
// ground's indirect light (what the box scatters down) carries little of the volume map's power, so
// the global map closes when the volume map is full, below its budget, without a "not filled"
// warning, and stays unbiased: its total power agrees with that of a pass whose small global budget
// fills first.
TEST(PhotonPass, GlobalMapCarryingLittlePowerClosesWithTheVolumeMap) {
    SceneDesc d = box_over_a_wide_ground(Color(5.0f), Color(0.25f));
    d.photons.caustic = 0;
    d.photons.volume = 200000;
    d.photons.global = 1000000;
    const auto scene = load_scene(d);
    const PhotonPassResult r =
        trace_photons(*scene, make_plan(photon(d)), d.photons, d.march, d.render.seed, true);
    ASSERT_TRUE(r.global && r.volume);
    EXPECT_LT(r.global->photons.size(), 1000000u);
    EXPECT_NE(r.global->stopped.find("closed with the volume map"), std::string::npos);
    EXPECT_TRUE(r.warnings.empty()) << r.warnings.front();

    d.photons.global = 10000;  // fills before the volume map
    const PhotonPassResult full =
        trace_photons(*scene, make_plan(photon(d)), d.photons, d.march, d.render.seed + 1, true);
    ASSERT_TRUE(full.global);
    EXPECT_GE(full.global->photons.size(), 10000u);
    EXPECT_TRUE(full.global->stopped.empty());
    // 10 000 and 15 000 photons: relative standard errors of 1-2% on the totals (measured 1.2%
    // apart); weights from the attempts at the wrong moment would be off by their ratio.
    EXPECT_NEAR(map_power(*r.global), map_power(*full.global), 0.06 * map_power(*full.global));
}

// Camera paths ending in the volume map (only that map is planned): it closes at
// photons.volume_attempts attempts below its budget, says so instead of warning, and stays
// unbiased — its total power agrees with that of a pass whose small budget fills first.
TEST(PhotonPass, VolumeMapAloneClosesAtItsAttempts) {
    SceneDesc d = box_over_a_wide_ground(Color(1.0f), Color(0.1f));
    d.volume.gather_depth = 3;
    d.photons.volume = 1000000;
    PhotonSettings settings = d.photons;
    settings.volume_attempts = 40000;
    const auto scene = load_scene(d);
    const PhotonPassResult r =
        trace_photons(*scene, make_plan(photon(d)), settings, d.march, d.render.seed, true);
    ASSERT_TRUE(r.volume);
    EXPECT_FALSE(r.global || r.caustic);
    EXPECT_EQ(r.emitted, 40000u);
    EXPECT_GT(r.volume->photons.size(), 5000u);
    EXPECT_EQ(r.volume->stopped,
              "closed after 40000 attempts (0.25 per camera sample, at least its budget)");
    EXPECT_TRUE(r.warnings.empty()) << r.warnings.front();

    settings.volume = 5000;  // fills first
    const PhotonPassResult full =
        trace_photons(*scene, make_plan(photon(d)), settings, d.march, d.render.seed + 1, true);
    ASSERT_TRUE(full.volume);
    EXPECT_LT(full.emitted, 40000u);
    EXPECT_TRUE(full.volume->stopped.empty());
    EXPECT_NEAR(map_power(*r.volume), map_power(*full.volume), 0.06 * map_power(*full.volume));
}

// A closed room with a point light and a thin fog: the walls' interreflected light carries more
// power than the fog scatters, so the global map fills its budget although the volume map (a
// small budget) is full first.
TEST(PhotonPass, GlobalMapCarryingMostOfTheLightFillsItsBudget) {
    SceneDesc d;
    d.lights.push_back(point_light(Vec3(0.2f, 1.5f, 0.1f), 4.0f));
    d.materials["wall"] = MaterialDesc{MaterialType::Diffuse, Color(0.7f), 1.5f};
    ShapeDesc room;
    room.type = ShapeType::Box;
    room.min = Vec3(-1.0f, 0.0f, -1.0f);
    room.max = Vec3(1.0f, 2.0f, 1.0f);
    room.material = "wall";
    d.shapes.push_back(room);
    d.media.push_back(homogeneous(Box3{Vec3(-1.0f, 0.0f, -1.0f), Vec3(1.0f, 2.0f, 1.0f)},
                                  Color(0.02f), Color(0.002f)));
    d.photons.caustic = 0;
    d.photons.volume = 500;
    d.photons.global = 20000;
    const PhotonPassResult r = trace_photons(*load_scene(d), make_plan(photon(d)), d.photons,
                                             d.march, d.render.seed, true);
    ASSERT_TRUE(r.global && r.volume);
    EXPECT_GE(r.global->photons.size(), 20000u);
    EXPECT_TRUE(r.global->stopped.empty()) << r.global->stopped;
}

// A sun at 45° over a mirror floor; the reflected beam lights a vertical diffuse wall (normal −x)
// with irradiance E · cos(angle to the wall normal) = E sin θ. Only L S D photons reach the
// caustic map, so its disc estimate (fixed radius, k unbounded) must converge to E sin θ.
// Photon batches (photon/estimators.h, BatchSums): a fixed-radius disc estimate times a batch's
// share is the estimate from a map of that batch's photons alone at 8 times their power, with the
// box filter and the cone filter (whose weights the shares must carry).
TEST(SurfaceEstimate, ABatchsShareOfTheDiscEstimateIsTheEstimateOfItsPhotonsAlone) {
    Rng rng(23, 7);
    std::vector<Photon> all, alone;
    const int batch = 3;
    for (int i = 0; i < 20000; ++i) {
        const Vec3 p(2.0f * rng.uniform() - 1.0f, 2.0f * rng.uniform() - 1.0f, 0.0f);
        Photon photon(p, Vec3(0.0f, 0.0f, 1.0f), Color(0.5f + rng.uniform()));
        photon.set_batch(int(rng.uniform() * Photon::kBatches));
        all.push_back(photon);
        if (photon.batch() == batch) alone.push_back(photon);
    }
    PhotonMap map_all, map_alone;
    map_all.tree = KdTree<Photon>(std::move(all));
    map_all.photon_power = 0.01f;
    map_alone.tree = KdTree<Photon>(std::move(alone));
    map_alone.photon_power = 0.01f * Photon::kBatches;
    NeighborList scratch;
    for (const float cone : {0.0f, 1.1f})
        for (int i = 0; i < 10; ++i) {
            const Vec3 x(rng.uniform() - 0.5f, rng.uniform() - 0.5f, 0.0f), n(0.0f, 0.0f, 1.0f);
            BatchSums sums;
            const Color whole = surface_irradiance(map_all, x, n, 0, 0.2f, cone, 0, scratch, &sums);
            const Color expected = surface_irradiance(map_alone, x, n, 0, 0.2f, cone, 0, scratch);
            for (int c = 0; c < 3; ++c)
                EXPECT_NEAR(whole[c] * sums.shares()[batch], expected[c], 1e-4f * expected[c])
                    << "cone " << cone << ", lookup " << i;
        }
}

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
            trace_photons(*scene, make_plan(photon(d)), d.photons, d.march, d.render.seed, true));
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

// Power carried into a test sphere by every stream of `light`: Σ_s Σ_attempts [photon and its
// first segment enters the sphere] × Φ_s / N_s, with its standard error (streams independent).
struct Flux {
    double mean, standard_error;
};

// Whether a ray's first segment enters a sphere, from the cross product in double (independent
// of streams.cpp's meets_sphere, which the streams themselves use).
bool enters_sphere(const Ray& ray, const Vec3& centre, float radius) {
    const glm::dvec3 oc = glm::dvec3(centre) - glm::dvec3(ray.o), d = glm::dvec3(ray.d);
    const double r2 = double(radius) * radius;
    if (glm::dot(oc, oc) <= r2) return true;
    const glm::dvec3 c = glm::cross(oc, d);
    return glm::dot(oc, d) > 0.0 && glm::dot(c, c) < r2 * glm::dot(d, d);
}

Flux flux_into_sphere(const StreamSet& set, const Scene& scene, int light, const Vec3& centre,
                      float radius, int n) {
    double mean = 0.0, var = 0.0;
    for (size_t s = 0; s < set.streams.size(); ++s) {
        if (set.streams[s].light != light) continue;
        const double w = set.streams[s].region_power;
        double sum = 0.0, sum2 = 0.0;
        for (int i = 0; i < n; ++i) {
            Rng rng(11, i, set.streams[s].key);
            Ray ray;
            if (!sample_stream(set, static_cast<int>(s), scene, rng, &ray)) continue;
            const double v = enters_sphere(ray, centre, radius) ? w : 0.0;
            sum += v;
            sum2 += v * v;
        }
        const double m = sum / n;
        mean += m;
        var += std::max(0.0, sum2 / n - m * m) / n;
    }
    return {mean, std::sqrt(var)};
}

// Streams partition each light's paths (by the first target sphere they meet: a glass sphere,
// the media, the ground around the media, the rest), each sampling its own region; the power they
// carry together into any sphere must equal the light's, whether the sphere lies inside a target,
// far outside all, or across their edges: E π r² for a sun, 4π² r² L for a sky, I Ω for a point
// light (Ω the solid angle of the sphere), and for a spot I times its falloff integrated over Ω
// (midpoint rule here). Over a 16 m floor and over a 10 km one, whose photons start kilometres
// away (where a stream's test of the earlier targets once lost all precision and counted paths
// twice).
void check_partition(float floor_size) {
    const SceneDesc d = four_lights_ball_and_fog(0.0f, 0.5f * floor_size);
    const auto scene = load_scene(d);
    const StreamSet set = make_streams(*scene, true, true);
    ASSERT_EQ(set.targets.size(), 3u);  // specular, media, near media
    const std::vector<std::pair<Vec3, float>> spheres{{Vec3(0.0f, 0.2f, 0.0f), 0.5f},
                                                      {Vec3(5.0f, 1.0f, 4.0f), 1.5f},
                                                      {Vec3(1.5f, 1.0f, 0.5f), 1.0f},
                                                      {Vec3(2.0f, 0.8f, -2.0f), 0.7f}};
    const Light& pl = scene->lights[2];
    const Light& sl = scene->lights[3];
    for (const auto& [centre, radius] : spheres) {
        // Beside a 10 km floor the rest stream's disc is 10⁷ times the far sphere's cross-section:
        // too few of its photons reach that sphere to measure here.
        if (floor_size > 100.0f && centre.x == 5.0f) continue;
        const double r2 = double(radius) * radius;
        const double dist = glm::length(centre - pl.position);
        const double omega = 2.0 * kPi * (1.0 - std::sqrt(1.0 - r2 / (dist * dist)));
        // The spot's falloff over the sphere's cone: a 200 × 200 midpoint rule in (cos, φ).
        const Vec3 axis = glm::normalize(centre - sl.position);
        const double cos_max =
            std::sqrt(1.0 - r2 / glm::dot(centre - sl.position, centre - sl.position));
        double spot_sum = 0.0;
        const double outer = std::cos(35.0 * kPi / 180.0), inner = std::cos(25.0 * kPi / 180.0);
        for (int a = 0; a < 200; ++a)
            for (int b = 0; b < 200; ++b) {
                const double c = 1.0 - (a + 0.5) / 200.0 * (1.0 - cos_max);
                const double sn = std::sqrt(1.0 - c * c), phi = 2.0 * kPi * (b + 0.5) / 200.0;
                const Vec3 dir = to_world(
                    Vec3(float(sn * std::cos(phi)), float(sn * std::sin(phi)), float(c)), axis);
                const double t = std::clamp(
                    (glm::dot(glm::normalize(dir), sl.direction) - outer) / (inner - outer), 0.0,
                    1.0);
                spot_sum += t * t * (3.0 - 2.0 * t);
            }
        const double spot_expected = 3.0 * spot_sum / 40000.0 * 2.0 * kPi * (1.0 - cos_max);
        const double expected[4] = {2.0 * kPi * r2, 4.0 * kPi * kPi * r2 * 0.5, 4.0 * omega,
                                    spot_expected};
        for (int l = 0; l < 4; ++l) {
            const Flux f = flux_into_sphere(set, *scene, l, centre, radius, 200000);
            EXPECT_NEAR(f.mean, expected[l], 4.0 * f.standard_error + 1e-9)
                << "floor " << floor_size << ", light " << l << ", sphere at " << centre.x << " "
                << centre.y;
        }
    }
}

TEST(PhotonStreams, PartitionCarriesEachLightsPowerIntoAnySphere) { check_partition(16.0f); }

TEST(PhotonStreams, PartitionHoldsOverATenKilometreGround) { check_partition(10000.0f); }

// The light a wide ground reflects into a medium: a thin box (optical thickness 0.005) 1 m over a
// 10 km Lambertian ground under a sun. What the volume map holds is ∫ σ_s φ dV over its stored
// (not first) scatterings, here the ground's light to O(τ): σ_s V 2π L_g, L_g = ρ E cos θ / π the
// ground's radiance seen from below. Before the bounce stream, the rest stream carried that light
// in photons of 10⁵× the power of the others, and a 100 000-photon map held a few or none.
TEST(PhotonStreams, GroundLightReachesAThinMediumThroughTheBounceStream) {
    SceneDesc d;
    const Vec3 dir(0.3f, -1.0f, 0.2f);
    const float E = 2.0f, albedo = 0.5f, sigma_s = 0.005f;
    d.lights.push_back(sun(dir, E));
    add_ground(&d, 0.0f, 5000.0f, albedo);
    d.media.push_back(homogeneous(Box3{Vec3(-0.5f, 1.0f, -0.5f), Vec3(0.5f, 2.0f, 0.5f)},
                                  Color(sigma_s), Color(0.0f)));
    d.photons.global = d.photons.caustic = 0;
    d.photons.volume = 100000;
    const PhotonPassResult r = trace_photons(*load_scene(d), make_plan(photon(d)), d.photons,
                                             d.march, d.render.seed, true);
    ASSERT_TRUE(r.volume);
    double total = 0.0;
    for (const Photon& p : r.volume->photons) total += average(p.power());
    total *= r.volume->photon_power;
    const double cos_theta = 1.0 / glm::length(dir);
    const double expected = sigma_s * 1.0 * 2.0 * kPi * (albedo * E * cos_theta / kPi);
    EXPECT_NEAR(total, expected, 0.03 * expected);
}

// meets_sphere from 7 km away: lines passing at 0.95 and 1.05 radii from a unit-scale target.
TEST(PhotonStreams, MeetsSphereKeepsItsPrecisionKilometresAway) {
    const Vec3 centre(0.3f, 1.4f, -0.2f);
    const float radius = 1.7f;
    Rng rng(3, 0, 0);
    for (int i = 0; i < 1000; ++i) {
        const Vec3 d = sample_uniform_sphere(Vec2(rng.uniform(), rng.uniform()));
        const Vec3 side =
            glm::normalize(glm::cross(d, std::abs(d.y) < 0.9f ? Vec3(0, 1, 0) : Vec3(1, 0, 0)));
        for (const float f : {0.95f, 1.05f}) {
            const Ray ray{centre + f * radius * side - 7000.0f * d, d};
            EXPECT_EQ(meets_sphere(ray, centre, radius), f < 1.0f) << i << " at " << f;
        }
    }
}

// A stream aimed at the media puts more of its photons into them than the light's plain emission
// would: of the sun's photons into the medium's sphere, the media stream's share is above 90%,
// its region a fraction of the scene's.
TEST(PhotonStreams, MediaStreamAimsAtTheMedia) {
    SceneDesc d;
    d.lights.push_back(sun(Vec3(-0.4f, -1.0f, -0.3f), 2.0f));
    add_ground(&d, -1.0f, 50.0f, 0.5f);
    d.media.push_back(fog_box());
    const auto scene = load_scene(d);
    const StreamSet set = make_streams(*scene, false, true);
    ASSERT_EQ(set.streams.size(), 4u);  // media, near media, rest; the ground's bounce
    EXPECT_EQ(set.bounce, 3);
    EXPECT_EQ(set.streams[0].target, 0);
    int hits = 0;
    for (int i = 0; i < 1000; ++i) {
        Rng rng(5, i, set.streams[0].key);
        Ray ray;
        ASSERT_TRUE(sample_stream(set, 0, *scene, rng, &ray));
        hits += meets_sphere(ray, Vec3(0.0f), std::sqrt(3.0f)) ? 1 : 0;
    }
    EXPECT_EQ(hits, 1000);
    EXPECT_LT(set.streams[0].region_power, 0.01 * set.streams[2].region_power);
}

}  // namespace
}  // namespace fogmap
