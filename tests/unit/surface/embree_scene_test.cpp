// Embree queries against analytic ray–plane and ray–sphere intersections.

#include "surface/embree_scene.h"

#include <gtest/gtest.h>

namespace fogmap {
namespace {

TEST(EmbreeScene, ClosestHitMatchesAnalyticPlaneAndSphere) {
    Mesh quad = make_quad(Vec3(-1.0f, 0.0f, -1.0f), Vec3(0.0f, 0.0f, 2.0f), Vec3(2.0f, 0.0f, 0.0f));
    quad.material = 3;
    std::vector<Mesh> meshes{quad};
    std::vector<Sphere> spheres{Sphere{Vec3(0.0f, 2.0f, 0.0f), 0.5f, 7}};
    const EmbreeScene scene(meshes, spheres);

    // Straight down from y = 5 at x = 0.2: the sphere's top at y = 2 + sqrt(0.25 − 0.04).
    const Ray down{Vec3(0.2f, 5.0f, 0.0f), Vec3(0.0f, -1.0f, 0.0f)};
    auto hit = scene.intersect(down, 0.0f, kInfinity);
    ASSERT_TRUE(hit);
    EXPECT_NEAR(hit->t, 5.0f - (2.0f + std::sqrt(0.25f - 0.04f)), 1e-4f);
    EXPECT_EQ(hit->material, 7);
    EXPECT_NEAR(glm::length(hit->ng - glm::normalize(hit->p - Vec3(0.0f, 2.0f, 0.0f))), 0.0f,
                1e-4f);

    // Past the sphere (x = 0.8) the ray meets the plane y = 0; its normal is u x v = +y.
    const Ray miss_sphere{Vec3(0.8f, 5.0f, 0.3f), Vec3(0.0f, -1.0f, 0.0f)};
    hit = scene.intersect(miss_sphere, 0.0f, kInfinity);
    ASSERT_TRUE(hit);
    EXPECT_NEAR(hit->t, 5.0f, 1e-5f);
    EXPECT_EQ(hit->material, 3);
    EXPECT_NEAR(hit->ng.y, 1.0f, 1e-6f);

    // Outside the quad nothing is hit; t_max before the plane also misses.
    EXPECT_FALSE(
        scene.intersect(Ray{Vec3(3.0f, 5.0f, 0.0f), Vec3(0.0f, -1.0f, 0.0f)}, 0.0f, kInfinity));
    EXPECT_FALSE(scene.intersect(miss_sphere, 0.0f, 4.9f));
}

TEST(EmbreeScene, OcclusionAgreesWithIntersection) {
    std::vector<Mesh> meshes{make_box(Vec3(-1.0f), Vec3(1.0f), Mat4(1.0f))};
    const EmbreeScene scene(meshes, {});
    const Ray r{Vec3(-5.0f, 0.1f, 0.2f), Vec3(1.0f, 0.0f, 0.0f)};
    EXPECT_TRUE(scene.occluded(r, 0.0f, 10.0f));
    EXPECT_FALSE(scene.occluded(r, 0.0f, 3.9f));  // the box face is at t = 4
    EXPECT_EQ(scene.triangle_count(), 12u);
    EXPECT_NEAR(scene.bounds().lo.x, -1.0f, 1e-6f);
    EXPECT_NEAR(scene.bounds().hi.z, 1.0f, 1e-6f);
    // The box's face normals point outward: the first hit from −x has normal −x.
    const auto hit = scene.intersect(r, 0.0f, kInfinity);
    ASSERT_TRUE(hit);
    EXPECT_NEAR(hit->ng.x, -1.0f, 1e-6f);
}

}  // namespace
}  // namespace fogmap
