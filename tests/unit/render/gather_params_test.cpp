// Gather parameters (render/gather_params.h) against values worked out here: progressive radii
// against the product r_i^d = r_1^d Π_{j=1}^{i-1} (j + α)/(j + 1) multiplied out by a loop, later
// iterations shrinking fixed radii (by a 2D kernel for surfaces and photon beams, 3D for
// volume points), the default radii as 2% / 1% of the scene's diagonal and 5% of the media's for a
// scene whose bounds are known by hand, the progressive radius from the first maps as the
// median distance to the k-th nearest photon on a lattice where that distance is the spacing,
// and k-nearest gathers (k shrinking as the radius's power) where two lattices spread those
// distances 100-fold.

#include "render/gather_params.h"

#include "scene_builders.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

namespace fogmap {
namespace {

/// r_1 (Π_{j=1}^{i-1} (j + α)/(j + 1))^(1/d), the product multiplied out term by term.
double product_radius(double r1, int i, double alpha, int d) {
    double product = 1.0;
    for (int j = 1; j < i; ++j) product *= (j + alpha) / (j + 1.0);
    return r1 * std::pow(product, 1.0 / d);
}

TEST(ProgressiveRadius, MatchesTheProductFormulaIn2DAnd3D) {
    for (int d : {2, 3})
        for (float alpha : {0.5f, 2.0f / 3.0f, 0.9f})
            for (int i : {1, 2, 3, 10, 100, 1000, 100000}) {
                const double want = product_radius(0.25, i, alpha, d);
                EXPECT_NEAR(progressive_radius(0.25f, i, alpha, d), want, 2e-6 * want)
                    << "d " << d << ", alpha " << alpha << ", iteration " << i;
            }
}

TEST(ProgressiveRadius, FirstIterationKeepsTheRadiusAndEachStepShrinksItsPower) {
    const float alpha = 0.7f;
    EXPECT_FLOAT_EQ(progressive_radius(1.5f, 1, alpha, 3), 1.5f);
    // Knaus & Zwicker: r_{i+1}^d / r_i^d = (i + α)/(i + 1).
    for (int d : {2, 3})
        for (int i = 1; i < 50; ++i) {
            const double ratio = std::pow(double(progressive_radius(1.0f, i + 1, alpha, d)) /
                                              progressive_radius(1.0f, i, alpha, d),
                                          d);
            EXPECT_NEAR(ratio, (i + alpha) / (i + 1.0), 1e-5) << "d " << d << ", i " << i;
        }
}

GatherParams fixed_and_knn(VolumeEstimator estimator) {
    GatherParams p;
    p.global = {100, 0.4f, true};
    p.caustic = {50, 0.2f, false};
    p.volume = {30, 0.8f, true};
    p.estimator = estimator;
    p.final_gather = true;
    p.gather_rays = 7;
    p.cone_filter = 1.5f;
    p.lookups_per_ray = 3;
    p.light_samples = 5;
    p.gather_depth = 2;
    return p;
}

TEST(GatherAtIteration, ShrinksFixedRadiiOnlyBySurfaceAndVolumeDimensions) {
    const float alpha = 2.0f / 3.0f;
    const int i = 17;
    const GatherParams first = fixed_and_knn(VolumeEstimator::Sphere);
    const GatherParams p = gather_at_iteration(first, i, alpha);
    EXPECT_NEAR(p.global.radius, product_radius(0.4, i, alpha, 2), 1e-6);
    EXPECT_EQ(p.caustic.radius, 0.2f);  // k-NN: unchanged
    EXPECT_NEAR(p.volume.radius, product_radius(0.8, i, alpha, 3), 1e-6);
    for (auto [a, b] : {std::pair{&p.global, &first.global}, std::pair{&p.caustic, &first.caustic},
                        std::pair{&p.volume, &first.volume}}) {
        EXPECT_EQ(a->k, b->k);
        EXPECT_EQ(a->fixed_radius, b->fixed_radius);
    }
    EXPECT_EQ(p.final_gather, first.final_gather);
    EXPECT_EQ(p.gather_rays, first.gather_rays);
    EXPECT_EQ(p.cone_filter, first.cone_filter);
    EXPECT_EQ(p.estimator, first.estimator);
    EXPECT_EQ(p.lookups_per_ray, first.lookups_per_ray);
    EXPECT_EQ(p.light_samples, first.light_samples);
    EXPECT_EQ(p.gather_depth, first.gather_depth);
    // Iteration 1 is iteration 1's gather.
    EXPECT_EQ(gather_at_iteration(first, 1, alpha).volume.radius, first.volume.radius);
}

TEST(GatherAtIteration, NearestGathersOfAProgressiveRunShrinkTheirKWithTheRadiusPower) {
    // k_i = k (r_i / r_1)^d = k Π_{j<i} (j + α)/(j + 1), rounded, at least 1.
    const float alpha = 2.0f / 3.0f;
    GatherParams first = fixed_and_knn(VolumeEstimator::Sphere);
    first.global = {100, 0.4f, false, true};
    first.volume = {50, 0.8f, false, true};
    for (int i : {1, 2, 17, 100000, 20000000}) {
        const GatherParams p = gather_at_iteration(first, i, alpha);
        const double surface = std::pow(product_radius(1.0, i, alpha, 2), 2.0);
        const double volume = std::pow(product_radius(1.0, i, alpha, 3), 3.0);
        EXPECT_NEAR(p.global.radius, product_radius(0.4, i, alpha, 2), 1e-6) << i;
        EXPECT_NEAR(p.volume.radius, product_radius(0.8, i, alpha, 3), 1e-6) << i;
        EXPECT_EQ(p.global.k, std::max(1, int(std::lround(100.0 * surface)))) << i;
        EXPECT_EQ(p.volume.k, std::max(1, int(std::lround(50.0 * volume)))) << i;
        EXPECT_FALSE(p.global.fixed_radius || p.volume.fixed_radius);
        EXPECT_EQ(p.caustic.k, 50);  // k-NN without shrink_k: as it was
        EXPECT_EQ(p.caustic.radius, 0.2f);
    }
    EXPECT_EQ(gather_at_iteration(first, 17, alpha).global.k, 43);  // 100 · 0.428…
    // 100 · 0.0041 rounds to 0: at least 1.
    EXPECT_EQ(gather_at_iteration(first, 20000000, alpha).global.k, 1);
}

TEST(GatherAtIteration, PhotonBeamsShrinkAsA2DKernel) {
    const float alpha = 0.5f;
    const int i = 40;
    const GatherParams p =
        gather_at_iteration(fixed_and_knn(VolumeEstimator::PhotonBeams), i, alpha);
    EXPECT_NEAR(p.volume.radius, product_radius(0.8, i, alpha, 2), 1e-6);
    const GatherParams beam = gather_at_iteration(fixed_and_knn(VolumeEstimator::Beam), i, alpha);
    EXPECT_NEAR(beam.volume.radius, product_radius(0.8, i, alpha, 3), 1e-6);
}

// A ground square x, z in [-2, 2] at y = 0, a fog box [-1, 0, -1]..[1, 1, 1] and the camera at
// (0, 1, 5): bounds [-2, 0, -2]..[2, 1, 5], diagonal sqrt(4² + 1² + 7²) = sqrt(66); the media's
// diagonal sqrt(2² + 1² + 2²) = 3.
SceneDesc known_bounds_scene() {
    SceneDesc d;
    d.camera.position = Vec3(0.0f, 1.0f, 5.0f);
    d.camera.look_at = Vec3(0.0f);
    d.lights.push_back(test::sun(Vec3(0.0f, -1.0f, 0.0f), 1.0f));
    test::add_ground(&d, 0.0f, 2.0f, 0.5f);
    d.media.push_back(test::homogeneous(Box3{Vec3(-1.0f, 0.0f, -1.0f), Vec3(1.0f, 1.0f, 1.0f)},
                                        Color(1.0f), Color(0.1f)));
    d.render.integrator = Integrator::Photon;
    d.global.k = 20;
    d.caustic.k = 10;
    d.volume.k = 2;
    return d;
}

TEST(GatherParams, DefaultRadiiAreSharesOfTheSceneAndMediaDiagonals) {
    const SceneDesc d = known_bounds_scene();
    const auto scene = load_scene(d);
    const double diag = std::sqrt(66.0), media_diag = 3.0;
    const GatherParams p = gather_params(d, *scene, PhotonMaps{}, false);
    EXPECT_NEAR(p.global.radius, 0.02 * diag, 1e-5 * diag);
    EXPECT_NEAR(p.caustic.radius, 0.01 * diag, 1e-5 * diag);
    EXPECT_NEAR(p.volume.radius, 0.05 * media_diag, 1e-5 * media_diag);
    EXPECT_FALSE(p.global.fixed_radius);
    EXPECT_FALSE(p.caustic.fixed_radius);
    EXPECT_FALSE(p.volume.fixed_radius);
    EXPECT_EQ(p.global.k, 20);
    EXPECT_EQ(p.caustic.k, 10);
    EXPECT_EQ(p.volume.k, 2);
}

TEST(GatherParams, MediaDiagonalFallsBackToTheScenesWithoutMedia) {
    SceneDesc d = known_bounds_scene();
    d.media.clear();
    // Without the fog box the bounds are the ground and the camera: [-2, 0, -2]..[2, 1, 5].
    const auto scene = load_scene(d);
    const GatherParams p = gather_params(d, *scene, PhotonMaps{}, false);
    EXPECT_NEAR(p.volume.radius, 0.05 * std::sqrt(66.0), 1e-5 * std::sqrt(66.0));
}

TEST(GatherParams, SceneRadiiAndSettingsAreTakenAsGiven) {
    SceneDesc d = known_bounds_scene();
    d.global.radius = 0.3f;
    d.global.final_gather = true;
    d.global.gather_rays = 9;
    d.caustic.radius = 0.07f;
    d.caustic.cone_filter = 1.2f;
    d.volume.radius = 0.11f;
    d.volume.estimator = VolumeEstimator::Sphere;
    d.volume.lookups_per_ray = 0;
    d.volume.light_samples = 6;
    const auto scene = load_scene(d);
    for (bool progressive : {false, true}) {
        const GatherParams p = gather_params(d, *scene, PhotonMaps{}, progressive);
        EXPECT_EQ(p.global.radius, 0.3f);
        EXPECT_EQ(p.caustic.radius, 0.07f);
        EXPECT_EQ(p.volume.radius, 0.11f);
        // Progressive runs gather within the radius; plain ones the k nearest.
        EXPECT_EQ(p.global.fixed_radius, progressive);
        EXPECT_EQ(p.caustic.fixed_radius, progressive);
        EXPECT_EQ(p.volume.fixed_radius, progressive);
        EXPECT_TRUE(p.final_gather);
        EXPECT_EQ(p.gather_rays, 9);
        EXPECT_EQ(p.cone_filter, 1.2f);
        EXPECT_EQ(p.estimator, VolumeEstimator::Sphere);
        EXPECT_EQ(p.lookups_per_ray, 0);
        EXPECT_EQ(p.light_samples, 6);
        EXPECT_EQ(p.gather_depth, 0);
    }
}

TEST(GatherParams, PathsEndingInTheVolumeMapGatherItWithinAFixedRadius) {
    SceneDesc d = known_bounds_scene();
    d.volume.gather_depth = 1;
    const auto scene = load_scene(d);
    const GatherParams p = gather_params(d, *scene, PhotonMaps{}, false);
    EXPECT_EQ(p.gather_depth, 1);
    EXPECT_TRUE(p.volume.fixed_radius);
    EXPECT_FALSE(p.global.fixed_radius);
    EXPECT_FALSE(p.caustic.fixed_radius);
}

/// Photons on a cubic lattice of n³ points of spacing h from `origin`, appended.
void add_lattice(std::vector<Photon>* photons, const Vec3& origin, int n, float h) {
    for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j)
            for (int k = 0; k < n; ++k)
                photons->emplace_back(origin + Vec3(i, j, k) * h, Vec3(0.0f, -1.0f, 0.0f),
                                      Color(1.0f));
}

PhotonMap map_of(std::vector<Photon> photons) {
    PhotonMap map;
    map.tree = KdTree<Photon>(std::move(photons));
    return map;
}

/// n³ photons on a cubic lattice of spacing h from the origin.
PhotonMap lattice_map(int n, float h) {
    std::vector<Photon> photons;
    add_lattice(&photons, Vec3(0.0f), n, h);
    return map_of(std::move(photons));
}

TEST(GatherParams, ProgressiveRadiusFromTheMapsIsTheMedianKthNeighbourDistance) {
    // k = 2 on a lattice: every photon's two nearest are itself and a neighbour one spacing away,
    // so the distance to the 2nd nearest is the spacing for every photon sampled.
    SceneDesc d = known_bounds_scene();
    d.global.k = 2;
    d.caustic.k = 2;
    const auto scene = load_scene(d);
    PhotonMaps first;
    first.global = lattice_map(12, 0.05f);  // 1728 photons: 256 are sampled
    first.caustic = lattice_map(5, 0.02f);  // 125: all of them
    first.volume = lattice_map(8, 0.125f);
    const GatherParams p = gather_params(d, *scene, first, true);
    EXPECT_NEAR(p.global.radius, 0.05f, 1e-6f);
    EXPECT_NEAR(p.caustic.radius, 0.02f, 1e-6f);
    EXPECT_NEAR(p.volume.radius, 0.125f, 1e-6f);
    EXPECT_TRUE(p.global.fixed_radius && p.caustic.fixed_radius && p.volume.fixed_radius);
    // A plain render keeps the default k-NN radii whatever the maps hold.
    const GatherParams plain = gather_params(d, *scene, first, false);
    EXPECT_NEAR(plain.global.radius, 0.02 * std::sqrt(66.0), 1e-5);
}

TEST(GatherParams, ProgressiveRunsGatherTheNearestFromMapsTooUnevenForOneRadius) {
    // k = 2: the distance to the 2nd nearest is a lattice's spacing. Half the photons 0.001
    // apart, half 0.1 apart: their 10th and 90th percentiles 100x apart (> 30), so the map's
    // gathers take the k nearest within its radius (the default, or the scene's) as a plain
    // render's do; a lattice of one spacing keeps a fixed radius (the median, or the scene's),
    // and so does the volume map where paths end in it.
    SceneDesc d = known_bounds_scene();
    d.global.k = 2;
    d.caustic.k = 2;
    d.caustic.radius = 0.07f;
    d.volume.k = 2;
    d.volume.gather_depth = 0;
    std::vector<Photon> uneven;
    add_lattice(&uneven, Vec3(0.0f), 8, 0.001f);
    add_lattice(&uneven, Vec3(1.0f), 8, 0.1f);
    PhotonMaps first;
    first.global = map_of(uneven);
    first.caustic = map_of(uneven);
    first.volume = map_of(uneven);
    const auto scene = load_scene(d);
    const GatherParams p = gather_params(d, *scene, first, true);
    for (const MapGather* g : {&p.global, &p.caustic, &p.volume}) {
        EXPECT_FALSE(g->fixed_radius);
        EXPECT_TRUE(g->shrink_k);
        EXPECT_EQ(g->k, 2);
    }
    EXPECT_NEAR(p.global.radius, 0.02 * std::sqrt(66.0), 1e-5);
    EXPECT_EQ(p.caustic.radius, 0.07f);
    EXPECT_NEAR(p.volume.radius, 0.05 * 3.0, 1e-5);
    // Even maps: the median, or the scene's radius as it is.
    first.global = lattice_map(12, 0.05f);
    first.caustic = lattice_map(5, 0.02f);
    const GatherParams even = gather_params(d, *scene, first, true);
    EXPECT_TRUE(even.global.fixed_radius && even.caustic.fixed_radius);
    EXPECT_FALSE(even.global.shrink_k || even.caustic.shrink_k);
    EXPECT_NEAR(even.global.radius, 0.05f, 1e-6f);
    EXPECT_EQ(even.caustic.radius, 0.07f);
    // Paths ending in the volume map gather it within a fixed radius whatever its spread.
    d.volume.gather_depth = 3;
    const GatherParams end = gather_params(d, *scene, first, true);
    EXPECT_TRUE(end.volume.fixed_radius);
    EXPECT_FALSE(end.volume.shrink_k);
    // A plain render's gathers are k-NN that never shrink.
    const GatherParams plain = gather_params(d, *scene, first, false);
    EXPECT_FALSE(plain.global.shrink_k || plain.global.fixed_radius);
}

TEST(GatherParams, ProgressiveRadiusFallsBackToTheDefaultWithTooFewPhotons) {
    // A map of k photons or fewer has no k-th neighbour to measure: the default radius stays.
    SceneDesc d = known_bounds_scene();
    d.volume.k = 8;
    const auto scene = load_scene(d);
    PhotonMaps first;
    first.volume = lattice_map(2, 0.1f);  // 8 photons
    const GatherParams p = gather_params(d, *scene, first, true);
    EXPECT_NEAR(p.volume.radius, 0.05 * 3.0, 1e-5);
    EXPECT_TRUE(p.volume.fixed_radius);
}

}  // namespace
}  // namespace fogmap
