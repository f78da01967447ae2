// Velocity motion blur: a box of uniform, purely absorbing density moving at a uniform velocity,
// seen nearly orthographically against a uniform sky. A pixel's value is then the transmittance
// through the box averaged over the shutter, which the test integrates itself from the box's
// trilinear profile (its density ramps to 0 over the voxel beyond the outermost voxel centres):
// mean over the pixel's x and the shutter's t of exp(-sigma * profile(x - v t) * depth). The path
// tracer (delta tracking) and the photon gather (ray marching) must both match it within their
// noise; and, the box scattering under the sun, the photon methods agree with the path tracer's
// blurred image far better than with the box at rest. Without a shutter the box stands still. Bad
// input: a velocity grid of the wrong type or moving the medium farther than its extent in a frame,
// a shutter outside [-1, 1] frames. A velocity split into float grids vel.x, vel.y, vel.z (as
// Houdini writes vector volumes) moves the box as the vec3s grid does.

#include "core/error.h"
#include "render/metrics.h"
#include "render/pipeline.h"
#include "scene/scene.h"
#include "scene/scene_desc.h"
#include "scene_builders.h"
#include "test_support.h"

#include <gtest/gtest.h>
#include <openvdb/openvdb.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

namespace fogmap {
namespace {

using namespace test;

constexpr double kVoxel = 0.05;  ///< world units
constexpr int kBox = 20;         ///< voxels along each axis: a unit box from x = 0, centred in y, z
constexpr float kSigma = 2.0f;   ///< sigma_a per unit density
constexpr float kSpeed = 1.0f;   ///< world units per second, along +x or -x

/// The box's density profile along x at world x: 1 between the first and last voxel centres (0
/// and (kBox - 1) h), ramping linearly to 0 one voxel beyond them.
double profile(double x) {
    const double u = x / kVoxel;
    if (u <= -1.0 || u >= kBox) return 0.0;
    if (u < 0.0) return 1.0 + u;
    if (u > kBox - 1) return kBox - u;
    return 1.0;
}

/// Writes the box (density 1) and a uniform velocity grid (speed along x) covering every place
/// it reaches.
std::string write_moving_box(const TempDir& dir, float speed = kSpeed,
                             const char* velocity_type = "vec3s") {
    openvdb::initialize();
    auto density = openvdb::FloatGrid::create(0.0f);
    for (int i = 0; i < kBox; ++i)
        for (int j = -kBox / 2; j < kBox / 2; ++j)
            for (int k = -kBox / 2; k < kBox / 2; ++k)
                density->tree().setValue(openvdb::Coord(i, j, k), 1.0f);
    density->setName("density");
    density->setTransform(openvdb::math::Transform::createLinearTransform(kVoxel));
    openvdb::GridPtrVec grids{density};
    const openvdb::CoordBBox region(openvdb::Coord(-3 * kBox, -kBox, -kBox),
                                    openvdb::Coord(3 * kBox, kBox, kBox));
    if (std::string(velocity_type) == "split") {  // Houdini's vel.x, vel.y, vel.z
        for (const char* axis : {"x", "y", "z"}) {
            auto component = openvdb::FloatGrid::create(0.0f);
            component->tree().fill(region, std::string(axis) == "x" ? speed : 0.0f, true);
            component->setName(std::string("vel.") + axis);
            component->setTransform(openvdb::math::Transform::createLinearTransform(kVoxel));
            grids.push_back(component);
        }
    } else if (std::string(velocity_type) == "vec3s") {
        auto vel = openvdb::Vec3SGrid::create(openvdb::Vec3s(0.0f));
        vel->tree().fill(region, openvdb::Vec3s(speed, 0.0f, 0.0f), true);
        vel->setName("vel");
        vel->setTransform(openvdb::math::Transform::createLinearTransform(kVoxel));
        grids.push_back(vel);
    } else {
        auto vel = openvdb::FloatGrid::create(0.0f);
        vel->tree().fill(region, speed, true);
        vel->setName("vel");
        vel->setTransform(openvdb::math::Transform::createLinearTransform(kVoxel));
        grids.push_back(vel);
    }
    const std::string file = (dir.path() / "box.vdb").string();
    openvdb::io::File(file).write(grids);
    return file;
}

/// 60 x 20 pixels over x in [centre - 1.5, centre + 1.5], y in [-0.5, 0.5], looking down -z from
/// z = 400 (rays drift by under 0.004 in x through the box); the sky's radiance 1; shutter [0, 1]
/// frame at 1 frame per second, so the box moves by v t for t in [0, 1] s.
SceneDesc moving_box_scene(const std::string& file, Integrator integrator, float centre = 1.0f) {
    SceneDesc d;
    d.camera.position = Vec3(centre, 0.0f, 400.0f);
    d.camera.look_at = Vec3(centre, 0.0f, 0.0f);
    d.camera.width = 60;
    d.camera.height = 20;
    d.camera.fov_deg = float(2.0 * std::atan(0.5 / 400.0) * 180.0 / 3.14159265358979);
    ShutterDesc shutter;
    shutter.open = 0.0f;
    shutter.close = 1.0f;
    shutter.fps = 1.0f;
    d.camera.shutter = shutter;
    d.lights.push_back(environment(1.0f));
    d.media.push_back(vdb_medium(file, Color(0.0f), Color(kSigma)));
    d.media[0].velocity_grid = "vel";
    d.render.integrator = integrator;
    d.render.spp = 256;
    d.volume.gather_depth = 0;
    return d;
}

/// The expected value of pixel column c of a camera centred on `centre`: exp(-sigma * profile(x -
/// v t) * depth) over the column's x and the shutter's t (midpoint rule, 200 x 400 points); depth:
/// the box's z extent, whose profile integrates to kBox voxels.
double expected_column(int c, double shift_s, double speed = kSpeed, double centre = 1.0) {
    const double x0 = centre - 1.5 + 3.0 * c / 60.0, depth = kBox * kVoxel;
    double sum = 0.0;
    constexpr int kX = 200, kT = 400;
    for (int a = 0; a < kX; ++a)
        for (int b = 0; b < kT; ++b) {
            const double x = x0 + 0.05 * (a + 0.5) / kX, t = shift_s * (b + 0.5) / kT;
            sum += std::exp(-kSigma * profile(x - speed * t) * depth);
        }
    return sum / (kX * kT);
}

/// Each column's mean over the rows within |y| < 0.3 (where the box is uniform in y).
std::vector<double> column_means(const Image& img) {
    std::vector<double> out(size_t(img.width), 0.0);
    for (int x = 0; x < img.width; ++x) {
        for (int y = 4; y < 16; ++y) out[size_t(x)] += average(img.at(x, y));
        out[size_t(x)] /= 12.0;
    }
    return out;
}

TEST(MotionBlur, AMovingBoxHasItsTimeAveragedTransmittance) {
    const TempDir dir("motion_box");
    // Along +x, then along -x (the velocity's negative parts), the camera following the box.
    for (const float speed : {kSpeed, -kSpeed})
        for (const Integrator integrator : {Integrator::Path, Integrator::Photon}) {
            SCOPED_TRACE((integrator == Integrator::Path ? "path, v " : "photon, v ") +
                         std::to_string(speed));
            const float centre = speed > 0.0f ? 1.0f : 0.0f;
            const std::string file = write_moving_box(dir, speed);
            const Image img =
                run_pipeline(moving_box_scene(file, integrator, centre), true).film.beauty;
            const std::vector<double> got = column_means(img);
            int blurred = 0;
            for (int c = 0; c < 60; ++c) {
                const double want = expected_column(c, 1.0, speed, centre);
                // A sample is 0 or 1 (delta tracking) or exact (marching): binomial noise at most.
                const double sd = std::sqrt(want * (1.0 - want) / (12.0 * 256.0));
                EXPECT_NEAR(got[size_t(c)], want, 5.0 * sd + 2e-3) << "column " << c;
                blurred += want > 0.2 && want < 0.9 ? 1 : 0;  // neither clear sky nor e^-2
            }
            EXPECT_GE(blurred, 30) << "the box's motion blurs most columns: " << blurred;
        }
}

TEST(MotionBlur, AVelocitySplitIntoFloatGridsMovesTheBoxAlike) {
    const TempDir dir("motion_split");
    const Image img =
        run_pipeline(
            moving_box_scene(write_moving_box(dir, -kSpeed, "split"), Integrator::Path, 0.0f), true)
            .film.beauty;
    const std::vector<double> got = column_means(img);
    for (int c = 0; c < 60; ++c) {
        const double want = expected_column(c, 1.0, -kSpeed, 0.0);
        const double sd = std::sqrt(want * (1.0 - want) / (12.0 * 256.0));
        EXPECT_NEAR(got[size_t(c)], want, 5.0 * sd + 2e-3) << "column " << c;
    }
}

TEST(MotionBlur, PhotonMapsSeeTheMotionThePathTracerSees) {
    // The box scattering (albedo 0.9) under the sun and a dim sky, seen from the side: the photon
    // methods (their photons at their own times) agree with the path tracer's motion-blurred image
    // far better than with the box at rest.
    const TempDir dir("motion_photons");
    const std::string file = write_moving_box(dir);
    const auto render = [&](Integrator integrator, int spp, bool moving, uint64_t seed,
                            int gather_depth = 3) {
        SceneDesc d = moving_box_scene(file, integrator);
        d.camera.position = Vec3(1.0f, 0.3f, 6.0f);
        d.camera.look_at = Vec3(1.0f, 0.0f, 0.0f);
        d.camera.fov_deg = 24.0f;
        d.camera.width = 48;
        d.camera.height = 24;
        d.lights = {sun(Vec3(-0.3f, -1.0f, -0.4f), 3.0f), environment(0.05f)};
        d.media[0].sigma_s = Color(1.8f);
        d.media[0].sigma_a = Color(0.2f);
        if (!moving) d.camera.shutter.reset();
        d.render.spp = spp;
        d.render.seed = seed;
        d.volume.gather_depth = gather_depth;
        return run_pipeline(d, true).film.beauty;
    };
    const Image reference = render(Integrator::Path, 2048, true, 7);
    const double still = image_error(render(Integrator::Path, 2048, false, 8), reference).rel_mse;
    const double path = image_error(render(Integrator::Path, 64, true, 9), reference).rel_mse;
    // Camera paths ending in the volume map (depth 3), and camera rays gathering (depth 0).
    for (const int depth : {3, 0}) {
        const double photon =
            image_error(render(Integrator::Photon, 64, true, 9, depth), reference).rel_mse;
        std::printf(
            "relMSE against the moving reference: at rest %.3g, path %.3g, photon "
            "(gather depth %d) %.3g\n",
            still, path, depth, photon);
        EXPECT_LT(photon, 0.1 * still) << "gather depth " << depth;
        EXPECT_LT(photon, 3.0 * path) << "gather depth " << depth;
    }
}

TEST(MotionBlur, WithoutAShutterTheBoxStandsStill) {
    const TempDir dir("motion_still");
    SceneDesc d = moving_box_scene(write_moving_box(dir), Integrator::Photon);
    d.camera.shutter.reset();
    const PipelineResult r = run_pipeline(d, true);
    const std::vector<double> got = column_means(r.film.beauty);
    for (int c = 0; c < 60; ++c)
        EXPECT_NEAR(got[size_t(c)], expected_column(c, 0.0), 2e-3) << "column " << c;
    ASSERT_FALSE(r.report.warnings.empty());
    EXPECT_NE(r.report.warnings[0].find("velocity_grid 'vel' is not read"), std::string::npos)
        << r.report.warnings[0];
}

TEST(MotionBlur, BadVelocityGridsAndShuttersAreRefusedByField) {
    const TempDir dir("motion_bad");
    {
        SceneDesc d = moving_box_scene(write_moving_box(dir, kSpeed, "float"), Integrator::Path);
        const InputError e = catch_input_error([&] { load_scene(d); });
        EXPECT_EQ(e.field, "/media/0/velocity_grid") << e.what();
        EXPECT_NE(e.reason.find("expected a vec3s grid"), std::string::npos) << e.what();
    }
    const std::string file = write_moving_box(dir);
    {
        SceneDesc d = moving_box_scene(file, Integrator::Path);
        d.camera.shutter->fps = 0.25f;  // 4 world units a frame through a box of 1.1
        const InputError e = catch_input_error([&] { load_scene(d); });
        EXPECT_EQ(e.field, "/media/0/velocity_grid") << e.what();
        EXPECT_NE(e.reason.find("more than its extent"), std::string::npos) << e.what();
    }
    for (const float open : {-1.5f, 2.0f, std::nanf("")}) {
        SceneDesc d = moving_box_scene(file, Integrator::Path);
        d.camera.shutter->open = open;
        const InputError e = catch_input_error([&] { validate(d); });
        EXPECT_EQ(e.field, "/camera/shutter/open") << e.what();
    }
    SceneDesc d = moving_box_scene(file, Integrator::Path);
    d.camera.shutter->open = 0.5f;
    d.camera.shutter->close = 0.25f;
    EXPECT_EQ(catch_input_error([&] { validate(d); }).field, "/camera/shutter/close");
}

}  // namespace
}  // namespace fogmap
